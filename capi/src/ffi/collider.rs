//! Colliders, wind and characters wearing cloths over the C ABI: collider create/destroy/move,
//! attaching a collider or pinning a cloth vertex to a character's bone, wind, contact
//! statistics.
//!
//! Colliders belong to a cloth (the cloth's contact pass runs over them); their ids are
//! generation-checked in a per-cloth arena with process-wide generations, so a stale id, an id of
//! another cloth or of another kind is `SLOD_RESULT_STALE_ID`. A cloth is worn by at most one
//! character: each `slod_cloth_step` first moves its bone pins and bone colliders to where that
//! character's bones are (after the host's `slod_crowd_advance`), then steps — the cloth and the
//! crowd share the world's one view and the host's one frame.

use glam::{Quat, Vec3};
use softbody::{ColliderDesc, ColliderId, Shape, Transform, WindField};

use super::arena::{Arena, RawId};
use super::boundary::{arg, arg_mut, boundary, write_out};
use super::cloth::{cloth_error, cloth_mut, in_range, position};
use super::ids::{SlodCharacterId, SlodClothId};
use super::result::{FfiError, SlodResult};
use super::world::{SLOD_DESC_GUARD, SlodWorld, check_guard};
use crate::cloth::{BoneAttachments, ClothError};

/// A collider of a cloth.
///
/// `index1` is a slot index plus one and `generation` the slot's stamp; the all-zero value is
/// the null id, never issued. Compare ids with both fields.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct SlodColliderId {
    /// Slot index plus one; 0 for the null id.
    pub index1: u32,
    /// Generation stamp of the slot when the id was issued.
    pub generation: u32,
}

impl From<RawId> for SlodColliderId {
    fn from(r: RawId) -> Self {
        SlodColliderId {
            index1: r.index1,
            generation: r.generation,
        }
    }
}

impl From<SlodColliderId> for RawId {
    fn from(id: SlodColliderId) -> Self {
        RawId {
            index1: id.index1,
            generation: id.generation,
        }
    }
}

/// A rigid placement: rotate by `rotation`, then translate by `position`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodTransform {
    /// Position (every coordinate within ±`SLOD_MAX_COORDINATE`).
    pub position: [f32; 3],
    /// Unit quaternion `x, y, z, w` (length within 1e-3 of 1).
    pub rotation: [f32; 4],
}

/// A collider's geometry (values of `SlodColliderDesc::shape`); each in its own frame.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodShape {
    /// The half-space below the plane through the origin with normal +y.
    Plane = 0,
    /// A sphere of `radius` around the origin.
    Sphere = 1,
    /// Points within `radius` of the segment from (0, −`half_length`, 0) to (0, `half_length`, 0).
    Capsule = 2,
    /// The box |x| <= `half_extents`.
    Box = 3,
}

/// A collider. Get one from `slod_default_collider_desc` and change what you need.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodColliderDesc {
    /// Set by `slod_default_collider_desc`; do not change.
    pub guard: u32,
    /// A `SlodShape` value.
    pub shape: u32,
    /// Radius of a sphere or capsule, metres, in (0, 1e4].
    pub radius: f32,
    /// Half the axis length of a capsule, metres, in [0, 1e4].
    pub half_length: f32,
    /// Half sizes of a box, metres, each in (0, 1e4].
    pub half_extents: [f32; 3],
    /// Where the collider starts.
    pub transform: SlodTransform,
    /// Distance the cloth keeps from the surface, metres, in [0, 10].
    pub thickness: f32,
    /// Coulomb friction coefficient, in [0, 100].
    pub friction: f32,
}

/// Wind on a cloth. Get one from `slod_default_wind_desc` and change what you need.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodWindDesc {
    /// Set by `slod_default_wind_desc`; do not change.
    pub guard: u32,
    /// Mean air velocity, m/s (each component in [−1e4, 1e4]).
    pub velocity: [f32; 3],
    /// Gust strength as a fraction of the mean speed (RMS), in [0, 100].
    pub gust: f32,
    /// Mean gust frequency, Hz, in (0, 1e4].
    pub gust_frequency: f32,
    /// Mean gust wavelength, metres, in (0, 1e6].
    pub gust_wavelength: f32,
    /// Seed of the gusts.
    pub seed: u64,
    /// Air density, kg/m³, in [0, 1e4].
    pub air_density: f32,
    /// Drag coefficient, in [0, 100].
    pub drag: f32,
    /// Lift coefficient, in [0, 100].
    pub lift: f32,
}

/// What a cloth's contact did in its last step.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlodContactStats {
    /// Colliders of the cloth.
    pub colliders: u32,
    /// Simulated nodes that touched a collider during the last step.
    pub touching_nodes: u32,
    /// Wall time of the last step's contact work (broad phase and projections), ms.
    pub collision_ms: f64,
}

/// The colliders and character ties of one cloth (kept in its world entry).
#[derive(Debug, Default)]
pub(crate) struct ClothContacts {
    colliders: Arena<ColliderId>,
    worn: Option<(SlodCharacterId, BoneAttachments)>,
}

impl ClothContacts {
    /// Whether the cloth is worn by a character (it then follows the character's pose each
    /// world step, after the crowds advanced).
    pub(crate) fn is_worn(&self) -> bool {
        self.worn.is_some()
    }
}

/// The default collider: a sphere of radius 0.5 m at the origin, 5 mm thickness, friction 0.3
/// (the Rust `ColliderDesc::default()`); capsule and box fields preset to half length 0.5 and
/// half extents 0.5.
///
/// Returns a value the host owns; change fields, then pass it to `slod_cloth_collider_create`.
#[unsafe(no_mangle)]
pub extern "C" fn slod_default_collider_desc() -> SlodColliderDesc {
    let d = ColliderDesc::default();
    let radius = match d.shape {
        Shape::Sphere { radius } => radius,
        _ => 0.5,
    };
    SlodColliderDesc {
        guard: SLOD_DESC_GUARD,
        shape: SlodShape::Sphere as u32,
        radius,
        half_length: 0.5,
        half_extents: [0.5; 3],
        transform: transform_out(&d.transform),
        thickness: d.thickness,
        friction: d.friction,
    }
}

/// The default wind: no mean velocity, gusts of 30% at 0.5 Hz and 4 m, air 1.2 kg/m³, drag 1,
/// lift 0.5 (the Rust `WindField::default()`).
///
/// Returns a value the host owns; change fields, then pass it to `slod_cloth_set_wind`.
#[unsafe(no_mangle)]
pub extern "C" fn slod_default_wind_desc() -> SlodWindDesc {
    let w = WindField::default();
    SlodWindDesc {
        guard: SLOD_DESC_GUARD,
        velocity: w.velocity.into(),
        gust: w.gust,
        gust_frequency: w.gust_frequency,
        gust_wavelength: w.gust_wavelength,
        seed: w.seed,
        air_density: w.air_density,
        drag: w.drag,
        lift: w.lift,
    }
}

fn transform_out(t: &Transform) -> SlodTransform {
    SlodTransform {
        position: t.position.into(),
        rotation: t.rotation.to_array(),
    }
}

impl SlodTransform {
    pub(crate) fn to_transform(self, name: &'static str) -> Result<Transform, FfiError> {
        let position = position(self.position, name)?;
        let q = Quat::from_array(self.rotation);
        if !(q.is_finite() && (q.length() - 1.0).abs() < 1e-3) {
            return Err(FfiError::invalid(
                name,
                format!(
                    "rotation {:?} is not a unit quaternion (x, y, z, w)",
                    self.rotation
                ),
            ));
        }
        Ok(Transform {
            position,
            rotation: q.normalize(),
        })
    }
}

impl SlodColliderDesc {
    pub(crate) fn to_desc(self) -> Result<ColliderDesc, FfiError> {
        check_guard(self.guard, "desc")?;
        let shape = match self.shape {
            s if s == SlodShape::Plane as u32 => Shape::Plane,
            s if s == SlodShape::Sphere as u32 => {
                in_range(self.radius, f32::MIN_POSITIVE, 1e4, "desc.radius")?;
                Shape::Sphere {
                    radius: self.radius,
                }
            }
            s if s == SlodShape::Capsule as u32 => {
                in_range(self.radius, f32::MIN_POSITIVE, 1e4, "desc.radius")?;
                in_range(self.half_length, 0.0, 1e4, "desc.half_length")?;
                Shape::Capsule {
                    radius: self.radius,
                    half_length: self.half_length,
                }
            }
            s if s == SlodShape::Box as u32 => {
                for e in self.half_extents {
                    in_range(e, f32::MIN_POSITIVE, 1e4, "desc.half_extents")?;
                }
                Shape::Box {
                    half_extents: Vec3::from(self.half_extents),
                }
            }
            s => {
                return Err(FfiError::invalid(
                    "desc.shape",
                    format!("{s} is not a SlodShape value (0..=3)"),
                ));
            }
        };
        let transform = self.transform.to_transform("desc.transform")?;
        in_range(self.thickness, 0.0, 10.0, "desc.thickness")?;
        in_range(self.friction, 0.0, 100.0, "desc.friction")?;
        let desc = ColliderDesc {
            shape,
            transform,
            thickness: self.thickness,
            friction: self.friction,
        };
        desc.validate().map_err(|e| FfiError::invalid("desc", e))?;
        Ok(desc)
    }
}

impl SlodWindDesc {
    pub(crate) fn to_field(self) -> Result<WindField, FfiError> {
        check_guard(self.guard, "desc")?;
        for v in self.velocity {
            in_range(v, -1e4, 1e4, "desc.velocity")?;
        }
        in_range(self.gust, 0.0, 100.0, "desc.gust")?;
        in_range(
            self.gust_frequency,
            f32::MIN_POSITIVE,
            1e4,
            "desc.gust_frequency",
        )?;
        in_range(
            self.gust_wavelength,
            f32::MIN_POSITIVE,
            1e6,
            "desc.gust_wavelength",
        )?;
        in_range(self.air_density, 0.0, 1e4, "desc.air_density")?;
        in_range(self.drag, 0.0, 100.0, "desc.drag")?;
        in_range(self.lift, 0.0, 100.0, "desc.lift")?;
        Ok(WindField {
            velocity: Vec3::from(self.velocity),
            gust: self.gust,
            gust_frequency: self.gust_frequency,
            gust_wavelength: self.gust_wavelength,
            seed: self.seed,
            air_density: self.air_density,
            drag: self.drag,
            lift: self.lift,
        })
    }
}

/// The crowd and in-crowd id of a live character.
fn character_of(
    world: &SlodWorld,
    id: SlodCharacterId,
) -> Result<(&animlod::Crowd, animlod::CharacterId), FfiError> {
    let (crowd, cid) = *world.characters.get(RawId::from(id), "character")?;
    let crowd = world
        .crowds
        .get(crowd, "character")
        .map_err(|_| FfiError::StaleId("character"))?;
    Ok((crowd, cid))
}

fn check_bone(crowd: &animlod::Crowd, bone: u32) -> Result<animlod::BoneId, FfiError> {
    let count = crowd.rig().bone_count();
    if (bone as usize) < count {
        Ok(animlod::BoneId::from_raw(bone))
    } else {
        Err(FfiError::invalid(
            "bone",
            format!("{bone} is not a bone of the character's rig ({count} bones)"),
        ))
    }
}

/// Moves a worn cloth's bone pins and bone colliders to its character's current pose (called
/// by `slod_cloth_step` before stepping). A stale character is `SLOD_RESULT_STALE_ID` and
/// nothing moves.
pub(crate) fn follow_character(world: &mut SlodWorld, cloth: SlodClothId) -> Result<(), FfiError> {
    let worn = world
        .cloths
        .get(RawId::from(cloth), "cloth")?
        .contacts
        .worn
        .as_ref()
        .map(|(c, _)| *c);
    let Some(who) = worn else {
        return Ok(());
    };
    let (crowd_raw, cid) = *world.characters.get(RawId::from(who), "character")?;
    let crowd = world
        .crowds
        .get(crowd_raw, "character")
        .map_err(|_| FfiError::StaleId("character"))?;
    let entry = world.cloths.get_mut(RawId::from(cloth), "cloth")?;
    if let Some((_, attachments)) = &entry.contacts.worn {
        attachments
            .apply(&mut entry.cloth, crowd, cid)
            .map_err(cloth_error)?;
    }
    Ok(())
}

/// The character a tie names must be the one the cloth is worn by (or the cloth worn by none).
fn wearer_slot(
    contacts: &mut ClothContacts,
    who: SlodCharacterId,
) -> Result<&mut BoneAttachments, FfiError> {
    match &mut contacts.worn {
        Some((c, _)) if *c != who => Err(FfiError::Refused(
            "the cloth is worn by another character: slod_cloth_detach_character first".into(),
        )),
        Some((_, a)) => Ok(a),
        slot @ None => Ok(&mut slot.insert((who, BoneAttachments::new())).1),
    }
}

fn collider_error(e: softbody::SoftBodyError) -> FfiError {
    cloth_error(ClothError::Collider(e))
}

/// Adds a collider to a cloth and writes its id.
///
/// Ownership: the cloth owns the collider; destroy it with `slod_cloth_collider_destroy`, or with
/// the cloth or world. The desc is copied. Threads: mutates the world. Errors:
/// `SLOD_RESULT_STALE_ID` for `cloth`, `SLOD_RESULT_INVALID_ARGUMENT` naming the bad desc field
/// (negative radius, NaN transform, unknown shape, missing guard); nothing is created.
///
/// # Safety
/// `world` NULL or a live world; `desc` NULL or valid; `out_collider` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_collider_create(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    desc: *const SlodColliderDesc,
    out_collider: *mut SlodColliderId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid desc.
        let desc = unsafe { arg(desc, "desc") }?.to_desc()?;
        if out_collider.is_null() {
            return Err(FfiError::Null("out_collider"));
        }
        let entry = cloth_mut(world, cloth)?;
        let id = entry.cloth.add_collider(desc).map_err(cloth_error)?;
        let c: SlodColliderId = entry.contacts.colliders.insert(id).into();
        // SAFETY: checked non-NULL; valid for a write per the caller contract.
        unsafe { write_out(out_collider, c, "out_collider") }
    })
}

/// Removes a collider (and its bone attachment, if any); its id is stale afterwards.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID` for `cloth` or `collider`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_collider_destroy(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    collider: SlodColliderId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let entry = cloth_mut(world, cloth)?;
        let id = entry
            .contacts
            .colliders
            .remove(RawId::from(collider), "collider")?;
        if let Some((_, a)) = &mut entry.contacts.worn {
            a.detach_collider(id);
        }
        entry.cloth.remove_collider(id).map_err(cloth_error)
    })
}

/// Moves a collider: during the next step it travels to `*transform` (linearly, rotation by
/// slerp) and friction sees that motion (a kinematic collider). Call once per frame.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID` for `cloth` or `collider`;
/// `SLOD_RESULT_INVALID_ARGUMENT` for a transform not finite, beyond `SLOD_MAX_COORDINATE` or
/// with a rotation that is not a unit quaternion (nothing moves).
///
/// # Safety
/// `world` NULL or a live world; `transform` NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_collider_set_transform(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    collider: SlodColliderId,
    transform: *const SlodTransform,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid transform.
        let t = unsafe { arg(transform, "transform") }?.to_transform("transform")?;
        let entry = cloth_mut(world, cloth)?;
        let id = *entry
            .contacts
            .colliders
            .get(RawId::from(collider), "collider")?;
        entry
            .cloth
            .body_mut()
            .colliders_mut()
            .set_transform(id, t)
            .map_err(collider_error)
    })
}

/// Attaches a collider to bone `bone` of `character` at `*local` in the bone's frame: from the
/// next `slod_cloth_step` on, the collider follows the bone (the cloth becomes worn by that
/// character).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID` for `cloth`, `collider` or
/// `character`; `SLOD_RESULT_INVALID_ARGUMENT` for a bone the character's rig lacks or a bad
/// transform; `SLOD_RESULT_REFUSED` if the cloth is already worn by another character. Nothing
/// changes on an error.
///
/// # Safety
/// `world` NULL or a live world; `local` NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_collider_attach_to_bone(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    collider: SlodColliderId,
    character: SlodCharacterId,
    bone: u32,
    local: *const SlodTransform,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid transform.
        let local = unsafe { arg(local, "local") }?.to_transform("local")?;
        let (crowd, _) = character_of(world, character)?;
        let bone = check_bone(crowd, bone)?;
        let bones = crowd.rig().bone_count();
        let entry = world.cloths.get_mut(RawId::from(cloth), "cloth")?;
        let id = *entry
            .contacts
            .colliders
            .get(RawId::from(collider), "collider")?;
        let cloth_ref = &entry.cloth;
        let was_worn = entry.contacts.worn.is_some();
        let slot = wearer_slot(&mut entry.contacts, character)?;
        let attached = slot.attach_collider(cloth_ref, bones, id, bone, local);
        if attached.is_err() && !was_worn {
            entry.contacts.worn = None;
        }
        attached.map_err(cloth_error)
    })
}

/// Pins finest vertex `vertex` to bone `bone` of `character`, at `(x, y, z)` in the bone's frame
/// (bone model space: offsets follow the bone's rotation): from the next `slod_cloth_step` on,
/// the vertex's anchor follows the bone (the cloth becomes worn by that character).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID` for `cloth` or `character`;
/// `SLOD_RESULT_INVALID_ARGUMENT` for a vertex out of range, a bone the rig lacks, or an offset
/// not finite or beyond `SLOD_MAX_COORDINATE`; `SLOD_RESULT_REFUSED` if the cloth is worn by
/// another character. Nothing changes on an error.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_pin_vertex_to_bone(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    vertex: u32,
    character: SlodCharacterId,
    bone: u32,
    x: f32,
    y: f32,
    z: f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let offset = position([x, y, z], "offset (x, y, z)")?;
        let (crowd, _) = character_of(world, character)?;
        let bone = check_bone(crowd, bone)?;
        let bones = crowd.rig().bone_count();
        let entry = world.cloths.get_mut(RawId::from(cloth), "cloth")?;
        let cloth_ref = &entry.cloth;
        let was_worn = entry.contacts.worn.is_some();
        let slot = wearer_slot(&mut entry.contacts, character)?;
        let pinned = slot.pin_vertex(cloth_ref, bones, vertex, bone, offset);
        if pinned.is_err() && !was_worn {
            entry.contacts.worn = None;
        }
        pinned.map_err(cloth_error)
    })
}

/// Releases every tie of a cloth to its character (bone pins stay pinned where they are,
/// colliders stay where they are); the cloth can then be worn by another character.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID` for `cloth`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_detach_character(
    world: *mut SlodWorld,
    cloth: SlodClothId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        cloth_mut(world, cloth)?.contacts.worn = None;
        Ok(())
    })
}

/// Sets the wind on a cloth (replacing any); forces are computed inside every step from the
/// nodes simulated then, per area of cloth, so they do not depend on the cut.
///
/// The desc is copied. Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID` for `cloth`;
/// `SLOD_RESULT_INVALID_ARGUMENT` naming the bad desc field (the wind is unchanged).
///
/// # Safety
/// `world` NULL or a live world; `desc` NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_set_wind(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    desc: *const SlodWindDesc,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid desc.
        let field = unsafe { arg(desc, "desc") }?.to_field()?;
        let entry = cloth_mut(world, cloth)?;
        entry.cloth.set_wind(Some(field)).map_err(cloth_error)
    })
}

/// Removes the wind from a cloth.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID` for `cloth`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_clear_wind(
    world: *mut SlodWorld,
    cloth: SlodClothId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let entry = cloth_mut(world, cloth)?;
        entry.cloth.set_wind(None).map_err(cloth_error)
    })
}

/// Writes what a cloth's contact did in its last step to `*out_stats`.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID` for `cloth`.
///
/// # Safety
/// `world` NULL or a live world; `out_stats` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_contact_stats(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out_stats: *mut SlodContactStats,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        if out_stats.is_null() {
            return Err(FfiError::Null("out_stats"));
        }
        let entry = world.cloths.get(RawId::from(cloth), "cloth")?;
        let c = &entry.cloth;
        let stats = SlodContactStats {
            colliders: c.colliders().len() as u32,
            touching_nodes: c.body().body().touched_all().iter().filter(|&&t| t).count() as u32,
            collision_ms: c.last_collision_seconds() * 1e3,
        };
        // SAFETY: checked non-NULL; valid for a write per the caller contract.
        unsafe { write_out(out_stats, stats, "out_stats") }
    })
}

/// Writes the index of the bone named `name` in `rig` to `*out_bone` (for
/// `slod_cloth_pin_vertex_to_bone` and `slod_cloth_collider_attach_to_bone`).
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`; `SLOD_RESULT_INVALID_ARGUMENT`
/// if no bone has that name or it is not UTF-8.
///
/// # Safety
/// `world` NULL or a live world; `name` NULL or NUL-terminated; `out_bone` NULL or valid for a
/// write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_rig_find_bone(
    world: *const SlodWorld,
    rig: super::ids::SlodRigId,
    name: *const std::ffi::c_char,
    out_bone: *mut u32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let r = super::rig::rig_ref(world, rig)?;
        // SAFETY: caller contract: NULL or NUL-terminated.
        let name = unsafe { super::boundary::c_str(name, "name") }?;
        let bone = r
            .skeleton()
            .find(name)
            .ok_or_else(|| FfiError::invalid("name", format!("no bone is named {name:?}")))?;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_bone, bone.index() as u32, "out_bone") }
    })
}
