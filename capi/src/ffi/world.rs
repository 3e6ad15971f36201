//! The world: the opaque owning handle that holds every cloth, rig and character, plus version
//! queries and the desc guard.

use std::sync::Arc;

use super::arena::{Arena, RawId};
use super::boundary::{arg, boundary, write_out};
use super::result::{FfiError, SlodResult};
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
    /// Worker threads for the cloth feedback stage: 0 uses one process-wide pool sized to the
    /// machine, 1 runs everything on the calling thread (no thread is ever started), n >= 2
    /// gives this world its own pool of n threads (at most 1024), stopped and joined before
    /// `slod_world_destroy` returns.
    ///
    /// After `fork()`, only the forking thread exists in the child: worker pools (this world's
    /// and the process-wide one) do not survive it. In a child, create new worlds with
    /// `worker_threads` 1 and do not use worlds inherited from the parent.
    pub worker_threads: u32,
}

/// The default world settings (worker_threads 0: the process-wide pool).
///
/// Returns a value the host owns; change fields, then pass it to `slod_world_create`.
#[unsafe(no_mangle)]
pub extern "C" fn slod_default_world_desc() -> SlodWorldDesc {
    SlodWorldDesc {
        guard: SLOD_DESC_GUARD,
        worker_threads: 0,
    }
}

/// A cloth as the world holds it (queries keep their scratch buffers per thread, so they can
/// read a `const SlodWorld*`).
#[derive(Debug)]
pub(crate) struct ClothEntry {
    pub(crate) cloth: AdaptiveCloth,
    /// Its colliders' C ids and its ties to a character's bones.
    pub(crate) contacts: super::collider::ClothContacts,
}

/// Everything a host created: cloths, rigs, crowds and characters. Opaque to C.
///
/// Threads: a world is used from one thread at a time; functions taking `const SlodWorld*` may
/// run concurrently with each other; distinct worlds are independent.
pub struct SlodWorld {
    pub(crate) desc: SlodWorldDesc,
    /// Worker threads of this world when the desc asked for two or more (else the global pool
    /// or none).
    pub(crate) pool: Option<rayon::ThreadPool>,
    /// The pool's threads, joined when the world is dropped (after the pool), so that
    /// destroying a world leaves no thread of it running and nothing "possibly lost".
    threads: Vec<std::thread::JoinHandle<()>>,
    /// The host's camera and light: the one view every cloth step and crowd advance is given.
    pub(crate) view: salience::View,
    pub(crate) cloths: Arena<ClothEntry>,
    pub(crate) rigs: Arena<Arc<animlod::Rig>>,
    pub(crate) crowds: Arena<animlod::Crowd>,
    /// Each character's crowd and its id inside that crowd.
    pub(crate) characters: Arena<(RawId, animlod::CharacterId)>,
    /// The frame budget `slod_world_step` spends (none until `slod_world_set_budget`).
    pub(crate) budget: crate::world::FrameBudgeter,
}

impl Drop for SlodWorld {
    fn drop(&mut self) {
        // Dropping the pool tells its threads to finish their work and exit; joining them
        // makes that happen before `slod_world_destroy` returns.
        drop(self.pool.take());
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl std::fmt::Debug for SlodWorld {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SlodWorld")
            .field("desc", &self.desc)
            .field("cloths", &self.cloths.len())
            .field("rigs", &self.rigs.len())
            .field("crowds", &self.crowds.len())
            .field("characters", &self.characters.len())
            .finish_non_exhaustive()
    }
}

impl SlodWorld {
    /// Runs `f` on this world's worker threads (or the global pool / the calling thread).
    pub(crate) fn run<R: Send>(
        pool: Option<&rayon::ThreadPool>,
        f: impl FnOnce() -> R + Send,
    ) -> R {
        match pool {
            Some(p) => p.install(f),
            None => f(),
        }
    }

    /// Whether parallel work is allowed (a desc with one worker thread forbids it).
    pub(crate) fn parallel_allowed(&self) -> bool {
        self.desc.worker_threads != 1
    }
}

/// How many objects of each kind a world holds.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlodWorldCounts {
    /// Live cloths.
    pub cloths: u32,
    /// Live rigs (destroyed rigs still used by a crowd are not counted).
    pub rigs: u32,
    /// Live crowds.
    pub crowds: u32,
    /// Live characters over all crowds.
    pub characters: u32,
}

/// Writes how many cloths, rigs, crowds and characters the world holds to `*out_counts`.
///
/// Threads: reads the world only (may run concurrently with other `const SlodWorld*` calls).
///
/// # Safety
/// `world` NULL or a live world; `out_counts` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_world_counts(
    world: *const SlodWorld,
    out_counts: *mut SlodWorldCounts,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let counts = SlodWorldCounts {
            cloths: world.cloths.len() as u32,
            rigs: world.rigs.len() as u32,
            crowds: world.crowds.len() as u32,
            characters: world.characters.len() as u32,
        };
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_counts, counts, "out_counts") }
    })
}

/// Creates a world and writes its owning pointer to `*out_world`.
///
/// Ownership: the host owns the world and must destroy it with `slod_world_destroy`, which frees
/// everything created in it. The desc is copied. Threads: any thread may create worlds; a world is
/// then used from one thread at a time.
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
        let mut threads = Vec::new();
        let pool = match desc.worker_threads {
            0 | 1 => None,
            n => Some(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n as usize)
                    .thread_name(|i| format!("slod-world-{i}"))
                    .spawn_handler(|thread| {
                        let mut b = std::thread::Builder::new();
                        if let Some(name) = thread.name() {
                            b = b.name(name.to_owned());
                        }
                        threads.push(b.spawn(|| thread.run())?);
                        Ok(())
                    })
                    .build()
                    .map_err(|e| FfiError::Refused(format!("cannot start worker threads: {e}")))?,
            ),
        };
        let world = Box::new(SlodWorld {
            desc,
            pool,
            threads,
            view: salience::View::default(),
            cloths: Arena::default(),
            rigs: Arena::default(),
            crowds: Arena::default(),
            characters: Arena::default(),
            budget: crate::world::FrameBudgeter::new(crate::world::WorldBudget {
                threads: if desc.worker_threads == 1 { 1 } else { 0 },
                ..crate::world::WorldBudget::default()
            })
            .map_err(|e| FfiError::Refused(e.to_string()))?,
        });
        // SAFETY: `out_world` checked non-NULL; validity per caller contract.
        unsafe { write_out(out_world, Box::into_raw(world), "out_world") }
    })
}

/// Destroys a world and everything in it (cloths, rigs, crowds, characters, worker threads).
///
/// NULL is accepted and ignored. The pointer and every id from this world are invalid afterwards;
/// ids of this world passed to another world return `SLOD_RESULT_STALE_ID` there.
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
