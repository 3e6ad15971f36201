//! The camera, the LOD modes, and the camera ratio Ω ∈ [0, 1] of a character: 1 means full
//! detail, 0 means no bone interpolates.

use glam::Vec3;

use crate::error::{CrowdError, invalid};

/// A perspective camera, enough to measure distances, project sizes to pixels and tell what is
/// on screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position in world space.
    pub position: Vec3,
    /// Unit viewing direction. With it, sizes use the view depth (distance along `forward`), and
    /// only what lies inside the view cone (the cone around `forward` that holds the frustum of
    /// `fov_y` and `aspect`) and beyond `near` counts as visible: an invisible character gets
    /// Ω = 0 and invisible joints no pixel error. Without it, sizes use the Euclidean distance and
    /// everything beyond `near` is visible.
    pub forward: Option<Vec3>,
    /// Vertical field of view in radians, in (0, π).
    pub fov_y: f32,
    /// Viewport height in pixels.
    pub viewport_height: f32,
    /// Viewport width over height.
    pub aspect: f32,
    /// Near plane distance: nothing nearer is visible.
    pub near: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            position: Vec3::ZERO,
            forward: None,
            fov_y: 60f32.to_radians(),
            viewport_height: 1080.0,
            aspect: 16.0 / 9.0,
            near: 0.01,
        }
    }
}

impl Camera {
    /// Checks every field (finite position, unit forward, fov in (0, π), positive viewport,
    /// aspect and near).
    pub fn validate(&self) -> Result<(), CrowdError> {
        if !self.position.is_finite() {
            return Err(invalid("camera position", "must be finite"));
        }
        if let Some(f) = self.forward {
            if !f.is_finite() || (f.length() - 1.0).abs() > 1e-3 {
                return Err(invalid("camera forward", "must be a finite unit vector"));
            }
        }
        if !(self.fov_y > 0.0 && self.fov_y < std::f32::consts::PI) {
            return Err(invalid("camera fov_y", "must be in (0, pi) radians"));
        }
        if !(self.viewport_height.is_finite() && self.viewport_height > 0.0) {
            return Err(invalid(
                "camera viewport_height",
                "must be finite and positive",
            ));
        }
        if !(self.aspect.is_finite() && self.aspect > 0.0) {
            return Err(invalid("camera aspect", "must be finite and positive"));
        }
        if !(self.near.is_finite() && self.near > 0.0) {
            return Err(invalid("camera near", "must be finite and positive"));
        }
        Ok(())
    }

    /// Pixels covered by one world unit at depth 1: `viewport_height / (2 · tan(fov_y / 2))`.
    #[inline]
    pub fn focal_pixels(&self) -> f32 {
        self.viewport_height / (2.0 * (0.5 * self.fov_y).tan())
    }

    /// The per-frame projection constants (computed once, used for many points).
    pub fn projection(&self) -> Projection {
        let half = (0.5 * self.fov_y).tan();
        let tan_cone = half * (1.0 + self.aspect * self.aspect).sqrt();
        Projection {
            position: self.position,
            forward: self.forward,
            focal: self.focal_pixels(),
            near: self.near,
            tan_cone,
            sec_cone: (1.0 + tan_cone * tan_cone).sqrt(),
        }
    }

    /// Pixels covered by one world unit at `point` (perpendicular to the view), or `None` if the
    /// point is not visible: `viewport_height / (2 · depth · tan(fov_y / 2))`.
    pub fn pixels_per_unit(&self, point: Vec3) -> Option<f32> {
        self.projection().pixels_per_unit(point)
    }

    /// Projected radius in pixels of a sphere (0 when it is not visible):
    /// `radius · viewport_height / (2 · distance · tan(fov_y / 2))`.
    pub fn projected_radius(&self, center: Vec3, radius: f32) -> f32 {
        self.projection().projected_radius(center, radius)
    }

    /// Euclidean distance from the eye.
    #[inline]
    pub fn distance(&self, point: Vec3) -> f32 {
        (point - self.position).length()
    }
}

/// A camera's projection constants for one frame (see [`Camera::projection`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    position: Vec3,
    forward: Option<Vec3>,
    focal: f32,
    near: f32,
    tan_cone: f32,
    sec_cone: f32,
}

impl Projection {
    /// Depth of a point and its distance from the view axis.
    #[inline]
    fn depth_and_offset(&self, p: Vec3) -> (f32, f32) {
        let d = p - self.position;
        match self.forward {
            Some(f) => {
                let depth = d.dot(f);
                (depth, (d - f * depth).length())
            }
            None => (d.length(), 0.0),
        }
    }

    /// Pixels per world unit at a visible point, `None` if it is nearer than the near plane or
    /// outside the view cone.
    #[inline]
    pub fn pixels_per_unit(&self, p: Vec3) -> Option<f32> {
        let (depth, offset) = self.depth_and_offset(p);
        (depth >= self.near && offset <= depth * self.tan_cone).then(|| self.focal / depth)
    }

    /// Projected radius (pixels) of a sphere any part of which is visible, else 0. The depth of
    /// the centre, clamped to the near plane, sets the scale.
    #[inline]
    pub fn projected_radius(&self, center: Vec3, radius: f32) -> f32 {
        let (depth, offset) = self.depth_and_offset(center);
        let visible =
            depth + radius >= self.near && offset <= depth * self.tan_cone + radius * self.sec_cone;
        if visible {
            radius * self.focal / depth.max(self.near)
        } else {
            0.0
        }
    }

    /// Pixels per world unit at the point of a sphere nearest the eye (0 when no part of it is
    /// visible): the largest scale any of its joints can be seen at.
    #[inline]
    pub fn nearest_pixels_per_unit(&self, center: Vec3, radius: f32) -> f32 {
        let (depth, offset) = self.depth_and_offset(center);
        let visible =
            depth + radius >= self.near && offset <= depth * self.tan_cone + radius * self.sec_cone;
        if visible {
            self.focal / (depth - radius).max(self.near)
        } else {
            0.0
        }
    }

    /// Whether any part of a sphere is visible.
    #[inline]
    pub fn sphere_visible(&self, center: Vec3, radius: f32) -> bool {
        self.projected_radius(center, radius) > 0.0
    }
}

/// How a crowd chooses each character's detail.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LodMode {
    /// Every animated bone of every character interpolates every frame (constant channels are
    /// still never sampled).
    Off,
    /// The same Ω for every character (tests, analysis, user control).
    Ratio(f32),
    /// The thesis' distance range: Ω = 1 nearer than `min`, 0 farther than `max`, linear between.
    Range {
        /// Distance below which a character is at full detail.
        min: f32,
        /// Distance beyond which no bone of it interpolates.
        max: f32,
    },
    /// Ω from the projected radius of the character's bounding sphere: `radius_px /
    /// full_detail_px`, capped at 1, and 0 below `freeze_below_px`. Because a joint's on-screen
    /// speed is proportional to the projected size while the scheduler's hold time is inversely
    /// proportional to Ω, the pixel error of a hold stays about the same at every distance.
    PixelSize {
        /// Projected radius (pixels) at and above which a character is at full detail.
        full_detail_px: f32,
        /// Projected radius (pixels) below which a character does not animate at all (0 to never
        /// freeze a visible character).
        freeze_below_px: f32,
    },
    /// A crowd-wide budget of bone interpolations per frame, spent on the bones whose hold has
    /// built up the most estimated on-screen error (projected size × priority integrated over
    /// the time held). Bones whose score is zero (invisible characters) never take budget.
    Budget {
        /// Bone interpolations allowed per frame over all characters.
        bone_updates_per_frame: u32,
    },
    /// Beyond the thesis: hold a bone only while the on-screen error its hold causes stays under
    /// a bound. Each animated bone integrates its measured hold error rate
    /// ([`crate::SubPriorities::hold_error_rate`]) over the time it holds, converts it to pixels
    /// at the character's nearest visible depth, and interpolates as soon as that reaches
    /// `max_error_px`. Invisible characters do not animate.
    ErrorBound {
        /// Largest on-screen drift (pixels) a single held bone may cause.
        max_error_px: f32,
    },
}

impl LodMode {
    /// Checks the parameters: finite, `0 ≤ min < max`, `full_detail_px > 0`,
    /// `0 ≤ freeze_below_px < full_detail_px`, Ω in [0, 1].
    pub fn validate(&self) -> Result<(), CrowdError> {
        match *self {
            LodMode::Off | LodMode::Budget { .. } => Ok(()),
            LodMode::Ratio(o) if (0.0..=1.0).contains(&o) => Ok(()),
            LodMode::Ratio(_) => Err(invalid("ratio", "must be in [0, 1]")),
            LodMode::Range { min, max }
                if min.is_finite() && max.is_finite() && min >= 0.0 && min < max =>
            {
                Ok(())
            }
            LodMode::Range { .. } => Err(invalid("range", "needs finite 0 <= min < max")),
            LodMode::PixelSize {
                full_detail_px: f,
                freeze_below_px: z,
            } if f.is_finite() && f > 0.0 && z.is_finite() && z >= 0.0 && z < f => Ok(()),
            LodMode::PixelSize { .. } => Err(invalid(
                "pixel size",
                "needs finite 0 <= freeze_below_px < full_detail_px",
            )),
            LodMode::ErrorBound { max_error_px: e } if e.is_finite() && e > 0.0 => Ok(()),
            LodMode::ErrorBound { .. } => {
                Err(invalid("max_error_px", "must be finite and positive"))
            }
        }
    }
}

/// The thesis' camera ratio from a distance range, the right way round: 1 at or nearer than
/// `min`, 0 at or beyond `max`, `(max − d) / (max − min)` between. (The thesis prints
/// `(d − min) / (max − min)`, which grows with distance, against its own text that Ω must shrink
/// as the character moves away.)
#[inline]
pub fn omega_from_distance(distance: f32, min: f32, max: f32) -> f32 {
    ((max - distance) / (max - min)).clamp(0.0, 1.0)
}

/// The camera ratio from a projected radius in pixels (see [`LodMode::PixelSize`]).
#[inline]
pub fn omega_from_pixels(radius_px: f32, full_detail_px: f32, freeze_below_px: f32) -> f32 {
    if radius_px < freeze_below_px || radius_px <= 0.0 {
        0.0
    } else {
        (radius_px / full_detail_px).min(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_and_ratios() {
        let cam = Camera {
            position: Vec3::ZERO,
            forward: Some(Vec3::NEG_Z),
            fov_y: 90f32.to_radians(),
            viewport_height: 1000.0,
            aspect: 1.0,
            near: 0.1,
        };
        // tan(45°) = 1: at depth 10, one unit is 1000 / 20 = 50 px.
        assert!((cam.pixels_per_unit(Vec3::new(3.0, 0.0, -10.0)).unwrap() - 50.0).abs() < 1e-3);
        assert!(cam.pixels_per_unit(Vec3::new(0.0, 0.0, 5.0)).is_none());
        // The view cone of a square 90° frustum has a half-angle of atan(√2): (13, 0, −10) is in,
        // (15, 0, −10) is out; a sphere reaching into the cone counts as visible.
        assert!(cam.pixels_per_unit(Vec3::new(13.0, 0.0, -10.0)).is_some());
        assert!(cam.pixels_per_unit(Vec3::new(15.0, 0.0, -10.0)).is_none());
        assert!(cam.projected_radius(Vec3::new(15.0, 0.0, -10.0), 2.0) > 0.0);
        assert_eq!(cam.projected_radius(Vec3::new(30.0, 0.0, -10.0), 2.0), 0.0);
        assert!(cam.pixels_per_unit(Vec3::new(0.0, 0.0, -0.05)).is_none());
        assert!(Camera { near: 0.0, ..cam }.validate().is_err());
        assert_eq!(cam.projected_radius(Vec3::new(0.0, 0.0, 5.0), 1.0), 0.0);
        assert_eq!(omega_from_distance(100.0, 200.0, 1700.0), 1.0);
        assert_eq!(omega_from_distance(2000.0, 200.0, 1700.0), 0.0);
        assert!((omega_from_distance(950.0, 200.0, 1700.0) - 0.5).abs() < 1e-6);
        assert_eq!(omega_from_pixels(500.0, 200.0, 2.0), 1.0);
        assert_eq!(omega_from_pixels(1.0, 200.0, 2.0), 0.0);
        assert!((omega_from_pixels(50.0, 200.0, 2.0) - 0.25).abs() < 1e-6);
        assert!(cam.validate().is_ok());
        assert!(Camera { fov_y: 0.0, ..cam }.validate().is_err());
        assert!(
            Camera {
                forward: Some(Vec3::new(0.0, 0.0, -2.0)),
                ..cam
            }
            .validate()
            .is_err()
        );
        assert!(
            Camera {
                position: Vec3::NAN,
                ..cam
            }
            .validate()
            .is_err()
        );
        assert!(LodMode::Range { min: 5.0, max: 5.0 }.validate().is_err());
        assert!(LodMode::Ratio(1.5).validate().is_err());
        assert!(
            LodMode::PixelSize {
                full_detail_px: 10.0,
                freeze_below_px: 20.0
            }
            .validate()
            .is_err()
        );
    }
}
