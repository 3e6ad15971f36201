//! The View: the one description of who looks at the scene — a pinhole camera, the viewport it
//! renders to, a near plane and an optional light — and the view measures every crate uses:
//! distance, depth, pixels per world unit at a point, projected radius in pixels, angular and
//! on-screen speed, projection to pixel coordinates and the in-view tests.
//!
//! A host builds one `View` per frame and passes it to every system's `step`/`advance`; nothing
//! keeps a copy of it between frames. Built by [`View::new`] or [`View::look_at`] (with
//! [`View::with_near`] and [`View::with_light`] for the rest), which reject NaN, zero viewports,
//! degenerate directions and bad lights: afterwards every field is finite and the basis is
//! orthonormal, so the measures never need to check again.
//!
//! Units: positions and radii in world units (metres by convention, nothing here depends on it),
//! velocities in world units per second, angles in radians, sizes and speeds on screen in pixels
//! (per second) of the viewport.
//!
//! One convention for sizes, used everywhere: a small length `l` seen at a point `p` covers
//! `l · pixels_per_unit(p)` pixels, with `pixels_per_unit(p) = focal_px / depth(p)` — the exact
//! scale of the perspective projection for a length parallel to the image plane (a length along
//! the view ray projects shorter). Radii are radii, never diameters.

use glam::{Vec2, Vec3};

use crate::error::ViewError;
use crate::light::Light;

/// Distances below this (in world units) are treated as this distance, so that measures which
/// divide by a distance stay finite when a point sits on the eye. It is a guard, not a near
/// plane: at 0.1 mm nothing rendered is meaningful anyway.
pub const MIN_VIEW_DISTANCE: f32 = 1.0e-4;

/// The near plane a [`View`] gets unless [`View::with_near`] sets another, in world units: 1 cm,
/// a common game-engine value for scenes measured in metres.
pub const DEFAULT_NEAR: f32 = 0.01;

/// A validated view: camera pose, vertical field of view, viewport in pixels, near plane and an
/// optional light (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    position: Vec3,
    forward: Vec3,
    up: Vec3,
    right: Vec3,
    fov_y_radians: f32,
    width_px: u32,
    height_px: u32,
    near: f32,
    tan_half_fov_y: f32,
    tan_half_fov_x: f32,
    /// `1 / sqrt(1 + tan²)` of each half-angle: turns a side-plane test into a distance.
    cos_half_fov_x: f32,
    cos_half_fov_y: f32,
    focal_px: f32,
    light: Option<Light>,
}

impl Default for View {
    /// A 1920 × 1080 view with a 60° vertical field of view at the origin, looking along −Z
    /// with +Y up, near plane [`DEFAULT_NEAR`], no light: what a host gets before it sets its
    /// own camera.
    fn default() -> Self {
        View::new(
            Vec3::ZERO,
            Vec3::NEG_Z,
            Vec3::Y,
            60f32.to_radians(),
            1920,
            1080,
        )
        .expect("the default view is valid")
    }
}

impl View {
    /// A view from `position` along `forward`, with `up` giving the image's vertical (it need not
    /// be orthogonal to `forward`, only not parallel), a vertical field of view of
    /// `fov_y_radians` in (0, π) and a viewport of `width_px` × `height_px` pixels. Near plane
    /// [`DEFAULT_NEAR`], no light.
    pub fn new(
        position: Vec3,
        forward: Vec3,
        up: Vec3,
        fov_y_radians: f32,
        width_px: u32,
        height_px: u32,
    ) -> Result<Self, ViewError> {
        if !(position.is_finite()
            && forward.is_finite()
            && up.is_finite()
            && fov_y_radians.is_finite())
        {
            return Err(ViewError::NonFinite);
        }
        if width_px == 0 || height_px == 0 {
            return Err(ViewError::ZeroViewport {
                width: width_px,
                height: height_px,
            });
        }
        if !(fov_y_radians > 0.0 && fov_y_radians < std::f32::consts::PI) {
            return Err(ViewError::FieldOfView { fov_y_radians });
        }
        let length = forward.length();
        // Relative to nothing: a forward vector this short has lost its direction to rounding.
        if !length.is_finite() || length <= 1.0e-6 {
            return Err(ViewError::DegenerateForward { length });
        }
        let forward = forward / length;
        let right = forward.cross(up);
        let up_len = up.length();
        // sin(angle between up and forward) below ~1e-4 leaves no usable image orientation.
        if up_len <= 1.0e-6 || right.length() <= 1.0e-4 * up_len {
            return Err(ViewError::DegenerateUp);
        }
        let right = right.normalize();
        let up = right.cross(forward);
        let tan_half_fov_y = (0.5 * fov_y_radians).tan();
        let aspect = width_px as f32 / height_px as f32;
        let tan_half_fov_x = tan_half_fov_y * aspect;
        Ok(Self {
            position,
            forward,
            up,
            right,
            fov_y_radians,
            width_px,
            height_px,
            near: DEFAULT_NEAR,
            tan_half_fov_y,
            tan_half_fov_x,
            cos_half_fov_x: 1.0 / (1.0 + tan_half_fov_x * tan_half_fov_x).sqrt(),
            cos_half_fov_y: 1.0 / (1.0 + tan_half_fov_y * tan_half_fov_y).sqrt(),
            focal_px: 0.5 * height_px as f32 / tan_half_fov_y,
            light: None,
        })
    }

    /// A view from `eye` looking at `target`; see [`View::new`]. `eye == target` is a degenerate
    /// forward direction.
    pub fn look_at(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov_y_radians: f32,
        width_px: u32,
        height_px: u32,
    ) -> Result<Self, ViewError> {
        Self::new(eye, target - eye, up, fov_y_radians, width_px, height_px)
    }

    /// The same view with its near plane at `near` world units (finite, > 0): nothing nearer is
    /// visible.
    pub fn with_near(mut self, near: f32) -> Result<Self, ViewError> {
        if !(near.is_finite() && near > 0.0) {
            return Err(ViewError::NearPlane { near });
        }
        self.near = near;
        Ok(self)
    }

    /// The same view lit by `light` (or unlit with `None`); the light is validated.
    pub fn with_light(mut self, light: Option<Light>) -> Result<Self, ViewError> {
        if let Some(l) = &light {
            l.validate().map_err(ViewError::Light)?;
        }
        self.light = light;
        Ok(self)
    }

    /// The same view with its viewport resized to `width_px` × `height_px` (the field of view
    /// stays vertical, so a wider viewport sees more to the sides).
    pub fn with_viewport(self, width_px: u32, height_px: u32) -> Result<Self, ViewError> {
        let light = self.light;
        let near = self.near;
        let mut v = View::new(
            self.position,
            self.forward,
            self.up,
            self.fov_y_radians,
            width_px,
            height_px,
        )?;
        v.near = near;
        v.light = light;
        Ok(v)
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

    /// Unit image-up direction, orthogonal to [`View::forward`].
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

    /// The near plane's distance along the view direction, world units.
    #[inline]
    pub fn near(&self) -> f32 {
        self.near
    }

    /// The light, if the view has one.
    #[inline]
    pub fn light(&self) -> Option<&Light> {
        self.light.as_ref()
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

    /// Focal length in pixels: pixels per world unit at depth 1, `(height / 2) / tan(fov_y / 2)`.
    #[inline]
    pub fn focal_length_px(&self) -> f32 {
        self.focal_px
    }

    /// Euclidean distance from the eye to `point`, world units.
    #[inline]
    pub fn distance(&self, point: Vec3) -> f32 {
        (point - self.position).length()
    }

    /// Depth of `point` along the view direction (negative behind the eye), world units.
    #[inline]
    pub fn depth(&self, point: Vec3) -> f32 {
        (point - self.position).dot(self.forward)
    }

    /// Pixels covered by one world unit at `point`, laid parallel to the image plane:
    /// `focal_px / depth`. A point nearer than the near plane (beside or behind the eye) counts
    /// at its distance from the eye (at least the near plane): what it would cover if the camera
    /// turned to face it. Clamping its depth to the near plane instead gave everything behind
    /// the camera the largest scale of all (11,600 px/m on a 1080-px, 50° view at 10 cm), and
    /// a world budget spent most of its nodes on cloths the camera had passed. The value is
    /// finite and positive for every point; whether the point is seen at all is
    /// [`View::is_in_view`]'s question.
    #[inline]
    pub fn pixels_per_unit(&self, point: Vec3) -> f32 {
        let depth = self.depth(point);
        let seen_at = if depth >= self.near {
            depth
        } else {
            self.distance(point).max(self.near)
        };
        self.focal_px / seen_at
    }

    /// Whether any part of a sphere of `radius` (negative counts as 0) centred at `centre` lies
    /// inside the view frustum (beyond the near plane, within the four side planes).
    #[inline]
    pub fn sphere_in_view(&self, centre: Vec3, radius: f32) -> bool {
        let r = radius.max(0.0);
        let ray = centre - self.position;
        let depth = ray.dot(self.forward);
        // Distance of the centre outside each side plane: (|lateral| − depth·tan)·cos.
        let out_x = (ray.dot(self.right).abs() - depth * self.tan_half_fov_x) * self.cos_half_fov_x;
        let out_y = (ray.dot(self.up).abs() - depth * self.tan_half_fov_y) * self.cos_half_fov_y;
        depth + r >= self.near && out_x <= r && out_y <= r
    }

    /// Projected radius in pixels of a sphere of `radius` centred at `centre`: `radius ·
    /// pixels_per_unit(centre)` (depth clamped to the near plane), and 0 when no part of it is
    /// in view. The small-angle formula: within 1% of the exact on-axis value while the sphere
    /// is smaller than a tenth of its distance, monotone in depth.
    #[inline]
    pub fn projected_radius_px(&self, centre: Vec3, radius: f32) -> f32 {
        if self.sphere_in_view(centre, radius) {
            radius.max(0.0) * self.pixels_per_unit(centre)
        } else {
            0.0
        }
    }

    /// Pixels per world unit at the point of a sphere nearest the eye, `focal_px / (depth −
    /// radius)` clamped to the near plane, and 0 when no part of it is in view: the largest
    /// scale anything inside the sphere can be seen at.
    #[inline]
    pub fn max_pixels_per_unit(&self, centre: Vec3, radius: f32) -> f32 {
        if self.sphere_in_view(centre, radius) {
            self.focal_px / (self.depth(centre) - radius.max(0.0)).max(self.near)
        } else {
            0.0
        }
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

    /// The same motion as [`View::angular_speed`], in pixels per second on screen (angular speed
    /// × focal length; the on-axis measure).
    #[inline]
    pub fn screen_speed_px(&self, position: Vec3, velocity: Vec3) -> f32 {
        self.angular_speed(position, velocity) * self.focal_px
    }

    /// Whether `point` lies beyond the near plane and inside the image, widened by `margin` (a
    /// fraction of the half-extent on each side: 0.1 accepts points up to 10% outside; negative
    /// counts as 0).
    #[inline]
    pub fn is_in_view(&self, point: Vec3, margin: f32) -> bool {
        let ray = point - self.position;
        let depth = ray.dot(self.forward);
        let widen = 1.0 + margin.max(0.0);
        depth >= self.near
            && ray.dot(self.right).abs() <= depth * self.tan_half_fov_x * widen
            && ray.dot(self.up).abs() <= depth * self.tan_half_fov_y * widen
    }

    /// Where `point` lands in the viewport, in pixels from the top-left corner (x to the right,
    /// y down; the image spans `[0, width] × [0, height]`), or `None` if it is nearer than the
    /// near plane or behind the eye. Points outside the image still get coordinates (outside
    /// that range), so errors of vertices leaving the frame stay measurable.
    #[inline]
    pub fn project(&self, point: Vec3) -> Option<Vec2> {
        let ray = point - self.position;
        let depth = ray.dot(self.forward);
        if depth < self.near {
            return None;
        }
        let s = self.focal_px / depth;
        Some(Vec2::new(
            0.5 * self.width_px as f32 + s * ray.dot(self.right),
            0.5 * self.height_px as f32 - s * ray.dot(self.up),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_PI_2;

    fn view() -> View {
        View::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, FRAC_PI_2, 800, 600).unwrap()
    }

    #[test]
    fn rejects_bad_input() {
        let ok = |p, f, u, fov, w, h| View::new(p, f, u, fov, w, h);
        assert_eq!(
            ok(Vec3::NAN, Vec3::Z, Vec3::Y, 1.0, 10, 10),
            Err(ViewError::NonFinite)
        );
        assert_eq!(
            ok(Vec3::ZERO, Vec3::Z, Vec3::Y, f32::NAN, 10, 10),
            Err(ViewError::NonFinite)
        );
        assert!(matches!(
            ok(Vec3::ZERO, Vec3::Z, Vec3::Y, 1.0, 0, 10),
            Err(ViewError::ZeroViewport { .. })
        ));
        assert!(matches!(
            ok(Vec3::ZERO, Vec3::ZERO, Vec3::Y, 1.0, 10, 10),
            Err(ViewError::DegenerateForward { .. })
        ));
        assert_eq!(
            ok(Vec3::ZERO, Vec3::Y, Vec3::Y * 3.0, 1.0, 10, 10),
            Err(ViewError::DegenerateUp)
        );
        assert!(matches!(
            ok(Vec3::ZERO, Vec3::Z, Vec3::Y, 3.2, 10, 10),
            Err(ViewError::FieldOfView { .. })
        ));
        assert!(matches!(
            View::look_at(Vec3::ONE, Vec3::ONE, Vec3::Y, 1.0, 10, 10),
            Err(ViewError::DegenerateForward { .. })
        ));
        for near in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                view().with_near(near),
                Err(ViewError::NearPlane { .. })
            ));
        }
        let too_bright = Light::directional(Vec3::Y, 0.6, 0.6);
        assert!(matches!(
            view().with_light(Some(too_bright)),
            Err(ViewError::Light(_))
        ));
        let lit = view()
            .with_light(Some(Light::directional(Vec3::Y, 0.2, 0.8)))
            .unwrap();
        assert!(lit.light().is_some());
        assert!(View::default().light().is_none());
    }

    #[test]
    fn basis_is_orthonormal_even_for_slanted_up() {
        let c = View::new(
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
        let c = view();
        // fov 90°: tan(45°) = 1, focal = 300 px.
        assert!((c.focal_length_px() - 300.0).abs() < 1e-3);
        let p = Vec3::new(0.0, 0.0, -10.0);
        assert!((c.pixels_per_unit(p) - 30.0).abs() < 1e-4);
        // Off axis the depth, not the distance, sets the scale.
        assert!((c.pixels_per_unit(Vec3::new(3.0, 0.0, -10.0)) - 30.0).abs() < 1e-4);
        // Behind the eye the distance does: 10 m behind is as small as 10 m ahead, not as
        // large as the near plane.
        assert!((c.pixels_per_unit(Vec3::new(0.0, 0.0, 10.0)) - 30.0).abs() < 1e-4);
        assert!((c.pixels_per_unit(Vec3::new(6.0, 0.0, 8.0)) - 30.0).abs() < 1e-4);
        assert!((c.distance(p) - 10.0).abs() < 1e-6);
        assert!((c.depth(p) - 10.0).abs() < 1e-6);
        assert!((c.projected_radius_px(p, 0.5) - 15.0).abs() < 1e-3);
        // Sideways 2 m/s at 10 m: 0.2 rad/s, 60 px/s.
        let v = Vec3::new(2.0, 0.0, 0.0);
        assert!((c.angular_speed(p, v) - 0.2).abs() < 1e-6);
        assert!((c.screen_speed_px(p, v) - 60.0).abs() < 1e-3);
        // Straight toward the eye: no angular motion.
        assert!(c.angular_speed(p, Vec3::new(0.0, 0.0, 5.0)).abs() < 1e-6);
        // Farther is smaller and slower.
        let far = Vec3::new(0.0, 0.0, -40.0);
        assert!(c.projected_radius_px(far, 0.5) < c.projected_radius_px(p, 0.5));
        assert!(c.angular_speed(far, v) < c.angular_speed(p, v));
        // On the eye: clamped, finite.
        assert!(c.angular_speed(Vec3::ZERO, v).is_finite());
        assert!(c.pixels_per_unit(Vec3::ZERO).is_finite());
        // The nearest point of a sphere is seen larger than its centre.
        assert!((c.max_pixels_per_unit(p, 2.0) - 300.0 / 8.0).abs() < 1e-3);
    }

    #[test]
    fn projection_lands_where_the_frustum_says() {
        let c = view();
        let centre = c.project(Vec3::new(0.0, 0.0, -5.0)).unwrap();
        assert!((centre - Vec2::new(400.0, 300.0)).length() < 1e-3);
        // Right edge at depth 1 is x = 4/3 (aspect 800/600, tan 45° = 1).
        let edge = c.project(Vec3::new(4.0 / 3.0, 1.0, -1.0)).unwrap();
        assert!((edge - Vec2::new(800.0, 0.0)).length() < 1e-2);
        assert!(c.project(Vec3::new(0.0, 0.0, 1.0)).is_none(), "behind");
        assert!(
            c.project(Vec3::new(0.0, 0.0, -0.005)).is_none(),
            "nearer than near"
        );
        // One unit sideways at depth 10 moves 30 px: the same scale as pixels_per_unit.
        let a = c.project(Vec3::new(0.0, 0.0, -10.0)).unwrap();
        let b = c.project(Vec3::new(1.0, 0.0, -10.0)).unwrap();
        assert!(((b - a).length() - c.pixels_per_unit(Vec3::new(0.0, 0.0, -10.0))).abs() < 1e-3);
    }

    #[test]
    fn view_tests_match_frustum() {
        let c = view();
        assert!(c.is_in_view(Vec3::new(0.0, 0.0, -1.0), 0.0));
        assert!(!c.is_in_view(Vec3::new(0.0, 0.0, 1.0), 0.0), "behind");
        // Horizontal half-extent at depth 1 is 4/3.
        assert!(c.is_in_view(Vec3::new(1.3, 0.0, -1.0), 0.0));
        assert!(!c.is_in_view(Vec3::new(1.4, 0.0, -1.0), 0.0));
        assert!(c.is_in_view(Vec3::new(1.4, 0.0, -1.0), 0.1));
        assert!(!c.is_in_view(Vec3::new(0.0, 1.05, -1.0), 0.0));
        // Spheres: a centre outside that reaches in counts, one that does not, does not.
        let out = Vec3::new(15.0, 0.0, -10.0); // half-extent at depth 10 is 13.3
        assert!(!c.sphere_in_view(out, 0.5));
        assert!(c.sphere_in_view(out, 2.0));
        assert_eq!(c.projected_radius_px(Vec3::new(30.0, 0.0, -10.0), 2.0), 0.0);
        assert!(!c.sphere_in_view(Vec3::new(0.0, 0.0, 5.0), 1.0), "behind");
        assert!(
            c.sphere_in_view(Vec3::new(0.0, 0.0, 0.5), 1.0),
            "straddles the eye"
        );
    }
}
