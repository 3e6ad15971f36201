//! The TreeCut evaluation off its step's critical path (issue 15), measured: the paper's net
//! stepped alone, its evaluations run before the solver as the loop does by default, or
//! overlapped with it (`FeedbackSettings::overlap_step`: the measurement on another thread of
//! the rayon pool while the solver runs, the operations begun after the step).
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), section 5
//! (its TreeCut evaluation ran in parallel with the simulation). Without the overlap an
//! evaluation lands inside every `interval`-th step as a spike; the figure of merit is that
//! step's wall time against a plain step's, both medians over the same window, the two cloths
//! stepped interval by interval in turn (the machine is shared and noisy).

use std::time::Instant;

use slod::cloth::{AdaptiveCloth, ClothBudget, ClothError, FeedbackSettings};

use crate::median;
use crate::net::NetConfig;

/// One budget's measurement.
#[derive(Clone, Debug, PartialEq)]
pub struct OverlapRow {
    /// The budget, as the report names it (`30%`, `100%`, `1 px`).
    pub budget: String,
    /// Mean simulated nodes of the overlapped cloth over the measured steps.
    pub nodes: f64,
    /// Median wall time of a step without evaluation, both cloths, ms.
    pub plain_step_ms: f64,
    /// Median wall time of an evaluating step, evaluation before the solver, ms.
    pub evaluating_step_ms_sequential: f64,
    /// Median wall time of an evaluating step, evaluation overlapped with the solver, ms.
    pub evaluating_step_ms_overlapped: f64,
    /// Threads of the rayon pool the overlapped measurement was spawned on.
    pub threads: usize,
}

/// The paper's net under `budget`, warmed up for `warm` steps (into the swing, the cut
/// adapted), with or without the overlap (which runs on the rayon pool: `parallel` on).
fn net(
    config: &NetConfig,
    budget: ClothBudget,
    overlap: bool,
) -> Result<AdaptiveCloth, ClothError> {
    let spec = config.grid();
    let n = config.size;
    let mut c = AdaptiveCloth::grid(&spec, 0, config.body)?;
    for (i, j) in [(0, 0), (n - 1, 0), (0, n - 1), (n - 1, n - 1)] {
        c.body_mut()
            .pin_vertex(spec.vertex(i, j), spec.position(i, j))?;
    }
    c.set_feedback(Some(FeedbackSettings {
        budget,
        overlap_step: overlap,
        parallel: overlap,
        ..config.feedback
    }))?;
    Ok(c)
}

/// Measures the net at 30%, at 100% and under a 1 px error bound: `warm` steps, then
/// `intervals` feedback intervals of each cloth in turn (the order alternating).
pub fn measure(
    config: &NetConfig,
    warm: u32,
    intervals: u32,
) -> Result<Vec<OverlapRow>, ClothError> {
    let budgets = [
        ("30%", ClothBudget::Compression(0.3)),
        ("100%", ClothBudget::Compression(1.0)),
        ("1 px", ClothBudget::MaxErrorPx(1.0)),
    ];
    let mut rows = Vec::new();
    for (name, budget) in budgets {
        let mut cloths = [net(config, budget, false)?, net(config, budget, true)?];
        for c in &mut cloths {
            for _ in 0..warm {
                c.step(&config.view)?;
            }
        }
        let (mut plain, mut evaluating) = (Vec::new(), [Vec::new(), Vec::new()]);
        let mut nodes = 0u64;
        let interval = config.feedback.interval;
        for k in 0..intervals {
            for turn in 0..2 {
                let which = (turn + k as usize) % 2;
                let c = &mut cloths[which];
                for _ in 0..interval {
                    let due = c.evaluation_due();
                    let t = Instant::now();
                    c.step(&config.view)?;
                    let ms = t.elapsed().as_secs_f64() * 1e3;
                    if due {
                        evaluating[which].push(ms);
                    } else {
                        plain.push(ms);
                    }
                    if which == 1 {
                        nodes += c.node_count() as u64;
                    }
                }
            }
        }
        let [sequential, overlapped] = &mut evaluating;
        rows.push(OverlapRow {
            budget: name.to_string(),
            nodes: nodes as f64 / (intervals * interval).max(1) as f64,
            plain_step_ms: median(&mut plain),
            evaluating_step_ms_sequential: median(sequential),
            evaluating_step_ms_overlapped: median(overlapped),
            threads: rayon::current_num_threads(),
        });
    }
    Ok(rows)
}
