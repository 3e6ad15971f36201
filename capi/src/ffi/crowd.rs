//! Crowds over the C ABI: characters of one rig animated together under one LOD mode, advanced
//! by the host's frame time and seen by the world's camera.

use animlod::{Crowd, CrowdError, LodMode};

use super::arena::RawId;
use super::boundary::{arg, arg_mut, boundary, write_out};
use super::cloth::in_range;
use super::ids::{SlodCrowdId, SlodRigId};
use super::result::{FfiError, SlodResult};
use super::rig::rig_ref;
use super::world::{SLOD_DESC_GUARD, SlodWorld, check_guard};

/// How a crowd chooses each character's detail (values of `SlodLodDesc::mode`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodLodMode {
    /// Every animated bone interpolates every frame.
    Off = 0,
    /// Camera ratio from distance: full detail nearer than `range_min`, none beyond `range_max`,
    /// linear between (the thesis' range).
    Range = 1,
    /// Camera ratio from the projected radius of the character's bounds: full detail at
    /// `full_detail_px` and above, frozen below `freeze_below_px`.
    PixelSize = 2,
    /// A crowd-wide budget of `bone_updates_per_frame` bone interpolations per frame, spent where
    /// held bones have built up the most on-screen error. A character whose admitted bones
    /// would cost more picked out than all of its bones together interpolates all of them and
    /// counts at most a sixth of them; a budget that affords every character that way runs as
    /// LOD off, as do the frames after one priced at LOD off's cost or more
    /// (`SlodCrowdStats::budget_units`).
    Budget = 3,
    /// Hold a bone only while its estimated on-screen drift stays under `max_error_px` pixels.
    ErrorBound = 4,
    /// The same camera ratio `ratio` (in [0, 1]) for every character.
    Ratio = 5,
    /// Whole key poses at intervals, model matrices blended between the last two, the next key
    /// placed as far ahead as keeps every joint origin and tip within `max_error_px` pixels.
    Interpolated = 6,
    /// Whole key poses, each standing unchanged over a window centred on its time, within
    /// `max_error_px` pixels at every joint origin and tip (no blending).
    KeyHold = 7,
}

/// A crowd's LOD mode and its parameters. Get one from `slod_default_lod_desc`; only the
/// fields of the chosen `mode` are read (but all must be valid numbers for it).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodLodDesc {
    /// Set by `slod_default_lod_desc`; do not change.
    pub guard: u32,
    /// A `SlodLodMode` value.
    pub mode: u32,
    /// `SLOD_LOD_MODE_RANGE`: distance (world units) below which a character is at full detail
    /// (finite, >= 0).
    pub range_min: f32,
    /// `SLOD_LOD_MODE_RANGE`: distance beyond which no bone interpolates (finite, > range_min).
    pub range_max: f32,
    /// `SLOD_LOD_MODE_PIXEL_SIZE`: projected radius (pixels) of full detail (finite, > 0).
    pub full_detail_px: f32,
    /// `SLOD_LOD_MODE_PIXEL_SIZE`: projected radius below which a character freezes
    /// (finite, 0 <= value < full_detail_px).
    pub freeze_below_px: f32,
    /// `SLOD_LOD_MODE_BUDGET`: bone interpolations per frame over the whole crowd.
    pub bone_updates_per_frame: u32,
    /// `SLOD_LOD_MODE_ERROR_BOUND`: largest on-screen drift of a held bone;
    /// `SLOD_LOD_MODE_INTERPOLATED` and `SLOD_LOD_MODE_KEY_HOLD`: largest on-screen error of the
    /// shown pose (pixels, finite, > 0).
    pub max_error_px: f32,
    /// `SLOD_LOD_MODE_RATIO`: the camera ratio of every character, in [0, 1].
    pub ratio: f32,
}

/// How to build a crowd. Get one from `slod_default_crowd_desc`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodCrowdDesc {
    /// Set by `slod_default_crowd_desc`; do not change.
    pub guard: u32,
    /// The initial LOD mode (change it later with `slod_crowd_set_lod`).
    pub lod: SlodLodDesc,
}

/// What one `slod_crowd_advance` did, summed over the crowd.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlodCrowdStats {
    /// Animated bones that interpolated their channels this frame.
    pub bones_interpolated: u64,
    /// Animated bones that held their last local transform (the work LOD saved).
    pub bones_held: u64,
    /// Bones with no animated channel in the current clip (never sampled).
    pub bones_constant: u64,
    /// Model-space matrices recomputed (subtrees that held entirely are skipped).
    pub bones_concatenated: u64,
    /// Characters advanced.
    pub characters: u32,
    /// Characters of which nothing interpolated (out of range, invisible or without budget).
    pub characters_frozen: u32,
    /// `SLOD_LOD_MODE_BUDGET`: budget units spent (never more than `bone_updates_per_frame`;
    /// `bones_interpolated` may be more), 0 in other modes.
    pub budget_units: u64,
}

/// The default LOD: `SLOD_LOD_MODE_OFF`, with the other modes' fields preset (range 5–50,
/// pixel size 200/1 px, 5000 bone updates per frame, 0.5 px error bound, ratio 1) so that setting
/// `mode` alone gives a working configuration.
///
/// Returns a value the host owns.
#[unsafe(no_mangle)]
pub extern "C" fn slod_default_lod_desc() -> SlodLodDesc {
    let LodMode::Range {
        min: range_min,
        max: range_max,
    } = LodMode::DEFAULT_RANGE
    else {
        unreachable!("DEFAULT_RANGE is a range")
    };
    let LodMode::PixelSize {
        full_detail_px,
        freeze_below_px,
    } = LodMode::DEFAULT_PIXEL_SIZE
    else {
        unreachable!("DEFAULT_PIXEL_SIZE is a pixel size")
    };
    let LodMode::Budget {
        bone_updates_per_frame,
    } = LodMode::DEFAULT_BUDGET
    else {
        unreachable!("DEFAULT_BUDGET is a budget")
    };
    let LodMode::ErrorBound { max_error_px } = LodMode::DEFAULT_ERROR_BOUND else {
        unreachable!("DEFAULT_ERROR_BOUND is an error bound")
    };
    let LodMode::Ratio(ratio) = LodMode::DEFAULT_RATIO else {
        unreachable!("DEFAULT_RATIO is a ratio")
    };
    SlodLodDesc {
        guard: SLOD_DESC_GUARD,
        mode: lod_mode_value(LodMode::default()) as u32,
        range_min,
        range_max,
        full_detail_px,
        freeze_below_px,
        bone_updates_per_frame,
        max_error_px,
        ratio,
    }
}

/// The C value of a mode's kind.
fn lod_mode_value(mode: LodMode) -> SlodLodMode {
    match mode {
        LodMode::Off => SlodLodMode::Off,
        LodMode::Range { .. } => SlodLodMode::Range,
        LodMode::PixelSize { .. } => SlodLodMode::PixelSize,
        LodMode::Budget { .. } => SlodLodMode::Budget,
        LodMode::ErrorBound { .. } => SlodLodMode::ErrorBound,
        LodMode::Ratio(_) => SlodLodMode::Ratio,
        LodMode::Interpolated { .. } => SlodLodMode::Interpolated,
        LodMode::KeyHold { .. } => SlodLodMode::KeyHold,
    }
}

/// The default crowd settings (LOD from `slod_default_lod_desc`). Returns a value the host owns.
#[unsafe(no_mangle)]
pub extern "C" fn slod_default_crowd_desc() -> SlodCrowdDesc {
    SlodCrowdDesc {
        guard: SLOD_DESC_GUARD,
        lod: slod_default_lod_desc(),
    }
}

impl SlodLodDesc {
    /// The LOD mode, or an error naming the bad field (`prefix` names the desc, e.g. `lod`).
    pub(super) fn to_mode(self, guard_name: &'static str) -> Result<LodMode, FfiError> {
        check_guard(self.guard, guard_name)?;
        let mode = match self.mode {
            0 => LodMode::Off,
            1 => {
                in_range(self.range_min, 0.0, f32::MAX, "lod.range_min")?;
                in_range(self.range_max, 0.0, f32::MAX, "lod.range_max")?;
                if self.range_max <= self.range_min {
                    return Err(FfiError::invalid(
                        "lod.range_max",
                        "must be greater than range_min",
                    ));
                }
                LodMode::Range {
                    min: self.range_min,
                    max: self.range_max,
                }
            }
            2 => {
                in_range(
                    self.full_detail_px,
                    f32::MIN_POSITIVE,
                    f32::MAX,
                    "lod.full_detail_px",
                )?;
                in_range(self.freeze_below_px, 0.0, f32::MAX, "lod.freeze_below_px")?;
                if self.freeze_below_px >= self.full_detail_px {
                    return Err(FfiError::invalid(
                        "lod.freeze_below_px",
                        "must be less than full_detail_px",
                    ));
                }
                LodMode::PixelSize {
                    full_detail_px: self.full_detail_px,
                    freeze_below_px: self.freeze_below_px,
                }
            }
            3 => LodMode::Budget {
                bone_updates_per_frame: self.bone_updates_per_frame,
            },
            4 | 6 | 7 => {
                in_range(
                    self.max_error_px,
                    f32::MIN_POSITIVE,
                    f32::MAX,
                    "lod.max_error_px",
                )?;
                let max_error_px = self.max_error_px;
                match self.mode {
                    4 => LodMode::ErrorBound { max_error_px },
                    6 => LodMode::Interpolated { max_error_px },
                    _ => LodMode::KeyHold { max_error_px },
                }
            }
            5 => {
                in_range(self.ratio, 0.0, 1.0, "lod.ratio")?;
                LodMode::Ratio(self.ratio)
            }
            m => {
                return Err(FfiError::invalid(
                    "lod.mode",
                    format!("{m} is not a SlodLodMode value"),
                ));
            }
        };
        mode.validate().map_err(crowd_error)?;
        Ok(mode)
    }
}

/// A crowd error as the C layer reports it.
pub(crate) fn crowd_error(e: CrowdError) -> FfiError {
    match e {
        CrowdError::StaleCharacter(_) => FfiError::StaleId("character"),
        CrowdError::UnknownClip(_) => FfiError::invalid("clip", e),
        CrowdError::UnknownSkin(_) => FfiError::invalid("skin", e),
        CrowdError::InvalidArgument { what, reason } => FfiError::invalid(what, reason),
        CrowdError::BufferTooSmall { needed, given } => FfiError::BufferTooSmall {
            arg: "out",
            cap: given,
            needed,
        },
        other => FfiError::Refused(other.to_string()),
    }
}

/// Creates an empty crowd animating characters of `rig` and writes its id.
///
/// Ownership: the world owns the crowd; the crowd holds its own reference to the rig (destroying
/// the rig later does not affect it). The desc is copied. Threads: mutates the world. Errors:
/// `SLOD_RESULT_STALE_ID` for `rig`, `SLOD_RESULT_INVALID_ARGUMENT` naming the bad LOD field.
///
/// # Safety
/// `world` NULL or a live world; `desc` NULL or valid; `out_crowd` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_create(
    world: *mut SlodWorld,
    rig: SlodRigId,
    desc: *const SlodCrowdDesc,
    out_crowd: *mut SlodCrowdId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid desc.
        let desc = *unsafe { arg(desc, "desc") }?;
        check_guard(desc.guard, "desc")?;
        let lod = desc.lod.to_mode("desc.lod")?;
        let rig = rig_ref(world, rig)?.clone();
        if out_crowd.is_null() {
            return Err(FfiError::Null("out_crowd"));
        }
        let mut crowd = Crowd::new(rig);
        crowd.set_lod(lod).map_err(crowd_error)?;
        let id: SlodCrowdId = world.crowds.insert(crowd).into();
        // SAFETY: checked non-NULL; valid for a write per the caller contract.
        unsafe { write_out(out_crowd, id, "out_crowd") }
    })
}

/// Destroys a crowd and every character in it (their ids go stale).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_destroy(
    world: *mut SlodWorld,
    crowd: SlodCrowdId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let raw = RawId::from(crowd);
        world.crowds.remove(raw, "crowd")?;
        world.characters.remove_where(|(c, _)| *c == raw);
        super::world_budget::forget_crowd(world, raw);
        Ok(())
    })
}

/// The live crowd behind an id.
pub(crate) fn crowd_mut(world: &mut SlodWorld, id: SlodCrowdId) -> Result<&mut Crowd, FfiError> {
    world.crowds.get_mut(RawId::from(id), "crowd")
}

/// Changes a crowd's LOD mode from the next advance on.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`
/// naming the bad field (the mode stays as it was).
///
/// # Safety
/// `world` NULL or a live world; `lod` NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_set_lod(
    world: *mut SlodWorld,
    crowd: SlodCrowdId,
    lod: *const SlodLodDesc,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or valid.
        let lod = *unsafe { arg(lod, "lod") }?;
        let c = crowd_mut(world, crowd)?;
        let mode = lod.to_mode("lod")?;
        c.set_lod(mode).map_err(crowd_error)
    })
}

/// Advances every character of a crowd by `dt` seconds and updates their poses under the
/// crowd's LOD mode, seen through the world's view; writes what the frame did to `*out_stats`
/// (optional: NULL skips the statistics).
///
/// Until the host sets a camera, the world's default view is used (see
/// `slod_world_set_camera`). Threads: mutates the world. Errors:
/// `SLOD_RESULT_STALE_ID`; `SLOD_RESULT_INVALID_ARGUMENT` for `dt` not finite or outside
/// [0, 3600] (nothing advanced); `SLOD_RESULT_NULL_ARGUMENT` for a NULL `world`.
///
/// Characters are split over the world's worker threads (unless it has one; not in budget
/// mode); the poses are the same on any number of threads.
///
/// # Safety
/// `world` NULL or a live world; `out_stats` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_advance(
    world: *mut SlodWorld,
    crowd: SlodCrowdId,
    dt: f32,
    out_stats: *mut SlodCrowdStats,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let view = world.view;
        let parallel = world.parallel_allowed();
        let pool = world.pool.as_ref();
        let c = world.crowds.get_mut(RawId::from(crowd), "crowd")?;
        in_range(dt, 0.0, 3600.0, "dt")?;
        c.set_parallel(parallel);
        let s = SlodWorld::run(pool, || c.advance(dt, &view)).map_err(crowd_error)?;
        if out_stats.is_null() {
            return Ok(());
        }
        let stats = SlodCrowdStats {
            bones_interpolated: s.bones_interpolated,
            bones_held: s.bones_held,
            bones_constant: s.bones_constant,
            bones_concatenated: s.bones_concatenated,
            characters: s.characters,
            characters_frozen: s.characters_frozen,
            budget_units: s.budget_units,
        };
        // SAFETY: checked non-NULL; valid for a write per the caller contract.
        unsafe { write_out(out_stats, stats, "out_stats") }
    })
}

/// Writes the number of live characters of a crowd to `*out_count`.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_count` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_character_count(
    world: *const SlodWorld,
    crowd: SlodCrowdId,
    out_count: *mut usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let c = world.crowds.get(RawId::from(crowd), "crowd")?;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_count, c.len(), "out_count") }
    })
}

/// Pose error against full-rate evaluation, measured where a viewer sees it: every joint at
/// its origin and at its tip (a point one bone length along the bone, so a bone's own rotation
/// counts), in scene units and in pixels through the world's view.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlodPoseError {
    /// Joints compared.
    pub joints: u64,
    /// Joints in view (the pixel figures cover these).
    pub visible_joints: u64,
    /// Mean error (scene units).
    pub mean: f32,
    /// Largest error (scene units).
    pub max: f32,
    /// Mean on-screen error (pixels).
    pub mean_px: f32,
    /// Largest on-screen error (pixels).
    pub max_px: f32,
    /// Root mean square on-screen error (pixels).
    pub rms_px: f32,
}

impl From<animlod::PoseError> for SlodPoseError {
    fn from(e: animlod::PoseError) -> SlodPoseError {
        SlodPoseError {
            joints: e.joints,
            visible_joints: e.visible_joints,
            mean: e.mean,
            max: e.max,
            mean_px: e.mean_px,
            max_px: e.max_px,
            rms_px: e.rms_px,
        }
    }
}

/// Writes the pose error of every character of a crowd (see `SlodPoseError`), seen through the
/// world's view, to `*out_error`. Costs a full-rate evaluation of every character: a
/// measurement, not a per-frame call.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_error` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_pose_error(
    world: *const SlodWorld,
    crowd: SlodCrowdId,
    out_error: *mut SlodPoseError,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let c = world.crowds.get(RawId::from(crowd), "crowd")?;
        let e = c.total_pose_error(&world.view);
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_error, e.into(), "out_error") }
    })
}

/// Weights of the six sub-priorities of the thesis' per-keyframe bone priority (only their
/// ratios matter; each finite and >= 0, not all 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodPriorityWeights {
    /// Translation change over the key segment.
    pub translation: f32,
    /// Rotation change (speed of the bone's tip).
    pub rotation: f32,
    /// Scale change.
    pub scale: f32,
    /// Number of descendants.
    pub descendants: f32,
    /// Closeness to the root.
    pub depth: f32,
    /// The per-bone user value (`slod_crowd_set_user_priority`).
    pub user: f32,
}

/// Sets the weights of a crowd's six sub-priorities (used with `SLOD_PRIORITY_SOURCE_FACTORS`).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`
/// (nothing changed) for a negative or non-finite weight or all zero.
///
/// # Safety
/// `world` NULL or a live world; `weights` NULL or valid for a read.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_set_priority_weights(
    world: *mut SlodWorld,
    crowd: SlodCrowdId,
    weights: *const SlodPriorityWeights,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or valid for a read.
        let w = *unsafe { arg(weights, "weights") }?;
        let c = crowd_mut(world, crowd)?;
        c.set_priority_weights(animlod::PriorityWeights {
            translation: w.translation,
            rotation: w.rotation,
            scale: w.scale,
            descendants: w.descendants,
            depth: w.depth,
            user: w.user,
        })
        .map_err(crowd_error)
    })
}

/// Sets the user priority of bone `bone` in a crowd (finite, >= 0; normalised by the largest
/// over the skeleton; every bone starts at 1).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`
/// (nothing changed) for a bone out of range or a bad value.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_set_user_priority(
    world: *mut SlodWorld,
    crowd: SlodCrowdId,
    bone: u32,
    value: f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let c = crowd_mut(world, crowd)?;
        let bone = super::rig::check_bone(c.rig(), bone)?;
        c.set_user_priority(bone, value).map_err(crowd_error)
    })
}

/// Where a crowd's bone priorities come from (values for `slod_crowd_set_priority_source`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodPrioritySource {
    /// The thesis: a weighted average of six sub-priorities (the default).
    Factors = 0,
    /// The measured hold error rate of each bone keyframe.
    HoldError = 1,
}

/// Chooses where a crowd's bone priorities come from (`SlodPrioritySource`, as `uint32_t`).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`
/// for an unknown value (nothing changed).
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_set_priority_source(
    world: *mut SlodWorld,
    crowd: SlodCrowdId,
    source: u32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let source = match source {
            0 => animlod::PrioritySource::Factors,
            1 => animlod::PrioritySource::HoldError,
            s => return Err(FfiError::invalid("source", format!("unknown source {s}"))),
        };
        crowd_mut(world, crowd)?.set_priority_source(source);
        Ok(())
    })
}

/// Sets the scheduler's period mapping of a crowd: `period_scale` (finite, > 0; the update
/// period in seconds of a bone of priority 1 at camera ratio 1/2) and `min_priority` (in
/// [0, 1]; priorities below count as this).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`
/// (nothing changed).
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_set_scheduler(
    world: *mut SlodWorld,
    crowd: SlodCrowdId,
    period_scale: f32,
    min_priority: f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        crowd_mut(world, crowd)?
            .set_scheduler(animlod::SchedulerParams {
                period_scale,
                min_priority,
            })
            .map_err(crowd_error)
    })
}

/// Writes where a crowd's bone priorities come from to `*out_source`.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_source` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_priority_source(
    world: *const SlodWorld,
    crowd: SlodCrowdId,
    out_source: *mut SlodPrioritySource,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let c = world.crowds.get(RawId::from(crowd), "crowd")?;
        let source = match c.priority_source() {
            animlod::PrioritySource::Factors => SlodPrioritySource::Factors,
            animlod::PrioritySource::HoldError => SlodPrioritySource::HoldError,
        };
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_source, source, "out_source") }
    })
}

/// Per-stage cost of a crowd's last `slod_crowd_advance`, with stage timing on
/// (`slod_crowd_set_stage_timing`); zeros otherwise.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlodCrowdStageStats {
    /// Nanoseconds spent sampling (key search, interpolation, local matrices).
    pub sample_ns: u64,
    /// Nanoseconds spent concatenating local to model matrices.
    pub concat_ns: u64,
    /// Characters whose pose changed (the others' palettes and skinned vertices can be reused).
    pub characters_changed: u32,
    /// Characters advanced.
    pub characters: u32,
}

/// Turns per-stage timing of a crowd's `slod_crowd_advance` on or off (off by default: two
/// clock reads per character per frame). Poses are the same either way.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_set_stage_timing(
    world: *mut SlodWorld,
    crowd: SlodCrowdId,
    on: bool,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        crowd_mut(world, crowd)?.set_stage_timing(on);
        Ok(())
    })
}

/// Writes the per-stage statistics of a crowd's last `slod_crowd_advance` to `*out_stats`.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_stats` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_crowd_stage_stats(
    world: *const SlodWorld,
    crowd: SlodCrowdId,
    out_stats: *mut SlodCrowdStageStats,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let c = world.crowds.get(RawId::from(crowd), "crowd")?;
        let s = c.last_stats();
        let changed = c
            .character_ids()
            .filter(|&id| c.pose_changed(id).unwrap_or(false))
            .count();
        let stats = SlodCrowdStageStats {
            sample_ns: s.sample_ns,
            concat_ns: s.concat_ns,
            characters_changed: changed as u32,
            characters: s.characters,
        };
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_stats, stats, "out_stats") }
    })
}
