//! Characters over the C ABI: animated instances in a crowd, their playback, and their joint
//! matrices (model space and skinning) for the renderer.

use std::cell::RefCell;

use animlod::{CharacterId, Crowd};
use glam::Mat4;

use super::arena::RawId;
use super::boundary::{arg, arg_mut, boundary, copy_out_map, write_out};
use super::cloth::{in_range, position};
use super::crowd::{crowd_error, crowd_mut};
use super::ids::{SlodCharacterId, SlodCrowdId};
use super::result::{FfiError, SlodResult};
use super::rig::{check_clip, check_skin};
use super::world::{SLOD_DESC_GUARD, SlodWorld, check_guard};

/// Largest playback speed a character accepts (1 = real time).
pub const SLOD_MAX_PLAYBACK_SPEED: f32 = 1000.0;

/// How to add a character. Get one from `slod_default_character_desc`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodCharacterDesc {
    /// Set by `slod_default_character_desc`; do not change.
    pub guard: u32,
    /// World position of the skeleton's origin (characters are not rotated; every coordinate
    /// finite, within `SLOD_MAX_COORDINATE`).
    pub position: [f32; 3],
    /// Clip index in the crowd's rig (`0..SlodRigInfo::clips`).
    pub clip: u32,
    /// Start time within the clip in seconds (finite; wrapped into the clip).
    pub time: f32,
    /// Playback speed, in [0, `SLOD_MAX_PLAYBACK_SPEED`] (1 = real time).
    pub speed: f32,
}

/// The default character: at the origin, clip 0 from time 0, speed 1. Returns a value the host
/// owns.
#[unsafe(no_mangle)]
pub extern "C" fn slod_default_character_desc() -> SlodCharacterDesc {
    SlodCharacterDesc {
        guard: SLOD_DESC_GUARD,
        position: [0.0; 3],
        clip: 0,
        time: 0.0,
        speed: 1.0,
    }
}

/// The crowd and in-crowd id of a live character.
fn lookup(world: &SlodWorld, id: SlodCharacterId) -> Result<(RawId, CharacterId), FfiError> {
    world.characters.get(RawId::from(id), "character").copied()
}

/// The crowd of a live character, mutably, with the character's in-crowd id.
fn character_mut(
    world: &mut SlodWorld,
    id: SlodCharacterId,
) -> Result<(&mut Crowd, CharacterId), FfiError> {
    let (crowd, cid) = lookup(world, id)?;
    let c = world
        .crowds
        .get_mut(crowd, "character")
        .map_err(|_| FfiError::StaleId("character"))?;
    Ok((c, cid))
}

/// The crowd of a live character, read-only, with the character's in-crowd id.
fn character_ref(
    world: &SlodWorld,
    id: SlodCharacterId,
) -> Result<(&Crowd, CharacterId), FfiError> {
    let (crowd, cid) = lookup(world, id)?;
    let c = world
        .crowds
        .get(crowd, "character")
        .map_err(|_| FfiError::StaleId("character"))?;
    Ok((c, cid))
}

/// Adds a character to a crowd and writes its id; its pose is evaluated at once.
///
/// Ownership: the crowd owns the character; destroy it with `slod_character_destroy`, or with
/// its crowd or world. The desc is copied. Threads: mutates the world. Errors:
/// `SLOD_RESULT_STALE_ID` for `crowd`, `SLOD_RESULT_INVALID_ARGUMENT` naming the bad desc field.
///
/// # Safety
/// `world` NULL or a live world; `desc` NULL or valid; `out_character` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_create(
    world: *mut SlodWorld,
    crowd: SlodCrowdId,
    desc: *const SlodCharacterDesc,
    out_character: *mut SlodCharacterId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid desc.
        let desc = *unsafe { arg(desc, "desc") }?;
        check_guard(desc.guard, "desc")?;
        let c = crowd_mut(world, crowd)?;
        let pos = position(desc.position, "desc.position")?;
        let clip = check_clip(c.rig(), desc.clip).map_err(|_| {
            FfiError::invalid(
                "desc.clip",
                format!("{} is not a clip of the crowd's rig", desc.clip),
            )
        })?;
        in_range(desc.time, f32::MIN, f32::MAX, "desc.time")?;
        in_range(desc.speed, 0.0, SLOD_MAX_PLAYBACK_SPEED, "desc.speed")?;
        if out_character.is_null() {
            return Err(FfiError::Null("out_character"));
        }
        // Everything is checked, so nothing below fails on the arguments; if it did, the
        // character is removed again so that the crowd is unchanged.
        let cid = c.add_character(pos, clip).map_err(crowd_error)?;
        let played = c
            .set_time(cid, desc.time)
            .and_then(|()| c.set_speed(cid, desc.speed));
        if let Err(e) = played {
            let _ = c.remove_character(cid);
            return Err(crowd_error(e));
        }
        let id: SlodCharacterId = world.characters.insert((RawId::from(crowd), cid)).into();
        // SAFETY: checked non-NULL; valid for a write per the caller contract.
        unsafe { write_out(out_character, id, "out_character") }
    })
}

/// Removes a character from its crowd; its id (and every copy) is stale afterwards.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_destroy(
    world: *mut SlodWorld,
    character: SlodCharacterId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let (c, cid) = character_mut(world, character)?;
        c.remove_character(cid).map_err(crowd_error)?;
        world
            .characters
            .remove(RawId::from(character), "character")?;
        Ok(())
    })
}

/// Moves a character to (`x`, `y`, `z`) (world position of its skeleton's origin).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`; `SLOD_RESULT_INVALID_ARGUMENT`
/// for a coordinate not finite or beyond `SLOD_MAX_COORDINATE`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_set_position(
    world: *mut SlodWorld,
    character: SlodCharacterId,
    x: f32,
    y: f32,
    z: f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let (c, cid) = character_mut(world, character)?;
        let p = position([x, y, z], "position (x, y, z)")?;
        c.set_position(cid, p).map_err(crowd_error)
    })
}

/// Switches a character to clip `clip` at `time` seconds (wrapped into the clip); the pose is
/// evaluated at once.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`; `SLOD_RESULT_INVALID_ARGUMENT`
/// for a bad clip index or a time that is not finite.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_set_clip(
    world: *mut SlodWorld,
    character: SlodCharacterId,
    clip: u32,
    time: f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let (c, cid) = character_mut(world, character)?;
        let clip = check_clip(c.rig(), clip)?;
        in_range(time, f32::MIN, f32::MAX, "time")?;
        c.set_clip(cid, clip).map_err(crowd_error)?;
        c.set_time(cid, time).map_err(crowd_error)
    })
}

/// Sets a character's playback speed, in [0, `SLOD_MAX_PLAYBACK_SPEED`] (1 = real time).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_set_speed(
    world: *mut SlodWorld,
    character: SlodCharacterId,
    speed: f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let (c, cid) = character_mut(world, character)?;
        in_range(speed, 0.0, SLOD_MAX_PLAYBACK_SPEED, "speed")?;
        c.set_speed(cid, speed).map_err(crowd_error)
    })
}

/// Copies a character's bone matrices in skeleton model space (16 floats per bone, stride 16
/// floats, column-major: element `col * 4 + row`, translation in elements 12..14) to `out`.
///
/// Add the character's position for world space. Bone order is the rig's (parents first).
/// Buffer: copy-out counted in matrices (`SlodRigInfo::bones`); the values change at the next
/// `slod_crowd_advance`. Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`,
/// `SLOD_RESULT_BUFFER_TOO_SMALL`.
///
/// # Safety
/// `world` NULL or a live world; `out` valid for `16 × cap` float writes (NULL if `cap` is 0);
/// `out_len` valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_model_matrices(
    world: *const SlodWorld,
    character: SlodCharacterId,
    out: *mut f32,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    // `[f32; 16]` has the size of 16 floats and the alignment of one: `16 × cap` floats are
    // `cap` matrices.
    let out = out.cast::<[f32; 16]>();
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let (c, cid) = character_ref(world, character)?;
        let models = c.model_matrices(cid).map_err(crowd_error)?;
        // SAFETY: caller contract: `out` valid for `cap` writes, `out_len` for one.
        unsafe { copy_out_map(models, Mat4::to_cols_array, out, cap, out_len, "out") }
    })
}

thread_local! {
    /// Skinning matrices of the last call on this thread (reused; no shared state, so the query
    /// can take a `const SlodWorld*`).
    static SKINNING: RefCell<Vec<Mat4>> = const { RefCell::new(Vec::new()) };
}

/// Copies a character's skinning matrices for skin `skin` (model matrix × inverse bind matrix
/// per joint, skeleton model space, 16 floats column-major as in
/// `slod_character_model_matrices`) to `out`: what a skinning shader takes.
///
/// Buffer: copy-out counted in matrices (`slod_rig_skin_joint_count`). Threads: reads the world
/// only. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT` for a bad skin index,
/// `SLOD_RESULT_BUFFER_TOO_SMALL`.
///
/// # Safety
/// `world` NULL or a live world; `out` valid for `16 × cap` float writes (NULL if `cap` is 0);
/// `out_len` valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_skinning_matrices(
    world: *const SlodWorld,
    character: SlodCharacterId,
    skin: u32,
    out: *mut f32,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    // `[f32; 16]` has the size of 16 floats and the alignment of one: `16 × cap` floats are
    // `cap` matrices.
    let out = out.cast::<[f32; 16]>();
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let (c, cid) = character_ref(world, character)?;
        let skin = check_skin(c.rig(), skin)?;
        let joints = c.rig().skin(skin).map_or(0, |s| s.joints.len());
        SKINNING.with(|m| {
            let mut m = m.borrow_mut();
            m.resize(joints, Mat4::IDENTITY);
            c.skinning_matrices(cid, skin, &mut m)
                .map_err(crowd_error)?;
            // SAFETY: caller contract: `out` valid for `cap` writes, `out_len` for one.
            unsafe { copy_out_map(&m, Mat4::to_cols_array, out, cap, out_len, "out") }
        })
    })
}
