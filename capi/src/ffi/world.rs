//! The world: the opaque owning handle that holds every cloth, rig and character, plus version
//! queries and the desc guard.

use std::sync::Arc;

use super::arena::{Arena, RawId};
use super::boundary::{arg, boundary, write_out};
use super::result::{FfiError, SlodResult};
use super::view::SlodCamera;
use crate::cloth::AdaptiveCloth;

/// Major version of the C ABI; a change breaks existing hosts.
pub const SLOD_VERSION_MAJOR: u32 = 0;
/// Minor version: functions or result codes appended.
pub const SLOD_VERSION_MINOR: u32 = 1;
/// Patch version: fixes only.
pub const SLOD_VERSION_PATCH: u32 = 0;

/// Value every `*Desc` carries in its `guard` field when it came from `slod_default_*_desc`.
/// Creation refuses a desc without it: a zero-filled struct is a bug, not a configuration.
pub const SLOD_DESC_GUARD: u32 = 0x510D_DE5C;

/// The library version as `major * 1000000 + minor * 1000 + patch`, to compare with the
/// `SLOD_VERSION_*` macros the host was compiled against.
#[unsafe(no_mangle)]
pub extern "C" fn slod_version() -> u32 {
    SLOD_VERSION_MAJOR * 1_000_000 + SLOD_VERSION_MINOR * 1_000 + SLOD_VERSION_PATCH
}

pub(crate) fn check_guard(guard: u32, name: &'static str) -> Result<(), FfiError> {
    if guard == SLOD_DESC_GUARD {
        Ok(())
    } else {
        Err(FfiError::invalid(
            name,
            "guard not set: fill the desc with its slod_default_*_desc function first",
        ))
    }
}

/// Settings of a world. Get one from `slod_default_world_desc` and change what you need.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct SlodWorldDesc {
    /// Set by `slod_default_world_desc`; do not change.
    pub guard: u32,
    /// Worker threads for evaluation and crowd updates; 0 lets slod choose, 1 runs everything on
    /// the calling thread.
    pub worker_threads: u32,
}

/// The default world settings (all work on the calling thread's pool choice).
#[unsafe(no_mangle)]
pub extern "C" fn slod_default_world_desc() -> SlodWorldDesc {
    SlodWorldDesc {
        guard: SLOD_DESC_GUARD,
        worker_threads: 0,
    }
}

/// Everything a host created: cloths, rigs and characters. Opaque to C.
///
/// Threads: a world is used from one thread at a time; functions taking `const SlodWorld*` may
/// run concurrently with each other; distinct worlds are independent.
pub struct SlodWorld {
    pub(crate) desc: SlodWorldDesc,
    /// The host's camera as given and as checked, once set.
    pub(crate) camera: Option<(SlodCamera, salience::Camera)>,
    /// The light cloth salience multiplies by, if any.
    pub(crate) light: Option<salience::Light>,
    pub(crate) cloths: Arena<AdaptiveCloth>,
    pub(crate) rigs: Arena<Arc<animlod::Rig>>,
    pub(crate) crowds: Arena<animlod::Crowd>,
    /// Each character's crowd and its id inside that crowd.
    pub(crate) characters: Arena<(RawId, animlod::CharacterId)>,
}

/// Creates a world and writes its owning pointer to `*out_world`. Destroy it with
/// `slod_world_destroy`, which frees everything created in it.
///
/// # Safety
/// `desc` must be NULL or point to a valid `SlodWorldDesc`; `out_world` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_world_create(
    desc: *const SlodWorldDesc,
    out_world: *mut *mut SlodWorld,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a valid desc.
        let desc = *unsafe { arg(desc, "desc") }?;
        check_guard(desc.guard, "desc")?;
        if desc.worker_threads > 1024 {
            return Err(FfiError::invalid("desc.worker_threads", "at most 1024"));
        }
        if out_world.is_null() {
            return Err(FfiError::Null("out_world"));
        }
        let world = Box::new(SlodWorld {
            desc,
            camera: None,
            light: None,
            cloths: Arena::default(),
            rigs: Arena::default(),
            crowds: Arena::default(),
            characters: Arena::default(),
        });
        // SAFETY: `out_world` checked non-NULL; validity per caller contract.
        unsafe { write_out(out_world, Box::into_raw(world), "out_world") }
    })
}

/// Destroys a world and everything in it. NULL is accepted and ignored. The pointer and every id
/// from this world are invalid afterwards.
///
/// # Safety
/// `world` must be NULL or a pointer returned by `slod_world_create` not yet destroyed, and no
/// other thread may be using it.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_world_destroy(world: *mut SlodWorld) {
    let _ = boundary(|| {
        if !world.is_null() {
            // SAFETY: per the contract, `world` came from `Box::into_raw` in `slod_world_create`
            // and is destroyed only once.
            drop(unsafe { Box::from_raw(world) });
        }
        Ok(())
    });
}
