//! Pins by finest vertex.
//!
//! Choice: a pin belongs to a mesh vertex, and *the node covering a pinned vertex is pinned*
//! (inverse mass 0), at the position that puts the pinned vertex at its anchor given the
//! node's current shape-matching rotation `R` (the one reconstruction uses):
//! `mean over its pinned vertices of (anchor − R (rest(vertex) − rest(node)))`, refreshed
//! every step. So a coarse corner node of a hanging net swings about the pinned corner
//! instead of being nailed at its rest centroid, and the reconstructed corner vertex stays
//! on its anchor.
//! The alternative — forbidding coarsening above pinned vertices — would keep the finest
//! level around every pin and defeat the compression near the pins that a swinging net
//! needs most. With several pinned vertices in one node the mean is exact when the anchors
//! keep their rest layout (translations of the whole net), and a least-squares compromise
//! otherwise. Pinned nodes are kinematic anchors of the solver, so moving an anchor moves
//! the node smoothly over the next step. Per node, the count and the sums of anchors and of
//! rest positions over pinned vertices of its subtree are kept up to date (O(depth) per pin
//! change), so a transition learns whether and where a node is pinned in O(1).

use glam::{DVec3, Mat3, Quat, Vec3};
use treecut::{Hierarchy, NodeId};

use super::{TreeCutError, TreeCutSoftBody};
use crate::ids::ParticleId;

/// Per-node pin summaries and per-vertex anchors.
#[derive(Clone, Debug)]
pub(super) struct Pins {
    count: Vec<u32>,
    anchor_sum: Vec<DVec3>,
    rest_sum: Vec<DVec3>,
    anchor: Vec<Option<Vec3>>,
}

impl Pins {
    pub(super) fn new(nodes: usize, vertices: usize) -> Self {
        Self {
            count: vec![0; nodes],
            anchor_sum: vec![DVec3::ZERO; nodes],
            rest_sum: vec![DVec3::ZERO; nodes],
            anchor: vec![None; vertices],
        }
    }

    /// Where `node` is pinned when its rotation is `rot`, if it covers a pinned vertex.
    pub(super) fn pin_position(&self, h: &Hierarchy, node: NodeId, rot: Quat) -> Option<Vec3> {
        let i = node.index();
        let c = self.count[i];
        (c > 0).then(|| {
            let anchor = (self.anchor_sum[i] / c as f64).as_vec3();
            let rest = (self.rest_sum[i] / c as f64).as_vec3();
            anchor - rot * (rest - h.rest_position(node))
        })
    }

    /// Whether any vertex is pinned.
    pub(super) fn any(&self, h: &Hierarchy) -> bool {
        self.count[h.root().index()] > 0
    }

    /// Adds (`sign` = 1) or removes (-1) vertex `v`'s contribution along its root path.
    fn update(&mut self, h: &Hierarchy, v: u32, anchor: Vec3, sign: i32) {
        let a = anchor.as_dvec3() * sign as f64;
        let r = h.rest_position(h.leaf_of_vertex(v)).as_dvec3() * sign as f64;
        let mut n = Some(h.leaf_of_vertex(v));
        while let Some(node) = n {
            let i = node.index();
            self.count[i] = self.count[i].wrapping_add_signed(sign);
            self.anchor_sum[i] += a;
            self.rest_sum[i] += r;
            if self.count[i] == 0 {
                // No drift once empty.
                self.anchor_sum[i] = DVec3::ZERO;
                self.rest_sum[i] = DVec3::ZERO;
            }
            n = h.parent(node);
        }
    }
}

impl TreeCutSoftBody {
    fn check_vertex(&self, v: u32) -> Result<(), TreeCutError> {
        let count = self.hierarchy.vertex_count();
        if (v as usize) < count {
            Ok(())
        } else {
            Err(TreeCutError::VertexOutOfRange { vertex: v, count })
        }
    }

    /// The particle whose node covers vertex `v` (O(depth)).
    pub fn particle_covering(&self, v: u32) -> Option<ParticleId> {
        let h = &*self.hierarchy;
        if v as usize >= h.vertex_count() {
            return None;
        }
        let mut n = Some(h.leaf_of_vertex(v));
        while let Some(node) = n {
            if let Some(p) = self.particle_of(node) {
                return Some(p);
            }
            n = h.parent(node);
        }
        None
    }

    /// Pins finest vertex `v` at `anchor` (or moves its anchor). The covering node becomes a
    /// kinematic anchor that reaches its new pin position over the next step.
    pub fn pin_vertex(&mut self, v: u32, anchor: Vec3) -> Result<(), TreeCutError> {
        self.check_vertex(v)?;
        if !anchor.is_finite() {
            return Err(crate::SoftBodyError::NotFinite { what: "anchor" }.into());
        }
        let h = self.hierarchy.clone();
        if let Some(old) = self.pins.anchor[v as usize] {
            self.pins.update(&h, v, old, -1);
        }
        self.pins.anchor[v as usize] = Some(anchor);
        self.pins.update(&h, v, anchor, 1);
        self.refresh_pin(v);
        Ok(())
    }

    /// Releases the pin of vertex `v` (no effect if it is not pinned).
    pub fn unpin_vertex(&mut self, v: u32) -> Result<(), TreeCutError> {
        self.check_vertex(v)?;
        let h = self.hierarchy.clone();
        if let Some(old) = self.pins.anchor[v as usize].take() {
            self.pins.update(&h, v, old, -1);
            self.refresh_pin(v);
        }
        Ok(())
    }

    /// The anchor of vertex `v`, if pinned.
    pub fn vertex_anchor(&self, v: u32) -> Option<Vec3> {
        self.pins.anchor.get(v as usize).copied().flatten()
    }

    /// Re-applies the pin state of the particle covering `v`.
    fn refresh_pin(&mut self, v: u32) {
        let Some(p) = self.particle_covering(v) else {
            return;
        };
        let node = self.particle_node[p.index()];
        match self
            .pins
            .pin_position(&self.hierarchy, node, self.rotation[node.index()])
        {
            Some(at) => self.body.set_anchor(p, at).expect("finite pin"),
            None => self.body.set_pinned(p, false).expect("particle exists"),
        }
    }

    /// Before a step: re-aims every pinned particle at the position that keeps its pinned
    /// vertices on their anchors under the node's current shape-matching rotation.
    pub(super) fn update_pins(&mut self) {
        if !self.pins.any(&self.hierarchy) {
            return;
        }
        let h = &*self.hierarchy;
        let mut anchored = std::mem::take(&mut self.scratch.particles);
        anchored.clear();
        anchored.extend(self.body.anchored_particles().map(|p| p.raw()));
        for &p in &anchored {
            let node = self.particle_node[p as usize];
            let x_p = self.body.positions()[p as usize].truncate();
            let rest_p = h.rest_position(node);
            let mut cov = Mat3::ZERO;
            for q in self.body.neighbours(ParticleId::from_raw(p)) {
                let q_node = self.particle_node[q.index()];
                crate::shape::accumulate(
                    &mut cov,
                    self.body.positions()[q.index()].truncate() - x_p,
                    h.rest_position(q_node) - rest_p,
                );
            }
            let rot = crate::shape::rotation_of(&cov, self.rotation[node.index()]);
            self.rotation[node.index()] = rot;
            if let Some(at) = self.pins.pin_position(h, node, rot) {
                self.body
                    .set_anchor(ParticleId::from_raw(p), at)
                    .expect("finite pin");
            }
        }
        self.scratch.particles = anchored;
    }
}
