//! Tests of the plain solver: builders, validation, determinism, deletion, material scaling.

use crate::*;
use glam::{Vec3, Vec4};

/// The plain solver as other engines configure it (one step of 20 iterations, light damping);
/// pinned here so the tests do not move with the defaults.
fn settings() -> SolverSettings {
    SolverSettings {
        dt: 1.0 / 60.0,
        substeps: 1,
        iterations: 20,
        gravity: Vec3::new(0.0, -9.81, 0.0),
        damping: 0.1,
        ..SolverSettings::default()
    }
}

fn bits(p: &[Vec4]) -> Vec<[u32; 4]> {
    p.iter().map(|v| v.to_array().map(f32::to_bits)).collect()
}

fn net(n: u32) -> (GridCloth, SoftBody) {
    let g = GridCloth::square(n, 1.0 / (n - 1) as f32, 1.0 / (n * n) as f32);
    let mut body = g.build_bullet(settings()).unwrap();
    for c in g.corners() {
        body.set_pinned(c, true).unwrap();
    }
    (g, body)
}

#[test]
fn bullet_cloth_has_bullets_link_counts() {
    let (_, body) = net(65);
    assert_eq!(body.link_count(), 12_416 + 24_319);
    body.check_links();
    let g = GridCloth::square(65, 0.1, 1.0);
    let plain = g.build(settings()).unwrap();
    // structural 2·64·65 + shear 2·64·64
    assert_eq!(plain.link_count(), 2 * 64 * 65 + 2 * 64 * 64);
    plain.check_links();
}

#[test]
fn bad_input_is_refused() {
    let mut b = SoftBody::new(settings()).unwrap();
    assert!(matches!(
        b.add_particle(Vec3::new(f32::NAN, 0.0, 0.0), 1.0),
        Err(SoftBodyError::NotFinite { .. })
    ));
    assert!(matches!(
        b.add_particle(Vec3::ZERO, 0.0),
        Err(SoftBodyError::BadMass { .. })
    ));
    assert!(matches!(
        b.add_particle(Vec3::ZERO, -1.0),
        Err(SoftBodyError::BadMass { .. })
    ));
    let p = b.add_particle(Vec3::ZERO, 1.0).unwrap();
    let q = b.add_particle(Vec3::X, 1.0).unwrap();
    assert!(matches!(
        b.add_link(p, ParticleId::from_raw(7), 1.0, 0.0),
        Err(SoftBodyError::OutOfRange { .. })
    ));
    assert!(matches!(
        b.add_link(p, p, 1.0, 0.0),
        Err(SoftBodyError::SelfLink(0))
    ));
    assert!(b.add_link(p, q, f32::NAN, 0.0).is_err());
    assert!(b.add_link(p, q, 1.0, -1.0).is_err());
    assert!(b.add_link_weighted(p, q, 1.0, 0.0, 1.5).is_err());
    assert_eq!(b.link_count(), 0);
    assert_eq!(b.particle_count(), 2);
    let bad_dt = SolverSettings {
        dt: 0.0,
        ..settings()
    };
    assert!(matches!(
        SoftBody::new(bad_dt),
        Err(SoftBodyError::BadSetting(_))
    ));
    assert!(
        b.set_settings(SolverSettings {
            dt: -1.0,
            ..settings()
        })
        .is_err()
    );
    assert!(
        b.set_settings(SolverSettings {
            iterations: 0,
            ..settings()
        })
        .is_err()
    );
    assert_eq!(b.settings(), &settings());
    let pos = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let bad_tri = MeshCloth {
        positions: &pos,
        triangles: &[[0, 1, 3]],
        masses: VertexMasses::Uniform(1.0),
        bend: false,
        material: Material::default(),
    };
    assert!(matches!(
        bad_tri.build(settings()),
        Err(SoftBodyError::OutOfRange { .. })
    ));
    let bad_mass = MeshCloth {
        triangles: &[[0, 1, 2]],
        masses: VertexMasses::PerVertex(&[1.0, 0.0, 1.0]),
        ..bad_tri
    };
    assert!(matches!(
        bad_mass.build(settings()),
        Err(SoftBodyError::BadMass { index: 1, .. })
    ));
    let ok = MeshCloth {
        triangles: &[[0, 1, 2]],
        ..bad_tri
    }
    .build(settings())
    .unwrap();
    assert_eq!(ok.link_count(), 3);
}

#[test]
fn runs_are_bit_identical() {
    let run = || {
        let (_, mut b) = net(33);
        b.set_external_force(ParticleId::from_raw(500), Vec3::new(0.3, 0.0, -0.2))
            .unwrap();
        for _ in 0..60 {
            b.step();
        }
        bits(b.positions())
    };
    assert_eq!(run(), run());
}

/// A link of weight 0 and a removed link are indistinguishable: removing links (which
/// reorders their batches by swap-removal) leaves the other links' results bit-identical.
#[test]
fn deleting_links_does_not_change_survivors() {
    let (_, mut kept) = net(33);
    let mut removed = kept.clone();
    // Remove a spread of links from many batches (early slots move tail links into lane chunks).
    let victims: Vec<LinkId> = kept
        .links()
        .map(|l| l.id)
        .filter(|l| l.raw() % 7 == 3)
        .collect();
    assert!(victims.len() > 500);
    for &l in &victims {
        kept.set_link_weight(l, 0.0).unwrap();
        removed.remove_link(l).unwrap();
    }
    removed.check_links();
    for _ in 0..40 {
        kept.step();
        removed.step();
    }
    assert_eq!(bits(kept.positions()), bits(removed.positions()));
    assert_eq!(bits(kept.velocities()), bits(removed.velocities()));
    // And the removal did change things compared with full-weight links (the test can fail).
    let (_, mut full) = net(33);
    for _ in 0..40 {
        full.step();
    }
    assert_ne!(bits(full.positions()), bits(removed.positions()));
}

#[test]
fn removing_particles_keeps_links_consistent() {
    let (_, mut b) = net(9);
    let before = b.particle_count();
    let moved = b.remove_particle(ParticleId::from_raw(10)).unwrap();
    assert_eq!(moved, Some(ParticleId::from_raw(before as u32 - 1)));
    b.check_links();
    assert_eq!(
        b.remove_particle(ParticleId::from_raw(b.particle_count() as u32 - 1))
            .unwrap(),
        None
    );
    b.check_links();
    for _ in 0..10 {
        b.step();
    }
    assert!(b.positions().iter().all(|p| p.is_finite()));
}

#[test]
fn momentum_is_conserved_without_pins_or_gravity() {
    let g = GridCloth::square(17, 0.1, 0.01);
    let s = SolverSettings {
        gravity: Vec3::ZERO,
        damping: 0.0,
        ..settings()
    };
    let mut b = g.build_bullet(s).unwrap();
    for i in 0..b.particle_count() {
        let f = i as f32;
        b.set_velocity(
            ParticleId::new(i),
            Vec3::new((f * 0.9).sin(), (f * 0.31).cos(), 0.5 * (f * 1.7).sin()),
        )
        .unwrap();
    }
    let p0 = b.total_momentum();
    // Rounding of f32 positions is the only source of error: bound it relative to Σ m|v|.
    let scale: f64 = b
        .velocities()
        .iter()
        .zip(b.masses())
        .map(|(v, &m)| v.length() as f64 * m as f64)
        .sum();
    for _ in 0..100 {
        b.step();
    }
    let p1 = b.total_momentum();
    assert!((p1 - p0).length() < 1e-5 * scale, "{p0} -> {p1}");
}

/// Chain scaling: n links of length l/n stretch like one link of length l.
#[test]
fn chain_compliance_is_resolution_independent() {
    let stretch = |n: usize| {
        let s = SolverSettings {
            gravity: Vec3::ZERO,
            damping: 20.0,
            substeps: 4,
            iterations: 20,
            dt: 1.0 / 60.0,
            ..SolverSettings::default()
        };
        let mut b = SoftBody::new(s).unwrap();
        let mat = Material {
            stretch_compliance: 1e-3,
            bend_compliance: 0.0,
            scaling: ComplianceScaling::Chain,
        };
        for i in 0..=n {
            // Compliance well above h²/m, so that the chain converges within the iterations.
            b.add_particle(Vec3::new(0.0, -(i as f32) / n as f32, 0.0), 1.0)
                .unwrap();
        }
        for i in 0..n {
            let rest = 1.0 / n as f32;
            b.add_link(
                ParticleId::new(i),
                ParticleId::new(i + 1),
                rest,
                mat.stretch(rest),
            )
            .unwrap();
        }
        b.set_pinned(ParticleId::from_raw(0), true).unwrap();
        b.set_external_force(ParticleId::new(n), Vec3::new(0.0, -10.0, 0.0))
            .unwrap();
        for _ in 0..600 {
            b.step();
        }
        -b.position(ParticleId::new(n)).y - 1.0
    };
    let (one, eight) = (stretch(1), stretch(8));
    // Expected F·c·l = 10 · 1e-3 · 1 = 0.01.
    assert!((one - 0.01).abs() < 1e-4, "{one}");
    assert!((eight - 0.01).abs() < 2e-4, "{eight}");
    // The membrane rule (same compliance per link) would stretch eight times as much.
    assert!(eight < 0.02);
}

/// Membrane scaling: a curtain hanging from its top edge stretches the same amount at
/// two resolutions with the same total mass and the same material compliance.
#[test]
fn membrane_compliance_is_resolution_independent() {
    let sag = |n: u32, scaling: ComplianceScaling| {
        let s = SolverSettings {
            damping: 10.0,
            substeps: 8,
            iterations: 10,
            ..settings()
        };
        let mut g = GridCloth::square(n, 1.0 / (n - 1) as f32, 1.0 / (n * n) as f32);
        g.v = Vec3::new(0.0, -1.0 / (n - 1) as f32, 0.0);
        g.material = Material {
            stretch_compliance: 2e-2,
            bend_compliance: 0.0,
            scaling,
        };
        let mut b = g.build(s).unwrap();
        for i in 0..n {
            b.set_pinned(ParticleId::from_raw(i), true).unwrap();
        }
        for _ in 0..400 {
            b.step();
        }
        // Mean stretch of the bottom row below its rest height (-1).
        let bottom = (n - 1) * n..n * n;
        bottom
            .map(|i| -b.position(ParticleId::from_raw(i)).y - 1.0)
            .sum::<f32>()
            / n as f32
    };
    let (coarse, fine) = (
        sag(9, ComplianceScaling::Membrane),
        sag(17, ComplianceScaling::Membrane),
    );
    assert!(coarse > 0.01, "{coarse}");
    assert!(
        (coarse - fine).abs() < 0.1 * fine,
        "membrane: coarse {coarse} fine {fine}"
    );
    // The chain rule would make the coarse cloth (longer links) clearly softer.
    let (cc, cf) = (
        sag(9, ComplianceScaling::Chain),
        sag(17, ComplianceScaling::Chain),
    );
    assert!(cc > 1.5 * cf, "chain: coarse {cc} fine {cf}");
}

#[test]
fn swinging_net_stays_finite_and_settles() {
    let (_, mut b) = net(33);
    let mut last = Vec::new();
    for step in 0..900 {
        b.step();
        if step == 898 {
            last = b.positions().to_vec();
        }
    }
    assert!(b.positions().iter().all(|p| p.is_finite()));
    let moved = b
        .positions()
        .iter()
        .zip(&last)
        .map(|(a, c)| (*a - *c).length())
        .fold(0.0f32, f32::max);
    let speed = b
        .velocities()
        .iter()
        .map(|v| v.length())
        .fold(0.0f32, f32::max);
    assert!(moved < 1e-3 && speed < 0.05, "moved {moved} speed {speed}");
    // It hangs below the pinned corners.
    let mid = b.position(ParticleId::from_raw(16 * 33 + 16));
    assert!(mid.y < -0.1, "{mid}");
}

#[test]
fn anchors_move_kinematically() {
    let (g, mut b) = net(9);
    let c = g.corners()[0];
    let target = b.position(c) + Vec3::new(0.0, 0.1, 0.0);
    b.set_anchor(c, target).unwrap();
    b.step();
    assert_eq!(b.position(c), target);
    assert!((b.velocity(c).y - 0.1 * 60.0).abs() < 1e-3);
    b.step();
    assert_eq!(b.position(c), target);
    assert_eq!(b.velocity(c), Vec3::ZERO);
}

/// Every kernel path this CPU supports steps a cloth to the same bits as the scalar path
/// (tolerance zero: no path uses FMA), including while links are removed and re-weighted.
#[test]
fn every_kernel_path_steps_like_scalar() {
    let (_, reference) = net(23);
    let run = |path: KernelPath| {
        let mut body = reference.clone();
        body.set_kernel_path(path).unwrap();
        assert_eq!(body.kernel_path(), path);
        for step in 0..12 {
            if step == 4 {
                thin_links(&mut body, 7, 0.3);
            }
            body.step();
        }
        (bits(body.positions()), bits(body.velocities()))
    };
    let scalar = run(KernelPath::Scalar);
    for path in KernelPath::supported() {
        assert!(run(path) == scalar, "{path:?} differs from the scalar path");
    }
    let unsupported = KernelPath::ALL.into_iter().find(|p| !p.is_supported());
    if let Some(p) = unsupported {
        let mut body = reference.clone();
        assert!(matches!(
            body.set_kernel_path(p),
            Err(SoftBodyError::UnsupportedKernel(_))
        ));
    }
}

/// Of every `every`-th link (in solve order), removes half and gives the others `weight`.
fn thin_links(body: &mut SoftBody, every: usize, weight: f32) {
    let ids: Vec<LinkId> = body.links().map(|l| l.id).step_by(every).collect();
    for (k, id) in ids.into_iter().enumerate() {
        if k % 2 == 0 {
            body.remove_link(id).unwrap();
        } else {
            body.set_link_weight(id, weight).unwrap();
        }
    }
}

/// Runs `f` on a rayon pool of `threads` threads (what a host does to choose the threads).
pub(crate) fn on_pool<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// Splitting the colour batches and particle loops across threads changes no bit: the same
/// body (every batch split, an ordered overflow batch from a 70-link hub, a collider, links
/// removed and reweighted midway) steps to identical positions and velocities on 1, 2 and 4 threads, and
/// with splitting switched off.
#[test]
fn threads_step_bit_identically() {
    let (_, mut reference) = net(23);
    let hub = reference
        .add_particle(Vec3::new(0.5, 0.3, 0.5), 0.01)
        .unwrap();
    for k in 0..70u32 {
        let p = ParticleId::from_raw(k * 7);
        reference.add_link(hub, p, 0.6, 1e-4).unwrap();
    }
    // A sphere under the middle, so the contact pass runs between the split sweeps.
    reference
        .colliders_mut()
        .add(ColliderDesc {
            shape: Shape::Sphere { radius: 0.15 },
            transform: Transform::from_position(Vec3::new(0.5, -0.2, 0.5)),
            ..ColliderDesc::default()
        })
        .unwrap();
    // A moving anchor and an external force, so every part of a substep is exercised.
    let anchor = ParticleId::from_raw(3);
    reference.set_pinned(anchor, true).unwrap();
    reference
        .set_external_force(ParticleId::from_raw(40), Vec3::new(0.3, 0.1, -0.2))
        .unwrap();
    let run = |min_links: u32, threads: usize, substeps: u32, iterations: u32| {
        let mut body = reference.clone();
        body.set_settings(SolverSettings {
            parallel_min_links: min_links,
            substeps,
            iterations,
            ..settings()
        })
        .unwrap();
        on_pool(threads, || {
            for step in 0..10 {
                if step == 4 {
                    thin_links(&mut body, 5, 0.4);
                }
                let target = Vec3::new(0.01 * step as f32, 0.0, 0.02 * step as f32);
                body.set_anchor(anchor, target).unwrap();
                body.step();
            }
        });
        body.check_links();
        assert!(
            body.touched_all().iter().any(|&t| t),
            "the sphere was reached"
        );
        (bits(body.positions()), bits(body.velocities()))
    };
    assert!(
        reference.link_count() > 64 * 2 * 16,
        "batches large enough to split"
    );
    // 3 × 4, and the default 32 substeps × 1 iteration (one team for 32 substeps).
    let defaults = SolverSettings::default();
    for (substeps, iterations) in [(3, 4), (defaults.substeps, defaults.iterations)] {
        let sequential = run(0, 1, substeps, iterations);
        for threads in [1, 2, 4] {
            for min_links in [1, 200] {
                assert!(
                    run(min_links, threads, substeps, iterations) == sequential,
                    "{threads} threads, parallel_min_links {min_links}, {substeps} × {iterations}"
                );
            }
        }
    }
}

/// The topology generation moves with every particle or link added or removed, and with
/// nothing else (a step, a position, a weight): what keeps a neighbourhood cache honest.
#[test]
fn topology_generation_moves_with_links_and_particles_only() {
    let (_, mut body) = net(5);
    let mut g = body.topology_generation();
    let mut moved = |body: &SoftBody, expect: bool, what: &str| {
        let now = body.topology_generation();
        assert_eq!(now != g, expect, "{what}");
        g = now;
    };
    body.step();
    moved(&body, false, "step");
    body.set_position(ParticleId::new(3), Vec3::ONE).unwrap();
    moved(&body, false, "position");
    let l = body
        .add_link(ParticleId::new(0), ParticleId::new(24), 1.0, 0.0)
        .unwrap();
    moved(&body, true, "link added");
    body.set_link_weight(l, 0.5).unwrap();
    moved(&body, false, "weight");
    body.remove_link(l).unwrap();
    moved(&body, true, "link removed");
    let p = body.add_particle(Vec3::ZERO, 1.0).unwrap();
    moved(&body, true, "particle added");
    body.remove_particle(p).unwrap();
    moved(&body, true, "particle removed");
    body.remove_particle(ParticleId::new(7)).unwrap();
    moved(&body, true, "particle with links removed");
}
