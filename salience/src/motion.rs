//! The object's own motion and the two global terms of eq. (2) it produces: the base salience a
//! moving object earns and the inspection cap it imposes on local motion.

use glam::Vec3;

use crate::error::SalienceError;
use crate::params::BswdfParams;
use crate::view::View;

/// The object as a whole: a reference point and its velocity (typically the centre of mass and
/// the centre-of-mass velocity). World units and world units per second.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ObjectMotion {
    /// Where the object is (its centre).
    pub centre: Vec3,
    /// How fast the object as a whole moves.
    pub velocity: Vec3,
}

impl ObjectMotion {
    /// The unweighted mean position and velocity of the nodes (equal masses). Zero for no nodes.
    pub fn mean_of(positions: &[Vec3], velocities: &[Vec3]) -> Result<Self, SalienceError> {
        if velocities.len() != positions.len() {
            return Err(SalienceError::LengthMismatch {
                what: "velocities",
                expected: positions.len(),
                found: velocities.len(),
            });
        }
        if positions.is_empty() {
            return Ok(Self::default());
        }
        let (sp, sv) = positions
            .iter()
            .zip(velocities)
            .fold((Vec3::ZERO, Vec3::ZERO), |(sp, sv), (p, v)| {
                (sp + *p, sv + *v)
            });
        let inv = 1.0 / positions.len() as f32;
        Ok(Self {
            centre: sp * inv,
            velocity: sv * inv,
        })
    }

    /// The centre of mass and its velocity (mass-weighted means). Zero if the total mass is not
    /// a positive finite number.
    pub fn centre_of_mass(
        positions: &[Vec3],
        velocities: &[Vec3],
        masses: &[f32],
    ) -> Result<Self, SalienceError> {
        for (what, len) in [("velocities", velocities.len()), ("masses", masses.len())] {
            if len != positions.len() {
                return Err(SalienceError::LengthMismatch {
                    what,
                    expected: positions.len(),
                    found: len,
                });
            }
        }
        let (sp, sv, sm) = positions.iter().zip(velocities).zip(masses).fold(
            (Vec3::ZERO, Vec3::ZERO, 0.0f32),
            |(sp, sv, sm), ((p, v), m)| (sp + *p * *m, sv + *v * *m, sm + m),
        );
        if !sm.is_finite() || sm <= 0.0 {
            return Ok(Self::default());
        }
        Ok(Self {
            centre: sp / sm,
            velocity: sv / sm,
        })
    }
}

/// The global-motion terms of one evaluation, returned so callers can log or reuse them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlobalMotion {
    /// The object's retinal angular speed, degrees per second.
    pub angular_speed_deg_per_s: f32,
    /// Base salience every node of the object receives for the object's motion, in
    /// [0, `global_base_max`].
    pub base: f32,
    /// Upper bound on the local-motion response, in [`global_cap.floor`, 1].
    ///
    /// [`global_cap.floor`]: crate::PursuitCap::floor
    pub cap: f32,
}

impl GlobalMotion {
    /// The global terms for `object` seen by `view`. Parameters are assumed valid.
    pub fn new(view: &View, object: &ObjectMotion, params: &BswdfParams) -> Self {
        let omega = view
            .angular_speed(object.centre, object.velocity)
            .to_degrees()
            * params.display_angle_scale;
        Self {
            angular_speed_deg_per_s: omega,
            base: params.global_base_max * params.global_base.response(omega),
            cap: params.global_cap.cap(omega),
        }
    }

    /// Combines a local-motion response `local` ∈ [0, 1] with the global terms (the ⊗ of eq. 2):
    /// `base + (1 − base) · min(local, cap)`, in [0, 1].
    ///
    /// A hard clamp, as the paper says: above the inspection limit differences in local motion
    /// cannot be told apart, so they honestly tie. The base term is added on top, scaled so the
    /// sum stays ≤ 1.
    #[inline]
    pub fn combine(&self, local: f32) -> f32 {
        self.base + (1.0 - self.base) * local.min(self.cap)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_are_weighted_correctly() {
        let p = [Vec3::ZERO, Vec3::X * 2.0];
        let v = [Vec3::Y, Vec3::Y * 3.0];
        let m = ObjectMotion::mean_of(&p, &v).unwrap();
        assert_eq!(m.centre, Vec3::X);
        assert_eq!(m.velocity, Vec3::Y * 2.0);
        let c = ObjectMotion::centre_of_mass(&p, &v, &[3.0, 1.0]).unwrap();
        assert!((c.centre - Vec3::X * 0.5).length() < 1e-6);
        assert!((c.velocity - Vec3::Y * 1.5).length() < 1e-6);
        assert!(ObjectMotion::mean_of(&p, &v[..1]).is_err());
        assert!(ObjectMotion::centre_of_mass(&p, &v, &[1.0]).is_err());
    }

    #[test]
    fn faster_object_lower_cap_higher_base() {
        let cam = View::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 640, 480).unwrap();
        let params = BswdfParams::default();
        let at = |speed: f32| {
            GlobalMotion::new(
                &cam,
                &ObjectMotion {
                    centre: Vec3::new(0.0, 0.0, -5.0),
                    velocity: Vec3::X * speed,
                },
                &params,
            )
        };
        let (still, slow, fast) = (at(0.0), at(1.0), at(10.0));
        assert_eq!(still.base, 0.0);
        assert_eq!(still.cap, 1.0);
        assert!(slow.base > 0.0 && fast.base > slow.base);
        assert!(fast.cap < slow.cap && slow.cap < 1.0);
        for g in [still, slow, fast] {
            for l in [0.0, 0.3, 1.0] {
                let a = g.combine(l);
                assert!((0.0..=1.0).contains(&a));
            }
        }
        // A still node on a moving object beats a still node on a still object.
        assert!(slow.combine(0.0) > still.combine(0.0));
    }
}
