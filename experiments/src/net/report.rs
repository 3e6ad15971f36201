//! What the swinging-net experiment measured: one [`NetRun`] per run, with snapshots and the
//! settling of a time budget, gathered in a [`NetReport`].

use glam::Vec3;
use softbody::{DrawLink, ReconstructionError};

use super::NetRunKind;
use crate::screen::ScreenError;

/// The state of a run after some step, for pictures.
#[derive(Clone, Debug, PartialEq)]
pub struct NetSnapshot {
    /// Steps taken.
    pub step: u32,
    /// Reconstructed finest vertices.
    pub vertices: Vec<Vec3>,
    /// Simulated node positions.
    pub particles: Vec<Vec3>,
    /// Links with blend weights.
    pub links: Vec<DrawLink>,
}

/// What one run measured (means over all steps).
#[derive(Clone, Debug, PartialEq)]
pub struct NetRun {
    /// Which run.
    pub kind: NetRunKind,
    /// A short label ("reference", "feedback 30%", ...).
    pub label: String,
    /// Node budget (the full count for the reference).
    pub budget_nodes: usize,
    /// Mean simulated nodes per step (the paper's N).
    pub nodes: f64,
    /// Mean links per step (L).
    pub links: f64,
    /// Mean refine/coarse transitions being blended per step (I).
    pub interpolations: f64,
    /// Mean wall time per step in milliseconds, evaluation included.
    pub ms_per_step: f64,
    /// Mean wall time of one feedback evaluation in milliseconds (0 without feedback).
    pub ms_per_evaluation: f64,
    /// Surface error against the reference over all steps: RMS and maximum vertex distance
    /// relative to the rest diagonal.
    pub error: ReconstructionError,
    /// The step (1-based) at which the maximum error occurred.
    pub max_error_step: u32,
    /// The on-screen error through [`super::NetConfig::measure_view`] (`None` for the reference
    /// itself).
    pub screen: Option<ScreenError>,
    /// Mean wall time per step of reconstructing the finest vertices (what a renderer pays every
    /// frame; not part of `ms_per_step`).
    pub reconstruct_ms_per_step: f64,
    /// Refines and coarses begun.
    pub operations: u64,
    /// Operations that undid one on the same node within 30 steps.
    pub undone_operations: u64,
    /// Snapshots at the configured steps.
    pub snapshots: Vec<NetSnapshot>,
    /// Wall time of every step in milliseconds, evaluation included.
    pub step_ms: Vec<f32>,
}

/// How a run held a target time per step (see [`NetRun::settling`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settling {
    /// The first step from which the mean time per evaluation interval stays within ±10% of
    /// the target to the end of the run (None: it never settles).
    pub settled_at: Option<u32>,
    /// Mean ms per step from `settled_at` on (or over the second half without settling).
    pub mean_ms_after: f64,
    /// The world budget's criterion ([`crate::world::settle`]) on the same windows: the first
    /// step of a window within ±10% from which at least 95% of windows are within (None: never).
    pub reached_at: Option<u32>,
    /// Fraction of windows within ±10% from `reached_at` on (over the whole run if never).
    pub within_fraction: f64,
}

impl NetRun {
    /// Of this run's windows of `window` steps, the fraction whose mean step time is within
    /// ±10% of the windows' median. On a run of fixed work (the full-resolution reference) it
    /// is the machine's own jitter: the most any controller of the wall clock could hold.
    pub fn windows_within_10pct_of_median(&self, window: usize) -> f64 {
        crate::world::within_10pct_of_median(&self.window_means(window))
    }

    /// Mean step time (ms) of each window of `window` steps (the last may be shorter).
    fn window_means(&self, window: usize) -> Vec<f64> {
        self.step_ms
            .chunks(window.max(1))
            .map(|c| c.iter().map(|&x| x as f64).sum::<f64>() / c.len() as f64)
            .collect()
    }

    /// How the run's step times held `target_ms`, in windows of `window` steps (the feedback
    /// interval: per-step times swing with the evaluation inside each interval).
    pub fn settling(&self, target_ms: f32, window: usize) -> Settling {
        let window = window.max(1);
        let means = self.window_means(window);
        let ok = |m: f64| (m - target_ms as f64).abs() <= 0.1 * target_ms as f64;
        let first_ok_window = means
            .iter()
            .rposition(|&m| !ok(m))
            .map_or(0, |last_bad| last_bad + 1);
        let settled_at =
            (first_ok_window < means.len()).then_some((first_ok_window * window) as u32);
        let from = settled_at.map_or(self.step_ms.len() / 2, |s| s as usize);
        let tail = &self.step_ms[from.min(self.step_ms.len())..];
        let mean_ms_after = if tail.is_empty() {
            0.0
        } else {
            tail.iter().map(|&x| x as f64).sum::<f64>() / tail.len() as f64
        };
        let world = crate::world::settle(&means, target_ms as f64);
        Settling {
            settled_at,
            mean_ms_after,
            reached_at: world.settled_after.map(|w| (w * window) as u32),
            within_fraction: world.within_fraction,
        }
    }
}

/// All runs of one configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct NetReport {
    /// Full-resolution node count.
    pub full_nodes: usize,
    /// Rest diagonal in metres (errors are relative to it).
    pub diagonal: f32,
    /// Steps per run.
    pub steps: u32,
    /// The runs, the reference first.
    pub runs: Vec<NetRun>,
}

impl NetReport {
    /// The first run of this kind.
    pub fn run(&self, kind: NetRunKind) -> Option<&NetRun> {
        self.runs.iter().find(|r| r.kind == kind)
    }
}
