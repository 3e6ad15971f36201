//! glTF 2.0 import (.gltf and .glb) of skins, the node hierarchy and animations.
//!
//! Only the document and the buffers are read (`gltf::json` for the document; buffers decoded
//! here), never images. Every index, accessor type, count and range is checked before use, and
//! the whole import runs inside `catch_unwind`, so a malformed file ends in an [`ImportError`],
//! never a panic.
//!
//! What becomes a bone: every joint of every skin and every ancestor of one (non-joint ancestors,
//! such as an armature node, carry transforms the joints inherit). Bones are ordered
//! breadth-first from the roots, so parents come first. Channels that target other nodes, or morph weights,
//! are skipped and counted in [`ImportReport`].

mod accessor;
pub(crate) mod container;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use glam::{Mat4, Quat, Vec3};
use gltf::json::Root;
use gltf::json::accessor::Type;
use gltf::json::animation::{Interpolation as GInterp, Property as GProp};
use gltf::json::validation::Checked;

use crate::clip::{ChannelDesc, Clip, ClipOptions, Interpolation, Keys};
use crate::error::ImportError;
use crate::ids::{BoneId, SkinId};
use crate::mesh::SkinnedMesh;
use crate::rig::{Rig, Skin};
use crate::skeleton::{BoneDesc, Skeleton};
use crate::transform::Transform;
use accessor::{Components, Reader};

/// Options for [`crate::build::import_slice_with`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImportOptions {
    /// How clips are built (constant-channel tolerance).
    pub clip: ClipOptions,
}

/// What the importer skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ImportReport {
    /// Channels animating morph-target weights (not part of a skeleton pose).
    pub weight_channels: u32,
    /// Channels targeting nodes that are neither joints nor ancestors of joints.
    pub non_skeleton_channels: u32,
}

/// Largest node count accepted.
const MAX_NODES: usize = 1 << 20;

/// Imports a rig, turning any panic of a dependency into [`ImportError::Panicked`].
pub(crate) fn import(
    bytes: &[u8],
    base: Option<&Path>,
    options: &ImportOptions,
) -> Result<Rig, ImportError> {
    match catch_unwind(AssertUnwindSafe(|| import_inner(bytes, base, options))) {
        Ok(r) => r,
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(ImportError::Panicked(msg))
        }
    }
}

fn import_inner(
    bytes: &[u8],
    base: Option<&Path>,
    options: &ImportOptions,
) -> Result<Rig, ImportError> {
    let (json, bin) = container::split(bytes)?;
    let value = container::prepass(json)?;
    let root: Root = serde_json::from_value(value).map_err(|e| ImportError::Json(e.to_string()))?;
    let mut reader = Reader::new(&root, bin, base);
    let (skeleton, bone_of_node, skins) = build_skeleton(&root, &mut reader)?;
    let mut report = ImportReport::default();
    let mut clips = Vec::with_capacity(root.animations.len());
    for (ai, anim) in root.animations.iter().enumerate() {
        let channels = read_channels(&root, ai, &bone_of_node, &mut reader, &mut report)?;
        let name = anim
            .name
            .clone()
            .unwrap_or_else(|| format!("animation{ai}"));
        let clip = Clip::new(name, &skeleton, channels, &options.clip).map_err(|e| {
            ImportError::Animation {
                animation: ai,
                reason: e.to_string(),
            }
        })?;
        clips.push(clip);
    }
    let skin_joints: Vec<usize> = skins.iter().map(|s| s.joints.len()).collect();
    let meshes = read_meshes(&root, &skin_joints, &mut reader)?;
    let mut rig = crate::build::rig(skeleton, clips, skins)?;
    rig.set_import_report(report);
    crate::build::attach_meshes(&mut rig, meshes)?;
    Ok(rig)
}

/// The skinned meshes: every node with both a mesh and a skin, its primitives that carry
/// `POSITION`, `JOINTS_0` and `WEIGHTS_0` concatenated (others are skipped; a primitive
/// without `NORMAL` gets +Y normals).
fn read_meshes(
    root: &Root,
    skin_joints: &[usize],
    reader: &mut Reader<'_>,
) -> Result<Vec<SkinnedMesh>, ImportError> {
    use gltf::json::mesh::Semantic;
    let mut out = Vec::new();
    for node in &root.nodes {
        let (Some(mi), Some(si)) = (node.mesh, node.skin) else {
            continue;
        };
        let (mi, si) = (mi.value(), si.value());
        let Some(mesh) = root.meshes.get(mi) else {
            return Err(hierarchy(format!("mesh {mi} does not exist")));
        };
        let Some(&joint_count) = skin_joints.get(si) else {
            return Err(ImportError::Skin {
                index: si,
                reason: "does not exist".into(),
            });
        };
        let mut m = SkinnedMesh {
            name: mesh.name.clone().unwrap_or_else(|| format!("mesh{mi}")),
            skin: SkinId::new(si),
            positions: Vec::new(),
            normals: Vec::new(),
            joints: Vec::new(),
            weights: Vec::new(),
        };
        for prim in &mesh.primitives {
            let get = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|a| a.value());
            let (Some(p), Some(j), Some(w)) = (
                get(Semantic::Positions),
                get(Semantic::Joints(0)),
                get(Semantic::Weights(0)),
            ) else {
                continue;
            };
            let p = reader.read(p, Type::Vec3, Components::Float)?;
            let n = match get(Semantic::Normals) {
                Some(n) => reader.read(n, Type::Vec3, Components::Float)?,
                // No normals (the Fox): +Y, so positions still skin.
                None => [0.0, 1.0, 0.0].repeat(p.len() / 3),
            };
            let j = reader.read(j, Type::Vec4, Components::Index)?;
            let w = reader.read(w, Type::Vec4, Components::FloatOrNormalized)?;
            let count = p.len() / 3;
            if n.len() / 3 != count || j.len() / 4 != count || w.len() / 4 != count {
                return Err(hierarchy(format!(
                    "mesh {mi}: attribute counts of a primitive differ"
                )));
            }
            m.positions
                .extend(p.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
            m.normals
                .extend(n.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
            m.joints.extend(
                j.chunks_exact(4)
                    .map(|c| [c[0], c[1], c[2], c[3]].map(|x| x as u16)),
            );
            m.weights
                .extend(w.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]));
        }
        if m.positions.is_empty() {
            continue;
        }
        let m = m
            .validated(joint_count)
            .map_err(|e| hierarchy(format!("mesh {mi}: {e}")))?;
        out.push(m);
    }
    Ok(out)
}

fn hierarchy(m: String) -> ImportError {
    ImportError::Hierarchy(m)
}

fn rest_transform(node: &gltf::json::scene::Node, index: usize) -> Result<Transform, ImportError> {
    let bad = || {
        hierarchy(format!(
            "node {index} has a non-finite or degenerate transform"
        ))
    };
    let t = if let Some(m) = node.matrix {
        let m = Mat4::from_cols_array(&m);
        if !m.is_finite() {
            return Err(bad());
        }
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        Transform {
            translation,
            rotation,
            scale,
        }
    } else {
        Transform {
            translation: node.translation.map_or(Vec3::ZERO, Vec3::from),
            rotation: node
                .rotation
                .map_or(Quat::IDENTITY, |q| Quat::from_array(q.0)),
            scale: node.scale.map_or(Vec3::ONE, Vec3::from),
        }
    };
    if !t.is_finite() || t.rotation.length() < 1e-6 {
        return Err(bad());
    }
    Ok(Transform {
        rotation: t.rotation.normalize(),
        ..t
    })
}

type SkeletonParts = (Skeleton, Vec<Option<BoneId>>, Vec<Skin>);

fn build_skeleton(root: &Root, reader: &mut Reader<'_>) -> Result<SkeletonParts, ImportError> {
    let n = root.nodes.len();
    if n > MAX_NODES {
        return Err(hierarchy(format!("{n} nodes is too many")));
    }
    if root.skins.is_empty() {
        return Err(ImportError::NoSkin);
    }
    let mut parent: Vec<Option<usize>> = vec![None; n];
    for (i, node) in root.nodes.iter().enumerate() {
        for c in node.children.iter().flatten() {
            let c = c.value();
            if c >= n {
                return Err(hierarchy(format!(
                    "node {i} lists child {c}, but there are {n} nodes"
                )));
            }
            if c == i || parent[c].is_some() {
                return Err(hierarchy(format!(
                    "node {c} has two parents or is its own child"
                )));
            }
            parent[c] = Some(i);
        }
    }
    // Joints and their ancestors; a walk longer than the node count means a cycle.
    let mut in_skeleton = vec![false; n];
    let mut is_joint = vec![false; n];
    for (si, skin) in root.skins.iter().enumerate() {
        if skin.joints.is_empty() {
            return Err(ImportError::Skin {
                index: si,
                reason: "has no joints".into(),
            });
        }
        for j in &skin.joints {
            let j = j.value();
            if j >= n {
                return Err(ImportError::Skin {
                    index: si,
                    reason: format!("joint node {j} does not exist"),
                });
            }
            is_joint[j] = true;
            let mut x = j;
            let mut steps = 0;
            loop {
                in_skeleton[x] = true;
                match parent[x] {
                    Some(p) => x = p,
                    None => break,
                }
                steps += 1;
                if steps > n {
                    return Err(hierarchy("the node graph has a cycle".into()));
                }
            }
        }
    }
    // Breadth-first from the roots: parents before children, and consecutive bones mostly
    // independent of each other, so the model-space pass is not one long dependency chain.
    let mut order: Vec<usize> = (0..n)
        .filter(|&i| in_skeleton[i] && parent[i].is_none())
        .collect();
    let mut head = 0;
    while head < order.len() {
        let x = order[head];
        head += 1;
        let children = root.nodes[x].children.iter().flatten().map(|c| c.value());
        order.extend(children.filter(|&c| in_skeleton[c]));
    }
    let mut bone_of_node: Vec<Option<BoneId>> = vec![None; n];
    for (b, &node) in order.iter().enumerate() {
        bone_of_node[node] = Some(BoneId::new(b));
    }
    let mut descs = Vec::with_capacity(order.len());
    for &node in &order {
        let nd = &root.nodes[node];
        descs.push(BoneDesc {
            name: nd.name.clone().unwrap_or_else(|| format!("node{node}")),
            parent: parent[node].and_then(|p| bone_of_node[p]),
            rest: rest_transform(nd, node)?,
            inverse_bind: Mat4::IDENTITY,
            is_joint: is_joint[node],
        });
    }
    let mut skins = Vec::with_capacity(root.skins.len());
    let mut has_bind = vec![false; order.len()];
    for (si, skin) in root.skins.iter().enumerate() {
        let joints: Vec<BoneId> = skin
            .joints
            .iter()
            .filter_map(|j| bone_of_node[j.value()])
            .collect();
        let inverse_bind: Vec<Mat4> = match skin.inverse_bind_matrices {
            Some(acc) => {
                let m = reader.read(acc.value(), Type::Mat4, Components::Float)?;
                if m.len() / 16 < joints.len() {
                    return Err(ImportError::Skin {
                        index: si,
                        reason: format!(
                            "{} inverse bind matrices for {} joints",
                            m.len() / 16,
                            joints.len()
                        ),
                    });
                }
                m.chunks_exact(16)
                    .take(joints.len())
                    .map(Mat4::from_cols_slice)
                    .collect()
            }
            None => vec![Mat4::IDENTITY; joints.len()],
        };
        for (j, m) in joints.iter().zip(&inverse_bind) {
            if !std::mem::replace(&mut has_bind[j.index()], true) {
                descs[j.index()].inverse_bind = *m;
            }
        }
        skins.push(Skin {
            name: skin.name.clone().unwrap_or_else(|| format!("skin{si}")),
            joints,
            inverse_bind,
        });
    }
    let skeleton = Skeleton::new(descs)?;
    Ok((skeleton, bone_of_node, skins))
}

fn read_channels(
    root: &Root,
    ai: usize,
    bone_of_node: &[Option<BoneId>],
    reader: &mut Reader<'_>,
    report: &mut ImportReport,
) -> Result<Vec<ChannelDesc>, ImportError> {
    let anim = &root.animations[ai];
    let err = |reason: String| ImportError::Animation {
        animation: ai,
        reason,
    };
    let mut out = Vec::new();
    for (ci, ch) in anim.channels.iter().enumerate() {
        let node = ch.target.node.value();
        if node >= bone_of_node.len() {
            return Err(err(format!(
                "channel {ci} targets node {node}, which does not exist"
            )));
        }
        let sampler = anim.samplers.get(ch.sampler.value()).ok_or_else(|| {
            err(format!(
                "channel {ci} uses sampler {}, which does not exist",
                ch.sampler.value()
            ))
        })?;
        let prop = match ch.target.path {
            Checked::Valid(GProp::Translation) => crate::clip::Property::Translation,
            Checked::Valid(GProp::Rotation) => crate::clip::Property::Rotation,
            Checked::Valid(GProp::Scale) => crate::clip::Property::Scale,
            Checked::Valid(GProp::MorphTargetWeights) => {
                report.weight_channels += 1;
                continue;
            }
            Checked::Invalid => {
                return Err(err(format!("channel {ci} has an unknown target path")));
            }
        };
        let Some(bone) = bone_of_node[node] else {
            report.non_skeleton_channels += 1;
            continue;
        };
        let interpolation = match sampler.interpolation {
            Checked::Valid(GInterp::Step) => Interpolation::Step,
            Checked::Valid(GInterp::Linear) => Interpolation::Linear,
            Checked::Valid(GInterp::CubicSpline) => Interpolation::CubicSpline,
            Checked::Invalid => {
                return Err(err(format!("channel {ci} has an unknown interpolation")));
            }
        };
        let times = reader.read(sampler.input.value(), Type::Scalar, Components::Float)?;
        let keys = match prop {
            crate::clip::Property::Rotation => {
                let output = sampler.output.value();
                let v = reader.read(output, Type::Vec4, Components::FloatOrNormalized)?;
                // A rotation key must be a finite, non-zero quaternion whose squared length does
                // not overflow (a component near 1.8e19 would make normalising it non-finite);
                // cubic-spline tangents must be finite in the same sense.
                let cubic = interpolation == Interpolation::CubicSpline;
                for (k, c) in v.chunks_exact(4).enumerate() {
                    let q = Quat::from_xyzw(c[0], c[1], c[2], c[3]);
                    let l2 = q.length_squared();
                    let value = !cubic || k % 3 == 1;
                    if !l2.is_finite() || (value && l2 < 1e-12) {
                        return Err(ImportError::Accessor {
                            index: output,
                            reason: format!("rotation key {k} ({q}) is not a usable rotation"),
                        });
                    }
                }
                Keys::Rotation(
                    v.chunks_exact(4)
                        .map(|c| Quat::from_xyzw(c[0], c[1], c[2], c[3]))
                        .collect(),
                )
            }
            p => {
                let v = reader.read(sampler.output.value(), Type::Vec3, Components::Float)?;
                let v = v.chunks_exact(3).map(Vec3::from_slice).collect();
                if p == crate::clip::Property::Translation {
                    Keys::Translation(v)
                } else {
                    Keys::Scale(v)
                }
            }
        };
        out.push(ChannelDesc {
            bone,
            interpolation,
            times,
            keys,
        });
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests;
