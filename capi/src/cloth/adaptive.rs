//! [`AdaptiveCloth`]: a TreeCut soft body driven by the feedback loop.
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), section 5 (the complete system: simulate, measure
//! salience in the feedback stage, evaluate, refine/coarse).

use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use salience::View;
use softbody::{DrawLink, TreeCutSettings, TreeCutSoftBody};
use treecut::{GridSpec, Hierarchy, NodeId, Op};

use super::clock::{StepClock, StepWork};
use super::contact::ContactMemory;
use super::controller::StepSample;
use super::error::ClothError;
use super::feedback::{Feedback, FeedbackSettings, Recent, node_radii};

/// An operation undone within this many steps counts as flicker in [`ClothStats::undone_ops`].
pub const UNDO_WINDOW_STEPS: u64 = 30;

/// Counters and last measurements of an [`AdaptiveCloth`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ClothStats {
    /// Steps taken.
    pub steps: u64,
    /// Feedback evaluations run.
    pub evaluations: u64,
    /// Refines begun (by feedback or explicitly).
    pub refines: u64,
    /// Coarses begun (by feedback or explicitly).
    pub coarses: u64,
    /// Operations the evaluator proposed that the body refused. Always 0: the evaluator plans
    /// around the locks of transitions (see [`treecut::Evaluator::evaluate_with_locks`]), and a
    /// refusal is an error of [`AdaptiveCloth::step`]. Kept because the C statistics report it.
    pub refused: u64,
    /// Operations that undid an operation on the same node begun within
    /// [`UNDO_WINDOW_STEPS`] steps (a refine after a coarse of that node, or the reverse).
    pub undone_ops: u64,
    /// The node budget of the last evaluation (0 before the first).
    pub node_budget: usize,
    /// The node count the cut is heading to, at the last evaluation (0 before the first): the
    /// node budget, or under `ClothBudget::MaxErrorPx` the count once refinement has gone down
    /// every level the error estimate asks for (what a world budget plans with).
    pub projected_nodes: usize,
    /// Time of the last step, evaluation included, in seconds, as the cloth's [`StepClock`]
    /// measures it (the wall clock unless [`AdaptiveCloth::set_step_clock`] chose a model).
    pub last_step_seconds: f64,
    /// Time of the last evaluation (salience, evaluator, beginning operations), in seconds, as
    /// the [`StepClock`] measures it.
    pub last_eval_seconds: f64,
    /// The work the last step did (what a [`super::CostModel`] charges): link solves, particle
    /// updates, transitions in flight, nodes an evaluation measured.
    pub last_work: StepWork,
}

/// A cloth whose simulated nodes follow a TreeCut chosen, every few steps, from what the
/// camera sees (the simulation paper's complete system).
///
/// Without feedback it is a TreeCut soft body the host refines and coarsens itself. With
/// [`AdaptiveCloth::set_feedback`] each [`AdaptiveCloth::step`] simulates, and every `interval`
/// steps measures the BSWDF salience of every node, lets the evaluator choose refines and
/// coarses under the budget, and begins them; the body blends and ends them over the next steps.
/// With a node or compression budget everything is deterministic: the same calls give
/// bit-identical results.
#[derive(Clone, Debug)]
pub struct AdaptiveCloth {
    body: TreeCutSoftBody,
    feedback: Option<Feedback>,
    /// Last estimated unit normal per hierarchy node (the sign hint for the next estimate).
    node_normals: Vec<Vec3>,
    node_radius: Vec<f32>,
    /// Per hierarchy node: the step and kind (1 refine, 2 coarse) of its last operation.
    last_op: Vec<(u64, u8)>,
    ops: Vec<Op>,
    stats: ClothStats,
    /// How steps are timed (for the statistics and the time budget).
    clock: StepClock,
    /// Which nodes touched a collider since the last evaluation.
    contact: ContactMemory,
    /// Offset of this cloth's evaluation steps within the feedback interval (see
    /// [`AdaptiveCloth::set_evaluation_phase`]).
    evaluation_phase: u32,
    /// What ran ahead of the next step ([`AdaptiveCloth::evaluate_ahead`],
    /// [`AdaptiveCloth::evaluate_ahead_part`]): reported with that step.
    ahead: Ahead,
    /// Wall seconds the last overlapped measurement added to its step's solver (see
    /// [`FeedbackSettings::overlap_step`]).
    overlap_seconds: f64,
    /// See [`AdaptiveCloth::parts_lost`].
    parts_lost: u64,
}

/// Work of the next step's evaluation run ahead of it, reported with that step.
#[derive(Clone, Copy, Debug, Default)]
struct Ahead {
    /// Wall seconds spent.
    seconds: f64,
    /// Nodes measured.
    nodes: u64,
    /// Whether the whole evaluation ran (the step then skips it); false while only parts of
    /// its measurement did (the step finishes it).
    finished: bool,
}

/// The least time a node stays merged before the loop refines it again (unless it touches a
/// collider), and a refined parent before it is merged again: half a second, the undo window at
/// 60 Hz. The hysteresis filters small priority gains, not churn: on the chaotic scenes, whose
/// salience moves with every gust, a fifth of the operations were undone within half a second.
///
/// History, measured (perception at 30% of the nodes, undone within 30 steps whole run / short
/// horizon; on-screen p99): with no dwell, flag 21.3 / 34.5%, curtain 13.7 / 23.8%, irregular
/// mesh 6.0%; a quarter second took them to 17.1 / 24.7%, 8.7 / 19.1% and 0.9%, while half a
/// second cost the engine drape 14.8 → 15.8 px RMS and was not taken. With the flicker control
/// (`FeedbackSettings::flicker_target`) added, a quarter second left flag 3.1 / 8.1%, curtain
/// 2.7 / 4.5%, irregular 0.9%, 129² net 0.2%; half a second leaves **nothing** undone on any
/// perception scene (flag p99 whole run 92.1 → 71.5 px, horizons 48.9 → 54.5, worse; curtain
/// 35.2 → 32.1 and 38.5 → 38.0; irregular mesh 13.02 → 13.31, worse; 129² net 12.95 → 12.92;
/// the rest unchanged, nothing was undone there) and is better on every engine scene
/// (on-screen RMS, undone: drape 15.28 → 14.81 px, 6.3 → 2.3%; flag 16.65 → 15.10, 1.9 → 0%;
/// cape 11.40 → 10.61, 1.1 → 0.4%; sliding box 34.95 → 33.41, 6.8 → 2.5%).
pub(crate) const DWELL_SECONDS: f32 = 0.5;

const OP_REFINE: u8 = 1;
const OP_COARSE: u8 = 2;

/// Whether `node`'s last operation (`last_op`: step and kind per node) was a refine or a
/// coarse begun within [`UNDO_WINDOW_STEPS`] of step `now`: undoing it would count as flicker.
fn recent_op(last_op: &[(u64, u8)], now: u64, node: NodeId) -> Recent {
    recent_within(last_op, now, node, UNDO_WINDOW_STEPS)
}

/// [`recent_op`] over a window of `window` steps.
fn recent_within(last_op: &[(u64, u8)], now: u64, node: NodeId, window: u64) -> Recent {
    let (when, kind) = last_op[node.index()];
    match kind {
        _ if now - when > window => Recent::No,
        OP_REFINE => Recent::Refined,
        OP_COARSE => Recent::Coarsened,
        _ => Recent::No,
    }
}

impl AdaptiveCloth {
    /// A cloth over `hierarchy` starting from `cut` (which must be a valid cut of it), with every
    /// node at rest. `rest_normal` orients the surface for the salience stage (any consistent
    /// choice works for two-sided cloth; the grid builder passes `u × v`).
    pub fn new(
        hierarchy: impl Into<Arc<Hierarchy>>,
        cut: treecut::Cut,
        settings: TreeCutSettings,
        rest_normal: Vec3,
    ) -> Result<AdaptiveCloth, ClothError> {
        let hierarchy: Arc<Hierarchy> = hierarchy.into();
        let normal = rest_normal.normalize_or(Vec3::Y);
        let node_radius = node_radii(&hierarchy);
        let len = hierarchy.len();
        let body = TreeCutSoftBody::new(hierarchy, cut, settings)?;
        Ok(AdaptiveCloth {
            body,
            feedback: None,
            node_normals: vec![normal; len],
            node_radius,
            last_op: vec![(0, 0); len],
            ops: Vec::new(),
            stats: ClothStats::default(),
            clock: StepClock::Wall,
            contact: ContactMemory::default(),
            evaluation_phase: 0,
            ahead: Ahead::default(),
            overlap_seconds: 0.0,
            parts_lost: 0,
        })
    }

    /// A regular grid cloth (a quadtree hierarchy) starting at `level` (0 = finest; clamped to
    /// the coarsest level).
    pub fn grid(
        spec: &GridSpec,
        level: u32,
        settings: TreeCutSettings,
    ) -> Result<AdaptiveCloth, ClothError> {
        let h = Hierarchy::grid(spec)?;
        let level = level.min(h.level_count().saturating_sub(1));
        let cut = treecut::Cut::uniform(&h, level);
        let mut cloth = AdaptiveCloth::new(h, cut, settings, spec.u.cross(spec.v))?;
        cloth
            .body
            .set_surface(&softbody::grid_triangles(spec.cols, spec.rows))?;
        Ok(cloth)
    }

    /// A cloth from the host's own triangle mesh (rest positions, triangles, optional masses
    /// per vertex), starting at the finest level. The mesh must be connected.
    pub fn from_mesh(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        masses: Option<&[f32]>,
        settings: TreeCutSettings,
    ) -> Result<AdaptiveCloth, ClothError> {
        let h = Hierarchy::from_mesh(positions, triangles, masses)?;
        // Area-weighted mean normal: with two-sided salience only a consistent orientation
        // matters, and the mean of the triangles' normals is one.
        let mut normal = Vec3::ZERO;
        for t in triangles {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            normal += (b - a).cross(c - a);
        }
        let cut = treecut::Cut::finest(&h);
        let mut cloth = AdaptiveCloth::new(h, cut, settings, normal)?;
        cloth.body.set_surface(triangles)?;
        Ok(cloth)
    }

    /// The TreeCut soft body (particles, links, cut, hierarchy).
    pub fn body(&self) -> &TreeCutSoftBody {
        &self.body
    }

    /// The soft body, mutably (pins, forces, settings). Refines and coarses begun through it
    /// directly are not counted in the statistics.
    pub fn body_mut(&mut self) -> &mut TreeCutSoftBody {
        self.lose_partial();
        &mut self.body
    }

    /// The hierarchy the cut runs through.
    pub fn hierarchy(&self) -> &Hierarchy {
        self.body.hierarchy()
    }

    /// Counters and last timings.
    pub fn stats(&self) -> &ClothStats {
        &self.stats
    }

    /// The feedback settings, if feedback is on.
    pub fn feedback(&self) -> Option<&FeedbackSettings> {
        self.feedback.as_ref().map(|f| &f.settings)
    }

    /// How the cloth times its steps: [`ClothStats::last_step_seconds`] and what a
    /// [`ClothBudget::TargetStepMs`](super::ClothBudget::TargetStepMs) controller reads.
    pub fn step_clock(&self) -> StepClock {
        self.clock
    }

    /// Chooses how the cloth times its steps: the wall clock (the default; what a host pays) or
    /// a deterministic cost model of each step's work, with which a time-budget run gives the
    /// same results on any machine under any load (for tests, and hosts that want
    /// reproducible runs). A model with a negative or non-finite coefficient is refused.
    pub fn set_step_clock(&mut self, clock: StepClock) -> Result<(), ClothError> {
        if let StepClock::Model(m) = clock
            && !m.is_valid()
        {
            return Err(ClothError::Feedback {
                field: "step_clock",
                reason: "cost model coefficients must be finite and >= 0",
            });
        }
        self.clock = clock;
        Ok(())
    }

    /// Turns the feedback loop on with these settings (or off with `None`). Invalid settings are
    /// refused and the previous ones stay.
    pub fn set_feedback(&mut self, settings: Option<FeedbackSettings>) -> Result<(), ClothError> {
        let Some(settings) = settings else {
            self.feedback = None;
            return Ok(());
        };
        settings.validate()?;
        match &mut self.feedback {
            // Keep the controller's learned state when only other settings change.
            Some(f) if f.settings.budget == settings.budget => {
                f.settings = settings;
                f.sync_evaluator(self.body.hierarchy().vertex_count());
            }
            _ => {
                let h = self.body.hierarchy();
                let mut f =
                    Feedback::new(settings, h.len(), h.vertex_count(), self.body.cut().len());
                // Flicker is counted from here on.
                f.undone_seen = self.stats.undone_ops;
                self.feedback = Some(f);
            }
        }
        Ok(())
    }

    /// Moves the on-screen error bound of a cloth under [`ClothBudget::MaxErrorPx`] to `px`
    /// without restarting its loop (the salience memory, the held deviations and the evaluator
    /// stay), as a world-wide budget does every few frames; a cloth under another budget (or no
    /// feedback) switches to `MaxErrorPx(px)` with its other settings kept (or the defaults).
    /// Refused, with nothing changed, unless `px` is finite and positive.
    ///
    /// [`ClothBudget::MaxErrorPx`]: super::ClothBudget::MaxErrorPx
    pub fn set_error_bound_px(&mut self, px: f32) -> Result<(), ClothError> {
        let budget = super::ClothBudget::MaxErrorPx(px);
        match &mut self.feedback {
            Some(f) if matches!(f.settings.budget, super::ClothBudget::MaxErrorPx(_)) => {
                let settings = FeedbackSettings {
                    budget,
                    ..f.settings
                };
                settings.validate()?;
                f.settings = settings;
                f.sync_evaluator(self.body.hierarchy().vertex_count());
                Ok(())
            }
            f => {
                let base = f
                    .as_ref()
                    .map_or_else(FeedbackSettings::default, |f| f.settings);
                self.set_feedback(Some(FeedbackSettings { budget, ..base }))
            }
        }
    }

    /// [`AdaptiveCloth::set_error_bound_px`] for a bound a world budget moves every few frames:
    /// merges also wait until merging stays under a quarter of the refine threshold
    /// (`settings::SHARED_BOUND_MERGE`), so a bound moving back and forth does not merge and
    /// refine the same nodes.
    pub(crate) fn set_shared_error_bound_px(&mut self, px: f32) -> Result<(), ClothError> {
        self.set_error_bound_px(px)?;
        if let Some(f) = self.feedback.as_mut() {
            f.shared_bound = true;
        }
        Ok(())
    }

    /// Back to a fixed bound's merge threshold (the cloth left a world's shared bound).
    pub(crate) fn clear_shared_bound(&mut self) {
        if let Some(f) = self.feedback.as_mut() {
            f.shared_bound = false;
            f.curve = None;
        }
    }

    /// Whether the bound was last set by [`AdaptiveCloth::set_shared_error_bound_px`].
    pub(crate) fn has_shared_bound(&self) -> bool {
        self.feedback.as_ref().is_some_and(|f| f.shared_bound)
    }

    /// Under a world's shared bound, the node count the cut heads to at any bound, from the
    /// last evaluation (`None` before one, or without a shared bound).
    pub(crate) fn bound_curve(&self) -> Option<&std::sync::Arc<super::feedback::BoundCurve>> {
        self.feedback
            .as_ref()
            .filter(|f| f.shared_bound)
            .and_then(|f| f.curve.as_ref())
    }

    /// Offsets the steps at which the feedback stage runs: with interval `k` it runs at the
    /// steps `s` with `(s + phase) % k == 0` (0, the default: steps 0, k, 2k, ...). A world of
    /// many cloths gives them different phases so that their evaluations, which cost several
    /// steps' worth of time, fall on different frames instead of all on every k-th one.
    pub fn set_evaluation_phase(&mut self, phase: u32) {
        if phase != self.evaluation_phase {
            // The evaluation a measurement was begun ahead for is no longer the next step's.
            self.forget_partial();
        }
        self.evaluation_phase = phase;
    }

    /// The step and kind (1 refine, 2 coarse; 0 none) of `node`'s last operation, for tests.
    #[cfg(test)]
    pub(crate) fn last_operation(&self, node: NodeId) -> (u64, u8) {
        self.last_op[node.index()]
    }

    /// Begins refining `node` (replacing it by its children over the blend steps). Refused, with
    /// nothing changed, if it is not on the cut, a leaf, or locked by a transition in flight.
    pub fn refine(&mut self, node: NodeId) -> Result<(), ClothError> {
        self.body.begin_refine(node)?;
        self.lose_partial();
        self.record(node, OP_REFINE);
        Ok(())
    }

    /// Begins coarsening `parent` (replacing its children by it over the blend steps). Refused,
    /// with nothing changed, unless all its children are on the cut and unlocked.
    pub fn coarse(&mut self, parent: NodeId) -> Result<(), ClothError> {
        self.body.begin_coarse(parent)?;
        self.lose_partial();
        self.record(parent, OP_COARSE);
        Ok(())
    }

    fn record(&mut self, node: NodeId, kind: u8) {
        let now = self.stats.steps;
        let (when, last) = self.last_op[node.index()];
        if last != 0 && last != kind && now - when <= UNDO_WINDOW_STEPS {
            self.stats.undone_ops += 1;
        }
        self.last_op[node.index()] = (now, kind);
        match kind {
            OP_REFINE => self.stats.refines += 1,
            _ => self.stats.coarses += 1,
        }
    }

    /// Advances the simulation by one step of the solver's `dt`; with feedback on, every
    /// `interval` steps (counting from the first, shifted by the evaluation phase) also measures salience as seen through `view`
    /// (the frame's camera, viewport and light; the cloth keeps no copy) and begins the
    /// operations the evaluator chose, unless [`AdaptiveCloth::evaluate_ahead`] ran that
    /// stage since the last step. Operations whose blend is done end inside the step. With
    /// [`FeedbackSettings::overlap_step`] the measurement runs beside the solver (on copies of
    /// the state before it) and the operations begin after the solver; an error of the
    /// evaluation's later parts (after the measurement began) is then returned after the step
    /// ran, its operations not begun (its earlier errors, as every error without the overlap,
    /// leave the cloth unstepped).
    ///
    /// With a time budget the controller is given every step's time (by the [`StepClock`]), the
    /// evaluation's part of it, the nodes and the transitions in flight, and moves the node
    /// budget once per interval, before the evaluation (see [`super::TimeController`]).
    pub fn step(&mut self, view: &View) -> Result<(), ClothError> {
        let start = Instant::now();
        let mut work = StepWork::default();
        let due = self.evaluation_due();
        // What ran ahead is this step's evaluation (see `evaluate_ahead`): reported with it.
        let ahead = std::mem::take(&mut self.ahead);
        let mut eval_seconds = (ahead.nodes > 0 || ahead.finished).then_some(ahead.seconds);
        let overlap = due
            && self
                .feedback
                .as_ref()
                .is_some_and(|f| f.settings.overlap_step);
        if overlap {
            // Prepared now (what can fail fails before anything moved), measured beside the
            // solver, concluded after it.
            eval_seconds = Some(ahead.seconds + self.prepare_overlapped(view, &mut work)?);
        } else if due {
            eval_seconds = Some(ahead.seconds + self.feedback_stage(view, &mut work)?);
        }
        let solver = self.body.settings().solver;
        let passes = solver.substeps as u64;
        work.link_iterations = self.link_count() as u64 * passes * solver.iterations as u64;
        work.node_substeps = self.body.particle_count() as u64 * passes;
        work.transitions = self.body.transitions_in_flight() as u64;
        work.transition_substeps = work.transitions * passes;
        self.stats.last_work = work;
        let nodes = self.body.particle_count();
        let mut late = Ok(());
        if overlap {
            let measured = self.step_overlapped();
            self.contact.after_step(&self.body);
            // The operations begin after the step (the sequential evaluation's begin before
            // it): recorded at this step, as theirs.
            let t = Instant::now();
            late = measured.and_then(|()| self.conclude_and_plan());
            if let Some(e) = eval_seconds.as_mut() {
                *e += self.overlap_seconds + t.elapsed().as_secs_f64();
            }
        } else {
            self.body.step();
            // A measurement begun ahead for an evaluation this step did not run (its phase
            // moved) measured a state that is gone.
            self.forget_partial();
            self.contact.after_step(&self.body);
        }
        self.stats.steps += 1;
        let (seconds, eval_seconds) = match self.clock {
            StepClock::Wall => (start.elapsed().as_secs_f64() + ahead.seconds, eval_seconds),
            StepClock::Model(m) => {
                let evaluated = StepWork {
                    evaluated_nodes: work.evaluated_nodes + ahead.nodes,
                    ..work
                };
                (
                    m.seconds(&evaluated),
                    eval_seconds.map(|_| m.evaluation_seconds(&evaluated)),
                )
            }
        };
        self.stats.last_step_seconds = seconds;
        if let Some(e) = eval_seconds {
            self.stats.last_eval_seconds = e;
        }
        if let Some(c) = self.feedback.as_mut().and_then(|f| f.controller.as_mut()) {
            c.observe(StepSample {
                seconds,
                eval_seconds: eval_seconds.unwrap_or(0.0),
                nodes,
                transitions: work.transitions as usize,
            });
        }
        late
    }

    /// The first part of an evaluation overlapped with its step
    /// ([`FeedbackSettings::overlap_step`]): the time controller's interval closed, the
    /// measurement prepared (copies of what it reads). Returns its wall seconds.
    fn prepare_overlapped(&mut self, view: &View, work: &mut StepWork) -> Result<f64, ClothError> {
        let t = Instant::now();
        let measured = self.feedback.as_ref().map_or(0, |f| f.measured_ahead());
        let dt = self.body.settings().solver.dt;
        let Some(f) = self.feedback.as_mut() else {
            return Ok(0.0);
        };
        f.prepare(&self.body, &self.node_normals, &self.node_radius, view, dt)?;
        if let Some(c) = f.controller.as_mut() {
            c.end_interval();
        }
        work.evaluated_nodes = self.body.particle_count().saturating_sub(measured) as u64;
        Ok(t.elapsed().as_secs_f64())
    }

    /// The solver's step with the prepared measurement computed beside it: spawned on the rayon
    /// pool (the one this runs in, else the global one) while the solver runs on this thread,
    /// when the settings allow the pool ([`FeedbackSettings::parallel`]), else before the
    /// solver on this thread (the same results: the measurement reads only its copies). Sets
    /// `overlap_seconds` to the wall time the measurement added to the solver's.
    fn step_overlapped(&mut self) -> Result<(), ClothError> {
        let t = Instant::now();
        let (body, node_radius) = (&mut self.body, &self.node_radius[..]);
        let h = body.hierarchy_arc().clone();
        let Some(feedback) = self.feedback.as_mut() else {
            body.step();
            return Ok(());
        };
        let mut measured = Ok(());
        let solver = if feedback.settings.parallel {
            // The solver stays on this thread (its particles are in this core's caches); the
            // measurement reads copies, cold wherever it runs.
            rayon::in_place_scope(|scope| {
                scope.spawn(|_| measured = feedback.compute(&h, node_radius));
                let t = Instant::now();
                body.step();
                t.elapsed().as_secs_f64()
            })
        } else {
            measured = feedback.compute(&h, node_radius);
            let t = Instant::now();
            body.step();
            t.elapsed().as_secs_f64()
        };
        self.overlap_seconds = (t.elapsed().as_secs_f64() - solver).max(0.0);
        measured
    }

    /// The last part of an evaluation (after the step when overlapped with it): the priorities
    /// of the cut as it is now, the evaluator, the operations begun.
    fn conclude_and_plan(&mut self) -> Result<(), ClothError> {
        let Some(f) = self.feedback.as_mut() else {
            return Ok(());
        };
        let (now, last_op) = (self.stats.steps, &self.last_op);
        let recent = |n: NodeId| recent_op(last_op, now, n);
        let seen = f.conclude(
            &self.body,
            &mut self.node_normals,
            &self.node_radius,
            &recent,
        )?;
        self.plan(&seen)
    }

    /// The feedback stage a step runs when it is due: the time controller's interval closed,
    /// the evaluation (`work` gets the nodes it measures: those no part measured ahead).
    /// Returns its wall seconds.
    fn feedback_stage(&mut self, view: &View, work: &mut StepWork) -> Result<f64, ClothError> {
        let measured = self.feedback.as_ref().map_or(0, |f| f.measured_ahead());
        if let Some(c) = self.feedback.as_mut().and_then(|f| f.controller.as_mut()) {
            c.end_interval();
        }
        work.evaluated_nodes = self.body.particle_count().saturating_sub(measured) as u64;
        let t = Instant::now();
        self.evaluate(view)?;
        Ok(t.elapsed().as_secs_f64())
    }

    /// Runs the feedback stage the next [`AdaptiveCloth::step`] is due to run now, seeing the
    /// cloth through `view`, and that step then skips it; returns its work (only
    /// [`StepWork::evaluated_nodes`] set), or `None` when no evaluation is due (or one already
    /// ran ahead). Nothing of the cloth moves between two steps, so the evaluation measures the
    /// same state and plans the same operations as the step would (seen through this `view`,
    /// under the budget set now), and the operations begin now to blend from that step on. A
    /// host whose frames are shorter than the cloth's step uses it to run a cloth's evaluation
    /// on a frame in which the cloth does not step (an evaluation costs most of a step: on
    /// the stepping frame it makes that frame the longest of its cycle; a world spreads it
    /// over several frames instead, [`AdaptiveCloth::evaluate_ahead_part`]).
    /// Its time is reported with the next step (`last_eval_seconds`, and the time budget's
    /// sample, whose step time includes it); that step's [`ClothStats::last_work`] does not
    /// count it (it was charged here).
    pub fn evaluate_ahead(&mut self, view: &View) -> Result<Option<StepWork>, ClothError> {
        if !self.evaluation_due() {
            return Ok(None);
        }
        let mut work = StepWork::default();
        let seconds = self.feedback_stage(view, &mut work)?;
        self.ahead.seconds += seconds;
        self.ahead.nodes += work.evaluated_nodes;
        self.ahead.finished = true;
        Ok(Some(work))
    }

    /// Runs part of the next step's due evaluation now: its measurement of the nodes, up to
    /// `fraction` of them (in [0, 1]; a measurement is begun if none is under way, seeing the
    /// cloth through `view`). The step (or [`AdaptiveCloth::evaluate_ahead`]) finishes it: the
    /// rest of the nodes, the priorities and the operations. Nothing of the cloth moves between
    /// two steps, so the parts measure one state, all through the first part's view, and the
    /// evaluation is the one [`AdaptiveCloth::evaluate_ahead`] would have run at the first
    /// part (its bound is the one set when it finishes). An evaluation costs most of a step;
    /// a host whose frames are a fraction of the cloth's step spreads one over the frames in
    /// which the cloth does not step, and one whose frames are a step can measure half of the
    /// next evaluation after this frame's step (a world does both). Returns the work (only
    /// [`StepWork::evaluated_nodes`] set), or `None` when no evaluation is due, one already
    /// ran ahead, or the cloth's budget is not [`super::ClothBudget::MaxErrorPx`] (other
    /// budgets measure in one go). The body changed in between ([`AdaptiveCloth::body_mut`],
    /// [`AdaptiveCloth::refine`], [`AdaptiveCloth::coarse`]): the parts are dropped and the step
    /// measures again. Refused (nothing changed) for a `fraction` that is not a number.
    pub fn evaluate_ahead_part(
        &mut self,
        view: &View,
        fraction: f32,
    ) -> Result<Option<StepWork>, ClothError> {
        if fraction.is_nan() {
            return Err(ClothError::Feedback {
                field: "fraction",
                reason: "must be a number in [0, 1]",
            });
        }
        if !self.evaluation_due() {
            return Ok(None);
        }
        let Some(f) = self.feedback.as_mut() else {
            return Ok(None);
        };
        let t = Instant::now();
        let dt = self.body.settings().solver.dt;
        let nodes = f.measure_part(&self.body, &self.node_radius, view, dt, fraction)?;
        if nodes == 0 && f.measured_ahead() == 0 {
            return Ok(None);
        }
        self.ahead.seconds += t.elapsed().as_secs_f64();
        self.ahead.nodes += nodes as u64;
        Ok(Some(StepWork {
            evaluated_nodes: nodes as u64,
            ..StepWork::default()
        }))
    }

    /// Drops a measurement begun ahead (the body is about to change).
    fn forget_partial(&mut self) {
        if let Some(f) = self.feedback.as_mut() {
            f.drop_partial();
        }
    }

    /// [`AdaptiveCloth::forget_partial`] for a change from outside the loop (the host's),
    /// counted in `parts_lost` when a measurement was under way.
    fn lose_partial(&mut self) {
        if self
            .feedback
            .as_ref()
            .is_some_and(|f| f.measured_ahead() > 0)
        {
            self.parts_lost += 1;
        }
        self.forget_partial();
    }

    /// Measurements begun ahead ([`AdaptiveCloth::evaluate_ahead_part`]) that a change from
    /// outside the loop (`body_mut`, `refine`, `coarse`) made the step measure again: a world
    /// stops splitting the evaluations of a cloth whose host moves it between frames (a cape
    /// whose pins follow a character), whose parts would be lost every time.
    pub(crate) fn parts_lost(&self) -> u64 {
        self.parts_lost
    }

    /// Runs the feedback stage once now, seeing the cloth through `view`: salience, evaluator,
    /// begin operations. Refused (nothing changed) without feedback settings. The evaluator plans
    /// only operations the body can begin one after the other, so every one begins; an operation
    /// the body refused anyway would be returned as its error (after the ones before it began).
    pub fn evaluate(&mut self, view: &View) -> Result<(), ClothError> {
        let Some(f) = self.feedback.as_mut() else {
            return Err(ClothError::Feedback {
                field: "feedback",
                reason: "not enabled",
            });
        };
        // A measurement begun ahead in parts is finished through the view it began with.
        let dt = self.body.settings().solver.dt;
        f.prepare(&self.body, &self.node_normals, &self.node_radius, view, dt)?;
        f.compute(self.body.hierarchy(), &self.node_radius)?;
        self.conclude_and_plan()
    }

    /// The evaluation after its measurement (made through `seen`): the contact priorities, the
    /// node budget, the evaluator, and the operations begun.
    fn plan(&mut self, seen: &View) -> Result<(), ClothError> {
        let Some(f) = self.feedback.as_mut() else {
            return Err(ClothError::Feedback {
                field: "feedback",
                reason: "not enabled",
            });
        };
        self.contact
            .raise_priorities(&self.body, &mut f.priorities, seen);
        let h = self.body.hierarchy_arc().clone();
        let budget = f.node_budget(h.vertex_count());
        // The operation limit follows the budget (see `FeedbackSettings::ops_per_evaluation`).
        let mut e = f.settings.evaluator_settings(budget);
        if !matches!(
            f.settings.budget,
            super::feedback::ClothBudget::MaxErrorPx(_)
        ) {
            // The hysteresis is a multiple of the simulated nodes' mean priority: priorities
            // scale with the viewport, the distance and the cloth's motion, so a fixed gain
            // would freeze a far cloth's cut and let a near one flicker.
            let active = self.body.cut().active();
            let mean = active
                .iter()
                .map(|n| f.priorities[n.index()] as f64)
                .sum::<f64>()
                / active.len().max(1) as f64;
            let flicker = f.flicker_gain(
                self.stats.refines + self.stats.coarses,
                self.stats.undone_ops,
                self.stats.steps,
                self.body.settings().solver.dt,
            );
            e.hysteresis *= mean as f32 * flicker;
            // A time budget below the cut may merge as fast as the locks allow (one family
            // per neighbourhood), on top of `max_ops`: the controller fits its cost per node
            // from steps without transitions, so the transitions of a fast shrink no longer
            // read as load, and at 64 operations a cold start from the finest 65×65 net took
            // 15 evaluations (75 steps) to shed the nodes a 0.46 ms target needs.
            if let Some(c) = &f.controller {
                let over = active.len().saturating_sub(budget);
                e.max_ops = if over > 0 {
                    e.max_ops + over
                } else {
                    // Each operation begun now is a transition in flight for the next steps.
                    let room = c.max_transitions(active.len()).unwrap_or(e.max_ops);
                    let busy = self.body.transitions_in_flight();
                    e.max_ops.min(room.saturating_sub(busy)).max(1)
                };
            }
            // A minimum dwell ([`DWELL_SECONDS`]): a node merged within it ranks last for
            // refining, and a parent refined within it is merged last. A time budget keeps its
            // own, the whole undo window: every move of the budget forces merges or opens room
            // for refines, which the hysteresis does not filter.
            {
                let now = self.stats.steps;
                let dwell = if f.controller.is_some() {
                    UNDO_WINDOW_STEPS
                } else {
                    (DWELL_SECONDS / self.body.settings().solver.dt)
                        .round()
                        .max(1.0) as u64
                };
                let recent = |n: NodeId| recent_within(&self.last_op, now, n, dwell);
                for &n in active {
                    // A node touching a collider is never kept coarse.
                    if recent(n) == Recent::Coarsened && !self.contact.touched(n) {
                        f.priorities[n.index()] = 0.0;
                    }
                    if let Some(p) = h.parent(n)
                        && recent(p) == Recent::Refined
                    {
                        f.priorities[p.index()] = f32::MAX;
                    }
                }
            }
        }
        f.evaluator.set_settings(e);
        self.contact.forget();
        // The evaluator knows what beginning each operation locks (transitions lock their
        // neighbourhoods), so every operation of the batch begins, in the order given, and the
        // cut stays within the budget after each; a refusal is a bug, reported as an error.
        // Over a node or compression budget, merges count against `max_ops` like any operation
        // (see `EvaluatorSettings::max_ops`).
        f.evaluator.set_refine_floor(match f.settings.budget {
            super::feedback::ClothBudget::MaxErrorPx(bound) => {
                super::feedback::ERROR_BOUND_REFINE * bound
            }
            _ => f32::NEG_INFINITY,
        });
        let body = &self.body;
        let ops = f.evaluator.evaluate_with_locks(
            &h,
            body.cut(),
            &f.priorities,
            None,
            treecut::Budget::Nodes(budget),
            &|op, out| body.would_lock(op, out),
        )?;
        self.ops.clear();
        self.ops.extend_from_slice(ops);
        let over = body.cut().len().saturating_sub(budget);
        if over > 0 && f.controller.is_some() {
            // A time budget that shrank: only the merges that bring the cut within it (the
            // batch's first operations). Swaps in the same batch would find most nodes locked
            // by the merges, keep room for refines they cannot begin, leave the cut under the
            // budget and refine it back over the next evaluations: undone operations.
            let (mut left, mut keep) = (over, 0);
            for &op in &self.ops {
                let Op::Coarse(p) = op else { break };
                keep += 1;
                left = left.saturating_sub(h.child_count(p).saturating_sub(1));
                if left == 0 {
                    break;
                }
            }
            self.ops.truncate(keep);
        } else if f.controller.is_some() {
            // Nor is a node merged within the undo window refined back (a minimum dwell): its
            // priority was zeroed above, but where most of the cut was merged recently (after a
            // cold start's shrink) a budget that grows would still reach it. Leaving a refine
            // out keeps every later operation of the batch valid: it only frees locks.
            let now = self.stats.steps;
            let last_op = &self.last_op;
            self.ops.retain(|&op| match op {
                Op::Refine(n) => recent_op(last_op, now, n) != Recent::Coarsened,
                Op::Coarse(_) => true,
            });
        }
        self.stats.evaluations += 1;
        self.stats.node_budget = budget;
        self.stats.projected_nodes = f.projected_nodes(h.vertex_count());
        let ops = std::mem::take(&mut self.ops);
        let begun = ops.iter().try_for_each(|&op| match op {
            Op::Refine(n) => self.refine(n),
            Op::Coarse(n) => self.coarse(n),
        });
        self.ops = ops;
        begun
    }

    /// Positions of every finest-level vertex reconstructed from the current nodes (for
    /// rendering and for measuring error); `out` holds one entry per vertex.
    pub fn reconstruct(&self, out: &mut [Vec3]) -> Result<(), ClothError> {
        Ok(self.body.reconstruct(out)?)
    }

    /// The links with their blend weights, for debug drawing (cleared first).
    pub fn draw_links(&self, out: &mut Vec<DrawLink>) {
        self.body.draw_links(out);
    }

    /// Simulated nodes now.
    pub fn node_count(&self) -> usize {
        self.body.particle_count()
    }

    /// Links now (plain and group links).
    pub fn link_count(&self) -> usize {
        self.body.link_count() + self.body.group_link_count()
    }

    pub(crate) fn contact(&self) -> &ContactMemory {
        &self.contact
    }

    pub(crate) fn contact_mut(&mut self) -> &mut ContactMemory {
        &mut self.contact
    }

    /// Whether the next [`AdaptiveCloth::step`] runs the feedback stage (feedback on, the
    /// step count at the cloth's evaluation phase, and the stage not already run ahead of it by
    /// [`AdaptiveCloth::evaluate_ahead`]).
    pub fn evaluation_due(&self) -> bool {
        !self.ahead.finished
            && self.feedback.as_ref().is_some_and(|f| {
                (self.stats.steps + self.evaluation_phase as u64)
                    .is_multiple_of(f.settings.interval as u64)
            })
    }

    /// Refine/coarse transitions being blended now (the paper's "interpolations").
    pub fn interpolations(&self) -> usize {
        self.body.transitions_in_flight()
    }
}
