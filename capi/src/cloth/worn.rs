//! A cloth worn by an animated character: vertices pinned to bones and colliders carried by
//! bones, updated from the character's pose before each cloth step (the first place the two
//! halves of slod, cloth and crowd, meet).
//!
//! Each frame the host advances the crowd, then [`BoneAttachments::apply`] reads the
//! character's bone model matrices (skeleton model space, placed by the character's world
//! transform: position, rotation and scale, [`Crowd::world_transform`]) and
//! moves every pinned vertex's anchor and every attached collider there; the cloth's next step
//! carries them along over its substeps (kinematic anchors and kinematic colliders, whose
//! motion friction sees). Offsets are in the bone's frame, so they follow its rotation and the
//! rig's scale; collider dimensions stay in world metres.

use animlod::{BoneId, CharacterId, Crowd};
use glam::{Affine3A, Mat4, Quat, Vec3};
use softbody::{ColliderId, Transform};

use super::adaptive::AdaptiveCloth;
use super::error::ClothError;

/// A finest vertex held at a point fixed in a bone's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct BonePin {
    vertex: u32,
    bone: BoneId,
    offset: Vec3,
}

/// A collider placed at a transform fixed in a bone's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct BoneCollider {
    collider: ColliderId,
    bone: BoneId,
    local: Transform,
}

/// The pins and colliders that tie a cloth to one character's bones.
#[derive(Clone, Debug, Default)]
pub struct BoneAttachments {
    pins: Vec<BonePin>,
    colliders: Vec<BoneCollider>,
}

fn check_bone(bone: BoneId, bones: usize) -> Result<(), ClothError> {
    if bone.index() < bones {
        Ok(())
    } else {
        Err(ClothError::Crowd(animlod::CrowdError::UnknownBone(bone)))
    }
}

/// A character's pose as attachments need it: its bones' model matrices and its world
/// transform (model space → world).
struct Pose<'a> {
    models: &'a [Mat4],
    world: Affine3A,
    /// The world transform's rotation.
    turn: Quat,
}

impl<'a> Pose<'a> {
    fn of(crowd: &'a Crowd, character: CharacterId) -> Result<Pose<'a>, ClothError> {
        let models = crowd.model_matrices(character)?;
        let world = crowd.world_transform(character)?;
        let (_, turn, _) = world.to_scale_rotation_translation();
        Ok(Pose {
            models,
            world,
            turn,
        })
    }

    /// World position of a point fixed in `bone`'s frame.
    fn point(&self, bone: BoneId, offset: Vec3) -> Vec3 {
        self.world
            .transform_point3(self.models[bone.index()].transform_point3(offset))
    }

    /// World placement of a frame fixed in `bone`'s frame.
    fn frame(&self, bone: BoneId, local: &Transform) -> Transform {
        let (_, rotation, _) = self.models[bone.index()].to_scale_rotation_translation();
        Transform {
            position: self.point(bone, local.position),
            rotation: (self.turn * rotation * local.rotation).normalize(),
        }
    }
}

impl BoneAttachments {
    /// No attachments.
    pub fn new() -> Self {
        Self::default()
    }

    /// Pins finest vertex `vertex` of `cloth` at `offset` in the frame of `bone` of a skeleton
    /// with `bones` bones (or moves an existing pin). Refused, with nothing changed, for a vertex
    /// outside the cloth, a bone the skeleton lacks, or a non-finite offset.
    pub fn pin_vertex(
        &mut self,
        cloth: &AdaptiveCloth,
        bones: usize,
        vertex: u32,
        bone: BoneId,
        offset: Vec3,
    ) -> Result<(), ClothError> {
        let count = cloth.hierarchy().vertex_count();
        if vertex as usize >= count {
            return Err(ClothError::Body(softbody::TreeCutError::VertexOutOfRange {
                vertex,
                count,
            }));
        }
        check_bone(bone, bones)?;
        if !offset.is_finite() {
            return Err(ClothError::Collider(softbody::SoftBodyError::NotFinite {
                what: "pin offset",
            }));
        }
        let pin = BonePin {
            vertex,
            bone,
            offset,
        };
        match self.pins.iter_mut().find(|p| p.vertex == vertex) {
            Some(p) => *p = pin,
            None => self.pins.push(pin),
        }
        Ok(())
    }

    /// Attaches a collider of `cloth` to `bone` at `local` in the bone's frame (or moves an
    /// existing attachment). Refused, with nothing changed, for a stale collider, a bone the
    /// skeleton lacks, or an invalid transform.
    pub fn attach_collider(
        &mut self,
        cloth: &AdaptiveCloth,
        bones: usize,
        collider: ColliderId,
        bone: BoneId,
        local: Transform,
    ) -> Result<(), ClothError> {
        if cloth.colliders().get(collider).is_none() {
            return Err(ClothError::Collider(softbody::SoftBodyError::StaleCollider));
        }
        check_bone(bone, bones)?;
        if !(local.position.is_finite()
            && local.rotation.is_finite()
            && (local.rotation.length() - 1.0).abs() < 1e-3)
        {
            return Err(ClothError::Collider(softbody::SoftBodyError::BadCollider(
                "bone-local transform must be finite with a unit rotation",
            )));
        }
        let a = BoneCollider {
            collider,
            bone,
            local,
        };
        match self.colliders.iter_mut().find(|c| c.collider == collider) {
            Some(c) => *c = a,
            None => self.colliders.push(a),
        }
        Ok(())
    }

    /// Forgets a collider's attachment (the collider stays where it is).
    pub fn detach_collider(&mut self, collider: ColliderId) {
        self.colliders.retain(|c| c.collider != collider);
    }

    /// Forgets a vertex's pin to a bone (the cloth keeps the pin where it is until unpinned).
    pub fn unpin_vertex(&mut self, vertex: u32) {
        self.pins.retain(|p| p.vertex != vertex);
    }

    /// Number of pinned vertices and attached colliders.
    pub fn counts(&self) -> (usize, usize) {
        (self.pins.len(), self.colliders.len())
    }

    /// Moves every pin anchor and attached collider to where `character`'s bones are now.
    /// Everything is checked before anything moves: a stale character, a removed collider or a
    /// bone the rig lacks is refused with the cloth unchanged.
    pub fn apply(
        &self,
        cloth: &mut AdaptiveCloth,
        crowd: &Crowd,
        character: CharacterId,
    ) -> Result<(), ClothError> {
        let pose = Pose::of(crowd, character)?;
        for p in &self.pins {
            check_bone(p.bone, pose.models.len())?;
        }
        for c in &self.colliders {
            check_bone(c.bone, pose.models.len())?;
            if cloth.colliders().get(c.collider).is_none() {
                return Err(ClothError::Collider(softbody::SoftBodyError::StaleCollider));
            }
        }
        for p in &self.pins {
            cloth
                .body_mut()
                .pin_vertex(p.vertex, pose.point(p.bone, p.offset))?;
        }
        for c in &self.colliders {
            cloth.set_collider_transform(c.collider, pose.frame(c.bone, &c.local))?;
        }
        Ok(())
    }

    /// Places every attached collider where its bone is now without motion (for the first
    /// frame, so colliders do not sweep from the origin).
    pub fn teleport_colliders(
        &self,
        cloth: &mut AdaptiveCloth,
        crowd: &Crowd,
        character: CharacterId,
    ) -> Result<(), ClothError> {
        let pose = Pose::of(crowd, character)?;
        for c in &self.colliders {
            check_bone(c.bone, pose.models.len())?;
        }
        for c in &self.colliders {
            cloth
                .body_mut()
                .colliders_mut()
                .teleport(c.collider, pose.frame(c.bone, &c.local))?;
        }
        Ok(())
    }
}
