//! Perception that pays, measured on screen: every strategy on every scene family at the same
//! node count, against the full-resolution reference, in pixels on a 1080-px-high view.
//!
//! By subject: [`scenes`] (the scene families and their cameras), [`strategies`] (how each run
//! chooses its cut), [`measures`] (whole-run and short-horizon on-screen error, the twin floor,
//! cost per frame) and [`equal`] (the uniform cost at the feedback loop's error). [`run_scene`]
//! runs one scene; the demo and the tests call it.
//!
//! Based on: the simulation paper (`simulation-lod-treecut-softbody-bswdf.txt`, section 6)
//! for the comparison at equal node count; Koh, Narain, O'Brien, "View-Dependent Adaptive Cloth
//! Simulation" (SCA 2014) for view-dependent scenes and measuring cost at equal visible error.

mod adapter;
pub mod equal;
pub mod measures;
pub mod scenes;
pub mod strategies;
#[cfg(test)]
mod tests;

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;
use slod::cloth::{ClothError, compression_nodes};

pub use equal::{CostPoint, uniform_cost_at};
pub use measures::{
    Reference, Run, RunResult, RunSpec, SOLVER_FLOOR_SUBSTEPS_FACTOR, SplitError,
    TWIN_PERTURBATION_M, perturbed_twin, record_reference, run_strategy, solver_floor, twin_floor,
};
pub use scenes::{FOV_Y_DEG, MEASURE_HEIGHT_PX, MEASURE_WIDTH_PX, Scene, SceneScale};
pub use strategies::Strategy;

use crate::screen::ScreenError;

/// What the perception experiment runs on each scene.
#[derive(Clone, Debug, PartialEq)]
pub struct PerceptionConfig {
    /// Fraction of the full node count every strategy gets (the error-bound run chooses its own).
    pub compression: f32,
    /// The error-bound strategy's bound, px (> 0).
    pub bound_px: f32,
    /// Short-horizon length for chaotic scenes, steps (≥ 1).
    pub horizon_steps: u32,
    /// Fractions of the full node count of the uniform cost–error curve (the run at
    /// `compression` and the reference complete it).
    pub uniform_fractions: Vec<f32>,
    /// Run a scene's independent runs on the rayon pool (timings then share the cores).
    pub parallel: bool,
}

impl Default for PerceptionConfig {
    /// 30% of the nodes (the paper's strongest compression), a 1 px bound, horizons of 30
    /// steps (half a second), uniform cuts at 10, 50 and 75% for the curve (with the run at 30%
    /// and the reference, five points), sequential (parallel runs share the cores their timings
    /// measure).
    fn default() -> Self {
        PerceptionConfig {
            compression: 0.3,
            bound_px: 1.0,
            horizon_steps: 30,
            uniform_fractions: vec![0.1, 0.5, 0.75],
            parallel: false,
        }
    }
}

impl PerceptionConfig {
    /// Checks every field; the error names the bad one.
    pub fn validate(&self) -> Result<(), ClothError> {
        let bad = |field, reason| Err(ClothError::Feedback { field, reason });
        let fraction = |f: f32| f.is_finite() && f > 0.0 && f <= 1.0;
        if !fraction(self.compression) {
            return bad("compression", "must be in (0, 1]");
        }
        if !(self.bound_px.is_finite() && self.bound_px > 0.0) {
            return bad("bound_px", "must be finite and > 0 px");
        }
        if self.horizon_steps == 0 {
            return bad("horizon_steps", "must be >= 1 step");
        }
        if !self.uniform_fractions.iter().all(|&f| fraction(f)) {
            return bad("uniform_fractions", "each must be in (0, 1]");
        }
        Ok(())
    }
}

/// Equal error on one scene: the feedback run's p99 and cost, and a uniform cut's cost at the
/// same p99 (interpolated on the uniform curve).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EqualError {
    /// The feedback run's p99 (short-horizon on chaotic scenes), px.
    pub p99_px: f64,
    /// The feedback run's mean nodes.
    pub feedback_nodes: f64,
    /// The feedback run's cost per frame, ms.
    pub feedback_ms: f64,
    /// The uniform cut's nodes at that p99.
    pub uniform_nodes: f64,
    /// The uniform cut's cost per frame at that p99, ms.
    pub uniform_ms: f64,
}

impl EqualError {
    /// Feedback's cost over the uniform cut's at equal p99 (< 1: feedback pays).
    pub fn cost_ratio(&self) -> f64 {
        self.feedback_ms / self.uniform_ms
    }
}

/// Everything measured on one scene.
#[derive(Clone, Debug)]
pub struct SceneOutcome {
    /// The scene's name.
    pub name: &'static str,
    /// Whether the view decides what matters.
    pub view_dependent: bool,
    /// Whether the scene is chaotic (short-horizon runs added).
    pub chaotic: bool,
    /// Finest vertices (the reference's nodes).
    pub full_nodes: usize,
    /// The node budget every strategy got.
    pub budget_nodes: usize,
    /// Steps per run.
    pub steps: u32,
    /// The twin floor: the reference perturbed by 1 µm against the reference.
    pub twin_floor: ScreenError,
    /// The solver floor: the reference against the same cloth with twice the substeps
    /// ([`solver_floor`]).
    pub solver_floor: ScreenError,
    /// Every run: the reference, each strategy over the whole run, and on chaotic scenes each
    /// strategy over short horizons.
    pub runs: Vec<RunResult>,
    /// The uniform cost–error curve (short-horizon on chaotic scenes), the reference last.
    pub uniform_curve: Vec<CostPoint>,
    /// Equal error (`None` when no uniform point reaches the feedback run's p99).
    pub equal_error: Option<EqualError>,
}

impl SceneOutcome {
    /// The run of `strategy` measured over the whole run (`horizon` `None`) or short horizons.
    pub fn run(&self, strategy: Strategy, horizon: Option<u32>) -> Option<&RunResult> {
        self.runs
            .iter()
            .find(|r| r.strategy == strategy && r.horizon_steps == horizon)
    }

    /// The horizon the scene's headline figures use: short horizons on chaotic scenes.
    pub fn headline_horizon(&self, config: &PerceptionConfig) -> Option<u32> {
        self.chaotic.then_some(config.horizon_steps)
    }
}

/// Progress of [`run_scene`]: a label, units done, units in all.
pub type Progress<'a> = &'a (dyn Fn(&str, usize, usize) + Sync);

/// Whether a run's result belongs to the strategies' table or to the uniform curve.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Role {
    Table,
    Curve,
}

/// Runs every strategy on `scene` as configured: the reference (keeping states for short
/// horizons on chaotic scenes), the twin floor, each strategy at the same node count (and over
/// short horizons on chaotic scenes), the uniform curve, and equal error. Bad settings are
/// refused before anything runs.
///
/// Sequential (the default): every run, and a second full-resolution run that only times the
/// reference, advance together on one thread, [`INTERLEAVE_STEPS`] steps of each in turn (the
/// order rotating), so that all costs are measured in the same window of a shared machine. Parallel:
/// each run alone on its own thread of the rayon pool.
pub fn run_scene(
    scene: &Scene,
    config: &PerceptionConfig,
    progress: Progress<'_>,
) -> Result<SceneOutcome, ClothError> {
    config.validate()?;
    let full = scene.hierarchy.vertex_count();
    let budget = compression_nodes(config.compression, full);
    let horizon = scene.chaotic.then_some(config.horizon_steps);
    let reference = record_reference(scene, horizon)?;
    let total = scene.steps as usize + 2;
    progress(scene.name, 1, total);
    let spec = |strategy, nodes, horizon| RunSpec {
        strategy,
        nodes,
        bound_px: config.bound_px,
        horizon,
    };
    let mut jobs = Vec::new();
    for &s in &Strategy::ALL[1..] {
        jobs.push((Role::Table, spec(s, budget, None)));
        if horizon.is_some() {
            jobs.push((Role::Table, spec(s, budget, horizon)));
        }
    }
    for &f in &config.uniform_fractions {
        let nodes = compression_nodes(f, full);
        if nodes != budget && nodes < full {
            jobs.push((Role::Curve, spec(Strategy::Uniform, nodes, horizon)));
        }
    }
    let floors = |scene: &Scene, reference: &Reference| {
        Ok::<_, ClothError>((
            twin_floor(scene, reference)?,
            solver_floor(scene, reference)?,
        ))
    };
    let (results, reference_run, (twin, solver)) = if config.parallel {
        let done = AtomicUsize::new(1);
        let results = jobs
            .par_iter()
            .map(|&(role, spec)| {
                let r = run_strategy(scene, &reference, spec, None)?;
                let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(
                    scene.name,
                    1 + d * scene.steps as usize / (jobs.len() + 1),
                    total,
                );
                Ok((role, r))
            })
            .collect::<Result<Vec<_>, ClothError>>()?;
        (results, reference.run, floors(scene, &reference)?)
    } else {
        // The floors are not timed: they run on a second thread while the timed runs step on
        // theirs (each timed by its own thread's CPU time; the two share only the last-level
        // cache), which keeps the section about 20% shorter.
        let (timed, floors) = std::thread::scope(|s| {
            let floors = s.spawn(|| floors(scene, &reference));
            let timed = interleaved(scene, &reference, &jobs, progress);
            (timed, floors.join())
        });
        let floors = floors.map_err(|_| ClothError::Feedback {
            field: "floors",
            reason: "the floor thread panicked",
        })??;
        let (results, reference_run) = timed?;
        (results, reference_run, floors)
    };
    progress(scene.name, total, total);
    let mut curve = Vec::new();
    let mut runs = vec![reference_run];
    for (role, r) in results {
        match role {
            Role::Table => runs.push(r),
            Role::Curve => curve.push(r),
        }
    }
    let point = |r: &RunResult| CostPoint {
        nodes: r.nodes,
        ms: r.ms_per_step(),
        p99_px: r.screen.p99_px,
    };
    let mut uniform_curve: Vec<CostPoint> = curve.iter().map(point).collect();
    if let Some(u) = runs
        .iter()
        .find(|r| r.strategy == Strategy::Uniform && r.horizon_steps == horizon)
    {
        uniform_curve.push(point(u));
    }
    uniform_curve.sort_by(|a, b| a.nodes.total_cmp(&b.nodes));
    uniform_curve.push(CostPoint {
        nodes: full as f64,
        ms: reference_run.ms_per_step(),
        p99_px: 0.0,
    });
    let equal_error = runs
        .iter()
        .find(|r| r.strategy == Strategy::Feedback && r.horizon_steps == horizon)
        .and_then(|fb| {
            let u = uniform_cost_at(&uniform_curve, fb.screen.p99_px)?;
            Some(EqualError {
                p99_px: fb.screen.p99_px,
                feedback_nodes: fb.nodes,
                feedback_ms: fb.ms_per_step(),
                uniform_nodes: u.nodes,
                uniform_ms: u.ms,
            })
        });
    Ok(SceneOutcome {
        name: scene.name,
        view_dependent: scene.view_dependent,
        chaotic: scene.chaotic,
        full_nodes: full,
        budget_nodes: budget,
        steps: scene.steps,
        twin_floor: twin,
        solver_floor: solver,
        runs,
        uniform_curve,
        equal_error,
    })
}

/// Steps a run takes in its turn when [`run_scene`] interleaves a scene's runs: 10 steps of
/// one run are 2–50 ms, short against the machine's slow changes (another job starting, clock
/// changes), so every run meets the same conditions; and long enough that a run works on warm
/// caches, as it would stepping alone. Measured on the net (one thread's CPU time, feedback /
/// uniform at 30% / reference): a step of each in turn 0.708 / 0.530 / 1.404 ms (every run's
/// data cold at each step, the feedback loop's many structures most), 10 steps per turn
/// 0.482 / 0.358 / 1.026 ms.
pub const INTERLEAVE_STEPS: usize = 10;

/// The runs of `jobs` and a timing-only reference run, advanced [`INTERLEAVE_STEPS`] steps of
/// each in turn on one thread of their own (the order rotating with the turn): the results in
/// `jobs`' order and the reference's result with its cost from this window.
fn interleaved(
    scene: &Scene,
    reference: &Reference,
    jobs: &[(Role, RunSpec)],
    progress: Progress<'_>,
) -> Result<(Vec<(Role, RunResult)>, RunResult), ClothError> {
    measures::on_one_thread(|| {
        let timing = RunSpec {
            strategy: Strategy::Reference,
            nodes: scene.hierarchy.vertex_count(),
            bound_px: 1.0,
            horizon: None,
        };
        let mut runs = jobs
            .iter()
            .map(|&(_, spec)| Run::start(scene, reference, spec))
            .chain([Run::start(scene, reference, timing)])
            .collect::<Result<Vec<_>, _>>()?;
        let n = runs.len();
        let steps = scene.steps as usize;
        for (turn, first) in (0..steps).step_by(INTERLEAVE_STEPS).enumerate() {
            for k in 0..n {
                let run = &mut runs[(k + turn) % n];
                for _ in first..(first + INTERLEAVE_STEPS).min(steps) {
                    run.advance(None)?;
                }
            }
            progress(scene.name, 2 + first, steps + 2);
        }
        let timed = runs.pop().map(Run::finish);
        let reference_run = RunResult {
            step_ms: timed.map_or(reference.run.step_ms, |t| t.step_ms),
            ..reference.run
        };
        let results = jobs
            .iter()
            .zip(runs)
            .map(|(&(role, _), run)| (role, run.finish()))
            .collect();
        Ok((results, reference_run))
    })
}
