//! The world section (issue 15): sixteen cloths and a 1,000-character crowd along a street,
//! a camera flying through, one budget of 4 ms per frame ([`slod_experiments::world`]), as a
//! table, report.json's `world` object and two plots.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use slod_experiments::net::NetConfig;
use slod_experiments::overlap;
use slod_experiments::table::Table;
use slod_experiments::world::{self, WorldConfig, WorldReport};

use crate::error::DemoError;
use crate::progress::Progress;

/// Frames of the default run: the section's share of the demo's time on a 2-core machine.
pub(crate) const DEFAULT_FRAMES: u32 = 300;

/// What the section runs.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct WorldPlan {
    pub(crate) config: WorldConfig,
    /// The overlap measurement's warm-up steps and feedback intervals measured.
    pub(crate) overlap: (u32, u32),
}

impl WorldPlan {
    /// The standard scene (the quick one with `quick`), `frames` and `target_ms` if given.
    pub(crate) fn new(frames: Option<u32>, target_ms: Option<f32>, quick: bool) -> WorldPlan {
        let assets = crate::engine::assets_dir();
        let mut config = if quick {
            WorldConfig::quick(&assets)
        } else {
            WorldConfig {
                frames: DEFAULT_FRAMES,
                cost_frames: 200,
                twin: true,
                ..WorldConfig::standard(&assets)
            }
        };
        if let Some(f) = frames {
            config.frames = f;
        }
        if let Some(ms) = target_ms {
            config.target_ms = ms;
        }
        let overlap = if quick { (20, 6) } else { (240, 120) };
        WorldPlan { config, overlap }
    }
}

/// One object as reported.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct WorldObjectReport {
    /// `flag`, `curtain`, `cape` or `crowd`.
    pub(crate) kind: &'static str,
    /// e.g. `flag 49x49 @5m R`.
    pub(crate) name: String,
    /// Finest vertices of a cloth; characters × bones of the crowd.
    pub(crate) full_detail: u64,
    /// Distance along the street from the camera's start, m.
    pub(crate) along_m: f32,
    /// Its part of the units the millisecond run spent.
    pub(crate) units_fraction: f64,
    /// Mean detail (nodes or bones interpolated) over full detail.
    pub(crate) mean_detail_fraction: f64,
    /// The same over the frames its centre was in view (null if never).
    pub(crate) in_view_detail_fraction: Option<f64>,
}

/// The paper's net stepped alone, its evaluations before the solver or overlapped with it
/// ([`slod_experiments::overlap`]).
#[derive(Clone, Debug, Serialize)]
pub(crate) struct OverlapReport {
    /// `30%`, `100%` or `1 px`.
    pub(crate) budget: String,
    /// Mean simulated nodes.
    pub(crate) nodes: f64,
    /// Threads of the pool the overlapped measurement ran on.
    pub(crate) threads: usize,
    /// Median step without evaluation, ms.
    pub(crate) plain_step_ms: f64,
    /// Median evaluating step, evaluation before the solver, ms.
    pub(crate) evaluating_step_ms_sequential: f64,
    /// Median evaluating step, evaluation overlapped with the solver, ms.
    pub(crate) evaluating_step_ms_overlapped: f64,
    /// `evaluating_step_ms_sequential / plain_step_ms`: the spike.
    pub(crate) spike_sequential: f64,
    /// `evaluating_step_ms_overlapped / plain_step_ms`.
    pub(crate) spike_overlapped: f64,
}

/// The deterministic cost-unit run as reported.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct CostUnitsReport {
    /// The target, cost units per frame.
    pub(crate) target_units: f64,
    /// The target as a fraction of the full-detail frame's units.
    pub(crate) target_fraction_of_full: f64,
    /// Frames.
    pub(crate) frames: usize,
    /// See the millisecond run.
    pub(crate) reached_target_after_frames: Option<usize>,
    /// See the millisecond run.
    pub(crate) settled_after_frames: Option<usize>,
    /// See the millisecond run.
    pub(crate) within_10pct_fraction: f64,
    /// Median units per frame.
    pub(crate) p50_units: f64,
    /// 99th percentile of units per frame.
    pub(crate) p99_units: f64,
    /// See the millisecond run.
    pub(crate) undone_fraction: f64,
}

/// report.json's `world` object.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct WorldSection {
    /// The budget per frame, ms (wall clock).
    pub(crate) target_ms: f32,
    /// Frames of the budgeted run.
    pub(crate) frames: u32,
    /// First frame from which the median of the next 10 frames is within ±10% of the target:
    /// when the cold start reached it; null if never.
    pub(crate) reached_target_after_frames: Option<usize>,
    /// First frame within ±10% of the target from which ≥ 95% of frames are, with at least 60
    /// frames (or half the run) to come; null if none.
    pub(crate) settled_after_frames: Option<usize>,
    /// Frames within ±10% from the settle frame on; never settled, from the frame the target
    /// was reached on (the cold start before it excluded); over the run if never reached.
    pub(crate) within_10pct_fraction: f64,
    /// Median frame time, ms.
    pub(crate) p50_ms: f64,
    /// 99th percentile of the frame time, ms.
    pub(crate) p99_ms: f64,
    /// Operations undone within 30 steps over operations begun, all cloths.
    pub(crate) undone_fraction: f64,
    /// Threads of the budgeted world.
    pub(crate) threads: usize,
    /// How long its idle workers spin between phases and frames, ms
    /// (`WorldBudget::spin_wait_ms`).
    pub(crate) spin_wait_ms: f32,
    /// Full-detail frame on one thread over the frame on `parallel_threads` (null if unmeasured).
    pub(crate) parallel_speedup: Option<f64>,
    /// The same ratio of the median frames (null if unmeasured): robust to bursts in which the
    /// host wakes the second thread late.
    pub(crate) parallel_speedup_median: Option<f64>,
    /// Of the full-detail frames on `parallel_threads` (fixed work), the fraction within ±10%
    /// of their median: the machine's own jitter, the most a wall-clock controller can hold.
    pub(crate) fixed_work_within_10pct_fraction: f64,
    /// Threads of the speedup's parallel blocks.
    pub(crate) parallel_threads: usize,
    /// Mean full-detail frame on one thread, ms.
    pub(crate) full_detail_ms_serial: f64,
    /// Mean full-detail frame on `parallel_threads`, ms.
    pub(crate) full_detail_ms_parallel: f64,
    /// Cloths on screen against the full-detail reference: mean per-frame RMS, px.
    pub(crate) screen_rms_px: Option<f64>,
    /// 99th percentile over vertex-frames, px.
    pub(crate) screen_p99_px: Option<f64>,
    /// Largest, px.
    pub(crate) screen_max_px: Option<f64>,
    /// The reference against its twin with one node per cloth moved by 1 µm (the chaos
    /// floor): mean per-frame RMS, px (null when not run).
    pub(crate) twin_screen_rms_px: Option<f64>,
    /// The twin's largest, px (null when not run).
    pub(crate) twin_screen_max_px: Option<f64>,
    /// The crowd's mean on-screen pose error against exact poses, px.
    pub(crate) crowd_mean_error_px: f64,
    /// The crowd's largest, px.
    pub(crate) crowd_max_error_px: f64,
    /// Objects in the world.
    pub(crate) objects: usize,
    /// Characters of the crowd.
    pub(crate) characters: usize,
    /// Mean detail fraction of in-view cloths nearer than 15 m / farther than 30 m.
    pub(crate) near_detail_fraction: Option<f64>,
    /// See `near_detail_fraction`.
    pub(crate) far_detail_fraction: Option<f64>,
    /// Cost units of cloths whose centre was out of view over all cloths' units.
    pub(crate) out_of_view_units_fraction: f64,
    /// The shared error bound at the end of the run, px.
    pub(crate) final_bound_px: f32,
    /// Each object.
    pub(crate) per_object: Vec<WorldObjectReport>,
    /// The deterministic variant.
    pub(crate) cost_units: CostUnitsReport,
    /// The TreeCut evaluation off its step's critical path, on a cloth stepped alone.
    pub(crate) evaluation_overlap: Vec<OverlapReport>,
    /// Wall time of the section, s.
    pub(crate) seconds: f64,
}

/// The section, its table and the run for the plots.
#[derive(Debug)]
pub(crate) struct WorldOutcome {
    pub(crate) section: WorldSection,
    pub(crate) report: WorldReport,
    pub(crate) text: String,
}

/// Runs the section.
pub(crate) fn run(plan: &WorldPlan, progress: Progress) -> Result<WorldOutcome, DemoError> {
    let start = Instant::now();
    let c = &plan.config;
    let bar = progress.bar((c.frames + c.cost_frames) as u64, "world");
    let report = world::run_world(c, &mut |name, done, _| {
        // The budgeted run and its reference first, then the cost-unit variant.
        let before = if name == "cost units" { c.frames } else { 0 };
        bar.set_position((before + done) as u64);
        bar.set_message(name.to_string());
    })
    .map_err(|e| DemoError::Internal(format!("world: {e}")))?;
    bar.finish_and_clear();
    let (warm, intervals) = plan.overlap;
    let net = NetConfig::paper().map_err(|e| DemoError::Internal(format!("overlap: {e}")))?;
    let evaluation_overlap: Vec<OverlapReport> = overlap::measure(&net, warm, intervals)
        .map_err(|e| DemoError::Internal(format!("overlap: {e}")))?
        .into_iter()
        .map(|r| OverlapReport {
            spike_sequential: r.evaluating_step_ms_sequential / r.plain_step_ms.max(1e-9),
            spike_overlapped: r.evaluating_step_ms_overlapped / r.plain_step_ms.max(1e-9),
            budget: r.budget,
            nodes: r.nodes,
            threads: r.threads,
            plain_step_ms: r.plain_step_ms,
            evaluating_step_ms_sequential: r.evaluating_step_ms_sequential,
            evaluating_step_ms_overlapped: r.evaluating_step_ms_overlapped,
        })
        .collect();
    let text = format!(
        "{}\n{}",
        world::format_table(&report),
        overlap_table(&evaluation_overlap)
    );
    let b = &report.budgeted;
    let cu = &report.cost_units;
    let per_object = report
        .objects
        .iter()
        .zip(&b.objects)
        .map(|(o, s)| WorldObjectReport {
            kind: o.kind,
            name: o.name.clone(),
            full_detail: o.full_detail,
            along_m: o.along_m,
            units_fraction: s.units_share,
            mean_detail_fraction: s.mean_detail_fraction,
            in_view_detail_fraction: s.in_view_detail_fraction,
        })
        .collect();
    let section = WorldSection {
        target_ms: c.target_ms,
        frames: c.frames,
        reached_target_after_frames: b.settle.reached_after,
        settled_after_frames: b.settle.settled_after,
        within_10pct_fraction: b.settle.within_fraction,
        p50_ms: b.p50_ms,
        p99_ms: b.p99_ms,
        undone_fraction: b.undone_fraction,
        threads: b.threads,
        spin_wait_ms: c.spin_wait_ms,
        parallel_speedup: report.parallel_speedup,
        parallel_speedup_median: report.parallel_speedup_median,
        fixed_work_within_10pct_fraction: report.fixed_work_within_10pct_fraction,
        parallel_threads: report.parallel_threads,
        full_detail_ms_serial: report.reference_ms_serial,
        full_detail_ms_parallel: report.reference_ms_parallel,
        screen_rms_px: Some(report.screen.rms_px),
        screen_p99_px: Some(report.screen.p99_px),
        screen_max_px: Some(report.screen.max_px),
        twin_screen_rms_px: report.twin_screen.map(|e| e.rms_px),
        twin_screen_max_px: report.twin_screen.map(|e| e.max_px),
        crowd_mean_error_px: report.crowd_mean_error_px,
        crowd_max_error_px: report.crowd_max_error_px,
        objects: report.objects.len(),
        characters: c.characters,
        near_detail_fraction: b.near_detail_fraction,
        far_detail_fraction: b.far_detail_fraction,
        out_of_view_units_fraction: b.out_of_view_units_fraction,
        final_bound_px: b.frames.last().map_or(0.0, |f| f.bound_px),
        per_object,
        cost_units: CostUnitsReport {
            target_units: cu.target,
            target_fraction_of_full: cu.target / report.full_detail_units.max(1.0),
            frames: cu.frames.len(),
            reached_target_after_frames: cu.settle.reached_after,
            settled_after_frames: cu.settle.settled_after,
            within_10pct_fraction: cu.settle.within_fraction,
            p50_units: cu.p50_measured,
            p99_units: cu.p99_measured,
            undone_fraction: cu.undone_fraction,
        },
        evaluation_overlap,
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok(WorldOutcome {
        section,
        report,
        text,
    })
}

/// The overlap measurement as a table.
fn overlap_table(rows: &[OverlapReport]) -> String {
    let threads = rows.first().map_or(0, |r| r.threads);
    let mut t = Table::new(
        format!(
            "The net stepped alone: its evaluating step (every 5th) with the evaluation before \
             the solver or overlapped with it (medians, {threads} threads)"
        ),
        &[
            "budget",
            "nodes",
            "plain step ms",
            "evaluating ms, before",
            "overlapped",
            "spike before",
            "overlapped",
        ],
    );
    for r in rows {
        t.row([
            r.budget.clone(),
            format!("{:.0}", r.nodes),
            format!("{:.3}", r.plain_step_ms),
            format!("{:.3}", r.evaluating_step_ms_sequential),
            format!("{:.3}", r.evaluating_step_ms_overlapped),
            format!("{:.2}x", r.spike_sequential),
            format!("{:.2}x", r.spike_overlapped),
        ]);
    }
    t.render()
}

/// The section's plots: frame time and bound, and the budget spent per object.
pub(crate) fn plots(outcome: &WorldOutcome, dir: &Path) -> Result<Vec<PathBuf>, DemoError> {
    Ok(vec![
        crate::plots::world_frame_time(&outcome.report, dir)?,
        crate::plots::world_budget_per_object(&outcome.report, dir)?,
    ])
}
