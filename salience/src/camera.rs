//! The pinhole camera and the view measures built on it: distance, projected size in pixels,
//! pixels per world unit, and the angular (retinal) and on-screen speed of a moving point.
//!
//! These are shared by the cloth (BSWDF) and by the animation crowd (camera ratio per character),
//! so they are plain methods on a validated [`Camera`] that cost a few flops each.
//!
//! Units: positions and radii in world units (metres by convention, but nothing here depends on
//! it), velocities in world units per second, angles in radians, speeds on screen in pixels per
//! second.

use glam::Vec3;

use crate::error::CameraError;

/// Distances below this (in world units) are treated as this distance, so that measures which
/// divide by the distance stay finite when a point sits on the eye. It is a guard, not a near
/// plane: at 0.1 mm nothing rendered is meaningful anyway.
pub const MIN_VIEW_DISTANCE: f32 = 1.0e-4;

/// A validated pinhole camera: where it is, where it looks, and the image it renders to.
///
/// Built by [`Camera::new`] or [`Camera::look_at`], which reject NaN, zero viewports and
/// degenerate directions; afterwards every field is finite and the basis is orthonormal, so the
/// view measures never need to check again.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    position: Vec3,
    forward: Vec3,
    up: Vec3,
    right: Vec3,
    fov_y_radians: f32,
    width_px: u32,
    height_px: u32,
    tan_half_fov_y: f32,
    tan_half_fov_x: f32,
    focal_px: f32,
}

impl Camera {
    /// A camera at `position` looking along `forward`, with `up` giving the image's vertical
    /// (it need not be orthogonal to `forward`, only not parallel), a vertical field of view of
    /// `fov_y_radians` in (0, π) and a viewport of `width_px` × `height_px` pixels.
    pub fn new(
        position: Vec3,
        forward: Vec3,
        up: Vec3,
        fov_y_radians: f32,
        width_px: u32,
        height_px: u32,
    ) -> Result<Self, CameraError> {
        if !(position.is_finite()
            && forward.is_finite()
            && up.is_finite()
            && fov_y_radians.is_finite())
        {
            return Err(CameraError::NonFinite);
        }
        if width_px == 0 || height_px == 0 {
            return Err(CameraError::ZeroViewport {
                width: width_px,
                height: height_px,
            });
        }
        if !(fov_y_radians > 0.0 && fov_y_radians < std::f32::consts::PI) {
            return Err(CameraError::FieldOfView { fov_y_radians });
        }
        let length = forward.length();
        // Relative to nothing: a forward vector this short has lost its direction to rounding.
        if !length.is_finite() || length <= 1.0e-6 {
            return Err(CameraError::DegenerateForward { length });
        }
        let forward = forward / length;
        let right = forward.cross(up);
        let up_len = up.length();
        // sin(angle between up and forward) below ~1e-4 leaves no usable image orientation.
        if up_len <= 1.0e-6 || right.length() <= 1.0e-4 * up_len {
            return Err(CameraError::DegenerateUp);
        }
        let right = right.normalize();
        let up = right.cross(forward);
        let tan_half_fov_y = (0.5 * fov_y_radians).tan();
        let aspect = width_px as f32 / height_px as f32;
        Ok(Self {
            position,
            forward,
            up,
            right,
            fov_y_radians,
            width_px,
            height_px,
            tan_half_fov_y,
            tan_half_fov_x: tan_half_fov_y * aspect,
            focal_px: 0.5 * height_px as f32 / tan_half_fov_y,
        })
    }

    /// A camera at `eye` looking at `target`; see [`Camera::new`]. `eye == target` is a
    /// degenerate forward direction.
    pub fn look_at(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y_radians: f32,
        width_px: u32,
        height_px: u32,
    ) -> Result<Self, CameraError> {
        Self::new(eye, target - eye, up, fov_y_radians, width_px, height_px)
    }

    /// Where the eye is, in world coordinates.
    #[inline]
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// Unit view direction.
    #[inline]
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Unit image-up direction, orthogonal to [`Camera::forward`].
    #[inline]
    pub fn up(&self) -> Vec3 {
        self.up
    }

    /// Unit image-right direction (`forward × up`).
    #[inline]
    pub fn right(&self) -> Vec3 {
        self.right
    }

    /// Vertical field of view in radians.
    #[inline]
    pub fn fov_y_radians(&self) -> f32 {
        self.fov_y_radians
    }

    /// Viewport width in pixels.
    #[inline]
    pub fn width_px(&self) -> u32 {
        self.width_px
    }

    /// Viewport height in pixels.
    #[inline]
    pub fn height_px(&self) -> u32 {
        self.height_px
    }

    /// tan of half the vertical field of view (image half-height at depth 1).
    #[inline]
    pub fn tan_half_fov_y(&self) -> f32 {
        self.tan_half_fov_y
    }

    /// tan of half the horizontal field of view (image half-width at depth 1).
    #[inline]
    pub fn tan_half_fov_x(&self) -> f32 {
        self.tan_half_fov_x
    }

    /// Focal length in pixels: pixels per radian of visual angle on the optical axis,
    /// `(height / 2) / tan(fov_y / 2)`.
    #[inline]
    pub fn focal_length_px(&self) -> f32 {
        self.focal_px
    }

    /// Euclidean distance from the eye to `point`, in world units.
    #[inline]
    pub fn distance(&self, point: Vec3) -> f32 {
        (point - self.position).length()
    }

    /// Depth of `point` along the view direction (negative behind the camera), in world units.
    #[inline]
    pub fn depth(&self, point: Vec3) -> f32 {
        (point - self.position).dot(self.forward)
    }

    /// Pixels covered by one world unit seen face-on at `distance`: `focal_px / distance`.
    ///
    /// Small-angle (on-axis) measure; toward the image corners a pinhole stretches objects by up
    /// to `1 / cos²` of the off-axis angle, which LOD decisions ignore on purpose (the eye does not
    /// see more detail there). Distances below [`MIN_VIEW_DISTANCE`] are clamped.
    #[inline]
    pub fn pixels_per_unit(&self, distance: f32) -> f32 {
        self.focal_px / distance.max(MIN_VIEW_DISTANCE)
    }

    /// Projected diameter in pixels of a sphere (or a bone segment's bounding sphere) of `radius`
    /// world units centred at `centre`: `2 · radius · pixels_per_unit(distance)`.
    ///
    /// The small-angle formula used for LOD everywhere: within 1% of the exact on-axis value
    /// while the sphere is smaller than a tenth of its distance, monotone in distance, finite
    /// for every finite input. Negative radii count as zero.
    #[inline]
    pub fn projected_size_px(&self, centre: Vec3, radius: f32) -> f32 {
        2.0 * radius.max(0.0) * self.pixels_per_unit(self.distance(centre))
    }

    /// Angular speed in radians per second at which a point at `position` moving with
    /// `velocity` sweeps across the visual field: the component of the velocity perpendicular
    /// to the view ray, divided by the distance, i.e. `|velocity × r| / |r|²` with
    /// `r = position − eye`. Motion straight toward or away from the eye has angular speed 0.
    #[inline]
    pub fn angular_speed(&self, position: Vec3, velocity: Vec3) -> f32 {
        let ray = position - self.position;
        let dist_sq = ray
            .length_squared()
            .max(MIN_VIEW_DISTANCE * MIN_VIEW_DISTANCE);
        velocity.cross(ray).length() / dist_sq
    }

    /// The same motion as [`Camera::angular_speed`], in pixels per second on screen
    /// (angular speed × focal length; on-axis measure, see [`Camera::pixels_per_unit`]).
    #[inline]
    pub fn screen_speed_px(&self, position: Vec3, velocity: Vec3) -> f32 {
        self.angular_speed(position, velocity) * self.focal_px
    }

    /// Whether `point` lies in front of the camera and inside the image, widened by `margin`
    /// (a fraction of the half-extent on each side: 0.1 accepts points up to 10% outside).
    #[inline]
    pub fn is_in_view(&self, point: Vec3, margin: f32) -> bool {
        let ray = point - self.position;
        let depth = ray.dot(self.forward);
        let widen = 1.0 + margin.max(0.0);
        depth > 0.0
            && ray.dot(self.right).abs() <= depth * self.tan_half_fov_x * widen
            && ray.dot(self.up).abs() <= depth * self.tan_half_fov_y * widen
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_PI_2;

    fn cam() -> Camera {
        Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 800, 600).unwrap()
    }

    #[test]
    fn rejects_bad_input() {
        let ok = |p, f, u, fov, w, h| Camera::new(p, f, u, fov, w, h);
        assert_eq!(
            ok(Vec3::NAN, Vec3::Z, Vec3::Y, 1.0, 10, 10),
            Err(CameraError::NonFinite)
        );
        assert_eq!(
            ok(Vec3::ZERO, Vec3::Z, Vec3::Y, f32::NAN, 10, 10),
            Err(CameraError::NonFinite)
        );
        assert!(matches!(
            ok(Vec3::ZERO, Vec3::Z, Vec3::Y, 1.0, 0, 10),
            Err(CameraError::ZeroViewport { .. })
        ));
        assert!(matches!(
            ok(Vec3::ZERO, Vec3::ZERO, Vec3::Y, 1.0, 10, 10),
            Err(CameraError::DegenerateForward { .. })
        ));
        assert_eq!(
            ok(Vec3::ZERO, Vec3::Y, Vec3::Y * 3.0, 1.0, 10, 10),
            Err(CameraError::DegenerateUp)
        );
        assert!(matches!(
            ok(Vec3::ZERO, Vec3::Z, Vec3::Y, 3.2, 10, 10),
            Err(CameraError::FieldOfView { .. })
        ));
        assert!(matches!(
            Camera::look_at(Vec3::ONE, Vec3::ONE, Vec3::Y, 1.0, 10, 10),
            Err(CameraError::DegenerateForward { .. })
        ));
    }

    #[test]
    fn basis_is_orthonormal_even_for_slanted_up() {
        let c = Camera::new(
            Vec3::ZERO,
            Vec3::new(1.0, 0.2, -3.0),
            Vec3::new(0.3, 1.0, 0.1),
            1.0,
            64,
            48,
        )
        .unwrap();
        for (a, b) in [
            (c.forward(), c.up()),
            (c.up(), c.right()),
            (c.right(), c.forward()),
        ] {
            assert!(a.dot(b).abs() < 1e-6);
        }
        for v in [c.forward(), c.up(), c.right()] {
            assert!((v.length() - 1.0).abs() < 1e-6);
        }
        assert!(c.up().dot(Vec3::Y) > 0.9, "up keeps its sense");
    }

    #[test]
    fn measures_match_hand_values() {
        let c = cam();
        // fov 90°: tan(45°) = 1, focal = 300 px.
        assert!((c.focal_length_px() - 300.0).abs() < 1e-3);
        assert!((c.pixels_per_unit(10.0) - 30.0).abs() < 1e-4);
        let p = Vec3::new(0.0, 0.0, -10.0);
        assert!((c.distance(p) - 10.0).abs() < 1e-6);
        assert!((c.depth(p) - 10.0).abs() < 1e-6);
        assert!((c.projected_size_px(p, 0.5) - 30.0).abs() < 1e-3);
        // Sideways 2 m/s at 10 m: 0.2 rad/s, 60 px/s.
        let v = Vec3::new(2.0, 0.0, 0.0);
        assert!((c.angular_speed(p, v) - 0.2).abs() < 1e-6);
        assert!((c.screen_speed_px(p, v) - 60.0).abs() < 1e-3);
        // Straight toward the eye: no angular motion.
        assert!(c.angular_speed(p, Vec3::new(0.0, 0.0, 5.0)).abs() < 1e-6);
        // Farther is smaller and slower.
        let far = Vec3::new(0.0, 0.0, -40.0);
        assert!(c.projected_size_px(far, 0.5) < c.projected_size_px(p, 0.5));
        assert!(c.angular_speed(far, v) < c.angular_speed(p, v));
        // On the eye: clamped, finite.
        assert!(c.angular_speed(Vec3::ZERO, v).is_finite());
        assert!(c.projected_size_px(Vec3::ZERO, 1.0).is_finite());
    }

    #[test]
    fn view_test_matches_frustum() {
        let c = cam();
        assert!(c.is_in_view(Vec3::new(0.0, 0.0, -1.0), 0.0));
        assert!(!c.is_in_view(Vec3::new(0.0, 0.0, 1.0), 0.0), "behind");
        // Horizontal half-extent at depth 1 is 4/3.
        assert!(c.is_in_view(Vec3::new(1.3, 0.0, -1.0), 0.0));
        assert!(!c.is_in_view(Vec3::new(1.4, 0.0, -1.0), 0.0));
        assert!(c.is_in_view(Vec3::new(1.4, 0.0, -1.0), 0.1));
        assert!(!c.is_in_view(Vec3::new(0.0, 1.05, -1.0), 0.0));
    }
}
