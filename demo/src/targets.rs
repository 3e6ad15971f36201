//! The open issues' targets, checked against this run's own figures: one row per target with
//! the issue's words, what this run measured, and whether it was met — so a reader sees where
//! the project stands without adding up the tables, and a missed target is printed as missed.
//!
//! Each check reads only the sections' records (the same figures `report.json` carries); a
//! target this run does not measure (a peer figure not on this host, a size a quick run does
//! not reach) has `met: null` and says why; a section not run has no rows.
//! The criteria are the issues' (12: perception, 15: the world budget, 16: solver speed); where
//! an issue leaves a word open ("flat in N"), the row states the reading used.

use serde::Serialize;
use slod_experiments::table::{Table, num, pct};

use crate::net::NetSection;
use crate::perception::{PerceptionSection, RunRecord, SceneRecord};
use crate::world::WorldSection;

/// One target of an open issue and this run's figure for it.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct TargetCheck {
    /// The issue that sets it.
    pub(crate) issue: u32,
    /// The target, in the issue's words.
    pub(crate) target: &'static str,
    /// What this run measured (or why it did not).
    pub(crate) measured: String,
    /// Whether it was met; null when this run does not measure it.
    pub(crate) met: Option<bool>,
}

impl TargetCheck {
    fn new(issue: u32, target: &'static str, measured: String, met: Option<bool>) -> Self {
        TargetCheck {
            issue,
            target,
            measured,
            met,
        }
    }
}

/// Every target the sections that ran can speak to (none for a section not run).
pub(crate) fn check(
    net: Option<&NetSection>,
    perception: Option<&PerceptionSection>,
    world: Option<&WorldSection>,
) -> Vec<TargetCheck> {
    let mut out = Vec::new();
    if let Some(p) = perception {
        perception_targets(p, &mut out);
    }
    if let Some(w) = world {
        world_targets(w, &mut out);
    }
    if let Some(n) = net {
        net_targets(n, &mut out);
    }
    out
}

/// The run a scene's figures are judged by: over short horizons on a chaotic scene (its
/// whole-run error is the chaos), else over the whole run.
fn judged<'a>(scene: &'a SceneRecord, strategy: &str) -> Option<&'a RunRecord> {
    let whole = || {
        scene
            .runs
            .iter()
            .find(|r| r.strategy == strategy && r.horizon_steps.is_none())
    };
    if scene.chaotic {
        scene
            .runs
            .iter()
            .find(|r| r.strategy == strategy && r.horizon_steps.is_some())
            .or_else(whole)
    } else {
        whole()
    }
}

/// `(scenes meeting, scenes checked, the worst scene's name and description)`.
fn tally<'a>(
    scenes: impl Iterator<Item = (&'a str, bool, f64, String)>,
) -> (usize, usize, Option<(&'a str, String)>) {
    let (mut met, mut all) = (0, 0);
    let mut worst: Option<(&str, f64, String)> = None;
    for (name, ok, badness, text) in scenes {
        all += 1;
        met += usize::from(ok);
        if worst.as_ref().is_none_or(|w| badness > w.1) {
            worst = Some((name, badness, text));
        }
    }
    (met, all, worst.map(|(n, _, t)| (n, t)))
}

/// A target over scenes: met when every scene checked meets it (null when none was), with the
/// worst scene's figure.
fn scenes_row(
    out: &mut Vec<TargetCheck>,
    issue: u32,
    target: &'static str,
    (met, all, worst): (usize, usize, Option<(&str, String)>),
) {
    let measured = match worst {
        Some((name, text)) => format!("{met} of {all} scenes; worst {name}: {text}"),
        None => "no scene measured".to_string(),
    };
    let ok = (all > 0).then_some(met == all);
    out.push(TargetCheck::new(issue, target, measured, ok));
}

fn perception_targets(p: &PerceptionSection, out: &mut Vec<TargetCheck>) {
    // Error-bound mode at 1 px.
    let bound = p.scenes.iter().filter_map(|s| {
        let r = judged(s, "error_bound")?;
        let ok = r.screen_p99_px <= 1.0 && r.screen_max_px <= 2.0;
        let badness = (r.screen_p99_px / 1.0).max(r.screen_max_px / 2.0);
        let text = format!(
            "p99 {} / max {} px (twin floor {} / {})",
            num(r.screen_p99_px, 2),
            num(r.screen_max_px, 2),
            num(s.twin_floor_px.p99, 2),
            num(s.twin_floor_px.max, 2)
        );
        Some((s.name, ok, badness, text))
    });
    scenes_row(
        out,
        12,
        "error bound 1 px: p99 <= 1 px and max <= 2 px on every scene (short horizons on chaotic ones)",
        tally(bound),
    );
    // Cost at equal p99 against the cheapest uniform cut.
    let ratio = |view_dependent: bool, limit: f64| {
        p.equal_error.iter().filter_map(move |e| {
            let s = p.scenes.iter().find(|s| s.name == e.name)?;
            (s.view_dependent == view_dependent).then(|| {
                let text = format!("{} of uniform", num(e.cost_ratio, 2));
                (e.name, e.cost_ratio <= limit, e.cost_ratio, text)
            })
        })
    };
    scenes_row(
        out,
        12,
        "at equal on-screen p99, feedback costs <= 0.5x the cheapest uniform cut on view-dependent scenes",
        tally(ratio(true, 0.5)),
    );
    scenes_row(
        out,
        12,
        "at equal on-screen p99, feedback costs no more than the cheapest uniform cut on the other scenes",
        tally(ratio(false, 1.0)),
    );
    // The paper's net at 30% of the nodes.
    if let Some(s) = p.scenes.iter().find(|s| s.name == "net")
        && let (Some(f), Some(r)) = (judged(s, "feedback"), judged(s, "reference"))
    {
        let cost = f.ms_per_step / r.ms_per_step.max(1e-12);
        out.push(TargetCheck::new(
            12,
            "the paper's net at 30% of the nodes: RMS <= 0.5 px, max <= 2 px, cost <= 0.4x the full-resolution step",
            format!(
                "RMS {} px, max {} px, cost {}x (step, evaluation and reconstruction, one thread's CPU time)",
                num(f.screen_rms_px, 2),
                num(f.screen_max_px, 1),
                num(cost, 2)
            ),
            Some(f.screen_rms_px <= 0.5 && f.screen_max_px <= 2.0 && cost <= 0.4),
        ));
    }
    // Feedback against the baselines at equal nodes.
    for (baseline, target) in [
        (
            "uniform",
            "feedback's on-screen RMS below uniform's at equal nodes on every scene",
        ),
        (
            "random",
            "feedback's on-screen RMS below random's at equal nodes on every scene",
        ),
        (
            "camera_blind",
            "feedback's on-screen RMS below camera_blind's at equal nodes on every scene",
        ),
    ] {
        let rows = p.scenes.iter().filter_map(|s| {
            let (f, b) = (judged(s, "feedback")?, judged(s, baseline)?);
            let text = format!(
                "{} against {} px",
                num(f.screen_rms_px, 2),
                num(b.screen_rms_px, 2)
            );
            let badness = f.screen_rms_px / b.screen_rms_px.max(1e-12);
            Some((s.name, f.screen_rms_px < b.screen_rms_px, badness, text))
        });
        scenes_row(out, 12, target, tally(rows));
    }
    let undone = p.scenes.iter().filter_map(|s| {
        let worst = s
            .runs
            .iter()
            .filter(|r| r.strategy == "feedback")
            .filter_map(|r| r.undone_fraction)
            .fold(None, |m: Option<f64>, u| Some(m.map_or(u, |m| m.max(u))))?;
        Some((s.name, worst < 0.01, worst, pct(worst, 2)))
    });
    scenes_row(
        out,
        12,
        "feedback: operations undone within 30 steps < 1% on every scene",
        tally(undone),
    );
    let pops = p.scenes.iter().filter_map(|s| {
        let r = judged(s, "feedback")?;
        let pop = r.pop_max_px?;
        let text = format!(
            "{} px ({} px at operations)",
            num(pop, 2),
            num(r.pop_operation_max_px.unwrap_or(f64::NAN), 2)
        );
        Some((s.name, pop <= 0.5, pop, text))
    });
    scenes_row(
        out,
        12,
        "feedback: pops <= 0.5 px on every scene",
        tally(pops),
    );
}

fn world_targets(w: &WorldSection, out: &mut Vec<TargetCheck>) {
    out.push(TargetCheck::new(
        15,
        "world: from a cold start the frame time reaches the target within 60 frames",
        w.reached_target_after_frames
            .map_or("never reached".to_string(), |f| format!("after {f} frames")),
        Some(w.reached_target_after_frames.is_some_and(|f| f <= 60)),
    ));
    out.push(TargetCheck::new(
        15,
        "world: then within +-10% of the target on >= 95% of frames",
        format!(
            "{} of frames (fixed work on this machine: {} within 10% of its median)",
            pct(w.within_10pct_fraction, 1),
            pct(w.fixed_work_within_10pct_fraction, 1)
        ),
        Some(w.within_10pct_fraction >= 0.95),
    ));
    out.push(TargetCheck::new(
        15,
        "world: < 1% of operations undone within 30 frames",
        pct(w.undone_fraction, 2),
        Some(w.undone_fraction < 0.01),
    ));
    out.push(TargetCheck::new(
        15,
        "world: parallel speed-up >= 1.8x on 2 cores for the full-detail scene",
        w.parallel_speedup.map_or("not measured".to_string(), |s| {
            format!("{}x on {} threads", num(s, 2), w.parallel_threads)
        }),
        w.parallel_speedup.map(|s| s >= 1.8),
    ));
}

fn net_targets(n: &NetSection, out: &mut Vec<TargetCheck>) {
    if let Some(r) = n.runs.iter().find(|r| r.kind == "time_budget") {
        let undone = r.undone_operations as f64 / (r.operations.max(1)) as f64;
        out.push(TargetCheck::new(
            15,
            "the single-cloth time budget (Table 2's run) settles within 60 steps with < 1% undone",
            format!(
                "{} of its 5-step windows within 10% {}, {} undone (fixed work: {} within 10% of \
                 its median)",
                pct(r.within_10pct_fraction.unwrap_or(0.0), 0),
                r.reached_after_steps
                    .map_or("over the run: never settled".to_string(), |s| format!(
                        "from step {s}, where it settled"
                    )),
                pct(undone, 2),
                pct(r.fixed_work_within_10pct_fraction.unwrap_or(0.0), 0)
            ),
            Some(r.reached_after_steps.is_some_and(|s| s <= 60) && undone < 0.01),
        ));
    }
    let ours = &n.table2.bullet_like;
    let peer = &n.table2.peer_bullet;
    out.push(TargetCheck::new(
        16,
        "Bullet topology 65², 20 iterations: >= 10x Bullet's soft body",
        match peer.ms_per_step {
            Some(_) if peer.size != ours.size => format!(
                "Bullet measured at {0}², this run's cloth is {1}² (a quick run): not compared",
                peer.size, ours.size
            ),
            Some(b) => format!(
                "{}x ({} ms against Bullet's {} ms from {})",
                num(b / ours.ms_per_step.max(1e-12), 1),
                num(ours.ms_per_step, 3),
                num(b, 2),
                peer.results_file
            ),
            None => "Bullet not measured on this host (bench/peers/bullet_cloth.py)".to_string(),
        },
        peer.ms_per_step
            .filter(|_| peer.size == ours.size)
            .map(|b| b / ours.ms_per_step.max(1e-12) >= 10.0),
    ));
    let link_iterations = ours.links as f64 * f64::from(ours.iterations);
    let ns = ours.ms_per_step * 1e6 / link_iterations.max(1.0);
    out.push(TargetCheck::new(
        16,
        "about 1 ns per link-iteration on one core (read: <= 1.2 ns)",
        format!(
            "{} ns ({} links x {} iterations, the whole step)",
            num(ns, 2),
            ours.links,
            ours.iterations
        ),
        Some(ns <= 1.2),
    ));
    let slowest = n
        .table1
        .rows
        .iter()
        .max_by(|a, b| a.median_us.total_cmp(&b.median_us));
    if let Some(s) = slowest {
        out.push(TargetCheck::new(
            16,
            "Table 1: each of begin/end refine/coarse < 1 µs",
            format!(
                "{} (medians at {} nodes); slowest {} {} µs",
                n.table1
                    .rows
                    .iter()
                    .map(|r| format!("{} {}", r.operation, num(r.median_us, 2)))
                    .collect::<Vec<_>>()
                    .join(", "),
                num(s.nodes, 0),
                s.operation,
                num(s.median_us, 2)
            ),
            Some(n.table1.rows.iter().all(|r| r.median_us < 1.0)),
        ));
    }
    // "Flat in N", read as: the fitted line grows by at most a tenth of its intercept from
    // 0 to 250,000 nodes.
    let steep = n
        .figure4
        .fits
        .iter()
        .map(|f| (f, f.us_per_100k_nodes * 2.5 / f.intercept_us.max(1e-12)))
        .max_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((f, growth)) = steep {
        out.push(TargetCheck::new(
            16,
            "Figure 4: operation time flat in N (read: the fit grows <= 10% over 250,000 nodes)",
            format!(
                "steepest {}: {} µs + {} µs per 100k nodes ({} over 250k)",
                f.operation,
                num(f.intercept_us, 2),
                num(f.us_per_100k_nodes, 2),
                pct(growth, 0)
            ),
            Some(growth <= 0.1),
        ));
    }
    let solver = &n.solver;
    let at = |size: u32| solver.bullet.iter().find(|b| b.size == size);
    let (b65, b129) = (at(65), at(129));
    out.push(TargetCheck::new(
        16,
        "Bullet topology 129²: >= 10x Bullet, the same cost per link as at 65² (read: within 10%)",
        match (b65, b129) {
            (Some(s), Some(l)) => format!(
                "{} ({} ms); {} ns per link-iteration against {} at 65²",
                l.bullet_ratio
                    .map_or("Bullet not measured here".to_string(), |r| format!(
                        "{}x Bullet",
                        num(r, 1)
                    )),
                num(l.ms_per_step, 3),
                num(l.ns_per_link_iteration, 2),
                num(s.ns_per_link_iteration, 2)
            ),
            _ => "not measured at these sizes (a quick run)".to_string(),
        },
        match (b65, b129) {
            (Some(s), Some(l)) => l
                .bullet_ratio
                .map(|r| r >= 10.0 && l.ns_per_link_iteration <= 1.1 * s.ns_per_link_iteration),
            _ => None,
        },
    ));
    let p = &solver.paper_net;
    out.push(TargetCheck::new(
        16,
        "the paper's net (structural links) at 20 iterations: <= 0.1 ms",
        format!(
            "{} ms ({} nodes, {} links, {} ns per link-iteration)",
            num(p.ms_per_step, 3),
            p.nodes,
            p.links,
            num(p.ns_per_link_iteration, 2)
        ),
        Some(p.ms_per_step <= 0.1),
    ));
    let a = &solver.after_operations;
    out.push(TargetCheck::new(
        16,
        "after many refines and coarses, cost per link-iteration within 10% of an untouched grid",
        format!(
            "{}x ({} against {} ns, 75% cut after {} operations)",
            num(a.ratio, 2),
            num(a.after_ns_per_link_iteration, 2),
            num(a.built_ns_per_link_iteration, 2),
            a.operations
        ),
        Some(a.ratio <= 1.1),
    ));
    let h = &solver.threaded;
    out.push(TargetCheck::new(
        16,
        "multi-threaded step of one large cloth: >= 1.6x on 2 cores at 129² and above",
        format!(
            "{}x at {}² on {} threads ({} against {} ms; two independent bodies side by side: {}x)",
            num(h.speedup, 2),
            h.size,
            h.threads,
            num(h.ms_threaded, 3),
            num(h.ms_one_thread, 3),
            num(h.independent_speedup, 2)
        ),
        (h.size >= 129).then_some(h.speedup >= 1.6),
    ));
}

/// The checks as a table: met, missed, or measured elsewhere.
pub(crate) fn render(checks: &[TargetCheck]) -> String {
    let mut t = Table::new(
        "Targets of the open issues, this run",
        &["issue", "target", "this run", "met"],
    )
    .left_aligned();
    for c in checks {
        t.row([
            c.issue.to_string(),
            c.target.to_string(),
            c.measured.clone(),
            match c.met {
                Some(true) => "yes",
                Some(false) => "NO",
                None => "-",
            }
            .to_string(),
        ]);
    }
    let met = checks.iter().filter(|c| c.met == Some(true)).count();
    let judged = checks.iter().filter(|c| c.met.is_some()).count();
    t.note(format!(
        "{met} of {judged} targets this run measures are met; '-': not measured by this run (see the row)"
    ));
    t.render()
}
