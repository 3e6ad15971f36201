//! The `perception` object of report.json, with the names the issue fixes (see the README's
//! report section).

use serde::Serialize;
use slod_experiments::perception::{
    FOV_Y_DEG, MEASURE_HEIGHT_PX, PerceptionConfig, RunResult, SceneOutcome,
};

/// The whole section.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct PerceptionSection {
    /// Height of the view errors are measured through, px.
    pub(crate) viewport_height_px: u32,
    /// Its vertical field of view, degrees.
    pub(crate) fov_y_deg: f32,
    /// Node budget as a fraction of each scene's full count.
    pub(crate) compression: f32,
    /// Short-horizon length on chaotic scenes, steps.
    pub(crate) horizon_steps: u32,
    /// Per scene.
    pub(crate) scenes: Vec<SceneRecord>,
    /// Per scene with a uniform cut as good as feedback: feedback's cost against it.
    pub(crate) equal_error: Vec<EqualErrorRecord>,
    /// Wall time of the section's measurements, s.
    pub(crate) seconds: f64,
}

/// One scene.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct SceneRecord {
    pub(crate) name: &'static str,
    pub(crate) view_dependent: bool,
    pub(crate) chaotic: bool,
    pub(crate) full_nodes: usize,
    pub(crate) budget_nodes: usize,
    pub(crate) steps: u32,
    pub(crate) twin_floor_px: Floor,
    pub(crate) solver_floor_px: Floor,
    pub(crate) runs: Vec<RunRecord>,
    pub(crate) uniform_curve: Vec<CurvePoint>,
}

/// A floor (the twin floor, the solver floor): on-screen RMS, 99th percentile and maximum,
/// px (the percentile to set beside an error-bound run's).
#[derive(Clone, Copy, Debug, Serialize)]
pub(crate) struct Floor {
    pub(crate) rms: f64,
    pub(crate) p99: f64,
    pub(crate) max: f64,
}

/// One run.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct RunRecord {
    pub(crate) strategy: &'static str,
    pub(crate) nodes: f64,
    pub(crate) ms_per_step: f64,
    pub(crate) reconstruct_ms: Option<f64>,
    pub(crate) reconstruct_share: Option<f64>,
    pub(crate) screen_rms_px: f64,
    pub(crate) screen_p99_px: f64,
    pub(crate) screen_max_px: f64,
    pub(crate) pop_max_px: Option<f64>,
    /// The largest pop at a vertex whose simulating node changed that frame (a refine begun,
    /// a coarse ended), and the largest elsewhere (the error drifting between frames); null
    /// for the reference.
    pub(crate) pop_operation_max_px: Option<f64>,
    pub(crate) pop_drift_max_px: Option<f64>,
    /// p99 and max at the vertices coarse nodes cover (null for the reference): the error the
    /// on-screen deviation estimate is about.
    pub(crate) coarse_p99_px: Option<f64>,
    pub(crate) coarse_max_px: Option<f64>,
    /// p99 and max at the vertices simulated at the finest level (null for the reference):
    /// the drift the coarse parts carry across the cloth.
    pub(crate) fine_p99_px: Option<f64>,
    pub(crate) fine_max_px: Option<f64>,
    pub(crate) operations: u64,
    pub(crate) undone_fraction: Option<f64>,
    pub(crate) bound_px: Option<f32>,
    pub(crate) horizon_steps: Option<u32>,
}

/// One point of the uniform cost–error curve.
#[derive(Clone, Copy, Debug, Serialize)]
pub(crate) struct CurvePoint {
    pub(crate) nodes: f64,
    pub(crate) ms_per_step: f64,
    pub(crate) screen_p99_px: f64,
}

/// Equal error on one scene.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct EqualErrorRecord {
    pub(crate) name: &'static str,
    pub(crate) p99_px: f64,
    pub(crate) feedback_nodes: f64,
    pub(crate) feedback_ms: f64,
    pub(crate) uniform_nodes: f64,
    pub(crate) uniform_ms: f64,
    pub(crate) cost_ratio: f64,
}

fn run(r: &RunResult) -> RunRecord {
    let is_reference = r.reconstruct_ms.is_none();
    RunRecord {
        strategy: r.strategy.name(),
        nodes: r.nodes,
        ms_per_step: r.ms_per_step(),
        reconstruct_ms: r.reconstruct_ms,
        reconstruct_share: r.reconstruct_ms.map(|_| r.reconstruct_share()),
        screen_rms_px: r.screen.rms_px,
        screen_p99_px: r.screen.p99_px,
        screen_max_px: r.screen.max_px,
        pop_max_px: (!is_reference).then_some(r.screen.pop_max_px),
        pop_operation_max_px: (!is_reference).then_some(r.screen.pop_operation_max_px),
        pop_drift_max_px: (!is_reference).then_some(r.screen.pop_drift_max_px),
        coarse_p99_px: r.screen_split.map(|s| s.coarse.p99_px),
        coarse_max_px: r.screen_split.map(|s| s.coarse.max_px),
        fine_p99_px: r.screen_split.map(|s| s.fine.p99_px),
        fine_max_px: r.screen_split.map(|s| s.fine.max_px),
        operations: r.operations,
        undone_fraction: r.undone_fraction(),
        bound_px: r.bound_px,
        horizon_steps: r.horizon_steps,
    }
}

/// The section from the scenes' outcomes.
pub(crate) fn section(
    outcomes: &[SceneOutcome],
    config: &PerceptionConfig,
    seconds: f64,
) -> PerceptionSection {
    PerceptionSection {
        viewport_height_px: MEASURE_HEIGHT_PX,
        fov_y_deg: FOV_Y_DEG,
        compression: config.compression,
        horizon_steps: config.horizon_steps,
        scenes: outcomes
            .iter()
            .map(|o| SceneRecord {
                name: o.name,
                view_dependent: o.view_dependent,
                chaotic: o.chaotic,
                full_nodes: o.full_nodes,
                budget_nodes: o.budget_nodes,
                steps: o.steps,
                twin_floor_px: Floor {
                    rms: o.twin_floor.rms_px,
                    p99: o.twin_floor.p99_px,
                    max: o.twin_floor.max_px,
                },
                solver_floor_px: Floor {
                    rms: o.solver_floor.rms_px,
                    p99: o.solver_floor.p99_px,
                    max: o.solver_floor.max_px,
                },
                runs: o.runs.iter().map(run).collect(),
                uniform_curve: o
                    .uniform_curve
                    .iter()
                    .map(|p| CurvePoint {
                        nodes: p.nodes,
                        ms_per_step: p.ms,
                        screen_p99_px: p.p99_px,
                    })
                    .collect(),
            })
            .collect(),
        equal_error: outcomes
            .iter()
            .filter_map(|o| {
                let e = o.equal_error?;
                Some(EqualErrorRecord {
                    name: o.name,
                    p99_px: e.p99_px,
                    feedback_nodes: e.feedback_nodes,
                    feedback_ms: e.feedback_ms,
                    uniform_nodes: e.uniform_nodes,
                    uniform_ms: e.uniform_ms,
                    cost_ratio: e.cost_ratio(),
                })
            })
            .collect(),
        seconds,
    }
}
