//! The engine scenes (issue 14): cloth an engine ships — colliders, wind, a cape worn by a
//! walking character — run at full resolution and with the feedback loop at 30% of the nodes,
//! measured where a viewer sees them.
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), sections
//! 3.3–3.4 (collision in TreeCut-SoftBody) and 5–6 (the feedback loop and its evaluation against
//! a full-resolution reference).
//!
//! Every run reconstructs the finest surface each step. The reference run records it; the
//! other runs are measured against it frame by frame through the scene's 1080-px-high camera
//! ([`crate::screen`]). Every run reports the deepest point of its reconstructed surface inside
//! any collider's bare shape (thickness not counted) over all steps, its mean step time and the
//! part of it spent in contact (broad phase and projections).
//!
//! Strategies: `reference` (every node), `lod` (feedback at 30% of the nodes, contact raising
//! priorities), `lod_no_contact` (the same without contact priorities, to show what they do).

mod scenes;

pub use scenes::{SceneInstance, SceneKind, build_scene, scene_hierarchy};

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3;
use slod::cloth::{ClothBudget, ClothError, ContactSettings, FeedbackSettings};
use softbody::TreeCutError;
use treecut::{Cut, uniform_cut};

use crate::screen::{ScreenError, ScreenMeter};

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct EngineConfig {
    /// Vertices per side of each cloth (the flag has half as many rows).
    pub size: u32,
    /// Steps per run (60 per second).
    pub steps: u32,
    /// Fraction of the nodes the LOD runs simulate.
    pub compression: f32,
    /// Which scenes.
    pub scenes: Vec<SceneKind>,
    /// Directory of the glTF rigs (for the cape's character).
    pub assets: PathBuf,
}

impl EngineConfig {
    /// The setting: 65² cloths, 4 s each, LOD at 30% of the nodes, every scene.
    pub fn standard(assets: &Path) -> EngineConfig {
        EngineConfig {
            size: 65,
            steps: 240,
            compression: 0.3,
            scenes: SceneKind::ALL.to_vec(),
            assets: assets.to_path_buf(),
        }
    }

    /// A small, fast version for `--quick` and tests: 17² cloths, 1 s.
    pub fn quick(assets: &Path) -> EngineConfig {
        EngineConfig {
            size: 17,
            steps: 60,
            ..EngineConfig::standard(assets)
        }
    }
}

/// One run of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct EngineRun {
    /// `reference`, `lod` or `lod_no_contact`.
    pub strategy: &'static str,
    /// Mean simulated nodes per step.
    pub nodes: f64,
    /// Mean wall time of a step (feedback included, reconstruction not), ms.
    pub ms_per_step: f64,
    /// Mean wall time of a step's contact work, ms.
    pub collision_ms: f64,
    /// Deepest point of the reconstructed surface inside a collider over all steps, mm.
    pub max_penetration_mm: f64,
    /// On-screen error against the reference (zero for the reference itself).
    pub screen: ScreenError,
    /// The reconstructed finest surface after the last step (for determinism checks).
    pub final_surface: Vec<Vec3>,
}

/// One scene's runs.
#[derive(Clone, Debug, PartialEq)]
pub struct EngineScene {
    /// The scene's report name.
    pub name: &'static str,
    /// Number of colliders.
    pub colliders: usize,
    /// Vertices of the cloth.
    pub vertices: usize,
    /// Collider thickness (the same for every collider of the scenes), mm.
    pub thickness_mm: f64,
    /// Reference first, then the LOD runs.
    pub runs: Vec<EngineRun>,
}

/// Progress callback: scene name, strategy, steps done, steps in all.
pub type Progress<'a> = &'a mut dyn FnMut(&str, &str, u32, u32);

/// Runs every configured scene: reference, LOD, LOD without contact priorities.
pub fn run_engine(
    config: &EngineConfig,
    progress: Progress<'_>,
) -> Result<Vec<EngineScene>, ClothError> {
    config
        .scenes
        .iter()
        .map(|&kind| run_scene(kind, config, progress))
        .collect()
}

/// Runs one scene (see [`run_engine`]).
pub fn run_scene(
    kind: SceneKind,
    config: &EngineConfig,
    progress: Progress<'_>,
) -> Result<EngineScene, ClothError> {
    if config.steps == 0 || !(config.compression > 0.0 && config.compression <= 1.0) {
        return Err(ClothError::Feedback {
            field: "steps/compression",
            reason: "at least one step, compression in (0, 1]",
        });
    }
    let (spec, h) = scene_hierarchy(kind, config.size)?;
    let full = h.vertex_count();
    let mut reference = vec![Vec3::ZERO; full * config.steps as usize];
    let mut runs = Vec::new();
    let mut scene = build_scene(kind, &h, &spec, Cut::finest(&h), &config.assets)?;
    let colliders = scene.cloth.colliders().len();
    let thickness_mm = scene
        .cloth
        .colliders()
        .iter()
        .map(|(_, d)| d.thickness as f64 * 1e3)
        .fold(0.0, f64::max);
    runs.push(simulate(
        &mut scene,
        "reference",
        Frames::Record(&mut reference),
        config,
        kind,
        progress,
    )?);
    let budget = ((config.compression as f64 * full as f64).round() as usize).clamp(1, full);
    for (strategy, weight) in [("lod", 1.0), ("lod_no_contact", 0.0)] {
        let cut = uniform_cut(&h, budget).map_err(TreeCutError::from)?;
        let mut scene = build_scene(kind, &h, &spec, cut, &config.assets)?;
        scene.cloth.set_feedback(Some(FeedbackSettings {
            budget: ClothBudget::Compression(config.compression),
            ..FeedbackSettings::default()
        }))?;
        scene
            .cloth
            .set_contact_settings(ContactSettings { weight })?;
        runs.push(simulate(
            &mut scene,
            strategy,
            Frames::Compare(&reference),
            config,
            kind,
            progress,
        )?);
    }
    Ok(EngineScene {
        name: kind.name(),
        colliders,
        vertices: full,
        thickness_mm,
        runs,
    })
}

/// What a run does with its reconstructed frames.
enum Frames<'a> {
    Record(&'a mut [Vec3]),
    Compare(&'a [Vec3]),
}

fn simulate(
    scene: &mut SceneInstance,
    strategy: &'static str,
    mut frames: Frames<'_>,
    config: &EngineConfig,
    kind: SceneKind,
    progress: Progress<'_>,
) -> Result<EngineRun, ClothError> {
    let full = scene.cloth.hierarchy().vertex_count();
    let mut surface = vec![Vec3::ZERO; full];
    let mut meter = ScreenMeter::new(scene.view);
    let (mut step_s, mut contact_s, mut nodes) = (0f64, 0f64, 0f64);
    let mut penetration = 0f32;
    for s in 0..config.steps {
        let t = Instant::now();
        scene.frame()?;
        step_s += t.elapsed().as_secs_f64();
        contact_s += scene.cloth.last_collision_seconds();
        nodes += scene.cloth.node_count() as f64;
        scene.cloth.reconstruct(&mut surface)?;
        penetration = penetration.max(scene.cloth.max_penetration(&surface));
        let frame = s as usize * full..(s as usize + 1) * full;
        match &mut frames {
            Frames::Record(r) => r[frame].copy_from_slice(&surface),
            Frames::Compare(r) => meter.frame(&surface, &r[frame]),
        }
        if s % 20 == 19 || s + 1 == config.steps {
            progress(kind.name(), strategy, s + 1, config.steps);
        }
    }
    let n = config.steps as f64;
    Ok(EngineRun {
        strategy,
        nodes: nodes / n,
        ms_per_step: step_s / n * 1e3,
        collision_ms: contact_s / n * 1e3,
        max_penetration_mm: penetration as f64 * 1e3,
        screen: match frames {
            Frames::Record(_) => ScreenError::default(),
            Frames::Compare(_) => meter.finish(),
        },
        final_surface: surface,
    })
}

/// The engine scenes as a plain-text table.
pub fn format_table(scenes: &[EngineScene]) -> String {
    let mut t = crate::table::Table::new(
        "Engine scenes: reference and LOD runs (on-screen error through a 1080-px-high view)",
        &[
            "scene",
            "colliders",
            "strategy",
            "nodes",
            "ms/step",
            "collision ms",
            "max pen. mm",
            "screen RMS px",
            "screen max px",
        ],
    );
    for s in scenes {
        for r in &s.runs {
            t.row([
                s.name.to_string(),
                s.colliders.to_string(),
                r.strategy.to_string(),
                format!("{:.0}", r.nodes),
                format!("{:.2}", r.ms_per_step),
                format!("{:.3}", r.collision_ms),
                format!("{:.2}", r.max_penetration_mm),
                format!("{:.2}", r.screen.rms_px),
                format!("{:.1}", r.screen.max_px),
            ]);
        }
    }
    t.render()
}

#[cfg(test)]
mod tests;
