//! `report.json`: every figure the demo printed, with its units in the field names (`_ms`,
//! `_us`, `_px`, `_mm`, `_m`, `_s`, `_fraction`), the papers' figures beside ours, and the
//! machine it ran on. The README (its report.json section) documents every field.

use std::path::Path;

use serde::Serialize;

use crate::crowd::CrowdSection;
use crate::engine::EngineSection;
use crate::error::DemoError;
use crate::machine::Machine;
use crate::net::NetSection;
use crate::perception::PerceptionSection;
use crate::targets::TargetCheck;
use crate::world::WorldSection;

/// Version of the report's layout; bumped when a field changes meaning or disappears.
pub(crate) const SCHEMA: &str = "slod-demo-report/2";

/// Wall times of the stages (s).
#[derive(Clone, Debug, Default, Serialize)]
pub(crate) struct Seconds {
    /// The net section's measurements.
    pub(crate) net: f64,
    /// The crowd section's measurements.
    pub(crate) crowd: f64,
    /// The engine section's measurements.
    pub(crate) engine: f64,
    /// The perception section's measurements.
    pub(crate) perception: f64,
    /// The world section's measurements.
    pub(crate) world: f64,
    /// Drawing pictures and plots.
    pub(crate) pictures: f64,
    /// Everything, report included.
    pub(crate) total: f64,
}

/// The whole report.
#[derive(Debug, Serialize)]
pub(crate) struct Report<'a> {
    /// [`SCHEMA`].
    pub(crate) schema: &'static str,
    /// `all`, `net`, `crowd`, `engine`, `perception` or `world`.
    pub(crate) command: &'static str,
    /// Whether `--quick` was given.
    pub(crate) quick: bool,
    /// The command line (without the program name).
    pub(crate) arguments: &'a [String],
    /// Where and when.
    pub(crate) machine: &'a Machine,
    /// The swinging net (null when not run).
    pub(crate) net: Option<&'a NetSection>,
    /// The crowd (null when not run).
    pub(crate) crowd: Option<&'a CrowdSection>,
    /// The engine scenes (null when not run).
    pub(crate) engine: Option<&'a EngineSection>,
    /// Perception scenes and strategies on screen (null when not run).
    pub(crate) perception: Option<&'a PerceptionSection>,
    /// One frame budget for the whole world (null when not run).
    pub(crate) world: Option<&'a WorldSection>,
    /// The open issues' targets checked against this run's figures (only those the sections
    /// that ran speak to; `met` null where this run does not measure the target).
    pub(crate) targets: &'a [TargetCheck],
    /// Files written next to the report (names relative to the output directory).
    pub(crate) files: Vec<String>,
    /// Wall times.
    pub(crate) seconds: Seconds,
}

/// Writes the report as pretty JSON.
pub(crate) fn write(path: &Path, report: &Report<'_>) -> Result<(), DemoError> {
    let mut text = serde_json::to_string_pretty(report)?;
    text.push('\n');
    std::fs::write(path, text).map_err(|e| DemoError::io(path, e))
}
