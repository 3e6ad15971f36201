//! [`LodMode::Interpolated`]: whole key poses evaluated at error-bounded intervals, the model
//! matrices blended linearly between the last two.
//!
//! Based on the error of linear interpolation between samples of a trajectory (the build
//! step's `key_error` module derives the bound: a quarter of the interval times the velocity
//! variation over it, second order in the interval for smooth motion, where a hold's error is
//! first order), applied as keyframe reduction is in animation compression (ACL,
//! ozz-animation's keyframe optimiser) but at run time and per character: the next key is
//! placed as far ahead as the bound allows at the character's current on-screen size. A
//! character's frame then costs a blend of its model matrices; a key frame costs one
//! evaluation (sampling and concatenation of every animated bone).
//!
//! [`LodMode::KeyHold`] shares the key poses but never blends: each key pose stands over a
//! window centred on its own time (error first order, as a hold's, but spent both ways).
//!
//! Key times are whole frames of the character's current playback step ahead of the current
//! time, so at 60 Hz a key lands on a frame and that frame is exact. Keys never cross the end
//! of the clip. At a looping clip's wrap, the key pose at the clip's end stands in for the
//! start pose when the two are within a tenth of the tolerance (the build step measures the
//! end→start jump; it is added to the interval's bound); otherwise the wrap restarts from exact
//! poses.

use std::time::Instant;

use glam::{Affine3A, Mat4};
use rayon::prelude::*;

use super::frame::concat_bones;
use super::*;

/// Most frames a key interval may span (a far, slow character would otherwise go seconds
/// between keys, and a change of speed or camera would be noticed late).
const MAX_KEY_FRAMES: u32 = 32;

/// Share of the tolerance a character may spend holding its last key pose (no blend, no
/// skinning: its output is reused) before the next key is placed; the interpolation from that
/// key pose, whose bound covers the held time too, must still fit the whole tolerance.
const HOLD_SHARE: f32 = 0.5;

/// Largest share of the tolerance a looping clip's end→start jump may take for an
/// interpolation to continue across the wrap from the end key pose.
const WRAP_SHARE: f32 = 0.1;

/// Characters per parallel task.
const PARALLEL_CHUNK: usize = 32;

/// The blend weight of `to` at the character's current time.
#[inline]
pub(super) fn weight(c: &Character) -> f32 {
    let span = c.key_to - c.key_from;
    if span > 0.0 {
        ((c.time - c.key_from) / span).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// One character's bone arrays in the interpolated mode.
struct KeyLanes<'a> {
    locals: &'a mut [Affine3A],
    models: &'a mut [Mat4],
    from: &'a mut [Mat4],
    to: &'a mut [Mat4],
}

impl Crowd {
    /// The frame of [`LodMode::Interpolated`] (after `advance` moved every character's time
    /// and measured it in the view): per character, blend or place a new key.
    pub(super) fn advance_keyed(&mut self, max_error_px: f32, centred: bool) -> FrameStats {
        let (rig, stride, bones, timing) = (&*self.rig, self.stride, self.bones, self.stage_timing);
        let run = |chars: &mut [Character],
                   locals: &mut [Affine3A],
                   models: &mut [Mat4],
                   from: &mut [Mat4],
                   to: &mut [Mat4],
                   s: &mut Scratch| {
            let mut sum = FrameStats::default();
            for (i, c) in chars.iter_mut().enumerate() {
                if c.pose_shared {
                    let animated = rig.clips()[c.clip.index()].animated.len() as u64;
                    sum += FrameStats {
                        characters: 1,
                        characters_frozen: 1,
                        bones_held: animated,
                        bones_constant: bones as u64 - animated,
                        ..FrameStats::default()
                    };
                    c.key_update = KeyUpdate::Unchanged;
                    c.changed = false;
                    continue;
                }
                let r = i * stride..i * stride + bones;
                let lanes = KeyLanes {
                    locals: &mut locals[r.clone()],
                    models: &mut models[r.clone()],
                    from: &mut from[r.clone()],
                    to: &mut to[r],
                };
                sum += if centred {
                    advance_centred_character(rig, max_error_px, c, lanes, s, timing)
                } else {
                    advance_keyed_character(rig, max_error_px, c, lanes, s, timing)
                };
                if std::mem::take(&mut c.reset_unreported) {
                    c.key_update = KeyUpdate::Restarted;
                }
            }
            sum
        };
        if self.parallel {
            // Characters are independent: the poses and the stats (summed in chunk order)
            // equal a one-thread run's.
            let n = PARALLEL_CHUNK * stride;
            let per_chunk: Vec<FrameStats> = self
                .chars
                .par_chunks_mut(PARALLEL_CHUNK)
                .zip(self.locals.par_chunks_mut(n))
                .zip(self.models.par_chunks_mut(n))
                .zip(self.key_from.par_chunks_mut(n))
                .zip(self.key_to.par_chunks_mut(n))
                .map_init(
                    || Scratch::new(bones),
                    |s, ((((c, l), m), f), t)| run(c, l, m, f, t, s),
                )
                .collect();
            let mut stats = FrameStats::default();
            for st in per_chunk {
                stats += st;
            }
            stats
        } else {
            run(
                &mut self.chars,
                &mut self.locals,
                &mut self.models,
                &mut self.key_from,
                &mut self.key_to,
                &mut self.scratch,
            )
        }
    }
}

/// Evaluates the clip's pose at clip time `t` into `out` (model matrices of the bones that
/// move in the clip; the others keep the clip's static matrices), through `locals`.
fn evaluate(
    clip: &Clip,
    parents: &[u32],
    t: f32,
    s: &mut Scratch,
    locals: &mut [Affine3A],
    out: &mut [Mat4],
) {
    s.trs.prepare(clip.base_pose());
    clip.locate_all(t, &mut s.cursors);
    clip.sample_compose(&s.cursors, &mut s.trs, locals);
    concat_bones(parents, &clip.moving, locals, out);
}

/// `models[b] = from[b] + (to[b] − from[b]) · w` over the bones that move in the clip.
#[inline]
fn blend(moving: &[u32], from: &[Mat4], to: &[Mat4], w: f32, models: &mut [Mat4]) {
    for &b in moving {
        let b = b as usize;
        let (a, z) = (&from[b], &to[b]);
        models[b] = Mat4::from_cols(
            a.x_axis + (z.x_axis - a.x_axis) * w,
            a.y_axis + (z.y_axis - a.y_axis) * w,
            a.z_axis + (z.z_axis - a.z_axis) * w,
            a.w_axis + (z.w_axis - a.w_axis) * w,
        );
    }
}

/// A character's clip, its key-error table, its animated bone count, and the stats of a frame
/// that changes nothing (every animated bone held).
fn begin<'a>(
    rig: &'a Rig,
    c: &Character,
) -> (&'a Clip, &'a crate::build::VariationTable, u64, FrameStats) {
    let clip = &rig.clips()[c.clip.index()];
    let animated = clip.animated.len() as u64;
    let st = FrameStats {
        characters: 1,
        bones_constant: rig.bone_count() as u64 - animated,
        bones_held: animated,
        ..FrameStats::default()
    };
    (
        clip,
        &rig.priorities[c.clip.index()].variation,
        animated,
        st,
    )
}

/// One character's interpolated frame: blend within the current key interval, or place the
/// next key (restarting from exact poses when the interval cannot continue).
fn advance_keyed_character(
    rig: &Rig,
    max_error_px: f32,
    c: &mut Character,
    lanes: KeyLanes<'_>,
    s: &mut Scratch,
    timing: bool,
) -> FrameStats {
    let (clip, table, animated, mut st) = begin(rig, c);
    let KeyLanes {
        locals,
        models,
        from,
        to,
    } = lanes;
    c.key_update = KeyUpdate::Unchanged;
    c.changed = false;
    let was_holding = std::mem::take(&mut c.holding);
    if c.near_ppu <= 0.0 || animated == 0 {
        // Invisible (or nothing moves): skipped; it restarts from exact poses once visible.
        c.stale |= c.near_ppu <= 0.0;
        st.characters_frozen = 1;
        return st;
    }
    let tolerance = max_error_px / c.near_ppu;
    let t = c.time;
    // A wrap continues from the end key pose when the clip's end→start jump is small.
    let duration = clip.duration();
    let wrap_continues =
        c.wrapped && !c.stale && c.key_to >= duration && table.wrap_jump <= WRAP_SHARE * tolerance;
    if wrap_continues {
        (c.key_from, c.key_to) = (c.key_from - duration, 0.0);
    }
    let jump = if wrap_continues { table.wrap_jump } else { 0.0 };
    let restart = c.stale
        || (c.wrapped && !wrap_continues)
        || t < c.key_from
        || (t < c.key_to && c.key_error > tolerance);
    if !restart && t <= c.key_to {
        // Within the interval: blend (nothing to do when time stood still).
        if c.step > 0.0 {
            let clock = timing.then(Instant::now);
            blend(&clip.moving, from, to, weight(c), models);
            st.bones_blended = clip.moving.len() as u64;
            if let Some(t0) = clock {
                st.concat_ns += t0.elapsed().as_nanos() as u64;
            }
            c.changed = true;
        } else {
            st.characters_frozen = 1;
        }
        return st;
    }
    c.holding = was_holding;
    if !restart
        && !wrap_continues
        && c.step > 0.0
        && table.hold_error(c.key_to, t) <= HOLD_SHARE * tolerance
    {
        // Past the interval but still close to the last key pose: hold it (weight 1, so the
        // pose and any skinned output of `to` stand). The frame that starts the hold moves
        // the model matrices to `to` (the last blend may have stopped short of it).
        if c.holding {
            st.characters_frozen = 1;
        } else {
            blend(&clip.moving, from, to, 1.0, models);
            st.bones_blended = clip.moving.len() as u64;
            (c.holding, c.changed) = (true, true);
        }
        return st;
    }
    let clock = timing.then(Instant::now);
    let parents = rig.skeleton().parents_raw();
    let mut evaluations = 0u64;
    let start = if restart {
        evaluate(clip, parents, t, s, locals, to);
        evaluations += 1;
        c.key_update = KeyUpdate::Restarted;
        t
    } else {
        c.key_update = KeyUpdate::Advanced;
        c.key_to
    };
    from[..].copy_from_slice(to);
    // The farthest key, in whole steps ahead of now and not past the clip's end, whose
    // interpolation from `start` stays within the tolerance.
    let limit = clip.duration();
    let mut end = t;
    if c.step > 0.0 {
        for n in 1..=MAX_KEY_FRAMES {
            let candidate = (t + n as f32 * c.step).min(limit);
            if candidate <= end || jump + table.lerp_error(start, candidate) > tolerance {
                break;
            }
            end = candidate;
        }
    }
    if !(restart && end == t) {
        evaluate(clip, parents, end, s, locals, to);
        evaluations += 1;
    }
    (c.key_from, c.key_to, c.key_error, c.stale, c.holding) = (
        start,
        end,
        jump + table.lerp_error(start, end),
        false,
        false,
    );
    let w = weight(c);
    blend(&clip.moving, from, to, w, models);
    c.changed = true;
    st.key_poses = evaluations;
    // A bone counts once as interpolated when any key pose was evaluated this frame (a restart
    // evaluates two; `key_poses` says how many), so interpolated, held and constant bones still
    // partition the character's bones.
    st.bones_interpolated = if evaluations > 0 { animated } else { 0 };
    st.bones_held = animated - st.bones_interpolated;
    st.bones_concatenated = evaluations * clip.moving.len() as u64;
    st.bones_blended = clip.moving.len() as u64;
    if let Some(t0) = clock {
        // Key evaluation counted as sampling (its concatenation and the blend are a small
        // part of it).
        st.sample_ns += t0.elapsed().as_nanos() as u64;
    }
    st
}

/// One character's centred-hold frame ([`LodMode::KeyHold`]): nothing changes inside the
/// window; past it, the next key time `k` is the farthest whole step ahead whose path from now
/// stays within the tolerance, and the window ends at the farthest whole step after `k` whose
/// path from `k` does. The pose of `k` is shown from now to the window's end. Key times stay
/// within the clip (a looping clip's wrap starts a new window).
fn advance_centred_character(
    rig: &Rig,
    max_error_px: f32,
    c: &mut Character,
    lanes: KeyLanes<'_>,
    s: &mut Scratch,
    timing: bool,
) -> FrameStats {
    let (clip, table, animated, mut st) = begin(rig, c);
    st.characters_frozen = 1;
    let KeyLanes {
        locals,
        models,
        from,
        to,
    } = lanes;
    c.key_update = KeyUpdate::Unchanged;
    c.changed = false;
    if c.near_ppu <= 0.0 || animated == 0 {
        c.stale |= c.near_ppu <= 0.0;
        return st;
    }
    let tolerance = max_error_px / c.near_ppu;
    let t = c.time;
    // `key_from` and `key_to` hold the window (start, end); `key_error` its bound.
    let inside =
        !c.stale && !c.wrapped && t >= c.key_from && t <= c.key_to && c.key_error <= tolerance;
    if inside {
        return st;
    }
    let clock = timing.then(Instant::now);
    let limit = clip.duration();
    let step = c.step.max(0.0);
    // The farthest key time whose pose is within the tolerance of now's…
    let mut k = t;
    if step > 0.0 {
        for n in 1..=MAX_KEY_FRAMES {
            let candidate = (t + n as f32 * step).min(limit);
            if candidate <= k || table.hold_error(t, candidate) > tolerance {
                break;
            }
            k = candidate;
        }
    }
    // …and the farthest frame after it still within the tolerance of the key's pose.
    let mut end = k;
    if step > 0.0 {
        for n in 1..=MAX_KEY_FRAMES {
            let candidate = (k + n as f32 * step).min(limit);
            if candidate <= end || table.hold_error(k, candidate) > tolerance {
                break;
            }
            end = candidate;
        }
    }
    from[..].copy_from_slice(to);
    evaluate(clip, rig.skeleton().parents_raw(), k, s, locals, to);
    blend(&clip.moving, from, to, 1.0, models);
    (c.key_from, c.key_to, c.stale) = (t, end, false);
    c.key_error = table.hold_error(t, k).max(table.hold_error(k, end));
    c.key_update = KeyUpdate::Advanced;
    c.changed = true;
    st.characters_frozen = 0;
    st.key_poses = 1;
    st.bones_interpolated = animated;
    st.bones_held = 0;
    st.bones_concatenated = clip.moving.len() as u64;
    if let Some(t0) = clock {
        st.sample_ns += t0.elapsed().as_nanos() as u64;
    }
    st
}
