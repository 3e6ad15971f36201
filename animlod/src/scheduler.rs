//! The per-bone update scheduler: each frame, from a bone's current keyframe priority `P` and its
//! character's camera ratio `Ω`, decide whether the bone interpolates or holds its last local
//! transform.
//!
//! # The mapping
//!
//! The thesis uses a bone's LOD value `ℓ = P · Ω` as that bone's own update period ("the current
//! level of detail value of each bone will be used as the new time step"). Taken literally that
//! runs backwards — a far character (Ω → 0) would get a period near 0 and update *every* frame,
//! and a near one (Ω = 1) would wait up to a second — so we keep the idea, a period per bone
//! derived from `P · Ω`, and orient it so the contract holds:
//!
//! ```text
//!     period(P, Ω) = s · (1 − Ω) / (Ω · max(P, P_min))        seconds
//! ```
//!
//! where `s` is [`SchedulerParams::period_scale`] and `P_min` is
//! [`SchedulerParams::min_priority`]. A bone interpolates on the first frame at which the
//! time since its last interpolation (in the character's playback time) reaches its period; the
//! test is evaluated as `held · Ω · max(P, P_min) ≥ s · (1 − Ω)`, with no division, so that:
//! - Ω = 1 gives period 0: every animated bone interpolates every frame;
//! - Ω = 0 gives an infinite period: no bone interpolates;
//! - the period grows as P or Ω falls (fewer updates), and shrinks as they rise.
//!
//! `P` is read from the keyframe segment playing *now*, so a bone held through a quiet segment
//! catches up as soon as a lively one starts. `P_min` keeps a bone whose current segment is
//! still from being held forever at a stale pose from an earlier, moving segment.
//!
//! Why the period falls as `1/Ω` far away: in [`crate::LodMode::PixelSize`] Ω is proportional
//! to the projected size, a joint's on-screen speed is proportional to the projected size too,
//! so on-screen error ≈ speed · period stays roughly constant with distance.

use crate::error::{CrowdError, invalid};

/// Parameters of the period mapping (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SchedulerParams {
    /// `s`: the period, in seconds, of a bone with priority 1 at Ω = ½.
    pub period_scale: f32,
    /// `P_min`: priorities below this count as this (in `[0, 1]`).
    pub min_priority: f32,
}

impl Default for SchedulerParams {
    fn default() -> Self {
        SchedulerParams {
            period_scale: 0.02,
            min_priority: 0.05,
        }
    }
}

impl SchedulerParams {
    /// Checks `period_scale` is finite and positive and `min_priority` is in `[0, 1]`.
    pub fn validate(&self) -> Result<(), CrowdError> {
        if !(self.period_scale.is_finite() && self.period_scale > 0.0) {
            return Err(invalid("period_scale", "must be finite and positive"));
        }
        if !(0.0..=1.0).contains(&self.min_priority) {
            return Err(invalid("min_priority", "must be in [0, 1]"));
        }
        Ok(())
    }
}

/// The update period in seconds of a bone with priority `priority` in a character with camera
/// ratio `omega`: `s · (1 − Ω) / (Ω · max(P, P_min))`, 0 when Ω ≥ 1, infinite when Ω ≤ 0.
#[cfg(test)]
pub(crate) fn update_period(priority: f32, omega: f32, params: &SchedulerParams) -> f32 {
    if omega >= 1.0 {
        0.0
    } else if omega <= 0.0 {
        f32::INFINITY
    } else {
        params.period_scale * (1.0 - omega) / (omega * priority.max(params.min_priority))
    }
}

/// Decides for each animated bone slot `i` (priority `priorities[i]`, last interpolated at
/// `last[i]`) whether it interpolates now; writes `go[i]` (1 = interpolate), stamps
/// `last[i] = clock` for those that do, and returns how many do. Branch-free over contiguous
/// arrays: this loop is the whole cost of a held bone.
#[inline]
pub(crate) fn schedule(
    priorities: &[f32],
    omega: f32,
    params: &SchedulerParams,
    clock: f32,
    last: &mut [f32],
    go: &mut [u8],
) -> u32 {
    let threshold = params.period_scale * (1.0 - omega);
    let floor = params.min_priority;
    let n = priorities.len().min(last.len()).min(go.len());
    let (priorities, last, go) = (&priorities[..n], &mut last[..n], &mut go[..n]);
    let mut count = 0;
    for i in 0..n {
        let held = clock - last[i];
        let update = held * (omega * priorities[i].max(floor)) >= threshold;
        go[i] = update as u8;
        last[i] = if update { clock } else { last[i] };
        count += update as u32;
    }
    count
}

/// One character's error-bounded scheduling step ([`crate::LodMode::ErrorBound`]), as a job
/// with named fields (in the manner of ozz-animation's sampling jobs). Each animated-bone slot
/// `i` adds `step · rates[i]` (the drift its hold causes over this frame, model units; plus
/// `jumps[i]` when the step wrapped around a looping clip) to its running bound `drift[i]`.
/// A point of bone `i`'s subtree is displaced by at most the sum of the drifts of `i` and its
/// held animated ancestors (`chain[i]`), so, visiting parents first, slot `i` interpolates —
/// resetting its drift and stamping `last[i] = clock` — once `chain[i] · pixels_per_unit`
/// reaches `tolerance_px`. Every chain then stays under the tolerance: an ancestor's chain
/// already does when its descendants are visited.
pub(crate) struct ErrorBoundJob<'a> {
    /// Hold error rate of each slot over this frame's step (model units per second).
    pub(crate) rates: &'a [f32],
    /// Per slot: a displacement (model units) added once before the rate — the looping clip's
    /// end→start jump when this step wrapped; empty when it did not.
    pub(crate) jumps: &'a [f32],
    /// Per slot: the slot of its nearest animated ancestor (`u32::MAX`: none); ancestors come
    /// before their descendants.
    pub(crate) ancestors: &'a [u32],
    /// Playback seconds advanced this frame.
    pub(crate) step: f32,
    /// Pixels per model unit at the character's nearest visible depth.
    pub(crate) pixels_per_unit: f32,
    /// Largest on-screen displacement (pixels) the held bones may cause at any point.
    pub(crate) tolerance_px: f32,
    /// Clock time stamped on the slots that interpolate.
    pub(crate) clock: f32,
    /// Per slot: running drift bound of its hold (model units), updated.
    pub(crate) drift: &'a mut [f32],
    /// Per slot: clock time of the last interpolation, updated.
    pub(crate) last: &'a mut [f32],
    /// Per slot: written 1 if it interpolates now, else 0.
    pub(crate) go: &'a mut [u8],
    /// Per slot: scratch for the summed drift down its chain.
    pub(crate) chain: &'a mut [f32],
}

impl ErrorBoundJob<'_> {
    /// Runs the job over the shortest of its slices; returns how many slots interpolate.
    /// Branch-free over contiguous arrays.
    #[inline]
    pub(crate) fn run(self) -> u32 {
        let n = self
            .rates
            .len()
            .min(self.ancestors.len())
            .min(self.drift.len())
            .min(self.last.len())
            .min(self.go.len())
            .min(self.chain.len());
        let (rates, ancestors, drift, last, go, chain) = (
            &self.rates[..n],
            &self.ancestors[..n],
            &mut self.drift[..n],
            &mut self.last[..n],
            &mut self.go[..n],
            &mut self.chain[..n],
        );
        if !self.jumps.is_empty() {
            for (d, &j) in drift.iter_mut().zip(self.jumps) {
                *d += j;
            }
        }
        let (step, gain, tolerance, clock) = (
            self.step,
            self.pixels_per_unit,
            self.tolerance_px,
            self.clock,
        );
        let mut count = 0;
        for i in 0..n {
            let a = ancestors[i] as usize;
            let above = if a < i { chain[a] } else { 0.0 };
            let d = drift[i] + step * rates[i];
            let update = (above + d) * gain >= tolerance;
            go[i] = update as u8;
            drift[i] = if update { 0.0 } else { d };
            chain[i] = above + drift[i];
            last[i] = if update { clock } else { last[i] };
            count += update as u32;
        }
        count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn period_contract() {
        let p = SchedulerParams::default();
        assert_eq!(update_period(0.0, 1.0, &p), 0.0);
        assert_eq!(update_period(1.0, 0.0, &p), f32::INFINITY);
        // Monotone: lower priority or lower Ω → longer period.
        let mut last = 0.0;
        for i in (1..100).rev() {
            let t = update_period(0.5, i as f32 / 100.0, &p);
            assert!(t >= last);
            last = t;
        }
        assert!(update_period(0.2, 0.5, &p) > update_period(0.8, 0.5, &p));
        assert!(p.validate().is_ok());
        assert!(
            SchedulerParams {
                period_scale: 0.0,
                ..p
            }
            .validate()
            .is_err()
        );
        assert!(
            SchedulerParams {
                min_priority: f32::NAN,
                ..p
            }
            .validate()
            .is_err()
        );
    }

    #[test]
    fn schedule_extremes() {
        let p = SchedulerParams::default();
        let prio = [0.0, 0.5, 1.0];
        let mut last = [0.0f32; 3];
        let mut go = [0u8; 3];
        assert_eq!(schedule(&prio, 1.0, &p, 0.0, &mut last, &mut go), 3);
        assert_eq!(go, [1, 1, 1]);
        assert_eq!(schedule(&prio, 0.0, &p, 1e9, &mut last, &mut go), 0);
        assert_eq!(go, [0, 0, 0]);
        // A bone updates once its hold reaches its period.
        let period = update_period(0.5, 0.5, &p);
        let mut last = [0.0f32; 3];
        schedule(&prio, 0.5, &p, period * 0.9, &mut last, &mut go);
        assert_eq!(go[1], 0);
        schedule(&prio, 0.5, &p, period * 1.01, &mut last, &mut go);
        assert_eq!(go[1], 1);
        assert_eq!(last[1], period * 1.01);
    }
}
