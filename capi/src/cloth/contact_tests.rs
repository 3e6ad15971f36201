//! Contact in the feedback loop and cloths worn by characters: touching nodes are refined, bone
//! ties refuse bad input and change nothing.

use std::sync::Arc;

use animlod::{BoneId, CharacterId, Crowd, Rig};
use glam::Vec3;
use salience::View;
use softbody::{ColliderDesc, Shape, Transform, TreeCutSettings};
use treecut::GridSpec;

use super::*;

/// A 2 m cloth at level 2 dropped onto a sphere, feedback at 30% of the nodes with the given
/// contact weight; returns the mean level of the nodes touching the sphere after 150 steps.
fn touching_level(weight: f32) -> f32 {
    let mut spec = GridSpec::horizontal(33, 33, 2.0 / 32.0, 0.5);
    spec.origin.y = 0.55;
    let mut cloth = AdaptiveCloth::grid(&spec, 2, TreeCutSettings::default()).unwrap();
    cloth
        .add_collider(ColliderDesc {
            shape: Shape::Sphere { radius: 0.5 },
            ..ColliderDesc::default()
        })
        .unwrap();
    cloth
        .set_feedback(Some(FeedbackSettings {
            budget: ClothBudget::Compression(0.3),
            ..FeedbackSettings::default()
        }))
        .unwrap();
    cloth
        .set_contact_settings(ContactSettings { weight })
        .unwrap();
    let view = View::look_at(
        Vec3::new(0.0, 2.0, 3.5),
        Vec3::ZERO,
        Vec3::Y,
        0.87,
        1920,
        1080,
    )
    .unwrap();
    for _ in 0..150 {
        cloth.step(&view).unwrap();
    }
    let body = cloth.body();
    let h = body.hierarchy();
    let (mut sum, mut n) = (0f32, 0usize);
    for (p, &node) in body.particle_nodes().iter().enumerate() {
        if body.body().touched_all()[p] {
            sum += h.level(node) as f32;
            n += 1;
        }
    }
    assert!(n > 0, "the cloth touches the sphere");
    sum / n as f32
}

#[test]
fn contact_refines_the_nodes_that_touch() {
    let with = touching_level(1.0);
    let without = touching_level(0.0);
    assert!(
        with < without,
        "touching nodes at mean level {with} with contact priorities, {without} without"
    );
}

fn gdbot() -> Arc<Rig> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf/GDQuest_GDBot.glb");
    Arc::new(animlod::build::import_path(&path).unwrap())
}

#[test]
fn bone_ties_refuse_bad_input_and_change_nothing() {
    let rig = gdbot();
    let mut crowd = Crowd::new(rig.clone());
    let walk = rig.clip_by_name("walk").unwrap();
    let who = crowd.add_character(Vec3::ZERO, walk).unwrap();
    let spec = GridSpec::horizontal(9, 9, 0.05, 0.1);
    let mut cloth = AdaptiveCloth::grid(&spec, 0, TreeCutSettings::default()).unwrap();
    let id = cloth.add_collider(ColliderDesc::default()).unwrap();
    let bones = rig.bone_count();
    let mut ties = BoneAttachments::new();
    let torso = rig.skeleton().find("torso").unwrap();
    let missing = BoneId::from_raw(bones as u32 + 3);
    assert!(
        ties.pin_vertex(&cloth, bones, 0, missing, Vec3::ZERO)
            .is_err()
    );
    assert!(
        ties.pin_vertex(&cloth, bones, 10_000, torso, Vec3::ZERO)
            .is_err()
    );
    assert!(ties.pin_vertex(&cloth, bones, 0, torso, Vec3::NAN).is_err());
    let nan = Transform {
        position: Vec3::new(f32::NAN, 0.0, 0.0),
        ..Transform::IDENTITY
    };
    assert!(ties.attach_collider(&cloth, bones, id, torso, nan).is_err());
    assert_eq!(ties.counts(), (0, 0), "refused ties are not kept");
    ties.attach_collider(&cloth, bones, id, torso, Transform::IDENTITY)
        .unwrap();
    ties.pin_vertex(&cloth, bones, 0, torso, Vec3::Y).unwrap();
    // A stale character: refused before anything moves.
    let before = *cloth.colliders().get(id).unwrap();
    let stale = CharacterId::from_raw(who.index(), who.generation() + 7);
    assert!(matches!(
        ties.apply(&mut cloth, &crowd, stale),
        Err(ClothError::Crowd(animlod::CrowdError::StaleCharacter(_)))
    ));
    assert_eq!(*cloth.colliders().get(id).unwrap(), before);
    assert!(cloth.body().vertex_anchor(0).is_none());
    // The real one: the collider goes to the torso, the vertex to its anchor.
    crowd.advance(0.1, &View::default()).unwrap();
    ties.apply(&mut cloth, &crowd, who).unwrap();
    let torso_at = crowd.model_matrices(who).unwrap()[torso.index()]
        .w_axis
        .truncate();
    let at = cloth.colliders().get(id).unwrap().transform.position;
    assert!(at.distance(torso_at) < 1e-5, "{at} vs {torso_at}");
    assert!(cloth.body().vertex_anchor(0).is_some());
}

/// A worn cloth follows the whole character, not only its position: turned a quarter about
/// +Y, scaled 1.5× and moved, the pin's anchor and the collider land where the character's world
/// transform puts the bone-frame point, and the collider turns with the character.
#[test]
fn bone_ties_follow_the_characters_rotation_and_scale() {
    let rig = gdbot();
    let mut crowd = Crowd::new(rig.clone());
    let walk = rig.clip_by_name("walk").unwrap();
    let who = crowd
        .add_character(Vec3::new(3.0, 0.0, -2.0), walk)
        .unwrap();
    let turn = glam::Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    crowd.set_rotation(who, turn).unwrap();
    crowd.set_scale(who, 1.5).unwrap();
    crowd.advance(0.1, &View::default()).unwrap();
    let spec = GridSpec::horizontal(9, 9, 0.05, 0.1);
    let mut cloth = AdaptiveCloth::grid(&spec, 0, TreeCutSettings::default()).unwrap();
    let id = cloth.add_collider(ColliderDesc::default()).unwrap();
    let torso = rig.skeleton().find("torso").unwrap();
    let mut ties = BoneAttachments::new();
    let offset = Vec3::new(0.1, 0.2, 0.0);
    ties.pin_vertex(&cloth, rig.bone_count(), 0, torso, offset)
        .unwrap();
    ties.attach_collider(&cloth, rig.bone_count(), id, torso, Transform::IDENTITY)
        .unwrap();
    ties.apply(&mut cloth, &crowd, who).unwrap();
    let model = crowd.model_matrices(who).unwrap()[torso.index()];
    let world = crowd.world_transform(who).unwrap();
    let expected = world.transform_point3(model.transform_point3(offset));
    let anchor = cloth.body().vertex_anchor(0).unwrap();
    assert!(anchor.distance(expected) < 1e-4, "{anchor} vs {expected}");
    let placed = cloth.colliders().get(id).unwrap().transform;
    let torso_world = world.transform_point3(model.w_axis.truncate());
    assert!(placed.position.distance(torso_world) < 1e-4);
    let (_, bone_turn, _) = model.to_scale_rotation_translation();
    assert!(placed.rotation.angle_between(turn * bone_turn) < 1e-3);
}
