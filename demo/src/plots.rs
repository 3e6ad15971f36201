//! Plots (plotters, bitmap backend): the net's TreeCut operation time against node count (the
//! paper's Figure 4, with linear fits), its step time against node count (the paper's
//! Figure 5, with our feedback runs and the paper's Table 2 points), for the crowd the frame
//! cost and the pose error against camera distance, and for the perception section on-screen
//! error against cost per scene.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::crowd::CrowdSection;
use crate::error::DemoError;
use crate::font;
use crate::net::NetSection;
use crate::paper::{TABLE2_BULLET, TABLE2_TCSB, THESIS};
use crate::perception::PerceptionSection;
use slod_experiments::world::WorldReport;

const SIZE: (u32, u32) = (1100, 720);

/// Colours of successive series (colour-blind-safe Okabe–Ito palette, then grey).
const COLOURS: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(240, 228, 66),
    RGBColor(120, 120, 120),
];

fn colour(i: usize) -> RGBColor {
    COLOURS[i % COLOURS.len()]
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Draws one picture with `draw` and writes it to `path`.
fn plot(
    path: &Path,
    draw: impl FnOnce(&Area<'_>) -> Result<(), String>,
) -> Result<PathBuf, DemoError> {
    plot_sized(path, SIZE, draw)
}

/// [`plot`] at another size.
fn plot_sized(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area<'_>) -> Result<(), String>,
) -> Result<PathBuf, DemoError> {
    font::register().map_err(|e| DemoError::draw(path, e))?;
    let area = BitMapBackend::new(path, size).into_drawing_area();
    area.fill(&WHITE).map_err(|e| DemoError::draw(path, e))?;
    draw(&area).map_err(|e| DemoError::draw(path, e))?;
    area.present().map_err(|e| DemoError::draw(path, e))?;
    Ok(path.to_path_buf())
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

type NodesChart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A chart with simulated nodes along x from 0 to `max.0` and `y_desc` from 0 to `max.1`.
fn nodes_chart<'a, 'b>(
    area: &'a Area<'b>,
    caption: &str,
    max: (f64, f64),
    y_desc: &str,
) -> Result<NodesChart<'a, 'b>, String> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (font::FAMILY, 24))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..max.0, 0.0..max.1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("simulated nodes")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_desc(y_desc)
        .label_style((font::FAMILY, 16))
        .axis_desc_style((font::FAMILY, 18))
        .draw()
        .map_err(err)?;
    Ok(chart)
}

/// The series labels in a box at the upper right.
fn upper_right_legend<'a, 'b: 'a>(chart: &mut NodesChart<'a, 'b>) -> Result<(), String> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((font::FAMILY, 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(err)
}

/// The paper's Figure 4, measured: `net_operation_time.png` (median time of each TreeCut
/// operation against the node count, with each operation's least-squares line).
pub(crate) fn net_operation_time(net: &NetSection, dir: &Path) -> Result<PathBuf, DemoError> {
    let path = dir.join("net_operation_time.png");
    let f = &net.figure4;
    let max_x = f.points.iter().map(|p| p.nodes).fold(1.0, f64::max);
    let max_y = f.points.iter().map(|p| p.median_us).fold(1e-3, f64::max);
    plot(&path, |area| {
        let mut chart = nodes_chart(
            area,
            "Time of one TreeCut operation against node count (the simulation paper's Figure 4)",
            (max_x * 1.05, max_y * 1.3),
            "µs per operation (median)",
        )?;
        for (k, fit) in f.fits.iter().enumerate() {
            let col = colour(k);
            let pts: Vec<(f64, f64)> = f
                .points
                .iter()
                .filter(|p| p.operation == fit.operation)
                .map(|p| (p.nodes, p.median_us))
                .collect();
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 5, col.filled())))
                .map_err(err)?
                .label(format!(
                    "{}: {:.2} µs + {:.3} µs per 100k nodes",
                    fit.operation, fit.intercept_us, fit.us_per_100k_nodes
                ))
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, col.filled()));
            let line =
                [0.0, max_x].map(|x| (x, fit.intercept_us + fit.us_per_100k_nodes * x / 1e5));
            chart
                .draw_series(DashedLineSeries::new(line, 8, 6, col.stroke_width(1)))
                .map_err(err)?;
        }
        upper_right_legend(&mut chart)
    })
}

/// The paper's Figure 5, measured: `net_step_time.png`.
pub(crate) fn net_step_time(net: &NetSection, dir: &Path) -> Result<PathBuf, DemoError> {
    let path = dir.join("net_step_time.png");
    let f = &net.figure5;
    let paper: Vec<(f64, f64)> = std::iter::once(&TABLE2_BULLET)
        .chain(&TABLE2_TCSB)
        .map(|p| (p.nodes as f64, p.ms_per_step))
        .collect();
    let max_x = f
        .points
        .iter()
        .map(|p| p.nodes)
        .chain(paper.iter().map(|p| p.0))
        .fold(1.0, f64::max);
    let max_y = f
        .points
        .iter()
        .map(|p| p.ms_per_step)
        .chain(paper.iter().map(|p| p.1))
        .fold(1e-3, f64::max);
    let series = |body: &str, c: f32| -> Vec<(f64, f64)> {
        f.points
            .iter()
            .filter(|p| p.body == body && (p.compression - c).abs() < 1e-4)
            .map(|p| (p.nodes, p.ms_per_step))
            .collect()
    };
    plot(&path, |area| {
        let mut chart = nodes_chart(
            area,
            "Time per step against node count (the simulation paper's Figure 5)",
            (max_x * 1.05, max_y * 1.1),
            "ms per step",
        )?;
        let plain = series("plain", 1.0);
        chart
            .draw_series(LineSeries::new(plain.clone(), BLACK.stroke_width(2)))
            .map_err(err)?
            .label("plain soft body (no LOD)")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        chart
            .draw_series(
                plain
                    .iter()
                    .map(|&p| Cross::new(p, 6, BLACK.stroke_width(2))),
            )
            .map_err(err)?;
        for (k, &c) in f.compressions.iter().enumerate() {
            let col = colour(k);
            chart
                .draw_series(
                    series("treecut", c)
                        .into_iter()
                        .map(|p| Circle::new(p, 5, col.filled())),
                )
                .map_err(err)?
                .label(format!("TreeCut, static cut at {:.0}%", c * 100.0))
                .legend(move |(x, y)| Circle::new((x + 10, y), 5, col.filled()));
        }
        for (k, &c) in f.feedback_compressions.iter().enumerate() {
            let col = colour(f.compressions.len() + k);
            let pts = series("feedback", c);
            chart
                .draw_series(LineSeries::new(pts.clone(), col.stroke_width(1)))
                .map_err(err)?;
            chart
                .draw_series(
                    pts.into_iter()
                        .map(|p| TriangleMarker::new(p, 8, col.filled())),
                )
                .map_err(err)?
                .label(format!(
                    "TreeCut with feedback at {:.0}% (evaluation included)",
                    c * 100.0
                ))
                .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 7, col.filled()));
        }
        if let Some(fit) = f.fits.iter().find(|x| x.body == "treecut") {
            let line =
                [0.0, max_x].map(|x| (x, fit.intercept_ms + fit.ms_per_1000_nodes * x / 1e3));
            let grey = RGBColor(150, 150, 150);
            chart
                .draw_series(DashedLineSeries::new(line, 8, 6, grey.stroke_width(1)))
                .map_err(err)?
                .label(format!(
                    "static cuts, linear fit: {:.3} ms per 1000 nodes",
                    fit.ms_per_1000_nodes
                ))
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], grey));
        }
        let purple = RGBColor(110, 40, 150);
        chart
            .draw_series(paper.iter().map(|&p| {
                Rectangle::new(
                    [
                        (p.0 - max_x * 0.006, p.1 - max_y * 0.01),
                        (p.0 + max_x * 0.006, p.1 + max_y * 0.01),
                    ],
                    purple.filled(),
                )
            }))
            .map_err(err)?
            .label("the paper's Table 2: Bullet and TC-SB (i5 670, 2011)")
            .legend(move |(x, y)| {
                Rectangle::new([(x + 5, y - 5), (x + 15, y + 5)], purple.filled())
            });
        upper_right_legend(&mut chart)
    })
}

/// Frame cost against distance: `crowd_frame_cost.png` (milliseconds on the left, cost
/// relative to full detail on the right, with the thesis' two published points).
pub(crate) fn crowd_frame_cost(crowd: &CrowdSection, dir: &Path) -> Result<PathBuf, DemoError> {
    let path = dir.join("crowd_frame_cost.png");
    let max_d = crowd
        .config
        .distances
        .iter()
        .copied()
        .fold(1.0f32, f32::max) as f64;
    let max_ms = crowd
        .sweeps
        .iter()
        .flat_map(|s| s.rows.iter().map(|r| r.full_ms.max(r.lod_ms)))
        .fold(1e-3, f64::max);
    plot(&path, |area| {
        let title = format!(
            "Crowd frame cost: {} characters x {} bones, camera moving away",
            crowd.config.characters, crowd.config.bones
        );
        let area = area.titled(&title, (font::FAMILY, 26)).map_err(err)?;
        let (left, right) = area.split_horizontally(SIZE.0 / 2);
        let mut ms = ChartBuilder::on(&left)
            .margin(14)
            .x_label_area_size(46)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..max_d * 1.03, 0.0..max_ms * 1.15)
            .map_err(err)?;
        ms.configure_mesh()
            .x_desc("camera distance (units; characters 180 tall)")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_desc("ms per frame (median)")
            .label_style((font::FAMILY, 15))
            .axis_desc_style((font::FAMILY, 16))
            .draw()
            .map_err(err)?;
        if let Some(first) = crowd.sweeps.first() {
            ms.draw_series(LineSeries::new(
                first.rows.iter().map(|r| (r.distance as f64, r.full_ms)),
                BLACK.stroke_width(2),
            ))
            .map_err(err)?
            .label("full detail")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        }
        for (k, s) in crowd.sweeps.iter().enumerate() {
            let col = colour(k);
            ms.draw_series(
                LineSeries::new(
                    s.rows.iter().map(|r| (r.distance as f64, r.lod_ms)),
                    col.stroke_width(2),
                )
                .point_size(3),
            )
            .map_err(err)?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], col.stroke_width(2)));
        }
        ms.configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((font::FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;

        let mut ratio = ChartBuilder::on(&right)
            .margin(14)
            .x_label_area_size(46)
            .y_label_area_size(56)
            .build_cartesian_2d(0.0..max_d * 1.03, 0.0..1.25f64)
            .map_err(err)?;
        ratio
            .configure_mesh()
            .x_desc("camera distance (units)")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_desc("frame cost with LOD / without")
            .label_style((font::FAMILY, 15))
            .axis_desc_style((font::FAMILY, 16))
            .draw()
            .map_err(err)?;
        for (k, s) in crowd.sweeps.iter().enumerate() {
            let col = colour(k);
            ratio
                .draw_series(
                    LineSeries::new(
                        s.rows.iter().map(|r| (r.distance as f64, r.cost_ratio)),
                        col.stroke_width(2),
                    )
                    .point_size(3),
                )
                .map_err(err)?;
        }
        let thesis = [
            (THESIS.range[0] as f64, 1.0),
            (max_d, THESIS.far_cost_ratio()),
        ];
        let purple = RGBColor(110, 40, 150);
        ratio
            .draw_series(thesis.iter().map(|&p| {
                Rectangle::new(
                    [
                        (p.0 - max_d * 0.012, p.1 - 0.02),
                        (p.0 + max_d * 0.012, p.1 + 0.02),
                    ],
                    purple.filled(),
                )
            }))
            .map_err(err)?
            .label("thesis: 12 fps near, 43.6 fps far (rendering incl.)")
            .legend(move |(x, y)| {
                Rectangle::new([(x + 5, y - 5), (x + 15, y + 5)], purple.filled())
            });
        ratio
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((font::FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(err)
    })
}

/// Pose error against distance: `crowd_pose_error.png` (mean and largest joint error on
/// screen, log scale).
pub(crate) fn crowd_pose_error(crowd: &CrowdSection, dir: &Path) -> Result<PathBuf, DemoError> {
    let path = dir.join("crowd_pose_error.png");
    const FLOOR: f64 = 1e-3;
    let max_d = crowd
        .config
        .distances
        .iter()
        .copied()
        .fold(1.0f32, f32::max) as f64;
    let max_px = crowd
        .sweeps
        .iter()
        .flat_map(|s| s.rows.iter().map(|r| r.max_error_px as f64))
        .fold(1.0, f64::max);
    plot(&path, |area| {
        let mut chart = ChartBuilder::on(area)
            .caption(
                format!(
                    "Crowd pose error on screen ({:.0}-pixel-high view): mean (solid), largest (dashed)",
                    crowd.config.viewport_height_px
                ),
                (font::FAMILY, 24),
            )
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..max_d * 1.03, (FLOOR..max_px * 2.0).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("camera distance (units; characters 180 tall)")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .y_desc("joint error (pixels, log scale)")
            .label_style((font::FAMILY, 16))
            .axis_desc_style((font::FAMILY, 18))
            .draw()
            .map_err(err)?;
        for (k, s) in crowd.sweeps.iter().enumerate() {
            let col = colour(k);
            chart
                .draw_series(
                    LineSeries::new(
                        s.rows
                            .iter()
                            .map(|r| (r.distance as f64, (r.mean_error_px as f64).max(FLOOR))),
                        col.stroke_width(2),
                    )
                    .point_size(3),
                )
                .map_err(err)?
                .label(s.name.clone())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], col.stroke_width(2)));
            chart
                .draw_series(DashedLineSeries::new(
                    s.rows
                        .iter()
                        .map(|r| (r.distance as f64, (r.max_error_px as f64).max(FLOOR))),
                    7,
                    5,
                    col.stroke_width(2),
                ))
                .map_err(err)?;
        }
        let one_px = [(0.0, 1.0), (max_d * 1.03, 1.0)];
        chart
            .draw_series(DashedLineSeries::new(one_px, 3, 4, BLACK.stroke_width(1)))
            .map_err(err)?
            .label("1 pixel")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .label_font((font::FAMILY, 15))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(err)
    })
}

/// On-screen p99 error against cost per frame, one panel per scene:
/// `perception_error_cost.png`. The uniform cuts' curve (line), every strategy at the budget
/// (markers; short horizons on chaotic scenes), the 1 px line.
pub(crate) fn perception_error_cost(
    section: &PerceptionSection,
    dir: &Path,
) -> Result<PathBuf, DemoError> {
    const FLOOR: f64 = 0.01;
    let path = dir.join("perception_error_cost.png");
    let cols = 4usize;
    let rows = section.scenes.len().div_ceil(cols).max(1);
    let size = (1780, 60 + 420 * rows as u32);
    let strategies: Vec<&str> = section
        .scenes
        .iter()
        .flat_map(|s| s.runs.iter().map(|r| r.strategy))
        .filter(|&s| s != "reference" && s != "uniform")
        .fold(Vec::new(), |mut v, s| {
            if !v.contains(&s) {
                v.push(s);
            }
            v
        });
    plot_sized(&path, size, |area| {
        let area = area
            .titled(
                &format!(
                    "On-screen error against cost per frame ({} px high view, {} deg): uniform cuts \
                     (black line), the reference (triangle, 0 px) and each strategy at {:.0}% of \
                     the nodes",
                    section.viewport_height_px,
                    section.fov_y_deg,
                    section.compression * 100.0
                ),
                (font::FAMILY, 22),
            )
            .map_err(err)?;
        // One legend for every panel, in a column of its own, so it hides no point.
        let (grid, key) = area.split_horizontally(1600);
        let style = TextStyle::from((font::FAMILY, 16).into_font()).color(&BLACK);
        let mut y = 60;
        key.draw(&PathElement::new([(10, y), (30, y)], BLACK.stroke_width(2)))
            .map_err(err)?;
        key.draw_text("uniform cuts", &style, (38, y - 9))
            .map_err(err)?;
        y += 26;
        key.draw(&TriangleMarker::new((20, y), 7, BLACK.filled()))
            .map_err(err)?;
        key.draw_text("reference (0 px)", &style, (38, y - 9))
            .map_err(err)?;
        for (k, name) in strategies.iter().enumerate() {
            y += 26;
            key.draw(&Circle::new((20, y), 6, colour(k).filled()))
                .map_err(err)?;
            key.draw_text(name, &style, (38, y - 9)).map_err(err)?;
        }
        y += 26;
        key.draw(&PathElement::new([(10, y), (30, y)], BLACK.stroke_width(1)))
            .map_err(err)?;
        key.draw_text("1 pixel", &style, (38, y - 9)).map_err(err)?;
        let panels = grid.split_evenly((rows, cols));
        for (scene, panel) in section.scenes.iter().zip(panels.iter()) {
            let horizon = scene.chaotic.then_some(section.horizon_steps);
            let runs: Vec<_> = scene
                .runs
                .iter()
                .filter(|r| r.horizon_steps == horizon && r.strategy != "reference")
                .collect();
            let xs = scene
                .uniform_curve
                .iter()
                .map(|p| p.ms_per_step)
                .chain(runs.iter().map(|r| r.ms_per_step));
            let max_ms = xs.fold(1e-3, f64::max);
            let ys = scene
                .uniform_curve
                .iter()
                .map(|p| p.screen_p99_px)
                .chain(runs.iter().map(|r| r.screen_p99_px));
            let max_px = ys.fold(2.0, f64::max);
            let mut chart = ChartBuilder::on(panel)
                .caption(
                    format!(
                        "{}{}",
                        scene.name,
                        if scene.chaotic {
                            format!(" ({}-step horizons)", section.horizon_steps)
                        } else {
                            String::new()
                        }
                    ),
                    (font::FAMILY, 18),
                )
                .margin(8)
                .x_label_area_size(36)
                .y_label_area_size(52)
                .build_cartesian_2d(0.0..max_ms * 1.08, (FLOOR..max_px * 2.0).log_scale())
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("ms per frame")
                .y_desc("p99 error (px)")
                .label_style((font::FAMILY, 13))
                .axis_desc_style((font::FAMILY, 14))
                .draw()
                .map_err(err)?;
            // The reduced uniform cuts as a line; the reference (0 px) as its own marker at the
            // bottom of the log scale.
            let curve: Vec<(f64, f64)> = scene
                .uniform_curve
                .iter()
                .filter(|p| p.screen_p99_px > 0.0)
                .map(|p| (p.ms_per_step, p.screen_p99_px))
                .collect();
            chart
                .draw_series(LineSeries::new(curve.clone(), BLACK.stroke_width(2)))
                .map_err(err)?;
            chart
                .draw_series(
                    curve
                        .iter()
                        .map(|&p| Cross::new(p, 5, BLACK.stroke_width(2))),
                )
                .map_err(err)?;
            let full: Vec<(f64, f64)> = scene
                .uniform_curve
                .iter()
                .filter(|p| p.screen_p99_px <= 0.0)
                .map(|p| (p.ms_per_step, FLOOR * 1.3))
                .collect();
            chart
                .draw_series(
                    full.iter()
                        .map(|&p| TriangleMarker::new(p, 8, BLACK.filled())),
                )
                .map_err(err)?;
            chart
                .draw_series(DashedLineSeries::new(
                    [(0.0, 1.0), (max_ms * 1.08, 1.0)],
                    3,
                    4,
                    BLACK.stroke_width(1),
                ))
                .map_err(err)?;
            for r in runs.iter().filter(|r| r.strategy != "uniform") {
                let k = strategies
                    .iter()
                    .position(|&s| s == r.strategy)
                    .unwrap_or(0);
                let col = colour(k);
                let p = (r.ms_per_step, r.screen_p99_px.max(FLOOR));
                chart
                    .draw_series(std::iter::once(Circle::new(p, 6, col.filled())))
                    .map_err(err)?;
            }
        }
        Ok(())
    })
}

/// A chart with frames along x from 0 to `frames` and `y_desc` from `y.0` to `y.1`.
fn frames_chart<'a, 'b>(
    area: &'a Area<'b>,
    caption: &str,
    frames: usize,
    y: (f64, f64),
    y_desc: &str,
) -> Result<NodesChart<'a, 'b>, String> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (font::FAMILY, 22))
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..frames.max(1) as f64, y.0..y.1)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("frame (60 per second)")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .y_desc(y_desc)
        .label_style((font::FAMILY, 15))
        .axis_desc_style((font::FAMILY, 17))
        .draw()
        .map_err(err)?;
    Ok(chart)
}

/// The world budget over the run: `world_frame_time.png` (above: each frame's wall time
/// against the target and its ±10% band, with the settle frame; below: the shared on-screen
/// error bound the controller set).
pub(crate) fn world_frame_time(report: &WorldReport, dir: &Path) -> Result<PathBuf, DemoError> {
    let path = dir.join("world_frame_time.png");
    let b = &report.budgeted;
    let n = b.frames.len();
    let target = b.target;
    let max_ms = b
        .frames
        .iter()
        .map(|f| f.wall_ms)
        .fold(target * 1.3, f64::max)
        .min(target * 4.0);
    let max_bound = b
        .frames
        .iter()
        .map(|f| f.bound_px as f64)
        .fold(1e-3, f64::max);
    plot(&path, |area| {
        let (top, bottom) = area.split_vertically(SIZE.1 * 3 / 5);
        let mut ms = frames_chart(
            &top,
            &format!(
                "World frame time against a {target:.1} ms budget ({} objects, {} threads)",
                report.objects.len(),
                b.threads
            ),
            n,
            (0.0, max_ms),
            "ms per frame",
        )?;
        let band = RGBColor(0, 158, 115).mix(0.18);
        ms.draw_series(std::iter::once(Rectangle::new(
            [(0.0, 0.9 * target), (n as f64, 1.1 * target)],
            band.filled(),
        )))
        .map_err(err)?
        .label("target ±10%")
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], band.filled()));
        ms.draw_series(LineSeries::new(
            [(0.0, target), (n as f64, target)],
            BLACK.stroke_width(2),
        ))
        .map_err(err)?
        .label("target")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        let col = colour(0);
        ms.draw_series(LineSeries::new(
            b.frames
                .iter()
                .enumerate()
                .map(|(i, f)| (i as f64, f.wall_ms.min(max_ms))),
            col.stroke_width(1),
        ))
        .map_err(err)?
        .label("frame time (clipped at the top)")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], col.stroke_width(2)));
        if let Some(s) = b.settle.settled_after {
            let red = colour(1);
            ms.draw_series(LineSeries::new(
                [(s as f64, 0.0), (s as f64, max_ms)],
                red.stroke_width(2),
            ))
            .map_err(err)?
            .label(format!("settled after frame {s}"))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], red.stroke_width(2)));
        }
        upper_right_legend(&mut ms)?;
        let mut px = frames_chart(
            &bottom,
            "The shared on-screen error bound",
            n,
            (0.0, max_bound * 1.1),
            "bound, px",
        )?;
        px.draw_series(LineSeries::new(
            b.frames
                .iter()
                .enumerate()
                .map(|(i, f)| (i as f64, f.bound_px as f64)),
            colour(2).stroke_width(2),
        ))
        .map_err(err)?;
        Ok(())
    })
}

/// How the budget was spent: `world_budget_per_object.png` (cost units of each object per
/// frame, stacked, nearest cloth at the bottom and the crowd on top; colour by kind), beside
/// each object's detail fraction over the frames.
pub(crate) fn world_budget_per_object(
    report: &WorldReport,
    dir: &Path,
) -> Result<PathBuf, DemoError> {
    let path = dir.join("world_budget_per_object.png");
    let b = &report.budgeted;
    let n = b.frames.len();
    // Nearest first along the street, the crowd last.
    let mut order: Vec<usize> = (0..report.objects.len()).collect();
    order.sort_by(|&i, &j| {
        let key = |k: usize| {
            let o = &report.objects[k];
            (o.kind == "crowd", o.along_m)
        };
        key(i)
            .partial_cmp(&key(j))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let kind_colour = |kind: &str| match kind {
        "flag" => colour(0),
        "curtain" => colour(1),
        "cape" => colour(2),
        _ => colour(7),
    };
    let max_units = b
        .frames
        .iter()
        .map(|f| f.objects.iter().map(|o| o.units).sum::<f64>())
        .fold(1.0, f64::max);
    plot_sized(&path, (1400, 720), |area| {
        let area = area
            .titled(
                "How the world budget was spent per object (millisecond run)",
                (font::FAMILY, 24),
            )
            .map_err(err)?;
        let (left, right) = area.split_horizontally(760);
        let mut units = frames_chart(
            &left,
            "Cost units per frame, stacked (nearest at the bottom)",
            n,
            (0.0, max_units * 1.05),
            "cost units",
        )?;
        let mut below = vec![0.0f64; n];
        let mut labelled = Vec::new();
        for (rank, &k) in order.iter().enumerate() {
            let o = &report.objects[k];
            let shade = if rank % 2 == 0 { 1.0 } else { 0.55 };
            let c = kind_colour(o.kind).mix(shade);
            let above: Vec<f64> = below
                .iter()
                .zip(&b.frames)
                .map(|(y, f)| y + f.objects[k].units)
                .collect();
            let polygon: Vec<(f64, f64)> = above
                .iter()
                .enumerate()
                .map(|(i, &y)| (i as f64, y))
                .chain(below.iter().enumerate().rev().map(|(i, &y)| (i as f64, y)))
                .collect();
            let drawn = units
                .draw_series(std::iter::once(Polygon::new(polygon, c.filled())))
                .map_err(err)?;
            if !labelled.contains(&o.kind) {
                labelled.push(o.kind);
                let solid = kind_colour(o.kind);
                drawn.label(format!("{}s", o.kind)).legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 20, y + 5)], solid.filled())
                });
            }
            below = above;
        }
        upper_right_legend(&mut units)?;
        let mut detail = frames_chart(
            &right,
            "Detail of each object (nodes or bones over full)",
            n,
            (0.0, 1.02),
            "fraction of full detail",
        )?;
        for &k in &order {
            let o = &report.objects[k];
            let c = kind_colour(o.kind);
            let width = if o.kind == "crowd" { 3 } else { 1 };
            detail
                .draw_series(LineSeries::new(
                    b.frames
                        .iter()
                        .enumerate()
                        .map(|(i, f)| (i as f64, f.objects[k].detail_fraction)),
                    c.stroke_width(width),
                ))
                .map_err(err)?;
        }
        Ok(())
    })
}
