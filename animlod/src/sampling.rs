//! The playback core: key blocks stored key-major, the segment search, per-channel
//! interpolation (step, linear with shortest-path rotations, cubic Hermite), and the per-character
//! scratch the sampled values land in. [`crate::Clip`] builds these when it is built.

use glam::{Quat, Vec3A, Vec4};

use crate::transform::Transform;
use crate::transform::interpolate_rotation;

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

/// Per-bone translation, rotation and scale being assembled for one character. Entries of
/// channels a clip does not animate hold the clip's base pose.
#[derive(Clone, Debug, Default)]
pub(crate) struct TrsScratch {
    pub(crate) t: Vec<Vec3A>,
    pub(crate) r: Vec<Quat>,
    pub(crate) s: Vec<Vec3A>,
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
