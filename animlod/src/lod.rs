//! The LOD modes of a crowd and the camera ratio Ω ∈ [0, 1] of a character: 1 means full
//! detail, 0 means no bone interpolates. The view measures they use come from
//! [`salience::View`].

use crate::error::{CrowdError, invalid};

/// How a crowd chooses each character's detail. The default is [`LodMode::Off`]; each mode's
/// default parameters are the `DEFAULT_*` constants (the C ABI's `slod_default_lod_desc` copies
/// them).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum LodMode {
    /// Every animated bone of every character interpolates every frame (constant channels are
    /// still never sampled).
    #[default]
    Off,
    /// The same Ω for every character (tests, analysis, user control).
    Ratio(f32),
    /// The thesis' distance range: Ω = 1 nearer than `min`, 0 farther than `max`, linear between.
    Range {
        /// Distance below which a character is at full detail.
        min: f32,
        /// Distance beyond which no bone of it interpolates.
        max: f32,
    },
    /// Ω from the projected radius of the character's bounding sphere: `radius_px /
    /// full_detail_px`, capped at 1, and 0 below `freeze_below_px`. Because a joint's on-screen
    /// speed is proportional to the projected size while the scheduler's hold time is inversely
    /// proportional to Ω, the pixel error of a hold stays about the same at every distance.
    PixelSize {
        /// Projected radius (pixels) at and above which a character is at full detail.
        full_detail_px: f32,
        /// Projected radius (pixels) below which a character does not animate at all (0 to never
        /// freeze a visible character).
        freeze_below_px: f32,
    },
    /// A crowd-wide budget of bone interpolations per frame, spent on the bones whose hold has
    /// built up the most estimated on-screen error (projected size × priority integrated over
    /// the time held). Bones whose score is zero (invisible characters) never take budget.
    /// The budget counts cost: a character whose admitted bones a cost model prices above
    /// interpolating all of them through the block path (picked bones re-concatenate their
    /// subtrees) takes the block path and counts at most a sixth of its animated bones; a
    /// budget that affords every character that way runs LOD off, and so do the frames after
    /// one whose work the cost model priced at LOD off's or more (see
    /// [`crate::FrameStats::budget_units`]): the budget mode costs no more than LOD off.
    Budget {
        /// Bone interpolations allowed per frame over all characters (budget units).
        bone_updates_per_frame: u32,
    },
    /// Beyond the thesis: hold a bone only while the on-screen error its hold causes stays under
    /// a bound. Each animated bone integrates its measured hold error rate
    /// (the priority table\'s `hold_error_rate`) over the time it holds, converts it to pixels
    /// at the character's nearest visible depth, and interpolates as soon as that reaches
    /// `max_error_px`. Invisible characters do not animate. Like the budget, it never costs more
    /// than LOD off: a frame whose work and bookkeeping the crowd's cost model prices at LOD
    /// off's or more sends the next 30 frames down LOD off's path (exact poses of the characters
    /// in view).
    ErrorBound {
        /// Largest on-screen drift (pixels) a single held bone may cause.
        max_error_px: f32,
    },
    /// Beyond the thesis and [`LodMode::ErrorBound`]: evaluate whole key poses at intervals and
    /// interpolate the model matrices linearly between the last two, so that a bone's error is
    /// second order in the interval (a hold's is first order). Each character's next key pose is
    /// placed as far ahead (in whole frames of its current step) as keeps the interpolation's
    /// bound on every joint origin and tip — a quarter of the interval times the velocity
    /// variation over it, from the build step's table — under `max_error_px` at the
    /// character's nearest visible depth; a looping clip's wrap and a camera that comes closer
    /// than the bound allows restart from exact poses. A host skins the key poses
    /// ([`crate::Crowd::key_poses`]) and blends the skinned vertices, which equals skinning the
    /// blended matrices (skinning is linear in the palette). Invisible characters do not
    /// animate.
    Interpolated {
        /// Largest on-screen displacement (pixels) of any joint origin or tip from its
        /// full-detail position.
        max_error_px: f32,
    },
    /// Whole key poses, each shown unchanged over a window of frames centred on its own time:
    /// the pose of time `k` stands from `s ≤ k` to `e ≥ k`, with the path of every joint origin
    /// and tip from `s` to `k` and from `k` to `e` (the build step's speed table) within
    /// `max_error_px` at the character's nearest visible depth. A hold from the window's start
    /// (what [`LodMode::ErrorBound`] does per bone) spends the tolerance in one direction; a
    /// centred one spends it both ways, so a window is about twice as long, and no blending is
    /// needed — between keys a character's pose, palette and skinned vertices stand unchanged
    /// ([`crate::Crowd::key_poses`]: always weight 1). Invisible characters do not animate.
    KeyHold {
        /// Largest on-screen displacement (pixels) of any joint origin or tip from its
        /// full-detail position.
        max_error_px: f32,
    },
}

impl LodMode {
    /// The thesis' distance range in metres: full detail nearer than 5, none beyond 50.
    pub const DEFAULT_RANGE: LodMode = LodMode::Range {
        min: 5.0,
        max: 50.0,
    };
    /// Full detail from a projected radius of 200 px; frozen below 1 px.
    pub const DEFAULT_PIXEL_SIZE: LodMode = LodMode::PixelSize {
        full_detail_px: 200.0,
        freeze_below_px: 1.0,
    };
    /// 5,000 bone interpolations per frame for the whole crowd.
    pub const DEFAULT_BUDGET: LodMode = LodMode::Budget {
        bone_updates_per_frame: 5000,
    };
    /// A held bone may drift half a pixel on screen.
    pub const DEFAULT_ERROR_BOUND: LodMode = LodMode::ErrorBound { max_error_px: 0.5 };
    /// Full detail for every character.
    pub const DEFAULT_RATIO: LodMode = LodMode::Ratio(1.0);
    /// Interpolated key poses within half a pixel (the C ABI shares `max_error_px` with the
    /// error bound, so the two defaults agree).
    pub const DEFAULT_INTERPOLATED: LodMode = LodMode::Interpolated { max_error_px: 0.5 };
    /// Centred key holds within half a pixel (sharing `max_error_px` in the C ABI).
    pub const DEFAULT_KEY_HOLD: LodMode = LodMode::KeyHold { max_error_px: 0.5 };

    /// Checks the parameters: finite, `0 ≤ min < max`, `full_detail_px > 0`,
    /// `0 ≤ freeze_below_px < full_detail_px`, Ω in [0, 1].
    pub fn validate(&self) -> Result<(), CrowdError> {
        match *self {
            LodMode::Off | LodMode::Budget { .. } => Ok(()),
            LodMode::Ratio(o) if (0.0..=1.0).contains(&o) => Ok(()),
            LodMode::Ratio(_) => Err(invalid("ratio", "must be in [0, 1]")),
            LodMode::Range { min, max }
                if min.is_finite() && max.is_finite() && min >= 0.0 && min < max =>
            {
                Ok(())
            }
            LodMode::Range { .. } => Err(invalid("range", "needs finite 0 <= min < max")),
            LodMode::PixelSize {
                full_detail_px: f,
                freeze_below_px: z,
            } if f.is_finite() && f > 0.0 && z.is_finite() && z >= 0.0 && z < f => Ok(()),
            LodMode::PixelSize { .. } => Err(invalid(
                "pixel size",
                "needs finite 0 <= freeze_below_px < full_detail_px",
            )),
            LodMode::ErrorBound { max_error_px: e }
            | LodMode::Interpolated { max_error_px: e }
            | LodMode::KeyHold { max_error_px: e }
                if e.is_finite() && e > 0.0 =>
            {
                Ok(())
            }
            LodMode::ErrorBound { .. } | LodMode::Interpolated { .. } | LodMode::KeyHold { .. } => {
                Err(invalid("max_error_px", "must be finite and positive"))
            }
        }
    }
}

/// The thesis' camera ratio from a distance range, the right way round: 1 at or nearer than
/// `min`, 0 at or beyond `max`, `(max − d) / (max − min)` between. (The thesis prints
/// `(d − min) / (max − min)`, which grows with distance, against its own text that Ω must shrink
/// as the character moves away.)
#[inline]
pub(crate) fn omega_from_distance(distance: f32, min: f32, max: f32) -> f32 {
    ((max - distance) / (max - min)).clamp(0.0, 1.0)
}

/// The camera ratio from a projected radius in pixels (see [`LodMode::PixelSize`]).
#[inline]
pub(crate) fn omega_from_pixels(radius_px: f32, full_detail_px: f32, freeze_below_px: f32) -> f32 {
    if radius_px < freeze_below_px || radius_px <= 0.0 {
        0.0
    } else {
        (radius_px / full_detail_px).min(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_and_validation() {
        assert_eq!(omega_from_distance(100.0, 200.0, 1700.0), 1.0);
        assert_eq!(omega_from_distance(2000.0, 200.0, 1700.0), 0.0);
        assert!((omega_from_distance(950.0, 200.0, 1700.0) - 0.5).abs() < 1e-6);
        assert_eq!(omega_from_pixels(500.0, 200.0, 2.0), 1.0);
        assert_eq!(omega_from_pixels(1.0, 200.0, 2.0), 0.0);
        assert!((omega_from_pixels(50.0, 200.0, 2.0) - 0.25).abs() < 1e-6);
        assert!(LodMode::Range { min: 5.0, max: 5.0 }.validate().is_err());
        assert!(LodMode::Ratio(1.5).validate().is_err());
        assert!(
            LodMode::PixelSize {
                full_detail_px: 10.0,
                freeze_below_px: 20.0
            }
            .validate()
            .is_err()
        );
    }
}
