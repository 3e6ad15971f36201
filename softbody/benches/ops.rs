//! Cost of the four TreeCut operations (the paper's Table 1: begin-refine 18 µs, end-refine
//! 1.8 µs, begin-coarse 32.7 µs, end-coarse 2.5 µs at ~4900 nodes).
//!
//! The body is a square grid net at the finest cut (70×70 = 4900 nodes, 224×224 = 50,176),
//! corners pinned, sagged for a few steps. Each iteration picks the next level-1 node (in a
//! scattered order) and runs the cycle begin-coarse, end-coarse, begin-refine, end-refine
//! (blend_steps = 0, so every transition ends at the next `end_finished`), which returns the
//! body to the finest cut; only the named operation is timed.
use criterion::{Criterion, criterion_group, criterion_main};
use softbody::treecut::{Cut, GridSpec, Hierarchy, NodeId};
use softbody::{TreeCutSettings, TreeCutSoftBody};
use std::hint::black_box;
use std::time::{Duration, Instant};

fn net(n: u32) -> (TreeCutSoftBody, Vec<NodeId>) {
    let spec = GridSpec::horizontal(n, n, 1.0 / (n - 1) as f32, 1.0);
    let h = Hierarchy::grid(&spec).unwrap();
    let cut = Cut::finest(&h);
    let s = TreeCutSettings {
        blend_steps: 0,
        ..TreeCutSettings::default()
    };
    let mut tc = TreeCutSoftBody::new(h, cut, s).unwrap();
    for v in [0, n - 1, n * (n - 1), n * n - 1] {
        tc.pin_vertex(v, spec.position(v % n, v / n)).unwrap();
    }
    for _ in 0..20 {
        tc.step();
    }
    // Level-1 nodes in a scattered (multiplicative hash) order.
    let level1: Vec<NodeId> = tc.hierarchy().nodes_at_level(1).collect();
    let mut order: Vec<NodeId> = level1.clone();
    order.sort_by_key(|p| (p.raw().wrapping_mul(2654435761)) >> 8);
    (tc, order)
}

#[derive(Clone, Copy)]
enum Phase {
    BeginCoarse,
    EndCoarse,
    BeginRefine,
    EndRefine,
}

fn cycle(tc: &mut TreeCutSoftBody, p: NodeId, timed: Phase) -> Duration {
    let mut d = Duration::ZERO;
    let mut run = |phase: Phase, f: &mut dyn FnMut()| {
        if std::mem::discriminant(&phase) == std::mem::discriminant(&timed) {
            let t = Instant::now();
            f();
            d = t.elapsed();
        } else {
            f();
        }
    };
    run(Phase::BeginCoarse, &mut || tc.begin_coarse(p).unwrap());
    run(Phase::EndCoarse, &mut || assert_eq!(tc.end_finished(), 1));
    run(Phase::BeginRefine, &mut || tc.begin_refine(p).unwrap());
    run(Phase::EndRefine, &mut || assert_eq!(tc.end_finished(), 1));
    d
}

fn bench(c: &mut Criterion) {
    for n in [70u32, 224] {
        let (mut tc, order) = net(n);
        let nodes = tc.particle_count();
        let mut next = 0usize;
        for (name, phase) in [
            ("begin_refine", Phase::BeginRefine),
            ("end_refine", Phase::EndRefine),
            ("begin_coarse", Phase::BeginCoarse),
            ("end_coarse", Phase::EndCoarse),
        ] {
            c.bench_function(&format!("{name} ({nodes} nodes)"), |b| {
                b.iter_custom(|iters| {
                    let mut total = Duration::ZERO;
                    for _ in 0..iters {
                        let p = order[next % order.len()];
                        next += 1;
                        total += cycle(black_box(&mut tc), p, phase);
                    }
                    total
                });
            });
        }
        assert_eq!(tc.particle_count(), nodes);
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
