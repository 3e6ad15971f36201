//! The adaptive cloth: the simulation paper's closed loop, simulate → salience → evaluate →
//! refine/coarse, under a node, compression or time budget; and the paper's swinging-net
//! experiment measured against a full-resolution reference.

mod adaptive;
mod controller;
mod error;
mod feedback;
#[cfg(test)]
mod tests;

pub use adaptive::{AdaptiveCloth, ClothStats, UNDO_WINDOW_STEPS};
pub use controller::{ControllerSettings, TimeController};
pub use error::ClothError;
pub use feedback::{ClothBudget, FeedbackSettings, PriorityModel, compression_nodes};
