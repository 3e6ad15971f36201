//! Colliders: planes, spheres, capsules and oriented boxes the cloth rests on, slides over and
//! wraps around, with a thickness and Coulomb friction; static, or kinematic (the host moves
//! them every step and their surface velocity drives friction).
//!
//! Based on: Macklin, Müller, Chentanez, "XPBD: Position-Based Simulation of Compliant
//! Constrained Dynamics", 2016 (contacts as stiff inequality constraints projected once per
//! substep); friction as in Macklin, Müller, Chentanez, Kim, "Unified Particle Physics for
//! Real-Time Applications", 2014, section 6.1 (position-level static and kinetic friction
//! from the relative tangential displacement, bounded by the normal correction); and the
//! simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), sections 3.3–3.4 (new
//! TreeCut nodes join collision when their operation ends).
//!
//! # Contact
//! A particle `i` with collision radius `r_i` touches collider `c` when the signed distance `d`
//! of its predicted position to the shape is below `thickness + r_i`; the projection moves it
//! out along the shape normal `n` by the depth `δ = thickness + r_i − d` (an XPBD constraint
//! of compliance 0, so its λ is the depth itself). Friction then looks at the particle's motion
//! over the substep relative to the collider's surface point under it, tangential part `Δt`:
//! if `|Δt| < μ δ` it is removed (static friction), else shortened by `μ δ` (kinetic). Resting
//! on a slope of angle θ under gravity gives `δ = g cos θ h²` and `|Δt| = g sin θ h²` per
//! substep, so the cloth holds exactly while `tan θ < μ`.
//!
//! A coarse TreeCut node's radius covers its children (the paper's collision shapes), so a
//! coarse cloth cannot slip past a collider thinner than its node spacing; the price is that
//! it rests up to that radius above a surface. A disc across the node's normal was tried
//! instead (no hovering on flat surfaces) and let a coarse cloth slide off a thin capsule: a
//! disc slicing a thin shape is pushed sideways, never up. The adaptive cloth refines nodes in
//! contact instead, where the radii shrink to zero.
//!
//! # Broad phase and cost
//! Once per step each collider's bounds, swept from where it starts to where the host moves
//! it and grown by thickness, the largest particle radius and the largest distance a particle
//! can travel in the step, is tested against the bounds of the colliding particles; a collider
//! that misses them is skipped for the whole step. One that overlaps keeps the particles inside
//! its grown bounds whose distance to the shape is within reach: thickness, the particle's
//! radius, its travel and the sweep of the shape's surface during the step (translation plus
//! rotation angle times the shape's extent bound how much the distance can change). The substeps only test those candidates, so a collider
//! costs what it touches. Candidate lists are reused buffers: no allocation per step once warm.
//! Everything runs in a fixed order (colliders by slot, particles by index): deterministic.

mod shape;
#[cfg(test)]
mod tests;

pub use shape::{Shape, Transform};

use shape::Placed;

use crate::error::SoftBodyError;
use crate::kernel::Particles;
use glam::{Vec3, Vec3A, Vec4};
use slod_core::{Arena, Handle};

/// The largest speed (m/s, relative to the collider's surface) at which a contact pushes a
/// particle out. Separating a particle that arrived within a substep needs only its approach
/// speed undone; a larger push means it started deep inside (a coarse node's covering radius
/// after a coarse, a collider moved into the cloth), and turning that depth into velocity in one
/// substep would throw the cloth (a 10 cm overlap resolved in 1 ms is 100 m/s). 1 m/s clears
/// such overlaps within a few steps without a visible jump.
pub const MAX_SEPARATION_SPEED: f32 = 1.0;

/// Passes of [`Colliders::push_out`] at most: the first over every point, each later one over
/// the points the one before moved (a point pushed out of one collider into an overlapping
/// one). Two overlapping capsules need two; four leave room for a joint where three meet.
pub const PUSH_OUT_PASSES: usize = 4;

/// Names a collider of a body. Generation-checked: a removed collider's id is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct ColliderId(pub Handle);

/// What a collider is, where it is, and how its surface feels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColliderDesc {
    /// The geometry in the collider's frame.
    pub shape: Shape,
    /// Where the collider is now.
    pub transform: Transform,
    /// Distance in metres the cloth keeps from the surface (the cloth's half thickness plus a
    /// skin); >= 0.
    pub thickness: f32,
    /// Coulomb friction coefficient (static = kinetic), >= 0.
    pub friction: f32,
}

/// A unit sphere at the origin; thickness 5 mm (a few cloth thicknesses: the finest node
/// spacing of a 2 m, 65² cloth is 31 mm, so 5 mm hides the straight edges of its triangles
/// between vertices on a curved collider without visible hovering); friction 0.3 (cotton on
/// plastic or skin is 0.3–0.6).
impl Default for ColliderDesc {
    fn default() -> Self {
        ColliderDesc {
            shape: Shape::Sphere { radius: 0.5 },
            transform: Transform::IDENTITY,
            thickness: 0.005,
            friction: 0.3,
        }
    }
}

impl ColliderDesc {
    /// Checks shape, transform, thickness and friction.
    pub fn validate(&self) -> Result<(), SoftBodyError> {
        self.shape.validate().map_err(SoftBodyError::BadCollider)?;
        if !self.transform.is_valid() {
            return Err(SoftBodyError::BadCollider(
                "collider transform must be finite with a unit rotation",
            ));
        }
        if !(self.thickness.is_finite() && self.thickness >= 0.0) {
            return Err(SoftBodyError::BadCollider(
                "collider thickness must be finite and >= 0",
            ));
        }
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return Err(SoftBodyError::BadCollider(
                "collider friction must be finite and >= 0",
            ));
        }
        Ok(())
    }
}

#[derive(Clone, Debug)]
struct Collider {
    desc: ColliderDesc,
    /// Where the collider was at the start of the step (the desc holds where it ends).
    start: Transform,
    /// Particles inside the grown bounds this step (reused buffer).
    candidates: Vec<u32>,
}

/// Per-particle contact data, parallel to the body's particles.
#[derive(Clone, Debug, Default)]
pub(crate) struct ContactParticles {
    /// Collision radius (0 for a point).
    pub(crate) radius: Vec<f32>,
    /// Whether the particle touched a collider during the last step.
    pub(crate) touched: Vec<bool>,
}

impl ContactParticles {
    pub(crate) fn push(&mut self) {
        self.radius.push(0.0);
        self.touched.push(false);
    }

    pub(crate) fn swap_remove(&mut self, i: usize) {
        self.radius.swap_remove(i);
        self.touched.swap_remove(i);
    }
}

/// The colliders of one body and the contact pass over them.
#[derive(Clone, Debug, Default)]
pub struct Colliders {
    arena: Arena<Collider>,
    /// Wall time of the last step's contact work (broad phase and projections), seconds.
    last_seconds: f64,
    /// The step's length (set by the broad phase).
    step_dt: f32,
}

impl Colliders {
    /// Adds a collider (validated first); it starts where its desc says, at rest.
    pub fn add(&mut self, desc: ColliderDesc) -> Result<ColliderId, SoftBodyError> {
        desc.validate()?;
        Ok(ColliderId(self.arena.insert(Collider {
            desc,
            start: desc.transform,
            candidates: Vec::new(),
        })))
    }

    /// Removes a collider; a stale id is refused.
    pub fn remove(&mut self, id: ColliderId) -> Result<ColliderDesc, SoftBodyError> {
        self.arena
            .remove(id.0)
            .map(|c| c.desc)
            .ok_or(SoftBodyError::StaleCollider)
    }

    /// The collider's description (its transform is where the next step ends).
    pub fn get(&self, id: ColliderId) -> Option<&ColliderDesc> {
        self.arena.get(id.0).map(|c| &c.desc)
    }

    /// Number of colliders.
    pub fn len(&self) -> usize {
        self.arena.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.arena.is_empty()
    }

    /// Every collider with its id, in slot order.
    pub fn iter(&self) -> impl Iterator<Item = (ColliderId, &ColliderDesc)> + '_ {
        self.arena.iter().map(|(h, c)| (ColliderId(h), &c.desc))
    }

    /// Moves a kinematic collider: during the next step it travels from where it is to
    /// `transform` (linearly, rotation by slerp), and friction sees that motion. Call once per
    /// frame. Refused (nothing changed) for a stale id or a non-finite transform.
    pub fn set_transform(
        &mut self,
        id: ColliderId,
        transform: Transform,
    ) -> Result<(), SoftBodyError> {
        if !transform.is_valid() {
            return Err(SoftBodyError::BadCollider(
                "collider transform must be finite with a unit rotation",
            ));
        }
        let c = self
            .arena
            .get_mut(id.0)
            .ok_or(SoftBodyError::StaleCollider)?;
        c.desc.transform = transform;
        Ok(())
    }

    /// Places a collider at `transform` at once, without motion (no friction drag).
    pub fn teleport(&mut self, id: ColliderId, transform: Transform) -> Result<(), SoftBodyError> {
        self.set_transform(id, transform)?;
        if let Some(c) = self.arena.get_mut(id.0) {
            c.start = transform;
        }
        Ok(())
    }

    /// Changes thickness and friction (validated).
    pub fn set_surface(
        &mut self,
        id: ColliderId,
        thickness: f32,
        friction: f32,
    ) -> Result<(), SoftBodyError> {
        let c = self
            .arena
            .get_mut(id.0)
            .ok_or(SoftBodyError::StaleCollider)?;
        let desc = ColliderDesc {
            thickness,
            friction,
            ..c.desc
        };
        desc.validate()?;
        c.desc = desc;
        Ok(())
    }

    /// Wall time of the last step's contact work (broad phase and every substep's projection).
    pub fn last_seconds(&self) -> f64 {
        self.last_seconds
    }

    /// The deepest point of `points` inside any collider's bare shape (thickness not counted),
    /// in metres (0 when nothing penetrates). For measuring what a viewer sees: pass the
    /// reconstructed finest surface.
    pub fn max_penetration(&self, points: &[Vec3]) -> f32 {
        let mut worst = 0f32;
        for (_, c) in self.arena.iter() {
            let t = &c.desc.transform;
            let (lo, hi) = c.desc.shape.bounds(t, 0.0);
            for &p in points {
                let p = Vec3A::from(p);
                if p.cmplt(lo).any() || p.cmpgt(hi).any() {
                    continue;
                }
                let (d, _) = c.desc.shape.distance(t.inverse_apply(p));
                worst = worst.max(-d);
            }
        }
        worst
    }

    /// Moves every point of `points` that is closer to a collider's shape than its thickness
    /// out to that distance, along the shape's normal. For the surface a viewer sees: a coarse
    /// node keeps its particle out of a collider, but the finest vertices placed between
    /// particles held outside a curved collider cut the chord through it; the full-resolution
    /// cloth keeps every vertex at the thickness.
    ///
    /// Colliders are visited in slot order; where two overlap (the capsules of a character's
    /// joints), a point pushed out of one may land inside the other, so the points a pass moved
    /// are checked against every collider again, up to [`PUSH_OUT_PASSES`] passes in all (a
    /// point in the crease of two convex shapes ends on their union's surface, up to what the
    /// last pass left). Points no pass moved are read once per collider, as before.
    pub fn push_out(&self, points: &mut [Vec3]) {
        let mut moved: Vec<u32> = Vec::new();
        self.push_out_pass(points, None, &mut moved);
        let mut again = Vec::new();
        for _ in 1..PUSH_OUT_PASSES {
            if moved.is_empty() {
                break;
            }
            again.clear();
            self.push_out_pass(points, Some(&moved), &mut again);
            std::mem::swap(&mut moved, &mut again);
        }
    }

    /// One pass of [`Colliders::push_out`] over `only` (every point when `None`); the indices
    /// of the points it moved go to `moved` (each once, in increasing order).
    fn push_out_pass(&self, points: &mut [Vec3], only: Option<&[u32]>, moved: &mut Vec<u32>) {
        let hit = |i: usize, moved: &mut Vec<u32>| {
            if moved.last() != Some(&(i as u32)) {
                moved.push(i as u32);
            }
        };
        for (_, c) in self.arena.iter() {
            let t = &c.desc.transform;
            let (lo, hi) = c.desc.shape.bounds(t, c.desc.thickness);
            let placed = Placed::new(&c.desc.shape, t);
            let push = |p: &mut Vec3| {
                let x = Vec3A::from(*p);
                if x.cmplt(lo).any() || x.cmpgt(hi).any() {
                    return false;
                }
                let (d, n) = placed.distance(x);
                let depth = c.desc.thickness - d;
                if depth > 0.0 {
                    *p = Vec3::from(x + n * depth);
                    return true;
                }
                false
            };
            match only {
                None => {
                    for (i, p) in points.iter_mut().enumerate() {
                        if push(p) {
                            hit(i, moved);
                        }
                    }
                }
                Some(only) => {
                    for &i in only {
                        if push(&mut points[i as usize]) {
                            hit(i as usize, moved);
                        }
                    }
                }
            }
        }
        // Several colliders may have moved the same points: each index once, in order.
        moved.sort_unstable();
        moved.dedup();
    }

    /// Broad phase for one step: which colliders may touch which particles (see the module
    /// docs). `reach` is how far a particle can travel in the step.
    pub(crate) fn begin_step(
        &mut self,
        positions: &[Vec4],
        collides: &[bool],
        particles: &mut ContactParticles,
        reach: f32,
        dt: f32,
    ) {
        let started = std::time::Instant::now();
        self.step_dt = dt;
        particles.touched.fill(false);
        let mut lo = Vec3A::splat(f32::INFINITY);
        let mut hi = Vec3A::splat(f32::NEG_INFINITY);
        let mut r_max = 0f32;
        for ((x, &c), &r) in positions.iter().zip(collides).zip(&particles.radius) {
            if c && x.w > 0.0 {
                let p = Vec3A::from_vec4(*x);
                lo = lo.min(p);
                hi = hi.max(p);
                r_max = r_max.max(r);
            }
        }
        for (_, c) in self.arena.iter_mut() {
            c.candidates.clear();
            let margin = c.desc.thickness + r_max + reach;
            let (a_lo, a_hi) = c.desc.shape.bounds(&c.start, margin);
            let (b_lo, b_hi) = c.desc.shape.bounds(&c.desc.transform, margin);
            let (c_lo, c_hi) = (a_lo.min(b_lo), a_hi.max(b_hi));
            if c_lo.cmpgt(hi).any() || c_hi.cmplt(lo).any() {
                continue;
            }
            // How far any surface point moves during the step: the shape's distance function
            // changes by at most this much, so a particle farther than margin + sweep from the
            // shape where it starts cannot touch it during the step.
            let Some(sweep) = c.desc.shape.sweep(&c.start, &c.desc.transform) else {
                // A rotating plane: every particle in the bounds is a candidate.
                for (i, (x, &col)) in positions.iter().zip(collides).enumerate() {
                    let p = Vec3A::from_vec4(*x);
                    if col && x.w > 0.0 && !(p.cmplt(c_lo).any() || p.cmpgt(c_hi).any()) {
                        c.candidates.push(i as u32);
                    }
                }
                continue;
            };
            let reach_all = c.desc.thickness + reach + sweep;
            let placed = Placed::new(&c.desc.shape, &c.start);
            for (i, ((x, &col), &r)) in positions
                .iter()
                .zip(collides)
                .zip(&particles.radius)
                .enumerate()
            {
                let p = Vec3A::from_vec4(*x);
                if !col || x.w == 0.0 || p.cmplt(c_lo).any() || p.cmpgt(c_hi).any() {
                    continue;
                }
                let (d, _) = placed.distance(p);
                if d < reach_all + r {
                    c.candidates.push(i as u32);
                }
            }
        }
        self.last_seconds = started.elapsed().as_secs_f64();
    }

    /// Projects the candidates out of every collider and applies friction, for substep `sub`
    /// of `substeps` (once per substep, after the links; `positions` and `prev` are slices or
    /// the shared views of a threaded step). `prev` holds the positions at the
    /// start of the substep.
    pub(crate) fn project<P: Particles + ?Sized>(
        &mut self,
        sub: u32,
        substeps: u32,
        positions: &mut P,
        prev: &mut P,
        particles: &mut ContactParticles,
    ) {
        let started = std::time::Instant::now();
        let h = self.step_dt / substeps as f32;
        let t0 = sub as f32 / substeps as f32;
        let t1 = (sub + 1) as f32 / substeps as f32;
        for (_, c) in self.arena.iter() {
            if c.candidates.is_empty() {
                continue;
            }
            let moving = c.start != c.desc.transform;
            let (from, to) = if moving {
                (
                    c.start.lerp(&c.desc.transform, t0),
                    if sub + 1 == substeps {
                        c.desc.transform
                    } else {
                        c.start.lerp(&c.desc.transform, t1)
                    },
                )
            } else {
                (c.desc.transform, c.desc.transform)
            };
            let placed = Placed::new(&c.desc.shape, &to);
            let mu = c.desc.friction;
            for &i in &c.candidates {
                let i = i as usize;
                let x = Vec3A::from_vec4(positions.get(i));
                let (d, n) = placed.distance(x);
                let depth = c.desc.thickness + particles.radius[i] - d;
                if depth <= 0.0 {
                    continue;
                }
                particles.touched[i] = true;
                let mut y = x + n * depth;
                // Motion of the surface point under the particle over the substep.
                let surface = if moving {
                    let local = to.inverse_apply(x);
                    to.apply(local) - from.apply(local)
                } else {
                    Vec3A::ZERO
                };
                let start = Vec3A::from_vec4(prev.get(i));
                if mu > 0.0 {
                    let rel = y - start - surface;
                    let tangential = rel - n * n.dot(rel);
                    let len2 = tangential.length_squared();
                    let limit = mu * depth;
                    // Static friction (the common, resting case) needs no square root.
                    if len2 <= limit * limit {
                        y -= tangential;
                    } else {
                        y -= tangential * (limit / len2.sqrt());
                    }
                }
                // Resolving a deep penetration (a coarse node whose radius grew past the
                // surface, a collider teleported into the cloth) must not launch the particle:
                // the outward speed the projection leaves is capped, relative to the surface.
                let outward = n.dot(y - start - surface) - MAX_SEPARATION_SPEED * h;
                if outward > 0.0 {
                    prev.set(i, Vec4::from((start + n * outward, prev.get(i).w)));
                }
                positions.set(i, Vec4::from((y, positions.get(i).w)));
            }
        }
        self.last_seconds += started.elapsed().as_secs_f64();
    }

    /// Ends the step: every collider is now where the host moved it.
    pub(crate) fn end_step(&mut self) {
        for (_, c) in self.arena.iter_mut() {
            c.start = c.desc.transform;
        }
    }
}
