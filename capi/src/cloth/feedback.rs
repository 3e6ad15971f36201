//! The feedback stage of the closed loop: per-particle BSWDF salience turned into a priority
//! per cut node, and the budget the evaluator spends.

use glam::{Vec3, Vec4};
use salience::{BswdfJob, BswdfParams, Neighbours, Nodes, ObjectMotion, Sidedness, View};
use softbody::TreeCutSoftBody;
use treecut::{Evaluator, EvaluatorSettings, MergeKey, NodeId};

use super::controller::{ControllerSettings, TimeController};
use super::error::ClothError;

/// What the cut may spend.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClothBudget {
    /// At most this many simulated nodes (≥ 1).
    Nodes(usize),
    /// This fraction of the full-resolution node count, in (0, 1] (the paper's "compression":
    /// 0.3 simulates 30% of the nodes).
    Compression(f32),
    /// A target time per step in milliseconds (> 0, evaluation included); a controller moves
    /// the node budget to hold it. Results then depend on the machine's speed, so runs are not
    /// bit-identical.
    TargetStepMs(f32),
}

/// How salience becomes a node's priority.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PriorityModel {
    /// The BSWDF value itself, as in the paper.
    Salience,
    /// The BSWDF value times the node's projected radius in pixels: salience says how much a
    /// viewer cares about detail at a point, the projected size how many pixels the missing
    /// detail of a coarse node spans. A parent spans about twice its children's radius, so its
    /// priority ranks above theirs at equal salience, and refining the biggest visible error
    /// first is what spends a node budget best (measured in `cloth::tests`).
    #[default]
    ScreenError,
}

/// Settings of the feedback loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeedbackSettings {
    /// Evaluate every `interval` steps (≥ 1; the paper's k).
    pub interval: u32,
    /// What the cut may spend.
    pub budget: ClothBudget,
    /// Minimum priority gain for swapping detail from one place to another (≥ 0, same unit as
    /// the priorities: salience-weighted pixels with [`PriorityModel::ScreenError`]). Keeps
    /// nodes from being refined and coarsened back and forth. Default 6: on the swinging net,
    /// 2 undid 1–12% of the operations within 30 steps, 4–5 about 1.5%, 6 none, with the same
    /// error (measured with `run_net`).
    pub hysteresis: f32,
    /// Most operations begun per evaluation (≥ 1); bounds the work of one step.
    pub max_ops: usize,
    /// How salience becomes priority.
    pub priority: PriorityModel,
    /// BSWDF constants. The default is [`BswdfParams::default`] made two-sided (cloth has no
    /// back face).
    pub params: BswdfParams,
    /// Weight of deformation, the feature added to the BSWDF's motion terms (see [`Feedback`]):
    /// a node's salience is raised by `deformation_weight × ε`, with `ε` the mean relative
    /// length change `|ℓ/ℓ₀ − 1|` of its links (≥ 0; 0 turns it off). Default 20: a 5%
    /// stretch weighs as much as fully salient motion. Linear on purpose, unlike the motion
    /// response: the error a coarse node makes grows with the strain it cannot represent, so
    /// the ranking must keep growing where a viewer's impression would saturate.
    pub deformation_weight: f32,
    /// Salience memory in seconds (≥ 0; 0 turns it off): a node's salience is the larger of
    /// its current value and its remembered value decayed by `exp(−t / memory_seconds)`.
    ///
    /// Why: a swinging cloth stops at every turning point, where its velocities (and with them
    /// instantaneous motion salience) pass through zero, only to move again a fraction of a
    /// second later. Attention drawn by motion persists for a few hundred milliseconds
    /// (inhibition of return and visual persistence act on that scale), so a region that just
    /// moved is still being looked at; coarsening it at the turning point and refining it again
    /// on the way back would be both wasted work and visible popping. Default 0.5 s.
    pub memory_seconds: f32,
    /// Split the salience evaluation over the rayon pool when there are enough nodes.
    pub parallel: bool,
    /// Controller settings for [`ClothBudget::TargetStepMs`].
    pub controller: ControllerSettings,
}

impl Default for FeedbackSettings {
    fn default() -> Self {
        FeedbackSettings {
            interval: 5,
            budget: ClothBudget::Compression(0.3),
            hysteresis: 6.0,
            max_ops: 64,
            priority: PriorityModel::default(),
            params: BswdfParams {
                sides: Sidedness::TwoSided,
                ..BswdfParams::default()
            },
            deformation_weight: 20.0,
            memory_seconds: 0.5,
            parallel: false,
            controller: ControllerSettings::default(),
        }
    }
}

impl FeedbackSettings {
    /// The evaluator settings these feedback settings imply.
    pub(crate) fn evaluator_settings(&self) -> EvaluatorSettings {
        EvaluatorSettings {
            hysteresis: self.hysteresis,
            max_ops: self.max_ops,
            merge_key: match self.priority {
                PriorityModel::Salience => MergeKey::MaxOfChildren,
                PriorityModel::ScreenError => MergeKey::Parent,
            },
        }
    }

    /// Checks every field; the error names the bad one.
    pub fn validate(&self) -> Result<(), ClothError> {
        let bad = |field, reason| Err(ClothError::Feedback { field, reason });
        if self.interval == 0 {
            return bad("interval", "must be >= 1");
        }
        if !(self.hysteresis.is_finite() && self.hysteresis >= 0.0) {
            return bad("hysteresis", "must be finite and >= 0");
        }
        if !(self.deformation_weight.is_finite() && self.deformation_weight >= 0.0) {
            return bad("deformation_weight", "must be finite and >= 0");
        }
        if !(self.memory_seconds.is_finite() && self.memory_seconds >= 0.0) {
            return bad("memory_seconds", "must be finite and >= 0");
        }
        if self.max_ops == 0 {
            return bad("max_ops", "must be >= 1");
        }
        match self.budget {
            ClothBudget::Nodes(0) => return bad("budget", "node budget must be >= 1"),
            ClothBudget::Compression(f) if !(f.is_finite() && f > 0.0 && f <= 1.0) => {
                return bad("budget", "compression must be in (0, 1]");
            }
            ClothBudget::TargetStepMs(ms) if !(ms.is_finite() && ms > 0.0) => {
                return bad("budget", "target step time must be finite and > 0 ms");
            }
            _ => {}
        }
        self.params.validate()?;
        let c = self.controller;
        let unit = |x: f32| x > 0.0 && x <= 1.0;
        let ok = unit(c.smoothing)
            && unit(c.gain)
            && c.max_change > 0.0
            && c.max_change.is_finite()
            && c.deadband >= 0.0
            && c.deadband < 1.0;
        if !ok {
            return bad(
                "controller",
                "smoothing and gain in (0, 1], max_change > 0, deadband in [0, 1)",
            );
        }
        Ok(())
    }
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
/// [`FeedbackSettings::deformation_weight`], weighted by whether it is in view and added to
/// the motion salience (so the sum may exceed 1; it is a priority, not a probability). With
/// it the feedback cut
/// has a lower error than uniform and random cuts (test
/// `swinging_net_at_30_percent_beats_uniform_and_random_cuts`); without it, it does not.
#[derive(Clone, Debug)]
pub(crate) struct Feedback {
    pub(crate) settings: FeedbackSettings,
    pub(crate) evaluator: Evaluator,
    pub(crate) controller: Option<TimeController>,
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    normals: Vec<Vec3>,
    hints: Vec<Vec3>,
    offsets: Vec<u32>,
    neighbours: Vec<u32>,
    salience: Vec<f32>,
    /// Per particle: summed link strain and summed link weight.
    strain: Vec<(f32, f32)>,
    /// Priority per hierarchy node (only active nodes' entries are meaningful).
    pub(crate) priorities: Vec<f32>,
    /// Remembered salience per hierarchy node, and the evaluation that last wrote it.
    memory: Vec<f32>,
    memory_stamp: Vec<u32>,
    evaluation: u32,
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
            evaluator: Evaluator::new(settings.evaluator_settings()),
            settings,
            controller,
            positions: Vec::new(),
            velocities: Vec::new(),
            normals: Vec::new(),
            hints: Vec::new(),
            offsets: Vec::new(),
            neighbours: Vec::new(),
            salience: Vec::new(),
            strain: Vec::new(),
            priorities: vec![0.0; hierarchy_len],
            memory: vec![0.0; hierarchy_len],
            memory_stamp: vec![0; hierarchy_len],
            evaluation: 0,
        }
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
        }
    }

    /// Computes the BSWDF of every particle and from it the priority of every active node.
    ///
    /// During a coarse in flight the cut holds the (virtual) parent while the particles are its
    /// children: the parent gets its children's largest priority, the same key the evaluator
    /// would use to merge them.
    pub(crate) fn measure(
        &mut self,
        body: &TreeCutSoftBody,
        node_normals: &mut [Vec3],
        node_radius: &[f32],
        view: &View,
        dt: f32,
    ) -> Result<(), ClothError> {
        let n = body.particle_count();
        let xyz = |v: &Vec4| v.truncate();
        self.positions.clear();
        self.positions
            .extend(body.particle_positions().iter().map(xyz));
        self.velocities.clear();
        self.velocities
            .extend(body.particle_velocities().iter().map(xyz));
        body.neighbour_csr(&mut self.offsets, &mut self.neighbours);
        let nbrs = Neighbours::new(&self.offsets, &self.neighbours, n)?;
        let nodes = body.particle_nodes();
        self.hints.clear();
        self.hints
            .extend(nodes.iter().map(|&node| node_normals[node.index()]));
        self.normals.resize(n, Vec3::ZERO);
        salience::estimate_normals(&self.positions, &nbrs, &self.hints, &mut self.normals)?;
        let object = ObjectMotion::centre_of_mass(
            &self.positions,
            &self.velocities,
            body.particle_masses(),
        )?;
        let job = BswdfJob {
            view,
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
        if self.settings.deformation_weight > 0.0 {
            self.add_deformation(body, view);
        }
        let cut = body.cut();
        let h = body.hierarchy();
        let decay = if self.settings.memory_seconds > 0.0 {
            (-(self.settings.interval as f32 * dt) / self.settings.memory_seconds).exp()
        } else {
            0.0
        };
        let previous = self.evaluation;
        self.evaluation = self.evaluation.wrapping_add(1).max(1);
        for (i, &node) in nodes.iter().enumerate() {
            node_normals[node.index()] = self.normals[i];
            let remembered = self.remembered(h, node, previous) * decay;
            self.salience[i] = self.salience[i].max(remembered);
            // Entries filled by maxima below start from zero.
            if let Some(p) = h.parent(node) {
                self.priorities[p.index()] = 0.0;
            }
        }
        let screen = self.settings.priority == PriorityModel::ScreenError;
        for (i, &node) in nodes.iter().enumerate() {
            let s = self.salience[i];
            self.memory[node.index()] = s;
            self.memory_stamp[node.index()] = self.evaluation;
            let px = if screen {
                view.pixels_per_unit(self.positions[i])
            } else {
                1.0
            };
            let value = |n: NodeId| {
                if screen {
                    s * px * node_radius[n.index()]
                } else {
                    s
                }
            };
            let Some(parent) = h.parent(node) else {
                self.priorities[node.index()] = value(node);
                continue;
            };
            if cut.is_on_cut(node) {
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
        Ok(())
    }

    /// Adds each particle's weighted link strain to its motion salience.
    fn add_deformation(&mut self, body: &TreeCutSoftBody, view: &View) {
        let n = self.positions.len();
        self.strain.clear();
        self.strain.resize(n, (0.0, 0.0));
        for l in body.links() {
            let (a, b) = (l.a.raw() as usize, l.b.raw() as usize);
            if l.rest <= 0.0 || l.weight <= 0.0 {
                continue;
            }
            let e = l.weight * (self.positions[a].distance(self.positions[b]) / l.rest - 1.0).abs();
            for p in [a, b] {
                self.strain[p].0 += e;
                self.strain[p].1 += l.weight;
            }
        }
        let params = &self.settings.params;
        for ((s, &(sum, weight)), &x) in self
            .salience
            .iter_mut()
            .zip(&self.strain)
            .zip(&self.positions)
        {
            if weight <= 0.0 {
                continue;
            }
            let seen = if view.is_in_view(x, params.view_margin) {
                1.0
            } else {
                params.outside_view_weight
            };
            *s += self.settings.deformation_weight * (sum / weight) * seen;
        }
    }

    /// The salience `node` had at evaluation `previous`: its own if it was simulated then,
    /// else its parent's (it was just refined) or its children's largest (just coarsened).
    fn remembered(&self, h: &treecut::Hierarchy, node: NodeId, previous: u32) -> f32 {
        let live =
            |n: NodeId| (self.memory_stamp[n.index()] == previous).then(|| self.memory[n.index()]);
        if let Some(s) = live(node) {
            return s;
        }
        if let Some(s) = h.parent(node).and_then(live) {
            return s;
        }
        h.children(node).filter_map(live).fold(0.0, f32::max)
    }
}

/// The node count a compression (fraction of the full count) allows: rounded, at least 1 (what
/// [`ClothBudget::Compression`] means).
pub fn compression_nodes(compression: f32, full_nodes: usize) -> usize {
    ((compression as f64 * full_nodes as f64).round() as usize).max(1)
}

/// A rest radius per hierarchy node: the largest rest distance from the node to a finest
/// vertex it covers, or half the shortest rest edge at a leaf (the area a vertex stands for).
pub(crate) fn node_radii(h: &treecut::Hierarchy) -> Vec<f32> {
    let rest = h.rest_positions();
    let mut leaf_half = vec![f32::INFINITY; h.vertex_count()];
    for &[a, b] in h.leaf_edges() {
        let d = 0.5 * rest[h.leaf_of_vertex(a).index()].distance(rest[h.leaf_of_vertex(b).index()]);
        leaf_half[a as usize] = leaf_half[a as usize].min(d);
        leaf_half[b as usize] = leaf_half[b as usize].min(d);
    }
    (0..h.len())
        .map(|i| {
            let n = NodeId::new(i);
            let c = rest[i];
            if let Some(v) = h.vertex_of_leaf(n) {
                let r = leaf_half[v as usize];
                if r.is_finite() { r } else { 0.0 }
            } else {
                h.vertices(n)
                    .iter()
                    .map(|&v| c.distance(rest[h.leaf_of_vertex(v).index()]))
                    .fold(0.0f32, f32::max)
            }
        })
        .collect()
}
