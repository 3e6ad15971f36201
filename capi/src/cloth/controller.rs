//! The time-budget controller: moves the node budget so that a target time per step is held.
//!
//! # The plant, measured
//! On the swinging net (65×65, 32 substeps) a step costs about 0.32 µs per simulated node, but a
//! refine or coarse transition in flight costs about 6 µs per step (its group constraint, the
//! links it fades, its begin and end): as much as twenty nodes. The evaluation adds a spike
//! every `interval` steps. The earlier controller fed the mean step time of each interval, spike
//! and transitions included, into a secant on the node count. From a cold start that read the
//! transitions of the shrink as per-node cost: it drove the budget to a quarter of what the
//! target allows (312 nodes for a 0.46 ms target where 1420 hold it), the cut followed, then
//! refined back (55 undone operations), and crept up by 3% steps until about step 320 — later
//! and with more churn on a loaded machine, whose timer noise moved the budget too.
//!
//! # The model
//! [`TimeController::observe`] is given every step: its time, the part the evaluation took,
//! the simulated nodes and the transitions in flight. At the end of each interval
//! ([`TimeController::end_interval`]) it fits
//!
//! * the cost per node from the steps without transitions (the *settled* work: the interval's
//!   median, against timer noise, smoothed over intervals; taken outright when the node count
//!   has moved by more than [`ControllerSettings::deadband`] · 3 since the last fit, because
//!   the old estimate then describes another cut),
//! * the evaluation's share per step,
//!
//! and sets the budget to the node count whose settled steps, plus the evaluation's share, take
//! the target: `(target − evaluation per step) / cost per node`. Transitions never enter the fit,
//! so a shrinking cut does not read as an expensive one; the budget jumps close to the target in
//! one or two updates and then holds. Steps with transitions in flight are skipped, so the
//! budget waits while the cut is still moving (hold-off); if an interval has none it keeps the
//! budget. With no settled step yet (a host whose first intervals all have transitions in flight)
//! the mean time per node over all steps stands in until the first settled one. A deadband keeps
//! timer noise from moving the budget: every move costs refines or merges the hysteresis cannot
//! filter (a shrinking budget forces merges).
//!
//! [`TimeController::update`] is the earlier interface: one mean time per update, a damped
//! secant on the node count. It is kept for hosts that measure their own steps.

/// Settings of the [`TimeController`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerSettings {
    /// Weight of the newest measurement in the moving average (0..=1): the newest interval's
    /// cost per node with [`TimeController::observe`], the newest mean time with
    /// [`TimeController::update`].
    pub smoothing: f32,
    /// Fraction of the way the budget moves towards its estimate per update (0..=1).
    pub gain: f32,
    /// Largest relative change of the budget per update.
    pub max_change: f32,
    /// Relative distance between estimate and budget below which the budget stays (≥ 0).
    /// Timer noise then does not move the budget, and every budget move costs refines or
    /// merges that the hysteresis cannot filter (a shrinking budget forces merges).
    pub deadband: f32,
    /// Share of the target step time the transitions in flight may cost (in (0, 1]; see
    /// [`TimeController::max_transitions`]).
    pub transition_share: f32,
}

impl Default for ControllerSettings {
    /// Smoothing 0.3, gain 1 (the fitted model is trusted: the budget goes to its estimate,
    /// within `max_change`), largest change 75% per update (a cold start from the finest cut
    /// reaches a quarter of it in one update), deadband 3%, transitions
    /// may cost 10% of the target.
    fn default() -> Self {
        ControllerSettings {
            smoothing: 0.3,
            gain: 1.0,
            max_change: 0.75,
            deadband: 0.03,
            transition_share: 0.1,
        }
    }
}

/// Settled steps the cost per node is the median of (the newest).
const RECENT_STEPS: usize = 15;
/// Evaluations the evaluation's cost per node is the median of (the newest).
const RECENT_EVALUATIONS: usize = 5;
/// Relative distance in node count within which a settled step still describes the cut.
const NEAR: f64 = 0.1;

/// One step as the controller sees it (see [`TimeController::observe`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepSample {
    /// Seconds the step took, evaluation included.
    pub seconds: f64,
    /// Seconds of them the feedback evaluation took (0 on steps without one).
    pub eval_seconds: f64,
    /// Simulated nodes during the step.
    pub nodes: usize,
    /// Refine/coarse transitions in flight during the step.
    pub transitions: usize,
}

/// Holds a target time per step by moving a node budget.
#[derive(Clone, Debug)]
pub struct TimeController {
    target_seconds: f64,
    settings: ControllerSettings,
    smoothed: Option<f64>,
    budget: f64,
    min_nodes: usize,
    max_nodes: usize,
    /// The steps observed since the last [`TimeController::end_interval`].
    interval: Vec<StepSample>,
    /// Fitted seconds per node of a settled step.
    per_node: Option<f64>,
    /// Seconds per node and node count of the recent steps without transitions, oldest first.
    recent: Vec<(f64, usize)>,
    /// Seconds a transition in flight added to the recent steps with transitions, oldest first.
    recent_transition: Vec<f64>,
    /// Evaluation seconds per node and step of the recent evaluations, oldest first.
    recent_eval: Vec<f64>,
}

impl TimeController {
    /// A controller aiming at `target_seconds` per step, starting at `initial` nodes and keeping
    /// the budget within `[min_nodes, max_nodes]`.
    pub fn new(
        target_seconds: f64,
        initial: usize,
        min_nodes: usize,
        max_nodes: usize,
        settings: ControllerSettings,
    ) -> TimeController {
        TimeController {
            target_seconds,
            settings,
            smoothed: None,
            budget: initial.clamp(min_nodes, max_nodes) as f64,
            min_nodes,
            max_nodes,
            interval: Vec::new(),
            per_node: None,
            recent: Vec::new(),
            recent_eval: Vec::new(),
            recent_transition: Vec::new(),
        }
    }

    /// The current node budget.
    pub fn budget(&self) -> usize {
        self.budget.round() as usize
    }

    /// The target time per step, in seconds.
    pub fn target_seconds(&self) -> f64 {
        self.target_seconds
    }

    /// The fitted seconds per simulated node of a step without transitions in flight (None
    /// before the first interval).
    pub fn seconds_per_node(&self) -> Option<f64> {
        self.per_node
    }

    /// The fitted seconds a refine or coarse transition in flight adds to a step (None before
    /// any step with transitions was observed after the first fit).
    pub fn seconds_per_transition(&self) -> Option<f64> {
        median(&mut self.recent_transition.clone())
    }

    /// How many transitions may be in flight in a step of a cut of `nodes` nodes: as many as
    /// [`ControllerSettings::transition_share`] of the target pays for, plus the time a cut
    /// under its budget leaves (the settled step of `nodes` nodes is predicted below the
    /// target), at least 1. None until the cost of a transition has been fitted.
    ///
    /// Why: a transition in flight costs a step as much as about twenty settled nodes (see the
    /// module documentation), so a batch of 64 swaps lifted the steps it blended through by
    /// half the target. The cap keeps a settled cut's swaps within the ±10% a host expects,
    /// while a cut far under its budget still grows quickly.
    pub fn max_transitions(&self, nodes: usize) -> Option<usize> {
        let c = self.seconds_per_transition().filter(|&c| c > 0.0)?;
        let k = self.per_node? + median(&mut self.recent_eval.clone()).unwrap_or(0.0);
        let headroom = (self.target_seconds - k * nodes as f64).max(0.0);
        let share = self.settings.transition_share as f64 * self.target_seconds;
        Some((((share + headroom) / c).floor() as usize).max(1))
    }

    /// Feeds one measured step (its duration and the active nodes it simulated) and returns the
    /// new node budget: the earlier interface, a damped secant on the smoothed mean time, with
    /// no knowledge of transitions or the evaluation (see the module documentation).
    pub fn update(&mut self, seconds: f64, active_nodes: usize) -> usize {
        if !(seconds.is_finite() && seconds > 0.0) || active_nodes == 0 {
            return self.budget();
        }
        let a = self.settings.smoothing as f64;
        let t = match self.smoothed {
            None => seconds,
            Some(s) => s + a * (seconds - s),
        };
        self.smoothed = Some(t);
        self.move_towards(active_nodes as f64 * self.target_seconds / t)
    }

    /// Records one step of the current interval; [`TimeController::end_interval`] fits the model
    /// and moves the budget. Steps with a non-finite or negative time, or no nodes, are ignored.
    pub fn observe(&mut self, sample: StepSample) {
        let ok = |x: f64| x.is_finite() && x >= 0.0;
        if ok(sample.seconds) && ok(sample.eval_seconds) && sample.nodes > 0 {
            self.interval.push(sample);
        }
    }

    /// Ends the interval observed since the last call: fits the cost per settled node and the
    /// evaluation's share per step (see the module documentation), moves the budget towards the
    /// node count they predict for the target, and returns the new budget. Without observed
    /// steps, or without a step free of transitions once a settled fit exists, the budget stays.
    pub fn end_interval(&mut self) -> usize {
        let steps = std::mem::take(&mut self.interval);
        if steps.is_empty() {
            return self.budget();
        }
        // The evaluation measures every node: its cost per node, spread over the interval; the
        // median of the recent evaluations, so one the machine disturbed does not move the
        // budget.
        for s in steps.iter().filter(|s| s.eval_seconds > 0.0) {
            if self.recent_eval.len() == RECENT_EVALUATIONS {
                self.recent_eval.remove(0);
            }
            self.recent_eval
                .push(s.eval_seconds / (s.nodes as f64 * steps.len() as f64));
        }
        let eval_per_node = median(&mut self.recent_eval.clone()).unwrap_or(0.0);
        let per_node = |s: &StepSample| (s.seconds - s.eval_seconds).max(0.0) / s.nodes as f64;
        // What a transition in flight costs a step: the time above the settled cost of its
        // nodes, per transition (the median of the recent steps with transitions).
        if let Some(k) = self.per_node {
            for s in steps.iter().filter(|s| s.transitions > 0) {
                if self.recent_transition.len() == RECENT_STEPS {
                    self.recent_transition.remove(0);
                }
                let extra = s.seconds - s.eval_seconds - k * s.nodes as f64;
                self.recent_transition
                    .push(extra.max(0.0) / s.transitions as f64);
            }
        }
        let clean = steps.iter().filter(|s| s.transitions == 0).count();
        if 2 * clean < steps.len() {
            if self.per_node.is_some() {
                // Hold-off: the cut is still moving (transitions in most steps); the budget
                // waits for it to settle rather than reading a moving cut.
                self.interval = steps;
                self.interval.clear();
                return self.budget();
            }
            // No settled interval seen yet: the mean over all steps stands in (it overestimates
            // the cost per node, so the budget errs low until a settled interval comes).
            let secs: f64 = steps.iter().map(|s| s.seconds - s.eval_seconds).sum();
            let nodes: f64 = steps.iter().map(|s| s.nodes as f64).sum();
            self.per_node = Some(secs.max(0.0) / nodes);
        } else {
            for s in steps.iter().filter(|s| s.transitions == 0) {
                if self.recent.len() == RECENT_STEPS {
                    self.recent.remove(0);
                }
                self.recent.push((per_node(s), s.nodes));
            }
            // The median of the recent settled steps at about the current node count: the cost
            // per node depends on the count (caches), and a median ignores the steps the
            // machine disturbed.
            let newest = self.recent.last().map_or(0, |&(_, n)| n) as f64;
            let mut near: Vec<f64> = self
                .recent
                .iter()
                .filter(|&&(_, n)| (n as f64 - newest).abs() <= NEAR * newest)
                .map(|&(k, _)| k)
                .collect();
            self.per_node = median(&mut near);
        }
        let k = self.per_node.expect("fitted above") + eval_per_node;
        // Half the transitions' share is kept free: a settled interval without operations then
        // takes that much under the target, one whose swaps spend the whole share that much
        // over it.
        let reserve = 0.5 * self.settings.transition_share as f64;
        let estimate = if k > 0.0 {
            self.target_seconds * (1.0 - reserve) / k
        } else {
            self.max_nodes as f64
        };
        self.interval = steps;
        self.interval.clear();
        self.move_towards(estimate)
    }

    /// Moves the budget towards `estimate` (nodes) within the deadband, gain and largest change.
    fn move_towards(&mut self, estimate: f64) -> usize {
        if (estimate - self.budget).abs() <= self.settings.deadband as f64 * self.budget {
            return self.budget();
        }
        let step = self.settings.gain as f64 * (estimate - self.budget);
        let limit = self.settings.max_change as f64 * self.budget.max(1.0);
        self.budget = (self.budget + step.clamp(-limit, limit))
            .clamp(self.min_nodes as f64, self.max_nodes as f64);
        self.budget()
    }
}

/// The median of `values` (sorted in place; the upper one of an even count), None if empty.
fn median(values: &mut [f64]) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A plant like the cloth: cost linear in nodes plus a fixed part, with ±3% timer noise, and
    /// a node count that follows the budget at a limited rate (the evaluator's operation cap).
    fn run(target_ms: f64, start_nodes: usize) -> Vec<(f64, usize)> {
        let (per_node, fixed) = (0.25e-6, 0.05e-3);
        let mut c = TimeController::new(
            target_ms * 1e-3,
            start_nodes,
            16,
            4225,
            ControllerSettings::default(),
        );
        let mut nodes = start_nodes;
        let mut noise: rand_pcg::Pcg64Mcg = rand_core::SeedableRng::seed_from_u64(12345);
        let mut out = Vec::new();
        for _ in 0..300 {
            let draw = rand_core::RngCore::next_u32(&mut noise) >> 8;
            let jitter = 1.0 + 0.03 * (draw as f64 / (1u32 << 24) as f64 * 2.0 - 1.0);
            let t = (fixed + per_node * nodes as f64) * jitter;
            out.push((t, nodes));
            let b = c.update(t, nodes);
            nodes = if b > nodes {
                (nodes + 150).min(b)
            } else {
                nodes.saturating_sub(150).max(b)
            };
        }
        out
    }

    #[test]
    fn settles_within_60_steps_and_holds_10_percent() {
        for (target, start) in [(0.5, 4225), (0.5, 100), (0.8, 1000), (0.3, 4225)] {
            let trace = run(target, start);
            for (i, &(t, n)) in trace.iter().enumerate().skip(60) {
                let ms = t * 1e3;
                assert!(
                    (ms - target).abs() <= 0.1 * target,
                    "target {target} ms from {start}: step {i} took {ms:.3} ms with {n} nodes"
                );
            }
        }
    }

    #[test]
    fn budget_stays_in_bounds() {
        let mut c = TimeController::new(1e-9, 500, 16, 4225, ControllerSettings::default());
        for _ in 0..100 {
            c.update(1e-3, 500);
        }
        assert_eq!(c.budget(), 16);
        let mut c = TimeController::new(1.0, 500, 16, 4225, ControllerSettings::default());
        for _ in 0..100 {
            c.update(1e-3, c.budget());
        }
        assert_eq!(c.budget(), 4225);
    }

    /// The fitted model ignores what transitions and a disturbed step cost: on a plant whose
    /// transitions cost twenty nodes each and whose machine once takes 4 ms more for a step,
    /// the budget goes to the node count that holds the target in one update and stays there.
    #[test]
    fn model_fit_ignores_transitions_and_disturbances() {
        let (per_node, per_transition, target) = (0.3e-6, 6e-6, 0.5e-3);
        let settings = ControllerSettings::default();
        let mut c = TimeController::new(target, 4000, 1, 4000, settings);
        let want = target * (1.0 - 0.5 * settings.transition_share as f64) / per_node;
        let mut nodes = 4000usize;
        for interval in 0..40 {
            let b = c.budget();
            // The cut moves 200 nodes per interval towards the budget, with a transition per
            // 3 nodes in flight in four of five steps while it moves.
            let moving = nodes.abs_diff(b).min(200);
            for step in 0..5 {
                let transitions = if step < 4 { moving / 3 } else { 0 };
                let mut seconds = per_node * nodes as f64 + per_transition * transitions as f64;
                if interval == 30 && step == 2 {
                    seconds += 4e-3;
                }
                c.observe(StepSample {
                    seconds,
                    eval_seconds: 0.0,
                    nodes,
                    transitions,
                });
            }
            nodes = if b > nodes {
                nodes + moving
            } else {
                nodes - moving
            };
            c.end_interval();
            if interval >= 1 {
                let err = (c.budget() as f64 - want).abs() / want;
                assert!(
                    err < 0.05,
                    "interval {interval}: budget {} for {want}",
                    c.budget()
                );
            }
        }
        let c_t = c.seconds_per_transition().unwrap();
        assert!((c_t - per_transition).abs() < 0.1 * per_transition, "{c_t}");
        assert!(c.max_transitions(c.budget()).unwrap() >= 1);
    }
}
