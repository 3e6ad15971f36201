//! The paper's Table 1 measured: the cost of one TreeCut operation (begin-refine, end-refine,
//! begin-coarse, end-coarse) on a net of about 4,900 nodes, the size the paper measured at.
//!
//! Measured the way softbody's `ops` benchmark does, in timed loops rather than criterion: the
//! net starts at the finest cut, sagged for a few steps; each cycle takes the next level-1
//! node (in a scattered order) through begin-coarse, end-coarse, begin-refine, end-refine with
//! `blend_steps = 0`, so every transition can end at once and the cycle returns the body to the
//! finest cut. Each half is timed on its own; the mean and median over all cycles are reported,
//! with the node and link counts while it ran (the paper's N and L).

use std::time::Instant;

use serde::Serialize;
use slod_experiments::median;
use slod_experiments::net::NetConfig;
use softbody::{TreeCutSettings, TreeCutSoftBody};
use treecut::{Cut, GridSpec, Hierarchy, NodeId};

use crate::error::DemoError;
use crate::paper::{PaperOp, TABLE1};
use crate::progress::Progress;
use slod_experiments::table::{Table, num};

/// One operation's measured cost beside the paper's.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct OpRow {
    /// Our name of the operation (`begin-refine`, ...).
    pub(crate) operation: &'static str,
    /// Mean node count while it ran (N).
    pub(crate) nodes: f64,
    /// Mean link count while it ran (L).
    pub(crate) links: f64,
    /// Mean time of one operation (µs).
    pub(crate) mean_us: f64,
    /// Median time of one operation (µs).
    pub(crate) median_us: f64,
    /// The paper's row for the same operation (its times in ms).
    pub(crate) paper: PaperOp,
}

/// The measured Table 1.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct Table1 {
    /// Vertices per side of the net measured.
    pub(crate) net_size: u32,
    /// Operations of each kind timed.
    pub(crate) cycles: usize,
    /// One row per operation, in the paper's order.
    pub(crate) rows: Vec<OpRow>,
    /// Wall time of the measurement (s).
    pub(crate) seconds: f64,
}

/// The operations, in the paper's order (the slots of [`time_cycles`]'s results).
pub(crate) const OPERATIONS: [&str; 4] =
    ["begin-refine", "end-refine", "begin-coarse", "end-coarse"];

/// Per operation (paper's order): every time measured (µs), and the sums of node and link
/// counts while they ran.
pub(crate) type CycleTimes = ([Vec<f64>; 4], [(f64, f64); 4]);

/// Runs `cycles` cycles on `body` (at the finest cut, `blend_steps = 0`): each takes the next
/// node of `order` through begin-coarse, end-coarse, begin-refine, end-refine, timing each half
/// on its own. `tick(k)` is called every 64 cycles.
pub(crate) fn time_cycles(
    body: &mut TreeCutSoftBody,
    order: &[NodeId],
    cycles: usize,
    tick: &mut dyn FnMut(usize),
) -> Result<CycleTimes, DemoError> {
    let mut times: [Vec<f64>; 4] = std::array::from_fn(|_| Vec::with_capacity(cycles));
    let mut counts = [(0f64, 0f64); 4];
    for k in 0..cycles {
        let p = order[k % order.len()];
        // The order of the cycle: begin-coarse, end-coarse, begin-refine, end-refine; stored
        // in the paper's order (refine, end-refine, coarse, end-coarse).
        for (slot, phase) in [(2usize, 0u8), (3, 1), (0, 2), (1, 3)] {
            counts[slot].0 += body.particle_count() as f64;
            counts[slot].1 += body.link_count() as f64;
            let t = Instant::now();
            let ended = match phase {
                0 => body.begin_coarse(p).map(|()| 1)?,
                2 => body.begin_refine(p).map(|()| 1)?,
                _ => body.end_finished(),
            };
            times[slot].push(t.elapsed().as_secs_f64() * 1e6);
            if ended != 1 {
                return Err(DemoError::Internal(format!(
                    "a transition with blend_steps = 0 did not end at once (ended {ended})"
                )));
            }
        }
        if k % 64 == 63 {
            tick(k + 1);
        }
    }
    Ok((times, counts))
}

/// Vertices per side of the measured net: 70² = 4,900 nodes, the paper's N.
pub(crate) const PAPER_SIZE: u32 = 70;

/// A `size`×`size` net at its finest cut with the experiment's material and solver and no
/// blending (each begun operation can end at once), and its grid: what the operation timings
/// run on.
pub(crate) fn unblended_body(
    config: &NetConfig,
    size: u32,
) -> Result<(TreeCutSoftBody, GridSpec), DemoError> {
    let mut config = config.clone();
    config.size = size;
    let spec = config.grid();
    let h = Hierarchy::grid(&spec)?;
    let settings = TreeCutSettings {
        blend_steps: 0,
        ..config.body
    };
    let cut = Cut::finest(&h);
    Ok((TreeCutSoftBody::new(h, cut, settings)?, spec))
}

/// Times `cycles` cycles on a `size`×`size` net with the experiment's material and solver.
pub(crate) fn measure(
    config: &NetConfig,
    size: u32,
    cycles: usize,
    progress: Progress,
) -> Result<Table1, DemoError> {
    let start = Instant::now();
    let (mut body, spec) = unblended_body(config, size)?;
    for (i, j) in [(0, 0), (size - 1, 0), (0, size - 1), (size - 1, size - 1)] {
        body.pin_vertex(spec.vertex(i, j), spec.position(i, j))?;
    }
    for _ in 0..30 {
        body.step();
    }
    // Level-1 nodes in a scattered order (a seeded shuffle), so consecutive cycles touch
    // different parts of the net, as the feedback loop's operations do.
    let mut order: Vec<NodeId> = body.hierarchy().nodes_at_level(1).collect();
    slod_experiments::rng::Rng::new(0x7AB1E1).shuffle(&mut order);

    let bar = progress.bar(cycles as u64, "Table 1");
    bar.set_message(format!("TreeCut operations on {size}x{size}"));
    let (mut times, counts) = time_cycles(&mut body, &order, cycles, &mut |k| {
        bar.set_position(k as u64);
    })?;
    bar.finish_and_clear();
    let rows = (0..4)
        .map(|slot| {
            let t = &mut times[slot];
            let n = t.len().max(1) as f64;
            let mean = t.iter().sum::<f64>() / n;
            OpRow {
                operation: OPERATIONS[slot],
                nodes: counts[slot].0 / n,
                links: counts[slot].1 / n,
                mean_us: mean,
                median_us: median(t),
                paper: TABLE1[slot],
            }
        })
        .collect();
    Ok(Table1 {
        net_size: size,
        cycles,
        rows,
        seconds: start.elapsed().as_secs_f64(),
    })
}

impl Table1 {
    /// The table beside the paper's.
    pub(crate) fn render(&self) -> String {
        let mut t = Table::new(
            format!(
                "Table 1: one TreeCut operation, {0}x{0} net, {1} of each timed (paper: {2})",
                self.net_size,
                self.cycles,
                crate::paper::PAPER_MACHINE
            ),
            &[
                "operation",
                "N",
                "L",
                "mean µs",
                "median µs",
                "paper µs",
                "paper N",
                "paper L",
                "paper/ours",
            ],
        );
        for r in &self.rows {
            let paper_us = r.paper.complete_ms * 1e3;
            t.row([
                format!("{} ({})", r.operation, r.paper.operation),
                num(r.nodes, 0),
                num(r.links, 0),
                num(r.mean_us, 2),
                num(r.median_us, 2),
                num(paper_us, 1),
                r.paper.nodes.to_string(),
                r.paper.links.to_string(),
                format!("{}x", num(paper_us / r.median_us, 1)),
            ]);
        }
        t.note(
            "Ours link every node to its 8 neighbours (structural + shear), so L is about 4N; \
             the paper's L is about 2N.",
        );
        t.note("The paper splits each time into node and link operations; ours are timed whole.");
        t.render()
    }
}
