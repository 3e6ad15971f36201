//! The feedback stage of the closed loop: per-particle BSWDF salience turned into a priority
//! per cut node, and the budget the evaluator spends. By subject: [`settings`] (budget, priority
//! model, parameters), the measurement here (BSWDF salience of every particle, then priorities
//! per cut node, in three parts: [`Feedback::prepare`], [`Feedback::compute`],
//! [`Feedback::conclude`]), [`deformation`] (the strain feature), [`memory`]
//! (salience memory) and [`radii`] (node sizes).
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), sections 4–5 (the feedback stage).

mod curve;
mod deformation;
mod deviation;
mod memory;
mod radii;
mod settings;

use glam::{Vec3, Vec4};
use salience::{BswdfJob, Neighbours, Nodes, ObjectMotion, View};
use softbody::TreeCutSoftBody;
use treecut::{Evaluator, NodeId};

use super::adaptive::UNDO_WINDOW_STEPS;
use super::controller::TimeController;
use super::error::ClothError;
pub use curve::BoundCurve;
use deformation::Strain;
use deviation::{Deviation, Frame};
use memory::Memory;
pub(crate) use radii::node_radii;
pub(crate) use settings::ERROR_BOUND_REFINE;
pub use settings::{
    AUTO_MAX_OPS_FRACTION, ClothBudget, FLICKER_GAIN_MAX, FLICKER_HALF_LIFE_SECONDS,
    FeedbackSettings, PACED_MAX_OPS, PriorityModel, compression_nodes,
};

/// Whether a node's level changed within the undo window (see [`Feedback::conclude`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Recent {
    /// Not recently.
    No,
    /// Refined recently (merging it would undo that).
    Refined,
    /// Coarsened recently (refining it would undo that).
    Coarsened,
}

/// The feedback loop's state: settings, evaluator, controller and reused buffers.
///
/// # Deformation, the feature the paper's BSWDF lacks
/// The paper's animation features are motion only, and it says itself that other features are
/// needed. Measured on its own scenario, motion alone is not enough: on the swinging net at 30%
/// it puts detail on the free edges (they flap, so they move unlike their neighbours) and ends
/// up no better than a uniform cut, because what a coarse cut gets wrong there is where the
/// cloth is *strained*: around the pinned corners, which carry the whole weight. A viewer sees
/// strain as a stretched pattern, and a coarse node misrepresents exactly those regions (the
/// missing degrees of freedom make the material effectively stiffer). So each node also gets
/// a deformation term, its links' mean relative length change times
/// [`FeedbackSettings::deformation_weight`], not weighted by the frustum (see `deformation`), and added to
/// the motion salience (so the sum may exceed 1; it is a priority, not a probability). With
/// it the feedback cut
/// has a lower error than uniform and random cuts (test
/// `swinging_net_at_30_percent_beats_uniform_and_random_cuts`); without it, it does not.
#[derive(Clone, Debug)]
pub(crate) struct Feedback {
    pub(crate) settings: FeedbackSettings,
    pub(crate) evaluator: Evaluator,
    pub(crate) controller: Option<TimeController>,
    /// Whether a world budget moves the bound of [`ClothBudget::MaxErrorPx`]: merges then wait
    /// for [`settings::SHARED_BOUND_MERGE`] of the bound, else [`settings::ERROR_BOUND_MERGE`].
    pub(crate) shared_bound: bool,
    /// Flicker control ([`FeedbackSettings::flicker_target`]): the base-2 logarithm of the
    /// factor the hysteresis is raised by now (0 to 6), the cloth's undone-operation count when
    /// it was last updated, and per evaluation within the undo window the step and the
    /// operations begun before it (oldest first).
    flicker_log2: f32,
    pub(crate) undone_seen: u64,
    flicker_window: std::collections::VecDeque<(u64, u64)>,
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    normals: Vec<Vec3>,
    hints: Vec<Vec3>,
    offsets: Vec<u32>,
    neighbours: Vec<u32>,
    salience: Vec<f32>,
    strain: Strain,
    /// Priority per hierarchy node (only active nodes' entries are meaningful).
    pub(crate) priorities: Vec<f32>,
    memory: Memory,
    deviation: Deviation,
    /// The node budget [`ClothBudget::MaxErrorPx`] derived at the last measurement.
    error_budget: Option<usize>,
    /// The node count [`ClothBudget::MaxErrorPx`] projects the cut to reach under its bound
    /// (refinement carried through every level the estimate says), at the last measurement.
    projected_nodes: Option<usize>,
    /// Under a world's shared bound: the node count the cut heads to at any bound, from the
    /// last measurement (shared with the world, which reads it when it moves the bound).
    pub(crate) curve: Option<std::sync::Arc<BoundCurve>>,
    /// Measurements made so far.
    measurements: u64,
    /// A measurement under [`ClothBudget::MaxErrorPx`] begun ahead of its step and carried out
    /// in parts ([`Feedback::measure_part`]); the next [`Feedback::compute`] finishes it.
    partial: Option<Partial>,
    /// Per hierarchy node: whether it is not a leaf and covers a rim vertex (computed at the
    /// first measurement; see [`FeedbackSettings::rim_weight`]).
    rim: Vec<bool>,
    /// Copies made by [`Feedback::prepare`]: each particle's node and mass, and the blend of a
    /// transition (its steps).
    nodes: Vec<NodeId>,
    masses: Vec<f32>,
    /// Per particle: whether its node is on the cut (not a child of a coarse in flight).
    on_cut: Vec<bool>,
    /// The body's links (for the strain term).
    links: Vec<softbody::LinkInfo>,
    blend_steps: u32,
    /// A measurement under way, not yet concluded (see [`Pending`]).
    pending: Option<Pending>,
}

impl Feedback {
    /// A loop for a cloth with `full_nodes` finest nodes, `hierarchy_len` nodes in all and
    /// `active` nodes now.
    pub(crate) fn new(
        settings: FeedbackSettings,
        hierarchy_len: usize,
        full_nodes: usize,
        active: usize,
    ) -> Feedback {
        let controller = match settings.budget {
            ClothBudget::TargetStepMs(ms) => Some(TimeController::new(
                ms as f64 * 1e-3,
                active,
                1,
                full_nodes,
                settings.controller,
            )),
            _ => None,
        };
        Feedback {
            evaluator: Evaluator::new(settings.evaluator_settings(full_nodes)),
            shared_bound: false,
            flicker_log2: 0.0,
            undone_seen: 0,
            flicker_window: std::collections::VecDeque::new(),
            settings,
            controller,
            positions: Vec::new(),
            velocities: Vec::new(),
            normals: Vec::new(),
            hints: Vec::new(),
            offsets: Vec::new(),
            neighbours: Vec::new(),
            salience: Vec::new(),
            strain: Strain::default(),
            priorities: vec![0.0; hierarchy_len],
            memory: Memory::new(hierarchy_len),
            deviation: Deviation::new(hierarchy_len),
            error_budget: None,
            projected_nodes: None,
            curve: None,
            measurements: 0,
            partial: None,
            rim: Vec::new(),
            nodes: Vec::new(),
            masses: Vec::new(),
            on_cut: Vec::new(),
            links: Vec::new(),
            blend_steps: 0,
            pending: None,
        }
    }

    /// The factor the evaluator's hysteresis is raised by at this evaluation (flicker control,
    /// [`FeedbackSettings::flicker_target`]; 1 without it, and under a time budget, whose
    /// undone operations follow its budget's moves, not noise: it keeps a dwell of the whole
    /// undo window instead). `ops` and `undone` are the cloth's operation and undone-operation
    /// counts so far, `now` its step count, `dt` its step.
    pub(crate) fn flicker_gain(&mut self, ops: u64, undone: u64, now: u64, dt: f32) -> f32 {
        let Some(target) = self.settings.flicker_target else {
            return 1.0;
        };
        if self.controller.is_some() {
            return 1.0;
        }
        self.flicker_window
            .retain(|&(step, _)| now - step <= UNDO_WINDOW_STEPS);
        let window_ops = self
            .flicker_window
            .front()
            .map_or(0, |&(_, before)| ops - before);
        self.flicker_window.push_back((now, ops));
        let new_undone = undone - self.undone_seen;
        self.undone_seen = undone;
        self.flicker_log2 = flicker_log2(
            self.flicker_log2,
            new_undone,
            window_ops,
            target,
            self.settings.interval as f32 * dt,
            UNDO_WINDOW_STEPS as f32 * dt,
        );
        self.flicker_log2.exp2()
    }

    /// The node budget now.
    pub(crate) fn node_budget(&self, full_nodes: usize) -> usize {
        match self.settings.budget {
            ClothBudget::Nodes(n) => n,
            ClothBudget::Compression(f) => compression_nodes(f, full_nodes),
            ClothBudget::TargetStepMs(_) => self
                .controller
                .as_ref()
                .map_or(full_nodes, TimeController::budget),
            ClothBudget::MaxErrorPx(_) => self.error_budget.unwrap_or(full_nodes),
        }
    }

    /// Gives the evaluator the settings [`Feedback::settings`] imply at the node budget now
    /// (a cloth of `full_nodes` finest nodes); an evaluation refines them further.
    pub(crate) fn sync_evaluator(&mut self, full_nodes: usize) {
        let budget = self.node_budget(full_nodes);
        self.evaluator
            .set_settings(self.settings.evaluator_settings(budget));
    }

    /// The node count the cut is heading to: under [`ClothBudget::MaxErrorPx`] the projection
    /// of the last measurement (see `error_priorities`), otherwise the node budget.
    pub(crate) fn projected_nodes(&self, full_nodes: usize) -> usize {
        match self.settings.budget {
            ClothBudget::MaxErrorPx(_) => self
                .projected_nodes
                .unwrap_or_else(|| self.node_budget(full_nodes)),
            _ => self.node_budget(full_nodes),
        }
    }

    /// Fills [`Feedback::rim`] for `h` once, when the rim weight is on (the rim is a property
    /// of the hierarchy, which never changes).
    fn refresh_rim(&mut self, h: &treecut::Hierarchy) {
        if self.settings.rim_weight > 0.0 && self.rim.len() != h.len() {
            self.rim = rim_nodes(h);
        }
    }

    /// The first of a measurement's three parts (a measurement: the BSWDF of every particle and
    /// from it the priority of every active node; under [`ClothBudget::MaxErrorPx`] the
    /// on-screen deviation alone, no normals, BSWDF or strain term, which that mode does not
    /// read), the only one that reads the body's particles and links: copies of what the measurement reads (positions, velocities, the neighbour
    /// table, the particles' nodes, masses and cut membership, the links for the strain term),
    /// the object's motion, and the view. [`Feedback::compute`] then reads only these copies and
    /// the hierarchy, so it can run while the body steps (see
    /// `FeedbackSettings::overlap_step`). Errors (a body whose state cannot be measured: no
    /// mass, a broken neighbour table) come from here, before anything changed.
    pub(crate) fn prepare(
        &mut self,
        body: &TreeCutSoftBody,
        node_normals: &[Vec3],
        node_radius: &[f32],
        view: &View,
        dt: f32,
    ) -> Result<(), ClothError> {
        self.pending = None;
        if matches!(self.settings.budget, ClothBudget::MaxErrorPx(_)) {
            // Under an error bound the priorities are the on-screen deviation alone: the
            // normals, the BSWDF and the strain term would be computed for nothing (they were:
            // about half of each evaluation). A measurement begun ahead (the copies and the
            // neighbour table are made) is finished as begun.
            if self.partial.is_none() {
                self.copy_state(body)?;
                let partial = self.begin_error_bound(body.hierarchy(), node_radius, view, dt);
                self.partial = Some(partial);
            }
            return Ok(());
        }
        self.partial = None;
        self.copy_state(body)?;
        self.hints.clear();
        self.hints
            .extend(self.nodes.iter().map(|&node| node_normals[node.index()]));
        self.masses.clear();
        self.masses.extend_from_slice(body.particle_masses());
        let object = ObjectMotion::centre_of_mass(&self.positions, &self.velocities, &self.masses)?;
        self.strain.added.clear();
        self.links.clear();
        if self.settings.deformation_weight > 0.0 {
            self.links.extend(body.links());
        }
        let cut = body.cut();
        self.on_cut.clear();
        self.on_cut
            .extend(self.nodes.iter().map(|&node| cut.is_on_cut(node)));
        self.pending = Some(Pending::Salience {
            view: *view,
            object,
            dt,
        });
        Ok(())
    }

    /// The second part of a measurement, most of its work: the on-screen deviation of
    /// the particles not measured ahead (under an error bound), or the normals, the BSWDF, the
    /// strain term, the deviation and the priorities (the cut's membership does not change in
    /// a step: only beginning an operation moves it). During a coarse in flight the cut holds
    /// the (virtual) parent while the particles are its children: the parent gets its
    /// children's largest priority, the same key the evaluator would use to merge them. Reads only the copies [`Feedback::prepare`] made and the
    /// hierarchy (which never changes), so it may run while the body steps. Does nothing
    /// unless a measurement was prepared.
    pub(crate) fn compute(
        &mut self,
        h: &treecut::Hierarchy,
        node_radius: &[f32],
    ) -> Result<(), ClothError> {
        let n = self.nodes.len();
        if let ClothBudget::MaxErrorPx(bound) = self.settings.budget
            && let Some(partial) = self.partial.take()
        {
            self.carry_on(h, node_radius, partial, n, true);
            self.pending = Some(Pending::Bound(partial, bound));
            return Ok(());
        }
        let Some(Pending::Salience { view, object, dt }) = self.pending else {
            return Ok(());
        };
        let nbrs = Neighbours::new(&self.offsets, &self.neighbours, n)?;
        self.normals.resize(n, Vec3::ZERO);
        salience::estimate_normals(&self.positions, &nbrs, &self.hints, &mut self.normals)?;
        let seen = if self.settings.view_dependent {
            view
        } else {
            canonical_view(&self.positions, &self.normals, object.centre, &view)
        };
        let job = BswdfJob {
            view: &seen,
            object,
            params: &self.settings.params,
            nodes: Nodes {
                positions: &self.positions,
                velocities: &self.velocities,
                normals: Some(&self.normals),
            },
            neighbours: nbrs,
        };
        self.salience.resize(n, 0.0);
        if self.settings.parallel && n >= 2 * salience::PARALLEL_CHUNK {
            salience::evaluate_parallel(&job, &mut self.salience)?;
        } else {
            salience::evaluate(&job, &mut self.salience)?;
        }
        if self.settings.motion_weight != 1.0 {
            let w = self.settings.motion_weight;
            self.salience.iter_mut().for_each(|s| *s *= w);
        }
        if self.settings.deformation_weight > 0.0 {
            self.strain.measure(
                &self.links,
                &self.positions,
                self.settings.deformation_weight,
            );
        }
        self.strain.add_to(&mut self.salience);
        if self.settings.priority == PriorityModel::ScreenDeviation {
            let decay = self.settings.memory_decay(dt);
            self.with_frame(h, node_radius, &view, dt, |f, frame| {
                f.deviation
                    .measure(frame, (&f.offsets, &f.neighbours), decay);
            });
        }
        let nodes = std::mem::take(&mut self.nodes);
        let deviation = self.settings.priority == PriorityModel::ScreenDeviation;
        let decay = self.settings.memory_decay(dt);
        let previous = self.memory.begin();
        for (i, &node) in nodes.iter().enumerate() {
            let remembered = self.memory.remembered(h, node, previous) * decay;
            self.salience[i] = self.salience[i].max(remembered);
            // Entries filled by maxima below start from zero.
            if let Some(p) = h.parent(node) {
                self.priorities[p.index()] = 0.0;
            }
        }
        let screen = self.settings.priority != PriorityModel::Salience;
        if screen {
            self.refresh_rim(h);
        }
        let rim_weight = self.settings.rim_weight;
        let rim = &self.rim;
        let strain = &self.strain.added;
        for (i, &node) in nodes.iter().enumerate() {
            let s = self.salience[i];
            self.memory.store(node, s);
            let px = if screen {
                seen.pixels_per_unit(self.positions[i])
            } else {
                1.0
            };
            let own = if deviation {
                self.deviation.particle_px[i]
            } else {
                0.0
            };
            let r_own = node_radius[node.index()];
            // On the rim the stretch term counts `1 + rim_weight` times.
            let rim_extra = rim_weight * strain.get(i).copied().unwrap_or(0.0);
            let value = |n: NodeId| {
                if screen {
                    let r = node_radius[n.index()];
                    let dev = if r_own > 0.0 {
                        own * (r / r_own).powi(2)
                    } else {
                        0.0
                    };
                    let s = if rim.get(n.index()) == Some(&true) {
                        s + rim_extra
                    } else {
                        s
                    };
                    s * px * r + dev
                } else {
                    s
                }
            };
            let Some(parent) = h.parent(node) else {
                self.priorities[node.index()] = value(node);
                continue;
            };
            if self.on_cut[i] {
                self.priorities[node.index()] = value(node);
            }
            // Either the parent is on the cut with a coarse in flight (its priority is its
            // children's largest), or it is a merge candidate: with screen-error priorities
            // its key is the value of keeping it refined, measured at its own size
            // (`MergeKey::Parent`); with plain salience the evaluator takes the children's
            // largest itself.
            let slot = &mut self.priorities[parent.index()];
            *slot = slot.max(value(parent));
        }
        self.nodes = nodes;
        Ok(())
    }

    /// The last part of a measurement: under an error bound, the priority of every node of the
    /// cut and the node budget, read against the body as it is now (it may have stepped since
    /// [`Feedback::prepare`], ending transitions and their locks: a parent just merged takes its
    /// children's estimate); otherwise the normals handed back. Returns the view the
    /// measurement saw the cloth through; refused when no measurement was computed.
    ///
    /// `recent(node)` says whether `node` was refined or coarsened so recently that undoing it
    /// would count as flicker. Under [`ClothBudget::MaxErrorPx`] such a node keeps its level
    /// for the undo window (a minimum residency, as engines' LOD systems keep a level for a
    /// minimum time) unless the error really asks: a just-refined node is not merged back, and
    /// a just-coarsened one is refined again only above four times the bound (not half of it),
    /// so a bound that moves does not undo what it just asked for.
    pub(crate) fn conclude(
        &mut self,
        body: &TreeCutSoftBody,
        node_normals: &mut [Vec3],
        node_radius: &[f32],
        recent: &dyn Fn(NodeId) -> Recent,
    ) -> Result<View, ClothError> {
        let view = match self.pending.take() {
            Some(Pending::Bound(partial, bound)) => {
                let (budget, projected) =
                    self.error_priorities(body, node_radius, bound, partial.warm, recent);
                self.error_budget = Some(budget);
                self.projected_nodes = Some(projected);
                return Ok(partial.view);
            }
            Some(Pending::Salience { view, .. }) => view,
            None => {
                return Err(ClothError::Feedback {
                    field: "measurement",
                    reason: "none was prepared and computed",
                });
            }
        };
        for (i, &node) in self.nodes.iter().enumerate() {
            node_normals[node.index()] = self.normals[i];
        }
        Ok(view)
    }

    /// Runs `run` with the [`Frame`] of the copies [`Feedback::copy_state`] made.
    fn with_frame(
        &mut self,
        h: &treecut::Hierarchy,
        node_radius: &[f32],
        view: &View,
        dt: f32,
        run: impl FnOnce(&mut Feedback, &Frame<'_>),
    ) {
        let nodes = std::mem::take(&mut self.nodes);
        let positions = std::mem::take(&mut self.positions);
        let velocities = std::mem::take(&mut self.velocities);
        let blend = self.blend_steps;
        self.refresh_rim(h);
        let rim = std::mem::take(&mut self.rim);
        let frame = Frame {
            hierarchy: h,
            nodes: &nodes,
            positions: &positions,
            velocities: &velocities,
            rim: &rim,
            rim_weight: self.settings.rim_weight,
            latency: (self.settings.interval + blend) as f32 * dt,
            node_radius,
            view,
            outside_weight: self.settings.params.outside_view_weight,
            // A bound the host set is a promise about what a viewer sees; a bound a world
            // moves is its exchange rate between error and cost across objects, which spends
            // on what is seen (see the `deviation` module).
            outside_as_seen: matches!(self.settings.budget, ClothBudget::MaxErrorPx(_))
                && !self.shared_bound,
        };
        run(self, &frame);
        self.nodes = nodes;
        self.positions = positions;
        self.velocities = velocities;
        self.rim = rim;
    }

    /// The particles' nodes, positions and velocities copied, the neighbour table built (and
    /// checked): what a measurement reads of the body besides the hierarchy.
    fn copy_state(&mut self, body: &TreeCutSoftBody) -> Result<(), ClothError> {
        let xyz = |v: &Vec4| v.truncate();
        self.blend_steps = body.settings().blend_steps;
        self.nodes.clear();
        self.nodes.extend_from_slice(body.particle_nodes());
        self.positions.clear();
        self.positions
            .extend(body.particle_positions().iter().map(xyz));
        self.velocities.clear();
        self.velocities
            .extend(body.particle_velocities().iter().map(xyz));
        body.neighbour_csr(&mut self.offsets, &mut self.neighbours);
        Neighbours::new(&self.offsets, &self.neighbours, body.particle_count())?;
        Ok(())
    }

    /// Begins a measurement under [`ClothBudget::MaxErrorPx`] (after [`Feedback::copy_state`]):
    /// the cold-start test, the deviation's start, and what its parts share.
    fn begin_error_bound(
        &mut self,
        h: &treecut::Hierarchy,
        node_radius: &[f32],
        view: &View,
        dt: f32,
    ) -> Partial {
        let period = self.settings.interval as f32 * dt;
        // Cold start: until the loop has watched the cloth for one memory period it has no
        // history, and a cloth at rest (about to be released, or to be hit by wind) reads as
        // one that can be merged; merges then wait.
        // (Counted when the measurement ends: one dropped half-way does not count.)
        let warm = self.measurements as f32 * period >= self.settings.memory_seconds;
        let mut progress = None;
        self.with_frame(h, node_radius, view, dt, |f, frame| {
            progress = Some(f.deviation.begin(frame));
        });
        Partial {
            view: *view,
            dt,
            warm,
            progress: progress.expect("with_frame runs its closure"),
        }
    }

    /// Measures the particles of a measurement under [`ClothBudget::MaxErrorPx`] up to
    /// `fraction` of them (begun now if none is under way, seeing the cloth through `view`),
    /// ahead of the step that finishes it ([`Feedback::compute`]): the cloth does not move
    /// between its steps, so the parts measure one state, all through the first part's view,
    /// and the result is the one measurement made at the first part. Returns the particles
    /// measured by this call (0 under another budget: its measurement is not split).
    pub(crate) fn measure_part(
        &mut self,
        body: &TreeCutSoftBody,
        node_radius: &[f32],
        view: &View,
        dt: f32,
        fraction: f32,
    ) -> Result<usize, ClothError> {
        if !matches!(self.settings.budget, ClothBudget::MaxErrorPx(_)) {
            return Ok(0);
        }
        let partial = match self.partial {
            Some(p) => p,
            None => {
                self.copy_state(body)?;
                self.begin_error_bound(body.hierarchy(), node_radius, view, dt)
            }
        };
        self.partial = Some(partial);
        let n = self.nodes.len();
        let upto = ((fraction.clamp(0.0, 1.0) as f64 * n as f64).ceil() as usize).min(n);
        let before = self.deviation.measured();
        self.carry_on(body.hierarchy(), node_radius, partial, upto, false);
        Ok(self.deviation.measured().saturating_sub(before))
    }

    /// Particles already measured by a measurement under way ([`Feedback::measure_part`]).
    pub(crate) fn measured_ahead(&self) -> usize {
        if self.partial.is_some() {
            self.deviation.measured()
        } else {
            0
        }
    }

    /// Forgets a measurement under way (the body changed since it began).
    pub(crate) fn drop_partial(&mut self) {
        self.partial = None;
    }

    /// Measures the deviation of a measurement under way up to particle `upto` (exclusive);
    /// with `end` closes it (its estimates become the ones the next measurement holds).
    fn carry_on(
        &mut self,
        h: &treecut::Hierarchy,
        node_radius: &[f32],
        partial: Partial,
        upto: usize,
        end: bool,
    ) {
        let decay = self.settings.memory_decay(partial.dt);
        let (view, dt) = (partial.view, partial.dt);
        self.with_frame(h, node_radius, &view, dt, |f, frame| {
            let mut progress = partial.progress;
            let csr = (&f.offsets[..], &f.neighbours[..]);
            f.deviation
                .measure_range(frame, csr, decay, &mut progress, upto);
            if end {
                f.measurements += 1;
                f.deviation.end(frame, progress);
            }
        });
    }

    /// [`ClothBudget::MaxErrorPx`]: priorities are estimated on-screen errors in pixels (a
    /// simulated node's error if kept, a merge candidate's error if merged), and the node budget
    /// is the cut after refining every node above [`settings::ERROR_BOUND_REFINE`] of the bound
    /// and merging every candidate under the merge fraction of it (see
    /// [`Feedback::shared_bound`]); and the node count the cut will reach once refinement has
    /// run its course: a refined node's children are estimated again at the next measurement
    /// and may be refined in turn, so each refine candidate is projected down as many levels as
    /// its estimate stays above the refine threshold when halved per level. Halving, not the
    /// smooth-curvature model's quarter: the drift and strain parts of the estimate scale with the
    /// radius, not its square, and a projection that falls short makes a world budget overshoot (it
    /// did, by 35%), while one that goes too far only settles from below as refinement ends. A
    /// world budget reads the projection; the evaluator gets the one-level budget.
    fn error_priorities(
        &mut self,
        body: &TreeCutSoftBody,
        node_radius: &[f32],
        bound: f32,
        merges: bool,
        recent: &dyn Fn(NodeId) -> Recent,
    ) -> (usize, usize) {
        let (h, cut) = (body.hierarchy(), body.cut());
        let nodes = body.particle_nodes();
        let mut budget = cut.len() as i64;
        let mut projected = cut.len() as i64;
        let refine_above = settings::ERROR_BOUND_REFINE * bound;
        let merge_fraction = if self.shared_bound {
            settings::SHARED_BOUND_MERGE
        } else {
            settings::ERROR_BOUND_MERGE
        };
        // The curve a world reads (only under its shared bound): every candidate at any bound.
        let mut shared_curve = match self.curve.take() {
            _ if !self.shared_bound => None,
            c => Some(c.unwrap_or_default()),
        };
        // Unshared once here (the world dropped its handle after the last frame), not per event.
        let mut curve = shared_curve.as_mut().map(std::sync::Arc::make_mut);
        if let Some(c) = curve.as_mut() {
            c.start(cut.len());
        }
        for &node in nodes {
            // The measurement's estimate (made before the body stepped, if it stepped since:
            // a node just merged takes its children's, see `Deviation::estimate`).
            let px = self.deviation.estimate(h, node, node_radius);
            if cut.is_on_cut(node) {
                // A just-coarsened node competes at an eighth of its estimate: refined again
                // only above four times the bound. Its first estimates after the merge run high
                // (the merged node is still settling into its neighbours' motion), and refined
                // again at half the bound, 1–2% of a world budget's operations were undone
                // within 30 steps (still 1.1% at twice the bound).
                let px = if px <= 4.0 * bound && recent(node) == Recent::Coarsened {
                    px * 0.125
                } else {
                    px
                };
                self.priorities[node.index()] = px;
                let refinable = !h.is_leaf(node) && cut.can_refine(h, node).is_ok();
                if let Some(c) = curve.as_mut().filter(|_| refinable) {
                    let leaves = h.vertices(node).len() as u64;
                    let r = settings::ERROR_BOUND_REFINE;
                    c.add_refine(px, h.level(node), leaves, r);
                }
                if px > refine_above && refinable {
                    budget += h.child_count(node) as i64 - 1;
                    let (mut e, mut levels) = (px, 0u32);
                    while e > refine_above && levels < h.level(node) {
                        e *= 0.5;
                        levels += 1;
                    }
                    let leaves = h.vertices(node).len() as i64;
                    projected += 4i64.saturating_pow(levels).min(leaves) - 1;
                }
            }
        }
        for &node in nodes {
            let Some(parent) = h.parent(node) else {
                continue;
            };
            // Once per parent: from its first child.
            if h.children(parent).next() != Some(node) {
                continue;
            }
            if cut.is_on_cut(parent) {
                // A coarse in flight: the parent is virtual, its priority its children's largest.
                let px = h
                    .children(parent)
                    .filter(|&c| body.particle_of(c).is_some())
                    .map(|c| self.deviation.estimate(h, c, node_radius))
                    .fold(0.0, f32::max);
                self.priorities[parent.index()] = px;
                continue;
            }
            // What the parent's own estimate would be: under the smooth-curvature model of the
            // `deviation` module a node's error grows with its radius squared, so the children's
            // largest estimate scaled to the parent's radius is the parent's, and refining and
            // merging are judged by one measure (a just-refined node is not merged back).
            let rp = node_radius[parent.index()];
            let px = h
                .children(parent)
                .filter_map(|c| {
                    body.particle_of(c)?;
                    let rc = node_radius[c.index()];
                    (rc > 0.0)
                        .then(|| self.deviation.estimate(h, c, node_radius) * (rp / rc).powi(2))
                })
                .fold(0.0, f32::max);
            let coarsenable = cut.can_coarse(h, parent).is_ok();
            if let Some(c) = curve.as_mut().filter(|_| coarsenable && merges) {
                let children = h.child_count(parent) as u64;
                c.add_merge(px, children, merge_fraction);
            }
            let mergeable = px < merge_fraction * bound && coarsenable;
            if !merges || recent(parent) == Recent::Refined {
                // The evaluator merges only to make room, and there is room; a key above every
                // refine candidate keeps swaps from merging too. A merge the residency only
                // delays still counts in the projection: it is coming.
                self.priorities[parent.index()] = f32::MAX;
                if mergeable && merges {
                    projected -= h.child_count(parent) as i64 - 1;
                }
                continue;
            }
            self.priorities[parent.index()] = px;
            if mergeable {
                budget -= h.child_count(parent) as i64 - 1;
                projected -= h.child_count(parent) as i64 - 1;
            }
        }
        if let Some(c) = curve {
            c.finish();
        }
        self.curve = shared_curve;
        (budget.max(1) as usize, projected.max(1) as usize)
    }
}

/// A measurement under way, not yet concluded ([`Feedback::conclude`]): from
/// [`Feedback::prepare`] under a budget that ranks nodes, from [`Feedback::compute`] under an
/// error bound (until then its [`Partial`] carries it).
#[derive(Clone, Copy, Debug)]
enum Pending {
    /// Under [`ClothBudget::MaxErrorPx`] at this bound.
    Bound(Partial, f32),
    /// Under another budget: the frame's view, the object's motion and the solver step.
    Salience {
        view: View,
        object: ObjectMotion,
        dt: f32,
    },
}

/// A measurement under [`ClothBudget::MaxErrorPx`] under way (see [`Feedback::measure_part`]).
#[derive(Clone, Copy, Debug)]
struct Partial {
    /// The view every part sees the cloth through (the first part's).
    view: View,
    /// The solver step it was begun at.
    dt: f32,
    /// Whether merges are allowed (the cold start is over).
    warm: bool,
    /// The deviation's state between parts.
    progress: deviation::Progress,
}

/// Per hierarchy node: whether it can be refined and covers a vertex on the finest mesh's rim.
fn rim_nodes(h: &treecut::Hierarchy) -> Vec<bool> {
    let rim = treecut::rim_vertices(h);
    (0..h.len())
        .map(|i| {
            let n = NodeId::new(i);
            !h.is_leaf(n) && h.vertices(n).iter().any(|&v| rim[v as usize])
        })
        .collect()
}

/// The `camera_blind` ablation's view: the object seen face-on along its mean normal through a
/// 60° field of view on a 1920 × 1080 viewport, from the distance at which it fills the height.
/// Nothing of the real camera (pose, field of view, viewport) plays a part; `frame` is only the
/// fallback for a degenerate cloth.
fn canonical_view(positions: &[Vec3], normals: &[Vec3], centre: Vec3, frame: &View) -> View {
    const FOV_Y: f32 = std::f32::consts::FRAC_PI_3;
    let extent = positions
        .iter()
        .map(|p| p.distance(centre))
        .fold(0.0f32, f32::max)
        .max(1e-3);
    let mean: Vec3 = normals.iter().copied().sum();
    let n = mean.normalize_or(Vec3::Y);
    let distance = extent / (0.5 * FOV_Y).tan() + extent;
    let up = if n.y.abs() < 0.9 { Vec3::Y } else { Vec3::Z };
    View::look_at(centre + n * distance, centre, up, FOV_Y, 1920, 1080).unwrap_or(*frame)
}

/// One evaluation's update of the flicker control's raise of the hysteresis (its base-2
/// logarithm, 0 to `log2(FLICKER_GAIN_MAX)`; see [`FeedbackSettings::flicker_target`]):
/// `undone` operations undone since the last evaluation, `window_ops` begun within the undo
/// window before this evaluation, `target` the undone fraction aimed at, `interval_s` and
/// `window_s` the evaluation interval and the undo window in seconds.
///
/// The raise decays by `interval_s / FLICKER_HALF_LIFE_SECONDS` doublings per evaluation and
/// grows by `undone / (window_ops · f₀)` with `f₀ = target · half-life / window_s`: when a
/// fraction `r` of the operations is undone steadily, the growth per evaluation is
/// `r · interval_s / (window_s · f₀)` (the window holds `window_s / interval_s` evaluations'
/// operations), which equals the decay exactly at `r = target`. Above it the raise climbs, below
/// it decays: the loop settles where its operations are undone at the target rate or less.
pub(crate) fn flicker_log2(
    log2: f32,
    undone: u64,
    window_ops: u64,
    target: f32,
    interval_s: f32,
    window_s: f32,
) -> f32 {
    let half_life = FLICKER_HALF_LIFE_SECONDS;
    let f0 = target * half_life / window_s;
    let raise = undone as f32 / (window_ops.max(1) as f32 * f0);
    (log2 - interval_s / half_life + raise).clamp(0.0, FLICKER_GAIN_MAX.log2())
}
