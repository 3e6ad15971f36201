//! The build step, run once per rig before any character plays it (offline, as in
//! ozz-animation's split of offline and runtime libraries): glTF import, the per-keyframe
//! priority pass, the bounds and the weight analysis. What it produces is plain runtime data —
//! a [`Rig`] holding the skeleton, the clips, the skins and one priority table per clip — which
//! the runtime ([`crate::Crowd`]) only reads.

pub mod analysis;
mod import;
mod key_error;
mod priorities;

use std::path::Path;

use glam::{Mat4, Vec3};

use crate::clip::{Clip, Keys};
use crate::error::{BuildError, ImportError};
use crate::ids::BoneId;
use crate::mesh::SkinnedMesh;
use crate::rig::{Rig, Skin};
use crate::skeleton::{BoneDesc, Skeleton};

pub use import::{ImportOptions, ImportReport};
pub(crate) use key_error::VariationTable;
use priorities::priorities;

#[cfg(test)]
pub(crate) use import::tests;

/// Builds a rig from parts made in code (or by the importer): checks that the clips were built
/// for this skeleton and the skins name existing bones with finite inverse bind matrices, then
/// computes each clip's priority table and the rig's bounds.
pub fn rig(skeleton: Skeleton, clips: Vec<Clip>, skins: Vec<Skin>) -> Result<Rig, BuildError> {
    Rig::check_parts(&skeleton, &clips, &skins)?;
    let priorities = clips.iter().map(|c| priorities(c, &skeleton)).collect();
    let (bounds_center, bounds_radius) = bounds(&skeleton, &clips);
    Ok(Rig {
        skeleton,
        clips,
        skins,
        priorities,
        meshes: Vec::new(),
        bounds_center,
        bounds_radius,
        report: ImportReport::default(),
    })
}

/// Attaches skinned meshes to a rig (each checked against its skin's joint count) and grows the
/// rig's bounds to hold their bind-pose vertices, so a rig whose joints all sit at one point
/// takes its size from its mesh.
pub fn attach_meshes(rig: &mut Rig, meshes: Vec<SkinnedMesh>) -> Result<(), BuildError> {
    let mut checked = Vec::with_capacity(meshes.len());
    for m in meshes {
        let joints = rig
            .skins()
            .get(m.skin.index())
            .map(|s| s.joints.len())
            .ok_or_else(|| BuildError::NonFinite {
                what: format!("mesh {:?}: skin {} does not exist", m.name, m.skin.index()),
            })?;
        checked.push(m.validated(joints)?);
    }
    let (mut center, mut radius) = rig.bounds();
    for p in checked.iter().flat_map(|m| &m.positions) {
        // Grow the sphere just enough to hold p (Ritter's pass).
        let d = p.distance(center);
        if d > radius {
            let grown = 0.5 * (radius + d);
            center += (*p - center) * ((grown - radius) / d);
            radius = grown;
        }
    }
    if !(center.is_finite() && radius.is_finite()) {
        return Err(BuildError::NonFinite {
            what: "bounds grown to hold the meshes".into(),
        });
    }
    rig.bounds_center = center;
    rig.bounds_radius = radius;
    rig.meshes.extend(checked);
    Ok(())
}

/// Imports a .glb or .gltf held in memory. A .gltf that references buffer files needs
/// `base_dir` (the directory of the .gltf); data URIs and .glb need nothing.
pub fn import_slice(bytes: &[u8], base_dir: Option<&Path>) -> Result<Rig, ImportError> {
    import::import(bytes, base_dir, &ImportOptions::default())
}

/// [`import_slice`] with options.
pub fn import_slice_with(
    bytes: &[u8],
    base_dir: Option<&Path>,
    options: &ImportOptions,
) -> Result<Rig, ImportError> {
    import::import(bytes, base_dir, options)
}

/// Imports a .glb or .gltf file; buffer files are looked up next to it.
pub fn import_path(path: &Path) -> Result<Rig, ImportError> {
    import_path_with(path, &ImportOptions::default())
}

/// [`import_path`] with options.
pub fn import_path_with(path: &Path, options: &ImportOptions) -> Result<Rig, ImportError> {
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    import::import(&bytes, path.parent(), options)
}

/// The same rig scaled uniformly by `factor` (> 0): translations, translation keys and the
/// translation part of inverse bind matrices are multiplied by it, and the priority tables are
/// rebuilt. Used to express a real rig in the units of a scene.
pub fn scaled(rig: &Rig, factor: f32) -> Result<Rig, BuildError> {
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
    let descs: Vec<BoneDesc> = rig
        .skeleton()
        .descs()
        .into_iter()
        .map(|mut d| {
            d.rest.translation *= factor;
            d.inverse_bind = scale_ib(d.inverse_bind);
            d
        })
        .collect();
    let skeleton = Skeleton::new(descs)?;
    let clips = rig
        .clips()
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
    let skins = rig
        .skins()
        .iter()
        .map(|s| Skin {
            inverse_bind: s.inverse_bind.iter().map(|&m| scale_ib(m)).collect(),
            ..s.clone()
        })
        .collect();
    let mut out = self::rig(skeleton, clips, skins)?;
    out.set_import_report(*rig.import_report());
    let meshes = rig
        .meshes()
        .iter()
        .map(|m| SkinnedMesh {
            positions: m.positions.iter().map(|p| *p * factor).collect(),
            ..m.clone()
        })
        .collect();
    attach_meshes(&mut out, meshes)?;
    Ok(out)
}

/// A sphere (centre, radius) holding every joint and every joint's tip ([`Skeleton::tip`]) in
/// the rest pose and in the first pose of every clip. The tips give a rig whose joints all sit
/// at one point a radius, so its characters still have a size on screen.
fn bounds(skeleton: &Skeleton, clips: &[Clip]) -> (Vec3, f32) {
    let joints: Vec<usize> = (0..skeleton.len())
        .filter(|&i| skeleton.is_joint(BoneId::new(i)))
        .collect();
    let mut points = Vec::new();
    let mut model = vec![Mat4::IDENTITY; skeleton.len()];
    let mut locals = skeleton.rest_locals().to_vec();
    skeleton.model_matrices(&locals, &mut model);
    let tips = skeleton.tips();
    let add = |model: &[Mat4], points: &mut Vec<Vec3>| {
        for &j in &joints {
            points.push(model[j].w_axis.truncate());
            points.push(model[j].transform_point3(tips[j]));
        }
    };
    add(&model, &mut points);
    for clip in clips {
        for (l, t) in locals.iter_mut().zip(clip.sample_pose(0.0)) {
            *l = t.to_affine();
        }
        skeleton.model_matrices(&locals, &mut model);
        add(&model, &mut points);
    }
    if points.is_empty() {
        return (Vec3::ZERO, 0.0);
    }
    let (lo, hi) = points.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    let center = (lo + hi) * 0.5;
    let radius = points
        .iter()
        .map(|p| p.distance(center))
        .fold(0.0f32, f32::max);
    (center, radius)
}
