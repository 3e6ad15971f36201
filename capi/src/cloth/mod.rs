//! The adaptive cloth: the simulation paper's closed loop, simulate → salience → evaluate →
//! refine/coarse, under a node, compression or time budget; and the paper's swinging-net
//! experiment measured against a full-resolution reference.

mod adaptive;
mod clock;
mod contact;
#[cfg(test)]
mod contact_tests;
mod controller;
mod error;
mod feedback;
#[cfg(test)]
mod tests;
mod worn;

pub use adaptive::{AdaptiveCloth, ClothStats, UNDO_WINDOW_STEPS};
pub use clock::{CostModel, StepClock, StepWork};
pub use contact::ContactSettings;
pub use controller::{ControllerSettings, StepSample, TimeController};
pub use error::ClothError;
pub use feedback::{
    AUTO_MAX_OPS_FRACTION, BoundCurve, ClothBudget, FLICKER_GAIN_MAX, FLICKER_HALF_LIFE_SECONDS,
    FeedbackSettings, PACED_MAX_OPS, PriorityModel, compression_nodes,
};
pub use worn::BoneAttachments;
