//! Bone transforms and the small amount of quaternion and matrix math the sampler needs:
//! shortest-path interpolation, the angle between two rotations, and parent × local concatenation.

use glam::{Affine3A, Mat3A, Mat4, Quat, Vec3, Vec3A, Vec4};

/// A bone's local transform as translation, rotation and scale (applied scale first, then
/// rotation, then translation: the glTF convention).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Translation relative to the parent bone.
    pub translation: Vec3,
    /// Rotation relative to the parent bone (unit quaternion).
    pub rotation: Quat,
    /// Scale along the bone's own axes.
    pub scale: Vec3,
}

impl Transform {
    /// The identity transform.
    pub const IDENTITY: Transform = Transform {
        translation: Vec3::ZERO,
        rotation: Quat::IDENTITY,
        scale: Vec3::ONE,
    };

    /// The transform as an affine matrix (scale, then rotation, then translation), with
    /// denormal-prone tiny rotation components flushed to zero (products of values like 4e-25
    /// down the hierarchy would otherwise hit x86's slow denormal path).
    #[inline]
    pub fn to_affine(&self) -> Affine3A {
        compose(self.scale.into(), self.rotation, self.translation.into())
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.translation.is_finite() && self.rotation.is_finite() && self.scale.is_finite()
    }
}

impl Default for Transform {
    fn default() -> Self {
        Transform::IDENTITY
    }
}

/// `q` or `-q`, whichever lies in the same hemisphere as `reference` (non-negative dot product).
/// Both describe the same rotation; interpolating between keys in one hemisphere takes the short
/// arc.
#[inline]
pub(crate) fn align_hemisphere(reference: Quat, q: Quat) -> Quat {
    if reference.dot(q) < 0.0 { -q } else { q }
}

/// The angle in radians (in `[0, π]`) of the rotation that takes `a` to `b`, treating `q` and `-q`
/// as the same rotation.
///
/// Computed as `4·atan2(|a − b|, |a + b|)` on hemisphere-aligned unit quaternions, which stays
/// accurate for tiny angles where `2·acos(dot)` loses everything to rounding (`acos` of a dot
/// product within one ulp of 1 is already 3e-4 rad).
#[inline]
pub(crate) fn rotation_angle(a: Quat, b: Quat) -> f32 {
    let b = align_hemisphere(a, b);
    let a = Vec4::from(a);
    let b = Vec4::from(b);
    4.0 * (a - b).length().atan2((a + b).length())
}

/// Shortest-path interpolation of two unit quaternions already in the same hemisphere, with the
/// accuracy of slerp at the cost of a normalised lerp.
///
/// A plain normalised lerp moves at uneven angular speed (too slow near the ends, too fast in the
/// middle); the parameter is corrected with the cubic `t' = t + t(t − ½)(t − 1)·k(d)` where `k`
/// depends on the cosine `d` between the keys (A. Kapoulkine, "Approximating slerp", 2015). The
/// test `onlerp_matches_slerp` bounds the deviation from slerp.
#[inline]
pub(crate) fn interpolate_rotation(a: Quat, b: Quat, t: f32) -> Quat {
    let av = Vec4::from(a);
    let bv = Vec4::from(b);
    let d = av.dot(bv).abs();
    let ka = 1.0904 + d * (-3.2452 + d * (3.55645 - d * 1.43519));
    let kb = 0.848013 + d * (-1.06021 + d * 0.215638);
    let c = t - 0.5;
    let k = ka * c * c + kb;
    let ot = t + t * c * (t - 1.0) * k;
    let v = av + (bv - av) * ot;
    Quat::from_vec4(v * v.length_recip())
}

/// Quaternion components below this magnitude are set to zero before a rotation becomes a
/// matrix. Real clips hold components like 4e-25; multiplied together down the hierarchy they
/// produce denormal floats, which x86 handles in microcode at ~100 cycles per operation (this
/// alone once doubled the cost of the model-space pass on a real rig). A component of 1e-6 moves
/// a point by at most 2e-6 of its distance to the joint, far below anything visible.
const TINY_COMPONENT: f32 = 1e-6;

/// A local matrix from scale, rotation (unit) and translation, flushing tiny rotation components
/// to zero so that model-space products stay clear of denormals.
#[inline]
pub(crate) fn compose(scale: Vec3A, rotation: Quat, translation: Vec3A) -> Affine3A {
    let q = Vec4::from(rotation);
    let q = Vec4::select(q.abs().cmplt(Vec4::splat(TINY_COMPONENT)), Vec4::ZERO, q);
    Affine3A::from_scale_rotation_translation(scale.into(), Quat::from_vec4(q), translation.into())
}

/// [`compose`] for four bones at once: the rotations are transposed into lanes (`x` of the four,
/// `y` of the four, …) and composed by [`compose_lanes`].
#[inline]
pub(crate) fn compose4(
    scale: [Vec3A; 4],
    rotation: [Quat; 4],
    translation: [Vec3A; 4],
) -> [Affine3A; 4] {
    let [q0, q1, q2, q3] = rotation.map(Vec4::from);
    let q = Mat4::from_cols(q0, q1, q2, q3).transpose();
    compose_lanes(scale, [q.x_axis, q.y_axis, q.z_axis, q.w_axis], translation)
}

/// [`compose`] for four bones whose rotations are given in lanes (`q[0]` the `x` of the four,
/// `q[1]` the `y`, …): the quaternion-to-matrix products run as vertical vector arithmetic and
/// the columns are transposed back. The same formulas as glam's
/// `Affine3A::from_scale_rotation_translation`, term for term, and the same flush of tiny
/// components.
#[inline(always)]
pub(crate) fn compose_lanes(
    scale: [Vec3A; 4],
    q: [Vec4; 4],
    translation: [Vec3A; 4],
) -> [Affine3A; 4] {
    let flush = |v: Vec4| Vec4::select(v.abs().cmplt(Vec4::splat(TINY_COMPONENT)), Vec4::ZERO, v);
    let [x, y, z, w] = q.map(flush);
    let [s0, s1, s2, s3] = scale.map(|s| s.extend(0.0));
    let s = Mat4::from_cols(s0, s1, s2, s3).transpose();
    let (x2, y2, z2) = (x + x, y + y, z + z);
    let (xx, xy, xz) = (x * x2, x * y2, x * z2);
    let (yy, yz, zz) = (y * y2, y * z2, z * z2);
    let (wx, wy, wz) = (w * x2, w * y2, w * z2);
    let one = Vec4::ONE;
    let columns = |a: Vec4, b: Vec4, c: Vec4, k: Vec4| {
        Mat4::from_cols(a * k, b * k, c * k, Vec4::ZERO).transpose()
    };
    let cx = columns(one - (yy + zz), xy + wz, xz - wy, s.x_axis);
    let cy = columns(xy - wz, one - (xx + zz), yz + wx, s.y_axis);
    let cz = columns(xz + wy, yz - wx, one - (xx + yy), s.z_axis);
    std::array::from_fn(|i| Affine3A {
        matrix3: Mat3A::from_cols(
            Vec3A::from_vec4(cx.col(i)),
            Vec3A::from_vec4(cy.col(i)),
            Vec3A::from_vec4(cz.col(i)),
        ),
        translation: translation[i],
    })
}

/// `parent × local` for a 4×4 parent and an affine local transform (its last row is `0 0 0 1`),
/// using 12 multiply-adds of 4-lane vectors instead of the 16 of a full 4×4 product.
#[inline]
pub(crate) fn concat(parent: &Mat4, local: &Affine3A) -> Mat4 {
    #[inline(always)]
    fn col(p: &Mat4, v: Vec3A) -> Vec4 {
        p.x_axis * v.x + p.y_axis * v.y + p.z_axis * v.z
    }
    let m = &local.matrix3;
    Mat4::from_cols(
        col(parent, m.x_axis),
        col(parent, m.y_axis),
        col(parent, m.z_axis),
        col(parent, local.translation) + parent.w_axis,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uniform draw in [0, 1) from the project's seeded generator (PCG-64 MCG).
    fn lcg(state: &mut rand_pcg::Pcg64Mcg) -> f32 {
        (rand_core::RngCore::next_u32(state) >> 8) as f32 / (1u32 << 24) as f32
    }

    fn random_quat(s: &mut rand_pcg::Pcg64Mcg) -> Quat {
        let axis = Vec3::new(lcg(s) - 0.5, lcg(s) - 0.5, lcg(s) - 0.5).normalize_or(Vec3::X);
        Quat::from_axis_angle(axis, lcg(s) * std::f32::consts::TAU)
    }

    #[test]
    fn onlerp_matches_slerp() {
        // Over random key pairs up to 180° apart, the corrected lerp stays within 2e-3 rad of
        // slerp; for pairs up to 30° apart (real clips at 24–30 keys/s) within 1e-4 rad.
        let mut s: rand_pcg::Pcg64Mcg = rand_core::SeedableRng::seed_from_u64(7);
        let mut worst_any = 0.0f32;
        let mut worst_small = 0.0f32;
        for i in 0..4000 {
            let a = random_quat(&mut s);
            let b = if i % 2 == 0 {
                align_hemisphere(a, random_quat(&mut s))
            } else {
                let axis = Vec3::new(lcg(&mut s) - 0.5, lcg(&mut s) - 0.5, lcg(&mut s) - 0.5)
                    .normalize_or(Vec3::Y);
                align_hemisphere(a, a * Quat::from_axis_angle(axis, lcg(&mut s) * 0.52))
            };
            let big = rotation_angle(a, b) > 0.53;
            for k in 0..=16 {
                let t = k as f32 / 16.0;
                let e = rotation_angle(interpolate_rotation(a, b, t), a.slerp(b, t));
                if big {
                    worst_any = worst_any.max(e);
                } else {
                    worst_small = worst_small.max(e);
                }
            }
        }
        assert!(worst_any < 2e-3, "worst deviation {worst_any}");
        assert!(
            worst_small < 1e-4,
            "worst small-angle deviation {worst_small}"
        );
    }

    #[test]
    fn q_and_minus_q_are_the_same_rotation() {
        let q = Quat::from_rotation_y(0.7);
        assert!(rotation_angle(q, -q) < 1e-6);
        assert!((rotation_angle(Quat::IDENTITY, Quat::from_rotation_x(0.3)) - 0.3).abs() < 1e-5);
        assert!((rotation_angle(Quat::IDENTITY, Quat::from_rotation_x(3.0)) - 3.0).abs() < 1e-4);
        // A tiny angle is still resolved (2·acos would return 0 or 3e-4 here).
        let tiny = rotation_angle(q, q * Quat::from_rotation_z(1e-5));
        assert!((tiny - 1e-5).abs() < 2e-6, "{tiny}");
        // Interpolating q towards -q (after alignment) stays at q: no flip through another pose.
        let b = align_hemisphere(q, -q);
        assert!(rotation_angle(interpolate_rotation(q, b, 0.5), q) < 1e-5);
    }

    #[test]
    fn concat_matches_full_product() {
        let parent = Mat4::from_scale_rotation_translation(
            Vec3::new(1.0, 2.0, 0.5),
            Quat::from_rotation_z(0.4),
            Vec3::new(3.0, -1.0, 2.0),
        );
        let local = Affine3A::from_scale_rotation_translation(
            Vec3::splat(1.5),
            Quat::from_rotation_x(-1.1),
            Vec3::new(0.2, 0.3, -4.0),
        );
        let a = concat(&parent, &local);
        let b = parent * Mat4::from(local);
        assert!(a.abs_diff_eq(b, 1e-5));
    }
}
