//! Pose error: how far the LOD pose's joints are from a full-rate evaluation at the same time,
//! in model units and in pixels on screen.

use glam::{Mat4, Vec3};

use salience::View;

/// Joint position error statistics.
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
}

/// Running sums for [`PoseError`].
#[derive(Clone, Copy, Debug, Default)]
pub struct ErrorSum {
    joints: u64,
    sum: f64,
    max: f32,
    visible: u64,
    sum_px: f64,
    max_px: f32,
}

impl ErrorSum {
    /// Adds one joint's error `e` (units) seen at `pixels_per_unit` (`None`: not visible).
    #[inline]
    pub fn add(&mut self, e: f32, pixels_per_unit: Option<f32>) {
        self.joints += 1;
        self.sum += e as f64;
        self.max = self.max.max(e);
        if let Some(ppu) = pixels_per_unit {
            let px = e * ppu;
            self.visible += 1;
            self.sum_px += px as f64;
            self.max_px = self.max_px.max(px);
        }
    }

    /// Adds every joint of a pose: `pose` and `reference` are model matrices, the character
    /// stands at `position`.
    pub fn add_pose(
        &mut self,
        joints: &[bool],
        pose: &[Mat4],
        reference: &[Mat4],
        position: Vec3,
        view: &View,
    ) {
        for ((&j, a), b) in joints.iter().zip(pose).zip(reference) {
            if !j {
                continue;
            }
            let pa = a.w_axis.truncate();
            let pb = b.w_axis.truncate();
            let at = position + pb;
            let ppu = view.is_in_view(at, 0.0).then(|| view.pixels_per_unit(at));
            self.add(pa.distance(pb), ppu);
        }
    }

    /// Merges another sum.
    pub fn merge(&mut self, o: &ErrorSum) {
        self.joints += o.joints;
        self.sum += o.sum;
        self.max = self.max.max(o.max);
        self.visible += o.visible;
        self.sum_px += o.sum_px;
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
        }
    }
}
