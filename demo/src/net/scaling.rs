//! The paper's Figure 5 measured: time per step against node count, for the TreeCut soft body
//! at several compressions and net sizes and for the plain soft body at full resolution; plus
//! our Bullet-like plain cloth at Bullet's own settings, the row Table 2 compares with Bullet.
//!
//! Each point is a static cut (the finest cut, or a level-uniform cut refined in a scattered
//! order up to the node count, see [`even_cut`]), so it measures the solver alone: no
//! feedback, no transitions. The feedback
//! runs of the net experiment add their own points (with evaluation and blending) on the plot.
//! Times are the median over the measured steps, which a busy machine disturbs less than the
//! mean.

use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;
use slod::cloth::{AdaptiveCloth, ClothBudget, FeedbackSettings};
use slod_experiments::net::NetConfig;
use softbody::{GridCloth, SoftBody, TreeCutSoftBody};
use treecut::{Cut, Hierarchy};

use super::solver::median_step_ms;
use crate::error::DemoError;
use crate::progress::Progress;
use slod_experiments::table::{Table, num};

/// One measured configuration.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct Point {
    /// `plain` (the plain soft body), `treecut` (the TreeCut soft body on a static cut) or
    /// `feedback` (the adaptive cloth, feedback loop on).
    pub(crate) body: &'static str,
    /// Vertices per side of the net.
    pub(crate) size: u32,
    /// Fraction of the full node count simulated (1 for `plain`).
    pub(crate) compression: f32,
    /// Simulated nodes (mean over the measured steps for `feedback`).
    pub(crate) nodes: f64,
    /// Links (mean over the measured steps for `feedback`).
    pub(crate) links: f64,
    /// Time per step (ms): median for static cuts, mean for `feedback`.
    pub(crate) ms_per_step: f64,
}

/// A least-squares line `ms = intercept + slope · nodes`.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct Fit {
    /// Which body's points.
    pub(crate) body: &'static str,
    /// Slope, in ms per 1000 nodes.
    pub(crate) ms_per_1000_nodes: f64,
    /// Intercept (ms).
    pub(crate) intercept_ms: f64,
    /// Coefficient of determination of the fit (1 = exactly linear).
    pub(crate) r_squared: f64,
}

/// The measured Figure 5.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct Figure5 {
    /// Net sizes (vertices per side).
    pub(crate) sizes: Vec<u32>,
    /// Compressions of the static-cut points.
    pub(crate) compressions: Vec<f32>,
    /// Compressions of the feedback points.
    pub(crate) feedback_compressions: Vec<f32>,
    /// Steps run before timing each point.
    pub(crate) warmup_steps: u32,
    /// Steps timed per static point.
    pub(crate) measured_steps: u32,
    /// Steps run before timing each feedback point (the cut settles from the even start).
    pub(crate) feedback_warmup_steps: u32,
    /// Steps timed per feedback point.
    pub(crate) feedback_steps: u32,
    /// Every point.
    pub(crate) points: Vec<Point>,
    /// A line through each body's points.
    pub(crate) fits: Vec<Fit>,
    /// Wall time of the measurement (s).
    pub(crate) seconds: f64,
}

/// Our plain cloth built the way Bullet builds one (triangle edges and distance-2 bend links),
/// at Bullet's settings, to set beside Bullet's own figures.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct BulletLike {
    /// Vertices per side.
    pub(crate) size: u32,
    /// Nodes.
    pub(crate) nodes: usize,
    /// Links.
    pub(crate) links: usize,
    /// Solver iterations per step (one substep).
    pub(crate) iterations: u32,
    /// Median time per step (ms).
    pub(crate) ms_per_step: f64,
}

impl Figure5 {
    /// The point of `body` at this size and compression, if measured.
    pub(crate) fn point(&self, body: &str, size: u32, compression: f32) -> Option<&Point> {
        self.points.iter().find(|p| {
            p.body == body && p.size == size && (p.compression - compression).abs() < 1e-4
        })
    }

    /// The plain point at this size, if measured.
    pub(crate) fn plain(&self, size: u32) -> Option<&Point> {
        self.points
            .iter()
            .find(|p| p.body == "plain" && p.size == size)
    }
}

fn corners(size: u32) -> [(u32, u32); 4] {
    [(0, 0), (size - 1, 0), (0, size - 1), (size - 1, size - 1)]
}

/// What Figure 5 measures.
#[derive(Clone, Debug)]
pub(crate) struct Figure5Plan {
    /// Net sizes (vertices per side).
    pub(crate) sizes: Vec<u32>,
    /// Compressions of the static cuts.
    pub(crate) compressions: Vec<f32>,
    /// Compressions run with the feedback loop.
    pub(crate) feedback_compressions: Vec<f32>,
    /// Steps before timing a static point.
    pub(crate) warmup: u32,
    /// Steps timed per static point.
    pub(crate) steps: u32,
    /// Steps before timing a feedback point.
    pub(crate) feedback_warmup: u32,
    /// Steps timed per feedback point.
    pub(crate) feedback_steps: u32,
}

/// The mean time per step and the mean node and link counts of the adaptive cloth with its
/// feedback loop holding `compression`, started from an even cut of that size.
fn feedback_point(
    config: &NetConfig,
    h: &Arc<Hierarchy>,
    compression: f32,
    plan: &Figure5Plan,
) -> Result<Point, DemoError> {
    let spec = config.grid();
    let full = h.vertex_count();
    let nodes = ((compression as f64 * full as f64).round() as usize).max(1);
    let mut cloth = AdaptiveCloth::new(
        h.clone(),
        even_cut(h, nodes)?,
        config.body,
        spec.u.cross(spec.v),
    )?;
    for (i, j) in corners(config.size) {
        cloth
            .body_mut()
            .pin_vertex(spec.vertex(i, j), spec.position(i, j))?;
    }
    cloth.set_feedback(Some(FeedbackSettings {
        budget: ClothBudget::Compression(compression),
        ..config.feedback
    }))?;
    for _ in 0..plan.feedback_warmup {
        cloth.step(&config.view)?;
    }
    let (mut seconds, mut nodes, mut links) = (0f64, 0f64, 0f64);
    let steps = plan.feedback_steps.max(1);
    for _ in 0..steps {
        let t = Instant::now();
        cloth.step(&config.view)?;
        seconds += t.elapsed().as_secs_f64();
        nodes += cloth.node_count() as f64;
        links += cloth.link_count() as f64;
    }
    let n = steps as f64;
    Ok(Point {
        body: "feedback",
        size: config.size,
        compression,
        nodes: nodes / n,
        links: links / n,
        ms_per_step: 1e3 * seconds / n,
    })
}

/// Measures every size: the plain body, the static cuts and the feedback loop.
pub(crate) fn measure(
    config: &NetConfig,
    plan: &Figure5Plan,
    progress: Progress,
) -> Result<Figure5, DemoError> {
    let start = Instant::now();
    let per_size = 1 + plan.compressions.len() + plan.feedback_compressions.len();
    let bar = progress.bar((plan.sizes.len() * per_size) as u64, "Figure 5");
    let mut points = Vec::new();
    for &size in &plan.sizes {
        let mut c = config.clone();
        c.size = size;
        let spec = c.grid();
        let h = Arc::new(Hierarchy::grid(&spec)?);
        let full = h.vertex_count();

        bar.set_message(format!("plain {size}x{size}"));
        let grid = GridCloth {
            cols: size,
            rows: size,
            origin: spec.origin,
            u: spec.u,
            v: spec.v,
            vertex_mass: spec.vertex_mass,
            shear: true,
            bend: false,
            material: config.body.material,
        };
        let mut body = pinned(grid.build(config.body.solver)?, &grid)?;
        let ms = median_step_ms(&mut || body.step(), plan.warmup, plan.steps);
        points.push(Point {
            body: "plain",
            size,
            compression: 1.0,
            nodes: body.particle_count() as f64,
            links: body.link_count() as f64,
            ms_per_step: ms,
        });
        bar.inc(1);

        for &compression in &plan.compressions {
            bar.set_message(format!(
                "TreeCut {size}x{size}, static cut at {:.0}%",
                compression * 100.0
            ));
            let cut = if compression >= 1.0 {
                Cut::finest(&h)
            } else {
                let nodes = ((compression as f64 * full as f64).round() as usize).max(1);
                even_cut(&h, nodes)?
            };
            let mut body = TreeCutSoftBody::new(h.clone(), cut, config.body)?;
            for (i, j) in corners(size) {
                body.pin_vertex(spec.vertex(i, j), spec.position(i, j))?;
            }
            let ms = median_step_ms(&mut || body.step(), plan.warmup, plan.steps);
            points.push(Point {
                body: "treecut",
                size,
                compression,
                nodes: body.particle_count() as f64,
                links: body.link_count() as f64,
                ms_per_step: ms,
            });
            bar.inc(1);
        }

        for &compression in &plan.feedback_compressions {
            bar.set_message(format!(
                "TreeCut {size}x{size}, feedback at {:.0}%",
                compression * 100.0
            ));
            points.push(feedback_point(&c, &h, compression, plan)?);
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    let fits = ["plain", "treecut", "feedback"]
        .into_iter()
        .filter_map(|b| {
            let xy: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| p.body == b)
                .map(|p| (p.nodes / 1000.0, p.ms_per_step))
                .collect();
            fit(&xy).map(|(slope, intercept, r2)| Fit {
                body: b,
                ms_per_1000_nodes: slope,
                intercept_ms: intercept,
                r_squared: r2,
            })
        })
        .collect();
    Ok(Figure5 {
        sizes: plan.sizes.clone(),
        compressions: plan.compressions.clone(),
        feedback_compressions: plan.feedback_compressions.clone(),
        warmup_steps: plan.warmup,
        measured_steps: plan.steps,
        feedback_warmup_steps: plan.feedback_warmup,
        feedback_steps: plan.feedback_steps,
        points,
        fits,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// A cut of at most `nodes` nodes spread evenly over the net
/// ([`treecut::uniform_cut`]).
fn even_cut(h: &Hierarchy, nodes: usize) -> Result<Cut, DemoError> {
    Ok(treecut::uniform_cut(h, nodes).map_err(softbody::TreeCutError::from)?)
}

fn pinned(mut body: SoftBody, grid: &GridCloth) -> Result<SoftBody, DemoError> {
    for p in grid.corners() {
        body.set_pinned(p, true)?;
    }
    Ok(body)
}

/// Times our Bullet-like cloth (triangle edges + bend links, 20 iterations, dt 1/60, corners
/// pinned, sagged 30 steps first): the configuration of the documented Bullet measurement.
pub(crate) fn bullet_like(size: u32, steps: u32) -> Result<BulletLike, DemoError> {
    let settings = super::solver::bullet_settings();
    let mut body = super::solver::bullet_body(size, settings)?;
    let ms = median_step_ms(&mut || body.step(), 5, steps);
    Ok(BulletLike {
        size,
        nodes: body.particle_count(),
        links: body.link_count(),
        iterations: settings.iterations,
        ms_per_step: ms,
    })
}

/// Least squares through `(x, y)`: (slope, intercept, R²); None with fewer than two distinct x.
pub(super) fn fit(xy: &[(f64, f64)]) -> Option<(f64, f64, f64)> {
    let n = xy.len() as f64;
    if xy.len() < 2 {
        return None;
    }
    let mx = xy.iter().map(|p| p.0).sum::<f64>() / n;
    let my = xy.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = xy.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = xy.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let syy: f64 = xy.iter().map(|p| (p.1 - my).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let r2 = if syy > 0.0 {
        sxy * sxy / (sxx * syy)
    } else {
        1.0
    };
    Some((slope, my - slope * mx, r2))
}

impl Figure5 {
    /// The points as a size × configuration table of step times.
    pub(crate) fn render(&self) -> String {
        let mut header: Vec<String> = vec!["net".into(), "nodes".into(), "plain".into()];
        header.extend(
            self.compressions
                .iter()
                .map(|c| format!("static {:.0}%", c * 100.0)),
        );
        header.extend(
            self.feedback_compressions
                .iter()
                .map(|c| format!("feedback {:.0}%", c * 100.0)),
        );
        let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
        let mut t = Table::new(
            "Figure 5: time per step (ms) against node count: plain soft body, TreeCut on static \
             cuts, TreeCut with feedback",
            &header_refs,
        );
        for &size in &self.sizes {
            let cell = |body: &str, c: f32| {
                self.point(body, size, c)
                    .map_or("-".into(), |p| num(p.ms_per_step, 3))
            };
            let mut row = vec![
                format!("{size}x{size}"),
                (size * size).to_string(),
                cell("plain", 1.0),
            ];
            row.extend(self.compressions.iter().map(|&c| cell("treecut", c)));
            row.extend(
                self.feedback_compressions
                    .iter()
                    .map(|&c| cell("feedback", c)),
            );
            t.row(row);
        }
        for f in &self.fits {
            t.note(format!(
                "{:<8} linear fit: {} ms per 1000 nodes {} {} ms (R² {})",
                f.body,
                num(f.ms_per_1000_nodes, 3),
                if f.intercept_ms < 0.0 { "-" } else { "+" },
                num(f.intercept_ms.abs(), 3),
                num(f.r_squared, 3)
            ));
        }
        t.note(format!(
            "static: median of {} steps; feedback: mean of {} steps after {} (evaluation and \
             blending included).",
            self.measured_steps, self.feedback_steps, self.feedback_warmup_steps
        ));
        t.note(
            "The paper's Figure 5: step time linear in the node count, with and without TreeCut.",
        );
        t.render()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use treecut::NodeId;

    #[test]
    fn fit_recovers_a_line() {
        let xy: Vec<(f64, f64)> = (0..5).map(|i| (i as f64, 2.0 + 0.5 * i as f64)).collect();
        let (s, b, r2) = fit(&xy).unwrap();
        assert!((s - 0.5).abs() < 1e-12 && (b - 2.0).abs() < 1e-12 && (r2 - 1.0).abs() < 1e-12);
        assert!(fit(&[(1.0, 1.0)]).is_none());
        assert!(fit(&[(1.0, 1.0), (1.0, 2.0)]).is_none());
    }

    #[test]
    fn even_cuts_hit_the_count_and_are_valid() {
        let mut c = NetConfig::paper().unwrap();
        c.size = 33;
        let h = Hierarchy::grid(&c.grid()).unwrap();
        // The cut stops within one refine of the count.
        let most_children = (0..h.len())
            .map(|i| h.child_count(NodeId::new(i)))
            .max()
            .unwrap();
        for fraction in [0.1, 0.3, 0.5, 0.75, 0.99] {
            let want = (fraction * h.vertex_count() as f64) as usize;
            let cut = even_cut(&h, want).unwrap();
            cut.check_invariant(&h).unwrap();
            assert!(
                cut.len() <= want && cut.len() + most_children > want,
                "{} for {want}",
                cut.len()
            );
        }
    }
}
