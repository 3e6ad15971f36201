//! The slod demo: runs the papers' scenarios and prints their tables beside ours.
//!
//! Until the full demo lands, this shows what exists: a treecut on the paper's 65×65 net refined
//! and coarsened under a moving priority field, with per-operation timings.

use std::time::Instant;

use treecut::{Budget, Cut, Evaluator, EvaluatorSettings, GridSpec, Hierarchy, Op};

fn main() {
    let spec = GridSpec::horizontal(65, 65, 1.0 / 64.0, 1.0);
    let h = Hierarchy::grid(&spec).expect("the 65x65 grid is valid");
    println!(
        "treecut on a {}x{} grid: {} nodes in {} levels",
        spec.cols,
        spec.rows,
        h.len(),
        h.level_count()
    );
    let mut cut = Cut::uniform(&h, 2);
    let mut ev = Evaluator::new(EvaluatorSettings::default());
    let budget = Budget::Nodes(h.vertex_count() * 3 / 10);
    let mut prio = vec![0f32; h.len()];
    let (mut refines, mut coarses) = (0usize, 0usize);
    let (mut op_time, mut eval_time) = (0f64, 0f64);
    for frame in 0..240 {
        // A bright spot circling the net: nodes near it matter most.
        let t = frame as f32 / 60.0;
        let spot = glam::Vec3::new(0.3 * t.cos(), 0.0, 0.3 * t.sin());
        for (i, p) in prio.iter_mut().enumerate() {
            let d = h.rest_positions()[i].distance(spot);
            *p = (-d * d / 0.02).exp();
        }
        let start = Instant::now();
        let ops = ev
            .evaluate(&h, &cut, &prio, None, budget)
            .expect("valid inputs")
            .to_vec();
        eval_time += start.elapsed().as_secs_f64();
        let start = Instant::now();
        for op in &ops {
            match *op {
                Op::Refine(n) => {
                    cut.refine(&h, n).expect("evaluator proposes valid ops");
                    refines += 1;
                }
                Op::Coarse(p) => {
                    cut.coarse(&h, p).expect("evaluator proposes valid ops");
                    coarses += 1;
                }
            }
        }
        op_time += start.elapsed().as_secs_f64();
        if frame % 60 == 59 {
            println!("frame {:3}: {:5} active nodes", frame + 1, cut.len());
        }
    }
    cut.check_invariant(&h).expect("the cut invariant holds");
    let ops = (refines + coarses).max(1) as f64;
    println!(
        "{refines} refines, {coarses} coarses: {:.1} ns per operation, {:.1} us per evaluation",
        op_time / ops * 1e9,
        eval_time / 240.0 * 1e6
    );
}
