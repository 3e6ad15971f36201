//! CPU skinning with held joints over the C ABI (`animlod::SkinHoldJob`): a host-owned object
//! per character and mesh keeps the held palette and the skinned output; each frame it skins
//! again only the vertices of joints that moved past an on-screen bound at those vertices.

use std::sync::Arc;

use animlod::{HeldSkin, Rig, SkinHoldJob, SkinHoldLayout};
use glam::{Mat4, Vec3};

use super::boundary::{arg, arg_mut, boundary, copy_out_map, write_out};
use super::character::character_ref;
use super::cloth::in_range;
use super::crowd::crowd_error;
use super::ids::SlodCharacterId;
use super::result::{FfiError, SlodResult};
use super::world::SlodWorld;

/// One character mesh's skinning with held joints: the layout of the mesh, the held palette,
/// and the skinned positions and normals. Opaque to C; created by `slod_held_skin_create`,
/// freed by `slod_held_skin_destroy`.
#[derive(Debug)]
pub struct SlodHeldSkin {
    rig: Arc<Rig>,
    mesh: usize,
    layout: SkinHoldLayout,
    state: HeldSkin,
    palette: Vec<Mat4>,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
}

/// Writes the pixels per model unit at the nearest visible point of a character's bounds in the
/// last advance (0 when it was out of view): a bound in pixels over it is a bound in model
/// units anywhere on the character.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_pixels_per_unit` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_character_pixels_per_unit(
    world: *const SlodWorld,
    character: SlodCharacterId,
    out_pixels_per_unit: *mut f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let (c, cid) = character_ref(world, character)?;
        let ppu = c.pixels_per_unit(cid).map_err(crowd_error)?;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_pixels_per_unit, ppu, "out_pixels_per_unit") }
    })
}

/// Creates the held skinning of mesh `mesh` of a character's rig and writes its owning pointer
/// to `*out_held`. Its first `slod_held_skin_update` skins every vertex.
///
/// Ownership: the host owns the object and frees it with `slod_held_skin_destroy` (it keeps
/// its own reference to the rig, so it outlives the world's rig). It may be used with any
/// character of the same rig. Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`,
/// `SLOD_RESULT_INVALID_ARGUMENT` for a mesh index out of range (`slod_rig_mesh_count`).
///
/// # Safety
/// `world` NULL or a live world; `out_held` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_held_skin_create(
    world: *const SlodWorld,
    character: SlodCharacterId,
    mesh: u32,
    out_held: *mut *mut SlodHeldSkin,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        if out_held.is_null() {
            return Err(FfiError::Null("out_held"));
        }
        let (c, _) = character_ref(world, character)?;
        let rig = c.rig().clone();
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
        let layout = SkinHoldLayout::new(m, joints).map_err(crowd_error)?;
        let n = m.vertex_count();
        let held = Box::new(SlodHeldSkin {
            state: HeldSkin::new(&layout),
            layout,
            mesh: mesh as usize,
            palette: vec![Mat4::IDENTITY; joints],
            positions: vec![Vec3::ZERO; n],
            normals: vec![Vec3::ZERO; n],
            rig,
        });
        // SAFETY: `out_held` checked non-NULL; validity per caller contract.
        unsafe { write_out(out_held, Box::into_raw(held), "out_held") }
    })
}

/// Skins a character's mesh with held joints: with this frame's exact palette of the character
/// (its pose after the last advance), every joint whose held matrix moves some vertex of it
/// more than `max_error_px` pixels (over `slod_character_pixels_per_unit`; a character out of
/// view holds everything) is refreshed, and the vertices of those joints are skinned again.
/// Every vertex then lies within `max_error_px` of exact skinning. Writes how many vertices
/// were skinned to `*out_skinned` (0: the output from the last call stands, no copy needed).
///
/// Threads: reads the world; mutates `held` only (distinct objects may be updated on distinct
/// threads). Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT` for a character of
/// another rig or a bound not finite or outside [0, 1e4] (nothing changed).
///
/// # Safety
/// `world` NULL or a live world; `held` NULL or a live object from `slod_held_skin_create`
/// used by this thread only; `out_skinned` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_held_skin_update(
    world: *const SlodWorld,
    character: SlodCharacterId,
    held: *mut SlodHeldSkin,
    max_error_px: f32,
    out_skinned: *mut usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        // SAFETY: caller contract: NULL or a live object used by this thread only.
        let h = unsafe { arg_mut(held, "held") }?;
        if out_skinned.is_null() {
            return Err(FfiError::Null("out_skinned"));
        }
        in_range(max_error_px, 0.0, 1.0e4, "max_error_px")?;
        let (c, cid) = character_ref(world, character)?;
        if !Arc::ptr_eq(c.rig(), &h.rig) {
            return Err(FfiError::invalid(
                "character",
                "its rig is not the one the held skin was made for",
            ));
        }
        let m = &h.rig.meshes()[h.mesh];
        c.skinning_matrices(cid, m.skin, &mut h.palette)
            .map_err(crowd_error)?;
        let ppu = c.pixels_per_unit(cid).map_err(crowd_error)?;
        let tolerance = if ppu > 0.0 {
            max_error_px / ppu
        } else {
            f32::INFINITY
        };
        let st = SkinHoldJob {
            mesh: m,
            layout: &h.layout,
            palette: &h.palette,
            tolerance,
            predict: false,
            state: &mut h.state,
            positions: &mut h.positions,
            normals: &mut h.normals,
        }
        .run()
        .map_err(crowd_error)?;
        // SAFETY: checked non-NULL above; validity per caller contract.
        unsafe { write_out(out_skinned, st.vertices_skinned as usize, "out_skinned") }
    })
}

/// Copies a held skin's output positions and normals (3 floats each, x, y, z; skeleton model
/// space) as of its last update.
///
/// Buffer: copy-out counted in vertices, both buffers `cap` long (call with `cap` 0 to size
/// them); nothing is written unless both fit. Threads: reads `held` only. Errors:
/// `SLOD_RESULT_BUFFER_TOO_SMALL`.
///
/// # Safety
/// `held` NULL or a live object; `positions` and `normals` valid for `3 × cap` float writes
/// each (NULL if `cap` is 0); `out_len` valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_held_skin_vertices(
    held: *const SlodHeldSkin,
    positions: *mut f32,
    normals: *mut f32,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live object.
        let h = unsafe { arg(held, "held") }?;
        // SAFETY: forwarded caller contract.
        unsafe { copy_out_vertices(&h.positions, &h.normals, positions, normals, cap, out_len) }
    })
}

/// Copies skinned positions and normals out as 3 floats each, both buffers `cap` vertices long
/// (the copy-out rule of the header: `cap` 0 with NULL buffers sizes them; nothing is written
/// unless both fit).
///
/// # Safety
/// `positions` and `normals` valid for `3 × cap` float writes each (NULL if `cap` is 0);
/// `out_len` NULL or valid for a write.
pub(super) unsafe fn copy_out_vertices(
    p: &[Vec3],
    n: &[Vec3],
    positions: *mut f32,
    normals: *mut f32,
    cap: usize,
    out_len: *mut usize,
) -> Result<(), FfiError> {
    // `[f32; 3]` has the size of 3 floats and the alignment of one: `3 × cap` floats are `cap`
    // triples.
    let (positions, normals) = (positions.cast::<[f32; 3]>(), normals.cast::<[f32; 3]>());
    if !positions.is_null() && normals.is_null() {
        return Err(FfiError::Null("normals"));
    }
    if !positions.is_null() && cap < p.len() {
        return Err(FfiError::BufferTooSmall {
            arg: "positions",
            cap,
            needed: p.len(),
        });
    }
    if !normals.is_null() {
        // SAFETY: caller contract: `normals` valid for `cap` >= n writes (checked above).
        unsafe { copy_out_map(n, Vec3::to_array, normals, cap, out_len, "normals") }?;
    }
    // SAFETY: caller contract: `positions` valid for `cap` writes (or NULL with cap 0),
    // `out_len` for one.
    unsafe { copy_out_map(p, Vec3::to_array, positions, cap, out_len, "positions") }
}

/// Frees a held skin. NULL is accepted and ignored.
///
/// # Safety
/// `held` NULL or a pointer from `slod_held_skin_create` not yet destroyed, used by no other
/// thread.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_held_skin_destroy(held: *mut SlodHeldSkin) {
    let _ = boundary(|| {
        if !held.is_null() {
            // SAFETY: per the contract, `held` came from `Box::into_raw` in
            // `slod_held_skin_create` and is freed only once.
            drop(unsafe { Box::from_raw(held) });
        }
        Ok(())
    });
}

#[cfg(test)]
mod tests {
    //! Held skinning through the C ABI on a real rig: within the bound of exact skinning, and
    //! bad input refused with nothing changed.
    use super::super::*;
    use std::ptr::{null, null_mut};

    #[test]
    fn held_skin_tracks_exact_skinning_within_the_bound() {
        let bytes = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../assets/gltf/GDQuest_GDBot.glb"
        ))
        .unwrap();
        let mut world = null_mut();
        let (mut rig, mut crowd, mut id) = (
            SlodRigId::default(),
            SlodCrowdId::default(),
            SlodCharacterId::default(),
        );
        let mut held: *mut SlodHeldSkin = null_mut();
        // SAFETY: a live world and valid out pointers throughout; every buffer is valid for the
        // length passed.
        unsafe {
            assert_eq!(
                slod_world_create(&slod_default_world_desc(), &mut world),
                SlodResult::Ok
            );
            assert_eq!(
                slod_rig_load_memory(world, bytes.as_ptr(), bytes.len(), &mut rig),
                SlodResult::Ok
            );
            assert_eq!(
                slod_crowd_create(world, rig, &slod_default_crowd_desc(), &mut crowd),
                SlodResult::Ok
            );
            let mut desc = slod_default_character_desc();
            desc.position = [0.0, 0.0, -8.0];
            assert_eq!(
                slod_character_create(world, crowd, &desc, &mut id),
                SlodResult::Ok
            );
            assert_eq!(
                slod_held_skin_create(world, id, 99, &mut held),
                SlodResult::InvalidArgument
            );
            assert_eq!(
                slod_held_skin_create(world, id, 0, &mut held),
                SlodResult::Ok
            );
            let mut n = 0usize;
            assert_eq!(
                slod_held_skin_vertices(held, null_mut(), null_mut(), 0, &mut n),
                SlodResult::Ok
            );
            assert!(n > 0);
            let (mut p, mut q) = (vec![0f32; 3 * n], vec![0f32; 3 * n]);
            let (mut e, mut f) = (vec![0f32; 3 * n], vec![0f32; 3 * n]);
            let (mut skinned, mut total, mut ppu) = (0usize, 0usize, 0.0f32);
            let mut stats = SlodCrowdStats::default();
            for frame in 0..30 {
                assert_eq!(
                    slod_crowd_advance(world, crowd, 1.0 / 60.0, &mut stats),
                    SlodResult::Ok
                );
                assert_eq!(
                    slod_held_skin_update(world, id, held, 1.0, &mut skinned),
                    SlodResult::Ok
                );
                if frame == 0 {
                    assert_eq!(skinned, n);
                }
                total += skinned;
                let mut got = 0usize;
                assert_eq!(
                    slod_held_skin_vertices(held, p.as_mut_ptr(), q.as_mut_ptr(), n, &mut got),
                    SlodResult::Ok
                );
                assert_eq!(
                    slod_character_skinned_vertices(
                        world,
                        id,
                        0,
                        e.as_mut_ptr(),
                        f.as_mut_ptr(),
                        n,
                        &mut got
                    ),
                    SlodResult::Ok
                );
                assert_eq!(
                    slod_character_pixels_per_unit(world, id, &mut ppu),
                    SlodResult::Ok
                );
                assert!(ppu > 0.0);
                let worst = p
                    .chunks(3)
                    .zip(e.chunks(3))
                    .map(|(a, b)| glam::Vec3::from_slice(a).distance(glam::Vec3::from_slice(b)))
                    .fold(0.0f32, f32::max);
                assert!(worst * ppu <= 1.0001, "frame {frame}: {} px", worst * ppu);
            }
            assert!(total < 30 * n, "{total}");
            // Bad input: refused, and the output stands.
            let before = p.clone();
            for bad in [f32::NAN, -1.0] {
                assert_eq!(
                    slod_held_skin_update(world, id, held, bad, &mut skinned),
                    SlodResult::InvalidArgument
                );
            }
            assert_eq!(
                slod_held_skin_update(world, id, null_mut(), 1.0, &mut skinned),
                SlodResult::NullArgument
            );
            let mut got = 0usize;
            assert_eq!(
                slod_held_skin_vertices(held, p.as_mut_ptr(), q.as_mut_ptr(), n - 1, &mut got),
                SlodResult::BufferTooSmall
            );
            assert_eq!(
                slod_held_skin_vertices(held, p.as_mut_ptr(), q.as_mut_ptr(), n, &mut got),
                SlodResult::Ok
            );
            assert_eq!(p, before);
            assert_eq!(
                slod_held_skin_vertices(null(), p.as_mut_ptr(), q.as_mut_ptr(), n, &mut got),
                SlodResult::NullArgument
            );
            slod_held_skin_destroy(held);
            slod_held_skin_destroy(null_mut());
            slod_world_destroy(world);
        }
    }
}
