//! Characters over the C ABI: animated instances in a crowd, their playback, and their joint
//! matrices (model space and skinning) for the renderer.

use std::cell::RefCell;

use animlod::{CharacterId, Crowd};
use glam::Mat4;

use super::arena::RawId;
use super::boundary::{arg, arg_mut, boundary, check_copy_out, copy_out_map, write_out};
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
    /// World position of the skeleton's origin (every coordinate finite, within
    /// `SLOD_MAX_COORDINATE`); turn and scale a character with `slod_character_set_rotation`
    /// and `slod_character_set_scale`.
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
pub(super) fn character_mut(
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
pub(super) fn character_ref(
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
    // SAFETY: caller contract, passed on.
    unsafe {
        copy_palette(
            world,
            character,
            skin,
            out,
            cap,
            out_len,
            |c, id, skin, m| c.skinning_matrices(id, skin, m),
        )
    }
}

/// Copies out a palette of skin `skin` that `write` computes for a character (the shared body
/// of the skinning-matrix queries).
///
/// # Safety
/// As `slod_character_skinning_matrices`.
unsafe fn copy_palette(
    world: *const SlodWorld,
    character: SlodCharacterId,
    skin: u32,
    out: *mut f32,
    cap: usize,
    out_len: *mut usize,
    write: impl Fn(
        &Crowd,
        CharacterId,
        animlod::SkinId,
        &mut [Mat4],
    ) -> Result<usize, animlod::CrowdError>,
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
            write(c, cid, skin, &mut m).map_err(crowd_error)?;
            // SAFETY: caller contract: `out` valid for `cap` writes, `out_len` for one.
            unsafe { copy_out_map(&m, Mat4::to_cols_array, out, cap, out_len, "out") }
        })
    })
}

/// What the last `slod_crowd_advance` changed in a character's key poses
/// (`SLOD_LOD_MODE_INTERPOLATED`; values of `slod_character_key_state`'s `out_update`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodKeyUpdate {
    /// Neither key pose changed (only the blend weight may have).
    Unchanged = 0,
    /// The old later pose became the earlier one and a new later pose was evaluated: swap the
    /// host's two copies (skinned vertices or palettes) and recompute the later one.
    Advanced = 1,
    /// Both key poses were evaluated anew: recompute both copies. The first advance after a
    /// character is added or the LOD mode changes always reports it.
    Restarted = 2,
}

/// Writes a character's key-pose blend weight (in [0, 1]; the current pose is
/// `earlier + (later − earlier) × weight`, matrix by matrix) to `*out_weight` and what the last
/// `slod_crowd_advance` changed in its key poses (a `SlodKeyUpdate` value) to `*out_update`.
/// A host skins each key pose once (`slod_character_key_skinning_matrices`) and blends the two
/// skinned copies with the weight — the same vertices as skinning the blended pose. Outside
/// `SLOD_LOD_MODE_INTERPOLATED` both key poses are the current pose and the weight is 1.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_weight` and `out_update` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_key_state(
    world: *const SlodWorld,
    character: SlodCharacterId,
    out_weight: *mut f32,
    out_update: *mut u32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let (c, cid) = character_ref(world, character)?;
        let k = c.key_poses(cid).map_err(crowd_error)?;
        let update = match k.update {
            animlod::KeyUpdate::Unchanged => SlodKeyUpdate::Unchanged,
            animlod::KeyUpdate::Advanced => SlodKeyUpdate::Advanced,
            animlod::KeyUpdate::Restarted => SlodKeyUpdate::Restarted,
        } as u32;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_weight, k.weight, "out_weight") }?;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_update, update, "out_update") }
    })
}

/// Copies the skinning matrices of one of a character's key poses (`later` true: the later
/// pose, else the earlier; see `slod_character_key_state`) for skin `skin` to `out`, laid out
/// as in `slod_character_skinning_matrices`.
///
/// Buffer: copy-out counted in matrices (`slod_rig_skin_joint_count`). Threads: reads the world
/// only. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT` for a bad skin index,
/// `SLOD_RESULT_BUFFER_TOO_SMALL`.
///
/// # Safety
/// `world` NULL or a live world; `out` valid for `16 × cap` float writes (NULL if `cap` is 0);
/// `out_len` valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_key_skinning_matrices(
    world: *const SlodWorld,
    character: SlodCharacterId,
    skin: u32,
    later: bool,
    out: *mut f32,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    // SAFETY: caller contract, passed on.
    unsafe {
        copy_palette(
            world,
            character,
            skin,
            out,
            cap,
            out_len,
            |c, id, skin, m| c.key_skinning_matrices(id, skin, later, m),
        )
    }
}

/// Makes a character play its clip once and stop on the last pose (`once` true), or loop it
/// (false, the default).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_set_play_once(
    world: *mut SlodWorld,
    character: SlodCharacterId,
    once: bool,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let (c, cid) = character_mut(world, character)?;
        c.set_play_once(cid, once).map_err(crowd_error)
    })
}

/// Writes whether a character's pose changed in the last `slod_crowd_advance` to
/// `*out_changed`. False means every bone held: the host's skinned vertices (or uploaded
/// palette) from the previous frame are still exact and can be reused.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_changed` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_pose_changed(
    world: *const SlodWorld,
    character: SlodCharacterId,
    out_changed: *mut bool,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let (c, cid) = character_ref(world, character)?;
        let changed = c.pose_changed(cid).map_err(crowd_error)?;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_changed, changed, "out_changed") }
    })
}

/// Writes a character's pose error against full-rate evaluation (joint origins and tips,
/// pixels through the world's view; see `SlodPoseError`) to `*out_error`.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_error` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_pose_error(
    world: *const SlodWorld,
    character: SlodCharacterId,
    out_error: *mut super::crowd::SlodPoseError,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let (c, cid) = character_ref(world, character)?;
        let e = c.pose_error(cid, &world.view).map_err(crowd_error)?;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_error, e.into(), "out_error") }
    })
}

thread_local! {
    /// Skinned positions and normals of the last call on this thread.
    static SKINNED: RefCell<(Vec<glam::Vec3>, Vec<glam::Vec3>)> =
        const { RefCell::new((Vec::new(), Vec::new())) };
}

/// Skins mesh `mesh` of a character's rig on the CPU (linear blend of up to four joints per
/// vertex) and copies its positions and normals (3 floats each: x, y, z, stride 3 floats;
/// skeleton model space; add the character's position for world space) to `positions` and
/// `normals`.
///
/// Buffer: copy-out counted in vertices, both buffers `cap` long (call with `cap` 0 to size
/// them); nothing is written unless both fit. Threads: reads the world only. Errors:
/// `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT` for a mesh index out of range
/// (`slod_rig_mesh_count`), `SLOD_RESULT_BUFFER_TOO_SMALL`.
///
/// # Safety
/// `world` NULL or a live world; `positions` and `normals` valid for `3 × cap` float writes
/// each (NULL if `cap` is 0); `out_len` valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_skinned_vertices(
    world: *const SlodWorld,
    character: SlodCharacterId,
    mesh: u32,
    positions: *mut f32,
    normals: *mut f32,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    // `[f32; 3]` has the size of 3 floats and the alignment of one: `3 × cap` floats are `cap`
    // triples.
    let (positions, normals) = (positions.cast::<[f32; 3]>(), normals.cast::<[f32; 3]>());
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let (c, cid) = character_ref(world, character)?;
        let rig = c.rig();
        let m = rig.meshes().get(mesh as usize).ok_or_else(|| {
            FfiError::invalid(
                "mesh",
                format!(
                    "mesh {mesh} is out of range (the rig has {})",
                    rig.meshes().len()
                ),
            )
        })?;
        let joints = rig.skin(m.skin).map_or(0, |s| s.joints.len());
        let n = m.vertex_count();
        // Sizing calls and short buffers end here, before any skinning.
        // SAFETY: caller contract: `out_len` valid for a write.
        unsafe { check_copy_out(n, positions, cap, out_len, "positions") }?;
        if positions.is_null() {
            return Ok(());
        }
        if normals.is_null() {
            return Err(FfiError::Null("normals"));
        }
        SKINNING.with(|palette| {
            SKINNED.with(|out| {
                let (mut palette, mut out) = (palette.borrow_mut(), out.borrow_mut());
                palette.resize(joints, Mat4::IDENTITY);
                c.skinning_matrices(cid, m.skin, &mut palette)
                    .map_err(crowd_error)?;
                let (p, nrm) = &mut *out;
                p.resize(n, glam::Vec3::ZERO);
                nrm.resize(n, glam::Vec3::ZERO);
                animlod::SkinningJob {
                    mesh: m,
                    palette: &palette,
                    positions: p,
                    normals: nrm,
                }
                .run()
                .map_err(crowd_error)?;
                // SAFETY: caller contract: `normals` valid for `cap` >= n writes.
                unsafe {
                    copy_out_map(nrm, glam::Vec3::to_array, normals, cap, out_len, "normals")
                }?;
                // SAFETY: caller contract: `positions` valid for `cap` writes, `out_len` for one.
                unsafe {
                    copy_out_map(
                        p,
                        glam::Vec3::to_array,
                        positions,
                        cap,
                        out_len,
                        "positions",
                    )
                }
            })
        })
    })
}

/// Turns a character: `rotation` is a quaternion `{x, y, z, w}` (finite, non-zero length;
/// normalised) mapping its skeleton model space to the world, about the skeleton's origin.
/// Distances, projected sizes and errors are measured with it; the matrices the character
/// reports stay in skeleton model space.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`
/// (nothing changed).
///
/// # Safety
/// `world` NULL or a live world; `rotation` NULL or valid for a read.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_set_rotation(
    world: *mut SlodWorld,
    character: SlodCharacterId,
    rotation: *const [f32; 4],
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or valid for a read.
        let q = *unsafe { arg(rotation, "rotation") }?;
        let (c, cid) = character_mut(world, character)?;
        c.set_rotation(cid, glam::Quat::from_array(q))
            .map_err(crowd_error)
    })
}

/// Scales a character uniformly about its skeleton's origin (finite, in (0, 1e4]; 1 by
/// default).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`
/// (nothing changed).
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_set_scale(
    world: *mut SlodWorld,
    character: SlodCharacterId,
    scale: f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let (c, cid) = character_mut(world, character)?;
        in_range(scale, 0.0, 1.0e4, "scale")?;
        c.set_scale(cid, scale).map_err(crowd_error)
    })
}

#[cfg(test)]
mod tests {
    //! The rig, crowd and character calls issue 13 added, on a real rig.
    use super::super::*;
    use std::f32::consts::FRAC_1_SQRT_2;
    use std::ptr::{null, null_mut};

    #[test]
    fn rig_structure_skinning_and_lod_controls_over_the_c_abi() {
        let bytes = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../assets/gltf/GDQuest_GDBot.glb"
        ))
        .unwrap();
        let mut w = null_mut();
        let (mut rig, mut crowd, mut ch) = (
            SlodRigId::default(),
            SlodCrowdId::default(),
            SlodCharacterId::default(),
        );
        // SAFETY: a live world throughout; every buffer is valid for the length passed.
        unsafe {
            assert_eq!(
                slod_world_create(&slod_default_world_desc(), &mut w),
                SlodResult::Ok
            );
            assert_eq!(
                slod_rig_load_memory(w, bytes.as_ptr(), bytes.len(), &mut rig),
                SlodResult::Ok
            );
            assert_eq!(
                slod_crowd_create(w, rig, &slod_default_crowd_desc(), &mut crowd),
                SlodResult::Ok
            );
            let mut desc = slod_default_character_desc();
            desc.position = [0.0, 0.0, -5.0];
            assert_eq!(
                slod_character_create(w, crowd, &desc, &mut ch),
                SlodResult::Ok
            );

            // Parents: sized with cap 0, then copied; parents come first.
            let mut n = 0;
            assert_eq!(
                slod_rig_bone_parents(w, rig, null_mut(), 0, &mut n),
                SlodResult::Ok
            );
            let mut parents = vec![0u32; n];
            assert_eq!(
                slod_rig_bone_parents(w, rig, parents.as_mut_ptr(), n, &mut n),
                SlodResult::Ok
            );
            assert_eq!(parents[0], SLOD_NO_PARENT);
            assert!(
                parents
                    .iter()
                    .enumerate()
                    .skip(1)
                    .all(|(i, &p)| p == SLOD_NO_PARENT || (p as usize) < i)
            );
            let mut name = [0 as std::ffi::c_char; 64];
            let mut len = 0;
            assert_eq!(
                slod_rig_bone_name(w, rig, 0, name.as_mut_ptr(), 64, &mut len),
                SlodResult::Ok
            );
            assert!(len > 1);
            assert_eq!(
                slod_rig_bone_name(w, rig, n as u32, name.as_mut_ptr(), 64, &mut len),
                SlodResult::InvalidArgument
            );
            // Skin joints → bones.
            let mut joints = 0;
            assert_eq!(
                slod_rig_skin_joint_count(w, rig, 0, &mut joints),
                SlodResult::Ok
            );
            let mut map = vec![0u32; joints];
            assert_eq!(
                slod_rig_skin_joints(w, rig, 0, map.as_mut_ptr(), joints, &mut len),
                SlodResult::Ok
            );
            assert!(map.iter().all(|&b| (b as usize) < n));

            // Skinned vertices: sized with cap 0; a short buffer gets nothing.
            let mut meshes = 0;
            assert_eq!(slod_rig_mesh_count(w, rig, &mut meshes), SlodResult::Ok);
            assert!(meshes >= 1);
            let mut v = 0;
            assert_eq!(
                slod_character_skinned_vertices(w, ch, 0, null_mut(), null_mut(), 0, &mut v),
                SlodResult::Ok
            );
            assert!(v > 0);
            let mut short = vec![[0.0f32; 3]; 1];
            assert_eq!(
                slod_character_skinned_vertices(
                    w,
                    ch,
                    0,
                    short.as_mut_ptr().cast(),
                    short.as_mut_ptr().cast(),
                    1,
                    &mut len
                ),
                SlodResult::BufferTooSmall
            );
            assert_eq!(short[0], [0.0; 3]);
            let (mut p, mut nrm) = (vec![[f32::NAN; 3]; v], vec![[f32::NAN; 3]; v]);
            assert_eq!(
                slod_character_skinned_vertices(
                    w,
                    ch,
                    0,
                    p.as_mut_ptr().cast(),
                    nrm.as_mut_ptr().cast(),
                    v,
                    &mut v
                ),
                SlodResult::Ok
            );
            assert!(p.iter().chain(&nrm).flatten().all(|x| x.is_finite()));
            assert_eq!(
                slod_character_skinned_vertices(
                    w,
                    ch,
                    meshes as u32,
                    p.as_mut_ptr().cast(),
                    nrm.as_mut_ptr().cast(),
                    v,
                    &mut v
                ),
                SlodResult::InvalidArgument
            );

            // Rotation and scale: bad values refused.
            assert_eq!(
                slod_character_set_rotation(w, ch, &[0.0, 0.0, 0.0, 0.0]),
                SlodResult::InvalidArgument
            );
            assert_eq!(
                slod_character_set_rotation(w, ch, &[0.0, FRAC_1_SQRT_2, 0.0, FRAC_1_SQRT_2]),
                SlodResult::Ok
            );
            assert_eq!(
                slod_character_set_scale(w, ch, 0.0),
                SlodResult::InvalidArgument
            );
            assert_eq!(slod_character_set_scale(w, ch, 1.5), SlodResult::Ok);

            // Stage statistics after a timed advance.
            assert_eq!(slod_crowd_set_stage_timing(w, crowd, true), SlodResult::Ok);
            assert_eq!(
                slod_crowd_advance(w, crowd, 0.016, null_mut()),
                SlodResult::Ok
            );
            let mut st = SlodCrowdStageStats::default();
            assert_eq!(slod_crowd_stage_stats(w, crowd, &mut st), SlodResult::Ok);
            assert_eq!((st.characters, st.characters_changed), (1, 1));
            assert!(st.sample_ns > 0);

            // Play once, pose changed, pose error (0 at full detail).
            assert_eq!(slod_character_set_play_once(w, ch, true), SlodResult::Ok);
            assert_eq!(
                slod_crowd_advance(w, crowd, 0.016, null_mut()),
                SlodResult::Ok
            );
            let mut changed = false;
            assert_eq!(
                slod_character_pose_changed(w, ch, &mut changed),
                SlodResult::Ok
            );
            assert!(changed);
            let mut e = SlodPoseError::default();
            assert_eq!(slod_character_pose_error(w, ch, &mut e), SlodResult::Ok);
            assert_eq!((e.max, e.max_px), (0.0, 0.0));
            assert!(e.joints > 0);
            assert_eq!(slod_crowd_pose_error(w, crowd, &mut e), SlodResult::Ok);
            assert_eq!(e.max, 0.0);

            // Priority and scheduler controls: bad values refused.
            let bad = SlodPriorityWeights {
                translation: -1.0,
                rotation: 1.0,
                scale: 0.0,
                descendants: 0.0,
                depth: 0.0,
                user: 0.0,
            };
            assert_eq!(
                slod_crowd_set_priority_weights(w, crowd, &bad),
                SlodResult::InvalidArgument
            );
            assert_eq!(
                slod_crowd_set_priority_weights(w, crowd, null()),
                SlodResult::NullArgument
            );
            let good = SlodPriorityWeights {
                translation: -bad.translation,
                ..bad
            };
            assert_eq!(
                slod_crowd_set_priority_weights(w, crowd, &good),
                SlodResult::Ok
            );
            assert_eq!(
                slod_crowd_set_user_priority(w, crowd, n as u32, 1.0),
                SlodResult::InvalidArgument
            );
            assert_eq!(
                slod_crowd_set_user_priority(w, crowd, 0, 2.0),
                SlodResult::Ok
            );
            assert_eq!(
                slod_crowd_set_priority_source(w, crowd, 7),
                SlodResult::InvalidArgument
            );
            assert_eq!(
                slod_crowd_set_priority_source(w, crowd, SlodPrioritySource::HoldError as u32),
                SlodResult::Ok
            );
            let mut source = SlodPrioritySource::Factors;
            assert_eq!(
                slod_crowd_priority_source(w, crowd, &mut source),
                SlodResult::Ok
            );
            assert_eq!(source, SlodPrioritySource::HoldError);
            assert_eq!(
                slod_crowd_set_scheduler(w, crowd, 0.0, 0.05),
                SlodResult::InvalidArgument
            );
            assert_eq!(
                slod_crowd_set_scheduler(w, crowd, 0.02, 0.05),
                SlodResult::Ok
            );
            slod_world_destroy(w);
        }
    }
}
