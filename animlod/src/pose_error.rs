//! Pose error: how far the LOD pose is from a full-rate evaluation at the same time, in model
//! units and in pixels on screen, measured where a viewer sees it — at every joint's origin and
//! at its tip ([`crate::Skeleton::tip`]), points that turn with the bone (as ACL measures
//! compression error at virtual vertices; Frechette, "Animation Compression Library", 2017–).
//! A joint's error is the larger of the two.

use glam::{Affine3A, Mat4, Vec3};

use salience::View;

use crate::skeleton::Skeleton;

/// Pose error statistics over joints (each joint's error: the larger of its origin's and its
/// tip's displacement).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PoseError {
    /// Joints compared.
    pub joints: u64,
    /// Mean model-space (= world-space) position error, in scene units.
    pub mean: f32,
    /// Largest model-space position error.
    pub max: f32,
    /// Joints inside the view (the pixel statistics cover these).
    pub visible_joints: u64,
    /// Mean on-screen error in pixels (error length × pixels per unit at the joint's depth).
    pub mean_px: f32,
    /// Largest on-screen error in pixels.
    pub max_px: f32,
    /// Root mean square on-screen error in pixels.
    pub rms_px: f32,
}

/// Running sums for [`PoseError`].
#[derive(Clone, Copy, Debug, Default)]
pub struct ErrorSum {
    joints: u64,
    sum: f64,
    max: f32,
    visible: u64,
    sum_px: f64,
    sum_px2: f64,
    max_px: f32,
}

impl ErrorSum {
    /// Adds one joint's error `e` (units) seen at `pixels_per_unit` (`None`: not visible).
    #[inline]
    pub fn add(&mut self, e: f32, pixels_per_unit: Option<f32>) {
        self.add_px(e, pixels_per_unit.map(|ppu| e * ppu));
    }

    /// Adds every joint of a pose, at its origin and its tip: `pose` and `reference` are model
    /// matrices of `skeleton`'s bones, `world` the character's model-to-world transform
    /// ([`crate::Crowd::world_transform`]). Errors are measured in world units.
    pub fn add_pose(
        &mut self,
        skeleton: &Skeleton,
        pose: &[Mat4],
        reference: &[Mat4],
        world: &Affine3A,
        view: &View,
    ) {
        let tips = skeleton.tips();
        for (((&j, a), b), &tip) in skeleton
            .joint_flags()
            .iter()
            .zip(pose)
            .zip(reference)
            .zip(tips)
        {
            if !j {
                continue;
            }
            let (e, px) = point_pair_error(a, b, tip, world, view);
            self.add_px(e, px);
        }
    }

    /// Adds one joint's error `e` (units) already converted to pixels (`None`: not visible).
    #[inline]
    pub(crate) fn add_px(&mut self, e: f32, px: Option<f32>) {
        self.joints += 1;
        self.sum += e as f64;
        self.max = self.max.max(e);
        if let Some(px) = px {
            self.visible += 1;
            self.sum_px += px as f64;
            self.sum_px2 += (px as f64) * (px as f64);
            self.max_px = self.max_px.max(px);
        }
    }

    /// Merges another sum.
    pub fn merge(&mut self, o: &ErrorSum) {
        self.joints += o.joints;
        self.sum += o.sum;
        self.max = self.max.max(o.max);
        self.visible += o.visible;
        self.sum_px += o.sum_px;
        self.sum_px2 += o.sum_px2;
        self.max_px = self.max_px.max(o.max_px);
    }

    /// The statistics.
    pub fn finish(&self) -> PoseError {
        PoseError {
            joints: self.joints,
            mean: if self.joints > 0 {
                (self.sum / self.joints as f64) as f32
            } else {
                0.0
            },
            max: self.max,
            visible_joints: self.visible,
            mean_px: if self.visible > 0 {
                (self.sum_px / self.visible as f64) as f32
            } else {
                0.0
            },
            max_px: self.max_px,
            rms_px: if self.visible > 0 {
                (self.sum_px2 / self.visible as f64).sqrt() as f32
            } else {
                0.0
            },
        }
    }
}

/// One joint's error between two model matrices, at the joint's origin and at its tip (`tip` in
/// the bone's local space), placed in the world by `world`: the larger displacement in world
/// units, and the larger in pixels through `view` (`None` when neither reference point is in
/// view).
#[inline]
pub(crate) fn point_pair_error(
    pose: &Mat4,
    reference: &Mat4,
    tip: Vec3,
    world: &Affine3A,
    view: &View,
) -> (f32, Option<f32>) {
    let w = |m: &Mat4, p: Vec3| world.transform_point3(m.transform_point3(p));
    let (oa, ob) = (w(pose, Vec3::ZERO), w(reference, Vec3::ZERO));
    let (ta, tb) = (w(pose, tip), w(reference, tip));
    let (eo, et) = (oa.distance(ob), ta.distance(tb));
    let px = |e: f32, at: Vec3| {
        view.is_in_view(at, 0.0)
            .then(|| e * view.pixels_per_unit(at))
    };
    let px = match (px(eo, ob), px(et, tb)) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, b) => a.or(b),
    };
    (eo.max(et), px)
}
