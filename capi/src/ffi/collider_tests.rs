//! Colliders, wind and bone ties over the C ABI: defaults agree with Rust, bad input is refused
//! with the right code and changes nothing, and a collider attached to a bone follows it.

use glam::{Mat4, Vec3};
use softbody::{ColliderDesc, WindField};

use super::arena::RawId;
use super::*;

struct World(*mut SlodWorld);
impl Drop for World {
    fn drop(&mut self) {
        // SAFETY: created by slod_world_create, destroyed once.
        unsafe { slod_world_destroy(self.0) };
    }
}

fn world() -> World {
    let mut w = std::ptr::null_mut();
    // SAFETY: valid desc and out pointer.
    let r = unsafe { slod_world_create(&slod_default_world_desc(), &mut w) };
    assert_eq!(r, SlodResult::Ok);
    World(w)
}

/// A small cloth, the GDBot rig, a crowd and one character playing its first clip.
fn scene(w: &World) -> (SlodClothId, SlodCharacterId) {
    let desc = SlodClothDesc {
        columns: 9,
        rows: 9,
        spacing: 0.05,
        ..slod_default_cloth_desc()
    };
    let mut cloth = SlodClothId::default();
    // SAFETY: live world, valid pointers.
    let r = unsafe { slod_cloth_create_grid(w.0, &desc, &mut cloth) };
    assert_eq!(r, SlodResult::Ok);
    let path = std::ffi::CString::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../assets/gltf/GDQuest_GDBot.glb"
    ))
    .unwrap();
    let mut rig = SlodRigId::default();
    // SAFETY: live world, NUL-terminated path, valid out pointer.
    let r = unsafe { slod_rig_load_file(w.0, path.as_ptr(), &mut rig) };
    assert_eq!(r, SlodResult::Ok);
    let mut crowd = SlodCrowdId::default();
    // SAFETY: live world, valid pointers.
    let r = unsafe { slod_crowd_create(w.0, rig, &slod_default_crowd_desc(), &mut crowd) };
    assert_eq!(r, SlodResult::Ok);
    let mut ch = SlodCharacterId::default();
    let cdesc = SlodCharacterDesc {
        position: [1.0, 0.0, 2.0],
        ..slod_default_character_desc()
    };
    // SAFETY: live world, valid pointers.
    let r = unsafe { slod_character_create(w.0, crowd, &cdesc, &mut ch) };
    assert_eq!(r, SlodResult::Ok);
    (cloth, ch)
}

fn identity() -> SlodTransform {
    SlodTransform {
        position: [0.0; 3],
        rotation: [0.0, 0.0, 0.0, 1.0],
    }
}

#[test]
fn collider_and_wind_descs_are_the_rust_defaults() {
    assert_eq!(
        slod_default_collider_desc().to_desc().unwrap(),
        ColliderDesc::default()
    );
    assert_eq!(
        slod_default_wind_desc().to_field().unwrap(),
        WindField::default()
    );
    let zeroed = SlodColliderDesc {
        guard: 0,
        ..slod_default_collider_desc()
    };
    assert!(zeroed.to_desc().is_err());
}

#[test]
fn bad_input_is_refused_and_changes_nothing() {
    let w = world();
    let (cloth, ch) = scene(&w);
    let mut id = SlodColliderId::default();
    let bad = [
        SlodColliderDesc {
            radius: -1.0,
            ..slod_default_collider_desc()
        },
        SlodColliderDesc {
            shape: 9,
            ..slod_default_collider_desc()
        },
        SlodColliderDesc {
            transform: SlodTransform {
                position: [f32::NAN, 0.0, 0.0],
                ..identity()
            },
            ..slod_default_collider_desc()
        },
    ];
    for d in bad {
        // SAFETY: live world, valid pointers.
        let r = unsafe { slod_cloth_collider_create(w.0, cloth, &d, &mut id) };
        assert_eq!(r, SlodResult::InvalidArgument);
        assert_eq!(id, SlodColliderId::default(), "nothing written");
    }
    // SAFETY: live world, valid pointers.
    let r =
        unsafe { slod_cloth_collider_create(w.0, cloth, &slod_default_collider_desc(), &mut id) };
    assert_eq!(r, SlodResult::Ok);
    let count = |w: &World| {
        let mut s = SlodContactStats::default();
        // SAFETY: live world, valid out pointer.
        let r = unsafe { slod_cloth_contact_stats(w.0, cloth, &mut s) };
        assert_eq!(r, SlodResult::Ok);
        s.colliders
    };
    assert_eq!(count(&w), 1);
    let nan = SlodTransform {
        rotation: [f32::NAN, 0.0, 0.0, 1.0],
        ..identity()
    };
    // SAFETY: live world, valid pointers (for every call below).
    unsafe {
        assert_eq!(
            slod_cloth_collider_set_transform(w.0, cloth, id, &nan),
            SlodResult::InvalidArgument
        );
        assert_eq!(
            slod_cloth_collider_attach_to_bone(w.0, cloth, id, ch, 100_000, &identity()),
            SlodResult::InvalidArgument
        );
        assert_eq!(
            slod_cloth_pin_vertex_to_bone(w.0, cloth, 0, ch, 100_000, 0.0, 0.0, 0.0),
            SlodResult::InvalidArgument
        );
        assert_eq!(
            slod_cloth_pin_vertex_to_bone(w.0, cloth, 10_000, ch, 1, 0.0, 0.0, 0.0),
            SlodResult::InvalidArgument
        );
        let stale_character = SlodCharacterId {
            index1: ch.index1,
            generation: ch.generation + 1000,
        };
        assert_eq!(
            slod_cloth_collider_attach_to_bone(w.0, cloth, id, stale_character, 1, &identity()),
            SlodResult::StaleId
        );
        let bad_wind = SlodWindDesc {
            gust: -1.0,
            ..slod_default_wind_desc()
        };
        assert_eq!(
            slod_cloth_set_wind(w.0, cloth, &bad_wind),
            SlodResult::InvalidArgument
        );
        // Nothing was tied to the character by the refused calls.
        let world = &*w.0;
        let entry = world.cloths.get(RawId::from(cloth), "cloth").unwrap();
        assert!(entry.cloth.body().wind().is_none());
        assert_eq!(slod_cloth_collider_destroy(w.0, cloth, id), SlodResult::Ok);
        assert_eq!(
            slod_cloth_collider_destroy(w.0, cloth, id),
            SlodResult::StaleId
        );
        assert_eq!(
            slod_cloth_collider_set_transform(w.0, cloth, id, &identity()),
            SlodResult::StaleId
        );
    }
    assert_eq!(count(&w), 0);
}

#[test]
fn a_capsule_attached_to_a_bone_follows_it_as_the_character_walks() {
    let w = world();
    let (cloth, ch) = scene(&w);
    let desc = SlodColliderDesc {
        shape: SlodShape::Capsule as u32,
        radius: 0.05,
        half_length: 0.1,
        ..slod_default_collider_desc()
    };
    let mut id = SlodColliderId::default();
    let bone = 5u32;
    let local = SlodTransform {
        position: [0.0, 0.1, 0.0],
        ..identity()
    };
    // SAFETY: live world, valid pointers (for every call below).
    unsafe {
        assert_eq!(
            slod_cloth_collider_create(w.0, cloth, &desc, &mut id),
            SlodResult::Ok
        );
        assert_eq!(
            slod_cloth_collider_attach_to_bone(w.0, cloth, id, ch, bone, &local),
            SlodResult::Ok
        );
    }
    let mut seen = Vec::new();
    for _ in 0..20 {
        // SAFETY: live world (for every call below).
        let world = unsafe {
            let world = &mut *w.0;
            let (crowd, _) = *world.characters.get(RawId::from(ch), "character").unwrap();
            assert_eq!(
                slod_crowd_advance(w.0, crowd.into(), 1.0 / 30.0, std::ptr::null_mut()),
                SlodResult::Ok
            );
            assert_eq!(slod_cloth_step(w.0, cloth), SlodResult::Ok);
            &*w.0
        };
        let (crowd, cid) = *world.characters.get(RawId::from(ch), "character").unwrap();
        let crowd = world.crowds.get(crowd, "crowd").unwrap();
        let model: Mat4 = crowd.model_matrices(cid).unwrap()[bone as usize];
        let expected = Vec3::new(1.0, 0.0, 2.0) + model.transform_point3(Vec3::new(0.0, 0.1, 0.0));
        let entry = world.cloths.get(RawId::from(cloth), "cloth").unwrap();
        let (_, d) = entry.cloth.colliders().iter().next().unwrap();
        assert!(
            d.transform.position.distance(expected) < 1e-5,
            "collider at {} but bone point at {expected}",
            d.transform.position
        );
        seen.push(expected);
    }
    let moved = seen.first().unwrap().distance(*seen.last().unwrap());
    assert!(moved > 1e-3, "the bone did not move ({moved} m)");
}
