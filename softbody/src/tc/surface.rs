//! What a TreeCut cloth's surface meets: colliders and wind, at any cut.
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), sections
//! 3.3–3.4 (new nodes are left out of collision until their operation ends, when their
//! collision shapes are inserted); contact and wind as in [`crate::collide`] and [`crate::wind`].
//!
//! * **Collision radius.** A node's radius covers the rest positions of every finest vertex
//!   below it (0 for a leaf), so a coarse cloth cannot slip past a collider thinner than its
//!   node spacing (see [`crate::collide`] for the price).
//! * **Normals.** Once per step each particle's normal is estimated from its linked
//!   neighbours: with `o_j` the rest offset and `d_j` the current offset of neighbour `j`, and
//!   `(t, b)` the node's rest tangent frame, `n ∝ (Σ d_j (o_j·t)) × (Σ d_j (o_j·b))` — the
//!   current images of the rest tangents in the least-squares sense (exact for any rotation of
//!   a flat neighbourhood, any cut level). The weights `(o_j·t, o_j·b)` depend only on the
//!   topology and are kept from step to step ([`NormalTable`]).
//! * **Wind.** Each finest triangle's area goes, a third to each of its vertices, to the node
//!   covering the vertex, so a node's area is the area of the cloth it stands for and the
//!   total force does not depend on the cut ([`crate::wind`]). The force is computed at the
//!   start of every step from the particles simulated then — new nodes of a refine get theirs
//!   the step they appear — and applied as the velocity change over the step; the host sets
//!   nothing per particle.

use super::{TreeCutError, TreeCutSoftBody};
use crate::collide::Colliders;
use crate::ids::ParticleId;
use crate::wind::Wind;
use glam::{Vec3, Vec3A};
use treecut::{Hierarchy, NodeId};

/// When the children of a refine start to collide.
///
/// The paper (section 3.3) leaves new nodes out of collision until their operation ends and
/// inserts their collision shapes then (section 3.4): [`TransitionCollision::AtEnd`]. Measured
/// on the engine scenes (`slod_experiments::engine`, drape and cape at 30% of the nodes), that
/// lets the children of a refine in contact fall into the collider for the blend's steps: node
/// centres 44–52 mm deep, against none when they collide at once. So the default is
/// [`TransitionCollision::Immediately`]; the paper's behaviour stays available.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TransitionCollision {
    /// New children collide from the step their refine begins (default).
    #[default]
    Immediately,
    /// New children join collision when their refine ends (the paper's section 3.4).
    AtEnd,
}

/// Per-node surface data and the wind, kept by [`TreeCutSoftBody`].
#[derive(Clone, Debug, Default)]
pub(super) struct Surface {
    /// Rest normal and one rest tangent per hierarchy node (the other is their cross product).
    frames: Vec<(Vec3, Vec3)>,
    /// Collision radius per hierarchy node.
    pub(super) radius: Vec<f32>,
    /// Area of cloth each hierarchy node stands for (empty until triangles are given).
    area: Vec<f32>,
    wind: Option<Wind>,
    /// Simulated time in seconds (the wind's clock).
    time: f64,
    /// Current normal per particle (reused buffer).
    normals: Vec<Vec3>,
    /// What the normals weigh each neighbour's offset by, per particle.
    normal_table: NormalTable,
    /// When the children of a refine start to collide.
    pub(super) transition_collision: TransitionCollision,
}

impl Surface {
    pub(super) fn new(h: &Hierarchy) -> Surface {
        let mut radius = vec![0f32; h.len()];
        let mut frames = vec![(Vec3::Y, Vec3::X); h.len()];
        for i in 0..h.len() {
            let n = NodeId::new(i);
            let c = h.rest_position(n);
            radius[i] = h
                .vertices(n)
                .iter()
                .map(|&v| (h.rest_position(h.leaf_of_vertex(v)) - c).length())
                .fold(0.0, f32::max);
            frames[i] = rest_frame(h, n);
        }
        Surface {
            frames,
            radius,
            ..Surface::default()
        }
    }
}

/// A node's rest normal from its same-level neighbours: the sum of the cross products of
/// pairs of rest offsets, each turned to agree with the largest one.
fn rest_frame(h: &Hierarchy, n: NodeId) -> (Vec3, Vec3) {
    let c = h.rest_position(n);
    let offsets: Vec<Vec3> = h
        .level_neighbours(n)
        .iter()
        .map(|&k| h.rest_position(k) - c)
        .collect();
    let mut best = Vec3::ZERO;
    for (i, a) in offsets.iter().enumerate() {
        for b in &offsets[i + 1..] {
            let x = a.cross(*b);
            if x.length_squared() > best.length_squared() {
                best = x;
            }
        }
    }
    let mut sum = Vec3::ZERO;
    for (i, a) in offsets.iter().enumerate() {
        for b in &offsets[i + 1..] {
            let x = a.cross(*b);
            sum += if x.dot(best) < 0.0 { -x } else { x };
        }
    }
    let normal = sum.normalize_or(Vec3::Y);
    (normal, normal.any_orthonormal_vector())
}

/// The weights of every particle's normal: for each neighbour `j` (in the order of the
/// particle's incident links), its rest offset `o_j` projected on the particle's rest tangents,
/// `(o_j·t, o_j·b)`. They depend only on rest positions and on who is linked to whom, so they
/// are kept from step to step and brought up to date only where the topology changed
/// (`SoftBody::topology_changed_since`; the whole table after a renumbering or when the change
/// log no longer reaches back), as the reconstruction's table is. The normals are the sums a
/// direct pass forms, bit for bit (test `normals_from_the_table_match_a_direct_pass`): the same
/// products in the same order. A windy cloth's step, before → after (with the gust speed
/// computed once per wind, not per particle; best of 15 windows of 20 steps, medians of five
/// runs of the two binaries interleaved; wall time, 2-core dev machine): 49² at its finest cut
/// 0.860 → 0.829 ms, a 65² net's uniform 1,056-node cut 0.380 → 0.364 ms, the same positions
/// to the bit. Bench: `cargo bench -p softbody --bench contact -- windy` (against `free`, the
/// same cloth without wind).
#[derive(Clone, Debug, Default)]
pub(super) struct NormalTable {
    /// The topology generation it is up to date with (`None`: never built).
    generation: Option<u64>,
    /// Per particle: the first of its entries and how many.
    spans: Vec<(u32, u32)>,
    /// `(neighbour, o·t, o·b)` per incident link, each particle's contiguous.
    entries: Vec<(u32, f32, f32)>,
    /// Entries no span refers to any more (a particle whose list grew got a new span).
    stale: usize,
}

impl NormalTable {
    /// Brings the table up to `generation` (the body's current one).
    fn update(&mut self, b: &TreeCutSoftBody, generation: u64) {
        if self.generation == Some(generation) {
            return;
        }
        let n = b.particle_node.len();
        let changed = self
            .generation
            .and_then(|g| b.body.topology_changed_since(g));
        match changed {
            Some(changed) if self.stale <= self.entries.len() / 2 => {
                // Removed particles' entries are stale from now on.
                self.stale += self
                    .spans
                    .iter()
                    .skip(n)
                    .map(|&(_, l)| l as usize)
                    .sum::<usize>();
                self.spans.resize(n, (0, 0));
                for p in changed {
                    if (p as usize) < n {
                        self.write(b, p as usize);
                    }
                }
            }
            _ => {
                self.spans.clear();
                self.spans.resize(n, (0, 0));
                self.entries.clear();
                self.stale = 0;
                for p in 0..n {
                    self.write(b, p);
                }
            }
        }
        self.generation = Some(generation);
    }

    /// (Re)writes particle `p`'s entries: in place when they fit its span, else at the end.
    fn write(&mut self, b: &TreeCutSoftBody, p: usize) {
        let h = &*b.hierarchy;
        let node = b.particle_node[p];
        let (rest_n, t) = b.surface.frames[node.index()];
        let bt = rest_n.cross(t);
        let rest = h.rest_position(node);
        let links = b.body.incident_raw(p as u32);
        let (start, len) = self.spans[p];
        let at = if links.len() <= len as usize {
            self.stale += len as usize - links.len();
            start as usize
        } else {
            self.stale += len as usize;
            self.entries.len()
        };
        if at == self.entries.len() {
            self.entries.resize(at + links.len(), (0, 0.0, 0.0));
        }
        for (e, &(_, q)) in self.entries[at..at + links.len()].iter_mut().zip(links) {
            let o = h.rest_position(b.particle_node[q as usize]) - rest;
            *e = (q, o.dot(t), o.dot(bt));
        }
        self.spans[p] = (at as u32, links.len() as u32);
    }
}

impl TreeCutSoftBody {
    /// Gives the cloth its finest triangles (vertex indices), from which each node's area is
    /// computed for the wind. [`crate::wind::grid_triangles`] makes them for a grid.
    pub fn set_surface(&mut self, triangles: &[[u32; 3]]) -> Result<(), TreeCutError> {
        let h = &*self.hierarchy;
        let count = h.vertex_count();
        let mut vertex_area = vec![0f32; count];
        for t in triangles {
            if let Some(&v) = t.iter().find(|&&v| v as usize >= count) {
                return Err(TreeCutError::VertexOutOfRange { vertex: v, count });
            }
            let [a, b, c] = t.map(|v| h.rest_position(h.leaf_of_vertex(v)));
            let third = (b - a).cross(c - a).length() / 6.0;
            for &v in t {
                vertex_area[v as usize] += third;
            }
        }
        self.surface.area = (0..h.len())
            .map(|i| {
                h.vertices(NodeId::new(i))
                    .iter()
                    .map(|&v| vertex_area[v as usize])
                    .sum()
            })
            .collect();
        Ok(())
    }

    /// Sets (or with `None` removes) the wind. Needs the surface's triangles
    /// ([`TreeCutSoftBody::set_surface`]); refused, with nothing changed, without them.
    pub fn set_wind(&mut self, wind: Option<Wind>) -> Result<(), TreeCutError> {
        if wind.is_some() && self.surface.area.is_empty() {
            return Err(TreeCutError::NoSurface);
        }
        self.surface.wind = wind;
        Ok(())
    }

    /// Chooses when the children of a refine start to collide (for refines begun from now on).
    pub fn set_transition_collision(&mut self, when: TransitionCollision) {
        self.surface.transition_collision = when;
    }

    /// When the children of a refine start to collide.
    pub fn transition_collision(&self) -> TransitionCollision {
        self.surface.transition_collision
    }

    /// The wind, if any.
    pub fn wind(&self) -> Option<&Wind> {
        self.surface.wind.as_ref()
    }

    /// Seconds simulated so far (the wind's clock).
    pub fn time(&self) -> f64 {
        self.surface.time
    }

    /// Area of cloth a node stands for (0 before [`TreeCutSoftBody::set_surface`]).
    pub fn node_area(&self, node: NodeId) -> f32 {
        self.surface.area.get(node.index()).copied().unwrap_or(0.0)
    }

    /// The collision radius of a node (covers every finest vertex below it at rest).
    pub fn node_collision_radius(&self, node: NodeId) -> f32 {
        self.surface.radius[node.index()]
    }

    /// The colliders.
    pub fn colliders(&self) -> &Colliders {
        self.body.colliders()
    }

    /// The colliders, to add, move or remove them.
    pub fn colliders_mut(&mut self) -> &mut Colliders {
        self.body.colliders_mut()
    }

    /// The wind force on every particle now (parallel to the particles; empty without wind).
    pub fn wind_forces(&mut self, out: &mut Vec<Vec3>) {
        out.clear();
        let Some(wind) = self.surface.wind else {
            return;
        };
        self.estimate_normals();
        let t = self.surface.time as f32;
        let x = self.body.positions();
        let v = self.body.velocities();
        for (p, node) in self.particle_node.iter().enumerate() {
            let at = x[p].truncate();
            out.push(wind.force(
                self.surface.area[node.index()],
                self.surface.normals[p],
                v[p].truncate(),
                wind.velocity_at(at, t),
            ));
        }
    }

    /// Before the solver's step: surface normals and the wind's velocity change (nothing
    /// without wind).
    pub(super) fn prepare_surface(&mut self) {
        if self.surface.wind.is_none() {
            self.advance_time();
            return;
        }
        self.estimate_normals();
        if let Some(wind) = self.surface.wind {
            let t = self.surface.time as f32;
            let dt = self.body.settings().dt;
            for p in 0..self.particle_node.len() {
                let node = self.particle_node[p];
                let x = self.body.positions()[p];
                if x.w == 0.0 {
                    continue;
                }
                let at = x.truncate();
                let f = wind.force(
                    self.surface.area[node.index()],
                    self.surface.normals[p],
                    self.body.velocities()[p].truncate(),
                    wind.velocity_at(at, t),
                );
                self.body.add_velocity_raw(p, f * (x.w * dt));
            }
        }
        self.advance_time();
    }

    fn advance_time(&mut self) {
        self.surface.time += self.body.settings().dt as f64;
    }

    /// Current unit normal of every particle (see the module docs), into `surface.normals`,
    /// from the weights table ([`NormalTable`]) brought up to date first.
    fn estimate_normals(&mut self) {
        let generation = self.body.topology_generation();
        let mut table = std::mem::take(&mut self.surface.normal_table);
        table.update(self, generation);
        let x = self.body.positions();
        let normals = &mut self.surface.normals;
        normals.clear();
        for (p, &(start, len)) in table.spans.iter().enumerate() {
            let here = Vec3A::from_vec4(x[p]);
            let (mut gt, mut gb) = (Vec3A::ZERO, Vec3A::ZERO);
            for &(q, wt, wb) in &table.entries[start as usize..(start + len) as usize] {
                let d = Vec3A::from_vec4(x[q as usize]) - here;
                gt += d * wt;
                gb += d * wb;
            }
            normals.push(Vec3::from(gt.cross(gb)).normalize_or_zero());
        }
        self.surface.normal_table = table;
    }

    /// The normals now, from the table (test access).
    #[cfg(test)]
    pub(super) fn normals_now(&mut self) -> Vec<Vec3> {
        self.estimate_normals();
        self.surface.normals.clone()
    }

    /// The normals now by a direct pass over the neighbourhoods, without the table: what
    /// [`NormalTable`] must reproduce bit for bit.
    #[cfg(test)]
    pub(super) fn normals_direct(&self) -> Vec<Vec3> {
        let h = &*self.hierarchy;
        let x = self.body.positions();
        self.particle_node
            .iter()
            .enumerate()
            .map(|(p, &node)| {
                let (rest_n, t) = self.surface.frames[node.index()];
                let b = rest_n.cross(t);
                let rest = h.rest_position(node);
                let here = Vec3A::from_vec4(x[p]);
                let (mut gt, mut gb) = (Vec3A::ZERO, Vec3A::ZERO);
                for &(_, q) in self.body.incident_raw(p as u32) {
                    let o = h.rest_position(self.particle_node[q as usize]) - rest;
                    let d = Vec3A::from_vec4(x[q as usize]) - here;
                    gt += d * o.dot(t);
                    gb += d * o.dot(b);
                }
                Vec3::from(gt.cross(gb)).normalize_or_zero()
            })
            .collect()
    }

    /// Gives a new particle its node's collision radius.
    pub(super) fn init_particle_contact(&mut self, p: u32) {
        let node = self.particle_node[p as usize];
        let r = self.surface.radius[node.index()];
        self.body
            .set_collision_radius(ParticleId::from_raw(p), r)
            .expect("radii are finite and >= 0");
    }

    /// The deepest point of `vertices` (e.g. the reconstructed finest surface) inside any
    /// collider's bare shape, in metres.
    pub fn max_penetration(&self, vertices: &[Vec3]) -> f32 {
        self.body.colliders().max_penetration(vertices)
    }
}
