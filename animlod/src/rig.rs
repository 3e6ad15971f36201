//! A rig: one skeleton, its clips, skins and the clips' priority tables — everything characters
//! share. Plain runtime data, made by the build step ([`crate::build`]: from glTF or from parts
//! built in code), then wrapped in an `Arc` and shared by any number of crowds.

use glam::{Mat4, Vec3};

use crate::build::ImportReport;
use crate::clip::Clip;
use crate::error::BuildError;
use crate::ids::{BoneId, ClipId, SkinId};
use crate::mesh::SkinnedMesh;
use crate::priority::SubPriorities;
use crate::skeleton::Skeleton;

/// A skin: the joints a mesh is bound to and their inverse bind matrices. Several skins may share
/// joints (one per mesh of a character).
#[derive(Clone, Debug, PartialEq)]
pub struct Skin {
    /// Name (glTF skin name, or `skin<i>`).
    pub name: String,
    /// Joint bones, in the order the mesh's joint indices refer to.
    pub joints: Vec<BoneId>,
    /// One inverse bind matrix per joint.
    pub inverse_bind: Vec<Mat4>,
}

/// A skeleton with its clips, skins, skinned meshes and one priority table per clip.
#[derive(Clone, Debug)]
pub struct Rig {
    pub(crate) skeleton: Skeleton,
    pub(crate) clips: Vec<Clip>,
    pub(crate) skins: Vec<Skin>,
    pub(crate) priorities: Vec<SubPriorities>,
    pub(crate) meshes: Vec<SkinnedMesh>,
    pub(crate) bounds_center: Vec3,
    pub(crate) bounds_radius: f32,
    pub(crate) report: ImportReport,
}

impl Rig {
    /// Checks that the parts fit together: every clip built for this skeleton, every skin naming
    /// existing bones with one finite inverse bind matrix each, one priority table per clip.
    pub(crate) fn check_parts(
        skeleton: &Skeleton,
        clips: &[Clip],
        skins: &[Skin],
    ) -> Result<(), BuildError> {
        let n = skeleton.len();
        for clip in clips {
            if clip.base_pose().len() != n {
                return Err(BuildError::UnknownBone {
                    bone: BoneId::new(clip.base_pose().len()),
                    bones: n,
                });
            }
        }
        for skin in skins {
            if let Some(&bone) = skin.joints.iter().find(|j| j.index() >= n) {
                return Err(BuildError::UnknownBone { bone, bones: n });
            }
            if skin.inverse_bind.len() != skin.joints.len()
                || skin.inverse_bind.iter().any(|m| !m.is_finite())
            {
                return Err(BuildError::NonFinite {
                    what: format!("inverse bind matrices of skin {:?}", skin.name),
                });
            }
        }
        Ok(())
    }

    /// Replaces what [`Rig::import_report`] says (for a rig derived from an imported one, which
    /// keeps its source's report).
    pub fn set_import_report(&mut self, report: ImportReport) {
        self.report = report;
    }

    /// What the importer skipped (zero for rigs built in code).
    pub fn import_report(&self) -> &ImportReport {
        &self.report
    }

    /// The skeleton.
    pub fn skeleton(&self) -> &Skeleton {
        &self.skeleton
    }

    /// Number of bones.
    pub fn bone_count(&self) -> usize {
        self.skeleton.len()
    }

    /// All clips, in file order.
    pub fn clips(&self) -> &[Clip] {
        &self.clips
    }

    /// One clip.
    pub fn clip(&self, id: ClipId) -> Option<&Clip> {
        self.clips.get(id.index())
    }

    /// The priority table of a clip (computed by the build step).
    #[cfg(test)]
    pub(crate) fn priorities(&self, id: ClipId) -> Option<&SubPriorities> {
        self.priorities.get(id.index())
    }

    /// The first clip with this name.
    pub fn clip_by_name(&self, name: &str) -> Option<ClipId> {
        self.clips
            .iter()
            .position(|c| c.name() == name)
            .map(ClipId::new)
    }

    /// The skinned meshes (from glTF: every node with a mesh and a skin), for CPU skinning
    /// ([`crate::SkinningJob`] with a palette from [`crate::Crowd::skinning_matrices`]).
    pub fn meshes(&self) -> &[SkinnedMesh] {
        &self.meshes
    }

    /// All skins.
    pub fn skins(&self) -> &[Skin] {
        &self.skins
    }

    /// One skin.
    pub fn skin(&self, id: SkinId) -> Option<&Skin> {
        self.skins.get(id.index())
    }

    /// A sphere (model space: centre, radius) holding the characters: by default every joint
    /// and joint tip in the rest pose and in the first pose of every clip (see
    /// [`Rig::set_bounds`]). The crowd measures distance to its centre and projects its radius.
    pub fn bounds(&self) -> (Vec3, f32) {
        (self.bounds_center, self.bounds_radius)
    }

    /// Replaces the bounds (for a host that knows its mesh's extent, e.g. from the skinned
    /// vertices). Refused, changing nothing, unless the centre is finite and the radius finite
    /// and positive.
    pub fn set_bounds(&mut self, center: Vec3, radius: f32) -> Result<(), BuildError> {
        if !(center.is_finite() && radius.is_finite() && radius > 0.0) {
            return Err(BuildError::NonFinite {
                what: format!("bounds (centre {center}, radius {radius}): need finite, radius > 0"),
            });
        }
        self.bounds_center = center;
        self.bounds_radius = radius;
        Ok(())
    }
}
