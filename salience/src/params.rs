//! The BSWDF's parameters: every curve constant in one plain struct with documented defaults and
//! units, validated on each evaluation (a few comparisons, not per node).

use crate::curves::{PursuitCap, ResponseCurve, check};
use crate::error::SalienceError;

/// Whether a surface is seen from one side only (closed meshes) or from both (cloth, leaves).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Sidedness {
    /// Back faces (normal pointing away from the eye) count as seen edge-on: facing factor
    /// `max(0, cos)`, and lighting uses the normal as given.
    #[default]
    OneSided,
    /// Both faces are visible: facing factor `|cos|`, and lighting uses the normal flipped
    /// toward the eye (what a renderer does for a two-sided material), so the side you see is lit
    /// only if the light is on that side too.
    TwoSided,
}

/// All constants of the BSWDF. [`BswdfParams::default`] holds the values chosen for a viewer
/// at a desktop display; the reasons for each are on the fields.
///
/// Angular speeds are retinal speeds in degrees per second. The camera's angles are turned into
/// retinal angles by [`BswdfParams::display_angle_scale`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BswdfParams {
    /// Response to local motion (a node's velocity relative to its neighbours' mean, as angular
    /// speed). Default: threshold 0.05 °/s, half-saturation 1 °/s.
    ///
    /// Relative motion against a visible reference is detected from a few arcminutes per second
    /// (the best reported thresholds are 1–3 arcmin/s; without a reference they are several
    /// times higher). 0.05 °/s = 3 arcmin/s sits at the top of that range, because shaded,
    /// textured cloth is a noisier reference than a lab stimulus. The half-saturation of 1 °/s
    /// is about where a motion becomes plainly noticeable (a point crossing a 1° region — a
    /// thumbnail at arm's length — in one second): from there on, faster only counts a little.
    pub local_motion: ResponseCurve,
    /// Response to the object's own angular speed, giving the base term that makes a moving
    /// object more salient than a still one. Default: threshold 0.2 °/s, half-saturation 10 °/s.
    ///
    /// 0.2 °/s (12 arcmin/s) is the order of the threshold for motion without a nearby reference;
    /// 10 °/s is a brisk motion that reliably captures attention.
    pub global_base: ResponseCurve,
    /// Largest base term a moving object receives, in [0, 1]. Default 0.25: motion of the whole
    /// object raises every node a little, but local differences (up to 1 − 0.25) still
    /// dominate the ranking within an object.
    pub global_base_max: f32,
    /// Upper bound on local-motion salience as a function of the object's angular speed (smooth
    /// pursuit / dynamic visual acuity). Default: half at 40 °/s, floor 0.15.
    ///
    /// Pursuit gain stays close to 1 up to roughly 30 °/s and degrades beyond; dynamic acuity is
    /// roughly halved around 40–60 °/s. The floor keeps a coarse ranking for very fast objects.
    pub global_cap: PursuitCap,
    /// Retinal angle per radian of camera angle. 1 (default) assumes the image is viewed at its
    /// geometrically correct distance, i.e. the display spans the camera's field of view in the
    /// viewer's eye. For a 60° camera shown on a monitor that spans 30° of the viewer's field,
    /// use 0.5: every motion is half as fast on the retina. > 0.
    pub display_angle_scale: f32,
    /// One- or two-sided surfaces; applies to the facing factor and to lighting.
    /// Default [`Sidedness::OneSided`]; cloth should use [`Sidedness::TwoSided`].
    pub sides: Sidedness,
    /// Facing factor of a surfel seen edge-on (or from behind, one-sided), in [0, 1]:
    /// `facing = floor + (1 − floor) · cos`, with cos between the normal and the direction to
    /// the eye. Default 0.2.
    ///
    /// A surfel's projected area, and with it the number of pixels its detail can change, falls
    /// with cos; but silhouettes stay visible and carry shape, so edge-on surfels keep a fifth.
    pub facing_floor: f32,
    /// Factor for nodes outside the view frustum (behind the eye or off the image by more than
    /// `view_margin`), in [0, 1]. Default 0.1: unseen detail is nearly worthless, but a residual
    /// ranking is kept because off-screen motion pulls on visible cloth and may come into view.
    pub outside_view_weight: f32,
    /// How far outside the image a node still counts as in view, as a fraction of the image's
    /// half-extent. ≥ 0. Default 0.1, so detail is ready just before it enters the image.
    pub view_margin: f32,
}

impl Default for BswdfParams {
    fn default() -> Self {
        Self {
            local_motion: ResponseCurve {
                threshold_deg_per_s: 0.05,
                half_saturation_deg_per_s: 1.0,
            },
            global_base: ResponseCurve {
                threshold_deg_per_s: 0.2,
                half_saturation_deg_per_s: 10.0,
            },
            global_base_max: 0.25,
            global_cap: PursuitCap {
                half_speed_deg_per_s: 40.0,
                floor: 0.15,
            },
            display_angle_scale: 1.0,
            sides: Sidedness::OneSided,
            facing_floor: 0.2,
            outside_view_weight: 0.1,
            view_margin: 0.1,
        }
    }
}

impl BswdfParams {
    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), SalienceError> {
        self.local_motion.validate(
            "local_motion.threshold_deg_per_s",
            "local_motion.half_saturation_deg_per_s",
        )?;
        self.global_base.validate(
            "global_base.threshold_deg_per_s",
            "global_base.half_saturation_deg_per_s",
        )?;
        self.global_cap.validate()?;
        let unit = |x: f32| (0.0..=1.0).contains(&x);
        check(
            "global_base_max",
            self.global_base_max,
            unit(self.global_base_max),
            "in [0, 1]",
        )?;
        check(
            "display_angle_scale",
            self.display_angle_scale,
            self.display_angle_scale > 0.0,
            "finite and > 0",
        )?;
        check(
            "facing_floor",
            self.facing_floor,
            unit(self.facing_floor),
            "in [0, 1]",
        )?;
        check(
            "outside_view_weight",
            self.outside_view_weight,
            unit(self.outside_view_weight),
            "in [0, 1]",
        )?;
        check(
            "view_margin",
            self.view_margin,
            self.view_margin >= 0.0,
            "finite and >= 0",
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_each_field_is_checked() {
        BswdfParams::default().validate().unwrap();
        let bad: [fn(&mut BswdfParams); 8] = [
            |p| p.local_motion.half_saturation_deg_per_s = 0.0,
            |p| p.global_base.threshold_deg_per_s = -1.0,
            |p| p.global_base_max = 1.5,
            |p| p.global_cap.half_speed_deg_per_s = f32::INFINITY,
            |p| p.display_angle_scale = 0.0,
            |p| p.facing_floor = f32::NAN,
            |p| p.outside_view_weight = -0.1,
            |p| p.view_margin = -0.5,
        ];
        for f in bad {
            let mut p = BswdfParams::default();
            f(&mut p);
            assert!(
                matches!(p.validate(), Err(SalienceError::InvalidParameter { .. })),
                "{p:?}"
            );
        }
    }
}
