//! The paper's Figure 4 measured: the time of one TreeCut operation against the node count,
//! from about 1,000 to 250,000 nodes, with a straight line fitted through each operation's
//! points. The paper's claim is that an operation costs O(fanout), independent of the size of
//! the cloth: the fitted slope should be close to zero.
//!
//! Each size is timed the way Table 1 is ([`super::ops::time_cycles`]: cycles of begin-coarse,
//! end-coarse, begin-refine, end-refine on scattered level-1 nodes of a net at the finest cut,
//! `blend_steps = 0`), on a flat net (no sagging steps: at 250,000 nodes a step costs tens of
//! milliseconds, and the operations do the same work on a flat net as on a sagged one), with
//! fewer cycles than Table 1 so the whole figure adds about a second to the demo.

use std::time::Instant;

use serde::Serialize;
use slod_experiments::net::NetConfig;
use slod_experiments::table::{Table, num};
use treecut::NodeId;

use super::ops::{OPERATIONS, time_cycles, unblended_body};
use super::scaling::fit;
use crate::error::DemoError;
use crate::progress::Progress;
use slod_experiments::median;

/// One operation at one size.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct OpPoint {
    /// `begin-refine`, `end-refine`, `begin-coarse` or `end-coarse`.
    pub(crate) operation: &'static str,
    /// Vertices per side of the net.
    pub(crate) size: u32,
    /// Mean node count while it ran.
    pub(crate) nodes: f64,
    /// Median time of one operation (µs).
    pub(crate) median_us: f64,
}

/// A least-squares line `µs = intercept + slope · nodes` through one operation's points.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct OpFit {
    /// The operation.
    pub(crate) operation: &'static str,
    /// Slope, in µs per 100,000 nodes (0 for an operation independent of the cloth's size).
    pub(crate) us_per_100k_nodes: f64,
    /// Intercept (µs).
    pub(crate) intercept_us: f64,
    /// Coefficient of determination.
    pub(crate) r_squared: f64,
}

/// The measured Figure 4.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct Figure4 {
    /// Net sizes (vertices per side).
    pub(crate) sizes: Vec<u32>,
    /// Cycles (operations of each kind) timed per size.
    pub(crate) cycles: usize,
    /// Every point.
    pub(crate) points: Vec<OpPoint>,
    /// One line per operation.
    pub(crate) fits: Vec<OpFit>,
    /// Wall time of the measurement (s).
    pub(crate) seconds: f64,
}

/// Net sides of the default run: 32² = 1,024 to 500² = 250,000 nodes, about ×4 apart.
pub(crate) const SIZES: [u32; 5] = [32, 64, 128, 256, 500];

/// Times `cycles` cycles of each operation on nets of each size in `sizes`.
pub(crate) fn measure(
    config: &NetConfig,
    sizes: &[u32],
    cycles: usize,
    progress: Progress,
) -> Result<Figure4, DemoError> {
    let start = Instant::now();
    let bar = progress.bar(sizes.len() as u64, "Figure 4");
    let mut points = Vec::new();
    for (k, &size) in sizes.iter().enumerate() {
        bar.set_message(format!("TreeCut operations on {size}x{size}"));
        let (mut body, _) = unblended_body(config, size)?;
        let mut order: Vec<NodeId> = body.hierarchy().nodes_at_level(1).collect();
        slod_experiments::rng::Rng::new(0xF164).shuffle(&mut order);
        let (mut times, counts) = time_cycles(&mut body, &order, cycles, &mut |_| {})?;
        for slot in 0..4 {
            points.push(OpPoint {
                operation: OPERATIONS[slot],
                size,
                nodes: counts[slot].0 / cycles.max(1) as f64,
                median_us: median(&mut times[slot]),
            });
        }
        bar.set_position(k as u64 + 1);
    }
    bar.finish_and_clear();
    let fits = OPERATIONS
        .iter()
        .filter_map(|&op| {
            let xy: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| p.operation == op)
                .map(|p| (p.nodes, p.median_us))
                .collect();
            fit(&xy).map(|(slope, intercept, r2)| OpFit {
                operation: op,
                us_per_100k_nodes: slope * 1e5,
                intercept_us: intercept,
                r_squared: r2,
            })
        })
        .collect();
    Ok(Figure4 {
        sizes: sizes.to_vec(),
        cycles,
        points,
        fits,
        seconds: start.elapsed().as_secs_f64(),
    })
}

impl Figure4 {
    /// The points as a size × operation table, with the fitted slopes.
    pub(crate) fn render(&self) -> String {
        let mut header = vec!["net".to_string(), "nodes".to_string()];
        header.extend(OPERATIONS.iter().map(|o| format!("{o} µs")));
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        let mut t = Table::new(
            format!(
                "Figure 4: one TreeCut operation against node count (median of {} each)",
                self.cycles
            ),
            &header,
        );
        for &size in &self.sizes {
            let at = |op: &str| {
                self.points
                    .iter()
                    .find(|p| p.size == size && p.operation == op)
            };
            let mut row = vec![
                format!("{size}x{size}"),
                at(OPERATIONS[0]).map_or_else(|| "-".into(), |p| num(p.nodes, 0)),
            ];
            row.extend(
                OPERATIONS
                    .iter()
                    .map(|op| at(op).map_or_else(|| "-".into(), |p| num(p.median_us, 2))),
            );
            t.row(row);
        }
        for f in &self.fits {
            t.note(format!(
                "{}: {} µs + {} µs per 100,000 nodes (R² {})",
                f.operation,
                num(f.intercept_us, 2),
                num(f.us_per_100k_nodes, 3),
                num(f.r_squared, 2)
            ));
        }
        t.note("The paper: operations cost O(fanout), flat in the cloth's size.");
        t.render()
    }
}
