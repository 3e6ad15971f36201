//! Static per-keyframe bone priority tables (thesis chapters 10–12) as plain runtime data: six
//! sub-priorities per bone and key segment, each normalised by its maximum over the clip,
//! combined by a weighted average. The build step (`build::priorities`) computes them.
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
//! - **Rotation change is the speed of the bone's tip** (angle rate × the bone's tip length,
//!   [`crate::Skeleton::tip`]): a turn moves points at the bone's length, not at its origin,
//!   and the same angle on a long bone is more visible than on a short one.
//! - **A keyframe's priority describes the segment being played** (from key `k` to key `k + 1`):
//!   that is the motion a held bone misses. The thesis attaches the change *into* key `k`, one
//!   segment late.

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
    pub(crate) fn from_array(w: [f32; 6]) -> Self {
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
/// animated bone (`[segment * bones + slot]`, slot = position in [`crate::Clip::animated_bones`]);
/// structural factors per animated bone. The user factor is applied by the crowd.
#[derive(Clone, Debug, Default)]
pub(crate) struct SubPriorities {
    pub(crate) timeline: Vec<f32>,
    pub(crate) slots: usize,
    pub(crate) motion: [Vec<f32>; 3],
    pub(crate) descendants: Vec<f32>,
    pub(crate) depth: Vec<f32>,
    // Folded into the motion factors at build time; read back by tests only.
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) max_rate: [f32; 3],
    /// Measured hold error rate per `[segment * bones + slot]`: the fastest any joint moves away
    /// from where it should be while this bone alone holds (model units per second).
    pub(crate) hold_max: Vec<f32>,
    /// The same summed over the joints (model units per second).
    pub(crate) hold_sum: Vec<f32>,
    /// Largest `hold_max` of the clip.
    pub(crate) hold_max_peak: f32,
    /// Per animated-bone slot: the displacement (model units) a hold across the looping clip's
    /// end→start jump adds (the build step computes it).
    pub(crate) wrap_jump: Vec<f32>,
    /// How fast the measured points' velocities change (the bound of
    /// [`crate::LodMode::Interpolated`]).
    pub(crate) variation: crate::build::VariationTable,
}

impl SubPriorities {
    /// Number of key segments.
    pub(crate) fn segment_count(&self) -> usize {
        self.timeline.len().saturating_sub(1).max(1)
    }

    /// Number of animated bones (columns of the table).
    pub(crate) fn bone_count(&self) -> usize {
        self.slots
    }

    /// Start times of the segments and the end of the last one.
    #[cfg(test)]
    pub(crate) fn timeline(&self) -> &[f32] {
        &self.timeline
    }

    /// The segment playing at time `t` (wrapped clip time).
    #[inline]
    pub(crate) fn segment_at(&self, t: f32) -> usize {
        let n = self.timeline.len();
        if n < 2 {
            return 0;
        }
        self.timeline
            .partition_point(|&x| x <= t)
            .saturating_sub(1)
            .min(n - 2)
    }

    /// Largest translation (units/s), rotation (tip speed, units/s) and scale (1/s) rates over
    /// the clip: the normalisers of the motion factors.
    #[cfg(test)]
    pub(crate) fn max_rates(&self) -> [f32; 3] {
        self.max_rate
    }

    /// Measured hold error rate of animated bone `slot` in `segment`: how fast (model units per
    /// second) the joint origin or tip that drifts most moves away from its true position while
    /// this bone alone holds its local transform from the segment start. Computed by the build step by
    /// replaying the segment with the bone held.
    #[cfg(test)]
    pub(crate) fn hold_error_rate(&self, segment: usize, slot: usize) -> f32 {
        self.hold_max[segment * self.slots + slot]
    }

    /// The summed (over joints) hold error rate of animated bone `slot` in `segment`.
    pub(crate) fn hold_error_rate_sum(&self, segment: usize, slot: usize) -> f32 {
        self.hold_sum[segment * self.slots + slot]
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
    pub(crate) fn get(&self, factor: Factor, segment: usize, slot: usize) -> f32 {
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

#[cfg(test)]
mod tests {
    use super::*;

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
