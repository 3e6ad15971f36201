//! The run itself: parse, measure the net and the crowd, draw, write the report, print the
//! summary. Tables go to `out` as each section finishes; errors and the usage to `err`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::cli::{self, EXIT_FAILURE, EXIT_USAGE, Options, Parsed};
use crate::crowd::{self, CrowdOutcome, CrowdPlan};
use crate::engine::{self, EngineOutcome};
use crate::error::DemoError;
use crate::machine::Machine;
use crate::net::{self, NetOutcome, NetPlan};
use crate::paper::{TABLE1, TABLE2_TCSB, THESIS};
use crate::perception::{self, PerceptionOutcome, PerceptionPlan};
use crate::progress::Progress;
use crate::report::{self, Report, SCHEMA, Seconds};
use crate::world::{self, WorldOutcome, WorldPlan};
use crate::{plots, render, targets};
use slod_experiments::table::{Table, num, opt, pct};

/// Runs the demo for `args` (without the program name), printing tables to `out` and errors
/// to `err`; returns the process exit status: 0, [`EXIT_USAGE`] for a bad command line (the
/// message and the usage are printed), [`EXIT_FAILURE`] when a run fails.
pub fn run_cli(
    args: &[String],
    out: &mut dyn Write,
    err: &mut dyn Write,
    progress: Progress,
) -> i32 {
    let options = match cli::parse(args) {
        Ok(Parsed::Help) => {
            let _ = write!(out, "{}", cli::usage());
            return 0;
        }
        Ok(Parsed::Run(o)) => o,
        Err(e) => {
            let _ = write!(err, "error: {e}\n\n{}", cli::usage());
            return EXIT_USAGE;
        }
    };
    match run(&options, args, out, progress) {
        Ok(()) => 0,
        Err(e @ DemoError::Usage(_)) => {
            let _ = write!(err, "error: {e}\n\n{}", cli::usage());
            EXIT_USAGE
        }
        Err(e) => {
            let _ = writeln!(err, "error: {e}");
            EXIT_FAILURE
        }
    }
}

/// Prints text, ignoring a closed stdout (a pipe to `head` must not fail the run).
fn say(out: &mut dyn Write, text: &str) {
    let _ = writeln!(out, "{text}");
    let _ = out.flush();
}

fn run(
    options: &Options,
    args: &[String],
    out: &mut dyn Write,
    progress: Progress,
) -> Result<(), DemoError> {
    let start = Instant::now();
    let machine = Machine::detect();
    say(
        out,
        &format!(
            "slod demo: simulation and animation level of detail, measured beside the papers\n\
             machine: {}\n",
            machine.summary()
        ),
    );
    if machine.build == "debug" {
        say(
            out,
            "warning: this is a debug build; timings mean little. Run with `cargo run --release`.\n",
        );
    }
    let dir = options.out.as_path();
    std::fs::create_dir_all(dir).map_err(|e| DemoError::io(dir, e))?;
    // Plans first, so a bad option fails before minutes of measuring.
    let net_plan = options
        .section
        .net()
        .then(|| NetPlan::new(&options.net, options.quick))
        .transpose()?;
    let crowd_plan = options
        .section
        .crowd()
        .then(|| CrowdPlan::new(&options.crowd, options.quick));
    let perception_plan = options
        .section
        .perception()
        .then(|| PerceptionPlan::new(options.quick));
    let world_plan = options
        .section
        .world()
        .then(|| WorldPlan::new(options.world.frames, options.world.target_ms, options.quick));

    let mut seconds = Seconds::default();
    let mut files: Vec<PathBuf> = Vec::new();
    let mut net_outcome: Option<NetOutcome> = None;
    if let Some(plan) = &net_plan {
        say(
            out,
            &format!(
                "== The swinging net (simulation paper, section 6): {0}x{0} vertices, {1} steps ==\n",
                plan.config.size, plan.config.steps
            ),
        );
        let outcome = net::run(plan, progress)?;
        seconds.net = outcome.section.seconds;
        say(out, &outcome.text);
        let t = Instant::now();
        files.extend(render::net_pictures(
            &outcome.report,
            &plan.config,
            &plan.picture_steps,
            dir,
        )?);
        files.push(plots::net_operation_time(&outcome.section, dir)?);
        files.push(plots::net_step_time(&outcome.section, dir)?);
        seconds.pictures += t.elapsed().as_secs_f64();
        net_outcome = Some(outcome);
    }
    let mut crowd_outcome: Option<CrowdOutcome> = None;
    if let Some(plan) = &crowd_plan {
        say(
            out,
            "== The crowd (bone-priority thesis, chapter 13): camera swept away ==\n",
        );
        let outcome = crowd::run(plan, progress)?;
        seconds.crowd = outcome.section.seconds;
        say(out, &outcome.text);
        let t = Instant::now();
        files.push(plots::crowd_frame_cost(&outcome.section, dir)?);
        files.push(plots::crowd_pose_error(&outcome.section, dir)?);
        seconds.pictures += t.elapsed().as_secs_f64();
        crowd_outcome = Some(outcome);
    }

    let mut engine_outcome: Option<EngineOutcome> = None;
    if options.section.engine() {
        say(
            out,
            "== Engine scenes (issue 14): colliders, wind, a cape on a walking character ==\n",
        );
        let outcome = engine::run(options.quick, progress)?;
        seconds.engine = outcome.section.seconds;
        say(out, &outcome.text);
        engine_outcome = Some(outcome);
    }

    let mut perception_outcome: Option<PerceptionOutcome> = None;
    if let Some(plan) = &perception_plan {
        say(
            out,
            "== Perception: every strategy on every scene family, on screen (1080-px-high view) ==\n",
        );
        let outcome = perception::run(plan, progress)?;
        seconds.perception = outcome.section.seconds;
        say(out, &outcome.text);
        let t = Instant::now();
        files.push(plots::perception_error_cost(&outcome.section, dir)?);
        if let Some(movie) = &outcome.movie {
            files.push(render::perception_movie(movie, dir)?);
        }
        seconds.pictures += t.elapsed().as_secs_f64();
        perception_outcome = Some(outcome);
    }

    let mut world_outcome: Option<WorldOutcome> = None;
    if let Some(plan) = &world_plan {
        say(
            out,
            &format!(
                "== World budget (issue 15): 16 cloths and {} characters, a flying camera, {} ms per frame ==\n",
                plan.config.characters, plan.config.target_ms
            ),
        );
        let outcome = world::run(plan, progress)?;
        seconds.world = outcome.section.seconds;
        say(out, &outcome.text);
        let t = Instant::now();
        files.extend(world::plots(&outcome, dir)?);
        seconds.pictures += t.elapsed().as_secs_f64();
        world_outcome = Some(outcome);
    }

    let report_path = dir.join("report.json");
    let names: Vec<String> = files
        .iter()
        .map(|f| relative(f, dir))
        .chain(std::iter::once("report.json".to_string()))
        .collect();
    seconds.total = start.elapsed().as_secs_f64();
    let checks = targets::check(
        net_outcome.as_ref().map(|o| &o.section),
        perception_outcome.as_ref().map(|o| &o.section),
        world_outcome.as_ref().map(|o| &o.section),
    );
    let report = Report {
        schema: SCHEMA,
        command: options.section.name(),
        quick: options.quick,
        arguments: args,
        machine: &machine,
        net: net_outcome.as_ref().map(|o| &o.section),
        crowd: crowd_outcome.as_ref().map(|o| &o.section),
        engine: engine_outcome.as_ref().map(|o| &o.section),
        perception: perception_outcome.as_ref().map(|o| &o.section),
        world: world_outcome.as_ref().map(|o| &o.section),
        targets: &checks,
        files: names.clone(),
        seconds: seconds.clone(),
    };
    report::write(&report_path, &report)?;
    if !checks.is_empty() {
        say(out, &targets::render(&checks));
    }
    say(
        out,
        &summary(&report, dir, &names, start.elapsed().as_secs_f64()),
    );
    Ok(())
}

fn relative(path: &Path, dir: &Path) -> String {
    path.strip_prefix(dir)
        .unwrap_or(path)
        .to_string_lossy()
        .into_owned()
}

/// The closing table: the headline figures, ours beside the papers'.
fn summary(report: &Report<'_>, dir: &Path, files: &[String], total_s: f64) -> String {
    let mut t = Table::new(
        "Summary",
        &["result", "ours (this machine)", "paper / thesis"],
    )
    .left_aligned();
    if let Some(net) = report.net {
        let c = &net.config;
        let base = net
            .runs
            .iter()
            .find(|r| r.kind == "feedback" && r.compression == Some(1.0))
            .or_else(|| net.runs.iter().find(|r| r.kind == "reference"));
        let strongest = net
            .runs
            .iter()
            .filter(|r| r.kind == "feedback")
            .min_by(|a, b| {
                a.compression
                    .unwrap_or(1.0)
                    .total_cmp(&b.compression.unwrap_or(1.0))
            });
        if let (Some(base), Some(s)) = (base, strongest) {
            let paper = &TABLE2_TCSB[2];
            t.row([
                format!("net {0}x{0}: step time, {1}", c.size, s.label),
                format!(
                    "{} ms, {} nodes ({} of no compression)",
                    num(s.ms_per_step, 3),
                    num(s.nodes, 0),
                    num(s.ms_per_step / base.ms_per_step, 2)
                ),
                format!(
                    "{} ms, {} nodes ({} of no compression)",
                    num(paper.ms_per_step, 2),
                    paper.nodes,
                    num(paper.ms_per_step / TABLE2_TCSB[0].ms_per_step, 2)
                ),
            ]);
            let baseline = |kind: &str| {
                net.runs
                    .iter()
                    .find(|r| r.kind == kind)
                    .map_or("-".to_string(), |r| pct(r.rms_error_fraction as f64, 2))
            };
            t.row([
                format!(
                    "net: rms surface error at {}",
                    s.label.replace("feedback ", "")
                ),
                format!(
                    "feedback {}, uniform {}, random {}",
                    pct(s.rms_error_fraction as f64, 2),
                    baseline("uniform"),
                    baseline("random")
                ),
                "not measured".to_string(),
            ]);
        }
        if let Some(r) = net.runs.iter().find(|r| r.kind == "time_budget") {
            t.row([
                format!(
                    "net: time budget {} ms/step",
                    num(c.target_step_ms as f64, 3)
                ),
                format!(
                    "{} ms mean, {} once settled ({}; >= 95% of windows within 10% {}; fixed \
                     work: {} of windows within 10% of their median), {} nodes, rms error {}",
                    num(r.ms_per_step, 3),
                    r.ms_per_step_settled.map_or("-".into(), |m| num(m, 3)),
                    r.settled_after_steps
                        .map_or("never within 10%".into(), |s| format!("from step {s}")),
                    r.reached_after_steps.map_or("never".into(), |s| format!(
                        "from step {s}: {}",
                        pct(r.within_10pct_fraction.unwrap_or(0.0), 0)
                    )),
                    r.fixed_work_within_10pct_fraction
                        .map_or("-".into(), |f| pct(f, 0)),
                    num(r.nodes, 0),
                    pct(r.rms_error_fraction as f64, 2)
                ),
                "proposed, not measured".to_string(),
            ]);
        }
        let op = |i: usize| net.table1.rows.get(i).map_or(f64::NAN, |r| r.median_us);
        t.row([
            "Table 1: begin-refine / begin-coarse (median)".to_string(),
            format!("{} / {} µs", num(op(0), 2), num(op(2), 2)),
            format!(
                "{} / {} µs",
                num(TABLE1[0].complete_ms * 1e3, 1),
                num(TABLE1[2].complete_ms * 1e3, 1)
            ),
        ]);
        if let Some(f) = net.figure5.fits.iter().find(|f| f.body == "treecut") {
            t.row([
                "Figure 5: step time against nodes".to_string(),
                format!(
                    "linear: {} ms per 1000 nodes (R² {})",
                    num(f.ms_per_1000_nodes, 3),
                    num(f.r_squared, 3)
                ),
                "linear".to_string(),
            ]);
        }
    }
    if let Some(crowd) = report.crowd {
        if let Some(first) = crowd.sweeps.first() {
            t.row([
                format!("crowd: far-away frame cost, {}", first.name),
                format!("{} of full detail", num(crowd.far_cost_ratio.ours, 2)),
                format!(
                    "{} ({} fps -> {} fps)",
                    num(crowd.far_cost_ratio.thesis, 2),
                    THESIS.fps_without_lod,
                    THESIS.fps_with_lod_far
                ),
            ]);
        }
        for s in &crowd.sweeps {
            let worst_mean = s
                .rows
                .iter()
                .map(|r| r.mean_error_px)
                .fold(0.0f32, f32::max);
            let worst_max = s.rows.iter().map(|r| r.max_error_px).fold(0.0f32, f32::max);
            let cost =
                s.rows.iter().map(|r| r.cost_ratio).sum::<f64>() / s.rows.len().max(1) as f64;
            t.row([
                format!("crowd: {}", s.name),
                format!(
                    "mean cost {}, error mean <= {} px, max {} px",
                    num(cost, 2),
                    num(worst_mean as f64, 2),
                    num(worst_max as f64, 1)
                ),
                if s.lod.mode == "range" {
                    "error not measured".to_string()
                } else {
                    "beyond the thesis".to_string()
                },
            ]);
        }
        let p = &crowd.pipeline;
        let total = |s: &crate::crowd_large::StagesReport| {
            s.sample_ms + s.concat_ms + s.palette_ms + s.skin_ms
        };
        t.row([
            format!(
                "crowd: pipeline, {}, {} characters",
                p.lod_mode.replace('_', " "),
                p.characters
            ),
            format!(
                "{} of full detail, error mean {} px, max {} px ({})",
                num(total(&p.lod) / total(&p.full).max(1e-12), 2),
                num(p.mean_error_px as f64, 3),
                num(p.max_error_px as f64, 2),
                p.error_measure.replace('_', " ")
            ),
            "issue 13: <= 0.33 at max <= 1 px, mean <= 0.1 px".to_string(),
        ]);
        for r in crowd
            .large
            .iter()
            .filter(|r| r.error_measure == "skinned_vertices")
        {
            t.row([
                format!(
                    "crowd: whole pipeline, {}, {} characters",
                    r.lod_mode.replace('_', " "),
                    r.characters
                ),
                format!(
                    "{} of full detail, error mean {} px, max {} px; {} threads {}x (median \
                     frame {}x), same vertices: {}",
                    num(r.cost_ratio, 2),
                    num(r.mean_error_px as f64, 3),
                    num(r.max_error_px as f64, 2),
                    r.threads,
                    opt(r.parallel_speedup, 2),
                    opt(r.parallel_speedup_median, 2),
                    if r.deterministic { "yes" } else { "NO" }
                ),
                "issue 13: <= 0.33 at max <= 1 px, mean <= 0.1 px; >= 1.8x on 2 cores".to_string(),
            ]);
        }
    }
    if let Some(engine) = report.engine {
        for s in &engine.scenes {
            let reference = s.runs.iter().find(|r| r.strategy == "reference");
            let lod = s.runs.iter().find(|r| r.strategy == "lod");
            if let (Some(reference), Some(lod)) = (reference, lod) {
                t.row([
                    format!(
                        "engine: {} ({} collider{})",
                        s.name,
                        s.colliders,
                        if s.colliders == 1 { "" } else { "s" }
                    ),
                    format!(
                        "LOD {} of {} nodes: {} ms/step ({} contact), screen RMS {} px, \
                         penetration {} mm (reference {} mm)",
                        num(lod.nodes, 0),
                        num(reference.nodes, 0),
                        num(lod.ms_per_step, 2),
                        pct(lod.collision_fraction, 0),
                        num(lod.screen_rms_px.unwrap_or(f64::NAN), 2),
                        num(lod.max_penetration_mm, 1),
                        num(reference.max_penetration_mm, 1)
                    ),
                    "beyond the paper (no collisions measured)".to_string(),
                ]);
            }
        }
    }
    if let Some(p) = report.perception {
        let whole = |s: &crate::perception::SceneRecord, name: &str| {
            s.runs
                .iter()
                .find(|r| r.strategy == name && r.horizon_steps.is_none())
                .map(|r| r.screen_rms_px)
        };
        let beats = |other: &str| {
            p.scenes
                .iter()
                .filter(|s| match (whole(s, "feedback"), whole(s, other)) {
                    (Some(f), Some(o)) => f < o,
                    _ => false,
                })
                .count()
        };
        t.row([
            "perception: feedback's on-screen rms below".to_string(),
            format!(
                "uniform on {}, random on {}, camera_blind on {}, rim_blind on {}, pin_aware on {} of {} scenes",
                beats("uniform"),
                beats("random"),
                beats("camera_blind"),
                beats("rim_blind"),
                beats("pin_aware"),
                p.scenes.len()
            ),
            "not measured".to_string(),
        ]);
        let ratios: Vec<f64> = p.equal_error.iter().map(|e| e.cost_ratio).collect();
        if !ratios.is_empty() {
            t.row([
                "perception: feedback cost at a uniform cut's p99".to_string(),
                format!(
                    "{} to {} of the uniform cut's",
                    num(ratios.iter().copied().fold(f64::MAX, f64::min), 2),
                    num(ratios.iter().copied().fold(f64::MIN, f64::max), 2)
                ),
                "5-9x faster than non-adaptive (Koh et al. 2014)".to_string(),
            ]);
        }
    }
    if let Some(w) = report.world {
        t.row([
            format!(
                "world: {} objects, {} ms per frame",
                w.objects,
                num(w.target_ms as f64, 1)
            ),
            format!(
                "p50 {} / p99 {} ms, {}, {} within 10%, {} undone, speedup {}, screen RMS {} px",
                num(w.p50_ms, 2),
                num(w.p99_ms, 2),
                w.settled_after_frames
                    .map_or("never settled".into(), |f| format!(
                        "settled after frame {f}"
                    )),
                pct(w.within_10pct_fraction, 1),
                pct(w.undone_fraction, 2),
                opt(w.parallel_speedup, 2),
                opt(w.screen_rms_px, 2)
            ),
            "APEX / Unreal budget practice; the paper's \"maximal computation time\"".to_string(),
        ]);
    }
    t.row([
        "written".to_string(),
        format!(
            "{} files in {} (report.json, {} PNG)",
            files.len(),
            dir.display(),
            files.iter().filter(|f| f.ends_with(".png")).count()
        ),
        String::new(),
    ]);
    t.row([
        "wall time".to_string(),
        format!("{total_s:.1} s"),
        String::new(),
    ]);
    t.render()
}
