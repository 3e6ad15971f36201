//! The bone hierarchy shared by every character of a rig: parents before children, names, rest
//! transforms, inverse bind matrices, and the structural facts the priorities use (depth, number
//! of descendants).

use glam::{Mat4, Vec3};

use crate::error::BuildError;
use crate::ids::BoneId;
use crate::transform::{Transform, concat};

/// Largest supported number of bones.
pub const MAX_BONES: usize = 65_535;

/// Marks a root bone in the parent array.
pub(crate) const NO_PARENT: u32 = u32::MAX;

/// One bone handed to [`Skeleton::new`].
#[derive(Clone, Debug, PartialEq)]
pub struct BoneDesc {
    /// Name (glTF node name, or a generated one).
    pub name: String,
    /// Parent bone; it must come earlier in the list. `None` for a root.
    pub parent: Option<BoneId>,
    /// Local transform of the bind/rest pose, used for channels a clip does not key.
    pub rest: Transform,
    /// Inverse bind matrix (model space to bone space at bind time); identity for non-joints.
    pub inverse_bind: Mat4,
    /// Whether a skin uses the bone as a joint (non-joint bones are ancestors kept so that
    /// transforms propagate; pose error is measured on joints only).
    pub is_joint: bool,
}

/// A bone hierarchy stored parents first, so one forward pass computes model transforms.
#[derive(Clone, Debug)]
pub struct Skeleton {
    parents: Vec<u32>,
    names: Vec<String>,
    rest: Vec<Transform>,
    rest_locals: Vec<glam::Affine3A>,
    inverse_bind: Vec<Mat4>,
    is_joint: Vec<bool>,
    depth: Vec<u32>,
    descendants: Vec<u32>,
    /// The bones in depth-first pre-order (roots and children in index order): every subtree
    /// is a contiguous run, starting at its root.
    preorder: Vec<u32>,
    /// Per bone: its position in [`Skeleton::preorder`].
    preorder_pos: Vec<u32>,
    /// Per bone, in its own local space: the point that turns with it (see [`Skeleton::tip`]).
    tips: Vec<Vec3>,
}

impl Skeleton {
    /// Builds a skeleton; bones must be listed parents first and hold finite values.
    pub fn new(bones: Vec<BoneDesc>) -> Result<Skeleton, BuildError> {
        if bones.is_empty() {
            return Err(BuildError::EmptySkeleton);
        }
        if bones.len() > MAX_BONES {
            return Err(BuildError::TooManyBones(bones.len()));
        }
        let n = bones.len();
        let mut parents = Vec::with_capacity(n);
        let mut depth = Vec::with_capacity(n);
        for (i, b) in bones.iter().enumerate() {
            let bone = BoneId::new(i);
            match b.parent {
                Some(p) if p.index() >= i => return Err(BuildError::ParentNotBefore { bone }),
                Some(p) => {
                    parents.push(p.raw());
                    depth.push(depth[p.index()] + 1);
                }
                None => {
                    parents.push(NO_PARENT);
                    depth.push(0);
                }
            }
            if !b.rest.is_finite() || b.rest.rotation.length() < 1e-6 {
                return Err(BuildError::NonFinite {
                    what: format!("rest transform of {bone}"),
                });
            }
            if !b.inverse_bind.is_finite() {
                return Err(BuildError::NonFinite {
                    what: format!("inverse bind matrix of {bone}"),
                });
            }
        }
        let mut descendants = vec![0u32; n];
        for i in (0..n).rev() {
            if parents[i] != NO_PARENT {
                descendants[parents[i] as usize] += descendants[i] + 1;
            }
        }
        let (preorder, preorder_pos) = depth_first(&parents);
        let mut names = Vec::with_capacity(n);
        let mut rest = Vec::with_capacity(n);
        let mut inverse_bind = Vec::with_capacity(n);
        let mut is_joint = Vec::with_capacity(n);
        for b in bones {
            names.push(b.name);
            rest.push(Transform {
                rotation: b.rest.rotation.normalize(),
                ..b.rest
            });
            inverse_bind.push(b.inverse_bind);
            is_joint.push(b.is_joint);
        }
        let tips = bone_tips(&parents, &rest);
        let rest_locals = rest.iter().map(Transform::to_affine).collect();
        Ok(Skeleton {
            parents,
            names,
            rest,
            rest_locals,
            inverse_bind,
            is_joint,
            depth,
            descendants,
            preorder,
            preorder_pos,
            tips,
        })
    }

    /// The bones in depth-first pre-order: the subtree of bone `b` is
    /// `preorder[pos[b]..pos[b] + descendants(b) + 1]` with `pos` = [`Skeleton::preorder_pos`],
    /// and every parent comes before its children.
    #[inline]
    pub(crate) fn preorder(&self) -> &[u32] {
        &self.preorder
    }

    /// Per bone: its position in [`Skeleton::preorder`].
    #[inline]
    pub(crate) fn preorder_pos(&self) -> &[u32] {
        &self.preorder_pos
    }

    /// Number of bones.
    #[inline]
    pub fn len(&self) -> usize {
        self.parents.len()
    }

    /// Always false: a skeleton has at least one bone.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.parents.is_empty()
    }

    /// All bone ids, parents first.
    pub fn bones(&self) -> impl ExactSizeIterator<Item = BoneId> + '_ {
        (0..self.len()).map(BoneId::new)
    }

    /// Parent of a bone, `None` for a root. Panics if `bone` is out of range.
    #[inline]
    pub fn parent(&self, bone: BoneId) -> Option<BoneId> {
        let p = self.parents[bone.index()];
        (p != NO_PARENT).then_some(BoneId::from_raw(p))
    }

    /// The parent array (`u32::MAX` marks a root), for fast loops.
    #[inline]
    pub(crate) fn parents_raw(&self) -> &[u32] {
        &self.parents
    }

    /// Name of a bone.
    pub fn name(&self, bone: BoneId) -> &str {
        &self.names[bone.index()]
    }

    /// The first bone with this name.
    pub fn find(&self, name: &str) -> Option<BoneId> {
        self.names.iter().position(|n| n == name).map(BoneId::new)
    }

    /// Rest (bind) local transform of a bone.
    pub fn rest(&self, bone: BoneId) -> Transform {
        self.rest[bone.index()]
    }

    /// Rest local transforms of all bones.
    pub(crate) fn rest_pose(&self) -> &[Transform] {
        &self.rest
    }

    /// Rest local transforms as affine matrices.
    pub(crate) fn rest_locals(&self) -> &[glam::Affine3A] {
        &self.rest_locals
    }

    /// Inverse bind matrix of a bone (from the first skin that lists it; identity otherwise).
    pub fn inverse_bind(&self, bone: BoneId) -> Mat4 {
        self.inverse_bind[bone.index()]
    }

    /// Whether some skin uses the bone as a joint.
    pub fn is_joint(&self, bone: BoneId) -> bool {
        self.is_joint[bone.index()]
    }

    /// The joint flags of all bones.
    pub(crate) fn joint_flags(&self) -> &[bool] {
        &self.is_joint
    }

    /// Number of edges between a bone and its root (0 for a root).
    pub fn depth(&self, bone: BoneId) -> u32 {
        self.depth[bone.index()]
    }

    /// Depth of the deepest bone.
    pub(crate) fn max_depth(&self) -> u32 {
        self.depth.iter().copied().max().unwrap_or(0)
    }

    /// Number of direct and indirect children of a bone.
    pub(crate) fn descendant_count(&self, bone: BoneId) -> u32 {
        self.descendants[bone.index()]
    }

    /// Number of direct and indirect children of a bone, by raw index.
    #[inline]
    pub(crate) fn descendant_count_raw(&self, bone: u32) -> u32 {
        self.descendants[bone as usize]
    }

    /// The bone's tip in its own local space: a point at the bone's length along its axis, which
    /// turns with the bone. Errors are measured there as well as at the bone's origin, because a
    /// bone's own rotation moves only its tip (and its children): measured at origins alone, a
    /// leaf bone animated by rotation shows no error however wrong it is.
    ///
    /// A bone with children points at its farthest child (its tip is that child's rest
    /// translation). A leaf gets a virtual tip continuing its parent's direction, at its parent's
    /// length (the distance from the parent); a bone with no length of its own there (a root, a
    /// bone at its parent's origin) gets its parent's tip length, or else the skeleton's longest
    /// bone, along its local +Y (the glTF exporters' bone axis).
    pub fn tip(&self, bone: BoneId) -> Vec3 {
        self.tips[bone.index()]
    }

    /// Every bone's tip in its local space (see [`Skeleton::tip`]).
    pub(crate) fn tips(&self) -> &[Vec3] {
        &self.tips
    }

    /// Model-space matrices of a pose given as local transforms (one per bone).
    pub fn model_matrices(&self, locals: &[glam::Affine3A], out: &mut [Mat4]) {
        for (i, &p) in self.parents.iter().enumerate() {
            out[i] = if p == NO_PARENT {
                Mat4::from(locals[i])
            } else {
                concat(&out[p as usize], &locals[i])
            };
        }
    }

    /// Model-space matrices of the rest pose.
    pub fn rest_model_matrices(&self) -> Vec<Mat4> {
        let mut out = vec![Mat4::IDENTITY; self.len()];
        self.model_matrices(&self.rest_locals, &mut out);
        out
    }

    /// The bone descriptions this skeleton was built from, parents first: what
    /// [`Skeleton::new`] takes, for building a modified skeleton (rig transformations).
    pub fn descs(&self) -> Vec<BoneDesc> {
        (0..self.len())
            .map(|i| BoneDesc {
                name: self.names[i].clone(),
                parent: self.parent(BoneId::new(i)),
                rest: self.rest[i],
                inverse_bind: self.inverse_bind[i],
                is_joint: self.is_joint[i],
            })
            .collect()
    }
}

/// Tips of every bone in local space (see [`Skeleton::tip`]); `parents` parents first.
/// Depth-first pre-order of a parents-first hierarchy (roots, then each bone's children, in
/// index order) and each bone's position in it.
fn depth_first(parents: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let n = parents.len();
    // Children in index order, as a compressed adjacency list.
    let mut start = vec![0u32; n + 1];
    for &p in parents {
        if p != NO_PARENT {
            start[p as usize + 1] += 1;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut children = vec![0u32; start[n] as usize];
    for (b, &p) in parents.iter().enumerate() {
        if p != NO_PARENT {
            children[fill[p as usize] as usize] = b as u32;
            fill[p as usize] += 1;
        }
    }
    let mut order = Vec::with_capacity(n);
    let mut stack = Vec::new();
    for root in (0..n).filter(|&b| parents[b] == NO_PARENT) {
        stack.push(root as u32);
        while let Some(b) = stack.pop() {
            order.push(b);
            let kids = &children[start[b as usize] as usize..start[b as usize + 1] as usize];
            stack.extend(kids.iter().rev());
        }
    }
    let mut pos = vec![0u32; n];
    for (i, &b) in order.iter().enumerate() {
        pos[b as usize] = i as u32;
    }
    (order, pos)
}

fn bone_tips(parents: &[u32], rest: &[Transform]) -> Vec<Vec3> {
    const EPS: f32 = 1e-6;
    let n = parents.len();
    let mut tips = vec![Vec3::ZERO; n];
    // Farthest child's rest translation.
    for c in 0..n {
        let p = parents[c];
        if p != NO_PARENT && rest[c].translation.length() > tips[p as usize].length() {
            tips[p as usize] = rest[c].translation;
        }
    }
    let longest = tips.iter().map(|t| t.length()).fold(0.0f32, f32::max);
    let fallback = if longest > EPS { longest } else { 1.0 };
    for b in 0..n {
        if tips[b].length() > EPS {
            continue;
        }
        let r = &rest[b];
        let along = r.translation.length();
        // In the bone's local frame, undoing its rest rotation and scale.
        let local_dir = |v: Vec3| {
            let d = r.rotation.inverse() * v;
            let s = r.scale;
            if s.abs().min_element() > EPS {
                d / s
            } else {
                d
            }
        };
        tips[b] = if along > EPS {
            local_dir(r.translation)
        } else {
            let len = match parents[b] {
                NO_PARENT => fallback,
                p => tips[p as usize].length().max(EPS),
            };
            let len = if len > EPS { len } else { fallback };
            local_dir(Vec3::Y * len)
        };
    }
    tips
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use glam::{Quat, Vec3};

    /// A joint `y` units above its parent (test helper).
    pub(crate) fn bone(name: &str, parent: Option<u32>, y: f32) -> BoneDesc {
        BoneDesc {
            name: name.into(),
            parent: parent.map(BoneId::from_raw),
            rest: Transform {
                translation: Vec3::new(0.0, y, 0.0),
                ..Transform::IDENTITY
            },
            inverse_bind: Mat4::IDENTITY,
            is_joint: true,
        }
    }

    #[test]
    fn structure_and_rest_pose() {
        let s = Skeleton::new(vec![
            bone("root", None, 1.0),
            bone("spine", Some(0), 1.0),
            bone("head", Some(1), 0.5),
            bone("arm", Some(1), 0.2),
        ])
        .unwrap();
        assert_eq!(s.descendant_count(BoneId::from_raw(0)), 3);
        assert_eq!(s.descendant_count(BoneId::from_raw(1)), 2);
        assert_eq!(s.depth(BoneId::from_raw(2)), 2);
        assert_eq!(s.max_depth(), 2);
        assert_eq!(s.find("arm"), Some(BoneId::from_raw(3)));
        let m = s.rest_model_matrices();
        assert!((m[2].w_axis.y - 2.5).abs() < 1e-6);
        // Tips: the farthest child; a leaf continues its parent's direction at its own length.
        assert_eq!(s.tip(BoneId::from_raw(1)), Vec3::new(0.0, 0.5, 0.0));
        assert_eq!(s.tip(BoneId::from_raw(3)), Vec3::new(0.0, 0.2, 0.0));
        // A rotated leaf: its tip is the parent→leaf direction in its own frame.
        let mut leaf = bone("leaf", Some(0), 1.0);
        leaf.rest.rotation = glam::Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let s = Skeleton::new(vec![bone("root", None, 0.0), leaf]).unwrap();
        assert!(
            s.tip(BoneId::from_raw(1))
                .abs_diff_eq(Vec3::new(1.0, 0.0, 0.0), 1e-6)
        );
        let m = s.rest_model_matrices();
        let tip = m[1].transform_point3(s.tip(BoneId::from_raw(1)));
        assert!(tip.abs_diff_eq(Vec3::new(0.0, 2.0, 0.0), 1e-5), "{tip}");
    }

    #[test]
    fn preorder_keeps_every_subtree_contiguous() {
        // Two roots; children listed breadth-first, so index order is not depth-first.
        let s = Skeleton::new(vec![
            bone("r0", None, 0.0),
            bone("a", Some(0), 1.0),
            bone("b", Some(0), 1.0),
            bone("a1", Some(1), 1.0),
            bone("r1", None, 0.0),
            bone("b1", Some(2), 1.0),
            bone("a2", Some(1), 1.0),
            bone("a1x", Some(3), 1.0),
        ])
        .unwrap();
        assert_eq!(s.preorder(), &[0, 1, 3, 7, 6, 2, 5, 4]);
        let pos = s.preorder_pos();
        for (b, &at) in pos.iter().enumerate() {
            assert_eq!(s.preorder()[at as usize] as usize, b);
            // The run from the bone over its descendant count holds exactly its subtree.
            let run = at as usize..at as usize + s.descendants[b] as usize + 1;
            for (i, &x) in s.preorder().iter().enumerate() {
                let mut a = x;
                let mut inside = a as usize == b;
                while s.parents[a as usize] != NO_PARENT && !inside {
                    a = s.parents[a as usize];
                    inside = a as usize == b;
                }
                assert_eq!(run.contains(&i), inside, "bone {b}, position {i}");
            }
        }
    }

    #[test]
    fn rejects_bad_input() {
        assert_eq!(
            Skeleton::new(vec![]).unwrap_err(),
            BuildError::EmptySkeleton
        );
        let err = Skeleton::new(vec![bone("a", Some(0), 0.0)]).unwrap_err();
        assert_eq!(
            err,
            BuildError::ParentNotBefore {
                bone: BoneId::from_raw(0)
            }
        );
        let mut b = bone("a", None, f32::NAN);
        assert!(matches!(
            Skeleton::new(vec![b.clone()]),
            Err(BuildError::NonFinite { .. })
        ));
        b.rest = Transform {
            rotation: Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
            ..Transform::IDENTITY
        };
        assert!(matches!(
            Skeleton::new(vec![b]),
            Err(BuildError::NonFinite { .. })
        ));
    }
}
