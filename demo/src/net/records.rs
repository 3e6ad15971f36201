//! What the net section writes to report.json: the configuration, one record per run, Table 2
//! and the section, built from the experiment's [`NetReport`].

use serde::Serialize;
use slod_experiments::net::{NetConfig, NetReport, NetRun, NetRunKind};

use super::{BulletLike, Figure4, Figure5, NetPlan, Table1};
use crate::peer::PeerBullet;

/// The configuration as recorded in the report.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct ConfigReport {
    /// Vertices per side.
    pub(crate) size: u32,
    /// Steps per run.
    pub(crate) steps: u32,
    /// Side length of the cloth (m).
    pub(crate) width_m: f32,
    /// Total mass (kg).
    pub(crate) mass_kg: f32,
    /// Full-resolution node count.
    pub(crate) full_nodes: usize,
    /// Rest diagonal (m); errors are relative to it.
    pub(crate) diagonal_m: f32,
    /// Height of the viewport on-screen errors are measured on (px).
    pub(crate) measure_height_px: u32,
    /// Vertical field of view of that view (degrees).
    pub(crate) fov_y_deg: f32,
    /// Time step (s).
    pub(crate) dt_s: f32,
    /// Solver substeps per step.
    pub(crate) substeps: u32,
    /// Solver iterations per substep.
    pub(crate) iterations: u32,
    /// Link compliance (m/N).
    pub(crate) stretch_compliance: f32,
    /// Steps over which a refine or coarse blends.
    pub(crate) blend_steps: u32,
    /// Steps between two feedback evaluations.
    pub(crate) feedback_interval: u32,
    /// Compressions run with feedback.
    pub(crate) compressions: Vec<f32>,
    /// Compression of the uniform and random cuts (null: not run).
    pub(crate) baseline_compression: Option<f32>,
    /// Target of the time-budget run (ms per step).
    pub(crate) target_step_ms: f32,
    /// `option` (given with --target-ms) or `half of the measured full-resolution step`.
    pub(crate) target_step_ms_source: &'static str,
    /// Steps after which the cloth is pictured.
    pub(crate) picture_steps: Vec<u32>,
    /// Steps after which the experiment kept a snapshot (the picture steps and a few after
    /// each, from which the links picture takes the one with the most blending links).
    pub(crate) snapshot_steps: Vec<u32>,
}

/// One run of the experiment, as recorded in the report.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct RunReport {
    /// Short label (`reference`, `feedback 30%`, ...).
    pub(crate) label: String,
    /// `reference`, `feedback`, `time_budget`, `uniform` or `random`.
    pub(crate) kind: &'static str,
    /// Fraction of the full node count (null for the reference and the time budget).
    pub(crate) compression: Option<f32>,
    /// Target ms per step of the time-budget run (null otherwise).
    pub(crate) target_ms: Option<f32>,
    /// Node budget (the full count for the reference).
    pub(crate) budget_nodes: usize,
    /// Mean simulated nodes per step (N).
    pub(crate) nodes: f64,
    /// Mean links per step (L).
    pub(crate) links: f64,
    /// Mean transitions being blended per step (I).
    pub(crate) interpolations: f64,
    /// Mean wall time per step (ms), evaluation included.
    pub(crate) ms_per_step: f64,
    /// Mean wall time of one feedback evaluation (ms; 0 without feedback).
    pub(crate) ms_per_evaluation: f64,
    /// Reference ms per step over this run's.
    pub(crate) speedup_vs_reference: f64,
    /// RMS distance of the reconstructed vertices from the reference's, over all steps, as a
    /// fraction of the rest diagonal.
    pub(crate) rms_error_fraction: f32,
    /// Largest such distance, as a fraction of the rest diagonal.
    pub(crate) max_error_fraction: f32,
    /// RMS distance in millimetres.
    pub(crate) rms_error_mm: f32,
    /// Largest distance in millimetres.
    pub(crate) max_error_mm: f32,
    /// On-screen error through the 1080-pixel-high measuring view: mean per-frame RMS (px;
    /// null for the reference).
    pub(crate) screen_rms_px: Option<f64>,
    /// 99th percentile over all vertex-frames (px).
    pub(crate) screen_p99_px: Option<f64>,
    /// Largest over all vertex-frames (px).
    pub(crate) screen_max_px: Option<f64>,
    /// Largest frame-to-frame change of one vertex's on-screen error vector (px).
    pub(crate) pop_max_px: Option<f64>,
    /// Mean wall time per step of reconstructing the finest vertices (ms), which a renderer pays
    /// every frame on top of `ms_per_step` (the full-resolution cloth does not).
    pub(crate) reconstruct_ms: f64,
    /// `ms_per_step + reconstruct_ms` for an adaptive run (ms_per_step for the reference).
    pub(crate) frame_ms: f64,
    /// Reconstruction's share of `frame_ms`.
    pub(crate) reconstruct_share: f64,
    /// Reference ms per step over this run's `frame_ms`: the speed-up a host sees.
    pub(crate) frame_speedup_vs_reference: f64,
    /// Refines and coarses begun.
    pub(crate) operations: u64,
    /// Operations that undid one on the same node soon after.
    pub(crate) undone_operations: u64,
    /// Time-budget run only: the first step from which the mean step time of every feedback
    /// interval stays within ±10% of the target (null if it never does, or for other runs).
    pub(crate) settled_after_steps: Option<u32>,
    /// Time-budget run only: mean ms per step from `settled_after_steps` on (over the second
    /// half of the run if it never settles).
    pub(crate) ms_per_step_settled: Option<f64>,
    /// Time-budget run only: the world budget's settle criterion on the same windows — the
    /// first step of a window within ±10% from which at least 95% of the windows are within
    /// (null if none, or for other runs).
    pub(crate) reached_after_steps: Option<u32>,
    /// Time-budget run only: fraction of those windows within ±10% from `reached_after_steps`
    /// on (over the whole run if never).
    pub(crate) within_10pct_fraction: Option<f64>,
    /// Time-budget run only: of the full-resolution reference's windows (fixed work), the
    /// fraction within ±10% of their median: the machine's own jitter during the run, the most
    /// a wall-clock controller could hold.
    pub(crate) fixed_work_within_10pct_fraction: Option<f64>,
}

/// One line of Table 2: ours, the paper's or Bullet's (measured on this host).
#[derive(Clone, Debug, Serialize)]
pub(crate) struct Table2Row {
    /// The method.
    pub(crate) method: String,
    /// The compression label.
    pub(crate) compression: String,
    /// `ours`, `paper` or `peer` (Bullet measured on this host).
    pub(crate) source: &'static str,
    /// Node count N (null when not known).
    pub(crate) nodes: Option<f64>,
    /// Link count L.
    pub(crate) links: Option<f64>,
    /// Interpolations per step I.
    pub(crate) interpolations: Option<f64>,
    /// Mean time per step (ms).
    pub(crate) ms_per_step: f64,
    /// Over the same source's TC-SB run without compression (the paper's 30% row: 0.476).
    pub(crate) relative_to_no_compression: Option<f64>,
    /// Rows of one group (the plain bodies, or one compression) are printed together.
    #[serde(skip)]
    pub(super) group: u32,
}

/// Table 2 with the Bullet comparisons it rests on.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct Table2 {
    /// The rows, grouped by compression, the paper's first in each group.
    pub(crate) rows: Vec<Table2Row>,
    /// Our Bullet-like plain cloth at Bullet's settings.
    pub(crate) bullet_like: BulletLike,
    /// Bullet measured on this host (or how to measure it).
    pub(crate) peer_bullet: PeerBullet,
    /// The machine of the paper's rows.
    pub(crate) paper_machine: &'static str,
}

/// The net section of the report.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct NetSection {
    /// What ran.
    pub(crate) config: ConfigReport,
    /// Every run of the experiment, the reference first.
    pub(crate) runs: Vec<RunReport>,
    /// Table 1.
    pub(crate) table1: Table1,
    /// Table 2.
    pub(crate) table2: Table2,
    /// Figure 4.
    pub(crate) figure4: Figure4,
    /// Figure 5.
    pub(crate) figure5: Figure5,
    /// Issue 16's solver figures (the benches' targets, measured again in this run).
    pub(crate) solver: super::SolverSpeed,
    /// Wall time of the experiment's runs (s).
    pub(crate) experiment_seconds: f64,
    /// Wall time of the whole section (s).
    pub(crate) seconds: f64,
}

pub(super) fn kind_name(kind: NetRunKind) -> (&'static str, Option<f32>, Option<f32>) {
    match kind {
        NetRunKind::Reference => ("reference", None, None),
        NetRunKind::Feedback { compression } => ("feedback", Some(compression), None),
        NetRunKind::TimeBudget { target_ms } => ("time_budget", None, Some(target_ms)),
        NetRunKind::Uniform { compression } => ("uniform", Some(compression), None),
        NetRunKind::Random { compression } => ("random", Some(compression), None),
    }
}

pub(super) fn config_report(
    plan: &NetPlan,
    c: &NetConfig,
    r: &NetReport,
    target: f32,
    source: &'static str,
) -> ConfigReport {
    ConfigReport {
        size: c.size,
        steps: c.steps,
        width_m: c.width,
        mass_kg: c.mass,
        full_nodes: r.full_nodes,
        diagonal_m: r.diagonal,
        measure_height_px: c.measure_view().map_or(0, |v| v.height_px()),
        fov_y_deg: c.view.fov_y_radians().to_degrees(),
        dt_s: c.body.solver.dt,
        substeps: c.body.solver.substeps,
        iterations: c.body.solver.iterations,
        stretch_compliance: c.body.material.stretch_compliance,
        blend_steps: c.body.blend_steps,
        feedback_interval: c.feedback.interval,
        compressions: c.compressions.clone(),
        baseline_compression: c.baseline_compression,
        target_step_ms: target,
        target_step_ms_source: source,
        picture_steps: plan.picture_steps.clone(),
        snapshot_steps: c.snapshot_steps.clone(),
    }
}

pub(super) fn run_report(r: &NetRun, report: &NetReport, interval: u32) -> RunReport {
    let (kind, compression, target_ms) = kind_name(r.kind);
    let reference_ms = report
        .run(NetRunKind::Reference)
        .map_or(f64::NAN, |x| x.ms_per_step);
    let jitter = report
        .run(NetRunKind::Reference)
        .map(|x| x.windows_within_10pct_of_median(interval as usize));
    let mm = report.diagonal * 1e3;
    let frame_ms = match r.kind {
        NetRunKind::Reference => r.ms_per_step,
        _ => r.ms_per_step + r.reconstruct_ms_per_step,
    };
    let settling = match r.kind {
        NetRunKind::TimeBudget { target_ms } => Some(r.settling(target_ms, interval as usize)),
        _ => None,
    };
    RunReport {
        label: r.label.clone(),
        kind,
        compression,
        target_ms,
        budget_nodes: r.budget_nodes,
        nodes: r.nodes,
        links: r.links,
        interpolations: r.interpolations,
        ms_per_step: r.ms_per_step,
        ms_per_evaluation: r.ms_per_evaluation,
        speedup_vs_reference: reference_ms / r.ms_per_step,
        rms_error_fraction: r.error.rms,
        max_error_fraction: r.error.max,
        rms_error_mm: r.error.rms * mm,
        max_error_mm: r.error.max * mm,
        screen_rms_px: r.screen.map(|s| s.rms_px),
        screen_p99_px: r.screen.map(|s| s.p99_px),
        screen_max_px: r.screen.map(|s| s.max_px),
        pop_max_px: r.screen.map(|s| s.pop_max_px),
        reconstruct_ms: r.reconstruct_ms_per_step,
        frame_ms,
        reconstruct_share: if frame_ms > 0.0 {
            (frame_ms - r.ms_per_step) / frame_ms
        } else {
            0.0
        },
        frame_speedup_vs_reference: reference_ms / frame_ms,
        operations: r.operations,
        undone_operations: r.undone_operations,
        settled_after_steps: settling.and_then(|s| s.settled_at),
        ms_per_step_settled: settling.map(|s| s.mean_ms_after),
        reached_after_steps: settling.and_then(|s| s.reached_at),
        within_10pct_fraction: settling.map(|s| s.within_fraction),
        fixed_work_within_10pct_fraction: settling.and(jitter),
    }
}
