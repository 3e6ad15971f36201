//! The swinging net (the simulation paper's section 6), measured: Table 1 (one TreeCut
//! operation), Figure 4 (operation time against node count), Figure 5 (step time against node count), then the experiment itself
//! (`slod_experiments::net::run_net`: a full-resolution reference, feedback runs at several
//! compressions, uniform and random cuts, a time-budget run), giving Table 2 (step times beside
//! the paper's and Bullet's) and the surface error of every run against the reference.

mod figure4;
mod ops;
mod records;
mod scaling;
mod solver;
mod tables;

use std::time::Instant;

use slod_experiments::net::{NetConfig, NetReport, run_net};

use crate::cli::NetOptions;
use crate::error::DemoError;
use crate::progress::Progress;

pub(crate) use figure4::Figure4;
pub(crate) use ops::Table1;
pub(crate) use records::NetSection;
use records::{config_report, run_report};
use scaling::Figure5Plan;
pub(crate) use scaling::{BulletLike, Figure5};
pub(crate) use solver::SolverSpeed;
use tables::{render_errors, render_table2, table2};

/// What to measure, from the options and the mode.
#[derive(Clone, Debug)]
pub(crate) struct NetPlan {
    /// The experiment's configuration.
    pub(crate) config: NetConfig,
    /// Steps after which the cloth is pictured (the paper's 45, 90, 180).
    pub(crate) picture_steps: Vec<u32>,
    /// Target of the time-budget run when the user gave one (else half the measured
    /// full-resolution step time).
    target_ms: Option<f32>,
    /// Net side and cycles of Table 1.
    ops_size: u32,
    ops_cycles: usize,
    /// Net sides and cycles per side of Figure 4.
    figure4_sizes: Vec<u32>,
    figure4_cycles: usize,
    /// What Figure 5 measures.
    figure5: Figure5Plan,
    /// Side of the Bullet-like cloth.
    bullet_size: u32,
    /// Sides of the Bullet-topology cloths of the solver figures (the largest also threaded),
    /// the side of the net reached by operations, and timed steps per figure.
    solver_sizes: Vec<u32>,
    churn_side: u32,
    solver_steps: u32,
}

impl NetPlan {
    /// The plan for these options; `quick` shrinks every default.
    pub(crate) fn new(options: &NetOptions, quick: bool) -> Result<NetPlan, DemoError> {
        let mut config = NetConfig::paper()?;
        let (size, steps) = if quick { (17, 60) } else { (65, 600) };
        config.size = options.size.unwrap_or(size);
        config.steps = options.steps.unwrap_or(steps);
        if let Some(c) = &options.compressions {
            config.compressions = c.clone();
        }
        // The baselines run at the strongest compression, where the choice of cut matters most.
        config.baseline_compression = config
            .compressions
            .iter()
            .copied()
            .filter(|&c| c < 1.0)
            .min_by(f32::total_cmp);
        let picture_steps = picture_steps(config.steps);
        config.snapshot_steps = snapshot_steps(&picture_steps, config.steps);
        let mut scaling_sizes = if quick {
            vec![9, 17]
        } else {
            vec![33, 49, 65, 97, 129]
        };
        if !scaling_sizes.contains(&config.size) {
            scaling_sizes.push(config.size);
            scaling_sizes.sort_unstable();
        }
        Ok(NetPlan {
            picture_steps,
            target_ms: options.target_ms,
            ops_size: if quick { 17 } else { ops::PAPER_SIZE },
            ops_cycles: if quick { 200 } else { 12_000 },
            figure4_sizes: if quick {
                vec![9, 17]
            } else {
                figure4::SIZES.to_vec()
            },
            figure4_cycles: if quick { 50 } else { 1_000 },
            figure5: Figure5Plan {
                sizes: scaling_sizes,
                compressions: if quick {
                    vec![1.0, 0.5]
                } else {
                    vec![1.0, 0.75, 0.5, 0.3]
                },
                feedback_compressions: if quick { vec![0.5] } else { vec![0.75, 0.3] },
                warmup: if quick { 2 } else { 10 },
                steps: if quick { 6 } else { 60 },
                feedback_warmup: if quick { 10 } else { 60 },
                feedback_steps: if quick { 10 } else { 120 },
            },
            bullet_size: if quick { 17 } else { crate::peer::BULLET_SIZE },
            solver_sizes: if quick { vec![17] } else { vec![65, 129] },
            churn_side: if quick { 17 } else { 65 },
            solver_steps: if quick { 4 } else { 40 },
            config,
        })
    }
}

/// The paper's Figure 6 shows the cloth after 45, 90 and 180 steps; shorter runs get the same
/// proportions of their length.
fn picture_steps(steps: u32) -> Vec<u32> {
    let mut s = if steps >= 180 {
        vec![45, 90, 180]
    } else {
        vec![(steps / 4).max(1), (steps / 2).max(1), steps]
    };
    s.dedup();
    s
}

/// Steps after which the experiment keeps a snapshot: each picture step and the
/// [`crate::render::LINK_WINDOW`] steps after it. The feedback loop begins its operations every
/// few steps and blends them over a few more, so the cut may have nothing in flight at exactly
/// step 45; the links picture takes the step of the window with the most links being blended.
fn snapshot_steps(pictures: &[u32], steps: u32) -> Vec<u32> {
    let mut s: Vec<u32> = pictures
        .iter()
        .flat_map(|&p| p..=(p + crate::render::LINK_WINDOW).min(steps))
        .collect();
    s.sort_unstable();
    s.dedup();
    s
}

/// The section's results: the report part, the library's report (for the pictures) and the
/// tables as text.
#[derive(Debug)]
pub(crate) struct NetOutcome {
    /// For report.json.
    pub(crate) section: NetSection,
    /// The experiment's raw report, with its snapshots.
    pub(crate) report: NetReport,
    /// The tables, ready to print.
    pub(crate) text: String,
}

/// Runs the whole net section.
pub(crate) fn run(plan: &NetPlan, progress: Progress) -> Result<NetOutcome, DemoError> {
    let start = Instant::now();
    let table1 = ops::measure(&plan.config, plan.ops_size, plan.ops_cycles, progress)?;
    let figure4 = figure4::measure(
        &plan.config,
        &plan.figure4_sizes,
        plan.figure4_cycles,
        progress,
    )?;
    let figure5 = scaling::measure(&plan.config, &plan.figure5, progress)?;
    let bullet_like = scaling::bullet_like(plan.bullet_size, plan.figure5.steps)?;
    let solver = solver::measure(&plan.solver_sizes, plan.churn_side, plan.solver_steps)?;

    let mut config = plan.config.clone();
    let (target, target_source) = match plan.target_ms {
        Some(t) => (t, "option"),
        None => {
            let full = figure5
                .point("treecut", config.size, 1.0)
                .map_or(1.0, |p| p.ms_per_step);
            // Rounded to a microsecond, so the run's label stays readable.
            let half = ((0.5 * full * 1e3).round() / 1e3).max(1e-3);
            (half as f32, "half of the measured full-resolution step")
        }
    };
    config.target_step_ms = Some(target);

    let runs =
        1 + config.compressions.len() + 2 * usize::from(config.baseline_compression.is_some()) + 1;
    let total = runs as u64 * config.steps as u64;
    let experiment_start = Instant::now();
    let bar = progress.bar(total, "net");
    // run_net reports (label, step, steps) every few steps; runs come one after another, all
    // of the same length.
    let mut finished_runs = 0u64;
    let mut current = String::new();
    let report = run_net(&config, &mut |label, step, steps| {
        if label != current {
            if !current.is_empty() {
                finished_runs += 1;
            }
            current = label.to_string();
            bar.set_message(format!("{0}x{0} net: {label}", config.size));
        }
        bar.set_position(finished_runs * steps as u64 + step as u64);
    })?;
    bar.finish_and_clear();

    let section = NetSection {
        config: config_report(plan, &config, &report, target, target_source),
        runs: report
            .runs
            .iter()
            .map(|r| run_report(r, &report, config.feedback.interval))
            .collect(),
        table2: table2(&report, &figure5, bullet_like, config.size),
        table1,
        figure4,
        figure5,
        solver,
        experiment_seconds: experiment_start.elapsed().as_secs_f64(),
        seconds: start.elapsed().as_secs_f64(),
    };
    let text = [
        section.table1.render(),
        section.figure4.render(),
        section.figure5.render(),
        render_table2(&section),
        section.solver.render(),
        render_errors(&section),
    ]
    .join("\n");
    Ok(NetOutcome {
        section,
        report,
        text,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snapshots_follow_figure_6() {
        assert_eq!(picture_steps(600), vec![45, 90, 180]);
        assert_eq!(picture_steps(60), vec![15, 30, 60]);
        assert_eq!(picture_steps(1), vec![1]);
        let w = crate::render::LINK_WINDOW;
        let s = snapshot_steps(&[45, 90], 600);
        assert_eq!(s.len(), 2 * (w as usize + 1));
        assert!(s.contains(&45) && s.contains(&(90 + w)));
        assert_eq!(snapshot_steps(&[15, 30, 60], 60).last(), Some(&60));
    }

    #[test]
    fn plan_keeps_user_choices() {
        let o = NetOptions {
            size: Some(21),
            steps: Some(40),
            compressions: Some(vec![1.0, 0.5, 0.25]),
            target_ms: Some(0.3),
        };
        let p = NetPlan::new(&o, false).unwrap();
        assert_eq!(p.config.size, 21);
        assert_eq!(p.config.steps, 40);
        assert_eq!(p.config.baseline_compression, Some(0.25));
        assert!(p.figure5.sizes.contains(&21));
        assert_eq!(p.target_ms, Some(0.3));
        let only_full = NetOptions {
            compressions: Some(vec![1.0]),
            ..NetOptions::default()
        };
        assert_eq!(
            NetPlan::new(&only_full, true)
                .unwrap()
                .config
                .baseline_compression,
            None
        );
    }
}
