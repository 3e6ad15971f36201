//! A small software rasteriser for the net pictures: Gouraud-shaded triangles with a depth
//! buffer, thick lines and discs (optionally depth-tested, so wire and points on a surface hide
//! behind it), drawn at a supersampled resolution and box-filtered down, which antialiases
//! everything at once. Colours are linear floats until the final 8-bit image.
//!
//! Depth is stored as 1/z (z = view depth), which is linear in screen space, so interpolating
//! it across a triangle is exact; larger means nearer.

use glam::{Vec2, Vec3};

/// A point on screen: pixel coordinates (supersampled) and 1/z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ScreenPoint {
    /// Pixel position.
    pub(crate) xy: Vec2,
    /// Inverse view depth (> 0 in front of the eye).
    pub(crate) inv_z: f32,
}

/// A final 8-bit RGB picture.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Image {
    /// Width in pixels.
    pub(crate) width: u32,
    /// Height in pixels.
    pub(crate) height: u32,
    /// Row-major RGB bytes.
    pub(crate) rgb: Vec<u8>,
}

impl Image {
    /// A picture filled with one colour.
    pub(crate) fn new(width: u32, height: u32, fill: [u8; 3]) -> Image {
        let mut rgb = Vec::with_capacity((width * height * 3) as usize);
        for _ in 0..width * height {
            rgb.extend_from_slice(&fill);
        }
        Image { width, height, rgb }
    }

    /// Copies `other` with its top-left corner at (x, y), clipped to this picture.
    pub(crate) fn blit(&mut self, other: &Image, x: u32, y: u32) {
        for row in 0..other.height {
            let ty = y + row;
            if ty >= self.height {
                break;
            }
            let w = other.width.min(self.width.saturating_sub(x)) as usize;
            let src = (row * other.width) as usize * 3;
            let dst = (ty * self.width + x) as usize * 3;
            self.rgb[dst..dst + 3 * w].copy_from_slice(&other.rgb[src..src + 3 * w]);
        }
    }
}

/// The supersampled drawing surface.
#[derive(Clone, Debug)]
pub(crate) struct Raster {
    width: usize,
    height: usize,
    color: Vec<Vec3>,
    depth: Vec<f32>,
}

impl Raster {
    /// A `width`×`height` surface filled with `background`, depth at infinity.
    pub(crate) fn new(width: u32, height: u32, background: Vec3) -> Raster {
        let n = (width * height) as usize;
        Raster {
            width: width as usize,
            height: height as usize,
            color: vec![background; n],
            depth: vec![0.0; n],
        }
    }

    /// A triangle with a colour per corner, depth-tested and depth-writing.
    pub(crate) fn triangle(&mut self, p: [ScreenPoint; 3], c: [Vec3; 3]) {
        let [a, b, d] = p.map(|q| q.xy);
        let area = edge(a, b, d);
        if area.abs() < 1e-12 || !area.is_finite() {
            return;
        }
        let (x0, x1, y0, y1) = self.bounds(a.min(b).min(d), a.max(b).max(d));
        for y in y0..y1 {
            for x in x0..x1 {
                let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let w0 = edge(b, d, q) / area;
                let w1 = edge(d, a, q) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let inv_z = w0 * p[0].inv_z + w1 * p[1].inv_z + w2 * p[2].inv_z;
                let i = y * self.width + x;
                if inv_z > self.depth[i] {
                    self.depth[i] = inv_z;
                    // Perspective-correct colour: interpolate colour/z, divide by 1/z.
                    let (k0, k1, k2) = (w0 * p[0].inv_z, w1 * p[1].inv_z, w2 * p[2].inv_z);
                    self.color[i] = (c[0] * k0 + c[1] * k1 + c[2] * k2) / inv_z;
                }
            }
        }
    }

    /// A line `width` pixels wide blended over the picture with `alpha`. With `depth_bias`,
    /// pixels behind the surface already drawn (by more than the bias, relative) are skipped.
    pub(crate) fn line(
        &mut self,
        a: ScreenPoint,
        b: ScreenPoint,
        width: f32,
        color: Vec3,
        alpha: f32,
        depth_bias: Option<f32>,
    ) {
        let r = 0.5 * width;
        let d = b.xy - a.xy;
        let len2 = d.length_squared();
        let (x0, x1, y0, y1) = self.bounds(a.xy.min(b.xy) - r, a.xy.max(b.xy) + r);
        for y in y0..y1 {
            for x in x0..x1 {
                let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let t = if len2 > 0.0 {
                    ((q - a.xy).dot(d) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                if (a.xy + d * t).distance_squared(q) > r * r {
                    continue;
                }
                let i = y * self.width + x;
                if let Some(bias) = depth_bias {
                    let inv_z = a.inv_z + (b.inv_z - a.inv_z) * t;
                    if inv_z * (1.0 + bias) < self.depth[i] {
                        continue;
                    }
                }
                self.color[i] = self.color[i] * (1.0 - alpha) + color * alpha;
            }
        }
    }

    /// A filled disc of radius `r` pixels, depth-tested like [`Raster::line`].
    pub(crate) fn disc(&mut self, c: ScreenPoint, r: f32, color: Vec3, depth_bias: Option<f32>) {
        self.line(c, c, 2.0 * r, color, 1.0, depth_bias);
    }

    /// The picture box-filtered down by `factor` in each direction, as 8-bit RGB.
    pub(crate) fn downsample(&self, factor: usize) -> Image {
        let factor = factor.max(1);
        let (w, h) = (self.width / factor, self.height / factor);
        let mut rgb = Vec::with_capacity(w * h * 3);
        let norm = 1.0 / (factor * factor) as f32;
        for y in 0..h {
            for x in 0..w {
                let mut sum = Vec3::ZERO;
                for sy in 0..factor {
                    let row = (y * factor + sy) * self.width + x * factor;
                    for c in &self.color[row..row + factor] {
                        sum += *c;
                    }
                }
                let c = (sum * norm).clamp(Vec3::ZERO, Vec3::ONE) * 255.0 + 0.5;
                rgb.extend_from_slice(&[c.x as u8, c.y as u8, c.z as u8]);
            }
        }
        Image {
            width: w as u32,
            height: h as u32,
            rgb,
        }
    }

    /// The pixel box covering `lo..hi`, clipped to the surface (end exclusive).
    fn bounds(&self, lo: Vec2, hi: Vec2) -> (usize, usize, usize, usize) {
        if !(lo.is_finite() && hi.is_finite()) {
            return (0, 0, 0, 0);
        }
        let clip = |v: f32, n: usize| v.clamp(0.0, n as f32) as usize;
        (
            clip(lo.x.floor(), self.width),
            clip(hi.x.ceil() + 1.0, self.width),
            clip(lo.y.floor(), self.height),
            clip(hi.y.ceil() + 1.0, self.height),
        )
    }
}

/// Twice the signed area of (a, b, c).
#[inline]
fn edge(a: Vec2, b: Vec2, c: Vec2) -> f32 {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sp(x: f32, y: f32, inv_z: f32) -> ScreenPoint {
        ScreenPoint {
            xy: Vec2::new(x, y),
            inv_z,
        }
    }

    #[test]
    fn nearer_triangle_wins_whatever_the_order() {
        let far = [sp(0.0, 0.0, 0.5), sp(20.0, 0.0, 0.5), sp(0.0, 20.0, 0.5)];
        let near = [sp(0.0, 0.0, 1.0), sp(20.0, 0.0, 1.0), sp(0.0, 20.0, 1.0)];
        for order in [[far, near], [near, far]] {
            let mut r = Raster::new(20, 20, Vec3::ZERO);
            r.triangle(order[0], [Vec3::X; 3]);
            r.triangle(order[1], [Vec3::Y; 3]);
            let colour = if order[0] == near { Vec3::X } else { Vec3::Y };
            assert_eq!(r.color[2 * 20 + 2], colour);
            assert_eq!(
                r.color[19 * 20 + 19],
                Vec3::ZERO,
                "outside stays background"
            );
        }
    }

    #[test]
    fn lines_hide_behind_surfaces_and_downsampling_averages() {
        let mut r = Raster::new(8, 8, Vec3::ZERO);
        r.triangle(
            [sp(0.0, 0.0, 1.0), sp(16.0, 0.0, 1.0), sp(0.0, 16.0, 1.0)],
            [Vec3::ONE; 3],
        );
        // Behind the surface: hidden; in front: drawn.
        r.line(
            sp(0.0, 1.5, 0.5),
            sp(8.0, 1.5, 0.5),
            1.0,
            Vec3::X,
            1.0,
            Some(0.01),
        );
        assert_eq!(r.color[8 + 3], Vec3::ONE);
        r.line(
            sp(0.0, 1.5, 2.0),
            sp(8.0, 1.5, 2.0),
            1.0,
            Vec3::X,
            1.0,
            Some(0.01),
        );
        assert_eq!(r.color[8 + 3], Vec3::X);
        let img = r.downsample(2);
        assert_eq!((img.width, img.height, img.rgb.len()), (4, 4, 48));
        let mut big = Image::new(6, 6, [9, 9, 9]);
        big.blit(&img, 4, 4);
        assert_eq!(&big.rgb[..3], &[9, 9, 9]);
        assert_eq!(
            &big.rgb[(4 * 6 + 4) * 3..(4 * 6 + 4) * 3 + 3],
            &img.rgb[..3]
        );
    }
}
