//! A rig: one skeleton, its clips and skins — everything characters share. Loaded once (from
//! glTF or built in code), then wrapped in an `Arc` and shared by any number of crowds.

use std::path::Path;

use glam::{Mat4, Vec3};

use crate::clip::{Clip, Keys};
use crate::error::{BuildError, ImportError};
use crate::ids::{BoneId, ClipId, SkinId};
use crate::import::{ImportOptions, ImportReport, import};
use crate::skeleton::{BoneDesc, Skeleton};

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

/// A skeleton with its clips and skins.
#[derive(Clone, Debug)]
pub struct Rig {
    skeleton: Skeleton,
    clips: Vec<Clip>,
    skins: Vec<Skin>,
    bounds_center: Vec3,
    bounds_radius: f32,
    report: ImportReport,
}

impl Rig {
    /// Assembles a rig; the clips must have been built for this skeleton, and every skin must name
    /// existing bones with one finite inverse bind matrix each.
    pub fn new(skeleton: Skeleton, clips: Vec<Clip>, skins: Vec<Skin>) -> Result<Rig, BuildError> {
        let n = skeleton.len();
        for clip in &clips {
            if clip.base_pose().len() != n {
                return Err(BuildError::UnknownBone {
                    bone: BoneId::new(clip.base_pose().len()),
                    bones: n,
                });
            }
        }
        for skin in &skins {
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
        let (bounds_center, bounds_radius) = bounds(&skeleton, &clips);
        Ok(Rig {
            skeleton,
            clips,
            skins,
            bounds_center,
            bounds_radius,
            report: ImportReport::default(),
        })
    }

    /// Imports a .glb or .gltf held in memory. A .gltf that references buffer files needs
    /// `base_dir` (the directory of the .gltf); data URIs and .glb need nothing.
    pub fn from_gltf_slice(bytes: &[u8], base_dir: Option<&Path>) -> Result<Rig, ImportError> {
        import(bytes, base_dir, &ImportOptions::default())
    }

    /// [`Rig::from_gltf_slice`] with options.
    pub fn from_gltf_slice_with(
        bytes: &[u8],
        base_dir: Option<&Path>,
        options: &ImportOptions,
    ) -> Result<Rig, ImportError> {
        import(bytes, base_dir, options)
    }

    /// Imports a .glb or .gltf file; buffer files are looked up next to it.
    pub fn from_gltf_path(path: &Path) -> Result<Rig, ImportError> {
        Self::from_gltf_path_with(path, &ImportOptions::default())
    }

    /// [`Rig::from_gltf_path`] with options.
    pub fn from_gltf_path_with(path: &Path, options: &ImportOptions) -> Result<Rig, ImportError> {
        let bytes = std::fs::read(path).map_err(|source| ImportError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        import(&bytes, path.parent(), options)
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

    /// The first clip with this name.
    pub fn clip_by_name(&self, name: &str) -> Option<ClipId> {
        self.clips
            .iter()
            .position(|c| c.name() == name)
            .map(ClipId::new)
    }

    /// All skins.
    pub fn skins(&self) -> &[Skin] {
        &self.skins
    }

    /// One skin.
    pub fn skin(&self, id: SkinId) -> Option<&Skin> {
        self.skins.get(id.index())
    }

    /// A sphere (model space: centre, radius) holding every joint in the rest pose and in the
    /// first pose of every clip. The crowd measures distance to its centre and projects its radius.
    pub fn bounds(&self) -> (Vec3, f32) {
        (self.bounds_center, self.bounds_radius)
    }

    /// The same rig scaled uniformly by `factor` (> 0): translations, translation keys and the
    /// translation part of inverse bind matrices are multiplied by it. Used to express a real rig
    /// in the units of a scene.
    pub fn scaled(&self, factor: f32) -> Result<Rig, BuildError> {
        if !(factor.is_finite() && factor > 0.0) {
            return Err(BuildError::NonFinite {
                what: format!("scale factor {factor}"),
            });
        }
        let scale_ib = |m: Mat4| {
            let mut m = m;
            m.w_axis = (m.w_axis.truncate() * factor).extend(m.w_axis.w);
            m
        };
        let descs: Vec<BoneDesc> = self
            .skeleton
            .descs()
            .into_iter()
            .map(|mut d| {
                d.rest.translation *= factor;
                d.inverse_bind = scale_ib(d.inverse_bind);
                d
            })
            .collect();
        let skeleton = Skeleton::new(descs)?;
        let clips = self
            .clips
            .iter()
            .map(|c| {
                let channels = c
                    .channels()
                    .iter()
                    .cloned()
                    .map(|mut ch| {
                        if let Keys::Translation(v) = &mut ch.keys {
                            v.iter_mut().for_each(|x| *x *= factor);
                        }
                        ch
                    })
                    .collect();
                let mut options = *c.options();
                if options.translation_tolerance > 0.0 {
                    options.translation_tolerance *= factor;
                }
                Clip::new(c.name(), &skeleton, channels, &options)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let skins = self
            .skins
            .iter()
            .map(|s| Skin {
                inverse_bind: s.inverse_bind.iter().map(|&m| scale_ib(m)).collect(),
                ..s.clone()
            })
            .collect();
        let mut rig = Rig::new(skeleton, clips, skins)?;
        rig.report = self.report;
        Ok(rig)
    }
}

fn bounds(skeleton: &Skeleton, clips: &[Clip]) -> (Vec3, f32) {
    let joints: Vec<usize> = (0..skeleton.len())
        .filter(|&i| skeleton.is_joint(BoneId::new(i)))
        .collect();
    let mut points = Vec::new();
    let mut model = vec![Mat4::IDENTITY; skeleton.len()];
    let mut locals = skeleton.rest_locals().to_vec();
    skeleton.model_matrices(&locals, &mut model);
    points.extend(joints.iter().map(|&j| model[j].w_axis.truncate()));
    for clip in clips {
        for (l, t) in locals.iter_mut().zip(clip.sample_pose(0.0)) {
            *l = t.to_affine();
        }
        skeleton.model_matrices(&locals, &mut model);
        points.extend(joints.iter().map(|&j| model[j].w_axis.truncate()));
    }
    let (lo, hi) = points.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    if points.is_empty() {
        return (Vec3::ZERO, 0.0);
    }
    let center = (lo + hi) * 0.5;
    let radius = points
        .iter()
        .map(|p| p.distance(center))
        .fold(0.0f32, f32::max);
    (center, radius)
}
