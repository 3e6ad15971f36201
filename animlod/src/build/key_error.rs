//! The build step's table for [`crate::LodMode::Interpolated`]: how fast the velocity of the
//! clip's measured points (every joint's origin and tip, the points the pose error is measured
//! at) changes over time, so that the runtime can bound the error of interpolating linearly
//! between two evaluated poses.
//!
//! Based on the error of linear interpolation. For a point moving along `p(t)` and its chord
//! `l(t)` between times `a` and `b = a + T`,
//! `p(t) − l(t) = ((t − a)(b − t) / T) · (v̄[a, t] − v̄[t, b])`, where `v̄[x, y]` is the mean
//! velocity over `[x, y]`; two mean velocities differ by at most the total variation `V` of
//! the velocity over `[a, b]`, so `|p(t) − l(t)| ≤ T · V / 4`. For smooth motion `V ≈ |p̈| T`
//! and the error is second order in the interval (`|p̈| T² / 4`; the classic `T² / 8` bound
//! needs a bounded second derivative, which key kinks do not have); a hold's error is first
//! order (`|ṗ| T`). Model matrices are linear in the points they carry, so interpolating the
//! matrices moves every measured point along its chord.
//!
//! A hold's bound comes from the same samples: a point held from `a` is at most its path
//! length away at `b`, and the path over a bin is at most the bin's width times the largest
//! speed sampled in it.
//!
//! The table: the clip is cut into bins of about 1/240 s (a quarter of a 60 Hz frame, so an
//! interval is over-read by at most half a frame at its two ends), each sampled at [`SUBSTEPS`] points;
//! per bin, the largest (over the measured points) sum of velocity changes between consecutive
//! sub-steps, including the change from the previous bin's last sub-step. The total variation
//! over an interval is at most the sum over the bins it touches, stored as prefix sums.

use glam::{Affine3A, Mat4, Vec3};

use crate::clip::{Clip, Cursor, TrsScratch};
use crate::skeleton::Skeleton;

/// Bins per second of clip time.
const BINS_PER_SECOND: f32 = 240.0;
/// Velocity samples per bin.
const SUBSTEPS: usize = 4;

/// The velocity-variation table of one clip: bin width (s) and prefix sums of the per-bin
/// bounds (model units per second), `prefix[k]` = sum of bins `0..k`.
#[derive(Clone, Debug, Default)]
pub(crate) struct VariationTable {
    /// Width of one bin in clip seconds (0 for a clip without duration).
    pub(crate) bin: f32,
    /// Prefix sums, one more than the bins.
    pub(crate) prefix: Vec<f32>,
    /// Prefix sums of the per-bin path bound (bin width × largest speed of any measured point
    /// in the bin; model units), one more than the bins.
    pub(crate) path: Vec<f32>,
    /// Largest distance (model units) of any measured point between the clip's end pose and
    /// its start pose: what continuing an interpolation across a looping clip's wrap costs.
    pub(crate) wrap_jump: f32,
}

impl VariationTable {
    /// Bound (model units) on the displacement of any measured point between the pose
    /// interpolated linearly from clip time `a` to `b` and the clip's own pose, at any time in
    /// between (`(b − a) / 4 ·` the velocity variation over the bins `[a, b]` touches).
    #[inline]
    pub(crate) fn lerp_error(&self, a: f32, b: f32) -> f32 {
        0.25 * (b - a).max(0.0) * Self::sum(&self.prefix, self.bin, a, b)
    }

    /// The sum, from prefix sums `prefix`, over the bins (of width `bin`) that clip times `a`
    /// to `b` touch (0 for an empty table or `b <= a`).
    #[inline]
    fn sum(prefix: &[f32], bin: f32, a: f32, b: f32) -> f32 {
        let n = prefix.len();
        if n < 2 || bin <= 0.0 || b <= a {
            return 0.0;
        }
        let at = |t: f32| ((t / bin) as usize).min(n - 2);
        prefix[at(b) + 1] - prefix[at(a)]
    }

    /// Bound (model units) on how far any measured point moves from clip time `a` to `b`: the
    /// error of holding the pose of `a` until `b`.
    #[inline]
    pub(crate) fn hold_error(&self, a: f32, b: f32) -> f32 {
        Self::sum(&self.path, self.bin, a, b)
    }
}

/// Builds the table of `clip` on `skeleton` by sampling the clip's model-space pose.
pub(crate) fn variation_table(clip: &Clip, skeleton: &Skeleton) -> VariationTable {
    let duration = clip.duration();
    if duration.is_nan() || duration <= 0.0 || clip.animated.is_empty() {
        return VariationTable::default();
    }
    let bins = (duration * BINS_PER_SECOND).ceil().max(1.0) as usize;
    let bin = duration / bins as f32;
    let dt = bin / SUBSTEPS as f32;
    let (joints, tips) = (skeleton.joint_flags(), skeleton.tips());
    let points = |models: &[Mat4], out: &mut Vec<Vec3>| {
        out.clear();
        for ((m, &j), &tip) in models.iter().zip(joints).zip(tips) {
            if j {
                out.push(m.w_axis.truncate());
                out.push(m.transform_point3(tip));
            }
        }
    };
    let n = skeleton.len();
    let (mut cursors, mut trs): (Vec<Cursor>, TrsScratch) = Default::default();
    let mut locals = vec![Affine3A::IDENTITY; n];
    let mut models = vec![Mat4::IDENTITY; n];
    let mut pose_at = |t: f32, out: &mut Vec<Vec3>| {
        clip.sample_locals(t.min(duration), &mut cursors, &mut trs, &mut locals);
        skeleton.model_matrices(&locals, &mut models);
        points(&models, out);
    };
    let (mut p0, mut p1) = (Vec::new(), Vec::new());
    pose_at(0.0, &mut p0);
    let first = p0.clone();
    let mut velocity: Vec<Vec3> = Vec::new();
    let mut per_point = vec![0.0f32; p0.len()];
    let mut prefix = Vec::with_capacity(bins + 1);
    prefix.push(0.0f32);
    let mut path = prefix.clone();
    for k in 0..bins {
        per_point.fill(0.0);
        let mut speed = 0.0f32;
        for s in 0..SUBSTEPS {
            let t = (k * SUBSTEPS + s + 1) as f32 * dt;
            pose_at(t, &mut p1);
            for (i, (a, b)) in p0.iter().zip(&p1).enumerate() {
                let v = (*b - *a) / dt;
                speed = speed.max(v.length());
                if let Some(prev) = velocity.get_mut(i) {
                    per_point[i] += (v - *prev).length();
                    *prev = v;
                } else {
                    velocity.push(v);
                }
            }
            std::mem::swap(&mut p0, &mut p1);
        }
        let worst = per_point.iter().copied().fold(0.0f32, f32::max);
        prefix.push(prefix[k] + worst);
        path.push(path[k] + speed * bin);
    }
    let wrap_jump = first
        .iter()
        .zip(&p0)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0f32, f32::max);
    VariationTable {
        bin,
        prefix,
        path,
        wrap_jump,
    }
}
