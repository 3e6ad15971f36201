//! Shape matching: the rotation that best maps a rest neighbourhood onto the current one.
//!
//! Given pairs (current offset `q_i`, rest offset `r_i`) of a node's neighbours relative to
//! the node, the best rotation maximises `Σ q_i · (R r_i)`, i.e. it is the rotational part
//! of the polar decomposition of the covariance `A = Σ q_i r_iᵀ`. We extract it with the
//! iteration of Müller et al. (2016, "A robust method to extract the rotational part of
//! deformations"): repeatedly rotate the current estimate by
//! `ω = Σ_k R_k × A_k / (|Σ_k R_k · A_k| + ε)` (columns `k`). It never leaves the rotation
//! group (no reflections, no SVD sign fixes) and is robust to rank deficiency: a planar rest
//! neighbourhood (cloth: rank 2) still determines the rotation fully; a collinear one
//! (rank 1) leaves the twist about that line at its starting value; an empty one returns
//! the start unchanged. The start is the caller's previous estimate, so it converges in one or
//! two iterations in steady use.

use glam::{Mat3, Quat, Vec3};

/// Maximum number of iterations.
const MAX_ITERATIONS: u32 = 24;
/// Stop when the correction angle (radians) drops below this.
const TOLERANCE: f32 = 1e-6;

/// Adds one pair to the covariance `Σ q rᵀ` of current offsets `q` and rest offsets `r`.
#[inline]
pub fn accumulate(a: &mut Mat3, current: Vec3, rest: Vec3) {
    a.x_axis += current * rest.x;
    a.y_axis += current * rest.y;
    a.z_axis += current * rest.z;
}

/// The rotation part of `a` (the best rotation mapping rest offsets onto current ones),
/// iterated from `start` (pass the previous estimate: one or two iterations in steady use).
pub fn rotation_of(a: &Mat3, start: Quat) -> Quat {
    let mut q = start;
    for _ in 0..MAX_ITERATIONS {
        let r = Mat3::from_quat(q);
        let num = r.x_axis.cross(a.x_axis) + r.y_axis.cross(a.y_axis) + r.z_axis.cross(a.z_axis);
        let den = (r.x_axis.dot(a.x_axis) + r.y_axis.dot(a.y_axis) + r.z_axis.dot(a.z_axis)).abs();
        let omega = num
            / (den
                + 1e-12
                    * (1.0
                        + a.x_axis.length_squared()
                        + a.y_axis.length_squared()
                        + a.z_axis.length_squared())
                    .sqrt());
        let angle = omega.length();
        if angle.is_nan() || angle < TOLERANCE {
            // Converged, or a degenerate (zero / non-finite) covariance: keep the estimate.
            break;
        }
        q = (Quat::from_axis_angle(omega / angle, angle) * q).normalize();
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(rest: &[Vec3], rot: Quat, start: Quat) -> Quat {
        let mut a = Mat3::ZERO;
        for &r in rest {
            accumulate(&mut a, rot * r * 1.1, r);
        }
        rotation_of(&a, start)
    }

    #[test]
    fn recovers_rotation_of_planar_neighbourhood() {
        let rest = [
            Vec3::X,
            Vec3::Z,
            -Vec3::X,
            -Vec3::Z,
            Vec3::new(1.0, 0.0, 1.0),
        ];
        for rot in [
            Quat::from_rotation_x(1.4),
            Quat::from_rotation_y(-2.5),
            Quat::from_euler(glam::EulerRot::XYZ, 0.3, 2.0, -1.0),
        ] {
            let q = fit(&rest, rot, Quat::IDENTITY);
            assert!(q.angle_between(rot) < 1e-4, "{q} vs {rot}");
        }
    }

    #[test]
    fn degenerate_neighbourhoods_stay_finite() {
        // Empty: the start comes back.
        let start = Quat::from_rotation_z(0.3);
        assert_eq!(rotation_of(&Mat3::ZERO, start), start);
        // Collinear: the rotation maps the line correctly, whatever the twist.
        let rot = Quat::from_rotation_z(0.8);
        let q = fit(&[Vec3::X, -Vec3::X * 2.0], rot, Quat::IDENTITY);
        assert!(q.is_finite());
        assert!((q * Vec3::X - rot * Vec3::X).length() < 1e-4);
        // All neighbours collapsed onto the node.
        let mut a = Mat3::ZERO;
        accumulate(&mut a, Vec3::ZERO, Vec3::X);
        assert!(rotation_of(&a, Quat::IDENTITY).is_finite());
        // NaN input does not poison the result.
        let mut a = Mat3::ZERO;
        accumulate(&mut a, Vec3::NAN, Vec3::X);
        assert!(rotation_of(&a, Quat::IDENTITY).is_finite());
    }
}
