//! What a world's frame budget holds ([`BudgetTarget`]), how work is counted when the budget is
//! in cost units ([`CostModel`]), how each object takes part ([`BudgetShare`]), and the settings
//! of the controller that holds it ([`WorldBudget`]).

use thiserror::Error;

/// What one world frame may spend.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BudgetTarget {
    /// No world budget: every object keeps its own settings (node budget, LOD mode); the world
    /// only steps them, in parallel.
    None,
    /// Wall-clock milliseconds per frame (> 0). The controller measures each frame's time, so
    /// results depend on the machine and its load: runs are not bit-identical.
    Milliseconds(f32),
    /// Modelled cost per frame in the units of the [`CostModel`] (> 0): simulated link
    /// iterations, node substeps, evaluations and animated bones, counted, not timed. The same
    /// inputs give bit-identical results on any machine and with any thread count.
    CostUnits(f64),
}

/// How work is counted in cost units: a linear model of what each kind of work costs, in
/// modelled nanoseconds on one core (one unit = one modelled nanosecond). The cloth part is the
/// cloth's own [`crate::cloth::CostModel`] (in seconds: what a cloth's deterministic step clock
/// charges, transitions in flight and the fixed cost of a step included), the crowd part is per
/// bone and per character. What matters for a budget is that the ratios between kinds of work
/// are right, so that a unit saved on a cloth is worth a unit saved on a crowd.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostModel {
    /// The cloths' work (seconds per unit of [`crate::cloth::StepWork`]).
    pub cloth: crate::cloth::CostModel,
    /// One bone whose channels were sampled and interpolated, ns.
    pub bone_sampled: f32,
    /// One bone whose model matrix was recomputed, ns.
    pub bone_concatenated: f32,
    /// One character advanced (clock, culling, the scheduler's per-character part), ns.
    pub character: f32,
}

impl Default for CostModel {
    /// The cloth's model with the evaluation of an error-bound loop (it measures each node's
    /// on-screen deviation besides the salience: about 250 ns per node here, against 70 for
    /// salience alone), and the crowd's per-bone costs measured on the same machine.
    fn default() -> Self {
        CostModel {
            cloth: crate::cloth::CostModel {
                evaluated_node: 250e-9,
                ..crate::cloth::CostModel::default()
            },
            bone_sampled: 40.0,
            bone_concatenated: 10.0,
            character: 150.0,
        }
    }
}

impl CostModel {
    /// Checks every weight is finite and ≥ 0.
    pub fn validate(&self) -> Result<(), WorldError> {
        if !self.cloth.is_valid() {
            return Err(WorldError::Setting {
                field: "cost.cloth",
                reason: "every coefficient must be finite and >= 0",
            });
        }
        let weights = [
            ("cost.bone_sampled", self.bone_sampled),
            ("cost.bone_concatenated", self.bone_concatenated),
            ("cost.character", self.character),
        ];
        for (field, w) in weights {
            if !(w.is_finite() && w >= 0.0) {
                return Err(WorldError::Setting {
                    field,
                    reason: "must be finite and >= 0",
                });
            }
        }
        Ok(())
    }
}

/// What a world frame measures to hold a [`BudgetTarget::Milliseconds`] budget.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum FrameClock {
    /// The frame's wall time (the default; what an engine pays).
    #[default]
    Wall,
    /// The frame's modelled cost times this many nanoseconds per unit: a deterministic clock
    /// for tests of the millisecond controller on a noisy machine.
    Modelled {
        /// Nanoseconds per cost unit (> 0).
        ns_per_unit: f64,
    },
}

/// How one object takes part in the world budget (Unreal's animation budget allocator and
/// NVIDIA APEX's LOD benefit both let the host override it per object).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BudgetShare {
    /// Spends the world budget: the object's error bound is the world's bound divided by
    /// `weight` (> 0, finite), so a weight of 2 gets the detail of an object twice as large on
    /// screen. The default, with weight 1.
    Shared {
        /// Importance relative to other objects (1 = as its pixels say).
        weight: f32,
    },
    /// Always at full detail (APEX's `forcePhysicalLod`): a cloth's cut goes to the finest
    /// level, a crowd plays with LOD off. Its cost still counts against the budget, so the
    /// others give way.
    FullDetail,
    /// Keeps its own settings (node budget, compression, time budget, LOD mode); the world
    /// steps it and counts its cost, but does not change its detail.
    Own,
}

impl Default for BudgetShare {
    fn default() -> Self {
        BudgetShare::Shared { weight: 1.0 }
    }
}

impl BudgetShare {
    /// Checks a shared weight is finite and positive.
    pub fn validate(&self) -> Result<(), WorldError> {
        match *self {
            BudgetShare::Shared { weight } if !(weight.is_finite() && weight > 0.0) => {
                Err(WorldError::Setting {
                    field: "weight",
                    reason: "must be finite and > 0",
                })
            }
            _ => Ok(()),
        }
    }
}

/// Settings of a world's frame budget. `Default` is the measured-good value with no budget
/// ([`BudgetTarget::None`]); set `target` to spend one.
///
/// # How the budget is spent
/// One on-screen error bound in pixels is shared by every object that takes part: each cloth
/// runs its feedback loop under [`crate::cloth::ClothBudget::MaxErrorPx`] and each crowd under
/// `animlod::LodMode::ErrorBound` with that bound (divided by the object's weight). An object
/// then spends nodes or bone updates exactly where its estimated on-screen error exceeds the
/// bound, so a close cloth gets nodes before a distant one and a crowd's far characters give way
/// to a near cape: the same pixel of error is worth the same everywhere. A controller moves the
/// bound every `update_frames` frames so that the frame's cost holds the target: each cloth
/// under the bound says how many nodes its cut heads to at any bound (its
/// [`crate::cloth::BoundCurve`], read off its last evaluation), a crowd's cost goes as the
/// bound's inverse (a held bone's drift grows with its hold time), and the controller moves
/// `gain` of the way (on the log scale) to the bound at which that model meets the target, at
/// most a factor `max_change` per update, and not at all inside the relative `deadband`
/// (without cloths: by `gain` times the logarithm of cost over target; see the `controller`
/// module).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldBudget {
    /// What a frame may spend.
    pub target: BudgetTarget,
    /// Threads the world step uses: 0 all of the current pool (the C world's pool), 1 the
    /// calling thread only, n ≥ 2 a pool of n threads the budget owns.
    pub threads: usize,
    /// The bound the controller starts from, px (> 0).
    pub initial_error_px: f32,
    /// The smallest bound the controller may set, px (> 0): below it every object is at about
    /// full detail already.
    pub min_error_px: f32,
    /// The largest bound, px (≥ `min_error_px`).
    pub max_error_px: f32,
    /// Frames between controller updates (≥ 1); the cloths' feedback interval, so every cloth
    /// has evaluated under a bound before it moves again. When a frame is shorter than the
    /// cloths' step the window is this many times the frames per step (10 frames at 120 Hz
    /// with 60 Hz cloths: the same simulated time). The cloths' step groups and evaluation
    /// phases are redrawn every `update_frames` frames.
    pub update_frames: u32,
    /// Fraction of the measured log-ratio the bound moves per update, in (0, 1].
    pub gain: f32,
    /// Relative distance between the window's cost and the target under which the bound stays
    /// ([0, 1)): every move of the bound costs refines or merges. Default 1%: the cloths' own
    /// merge hysteresis (a node merges at an eighth of the bound it refines at) already keeps a
    /// bound that moves by a few percent from undoing operations, and a wider band let the
    /// cost rest at its edge while the cloths' errors kept growing (wind picking up, swings
    /// building), so frames crossed +10%. On the world tests' twelve cloths and crowd (cost-unit
    /// budget, 35% / 60% of full detail, before the controller read the cloths' curves) it
    /// settled after 49 / 53 frames with 4%, 38 / 47 with 1%; with the cloths at 64 substeps
    /// 190 / 42 against 28 / 36; nothing undone either way, and the demo's street scene the
    /// same (54 against 53 frames, 96.6% against 95.9% within ±10%).
    pub deadband: f32,
    /// Largest factor the bound changes by per update (> 1).
    pub max_change: f32,
    /// Fraction of the target that refine/coarse transitions in flight may spend ([0, 1]; 0 =
    /// no cap). A transition costs a step as much as a few dozen simulated nodes while it
    /// blends (the cloth's [`crate::cloth::CostModel::transition`] and
    /// [`crate::cloth::CostModel::transition_substep`] by its substeps), so a cut that moves fast
    /// makes frames long exactly when the budget is being met: the cloths due to evaluate in a
    /// frame share what is left of this allowance (plus what the last frame left unspent; under
    /// a wall-clock millisecond target, its time left converted at what one more cost unit
    /// costs, fitted over recent frames) as their operation cap.
    pub transition_share: f32,
    /// Most solver steps a cloth takes in one frame when the frame's `dt` is longer than its
    /// own (≥ 1); time beyond it is dropped, so a long frame does not make the next one longer.
    pub max_cloth_steps: u32,
    /// How work is counted for [`BudgetTarget::CostUnits`] (and reported for the others).
    pub cost: CostModel,
    /// What a millisecond budget measures.
    pub clock: FrameClock,
    /// After each phase of a frame (crowds, cloths) the frame's worker threads spin for up to this
    /// long, ms, waiting for the next phase instead of going to sleep (all of them between phases,
    /// all but one after the frame; [0, 1000]; 0 = never). Waking a sleeping worker took 0.4–2.6 ms
    /// at the 99th percentile on this project's 2-core virtual machine, and a worker that starts a
    /// phase late leaves the frame on fewer threads for that long (see `world::warm`). Between
    /// phases the spin ends within microseconds; after a frame's last phase it lasts until the next
    /// world step or this limit, burning up to this long of one core per frame (and holding pool
    /// threads the host may want for other rayon work in that time). Only pools of ≥ 2 threads
    /// spin.
    pub spin_wait_ms: f32,
}

impl Default for WorldBudget {
    fn default() -> Self {
        WorldBudget {
            target: BudgetTarget::None,
            threads: 0,
            initial_error_px: 1.0,
            min_error_px: 0.05,
            max_error_px: 200.0,
            update_frames: 5,
            gain: 0.8,
            deadband: 0.01,
            max_change: 2.0,
            max_cloth_steps: 4,
            transition_share: 0.1,
            cost: CostModel::default(),
            clock: FrameClock::Wall,
            spin_wait_ms: 1.0,
        }
    }
}

impl WorldBudget {
    /// Checks every setting (see the fields); the first one out of range is named.
    pub fn validate(&self) -> Result<(), WorldError> {
        let bad = |field, reason| Err(WorldError::Setting { field, reason });
        match self.target {
            BudgetTarget::Milliseconds(ms) if !(ms.is_finite() && ms > 0.0) => {
                return bad("target_ms", "must be finite and > 0");
            }
            BudgetTarget::CostUnits(u) if !(u.is_finite() && u > 0.0) => {
                return bad("target_units", "must be finite and > 0");
            }
            _ => {}
        }
        if self.threads > 1024 {
            return bad("threads", "at most 1024");
        }
        let px = |v: f32| v.is_finite() && v > 0.0;
        if !px(self.initial_error_px) {
            return bad("initial_error_px", "must be finite and > 0");
        }
        if !px(self.min_error_px) {
            return bad("min_error_px", "must be finite and > 0");
        }
        if !(px(self.max_error_px) && self.max_error_px >= self.min_error_px) {
            return bad("max_error_px", "must be finite and >= min_error_px");
        }
        if self.update_frames == 0 {
            return bad("update_frames", "must be >= 1");
        }
        if !(self.gain > 0.0 && self.gain <= 1.0) {
            return bad("gain", "must be in (0, 1]");
        }
        if !(self.deadband >= 0.0 && self.deadband < 1.0) {
            return bad("deadband", "must be in [0, 1)");
        }
        if !(self.max_change.is_finite() && self.max_change > 1.0) {
            return bad("max_change", "must be finite and > 1");
        }
        if !(0.0..=1.0).contains(&self.transition_share) {
            return bad("transition_share", "must be in [0, 1]");
        }
        if self.max_cloth_steps == 0 {
            return bad("max_cloth_steps", "must be >= 1");
        }
        if !(self.spin_wait_ms.is_finite() && (0.0..=1000.0).contains(&self.spin_wait_ms)) {
            return bad("spin_wait_ms", "must be in [0, 1000]");
        }
        if let FrameClock::Modelled { ns_per_unit } = self.clock
            && !(ns_per_unit.is_finite() && ns_per_unit > 0.0)
        {
            return bad("clock.ns_per_unit", "must be finite and > 0");
        }
        self.cost.validate()
    }
}

/// Why a world refused a call. A refused setting changes nothing.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum WorldError {
    /// A budget setting is out of range; names the field.
    #[error("world budget setting `{field}`: {reason}")]
    Setting {
        /// The field.
        field: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// No object with this key lives in the world.
    #[error("no such object in the world")]
    NoSuchObject,
    /// The budget's worker threads could not be started.
    #[error("cannot start worker threads: {0}")]
    Threads(String),
    /// A cloth refused its step or its new bound (the others of the frame still stepped).
    #[error("cloth: {0}")]
    Cloth(#[from] crate::cloth::ClothError),
    /// A crowd refused its advance or its new bound.
    #[error("crowd: {0}")]
    Crowd(#[from] animlod::CrowdError),
}
