//! [`FrameBudgeter`]: one world frame under one budget — every crowd advanced, every cloth
//! stepped, on all cores, each object's detail set from the world's shared error bound, the
//! frame's cost counted and fed to the controller.
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), section 5
//! ("a maximal computation time" as a budget, the TreeCut evaluation run beside the
//! simulation), and the practice of NVIDIA APEX (a scene-wide LOD resource budget spent by each
//! actor's benefit) and Unreal's animation budget allocator (a millisecond budget for all
//! skeletal meshes, with per-component overrides).
//!
//! The budgeter does not own the objects: a frame is `begin_frame`, `advance_crowds`,
//! `step_cloths`, `end_frame`, each given the objects by key, so [`super::World`] (Rust) and the C world (its own arenas, and bone-attached cloths
//! that must see their character's new pose between the crowd and the cloth phase) share it.
//! What runs on the threads is in the `jobs` module.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use salience::View;

use super::budget::{BudgetShare, BudgetTarget, FrameClock, WorldBudget, WorldError};
use super::controller::{ClothResponse, ErrorBoundController, FrameCost};
use super::jobs::{
    ClothJob, CrowdJob, StepCost, apply_cloth_share, full_ratio, run_cloths, run_crowds,
    run_together,
};
use super::timefit::TimeFit;
use super::warm::KeepWarm;
use crate::cloth::{AdaptiveCloth, FeedbackSettings};
use animlod::{Crowd, LodMode};

/// The kind of object a key names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ObjectKind {
    /// An [`AdaptiveCloth`].
    Cloth,
    /// An [`animlod::Crowd`].
    Crowd,
}

/// Names an object to the budget: its kind and a number unique among objects of that kind in
/// the world (a generational handle packed into 64 bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ObjectKey {
    /// Cloth or crowd.
    pub kind: ObjectKind,
    /// Unique among the world's objects of this kind.
    pub id: u64,
}

impl ObjectKey {
    /// The key of the object of `kind` in slot `index` with stamp `generation`.
    pub(crate) fn new(kind: ObjectKind, index: u32, generation: u32) -> ObjectKey {
        ObjectKey {
            kind,
            id: (generation as u64) << 32 | index as u64,
        }
    }

    /// The slot index and generation the key was made from.
    pub(crate) fn slot(self) -> (u32, u32) {
        (self.id as u32, (self.id >> 32) as u32)
    }
}

/// What one object did in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectFrame {
    /// Which object.
    pub key: ObjectKey,
    /// Its cost this frame, in cost units.
    pub units: f64,
    /// Its detail: simulated nodes of a cloth, bones interpolated by a crowd.
    pub detail: u64,
    /// Its detail at full resolution: the cloth's finest node count, the crowd's animated bones.
    pub full_detail: u64,
    /// The error bound it ran under, px (0 when it keeps its own settings or is at full detail).
    pub bound_px: f32,
    /// How it takes part in the budget.
    pub share: BudgetShare,
}

/// What one world frame did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WorldStepStats {
    /// Frames stepped so far, this one included.
    pub frame: u64,
    /// Wall time of the frame (crowds, cloths, the budget's own work), ms.
    pub wall_ms: f64,
    /// Wall time of the crowd phase, ms (in [`super::World::step`], whose crowds and cloths
    /// share one phase: the crowds' own time inside it).
    pub crowd_ms: f64,
    /// Wall time of the cloth phase, ms (in [`super::World::step`]: the whole shared phase).
    pub cloth_ms: f64,
    /// Modelled cost of the frame, cost units.
    pub cost_units: f64,
    /// What the controller measured (ms or cost units, as the target; 0 without a budget).
    pub measured: f64,
    /// The error bound the frame's shared objects ran under, px.
    pub error_bound_px: f32,
    /// Cloths stepped.
    pub cloths: u32,
    /// Crowds advanced.
    pub crowds: u32,
    /// Solver steps taken over all cloths.
    pub cloth_steps: u32,
    /// Feedback evaluations run over all cloths.
    pub evaluations: u32,
    /// Simulated nodes over all cloths after the frame.
    pub cloth_nodes: u64,
    /// Finest nodes over all cloths.
    pub cloth_full_nodes: u64,
    /// Bones interpolated over all crowds.
    pub bones_interpolated: u64,
    /// Animated bones over all crowds (interpolated or held).
    pub bones_animated: u64,
    /// Threads the frame could use.
    pub threads: u32,
}

#[derive(Clone, Copy, Debug)]
struct ObjectState {
    share: BudgetShare,
    /// Simulated time owed to a cloth (its `dt` may differ from the frame's), s.
    debt: f64,
    /// The frame that last stepped it (objects not stepped in a frame are forgotten).
    seen: u64,
    /// The evaluation phase it was given (see `balance_phases`).
    phase: Option<u32>,
    /// The step group it was given, of how many (see `stagger_steps`).
    stagger: Option<(u32, u32)>,
    /// The settled cost of its last step, cost units (a staggered cloth's estimate between
    /// its steps).
    step_settled_units: f64,
    /// Solver steps per frame of a staggered cloth: the frame's `dt` over its own (at the last
    /// `stagger_steps`; 1/2.4 at 144 Hz with 60 Hz cloths, though it joins one of 2 groups).
    step_rate: f64,
    /// The cloth's [`AdaptiveCloth::parts_lost`] when it joined the budget: once its host has
    /// made a part be measured again, its evaluations are no longer split.
    parts_lost: Option<u64>,
    /// Time its regroupings (`stagger_steps`) added to what it owes, in all, s.
    regrouped: f64,
}

impl Default for ObjectState {
    fn default() -> Self {
        ObjectState {
            share: BudgetShare::default(),
            debt: 0.0,
            seen: u64::MAX,
            phase: None,
            stagger: None,
            step_rate: 1.0,
            parts_lost: None,
            step_settled_units: 0.0,
            regrouped: 0.0,
        }
    }
}

/// A frame in progress (from [`FrameBudgeter::begin_frame`] to [`FrameBudgeter::end_frame`]).
#[derive(Debug)]
pub struct Frame {
    start: Instant,
    stats: WorldStepStats,
    objects: Vec<ObjectFrame>,
    /// Cost units the cloths are committed to (see [`FrameCost`]).
    committed_units: f64,
    /// Cost units of crowds and evaluations.
    fluctuating_units: f64,
    /// Cost units of the crowds that spend the shared bound.
    crowd_units: f64,
    /// Cost units of the cloths' transitions in flight.
    transition_units: f64,
    /// How each cloth under the shared bound answers it.
    responses: Vec<ClothResponse>,
    first_error: Option<WorldError>,
}

impl Frame {
    /// The error bound of this frame, px.
    pub fn error_bound_px(&self) -> f32 {
        self.stats.error_bound_px
    }

    fn fail(&mut self, e: impl Into<WorldError>) {
        if self.first_error.is_none() {
            self.first_error = Some(e.into());
        }
    }
}

/// Spends one frame budget across a world's cloths and crowds (see the module docs and
/// [`WorldBudget`]).
#[derive(Debug)]
pub struct FrameBudgeter {
    settings: WorldBudget,
    controller: ErrorBoundController,
    pool: Option<rayon::ThreadPool>,
    objects: BTreeMap<ObjectKey, ObjectState>,
    frames: u64,
    /// Frames in the current controller window: `update_frames` cloth feedback intervals'
    /// worth, so `update_frames` times the frames per cloth step when frames are shorter than
    /// the cloths' step (see `start_window`).
    window_frames: u32,
    /// Frames left in the current controller window (0: the next frame starts one).
    window_left: u32,
    /// Measured wall milliseconds per cost unit, smoothed over frames (to turn a millisecond
    /// target into units for the transition allowance).
    ms_per_unit: Option<f64>,
    /// Wall milliseconds against cost units over recent frames (the marginal cost the
    /// transition allowance converts time left with).
    time_fit: TimeFit,
    last: WorldStepStats,
    last_objects: Vec<ObjectFrame>,
    /// Spinning workers between phases and frames (`WorldBudget::spin_wait_ms`).
    warm: KeepWarm,
}

impl FrameBudgeter {
    /// A budgeter with these settings (validated; a pool is started for `threads ≥ 2`).
    pub fn new(settings: WorldBudget) -> Result<FrameBudgeter, WorldError> {
        settings.validate()?;
        Ok(FrameBudgeter {
            pool: make_pool(settings.threads)?,
            controller: ErrorBoundController::new(&settings),
            settings,
            objects: BTreeMap::new(),
            frames: 0,
            window_frames: settings.update_frames,
            window_left: 0,
            ms_per_unit: None,
            time_fit: TimeFit::default(),
            last: WorldStepStats::default(),
            last_objects: Vec::new(),
            warm: KeepWarm::default(),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &WorldBudget {
        &self.settings
    }

    /// Replaces the settings (refused, with nothing changed, if invalid). The controller keeps
    /// its bound when only the target's value changes; a new kind of target, new bound limits or
    /// a new initial bound restart it.
    pub fn set_settings(&mut self, settings: WorldBudget) -> Result<(), WorldError> {
        settings.validate()?;
        let pool = if settings.threads != self.settings.threads {
            Some(make_pool(settings.threads)?)
        } else {
            None
        };
        let same_kind = std::mem::discriminant(&settings.target)
            == std::mem::discriminant(&self.settings.target);
        let same_limits = settings.initial_error_px == self.settings.initial_error_px
            && settings.min_error_px == self.settings.min_error_px
            && settings.max_error_px == self.settings.max_error_px;
        if !(same_kind && same_limits) {
            self.controller = ErrorBoundController::new(&settings);
            self.window_left = 0;
        }
        if let Some(p) = pool {
            self.warm.release();
            self.pool = p;
        }
        self.settings = settings;
        Ok(())
    }

    /// Sets how an object takes part in the budget (validated). The caller checks the object
    /// exists; a share set for an object that is then never stepped is forgotten.
    pub fn set_share(&mut self, key: ObjectKey, share: BudgetShare) -> Result<(), WorldError> {
        share.validate()?;
        let state = self.objects.entry(key).or_default();
        state.share = share;
        Ok(())
    }

    /// How an object takes part in the budget (the default for one never set).
    pub fn share(&self, key: ObjectKey) -> BudgetShare {
        self.objects
            .get(&key)
            .map_or_else(BudgetShare::default, |s| s.share)
    }

    /// Forgets an object (call when it is destroyed).
    pub fn forget(&mut self, key: ObjectKey) {
        self.objects.remove(&key);
    }

    /// The current shared error bound, px.
    pub fn error_bound_px(&self) -> f32 {
        self.controller.bound_px()
    }

    /// What the last frame did.
    pub fn last_stats(&self) -> &WorldStepStats {
        &self.last
    }

    /// What each object did in the last frame (crowds first, then cloths, in the order given).
    pub fn last_objects(&self) -> &[ObjectFrame] {
        &self.last_objects
    }

    /// Threads a frame uses.
    pub fn threads(&self) -> usize {
        match (&self.pool, self.settings.threads) {
            (Some(p), _) => p.current_num_threads(),
            (None, 1) => 1,
            (None, _) => rayon::current_num_threads(),
        }
    }

    fn serial(&self) -> bool {
        self.settings.threads == 1
    }

    /// Runs one phase of the frame on the frame's threads; spinning workers are released
    /// before it and armed again after it (`WorldBudget::spin_wait_ms`).
    fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        self.warm.release();
        let r = match &self.pool {
            Some(p) => p.install(f),
            None => f(),
        };
        // Until the next phase every worker spins (the calling thread waits while a phase
        // runs on the pool, and a worker asleep when a phase spawns its jobs starts late), but
        // the calling thread itself where it is one of the current pool's workers.
        let inside = self.pool.is_none() && rayon::current_thread_index().is_some();
        let workers = self.threads() - inside as usize;
        self.keep_warm(workers);
        r
    }

    /// Arms `workers` spinners for `spin_wait_ms` (none when serial).
    fn keep_warm(&self, workers: usize) {
        if !self.serial() {
            let limit = Duration::from_secs_f32(self.settings.spin_wait_ms * 1e-3);
            self.warm.arm(self.pool.as_ref(), workers, limit);
        }
    }

    /// Starts a frame: fixes its error bound.
    pub fn begin_frame(&mut self) -> Frame {
        self.frames += 1;
        Frame {
            start: Instant::now(),
            stats: WorldStepStats {
                frame: self.frames,
                error_bound_px: self.controller.bound_px(),
                threads: self.threads() as u32,
                ..WorldStepStats::default()
            },
            objects: Vec::new(),
            committed_units: 0.0,
            fluctuating_units: 0.0,
            crowd_units: 0.0,
            transition_units: 0.0,
            responses: Vec::new(),
            first_error: None,
        }
    }

    /// The bound an object runs under this frame, or `None` when the world leaves its detail
    /// alone (its own settings, or no world budget).
    fn bound_for(&self, share: BudgetShare, frame: &Frame) -> Option<f32> {
        match (share, self.settings.target) {
            (_, BudgetTarget::None) => None,
            (BudgetShare::Shared { weight }, _) => Some(frame.stats.error_bound_px / weight),
            _ => None,
        }
    }

    /// Advances every crowd by `dt` seconds seen through `view`, each split across the threads.
    /// A crowd that fails is reported by [`FrameBudgeter::end_frame`]; the others still advance.
    pub fn advance_crowds<'a>(
        &mut self,
        frame: &mut Frame,
        dt: f32,
        view: &View,
        crowds: impl IntoIterator<Item = (ObjectKey, &'a mut Crowd)>,
    ) {
        let mut jobs = self.prepare_crowds(frame, crowds);
        let ms = self.install(|| run_crowds(&mut jobs, dt, view));
        frame.stats.crowd_ms += ms;
        self.account_crowds(frame, jobs);
    }

    /// Steps every cloth through `dt` seconds of simulated time (as many of its own solver
    /// steps as fit, at most `max_cloth_steps`), seen through `view`, the cloths in parallel.
    /// Frames shorter than a cloth's step (a 120 Hz host, 60 Hz cloths) spread the cloths'
    /// steps over the frames, each within a step of the world's time (see `stagger_steps`),
    /// and each one's evaluation over the frames up to its step, measured in parts ahead of it
    /// (see `balance_phases`).
    /// Each cloth's detail follows its share first. A cloth that fails is reported by
    /// [`FrameBudgeter::end_frame`]; the others still step.
    pub fn step_cloths<'a>(
        &mut self,
        frame: &mut Frame,
        dt: f32,
        view: &View,
        cloths: impl IntoIterator<Item = (ObjectKey, &'a mut AdaptiveCloth)>,
    ) {
        let mut jobs = self.prepare_cloths(frame, dt, cloths);
        let (model, threads) = (self.settings.cost.cloth, self.cloth_threads());
        let ms = self.install(|| run_cloths(&mut jobs, view, model, threads));
        frame.stats.cloth_ms += ms;
        self.account_cloths(frame, jobs);
    }

    /// [`FrameBudgeter::advance_crowds`] and [`FrameBudgeter::step_cloths`] in one phase, for a
    /// world whose cloths do not follow its crowds' poses: the crowds start on one thread while
    /// the others step cloths, and whichever thread is free takes what is left, so neither kind
    /// waits at a barrier for the other's last job. Same results as the two phases in turn;
    /// [`WorldStepStats::crowd_ms`] is then the crowds' own time inside the phase and
    /// [`WorldStepStats::cloth_ms`] the whole phase's.
    pub fn advance_together<'a, 'b>(
        &mut self,
        frame: &mut Frame,
        dt: f32,
        view: &View,
        crowds: impl IntoIterator<Item = (ObjectKey, &'a mut Crowd)>,
        cloths: impl IntoIterator<Item = (ObjectKey, &'b mut AdaptiveCloth)>,
    ) {
        let mut crowd_jobs = self.prepare_crowds(frame, crowds);
        let mut cloth_jobs = self.prepare_cloths(frame, dt, cloths);
        let (model, threads) = (self.settings.cost.cloth, self.cloth_threads());
        let (crowd_ms, ms) = self
            .install(|| run_together(&mut crowd_jobs, &mut cloth_jobs, dt, view, model, threads));
        frame.stats.crowd_ms += crowd_ms;
        frame.stats.cloth_ms += ms;
        self.account_crowds(frame, crowd_jobs);
        self.account_cloths(frame, cloth_jobs);
    }

    /// Threads the cloth phase shares its cloths out to (1 when serial).
    fn cloth_threads(&self) -> usize {
        if self.serial() {
            1
        } else {
            self.threads().max(1)
        }
    }

    /// Each crowd's share applied (its LOD mode or bound), ready to advance.
    fn prepare_crowds<'a>(
        &mut self,
        frame: &mut Frame,
        crowds: impl IntoIterator<Item = (ObjectKey, &'a mut Crowd)>,
    ) -> Vec<CrowdJob<'a>> {
        let parallel = !self.serial();
        let mut jobs = Vec::new();
        for (key, crowd) in crowds {
            let state = self.objects.entry(key).or_default();
            state.seen = self.frames;
            let share = state.share;
            let bound = self.bound_for(share, frame);
            let applied = match share {
                BudgetShare::FullDetail if crowd.lod() != LodMode::Off => {
                    crowd.set_lod(LodMode::Off)
                }
                _ => match bound {
                    Some(b) if crowd.lod() != (LodMode::ErrorBound { max_error_px: b }) => {
                        crowd.set_error_bound_px(b)
                    }
                    _ => Ok(()),
                },
            };
            if let Err(e) = applied {
                frame.fail(e);
            }
            crowd.set_parallel(parallel);
            jobs.push(CrowdJob {
                key,
                crowd,
                bound: bound.unwrap_or(0.0),
                share,
                outcome: Ok(animlod::FrameStats::default()),
            });
        }
        jobs
    }

    /// Counts what the crowds did into the frame.
    fn account_crowds(&self, frame: &mut Frame, jobs: Vec<CrowdJob<'_>>) {
        let cost = self.settings.cost;
        for job in jobs {
            match job.outcome {
                Ok(s) => {
                    let units = s.bones_interpolated as f64 * cost.bone_sampled as f64
                        + s.bones_concatenated as f64 * cost.bone_concatenated as f64
                        + s.characters as f64 * cost.character as f64;
                    let animated = s.bones_interpolated + s.bones_held;
                    frame.stats.crowds += 1;
                    frame.stats.cost_units += units;
                    frame.fluctuating_units += units;
                    if matches!(job.share, BudgetShare::Shared { .. }) {
                        frame.crowd_units += units;
                    }
                    frame.stats.bones_interpolated += s.bones_interpolated;
                    frame.stats.bones_animated += animated;
                    frame.objects.push(ObjectFrame {
                        key: job.key,
                        units,
                        detail: s.bones_interpolated,
                        full_detail: animated,
                        bound_px: job.bound,
                        share: job.share,
                    });
                }
                Err(e) => frame.fail(e),
            }
        }
    }

    /// Each cloth's share applied, its steps for `dt` counted, evaluation phases balanced and
    /// operations capped: the cloth jobs of the frame.
    fn prepare_cloths<'a>(
        &mut self,
        frame: &mut Frame,
        dt: f32,
        cloths: impl IntoIterator<Item = (ObjectKey, &'a mut AdaptiveCloth)>,
    ) -> Vec<ClothJob<'a>> {
        let mut jobs: Vec<ClothJob<'a>> = Vec::new();
        for (key, cloth) in cloths {
            let state = self.objects.entry(key).or_default();
            state.seen = self.frames;
            state.parts_lost.get_or_insert(cloth.parts_lost());
            let share = state.share;
            let bound = self.bound_for(share, frame);
            if let Err(e) = apply_cloth_share(cloth, share, bound) {
                frame.fail(e);
            }
            jobs.push(ClothJob {
                key,
                cloth,
                steps: 0,
                part: None,
                split_next: false,
                bound: bound.unwrap_or(0.0),
                share,
                outcome: Ok(StepCost::default()),
            });
        }
        if self.window_left == 0 {
            self.start_window(&jobs, dt);
        }
        // Groups and phases are redrawn every `update_frames` frames, as the cuts change (at
        // the controller's pace when frames are as long as the cloths' step; more often than
        // its windows when they are shorter: redrawn every window of 10 frames at 120 Hz, the
        // groups' work drifted apart as the cuts grew, 90% of frame pairs within 12% against
        // 5%).
        let redraw = (self.frames - 1).is_multiple_of(self.settings.update_frames as u64);
        if redraw {
            self.stagger_steps(&jobs, dt);
        }
        let max_steps = self.settings.max_cloth_steps;
        for job in &mut jobs {
            let state = self.objects.entry(job.key).or_default();
            let cloth_dt = job.cloth.body().settings().solver.dt as f64;
            let owed = state.debt + dt as f64;
            let mut steps = (owed / cloth_dt + 1e-6).floor().max(0.0) as u32;
            // A staggered cloth may owe less than nothing: it waits a cycle more (see
            // `stagger_steps`).
            let least = if state.stagger.is_some() {
                -cloth_dt
            } else {
                0.0
            };
            if steps > max_steps {
                steps = max_steps;
                state.debt = 0.0;
            } else {
                state.debt = (owed - steps as f64 * cloth_dt).max(least);
            }
            job.steps = steps;
        }
        if redraw {
            self.balance_phases(&mut jobs);
        }
        // A cloth stepping on every frame measures half of its next step's evaluation after
        // this frame's steps (the state that step will see), the step the other half. A
        // staggered cloth not stepping now measures the next part of its next step's
        // evaluation when that step evaluates and is fewer than `spread` frames away: after
        // this frame, `(spread − until) / spread` of its nodes (with frames of varying length
        // the step may come sooner: it then finishes what is left).
        for job in &mut jobs {
            let Some(state) = self.objects.get(&job.key) else {
                continue;
            };
            if !splits(state, job.cloth) {
                continue;
            }
            match state.stagger {
                None => job.split_next = true,
                Some((m, group)) if job.steps == 0 && job.cloth.evaluation_due() => {
                    let (m, group) = (m as u64, group as u64);
                    let spread = m.min(MAX_SPREAD_FRAMES);
                    let until = group_wait(self.frames, m, group);
                    if until < spread {
                        job.part = Some((spread - until) as f32 / spread as f32);
                    }
                }
                Some(_) => {}
            }
        }
        if let Err(e) = self.cap_transitions(&mut jobs) {
            frame.fail(e);
        }
        jobs
    }

    /// Counts what the cloths did into the frame.
    fn account_cloths(&mut self, frame: &mut Frame, jobs: Vec<ClothJob<'_>>) {
        for job in jobs {
            let work = match job.outcome {
                Ok(w) => w,
                Err(e) => {
                    frame.fail(e);
                    StepCost::default()
                }
            };
            let c = &*job.cloth;
            let nodes = c.node_count() as f64;
            let units = work.units;
            // What the settled part of a step will cost once the cut reaches the node count the
            // last evaluation chose (see `FrameCost`); evaluations and transitions fluctuate.
            // A cloth staggered over `m` frames (`stagger_steps`) steps on about one of them:
            // its settled cost counts at its rate per frame (its last step's times the steps
            // per frame, 1/2.4 at 144 Hz with 60 Hz cloths), on every frame, so the estimate
            // does not swing with which group stepped last.
            let state = self.objects.entry(job.key).or_default();
            let (settled, steps_per_frame) = match state.stagger {
                Some((m, _)) if m >= 2 => {
                    if work.steps > 0 {
                        state.step_settled_units = work.settled_units / work.steps as f64;
                    }
                    let rate = state.step_rate;
                    (state.step_settled_units * rate, rate)
                }
                _ => (work.settled_units, work.steps as f64),
            };
            let chosen = c.stats().projected_nodes;
            let committed = if c.feedback().is_some() && chosen > 0 && nodes > 0.0 {
                settled * (chosen as f64 / nodes).min(full_ratio(c))
            } else {
                settled
            };
            frame.committed_units += committed;
            frame.fluctuating_units += units - work.settled_units;
            frame.transition_units += work.transition_units;
            if let (BudgetShare::Shared { weight }, Some(curve)) = (job.share, c.bound_curve())
                && nodes > 0.0
            {
                // The fixed cost of a step does not scale with the nodes.
                let fixed = steps_per_frame * self.settings.cost.cloth.fixed * 1e9;
                frame.responses.push(ClothResponse {
                    curve: curve.clone(),
                    units_per_node: (settled - fixed).max(0.0) / nodes,
                    weight,
                    full_nodes: c.hierarchy().vertex_count() as f64,
                });
            }
            let (steps, evaluations) = (work.steps, work.evaluations);
            let full = c.hierarchy().vertex_count() as u64;
            frame.stats.cloths += 1;
            frame.stats.cloth_steps += steps;
            frame.stats.evaluations += evaluations as u32;
            frame.stats.cost_units += units;
            frame.stats.cloth_nodes += c.node_count() as u64;
            frame.stats.cloth_full_nodes += full;
            frame.objects.push(ObjectFrame {
                key: job.key,
                units,
                detail: c.node_count() as u64,
                full_detail: full,
                bound_px: job.bound,
                share: job.share,
            });
        }
    }

    /// Ends the frame: measures it, feeds the controller, forgets objects that were not stepped,
    /// and returns its statistics, or the first error an object reported (every other object
    /// still advanced; the statistics are kept either way).
    pub fn end_frame(&mut self, mut frame: Frame) -> Result<WorldStepStats, WorldError> {
        frame.stats.wall_ms = frame.start.elapsed().as_secs_f64() * 1e3;
        // Until the next frame all workers but one spin: the host's thread needs a core.
        self.warm.release();
        self.keep_warm(self.threads().saturating_sub(1));
        // What the budget's clock reads for this frame, ms.
        let ms = match self.settings.clock {
            FrameClock::Wall => frame.stats.wall_ms,
            FrameClock::Modelled { ns_per_unit } => frame.stats.cost_units * ns_per_unit * 1e-6,
        };
        let measured = match self.settings.target {
            BudgetTarget::None => None,
            BudgetTarget::Milliseconds(target) => Some((ms, target as f64)),
            BudgetTarget::CostUnits(target) => Some((frame.stats.cost_units, target)),
        };
        if frame.stats.cost_units > 0.0 {
            let r = frame.stats.wall_ms / frame.stats.cost_units;
            self.ms_per_unit = Some(self.ms_per_unit.map_or(r, |m| m + 0.1 * (r - m)));
            self.time_fit
                .add(frame.stats.cost_units, frame.stats.wall_ms);
        }
        if let Some((cost, target)) = measured {
            frame.stats.measured = cost;
            let in_ms = matches!(self.settings.target, BudgetTarget::Milliseconds(_));
            let seen = FrameCost {
                committed_units: frame.committed_units,
                fluctuating_units: frame.fluctuating_units,
                crowd_units: frame.crowd_units,
                transition_units: frame.transition_units,
                units: frame.stats.cost_units,
                ms,
            };
            // The controller's window is the budgeter's (`start_window`).
            let window = WorldBudget {
                update_frames: self.window_frames.max(1),
                ..self.settings
            };
            self.controller
                .observe(seen, &frame.responses, target, in_ms, &window);
        }
        self.window_left = self.window_left.saturating_sub(1);
        let now = self.frames;
        // Shares set since the last frame for objects not yet stepped have `seen == MAX`.
        self.objects
            .retain(|_, s| s.seen == now || s.seen == u64::MAX);
        self.last = frame.stats;
        self.last_objects = frame.objects;
        match frame.first_error {
            Some(e) => Err(e),
            None => Ok(frame.stats),
        }
    }
}

impl FrameBudgeter {
    /// The frame target in cost units (a millisecond target converted at the measured ms per
    /// unit, or through the modelled clock), or `None` without a budget or a measurement yet.
    fn target_units(&self) -> Option<f64> {
        match (self.settings.target, self.settings.clock) {
            (BudgetTarget::None, _) => None,
            (BudgetTarget::CostUnits(u), _) => Some(u),
            (BudgetTarget::Milliseconds(ms), FrameClock::Modelled { ns_per_unit }) => {
                Some(ms as f64 * 1e6 / ns_per_unit)
            }
            (BudgetTarget::Milliseconds(ms), FrameClock::Wall) => {
                self.ms_per_unit.map(|r| ms as f64 / r)
            }
        }
    }

    /// Caps the operations the cloths due to evaluate this frame may begin, so that the
    /// transitions in flight stay within `transition_share` of the target plus what the last
    /// frame left unspent: what is left of that allowance after the transitions already
    /// blending, shared equally in cost units (so a cloth at fewer substeps, whose transitions
    /// cost less, may begin more; at least one operation
    /// each, at most what the cloth's settings with the automatic `max_ops` allow at its node
    /// count: [`FeedbackSettings::ops_per_evaluation`]; the cap set here replaces `max_ops`, so
    /// the automatic value, not the last cap, bounds the next).
    /// Cloths that keep their own budget, and worlds without one, are left alone.
    fn cap_transitions(&self, jobs: &mut [ClothJob<'_>]) -> Result<(), WorldError> {
        let (Some(target), share) = (self.target_units(), self.settings.transition_share) else {
            return Ok(());
        };
        let model = self.settings.cost.cloth;
        // What one transition in flight costs each cloth's step, units (it grows with the
        // cloth's substeps).
        let per_transition = |j: &ClothJob<'_>| {
            model.per_transition_seconds(j.cloth.body().settings().solver.substeps) * 1e9
        };
        if share <= 0.0 || model.per_transition_seconds(1) <= 0.0 {
            return Ok(());
        }
        let shared = |j: &ClothJob<'_>| matches!(j.share, BudgetShare::Shared { .. });
        // Begins operations this frame: an evaluation finished in a step (a part measured
        // ahead of one begins none).
        let evaluates = |j: &ClothJob<'_>| j.steps > 0 && j.cloth.evaluation_due();
        // A staggered cloth's transitions cost the frames it steps on, about one in `m`.
        let per_frame = |j: &ClothJob<'_>| {
            self.objects
                .get(&j.key)
                .filter(|s| s.stagger.is_some())
                .map_or(1.0, |s| s.step_rate)
        };
        let in_flight: f64 = jobs
            .iter()
            .map(|j| j.cloth.interpolations() as f64 * per_transition(j) * per_frame(j))
            .sum();
        // Unspent budget is room too: a cut far under its target may move fast. Under a
        // wall-clock millisecond target the time left is converted at what one more unit costs
        // (the fitted slope), not at the average (which a frame's fixed costs inflate).
        let headroom = match (self.settings.target, self.settings.clock) {
            (BudgetTarget::Milliseconds(ms), FrameClock::Wall) => self
                .time_fit
                .marginal_ms_per_unit()
                .map_or(0.0, |b| (ms as f64 - self.last.wall_ms) / b),
            _ => target - self.last.cost_units,
        }
        .max(0.0);
        // The allowance in cost units, less what the transitions in flight spend.
        let room = (share as f64 * target + headroom - in_flight).max(0.0);
        let due = jobs.iter().filter(|j| shared(j) && evaluates(j)).count();
        if due == 0 {
            return Ok(());
        }
        let fair = room / due as f64;
        for j in jobs.iter_mut().filter(|j| shared(j) && evaluates(j)) {
            let Some(&f) = j.cloth.feedback() else {
                continue;
            };
            let auto = FeedbackSettings { max_ops: 0, ..f };
            let ops = (fair / (per_transition(j) * per_frame(j))).floor() as usize;
            let each = ops.clamp(1, auto.ops_per_evaluation(j.cloth.node_count()));
            if f.max_ops != each {
                j.cloth
                    .set_feedback(Some(FeedbackSettings { max_ops: each, ..f }))?;
            }
        }
        Ok(())
    }

    /// Starts a controller window: `update_frames` frames, times the frames per cloth step
    /// when a frame is shorter than the cloths' step (the largest ratio, rounded, over the
    /// cloths). The window is what lets every cloth answer a bound before it moves again (a
    /// cloth evaluates every `interval` of its steps); at 120 Hz with 60 Hz cloths a window of
    /// `update_frames` frames saw half of them evaluate, the bound moved on the other half's
    /// stale curves, and it swung by 30–70% from update to update on the world tests' scene.
    fn start_window(&mut self, jobs: &[ClothJob<'_>], dt: f32) {
        let per_step = jobs
            .iter()
            .map(|j| frames_per_step(j.cloth, dt))
            .max()
            .unwrap_or(1);
        self.window_frames = self.settings.update_frames.saturating_mul(per_step);
        self.window_left = self.window_frames;
    }

    /// Spreads the cloths' solver steps over the frames when a frame is shorter than their step
    /// (a 120 Hz host stepping 60 Hz cloths): with `m` frames per step (the ratio rounded), each
    /// cloth joins one of `m` groups that step on different frames, largest first (links and
    /// nodes now, ties by key: deterministic) into the group with the least work, so every
    /// frame steps about `1/m` of the cloth work instead of all of it on every `m`-th frame and
    /// none between. A cloth given a new group has its owed time set so that it steps on the
    /// group's frames: of the two settings one cloth step apart, the one that keeps the time
    /// its regroupings added or dropped in all nearest zero, so its simulated time never
    /// drifts from the world's by more than a step however often it is regrouped. Frames as
    /// long as a step or longer (`m` = 1) are left alone. Run at the first frame of each
    /// controller window, as the cuts change. The groups' frames are exact when a step is a
    /// whole number of frames; with frame times that vary (or a ratio such as 2.4 at 144 Hz)
    /// the cloths still step when they owe a step, and groups can drift onto the same frames
    /// until a regrouping separates them.
    fn stagger_steps(&mut self, jobs: &[ClothJob<'_>], dt: f32) {
        if dt.is_nan() || dt <= 0.0 {
            return;
        }
        let ratio = |j: &ClothJob<'_>| frames_per_step(j.cloth, dt);
        let work = |j: &ClothJob<'_>| j.cloth.link_count() + j.cloth.node_count();
        let mut order = Vec::new();
        for (i, job) in jobs.iter().enumerate() {
            if ratio(job) >= 2 {
                order.push(i);
            } else if let Some(state) = self.objects.get_mut(&job.key) {
                state.stagger = None;
            }
        }
        order.sort_by_key(|&i| {
            (
                ratio(&jobs[i]),
                std::cmp::Reverse(work(&jobs[i])),
                jobs[i].key,
            )
        });
        // Work per (frames per step, group).
        let mut load: BTreeMap<(u32, u32), usize> = BTreeMap::new();
        for i in order {
            let (job, m) = (&jobs[i], ratio(&jobs[i]));
            let load_of = |g: u32| load.get(&(m, g)).copied().unwrap_or(0);
            let lightest = (0..m).min_by_key(|&g| (load_of(g), g)).unwrap_or(0);
            // A cloth stays in its group unless that group already carries more than the
            // lightest by the cloth's own work (moving it then evens the two): each regrouping
            // shifts its steps by up to a frame.
            let group = match self.objects.get(&job.key).and_then(|s| s.stagger) {
                Some((had, g)) if had == m && load_of(g) <= load_of(lightest) + work(job) => g,
                _ => lightest,
            };
            *load.entry((m, group)).or_default() += work(job);
            let state = self.objects.entry(job.key).or_default();
            state.step_rate = dt as f64 / job.cloth.body().settings().solver.dt as f64;
            if state.stagger != Some((m, group)) {
                // Owed time with which it steps on the frames `f` with `(f + group) % m ==
                // m − 1`, or that less one step (it waits a cycle more) or plus one (it takes
                // a step more on the way).
                let cloth_dt = job.cloth.body().settings().solver.dt as f64;
                let on = ((self.frames + group as u64) % m as u64) as f64 * dt as f64;
                let debt = [on, on - cloth_dt, on + cloth_dt]
                    .into_iter()
                    .min_by(|a, b| {
                        let drift = |d: f64| (state.regrouped + d - state.debt).abs();
                        drift(*a).total_cmp(&drift(*b))
                    })
                    .unwrap_or(on);
                state.regrouped += debt - state.debt;
                state.debt = debt;
                state.stagger = Some((m, group));
            }
        }
    }

    /// Spreads the cloths' feedback evaluations over the frames so that every frame costs
    /// about as much: an evaluation costs most of a step, and all cloths evaluating on the same
    /// frame make every k-th frame twice as long. Largest cloth first (by the node counts now,
    /// ties by key: deterministic) gets the phase whose evaluation lands on the frame with the
    /// least cost so far (longest-processing-time scheduling; an evaluation costs
    /// `CostModel::evaluated_node` per node), ties to the lowest phase. A cloth evaluates every
    /// `interval` of its steps, and one staggered to step every `m` frames (`stagger_steps`)
    /// every `m · interval` frames, so the frame is the slot: the frames until its next
    /// evaluation under each phase, within its cycle of `m · interval` (cloths of different
    /// cycles do not share slots). An error-bound evaluation is measured in parts
    /// ([`AdaptiveCloth::evaluate_ahead_part`]: nothing of a cloth moves between its steps): a
    /// cloth stepping every frame measures half of it after its step in the frame before, a
    /// staggered one `m` equal parts on the `m − 1` frames before its step and in the step's
    /// (at most [`MAX_SPREAD_FRAMES`]); its phase is the one whose frames carry the least cost
    /// in all (then the least at the fullest: by the fullest alone, a frame whose neighbours
    /// were full stayed empty, one frame in five 15% light), and the frames start loaded with
    /// the steps of the group that steps on them. Run every `update_frames` frames, as the cuts
    /// change.
    fn balance_phases(&mut self, jobs: &mut [ClothJob<'_>]) {
        // What an evaluation costs each cloth (it measures every simulated node) and a step of
        // a staggered cloth (its last settled step), cost units.
        let per_node = self.settings.cost.cloth.evaluated_node * 1e9;
        let evaluation = |j: &ClothJob<'_>| per_node * j.cloth.node_count() as f64;
        let mut order: Vec<usize> = (0..jobs.len()).collect();
        order.sort_by_key(|&i| (std::cmp::Reverse(jobs[i].cloth.node_count()), jobs[i].key));
        // Cost units per (cycle, frames from now): the frames' steps of staggered cloths
        // first, so that the largest evaluations land on the frames whose step group is
        // lightest, then the evaluations.
        let mut load: BTreeMap<(u64, u64), f64> = BTreeMap::new();
        for job in jobs.iter() {
            let interval = job.cloth.feedback().map_or(1, |f| f.interval).max(1) as u64;
            let Some(state) = self.objects.get(&job.key) else {
                continue;
            };
            let Some((m, group)) = state.stagger.filter(|s| s.0 >= 2) else {
                continue;
            };
            let (m, group) = (m as u64, group as u64);
            let wait = group_wait(self.frames, m, group);
            for t in 0..m * interval {
                if t % m == wait {
                    *load.entry((m * interval, t)).or_default() += state.step_settled_units;
                }
            }
        }
        for i in order {
            let job = &mut jobs[i];
            let interval = job.cloth.feedback().map_or(1, |f| f.interval).max(1) as u64;
            let state = self.objects.entry(job.key).or_default();
            let (m, group) = state.stagger.map_or((1, 0), |(m, g)| (m as u64, g as u64));
            // Frames until its next step: this frame when it steps now, else its group's next.
            let first = if job.steps > 0 {
                0
            } else {
                group_wait(self.frames, m, group)
            };
            let steps = job.cloth.stats().steps;
            let slot = |p: u64| {
                let until = (interval - (steps + p) % interval) % interval;
                (m * interval, first + until * m)
            };
            // Its evaluation's parts: the `spread` frames up to its evaluating step (one frame,
            // the step's, unless staggered); the cycle repeats, so earlier frames wrap round.
            let cycle = m * interval;
            let spread = if !splits(state, job.cloth) {
                1
            } else if m == 1 {
                2
            } else {
                m.min(MAX_SPREAD_FRAMES)
            };
            let frames = |p: u64| {
                let t = slot(p).1 as i64;
                (0..spread).map(move |l| (t - l as i64).rem_euclid(cycle as i64) as u64)
            };
            // A phase's score: the cost its frames carry in all, then at the fullest.
            let score = |p: u64| {
                let loads = frames(p).map(|t| load.get(&(cycle, t)).copied().unwrap_or(0.0));
                loads.fold((0.0, 0.0), |(sum, max): (f64, f64), l| {
                    (sum + l, max.max(l))
                })
            };
            let phase = (0..interval)
                .map(|p| (score(p), p))
                .min_by(|((ta, fa), a), ((tb, fb), b)| {
                    ta.total_cmp(tb).then(fa.total_cmp(fb)).then(a.cmp(b))
                })
                .map_or(0, |(_, p)| p);
            let part = evaluation(job) / spread as f64;
            for t in frames(phase) {
                *load.entry((cycle, t)).or_default() += part;
            }
            let phase = phase as u32;
            if state.phase != Some(phase) {
                // Moving a cloth's phase shifts its next evaluation by less than an interval.
                job.cloth.set_evaluation_phase(phase);
                state.phase = Some(phase);
            }
        }
    }
}

/// The most frames a staggered cloth's evaluation is spread over (its step's and those before
/// it; 240 Hz with 60 Hz cloths uses 4): a bound on the work of spreading when frames are far
/// shorter than a step.
pub(crate) const MAX_SPREAD_FRAMES: u64 = 16;

/// Whether `cloth`'s evaluations are measured in parts: an error-bound budget's are (see
/// [`AdaptiveCloth::evaluate_ahead_part`]), unless its host has changed it between a part and
/// its step since it joined the budget (its parts would be lost every frame).
fn splits(state: &ObjectState, cloth: &AdaptiveCloth) -> bool {
    state.parts_lost == Some(cloth.parts_lost())
        && cloth
            .feedback()
            .is_some_and(|f| matches!(f.budget, crate::cloth::ClothBudget::MaxErrorPx(_)))
}

/// Frames from frame `now` until step group `group` of `m` next steps (0: it steps in frame
/// `now`): a group steps on the frames `f` with `(f + group) % m == m − 1` (see
/// `FrameBudgeter::stagger_steps`).
fn group_wait(now: u64, m: u64, group: u64) -> u64 {
    (m - 1 + m - (now + group) % m) % m
}

/// Frames of `dt` per solver step of `cloth`, rounded, at least 1 (and 1 for a `dt` that is
/// not positive).
fn frames_per_step(cloth: &AdaptiveCloth, dt: f32) -> u32 {
    let r = (cloth.body().settings().solver.dt / dt).round();
    if r.is_finite() && r >= 1.0 {
        r.min(1e6) as u32
    } else {
        1
    }
}

fn make_pool(threads: usize) -> Result<Option<rayon::ThreadPool>, WorldError> {
    if threads < 2 {
        return Ok(None);
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("slod-budget-{i}"))
        .build()
        .map(Some)
        .map_err(|e| WorldError::Threads(e.to_string()))
}
