//! The feedback loop's settings: what the cut may spend ([`ClothBudget`]), how salience becomes
//! a priority ([`PriorityModel`]) and the loop's parameters ([`FeedbackSettings`]).

use salience::{BswdfParams, Sidedness};
use treecut::{EvaluatorSettings, MergeKey};

use crate::cloth::controller::ControllerSettings;
use crate::cloth::error::ClothError;

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
    /// An on-screen error bound in pixels of the frame's [`salience::View`] (> 0, finite): the
    /// loop spends the fewest nodes that keep every node's estimated on-screen deviation under
    /// it (see the `deviation` module: refine where a node's estimate exceeds half the bound,
    /// merge where merging would stay under half of it too, so the cut it ends at does not
    /// depend on where it started; under a world's moving bound merges wait for a quarter).
    /// Start it at the finest cut: it then merges only where the error stays small (merges
    /// wait one memory period), instead of refining out of a coarse start while the error
    /// shows. The same meaning as the crowd's
    /// `LodMode::ErrorBound`: pixels a viewer could see, so a farther camera needs fewer nodes.
    /// Error outside the view counts as seen while any of the cloth is in view (it reaches the
    /// screen through the cloth's dynamics; the `deviation` module says how), unless a world
    /// moves the bound; the BSWDF's `outside_view_weight` weighs it otherwise.
    /// The bound is on the estimate; the error measured against a full-resolution reference is
    /// reported by the experiments.
    MaxErrorPx(f32),
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
    /// [`PriorityModel::ScreenError`] plus the node's estimated on-screen deviation in pixels
    /// (what the error-bound budget uses: bending, latency and stretch; see the `deviation`
    /// module). Both terms are pixels, so no weight relates them.
    ScreenDeviation,
}

/// Settings of the feedback loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeedbackSettings {
    /// Evaluate every `interval` steps (≥ 1; the paper's k).
    pub interval: u32,
    /// What the cut may spend.
    pub budget: ClothBudget,
    /// Minimum priority gain for swapping detail from one place to another, as a multiple of
    /// the simulated nodes' mean priority at that evaluation (≥ 0). Keeps nodes from being
    /// refined and coarsened back and forth. Relative because priorities scale with the
    /// viewport, the camera's distance and the cloth's motion: the earlier absolute gain (6
    /// salience-weighted px, fitted to the swinging net on a 720-px view) froze the cut of the
    /// same net seen from three times farther away. Default 1.5: about that gain on the net's
    /// own view (mean priority ≈ 4 on a 1080-px view), with no operation undone within 30 steps
    /// there, at 3× the distance, and in the perception scenes (see `slod_experiments`).
    /// Ignored by [`ClothBudget::MaxErrorPx`], whose hysteresis is a fraction of its bound.
    pub hysteresis: f32,
    /// Most operations begun per evaluation; bounds the work of one step. 0 (the default)
    /// scales it with the cut: [`AUTO_MAX_OPS_FRACTION`] of the node budget at that evaluation
    /// (at least one), or [`PACED_MAX_OPS`] under the budgets whose node count the loop sets
    /// itself ([`ClothBudget::MaxErrorPx`], [`ClothBudget::TargetStepMs`]; see
    /// [`FeedbackSettings::ops_per_evaluation`]).
    pub max_ops: usize,
    /// How salience becomes priority.
    pub priority: PriorityModel,
    /// BSWDF constants. The default is [`BswdfParams::default`] made two-sided (cloth has no
    /// back face).
    pub params: BswdfParams,
    /// Weight of deformation, the feature added to the BSWDF's motion terms (see the `feedback` module docs):
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
    /// Weight of the BSWDF's motion salience (≥ 0, default 1; 0 leaves only the deformation
    /// term: the `strain_only` ablation).
    pub motion_weight: f32,
    /// Whether the camera shapes the cut (default true). False is the `camera_blind` ablation:
    /// salience and priorities are measured through a canonical view (the object seen face-on,
    /// filling the view's height) instead of the frame's, so distance, facing and frustum have
    /// no effect. [`ClothBudget::MaxErrorPx`] always uses the frame's view: its bound is in its
    /// pixels.
    pub view_dependent: bool,
    /// Weight of the rim (≥ 0; 0 turns it off; default 3): on a node that covers a vertex on
    /// the finest mesh's boundary (a free edge, a hole's outline, a pinned border;
    /// [`treecut::rim_vertices`]) the stretch term counts `1 + rim_weight` times — the
    /// deformation part of its salience under the screen priorities, the stretch part of its
    /// estimate under [`ClothBudget::MaxErrorPx`]. So the loop keeps a *strained* rim finer
    /// than the inside; a slack rim (a flag's free edge) gains little. Not used by
    /// [`PriorityModel::Salience`] (the paper's motion-only ranking).
    ///
    /// Why: a held sheet carries its load along its free edges and into its supports, where
    /// the stretch concentrates, and a coarse node there changes the motion of the *whole*
    /// sheet, not only of its own region. Measured on the pinned net (65², 1080-px view,
    /// on-screen RMS over 200 steps): static cuts with the rim at the finest level and the
    /// inside two levels coarser (22% of the nodes) 1.07 px, the rim and the inside one level
    /// coarse (24%) 9.49 px; a plain 33² grid against the 65² one 9.6 px, so what drifts is the
    /// coarse rim's lost stress concentration, not the quadtree's inset rim (doubling the rim
    /// links' compliance or halving the rim's lumped mass did not help). The loop at 30% of
    /// the nodes with weights 0 / 1 / 3 / 10: net 1.79 / 1.78 / 0.95 / 0.93 px, dolly and
    /// orbit 2.21 / 1.19 / 0.88 / 0.86; offscreen 3.99 → 1.96 and the irregular mesh 5.85 →
    /// 4.87 at 3. Its cost, on the chaotic scenes over 30-step horizons: flag 13.69 → 14.78,
    /// curtain 9.84 → 10.68 px (their 1 µm twins drift 10.5 and 4.9 px); boosting the whole
    /// priority instead of the stretch term gained 10% more on the held sheets and lost 40–55%
    /// on those. On the off-screen net the loop is bimodal at 3 (1.96–2.11 px or 4.6–4.7 px
    /// as the budget moves by 1–2%; 4.0–4.4 at 0); 10 holds 1.8–1.9 px at every budget
    /// tried but costs the chaotic scenes 35–45% (flag 19.9, curtain 13.3 px), so 3 it is. A
    /// ratio of terms, so it does not depend on the scene's size or units; the perception
    /// experiment's `rim_blind` runs measure it on every scene.
    ///
    /// Those figures were measured on grid hierarchies whose odd sides ended in a group of
    /// three, so one free edge's coarse nodes sat a whole spacing inside it; part of what the
    /// rim term bought was making up for that edge. With the three in the middle
    /// ([`treecut::Hierarchy::grid`]) the loop without the term improves most (net 1.82 →
    /// 1.03, dolly 2.29 → 1.13, off-screen 4.05 → 2.28 px) and the term's gain shrinks to
    /// 5–20% on the held sheets (net 0.94, dolly 0.94, off-screen 2.09, close-up 3.08 against
    /// 3.64 px), none on net_129 (3.95 against 3.75) and the curtain; weights 1 and 2 measured
    /// worse than 3 on six of eight scenes, so 3 stays.
    pub rim_weight: f32,
    /// Flicker control: the fraction of operations the loop lets be undone within the undo
    /// window (`UNDO_WINDOW_STEPS`, 30 steps: a refine of a node merged that recently, or the
    /// reverse), in (0, 1); `None` turns it off. Default 1% (the perception issue's target).
    /// Each evaluation raises the hysteresis by a factor that integrates the fraction of the
    /// window's operations undone since the last evaluation and decays with a half-life of
    /// [`FLICKER_HALF_LIFE_SECONDS`] (at most [`FLICKER_GAIN_MAX`]); in the steady state the two
    /// balance where the undone fraction is this target, whatever the scene. Applies to node
    /// and compression budgets (a time budget keeps a minimum dwell of the whole undo window,
    /// an error bound a hysteresis that is a fraction of its bound).
    ///
    /// Why: the hysteresis is relative to the mean priority, which says nothing about how much
    /// the priorities *fluctuate*. On cloth whose salience moves with every gust (a flag, a
    /// curtain on a moving rail) a fifth to a quarter of the operations were undone within
    /// half a second: detail chasing noise, paid for in transitions and visible as flicker.
    /// An undone operation is direct evidence that the threshold is below the noise, so the
    /// loop raises it where that happens, and in proportion to how much of its work is undone:
    /// a cut reshaping from a cold start with 60 operations per evaluation barely reacts to
    /// one undone, a flag swapping five nodes per evaluation and undoing one or two reacts
    /// within a few evaluations. Where nothing is undone the loop is unchanged, bit for bit.
    ///
    /// Measured, without → with (`slod-demo engine` and `perception`, 30% of the nodes; undone
    /// within 30 steps; on-screen RMS). Beside the half-second dwell (`DWELL_SECONDS`) it acts
    /// where the dwell cannot: contact keeps a node that touches a collider fine whatever it
    /// was a moment ago — drape over a sphere 8.7 → 2.3% undone, 15.07 → 14.81 px; cloth under a
    /// sliding box 14.4 → 2.5%, 33.65 → 33.41 px; the engine flag and cape nothing undone
    /// either way. On the perception scenes that dwell leaves nothing undone, so it changes
    /// nothing there. With the quarter-second dwell used before, it took the gusty flag from
    /// 19.9 / 27.5% (whole run / 30-step horizons) to 3.0 / 8.1% and its cost at equal error
    /// from 1.54 to 1.25 of a uniform cut's, the curtain from 9.3 / 19.4% to 3.6 / 4.5% (1.45 →
    /// 1.36). The fraction matters: raising by a fixed factor per undone operation instead (×2,
    /// same half-life) froze the close-up's cold-start reshaping after four undone of 705
    /// operations in the camera-blind and strain-only ablations (p99 12.9 → 18.3 and 12.7 →
    /// 19.8 px).
    pub flicker_target: Option<f32>,
    /// Let the evaluation use the rayon pool: the salience split over it when there are enough
    /// nodes, and the measurement of [`FeedbackSettings::overlap_step`] run on it (without,
    /// that measurement runs before the solver on the step's thread: the same results, no
    /// overlap). Off for a host that must not start threads.
    pub parallel: bool,
    /// Run the evaluation's measurement while its step's solver runs, on another thread of the
    /// rayon pool (with [`FeedbackSettings::parallel`]), instead of before it (default false),
    /// as the paper ran its TreeCut evaluation in parallel with the simulation: the step's
    /// wall time becomes the longer of the two plus the evaluation's short ends (copying the
    /// state before, choosing the operations after) instead of their sum. The measurement
    /// reads copies of the state before the step and the operations it chooses begin after
    /// the step, one step later than without it; results do not depend on the threads (same
    /// inputs, same results, also without `parallel`, where the two run one after the other).
    /// A world steps its cloths in parallel already: this pays for a cloth stepped alone, or
    /// fewer cloths than cores. The step's reported evaluation time
    /// ([`crate::cloth::ClothStats::last_eval_seconds`]) is then the wall time the evaluation
    /// added to the solver's; a modelled clock ([`crate::cloth::StepClock::Model`]) charges
    /// the same work as without the overlap (it models the work, not the threads). Measured
    /// (`cargo run --release -p slod-demo -- world`, report `world.evaluation_overlap`: the
    /// paper's net stepped alone on 2 cores, medians of interleaved intervals): the
    /// evaluating step over a plain step 2.05× → 1.31× under a 1 px bound, 1.37× → 1.17× at
    /// full detail, 1.43× → 1.30× at 30% of the nodes, where copying the state (before the
    /// step) and choosing the operations (after it), which cannot overlap the solver, are
    /// most of the evaluation; the solver itself runs about 10% slower beside the measurement
    /// (the two cores share their caches' bandwidth).
    pub overlap_step: bool,
    /// Controller settings for [`ClothBudget::TargetStepMs`].
    pub controller: ControllerSettings,
}

impl Default for FeedbackSettings {
    fn default() -> Self {
        FeedbackSettings {
            interval: 5,
            budget: ClothBudget::Compression(0.3),
            hysteresis: 1.5,
            max_ops: 0,
            priority: PriorityModel::default(),
            params: BswdfParams {
                sides: Sidedness::TwoSided,
                ..BswdfParams::default()
            },
            deformation_weight: 20.0,
            memory_seconds: 0.5,
            motion_weight: 1.0,
            view_dependent: true,
            rim_weight: 3.0,
            flicker_target: Some(0.01),
            parallel: false,
            overlap_step: false,
            controller: ControllerSettings::default(),
        }
    }
}

impl FeedbackSettings {
    /// Most operations one evaluation may begin under a node budget of `budget_nodes`:
    /// [`FeedbackSettings::max_ops`] when set, else [`AUTO_MAX_OPS_FRACTION`] of the budget,
    /// rounded up (at least one), and [`PACED_MAX_OPS`] under [`ClothBudget::MaxErrorPx`] and
    /// [`ClothBudget::TargetStepMs`].
    pub fn ops_per_evaluation(&self, budget_nodes: usize) -> usize {
        match self.budget {
            _ if self.max_ops > 0 => self.max_ops,
            ClothBudget::MaxErrorPx(_) | ClothBudget::TargetStepMs(_) => PACED_MAX_OPS,
            _ => ((budget_nodes as f64 * AUTO_MAX_OPS_FRACTION).ceil() as usize).max(1),
        }
    }

    /// The evaluator settings these feedback settings imply under a node budget of
    /// `budget_nodes`.
    pub(crate) fn evaluator_settings(&self, budget_nodes: usize) -> EvaluatorSettings {
        let max_ops = self.ops_per_evaluation(budget_nodes);
        if let ClothBudget::MaxErrorPx(bound) = self.budget {
            // Priorities are pixels of estimated error; a swap must gain a quarter of the bound.
            return EvaluatorSettings {
                hysteresis: ERROR_BOUND_HYSTERESIS * bound,
                max_ops,
                merge_key: MergeKey::Parent,
            };
        }
        EvaluatorSettings {
            hysteresis: self.hysteresis,
            max_ops,
            merge_key: match self.priority {
                PriorityModel::Salience => MergeKey::MaxOfChildren,
                PriorityModel::ScreenError | PriorityModel::ScreenDeviation => MergeKey::Parent,
            },
        }
    }

    /// How much a remembered value keeps from one evaluation to the next (`exp(−interval·dt /
    /// memory_seconds)`; 0 without memory), for a solver step of `dt` seconds.
    pub(crate) fn memory_decay(&self, dt: f32) -> f32 {
        if self.memory_seconds > 0.0 {
            (-(self.interval as f32 * dt) / self.memory_seconds).exp()
        } else {
            0.0
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
        if !(self.rim_weight.is_finite() && self.rim_weight >= 0.0) {
            return bad("rim_weight", "must be finite and >= 0");
        }
        if !(self.motion_weight.is_finite() && self.motion_weight >= 0.0) {
            return bad("motion_weight", "must be finite and >= 0");
        }
        if let Some(t) = self.flicker_target
            && !(t.is_finite() && t > 0.0 && t < 1.0)
        {
            return bad("flicker_target", "must be in (0, 1), or None");
        }
        match self.budget {
            ClothBudget::Nodes(0) => return bad("budget", "node budget must be >= 1"),
            ClothBudget::Compression(f) if !(f.is_finite() && f > 0.0 && f <= 1.0) => {
                return bad("budget", "compression must be in (0, 1]");
            }
            ClothBudget::TargetStepMs(ms) if !(ms.is_finite() && ms > 0.0) => {
                return bad("budget", "target step time must be finite and > 0 ms");
            }
            ClothBudget::MaxErrorPx(px) if !(px.is_finite() && px > 0.0) => {
                return bad("budget", "error bound must be finite and > 0 px");
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
            && c.deadband < 1.0
            && unit(c.transition_share);
        if !ok {
            return bad(
                "controller",
                "smoothing, gain and transition_share in (0, 1], max_change > 0, deadband in [0, 1)",
            );
        }
        Ok(())
    }
}

/// [`ClothBudget::MaxErrorPx`]: a node is refined when its estimated error exceeds this
/// fraction of the bound (the estimate is not the measured error: the margin absorbs what it
/// misses, such as the coarse cut's slightly different dynamics).
pub(crate) const ERROR_BOUND_REFINE: f32 = 0.5;
/// [`ClothBudget::MaxErrorPx`]: a parent is merged when merging would stay under this fraction
/// of the bound: the refine threshold itself. The merged node's estimate is the one compared
/// here, so it is not refined back unless its error grows; what keeps a just-refined node from
/// being merged back is the residency of the undo window (`Feedback::error_priorities`), and a
/// just-merged node is refined again only above four times the bound. A quarter of the refine
/// threshold (the earlier value) left every parent estimated between the two thresholds where
/// it was, so the cut depended on where it started: on the net at 1 px, 3,460 nodes from a 30%
/// start and all 4,225 from the finest; with equal thresholds both starts end at 2,250 nodes,
/// and from the finest the run held p99 0.59 px, max 1.39 px (before: 3.09 / 22.7 px from the
/// 30% start), with no operation undone within 30 steps.
pub(crate) const ERROR_BOUND_MERGE: f32 = ERROR_BOUND_REFINE;
/// [`ERROR_BOUND_MERGE`] for a cloth whose bound a world budget moves every few frames (by up
/// to ×2 per update, `crate::world::WorldBudget::max_change`): a quarter of the refine
/// threshold, so a bound that moves back and forth does not merge and refine the same nodes.
/// With the equal thresholds of a fixed bound the world's 12-cloth test scene at 35% of full
/// detail kept growing its cuts while the bound rose and ran 10–13% over its target on the
/// first frame of every controller window (settled at frame 226 instead of ≤ 90).
pub(crate) const SHARED_BOUND_MERGE: f32 = 0.125;
/// [`ClothBudget::MaxErrorPx`]: the evaluator's hysteresis as a fraction of the bound.
pub(crate) const ERROR_BOUND_HYSTERESIS: f32 = 0.25;

/// Half-life, in seconds of simulated time, with which the raise of the hysteresis by
/// [`FeedbackSettings::flicker_target`] decays: a few swings of a cloth, so a burst of flicker
/// is remembered through the next gusts, and a cut that calmed down is free to move at full
/// sensitivity again after some seconds.
pub const FLICKER_HALF_LIFE_SECONDS: f32 = 2.0;
/// Largest factor [`FeedbackSettings::flicker_target`] may raise the hysteresis by: six
/// doublings, enough to stop the chaotic scenes' churn, and short of freezing the cut for good
/// (the priorities of one cloth span a few orders of magnitude).
pub const FLICKER_GAIN_MAX: f32 = 64.0;

/// With [`FeedbackSettings::max_ops`] at 0 (the default), the operations one evaluation may
/// begin, as a fraction of the node budget: a tenth of the cut may be reshaped per evaluation,
/// at any size, so that the operations' cost stays about the same share of a step (both grow
/// with the node count) and a large cloth's cut moves as fast, in proportion, as a small one's.
/// The earlier fixed 64 was the swinging net's number: at 30% of a 65×65 net (1,268 nodes)
/// the loop never asked for more, and at 30% of a 129×129 net (4,992) it held the cold start
/// back (on-screen RMS 4.18 px against 3.84 px unbounded, perception scenes `net_129`;
/// `large_closeup` 3.24 against 3.02). A tenth gives 65 at the 644 nodes of the perception
/// flag, 127 at 30% of the 65×65 net and 500 at 30% of 129×129.
pub const AUTO_MAX_OPS_FRACTION: f64 = 0.1;

/// With [`FeedbackSettings::max_ops`] at 0, the operations one evaluation may begin under the
/// budgets whose node count is the loop's own output, not the host's input: they move the cut
/// at a fixed pace, since what they steer by shows only after the operations have blended.
///
/// * [`ClothBudget::MaxErrorPx`] starts from the finest cut and merges where the estimate is
///   under the bound, but a merge's error shows only once the coarse node has moved on its
///   own. A tenth of the cut (423 merges at the first evaluation of a 65×65 net) broke the
///   bound badly: perception p99 on the off-screen net 2.52 → 55.2 px, close-up 6.05 → 11.2 px,
///   the paper's net 0.63 → 0.82 px.
/// * [`ClothBudget::TargetStepMs`] reads the cost of a cut from the steps after it: with a
///   tenth of its moving budget, Table 2's time budget (65×65 net, 0.59 ms) met "≥ 95% of
///   windows within 10%" in 4 of 7 demo runs, against 6 of 6 with this pace in the same window.
pub const PACED_MAX_OPS: usize = 64;

/// The node count a compression (fraction of the full count) allows: rounded, at least 1 (what
/// [`ClothBudget::Compression`] means).
pub fn compression_nodes(compression: f32, full_nodes: usize) -> usize {
    ((compression as f64 * full_nodes as f64).round() as usize).max(1)
}
