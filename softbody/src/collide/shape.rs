//! Collider shapes and their rigid transforms: signed distance and outward normal of a point
//! in the shape's own frame, and the shape's bounds, for the contact pass and the penetration
//! measure.
//!
//! The distance functions are the standard closed forms (sphere, segment-swept sphere for the
//! capsule, the box distance of Quílez, "distance functions", 2008; an infinite plane).

use glam::{Quat, Vec3, Vec3A};

/// The geometry of a collider in its own frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// The infinite half-space below the plane through the origin with normal +Y (the cloth
    /// stays on the +Y side).
    Plane,
    /// A sphere of `radius` around the origin.
    Sphere {
        /// Radius in metres (> 0).
        radius: f32,
    },
    /// The points within `radius` of the segment from `(0, -half_length, 0)` to
    /// `(0, half_length, 0)`.
    Capsule {
        /// Radius in metres (> 0).
        radius: f32,
        /// Half the length of the axis segment, in metres (>= 0).
        half_length: f32,
    },
    /// The box `|x| <= half_extents` (componentwise).
    Box {
        /// Half the size along each local axis, in metres (each > 0).
        half_extents: Vec3,
    },
}

impl Shape {
    /// Checks the dimensions: finite, radii and half extents positive, half length not negative.
    pub(crate) fn validate(&self) -> Result<(), &'static str> {
        let ok = match *self {
            Shape::Plane => true,
            Shape::Sphere { radius } => radius.is_finite() && radius > 0.0,
            Shape::Capsule {
                radius,
                half_length,
            } => {
                radius.is_finite() && radius > 0.0 && half_length.is_finite() && half_length >= 0.0
            }
            Shape::Box { half_extents } => {
                half_extents.is_finite() && half_extents.min_element() > 0.0
            }
        };
        if ok {
            Ok(())
        } else {
            Err("collider dimensions must be finite and positive")
        }
    }

    /// Signed distance of `p` (in the shape's frame) to the surface, negative inside, and the
    /// outward unit normal at the closest surface point.
    #[inline]
    pub fn distance(&self, p: Vec3A) -> (f32, Vec3A) {
        match *self {
            Shape::Plane => (p.y, Vec3A::Y),
            Shape::Sphere { radius } => {
                let l = p.length();
                let n = if l > 1e-12 { p / l } else { Vec3A::Y };
                (l - radius, n)
            }
            Shape::Capsule {
                radius,
                half_length,
            } => {
                let q = Vec3A::new(0.0, p.y.clamp(-half_length, half_length), 0.0);
                let d = p - q;
                let l = d.length();
                let n = if l > 1e-12 { d / l } else { Vec3A::X };
                (l - radius, n)
            }
            Shape::Box { half_extents } => {
                let e = Vec3A::from(half_extents);
                let q = p.abs() - e;
                let outside = q.max(Vec3A::ZERO);
                let lo = outside.length();
                if lo > 0.0 {
                    (lo, (outside * p.signum()) / lo)
                } else {
                    // Inside: the nearest face.
                    let m = q.max_element();
                    let axis = if q.x == m {
                        Vec3A::X * p.x.signum()
                    } else if q.y == m {
                        Vec3A::Y * p.y.signum()
                    } else {
                        Vec3A::Z * p.z.signum()
                    };
                    (m, axis)
                }
            }
        }
    }

    /// Half size of the shape's axis-aligned bounds in its own frame (infinite for a plane).
    fn local_half_size(&self) -> Vec3A {
        match *self {
            Shape::Plane => Vec3A::splat(f32::INFINITY),
            Shape::Sphere { radius } => Vec3A::splat(radius),
            Shape::Capsule {
                radius,
                half_length,
            } => Vec3A::new(radius, radius + half_length, radius),
            Shape::Box { half_extents } => half_extents.into(),
        }
    }

    /// World-space bounds `(min, max)` of the shape placed by `t`, grown by `margin`.
    pub(crate) fn bounds(&self, t: &Transform, margin: f32) -> (Vec3A, Vec3A) {
        if matches!(self, Shape::Plane) {
            // The half-space: unbounded except in the direction its normal points away from.
            let n = Vec3A::from(t.rotation * Vec3::Y);
            let mut lo = Vec3A::splat(f32::NEG_INFINITY);
            let mut hi = Vec3A::splat(f32::INFINITY);
            let p = Vec3A::from(t.position);
            // A plane whose normal is an axis bounds that axis on one side.
            for k in 0..3 {
                if n[k] > 1.0 - 1e-6 {
                    hi[k] = p[k] + margin;
                } else if n[k] < -1.0 + 1e-6 {
                    lo[k] = p[k] - margin;
                }
            }
            return (lo, hi);
        }
        let m = glam::Mat3A::from_quat(t.rotation);
        let h = self.local_half_size();
        // |R| h: the half size of the rotated box.
        let half = Vec3A::new(
            m.row(0).abs().dot(h),
            m.row(1).abs().dot(h),
            m.row(2).abs().dot(h),
        ) + Vec3A::splat(margin);
        let c = Vec3A::from(t.position);
        (c - half, c + half)
    }
}

/// A rigid placement: rotate, then translate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Where the shape's origin is, in world space.
    pub position: Vec3,
    /// The shape's orientation (unit quaternion).
    pub rotation: Quat,
}

impl Default for Transform {
    fn default() -> Self {
        Transform::IDENTITY
    }
}

impl Transform {
    /// No rotation, at the origin.
    pub const IDENTITY: Transform = Transform {
        position: Vec3::ZERO,
        rotation: Quat::IDENTITY,
    };

    /// A translation only.
    pub fn from_position(position: Vec3) -> Self {
        Transform {
            position,
            rotation: Quat::IDENTITY,
        }
    }

    /// The frame of a [`Shape::Plane`] through `point` with unit-length `normal` (normalised here).
    pub fn plane(point: Vec3, normal: Vec3) -> Self {
        Transform {
            position: point,
            rotation: Quat::from_rotation_arc(Vec3::Y, normal.normalize_or(Vec3::Y)),
        }
    }

    /// Finite, with a rotation of length 1 (within 1e-3).
    pub(crate) fn is_valid(&self) -> bool {
        self.position.is_finite()
            && self.rotation.is_finite()
            && (self.rotation.length() - 1.0).abs() < 1e-3
    }

    /// The transform a fraction `t` of the way from `self` to `other` (lerp and slerp).
    #[inline]
    pub(crate) fn lerp(&self, other: &Transform, t: f32) -> Transform {
        Transform {
            position: self.position.lerp(other.position, t),
            rotation: self.rotation.slerp(other.rotation, t),
        }
    }

    /// World point of a local point.
    #[inline]
    pub fn apply(&self, p: Vec3A) -> Vec3A {
        Vec3A::from(self.rotation * Vec3::from(p)) + Vec3A::from(self.position)
    }

    /// Local point of a world point.
    #[inline]
    pub fn inverse_apply(&self, p: Vec3A) -> Vec3A {
        Vec3A::from(self.rotation.conjugate() * Vec3::from(p - Vec3A::from(self.position)))
    }

    /// A world direction in the local frame.
    #[inline]
    pub fn inverse_rotate(&self, d: Vec3A) -> Vec3A {
        Vec3A::from(self.rotation.conjugate() * Vec3::from(d))
    }

    /// A local direction in world space.
    #[inline]
    pub fn rotate(&self, d: Vec3A) -> Vec3A {
        Vec3A::from(self.rotation * Vec3::from(d))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_and_normals() {
        let s = Shape::Sphere { radius: 1.0 };
        let (d, n) = s.distance(Vec3A::new(0.0, 2.0, 0.0));
        assert!((d - 1.0).abs() < 1e-6 && n.abs_diff_eq(Vec3A::Y, 1e-6));
        let c = Shape::Capsule {
            radius: 0.5,
            half_length: 1.0,
        };
        let (d, n) = c.distance(Vec3A::new(0.0, 3.0, 0.0));
        assert!((d - 1.5).abs() < 1e-6 && n.abs_diff_eq(Vec3A::Y, 1e-6));
        let (d, n) = c.distance(Vec3A::new(0.2, 0.3, 0.0));
        assert!((d + 0.3).abs() < 1e-6 && n.abs_diff_eq(Vec3A::X, 1e-6));
        let b = Shape::Box {
            half_extents: Vec3::new(1.0, 2.0, 3.0),
        };
        let (d, n) = b.distance(Vec3A::new(0.0, 0.0, 2.5));
        assert!((d + 0.5).abs() < 1e-6 && n.abs_diff_eq(Vec3A::Z, 1e-6));
        let (d, _) = b.distance(Vec3A::new(4.0, 6.0, 0.0));
        assert!((d - 5.0).abs() < 1e-5);
        assert!(Shape::Sphere { radius: -1.0 }.validate().is_err());
        assert!(
            Shape::Box {
                half_extents: Vec3::new(1.0, f32::NAN, 1.0)
            }
            .validate()
            .is_err()
        );
    }

    #[test]
    fn bounds_cover_the_rotated_shape() {
        let t = Transform {
            position: Vec3::new(1.0, 0.0, 0.0),
            rotation: Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
        };
        let c = Shape::Capsule {
            radius: 0.5,
            half_length: 1.0,
        };
        let (lo, hi) = c.bounds(&t, 0.0);
        // The axis now lies along x.
        assert!((hi.x - 2.5).abs() < 1e-5 && (lo.x + 0.5).abs() < 1e-5);
        assert!((hi.y - 0.5).abs() < 1e-5);
        let (lo, hi) = Shape::Plane.bounds(&Transform::plane(Vec3::Y, Vec3::Y), 0.1);
        assert!(lo.y.is_infinite() && (hi.y - 1.1).abs() < 1e-6);
    }
}
