//! Static per-keyframe bone priorities (thesis chapters 10–12): six sub-priorities per bone and
//! key segment, each normalised by its maximum over the clip, combined by a weighted average.
//!
//! Deliberate departures from the thesis, each because the thesis contradicts its own text:
//! - **Rotation change** is the angle between consecutive keys (`q` and `−q` count as equal), not
//!   the raw quaternion dot product the thesis uses: the dot product is largest (1) when a bone
//!   does *not* rotate and shrinks as the rotation grows, and flips sign for the same rotation
//!   written as `−q`, so it ranked still bones as the most agitated.
//! - **Depth** gives bones near the root the higher priority, `1 − depth / max_depth`, as the
//!   thesis' text says (section 11.5); its formula `depth / max_depth` did the opposite.
//! - **Changes are rates** (per second of the segment) rather than per-key differences, so that
//!   clips with uneven key spacing, or channels with different key times, are comparable; for the
//!   evenly spaced keys the thesis assumed this only rescales, which the normalisation removes.
//! - **A keyframe's priority describes the segment being played** (from key `k` to key `k + 1`):
//!   that is the motion a held bone misses. The thesis attaches the change *into* key `k`, one
//!   segment late.

use glam::{Affine3A, Mat4};

use crate::clip::{Clip, Cursor, TrsScratch};
use crate::skeleton::{NO_PARENT, Skeleton};
use crate::transform::{concat, rotation_angle};

/// The six factors of a bone keyframe's priority.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Factor {
    /// Translation change over the segment.
    Translation,
    /// Rotation change (angle) over the segment.
    Rotation,
    /// Scale change over the segment.
    Scale,
    /// Number of direct and indirect children.
    Descendants,
    /// Closeness to the root.
    Depth,
    /// A value the user sets per bone.
    User,
}

impl Factor {
    /// All factors, in the order of [`PriorityWeights::as_array`].
    pub const ALL: [Factor; 6] = [
        Factor::Translation,
        Factor::Rotation,
        Factor::Scale,
        Factor::Descendants,
        Factor::Depth,
        Factor::User,
    ];
}

/// Weights of the six sub-priorities. They are normalised to sum to 1 when applied, so only their
/// ratios matter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PriorityWeights {
    /// Weight of the translation change.
    pub translation: f32,
    /// Weight of the rotation change.
    pub rotation: f32,
    /// Weight of the scale change.
    pub scale: f32,
    /// Weight of the number of descendants.
    pub descendants: f32,
    /// Weight of the closeness to the root.
    pub depth: f32,
    /// Weight of the user-set value.
    pub user: f32,
}

impl PriorityWeights {
    /// The thesis' default: every factor weighs 1/6.
    pub const EQUAL: PriorityWeights = PriorityWeights {
        translation: 1.0 / 6.0,
        rotation: 1.0 / 6.0,
        scale: 1.0 / 6.0,
        descendants: 1.0 / 6.0,
        depth: 1.0 / 6.0,
        user: 1.0 / 6.0,
    };

    /// The weights in [`Factor::ALL`] order.
    pub fn as_array(&self) -> [f32; 6] {
        [
            self.translation,
            self.rotation,
            self.scale,
            self.descendants,
            self.depth,
            self.user,
        ]
    }

    /// Weights from an array in [`Factor::ALL`] order.
    pub fn from_array(w: [f32; 6]) -> Self {
        PriorityWeights {
            translation: w[0],
            rotation: w[1],
            scale: w[2],
            descendants: w[3],
            depth: w[4],
            user: w[5],
        }
    }

    /// The weights scaled to sum to 1, or `None` if one is negative or non-finite or all are 0.
    pub fn normalized(&self) -> Option<PriorityWeights> {
        let w = self.as_array();
        if w.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return None;
        }
        let sum: f32 = w.iter().sum();
        if !sum.is_finite() || sum <= 0.0 {
            return None;
        }
        Some(Self::from_array(w.map(|x| x / sum)))
    }
}

impl Default for PriorityWeights {
    fn default() -> Self {
        PriorityWeights::EQUAL
    }
}

/// Sub-priorities of one clip's animated bones, per key segment, each in `[0, 1]`.
///
/// The segments are those of the clip's *timeline*: the union of the key times of its animated
/// channels (for a typical export, simply its keys). Motion factors are stored per segment and
/// animated bone (`[segment * bones + slot]`, slot = position in [`Clip::animated_bones`]);
/// structural factors per animated bone. The user factor is applied by the crowd.
#[derive(Clone, Debug, Default)]
pub struct SubPriorities {
    pub(crate) timeline: Vec<f32>,
    pub(crate) slots: usize,
    pub(crate) motion: [Vec<f32>; 3],
    pub(crate) descendants: Vec<f32>,
    pub(crate) depth: Vec<f32>,
    pub(crate) max_rate: [f32; 3],
    /// Measured hold error rate per `[segment * bones + slot]`: the fastest any joint moves away
    /// from where it should be while this bone alone holds (model units per second).
    pub(crate) hold_max: Vec<f32>,
    /// The same summed over the joints (model units per second).
    pub(crate) hold_sum: Vec<f32>,
    /// Largest `hold_max` of the clip.
    pub(crate) hold_max_peak: f32,
}

impl SubPriorities {
    /// Computes the table for a clip whose blocks and base pose are built.
    pub(crate) fn compute(clip: &Clip, skeleton: &Skeleton) -> SubPriorities {
        let mut timeline: Vec<f32> = clip.groups.iter().flatten().copied().collect();
        timeline.sort_by(f32::total_cmp);
        timeline.dedup_by(|a, b| (*a - *b).abs() <= 1e-6 * b.abs().max(1.0));
        if timeline.is_empty() {
            timeline.push(0.0);
        }
        let slots = clip.animated.len();
        let segments = timeline.len().saturating_sub(1).max(1);
        let mut motion = [
            vec![0.0f32; segments * slots],
            vec![0.0; segments * slots],
            vec![0.0; segments * slots],
        ];
        let mut max_rate = [0.0f32; 3];
        if timeline.len() >= 2 && slots > 0 {
            let mut cursors: Vec<Cursor> = Vec::new();
            let mut prev = TrsScratch::default();
            let mut next = TrsScratch::default();
            let sample = |t: f32, s: &mut TrsScratch, cursors: &mut Vec<Cursor>| {
                s.prepare(clip);
                clip.locate_all(t, cursors);
                clip.sample(cursors, s);
            };
            sample(timeline[0], &mut prev, &mut cursors);
            for j in 0..segments {
                sample(timeline[j + 1], &mut next, &mut cursors);
                let dt = timeline[j + 1] - timeline[j];
                if dt > 0.0 {
                    for (i, &b) in clip.animated.iter().enumerate() {
                        let b = b as usize;
                        let rates = [
                            (next.t[b] - prev.t[b]).length() / dt,
                            rotation_angle(prev.r[b], next.r[b]) / dt,
                            (next.s[b] - prev.s[b]).length() / dt,
                        ];
                        for f in 0..3 {
                            motion[f][j * slots + i] = rates[f];
                            max_rate[f] = max_rate[f].max(rates[f]);
                        }
                    }
                }
                std::mem::swap(&mut prev, &mut next);
            }
            for f in 0..3 {
                if max_rate[f] > 0.0 {
                    motion[f].iter_mut().for_each(|x| *x /= max_rate[f]);
                }
            }
        }
        let max_desc = skeleton
            .bones()
            .map(|b| skeleton.descendant_count(b))
            .max()
            .unwrap_or(0);
        let max_depth = skeleton.max_depth();
        let bone = |b: u32| crate::BoneId::from_raw(b);
        let descendants = clip
            .animated
            .iter()
            .map(|&b| {
                if max_desc > 0 {
                    skeleton.descendant_count(bone(b)) as f32 / max_desc as f32
                } else {
                    0.0
                }
            })
            .collect();
        let depth = clip
            .animated
            .iter()
            .map(|&b| {
                if max_depth > 0 {
                    1.0 - skeleton.depth(bone(b)) as f32 / max_depth as f32
                } else {
                    1.0
                }
            })
            .collect();
        let (hold_max, hold_sum) = hold_rates(clip, skeleton, &timeline, segments);
        let hold_max_peak = hold_max.iter().copied().fold(0.0, f32::max);
        SubPriorities {
            timeline,
            slots,
            motion,
            descendants,
            depth,
            max_rate,
            hold_max,
            hold_sum,
            hold_max_peak,
        }
    }

    /// Number of key segments.
    pub fn segment_count(&self) -> usize {
        self.timeline.len().saturating_sub(1).max(1)
    }

    /// Number of animated bones (columns of the table).
    pub fn bone_count(&self) -> usize {
        self.slots
    }

    /// Start times of the segments and the end of the last one.
    pub fn timeline(&self) -> &[f32] {
        &self.timeline
    }

    /// The segment playing at time `t` (wrapped clip time).
    #[inline]
    pub fn segment_at(&self, t: f32) -> usize {
        let n = self.timeline.len();
        if n < 2 {
            return 0;
        }
        self.timeline
            .partition_point(|&x| x <= t)
            .saturating_sub(1)
            .min(n - 2)
    }

    /// Largest translation (units/s), rotation (rad/s) and scale (1/s) rates over the clip: the
    /// normalisers of the motion factors.
    pub fn max_rates(&self) -> [f32; 3] {
        self.max_rate
    }

    /// Measured hold error rate of animated bone `slot` in `segment`: how fast (model units per
    /// second) the joint that drifts most moves away from its true position while this bone
    /// alone holds its local transform from the segment start. Computed at load time by
    /// replaying the segment with the bone held.
    pub fn hold_error_rate(&self, segment: usize, slot: usize) -> f32 {
        self.hold_max[segment * self.slots + slot]
    }

    /// The summed (over joints) hold error rate of animated bone `slot` in `segment`.
    pub fn hold_error_rate_sum(&self, segment: usize, slot: usize) -> f32 {
        self.hold_sum[segment * self.slots + slot]
    }

    /// Largest [`SubPriorities::hold_error_rate`] of the clip.
    pub fn peak_hold_error_rate(&self) -> f32 {
        self.hold_max_peak
    }

    /// The measured priority table `[segment * bones + slot]`: hold error rate over its clip peak.
    pub(crate) fn measured(&self) -> Vec<f32> {
        let peak = self.hold_max_peak;
        self.hold_max
            .iter()
            .map(|&r| if peak > 0.0 { r / peak } else { 0.0 })
            .collect()
    }

    /// One sub-priority in `[0, 1]` of animated bone `slot` in `segment` (the user factor is
    /// reported as 1: it is applied per crowd).
    pub fn get(&self, factor: Factor, segment: usize, slot: usize) -> f32 {
        match factor {
            Factor::Translation => self.motion[0][segment * self.slots + slot],
            Factor::Rotation => self.motion[1][segment * self.slots + slot],
            Factor::Scale => self.motion[2][segment * self.slots + slot],
            Factor::Descendants => self.descendants[slot],
            Factor::Depth => self.depth[slot],
            Factor::User => 1.0,
        }
    }

    /// The combined priority table `[segment * bones + slot]` for these weights (normalised here)
    /// and user values per animated bone slot (already in `[0, 1]`).
    pub(crate) fn combine(&self, weights: &PriorityWeights, user: &[f32]) -> Vec<f32> {
        let w = weights
            .normalized()
            .unwrap_or(PriorityWeights::EQUAL)
            .as_array();
        let segments = self.segment_count();
        let mut out = Vec::with_capacity(segments * self.slots);
        for j in 0..segments {
            let m = j * self.slots..(j + 1) * self.slots;
            let (t, r, s) = (
                &self.motion[0][m.clone()],
                &self.motion[1][m.clone()],
                &self.motion[2][m],
            );
            for (i, &u) in user.iter().enumerate().take(self.slots) {
                out.push(
                    w[0] * t[i]
                        + w[1] * r[i]
                        + w[2] * s[i]
                        + w[3] * self.descendants[i]
                        + w[4] * self.depth[i]
                        + w[5] * u,
                );
            }
        }
        out
    }
}

/// Replays every key segment once per animated bone with that bone held at the segment start,
/// and measures how fast the joints drift from the full-rate pose at the segment end: the
/// largest and the summed drift, divided by the segment length.
fn hold_rates(
    clip: &Clip,
    skeleton: &Skeleton,
    timeline: &[f32],
    segments: usize,
) -> (Vec<f32>, Vec<f32>) {
    let slots = clip.animated.len();
    let mut max = vec![0.0f32; segments * slots];
    let mut sum = vec![0.0f32; segments * slots];
    if timeline.len() < 2 || slots == 0 {
        return (max, sum);
    }
    let n = skeleton.len();
    let parents = skeleton.parents_raw();
    let joints = skeleton.joint_flags();
    let mut cursors: Vec<Cursor> = Vec::new();
    let mut trs = TrsScratch::default();
    let (mut l0, mut l1) = (vec![Affine3A::IDENTITY; n], vec![Affine3A::IDENTITY; n]);
    let (mut m1, mut held) = (vec![Mat4::IDENTITY; n], vec![Mat4::IDENTITY; n]);
    let mut in_subtree = vec![false; n];
    for j in 0..segments {
        let dt = timeline[j + 1] - timeline[j];
        if dt.is_nan() || dt <= 0.0 {
            continue;
        }
        clip.sample_locals(timeline[j], &mut cursors, &mut trs, &mut l0);
        clip.sample_locals(timeline[j + 1], &mut cursors, &mut trs, &mut l1);
        skeleton.model_matrices(&l1, &mut m1);
        for (i, &b) in clip.animated.iter().enumerate() {
            let b = b as usize;
            let (mut e_max, mut e_sum) = (0.0f32, 0.0f32);
            in_subtree.fill(false);
            for x in b..n {
                let p = parents[x];
                if x != b && (p == NO_PARENT || !in_subtree[p as usize]) {
                    continue;
                }
                in_subtree[x] = true;
                let local = if x == b { &l0[x] } else { &l1[x] };
                held[x] = match p {
                    NO_PARENT => Mat4::from(*local),
                    p if in_subtree[p as usize] => concat(&held[p as usize], local),
                    p => concat(&m1[p as usize], local),
                };
                if joints[x] {
                    let e = (held[x].w_axis - m1[x].w_axis).truncate().length();
                    e_max = e_max.max(e);
                    e_sum += e;
                }
            }
            max[j * slots + i] = e_max / dt;
            sum[j * slots + i] = e_sum / dt;
        }
    }
    (max, sum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clip::{ChannelDesc, ClipOptions, Interpolation, Keys};
    use crate::ids::BoneId;
    use crate::skeleton::BoneDesc;
    use crate::transform::Transform;
    use glam::{Mat4, Quat, Vec3};

    fn skeleton3() -> Skeleton {
        // root → a → b
        Skeleton::new(
            (0..3)
                .map(|i| BoneDesc {
                    name: format!("{i}"),
                    parent: (i > 0).then(|| BoneId::new(i - 1)),
                    rest: Transform {
                        translation: Vec3::Y,
                        ..Transform::IDENTITY
                    },
                    inverse_bind: Mat4::IDENTITY,
                    is_joint: true,
                })
                .collect(),
        )
        .unwrap()
    }

    #[test]
    fn rotation_priority_is_the_angle_and_depth_favours_the_root() {
        let sk = skeleton3();
        let t = vec![0.0, 1.0, 2.0];
        let rot = |angles: [f32; 3]| {
            Keys::Rotation(angles.iter().map(|&a| Quat::from_rotation_x(a)).collect())
        };
        let clip = Clip::new(
            "c",
            &sk,
            vec![
                // Root turns 0.1 then 0.4 rad; bone 2 turns 0.4 then not at all, written as −q.
                ChannelDesc {
                    bone: BoneId::from_raw(0),
                    interpolation: Interpolation::Linear,
                    times: t.clone(),
                    keys: rot([0.0, 0.1, 0.5]),
                },
                ChannelDesc {
                    bone: BoneId::from_raw(2),
                    interpolation: Interpolation::Linear,
                    times: t.clone(),
                    keys: Keys::Rotation(vec![
                        Quat::IDENTITY,
                        Quat::from_rotation_x(0.4),
                        -Quat::from_rotation_x(0.4),
                    ]),
                },
            ],
            &ClipOptions::default(),
        )
        .unwrap();
        let p = clip.sub_priorities();
        assert_eq!(p.segment_count(), 2);
        assert!((p.max_rates()[1] - 0.4).abs() < 1e-5);
        // Segment 0: root 0.1/0.4, bone 2 0.4/0.4 (the larger rotation ranks higher, unlike a dot product).
        assert!((p.get(Factor::Rotation, 0, 0) - 0.25).abs() < 1e-4);
        assert!((p.get(Factor::Rotation, 0, 1) - 1.0).abs() < 1e-4);
        // Segment 1: the −q key is no motion at all.
        assert!(p.get(Factor::Rotation, 1, 1) < 1e-5);
        // Depth: root 1, deepest 0. Descendants: root 2/2, leaf 0.
        assert_eq!(p.get(Factor::Depth, 0, 0), 1.0);
        assert_eq!(p.get(Factor::Depth, 0, 1), 0.0);
        assert_eq!(p.get(Factor::Descendants, 0, 0), 1.0);
        assert_eq!(p.get(Factor::Descendants, 0, 1), 0.0);
        assert_eq!(p.segment_at(0.5), 0);
        assert_eq!(p.segment_at(1.5), 1);
        assert_eq!(p.segment_at(9.0), 1);
        // Equal weights: average of the six factors (user = 1).
        let table = p.combine(&PriorityWeights::EQUAL, &[1.0, 1.0]);
        assert!((table[0] - (0.25 + 1.0 + 1.0 + 1.0) / 6.0).abs() < 1e-5);
    }

    #[test]
    fn weights_normalise() {
        let w = PriorityWeights::from_array([2.0, 2.0, 0.0, 0.0, 0.0, 0.0])
            .normalized()
            .unwrap();
        assert_eq!(w.translation, 0.5);
        assert!(PriorityWeights::from_array([0.0; 6]).normalized().is_none());
        assert!(
            PriorityWeights::from_array([1.0, -1.0, 0.0, 0.0, 0.0, 1.0])
                .normalized()
                .is_none()
        );
        assert!(
            PriorityWeights::from_array([1.0, f32::NAN, 0.0, 0.0, 0.0, 1.0])
                .normalized()
                .is_none()
        );
    }
}
