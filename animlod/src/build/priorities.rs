//! The build step's priority pass: the static per-keyframe sub-priorities of a clip's animated
//! bones (`animation-lod-bone-priority-thesis.txt`, chapters 10–12; the departures from the thesis
//! are listed in the `priority` module) and the measured hold error rates the
//! error-bound mode and the analysis pass use.

use glam::{Affine3A, Mat4};

use crate::clip::{Clip, Cursor, TrsScratch};
use crate::priority::SubPriorities;
use crate::skeleton::{NO_PARENT, Skeleton};
use crate::transform::{concat, rotation_angle};

/// Computes the priority table of a built clip: per key segment, the motion factors and the
/// measured hold error rates of each animated bone; per animated bone, the structural factors.
pub(crate) fn priorities(clip: &Clip, skeleton: &Skeleton) -> SubPriorities {
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
            s.prepare(clip.base_pose());
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
                        rotation_angle(prev.r[b], next.r[b]) * skeleton.tips()[b].length() / dt,
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
        wrap_jump: wrap_jumps(clip, skeleton),
        variation: super::key_error::variation_table(clip, skeleton),
    }
}

/// Fractions of a key segment a hold is replayed over to find its largest drift rate.
const HOLD_PARTS: [f32; 4] = [0.25, 0.5, 0.75, 1.0];

/// Replays every key segment once per animated bone with that bone held at the segment start,
/// and measures how fast the joints' origins and tips ([`Skeleton::tip`]) drift from the
/// full-rate pose over the segment: the largest and the summed drift per second of hold
/// (the fastest over holds of parts of the segment, [`HOLD_PARTS`]). The tips make a bone's own rotation count (a leaf animated by rotation alone moves
/// only its tip).
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
    let mut hold = HoldReplay::new(skeleton);
    let (mut m, mut s) = (vec![0.0f32; slots], vec![0.0f32; slots]);
    for j in 0..segments {
        let dt = timeline[j + 1] - timeline[j];
        if dt.is_nan() || dt <= 0.0 {
            continue;
        }
        let row = j * slots..(j + 1) * slots;
        // The displacement of a hold grows along an arc while the chord to the segment's end
        // is shorter (a 3 rad turn in one segment: 0.66 of the arc), so the rate is the largest
        // displacement per second over holds of a quarter, half, three quarters and all of it.
        for part in HOLD_PARTS {
            let held = part * dt;
            hold.displacements(clip, timeline[j], timeline[j] + held, &mut m, &mut s);
            for (k, x) in row.clone().enumerate() {
                max[x] = max[x].max(m[k] / held);
                sum[x] = sum[x].max(s[k] / held);
            }
        }
    }
    (max, sum)
}

/// The jump a looping clip makes from its end back to its start, per animated bone: the largest
/// displacement of any joint origin or tip while that bone alone holds its end pose and the rest
/// of the skeleton is at the start pose (model units). A bone held across the wrap owes this on
/// top of its drift rates (the wrap is a jump, not a rate).
fn wrap_jumps(clip: &Clip, skeleton: &Skeleton) -> Vec<f32> {
    let slots = clip.animated.len();
    let mut max = vec![0.0f32; slots];
    if slots == 0 || clip.duration() <= 0.0 {
        return max;
    }
    let mut sum = vec![0.0f32; slots];
    HoldReplay::new(skeleton).displacements(clip, clip.duration(), 0.0, &mut max, &mut sum);
    max
}

/// Scratch of a hold replay: the pose at two times and the model matrices of a subtree held.
struct HoldReplay<'a> {
    skeleton: &'a Skeleton,
    cursors: Vec<Cursor>,
    trs: TrsScratch,
    l0: Vec<Affine3A>,
    l1: Vec<Affine3A>,
    m1: Vec<Mat4>,
    held: Vec<Mat4>,
    in_subtree: Vec<bool>,
}

impl<'a> HoldReplay<'a> {
    fn new(skeleton: &'a Skeleton) -> Self {
        let n = skeleton.len();
        HoldReplay {
            skeleton,
            cursors: Vec::new(),
            trs: TrsScratch::default(),
            l0: vec![Affine3A::IDENTITY; n],
            l1: vec![Affine3A::IDENTITY; n],
            m1: vec![Mat4::IDENTITY; n],
            held: vec![Mat4::IDENTITY; n],
            in_subtree: vec![false; n],
        }
    }

    /// For each animated-bone slot: hold that bone's local transform at clip time `from` while
    /// everything else is at time `to`, and write the largest and the summed displacement of
    /// the joints' origins and tips in its subtree against the pose at `to`.
    fn displacements(&mut self, clip: &Clip, from: f32, to: f32, max: &mut [f32], sum: &mut [f32]) {
        let sk = self.skeleton;
        let n = sk.len();
        let (parents, joints, tips) = (sk.parents_raw(), sk.joint_flags(), sk.tips());
        clip.sample_locals(from, &mut self.cursors, &mut self.trs, &mut self.l0);
        clip.sample_locals(to, &mut self.cursors, &mut self.trs, &mut self.l1);
        sk.model_matrices(&self.l1, &mut self.m1);
        let (l0, l1, m1, held, in_subtree) = (
            &self.l0,
            &self.l1,
            &self.m1,
            &mut self.held,
            &mut self.in_subtree,
        );
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
                    let origin = (held[x].w_axis - m1[x].w_axis).truncate().length();
                    let tip = held[x]
                        .transform_point3(tips[x])
                        .distance(m1[x].transform_point3(tips[x]));
                    let e = origin.max(tip);
                    e_max = e_max.max(e);
                    e_sum += e;
                }
            }
            max[i] = e_max;
            sum[i] = e_sum;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clip::{ChannelDesc, ClipOptions, Interpolation, Keys};
    use crate::ids::BoneId;
    use crate::priority::{Factor, PriorityWeights};
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
        let p = priorities(&clip, &sk);
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
}
