//! What the swinging-net experiment runs: the net and camera ([`NetConfig`]) and the runs
//! compared ([`NetRunKind`]).

use glam::Vec3;
use salience::View;
use slod::cloth::{ClothError, FeedbackSettings};
use softbody::TreeCutSettings;
use treecut::GridSpec;

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct NetConfig {
    /// Vertices per side (the paper: 65).
    pub size: u32,
    /// Steps per run (the paper's figures: 600).
    pub steps: u32,
    /// Side length of the cloth in metres.
    pub width: f32,
    /// Total mass in kilograms.
    pub mass: f32,
    /// Solver, material and blending.
    pub body: TreeCutSettings,
    /// Feedback settings; each feedback run replaces the budget with its compression.
    pub feedback: FeedbackSettings,
    /// The view looking at the net.
    pub view: View,
    /// Compressions to run with feedback (fractions in (0, 1]).
    pub compressions: Vec<f32>,
    /// Compression at which the uniform and random cuts are run (None: skip them).
    pub baseline_compression: Option<f32>,
    /// Seed of the random cut.
    pub random_seed: u64,
    /// Steps after which a snapshot (vertices, particles, links) is kept.
    pub snapshot_steps: Vec<u32>,
    /// Also run the time-budget controller at this target (ms per step).
    pub target_step_ms: Option<f32>,
}

impl NetConfig {
    /// The paper's setup: a 65×65 net, 600 steps, feedback at 100%, 75% and 30%, baselines at
    /// 30%, snapshots after 45, 90 and 180 steps like its Figure 6.
    pub fn paper() -> Result<NetConfig, ClothError> {
        let view = View::look_at(
            Vec3::new(0.0, 0.6, 3.2),
            Vec3::new(0.0, -0.5, 0.0),
            Vec3::Y,
            50f32.to_radians(),
            1280,
            720,
        )?;
        Ok(NetConfig {
            size: 65,
            steps: 600,
            width: 2.0,
            mass: 1.0,
            body: TreeCutSettings::default(),
            feedback: FeedbackSettings::default(),
            view,
            compressions: vec![1.0, 0.75, 0.3],
            baseline_compression: Some(0.3),
            random_seed: 0x5EED,
            snapshot_steps: vec![45, 90, 180],
            target_step_ms: None,
        })
    }

    /// The view on-screen errors are measured through: the net's camera and field of view on a
    /// 1080-pixel-high viewport (1920 × 1080), whatever viewport drives the salience.
    pub fn measure_view(&self) -> Result<View, ClothError> {
        Ok(self.view.with_viewport(1920, 1080)?)
    }

    /// The grid this configuration simulates.
    pub fn grid(&self) -> GridSpec {
        let spacing = self.width / (self.size.max(2) - 1) as f32;
        GridSpec::horizontal(self.size, self.size, spacing, self.mass)
    }
}

/// Which run a [`NetRun`](super::NetRun) is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NetRunKind {
    /// Full resolution, no feedback: the reference every error is measured against.
    Reference,
    /// The feedback loop at this compression.
    Feedback {
        /// Fraction of the full node count.
        compression: f32,
    },
    /// The feedback loop holding a time per step.
    TimeBudget {
        /// Target milliseconds per step.
        target_ms: f32,
    },
    /// A static cut with every region at about the same depth.
    Uniform {
        /// Fraction of the full node count.
        compression: f32,
    },
    /// A static cut refined at random.
    Random {
        /// Fraction of the full node count.
        compression: f32,
    },
}

impl NetRunKind {
    /// A stable machine-readable name: `reference`, `feedback`, `time_budget`, `uniform` or
    /// `random`.
    pub fn name(self) -> &'static str {
        match self {
            NetRunKind::Reference => "reference",
            NetRunKind::Feedback { .. } => "feedback",
            NetRunKind::TimeBudget { .. } => "time_budget",
            NetRunKind::Uniform { .. } => "uniform",
            NetRunKind::Random { .. } => "random",
        }
    }
}
