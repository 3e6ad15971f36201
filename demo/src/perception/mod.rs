//! Perception that pays, measured on screen (`slod_experiments::perception`): every strategy on
//! every scene family at the same node count, in pixels on a 1080-px-high view, the twin floor,
//! short-horizon error on chaotic scenes, and equal error (feedback's cost against a uniform
//! cut's at the same p99). Printed as tables, plotted (error against cost per scene) and
//! written to report.json's `perception` object; one view-dependent scene is also recorded as
//! a moving picture (`render::movie`).

mod records;

use std::time::Instant;

use glam::Vec3;
use slod_experiments::perception::{
    self, FOV_Y_DEG, MEASURE_HEIGHT_PX, PerceptionConfig, Reference, RunSpec, Scene, SceneOutcome,
    SceneScale, Strategy,
};
use slod_experiments::table::{Table, num, pct};

use crate::error::DemoError;
use crate::progress::Progress;

pub(crate) use records::{PerceptionSection, RunRecord, SceneRecord};

/// The scene recorded as a moving picture: the camera dollies in and orbits, so the cut must
/// follow the view.
pub(crate) const MOVIE_SCENE: &str = "dolly_orbit";

/// What to measure.
#[derive(Clone, Debug)]
pub(crate) struct PerceptionPlan {
    /// Scene sizes.
    pub(crate) scale: SceneScale,
    /// The experiment's settings.
    pub(crate) config: PerceptionConfig,
    /// Frames of the moving picture.
    pub(crate) movie_frames: u32,
}

impl PerceptionPlan {
    /// The full plan, or the tiny one with `quick`.
    pub(crate) fn new(quick: bool) -> PerceptionPlan {
        PerceptionPlan {
            scale: if quick {
                SceneScale::Tiny
            } else {
                SceneScale::Full
            },
            config: PerceptionConfig::default(),
            movie_frames: if quick { 8 } else { 50 },
        }
    }
}

/// One frame of the moving picture: the reference's and the LOD run's finest vertices, and the
/// level of the node covering each vertex in the LOD run.
#[derive(Clone, Debug)]
pub(crate) struct MovieFrame {
    /// Step (0-based).
    pub(crate) step: u32,
    /// Reference vertices.
    pub(crate) reference: Vec<Vec3>,
    /// LOD vertices.
    pub(crate) lod: Vec<Vec3>,
    /// Level (0 = finest) of the simulated node covering each vertex.
    pub(crate) levels: Vec<u32>,
    /// Simulated nodes.
    pub(crate) nodes: usize,
}

/// The recorded scene.
#[derive(Clone, Debug)]
pub(crate) struct Movie {
    /// The scene.
    pub(crate) scene: Scene,
    /// Vertices per side (the scene is a square grid).
    pub(crate) side: usize,
    /// The frames.
    pub(crate) frames: Vec<MovieFrame>,
    /// Seconds of simulation between frames.
    pub(crate) frame_seconds: f32,
}

/// The section's results.
#[derive(Debug)]
pub(crate) struct PerceptionOutcome {
    /// For report.json.
    pub(crate) section: PerceptionSection,
    /// The moving picture's frames.
    pub(crate) movie: Option<Movie>,
    /// The tables, ready to print.
    pub(crate) text: String,
}

/// Runs the perception section.
pub(crate) fn run(
    plan: &PerceptionPlan,
    progress: Progress,
) -> Result<PerceptionOutcome, DemoError> {
    let start = Instant::now();
    let scenes = perception::scenes::all(plan.scale)?;
    let bar = progress.bar(scenes.len() as u64 * 100, "perception");
    let mut outcomes = Vec::new();
    for (k, scene) in scenes.iter().enumerate() {
        let base = k as u64 * 100;
        let outcome = perception::run_scene(scene, &plan.config, &|name, done, total| {
            bar.set_message(name.to_string());
            bar.set_position(base + (100 * done / total.max(1)) as u64);
        })?;
        outcomes.push(outcome);
    }
    bar.finish_and_clear();
    let movie = scenes
        .iter()
        .find(|s| s.name == MOVIE_SCENE)
        .map(|s| record_movie(s, plan))
        .transpose()?;
    let section = records::section(&outcomes, &plan.config, start.elapsed().as_secs_f64());
    let text = [
        render_runs(&outcomes, &plan.config),
        render_equal_error(&section, &plan.config),
    ]
    .join("\n");
    Ok(PerceptionOutcome {
        section,
        movie,
        text,
    })
}

/// Runs the feedback strategy on `scene` once more, keeping `plan.movie_frames` frames of it
/// and of the reference.
fn record_movie(scene: &Scene, plan: &PerceptionPlan) -> Result<Movie, DemoError> {
    let reference: Reference = perception::record_reference(scene, None)?;
    let h = scene.hierarchy.clone();
    let full = h.vertex_count();
    let every = (scene.steps / plan.movie_frames.max(1)).max(1);
    let mut frames = Vec::new();
    let spec = RunSpec {
        strategy: Strategy::Feedback,
        nodes: slod::cloth::compression_nodes(plan.config.compression, full),
        bound_px: plan.config.bound_px,
        horizon: None,
    };
    perception::run_strategy(
        scene,
        &reference,
        spec,
        Some(&mut |step, cloth, vertices| {
            if step % every != every - 1 {
                return;
            }
            let body = cloth.body();
            let levels = (0..full as u32)
                .map(|v| {
                    body.particle_covering(v)
                        .map_or(0, |p| h.level(body.particle_nodes()[p.index()]))
                })
                .collect();
            frames.push(MovieFrame {
                step,
                reference: reference.frame(step).to_vec(),
                lod: vertices.to_vec(),
                levels,
                nodes: cloth.node_count(),
            });
        }),
    )?;
    Ok(Movie {
        scene: scene.clone(),
        side: (full as f64).sqrt().round() as usize,
        frames,
        frame_seconds: every as f32 * scene.body.solver.dt,
    })
}

/// Per scene: every run's nodes, cost and on-screen error.
fn render_runs(outcomes: &[SceneOutcome], config: &PerceptionConfig) -> String {
    let mut out = Vec::new();
    for o in outcomes {
        let mut t = Table::new(
            format!(
                "Perception: {} ({} vertices, {} steps{}{}), budget {} nodes ({}), error in px on a \
                 {}-px-high view, {}° field of view",
                o.name,
                o.full_nodes,
                o.steps,
                if o.view_dependent {
                    ", view-dependent"
                } else {
                    ""
                },
                if o.chaotic { ", chaotic" } else { "" },
                o.budget_nodes,
                pct(config.compression as f64, 0),
                MEASURE_HEIGHT_PX,
                FOV_Y_DEG
            ),
            &[
                "strategy",
                "horizon",
                "nodes",
                "ms/frame",
                "reconstruct",
                "rms px",
                "p99 px",
                "max px",
                "coarse / fine p99",
                "pop px (ops / drift)",
                "undone",
            ],
        );
        for r in &o.runs {
            t.row([
                match r.bound_px {
                    Some(b) => format!("{} {} px", r.strategy.name(), num(b as f64, 1)),
                    None => r.strategy.name().to_string(),
                },
                r.horizon_steps
                    .map_or("whole".to_string(), |h| format!("{h} steps")),
                num(r.nodes, 0),
                num(r.ms_per_step(), 3),
                r.reconstruct_ms
                    .map_or("-".to_string(), |_| pct(r.reconstruct_share(), 0)),
                num(r.screen.rms_px, 2),
                num(r.screen.p99_px, 2),
                num(r.screen.max_px, 2),
                r.screen_split.map_or("-".to_string(), |s| {
                    format!("{} / {}", num(s.coarse.p99_px, 2), num(s.fine.p99_px, 2))
                }),
                format!(
                    "{} ({} / {})",
                    num(r.screen.pop_max_px, 2),
                    num(r.screen.pop_operation_max_px, 2),
                    num(r.screen.pop_drift_max_px, 2)
                ),
                r.undone_fraction().map_or("-".to_string(), |u| pct(u, 1)),
            ]);
        }
        t.note(format!(
            "twin floor (the reference perturbed by 1 µm): rms {} px, p99 {} px, max {} px; solver \
             floor (the reference against itself at {}× the substeps): rms {} px, p99 {} px, max \
             {} px; ms/frame = step + \
             evaluation + reconstruction (the reference needs none), one thread's CPU time, all \
             runs of the scene interleaved, {} steps of each in turn; reconstruct: its share; \
             coarse / fine p99: at the vertices coarse nodes cover (the error a node's deviation \
             estimate is about) and at those simulated at the finest level (the drift the coarse \
             parts' dynamics carry across the cloth); pop: the largest frame-to-frame change of a \
             vertex's error, at vertices whose simulating node changed that frame (ops: a refine \
             begun, a coarse ended) and elsewhere (drift)",
            num(o.twin_floor.rms_px, 3),
            num(o.twin_floor.p99_px, 3),
            num(o.twin_floor.max_px, 3),
            slod_experiments::perception::SOLVER_FLOOR_SUBSTEPS_FACTOR,
            num(o.solver_floor.rms_px, 2),
            num(o.solver_floor.p99_px, 2),
            num(o.solver_floor.max_px, 2),
            slod_experiments::perception::INTERLEAVE_STEPS
        ));
        out.push(t.render());
    }
    out.join("\n")
}

/// Equal error: feedback's cost against a uniform cut's at the same p99.
fn render_equal_error(section: &PerceptionSection, config: &PerceptionConfig) -> String {
    let mut t = Table::new(
        "Perception: equal error (the cheapest uniform cut, interpolated, at feedback's p99; \
         chaotic scenes over short horizons)",
        &[
            "scene",
            "p99 px",
            "feedback nodes",
            "feedback ms",
            "uniform nodes",
            "uniform ms",
            "cost ratio",
        ],
    );
    for e in &section.equal_error {
        t.row([
            e.name.to_string(),
            num(e.p99_px, 2),
            num(e.feedback_nodes, 0),
            num(e.feedback_ms, 3),
            num(e.uniform_nodes, 0),
            num(e.uniform_ms, 3),
            num(e.cost_ratio, 2),
        ]);
    }
    for s in section
        .scenes
        .iter()
        .filter(|s| !section.equal_error.iter().any(|e| e.name == s.name))
    {
        t.row([
            s.name.to_string(),
            "-".into(),
            "-".into(),
            "-".into(),
            "-".into(),
            "-".into(),
            "no uniform cut as good".into(),
        ]);
    }
    let mut fractions = config.uniform_fractions.clone();
    fractions.push(config.compression);
    fractions.sort_by(f32::total_cmp);
    let fractions: Vec<String> = fractions.iter().map(|&f| pct(f as f64, 0)).collect();
    t.note(format!(
        "cost ratio < 1: the feedback loop is cheaper than a uniform cut at the same p99; the \
         uniform curve: cuts at {} of the nodes and the reference (0 px)",
        fractions.join(", ")
    ));
    t.render()
}
