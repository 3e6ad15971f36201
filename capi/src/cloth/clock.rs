//! How an [`AdaptiveCloth`](super::AdaptiveCloth) measures the time of its steps: the wall clock
//! (what a host pays, the default) or a deterministic cost model of the step's work (what tests
//! and hosts that want reproducible runs use).
//!
//! The time-budget controller ([`super::TimeController`]) reads whatever the clock says, so with
//! [`StepClock::Model`] a [`ClothBudget::TargetStepMs`](super::ClothBudget::TargetStepMs) run is
//! bit-identical from run to run and machine to machine, and its settling can be asserted in a
//! test on a noisy machine.

/// The work one step did, as the cost model counts it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepWork {
    /// Link constraint solves: links (plain and group) × substeps × iterations.
    pub link_iterations: u64,
    /// Particle integrations: simulated nodes × substeps.
    pub node_substeps: u64,
    /// Refine/coarse transitions blended during the step (each one also begins or ends).
    pub transitions: u64,
    /// Those transitions × the step's substeps (their blended links are solved every substep).
    pub transition_substeps: u64,
    /// Nodes whose salience the feedback evaluation measured in this step (0 on steps without
    /// an evaluation).
    pub evaluated_nodes: u64,
}

/// A deterministic cost per unit of work, in seconds: `fixed + link_iteration ×
/// link_iterations + node_substep × node_substeps + transition × transitions +
/// transition_substep × transition_substeps + evaluated_node × evaluated_nodes`.
///
/// The defaults are the TreeCut cloth measured on the 2-core development machine (release build,
/// 65×65 net, 32 substeps of one iteration): 2 ns per link solve, 1 ns per particle update,
/// 6 µs per transition in flight at 32 substeps (a transition costs as much as about twenty
/// simulated nodes: its group constraint, the links it fades, and its begin and end), and 70 ns
/// per node an evaluation measures. A transition's cost grows with the substeps, as its blended
/// links are solved in every one: measured on a 65² net at level 2 with ~28 refines in flight,
/// 2.1 / 3.2 / 5.4 µs per transition per step at 16 / 32 / 64 substeps, about 1 µs plus 70 ns per
/// substep; so the 6 µs are charged as 1 µs per step plus 156 ns per substep (the same at 32,
/// 3.5 µs at 16, 11 µs at 64). They need not be accurate: what matters for a test is that the
/// model has the shape of the real cost (linear in the work, transitions expensive, the
/// evaluation a spike every `interval` steps).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostModel {
    /// Seconds per step whatever the work.
    pub fixed: f64,
    /// Seconds per link solve.
    pub link_iteration: f64,
    /// Seconds per particle update.
    pub node_substep: f64,
    /// Seconds per transition in flight per step (its part that does not depend on the
    /// substeps).
    pub transition: f64,
    /// Seconds per transition in flight per substep.
    pub transition_substep: f64,
    /// Seconds per node measured by an evaluation.
    pub evaluated_node: f64,
}

impl Default for CostModel {
    fn default() -> Self {
        CostModel {
            fixed: 5e-6,
            link_iteration: 2e-9,
            node_substep: 1e-9,
            transition: 1e-6,
            transition_substep: 5e-6 / 32.0,
            evaluated_node: 70e-9,
        }
    }
}

impl CostModel {
    /// The seconds this model charges for `work`.
    pub fn seconds(&self, work: &StepWork) -> f64 {
        self.fixed
            + self.link_iteration * work.link_iterations as f64
            + self.node_substep * work.node_substeps as f64
            + self.transition_seconds(work)
            + self.evaluated_node * work.evaluated_nodes as f64
    }

    /// The part of [`CostModel::seconds`] the transitions in flight account for.
    pub fn transition_seconds(&self, work: &StepWork) -> f64 {
        self.transition * work.transitions as f64
            + self.transition_substep * work.transition_substeps as f64
    }

    /// What one transition in flight costs a step of `substeps` substeps, seconds.
    pub fn per_transition_seconds(&self, substeps: u32) -> f64 {
        self.transition + self.transition_substep * substeps as f64
    }

    /// The part of [`CostModel::seconds`] the evaluation accounts for.
    pub fn evaluation_seconds(&self, work: &StepWork) -> f64 {
        self.evaluated_node * work.evaluated_nodes as f64
    }

    /// Whether every coefficient is finite and ≥ 0.
    pub fn is_valid(&self) -> bool {
        [
            self.fixed,
            self.link_iteration,
            self.node_substep,
            self.transition,
            self.transition_substep,
            self.evaluated_node,
        ]
        .iter()
        .all(|c| c.is_finite() && *c >= 0.0)
    }
}

/// How an [`AdaptiveCloth`](super::AdaptiveCloth) times its steps (see
/// [`AdaptiveCloth::set_step_clock`](super::AdaptiveCloth::set_step_clock)).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum StepClock {
    /// The wall clock (`std::time::Instant`): what the host really pays. Runs of a time budget
    /// then depend on the machine and its load.
    #[default]
    Wall,
    /// A deterministic cost computed from each step's work ([`StepWork`]): the same calls give
    /// the same times, so a time-budget run is reproducible.
    Model(CostModel),
}
