//! The perception section's moving picture: one view-dependent scene through its own moving
//! camera, the full-resolution reference (left) and the feedback loop's cloth (right) side by
//! side, the LOD cloth coloured by the level of the node that simulates each part (finest dark
//! purple, then blue, teal, green, yellow), as an animated PNG (APNG, written with `png`): LOD is judged in
//! motion. Drawn by the demo's rasteriser ([`super::raster`]).

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::raster::{Image, Raster, ScreenPoint};
use super::text::{self, Caption};
use crate::error::DemoError;
use crate::perception::Movie;

/// One panel's size in final pixels (16:9, like the measured view).
const PANEL: (u32, u32) = (480, 270);
/// Supersampling per direction.
const SS: u32 = 2;
/// Height of the title band.
const TITLE_H: u32 = 56;
const BACKGROUND: Vec3 = Vec3::new(0.97, 0.97, 0.96);
const CLOTH: Vec3 = Vec3::new(0.36, 0.56, 0.86);

/// Colour of level `level` (0 = finest): one clear step of a viridis-like ramp per level (dark
/// purple, blue, teal, green), yellow for level 4 and coarser, so the first levels, where a
/// budget is spent, stay distinguishable.
pub(crate) fn level_colour(level: u32) -> Vec3 {
    const RAMP: [Vec3; 5] = [
        Vec3::new(0.27, 0.00, 0.33),
        Vec3::new(0.23, 0.32, 0.55),
        Vec3::new(0.13, 0.57, 0.55),
        Vec3::new(0.37, 0.79, 0.38),
        Vec3::new(0.99, 0.91, 0.15),
    ];
    RAMP[(level as usize).min(RAMP.len() - 1)]
}

/// A square grid surface of `side` vertices through `view` (scaled to a panel), each vertex
/// coloured by `colour` and shaded by its normal against a light at the eye.
fn panel(
    view: &salience::View,
    vertices: &[Vec3],
    side: usize,
    colour: &dyn Fn(usize) -> Vec3,
) -> Image {
    let (w, h) = (PANEL.0 * SS, PANEL.1 * SS);
    let mut r = Raster::new(w, h, BACKGROUND);
    if vertices.len() != side * side || side < 2 {
        return r.downsample(SS as usize);
    }
    let scale = Vec2::new(
        w as f32 / view.width_px() as f32,
        h as f32 / view.height_px() as f32,
    );
    let screen: Vec<ScreenPoint> = vertices
        .iter()
        .map(|&p| match view.project(p) {
            Some(q) => ScreenPoint {
                xy: q * scale,
                inv_z: 1.0 / view.depth(p),
            },
            None => ScreenPoint {
                xy: Vec2::splat(-1e6),
                inv_z: 0.0,
            },
        })
        .collect();
    let normals = super::vertex_normals(vertices, side);
    let shade = |k: usize| {
        let to_eye = (view.position() - vertices[k]).normalize_or(Vec3::Z);
        colour(k) * (0.35 + 0.65 * normals[k].dot(to_eye).abs())
    };
    for t in super::grid_triangles(side) {
        if t.iter().all(|&k| screen[k].inv_z > 0.0) {
            r.triangle(t.map(|k| screen[k]), t.map(shade));
        }
    }
    r.downsample(SS as usize)
}

/// Draws every frame of `movie` and writes `perception_<scene>.png` (an animated PNG) into
/// `dir`; returns the file.
pub(crate) fn perception_movie(movie: &Movie, dir: &Path) -> Result<PathBuf, DemoError> {
    let path = dir.join(format!("perception_{}.png", movie.scene.name));
    let (pw, ph) = PANEL;
    let (width, height) = (2 * pw, TITLE_H + ph);
    let mut images = Vec::with_capacity(movie.frames.len());
    for f in &movie.frames {
        let view = movie.scene.view(f.step)?;
        let reference = panel(&view, &f.reference, movie.side, &|_| CLOTH);
        let lod = panel(&view, &f.lod, movie.side, &|k| level_colour(f.levels[k]));
        let mut image = Image::new(width, height, [255, 255, 255]);
        let mut left = reference;
        text::draw_captions(
            &mut left,
            &[Caption::sub(format!(
                "full resolution, {} nodes",
                f.reference.len()
            ))],
            false,
        )
        .map_err(|e| DemoError::draw(&path, e))?;
        let mut right = lod;
        text::draw_captions(
            &mut right,
            &[Caption::sub(format!("feedback loop, {} nodes", f.nodes))],
            false,
        )
        .map_err(|e| DemoError::draw(&path, e))?;
        image.blit(&left, 0, TITLE_H);
        image.blit(&right, pw, TITLE_H);
        text::draw_title(
            &mut image,
            &format!(
                "{}: the camera dollies in and orbits (step {})",
                movie.scene.name,
                f.step + 1
            ),
            "reference (left); feedback loop (right) by level: 0 (finest) purple, 1 blue, 2 teal, \
             3 green, 4+ yellow",
        )
        .map_err(|e| DemoError::draw(&path, e))?;
        images.push(image);
    }
    write_apng(&path, &images, movie.frame_seconds)?;
    Ok(path)
}

/// Writes `frames` (all the same size, at least one) as an endlessly looping animated PNG,
/// each shown `seconds`.
fn write_apng(path: &Path, frames: &[Image], seconds: f32) -> Result<(), DemoError> {
    let Some(first) = frames.first() else {
        return Err(DemoError::draw(path, "no frames"));
    };
    let file = std::fs::File::create(path).map_err(|e| DemoError::io(path, e))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), first.width, first.height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let draw = |e: png::EncodingError| DemoError::draw(path, e);
    encoder.set_animated(frames.len() as u32, 0).map_err(draw)?;
    let ms = (seconds * 1000.0).round().clamp(10.0, 10_000.0) as u16;
    encoder.set_frame_delay(ms, 1000).map_err(draw)?;
    let mut writer = encoder.write_header().map_err(draw)?;
    for f in frames {
        writer.write_image_data(&f.rgb).map_err(draw)?;
    }
    writer.finish().map_err(draw)
}
