//! Tests of colliders and wind on a TreeCut cloth: resolution-consistent wind, coarse nodes
//! held by thin colliders, new nodes joining collision at the end of their refine.

use super::*;
use crate::collide::{ColliderDesc, Shape, Transform};
use crate::wind::{Wind, WindField, grid_triangles};
use treecut::{GridSpec, uniform_cut};

/// A 2 m, 1 kg cloth of `n`² vertices with `nodes` simulated nodes (`uniform_cut`: levels mixed to the count; all when
/// `nodes` is the vertex count), bent into a fixed curved shape, with steady wind.
fn bent_cloth(n: u32, nodes: usize) -> TreeCutSoftBody {
    let spec = GridSpec::horizontal(n, n, 2.0 / (n - 1) as f32, 1.0);
    let h = Hierarchy::grid(&spec).unwrap();
    let cut = if nodes >= h.vertex_count() {
        Cut::finest(&h)
    } else {
        uniform_cut(&h, nodes).unwrap()
    };
    let mut body = TreeCutSoftBody::new(h, cut, TreeCutSettings::default()).unwrap();
    body.set_surface(&grid_triangles(n, n)).unwrap();
    for p in 0..body.particle_count() {
        let r = body.hierarchy().rest_position(body.particle_nodes()[p]);
        let bent = Vec3::new(r.x, 0.25 * (1.5 * r.x).sin() + 0.1 * r.z, r.z);
        body.set_particle_position(ParticleId::new(p), bent)
            .unwrap();
    }
    let wind = Wind::new(WindField {
        velocity: Vec3::new(6.0, -1.0, 2.0),
        gust: 0.0,
        ..WindField::default()
    })
    .unwrap();
    body.set_wind(Some(wind)).unwrap();
    body
}

fn total_wind_force(body: &mut TreeCutSoftBody) -> Vec3 {
    let mut f = Vec::new();
    body.wind_forces(&mut f);
    f.iter().sum()
}

#[test]
fn wind_force_is_the_same_at_every_resolution() {
    let full = total_wind_force(&mut bent_cloth(65, usize::MAX));
    let half = total_wind_force(&mut bent_cloth(33, usize::MAX));
    let cut = total_wind_force(&mut bent_cloth(65, (0.3 * 65.0 * 65.0) as usize));
    assert!(full.length() > 1.0, "wind force {full}");
    for (what, f) in [("33²", half), ("30% cut of 65²", cut)] {
        let rel = (f - full).length() / full.length();
        assert!(rel < 0.05, "{what}: total {f} vs {full} at 65² ({rel:.3})");
    }
}

#[test]
fn wind_needs_triangles_and_reaches_nodes_created_by_a_refine() {
    let spec = GridSpec::horizontal(17, 17, 0.5 / 16.0, 0.1);
    let h = Hierarchy::grid(&spec).unwrap();
    let settings = TreeCutSettings {
        solver: SolverSettings {
            gravity: Vec3::ZERO,
            ..SolverSettings::default()
        },
        ..TreeCutSettings::default()
    };
    let mut body = TreeCutSoftBody::new(h.clone(), Cut::uniform(&h, 2), settings).unwrap();
    let wind = Wind::new(WindField {
        velocity: Vec3::new(0.0, 5.0, 0.0),
        gust: 0.0,
        ..WindField::default()
    })
    .unwrap();
    assert_eq!(body.set_wind(Some(wind)), Err(TreeCutError::NoSurface));
    body.set_surface(&grid_triangles(17, 17)).unwrap();
    body.set_wind(Some(wind)).unwrap();
    let node = body.cut().active()[0];
    body.begin_refine(node).unwrap();
    body.step();
    // Every particle, the refine's new children included, was pushed up by the wind.
    for (p, v) in body.particle_velocities().iter().enumerate() {
        assert!(
            v.y > 0.01,
            "particle {p} ({:?}) has {v}",
            body.particle_nodes()[p]
        );
    }
}

#[test]
fn a_coarse_cloth_does_not_slip_past_a_thin_capsule() {
    // Level 3 of a 65² cloth 2 m wide: nodes 0.25 m apart, a capsule 4 cm thick between two
    // node columns. Points would fall past it; nodes with covering radii hang on it.
    let spec = GridSpec::horizontal(65, 65, 2.0 / 64.0, 1.0);
    let h = Hierarchy::grid(&spec).unwrap();
    let cut = Cut::uniform(&h, 3);
    let mut body = TreeCutSoftBody::new(h, cut, TreeCutSettings::default()).unwrap();
    let mut xs: Vec<f32> = body.particle_positions().iter().map(|p| p.x).collect();
    xs.sort_by(f32::total_cmp);
    xs.dedup_by(|a, b| (*a - *b).abs() < 1e-4);
    let mid = xs.len() / 2;
    let x = 0.5 * (xs[mid - 1] + xs[mid]);
    body.colliders_mut()
        .add(ColliderDesc {
            shape: Shape::Capsule {
                radius: 0.02,
                half_length: 2.0,
            },
            transform: Transform {
                position: Vec3::new(x, -0.1, 0.0),
                rotation: glam::Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
            },
            thickness: 0.005,
            friction: 0.5,
        })
        .unwrap();
    for _ in 0..120 {
        body.step();
    }
    let top = body
        .particle_positions()
        .iter()
        .map(|p| p.y)
        .fold(f32::NEG_INFINITY, f32::max);
    assert!(
        top > -0.1,
        "the cloth fell past the capsule (highest node at {top})"
    );
}

#[test]
fn with_the_papers_rule_children_join_collision_when_the_refine_ends() {
    let spec = GridSpec::horizontal(17, 17, 0.5 / 16.0, 0.1);
    let h = Hierarchy::grid(&spec).unwrap();
    let mut body =
        TreeCutSoftBody::new(h.clone(), Cut::uniform(&h, 1), TreeCutSettings::default()).unwrap();
    body.set_transition_collision(TransitionCollision::AtEnd);
    body.colliders_mut()
        .add(ColliderDesc {
            shape: Shape::Plane,
            transform: Transform::plane(Vec3::new(0.0, -0.5, 0.0), Vec3::Y),
            ..ColliderDesc::default()
        })
        .unwrap();
    let node = body.cut().active()[5];
    body.begin_refine(node).unwrap();
    let children: Vec<NodeId> = body.hierarchy().children(node).collect();
    let collides = |b: &TreeCutSoftBody| {
        children
            .iter()
            .map(|&k| b.body().collides(b.particle_of(k).unwrap()))
            .collect::<Vec<_>>()
    };
    assert!(collides(&body).iter().all(|&c| !c));
    for k in &children {
        let p = body.particle_of(*k).unwrap();
        assert_eq!(
            body.body().collision_radius(p),
            0.0,
            "leaf children are points"
        );
    }
    while body.transitions_in_flight() > 0 {
        assert!(collides(&body).iter().all(|&c| !c));
        body.step();
    }
    assert!(collides(&body).iter().all(|&c| c));
    // Coarse nodes cover their children.
    let parent = body.hierarchy().parent(children[0]).unwrap();
    assert!(body.node_collision_radius(parent) >= 0.5 * 0.5 / 16.0);
}

#[test]
fn by_default_children_collide_from_the_start() {
    let spec = GridSpec::horizontal(17, 17, 0.5 / 16.0, 0.1);
    let h = Hierarchy::grid(&spec).unwrap();
    let mut body =
        TreeCutSoftBody::new(h.clone(), Cut::uniform(&h, 1), TreeCutSettings::default()).unwrap();
    assert_eq!(
        body.transition_collision(),
        TransitionCollision::Immediately
    );
    let node = body.cut().active()[5];
    body.begin_refine(node).unwrap();
    for k in body.hierarchy().children(node) {
        assert!(body.body().collides(body.particle_of(k).unwrap()));
    }
}

#[test]
fn a_coarse_cloth_starting_inside_its_collision_radius_is_not_thrown() {
    // Level-3 nodes of a 2 m cloth cover 0.18 m; lying 6 mm above a plane, they start deep
    // inside their own collision radius. The contact pushes them out at a capped speed.
    let spec = GridSpec::horizontal(65, 65, 2.0 / 64.0, 1.0);
    let h = Hierarchy::grid(&spec).unwrap();
    let mut body =
        TreeCutSoftBody::new(h.clone(), Cut::uniform(&h, 3), TreeCutSettings::default()).unwrap();
    body.colliders_mut()
        .add(ColliderDesc {
            shape: Shape::Plane,
            transform: Transform::plane(Vec3::new(0.0, -0.006, 0.0), Vec3::Y),
            ..ColliderDesc::default()
        })
        .unwrap();
    let mut fastest = 0f32;
    for _ in 0..30 {
        body.step();
        for v in body.particle_velocities() {
            fastest = fastest.max(v.truncate().length());
        }
    }
    assert!(
        fastest <= crate::collide::MAX_SEPARATION_SPEED * 1.05,
        "thrown at {fastest} m/s"
    );
}

/// A coarse cloth lying on a sphere has its particles at the collider's thickness, but the
/// vertices placed between them cut the chord through the sphere; the reconstruction pushes
/// them out to the thickness, in every mode (the same cloth with the collider removed shows
/// the chord, so without the push the test fails).
#[test]
fn reconstructed_surface_stays_outside_colliders() {
    let n = 33;
    let spec = GridSpec::horizontal(n, n, 1.0 / (n - 1) as f32, 0.2);
    let h = Hierarchy::grid(&spec).unwrap();
    let mut body =
        TreeCutSoftBody::new(h.clone(), Cut::uniform(&h, 3), TreeCutSettings::default()).unwrap();
    let (centre, radius, thickness) = (Vec3::new(0.0, -1.0, 0.0), 1.0, 0.005);
    let sphere = body
        .colliders_mut()
        .add(ColliderDesc {
            shape: Shape::Sphere { radius },
            transform: Transform::from_position(centre),
            thickness,
            ..ColliderDesc::default()
        })
        .unwrap();
    // Every particle on the sphere, at the thickness (node spacing 0.25 m: the chord's sagitta
    // is about 8 mm).
    for p in 0..body.particle_count() {
        let rest = body.hierarchy().rest_position(body.particle_nodes()[p]);
        let on = centre + (rest - centre).normalize() * (radius + thickness);
        body.set_particle_position(ParticleId::new(p), on).unwrap();
    }
    let gap = |out: &[Vec3]| {
        out.iter()
            .map(|p| p.distance(centre) - radius)
            .fold(f32::INFINITY, f32::min)
    };
    let mut out = vec![Vec3::ZERO; h.vertex_count()];
    for mode in [
        ReconstructionMode::Rigid,
        ReconstructionMode::Smooth,
        ReconstructionMode::Mls,
    ] {
        body.reconstruct_with(mode, &mut out).unwrap();
        assert!(gap(&out) >= thickness - 1e-5, "{mode:?}: {}", gap(&out));
        assert_eq!(body.colliders().max_penetration(&out), 0.0);
    }
    body.colliders_mut().remove(sphere).unwrap();
    for mode in [ReconstructionMode::Smooth, ReconstructionMode::Mls] {
        body.reconstruct_with(mode, &mut out).unwrap();
        assert!(gap(&out) < 0.0, "{mode:?}: the chord ({})", gap(&out));
    }
}

/// The normals' weights table, brought up to date where the topology changed, gives the bits a
/// direct pass gives, through refines and coarses begun and ended (particles added, removed
/// and moved into freed slots), a renumbering, and steps of a windy, falling cloth.
#[test]
fn normals_from_the_table_match_a_direct_pass() {
    let mut body = bent_cloth(17, 80);
    body.set_auto_renumber(false);
    let mut rng: u64 = 0x5EED;
    let mut next = |n: usize| {
        rng = rng
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((rng >> 33) as usize) % n
    };
    let (mut refines, mut coarses) = (0, 0);
    for round in 0..60 {
        let active = body.cut().active().to_vec();
        for _ in 0..3 {
            let node = active[next(active.len())];
            if next(2) == 0 {
                refines += usize::from(body.begin_refine(node).is_ok());
            } else if let Some(parent) = body.hierarchy().parent(node) {
                coarses += usize::from(body.begin_coarse(parent).is_ok());
            }
        }
        if round == 30 {
            assert!(
                body.renumber_particles(),
                "the operations scattered the particles"
            );
        }
        body.step();
        let direct = body.normals_direct();
        let table = body.normals_now();
        assert_eq!(table.len(), body.particle_count());
        for (p, (a, b)) in table.iter().zip(&direct).enumerate() {
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits),
                "round {round}, particle {p}"
            );
        }
    }
    assert!(
        refines > 20 && coarses > 20,
        "{refines} refines, {coarses} coarses"
    );
}
