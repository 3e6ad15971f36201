//! What a viewer sees of a run, measured against the full-resolution reference: on-screen
//! error per frame (RMS, p99, max in px, pops; [`crate::screen`]), over the whole run or over
//! short horizons, the twin floor, and the cost a renderer pays per frame.
//!
//! - Whole run: the run under test and the reference step side by side from rest; every frame
//!   the reconstructed finest vertices are compared with the reference's through that frame's
//!   view.
//! - Short horizon (chaotic scenes): a chaotic cloth drifts from its own reference, so after a
//!   while any two runs differ by the chaos, not by their level of detail. Every `H` steps the
//!   run under test restarts from the reference state mapped onto its current cut (transitions
//!   in flight are ended first; each particle gets the mass-weighted mean position and velocity
//!   of the finest vertices its node covers) and the next `H` steps are measured. Restarts are
//!   not counted as pops.
//! - Twin floor: the reference itself perturbed by 1 µm (every free particle, in a seeded
//!   random direction), measured against the reference: the error no reduced cut can beat.
//! - Cost: step (evaluation included) + reconstruction per frame, with the reconstruction's
//!   share, since a renderer pays it every frame and the full-resolution cloth does not.
//!
//! Based on: the on-screen error of `screen.rs`, and the definitions (short-horizon
//! error as in shadowing studies of chaotic simulations: compare over horizons shorter than the
//! divergence time).

use std::time::Instant;

use glam::{Vec3, Vec4};
use slod::cloth::{AdaptiveCloth, ClothError};
use softbody::ParticleId;

use super::scenes::Scene;
use super::strategies::Strategy;
use crate::rng::Rng;
use crate::screen::{ScreenError, ScreenMeter};

/// Size of the perturbation of the twin run, metres.
pub const TWIN_PERTURBATION_M: f32 = 1e-6;

/// The reference run of a scene: every frame's finest vertices, the full state at each restart
/// step of a short-horizon measurement, and its cost.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Vertices per frame.
    pub vertex_count: usize,
    /// Finest vertices, frame-major (`steps × vertex_count`).
    pub frames: Vec<Vec3>,
    /// The horizon the states were kept for (`None`: none kept).
    pub horizon: Option<u32>,
    /// Positions and velocities of every finest vertex after `k · horizon` steps, k = 1, 2, ...
    pub states: Vec<State>,
    /// The reference's run figures (nodes, step time; no error, no reconstruction).
    pub run: RunResult,
}

/// The full-resolution state after some steps, per finest vertex.
#[derive(Clone, Debug)]
pub struct State {
    /// Steps taken.
    pub step: u32,
    /// Position of each finest vertex.
    pub positions: Vec<Vec3>,
    /// Velocity of each finest vertex.
    pub velocities: Vec<Vec3>,
}

impl Reference {
    /// The finest vertices of frame `step` (0-based).
    pub fn frame(&self, step: u32) -> &[Vec3] {
        let n = self.vertex_count;
        &self.frames[step as usize * n..(step as usize + 1) * n]
    }

    /// The state kept after `step` steps, if any.
    pub fn state(&self, step: u32) -> Option<&State> {
        self.states.iter().find(|s| s.step == step)
    }
}

/// One run's figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunResult {
    /// How the cut was chosen.
    pub strategy: Strategy,
    /// Mean simulated nodes per step.
    pub nodes: f64,
    /// Mean wall time of a step, evaluation included, ms.
    pub step_ms: f64,
    /// Mean wall time of a reconstruction, ms (`None` for the reference, which has none).
    pub reconstruct_ms: Option<f64>,
    /// On-screen error against the reference (zero for the reference).
    pub screen: ScreenError,
    /// [`RunResult::screen`] split (`None` for the reference): at the vertices a coarse node
    /// covers — where the reconstruction interpolates, the error a node's on-screen deviation
    /// estimate is about — and at the vertices simulated at the finest level, whose error is
    /// the drift the coarse parts' different dynamics carry across the cloth. (Frame RMS is over
    /// each part's vertices, so the parts' RMS do not combine into the whole's.)
    pub screen_split: Option<SplitError>,
    /// Refines and coarses begun.
    pub operations: u64,
    /// Operations that undid one on the same node within 30 steps.
    pub undone_operations: u64,
    /// The error bound of an error-bound run, px.
    pub bound_px: Option<f32>,
    /// The horizon of a short-horizon measurement (`None`: the whole run).
    pub horizon_steps: Option<u32>,
}

/// On-screen error at coarse-covered and at finest-simulated vertices (see
/// [`RunResult::screen_split`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplitError {
    /// At vertices a coarse node covers.
    pub coarse: ScreenError,
    /// At vertices simulated at the finest level.
    pub fine: ScreenError,
}

impl RunResult {
    /// Cost per frame: step + evaluation + reconstruction, ms.
    pub fn ms_per_step(&self) -> f64 {
        self.step_ms + self.reconstruct_ms.unwrap_or(0.0)
    }

    /// Reconstruction's share of [`RunResult::ms_per_step`] (0 without reconstruction).
    pub fn reconstruct_share(&self) -> f64 {
        let total = self.ms_per_step();
        if total > 0.0 {
            self.reconstruct_ms.unwrap_or(0.0) / total
        } else {
            0.0
        }
    }

    /// Undone operations over operations (`None` when none ran: static cuts).
    pub fn undone_fraction(&self) -> Option<f64> {
        (self.operations > 0).then(|| self.undone_operations as f64 / self.operations as f64)
    }
}

/// What to run: a strategy at a node count, measured over the whole run or short horizons.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunSpec {
    /// How the cut is chosen.
    pub strategy: Strategy,
    /// Node budget (the static cuts' size; the feedback loop's budget).
    pub nodes: usize,
    /// The bound of [`Strategy::ErrorBound`], px (> 0, finite).
    pub bound_px: f32,
    /// Restart from the reference every this many steps (`Some(0)` is refused).
    pub horizon: Option<u32>,
}

/// Sees each frame of a run: step (0-based), the cloth after it and its reconstructed vertices.
pub type Observer<'a> = &'a mut dyn FnMut(u32, &AdaptiveCloth, &[Vec3]);

fn bad(field: &'static str, reason: &'static str) -> ClothError {
    ClothError::Feedback { field, reason }
}

fn check_horizon(horizon: Option<u32>) -> Result<(), ClothError> {
    if horizon == Some(0) {
        return Err(bad("horizon_steps", "must be >= 1 step"));
    }
    Ok(())
}

/// Runs the scene at full resolution, keeping every frame, and the full state every `horizon`
/// steps when given (for short-horizon measurements). `Some(0)` is refused.
pub fn record_reference(scene: &Scene, horizon: Option<u32>) -> Result<Reference, ClothError> {
    check_horizon(horizon)?;
    let mut cloth = scene.cloth(Strategy::Reference.initial_cut(scene, usize::MAX)?)?;
    let n = scene.hierarchy.vertex_count();
    let mut frames = vec![Vec3::ZERO; n * scene.steps as usize];
    let mut states = Vec::new();
    let mut seconds = 0f64;
    for step in 0..scene.steps {
        scene.drive(&mut cloth, step)?;
        let view = scene.view(step)?;
        let t = Instant::now();
        cloth.step(&view)?;
        seconds += t.elapsed().as_secs_f64();
        let frame = &mut frames[step as usize * n..(step as usize + 1) * n];
        finest_state(&cloth, frame, None);
        if let Some(h) = horizon
            && (step + 1) % h == 0
            && step + 1 < scene.steps
        {
            let mut positions = vec![Vec3::ZERO; n];
            let mut velocities = vec![Vec3::ZERO; n];
            finest_state(&cloth, &mut positions, Some(&mut velocities));
            states.push(State {
                step: step + 1,
                positions,
                velocities,
            });
        }
    }
    Ok(Reference {
        vertex_count: n,
        frames,
        horizon,
        states,
        run: RunResult {
            strategy: Strategy::Reference,
            nodes: n as f64,
            step_ms: 1e3 * seconds / scene.steps as f64,
            reconstruct_ms: None,
            screen: ScreenError::default(),
            screen_split: None,
            operations: 0,
            undone_operations: 0,
            bound_px: None,
            horizon_steps: None,
        },
    })
}

/// Marks in `out` (one flag per finest vertex) the vertices a coarse node covers now.
fn mark_coarse(cloth: &AdaptiveCloth, out: &mut [bool]) {
    out.fill(false);
    let body = cloth.body();
    let h = body.hierarchy();
    for &node in body.particle_nodes() {
        if !h.is_leaf(node) {
            for &v in h.vertices(node) {
                out[v as usize] = true;
            }
        }
    }
}

/// Positions (and velocities) of every finest vertex of a full-resolution cloth.
fn finest_state(cloth: &AdaptiveCloth, positions: &mut [Vec3], velocities: Option<&mut [Vec3]>) {
    let body = cloth.body();
    let h = body.hierarchy();
    let nodes = body.particle_nodes();
    let x = body.particle_positions();
    for (i, &node) in nodes.iter().enumerate() {
        if let Some(v) = h.vertex_of_leaf(node) {
            positions[v as usize] = x[i].truncate();
        }
    }
    if let Some(out) = velocities {
        let v4 = body.particle_velocities();
        for (i, &node) in nodes.iter().enumerate() {
            if let Some(v) = h.vertex_of_leaf(node) {
                out[v as usize] = v4[i].truncate();
            }
        }
    }
}

/// Sets the run under test to the reference `state` mapped onto its cut: transitions in flight
/// end first; every free particle gets the mass-weighted mean position and velocity of the
/// finest vertices its node covers (pinned particles keep following their anchors).
fn restart_from(cloth: &mut AdaptiveCloth, state: &State) -> Result<(), ClothError> {
    cloth.body_mut().end_all();
    let h = cloth.body().hierarchy_arc().clone();
    let nodes = cloth.body().particle_nodes().to_vec();
    let pinned: Vec<bool> = cloth
        .body()
        .particle_positions()
        .iter()
        .map(|p: &Vec4| p.w == 0.0)
        .collect();
    let body = cloth.body_mut();
    for (i, &node) in nodes.iter().enumerate() {
        if pinned[i] {
            continue;
        }
        let (mut m, mut x, mut v) = (0f64, glam::DVec3::ZERO, glam::DVec3::ZERO);
        for &vertex in h.vertices(node) {
            let w = h.mass(h.leaf_of_vertex(vertex)) as f64;
            m += w;
            x += w * state.positions[vertex as usize].as_dvec3();
            v += w * state.velocities[vertex as usize].as_dvec3();
        }
        if m > 0.0 {
            let p = ParticleId::new(i);
            body.set_particle_position(p, (x / m).as_vec3())?;
            body.set_particle_velocity(p, (v / m).as_vec3())?;
        }
    }
    Ok(())
}

/// Runs `spec` on `scene` and measures it against `reference` (recorded with the same horizon
/// when `spec.horizon` is set). A bound ≤ 0 or not finite, a horizon of 0 or one the reference
/// kept no states for is refused before anything runs.
pub fn run_strategy(
    scene: &Scene,
    reference: &Reference,
    spec: RunSpec,
    mut observer: Option<Observer<'_>>,
) -> Result<RunResult, ClothError> {
    check_horizon(spec.horizon)?;
    if spec.strategy == Strategy::ErrorBound && !(spec.bound_px.is_finite() && spec.bound_px > 0.0)
    {
        return Err(bad("bound_px", "must be finite and > 0 px"));
    }
    if spec.horizon.is_some() && spec.horizon != reference.horizon {
        return Err(bad(
            "horizon_steps",
            "the reference kept no states for this horizon",
        ));
    }
    if spec.strategy == Strategy::Reference {
        return Ok(reference.run);
    }
    let mut cloth = scene.cloth(spec.strategy.initial_cut(scene, spec.nodes)?)?;
    cloth.set_feedback(spec.strategy.feedback(spec.nodes, spec.bound_px))?;
    let mut meter = ScreenMeter::new(scene.view(0)?);
    let (mut coarse_meter, mut fine_meter) = (meter.clone(), meter.clone());
    let mut coarse = vec![false; reference.vertex_count];
    let mut vertices = vec![Vec3::ZERO; reference.vertex_count];
    let (mut nodes, mut step_s, mut reconstruct_s) = (0f64, 0f64, 0f64);
    for step in 0..scene.steps {
        if let Some(state) = spec.horizon.and_then(|_| reference.state(step)) {
            restart_from(&mut cloth, state)?;
            meter.restart_sequence();
            coarse_meter.restart_sequence();
            fine_meter.restart_sequence();
        }
        scene.drive(&mut cloth, step)?;
        let view = scene.view(step)?;
        let t = Instant::now();
        cloth.step(&view)?;
        step_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        cloth.reconstruct(&mut vertices)?;
        reconstruct_s += t.elapsed().as_secs_f64();
        nodes += cloth.node_count() as f64;
        meter.set_view(view);
        meter.frame(&vertices, reference.frame(step));
        mark_coarse(&cloth, &mut coarse);
        coarse_meter.set_view(view);
        coarse_meter.frame_masked(&vertices, reference.frame(step), &coarse);
        coarse.iter_mut().for_each(|c| *c = !*c);
        fine_meter.set_view(view);
        fine_meter.frame_masked(&vertices, reference.frame(step), &coarse);
        if let Some(o) = observer.as_mut() {
            o(step, &cloth, &vertices);
        }
    }
    let steps = scene.steps as f64;
    let stats = cloth.stats();
    Ok(RunResult {
        strategy: spec.strategy,
        nodes: nodes / steps,
        step_ms: 1e3 * step_s / steps,
        reconstruct_ms: Some(1e3 * reconstruct_s / steps),
        screen: meter.finish(),
        screen_split: Some(SplitError {
            coarse: coarse_meter.finish(),
            fine: fine_meter.finish(),
        }),
        operations: stats.refines + stats.coarses,
        undone_operations: stats.undone_ops,
        bound_px: (spec.strategy == Strategy::ErrorBound).then_some(spec.bound_px),
        horizon_steps: spec.horizon,
    })
}

/// The twin floor: the reference perturbed by [`TWIN_PERTURBATION_M`] (every free particle, in
/// a seeded random direction) at the start, measured against the reference over the whole run.
pub fn twin_floor(scene: &Scene, reference: &Reference) -> Result<ScreenError, ClothError> {
    perturbed_twin(scene, reference, TWIN_PERTURBATION_M)
}

/// The reference perturbed by `metres` (every free particle, in a seeded random direction),
/// measured against `reference`. With 0 it is the reference again: a deterministic simulation
/// gives exactly zero.
pub fn perturbed_twin(
    scene: &Scene,
    reference: &Reference,
    metres: f32,
) -> Result<ScreenError, ClothError> {
    let mut cloth = scene.cloth(Strategy::Reference.initial_cut(scene, usize::MAX)?)?;
    let mut rng = Rng::new(0x7_1412);
    let positions: Vec<Vec4> = cloth.body().particle_positions().to_vec();
    for (i, p) in positions.iter().enumerate() {
        if p.w == 0.0 {
            continue;
        }
        let d = loop {
            let d = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            if (0.01..=1.0).contains(&d.length_squared()) {
                break d.normalize();
            }
        };
        cloth
            .body_mut()
            .set_particle_position(ParticleId::new(i), p.truncate() + d * metres)?;
    }
    let mut meter = ScreenMeter::new(scene.view(0)?);
    let mut vertices = vec![Vec3::ZERO; reference.vertex_count];
    for step in 0..scene.steps {
        scene.drive(&mut cloth, step)?;
        let view = scene.view(step)?;
        cloth.step(&view)?;
        finest_state(&cloth, &mut vertices, None);
        meter.set_view(view);
        meter.frame(&vertices, reference.frame(step));
    }
    Ok(meter.finish())
}
