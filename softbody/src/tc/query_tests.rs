//! Queries do not change the simulation, and what the host renders keeps its pins: the
//! reconstruction contracts of the C ABI (issue "contracts that hold at the boundary").

use super::tests::{Rng, bits, body, pin_corners, random_op, spec};
use super::*;
use crate::ReconstructionMode;

/// Two identical bodies under identical operations; only one is reconstructed, every step and
/// in both modes. They stay bit-identical, on coarse and changing cuts.
#[test]
fn reading_the_surface_never_changes_the_simulation() {
    let n = 17;
    let (mut read, mut unread) = (body(n, 2, true), body(n, 2, true));
    pin_corners(&mut read, n);
    pin_corners(&mut unread, n);
    let (mut rng_a, mut rng_b) = (Rng::new(11), Rng::new(11));
    let mut out = vec![Vec3::ZERO; (n * n) as usize];
    for step in 0..300 {
        if step % 4 == 0 {
            assert_eq!(
                random_op(&mut read, &mut rng_a),
                random_op(&mut unread, &mut rng_b)
            );
        }
        read.reconstruct(&mut out).unwrap();
        read.reconstruct_with(ReconstructionMode::Rigid, &mut out)
            .unwrap();
        read.step();
        unread.step();
        assert_eq!(
            bits(read.particle_positions()),
            bits(unread.particle_positions()),
            "step {step}"
        );
        assert_eq!(read.cut().active(), unread.cut().active(), "step {step}");
    }
}

/// Every pinned vertex is exactly at its anchor in the reconstructed surface, at every cut
/// (coarse ones included) and with the anchors moved.
#[test]
fn pinned_vertices_are_at_their_anchors_at_every_cut() {
    let n = 17;
    let s = spec(n);
    for level in 0..4 {
        let mut tc = body(n, level, true);
        pin_corners(&mut tc, n);
        // One extra pin in the middle of an edge, inside a coarse node.
        let mid = n / 2;
        tc.pin_vertex(mid, s.position(mid, 0) + Vec3::new(0.0, 0.05, 0.0))
            .unwrap();
        let mut rng = Rng::new(level as u64);
        let mut out = vec![Vec3::ZERO; (n * n) as usize];
        for step in 0..120 {
            if step % 3 == 0 {
                random_op(&mut tc, &mut rng);
            }
            if step == 60 {
                // Move one anchor: a kinematic pin.
                tc.pin_vertex(0, s.position(0, 0) + Vec3::new(0.1, 0.0, 0.0))
                    .unwrap();
            }
            tc.step();
            for mode in [
                ReconstructionMode::Rigid,
                ReconstructionMode::Smooth,
                ReconstructionMode::Mls,
            ] {
                tc.reconstruct_with(mode, &mut out).unwrap();
                for v in 0..n * n {
                    if let Some(anchor) = tc.vertex_anchor(v) {
                        assert_eq!(out[v as usize], anchor, "level {level} step {step} v {v}");
                    }
                }
            }
        }
    }
}
