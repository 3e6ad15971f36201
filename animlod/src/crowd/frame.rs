//! The frame: [`Crowd::advance`] samples, holds and concatenates every character under the
//! LOD mode (the scheduler of `animation-lod-bone-priority-thesis.txt`, chapters 11–13, and
//! the budget and error-bound modes beyond it).

use std::time::Instant;

use glam::{Affine3A, Mat4};
use rayon::prelude::*;
use salience::View;

use super::*;

/// Model-space concatenation with skipping: a bone is recomputed iff it or an ancestor changed
/// (`mask`); returns how many were. Branch-free flag propagation and compaction into `list`
/// first (the changed set is data-dependent, so a branch per bone would mispredict often), then
/// one pass over the changed bones. `dirty` has one extra, always-zero slot that roots point at.
#[inline]
fn concat_changed(
    parents: &[u32],
    sentinel_parents: &[u32],
    mask: &[u8],
    dirty: &mut [u8],
    list: &mut [u32],
    locals: &[Affine3A],
    models: &mut [Mat4],
) -> u32 {
    let n = parents.len();
    let (mask, dirty, list, sp) = (
        &mask[..n],
        &mut dirty[..n + 1],
        &mut list[..n],
        &sentinel_parents[..n],
    );
    dirty[n] = 0;
    let mut k = 0usize;
    for b in 0..n {
        let d = mask[b] | dirty[sp[b] as usize];
        dirty[b] = d;
        list[k] = b as u32;
        k += d as usize;
    }
    for &b in &list[..k] {
        let b = b as usize;
        let p = parents[b];
        models[b] = if p == NO_PARENT {
            Mat4::from(locals[b])
        } else {
            concat(&models[p as usize], &locals[b])
        };
    }
    k as u32
}

/// The row of a per-segment table (`slots` wide) for a character's last playback step: the
/// row of the segment playing now, or, when the step crossed key boundaries, the element-wise
/// maximum over every segment it touched (in `buf`). Without this, motion in the part of a step
/// that fell in the previous segment would be missed whenever the new segment is quiet.
pub(super) fn step_row<'a>(
    table: &'a [f32],
    slots: usize,
    segments: usize,
    c: &Character,
    buf: &'a mut Vec<f32>,
) -> &'a [f32] {
    let (a, b) = (c.prev_segment as usize, c.segment as usize);
    if a == b && !c.wrapped {
        return &table[b * slots..(b + 1) * slots];
    }
    buf.clear();
    buf.extend_from_slice(&table[b * slots..(b + 1) * slots]);
    let mut k = a;
    for _ in 0..segments {
        if k == b && !(a == b && c.wrapped) {
            break;
        }
        for (o, &x) in buf.iter_mut().zip(&table[k * slots..(k + 1) * slots]) {
            *o = o.max(x);
        }
        k = (k + 1) % segments;
        if k == b {
            break;
        }
    }
    buf
}

/// Full-detail model-space pass over the bones that move in this clip (a precomputed list, so
/// no per-bone flag tests).
#[inline]
pub(super) fn concat_moving(
    parents: &[u32],
    moving: &[u32],
    locals: &[Affine3A],
    models: &mut [Mat4],
) {
    for &b in moving {
        let b = b as usize;
        let p = parents[b];
        models[b] = if p == NO_PARENT {
            Mat4::from(locals[b])
        } else {
            concat(&models[p as usize], &locals[b])
        };
    }
}

impl Crowd {
    /// The budget units LOD off's path costs: every character's animated bones through the
    /// block path, a [`BLOCK_SHARE`]th of them rounded up each (see
    /// [`FrameStats::budget_units`]).
    fn full_detail_units(&self) -> u64 {
        self.chars
            .iter()
            .map(|c| block_units(self.rig.clips()[c.clip.index()].animated.len()))
            .sum()
    }

    /// Evaluates a character's full pose at its current time and stamps every bone as updated.
    pub(super) fn evaluate_full(&mut self, d: usize) {
        let span = self.span(d);
        let clip = &self.rig.clips()[self.chars[d].clip.index()];
        let seg =
            self.rig.priorities[self.chars[d].clip.index()].segment_at(self.chars[d].time) as u32;
        let c = &mut self.chars[d];
        (c.segment, c.prev_segment, c.wrapped, c.changed) = (seg, seg, false, true);
        let c = *c;
        let locals = &mut self.locals[span.clone()];
        let s = &mut self.scratch;
        clip.sample_locals(c.time, &mut s.cursors, &mut s.trs, locals);
        self.rig
            .skeleton()
            .model_matrices(locals, &mut self.models[span.clone()]);
        self.last_update[span.clone()].fill(c.clock);
        self.drift[span.clone()].fill(0.0);
        if self.keyed() {
            self.key_from[span.clone()].copy_from_slice(&self.models[span.clone()]);
            self.key_to[span.clone()].copy_from_slice(&self.models[span]);
            let c = &mut self.chars[d];
            (c.key_from, c.key_to, c.key_error) = (c.time, c.time, 0.0);
            (c.stale, c.key_update, c.holding) = (false, KeyUpdate::Restarted, false);
            c.reset_unreported = true;
        }
    }

    /// Advances every character by `dt` seconds (finite, ≥ 0) and updates their poses under the
    /// current LOD mode, as seen through `view` (distances, projected sizes and visibility are
    /// measured in it this frame; the crowd keeps no copy). Refused (state unchanged) for a bad
    /// `dt`.
    pub fn advance(&mut self, dt: f32, view: &View) -> Result<FrameStats, CrowdError> {
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(invalid("dt", "must be finite and non-negative"));
        }
        let (center, radius) = self.rig.bounds();
        let lod = self.lod;
        let (rig, stride) = (&self.rig, self.stride);
        for (d, c) in self.chars.iter_mut().enumerate() {
            let clip = &rig.clips()[c.clip.index()];
            let mut step = dt * c.speed;
            let before = c.time;
            if c.once {
                // Stops on the last pose: only the time actually played counts as a step (a
                // finished character accumulates no drift).
                c.time = (c.time + step).min(clip.duration());
                step = c.time - before;
                c.wrapped = false;
            } else {
                c.time = clip.wrap_time(c.time + step);
                c.wrapped = c.time < before;
            }
            c.prev_segment = c.segment;
            c.segment = rig.priorities[c.clip.index()].segment_at(c.time) as u32;
            c.clock += step;
            if c.clock > CLOCK_REBASE {
                let shift = 0.5 * CLOCK_REBASE;
                c.clock -= shift;
                self.last_update[d * stride..(d + 1) * stride]
                    .iter_mut()
                    .for_each(|l| *l -= shift);
            }
            c.step = step;
            let world = c.world().transform_point3(center);
            let radius = radius * c.scale;
            c.size_px = view.projected_radius_px(world, radius);
            // Pixels per model unit: the view's per world unit times the character's scale.
            c.near_ppu = view.max_pixels_per_unit(world, radius) * c.scale;
            let visible = view.sphere_in_view(world, radius);
            c.omega = match lod {
                LodMode::Off
                | LodMode::Budget { .. }
                | LodMode::ErrorBound { .. }
                | LodMode::Interpolated { .. }
                | LodMode::KeyHold { .. } => 1.0,
                LodMode::Ratio(o) => o,
                LodMode::Range { min, max } => {
                    if visible {
                        omega_from_distance(view.distance(world), min, max)
                    } else {
                        0.0
                    }
                }
                LodMode::PixelSize {
                    full_detail_px,
                    freeze_below_px,
                } => omega_from_pixels(c.size_px, full_detail_px, freeze_below_px),
            };
        }
        if let LodMode::Interpolated { max_error_px } | LodMode::KeyHold { max_error_px } = lod {
            let centred = matches!(lod, LodMode::KeyHold { .. });
            let stats = self.advance_keyed(max_error_px, centred);
            self.last_stats = stats;
            return Ok(stats);
        }
        let mut stats = FrameStats::default();
        let budget = match lod {
            // A budget that affords every character through the block path takes LOD off's
            // path (one block pass per character, no scores, no error): the budget mode does no
            // more work than LOD off. Before this rule and the block path in budget mode, 100
            // GDBot characters (153 bones) at budgets of 25%, 50% and 76% of the animated
            // bones cost 1.03x, 1.28x and 1.53x of LOD off, picking bones out one by one.
            LodMode::Budget {
                bone_updates_per_frame,
            } => {
                let full = self.full_detail_units();
                if (bone_updates_per_frame as u64) < full {
                    Some(self.budget_cut(bone_updates_per_frame))
                } else {
                    stats.budget_units = full;
                    None
                }
            }
            _ => None,
        };
        let mut partial_left = budget.map_or(0, |b| b.1);
        // Rotate the starting character each frame so that no character is always first to the
        // budget's last, partially admitted score bin.
        let len = self.chars.len();
        let start = if len > 0 {
            (self.frame % len as u64) as usize
        } else {
            0
        };
        self.frame = self.frame.wrapping_add(1);
        let shared = Shared {
            rig: &self.rig,
            lod: self.lod,
            params: &self.params,
            tables: &self.tables,
            stage_timing: self.stage_timing,
            bones: self.bones,
        };
        let stride = self.stride;
        if self.parallel && budget.is_none() {
            // Characters are independent outside budget mode: chunks of them run on the rayon
            // pool, each with its own scratch; the stats are summed in chunk order, so the
            // poses and counts equal a serial run's.
            let per_chunk: Vec<FrameStats> = self
                .chars
                .par_chunks_mut(PARALLEL_CHUNK)
                .zip(self.locals.par_chunks_mut(PARALLEL_CHUNK * stride))
                .zip(self.models.par_chunks_mut(PARALLEL_CHUNK * stride))
                .zip(self.last_update.par_chunks_mut(PARALLEL_CHUNK * stride))
                .zip(self.drift.par_chunks_mut(PARALLEL_CHUNK * stride))
                .map_init(
                    || Scratch::new(shared.bones),
                    |s, ((((chars, locals), models), last), drift)| {
                        let mut sum = FrameStats::default();
                        for (i, c) in chars.iter_mut().enumerate() {
                            let r = i * stride..i * stride + shared.bones;
                            let lanes = Lanes {
                                locals: &mut locals[r.clone()],
                                models: &mut models[r.clone()],
                                last: &mut last[r.clone()],
                                drift: &mut drift[r],
                            };
                            let st = advance_character(&shared, c, lanes, s, None, &mut 0);
                            c.changed = st.bones_concatenated > 0;
                            sum += st;
                        }
                        sum
                    },
                )
                .collect();
            for st in per_chunk {
                stats += st;
            }
        } else {
            let bins = std::mem::take(&mut self.scratch.bins);
            let mut d = start;
            for _ in 0..len {
                let r = d * stride..d * stride + self.bones;
                let lanes = Lanes {
                    locals: &mut self.locals[r.clone()],
                    models: &mut self.models[r.clone()],
                    last: &mut self.last_update[r.clone()],
                    drift: &mut self.drift[r],
                };
                let cut = budget.map(|b| (b.0, &bins[d * stride..(d + 1) * stride]));
                let c = &mut self.chars[d];
                let st =
                    advance_character(&shared, c, lanes, &mut self.scratch, cut, &mut partial_left);
                c.changed = st.bones_concatenated > 0;
                stats += st;
                d += 1;
                if d == len {
                    d = 0;
                }
            }
            self.scratch.bins = bins;
        }
        self.last_stats = stats;
        Ok(stats)
    }
}

/// Budget units of `slots` animated bones interpolated through the block path: a
/// [`BLOCK_SHARE`]th of them, rounded up.
fn block_units(slots: usize) -> u64 {
    slots.div_ceil(BLOCK_SHARE) as u64
}

/// In budget mode a character with at least this fraction's inverse of its animated bones
/// admitted takes the block path (every animated bone, sampled block by block and concatenated
/// in one pass) and counts that fraction of them. The break-even depends on the rig (a picked
/// bone re-concatenates its whole subtree) and on how fast the block path is; measured with
/// `cargo run --release -p slod-demo -- crowd --gltf RIG --budget N` (100 characters grown to
/// 153 bones; LOD cost over LOD off, after the two-pass block sampling): with 6, GDBot and
/// RobotExpressive cost 0.59-0.61x at 5% of their bones, 0.72-0.76x at 9%, 0.81-0.86x at
/// 13%, 1.00-1.01x from a sixth on (LOD off's path); Fox and Godot_PlatformerRobot 0.88-0.94x
/// at 5% but 1.03-1.19x at 9-13%. With 4 or 5, Fox and Godot_PlatformerRobot cost 1.10-1.47x
/// at 9-22%; with 8, GDBot cost 1.04-1.08x at 13%. A per-character cost model (the subtrees the
/// picked bones dirty) would place the break-even per rig.
pub(super) const BLOCK_SHARE: usize = 6;

/// Characters per parallel task (enough work per task to outweigh scheduling).
const PARALLEL_CHUNK: usize = 32;

/// What every character of a frame reads.
struct Shared<'a> {
    rig: &'a Rig,
    lod: LodMode,
    params: &'a SchedulerParams,
    tables: &'a [Vec<f32>],
    stage_timing: bool,
    bones: usize,
}

/// One character's bone arrays.
struct Lanes<'a> {
    locals: &'a mut [Affine3A],
    models: &'a mut [Mat4],
    last: &'a mut [f32],
    drift: &'a mut [f32],
}

/// Samples, holds and concatenates one character under the frame's LOD mode; `budget` is the
/// budget's cut and this character's score bins (budget mode only).
fn advance_character(
    sh: &Shared<'_>,
    c: &mut Character,
    lanes: Lanes<'_>,
    s: &mut Scratch,
    budget: Option<(usize, &[u16])>,
    partial_left: &mut u32,
) -> FrameStats {
    let n = sh.bones;
    let c = *c;
    let rig = sh.rig;
    let clip = &rig.clips()[c.clip.index()];
    let parents = rig.skeleton().parents_raw();
    let animated = clip.animated.len() as u64;
    let mut st = FrameStats {
        characters: 1,
        bones_constant: n as u64 - animated,
        ..FrameStats::default()
    };
    let Lanes {
        locals,
        models,
        last,
        drift,
    } = lanes;
    let error_bound = match sh.lod {
        LodMode::ErrorBound { max_error_px } => Some(max_error_px),
        _ => None,
    };
    let slots = clip.animated.len();
    let mut full = budget.is_none() && error_bound.is_none() && c.omega >= 1.0;
    if budget.is_none() && error_bound.is_none() && c.omega <= 0.0 {
        st.bones_held = animated;
        st.characters_frozen = 1;
        return st;
    }
    let mut count = slots;
    if !full {
        let sub = &rig.priorities[c.clip.index()];
        let go = &mut s.go[..slots];
        let last = &mut last[..slots];
        count = match budget {
            None if error_bound.is_some() => {
                let rates = step_row(&sub.hold_max, slots, sub.segment_count(), &c, &mut s.row);
                let tol = error_bound.unwrap_or(f32::INFINITY);
                ErrorBoundJob {
                    rates,
                    jumps: if c.wrapped { &sub.wrap_jump } else { &[] },
                    ancestors: &clip.ancestor_slot,
                    step: c.step,
                    pixels_per_unit: c.near_ppu,
                    tolerance_px: tol,
                    clock: c.clock,
                    drift: &mut drift[..slots],
                    last,
                    go,
                    chain: &mut s.chain[..slots],
                }
                .run()
            }
            None => {
                let row = step_row(
                    &sh.tables[c.clip.index()],
                    slots,
                    sub.segment_count(),
                    &c,
                    &mut s.row,
                );
                schedule(row, c.omega, sh.params, c.clock, last, go)
            }
            Some((cut, bins)) => {
                // Drifts and bins were updated by `budget_cut` this frame.
                let bins = &bins[..slots];
                let mut count = 0;
                for (((g, l), e), &bin) in go
                    .iter_mut()
                    .zip(last.iter_mut())
                    .zip(drift[..slots].iter_mut())
                    .zip(bins)
                {
                    let bin = bin as usize;
                    let partial = bin == cut && *partial_left > 0;
                    let update = bin > cut || partial;
                    *partial_left -= partial as u32;
                    *l = if update { c.clock } else { *l };
                    *e = if update { 0.0 } else { *e };
                    *g = update as u8;
                    count += update as u32;
                }
                count
            }
        } as usize;
        if count == 0 {
            st.bones_held = animated;
            st.characters_frozen = 1;
            return st;
        }
        // When most bones are due anyway, interpolating all of them through the contiguous
        // block path costs less than picking them out one by one. In budget mode from a
        // sixth of them on, counted as a sixth (see `BLOCK_SHARE`).
        let block = match budget {
            Some(_) => count as u64 >= block_units(slots),
            None => 2 * count >= slots,
        };
        if budget.is_some() {
            st.budget_units = if block {
                block_units(slots)
            } else {
                count as u64
            };
        }
        if block {
            full = true;
            count = slots;
        }
    }
    st.bones_interpolated = count as u64;
    st.bones_held = animated - count as u64;
    let clock = sh.stage_timing.then(Instant::now);
    s.trs.prepare(clip.base_pose());
    clip.locate_all(c.time, &mut s.cursors);
    if full {
        clip.sample_compose(&s.cursors, &mut s.trs, locals);
        last[..slots].fill(c.clock);
        drift[..slots].fill(0.0);
        let sampled = clock.map(|t| (t, Instant::now()));
        concat_moving(parents, &clip.moving, locals, models);
        st.bones_concatenated = clip.moving.len() as u64;
        stage_times(&mut st, sampled);
        return st;
    }
    // Branch-free: the update pattern is data-dependent.
    s.mask.fill(0);
    let mut k = 0usize;
    for (i, (&b, &g)) in clip.animated.iter().zip(&s.go[..slots]).enumerate() {
        s.mask[b as usize] = g;
        s.updated[k] = i as u32;
        k += g as usize;
    }
    clip.sample_slots(&s.cursors, &s.updated[..k], &mut s.trs, locals);
    let sampled = clock.map(|t| (t, Instant::now()));
    let sentinel = rig.skeleton().parents_sentinel();
    st.bones_concatenated = concat_changed(
        parents,
        sentinel,
        &s.mask,
        &mut s.dirty,
        &mut s.list,
        locals,
        models,
    ) as u64;
    stage_times(&mut st, sampled);
    st
}

/// With stage timing on: the sampling time (from `start` to `sampled`) and the concatenation
/// time (from `sampled` to now) of one character, added to its stats.
#[inline]
fn stage_times(st: &mut FrameStats, stamps: Option<(Instant, Instant)>) {
    if let Some((start, sampled)) = stamps {
        st.sample_ns += (sampled - start).as_nanos() as u64;
        st.concat_ns += sampled.elapsed().as_nanos() as u64;
    }
}
