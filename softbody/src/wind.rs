//! Wind: a velocity field with seeded gusts, and the aerodynamic force it puts on a patch of
//! cloth (drag and lift, proportional to the patch's area).
//!
//! Based on: Keckeisen, Kimmerle, Thomaszewski, Wacker, "Modelling Effects of Wind Fields in
//! Cloth Animations", 2004 (per-element drag along the relative air velocity and lift across
//! it, both scaling with area × relative speed² and with the element's orientation), and the
//! sum-of-sines gust model common in games (several travelling waves of seeded direction,
//! wavelength and phase).
//!
//! # Force on a patch
//! With `u` the air velocity relative to the patch, `û = u/|u|`, `n` the patch normal and
//! `c = n·û`, air density `ρ` and area `A`:
//! * drag `½ ρ C_d A |u|² |c| û` — along the flow, from the area the flow sees;
//! * lift `½ ρ C_l A |u|² c (n − c û)` — across the flow, in the plane of `n` and `û`, zero
//!   when the patch faces the flow or lies along it.
//!
//! Both are unchanged when `n` flips, so a two-sided cloth needs no oriented normals. The
//! force is linear in `A`: a coarse node carrying the area of every finest triangle it covers
//! feels the force those triangles would (exactly so while they share its normal and velocity).

use glam::Vec3;

/// A wind field: a mean velocity with travelling gusts, and the air's aerodynamic constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindField {
    /// Mean air velocity, m/s.
    pub velocity: Vec3,
    /// Gust strength as a fraction of the mean speed (RMS of the gust term; 0 = steady).
    pub gust: f32,
    /// Mean gust frequency, Hz.
    pub gust_frequency: f32,
    /// Mean gust wavelength, metres (how far apart gust fronts travel).
    pub gust_wavelength: f32,
    /// Seed of the gusts' directions, wavelengths and phases.
    pub seed: u64,
    /// Air density, kg/m³.
    pub air_density: f32,
    /// Drag coefficient `C_d` of the cloth.
    pub drag: f32,
    /// Lift coefficient `C_l` of the cloth.
    pub lift: f32,
}

/// No wind; with gusts of 30% at 0.5 Hz and 4 m wavelength once a velocity is set; air at sea
/// level (1.2 kg/m³); a flat plate's drag coefficient (about 1 face-on) and a lift coefficient
/// of 0.5 (thin cambered fabric at moderate angles of attack).
impl Default for WindField {
    fn default() -> Self {
        WindField {
            velocity: Vec3::ZERO,
            gust: 0.3,
            gust_frequency: 0.5,
            gust_wavelength: 4.0,
            seed: 1,
            air_density: 1.2,
            drag: 1.0,
            lift: 0.5,
        }
    }
}

/// The number of travelling waves summed for the gusts.
const WAVES: usize = 4;

/// One travelling wave of the gust sum.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Wave {
    /// Wave vector (direction / wavelength) times 2π.
    k: Vec3,
    /// Angular frequency.
    omega: f32,
    phase: f32,
    /// Which velocity component it modulates: along the mean (0) or across it (1).
    across: bool,
}

/// splitmix64: a seeded stream of well-mixed numbers.
fn mix(state: &mut u64) -> f32 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 24) as f32
}

/// A validated wind field with its gust waves drawn from the seed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wind {
    field: WindField,
    waves: [Wave; WAVES],
    across: Vec3,
    /// `|field.velocity|`, computed once: every particle's gust scales with it.
    speed: f32,
}

/// Why a wind field was refused.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("invalid wind field: {0}")]
pub struct WindError(pub &'static str);

impl Wind {
    /// Validates `field` and draws its gust waves.
    pub fn new(field: WindField) -> Result<Wind, WindError> {
        if !field.velocity.is_finite() {
            return Err(WindError("velocity must be finite"));
        }
        for (v, what) in [
            (field.gust, "gust must be finite and >= 0"),
            (field.air_density, "air density must be finite and >= 0"),
            (field.drag, "drag must be finite and >= 0"),
            (field.lift, "lift must be finite and >= 0"),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(WindError(what));
            }
        }
        if !(field.gust_frequency.is_finite() && field.gust_frequency > 0.0) {
            return Err(WindError("gust frequency must be finite and > 0"));
        }
        if !(field.gust_wavelength.is_finite() && field.gust_wavelength > 0.0) {
            return Err(WindError("gust wavelength must be finite and > 0"));
        }
        let mut s = field.seed;
        let tau = std::f32::consts::TAU;
        let mut waves = [Wave::default(); WAVES];
        for (i, w) in waves.iter_mut().enumerate() {
            // Directions spread around the mean, wavelengths and frequencies within ×/÷ 2.
            let angle = tau * mix(&mut s);
            let dir = Vec3::new(angle.cos(), 0.3 * (mix(&mut s) - 0.5), angle.sin()).normalize();
            let scale = 2f32.powf(2.0 * mix(&mut s) - 1.0);
            w.k = dir * (tau / (field.gust_wavelength * scale));
            w.omega = tau * field.gust_frequency * 2f32.powf(2.0 * mix(&mut s) - 1.0);
            w.phase = tau * mix(&mut s);
            w.across = i % 2 == 1;
        }
        let along = field.velocity.normalize_or(Vec3::X);
        let across = along.cross(Vec3::Y).normalize_or(Vec3::Z);
        Ok(Wind {
            field,
            waves,
            across,
            speed: field.velocity.length(),
        })
    }

    /// The field it was made from.
    pub fn field(&self) -> &WindField {
        &self.field
    }

    /// Air velocity at `x` at time `t` seconds: the mean plus gusts along it and across it, each
    /// a sum of travelling sines whose RMS is `gust × mean speed`.
    pub fn velocity_at(&self, x: Vec3, t: f32) -> Vec3 {
        let speed = self.speed;
        if self.field.gust == 0.0 || speed == 0.0 {
            return self.field.velocity;
        }
        // Two waves per component, each of amplitude 1: RMS of the sum is 1.
        let (mut along, mut across) = (0f32, 0f32);
        for w in &self.waves {
            let s = (w.omega * t - w.k.dot(x) + w.phase).sin();
            if w.across {
                across += s;
            } else {
                along += s;
            }
        }
        let g = self.field.gust * speed;
        self.field.velocity * (1.0 + self.field.gust * along) + self.across * (g * across)
    }

    /// Aerodynamic force on a patch of `area` m² with unit normal `normal` (either side) moving
    /// at `velocity` in air moving at `air` (see the module docs).
    #[inline]
    pub fn force(&self, area: f32, normal: Vec3, velocity: Vec3, air: Vec3) -> Vec3 {
        let u = air - velocity;
        let speed2 = u.length_squared();
        if speed2 < 1e-12 {
            return Vec3::ZERO;
        }
        let uh = u / speed2.sqrt();
        let c = normal.dot(uh);
        let q = 0.5 * self.field.air_density * area * speed2;
        uh * (q * self.field.drag * c.abs()) + (normal - uh * c) * (q * self.field.lift * c)
    }
}

/// The triangles of a `cols × rows` grid of vertices `j * cols + i`, two per cell (for the
/// wind's areas on a grid cloth).
pub fn grid_triangles(cols: u32, rows: u32) -> Vec<[u32; 3]> {
    let mut t = Vec::with_capacity(2 * (cols.saturating_sub(1) * rows.saturating_sub(1)) as usize);
    for j in 0..rows.saturating_sub(1) {
        for i in 0..cols.saturating_sub(1) {
            let a = j * cols + i;
            let (b, c, d) = (a + 1, a + cols, a + cols + 1);
            t.push([a, b, d]);
            t.push([a, d, c]);
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drag_and_lift_follow_the_plate() {
        let w = Wind::new(WindField {
            velocity: Vec3::new(10.0, 0.0, 0.0),
            gust: 0.0,
            ..WindField::default()
        })
        .unwrap();
        // Face-on: pure drag ½ρ C_d A |u|² along the flow, no lift.
        let f = w.force(2.0, Vec3::X, Vec3::ZERO, w.velocity_at(Vec3::ZERO, 0.0));
        assert!(f.abs_diff_eq(Vec3::new(120.0, 0.0, 0.0), 1e-3));
        // Edge-on: nothing.
        let f = w.force(2.0, Vec3::Y, Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0));
        assert!(f.length() < 1e-4);
        // Tilted 45°: lift across the flow, the same for either side's normal.
        let n = Vec3::new(1.0, 1.0, 0.0).normalize();
        let a = w.force(1.0, n, Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0));
        let b = w.force(1.0, -n, Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0));
        assert!(a.abs_diff_eq(b, 1e-4) && a.y > 0.0 && a.x > 0.0);
        // Moving with the air: nothing.
        assert_eq!(
            w.force(1.0, Vec3::X, Vec3::X * 10.0, Vec3::X * 10.0),
            Vec3::ZERO
        );
    }

    #[test]
    fn gusts_are_seeded_and_about_the_asked_strength() {
        let field = WindField {
            velocity: Vec3::new(5.0, 0.0, 0.0),
            gust: 0.3,
            ..WindField::default()
        };
        let a = Wind::new(field).unwrap();
        let b = Wind::new(field).unwrap();
        let c = Wind::new(WindField { seed: 9, ..field }).unwrap();
        let x = Vec3::new(0.3, 1.0, -2.0);
        assert_eq!(a.velocity_at(x, 1.7), b.velocity_at(x, 1.7));
        assert_ne!(a.velocity_at(x, 1.7), c.velocity_at(x, 1.7));
        let n = 4000;
        let mut sum = 0f64;
        for i in 0..n {
            let d = a.velocity_at(x, i as f32 * 0.037) - field.velocity;
            sum += d.length_squared() as f64;
        }
        let rms = (sum / n as f64).sqrt() as f32;
        // Two components of RMS 0.3 × 5 each: about 2.1 m/s.
        assert!((rms - 2.12).abs() < 0.5, "gust RMS {rms}");
        assert!(
            Wind::new(WindField {
                gust: -1.0,
                ..field
            })
            .is_err()
        );
        assert!(
            Wind::new(WindField {
                velocity: Vec3::NAN,
                ..field
            })
            .is_err()
        );
    }

    #[test]
    fn grid_triangles_cover_the_grid() {
        let t = grid_triangles(3, 2);
        assert_eq!(t, vec![[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]]);
    }
}
