//! What one refine/coarse transition in flight costs a cloth's step, at 16, 32 and 64 substeps:
//! the measurement behind `slod::cloth::CostModel::transition` and `transition_substep`.
//!
//! A 65×65 net pinned at its corners starts at level 2 and swings for 30 steps; then, 60 times,
//! up to 40 of its nodes (every seventh refinable one, the choice rotating) begin a refine, the
//! three steps after that are timed with the transitions in flight, three more let them end,
//! three are timed with the same nodes and none in flight, and the refined nodes are merged
//! back. (Time with − time without) / (transitions × steps) is the cost of a transition per step.
//! One thread's wall time; quote ratios from one run (the machine is shared).
//!
//! `cargo run --release -p slod-experiments --example transition_cost`

use std::time::Instant;

use glam::Vec3;
use salience::View;
use slod::cloth::AdaptiveCloth;
use softbody::TreeCutSettings;
use treecut::GridSpec;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let spec = GridSpec::horizontal(65, 65, 2.0 / 64.0, 1.0);
    let eye = Vec3::new(0.0, 1.0, 3.0);
    let view = View::look_at(eye, Vec3::ZERO, Vec3::Y, 50f32.to_radians(), 1920, 1080)?;
    for substeps in [16u32, 32, 64] {
        let mut c = AdaptiveCloth::grid(&spec, 2, TreeCutSettings::default())?;
        for (i, j) in [(0, 0), (64, 0), (0, 64), (64, 64)] {
            c.body_mut()
                .pin_vertex(spec.vertex(i, j), spec.position(i, j))?;
        }
        let mut solver = c.body().settings().solver;
        solver.substeps = substeps;
        c.body_mut().set_solver_settings(solver)?;
        for _ in 0..30 {
            c.step(&view)?;
        }
        let (mut with, mut without, mut transition_steps) = (0.0, 0.0, 0usize);
        let rounds = 60;
        for round in 0..rounds {
            let h = c.hierarchy().clone();
            let active = c.body().cut().active().to_vec();
            let mut begun = Vec::new();
            for (k, &n) in active.iter().enumerate() {
                if (k + round) % 7 != 0 || h.is_leaf(n) || c.body().cut().can_refine(&h, n).is_err()
                {
                    continue;
                }
                c.refine(n)?;
                begun.push(n);
                if begun.len() == 40 {
                    break;
                }
            }
            let in_flight = c.interpolations();
            let t = Instant::now();
            for _ in 0..3 {
                c.step(&view)?;
            }
            with += t.elapsed().as_secs_f64();
            transition_steps += 3 * in_flight;
            for _ in 0..3 {
                c.step(&view)?;
            }
            assert_eq!(c.interpolations(), 0, "the transitions ended");
            let t = Instant::now();
            for _ in 0..3 {
                c.step(&view)?;
            }
            without += t.elapsed().as_secs_f64();
            for &n in &begun {
                c.coarse(n)?;
            }
            for _ in 0..6 {
                c.step(&view)?;
            }
        }
        let steps = 3.0 * rounds as f64;
        let per = (with - without) / transition_steps as f64;
        println!(
            "{substeps} substeps: step {:.3} ms with {:.1} transitions in flight, {:.3} ms \
             without; one transition per step {:.2} µs ({:.0} ns per substep)",
            with / steps * 1e3,
            transition_steps as f64 / steps,
            without / steps * 1e3,
            per * 1e6,
            per * 1e9 / substeps as f64
        );
    }
    Ok(())
}
