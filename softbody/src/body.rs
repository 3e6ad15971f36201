//! The plain solver: particles in structure-of-arrays form, coloured links, group links,
//! and the fixed-step XPBD integrator.
//!
//! Based on: Macklin, Müller, Chentanez, "XPBD: Position-Based Simulation of Compliant
//! Constrained Dynamics", 2016 (the integrator: predict, project constraints, update
//! velocities from positions); the paper's physics stage is the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), section 3.1.
//!
//! Particle state is `positions[i] = (x, y, z, inverse mass)` and `velocities[i] = (vx, vy, vz, 0)`:
//! keeping the inverse mass in the fourth lane means a link reads everything it needs about
//! a particle from one 16-byte load. Pinned particles have inverse mass 0; their true mass is
//! kept in `masses` for momentum and centroids.

use crate::collide::{Colliders, ContactParticles};
use crate::error::SoftBodyError;
use crate::group::{GroupId, GroupStore, GroupTarget};
use crate::ids::{LinkId, ParticleId};
use crate::kernel::{self, KernelPath};
use crate::kernel::{Particles, SharedParticles};
use crate::links::{LinkInfo, LinkStore};
use crate::settings::SolverSettings;
use crate::team;
use glam::{Vec3, Vec3A, Vec4};
use std::cell::Cell;

/// A kinematic anchor: a pinned particle the host moves; it travels linearly to `target`
/// over the substeps of the next step (so it carries the matching velocity).
#[derive(Clone, Copy, Debug)]
struct Anchor {
    particle: u32,
    start: Vec3A,
    target: Vec3A,
}

impl Anchor {
    /// Where the anchor puts its particle at the end of substep `sub` of `substeps`.
    fn position(&self, sub: u32, substeps: u32) -> Vec3A {
        if sub + 1 == substeps {
            self.target
        } else {
            self.start
                .lerp(self.target, (sub + 1) as f32 / substeps as f32)
        }
    }
}

/// Particle ranges a per-particle phase of a threaded step is cut into per thread (as
/// `links::RUNS_PER_THREAD`: a late thread's share is taken over by the others).
const PARTICLE_RUNS_PER_THREAD: usize = 4;

/// A deterministic XPBD mass-spring body (cloth, rope, any particle/link network).
#[derive(Clone, Debug)]
pub struct SoftBody {
    settings: SolverSettings,
    positions: Vec<Vec4>,
    velocities: Vec<Vec4>,
    masses: Vec<f32>,
    forces: Vec<Vec4>,
    collides: Vec<bool>,
    prev: Vec<Vec4>,
    anchors: Vec<Anchor>,
    links: LinkStore,
    groups: GroupStore,
    kernel: KernelPath,
    colliders: Colliders,
    contact: ContactParticles,
}

fn finite3(v: Vec3, what: &'static str) -> Result<(), SoftBodyError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SoftBodyError::NotFinite { what })
    }
}

/// The per-substep constants of the prediction (see [`SoftBody::step`]) and the passes over
/// the particles that use them.
#[derive(Clone, Copy)]
struct Motion(kernel::MotionConsts);

impl Motion {
    /// Predicts positions from velocities, gravity and external forces (pinned particles keep
    /// still), keeping the start positions in `prev`. Per particle ([`Motion::particle`]), so
    /// any split of the particles gives the same bits.
    fn predict(&self, x: &mut [Vec4], v: &mut [Vec4], f: &[Vec4], prev: &mut [Vec4]) {
        for (((x, v), f), prev) in x.iter_mut().zip(v).zip(f).zip(prev) {
            *prev = *x;
            (*x, *v) = self.particle(*x, *v, *f);
        }
    }

    /// [`update_velocities`] then [`Motion::predict`], fused: per particle the velocity of the
    /// substep that ends (`(x − prev) / h`) and the prediction of the next, bit for bit what the
    /// two passes give, in one pass over the particles (two particles per register where the
    /// kernel path has AVX2: [`kernel::update_and_predict`]).
    fn update_and_predict(
        &self,
        path: KernelPath,
        x: &mut [Vec4],
        v: &mut [Vec4],
        f: &[Vec4],
        prev: &mut [Vec4],
    ) {
        kernel::update_and_predict(path, &self.0, kernel::MotionSlices { x, v, f, prev });
    }

    /// [`Motion::predict`] of the cells of one thread's range of particles.
    fn predict_cells(&self, x: &[Cell<Vec4>], v: &[Cell<Vec4>], f: &[Vec4], prev: &[Cell<Vec4>]) {
        for (((x, v), f), prev) in x.iter().zip(v).zip(f).zip(prev) {
            let (x0, v0) = (x.get(), v.get());
            prev.set(x0);
            let (x1, v1) = self.particle(x0, v0, *f);
            x.set(x1);
            v.set(v1);
        }
    }

    /// One particle's predicted position and velocity.
    #[inline(always)]
    fn particle(&self, x: Vec4, v: Vec4, f: Vec4) -> (Vec4, Vec4) {
        kernel::predict_particle(&self.0, x, v, f)
    }
}

/// Velocities from the substep's displacement (per particle, like [`Motion::predict`]).
fn update_velocities(v: &mut [Vec4], x: &[Vec4], prev: &[Vec4], inv_h: f32) {
    for ((v, x), prev) in v.iter_mut().zip(x).zip(prev) {
        *v = (*x - *prev) * inv_h;
    }
}

/// [`update_velocities`] of the cells of one thread's range of particles.
fn update_velocity_cells(v: &[Cell<Vec4>], x: &[Cell<Vec4>], prev: &[Cell<Vec4>], inv_h: f32) {
    for ((v, x), prev) in v.iter().zip(x).zip(prev) {
        v.set((x.get() - prev.get()) * inv_h);
    }
}

impl SoftBody {
    /// An empty body with the given settings.
    pub fn new(settings: SolverSettings) -> Result<Self, SoftBodyError> {
        settings.validate()?;
        Ok(Self {
            settings,
            positions: Vec::new(),
            velocities: Vec::new(),
            masses: Vec::new(),
            forces: Vec::new(),
            collides: Vec::new(),
            prev: Vec::new(),
            anchors: Vec::new(),
            links: LinkStore::default(),
            groups: GroupStore::default(),
            kernel: KernelPath::detect(),
            colliders: Colliders::default(),
            contact: ContactParticles::default(),
        })
    }

    /// The current settings.
    pub fn settings(&self) -> &SolverSettings {
        &self.settings
    }

    /// The link kernel path this body uses ([`KernelPath::detect`] unless set).
    pub fn kernel_path(&self) -> KernelPath {
        self.kernel
    }

    /// Chooses the link kernel path. Every path gives bit-identical results (see
    /// [`KernelPath`]), so this only changes speed; tests and benchmarks use it to compare paths.
    /// A path this CPU cannot run is refused.
    pub fn set_kernel_path(&mut self, path: KernelPath) -> Result<(), SoftBodyError> {
        if !path.is_supported() {
            return Err(SoftBodyError::UnsupportedKernel(path.name()));
        }
        self.kernel = path;
        Ok(())
    }

    /// Replaces the settings (validated first).
    pub fn set_settings(&mut self, settings: SolverSettings) -> Result<(), SoftBodyError> {
        settings.validate()?;
        self.settings = settings;
        Ok(())
    }

    /// Adds a free particle at rest; `mass` must be positive and finite.
    pub fn add_particle(&mut self, position: Vec3, mass: f32) -> Result<ParticleId, SoftBodyError> {
        finite3(position, "particle position")?;
        if !(mass.is_finite() && mass > 0.0) {
            return Err(SoftBodyError::BadMass {
                index: self.positions.len(),
                mass,
            });
        }
        Ok(self.push_particle(position, Vec3::ZERO, mass, false))
    }

    /// Adds a particle without validation (callers have checked), optionally pinned.
    pub(crate) fn push_particle(
        &mut self,
        position: Vec3,
        velocity: Vec3,
        mass: f32,
        pinned: bool,
    ) -> ParticleId {
        let w = if pinned { 0.0 } else { 1.0 / mass };
        self.positions.push(position.extend(w));
        self.velocities.push(if pinned {
            Vec4::ZERO
        } else {
            velocity.extend(0.0)
        });
        self.masses.push(mass);
        self.forces.push(Vec4::ZERO);
        self.collides.push(true);
        self.prev.push(Vec4::ZERO);
        self.contact.push();
        self.links.add_particle();
        ParticleId::new(self.positions.len() - 1)
    }

    fn check_particle(&self, p: ParticleId) -> Result<usize, SoftBodyError> {
        let i = p.index();
        if i < self.positions.len() {
            Ok(i)
        } else {
            Err(SoftBodyError::OutOfRange {
                what: "particle",
                index: i,
                len: self.positions.len(),
            })
        }
    }

    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.positions.len()
    }

    /// Positions: `xyz` = position, `w` = inverse mass (0 = pinned). Valid until the next mutation.
    pub fn positions(&self) -> &[Vec4] {
        &self.positions
    }

    /// Velocities: `xyz` = velocity, `w` = 0.
    pub fn velocities(&self) -> &[Vec4] {
        &self.velocities
    }

    /// Masses (the true mass, also for pinned particles).
    pub fn masses(&self) -> &[f32] {
        &self.masses
    }

    /// Position of one particle.
    pub fn position(&self, p: ParticleId) -> Vec3 {
        self.positions[p.index()].truncate()
    }

    /// Velocity of one particle.
    pub fn velocity(&self, p: ParticleId) -> Vec3 {
        self.velocities[p.index()].truncate()
    }

    /// Moves a particle (teleport: velocity unchanged).
    pub fn set_position(&mut self, p: ParticleId, position: Vec3) -> Result<(), SoftBodyError> {
        let i = self.check_particle(p)?;
        finite3(position, "particle position")?;
        let w = self.positions[i].w;
        self.positions[i] = position.extend(w);
        Ok(())
    }

    /// Sets a particle's velocity (ignored while it is pinned).
    pub fn set_velocity(&mut self, p: ParticleId, velocity: Vec3) -> Result<(), SoftBodyError> {
        let i = self.check_particle(p)?;
        finite3(velocity, "particle velocity")?;
        if self.positions[i].w > 0.0 {
            self.velocities[i] = velocity.extend(0.0);
        }
        Ok(())
    }

    /// Pins (`true`: inverse mass 0, velocity 0) or frees a particle.
    pub fn set_pinned(&mut self, p: ParticleId, pinned: bool) -> Result<(), SoftBodyError> {
        let i = self.check_particle(p)?;
        self.set_pinned_raw(i, pinned);
        if !pinned {
            self.anchors.retain(|a| a.particle as usize != i);
        }
        Ok(())
    }

    pub(crate) fn set_pinned_raw(&mut self, i: usize, pinned: bool) {
        self.positions[i].w = if pinned { 0.0 } else { 1.0 / self.masses[i] };
        if pinned {
            self.velocities[i] = Vec4::ZERO;
        }
    }

    /// Whether a particle is pinned.
    pub fn is_pinned(&self, p: ParticleId) -> bool {
        self.positions[p.index()].w == 0.0
    }

    /// Pins a particle as a kinematic anchor that moves to `target` during the next step
    /// (linearly over its substeps, with the matching velocity). Call each frame to drive it.
    pub fn set_anchor(&mut self, p: ParticleId, target: Vec3) -> Result<(), SoftBodyError> {
        let i = self.check_particle(p)?;
        finite3(target, "anchor target")?;
        self.set_pinned_raw(i, true);
        let start = Vec3A::from_vec4(self.positions[i]);
        match self.anchors.iter_mut().find(|a| a.particle as usize == i) {
            Some(a) => a.target = target.into(),
            None => self.anchors.push(Anchor {
                particle: i as u32,
                start,
                target: target.into(),
            }),
        }
        Ok(())
    }

    /// Particles currently driven as kinematic anchors.
    pub fn anchored_particles(&self) -> impl Iterator<Item = ParticleId> + '_ {
        self.anchors
            .iter()
            .map(|a| ParticleId::from_raw(a.particle))
    }

    /// Stops driving a particle as an anchor (it stays pinned where it is).
    pub fn clear_anchor(&mut self, p: ParticleId) {
        self.anchors.retain(|a| a.particle as usize != p.index());
    }

    /// Sets the external force on a particle, applied every step until changed.
    pub fn set_external_force(&mut self, p: ParticleId, force: Vec3) -> Result<(), SoftBodyError> {
        let i = self.check_particle(p)?;
        finite3(force, "external force")?;
        self.forces[i] = force.extend(0.0);
        Ok(())
    }

    /// Sets all external forces to zero.
    pub fn clear_external_forces(&mut self) {
        self.forces.fill(Vec4::ZERO);
    }

    /// Whether a particle takes part in collision (see [`crate::collide`]). TreeCut clears it
    /// on particles created by a transition until the transition ends (the paper's section 3.4).
    pub fn collides(&self, p: ParticleId) -> bool {
        self.collides[p.index()]
    }

    /// Sets the collision flag (see [`SoftBody::collides`]).
    pub fn set_collides(&mut self, p: ParticleId, collides: bool) {
        self.collides[p.index()] = collides;
    }

    /// The colliders this body collides with.
    pub fn colliders(&self) -> &Colliders {
        &self.colliders
    }

    /// The colliders, to add, move or remove them.
    pub fn colliders_mut(&mut self) -> &mut Colliders {
        &mut self.colliders
    }

    /// A particle's collision radius in metres (0: a point; the collider's thickness still
    /// applies).
    pub fn collision_radius(&self, p: ParticleId) -> f32 {
        self.contact.radius[p.index()]
    }

    /// Sets a particle's collision radius (finite, >= 0).
    pub fn set_collision_radius(
        &mut self,
        p: ParticleId,
        radius: f32,
    ) -> Result<(), SoftBodyError> {
        let i = self.check_particle(p)?;
        if !(radius.is_finite() && radius >= 0.0) {
            return Err(SoftBodyError::BadCollider(
                "collision radius must be finite and >= 0",
            ));
        }
        self.contact.radius[i] = radius;
        Ok(())
    }

    /// Whether a particle touched a collider during the last step.
    pub fn touched(&self, p: ParticleId) -> bool {
        self.contact.touched[p.index()]
    }

    /// Which particles touched a collider during the last step, parallel to the particles.
    pub fn touched_all(&self) -> &[bool] {
        &self.contact.touched
    }

    /// Adds `dv` to a free particle's velocity (an impulse per unit mass; pinned particles
    /// ignore it).
    pub(crate) fn add_velocity_raw(&mut self, i: usize, dv: Vec3) {
        if self.positions[i].w > 0.0 {
            self.velocities[i] += dv.extend(0.0);
        }
    }

    /// Adds a full-weight link; see [`SoftBody::add_link_weighted`].
    pub fn add_link(
        &mut self,
        a: ParticleId,
        b: ParticleId,
        rest: f32,
        compliance: f32,
    ) -> Result<LinkId, SoftBodyError> {
        self.add_link_weighted(a, b, rest, compliance, 1.0)
    }

    /// Adds a distance link between two particles with a rest length, a compliance (already
    /// scaled, see [`crate::Material`]) and a blend weight in 0..=1 multiplying its stiffness.
    pub fn add_link_weighted(
        &mut self,
        a: ParticleId,
        b: ParticleId,
        rest: f32,
        compliance: f32,
        weight: f32,
    ) -> Result<LinkId, SoftBodyError> {
        self.check_particle(a)?;
        self.check_particle(b)?;
        if a == b {
            return Err(SoftBodyError::SelfLink(a.index()));
        }
        if !(rest.is_finite() && rest >= 0.0) {
            return Err(SoftBodyError::BadLinkParameter {
                what: "rest length",
                value: rest,
            });
        }
        if !(compliance.is_finite() && compliance >= 0.0) {
            return Err(SoftBodyError::BadLinkParameter {
                what: "compliance",
                value: compliance,
            });
        }
        if !(0.0..=1.0).contains(&weight) {
            return Err(SoftBodyError::BadLinkParameter {
                what: "blend weight",
                value: weight,
            });
        }
        Ok(self.links.add(a.raw(), b.raw(), rest, compliance, weight))
    }

    pub(crate) fn add_link_raw(
        &mut self,
        a: u32,
        b: u32,
        rest: f32,
        compliance: f32,
        weight: f32,
    ) -> LinkId {
        self.links.add(a, b, rest, compliance, weight)
    }

    fn check_link(&self, id: LinkId) -> Result<(), SoftBodyError> {
        if self.links.contains(id) {
            Ok(())
        } else {
            Err(SoftBodyError::OutOfRange {
                what: "link",
                index: id.index(),
                len: self.links.len(),
            })
        }
    }

    /// Removes a link in O(1); the other links compute exactly what they did before
    /// (see the crate docs, *colouring, deletion, determinism*).
    pub fn remove_link(&mut self, id: LinkId) -> Result<(), SoftBodyError> {
        self.check_link(id)?;
        self.links.remove(id);
        Ok(())
    }

    /// Sets a link's blend weight (0..=1).
    pub fn set_link_weight(&mut self, id: LinkId, weight: f32) -> Result<(), SoftBodyError> {
        self.check_link(id)?;
        if !(0.0..=1.0).contains(&weight) {
            return Err(SoftBodyError::BadLinkParameter {
                what: "blend weight",
                value: weight,
            });
        }
        self.links.set_weight(id, weight);
        Ok(())
    }

    pub(crate) fn set_link_weight_raw(&mut self, id: LinkId, weight: f32) {
        self.links.set_weight(id, weight);
    }

    /// A link's description, if it is live.
    pub fn link(&self, id: LinkId) -> Option<LinkInfo> {
        self.links.contains(id).then(|| self.links.info(id))
    }

    /// All plain links, in solve order (colour batches, then the ordered overflow batch).
    pub fn links(&self) -> impl Iterator<Item = LinkInfo> + '_ {
        self.links.iter()
    }

    /// Number of plain links (group links not included).
    pub fn link_count(&self) -> usize {
        self.links.len()
    }

    /// Number of group links (links to the centroid of a group, used by TreeCut transitions).
    pub fn group_link_count(&self) -> usize {
        self.groups.link_count()
    }

    /// Number of colour batches and their sizes.
    pub fn batch_sizes(&self) -> Vec<usize> {
        self.links.batch_sizes()
    }

    /// The links incident to a particle (O(degree)).
    pub fn incident_links(&self, p: ParticleId) -> impl ExactSizeIterator<Item = LinkId> + '_ {
        self.links.incident(p.raw()).iter().map(|&(l, _)| l)
    }

    /// The particles linked to `p` by plain links (O(degree), without touching the links).
    pub fn neighbours(&self, p: ParticleId) -> impl ExactSizeIterator<Item = ParticleId> + '_ {
        self.links
            .incident(p.raw())
            .iter()
            .map(|&(_, q)| ParticleId::from_raw(q))
    }

    /// Changes whenever a particle or a link is added, removed or renumbered (never for a
    /// position, weight or setting): a cache of anything derived from the neighbourhoods
    /// compares it to know it is still valid.
    pub(crate) fn topology_generation(&self) -> u64 {
        self.links.generation()
    }

    /// The particles whose neighbourhoods changed after topology generation `since` (see
    /// `LinkStore::changed_since`); `None`: unknown, rebuild whatever depends on them.
    pub(crate) fn topology_changed_since(
        &self,
        since: u64,
    ) -> Option<impl Iterator<Item = u32> + '_> {
        self.links.changed_since(since)
    }

    /// Incident links with the particle at the other end.
    pub(crate) fn incident_raw(&self, p: u32) -> &[(LinkId, u32)] {
        self.links.incident(p)
    }

    /// Removes a particle and its links. The last particle moves into the freed slot; the
    /// return value is the id it had before (None if `p` was the last one). Group links must
    /// no longer refer to `p`.
    pub fn remove_particle(&mut self, p: ParticleId) -> Result<Option<ParticleId>, SoftBodyError> {
        let i = self.check_particle(p)?;
        if self.groups.references(p.raw()) {
            return Err(SoftBodyError::BadSetting(
                "particle is still part of a group link",
            ));
        }
        Ok(self.remove_particle_raw(i as u32))
    }

    pub(crate) fn remove_particle_raw(&mut self, p: u32) -> Option<ParticleId> {
        self.links.remove_all_of(p);
        let last = (self.positions.len() - 1) as u32;
        self.links.move_particle(p, last);
        let i = p as usize;
        self.positions.swap_remove(i);
        self.velocities.swap_remove(i);
        self.masses.swap_remove(i);
        self.forces.swap_remove(i);
        self.collides.swap_remove(i);
        self.prev.swap_remove(i);
        self.contact.swap_remove(i);
        self.anchors.retain(|a| a.particle != p);
        if p != last {
            for a in &mut self.anchors {
                if a.particle == last {
                    a.particle = p;
                }
            }
            self.groups.rename_particle(last, p);
            Some(ParticleId::from_raw(last))
        } else {
            None
        }
    }

    /// Renumbers the particles: new particle `i` is old particle `order[i]` (`order` is a
    /// permutation of `0..particle_count`). Every per-particle value, anchor and group member
    /// moves with its particle, and the links are re-coloured in canonical order (see
    /// `LinkStore::renumber`); link ids do not change.
    pub(crate) fn permute_particles(&mut self, order: &[u32]) {
        debug_assert_eq!(order.len(), self.positions.len());
        let mut new_of_old = vec![0u32; order.len()];
        for (new, &old) in order.iter().enumerate() {
            new_of_old[old as usize] = new as u32;
        }
        fn gather<T: Copy>(v: &mut Vec<T>, order: &[u32]) {
            let permuted: Vec<T> = order.iter().map(|&o| v[o as usize]).collect();
            *v = permuted;
        }
        gather(&mut self.positions, order);
        gather(&mut self.velocities, order);
        gather(&mut self.masses, order);
        gather(&mut self.forces, order);
        gather(&mut self.collides, order);
        gather(&mut self.prev, order);
        gather(&mut self.contact.radius, order);
        gather(&mut self.contact.touched, order);
        for a in &mut self.anchors {
            a.particle = new_of_old[a.particle as usize];
        }
        self.groups.remap_particles(&new_of_old);
        self.links.renumber(&new_of_old);
    }

    /// Creates a group (see [`crate::group`]) over `members` with their `masses`.
    pub(crate) fn create_group(&mut self, members: &[u32], masses: &[f32], weight: f32) -> GroupId {
        self.groups.create(members, masses, weight)
    }

    pub(crate) fn add_group_target(
        &mut self,
        g: GroupId,
        particle: u32,
        rest: f32,
        compliance: f32,
    ) {
        self.groups.get_mut(g).targets.push(GroupTarget {
            particle,
            rest,
            compliance,
            lambda: 0.0,
        });
    }

    pub(crate) fn set_group_weight(&mut self, g: GroupId, weight: f32) {
        self.groups.get_mut(g).weight = weight;
    }

    pub(crate) fn group(&self, g: GroupId) -> &crate::group::Group {
        self.groups.get(g)
    }

    pub(crate) fn remove_group(&mut self, g: GroupId) {
        self.groups.remove(g);
    }

    pub(crate) fn groups(&self) -> impl Iterator<Item = &crate::group::Group> + '_ {
        self.groups.groups.iter().filter(|g| g.live)
    }

    /// Sum of all particle masses.
    pub fn total_mass(&self) -> f64 {
        self.masses.iter().map(|&m| m as f64).sum()
    }

    /// Total linear momentum `Σ m v` (accumulated in f64).
    pub fn total_momentum(&self) -> glam::DVec3 {
        let mut s = glam::DVec3::ZERO;
        for (v, &m) in self.velocities.iter().zip(&self.masses) {
            s += v.truncate().as_dvec3() * m as f64;
        }
        s
    }

    /// Advances the body by `settings.dt`: per substep, predict positions from velocities,
    /// gravity and external forces, run `iterations` sweeps over the colour batches and the
    /// group links, then derive velocities from the displacement.
    pub fn step(&mut self) {
        let s = self.settings;
        let n = s.substeps;
        let h = s.dt / n as f32;
        let inv_h = 1.0 / h;
        let inv_h2 = inv_h * inv_h;
        let motion = Motion(kernel::MotionConsts {
            h,
            damp: (-s.damping * h).exp(),
            g: s.gravity.extend(0.0),
            inv_h,
        });
        let colliding = !self.colliders.is_empty();
        let threads = self.threads();
        // One sweep per substep (the default): every link's multiplier is 0 when it is solved
        // and never read again, so the kernels neither load nor store them and nothing resets
        // them (`kernel::solve_batch_unchecked`); the same bits as resetting and sweeping.
        let fresh = s.iterations == 1;
        if colliding {
            self.begin_contact_step();
        } else {
            // No contact this step (the last collider may just have been removed).
            self.contact.touched.fill(false);
        }
        if threads > 1 {
            self.substeps_team(threads, motion, colliding, fresh);
        } else {
            motion.predict(
                &mut self.positions,
                &mut self.velocities,
                &self.forces,
                &mut self.prev,
            );
            for sub in 0..n {
                for a in &self.anchors {
                    let i = a.particle as usize;
                    self.positions[i] = a.position(sub, n).extend(self.positions[i].w);
                }
                if !fresh {
                    self.links.reset_lambdas();
                }
                self.groups.reset_lambdas();
                for _ in 0..s.iterations {
                    self.links
                        .solve(self.kernel, &mut self.positions, inv_h2, fresh);
                    if !self.groups.is_empty() {
                        self.groups.solve(self.positions.as_mut_slice(), inv_h2);
                    }
                }
                if colliding {
                    self.colliders.project(
                        sub,
                        n,
                        self.positions.as_mut_slice(),
                        self.prev.as_mut_slice(),
                        &mut self.contact,
                    );
                }
                if sub + 1 < n {
                    // This substep's velocities and the next one's prediction in one pass over
                    // the particles (the same arithmetic as the two passes in turn).
                    motion.update_and_predict(
                        self.kernel,
                        &mut self.positions,
                        &mut self.velocities,
                        &self.forces,
                        &mut self.prev,
                    );
                } else {
                    update_velocities(&mut self.velocities, &self.positions, &self.prev, inv_h);
                }
            }
        }
        for a in &mut self.anchors {
            a.start = a.target;
        }
        self.colliders.end_step();
    }

    /// The substeps of [`SoftBody::step`] on a [`team`] of `threads` threads that lives for
    /// the whole step: per substep the leader publishes the lambda reset and prediction as one
    /// phase, every split colour batch of every sweep as a phase, and the velocity update as a
    /// phase; the anchors, small batches, the overflow batch, the group links and the contacts
    /// run on the leader between phases. Every run of a phase writes only its own particles
    /// (its range of them, or the disjoint links of one colour batch) or its own blocks, so
    /// the result has exactly the bits of the one-thread loop.
    #[allow(unsafe_code)]
    fn substeps_team(&mut self, threads: usize, motion: Motion, colliding: bool, fresh: bool) {
        let s = self.settings;
        let n = s.substeps;
        let inv_h = motion.0.inv_h;
        let inv_h2 = inv_h * inv_h;
        let Self {
            positions,
            velocities,
            forces,
            prev,
            anchors,
            links,
            groups,
            kernel,
            colliders,
            contact,
            ..
        } = self;
        let path = *kernel;
        let links = links.runs(s.parallel_min_links as usize, threads, positions.len());
        // Run numbers: link runs `0..r` (solve), `r..2r` (reset their multipliers), particle
        // ranges `2r..2r + chunks` (predict), `2r + chunks..2r + 2chunks` (velocities). The
        // reset and the prediction are adjacent, so one phase does both when it may have that
        // many runs. (`LinkStore::runs` makes at most 64 × MAX_RUNS / 4 runs, so every run
        // number fits a phase's 16-bit start.)
        let r = links.len();
        let count = positions.len();
        let chunks = (threads * PARTICLE_RUNS_PER_THREAD).clamp(1, team::MAX_RUNS / 4);
        let range = |k: usize| k * count / chunks..(k + 1) * count / chunks;
        let forces = forces.as_slice();
        // SAFETY: copies of these views are used (a) by the runs of one phase at a time and
        // (b) by the leader between phases, when no run is in flight (`Leader::phase` returns
        // only after every run it published is done; helpers touch particles only inside a
        // claimed run). The runs of one phase touch disjoint particles: a particle phase hands
        // each run its own range (`range(k)`, disjoint for distinct `k`) of all three arrays,
        // and a link phase solves pieces of one colour batch, whose links share no particle
        // (next paragraph) and touch positions only; a reset run touches no particle at all.
        // Every copy is dropped when `team::run` returns, having joined its helpers.
        //
        // No colour batch holds two links sharing a particle: `LinkStore::insert` puts a link
        // in colour `c` only when neither end has bit `c` in its colour mask and sets the bit
        // on both ends; the bit is cleared only when that link leaves the batch (`remove`,
        // `remove_all_of`); `move_particle` renames a particle that has no links left;
        // `renumber` rebuilds through `insert` (all checked by `LinkStore::check` in tests).
        let (x, v, x0) = unsafe {
            (
                SharedParticles::new(positions),
                SharedParticles::new(velocities),
                SharedParticles::new(prev),
            )
        };
        let work = |run: usize| {
            if run < r {
                let mut view = x;
                links.solve(run, path, &mut view, inv_h2, fresh);
            } else if run < 2 * r {
                links.reset_lambdas(run - r);
            } else if run < 2 * r + chunks {
                let k = range(run - 2 * r);
                motion.predict_cells(
                    x.range(k.clone()),
                    v.range(k.clone()),
                    &forces[k.clone()],
                    x0.range(k),
                );
            } else {
                let k = range(run - 2 * r - chunks);
                update_velocity_cells(v.range(k.clone()), x.range(k.clone()), x0.range(k), inv_h);
            }
        };
        let most = links.parts().max(r + chunks);
        team::run(threads - 1, most, &work, |leader| {
            let (mut x, mut x0) = (x, x0);
            for sub in 0..n {
                if fresh {
                    // No multiplier to reset: the prediction alone.
                    leader.phase(2 * r, chunks);
                } else if r + chunks <= team::MAX_RUNS {
                    leader.phase(r, r + chunks);
                } else {
                    for lo in (r..2 * r).step_by(team::MAX_RUNS) {
                        leader.phase(lo, team::MAX_RUNS.min(2 * r - lo));
                    }
                    leader.phase(2 * r, chunks);
                }
                for a in anchors.iter() {
                    let i = a.particle as usize;
                    x.set(i, a.position(sub, n).extend(x.get(i).w));
                }
                if !fresh {
                    links.reset_overflow_lambdas();
                }
                groups.reset_lambdas();
                for _ in 0..s.iterations {
                    links.sweep(leader, path, &mut x, inv_h2, fresh);
                    if !groups.is_empty() {
                        groups.solve(&mut x, inv_h2);
                    }
                }
                if colliding {
                    colliders.project(sub, n, &mut x, &mut x0, contact);
                }
                leader.phase(2 * r + chunks, chunks);
            }
        });
    }

    /// How many threads the coming step splits its work over: the current rayon pool's when
    /// some colour batch has at least [`SolverSettings::parallel_min_links`] links (never
    /// asking rayon otherwise, so a small body does not start the global pool), else 1.
    fn threads(&self) -> usize {
        let min = self.settings.parallel_min_links as usize;
        if min == 0 || self.links.max_batch_len() < min.max(crate::links::MIN_SPLIT) {
            1
        } else {
            rayon::current_num_threads()
        }
    }

    /// The contact broad phase for the coming step: how far a particle can get in one step
    /// (twice its current speed plus gravity and its external force over the step, for
    /// safety against links pulling it) bounds which particles each collider may touch.
    fn begin_contact_step(&mut self) {
        let dt = self.settings.dt;
        let mut reach = 0f32;
        for ((x, v), f) in self
            .positions
            .iter()
            .zip(&self.velocities)
            .zip(&self.forces)
        {
            if x.w > 0.0 {
                let a = self.settings.gravity + f.truncate() * x.w;
                reach = reach.max(v.truncate().length() * dt + a.length() * dt * dt);
            }
        }
        self.colliders.begin_step(
            &self.positions,
            &self.collides,
            &mut self.contact,
            2.0 * reach + 1e-3,
            dt,
        );
    }

    #[cfg(test)]
    pub(crate) fn check_links(&self) {
        self.links.check();
    }
}
