//! The engine section (issue 14): the four collider and wind scenes of
//! [`slod_experiments::engine`], reference and LOD runs, as a table and as report.json's
//! `engine` object.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;
use slod_experiments::engine::{self, EngineConfig};

use crate::error::DemoError;
use crate::progress::Progress;

/// One run as reported.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct EngineRunReport {
    /// `reference`, `reference_twin` (the reference with one node nudged by 0.1 mm: the scene's
    /// chaos floor), `lod` (feedback at 30% of the nodes), `lod_join_at_end` (the paper's rule:
    /// a refine's children join collision when it ends) or `lod_no_contact` (`lod` without
    /// contact raising priorities).
    pub(crate) strategy: &'static str,
    /// Mean simulated nodes per step.
    pub(crate) nodes: f64,
    /// Mean step time (feedback included, reconstruction not), ms.
    pub(crate) ms_per_step: f64,
    /// Mean contact time per step (broad phase and projections), ms.
    pub(crate) collision_ms: f64,
    /// Contact time as a fraction of the step.
    pub(crate) collision_fraction: f64,
    /// Deepest point of the reconstructed finest surface inside a collider's bare shape over
    /// all steps, mm.
    pub(crate) max_penetration_mm: f64,
    /// Operations undone within 30 steps per operation begun (flicker).
    pub(crate) undone_fraction: f64,
    /// On-screen error against the reference: mean per-frame RMS, px (null for the reference).
    pub(crate) screen_rms_px: Option<f64>,
    /// 99th percentile over vertex-frames, px (null for the reference).
    pub(crate) screen_p99_px: Option<f64>,
    /// Largest, px (null for the reference).
    pub(crate) screen_max_px: Option<f64>,
}

/// One scene as reported.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct EngineSceneReport {
    /// `drape_sphere`, `flag_wind`, `cape_walk` or `slide_box`.
    pub(crate) name: &'static str,
    /// Number of colliders.
    pub(crate) colliders: usize,
    /// Finest vertices of the cloth.
    pub(crate) vertices: usize,
    /// Collider thickness, mm (the penetration target is thickness + 1 mm).
    pub(crate) thickness_mm: f64,
    /// Reference first.
    pub(crate) runs: Vec<EngineRunReport>,
}

/// The section of report.json.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct EngineSection {
    /// Vertices per side of the cloths.
    pub(crate) size: u32,
    /// Steps per run.
    pub(crate) steps: u32,
    /// Fraction of the nodes the LOD runs simulate.
    pub(crate) compression: f32,
    /// Viewport height of every scene's camera, px.
    pub(crate) viewport_height_px: u32,
    /// The scenes.
    pub(crate) scenes: Vec<EngineSceneReport>,
    /// Wall time of the section, s.
    pub(crate) seconds: f64,
}

/// The section and its printed table.
#[derive(Debug)]
pub(crate) struct EngineOutcome {
    pub(crate) section: EngineSection,
    pub(crate) text: String,
}

pub(crate) fn assets_dir() -> PathBuf {
    let in_tree = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf");
    if in_tree.is_dir() {
        in_tree
    } else {
        PathBuf::from("assets/gltf")
    }
}

/// Runs the section: 65² cloths for 4 s (17² for 1 s with `--quick`).
pub(crate) fn run(quick: bool, progress: Progress) -> Result<EngineOutcome, DemoError> {
    let start = Instant::now();
    let assets = assets_dir();
    let config = if quick {
        EngineConfig::quick(&assets)
    } else {
        EngineConfig::standard(&assets)
    };
    let runs = config.scenes.len() as u64 * 5 * config.steps as u64;
    let bar = progress.bar(runs, "engine");
    let mut done = 0u64;
    let mut last = 0u32;
    let scenes = engine::run_engine(&config, &mut |scene, strategy, s, _| {
        let step = if s < last { s } else { s - last };
        last = s;
        done += step as u64;
        bar.set_position(done);
        bar.set_message(format!("{scene} {strategy}"));
    })?;
    bar.finish_and_clear();
    let text = engine::format_table(&scenes);
    let scenes = scenes
        .iter()
        .map(|s| EngineSceneReport {
            name: s.name,
            colliders: s.colliders,
            vertices: s.vertices,
            thickness_mm: s.thickness_mm,
            runs: s
                .runs
                .iter()
                .map(|r| {
                    let measured = r.strategy != "reference";
                    EngineRunReport {
                        strategy: r.strategy,
                        nodes: r.nodes,
                        ms_per_step: r.ms_per_step,
                        collision_ms: r.collision_ms,
                        collision_fraction: r.collision_ms / r.ms_per_step.max(1e-12),
                        max_penetration_mm: r.max_penetration_mm,
                        undone_fraction: r.undone_fraction,
                        screen_rms_px: measured.then_some(r.screen.rms_px),
                        screen_p99_px: measured.then_some(r.screen.p99_px),
                        screen_max_px: measured.then_some(r.screen.max_px),
                    }
                })
                .collect(),
        })
        .collect();
    Ok(EngineOutcome {
        section: EngineSection {
            size: config.size,
            steps: config.steps,
            compression: config.compression,
            viewport_height_px: 1080,
            scenes,
            seconds: start.elapsed().as_secs_f64(),
        },
        text,
    })
}
