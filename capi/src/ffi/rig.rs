//! Rigs over the C ABI: load a skeleton with its clips and skins from a glTF file or from memory,
//! query it, destroy it.
//!
//! Lifetime choice: a crowd holds its own reference to its rig (`Arc`), so destroying a rig only
//! drops the world's reference. Crowds made from it keep working and the memory goes with the
//! last of them; the rig's id is stale at once. This never refuses a destroy and never leaves a
//! crowd without its data.

use std::path::Path;
use std::sync::Arc;

use animlod::{ClipId, ImportError, Rig, SkinId};

use super::arena::RawId;
use super::boundary::{arg, arg_mut, boundary, c_str, copy_out, slice, write_out};
use super::ids::SlodRigId;
use super::result::{FfiError, SlodResult};
use super::world::SlodWorld;

/// Largest glTF blob `slod_rig_load_memory` accepts, in bytes (1 GiB).
pub const SLOD_MAX_GLTF_BYTES: u64 = 1 << 30;

/// What a rig holds (`slod_rig_info`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlodRigInfo {
    /// Bones of the skeleton (the length `slod_character_model_matrices` writes).
    pub bones: u32,
    /// Animation clips; valid clip indices are `0..clips`.
    pub clips: u32,
    /// Skins; valid skin indices are `0..skins`.
    pub skins: u32,
    /// Centre of a sphere (skeleton model space) holding every joint in the rest pose and the
    /// first pose of every clip.
    pub bounds_center: [f32; 3],
    /// Radius of that sphere.
    pub bounds_radius: f32,
}

fn import_error(e: ImportError) -> FfiError {
    match e {
        ImportError::Io { path, source } => FfiError::Io {
            path: path.display().to_string(),
            reason: source.to_string(),
        },
        other => FfiError::Parse(other.to_string()),
    }
}

fn insert(world: &mut SlodWorld, rig: Rig) -> SlodRigId {
    world.rigs.insert(Arc::new(rig)).into()
}

/// Loads a rig (skeleton, clips, skins) from a .glb or .gltf file and writes its id.
///
/// `path` is a NUL-terminated path (bytes as the OS takes them on Unix, UTF-8 elsewhere); buffer
/// files a .gltf references are looked up next to it. Ownership: the world owns the rig; the
/// path is read during the call only. Threads: mutates the world. Errors: `SLOD_RESULT_IO_ERROR`
/// if a file cannot be read, `SLOD_RESULT_PARSE_ERROR` with the importer's message for malformed
/// or unsupported glTF (no skin, bad accessors, ...), `SLOD_RESULT_INVALID_ARGUMENT` for an empty
/// path, `SLOD_RESULT_NULL_ARGUMENT` for a NULL `world`, `path` or `out_rig`. Nothing is created
/// on error.
///
/// # Safety
/// `world` NULL or a live world; `path` NULL or a NUL-terminated string; `out_rig` NULL or valid
/// for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_rig_load_file(
    world: *mut SlodWorld,
    path: *const std::ffi::c_char,
    out_rig: *mut SlodRigId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        #[cfg(unix)]
        let path: &Path = {
            use std::os::unix::ffi::OsStrExt;
            if path.is_null() {
                return Err(FfiError::Null("path"));
            }
            // SAFETY: non-NULL and NUL-terminated per the caller contract.
            let bytes = unsafe { std::ffi::CStr::from_ptr(path) }.to_bytes();
            Path::new(std::ffi::OsStr::from_bytes(bytes))
        };
        #[cfg(not(unix))]
        // SAFETY: caller contract: NULL or a NUL-terminated string.
        let path: &Path = Path::new(unsafe { c_str(path, "path") }?);
        if path.as_os_str().is_empty() {
            return Err(FfiError::invalid("path", "empty"));
        }
        if out_rig.is_null() {
            return Err(FfiError::Null("out_rig"));
        }
        let rig = animlod::build::import_path(path).map_err(import_error)?;
        let id = insert(world, rig);
        // SAFETY: checked non-NULL; valid for a write per the caller contract.
        unsafe { write_out(out_rig, id, "out_rig") }
    })
}

/// Loads a rig from a .glb or a self-contained .gltf (data URIs) held in memory.
///
/// Ownership: the bytes are read during the call only (the host keeps them); the world owns the
/// rig. Threads: mutates the world. Errors: `SLOD_RESULT_INVALID_ARGUMENT` for `len` 0 or above
/// `SLOD_MAX_GLTF_BYTES`, `SLOD_RESULT_PARSE_ERROR` with the importer's message. Nothing is
/// created on error.
///
/// # Safety
/// `world` NULL or a live world; `bytes` valid for `len` reads; `out_rig` NULL or valid for a
/// write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_rig_load_memory(
    world: *mut SlodWorld,
    bytes: *const u8,
    len: usize,
    out_rig: *mut SlodRigId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        if len == 0 || len as u64 > SLOD_MAX_GLTF_BYTES {
            return Err(FfiError::invalid(
                "len",
                format!("{len} is outside [1, {SLOD_MAX_GLTF_BYTES}]"),
            ));
        }
        // SAFETY: caller contract: valid for `len` reads (NULL checked inside).
        let bytes = unsafe { slice(bytes, len, "bytes") }?;
        if out_rig.is_null() {
            return Err(FfiError::Null("out_rig"));
        }
        let rig = animlod::build::import_slice(bytes, None).map_err(import_error)?;
        let id = insert(world, rig);
        // SAFETY: checked non-NULL; valid for a write per the caller contract.
        unsafe { write_out(out_rig, id, "out_rig") }
    })
}

/// Destroys the world's reference to a rig; its id is stale at once.
///
/// Crowds created from the rig keep their own reference and keep working; the rig's memory is
/// freed with the last of them. Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_rig_destroy(world: *mut SlodWorld, rig: SlodRigId) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        world.rigs.remove(RawId::from(rig), "rig")?;
        Ok(())
    })
}

/// The live rig behind an id.
pub(crate) fn rig_ref(world: &SlodWorld, id: SlodRigId) -> Result<&Arc<Rig>, FfiError> {
    world.rigs.get(RawId::from(id), "rig")
}

/// Writes the rig's bone, clip and skin counts and its bounds to `*out_info`.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_info` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_rig_info(
    world: *const SlodWorld,
    rig: SlodRigId,
    out_info: *mut SlodRigInfo,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let r = rig_ref(world, rig)?;
        let (center, radius) = r.bounds();
        let info = SlodRigInfo {
            bones: r.bone_count() as u32,
            clips: r.clips().len() as u32,
            skins: r.skins().len() as u32,
            bounds_center: center.to_array(),
            bounds_radius: radius,
        };
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_info, info, "out_info") }
    })
}

/// Checks a clip index against a rig.
pub(crate) fn check_clip(rig: &Rig, clip: u32) -> Result<ClipId, FfiError> {
    let id = ClipId::from_raw(clip);
    match rig.clip(id) {
        Some(_) => Ok(id),
        None => Err(FfiError::invalid(
            "clip",
            format!(
                "{clip} is not a clip of this rig ({} clips)",
                rig.clips().len()
            ),
        )),
    }
}

/// Checks a skin index against a rig.
pub(crate) fn check_skin(rig: &Rig, skin: u32) -> Result<SkinId, FfiError> {
    let id = SkinId::from_raw(skin);
    match rig.skin(id) {
        Some(_) => Ok(id),
        None => Err(FfiError::invalid(
            "skin",
            format!(
                "{skin} is not a skin of this rig ({} skins)",
                rig.skins().len()
            ),
        )),
    }
}

/// Copies the name of clip `clip` (UTF-8, NUL-terminated) to `buf`.
///
/// Buffer: copy-out (the header's rule) counted in bytes including the NUL: on success
/// `*out_len` is the name's length plus one; with `cap` smaller nothing is written and
/// `SLOD_RESULT_BUFFER_TOO_SMALL` is returned.
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`
/// for a bad clip index.
///
/// # Safety
/// `world` NULL or a live world; `buf` valid for `cap` writes (NULL if `cap` is 0); `out_len`
/// valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_rig_clip_name(
    world: *const SlodWorld,
    rig: SlodRigId,
    clip: u32,
    buf: *mut std::ffi::c_char,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let r = rig_ref(world, rig)?;
        let id = check_clip(r, clip)?;
        let name = r.clip(id).map(|c| c.name()).unwrap_or_default();
        // A name with an interior NUL would be cut short in C; those bytes are replaced.
        let mut bytes: Vec<u8> = name
            .bytes()
            .map(|b| if b == 0 { b'?' } else { b })
            .collect();
        bytes.push(0);
        // SAFETY: caller contract: `buf` valid for `cap` writes, `out_len` for one.
        unsafe { copy_out(&bytes, buf.cast::<u8>(), cap, out_len, "buf") }
    })
}

/// Writes the duration in seconds of clip `clip` to `*out_seconds`.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`.
///
/// # Safety
/// `world` NULL or a live world; `out_seconds` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_rig_clip_duration(
    world: *const SlodWorld,
    rig: SlodRigId,
    clip: u32,
    out_seconds: *mut f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let r = rig_ref(world, rig)?;
        let id = check_clip(r, clip)?;
        let d = r.clip(id).map_or(0.0, |c| c.duration());
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_seconds, d, "out_seconds") }
    })
}

/// Writes the index of the first clip named `name` to `*out_clip`.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`; `SLOD_RESULT_INVALID_ARGUMENT`
/// if no clip has that name or it is not UTF-8.
///
/// # Safety
/// `world` NULL or a live world; `name` NULL or NUL-terminated; `out_clip` NULL or valid for a
/// write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_rig_find_clip(
    world: *const SlodWorld,
    rig: SlodRigId,
    name: *const std::ffi::c_char,
    out_clip: *mut u32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let r = rig_ref(world, rig)?;
        // SAFETY: caller contract: NULL or NUL-terminated.
        let name = unsafe { c_str(name, "name") }?;
        let id = r
            .clip_by_name(name)
            .ok_or_else(|| FfiError::invalid("name", format!("no clip is named {name:?}")))?;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_clip, id.raw(), "out_clip") }
    })
}

/// Writes the number of joints of skin `skin` (the length `slod_character_skinning_matrices`
/// writes) to `*out_count`.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`.
///
/// # Safety
/// `world` NULL or a live world; `out_count` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_rig_skin_joint_count(
    world: *const SlodWorld,
    rig: SlodRigId,
    skin: u32,
    out_count: *mut usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let r = rig_ref(world, rig)?;
        let id = check_skin(r, skin)?;
        let n = r.skin(id).map_or(0, |s| s.joints.len());
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_count, n, "out_count") }
    })
}
