//! Pose error of the crowd against full-rate evaluation, through the frame's view.

use glam::{Affine3A, Mat4};
use salience::View;

use super::*;

impl Crowd {
    /// Pose error of one character against full-rate evaluation at its current time (every joint at
    /// its origin and tip; pixels through `view`).
    pub fn pose_error(&self, id: CharacterId, view: &View) -> Result<PoseError, CrowdError> {
        let d = self.dense(id)?;
        let mut sum = ErrorSum::default();
        self.accumulate_error(d, view, &mut sum, &mut Vec::new(), &mut Vec::new());
        Ok(sum.finish())
    }

    /// Pose error over every joint of every character, pixels through `view`.
    pub fn total_pose_error(&self, view: &View) -> PoseError {
        let mut sum = ErrorSum::default();
        self.accumulate_pose_error(view, &mut sum);
        sum.finish()
    }

    /// Adds every joint of every character, seen through `view`, to running error sums (to
    /// aggregate over frames).
    pub fn accumulate_pose_error(&self, view: &View, sum: &mut ErrorSum) {
        let (mut locals, mut models) = (Vec::new(), Vec::new());
        for d in 0..self.chars.len() {
            self.accumulate_error(d, view, sum, &mut locals, &mut models);
        }
    }

    fn accumulate_error(
        &self,
        d: usize,
        view: &View,
        sum: &mut ErrorSum,
        locals: &mut Vec<Affine3A>,
        reference: &mut Vec<Mat4>,
    ) {
        let n = self.bones;
        let c = &self.chars[d];
        let clip = &self.rig.clips()[c.clip.index()];
        let models = &self.models[self.span(d)];
        locals.resize(n, Affine3A::IDENTITY);
        reference.resize(n, Mat4::IDENTITY);
        let mut trs = TrsScratch::default();
        clip.sample_locals(c.time, &mut Vec::new(), &mut trs, locals);
        let skeleton = self.rig.skeleton();
        skeleton.model_matrices(locals, reference);
        sum.add_pose(skeleton, models, reference, &c.world(), view);
    }
}
