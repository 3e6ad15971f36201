//! Contact tests: resting on a plane and a sphere, friction on a slope, kinematic colliders,
//! the broad phase, determinism and refused input.

use super::*;
use crate::{GridCloth, Material, SoftBody, SolverSettings};
use glam::{Quat, Vec3};

/// A square cloth of `n`² vertices, `size` metres wide, 0.25 kg/m², centred on `centre` in the
/// plane of `u` and `v`, with the TreeCut cloth's default material.
fn cloth(n: u32, size: f32, centre: Vec3, u: Vec3, v: Vec3) -> SoftBody {
    let spacing = size / (n - 1) as f32;
    let g = GridCloth {
        cols: n,
        rows: n,
        origin: centre - 0.5 * size * (u + v),
        u: u * spacing,
        v: v * spacing,
        vertex_mass: 0.25 * size * size / (n * n) as f32,
        shear: true,
        bend: false,
        material: Material {
            stretch_compliance: 0.015,
            ..Material::default()
        },
    };
    g.build(SolverSettings::default()).unwrap()
}

fn flat(n: u32, size: f32, centre: Vec3) -> SoftBody {
    cloth(n, size, centre, Vec3::X, Vec3::Z)
}

/// Largest particle displacement between two snapshots.
fn max_move(a: &[glam::Vec4], b: &[glam::Vec4]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(p, q)| p.truncate().distance(q.truncate()))
        .fold(0.0, f32::max)
}

#[test]
fn cloth_rests_on_a_plane_without_sinking_or_jitter() {
    let mut body = flat(17, 0.5, Vec3::new(0.0, 0.05, 0.0));
    let thickness = 0.005;
    body.colliders_mut()
        .add(ColliderDesc {
            shape: Shape::Plane,
            transform: Transform::plane(Vec3::ZERO, Vec3::Y),
            thickness,
            friction: 0.4,
        })
        .unwrap();
    let mut lowest = f32::INFINITY;
    let mut jitter = 0f32;
    for step in 0..1000 {
        let before = body.positions().to_vec();
        body.step();
        let low = body
            .positions()
            .iter()
            .map(|p| p.y)
            .fold(f32::INFINITY, f32::min);
        lowest = lowest.min(low);
        if step >= 200 {
            jitter = jitter.max(max_move(&before, body.positions()));
        }
    }
    assert!(
        lowest >= thickness - 1e-4,
        "sank to {lowest} (thickness {thickness})"
    );
    assert!(jitter < 1e-4, "jitter {jitter} m per step at rest");
    assert!(
        body.touched_all().iter().all(|&t| t),
        "all rest on the plane"
    );
}

#[test]
fn cloth_drapes_on_a_sphere_without_sinking_or_jitter() {
    let radius = 0.2;
    let thickness = 0.005;
    let mut body = flat(21, 0.6, Vec3::new(0.0, radius + 0.05, 0.0));
    body.colliders_mut()
        .add(ColliderDesc {
            shape: Shape::Sphere { radius },
            transform: Transform::IDENTITY,
            thickness,
            friction: 0.5,
        })
        .unwrap();
    let mut closest = f32::INFINITY;
    let mut jitter = 0f32;
    for step in 0..1000 {
        let before = body.positions().to_vec();
        body.step();
        let near = body
            .positions()
            .iter()
            .map(|p| p.truncate().length())
            .fold(f32::INFINITY, f32::min);
        closest = closest.min(near);
        // Jitter of the contact: the particles resting on the sphere (within 1 mm of its
        // surface plus thickness). The free corners hanging below it still swing slowly
        // after 700 steps; that is the cloth's motion, not the contact's.
        if step >= 700 {
            let touching: Vec<usize> = (0..before.len())
                .filter(|&i| before[i].truncate().length() < radius + thickness + 1e-3)
                .collect();
            assert!(touching.len() > 20, "the cloth rests on the sphere");
            let moved = touching
                .iter()
                .map(|&i| {
                    before[i]
                        .truncate()
                        .distance(body.positions()[i].truncate())
                })
                .fold(0.0, f32::max);
            jitter = jitter.max(moved);
        }
    }
    assert!(
        closest >= radius + thickness - 1e-4,
        "a particle got within {closest} of the centre"
    );
    assert!(jitter < 1e-4, "jitter {jitter} m per step once draped");
    // Draped: the edges hang well below the top.
    let low = body
        .positions()
        .iter()
        .map(|p| p.y)
        .fold(f32::INFINITY, f32::min);
    assert!(low < 0.05, "edges at {low}: the cloth did not drape");
}

/// How far a cloth lying on a box face tilted by `angle` slides down in `steps` steps.
fn slide(angle: f32, friction: f32, steps: u32) -> f32 {
    let rot = Quat::from_rotation_z(angle);
    let half = Vec3::new(2.0, 0.1, 1.0);
    let face_normal = rot * Vec3::Y;
    let downhill = rot * Vec3::X;
    let centre = rot * Vec3::new(0.0, half.y + 0.006, 0.0);
    let mut body = cloth(9, 0.3, centre, downhill, rot * Vec3::Z);
    body.colliders_mut()
        .add(ColliderDesc {
            shape: Shape::Box { half_extents: half },
            transform: Transform {
                position: Vec3::ZERO,
                rotation: rot,
            },
            thickness: 0.005,
            friction,
        })
        .unwrap();
    let start = mean(&body);
    for _ in 0..steps {
        body.step();
    }
    let d = mean(&body) - start;
    // Only the motion along the face counts.
    (d - face_normal * d.dot(face_normal)).length()
}

fn mean(body: &SoftBody) -> Vec3 {
    let p = body.positions();
    p.iter().map(|x| x.truncate()).sum::<Vec3>() / p.len() as f32
}

#[test]
fn friction_holds_below_the_predicted_angle_and_slides_above() {
    for mu in [0.3f32, 0.6] {
        let critical = mu.atan();
        let held = slide(0.9 * critical, mu, 120);
        let slid = slide(1.1 * critical, mu, 120);
        // Sliding at 1.1× the angle accelerates at a = g(sin θ − μ cos θ), against the solver's
        // velocity damping c: x(t) = a/c (t − (1 − e^(−ct))/c).
        let (t, c) = (2.0f32, SolverSettings::default().damping);
        let a = 9.81 * ((1.1 * critical).sin() - mu * (1.1 * critical).cos());
        let predicted = a / c * (t - (1.0 - (-c * t).exp()) / c);
        assert!(held < 0.005, "μ {mu}: slid {held} m at 0.9× the angle");
        assert!(
            (slid - predicted).abs() < 0.1 * predicted,
            "μ {mu}: slid {slid} m at 1.1× the angle, kinetic friction predicts {predicted}"
        );
    }
}

#[test]
fn a_moving_plane_carries_the_cloth_by_friction() {
    let mut body = flat(9, 0.3, Vec3::new(0.0, 0.006, 0.0));
    let id = body
        .colliders_mut()
        .add(ColliderDesc {
            shape: Shape::Plane,
            transform: Transform::plane(Vec3::ZERO, Vec3::Y),
            thickness: 0.005,
            friction: 0.8,
        })
        .unwrap();
    for _ in 0..30 {
        body.step();
    }
    let start = mean(&body);
    // Accelerate the plane gently along x (0.5 m/s², below μ g), for 1 s.
    let dt = body.settings().dt;
    for k in 1..=60 {
        let t = k as f32 * dt;
        let x = 0.25 * t * t;
        body.colliders_mut()
            .set_transform(id, Transform::plane(Vec3::new(x, 0.0, 0.0), Vec3::Y))
            .unwrap();
        body.step();
    }
    let moved = (mean(&body) - start).x;
    assert!((moved - 0.25).abs() < 0.02, "carried {moved} m of 0.25");
}

#[test]
fn far_colliders_are_skipped_and_change_nothing() {
    let run = |far: bool| {
        let mut body = flat(9, 0.3, Vec3::new(0.0, 0.05, 0.0));
        body.colliders_mut()
            .add(ColliderDesc {
                shape: Shape::Sphere { radius: 0.1 },
                ..ColliderDesc::default()
            })
            .unwrap();
        if far {
            for k in 0..10 {
                body.colliders_mut()
                    .add(ColliderDesc {
                        shape: Shape::Capsule {
                            radius: 0.1,
                            half_length: 0.2,
                        },
                        transform: Transform::from_position(Vec3::new(5.0 + k as f32, 0.0, 0.0)),
                        ..ColliderDesc::default()
                    })
                    .unwrap();
            }
        }
        for _ in 0..60 {
            body.step();
        }
        let untouched = body
            .colliders()
            .arena
            .iter()
            .skip(1)
            .all(|(_, c)| c.candidates.is_empty());
        assert!(untouched, "far colliders have no candidates");
        body.positions().to_vec()
    };
    let a = run(false);
    let b = run(true);
    assert!(
        a.iter()
            .zip(&b)
            .all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits))
    );
}

#[test]
fn contact_is_deterministic() {
    let run = || {
        let mut body = flat(13, 0.5, Vec3::new(0.0, 0.3, 0.0));
        let id = body
            .colliders_mut()
            .add(ColliderDesc {
                shape: Shape::Capsule {
                    radius: 0.08,
                    half_length: 0.3,
                },
                transform: Transform {
                    position: Vec3::ZERO,
                    rotation: Quat::from_rotation_x(1.2),
                },
                thickness: 0.004,
                friction: 0.3,
            })
            .unwrap();
        body.colliders_mut()
            .add(ColliderDesc {
                shape: Shape::Box {
                    half_extents: Vec3::new(0.1, 0.05, 0.2),
                },
                transform: Transform::from_position(Vec3::new(0.2, 0.0, 0.0)),
                ..ColliderDesc::default()
            })
            .unwrap();
        for k in 0..200 {
            let t = Transform {
                position: Vec3::new(0.0, 0.1 * (k as f32 * 0.05).sin(), 0.0),
                rotation: Quat::from_rotation_x(1.2 + 0.01 * k as f32),
            };
            body.colliders_mut().set_transform(id, t).unwrap();
            body.step();
        }
        body.positions()
            .iter()
            .map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(run(), run());
}

#[test]
fn bad_colliders_are_refused_and_change_nothing() {
    let mut body = flat(5, 0.2, Vec3::ZERO);
    let bad = [
        ColliderDesc {
            shape: Shape::Sphere { radius: -1.0 },
            ..ColliderDesc::default()
        },
        ColliderDesc {
            transform: Transform::from_position(Vec3::new(f32::NAN, 0.0, 0.0)),
            ..ColliderDesc::default()
        },
        ColliderDesc {
            thickness: -0.1,
            ..ColliderDesc::default()
        },
        ColliderDesc {
            friction: f32::INFINITY,
            ..ColliderDesc::default()
        },
    ];
    for d in bad {
        assert!(matches!(
            body.colliders_mut().add(d),
            Err(SoftBodyError::BadCollider(_))
        ));
    }
    assert!(body.colliders().is_empty());
    let id = body.colliders_mut().add(ColliderDesc::default()).unwrap();
    let before = *body.colliders().get(id).unwrap();
    let nan = Transform {
        position: Vec3::ZERO,
        rotation: Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0),
    };
    assert!(body.colliders_mut().set_transform(id, nan).is_err());
    assert!(body.colliders_mut().set_surface(id, 0.01, -1.0).is_err());
    assert_eq!(*body.colliders().get(id).unwrap(), before);
    body.colliders_mut().remove(id).unwrap();
    assert_eq!(
        body.colliders_mut().remove(id),
        Err(SoftBodyError::StaleCollider)
    );
    assert!(
        body.colliders_mut()
            .set_transform(id, Transform::IDENTITY)
            .is_err()
    );
}

#[test]
fn penetration_is_measured_against_the_bare_shape() {
    let mut c = Colliders::default();
    c.add(ColliderDesc {
        shape: Shape::Sphere { radius: 1.0 },
        ..ColliderDesc::default()
    })
    .unwrap();
    let pts = [Vec3::new(0.0, 0.99, 0.0), Vec3::new(0.0, 1.5, 0.0)];
    assert!((c.max_penetration(&pts) - 0.01).abs() < 1e-5);
    assert_eq!(c.max_penetration(&pts[1..]), 0.0);
}

/// Where two colliders overlap (two capsules side by side, as at a joint or between the
/// legs), a point pushed out of one can land in the other; `push_out` checks the points it
/// moved again, so none is left inside either. One pass over the colliders (what it did
/// before) leaves some.
#[test]
fn push_out_leaves_no_point_inside_overlapping_colliders() {
    let mut c = Colliders::default();
    let capsule = Shape::Capsule {
        radius: 0.1,
        half_length: 0.3,
    };
    for x in [0.0, 0.12] {
        c.add(ColliderDesc {
            shape: capsule,
            transform: Transform {
                position: Vec3::new(x, 0.0, 0.0),
                rotation: Quat::IDENTITY,
            },
            thickness: 0.01,
            ..ColliderDesc::default()
        })
        .unwrap();
    }
    let mut points = Vec::new();
    for i in 0..24 {
        for j in 0..8 {
            for k in 0..24 {
                points.push(Vec3::new(
                    -0.1 + 0.32 * i as f32 / 23.0,
                    -0.2 + 0.4 * j as f32 / 7.0,
                    -0.12 + 0.24 * k as f32 / 23.0,
                ));
            }
        }
    }
    assert!(c.max_penetration(&points) > 0.05, "the points start inside");
    let mut once = points.clone();
    let mut moved = Vec::new();
    c.push_out_pass(&mut once, None, &mut moved);
    let left = c.max_penetration(&once);
    assert!(left > 1e-3, "one pass leaves points inside: {left}");
    c.push_out(&mut points);
    let left = c.max_penetration(&points);
    assert_eq!(left, 0.0, "push_out left a point {left} m inside");
}
