//! Shared poses over the C ABI (`animlod::PoseShare`): characters far enough away show the
//! skinned pose of their clip's phase bucket, skinned once for every character that shares it
//! and kept across frames, within an on-screen bound at every vertex.
//!
//! A frame: advance the crowd; for every character, `slod_pose_share_request` (its candidate
//! bucket, or none when it is too near); `slod_pose_share_prepare` over all candidates (keeps
//! those worth sharing, skins the missing poses); draw a shared character with
//! `slod_pose_share_vertices` of its pose and mark it with `slod_character_set_pose_shared`
//! (the crowd then skips its pose), and skin the others as usual (e.g. with a held skin).

use std::sync::Arc;

use animlod::{ClipId, PoseShare, Rig, SharedPose};

use super::boundary::{arg, arg_mut, boundary, slice, write_out};
use super::character::{character_mut, character_ref};
use super::cloth::in_range;
use super::crowd::crowd_error;
use super::held_skin::copy_out_vertices;
use super::ids::SlodCharacterId;
use super::result::{FfiError, SlodResult};
use super::world::SlodWorld;

/// A rig's shared poses: each bucket's measured deviation and the skinned poses kept. Opaque to
/// C; created by `slod_pose_share_create`, freed by `slod_pose_share_destroy`.
#[derive(Debug)]
pub struct SlodPoseShare {
    share: PoseShare,
}

/// One phase bucket of one clip (`level`: the clip is cut into `2^level` buckets; `bucket`:
/// the index from the clip's start). Plain data, written by `slod_pose_share_request`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlodSharedPose {
    /// The clip's index in its rig.
    pub clip: u32,
    /// Bucket level (0 to 9).
    pub level: u32,
    /// Bucket index at that level.
    pub bucket: u32,
}

/// What one `slod_pose_share_prepare` did.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlodPoseShareStats {
    /// Candidates dropped as not worth sharing (their characters are skinned on their own).
    pub candidates_dropped: u32,
    /// Distinct poses shown this frame.
    pub poses_used: u32,
    /// Of those, poses skinned this frame (the others were kept from earlier frames).
    pub poses_skinned: u32,
    /// Poses dropped to stay within the capacity, least recently used first.
    pub poses_evicted: u32,
    /// Vertices skinned for the poses skinned.
    pub vertices_skinned: u64,
}

impl SlodSharedPose {
    fn to_rust(self) -> Result<SharedPose, FfiError> {
        let level = u8::try_from(self.level)
            .ok()
            .filter(|&l| l <= animlod::MAX_LEVEL)
            .ok_or_else(|| FfiError::invalid("pose", "level past the finest (9)"))?;
        Ok(SharedPose {
            clip: ClipId::new(self.clip as usize),
            level,
            bucket: self.bucket,
        })
    }
}

/// Creates the shared poses of a character's rig (measuring every clip's buckets on the calling
/// thread: 0.03-0.5 s per rig), keeping at most `capacity` skinned poses across frames
/// (`slod_pose_share_bytes_per_pose` each), and writes its owning pointer to `*out_share`.
///
/// Ownership: the host owns the object and frees it with `slod_pose_share_destroy` (it keeps
/// its own reference to the rig). Threads: reads the world only. Errors:
/// `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT` for a capacity of 0 or a rig without
/// a skinned mesh.
///
/// # Safety
/// `world` NULL or a live world; `out_share` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_pose_share_create(
    world: *const SlodWorld,
    character: SlodCharacterId,
    capacity: usize,
    out_share: *mut *mut SlodPoseShare,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        if out_share.is_null() {
            return Err(FfiError::Null("out_share"));
        }
        let (c, _) = character_ref(world, character)?;
        let rig: Arc<Rig> = c.rig().clone();
        let share = PoseShare::new(rig, capacity, false).map_err(crowd_error)?;
        let boxed = Box::new(SlodPoseShare { share });
        // SAFETY: `out_share` checked non-NULL; validity per caller contract.
        unsafe { write_out(out_share, Box::into_raw(boxed), "out_share") }
    })
}

/// Writes the bytes one kept pose takes (positions and normals of every mesh) to
/// `*out_bytes`, to size the capacity from a memory budget.
///
/// Threads: reads `share` only.
///
/// # Safety
/// `share` NULL or a live object; `out_bytes` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_pose_share_bytes_per_pose(
    share: *const SlodPoseShare,
    out_bytes: *mut usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live object.
        let s = unsafe { arg(share, "share") }?;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_bytes, s.share.bytes_per_pose(), "out_bytes") }
    })
}

/// Writes the coarsest bucket a character (after the last advance: its clip, time and pixels
/// per unit) may share with every vertex within `max_error_px` pixels of its exact position to
/// `*out_pose`, and whether there is one to `*out_shared` (false: too near; `*out_pose` is then
/// left alone).
///
/// Threads: reads the world and `share`. Errors: `SLOD_RESULT_STALE_ID`,
/// `SLOD_RESULT_INVALID_ARGUMENT` for a character of another rig or a bound not finite or
/// outside [0, 1e4].
///
/// # Safety
/// `world` NULL or a live world; `share` NULL or a live object; `out_pose` and `out_shared`
/// NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_pose_share_request(
    world: *const SlodWorld,
    character: SlodCharacterId,
    share: *const SlodPoseShare,
    max_error_px: f32,
    out_pose: *mut SlodSharedPose,
    out_shared: *mut bool,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        // SAFETY: caller contract: NULL or a live object.
        let s = unsafe { arg(share, "share") }?;
        if out_pose.is_null() {
            return Err(FfiError::Null("out_pose"));
        }
        if out_shared.is_null() {
            return Err(FfiError::Null("out_shared"));
        }
        in_range(max_error_px, 0.0, 1.0e4, "max_error_px")?;
        let (c, cid) = character_ref(world, character)?;
        if !Arc::ptr_eq(c.rig(), s.share.rig()) {
            return Err(FfiError::invalid(
                "character",
                "its rig is not the one the shared poses were made for",
            ));
        }
        let ppu = c.pixels_per_unit(cid).map_err(crowd_error)?;
        let tolerance = if ppu > 0.0 {
            max_error_px / ppu
        } else {
            f32::INFINITY
        };
        let clip = c.clip(cid).map_err(crowd_error)?;
        let time = c.time(cid).map_err(crowd_error)?;
        let pose = s
            .share
            .pose_for(clip, time, tolerance)
            .map_err(crowd_error)?;
        if let Some(p) = pose {
            let p = SlodSharedPose {
                clip: p.clip.index() as u32,
                level: u32::from(p.level),
                bucket: p.bucket,
            };
            // SAFETY: checked non-NULL above; validity per caller contract.
            unsafe { write_out(out_pose, p, "out_pose") }?;
        }
        // SAFETY: checked non-NULL above; validity per caller contract.
        unsafe { write_out(out_shared, pose.is_some(), "out_shared") }
    })
}

/// Prepares a frame's shared poses from every character's candidate (`poses[i]` counts where
/// `shared[i]` is nonzero): keeps those worth sharing (a pose already kept, or asked for by two
/// characters or more, or any while the capacity has room), setting `shared[i]` to 0 for the
/// others, then skins the poses not kept yet (on the calling thread) and drops the least
/// recently used beyond the capacity. Writes what it did to `*out_stats` (NULL: not wanted).
///
/// Threads: mutates `share` only. Errors: `SLOD_RESULT_INVALID_ARGUMENT` for a pose the rig
/// does not have (nothing changed).
///
/// # Safety
/// `share` NULL or a live object used by this thread only; `poses` and `shared` valid for
/// `count` reads (and `shared` for `count` writes), NULL if `count` is 0; `out_stats` NULL or
/// valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_pose_share_prepare(
    share: *mut SlodPoseShare,
    poses: *const SlodSharedPose,
    shared: *mut u8,
    count: usize,
    out_stats: *mut SlodPoseShareStats,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live object used by this thread only.
        let s = unsafe { arg_mut(share, "share") }?;
        // SAFETY: caller contract: valid for `count` reads (NULL only with 0).
        let poses = unsafe { slice(poses, count, "poses") }?;
        // SAFETY: as above; `shared` is also written below, after every check.
        let flags = unsafe { slice(shared.cast_const(), count, "shared") }?;
        let mut candidates = poses
            .iter()
            .zip(flags)
            .map(|(p, &f)| {
                if f != 0 {
                    p.to_rust().map(Some)
                } else {
                    Ok(None)
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        if let Some(p) = candidates
            .iter()
            .flatten()
            .find(|&&p| s.share.deviation(p).is_none())
        {
            return Err(FfiError::invalid(
                "pose",
                format!(
                    "clip {} level {} bucket {} is not a bucket of the rig",
                    p.clip.index(),
                    p.level,
                    p.bucket
                ),
            ));
        }
        let dropped = s.share.keep_worthwhile(&mut candidates);
        let used: Vec<SharedPose> = candidates.iter().flatten().copied().collect();
        let st = s.share.prepare(&used).map_err(crowd_error)?;
        for (i, c) in candidates.iter().enumerate() {
            // SAFETY: caller contract: `shared` valid for `count` writes; i < count.
            unsafe { *shared.add(i) = u8::from(c.is_some()) };
        }
        if !out_stats.is_null() {
            let stats = SlodPoseShareStats {
                candidates_dropped: dropped as u32,
                poses_used: st.poses_used,
                poses_skinned: st.poses_skinned,
                poses_evicted: st.poses_evicted,
                vertices_skinned: st.vertices_skinned,
            };
            // SAFETY: checked non-NULL; validity per caller contract.
            unsafe { write_out(out_stats, stats, "out_stats") }?;
        }
        Ok(())
    })
}

/// Copies a prepared pose's skinned positions and normals (3 floats each, x, y, z; skeleton
/// model space; every mesh of the rig in order) as the copy-out rule of the header says.
///
/// Buffer: copy-out counted in vertices, both buffers `cap` long (call with `cap` 0 to size
/// them). Threads: reads `share` only. Errors: `SLOD_RESULT_INVALID_ARGUMENT` for a pose not
/// prepared (or dropped since), `SLOD_RESULT_BUFFER_TOO_SMALL`.
///
/// # Safety
/// `share` NULL or a live object; `positions` and `normals` valid for `3 × cap` float writes
/// each (NULL if `cap` is 0); `out_len` valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_pose_share_vertices(
    share: *const SlodPoseShare,
    pose: SlodSharedPose,
    positions: *mut f32,
    normals: *mut f32,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live object.
        let s = unsafe { arg(share, "share") }?;
        let (p, n) = s
            .share
            .skinned(pose.to_rust()?)
            .ok_or_else(|| FfiError::invalid("pose", "is not prepared (or was dropped since)"))?;
        // SAFETY: forwarded caller contract.
        unsafe { copy_out_vertices(p, n, positions, normals, cap, out_len) }
    })
}

/// Marks a character as showing a shared pose (true) or its own (false): while marked, the
/// crowd advances its clock but samples none of its bones; unmarking evaluates its pose in full
/// at once, so it can be skinned the same frame.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world used by this thread only.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_set_pose_shared(
    world: *mut SlodWorld,
    character: SlodCharacterId,
    shared: bool,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let (c, cid) = character_mut(world, character)?;
        c.set_pose_shared(cid, shared).map_err(crowd_error)
    })
}

/// Frees shared poses. NULL is accepted and ignored.
///
/// # Safety
/// `share` NULL or a pointer from `slod_pose_share_create` not yet destroyed, used by no other
/// thread.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_pose_share_destroy(share: *mut SlodPoseShare) {
    let _ = boundary(|| {
        if !share.is_null() {
            // SAFETY: per the contract, `share` came from `Box::into_raw` in
            // `slod_pose_share_create` and is freed only once.
            drop(unsafe { Box::from_raw(share) });
        }
        Ok(())
    });
}
