//! A crowd of characters sharing one rig: per-character state (position, clip, playback time,
//! local and model matrices, last-update stamps), the LOD mode, and the frame loop that samples,
//! schedules and concatenates as seen through the frame's [`salience::View`].
//!
//! Per-character bone data lives in crowd-wide arrays (`characters × bones`), so a frame walks
//! contiguous memory. Characters are kept dense (removal moves the last one into the hole); ids
//! go through a generational slot table.
//!
//! By subject: this file holds the storage (characters, slots, settings, accessors);
//! `frame` the frame (`advance`: sampling, holds, concatenation), `budget` the crowd
//! budget's histogram cut, `error` the pose error against full-rate evaluation.

use std::sync::Arc;

use slod_core::{Arena, Generations, Handle};

use glam::{Affine3A, Mat4, Quat, Vec3};

use crate::clip::{Clip, Cursor, TrsScratch};
use crate::error::{CrowdError, invalid};
use crate::ids::{BoneId, CharacterId, ClipId, SkinId};
use crate::lod::{LodMode, omega_from_distance, omega_from_pixels};
use crate::pose_error::{ErrorSum, PoseError};
use crate::priority::PriorityWeights;
use crate::rig::Rig;
use crate::scheduler::{ErrorBoundJob, SchedulerParams, schedule};
use crate::skeleton::NO_PARENT;
use crate::transform::concat;

/// Where a crowd's bone priorities come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PrioritySource {
    /// The thesis: a weighted average of the six sub-priorities ([`PriorityWeights`], user
    /// values).
    #[default]
    Factors,
    /// The measured hold error rate of each bone keyframe over its clip's peak — what the six
    /// factors approximate (see the priority table\'s `hold_error_rate`).
    HoldError,
}

/// What a frame did, summed over the crowd.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Characters advanced.
    pub characters: u32,
    /// Characters with Ω = 0 (or no budget share), or showing a shared pose
    /// ([`Crowd::set_pose_shared`]): nothing of them was interpolated.
    pub characters_frozen: u32,
    /// Animated bones that interpolated their channels this frame.
    pub bones_interpolated: u64,
    /// Animated bones that held their last local transform.
    pub bones_held: u64,
    /// Bones with no animated channel in the current clip (constant; never sampled).
    pub bones_constant: u64,
    /// Model-space matrices recomputed (a bone whose own and all ancestors' local transforms held
    /// is skipped).
    pub bones_concatenated: u64,
    /// With [`Crowd::set_stage_timing`] on: nanoseconds spent sampling (locating keys,
    /// interpolating, composing local matrices); 0 otherwise.
    pub sample_ns: u64,
    /// With [`Crowd::set_stage_timing`] on: nanoseconds spent concatenating local to model
    /// matrices (and, in [`LodMode::Interpolated`], blending them between key poses); 0
    /// otherwise.
    pub concat_ns: u64,
    /// [`LodMode::Interpolated`]: model matrices blended between two key poses (no sampling,
    /// no concatenation).
    pub bones_blended: u64,
    /// [`LodMode::Interpolated`]: whole key poses evaluated (sampled and concatenated).
    pub key_poses: u64,
    /// [`LodMode::Budget`]: the budget's units spent. A bone picked out one by one counts 1; a
    /// character whose admitted bones the crowd's cost model prices above its block path
    /// (every animated bone sampled in lanes and concatenated in one pass) takes that path
    /// and counts its admitted bones, at most a sixth of its animated bones rounded up: never
    /// more than `bone_updates_per_frame`. A frame on LOD off's path counts a sixth of every
    /// character's animated bones: when the budget affords that, and on the
    /// `BUDGET_RETRY_FRAMES` (30) frames after a frame whose work and scoring the cost model
    /// priced at LOD off's or more (then it exceeds the budget, doing less work and no error:
    /// the budget mode never costs more than LOD off). 0 in other modes.
    /// `bones_interpolated` counts the bones actually interpolated, which may be more.
    pub budget_units: u64,
}

impl std::ops::AddAssign for FrameStats {
    fn add_assign(&mut self, o: Self) {
        self.characters += o.characters;
        self.characters_frozen += o.characters_frozen;
        self.bones_interpolated += o.bones_interpolated;
        self.bones_held += o.bones_held;
        self.bones_constant += o.bones_constant;
        self.bones_concatenated += o.bones_concatenated;
        self.sample_ns += o.sample_ns;
        self.concat_ns += o.concat_ns;
        self.bones_blended += o.bones_blended;
        self.key_poses += o.key_poses;
        self.budget_units += o.budget_units;
    }
}

/// When a character's clock passes this many seconds, it and its stamps move back by half.
const CLOCK_REBASE: f32 = 1024.0;

#[derive(Clone, Copy, Debug)]
struct Character {
    id: CharacterId,
    position: Vec3,
    /// Orientation of the character (applied to its skeleton model space).
    rotation: Quat,
    /// Uniform scale of the character.
    scale: f32,
    clip: ClipId,
    /// Playback time, wrapped into the clip.
    time: f32,
    /// Key segment (of the clip's priority timeline) playing now, and before the last step.
    segment: u32,
    prev_segment: u32,
    /// Whether the last step wrapped around the end of the clip.
    wrapped: bool,
    /// Plays the clip once and stops on its last pose (instead of looping).
    once: bool,
    speed: f32,
    /// Playback seconds elapsed (holds are timed on it), kept below [`CLOCK_REBASE`] by shifting
    /// it and the last-update stamps together, so f32 keeps sub-millisecond resolution.
    clock: f32,
    omega: f32,
    size_px: f32,
    /// Playback seconds advanced this frame.
    step: f32,
    /// Pixels per unit at the nearest visible point of the bounding sphere (0: invisible).
    near_ppu: f32,
    /// Whether any model matrix changed in the last advance (or evaluation).
    changed: bool,
    /// Whether the host shows a shared pose for it (see [`Crowd::set_pose_shared`]).
    pose_shared: bool,
    /// [`LodMode::Interpolated`]: clip times of the two key poses the model matrices are
    /// blended between.
    key_from: f32,
    key_to: f32,
    /// [`LodMode::Interpolated`]: bound (model units) on the blend's error over the interval.
    key_error: f32,
    /// [`LodMode::Interpolated`]: the character was skipped while invisible; it restarts from
    /// exact poses when it comes back into view.
    stale: bool,
    /// What the last advance did to the key poses.
    key_update: KeyUpdate,
    /// The key poses were reset (added, a LOD mode change) since the last keyed advance: that
    /// advance reports [`KeyUpdate::Restarted`] whatever it did, since a host that reads the
    /// update after each advance has no copies of the reset poses yet.
    reset_unreported: bool,
    /// [`LodMode::Interpolated`]: holding the `to` pose past the interval's end.
    holding: bool,
}

/// What the last [`Crowd::advance`] did to a character's key poses ([`Crowd::key_poses`]):
/// what a host that keeps one skinned copy (or palette) per key pose must recompute.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum KeyUpdate {
    /// Neither key pose changed (only the blend weight may have).
    #[default]
    Unchanged,
    /// The old `to` became `from` and a new `to` was evaluated: swap the two copies and
    /// recompute `to`'s.
    Advanced,
    /// Both key poses were evaluated anew (first frame, a looping clip's wrap, a jump in time,
    /// a mode change, a camera that came closer than the bound allows): recompute both. The
    /// first advance after a character is added or the LOD mode changes always reports it, so
    /// a host that reads the update only after advances starts from the right copies.
    Restarted,
}

/// A character's two key poses and the blend weight of its current pose:
/// `model = from + (to − from) · weight`, matrix by matrix. Outside
/// [`LodMode::Interpolated`], `from` and `to` are both the current model matrices, weight 1.
#[derive(Clone, Copy, Debug)]
pub struct KeyPoses<'a> {
    /// Model matrices of the earlier key pose (skeleton model space).
    pub from: &'a [Mat4],
    /// Model matrices of the later key pose.
    pub to: &'a [Mat4],
    /// Blend weight in [0, 1] of `to`.
    pub weight: f32,
    /// What the last advance changed.
    pub update: KeyUpdate,
}

impl Character {
    /// Model-to-world transform: scale, rotation, then translation.
    #[inline]
    fn world(&self) -> Affine3A {
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(self.scale),
            self.rotation,
            self.position,
        )
    }
}

/// Scratch reused every frame (no allocation in the frame loop once warmed up).
#[derive(Clone, Debug, Default)]
struct Scratch {
    trs: TrsScratch,
    cursors: Vec<Cursor>,
    /// Bit set over the skeleton's depth-first order: the picked bones (see `dirty_subtrees`).
    bits: Vec<u64>,
    /// Per animated-bone slot: 1 if it interpolates this frame.
    go: Vec<u8>,
    /// Per animated-bone slot: priorities or rates max-combined over the segments a step crossed.
    row: Vec<f32>,
    /// Error-bound mode: per animated-bone slot, the summed drift down its chain of ancestors.
    chain: Vec<f32>,

    /// The slots that interpolate this frame (first entries).
    updated: Vec<u32>,
    /// The bones whose model matrix is recomputed this frame (first entries).
    list: Vec<u32>,
    /// Budget mode: each animated-bone slot's score bin this frame (per character stride).
    bins: Vec<u16>,
    /// Budget mode: each character's highest score bin this frame (a character whose highest
    /// bin is below the cut holds every bone without looking at them).
    top_bin: Vec<u16>,
}

impl Scratch {
    /// Scratch for a rig of `bones` bones.
    fn new(bones: usize) -> Scratch {
        Scratch {
            bits: vec![0; bones.div_ceil(64)],
            go: vec![0; bones],
            updated: vec![0; bones],
            list: vec![0; bones],
            chain: vec![0.0; bones],
            ..Scratch::default()
        }
    }
}

/// Characters sharing one rig, animated with bone-priority LOD.
#[derive(Clone, Debug)]
pub struct Crowd {
    rig: Arc<Rig>,
    bones: usize,
    /// Per-character stride of the bone arrays: the bone count made odd, so two characters'
    /// model matrices are never a multiple of 4 KiB apart (that aliasing made loads of a parent's
    /// fresh model matrix wait on unrelated stores and cost half the model-space pass).
    stride: usize,
    /// Id → dense index (generational: a removed character's id goes stale).
    slots: Arena<u32>,
    chars: Vec<Character>,
    locals: Vec<Affine3A>,
    models: Vec<Mat4>,
    /// [`LodMode::Interpolated`] only (empty otherwise): per character, the model matrices of
    /// the earlier and the later key pose (same stride as `models`).
    key_from: Vec<Mat4>,
    key_to: Vec<Mat4>,
    /// Per character, per animated-bone slot of its clip: clock time of the last interpolation.
    last_update: Vec<f32>,
    /// Per character, per animated-bone slot: bound on the drift of its hold so far (model
    /// units; used by [`LodMode::ErrorBound`]).
    drift: Vec<f32>,
    lod: LodMode,
    params: SchedulerParams,
    weights: PriorityWeights,
    source: PrioritySource,
    user: Vec<f32>,
    /// Combined priority table per clip, `[segment * animated + slot]`.
    tables: Vec<Vec<f32>>,
    /// Whether `advance` times its sampling and concatenation stages (see [`FrameStats`]).
    stage_timing: bool,
    /// What the last `advance` did.
    last_stats: FrameStats,
    /// Whether `advance` splits the characters over the rayon pool (not in budget mode).
    parallel: bool,
    /// Frames advanced (rotates the budget's processing order).
    frame: u64,
    /// Budget and error-bound modes: frames left that take LOD off's path because the cost
    /// model priced the mode's last frame at LOD off's cost or more.
    budget_lod_off_frames: u32,
    scratch: Scratch,
}

/// The arena handle of a character id.
fn handle(id: CharacterId) -> Handle {
    Handle::from_raw(id.index(), id.generation())
}

fn check_finite3(v: Vec3, what: &'static str) -> Result<(), CrowdError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(invalid(what, "must be finite"))
    }
}

impl Crowd {
    /// An empty crowd for `rig`, with LOD off, the default scheduler, equal priority
    /// weights and every user priority 1.
    pub fn new(rig: Arc<Rig>) -> Crowd {
        let bones = rig.bone_count();
        let mut crowd = Crowd {
            rig,
            bones,
            stride: bones | 1,
            slots: Arena::new(Generations::PerSlot),
            chars: Vec::new(),
            locals: Vec::new(),
            models: Vec::new(),
            key_from: Vec::new(),
            key_to: Vec::new(),
            last_update: Vec::new(),
            drift: Vec::new(),
            lod: LodMode::default(),
            params: SchedulerParams::default(),
            weights: PriorityWeights::EQUAL,
            source: PrioritySource::Factors,
            user: vec![1.0; bones],
            tables: Vec::new(),
            stage_timing: false,
            last_stats: FrameStats::default(),
            frame: 0,
            budget_lod_off_frames: 0,
            scratch: Scratch::new(bones),
            parallel: false,
        };
        crowd.rebuild_tables();
        crowd
    }

    /// The shared rig.
    pub fn rig(&self) -> &Arc<Rig> {
        &self.rig
    }

    /// Number of live characters.
    pub fn len(&self) -> usize {
        self.chars.len()
    }

    /// Whether the crowd has no character.
    pub fn is_empty(&self) -> bool {
        self.chars.is_empty()
    }

    /// Ids of the live characters (in storage order, which removal changes).
    pub fn character_ids(&self) -> impl ExactSizeIterator<Item = CharacterId> + '_ {
        self.chars.iter().map(|c| c.id)
    }

    /// Whether `id` names a live character.
    pub fn contains(&self, id: CharacterId) -> bool {
        self.dense(id).is_ok()
    }

    /// Where character `d`'s bones lie in the per-character arrays.
    #[inline]
    fn span(&self, d: usize) -> std::ops::Range<usize> {
        d * self.stride..d * self.stride + self.bones
    }

    fn dense(&self, id: CharacterId) -> Result<usize, CrowdError> {
        self.slots
            .get(handle(id))
            .map(|&d| d as usize)
            .ok_or(CrowdError::StaleCharacter(id))
    }

    fn clip_ref(&self, clip: ClipId) -> Result<&Clip, CrowdError> {
        self.rig.clip(clip).ok_or(CrowdError::UnknownClip(clip))
    }

    /// Adds a character at `position` (world space; unrotated, scale 1 until
    /// [`Crowd::set_rotation`] / [`Crowd::set_scale`]) playing `clip`
    /// from time 0 at speed 1. Its pose is evaluated at once.
    pub fn add_character(
        &mut self,
        position: Vec3,
        clip: ClipId,
    ) -> Result<CharacterId, CrowdError> {
        check_finite3(position, "position")?;
        self.clip_ref(clip)?;
        if self.chars.len() >= u32::MAX as usize - 1 {
            return Err(CrowdError::TooManyCharacters);
        }
        let h = self.slots.insert(self.chars.len() as u32);
        let id = CharacterId::from_raw(h.index(), h.generation());
        self.chars.push(Character {
            id,
            position,
            rotation: Quat::IDENTITY,
            scale: 1.0,
            clip,
            time: 0.0,
            segment: 0,
            prev_segment: 0,
            wrapped: false,
            once: false,
            speed: 1.0,
            clock: 0.0,
            omega: 1.0,
            size_px: 0.0,
            step: 0.0,
            near_ppu: 0.0,
            changed: true,
            pose_shared: false,
            key_from: 0.0,
            key_to: 0.0,
            key_error: 0.0,
            stale: false,
            key_update: KeyUpdate::Restarted,
            reset_unreported: true,
            holding: false,
        });
        let n = self.stride;
        self.locals
            .extend(std::iter::repeat_n(Affine3A::IDENTITY, n));
        self.models.extend(std::iter::repeat_n(Mat4::IDENTITY, n));
        if self.keyed() {
            self.key_from.extend(std::iter::repeat_n(Mat4::IDENTITY, n));
            self.key_to.extend(std::iter::repeat_n(Mat4::IDENTITY, n));
        }
        self.last_update.extend(std::iter::repeat_n(0.0, n));
        self.drift.extend(std::iter::repeat_n(0.0, n));
        self.evaluate_full(self.chars.len() - 1);
        Ok(id)
    }

    /// Removes a character; its id (and any copy of it) goes stale.
    pub fn remove_character(&mut self, id: CharacterId) -> Result<(), CrowdError> {
        let d = self.dense(id)?;
        let last = self.chars.len() - 1;
        let n = self.stride;
        if d != last {
            self.locals.copy_within(last * n..(last + 1) * n, d * n);
            self.models.copy_within(last * n..(last + 1) * n, d * n);
            if self.keyed() {
                self.key_from.copy_within(last * n..(last + 1) * n, d * n);
                self.key_to.copy_within(last * n..(last + 1) * n, d * n);
            }
            self.last_update
                .copy_within(last * n..(last + 1) * n, d * n);
            self.drift.copy_within(last * n..(last + 1) * n, d * n);
            let moved = self.chars[last].id;
            *self
                .slots
                .get_mut(handle(moved))
                .expect("every live character has a slot") = d as u32;
        }
        self.chars.swap_remove(d);
        self.locals.truncate(last * n);
        self.models.truncate(last * n);
        if self.keyed() {
            self.key_from.truncate(last * n);
            self.key_to.truncate(last * n);
        }
        self.last_update.truncate(last * n);
        self.drift.truncate(last * n);
        self.slots.remove(handle(id));
        Ok(())
    }

    /// Moves a character.
    pub fn set_position(&mut self, id: CharacterId, position: Vec3) -> Result<(), CrowdError> {
        check_finite3(position, "position")?;
        let d = self.dense(id)?;
        self.chars[d].position = position;
        Ok(())
    }

    /// A character's position.
    pub fn position(&self, id: CharacterId) -> Result<Vec3, CrowdError> {
        Ok(self.chars[self.dense(id)?].position)
    }

    /// Turns a character: `rotation` (finite, non-zero length; normalised here) maps its
    /// skeleton model space to world space, about the skeleton's origin. Distances, projected
    /// sizes and errors are measured with it.
    pub fn set_rotation(&mut self, id: CharacterId, rotation: Quat) -> Result<(), CrowdError> {
        if !(rotation.is_finite() && rotation.length() > 1e-6) {
            return Err(invalid("rotation", "must be finite with a non-zero length"));
        }
        let d = self.dense(id)?;
        self.chars[d].rotation = rotation.normalize();
        Ok(())
    }

    /// Scales a character uniformly (finite, > 0; 1 by default): its skeleton model space is
    /// scaled by `scale` about the skeleton's origin before rotation and translation.
    pub fn set_scale(&mut self, id: CharacterId, scale: f32) -> Result<(), CrowdError> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(invalid("scale", "must be finite and positive"));
        }
        let d = self.dense(id)?;
        self.chars[d].scale = scale;
        Ok(())
    }

    /// A character's model-to-world transform: scale, then rotation, then translation to its
    /// position. Model matrices ([`Crowd::model_matrices`]) are in skeleton model space; this
    /// places them in the world.
    pub fn world_transform(&self, id: CharacterId) -> Result<Affine3A, CrowdError> {
        let c = &self.chars[self.dense(id)?];
        Ok(c.world())
    }

    /// Switches a character to another clip from time 0; its pose is re-evaluated at once.
    pub fn set_clip(&mut self, id: CharacterId, clip: ClipId) -> Result<(), CrowdError> {
        self.clip_ref(clip)?;
        let d = self.dense(id)?;
        let c = &mut self.chars[d];
        c.clip = clip;
        c.time = 0.0;
        self.evaluate_full(d);
        Ok(())
    }

    /// A character's clip.
    pub fn clip(&self, id: CharacterId) -> Result<ClipId, CrowdError> {
        Ok(self.chars[self.dense(id)?].clip)
    }

    /// Jumps a character to playback time `time` (wrapped into the clip, or clamped to it for a
    /// character that plays its clip once); the pose is re-evaluated at once.
    pub fn set_time(&mut self, id: CharacterId, time: f32) -> Result<(), CrowdError> {
        if !time.is_finite() {
            return Err(invalid("time", "must be finite"));
        }
        let d = self.dense(id)?;
        let clip = self.chars[d].clip;
        let clip = &self.rig.clips()[clip.index()];
        self.chars[d].time = if self.chars[d].once {
            time.clamp(0.0, clip.duration())
        } else {
            clip.wrap_time(time)
        };
        self.evaluate_full(d);
        Ok(())
    }

    /// Whether a character plays its clip once, stopping on the last pose (`true`), or loops it
    /// (`false`, the default). Switching to play-once past the end holds the last pose.
    pub fn set_play_once(&mut self, id: CharacterId, once: bool) -> Result<(), CrowdError> {
        let d = self.dense(id)?;
        self.chars[d].once = once;
        Ok(())
    }

    /// Whether a character plays its clip once (see [`Crowd::set_play_once`]).
    pub fn play_once(&self, id: CharacterId) -> Result<bool, CrowdError> {
        Ok(self.chars[self.dense(id)?].once)
    }

    /// Marks a character as showing a shared pose (a [`crate::PoseShare`] bucket's skinned
    /// output) instead of its own: from the next [`Crowd::advance`] its clock, clip time,
    /// projected size and pixels per unit go on being updated, but no bone of it is sampled
    /// or concatenated, and the budget mode spends nothing on it. Unmarking evaluates its pose
    /// in full at its current time at once (its model matrices are stale until then), so the
    /// host can skin it the same frame.
    pub fn set_pose_shared(&mut self, id: CharacterId, shared: bool) -> Result<(), CrowdError> {
        let d = self.dense(id)?;
        if self.chars[d].pose_shared != shared {
            self.chars[d].pose_shared = shared;
            if !shared {
                self.evaluate_full(d);
            }
        }
        Ok(())
    }

    /// Whether a character shows a shared pose (see [`Crowd::set_pose_shared`]).
    pub fn pose_shared(&self, id: CharacterId) -> Result<bool, CrowdError> {
        Ok(self.chars[self.dense(id)?].pose_shared)
    }

    /// A character's playback time within its clip.
    pub fn time(&self, id: CharacterId) -> Result<f32, CrowdError> {
        Ok(self.chars[self.dense(id)?].time)
    }

    /// Sets a character's playback speed (finite, ≥ 0; 1 = real time).
    pub fn set_speed(&mut self, id: CharacterId, speed: f32) -> Result<(), CrowdError> {
        if !(speed.is_finite() && speed >= 0.0) {
            return Err(invalid("speed", "must be finite and non-negative"));
        }
        let d = self.dense(id)?;
        self.chars[d].speed = speed;
        Ok(())
    }

    /// The camera ratio Ω used for a character in the last frame (1 before any frame, and in
    /// [`LodMode::Off`] and [`LodMode::Budget`]).
    pub fn ratio(&self, id: CharacterId) -> Result<f32, CrowdError> {
        Ok(self.chars[self.dense(id)?].omega)
    }

    /// Pixels per model unit (skeleton model space, the character's scale included) at the
    /// nearest visible point of the character's bounding sphere in the last
    /// [`Crowd::advance`]'s view; 0 when the sphere was out of view or before any frame. A bound
    /// in pixels over it is a bound in model units that holds anywhere on the character
    /// (as [`crate::SkinHoldJob`]'s tolerance).
    pub fn pixels_per_unit(&self, id: CharacterId) -> Result<f32, CrowdError> {
        Ok(self.chars[self.dense(id)?].near_ppu)
    }

    /// Sets the LOD mode (validated). A different mode starts from exact poses: every
    /// character is evaluated in full at its current time, so no hold carries over that the
    /// new mode has not accounted for (the error bound's drift, for one).
    pub fn set_lod(&mut self, lod: LodMode) -> Result<(), CrowdError> {
        lod.validate()?;
        if lod != self.lod {
            self.lod = lod;
            self.budget_lod_off_frames = 0;
            let keys = if self.keyed() { self.models.len() } else { 0 };
            for k in [&mut self.key_from, &mut self.key_to] {
                k.clear();
                k.resize(keys, Mat4::IDENTITY);
                k.shrink_to(keys);
            }
            for d in 0..self.chars.len() {
                self.evaluate_full(d);
            }
        }
        Ok(())
    }

    /// Moves the bound of [`LodMode::ErrorBound`] to `max_error_px` in place, as a world-wide
    /// frame budget does every few frames. Unlike [`Crowd::set_lod`] with a new bound, nothing
    /// is re-evaluated: the drift each held bone has built up is measured in pixels already, so
    /// under a lower bound the bones past it interpolate on the next frame, and under a higher
    /// one they hold longer. A crowd in another mode switches to `ErrorBound` (through
    /// `set_lod`). Refused, with nothing changed, unless the bound is finite and positive.
    pub fn set_error_bound_px(&mut self, max_error_px: f32) -> Result<(), CrowdError> {
        let lod = LodMode::ErrorBound { max_error_px };
        lod.validate()?;
        if matches!(self.lod, LodMode::ErrorBound { .. }) {
            self.lod = lod;
            Ok(())
        } else {
            self.set_lod(lod)
        }
    }

    /// Turns per-stage timing of [`Crowd::advance`] on or off (off by default: two clock reads
    /// per character per frame). Measurement only; poses are the same either way.
    pub fn set_stage_timing(&mut self, on: bool) {
        self.stage_timing = on;
    }

    /// Splits [`Crowd::advance`] over the current rayon pool (off by default). Outside
    /// [`LodMode::Budget`], whose crowd-wide cut is serial, characters are independent, so the
    /// poses and statistics equal a one-thread run's.
    pub fn set_parallel(&mut self, on: bool) {
        self.parallel = on;
    }

    /// What the last [`Crowd::advance`] did (zero before the first).
    pub fn last_stats(&self) -> &FrameStats {
        &self.last_stats
    }

    /// The LOD mode.
    pub fn lod(&self) -> LodMode {
        self.lod
    }

    /// Sets the period mapping's parameters (validated).
    pub fn set_scheduler(&mut self, params: SchedulerParams) -> Result<(), CrowdError> {
        params.validate()?;
        self.params = params;
        Ok(())
    }

    /// The period mapping's parameters.
    pub fn scheduler(&self) -> &SchedulerParams {
        &self.params
    }

    /// Sets the weights of the six sub-priorities (non-negative, finite, not all zero; normalised
    /// to sum to 1).
    pub fn set_priority_weights(&mut self, weights: PriorityWeights) -> Result<(), CrowdError> {
        let w = weights.normalized().ok_or(invalid(
            "priority weights",
            "must be finite, >= 0 and not all 0",
        ))?;
        self.weights = w;
        self.rebuild_tables();
        Ok(())
    }

    /// The normalised sub-priority weights.
    pub fn priority_weights(&self) -> &PriorityWeights {
        &self.weights
    }

    /// Sets the user priority of a bone (finite, ≥ 0; normalised by the largest over the
    /// skeleton). All bones start at 1.
    pub fn set_user_priority(&mut self, bone: BoneId, value: f32) -> Result<(), CrowdError> {
        if bone.index() >= self.bones {
            return Err(CrowdError::UnknownBone(bone));
        }
        if !(value.is_finite() && value >= 0.0) {
            return Err(invalid("user priority", "must be finite and non-negative"));
        }
        self.user[bone.index()] = value;
        self.rebuild_tables();
        Ok(())
    }

    /// The combined priority of every animated bone of `clip` in key segment `segment`
    /// (`[slot]`, slot = position in [`crate::Clip::animated_bones`]).
    pub fn priorities(&self, clip: ClipId, segment: usize) -> Result<&[f32], CrowdError> {
        let c = self.clip_ref(clip)?;
        let slots = c.animated_bone_count();
        if segment >= self.rig.priorities[clip.index()].segment_count() {
            return Err(invalid("segment", "out of range"));
        }
        Ok(&self.tables[clip.index()][segment * slots..(segment + 1) * slots])
    }

    /// Chooses where bone priorities come from (see [`PrioritySource`]).
    pub fn set_priority_source(&mut self, source: PrioritySource) {
        self.source = source;
        self.rebuild_tables();
    }

    /// Where bone priorities come from.
    pub fn priority_source(&self) -> PrioritySource {
        self.source
    }

    fn rebuild_tables(&mut self) {
        let max = self.user.iter().copied().fold(0.0f32, f32::max);
        let norm: Vec<f32> = self
            .user
            .iter()
            .map(|&u| if max > 0.0 { u / max } else { 0.0 })
            .collect();
        self.tables = self
            .rig
            .clips()
            .iter()
            .zip(&self.rig.priorities)
            .map(|(c, p)| match self.source {
                PrioritySource::Factors => {
                    let user: Vec<f32> = c.animated.iter().map(|&b| norm[b as usize]).collect();
                    p.combine(&self.weights, &user)
                }
                PrioritySource::HoldError => p.measured(),
            })
            .collect();
    }

    /// Whether a character's pose changed in the last [`Crowd::advance`] (or since it was
    /// added, moved to another clip or time). `false` means every bone held: its model
    /// matrices, skinning palette and skinned vertices from the previous frame are still exact,
    /// so a host reuses them instead of recomputing.
    pub fn pose_changed(&self, id: CharacterId) -> Result<bool, CrowdError> {
        Ok(self.chars[self.dense(id)?].changed)
    }

    /// Whether the crowd keeps key poses ([`LodMode::Interpolated`], [`LodMode::KeyHold`]).
    #[inline]
    fn keyed(&self) -> bool {
        matches!(
            self.lod,
            LodMode::Interpolated { .. } | LodMode::KeyHold { .. }
        )
    }

    /// A character's two key poses, the weight its current pose blends them with, and what the
    /// last [`Crowd::advance`] changed in them. A host that skins on the CPU keeps one skinned
    /// copy per key pose, recomputes only what [`KeyUpdate`] names, and blends the two copies
    /// with `weight` — the same vertices as skinning the blended model matrices, because
    /// linear-blend skinning is linear in the palette (a GPU host uploads both palettes and
    /// blends in the vertex shader). Outside [`LodMode::Interpolated`] both poses are the
    /// current model matrices (weight 1; [`KeyUpdate::Advanced`] when the pose changed).
    pub fn key_poses(&self, id: CharacterId) -> Result<KeyPoses<'_>, CrowdError> {
        let d = self.dense(id)?;
        let c = &self.chars[d];
        let span = self.span(d);
        if !self.keyed() {
            let m = &self.models[span];
            return Ok(KeyPoses {
                from: m,
                to: m,
                weight: 1.0,
                update: if c.changed {
                    KeyUpdate::Advanced
                } else {
                    KeyUpdate::Unchanged
                },
            });
        }
        Ok(KeyPoses {
            from: &self.key_from[span.clone()],
            to: &self.key_to[span],
            weight: if matches!(self.lod, LodMode::KeyHold { .. }) {
                1.0
            } else {
                keys::weight(c)
            },
            update: c.key_update,
        })
    }

    /// Model-space matrices of a character's bones (skeleton model space; apply
    /// [`Crowd::world_transform`] for world space). Valid until the next mutating call on the crowd.
    pub fn model_matrices(&self, id: CharacterId) -> Result<&[Mat4], CrowdError> {
        let d = self.dense(id)?;
        Ok(&self.models[self.span(d)])
    }

    /// Writes a skin's joint matrices (model matrix × inverse bind matrix, in skeleton model
    /// space) for a character into `out`, which must hold at least as many matrices as the skin
    /// has joints. Returns the number written.
    pub fn skinning_matrices(
        &self,
        id: CharacterId,
        skin: SkinId,
        out: &mut [Mat4],
    ) -> Result<usize, CrowdError> {
        let d = self.dense(id)?;
        self.palette_of(skin, &self.models[self.span(d)], out)
    }

    /// A skin's palette from `models` into `out` (checked against the skin's joint count).
    fn palette_of(
        &self,
        skin: SkinId,
        models: &[Mat4],
        out: &mut [Mat4],
    ) -> Result<usize, CrowdError> {
        let s = self.rig.skin(skin).ok_or(CrowdError::UnknownSkin(skin))?;
        if out.len() < s.joints.len() {
            return Err(CrowdError::BufferTooSmall {
                needed: s.joints.len(),
                given: out.len(),
            });
        }
        Ok(palette(s, models, out))
    }

    /// Writes the skinning matrices of one of a character's key poses (`later`: the `to` pose,
    /// else `from`; see [`Crowd::key_poses`]) into `out`, as [`Crowd::skinning_matrices`]
    /// does for the current pose. Returns the number written.
    pub fn key_skinning_matrices(
        &self,
        id: CharacterId,
        skin: SkinId,
        later: bool,
        out: &mut [Mat4],
    ) -> Result<usize, CrowdError> {
        let k = self.key_poses(id)?;
        self.palette_of(skin, if later { k.to } else { k.from }, out)
    }
}

/// A skin's palette (model × inverse bind per joint) from model matrices into `out` (long
/// enough); returns the joint count.
pub(crate) fn palette(s: &crate::rig::Skin, models: &[Mat4], out: &mut [Mat4]) -> usize {
    {
        for ((o, j), ib) in out.iter_mut().zip(&s.joints).zip(&s.inverse_bind) {
            *o = models[j.index()] * *ib;
        }
        s.joints.len()
    }
}

mod budget;
mod error;
mod frame;
mod keys;

#[cfg(test)]
#[path = "../crowd_tests.rs"]
mod tests;

#[cfg(test)]
#[path = "../crowd_error_tests.rs"]
mod error_tests;
