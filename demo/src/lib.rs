//! The slod demo: the simulation paper's swinging net (TreeCut-SoftBody, section 6) and the
//! bone-priority thesis' crowd (chapter 13) measured on this machine, printed beside the
//! papers' own figures, with pictures of the net, plots and a machine-readable `report.json`.
//!
//! The binary is a thin wrapper over [`run_cli`], so the tests run exactly what a user runs.
//! Modules, in the order a run uses them: `cli` (arguments), `net`, `crowd`, `engine`, `perception` and
//! `world` (the experiments), `render` and `plots` (pictures), `report` (JSON) and
//! `app` (the sequence and the summary).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod app;
mod cli;
mod crowd;
mod crowd_large;
mod engine;
mod error;
mod font;
mod machine;
mod net;
mod paper;
mod peer;
mod perception;
mod plots;
mod progress;
mod render;
mod report;
mod targets;
mod world;

pub use app::run_cli;
pub use cli::{EXIT_FAILURE, EXIT_USAGE, usage};
pub use progress::Progress;
