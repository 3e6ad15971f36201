//! Pictures of the swinging net like the paper's Figure 6: the full-resolution cloth and the
//! TreeCut cloth after 45, 90 and 180 steps (shaded, seen from above the experiment camera's
//! side), and the
//! TreeCut cloth's links with the links being blended by a refine or coarse highlighted.
//! One composite (`net_figure6.png`) and every panel on its own.
//!
//! Drawn by our own rasteriser ([`raster`]); captions with plotters' text on the finished
//! bitmap; written with `png`. Every panel uses the same projection, fitted once to all the
//! cloths drawn, so positions compare across panels.

mod movie;
mod raster;
mod text;

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use slod_experiments::net::{NetConfig, NetReport, NetRun, NetRunKind, NetSnapshot};
use softbody::DrawLink;

use crate::error::DemoError;
pub(crate) use movie::perception_movie;
pub(crate) use raster::Image;
use raster::{Raster, ScreenPoint};
use text::Caption;

/// Panel size in final pixels.
const PANEL: (u32, u32) = (640, 480);
/// Supersampling factor per direction.
const SS: u32 = 3;
/// How far above the cloth the pictures look from (degrees above the horizontal).
const ELEVATION_DEG: f32 = 35.0;
/// Height of the composite's title bar.
const TITLE_H: u32 = 56;

const CLOTH: Vec3 = Vec3::new(0.36, 0.56, 0.86);
const BACKGROUND: Vec3 = Vec3::new(0.97, 0.97, 0.96);
const WIRE: Vec3 = Vec3::new(0.08, 0.12, 0.25);
const PARTICLE: Vec3 = Vec3::new(0.75, 0.12, 0.08);
const LINK: Vec3 = Vec3::new(0.42, 0.47, 0.58);
/// A link fading in or out (refine or coarse being blended).
pub(crate) const FADING: Vec3 = Vec3::new(1.0, 0.50, 0.0);
/// A group link to a virtual parent (the parent's side of a blend).
pub(crate) const GROUP: Vec3 = Vec3::new(0.80, 0.05, 0.70);

/// How a picture frames the scene: the perspective of the experiment's view from above, scaled to
/// fit a panel.
#[derive(Clone, Copy, Debug)]
struct Framing {
    eye: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    scale: f32,
    centre: Vec2,
    panel: Vec2,
}

impl Framing {
    /// A view of every point of `clouds` from the experiment camera's side and distance but
    /// raised to [`ELEVATION_DEG`] above the cloth (the experiment's camera looks at the net
    /// almost edge-on, which hides where the nodes are), fitted into a panel with margins and
    /// room for the caption at the top.
    fn fit(camera: &salience::View, clouds: &[&[Vec3]]) -> Framing {
        let count = clouds.iter().map(|c| c.len()).sum::<usize>().max(1);
        let centre = clouds.iter().flat_map(|c| c.iter()).sum::<Vec3>() / count as f32;
        let d = camera.position() - centre;
        let side = Vec3::new(d.x, 0.0, d.z).normalize_or(Vec3::Z);
        let e = ELEVATION_DEG.to_radians();
        let towards_eye = side * e.cos() + Vec3::Y * e.sin();
        let forward = -towards_eye;
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        let mut view = Framing {
            eye: centre + towards_eye * d.length().max(1e-3),
            right,
            up: right.cross(forward),
            forward,
            scale: 1.0,
            centre: Vec2::ZERO,
            panel: Vec2::new((PANEL.0 * SS) as f32, (PANEL.1 * SS) as f32),
        };
        let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        for p in clouds.iter().flat_map(|c| c.iter()) {
            if let Some(q) = view.image_plane(*p) {
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
        if lo.x > hi.x {
            (lo, hi) = (Vec2::splat(-1.0), Vec2::splat(1.0));
        }
        let margin = 0.05 * view.panel.y;
        let caption = 0.13 * view.panel.y;
        let room = view.panel - Vec2::new(2.0 * margin, 2.0 * margin + caption);
        let extent = (hi - lo).max(Vec2::splat(1e-6));
        view.scale = (room.x / extent.x).min(room.y / extent.y);
        view.centre = 0.5 * (lo + hi);
        // Shift the picture down by half the caption's height.
        view.centre.y += 0.5 * caption / view.scale;
        view
    }

    /// Position on the image plane at unit depth (x right, y up), None behind the eye.
    fn image_plane(&self, p: Vec3) -> Option<Vec2> {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        (z > 1e-4).then(|| Vec2::new(d.dot(self.right) / z, d.dot(self.up) / z))
    }

    /// The supersampled screen point of `p` (off-screen and 1/z = 0 when behind the eye).
    fn project(&self, p: Vec3) -> ScreenPoint {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        match self.image_plane(p) {
            Some(q) => ScreenPoint {
                xy: Vec2::new(
                    0.5 * self.panel.x + (q.x - self.centre.x) * self.scale,
                    0.5 * self.panel.y - (q.y - self.centre.y) * self.scale,
                ),
                inv_z: 1.0 / z,
            },
            None => ScreenPoint {
                xy: Vec2::splat(-1e6),
                inv_z: 0.0,
            },
        }
    }
}

/// Vertex normals of a `size`×`size` grid surface (area-weighted face normals).
pub(super) fn vertex_normals(v: &[Vec3], size: usize) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; v.len()];
    for [x, y, z] in grid_triangles(size) {
        let f = (v[y] - v[x]).cross(v[z] - v[x]);
        n[x] += f;
        n[y] += f;
        n[z] += f;
    }
    n.iter().map(|x| x.normalize_or(Vec3::Y)).collect()
}

/// The triangles of a `size`×`size` grid surface (vertex `j * size + i`), two per cell,
/// consistently wound: the one triangulation every picture draws.
pub(super) fn grid_triangles(size: usize) -> impl Iterator<Item = [usize; 3]> {
    (0..size.saturating_sub(1)).flat_map(move |j| {
        (0..size - 1).flat_map(move |i| {
            let [a, b, c, d] = [
                j * size + i,
                j * size + i + 1,
                (j + 1) * size + i,
                (j + 1) * size + i + 1,
            ];
            [[a, b, d], [a, d, c]]
        })
    })
}

/// A shaded cloth surface, optionally with a wire every `wire_stride` grid lines and the
/// simulated particles as dots.
fn surface_panel(
    view: &Framing,
    vertices: &[Vec3],
    size: usize,
    wire_stride: Option<usize>,
    particles: Option<&[Vec3]>,
) -> Image {
    let mut r = Raster::new(PANEL.0 * SS, PANEL.1 * SS, BACKGROUND);
    if vertices.len() != size * size || size < 2 {
        return r.downsample(SS as usize);
    }
    let normals = vertex_normals(vertices, size);
    // A key light from above, left and in front of the camera; two-sided, since cloth is seen
    // from both sides.
    let light = (view.up * 0.8 - view.right * 0.35 - view.forward * 0.5).normalize();
    let shade = |k: usize| CLOTH * (0.28 + 0.72 * normals[k].dot(light).abs());
    let screen: Vec<ScreenPoint> = vertices.iter().map(|&p| view.project(p)).collect();
    for t in grid_triangles(size) {
        r.triangle(t.map(|k| screen[k]), t.map(shade));
    }
    if let Some(stride) = wire_stride {
        let stride = stride.max(1);
        for line in (0..size).step_by(stride).chain([size - 1]) {
            for k in 0..size - 1 {
                for (p, q) in [
                    (line * size + k, line * size + k + 1),
                    (k * size + line, (k + 1) * size + line),
                ] {
                    r.line(
                        screen[p],
                        screen[q],
                        1.2 * SS as f32 / 2.0,
                        WIRE,
                        0.45,
                        Some(0.004),
                    );
                }
            }
        }
    }
    if let Some(ps) = particles {
        // Fewer, larger dots read better on small nets.
        let radius = if ps.len() > 2000 { 1.3 } else { 1.8 } * SS as f32;
        for &p in ps {
            r.disc(view.project(p), radius, PARTICLE, Some(0.03));
        }
    }
    r.downsample(SS as usize)
}

/// Whether a link is part of a blend in flight.
pub(crate) fn is_blending(l: &DrawLink) -> bool {
    l.group || l.weight < 0.999
}

/// The links of a snapshot: plain links thin and grey, blending links thick and coloured.
fn links_panel(view: &Framing, links: &[DrawLink]) -> Image {
    let mut r = Raster::new(PANEL.0 * SS, PANEL.1 * SS, Vec3::ONE);
    let w = SS as f32;
    for l in links.iter().filter(|l| !is_blending(l)) {
        r.line(
            view.project(l.a),
            view.project(l.b),
            0.9 * w,
            LINK,
            0.7,
            None,
        );
    }
    // Group links (to the centroid of a virtual parent) under the fading links, so both show.
    for l in links.iter().filter(|l| l.group) {
        r.line(
            view.project(l.a),
            view.project(l.b),
            2.0 * w,
            GROUP,
            1.0,
            None,
        );
    }
    for l in links.iter().filter(|l| is_blending(l) && !l.group) {
        r.line(
            view.project(l.a),
            view.project(l.b),
            2.6 * w,
            FADING,
            1.0,
            None,
        );
    }
    r.downsample(SS as usize)
}

/// The TreeCut run to picture: the feedback run with the strongest compression (where the
/// cut differs most from the full cloth), else any run other than the reference.
fn treecut_run(report: &NetReport) -> Option<&NetRun> {
    report
        .runs
        .iter()
        .filter_map(|r| match r.kind {
            NetRunKind::Feedback { compression } => Some((compression, r)),
            _ => None,
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, r)| r)
        .or_else(|| report.runs.iter().find(|r| r.kind != NetRunKind::Reference))
}

/// Writes `image` as an 8-bit RGB PNG.
pub(crate) fn write_png(path: &Path, image: &Image) -> Result<(), DemoError> {
    let file = std::fs::File::create(path).map_err(|e| DemoError::io(path, e))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), image.width, image.height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder
        .write_header()
        .map_err(|e| DemoError::draw(path, e))?;
    writer
        .write_image_data(&image.rgb)
        .map_err(|e| DemoError::draw(path, e))?;
    writer.finish().map_err(|e| DemoError::draw(path, e))
}

/// Steps after each picture step searched for a links picture with transitions in flight.
pub(crate) const LINK_WINDOW: u32 = 4;

/// The snapshot taken after exactly `step` steps.
fn at(run: &NetRun, step: u32) -> Option<&NetSnapshot> {
    run.snapshots.iter().find(|s| s.step == step)
}

/// The snapshot of `run` in `step..=step + LINK_WINDOW` with the most links being blended
/// (the earliest of equals).
fn most_blending(run: &NetRun, step: u32) -> Option<&NetSnapshot> {
    run.snapshots
        .iter()
        .filter(|s| (step..=step + LINK_WINDOW).contains(&s.step))
        .max_by_key(|s| {
            let blending = s.links.iter().filter(|l| is_blending(l)).count();
            (blending, std::cmp::Reverse(s.step))
        })
}

/// Draws and writes the net pictures into `dir` for each of `steps`; returns the files written.
pub(crate) fn net_pictures(
    report: &NetReport,
    config: &NetConfig,
    steps: &[u32],
    dir: &Path,
) -> Result<Vec<PathBuf>, DemoError> {
    let size = config.size as usize;
    let reference = report.run(NetRunKind::Reference);
    let treecut = treecut_run(report);
    let (Some(reference), Some(treecut)) = (reference, treecut) else {
        return Ok(Vec::new());
    };
    // The columns: picture steps both runs have a snapshot of.
    let columns: Vec<(&NetSnapshot, &NetSnapshot, &NetSnapshot)> = steps
        .iter()
        .filter_map(|&step| {
            Some((
                at(reference, step)?,
                at(treecut, step)?,
                most_blending(treecut, step)?,
            ))
        })
        .collect();
    let clouds: Vec<&[Vec3]> = columns
        .iter()
        .flat_map(|(a, b, _)| [a.vertices.as_slice(), b.vertices.as_slice()])
        .collect();
    let view = Framing::fit(&config.view, &clouds);
    let wire = Some(((size - 1) / 16).max(1));

    let mut files = Vec::new();
    let (pw, ph) = PANEL;
    let mut composite = Image::new(
        pw * columns.len().max(1) as u32,
        TITLE_H + 3 * ph,
        [255, 255, 255],
    );
    for (col, (full, tc, links)) in columns.iter().enumerate() {
        let blending = links.links.iter().filter(|l| is_blending(l)).count();
        let panels = [
            (
                "reference",
                surface_panel(&view, &full.vertices, size, wire, None),
                vec![
                    Caption::title(format!("full resolution: {} nodes", full.particles.len())),
                    Caption::sub(format!("after {} steps", full.step)),
                ],
            ),
            (
                "treecut",
                surface_panel(&view, &tc.vertices, size, None, Some(&tc.particles)),
                vec![
                    Caption::title(format!(
                        "TreeCut {}: {} nodes",
                        treecut.label,
                        tc.particles.len()
                    )),
                    Caption::sub(format!("after {} steps; dots: simulated nodes", tc.step)),
                ],
            ),
            (
                "links",
                links_panel(&view, &links.links),
                vec![
                    Caption::title(format!(
                        "TreeCut links: {} ({} being blended)",
                        links.links.len(),
                        blending
                    )),
                    Caption::sub(format!("after {} steps", links.step)),
                ],
            ),
        ];
        for (row, (name, mut image, captions)) in panels.into_iter().enumerate() {
            let path = dir.join(format!("net_{name}_{:03}.png", full.step));
            text::draw_captions(&mut image, &captions, name == "links")
                .map_err(|e| DemoError::draw(&path, e))?;
            write_png(&path, &image)?;
            files.push(path);
            composite.blit(&image, col as u32 * pw, TITLE_H + row as u32 * ph);
        }
    }
    let path = dir.join("net_figure6.png");
    text::draw_title(
        &mut composite,
        &format!(
            "Swinging net {size}x{size}: full resolution (top), TreeCut {} (middle), its links with \
             blending links highlighted (bottom)",
            treecut.label
        ),
        "like the simulation paper's Figure 6: the same steps of both runs, seen from the \
         experiment camera's side, 35 degrees above the cloth",
    )
    .map_err(|e| DemoError::draw(&path, e))?;
    write_png(&path, &composite)?;
    files.insert(0, path);
    Ok(files)
}
