//! Solver settings (time step, substeps, iterations, gravity, damping) and the link material.
//!
//! # Compliance formulation (why links keep the material across resolutions)
//!
//! Links are XPBD distance constraints `C = |x_b - x_a| - rest` with compliance `α`
//! (inverse stiffness, `α = 1/k`). What must stay the same when the cloth is coarser or finer
//! is the *material*, not the per-link stiffness, and the right scaling depends on the
//! dimension the link network discretises:
//!
//! * **Membrane (2D, cloth — the default).** Stretch a lattice of spacing `h` by a strain `ε`
//!   across a width `W`: `W/h` links carry the load, each stretched by `ε·h`, so the force is
//!   `(W/h)·k·ε·h = W·k·ε`. The sheet modulus (force per width per strain) is `k` itself,
//!   independent of `h`. So a self-similar lattice (a grid and every level of its quadtree,
//!   with the same 8-neighbourhood topology) has the same membrane stiffness when every link
//!   has the **same compliance**, whatever its rest length. Masses add up the hierarchy, so
//!   the areal density is the same too, hence equal sag and equal wave speed `sqrt(k/ρ)`.
//! * **Chain (1D, ropes).** `n` springs of length `l/n` in series must stretch like one spring
//!   of length `l`: compliances add, so `α = c·rest` (compliance per unit rest length).
//!
//! Giving cloth the chain scaling would make a cut two levels coarser four times softer,
//! which is exactly the "different material" the issue warns about, so cloth uses the
//! membrane rule. Both are available through [`ComplianceScaling`].
//!
//! One caveat no formulation removes: with a fixed iteration count a stiff (`α ≈ 0`) cloth is
//! limited by convergence, and a coarse cloth converges faster than a fine one. A material
//! whose compliance is not negligible against `h²/(iterations·m)` behaves the same at every
//! resolution; an "infinitely stiff" one is as stiff as the iterations make it.

use crate::error::SoftBodyError;
use glam::Vec3;

/// How a link's compliance follows from the material compliance and the link's rest length.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ComplianceScaling {
    /// 2D sheets (cloth): every link gets the material compliance unchanged, which keeps the
    /// sheet modulus of self-similar lattices independent of their spacing (see the crate docs).
    #[default]
    Membrane,
    /// 1D chains: compliance is per unit rest length (`α = c · rest`), so links in series add up.
    Chain,
}

/// The material of a set of links: compliances (inverse stiffnesses) and how they scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Compliance of stretch links (structural, shear, triangle edges) in m/N
    /// (per metre of rest length for [`ComplianceScaling::Chain`]). 0 = as stiff as the
    /// iterations allow.
    pub stretch_compliance: f32,
    /// Compliance of bend links (distance-2 links).
    pub bend_compliance: f32,
    /// How compliance scales with rest length.
    pub scaling: ComplianceScaling,
}

/// The default material is as stiff as the iterations allow (both compliances 0), what a plain
/// cloth compared with other solvers uses. The TreeCut cloth's measured-good material is
/// [`crate::TreeCutSettings`]'s default, which is resolution-consistent.
impl Default for Material {
    fn default() -> Self {
        Self {
            stretch_compliance: 0.0,
            bend_compliance: 0.0,
            scaling: ComplianceScaling::Membrane,
        }
    }
}

impl Material {
    /// Compliance of one stretch link of the given rest length.
    #[inline]
    pub fn stretch(&self, rest: f32) -> f32 {
        self.scale(self.stretch_compliance, rest)
    }
    /// Compliance of one bend link of the given rest length.
    #[inline]
    pub fn bend(&self, rest: f32) -> f32 {
        self.scale(self.bend_compliance, rest)
    }
    #[inline]
    fn scale(&self, c: f32, rest: f32) -> f32 {
        match self.scaling {
            ComplianceScaling::Membrane => c,
            ComplianceScaling::Chain => c * rest,
        }
    }
    /// Checks that both compliances are finite and not negative.
    pub fn validate(&self) -> Result<(), SoftBodyError> {
        for (what, v) in [
            ("stretch_compliance", self.stretch_compliance),
            ("bend_compliance", self.bend_compliance),
        ] {
            if !v.is_finite() || v < 0.0 {
                return Err(SoftBodyError::BadLinkParameter { what, value: v });
            }
        }
        Ok(())
    }
}

/// Time stepping of the solver. One [`crate::SoftBody::step`] advances `dt`, split into
/// `substeps`, each running `iterations` sweeps over all links.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverSettings {
    /// Time advanced by one step, in seconds (> 0).
    pub dt: f32,
    /// Substeps per step (>= 1). More substeps converge stiffer than more iterations.
    pub substeps: u32,
    /// Constraint sweeps per substep (>= 1).
    pub iterations: u32,
    /// Gravity acceleration, m/s².
    pub gravity: Vec3,
    /// Velocity damping rate in 1/s: velocities decay by `exp(-damping·dt)` per step,
    /// independent of how the step is split.
    pub damping: f32,
    /// Threads for one large body: a colour batch with at least this many links is split into
    /// one run of links per thread of the caller's rayon pool (`rayon::current_num_threads()`;
    /// install a pool to choose), and when any batch is, the per-particle loops (prediction,
    /// velocity update) are split too. 0 = always on the calling thread; batches under 32 links
    /// (two blocks) are never split. Results are the same
    /// bits whatever the threads (see the crate docs, *threads*).
    pub parallel_min_links: u32,
}

/// The defaults are the values the swinging-net experiment measured good, chosen so that a
/// comparison between resolutions measures level of detail and not solver artefacts:
///
/// * 32 substeps of one iteration at 60 Hz: small steps converge better than many iterations
///   at the same cost (Macklin et al., "Small Steps in Physics Simulation", 2019), and level
///   of detail needs a *converged* solver: Gauss–Seidel XPBD with too few sweeps is softer the
///   more nodes it has (a coarse cut converges further per sweep), so a coarse cut and the
///   full cloth become different materials. Measured on the swinging net (2 m, 1 kg, 240
///   steps): the centre sagged 0.467 / 0.526 / 0.678 m on 33² / 65² / 129² nets at 16
///   substeps and 0.454 / 0.479 / 0.513 m at 64; the feedback loop at 30 % of the nodes
///   measured 3.6 px on-screen RMS against its reference at 16 substeps, 1.8 px at 32 and
///   2.0 px at 48 (the perception `net` scene; the off-screen scene 8.3, 4.1 and 4.3 px). 32 is
///   where that error stopped falling; a step costs twice what it did at 16, the reference's
///   too.
/// * `parallel_min_links` 4096 ([`SolverSettings::DEFAULT_PARALLEL_MIN_LINKS`]): a batch of 4096
///   links is about 8 µs of work on one core (about 2 ns per link), and sharing one batch out
///   costs about 0.2–0.7 µs, so a split batch keeps its synchronisation under a tenth of its
///   work. Bullet-style cloths of 129² (about 8,300 links per colour) and more are split, 65²
///   (2,100) and the paper's 4266-node net (2,100) stay on one thread. Measured (`step` bench,
///   `threads/…`, 20 iterations, 1 vs 2 threads, in a window where two independent bodies ran
///   1.92× as fast as one): 129² 1.47×, 257² 1.73×, 65² unsplit 1.00×. With 32 substeps of one
///   iteration (this default) 129² gained only about 1.1×: each substep starts its own team
///   and splits its particle loops with `rayon`, which a step pays 32 times. Only pays where the
///   pool's threads have cores to themselves (see the crate docs, *threads*).
/// * Damping 2/s: air drag on a light cloth. A linearised quadratic drag `½ρ c_d A v / m` with
///   `ρ` = 1.2 kg/m³, `c_d` ≈ 1, 4 m² and 1 kg gives 2.4/s at 1 m/s. Without drag a swing
///   goes on for many seconds and every comparison measures mostly phase drift between
///   discretisations.
impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            dt: 1.0 / 60.0,
            substeps: 32,
            iterations: 1,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            damping: 2.0,
            parallel_min_links: Self::DEFAULT_PARALLEL_MIN_LINKS,
        }
    }
}

impl SolverSettings {
    /// The default [`SolverSettings::parallel_min_links`]: see `Default`.
    pub const DEFAULT_PARALLEL_MIN_LINKS: u32 = 4096;

    /// Checks every field; a bad one is named in the error.
    pub fn validate(&self) -> Result<(), SoftBodyError> {
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(SoftBodyError::BadSetting("dt must be finite and > 0"));
        }
        if self.substeps == 0 {
            return Err(SoftBodyError::BadSetting("substeps must be >= 1"));
        }
        if self.iterations == 0 {
            return Err(SoftBodyError::BadSetting("iterations must be >= 1"));
        }
        if !self.gravity.is_finite() {
            return Err(SoftBodyError::BadSetting("gravity must be finite"));
        }
        if !(self.damping.is_finite() && self.damping >= 0.0) {
            return Err(SoftBodyError::BadSetting("damping must be finite and >= 0"));
        }
        Ok(())
    }
}
