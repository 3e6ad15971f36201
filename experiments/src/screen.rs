//! What a viewer sees: the on-screen error of a reconstructed surface against a
//! full-resolution reference, through a [`View`], per frame.
//!
//! Per frame, every reference vertex in view and its reconstructed counterpart are projected;
//! the per-vertex distance in pixels is the error a viewer could see. A run reports the mean of
//! the per-frame RMS, the 99th percentile over all vertex-frames and the maximum, and the
//! largest *pop*: the largest frame-to-frame change of one vertex's on-screen error vector, so a
//! refine or an end-coarse that jumps shows even when the averages are small. Told which
//! vertices changed the node that simulates them that frame ([`ScreenMeter::frame_changed`]),
//! it splits the pops into those operations caused and the rest: the error vector's own change
//! from frame to frame, a reduced cloth moving a little faster or slower than the reference.

use glam::{Vec2, Vec3};
use salience::View;

/// On-screen error of one run (pixels).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScreenError {
    /// Mean over frames of the per-frame RMS over the reference's in-view vertices.
    pub rms_px: f64,
    /// 99th percentile over all vertex-frames.
    pub p99_px: f64,
    /// Largest over all vertex-frames.
    pub max_px: f64,
    /// Largest frame-to-frame change of one vertex's on-screen error vector.
    pub pop_max_px: f64,
    /// [`ScreenError::pop_max_px`] over the vertex-frames where the node simulating the vertex
    /// changed (a refine began or a coarse ended there): the jumps level-of-detail operations
    /// make. 0 when the meter was never told ([`ScreenMeter::frame_changed`]).
    pub pop_operation_max_px: f64,
    /// [`ScreenError::pop_max_px`] over every other vertex-frame: the error drifting from one
    /// frame to the next (all pops when the meter was never told which vertices changed).
    pub pop_drift_max_px: f64,
}

/// Accumulates [`ScreenError`] frame by frame.
#[derive(Clone, Debug)]
pub struct ScreenMeter {
    view: View,
    frames: u64,
    rms_sum: f64,
    samples: Vec<f32>,
    max: f32,
    pop_operation: f32,
    pop_drift: f32,
    previous: Vec<Option<Vec2>>,
}

impl ScreenMeter {
    /// A meter seeing through `view`.
    pub fn new(view: View) -> ScreenMeter {
        ScreenMeter {
            view,
            frames: 0,
            rms_sum: 0.0,
            samples: Vec::new(),
            max: 0.0,
            pop_operation: 0.0,
            pop_drift: 0.0,
            previous: Vec::new(),
        }
    }

    /// The view measured through.
    pub fn view(&self) -> &View {
        &self.view
    }

    /// Measures the next frames through `view` (a camera that moves every frame).
    pub fn set_view(&mut self, view: View) {
        self.view = view;
    }

    /// Forgets the previous frame's error vectors, so the next frame counts no pop: for a
    /// measurement that restarts the run under test (short-horizon error), where the jump is
    /// the measurement's, not the level of detail's.
    pub fn restart_sequence(&mut self) {
        self.previous.iter_mut().for_each(|p| *p = None);
    }

    /// Adds one frame: `reconstructed[i]` against `reference[i]` (same length).
    pub fn frame(&mut self, reconstructed: &[Vec3], reference: &[Vec3]) {
        self.add(reconstructed, reference, |_| true, |_| false);
    }

    /// [`ScreenMeter::frame`], told which vertices changed the node that simulates them since
    /// the previous frame (`changed`, same length): their pops count as the operations'
    /// ([`ScreenError::pop_operation_max_px`]), the others' as drift.
    pub fn frame_changed(&mut self, reconstructed: &[Vec3], reference: &[Vec3], changed: &[bool]) {
        assert_eq!(changed.len(), reference.len(), "one flag per vertex");
        self.add(reconstructed, reference, |_| true, |i| changed[i]);
    }

    /// [`ScreenMeter::frame`] over the vertices `counted` marks only (same length): the error
    /// of one part of a surface (say, the vertices coarse nodes cover). A vertex not counted
    /// this frame counts no pop the next.
    pub fn frame_masked(&mut self, reconstructed: &[Vec3], reference: &[Vec3], counted: &[bool]) {
        assert_eq!(counted.len(), reference.len(), "one flag per vertex");
        self.add(reconstructed, reference, |i| counted[i], |_| false);
    }

    fn add(
        &mut self,
        reconstructed: &[Vec3],
        reference: &[Vec3],
        counted: impl Fn(usize) -> bool,
        changed: impl Fn(usize) -> bool,
    ) {
        assert_eq!(
            reconstructed.len(),
            reference.len(),
            "one vertex per vertex"
        );
        self.previous.resize(reference.len(), None);
        let (mut sum_sq, mut count) = (0f64, 0u64);
        for (i, (a, r)) in reconstructed.iter().zip(reference).enumerate() {
            let error = if counted(i) {
                self.error_px(*a, *r)
            } else {
                None
            };
            if let (Some(e), Some(p)) = (error, self.previous[i]) {
                let pop = if changed(i) {
                    &mut self.pop_operation
                } else {
                    &mut self.pop_drift
                };
                *pop = pop.max((e - p).length());
            }
            self.previous[i] = error;
            if let Some(e) = error {
                let d = e.length();
                sum_sq += (d as f64) * (d as f64);
                count += 1;
                self.samples.push(d);
                self.max = self.max.max(d);
            }
        }
        if count > 0 {
            self.rms_sum += (sum_sq / count as f64).sqrt();
        }
        self.frames += 1;
    }

    /// The on-screen error vector of `a` against reference `r`, if `r` is in view. A
    /// reconstructed point behind the near plane is as far off as its world distance at the
    /// reference's scale.
    fn error_px(&self, a: Vec3, r: Vec3) -> Option<Vec2> {
        if !self.view.is_in_view(r, 0.0) {
            return None;
        }
        let pr = self.view.project(r)?;
        Some(match self.view.project(a) {
            Some(pa) => pa - pr,
            None => Vec2::new(a.distance(r) * self.view.pixels_per_unit(r), 0.0),
        })
    }

    /// The run's figures so far.
    pub fn finish(&mut self) -> ScreenError {
        let p99 = if self.samples.is_empty() {
            0.0
        } else {
            let k = ((self.samples.len() - 1) as f64 * 0.99).round() as usize;
            *self.samples.select_nth_unstable_by(k, f32::total_cmp).1
        };
        ScreenError {
            rms_px: if self.frames > 0 {
                self.rms_sum / self.frames as f64
            } else {
                0.0
            },
            p99_px: p99 as f64,
            max_px: self.max as f64,
            pop_max_px: self.pop_operation.max(self.pop_drift) as f64,
            pop_operation_max_px: self.pop_operation as f64,
            pop_drift_max_px: self.pop_drift as f64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view() -> View {
        View::look_at(
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::ZERO,
            Vec3::Y,
            1.0,
            1920,
            1080,
        )
        .unwrap()
    }

    #[test]
    fn identical_surfaces_have_zero_error_and_an_offset_has_its_pixels() {
        let reference = vec![Vec3::ZERO, Vec3::X * 0.5, Vec3::new(0.0, 0.0, 20.0)];
        let mut m = ScreenMeter::new(view());
        m.frame(&reference, &reference);
        assert_eq!(m.finish(), ScreenError::default());
        // A 1 cm offset at 5 m: focal/5 px per metre × 0.01 m.
        let v = view();
        let px = v.pixels_per_unit(Vec3::ZERO) * 0.01;
        let moved: Vec<Vec3> = reference.iter().map(|p| *p + Vec3::Y * 0.01).collect();
        let mut m = ScreenMeter::new(v);
        m.frame(&moved, &reference);
        let e = m.finish();
        assert!(
            (e.max_px - px as f64).abs() < 0.05 * px as f64,
            "{e:?} vs {px}"
        );
        // The vertex behind the camera is not counted.
        assert!(e.rms_px <= e.max_px && e.p99_px <= e.max_px);
    }

    #[test]
    fn a_jump_is_a_pop_and_a_steady_offset_is_not() {
        let reference = vec![Vec3::ZERO; 4];
        let steady: Vec<Vec3> = reference.iter().map(|p| *p + Vec3::X * 0.02).collect();
        let mut m = ScreenMeter::new(view());
        for _ in 0..5 {
            m.frame(&steady, &reference);
        }
        let calm = m.finish();
        assert!(calm.pop_max_px < 1e-3, "{calm:?}");
        m.frame(&reference, &reference); // the offset vanishes at once
        let jumped = m.finish();
        assert!((jumped.pop_max_px - calm.max_px).abs() < 1e-3, "{jumped:?}");
        assert_eq!(jumped.pop_operation_max_px, 0.0);
        assert_eq!(jumped.pop_drift_max_px, jumped.pop_max_px);
    }

    /// Told which vertices changed their node, the meter files their pops as the operations'
    /// and the others' as drift; the overall pop is the larger.
    #[test]
    fn pops_split_between_operations_and_drift() {
        let reference = vec![Vec3::ZERO; 2];
        let v = view();
        let px = v.pixels_per_unit(Vec3::ZERO);
        let mut m = ScreenMeter::new(v);
        m.frame_changed(&reference, &reference, &[false, false]);
        // Vertex 0 jumps 2 cm as its node changes; vertex 1 drifts 1 cm.
        let next = vec![Vec3::Y * 0.02, Vec3::X * 0.01];
        m.frame_changed(&next, &reference, &[true, false]);
        let e = m.finish();
        let close = |a: f64, b: f32| (a - b as f64).abs() < 0.02 * b as f64;
        assert!(close(e.pop_operation_max_px, 0.02 * px), "{e:?}");
        assert!(close(e.pop_drift_max_px, 0.01 * px), "{e:?}");
        assert_eq!(e.pop_max_px, e.pop_operation_max_px);
    }

    #[test]
    fn a_mask_counts_only_its_vertices() {
        let reference = vec![Vec3::ZERO, Vec3::X * 0.5, Vec3::Y * 0.5];
        // Vertex 1 is 2 cm off, the others exact.
        let mut moved = reference.clone();
        moved[1] += Vec3::Y * 0.02;
        let (mut all, mut masked, mut rest) = (
            ScreenMeter::new(view()),
            ScreenMeter::new(view()),
            ScreenMeter::new(view()),
        );
        all.frame(&moved, &reference);
        masked.frame_masked(&moved, &reference, &[true, true, true]);
        assert_eq!(all.finish(), masked.finish());
        rest.frame_masked(&moved, &reference, &[true, false, true]);
        assert_eq!(rest.finish(), ScreenError::default());
        // A vertex leaving the mask and coming back counts no pop.
        let mut m = ScreenMeter::new(view());
        m.frame_masked(&moved, &reference, &[false, true, false]);
        m.frame_masked(&reference, &reference, &[false, false, false]);
        m.frame_masked(&reference, &reference, &[false, true, false]);
        assert_eq!(m.finish().pop_max_px, 0.0);
    }
}
