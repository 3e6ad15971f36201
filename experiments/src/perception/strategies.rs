//! The strategies compared on every scene at the same node count: the full-resolution
//! reference, the feedback loop and its ablations (the paper's motion-only BSWDF, strain only,
//! camera-blind), the static cuts (uniform, random, near the pins) and the error-bound mode.
//!
//! Based on: the simulation paper (`simulation-lod-treecut-softbody-bswdf.txt`), sections 4–6
//! (the BSWDF feedback loop and its swinging-net comparison), and its seed's motion-only
//! salience (`paper_motion_only`).

use slod::cloth::{ClothBudget, ClothError, FeedbackSettings, PriorityModel};
use softbody::TreeCutError;
use treecut::{Cut, near_vertices_cut, random_cut, uniform_cut};

use super::adapter;
use super::scenes::Scene;

/// Share of a [`Strategy::PinAware`] cut's nodes spent near the pins and anchors.
pub const PIN_AWARE_SHARE: f32 = 0.5;

/// Seed of the [`Strategy::Random`] cut.
pub const RANDOM_SEED: u64 = 0x5EED;

/// How a run chooses its cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Strategy {
    /// Full resolution, no feedback: what every other run is measured against.
    Reference,
    /// The default feedback loop (`FeedbackSettings::default()`) under the node budget.
    Feedback,
    /// The seed's BSWDF alone: salience as priority, no strain term, no memory.
    PaperMotionOnly,
    /// The default loop with the motion salience weighted 0: strain (deformation) only.
    StrainOnly,
    /// The default loop without the view factors (facing, frustum, distance), priorities by
    /// world-space size instead of pixels.
    CameraBlind,
    /// The default loop without the rim weight (`FeedbackSettings::rim_weight` 0): what
    /// keeping the cloth's boundary fine buys.
    RimBlind,
    /// A static cut with every region at about the same depth.
    Uniform,
    /// A static cut refined in a seeded random order.
    Random,
    /// A static cut spending [`PIN_AWARE_SHARE`] of its nodes nearest the pins and anchors.
    PinAware,
    /// The error-bound mode: the fewest nodes that keep the estimated on-screen error under a
    /// bound in pixels.
    ErrorBound,
}

impl Strategy {
    /// Every strategy, in the order the report lists them.
    pub const ALL: [Strategy; 10] = [
        Strategy::Reference,
        Strategy::Feedback,
        Strategy::PaperMotionOnly,
        Strategy::StrainOnly,
        Strategy::CameraBlind,
        Strategy::RimBlind,
        Strategy::Uniform,
        Strategy::Random,
        Strategy::PinAware,
        Strategy::ErrorBound,
    ];

    /// The name in the report: `reference`, `feedback`, `paper_motion_only`, `strain_only`,
    /// `camera_blind`, `rim_blind`, `uniform`, `random`, `pin_aware` or `error_bound`.
    pub fn name(self) -> &'static str {
        match self {
            Strategy::Reference => "reference",
            Strategy::Feedback => "feedback",
            Strategy::PaperMotionOnly => "paper_motion_only",
            Strategy::StrainOnly => "strain_only",
            Strategy::CameraBlind => "camera_blind",
            Strategy::RimBlind => "rim_blind",
            Strategy::Uniform => "uniform",
            Strategy::Random => "random",
            Strategy::PinAware => "pin_aware",
            Strategy::ErrorBound => "error_bound",
        }
    }

    /// Whether the cut follows the feedback loop (else it is static).
    pub fn adapts(self) -> bool {
        self.feedback(1, 1.0).is_some()
    }

    /// The feedback settings of this strategy with a budget of `nodes` (`bound_px` for
    /// [`Strategy::ErrorBound`]); `None` for the reference and the static cuts.
    pub fn feedback(self, nodes: usize, bound_px: f32) -> Option<FeedbackSettings> {
        let budget = ClothBudget::Nodes(nodes.max(1));
        let default = FeedbackSettings {
            budget,
            ..FeedbackSettings::default()
        };
        Some(match self {
            Strategy::Reference | Strategy::Uniform | Strategy::Random | Strategy::PinAware => {
                return None;
            }
            Strategy::Feedback => default,
            Strategy::PaperMotionOnly => FeedbackSettings {
                deformation_weight: 0.0,
                memory_seconds: 0.0,
                priority: PriorityModel::Salience,
                ..default
            },
            Strategy::StrainOnly => adapter::strain_only(default),
            Strategy::CameraBlind => adapter::camera_blind(default),
            Strategy::RimBlind => adapter::rim_blind(default),
            Strategy::ErrorBound => adapter::error_bound(default, bound_px),
        })
    }

    /// The cut a run of this strategy starts from with `nodes` nodes: the finest for the
    /// reference, the strategy's own static cut, a uniform cut for the node-budget loops, and
    /// the finest for the error bound: it starts exact and merges where the error stays under
    /// the bound (merges wait one memory period). Started from the uniform 30% cut, the net's
    /// 1 px run spent its first 90 steps refining (at most 64 transitions in flight) at p99
    /// 2–6 px, and the drift of that coarse start took until step ~135 to decay, so the
    /// whole run's p99 read 3.1 px while steps 135–200 held p99 ≤ 0.87 px, max ≤ 1.6 px.
    pub fn initial_cut(self, scene: &Scene, nodes: usize) -> Result<Cut, ClothError> {
        let h = &*scene.hierarchy;
        let cut = match self {
            Strategy::Reference | Strategy::ErrorBound => Ok(Cut::finest(h)),
            Strategy::Random => random_cut(h, nodes, RANDOM_SEED),
            Strategy::PinAware => {
                near_vertices_cut(h, nodes, &scene.pinned_vertices(), PIN_AWARE_SHARE)
            }
            _ => uniform_cut(h, nodes),
        };
        Ok(cut.map_err(TreeCutError::from)?)
    }
}
