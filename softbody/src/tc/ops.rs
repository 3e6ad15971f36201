//! The two halves of refine and coarse.
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), section 3.3 (beginning an operation) and 3.4 (ending
//! it).
//!
//! **begin_refine(P)** — P's particle is replaced by one particle per child: masses from the
//! hierarchy (they sum to P's), positions `x_P + R (rest(child) − rest(P))` with `R` the
//! shape-matching rotation of P's current neighbourhood onto its rest neighbourhood (so a
//! bent or swung cloth refines without popping), shifted so that the mass-weighted centroid
//! is exactly `x_P`; every child gets P's velocity, so the total momentum is unchanged.
//! (An angular velocity part consistent with R would also sum to zero momentum; it is left
//! out because a single node's neighbourhood gives no reliable spin estimate. Measured: giving
//! each child the neighbourhood's affine velocity field instead — the least-squares velocity
//! gradient over P's linked neighbours' rest offsets, its mass-weighted mean removed so the
//! momentum stays exact — moved the perception scenes' figures at 30% of the nodes both ways
//! and within noise: RMS net 0.942 → 0.953 px, off-screen 2.09 → 2.06, dolly 0.938 → 0.921,
//! curtain 8.76 → 8.94; pops at operations net 2.33 → 2.98, dolly 2.92 → 1.80.) P's links to
//! its neighbours Q become *group links* from Q to the children's centroid — the virtual P —
//! which fade out, while new links child–Q (for every Q adjacent to that child) fade in. Links
//! between adjacent siblings start at full weight: the children are placed at their rotated
//! rest layout, so those links start near rest.
//!
//! **begin_coarse(P)** — the children stay real during the blend. A group link from the
//! children's centroid to each distinct external neighbour Q fades in; the children's links to
//! those neighbours fade out; sibling links stay.
//!
//! **end** — refine: the group is deleted, the new links are at full weight, the children
//! join collision. Coarse: the children are replaced by one particle for P with the total
//! mass, the mass-weighted centroid as position and the mass-weighted mean velocity (exact
//! conservation), the group links become plain P–Q links and the children's links go with
//! them. Links are removed by O(1) swap-removal in their colour batch, which cannot change
//! what the other links compute (see the crate docs).
//!
//! Locks: P, its children and all its (their) neighbours are locked in the cut until the end.

use super::{NO_PARTICLE, Transition, TransitionKind, TreeCutError, TreeCutSoftBody};
use crate::group::GroupId;
use crate::ids::ParticleId;
use crate::shape;
use glam::{DVec3, Mat3};
use std::sync::Arc;
use treecut::{NodeId, Op};

impl TreeCutSoftBody {
    fn take_transition(
        &mut self,
        kind: TransitionKind,
        node: NodeId,
        group: GroupId,
    ) -> Transition {
        let mut t = self.spare.pop().unwrap_or_else(|| Transition {
            kind,
            node,
            steps_done: 0,
            group,
            fade_in: Vec::new(),
            fade_out: Vec::new(),
            locked: Vec::new(),
        });
        t.kind = kind;
        t.node = node;
        t.steps_done = 0;
        t.group = group;
        t.fade_in.clear();
        t.fade_out.clear();
        t.locked.clear();
        t
    }

    /// Appends to `out` the nodes that beginning `op` now would lock until its transition ends,
    /// each once: exactly what [`TreeCutSoftBody::begin_refine`] and
    /// [`TreeCutSoftBody::begin_coarse`] lock. A refine locks the node's children and every
    /// node whose particle is linked to the node's; a coarse locks the parent, its children and
    /// every node whose particle is linked to a child from outside the family. Links are the
    /// induced mesh adjacency, so for an operation that can begin these are its nodes and every
    /// node of the cut next to the refined node or merged parent (`Hierarchy::adjacent`).
    ///
    /// This is the lock rule [`treecut::Evaluator::evaluate_with_locks`] takes, so that every
    /// operation of a batch it plans begins. Answered for the body as it is now; for an
    /// operation that could not begin now the answer means nothing (but nothing panics).
    pub fn would_lock(&self, op: Op, out: &mut Vec<NodeId>) {
        let h = &*self.hierarchy;
        if !h.contains(op.node()) {
            return;
        }
        match op {
            Op::Refine(node) => {
                out.extend(h.children(node));
                if let Some(p) = self.particle_of(node) {
                    out.extend(
                        self.body
                            .incident_raw(p.raw())
                            .iter()
                            .map(|&(_, q)| self.particle_node[q as usize]),
                    );
                }
            }
            Op::Coarse(parent) => {
                out.push(parent);
                out.extend(h.children(parent));
                // Each external neighbour once, however many children it is linked to.
                let start = out.len();
                for k in h.children(parent) {
                    let Some(c) = self.particle_of(k) else {
                        continue;
                    };
                    for &(_, o) in self.body.incident_raw(c.raw()) {
                        let q = self.particle_node[o as usize];
                        if h.parent(q) != Some(parent) && !out[start..].contains(&q) {
                            out.push(q);
                        }
                    }
                }
            }
        }
    }

    /// Begins refining active node `node`: its particle is replaced by its children's, placed by
    /// shape matching, conserving mass and momentum, with blended links (see the crate docs).
    /// Refused, changing nothing,
    /// if the node is not on the cut, is a leaf, or is locked by a transition in flight.
    pub fn begin_refine(&mut self, node: NodeId) -> Result<(), TreeCutError> {
        let h = Arc::clone(&self.hierarchy);
        self.cut.can_refine(&h, node)?;
        let p = self.node_particle[node.index()];
        debug_assert_ne!(p, NO_PARTICLE);
        let x_p = self.body.positions()[p as usize].truncate();
        let v_p = self.body.velocities()[p as usize].truncate();
        let rest_p = h.rest_position(node);

        // 1. The old neighbours (all linked by plain, full-weight links: the node is unlocked),
        //    and the covariance of the neighbourhood for shape matching. Rest lengths and
        //    compliances follow from the hierarchy and the material, as when the links were made.
        let material = self.settings.material;
        let sc = &mut self.scratch;
        sc.nodes.clear();
        sc.rest.clear();
        sc.compliance.clear();
        let mut cov = Mat3::ZERO;
        for &(_, q) in self.body.incident_raw(p) {
            let q_node = self.particle_node[q as usize];
            let rest_offset = h.rest_position(q_node) - rest_p;
            let rest = rest_offset.length();
            sc.nodes.push(q_node);
            sc.rest.push(rest);
            sc.compliance.push(material.stretch(rest));
            let x_q = self.body.positions()[q as usize].truncate();
            shape::accumulate(&mut cov, x_q - x_p, rest_offset);
        }
        let rot = shape::rotation_of(&cov, self.rotation[node.index()]);
        self.rotation[node.index()] = rot;

        // 2. Child placement: rotated rest offsets, then shifted so that the centroid is x_P.
        let kids = h.children(node);
        sc.positions.clear();
        sc.masses.clear();
        let mut centroid = DVec3::ZERO;
        let mut mass = 0f64;
        for k in kids {
            let x = x_p + rot * (h.rest_position(k) - rest_p);
            let m = h.mass(k);
            centroid += x.as_dvec3() * m as f64;
            mass += m as f64;
            sc.positions.push(x);
            sc.masses.push(m);
        }
        let shift = x_p.as_dvec3() - centroid / mass;
        for x in &mut sc.positions {
            *x = (x.as_dvec3() + shift).as_vec3();
        }

        // 3. Swap P's particle (and its links) for the children's.
        self.remove_node_particle(p);
        let mut members = std::mem::take(&mut self.scratch.particles);
        members.clear();
        for (i, k) in kids.enumerate() {
            let (x, m) = (self.scratch.positions[i], self.scratch.masses[i]);
            let c = self.add_node_particle(k, x, v_p, m);
            let joins =
                self.surface.transition_collision == super::TransitionCollision::Immediately;
            self.body.set_collides(ParticleId::from_raw(c), joins);
            self.rotation[k.index()] = rot;
            members.push(c);
        }

        // 4. The virtual parent: group links from each old neighbour to the children's centroid.
        let group = self.body.create_group(&members, &self.scratch.masses, 1.0);
        for i in 0..self.scratch.nodes.len() {
            let q = self.node_particle[self.scratch.nodes[i].index()];
            self.body
                .add_group_target(group, q, self.scratch.rest[i], self.scratch.compliance[i]);
        }
        let mut t = self.take_transition(TransitionKind::Refine, node, group);

        // 5. Sibling links at full weight (adjacent siblings are each other's level
        //    neighbours), child–neighbour links fading in.
        let first = kids.start;
        for (i, a) in kids.enumerate() {
            for &b in h.level_neighbours(a) {
                if b > a && kids.contains(b) {
                    let rest = (h.rest_position(a) - h.rest_position(b)).length();
                    let j = (b.raw() - first) as usize;
                    self.body.add_link_raw(
                        members[i],
                        members[j],
                        rest,
                        material.stretch(rest),
                        1.0,
                    );
                }
            }
        }
        // Each child's neighbours: walk up from its same-level neighbours to the node that is
        // simulated there (a neighbour of P, since the child is inside P). Neighbours finer
        // than the children are not reached that way and are tested directly.
        let max_q_level = self
            .scratch
            .nodes
            .iter()
            .map(|&q| h.level(q))
            .max()
            .unwrap_or(0);
        let mut found = std::mem::take(&mut self.scratch.found);
        for (i, k) in kids.enumerate() {
            found.clear();
            for &y in h.level_neighbours(k) {
                if kids.contains(y) {
                    continue;
                }
                let mut n = y;
                loop {
                    if self.node_particle[n.index()] != NO_PARTICLE {
                        if !found.contains(&n) {
                            found.push(n);
                        }
                        break;
                    }
                    if h.level(n) >= max_q_level {
                        break;
                    }
                    match h.parent(n) {
                        Some(up) => n = up,
                        None => break,
                    }
                }
            }
            let level_k = h.level(k);
            for &q_node in &self.scratch.nodes {
                if h.level(q_node) < level_k && !found.contains(&q_node) && h.adjacent(k, q_node) {
                    found.push(q_node);
                }
            }
            for &q_node in &found {
                let q = self.node_particle[q_node.index()];
                let rest = (h.rest_position(k) - h.rest_position(q_node)).length();
                let id = self
                    .body
                    .add_link_raw(members[i], q, rest, material.stretch(rest), 0.0);
                t.fade_in.push(id);
            }
        }
        self.scratch.found = found;
        self.scratch.particles = members;

        // 6. The cut, and the locks.
        self.cut.refine(&h, node).expect("checked by can_refine");
        for k in kids {
            self.cut.lock(k);
            t.locked.push(k);
        }
        for &q in &self.scratch.nodes {
            self.cut.lock(q);
            t.locked.push(q);
        }
        self.transitions.push(t);
        Ok(())
    }

    /// Begins coarsening: the children of `parent` (all active, none locked) will be replaced
    /// by `parent`. Refused, changing nothing, otherwise.
    pub fn begin_coarse(&mut self, parent: NodeId) -> Result<(), TreeCutError> {
        let h = Arc::clone(&self.hierarchy);
        self.cut.can_coarse(&h, parent)?;
        let kids = h.children(parent);
        let n = self.particle_count();
        let sc = &mut self.scratch;
        if sc.stamp.len() < n {
            sc.stamp.resize(n, 0);
        }
        if sc.stamp_counter > u32::MAX - 4 {
            sc.stamp.fill(0);
            sc.stamp_counter = 0;
        }
        sc.stamp_counter += 2;
        let (sibling, seen) = (sc.stamp_counter - 1, sc.stamp_counter);
        sc.particles.clear();
        sc.masses.clear();
        for k in kids {
            let c = self.node_particle[k.index()];
            debug_assert_ne!(c, NO_PARTICLE);
            sc.stamp[c as usize] = sibling;
            sc.particles.push(c);
            sc.masses.push(h.mass(k));
        }
        // External neighbours (distinct, in order of discovery) and the links that fade out.
        let group = self.body.create_group(&sc.particles, &sc.masses, 0.0);
        let mut t = self.take_transition(TransitionKind::Coarse, parent, group);
        let sc = &mut self.scratch;
        sc.nodes.clear();
        for &c in &sc.particles {
            for &(l, o) in self.body.incident_raw(c) {
                if sc.stamp[o as usize] == sibling {
                    continue;
                }
                t.fade_out.push(l);
                if sc.stamp[o as usize] != seen {
                    sc.stamp[o as usize] = seen;
                    sc.nodes.push(self.particle_node[o as usize]);
                }
            }
        }
        let material = self.settings.material;
        let rest_parent = h.rest_position(parent);
        for &q_node in &self.scratch.nodes {
            let q = self.node_particle[q_node.index()];
            let rest = (rest_parent - h.rest_position(q_node)).length();
            self.body
                .add_group_target(group, q, rest, material.stretch(rest));
        }
        self.cut.coarse(&h, parent).expect("checked by can_coarse");
        self.cut.lock(parent);
        t.locked.push(parent);
        for k in kids {
            self.cut.lock(k);
            t.locked.push(k);
        }
        for &q in &self.scratch.nodes {
            self.cut.lock(q);
            t.locked.push(q);
        }
        self.transitions.push(t);
        Ok(())
    }

    /// Ends a refine: the virtual parent's group links go, the new links are at full weight
    /// and the children take part in collision.
    pub(super) fn end_refine(&mut self, t: &Transition) {
        self.body.remove_group(t.group);
        for &l in &t.fade_in {
            self.body.set_link_weight_raw(l, 1.0);
        }
        for k in self.hierarchy.children(t.node) {
            let p = self.node_particle[k.index()];
            self.body.set_collides(ParticleId::from_raw(p), true);
        }
    }

    /// Ends a coarse: the children merge into one particle (exact mass, centroid and
    /// momentum), whose group links become plain links.
    pub(super) fn end_coarse(&mut self, t: &Transition) {
        let h = Arc::clone(&self.hierarchy);
        let kids = h.children(t.node);
        let mut mass = 0f64;
        let mut centroid = DVec3::ZERO;
        let mut momentum = DVec3::ZERO;
        for k in kids {
            let p = self.node_particle[k.index()] as usize;
            let m = self.body.masses()[p] as f64;
            mass += m;
            centroid += self.body.positions()[p].truncate().as_dvec3() * m;
            momentum += self.body.velocities()[p].truncate().as_dvec3() * m;
        }
        let x = (centroid / mass).as_vec3();
        let v = (momentum / mass).as_vec3();
        // Keep the group links' data by node (particle indices move as children are removed).
        let sc = &mut self.scratch;
        sc.nodes.clear();
        sc.rest.clear();
        sc.compliance.clear();
        for target in &self.body.group(t.group).targets {
            sc.nodes.push(self.particle_node[target.particle as usize]);
            sc.rest.push(target.rest);
            sc.compliance.push(target.compliance);
        }
        self.body.remove_group(t.group);
        // Highest index first: children created together sit at the end of the arrays, and
        // removing the last particle moves nobody.
        let mut doomed = std::mem::take(&mut self.scratch.particles);
        doomed.clear();
        doomed.extend(kids.map(|k| self.node_particle[k.index()]));
        doomed.sort_unstable_by(|a, b| b.cmp(a));
        for &p in &doomed {
            self.remove_node_particle(p);
        }
        self.scratch.particles = doomed;
        let p = self.add_node_particle(t.node, x, v, mass as f32);
        for i in 0..self.scratch.nodes.len() {
            let q = self.node_particle[self.scratch.nodes[i].index()];
            self.body
                .add_link_raw(p, q, self.scratch.rest[i], self.scratch.compliance[i], 1.0);
        }
        if let Some(k) = kids.first() {
            self.rotation[t.node.index()] = self.rotation[k.index()];
        }
    }
}
