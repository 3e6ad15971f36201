//! The playback core: key blocks stored key-major, the segment search, per-channel
//! interpolation (step, linear with shortest-path rotations, cubic Hermite), and the per-character
//! scratch the sampled values land in. [`crate::Clip`] builds these when it is built.
//!
//! Linear rotation blocks also keep their keys in lanes of four channels (structure of arrays:
//! per key, per group of four channels, one vector of `x`, one of `y`, one of `z`, one of `w`), so
//! that the interpolation and normalisation of four rotations run as plain vertical vector
//! arithmetic instead of per-quaternion horizontal sums. This is the layout idea of
//! ozz-animation's runtime sampler (G. Blanc, ozz-animation, `SamplingJob`: "SoA" tracks of four);
//! unlike ozz, keys stay in one shared key-time row per block, so no per-track cursor is needed.

use glam::{Affine3A, Mat4, Quat, Vec3A, Vec4};

use crate::transform::interpolate_rotation;
use crate::transform::{Transform, compose_lanes};

/// How values between two keys are computed (the glTF sampler interpolations).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Interpolation {
    /// Hold the value of the previous key.
    Step,
    /// Linear for translation and scale; shortest-path spherical for rotation.
    Linear,
    /// Cubic Hermite spline with per-key in and out tangents (glTF `CUBICSPLINE`).
    CubicSpline,
}

/// The values a block can hold, with their interpolation rules.
pub(crate) trait KeyValue: Copy {
    fn lerp(a: Self, b: Self, t: f32) -> Self;
    /// `v0·w0 + out0·w1 + v1·w2 + in1·w3`, normalised for rotations.
    fn hermite(v0: Self, out0: Self, v1: Self, in1: Self, w: &[f32; 4]) -> Self;
}

impl KeyValue for Vec3A {
    #[inline(always)]
    fn lerp(a: Self, b: Self, t: f32) -> Self {
        a + (b - a) * t
    }
    #[inline(always)]
    fn hermite(v0: Self, out0: Self, v1: Self, in1: Self, w: &[f32; 4]) -> Self {
        v0 * w[0] + out0 * w[1] + v1 * w[2] + in1 * w[3]
    }
}

impl KeyValue for Quat {
    #[inline(always)]
    fn lerp(a: Self, b: Self, t: f32) -> Self {
        interpolate_rotation(a, b, t)
    }
    #[inline(always)]
    fn hermite(v0: Self, out0: Self, v1: Self, in1: Self, w: &[f32; 4]) -> Self {
        let v = Vec4::from(v0) * w[0]
            + Vec4::from(out0) * w[1]
            + Vec4::from(v1) * w[2]
            + Vec4::from(in1) * w[3];
        Quat::from_vec4(v.normalize_or(Vec4::W))
    }
}

/// Animated channels of one property sharing one key-time array and one interpolation.
#[derive(Clone, Debug)]
pub(crate) struct Block<T> {
    /// Index of the shared key times in `Clip::groups`.
    pub(crate) group: u32,
    pub(crate) interpolation: Interpolation,
    /// Target bone of each channel.
    pub(crate) bones: Vec<u32>,
    /// Key-major values: row `k` (or rows `3k..3k+3` for cubic: in, value, out) holds one value
    /// per channel.
    pub(crate) keys: Vec<T>,
    /// Linear rotation blocks only (empty otherwise): the keys again in lanes of four channels,
    /// `lanes[(k * groups + g) * 4 + i]` holding component `i` (`x y z w`) of channels
    /// `4g..4g + 4` at key `k`; a last group with fewer than four channels is padded with the
    /// identity.
    pub(crate) lanes: Vec<Vec4>,
}

/// Where an animated bone's channel of one property lives: block index and column, or
/// `block == u32::MAX` when the property is not animated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct ChannelRef {
    pub(crate) block: u32,
    pub(crate) col: u32,
}

impl ChannelRef {
    pub(crate) const NONE: ChannelRef = ChannelRef {
        block: u32::MAX,
        col: 0,
    };
}

/// Where playback is within one key-time array: segment start `k`, the fraction `alpha` through
/// it, and the segment length in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Cursor {
    pub(crate) k: u32,
    pub(crate) alpha: f32,
    pub(crate) span: f32,
}

/// Finds the segment of `times` (at least two keys) containing `t`; before the first key the
/// first value holds (`alpha = 0`), after the last the last holds (`alpha = 1`).
#[inline]
pub(crate) fn locate(times: &[f32], t: f32) -> Cursor {
    let n = times.len();
    debug_assert!(n >= 2);
    let idx = times.partition_point(|&x| x <= t);
    if idx == 0 {
        Cursor {
            k: 0,
            alpha: 0.0,
            span: times[1] - times[0],
        }
    } else if idx >= n {
        Cursor {
            k: (n - 2) as u32,
            alpha: 1.0,
            span: times[n - 1] - times[n - 2],
        }
    } else {
        let k = idx - 1;
        let span = times[k + 1] - times[k];
        let alpha = if span > 0.0 {
            ((t - times[k]) / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
        Cursor {
            k: k as u32,
            alpha,
            span,
        }
    }
}

impl<T: KeyValue> Block<T> {
    /// Samples one channel (column `c`) of the block.
    #[inline(always)]
    pub(crate) fn sample_one(&self, c: usize, cur: Cursor) -> T {
        let w = self.bones.len();
        let k = cur.k as usize;
        match self.interpolation {
            Interpolation::Step => self.keys[if cur.alpha >= 1.0 { k + 1 } else { k } * w + c],
            Interpolation::Linear => {
                T::lerp(self.keys[k * w + c], self.keys[(k + 1) * w + c], cur.alpha)
            }
            Interpolation::CubicSpline => {
                let s = cur.alpha;
                let (s2, s3) = (s * s, s * s * s);
                let wts = [
                    2.0 * s3 - 3.0 * s2 + 1.0,
                    (s3 - 2.0 * s2 + s) * cur.span,
                    -2.0 * s3 + 3.0 * s2,
                    (s3 - s2) * cur.span,
                ];
                let at = |r: usize| self.keys[r * w + c];
                T::hermite(
                    at(3 * k + 1),
                    at(3 * k + 2),
                    at(3 * k + 4),
                    at(3 * k + 3),
                    &wts,
                )
            }
        }
    }

    /// Samples every channel of the block into `out[bone]`.
    #[inline]
    pub(crate) fn sample(&self, cur: Cursor, out: &mut [T]) {
        let c = self.bones.len();
        let k = cur.k as usize;
        match self.interpolation {
            Interpolation::Step => {
                let row = if cur.alpha >= 1.0 { k + 1 } else { k };
                let keys = &self.keys[row * c..row * c + c];
                for (&b, &v) in self.bones.iter().zip(keys) {
                    out[b as usize] = v;
                }
            }
            Interpolation::Linear => {
                let a = &self.keys[k * c..k * c + c];
                let bk = &self.keys[(k + 1) * c..(k + 1) * c + c];
                let t = cur.alpha;
                for ((&b, &va), &vb) in self.bones.iter().zip(a).zip(bk) {
                    out[b as usize] = T::lerp(va, vb, t);
                }
            }
            Interpolation::CubicSpline => {
                let s = cur.alpha;
                let (s2, s3) = (s * s, s * s * s);
                let w = [
                    2.0 * s3 - 3.0 * s2 + 1.0,
                    (s3 - 2.0 * s2 + s) * cur.span,
                    -2.0 * s3 + 3.0 * s2,
                    (s3 - s2) * cur.span,
                ];
                let row = |r: usize| &self.keys[r * c..r * c + c];
                let (v0, out0) = (row(3 * k + 1), row(3 * k + 2));
                let (in1, v1) = (row(3 * k + 3), row(3 * k + 4));
                for (i, &b) in self.bones.iter().enumerate() {
                    out[b as usize] = T::hermite(v0[i], out0[i], v1[i], in1[i], &w);
                }
            }
        }
    }
}

impl Block<Quat> {
    /// Fills [`Block::lanes`] from the key-major keys (linear blocks only).
    pub(crate) fn build_lanes(&mut self) {
        self.lanes.clear();
        if self.interpolation != Interpolation::Linear || self.bones.is_empty() {
            return;
        }
        let c = self.bones.len();
        for row in self.keys.chunks_exact(c) {
            for group in row.chunks(4) {
                let mut q = [Vec4::W; 4];
                for (dst, src) in q.iter_mut().zip(group) {
                    *dst = Vec4::from(*src);
                }
                let m = Mat4::from_cols(q[0], q[1], q[2], q[3]).transpose();
                self.lanes.extend([m.x_axis, m.y_axis, m.z_axis, m.w_axis]);
            }
        }
    }

    /// Samples every channel of a rotation block into `out[bone]`: linear blocks four channels at
    /// a time from [`Block::lanes`] (the same arithmetic as [`interpolate_rotation`], lane by
    /// lane), other interpolations through [`Block::sample`].
    #[inline]
    pub(crate) fn sample_rotations(&self, cur: Cursor, out: &mut [Quat]) {
        if self.lanes.is_empty() {
            self.sample(cur, out);
            return;
        }
        let n = self.bones.len();
        for (g, v) in self.lane_groups(cur) {
            let m = Mat4::from_cols(v[0], v[1], v[2], v[3]).transpose();
            let bones = &self.bones[4 * g..(4 * g + 4).min(n)];
            for (i, &bone) in bones.iter().enumerate() {
                out[bone as usize] = Quat::from_vec4(m.col(i));
            }
        }
    }

    /// The interpolated rotations of a linear block at `cur`, four channels at a time: group `g`
    /// and its `x y z w` lanes. The arithmetic of [`interpolate_rotation`], lane by lane.
    #[inline(always)]
    fn lane_groups(&self, cur: Cursor) -> impl Iterator<Item = (usize, [Vec4; 4])> + '_ {
        let row = self.bones.len().div_ceil(4) * 4;
        let k = cur.k as usize;
        let a = &self.lanes[k * row..(k + 1) * row];
        let b = &self.lanes[(k + 1) * row..(k + 2) * row];
        let t = cur.alpha;
        let c = t - 0.5;
        let (c2, tc) = (Vec4::splat(c * c), Vec4::splat(t * c * (t - 1.0)));
        let t = Vec4::splat(t);
        a.chunks_exact(4)
            .zip(b.chunks_exact(4))
            .enumerate()
            .map(move |(g, (a, b))| {
                let d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]).abs();
                let ka = Vec4::splat(1.0904)
                    + d * (Vec4::splat(-3.2452) + d * (Vec4::splat(3.55645) - d * 1.43519));
                let kb = Vec4::splat(0.848013) + d * (Vec4::splat(-1.06021) + d * 0.215638);
                let k = ka * c2 + kb;
                let ot = t + tc * k;
                let v = [
                    a[0] + (b[0] - a[0]) * ot,
                    a[1] + (b[1] - a[1]) * ot,
                    a[2] + (b[2] - a[2]) * ot,
                    a[3] + (b[3] - a[3]) * ot,
                ];
                let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3])
                    .to_array()
                    .map(f32::sqrt);
                let inv = Vec4::ONE / Vec4::from_array(len);
                (g, v.map(|v| v * inv))
            })
    }

    /// Samples a linear block's rotations and composes its bones' local matrices with the
    /// translations and scales already sampled into `t` and `s`, four bones at a time without
    /// leaving the lanes (the rotations are not stored).
    #[inline]
    pub(crate) fn sample_compose(
        &self,
        cur: Cursor,
        t: &[Vec3A],
        s: &[Vec3A],
        rotations: &mut Vec<[Vec4; 4]>,
        locals: &mut [Affine3A],
    ) {
        debug_assert!(!self.lanes.is_empty());
        let n = self.bones.len();
        // Two passes: every group's rotations first (independent vector chains whose square
        // roots and divisions overlap), then the gathers, compositions and stores.
        rotations.clear();
        rotations.extend(self.lane_groups(cur).map(|(_, q)| q));
        for (g, &q) in rotations.iter().enumerate() {
            let bones = &self.bones[4 * g..(4 * g + 4).min(n)];
            if let Ok(b) = <&[u32; 4]>::try_from(bones) {
                // A whole group: fixed-size gathers and stores, no per-lane loop.
                let b = b.map(|b| b as usize);
                let m = compose_lanes(b.map(|b| s[b]), q, b.map(|b| t[b]));
                for (b, m) in b.into_iter().zip(m) {
                    locals[b] = m;
                }
                continue;
            }
            let (mut bt, mut bs) = ([Vec3A::ZERO; 4], [Vec3A::ONE; 4]);
            for (i, &b) in bones.iter().enumerate() {
                (bt[i], bs[i]) = (t[b as usize], s[b as usize]);
            }
            let m = compose_lanes(bs, q, bt);
            for (&b, m) in bones.iter().zip(m) {
                locals[b as usize] = m;
            }
        }
    }
}

/// Per-bone translation, rotation and scale being assembled for one character. Entries of
/// channels a clip does not animate hold the clip's base pose.
#[derive(Clone, Debug, Default)]
pub(crate) struct TrsScratch {
    pub(crate) t: Vec<Vec3A>,
    pub(crate) r: Vec<Quat>,
    pub(crate) s: Vec<Vec3A>,
    /// Rotations of one linear block's lane groups (see [`Block::sample_compose`]).
    pub(crate) lane_rotations: Vec<[Vec4; 4]>,
    /// Address of the clip whose base pose is loaded (0: none).
    loaded: usize,
}

impl TrsScratch {
    /// Loads a clip's base pose unless it is already loaded.
    #[inline]
    pub(crate) fn prepare(&mut self, base_pose: &[Transform]) {
        let id = base_pose.as_ptr() as usize;
        if self.loaded == id && self.t.len() == base_pose.len() {
            return;
        }
        self.t.clear();
        self.r.clear();
        self.s.clear();
        for b in base_pose {
            self.t.push(b.translation.into());
            self.r.push(b.rotation);
            self.s.push(b.scale.into());
        }
        self.loaded = id;
    }
}
