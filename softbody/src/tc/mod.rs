//! TreeCut-SoftBody: a soft body whose particles are the active nodes of a `treecut::Cut`.
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), sections 3.2–3.4 (TreeCut-SoftBody: the cut's nodes
//! as particles, operations split into a begin and an end with blended links).
//!
//! * Every particle stands for one hierarchy node ([`TreeCutSoftBody::particle_nodes`]); a
//!   per-node table maps back. Particle storage is dense (swap-removal), so particle indices
//!   change when transitions end; node ids do not.
//! * Links are the *induced adjacency*: two simulated nodes are linked iff some finest mesh
//!   edge joins them (`Hierarchy::adjacent`), with the distance of their rest positions as
//!   rest length and the material's stretch compliance (membrane scaling, so every level is
//!   the same material; see the crate docs). On a grid quadtree this is the structural +
//!   shear 8-neighbourhood at every level, so the finest cut is exactly the plain grid cloth.
//! * Refine and coarse run in two halves (module `ops`): *begin* builds the new state and fades
//!   links, *end* (after `blend_steps` steps, from [`TreeCutSoftBody::step`]) finalises it.
//!   A parent and its children are never simulated at once: during a transition the parent is
//!   virtual, the mass-weighted centroid of its real children, reached by group links. So
//!   mass and linear momentum are conserved exactly (up to rounding) by both operations.
//! * During a transition, the transition's nodes and all their neighbours are locked in the
//!   cut, so no other transition can start next to one in flight. A consequence used
//!   throughout: an unlocked node's links are all plain, full-weight links.

mod ops;
mod pins;
#[cfg(test)]
mod query_tests;
mod reconstruct;
mod renumber;
mod surface;
#[cfg(test)]
mod surface_tests;
#[cfg(test)]
mod tests;

pub use reconstruct::{ReconstructionError, ReconstructionMode, reconstruction_error};
pub use surface::TransitionCollision;

use crate::body::SoftBody;
use crate::error::SoftBodyError;
use crate::group::GroupId;
use crate::ids::{LinkId, ParticleId};
use crate::links::LinkInfo;
use crate::settings::{Material, SolverSettings};
use glam::{DVec3, Quat, Vec3, Vec4};
use std::sync::Arc;
use thiserror::Error;
use treecut::{Cut, CutError, Hierarchy, InvariantError, NodeId};

/// Marks "no particle" in the node → particle table.
const NO_PARTICLE: u32 = u32::MAX;

/// Settings of a [`TreeCutSoftBody`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeCutSettings {
    /// Time stepping of the underlying solver.
    pub solver: SolverSettings,
    /// Link material (stretch compliance; TreeCut links are all stretch links).
    pub material: Material,
    /// Steps over which a transition fades old links out and new links in. 0 switches at once.
    pub blend_steps: u32,
    /// How [`TreeCutSoftBody::reconstruct`] places finest vertices.
    pub reconstruction: ReconstructionMode,
}

/// The values the swinging-net experiment measured good:
///
/// * the solver's defaults ([`SolverSettings`]: 32 substeps of one iteration at 60 Hz,
///   damping 2/s);
/// * a membrane stretch compliance of 0.015 m/N, about three times the `w·dt²` of a finest
///   node of a 1 kg, 65×65 net at 16 substeps (twelve times at 32): the finest cloth's stretch then comes from the
///   material rather than from unfinished iterations, so coarse and fine cuts are the same
///   material (see the settings module's docs). A stiffer material makes the full-resolution
///   cloth iteration-limited: it creeps instead of swinging, and a coarse cut would be judged
///   against an artefact;
/// * transitions blended over 4 steps: long enough that a refine or coarse does not jerk,
///   short enough that the feedback loop's next evaluation (every 5 steps) sees it finished.
impl Default for TreeCutSettings {
    fn default() -> Self {
        Self {
            solver: SolverSettings::default(),
            material: Material {
                stretch_compliance: 0.015,
                ..Material::default()
            },
            blend_steps: 4,
            reconstruction: ReconstructionMode::default(),
        }
    }
}

/// Why a TreeCut soft body refused an operation. Refused operations change nothing.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum TreeCutError {
    /// The cut refused it (node not on the cut, leaf, locked, children not on the cut, ...).
    #[error(transparent)]
    Cut(#[from] CutError),
    /// The initial cut does not cover every vertex exactly once, or belongs to another hierarchy.
    #[error(transparent)]
    Invariant(#[from] InvariantError),
    /// Invalid settings or values.
    #[error(transparent)]
    Solver(#[from] SoftBodyError),
    /// A vertex index outside the hierarchy.
    #[error("vertex {vertex} out of range ({count} vertices)")]
    VertexOutOfRange {
        /// The vertex given.
        vertex: u32,
        /// Number of vertices.
        count: usize,
    },
    /// Wind needs the cloth's triangles first ([`TreeCutSoftBody::set_surface`]).
    #[error("wind needs the cloth's triangles: call set_surface first")]
    NoSurface,
    /// An output buffer has the wrong length.
    #[error("buffer holds {got} entries, {expected} needed")]
    BufferLength {
        /// Length given.
        got: usize,
        /// Length needed.
        expected: usize,
    },
}

/// Which way a transition goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransitionKind {
    /// A node is being replaced by its children.
    Refine,
    /// Children are being replaced by their parent.
    Coarse,
}

/// A refine or coarse in flight (storage reused between transitions).
#[derive(Clone, Debug)]
struct Transition {
    kind: TransitionKind,
    node: NodeId,
    steps_done: u32,
    group: GroupId,
    /// Refine: child–neighbour links fading in.
    fade_in: Vec<LinkId>,
    /// Coarse: child–neighbour links fading out.
    fade_out: Vec<LinkId>,
    /// Nodes this transition locked (unlocked at the end).
    locked: Vec<NodeId>,
}

/// A transition in flight, as reported by [`TreeCutSoftBody::transitions`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransitionInfo {
    /// Refine or coarse.
    pub kind: TransitionKind,
    /// The refined node, or the parent being formed.
    pub node: NodeId,
    /// Blend progress in 0..=1 (1 = ends after this step).
    pub progress: f32,
}

/// A link for debug drawing: plain links between two particles, or group links from a
/// particle to the centroid of a transition's children (the virtual parent).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrawLink {
    /// First end (current position).
    pub a: Vec3,
    /// Second end (current position; the centroid for group links).
    pub b: Vec3,
    /// Blend weight in 0..=1.
    pub weight: f32,
    /// Whether this is a group link to a virtual parent.
    pub group: bool,
}

/// Scratch buffers reused by the operations (no allocation per operation once warm).
#[derive(Clone, Debug, Default)]
struct Scratch {
    nodes: Vec<NodeId>,
    found: Vec<NodeId>,
    rest: Vec<f32>,
    compliance: Vec<f32>,
    particles: Vec<u32>,
    masses: Vec<f32>,
    positions: Vec<Vec3>,
    stamp: Vec<u32>,
    stamp_counter: u32,
}

/// The rotations the last reconstruction found, per hierarchy node: the warm start of the next
/// one. Separate from the simulation's rotations, so reading the surface never changes what is
/// simulated. Behind a mutex because reconstruction takes `&self` (hosts read a `const` world,
/// possibly from several threads): a reader that finds it busy (or poisoned) starts from the
/// simulation's rotations instead, which converges to the same tolerance, only more slowly.
#[derive(Debug, Default)]
struct RotationCache(std::sync::Mutex<Vec<Quat>>);

impl RotationCache {
    fn new(nodes: usize) -> Self {
        RotationCache(std::sync::Mutex::new(vec![Quat::IDENTITY; nodes]))
    }
}

impl Clone for RotationCache {
    fn clone(&self) -> Self {
        let v = self.0.lock().map(|v| v.clone()).unwrap_or_default();
        RotationCache(std::sync::Mutex::new(v))
    }
}

/// A soft body whose simulation nodes follow a TreeCut (see the crate docs, *TreeCut-SoftBody*).
#[derive(Clone, Debug)]
pub struct TreeCutSoftBody {
    hierarchy: Arc<Hierarchy>,
    cut: Cut,
    body: SoftBody,
    settings: TreeCutSettings,
    particle_node: Vec<NodeId>,
    node_particle: Vec<u32>,
    /// Last shape-matching rotation per hierarchy node (warm start; identity until computed).
    rotation: Vec<Quat>,
    /// The reconstruction's own warm start (see [`RotationCache`]).
    recon_rotation: RotationCache,
    /// The reconstruction's weights (`Smooth` or `Mls`) for the current topology.
    recon_table: reconstruct::TableCache,
    transitions: Vec<Transition>,
    spare: Vec<Transition>,
    pins: pins::Pins,
    scratch: Scratch,
    /// Particles added or removed since the last spatial renumbering (module `renumber`).
    churn: u32,
    /// Whether `step` renumbers by itself.
    auto_renumber: bool,
    surface: surface::Surface,
}

impl TreeCutSoftBody {
    /// Builds the body for `cut` (which must be a valid cut of `hierarchy`): one particle per
    /// active node at its rest position with the node's mass, and the induced links.
    pub fn new(
        hierarchy: impl Into<Arc<Hierarchy>>,
        cut: Cut,
        settings: TreeCutSettings,
    ) -> Result<Self, TreeCutError> {
        let hierarchy: Arc<Hierarchy> = hierarchy.into();
        settings.solver.validate()?;
        settings.material.validate()?;
        cut.check_invariant(&hierarchy)?;
        let h = &*hierarchy;
        let mut body = SoftBody::new(settings.solver)?;
        let mut node_particle = vec![NO_PARTICLE; h.len()];
        let mut particle_node = Vec::with_capacity(cut.len());
        for &n in cut.active() {
            node_particle[n.index()] = body
                .push_particle(h.rest_position(n), Vec3::ZERO, h.mass(n), false)
                .raw();
            particle_node.push(n);
        }
        // Cover each vertex by its active node, then link the ends of every mesh edge that
        // falls between two nodes. Links are added sorted by the nodes' smallest vertex
        // index, the same order a plain builder uses for the same vertex pairs, so the
        // colouring (and every result) at the finest cut equals the plain solver's.
        let mut cover = vec![0u32; h.vertex_count()];
        let mut key = vec![u32::MAX; h.len()];
        for &n in cut.active() {
            let p = node_particle[n.index()];
            for &v in h.vertices(n) {
                cover[v as usize] = p;
                key[n.index()] = key[n.index()].min(v);
            }
        }
        let mut pairs: Vec<(u32, u32, u32, u32)> = Vec::new();
        for &[u, v] in h.leaf_edges() {
            let (pu, pv) = (cover[u as usize], cover[v as usize]);
            if pu != pv {
                let (ku, kv) = (
                    key[particle_node[pu as usize].index()],
                    key[particle_node[pv as usize].index()],
                );
                let (a, b) = if ku < kv { (pu, pv) } else { (pv, pu) };
                pairs.push((ku.min(kv), ku.max(kv), a, b));
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        for &(_, _, a, b) in &pairs {
            let rest = (h.rest_position(particle_node[a as usize])
                - h.rest_position(particle_node[b as usize]))
            .length();
            body.add_link_raw(a, b, rest, settings.material.stretch(rest), 1.0);
        }
        let n_nodes = h.len();
        let n_vertices = h.vertex_count();
        let surface = surface::Surface::new(h);
        for (p, n) in particle_node.iter().enumerate() {
            body.set_collision_radius(ParticleId::new(p), surface.radius[n.index()])?;
        }
        Ok(Self {
            hierarchy,
            cut,
            body,
            settings,
            particle_node,
            node_particle,
            rotation: vec![Quat::IDENTITY; n_nodes],
            recon_rotation: RotationCache::new(n_nodes),
            recon_table: reconstruct::TableCache::default(),
            transitions: Vec::new(),
            spare: Vec::new(),
            pins: pins::Pins::new(n_nodes, n_vertices),
            scratch: Scratch::default(),
            churn: 0,
            auto_renumber: true,
            surface,
        })
    }

    /// The hierarchy.
    pub fn hierarchy(&self) -> &Hierarchy {
        &self.hierarchy
    }

    /// The hierarchy, shared.
    pub fn hierarchy_arc(&self) -> &Arc<Hierarchy> {
        &self.hierarchy
    }

    /// The current cut (transitions apply to it at *begin*; their nodes are locked until *end*).
    pub fn cut(&self) -> &Cut {
        &self.cut
    }

    /// The settings.
    pub fn settings(&self) -> &TreeCutSettings {
        &self.settings
    }

    /// The underlying solver (read-only: links and particles are managed by the TreeCut).
    pub fn body(&self) -> &SoftBody {
        &self.body
    }

    /// Changes the solver settings (time step, iterations, gravity, damping).
    pub fn set_solver_settings(&mut self, solver: SolverSettings) -> Result<(), TreeCutError> {
        self.body.set_settings(solver)?;
        self.settings.solver = solver;
        Ok(())
    }

    /// Changes the number of blend steps for transitions begun from now on and in flight.
    pub fn set_blend_steps(&mut self, blend_steps: u32) {
        self.settings.blend_steps = blend_steps;
    }

    /// Number of particles (simulated nodes).
    pub fn particle_count(&self) -> usize {
        self.particle_node.len()
    }

    /// Particle positions: `xyz` position, `w` inverse mass (0 = pinned). Parallel to
    /// [`TreeCutSoftBody::particle_nodes`]; valid until the next mutating call.
    pub fn particle_positions(&self) -> &[Vec4] {
        self.body.positions()
    }

    /// Particle velocities (`w` = 0), parallel to [`TreeCutSoftBody::particle_nodes`].
    pub fn particle_velocities(&self) -> &[Vec4] {
        self.body.velocities()
    }

    /// Sets a particle's velocity (ignored for pinned particles), e.g. for an impulse.
    pub fn set_particle_velocity(
        &mut self,
        p: ParticleId,
        velocity: Vec3,
    ) -> Result<(), TreeCutError> {
        Ok(self.body.set_velocity(p, velocity)?)
    }

    /// Moves a particle (teleport; velocity unchanged).
    pub fn set_particle_position(
        &mut self,
        p: ParticleId,
        position: Vec3,
    ) -> Result<(), TreeCutError> {
        Ok(self.body.set_position(p, position)?)
    }

    /// Sets the external force on a particle (kept until changed; a transition's new particles start without one).
    pub fn set_external_force(&mut self, p: ParticleId, force: Vec3) -> Result<(), TreeCutError> {
        Ok(self.body.set_external_force(p, force)?)
    }

    /// Particle masses (hierarchy masses).
    pub fn particle_masses(&self) -> &[f32] {
        self.body.masses()
    }

    /// The hierarchy node each particle stands for. These are the active cut nodes, except
    /// during a coarse transition, whose children stay simulated (and are reported here)
    /// while their parent is already on the cut.
    pub fn particle_nodes(&self) -> &[NodeId] {
        &self.particle_node
    }

    /// The particle simulating `node`, if any.
    pub fn particle_of(&self, node: NodeId) -> Option<ParticleId> {
        match self.node_particle.get(node.index()) {
            Some(&p) if p != NO_PARTICLE => Some(ParticleId::from_raw(p)),
            _ => None,
        }
    }

    /// Plain links incident to a particle.
    pub fn incident_links(&self, p: ParticleId) -> impl ExactSizeIterator<Item = LinkId> + '_ {
        self.body.incident_links(p)
    }

    /// Particles linked to `p` by plain links.
    pub fn neighbours(&self, p: ParticleId) -> impl Iterator<Item = ParticleId> + '_ {
        self.body.neighbours(p)
    }

    /// Fills a CSR neighbour table: the neighbours of particle `i` are
    /// `neighbours[offsets[i]..offsets[i+1]]` (plain links, any weight).
    pub fn neighbour_csr(&self, offsets: &mut Vec<u32>, neighbours: &mut Vec<u32>) {
        offsets.clear();
        neighbours.clear();
        offsets.push(0);
        for p in 0..self.particle_count() {
            neighbours.extend(self.body.neighbours(ParticleId::new(p)).map(|q| q.raw()));
            offsets.push(neighbours.len() as u32);
        }
    }

    /// Number of plain links.
    pub fn link_count(&self) -> usize {
        self.body.link_count()
    }

    /// Number of group links (to virtual parents of transitions in flight).
    pub fn group_link_count(&self) -> usize {
        self.body.group_link_count()
    }

    /// Plain links with their blend weights.
    pub fn links(&self) -> impl Iterator<Item = LinkInfo> + '_ {
        self.body.links()
    }

    /// Every link as two end points and a weight, group links included, for debug drawing.
    pub fn draw_links(&self, out: &mut Vec<DrawLink>) {
        out.clear();
        let p = self.body.positions();
        out.extend(self.body.links().map(|l| DrawLink {
            a: p[l.a.index()].truncate(),
            b: p[l.b.index()].truncate(),
            weight: l.weight,
            group: false,
        }));
        for g in self.body.groups() {
            let c = Vec3::from(g.centroid(p));
            for t in &g.targets {
                out.push(DrawLink {
                    a: p[t.particle as usize].truncate(),
                    b: c,
                    weight: g.weight,
                    group: true,
                });
            }
        }
    }

    /// Number of transitions in flight.
    pub fn transitions_in_flight(&self) -> usize {
        self.transitions.len()
    }

    /// The transitions in flight, in the order they began.
    pub fn transitions(&self) -> impl Iterator<Item = TransitionInfo> + '_ {
        let steps = self.settings.blend_steps;
        self.transitions.iter().map(move |t| TransitionInfo {
            kind: t.kind,
            node: t.node,
            progress: blend_progress(t.steps_done, steps),
        })
    }

    /// Total mass of all particles (equals the hierarchy's total mass up to rounding).
    pub fn total_mass(&self) -> f64 {
        self.body.total_mass()
    }

    /// Total linear momentum of all particles.
    pub fn total_momentum(&self) -> DVec3 {
        self.body.total_momentum()
    }

    /// One frame: advance blend weights, step the solver, end the transitions whose blend is
    /// complete (in the order they began), and renumber the particles spatially when enough
    /// have come and gone (see [`TreeCutSoftBody::renumber_particles`]).
    pub fn step(&mut self) {
        self.update_pins();
        self.advance_blends();
        self.prepare_surface();
        self.body.step();
        self.end_finished();
        self.renumber_if_scattered();
    }

    /// Advances every transition's blend by one step and sets the link weights accordingly
    /// (done by [`TreeCutSoftBody::step`]; public for hosts that drive the phases themselves).
    pub fn advance_blends(&mut self) {
        let steps = self.settings.blend_steps;
        for t in &mut self.transitions {
            t.steps_done += 1;
            let s = blend_progress(t.steps_done, steps);
            match t.kind {
                TransitionKind::Refine => {
                    self.body.set_group_weight(t.group, 1.0 - s);
                    for &l in &t.fade_in {
                        self.body.set_link_weight_raw(l, s);
                    }
                }
                TransitionKind::Coarse => {
                    self.body.set_group_weight(t.group, s);
                    for &l in &t.fade_out {
                        self.body.set_link_weight_raw(l, 1.0 - s);
                    }
                }
            }
        }
    }

    /// Ends every transition whose blend is complete (`blend_steps` steps done), in the order
    /// they began; returns how many ended.
    pub fn end_finished(&mut self) -> usize {
        let steps = self.settings.blend_steps;
        let mut ended = 0;
        let mut i = 0;
        while i < self.transitions.len() {
            if self.transitions[i].steps_done >= steps {
                let t = self.transitions.remove(i);
                self.end_transition(t);
                ended += 1;
            } else {
                i += 1;
            }
        }
        ended
    }

    /// Ends every transition now, whatever its blend (for tear-down or benchmarks).
    pub fn end_all(&mut self) {
        while !self.transitions.is_empty() {
            let t = self.transitions.remove(0);
            self.end_transition(t);
        }
    }

    fn end_transition(&mut self, t: Transition) {
        match t.kind {
            TransitionKind::Refine => self.end_refine(&t),
            TransitionKind::Coarse => self.end_coarse(&t),
        }
        for &n in &t.locked {
            self.cut.unlock(n).expect("transition lock bookkeeping");
        }
        self.spare.push(t);
    }

    // --- particle bookkeeping shared by the operations ---

    /// Adds a particle for `node`; pinned nodes are placed at their pin position.
    fn add_node_particle(
        &mut self,
        node: NodeId,
        position: Vec3,
        velocity: Vec3,
        mass: f32,
    ) -> u32 {
        let pin = self
            .pins
            .pin_position(&self.hierarchy, node, self.rotation[node.index()]);
        let p = match pin {
            Some(at) => {
                let p = self.body.push_particle(at, Vec3::ZERO, mass, true);
                self.body.set_anchor(p, at).expect("pin position is finite");
                p
            }
            None => self.body.push_particle(position, velocity, mass, false),
        };
        self.node_particle[node.index()] = p.raw();
        self.particle_node.push(node);
        self.churn += 1;
        self.init_particle_contact(p.raw());
        p.raw()
    }

    /// Removes particle `p` (and its plain links), keeping the node tables in step with the
    /// swap-removal.
    fn remove_node_particle(&mut self, p: u32) {
        let node = self.particle_node[p as usize];
        self.node_particle[node.index()] = NO_PARTICLE;
        if let Some(moved) = self.body.remove_particle_raw(p) {
            let moved_node = self.particle_node[moved.index()];
            self.particle_node[p as usize] = moved_node;
            self.node_particle[moved_node.index()] = p;
        }
        self.particle_node.pop();
        self.churn += 1;
    }

    /// Checks internal consistency (tests).
    #[cfg(test)]
    fn check(&self) {
        self.body.check_links();
        self.cut.check_invariant(&self.hierarchy).unwrap();
        assert_eq!(self.particle_node.len(), self.body.particle_count());
        for (p, n) in self.particle_node.iter().enumerate() {
            assert_eq!(self.node_particle[n.index()], p as u32);
        }
        let mapped = self
            .node_particle
            .iter()
            .filter(|&&p| p != NO_PARTICLE)
            .count();
        assert_eq!(mapped, self.particle_node.len());
    }
}

/// Blend progress after `done` of `steps` steps, in 0..=1.
fn blend_progress(done: u32, steps: u32) -> f32 {
    if steps == 0 {
        1.0
    } else {
        (done as f32 / steps as f32).min(1.0)
    }
}
