//! The time-budget controller: moves the node budget so that a target time per step is held.
//!
//! Step cost is close to linear in the active node count (links per node are bounded), plus a
//! fixed part (evaluation, transitions). The controller therefore treats the measured time per
//! node as the plant: the budget that would hit the target is `nodes * target / time`. Measured
//! times are smoothed (exponential moving average) against timer noise, and the budget moves a
//! fraction of the way to that estimate each update, with its change limited per update. On a
//! linear plant this is a damped secant iteration: it cannot overshoot by more than the damping
//! allows and settles geometrically; the fixed part only shifts the fixed point, which is still
//! where the measured time equals the target.

/// Settings of the [`TimeController`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerSettings {
    /// Weight of the newest measurement in the moving average (0..=1).
    pub smoothing: f32,
    /// Fraction of the way the budget moves towards its estimate per update (0..=1).
    pub gain: f32,
    /// Largest relative change of the budget per update.
    pub max_change: f32,
    /// Relative distance between estimate and budget below which the budget stays (≥ 0).
    /// Timer noise then does not move the budget, and every budget move costs refines or
    /// merges that the hysteresis cannot filter (a shrinking budget forces merges).
    pub deadband: f32,
}

impl Default for ControllerSettings {
    fn default() -> Self {
        ControllerSettings {
            smoothing: 0.3,
            gain: 0.5,
            max_change: 0.25,
            deadband: 0.03,
        }
    }
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

    /// Feeds one measured step (its duration and the active nodes it simulated) and returns the
    /// new node budget.
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
        let estimate = active_nodes as f64 * self.target_seconds / t;
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
}
