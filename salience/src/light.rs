//! The illumination term `Illu(ωL, x)` of eq. (1): a Lambertian light whose factor multiplies
//! the animation features. Dark regions hide motion detail; the ambient part keeps shadowed
//! surfaces from dropping to zero, since they are still seen.

use glam::Vec3;

use crate::curves::check;
use crate::error::SalienceError;

/// Where the light comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightSource {
    /// A light at infinity (the sun); `towards_light` points from the surface to the light and
    /// need not be unit length (it is normalised once per evaluation).
    Directional {
        /// Direction from the surface toward the light. Non-zero.
        towards_light: Vec3,
    },
    /// A point light at `position` (world units); the direction is taken per node.
    Point {
        /// Position of the light.
        position: Vec3,
    },
}

/// A Lambertian light: `Illu = ambient + diffuse · max(0, n · l)` with `n` the unit surface
/// normal and `l` the unit direction to the light (for two-sided surfaces `n` is first flipped
/// toward the eye, see [`crate::Sidedness`]). `ambient + diffuse ≤ 1` so the factor stays in
/// [0, 1] and the BSWDF in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Where the light comes from.
    pub source: LightSource,
    /// Illumination of a surface facing away from the light, in [0, 1].
    pub ambient: f32,
    /// Extra illumination of a surface facing the light head-on, in [0, 1 − ambient].
    pub diffuse: f32,
}

impl Light {
    /// A directional light with the given ambient and diffuse parts.
    pub fn directional(towards_light: Vec3, ambient: f32, diffuse: f32) -> Self {
        Self {
            source: LightSource::Directional { towards_light },
            ambient,
            diffuse,
        }
    }

    /// A point light with the given ambient and diffuse parts.
    pub fn point(position: Vec3, ambient: f32, diffuse: f32) -> Self {
        Self {
            source: LightSource::Point { position },
            ambient,
            diffuse,
        }
    }

    /// Checks the light: finite, a non-zero direction, both parts ≥ 0 and their sum ≤ 1.
    pub fn validate(&self) -> Result<(), SalienceError> {
        match self.source {
            LightSource::Directional { towards_light } => {
                if !towards_light.is_finite() || towards_light.length_squared() <= 1.0e-12 {
                    return Err(SalienceError::InvalidLight);
                }
            }
            LightSource::Point { position } => {
                if !position.is_finite() {
                    return Err(SalienceError::InvalidLight);
                }
            }
        }
        check(
            "light.ambient",
            self.ambient,
            self.ambient >= 0.0,
            "finite and >= 0",
        )?;
        check(
            "light.diffuse",
            self.diffuse,
            self.diffuse >= 0.0,
            "finite and >= 0",
        )?;
        // A little slack so that 0.3 + 0.7 passes despite rounding.
        check(
            "light.ambient + light.diffuse",
            self.ambient + self.diffuse,
            self.ambient + self.diffuse <= 1.0 + 1.0e-6,
            "<= 1",
        )
    }
}
