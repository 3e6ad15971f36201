//! The crowd (the bone-priority thesis' chapter 13), measured with `slod_experiments::crowd`:
//! characters of a 153-bone rig in a grid and at random positions, the camera swept away from
//! the crowd; at each distance the frame cost with and without LOD and the pose error in pixels.
//! By default: the thesis' range [200, 1700] in both layouts, then the crowd budget mode
//! (a quarter of the full-detail interpolations per frame) and the error-bound mode (1 px).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use animlod::{ClipId, LodMode, PrioritySource, Rig};
use serde::Serialize;
use slod_experiments::crowd::{self, CrowdExperiment, Layout, SweepRow, THESIS_HEIGHT};

use crate::cli::{CrowdLod, CrowdOptions};
use crate::error::DemoError;
use crate::paper::{THESIS, Thesis};
use crate::progress::Progress;
use slod_experiments::table::{Table, num};

/// The default rig: GDQuest's GDBot (CC-BY 4.0), the workspace's real 63-joint humanoid.
const DEFAULT_RIG: &str = "assets/gltf/GDQuest_GDBot.glb";

/// Distance between neighbours in the grid layout (scene units; characters are 180 tall).
const GRID_SPACING: f32 = 150.0;

/// One sweep to run.
#[derive(Clone, Debug)]
struct SweepSpec {
    name: String,
    layout: Layout,
    lod: LodMode,
    source: PrioritySource,
}

/// What to run.
#[derive(Clone, Debug)]
pub(crate) struct CrowdPlan {
    rig_path: PathBuf,
    clip: Option<String>,
    characters: usize,
    lod: Option<CrowdLod>,
    distances: Vec<f32>,
    warmup: usize,
    frames: usize,
    quick: bool,
}

impl CrowdPlan {
    /// The plan for these options; `quick` shrinks the defaults.
    pub(crate) fn new(options: &CrowdOptions, quick: bool) -> CrowdPlan {
        let thesis = CrowdExperiment::thesis(ClipId::new(0));
        let mut distances = if quick {
            vec![100.0, 800.0, 1600.0, 3000.0]
        } else {
            thesis.distances.clone()
        };
        // A user's range beyond the thesis' sweep: extend the sweep past its far end.
        if let Some(CrowdLod::Range { max, .. }) = options.lod {
            let last = distances.last().copied().unwrap_or(0.0);
            if max * 1.2 > last {
                distances.extend([max * 1.2, max * 1.5, max * 2.0]);
            }
        }
        CrowdPlan {
            rig_path: options.gltf.clone().unwrap_or_else(default_rig_path),
            clip: options.clip.clone(),
            characters: options.characters.unwrap_or(if quick { 16 } else { 100 }),
            lod: options.lod,
            distances,
            warmup: if quick { 2 } else { thesis.warmup_frames },
            frames: if quick { 4 } else { thesis.frames },
            quick,
        }
    }
}

/// The bundled rig, found from the source tree (where `cargo run` builds the demo) or from the
/// working directory.
fn default_rig_path() -> PathBuf {
    let in_tree = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(DEFAULT_RIG);
    if in_tree.is_file() {
        in_tree
    } else {
        PathBuf::from(DEFAULT_RIG)
    }
}

/// The crowd's setup as recorded in the report.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct CrowdConfigReport {
    /// The rig file.
    pub(crate) gltf: String,
    /// The clip played.
    pub(crate) clip: String,
    /// Its duration (s).
    pub(crate) clip_duration_s: f32,
    /// Bones of the rig as loaded.
    pub(crate) source_bones: usize,
    /// Bones per character after growing the rig to the thesis' 153.
    pub(crate) bones: usize,
    /// Bones the clip animates (the others are constant and never sampled).
    pub(crate) animated_bones: usize,
    /// Characters.
    pub(crate) characters: usize,
    /// Character height (scene units) the rig is scaled to.
    pub(crate) height_units: f32,
    /// Frame step (s).
    pub(crate) dt_s: f32,
    /// Frames run before measuring at each distance.
    pub(crate) warmup_frames: usize,
    /// Frames measured at each distance.
    pub(crate) measured_frames: usize,
    /// Camera distances from the crowd's centre (scene units).
    pub(crate) distances: Vec<f32>,
    /// Vertical field of view (degrees).
    pub(crate) fov_y_deg: f32,
    /// Viewport height (pixels) the errors are measured in.
    pub(crate) viewport_height_px: f32,
}

/// The LOD mode of a sweep.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct LodReport {
    /// `range`, `budget` or `error_bound`.
    pub(crate) mode: &'static str,
    /// Range: full detail nearer than this (units).
    pub(crate) min: Option<f32>,
    /// Range: nothing interpolates farther than this (units).
    pub(crate) max: Option<f32>,
    /// Budget: bone interpolations per frame over the crowd.
    pub(crate) bone_updates_per_frame: Option<u32>,
    /// Error bound: largest drift of a held bone (pixels).
    pub(crate) max_error_px: Option<f32>,
}

/// One camera distance of a sweep.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct RowReport {
    /// Camera distance from the crowd's centre (units).
    pub(crate) distance: f32,
    /// Median frame time at full detail (ms).
    pub(crate) full_ms: f64,
    /// Median frame time with LOD (ms).
    pub(crate) lod_ms: f64,
    /// lod_ms / full_ms.
    pub(crate) cost_ratio: f64,
    /// Median frame time (ms) of culling alone (full detail for visible characters only).
    pub(crate) cull_ms: f64,
    /// Characters in view per frame (the camera stands outside the crowd).
    pub(crate) visible_characters: f64,
    /// Bone interpolations per frame at full detail.
    pub(crate) full_interpolated: f64,
    /// Bone interpolations per frame with LOD.
    pub(crate) lod_interpolated: f64,
    /// Budget units spent per frame with LOD (budget mode: a bone picked out one by one counts
    /// 1, a character interpolated whole through the block path at most a sixth of its
    /// animated bones, a frame on LOD off's path a sixth of every character's; see
    /// `animlod::FrameStats::budget_units`), 0 in other modes.
    pub(crate) lod_budget_units: f64,
    /// Model-space matrices recomputed per frame with LOD.
    pub(crate) lod_concatenated: f64,
    /// Characters with nothing interpolated per frame.
    pub(crate) frozen_characters: f64,
    /// Mean camera ratio Ω (1 in budget mode).
    pub(crate) mean_ratio: f64,
    /// Mean on-screen joint error (pixels).
    pub(crate) mean_error_px: f32,
    /// Largest on-screen joint error (pixels).
    pub(crate) max_error_px: f32,
    /// Root mean square on-screen joint error (pixels).
    pub(crate) rms_error_px: f32,
    /// Mean joint error (scene units).
    pub(crate) mean_error_units: f32,
    /// Largest joint error (scene units).
    pub(crate) max_error_units: f32,
}

impl From<&SweepRow> for RowReport {
    fn from(r: &SweepRow) -> RowReport {
        RowReport {
            distance: r.distance,
            full_ms: r.full_ms,
            lod_ms: r.lod_ms,
            cost_ratio: r.cost_ratio(),
            cull_ms: r.cull_ms,
            visible_characters: r.visible,
            full_interpolated: r.full_interpolated,
            lod_interpolated: r.lod_interpolated,
            lod_budget_units: r.lod_budget_units,
            lod_concatenated: r.lod_concatenated,
            frozen_characters: r.frozen,
            mean_ratio: r.mean_ratio,
            mean_error_px: r.mean_px,
            max_error_px: r.max_px,
            rms_error_px: r.rms_px,
            mean_error_units: r.mean_units,
            max_error_units: r.max_units,
        }
    }
}

/// One sweep: a layout and a LOD mode over all distances.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct SweepReport {
    /// Short name (`thesis range, grid`, ...).
    pub(crate) name: String,
    /// `grid` or `random`.
    pub(crate) layout: &'static str,
    /// Grid spacing or side of the random square (units).
    pub(crate) layout_size: f32,
    /// The LOD mode.
    pub(crate) lod: LodReport,
    /// `factors` (the thesis' six sub-priorities) or `hold_error` (measured).
    pub(crate) priority_source: &'static str,
    /// One row per distance, nearest first.
    pub(crate) rows: Vec<RowReport>,
}

/// The crowd section of the report.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct CrowdSection {
    /// What ran.
    pub(crate) config: CrowdConfigReport,
    /// The sweeps, in the order run.
    pub(crate) sweeps: Vec<SweepReport>,
    /// The thesis' published figures.
    pub(crate) thesis: Thesis,
    /// Frame cost with LOD over without at the farthest distance: the thesis' (12 / 43.6 fps,
    /// rendering included) and ours (first sweep, animation only).
    pub(crate) far_cost_ratio: FarCost,
    /// The whole per-character pipeline, per stage, with and without LOD.
    pub(crate) pipeline: crate::crowd_large::PipelineReport,
    /// The pipeline under every LOD measured (`pipeline` is held joints within 0.6 px, 100
    /// characters; the last row is the same with 1,000).
    pub(crate) pipelines: Vec<crate::crowd_large::PipelineReport>,
    /// Large crowds (1,000 and 10,000 characters), one thread and every core.
    pub(crate) large: Vec<crate::crowd_large::LargeReport>,
    /// Per-bone priorities against every bone alike, and the derived weights in and out of
    /// sample, at equal cost.
    pub(crate) ablation: Vec<crate::crowd_large::AblationReport>,
    /// Wall time of the whole section (s).
    pub(crate) seconds: f64,
}

/// The thesis' headline comparison.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct FarCost {
    /// 12 fps / 43.6 fps.
    pub(crate) thesis: f64,
    /// Our first sweep's last row.
    pub(crate) ours: f64,
}

/// The section's results.
#[derive(Debug)]
pub(crate) struct CrowdOutcome {
    /// For report.json.
    pub(crate) section: CrowdSection,
    /// The tables, ready to print.
    pub(crate) text: String,
}

fn pick_clip(rig: &Rig, wanted: Option<&str>, path: &Path) -> Result<ClipId, DemoError> {
    let names: Vec<&str> = rig.clips().iter().map(|c| c.name()).collect();
    if names.is_empty() {
        return Err(DemoError::Clip(format!(
            "{} has no animation to play",
            path.display()
        )));
    }
    let found = match wanted {
        Some(w) => names
            .iter()
            .position(|n| *n == w)
            .or_else(|| names.iter().position(|n| n.eq_ignore_ascii_case(w))),
        None => Some(
            names
                .iter()
                .position(|n| n.to_ascii_lowercase().contains("walk"))
                .unwrap_or(0),
        ),
    };
    found.map(ClipId::new).ok_or_else(|| {
        DemoError::Clip(format!(
            "{} has no animation named `{}`; it has: {}",
            path.display(),
            wanted.unwrap_or(""),
            names.join(", ")
        ))
    })
}

fn sweeps(plan: &CrowdPlan, animated: usize) -> Vec<SweepSpec> {
    let grid = Layout::Grid {
        spacing: GRID_SPACING,
    };
    // The same density as the grid: the thesis' 100 characters in a 1500-unit square.
    let random = Layout::Random {
        side: GRID_SPACING * (plan.characters as f32).sqrt(),
        seed: 1,
    };
    let range = |min: f32, max: f32| {
        [(grid, "grid"), (random, "random")].map(|(layout, name)| SweepSpec {
            name: format!("range [{min:.0}, {max:.0}], {name}"),
            layout,
            lod: LodMode::Range { min, max },
            source: PrioritySource::Factors,
        })
    };
    let budget = |n: u32, label: String| {
        [(grid, "grid"), (random, "random")].map(|(layout, name)| SweepSpec {
            name: format!("{label}, {name}"),
            layout,
            lod: LodMode::Budget {
                bone_updates_per_frame: n,
            },
            source: PrioritySource::HoldError,
        })
    };
    match plan.lod {
        Some(CrowdLod::Range { min, max }) => range(min, max).to_vec(),
        Some(CrowdLod::Budget(n)) => budget(n, format!("budget {n}/frame")).to_vec(),
        None => {
            let [min, max] = THESIS.range;
            let mut v = range(min, max).to_vec();
            // A tenth of the full-detail interpolations: budgets from a sixth on run LOD off's
            // path (see `animlod::FrameStats::budget_units`).
            let tenth = ((plan.characters * animated / 10) as u32).max(1);
            let [grid_budget, _] = budget(tenth, format!("budget 10% ({tenth}/frame)"));
            v.push(grid_budget);
            v.push(SweepSpec {
                name: "error bound 1 px, grid".into(),
                layout: grid,
                lod: LodMode::ErrorBound { max_error_px: 1.0 },
                source: PrioritySource::Factors,
            });
            v
        }
    }
}

fn lod_report(lod: LodMode) -> LodReport {
    let mut r = LodReport {
        mode: "range",
        min: None,
        max: None,
        bone_updates_per_frame: None,
        max_error_px: None,
    };
    match lod {
        LodMode::Range { min, max } => {
            r.min = Some(min);
            r.max = Some(max);
        }
        LodMode::Budget {
            bone_updates_per_frame,
        } => {
            r.mode = "budget";
            r.bone_updates_per_frame = Some(bone_updates_per_frame);
        }
        LodMode::ErrorBound { max_error_px } => {
            r.mode = "error_bound";
            r.max_error_px = Some(max_error_px);
        }
        LodMode::Interpolated { max_error_px } => {
            r.mode = "interpolated";
            r.max_error_px = Some(max_error_px);
        }
        LodMode::KeyHold { max_error_px } => {
            r.mode = "key_hold";
            r.max_error_px = Some(max_error_px);
        }
        LodMode::Off | LodMode::Ratio(_) | LodMode::PixelSize { .. } => r.mode = "other",
    }
    r
}

/// Runs every sweep of the plan.
pub(crate) fn run(plan: &CrowdPlan, progress: Progress) -> Result<CrowdOutcome, DemoError> {
    let start = Instant::now();
    let base = animlod::build::import_path(&plan.rig_path).map_err(|source| DemoError::Import {
        path: plan.rig_path.clone(),
        source,
    })?;
    let clip = pick_clip(&base, plan.clip.as_deref(), &plan.rig_path)?;
    let rig = Arc::new(crowd::thesis_rig(&base)?);
    let clip_data = rig
        .clip(clip)
        .ok_or_else(|| DemoError::Clip("the clip vanished while scaling the rig".into()))?;
    let animated = clip_data.animated_bone_count();
    let mut cfg = CrowdExperiment::thesis(clip);
    cfg.characters = plan.characters;
    cfg.warmup_frames = plan.warmup;
    cfg.frames = plan.frames;
    let config = CrowdConfigReport {
        gltf: plan.rig_path.display().to_string(),
        clip: clip_data.name().to_string(),
        clip_duration_s: clip_data.duration(),
        source_bones: base.bone_count(),
        bones: rig.bone_count(),
        animated_bones: animated,
        characters: plan.characters,
        height_units: THESIS_HEIGHT,
        dt_s: cfg.dt,
        warmup_frames: cfg.warmup_frames,
        measured_frames: cfg.frames,
        distances: plan.distances.clone(),
        fov_y_deg: cfg.fov_y.to_degrees(),
        viewport_height_px: cfg.viewport_height,
    };

    let specs = sweeps(plan, animated);
    let bar = progress.bar((specs.len() * plan.distances.len()) as u64, "crowd");
    let mut reports = Vec::new();
    for spec in &specs {
        bar.set_message(format!(
            "{} characters x {} bones: {}",
            plan.characters,
            rig.bone_count(),
            spec.name
        ));
        cfg.layout = spec.layout;
        cfg.lod = spec.lod;
        cfg.source = spec.source;
        let mut rows = Vec::new();
        // One distance at a time, for the progress bar; each call warms up the crowds anew,
        // as the sweep does at every distance.
        for &d in &plan.distances {
            cfg.distances = vec![d];
            rows.extend(crowd::run(&rig, &cfg)?.iter().map(RowReport::from));
            bar.inc(1);
        }
        let (layout, layout_size) = match spec.layout {
            Layout::Grid { spacing } => ("grid", spacing),
            Layout::Random { side, .. } => ("random", side),
        };
        reports.push(SweepReport {
            name: spec.name.clone(),
            layout,
            layout_size,
            lod: lod_report(spec.lod),
            priority_source: match spec.source {
                PrioritySource::Factors => "factors",
                PrioritySource::HoldError => "hold_error",
            },
            rows,
        });
    }
    bar.finish_and_clear();
    let large = crate::crowd_large::run(&base, clip, plan.quick, &progress)?;

    let ours_far = reports
        .first()
        .and_then(|s| s.rows.last())
        .map_or(f64::NAN, |r| r.cost_ratio);
    let section = CrowdSection {
        config,
        sweeps: reports,
        thesis: THESIS,
        far_cost_ratio: FarCost {
            thesis: THESIS.far_cost_ratio(),
            ours: ours_far,
        },
        pipeline: large.pipeline,
        pipelines: large.pipelines,
        large: large.large,
        ablation: large.ablation,
        seconds: start.elapsed().as_secs_f64(),
    };
    let mut text = section
        .sweeps
        .iter()
        .map(|s| render_sweep(&section, s))
        .collect::<Vec<_>>()
        .join("\n");
    text += "\n";
    text += &large.text;
    Ok(CrowdOutcome { section, text })
}

fn render_sweep(section: &CrowdSection, s: &SweepReport) -> String {
    let c = &section.config;
    let mut t = Table::new(
        format!(
            "Crowd: {} characters x {} bones ({} `{}`), {}, {} priorities",
            c.characters,
            c.bones,
            Path::new(&c.gltf)
                .file_name()
                .map_or_else(|| c.gltf.clone(), |f| f.to_string_lossy().into_owned()),
            c.clip,
            s.name,
            s.priority_source.replace('_', " ")
        ),
        &[
            "distance",
            "in view",
            "full ms",
            "cull ms",
            "LOD ms",
            "cost",
            "interp/frame",
            "frozen",
            "mean Ω",
            "mean px",
            "max px",
        ],
    );
    for r in &s.rows {
        t.row([
            num(r.distance as f64, 0),
            num(r.visible_characters, 0),
            num(r.full_ms, 3),
            num(r.cull_ms, 3),
            num(r.lod_ms, 3),
            num(r.cost_ratio, 2),
            format!(
                "{} / {}",
                num(r.lod_interpolated, 0),
                num(r.full_interpolated, 0)
            ),
            num(r.frozen_characters, 1),
            num(r.mean_ratio, 2),
            num(r.mean_error_px as f64, 2),
            num(r.max_error_px as f64, 1),
        ]);
    }
    if s.lod.mode == "range" {
        t.note(format!(
            "thesis ({} x {} bones, range [{:.0}, {:.0}]): {} fps without LOD at every distance, \
             {} fps far away: cost {} (rendering included).",
            THESIS.characters,
            THESIS.bones,
            THESIS.range[0],
            THESIS.range[1],
            THESIS.fps_without_lod,
            THESIS.fps_with_lod_far,
            num(THESIS.far_cost_ratio(), 2)
        ));
        t.note("ours: animation only (sampling, holding, concatenation), median frame time.");
    }
    t.note(format!(
        "errors: joints (origins and tips) on screen, camera outside the crowd, {:.0}-pixel-high view, {:.0}° field of view, against \
         full-rate evaluation.",
        c.viewport_height_px, c.fov_y_deg
    ));
    t.render()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_plan_runs_the_thesis_then_budget_and_error_bound() {
        let plan = CrowdPlan::new(&CrowdOptions::default(), false);
        assert_eq!(plan.characters, 100);
        assert!(plan.rig_path.is_file(), "{}", plan.rig_path.display());
        let s = sweeps(&plan, 25);
        let modes: Vec<&str> = s.iter().map(|x| lod_report(x.lod).mode).collect();
        assert_eq!(modes, ["range", "range", "budget", "error_bound"]);
        assert_eq!(
            s[2].lod,
            LodMode::Budget {
                bone_updates_per_frame: 250
            }
        );
        let budget = CrowdOptions {
            lod: Some(CrowdLod::Budget(40)),
            ..CrowdOptions::default()
        };
        let s = sweeps(&CrowdPlan::new(&budget, true), 25);
        assert_eq!(s.len(), 2);
        assert!(s.iter().all(|x| lod_report(x.lod).mode == "budget"));
    }

    #[test]
    fn a_far_range_extends_the_sweep() {
        let o = CrowdOptions {
            lod: Some(CrowdLod::Range {
                min: 1000.0,
                max: 5000.0,
            }),
            ..CrowdOptions::default()
        };
        let plan = CrowdPlan::new(&o, false);
        assert_eq!(plan.distances.last().copied(), Some(10_000.0));
    }
}
