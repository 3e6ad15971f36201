//! The perceptual transfer curves of the BSWDF: how strongly a viewer responds to a motion of a
//! given angular speed, and how far a moving object can still be inspected.
//!
//! All speeds are retinal angular speeds in **degrees per second** of visual angle, the unit of
//! the psychophysics they are modelled on. Each curve is a rational function (no `exp`), so the
//! BSWDF's per-node cost stays a handful of flops.

use crate::error::SalienceError;

/// A thresholded saturating response (a Naka–Rushton / Michaelis–Menten curve, the standard
/// model of how visual neurons respond to increasing stimulus strength):
///
/// ```text
/// m = max(0, speed − threshold)
/// R(speed) = m / (m + half_saturation)        ∈ [0, 1)
/// ```
///
/// Below `threshold` a motion is not seen at all (R = 0); just above it the response grows
/// linearly with slope `1 / half_saturation`; at `threshold + half_saturation` it is 0.5 and it
/// saturates toward 1, because a viewer who already notices a motion is not twice as drawn to
/// one twice as fast (speed discrimination follows Weber's law).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResponseCurve {
    /// Speed below which the motion is invisible, in degrees per second. ≥ 0.
    pub threshold_deg_per_s: f32,
    /// Speed above the threshold at which the response reaches one half, in degrees per
    /// second. > 0.
    pub half_saturation_deg_per_s: f32,
}

impl ResponseCurve {
    /// The response to a motion of `speed_deg_per_s`, in [0, 1).
    #[inline]
    pub fn response(&self, speed_deg_per_s: f32) -> f32 {
        let m = (speed_deg_per_s - self.threshold_deg_per_s).max(0.0);
        m / (m + self.half_saturation_deg_per_s)
    }

    pub(crate) fn validate(
        &self,
        threshold_name: &'static str,
        half_name: &'static str,
    ) -> Result<(), SalienceError> {
        check(
            threshold_name,
            self.threshold_deg_per_s,
            self.threshold_deg_per_s >= 0.0,
            "finite and >= 0",
        )?;
        check(
            half_name,
            self.half_saturation_deg_per_s,
            self.half_saturation_deg_per_s > 0.0,
            "finite and > 0",
        )
    }
}

/// The inspection limit set by the object's own motion (the ⊗ of eq. 2): local motion is
/// clamped to
///
/// ```text
/// U(ω) = floor + (1 − floor) / (1 + (ω / half_speed)²)     ∈ [floor, 1]
/// ```
///
/// where ω is the object's angular speed. A still object can be inspected fully (U = 1). The eye
/// follows a moving object with smooth pursuit, whose gain stays near 1 up to a few tens of
/// degrees per second and then falls, so retinal slip grows and dynamic visual acuity drops;
/// the curve is flat near 0 (slow pursuit costs nothing), halves at `half_speed` and decays
/// like 1/ω² beyond. `floor` keeps a residual ranking for very fast objects, since their
/// silhouette and gross deformation remain visible.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PursuitCap {
    /// Object angular speed at which the cap falls half-way to `floor`, in degrees per second.
    /// > 0.
    pub half_speed_deg_per_s: f32,
    /// The lowest the cap goes, for arbitrarily fast objects. In [0, 1].
    pub floor: f32,
}

impl PursuitCap {
    /// The upper bound on local-motion salience for an object moving at `speed_deg_per_s`.
    #[inline]
    pub fn cap(&self, speed_deg_per_s: f32) -> f32 {
        let x = speed_deg_per_s.max(0.0) / self.half_speed_deg_per_s;
        self.floor + (1.0 - self.floor) / (1.0 + x * x)
    }

    pub(crate) fn validate(&self) -> Result<(), SalienceError> {
        check(
            "global_cap.half_speed_deg_per_s",
            self.half_speed_deg_per_s,
            self.half_speed_deg_per_s > 0.0,
            "finite and > 0",
        )?;
        check(
            "global_cap.floor",
            self.floor,
            (0.0..=1.0).contains(&self.floor),
            "in [0, 1]",
        )
    }
}

/// Rejects a non-finite value or one that fails `ok`.
pub(crate) fn check(
    name: &'static str,
    value: f32,
    ok: bool,
    expected: &'static str,
) -> Result<(), SalienceError> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(SalienceError::InvalidParameter {
            name,
            value,
            expected,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn response_is_thresholded_saturating_and_monotone() {
        let r = ResponseCurve {
            threshold_deg_per_s: 0.1,
            half_saturation_deg_per_s: 1.0,
        };
        assert_eq!(r.response(0.0), 0.0);
        assert_eq!(r.response(0.1), 0.0);
        assert!((r.response(1.1) - 0.5).abs() < 1e-6);
        assert!(r.response(1e6) < 1.0 && r.response(1e6) > 0.999);
        let mut last = 0.0;
        for i in 0..1000 {
            let v = r.response(i as f32 * 0.05);
            assert!(v >= last);
            last = v;
        }
    }

    #[test]
    fn cap_decreases_from_one_to_floor() {
        let c = PursuitCap {
            half_speed_deg_per_s: 30.0,
            floor: 0.2,
        };
        assert_eq!(c.cap(0.0), 1.0);
        assert!((c.cap(30.0) - 0.6).abs() < 1e-6);
        assert!(c.cap(1e6) >= 0.2 && c.cap(1e6) < 0.2001);
        assert!(c.cap(10.0) > c.cap(20.0));
    }

    #[test]
    fn validation_rejects_nan_and_out_of_range() {
        let bad = ResponseCurve {
            threshold_deg_per_s: f32::NAN,
            half_saturation_deg_per_s: 1.0,
        };
        assert!(bad.validate("t", "h").is_err());
        let bad = ResponseCurve {
            threshold_deg_per_s: 0.0,
            half_saturation_deg_per_s: 0.0,
        };
        assert!(bad.validate("t", "h").is_err());
        let bad = PursuitCap {
            half_speed_deg_per_s: 1.0,
            floor: 1.5,
        };
        assert!(bad.validate().is_err());
    }
}
