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
//!   Every run (the reference too) runs on a rayon pool of one thread of its own and its cost
//!   is that thread's CPU time: like for like (the reference's 129² cloths split their colour
//!   batches over every core of the global pool, and the salience evaluation splits its nodes,
//!   while a 30% cut's batches are too small to split, so wall time compared two cores with
//!   one), and the same whether the runs of a scene share the cores or not
//!   ([`super::PerceptionConfig::parallel`]) and whatever else the machine runs.
//!
//! Based on: the on-screen error of `screen.rs`, and the definitions (short-horizon
//! error as in shadowing studies of chaotic simulations: compare over horizons shorter than the
//! divergence time).

use cpu_time::ThreadTime;
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
    /// Mean CPU time of a step, evaluation included, on one thread, ms.
    pub step_ms: f64,
    /// Mean CPU time of a reconstruction on one thread, ms (`None` for the reference, which
    /// has none).
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
pub type Observer<'a> = &'a mut ObserveFrame<'a>;

/// What an [`Observer`] calls: step (0-based), the cloth after it, its reconstructed vertices.
pub type ObserveFrame<'a> = dyn FnMut(u32, &AdaptiveCloth, &[Vec3]) + Send + 'a;

fn bad(field: &'static str, reason: &'static str) -> ClothError {
    ClothError::Feedback { field, reason }
}

/// Runs `f` on a rayon pool of one thread of its own, so that everything a run does (the
/// body's team, the salience evaluation) happens on the thread whose CPU time is its cost.
pub(super) fn on_one_thread<T: Send>(
    f: impl FnOnce() -> Result<T, ClothError> + Send,
) -> Result<T, ClothError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .thread_name(|_| "slod-measure".into())
        .build()
        .map_err(|_| bad("measurement thread", "could not be started"))?
        .install(f)
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
    on_one_thread(|| record_reference_here(scene, horizon))
}

fn record_reference_here(scene: &Scene, horizon: Option<u32>) -> Result<Reference, ClothError> {
    let mut cloth = scene.cloth(Strategy::Reference.initial_cut(scene, usize::MAX)?)?;
    let n = scene.hierarchy.vertex_count();
    let mut frames = vec![Vec3::ZERO; n * scene.steps as usize];
    let mut states = Vec::new();
    let mut seconds = 0f64;
    for step in 0..scene.steps {
        scene.drive(&mut cloth, step)?;
        let view = scene.view(step)?;
        let t = ThreadTime::now();
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

/// The node simulating each finest vertex (`out[v]`: its raw id): the pops of a vertex whose
/// node changed are the level-of-detail operations' (a refine begun, a coarse ended).
fn simulating_nodes(cloth: &AdaptiveCloth, out: &mut [u32]) {
    let body = cloth.body();
    let h = body.hierarchy();
    for &node in body.particle_nodes() {
        for &v in h.vertices(node) {
            out[v as usize] = node.raw();
        }
    }
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
/// when `spec.horizon` is set), alone on a thread of its own. A bound ≤ 0 or not finite, a
/// horizon of 0 or one the reference kept no states for is refused before anything runs.
pub fn run_strategy(
    scene: &Scene,
    reference: &Reference,
    spec: RunSpec,
    mut observer: Option<Observer<'_>>,
) -> Result<RunResult, ClothError> {
    if spec.strategy == Strategy::Reference {
        check_spec(reference, spec)?;
        return Ok(reference.run);
    }
    on_one_thread(|| {
        let mut run = Run::start(scene, reference, spec)?;
        while !run.done() {
            run.advance(observer.as_deref_mut())?;
        }
        Ok(run.finish())
    })
}

fn check_spec(reference: &Reference, spec: RunSpec) -> Result<(), ClothError> {
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
    Ok(())
}

/// The error meters of a measured run: the whole, coarse-covered and finest vertices.
#[derive(Debug)]
struct Meters {
    whole: ScreenMeter,
    coarse: ScreenMeter,
    fine: ScreenMeter,
    /// Scratch: which vertices a coarse node covers this frame.
    covered: Vec<bool>,
    /// The node simulating each vertex this frame ([`NO_NODE`] before the first).
    node_of: Vec<u32>,
    /// [`Meters::node_of`] of the frame before.
    previous_node_of: Vec<u32>,
    /// Scratch: which vertices changed their simulating node this frame.
    changed: Vec<bool>,
}

/// [`Meters::node_of`] before any frame.
const NO_NODE: u32 = u32::MAX;

/// One run in progress, advanced a step at a time, so that [`super::run_scene`] can interleave
/// the runs of a scene ([`super::INTERLEAVE_STEPS`] steps of each in turn): every strategy then
/// meets the same moments of a shared, noisy machine, and the ratios between their costs are
/// measured in one window.
///
/// A [`Strategy::Reference`] run only steps the full-resolution cloth and times it (its error
/// is zero by construction: it is the reference); every other run is measured against the
/// reference's frames.
#[derive(Debug)]
pub struct Run<'a> {
    scene: &'a Scene,
    reference: &'a Reference,
    spec: RunSpec,
    cloth: AdaptiveCloth,
    /// `None` for a reference run.
    meters: Option<Meters>,
    vertices: Vec<Vec3>,
    step: u32,
    nodes: f64,
    step_s: f64,
    reconstruct_s: f64,
}

impl<'a> Run<'a> {
    /// Builds the run's cloth on its initial cut; bad specs are refused as by [`run_strategy`].
    pub fn start(
        scene: &'a Scene,
        reference: &'a Reference,
        spec: RunSpec,
    ) -> Result<Self, ClothError> {
        check_spec(reference, spec)?;
        let mut cloth = scene.cloth(spec.strategy.initial_cut(scene, spec.nodes)?)?;
        cloth.set_feedback(spec.strategy.feedback(spec.nodes, spec.bound_px))?;
        let meters = if spec.strategy == Strategy::Reference {
            None
        } else {
            let whole = ScreenMeter::new(scene.view(0)?);
            Some(Meters {
                coarse: whole.clone(),
                fine: whole.clone(),
                whole,
                covered: vec![false; reference.vertex_count],
                node_of: vec![NO_NODE; reference.vertex_count],
                previous_node_of: vec![NO_NODE; reference.vertex_count],
                changed: vec![false; reference.vertex_count],
            })
        };
        Ok(Run {
            scene,
            reference,
            spec,
            cloth,
            meters,
            vertices: vec![Vec3::ZERO; reference.vertex_count],
            step: 0,
            nodes: 0.0,
            step_s: 0.0,
            reconstruct_s: 0.0,
        })
    }

    /// Whether every step of the scene has run.
    pub fn done(&self) -> bool {
        self.step >= self.scene.steps
    }

    /// Runs the next step (a no-op when [`Run::done`]): restart (short horizons), drive, step
    /// and reconstruct (timed: the calling thread's CPU time), measure, then `observer`.
    pub fn advance(&mut self, observer: Option<&mut ObserveFrame<'_>>) -> Result<(), ClothError> {
        if self.done() {
            return Ok(());
        }
        let (step, scene) = (self.step, self.scene);
        let cloth = &mut self.cloth;
        if let Some(state) = self.spec.horizon.and_then(|_| self.reference.state(step)) {
            restart_from(cloth, state)?;
            if let Some(m) = &mut self.meters {
                m.whole.restart_sequence();
                m.coarse.restart_sequence();
                m.fine.restart_sequence();
            }
        }
        scene.drive(cloth, step)?;
        let view = scene.view(step)?;
        let t = ThreadTime::now();
        cloth.step(&view)?;
        self.step_s += t.elapsed().as_secs_f64();
        self.nodes += cloth.node_count() as f64;
        self.step += 1;
        let Some(m) = &mut self.meters else {
            return Ok(());
        };
        let vertices = &mut self.vertices;
        let t = ThreadTime::now();
        cloth.reconstruct(vertices)?;
        self.reconstruct_s += t.elapsed().as_secs_f64();
        let reference = self.reference.frame(step);
        m.whole.set_view(view);
        std::mem::swap(&mut m.node_of, &mut m.previous_node_of);
        simulating_nodes(cloth, &mut m.node_of);
        for ((c, &now), &before) in m
            .changed
            .iter_mut()
            .zip(&m.node_of)
            .zip(&m.previous_node_of)
        {
            *c = before != NO_NODE && now != before;
        }
        m.whole.frame_changed(vertices, reference, &m.changed);
        mark_coarse(cloth, &mut m.covered);
        m.coarse.set_view(view);
        m.coarse.frame_masked(vertices, reference, &m.covered);
        m.covered.iter_mut().for_each(|c| *c = !*c);
        m.fine.set_view(view);
        m.fine.frame_masked(vertices, reference, &m.covered);
        if let Some(o) = observer {
            o(step, cloth, vertices);
        }
        Ok(())
    }

    /// The run's figures (over the steps run so far).
    pub fn finish(self) -> RunResult {
        let steps = f64::from(self.step.max(1));
        let stats = self.cloth.stats();
        let spec = self.spec;
        let measured = self.meters.map(|mut m| {
            (
                m.whole.finish(),
                SplitError {
                    coarse: m.coarse.finish(),
                    fine: m.fine.finish(),
                },
            )
        });
        RunResult {
            strategy: spec.strategy,
            nodes: self.nodes / steps,
            step_ms: 1e3 * self.step_s / steps,
            reconstruct_ms: measured.is_some().then(|| 1e3 * self.reconstruct_s / steps),
            screen: measured.map(|m| m.0).unwrap_or_default(),
            screen_split: measured.map(|m| m.1),
            operations: stats.refines + stats.coarses,
            undone_operations: stats.undone_ops,
            bound_px: (spec.strategy == Strategy::ErrorBound).then_some(spec.bound_px),
            horizon_steps: spec.horizon,
        }
    }
}

/// The twin floor: the reference perturbed by [`TWIN_PERTURBATION_M`] (every free particle, in
/// a seeded random direction) at the start, measured against the reference over the whole run.
pub fn twin_floor(scene: &Scene, reference: &Reference) -> Result<ScreenError, ClothError> {
    perturbed_twin(scene, reference, TWIN_PERTURBATION_M)
}

/// How many times the scene's substeps [`solver_floor`] runs its comparison with.
pub const SOLVER_FLOOR_SUBSTEPS_FACTOR: u32 = 2;

/// The solver floor: the reference (the scene's solver settings) measured against the same
/// full-resolution cloth with [`SOLVER_FLOOR_SUBSTEPS_FACTOR`] times the substeps, whole run.
/// It is (a lower estimate of) the error the solver's own convergence makes at full
/// resolution, which every reduced cut inherits: where a strategy's error is near it or below
/// it, comparisons between strategies measure which cut happens to match the unconverged
/// reference as much as level of detail. Twice, not more: single-precision positions lose a
/// substep's corrections to rounding when there are very many (the paper's net against itself
/// at 256 substeps differs by 10–11 px RMS from 32, 64 and 128 alike, while 32 → 64 → 128
/// differ by 2.3 and 1.9 px). On a chaotic scene it includes the divergence of any two runs,
/// as the twin floor does.
pub fn solver_floor(scene: &Scene, reference: &Reference) -> Result<ScreenError, ClothError> {
    let mut converged = scene.clone();
    converged.body.solver.substeps = scene
        .body
        .solver
        .substeps
        .saturating_mul(SOLVER_FLOOR_SUBSTEPS_FACTOR);
    let cloth = converged.cloth(Strategy::Reference.initial_cut(scene, usize::MAX)?)?;
    full_resolution_run(&converged, cloth, reference, Truth::Run)
}

/// Which side of a [`full_resolution_run`] stands for the truth: its vertices in view are the
/// ones measured, and the other side's are measured against them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Truth {
    /// The recorded reference (the twin floor: a perturbed copy against it).
    Reference,
    /// The run stepped here (the solver floor: the reference against a more converged run).
    Run,
}

/// Steps `cloth` (full resolution) through `scene` and measures its finest vertices and the
/// reference's frame by frame on screen, `truth` saying which of the two is measured against.
fn full_resolution_run(
    scene: &Scene,
    mut cloth: AdaptiveCloth,
    reference: &Reference,
    truth: Truth,
) -> Result<ScreenError, ClothError> {
    let mut meter = ScreenMeter::new(scene.view(0)?);
    let mut vertices = vec![Vec3::ZERO; reference.vertex_count];
    for step in 0..scene.steps {
        scene.drive(&mut cloth, step)?;
        let view = scene.view(step)?;
        cloth.step(&view)?;
        finest_state(&cloth, &mut vertices, None);
        meter.set_view(view);
        match truth {
            Truth::Reference => meter.frame(&vertices, reference.frame(step)),
            Truth::Run => meter.frame(reference.frame(step), &vertices),
        }
    }
    Ok(meter.finish())
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
    full_resolution_run(scene, cloth, reference, Truth::Reference)
}
