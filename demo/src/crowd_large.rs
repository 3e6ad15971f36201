//! The crowd beyond the thesis, measured with `slod_experiments::crowd_large`: the whole
//! per-character pipeline (sampling, concatenation, skinning palette, CPU skinning of the rig's
//! own mesh) with and without LOD, and crowds of 1,000 and 10,000 characters 2–200 m in front of
//! a camera outside the crowd, on one thread and on every core: the animation stages of every
//! LOD mode, and the whole pipeline skinned with held joints. Errors are measured at joint
//! origins and tips (`bone_tips`) or at every skinned vertex (`skinned_vertices`), in pixels
//! through a 1080-px-high view.

use std::sync::Arc;

use animlod::{ClipId, LodMode, Rig};
use serde::Serialize;
use slod_experiments::ablation;
use slod_experiments::crowd_large::{self, LargeRow, LargeSetup, PipelineRow, Stages, metric_rig};
use slod_experiments::table::{Table, num};

use crate::error::DemoError;
use crate::progress::Progress;

/// The error measure of the LOD modes' figures (the held joints' pipeline measures at skinned
/// vertices).
const ERROR_MEASURE: &str = "bone_tips";

/// The whole pipeline's rows with shared poses: held joints within 0.6 px for characters too
/// near to share (`animlod::PoseShare`), as many shared poses kept as fit in
/// [`SHARED_POSES_MIB`] MiB.
const SHARED_POSES: &str = "shared_poses+held_joints_0.6px";

/// Memory for shared poses (MiB): 400 of GDBot's (6,953 vertices), 2,800 of Fox's.
const SHARED_POSES_MIB: usize = 64;

/// `stages` of the `crowd.large` rows that time the whole pipeline, skinning included.
const WHOLE_PIPELINE: &str = "sample+concat+palette+skin";

/// The LOD modes measured, with their report names: per-bone holds, whole key poses blended,
/// and whole key poses held over centred windows, each within 1 px. The last is
/// the pipeline's key-pose reference; `crowd.pipelines` holds all three and the held joints.
const MODES: [(&str, LodMode); 3] = [
    ("error_bound_1px", LodMode::ErrorBound { max_error_px: 1.0 }),
    (
        "interpolated_1px",
        LodMode::Interpolated { max_error_px: 1.0 },
    ),
    ("key_hold_1px", LodMode::KeyHold { max_error_px: 1.0 }),
];

/// The pipeline with exact poses skinned with held joints (`animlod::SkinHoldJob`), with their
/// report names: within 1 px at every vertex holding the exact matrix, the same holding a
/// matrix predicted ahead (the ablation of prediction), and within 0.6 px, the bound at which
/// the mean error meets 0.1 px (`crowd.pipeline`; at 1 px the mean is about 0.15 px).
const HELD_JOINTS: [(&str, f32, bool); 3] = [
    ("held_joints_1px", 1.0, false),
    ("held_joints_predicted_1px", 1.0, true),
    ("held_joints_0.6px", 0.6, false),
];

/// One pipeline's per-stage costs (ms per frame, summed over the crowd).
#[derive(Clone, Debug, Serialize)]
pub(crate) struct StagesReport {
    /// Sampling.
    pub(crate) sample_ms: f64,
    /// Local → model concatenation.
    pub(crate) concat_ms: f64,
    /// Skinning palette (model × inverse bind).
    pub(crate) palette_ms: f64,
    /// CPU linear-blend skinning (positions and normals), including `blend_ms`.
    pub(crate) skin_ms: f64,
    /// Of `skin_ms`: blending two skinned key poses (interpolated mode only).
    pub(crate) blend_ms: f64,
}

impl From<Stages> for StagesReport {
    fn from(s: Stages) -> StagesReport {
        StagesReport {
            sample_ms: s.sample_ms,
            concat_ms: s.concat_ms,
            palette_ms: s.palette_ms,
            skin_ms: s.skin_ms,
            blend_ms: s.blend_ms,
        }
    }
}

/// `crowd.pipeline` in report.json.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct PipelineReport {
    /// The LOD mode (`error_bound_1px`, `interpolated_1px`, `key_hold_1px`, or held joints:
    /// `held_joints_1px`, `held_joints_predicted_1px`, `held_joints_0.6px`).
    pub(crate) lod_mode: &'static str,
    /// Characters.
    pub(crate) characters: usize,
    /// Vertices skinned per character.
    pub(crate) vertices: usize,
    /// LOD off: every stage for every character every frame.
    pub(crate) full: StagesReport,
    /// With LOD: characters whose pose held reuse palette and skinned vertices; in the
    /// interpolated mode only key poses are skinned and the output blends two skinned copies.
    pub(crate) lod: StagesReport,
    /// Fraction of character-frames skinned with LOD.
    pub(crate) lod_skinned_fraction: f64,
    /// Mean on-screen error (px) with LOD, at the skinned vertices.
    pub(crate) mean_error_px: f32,
    /// Largest on-screen error (px) with LOD, at the skinned vertices.
    pub(crate) max_error_px: f32,
    /// Largest on-screen error (px) with LOD at bone origins and tips (the crowd's model
    /// matrices; 0 with held joints, whose poses are exact).
    pub(crate) max_bone_tip_error_px: f32,
    /// `skinned_vertices`: every vertex in view against the full-detail host's.
    pub(crate) error_measure: &'static str,
}

/// One row of `crowd.large` in report.json.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct LargeReport {
    /// The LOD mode (`error_bound_1px`, `interpolated_1px` or `key_hold_1px`; the whole
    /// pipeline's rows: `held_joints_0.6px`, and `shared_poses+held_joints_0.6px` with far
    /// characters sharing phase-bucket poses, `SHARED_POSES_MIB` MiB of them kept).
    pub(crate) lod_mode: &'static str,
    /// Characters.
    pub(crate) characters: usize,
    /// Nearest character (m).
    pub(crate) near_m: f32,
    /// Farthest character (m).
    pub(crate) far_m: f32,
    /// Threads of the parallel run.
    pub(crate) threads: usize,
    /// Stages timed in `full_ms`/`lod_ms`.
    pub(crate) stages: &'static str,
    /// Frame time at full detail, one thread (ms).
    pub(crate) full_ms: f64,
    /// Frame time with LOD, one thread (ms).
    pub(crate) lod_ms: f64,
    /// Frame time with LOD on one thread, the LOD crowd run alone (ms): the speed-up's
    /// reference.
    pub(crate) lod_serial_ms: f64,
    /// Frame time with LOD on `threads` threads, the LOD crowd run alone (ms).
    pub(crate) lod_parallel_ms: f64,
    /// lod_ms / full_ms.
    pub(crate) cost_ratio: f64,
    /// Mean on-screen error (px).
    pub(crate) mean_error_px: f32,
    /// Largest on-screen error (px).
    pub(crate) max_error_px: f32,
    /// RMS on-screen error (px).
    pub(crate) rms_error_px: f32,
    /// `bone_tips` (joint origins and tips) or `skinned_vertices` (every skinned vertex in
    /// view; the whole pipeline's rows).
    pub(crate) error_measure: &'static str,
    /// One-thread LOD time over `threads`-thread LOD time (mean frame times).
    pub(crate) parallel_speedup: Option<f64>,
    /// The same of median frame times (frames in which the virtual machine took a core away
    /// for milliseconds weigh on the mean only).
    pub(crate) parallel_speedup_median: Option<f64>,
    /// Whether the parallel run's poses (and, for the whole pipeline, skinned vertices) equal
    /// the one-thread run's bit for bit.
    pub(crate) deterministic: bool,
    /// Fraction of full-detail bone interpolations spent with LOD (1 with held joints: poses
    /// are exact).
    pub(crate) interpolated_fraction: f64,
    /// Fraction of characters whose pose changed per frame with LOD (held joints: fraction of
    /// vertices skinned).
    pub(crate) changed_fraction: f64,
    /// Fraction of character-frames that showed a shared phase-bucket pose
    /// (`animlod::PoseShare`; 0 in rows without shared poses).
    pub(crate) shared_fraction: f64,
}

impl LargeReport {
    /// A row of `r`, whose frame times cover `stages` and whose error was measured by
    /// `error_measure`.
    fn new(
        lod_mode: &'static str,
        r: &LargeRow,
        stages: &'static str,
        error_measure: &'static str,
    ) -> LargeReport {
        LargeReport {
            lod_mode,
            characters: r.characters,
            near_m: r.near_m,
            far_m: r.far_m,
            threads: r.threads,
            stages,
            full_ms: r.full_ms,
            lod_ms: r.lod_ms,
            lod_serial_ms: r.lod_serial_ms,
            lod_parallel_ms: r.lod_parallel_ms,
            cost_ratio: r.cost_ratio(),
            mean_error_px: r.mean_error_px,
            max_error_px: r.max_error_px,
            rms_error_px: r.rms_error_px,
            error_measure,
            parallel_speedup: (r.threads > 1).then(|| r.parallel_speedup()),
            parallel_speedup_median: (r.threads > 1).then_some(r.parallel_speedup_median),
            deterministic: r.deterministic,
            interpolated_fraction: r.interpolated_fraction,
            changed_fraction: r.changed_fraction,
            shared_fraction: r.shared_fraction,
        }
    }
}

/// One row of `crowd.ablation` in report.json: a priority weighting judged at equal cost.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct AblationReport {
    /// The clip judged.
    pub(crate) clip: String,
    /// `equal`, `uniform` (every bone alike), `derived_in_sample`, `derived_out_of_sample`.
    pub(crate) weighting: &'static str,
    /// Fraction of full-detail interpolations spent.
    pub(crate) update_fraction: f32,
    /// Mean on-screen error (px).
    pub(crate) mean_error_px: f32,
    /// RMS on-screen error (px).
    pub(crate) rms_error_px: f32,
    /// Largest on-screen error (px).
    pub(crate) max_error_px: f32,
    /// `bone_tips`.
    pub(crate) error_measure: &'static str,
}

/// What this part adds to the crowd section.
pub(crate) struct LargeOutcome {
    pub(crate) pipeline: PipelineReport,
    pub(crate) pipelines: Vec<PipelineReport>,
    pub(crate) large: Vec<LargeReport>,
    pub(crate) ablation: Vec<AblationReport>,
    pub(crate) text: String,
}

/// The clip the sweeps play and the longest other animated clip, judged by the ablation.
fn ablation_clips(rig: &Rig, played: ClipId) -> Vec<ClipId> {
    let other = (0..rig.clips().len())
        .map(ClipId::new)
        .filter(|&c| c != played)
        .filter(|&c| rig.clip(c).is_some_and(|c| c.animated_bone_count() > 0))
        .max_by(|&a, &b| {
            let d = |c: ClipId| rig.clip(c).map_or(0.0, |c| c.duration());
            d(a).total_cmp(&d(b))
        });
    std::iter::once(played).chain(other).collect()
}

/// Runs the pipeline measurement and the large crowds on `base` (scaled to 1.8 m).
pub(crate) fn run(
    base: &Rig,
    played: ClipId,
    quick: bool,
    progress: &Progress,
) -> Result<LargeOutcome, DemoError> {
    let rig = Arc::new(metric_rig(base)?);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let sizes: &[usize] = if quick { &[1000] } else { &[1000, 10_000] };
    let bar = progress.bar(
        (MODES.len() * (sizes.len() + 1) + HELD_JOINTS.len() + 1 + 2 * sizes.len()) as u64,
        "crowd pipeline",
    );
    let mut pipelines = Vec::new();
    let mut large = Vec::new();
    for (name, lod) in MODES {
        let mut setup = LargeSetup::new(if quick { 16 } else { 100 });
        setup.lod = lod;
        (setup.warmup_frames, setup.frames) = if quick { (2, 4) } else { (10, 30) };
        pipelines.push(pipeline_report(
            name,
            crowd_large::run_pipeline(&rig, &setup)?,
        ));
        bar.inc(1);
        for &n in sizes {
            let mut s = LargeSetup::new(n);
            s.lod = lod;
            (s.warmup_frames, s.frames) = match (quick, n >= 10_000) {
                (true, _) => (2, 3),
                (false, false) => (10, 30),
                (false, true) => (5, 10),
            };
            large.push(LargeReport::new(
                name,
                &crowd_large::run_large(&rig, &s, threads)?,
                "sample+concat+palette",
                ERROR_MEASURE,
            ));
            bar.inc(1);
        }
    }
    for (name, px, predict) in HELD_JOINTS {
        let mut setup = LargeSetup::new(if quick { 16 } else { 100 });
        (setup.held_joints_px, setup.held_joints_predict) = (Some(px), predict);
        (setup.warmup_frames, setup.frames) = if quick { (2, 4) } else { (10, 30) };
        pipelines.push(pipeline_report(
            name,
            crowd_large::run_pipeline(&rig, &setup)?,
        ));
        bar.inc(1);
    }
    let pipeline = pipelines.last().cloned().expect("held joints ran");
    if !quick {
        // The same at the crowd size (fewer frames: a full-detail frame skins 7 M
        // vertices).
        let (name, px, predict) = HELD_JOINTS[HELD_JOINTS.len() - 1];
        let mut setup = LargeSetup::new(1000);
        (setup.held_joints_px, setup.held_joints_predict) = (Some(px), predict);
        (setup.warmup_frames, setup.frames) = (5, 15);
        pipelines.push(pipeline_report(
            name,
            crowd_large::run_pipeline(&rig, &setup)?,
        ));
    }
    // The whole pipeline (skinning included) with held joints at the crowd sizes, on
    // one thread against full detail and on every core against one thread (a full-detail
    // frame of 10,000 characters skins 70 M vertices: few frames there).
    // Then the same with far characters sharing phase-bucket poses (the ablation: held
    // joints alone above).
    let (name, px, predict) = HELD_JOINTS[HELD_JOINTS.len() - 1];
    let whole_sizes: &[usize] = if quick { &[100] } else { sizes };
    for (name, shared) in [(name, None), (SHARED_POSES, Some(SHARED_POSES_MIB))] {
        for &n in whole_sizes {
            let mut s = LargeSetup::new(n);
            (s.held_joints_px, s.held_joints_predict) = (Some(px), predict);
            s.shared_poses_mib = shared;
            // The two-thread speed-up is timed in turns of four frames per side, the first of
            // each turn not counted: 10,000 characters get 9 measured frames so that 7 count.
            (s.warmup_frames, s.frames) = match (quick, n >= 10_000) {
                (true, _) => (2, 3),
                (false, false) => (5, 15),
                (false, true) => (3, 9),
            };
            large.push(LargeReport::new(
                name,
                &crowd_large::run_pipeline_large(&rig, &s, threads)?,
                WHOLE_PIPELINE,
                "skinned_vertices",
            ));
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    let frames = if quick { 24 } else { 96 };
    let ablation: Vec<AblationReport> =
        ablation::run(&rig, &ablation_clips(&rig, played), 0.35, 4, frames)?
            .into_iter()
            .map(|r| AblationReport {
                clip: r.clip,
                weighting: r.weighting,
                update_fraction: r.update_fraction,
                mean_error_px: r.mean_px,
                rms_error_px: r.rms_px,
                max_error_px: r.max_px,
                error_measure: ERROR_MEASURE,
            })
            .collect();
    let text = format!(
        "{}\n{}\n{}",
        render_pipeline(&pipelines.iter().collect::<Vec<_>>()),
        render_large(&large),
        render_ablation(&ablation)
    );
    Ok(LargeOutcome {
        pipeline,
        pipelines,
        large,
        ablation,
        text,
    })
}

/// The report of one pipeline measurement.
fn pipeline_report(lod_mode: &'static str, pipeline: PipelineRow) -> PipelineReport {
    PipelineReport {
        lod_mode,
        characters: pipeline.characters,
        vertices: pipeline.vertices,
        full: pipeline.full.into(),
        lod: pipeline.lod.into(),
        lod_skinned_fraction: pipeline.lod_skinned_fraction,
        mean_error_px: pipeline.mean_error_px,
        max_error_px: pipeline.max_error_px,
        max_bone_tip_error_px: pipeline.max_bone_tip_error_px,
        error_measure: "skinned_vertices",
    }
}

fn render_pipeline(ps: &[&PipelineReport]) -> String {
    let p0 = ps[0];
    let mut t = Table::new(
        format!(
            "Crowd pipeline: {} skinned vertices per character, 2-200 m, one thread (ms per frame)",
            p0.vertices
        ),
        &[
            "LOD", "chars", "sample", "concat", "palette", "skin", "blend", "total", "cost",
            "skinned", "mean px", "max px", "tip px",
        ],
    );
    let total = |s: &StagesReport| s.sample_ms + s.concat_ms + s.palette_ms + s.skin_ms;
    for p in ps {
        for (name, s, lod) in [("off", &p.full, false), (p.lod_mode, &p.lod, true)] {
            t.row([
                name.replace('_', " "),
                p.characters.to_string(),
                num(s.sample_ms, 3),
                num(s.concat_ms, 3),
                num(s.palette_ms, 3),
                num(s.skin_ms, 3),
                num(s.blend_ms, 3),
                num(total(s), 3),
                num(total(s) / total(&p.full).max(1e-12), 2),
                if lod {
                    num(p.lod_skinned_fraction, 2)
                } else {
                    "1".into()
                },
                if lod {
                    num(p.mean_error_px as f64, 3)
                } else {
                    "0".into()
                },
                if lod {
                    num(p.max_error_px as f64, 2)
                } else {
                    "0".into()
                },
                if lod {
                    num(p.max_bone_tip_error_px as f64, 2)
                } else {
                    "0".into()
                },
            ]);
        }
    }
    t.note(
        "skinned: vertices skinned over full detail's (error bound: a character whose bones \
         all held reuses its palette and vertices; interpolated: only key poses are skinned, \
         the output blends the two skinned copies, blend included in skin; held joints: exact \
         poses and palettes, only vertices of joints that moved past the bound at their vertices \
         are skinned again). Errors at every skinned vertex in view against full detail's, \
         every frame; tip px: largest at bone origins and tips (the crowd's model matrices).",
    );
    t.render()
}

fn render_large(rows: &[LargeReport]) -> String {
    let mut t = Table::new(
        "Large crowds: 2-200 m in front of a camera outside the crowd (ms per frame)",
        &[
            "LOD",
            "stages",
            "characters",
            "full ms",
            "LOD ms",
            "cost",
            "interp",
            "changed",
            "shared",
            "mean px",
            "max px",
            "threads",
            "speedup",
            "median",
            "same",
        ],
    );
    for r in rows {
        t.row([
            r.lod_mode.replace('_', " "),
            if r.stages == WHOLE_PIPELINE {
                "+ skin"
            } else {
                "animation"
            }
            .into(),
            r.characters.to_string(),
            num(r.full_ms, 2),
            num(r.lod_ms, 2),
            num(r.cost_ratio, 2),
            num(r.interpolated_fraction, 2),
            num(r.changed_fraction, 2),
            num(r.shared_fraction, 2),
            num(r.mean_error_px as f64, 3),
            num(r.max_error_px as f64, 2),
            r.threads.to_string(),
            r.parallel_speedup.map_or("-".into(), |s| num(s, 2)),
            r.parallel_speedup_median.map_or("-".into(), |s| num(s, 2)),
            if r.deterministic { "yes" } else { "NO" }.into(),
        ]);
    }
    t.note(
        "animation: sample + concat + palette, errors at bone origins and tips; + skin: the \
         whole pipeline with CPU skinning of every character's mesh (held joints: exact poses, \
         vertices skinned again only where a joint moved past the bound; changed = fraction of \
         vertices skinned; shared poses: characters far enough away show the skinned pose of \
         their clip's phase bucket, kept across frames, shared = fraction of them), errors at every skinned vertex in view, same = bit-identical \
         vertices and poses on every thread count. speedup: one thread over all cores, mean \
         frame times (median: of median frame times; on this shared VM runs of frames lose a \
         core for milliseconds).",
    );
    t.note("targets (issue 13): cost <= 0.33 at max error <= 1 px and mean <= 0.1 px; >= 1.8x on 2 cores.");
    t.render()
}

fn render_ablation(rows: &[AblationReport]) -> String {
    let mut t = Table::new(
        "Priorities at equal cost (35% of full-detail interpolations, camera ratio 1/2, 4 characters)",
        &["clip", "weighting", "spent", "mean px", "rms px", "max px"],
    );
    for r in rows {
        t.row([
            r.clip.clone(),
            r.weighting.replace('_', " "),
            num(r.update_fraction as f64, 2),
            num(r.mean_error_px as f64, 3),
            num(r.rms_error_px as f64, 3),
            num(r.max_error_px as f64, 2),
        ]);
    }
    t.note(
        "uniform: every bone of a character updated alike (the ablation of per-bone priority); \
         derived out of sample: weights fitted on the rig's other clips.",
    );
    t.render()
}
