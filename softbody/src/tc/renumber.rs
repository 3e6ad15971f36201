//! Spatial renumbering of a TreeCut body's particles.
//!
//! Particle storage is dense: a transition's new particles go to the end and its removed ones
//! are swap-removed, so after many refines and coarses neighbouring nodes sit far apart in
//! memory and the link kernel's gathers miss the cache (a 75 % cut reached by operations cost
//! about 30 % more per link-iteration than the same cut built at once). Every so often the body
//! puts its particles back in the order of their nodes' smallest finest-vertex index — for a grid
//! quadtree, row-major order, the order [`TreeCutSoftBody::new`] uses — and re-colours the links
//! in canonical order. At the finest cut the result is the plain grid cloth's numbering exactly.
//!
//! # Determinism rule
//! Renumbering moves every particle's state (position, velocity, mass, pin, forces, collision
//! flag, group membership) with the particle and keeps every link (ids, ends, rest length,
//! compliance, weight): it is a permutation, tested as one. What it does change is the order in
//! which the same constraints are solved — the colour batches, as a function of the new
//! numbering — so later results differ from those without renumbering by what that reordering
//! implies (Gauss–Seidel order), and by nothing else. When it happens is a function of the
//! sequence of operations only (particles added and removed since the last renumbering), never
//! of time or threads: the same calls give the same bits.

use super::TreeCutSoftBody;

/// Renumber once the particles added or removed since the last renumbering reach this
/// fraction of the particle count.
const CHURN_FRACTION: f32 = 0.25;

impl TreeCutSoftBody {
    /// Puts the particles in spatial order now (see the module docs); returns whether the order
    /// changed. [`TreeCutSoftBody::step`] does this by itself once enough particles have come
    /// and gone; particle ids change, node ids do not.
    pub fn renumber_particles(&mut self) -> bool {
        self.churn = 0;
        let h = &*self.hierarchy;
        let key = |p: usize| {
            let n = self.particle_node[p];
            h.vertices(n).iter().copied().min().unwrap_or(u32::MAX)
        };
        let mut order: Vec<u32> = (0..self.particle_node.len() as u32).collect();
        order.sort_by_cached_key(|&p| key(p as usize));
        if order.iter().enumerate().all(|(i, &p)| i as u32 == p) {
            return false;
        }
        self.body.permute_particles(&order);
        let old_nodes = std::mem::take(&mut self.particle_node);
        self.particle_node = order.iter().map(|&p| old_nodes[p as usize]).collect();
        for (p, n) in self.particle_node.iter().enumerate() {
            self.node_particle[n.index()] = p as u32;
        }
        true
    }

    /// Whether [`TreeCutSoftBody::step`] renumbers by itself (default true). Hosts that keep
    /// particle ids across steps, or benchmarks measuring the unrenumbered order, turn it off.
    pub fn set_auto_renumber(&mut self, enabled: bool) {
        self.auto_renumber = enabled;
    }

    /// Renumbers when the churn since the last renumbering is large enough.
    pub(super) fn renumber_if_scattered(&mut self) {
        if !self.auto_renumber {
            return;
        }
        let n = self.particle_node.len() as f32;
        if self.churn as f32 >= (CHURN_FRACTION * n).max(16.0) {
            self.renumber_particles();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{Rng, body, pin_corners, random_op};
    use glam::Vec4;
    use std::collections::BTreeMap;

    /// A pinned 17×17 net after many random operations and steps, with transitions just begun.
    fn scattered_body() -> super::TreeCutSoftBody {
        let mut tc = body(17, 2, true);
        pin_corners(&mut tc, 17);
        let mut rng = Rng::new(7);
        for _ in 0..80 {
            random_op(&mut tc, &mut rng);
            random_op(&mut tc, &mut rng);
            tc.step();
        }
        // Two refines just begun: their children sit at the end of the particle storage.
        let mut begun = 0;
        for n in tc.cut().active().to_vec() {
            if begun < 2 && tc.begin_refine(n).is_ok() {
                begun += 1;
            }
        }
        assert_eq!(begun, 2);
        tc
    }

    /// Everything about the body keyed by node, not by particle index: a renumbering must
    /// leave it unchanged, bit for bit.
    fn by_node(tc: &super::TreeCutSoftBody) -> (BTreeMap<u32, [u32; 13]>, Vec<[u32; 5]>) {
        let nodes = tc.particle_nodes();
        let bits = |v: Vec4| v.to_array().map(f32::to_bits);
        let mut particles = BTreeMap::new();
        for (p, n) in nodes.iter().enumerate() {
            let x = bits(tc.particle_positions()[p]);
            let v = bits(tc.particle_velocities()[p]);
            let m = tc.particle_masses()[p].to_bits();
            let c = u32::from(tc.body().collides(softbody_pid(p)));
            let mut all = [0u32; 13];
            all[..4].copy_from_slice(&x);
            all[4..8].copy_from_slice(&v);
            all[8] = m;
            all[9] = c;
            all[10] = u32::from(tc.body().is_pinned(softbody_pid(p)));
            particles.insert(n.raw(), all);
        }
        let mut links: Vec<[u32; 5]> = tc
            .links()
            .map(|l| {
                let (a, b) = (nodes[l.a.index()].raw(), nodes[l.b.index()].raw());
                [
                    l.id.raw(),
                    a.min(b),
                    a.max(b),
                    l.rest.to_bits(),
                    l.weight.to_bits() ^ l.compliance.to_bits().rotate_left(7),
                ]
            })
            .collect();
        links.sort_unstable();
        (particles, links)
    }

    fn softbody_pid(p: usize) -> crate::ParticleId {
        crate::ParticleId::new(p)
    }

    /// Renumbering after many operations (with transitions in flight) is a permutation: every
    /// node keeps its position, velocity, mass, pin and flags, every link its ends, rest length,
    /// compliance, weight and id; the tables stay consistent; the particles end up sorted.
    #[test]
    fn renumbering_is_a_permutation() {
        let mut tc = scattered_body();
        assert!(tc.transitions_in_flight() > 0);
        let before = by_node(&tc);
        let groups_before = tc.group_link_count();
        assert!(
            tc.renumber_particles(),
            "operations left the particles out of order"
        );
        tc.check();
        assert_eq!(by_node(&tc), before);
        assert_eq!(tc.group_link_count(), groups_before);
        assert!(
            !tc.renumber_particles(),
            "a second renumbering changes nothing"
        );
        // Transitions in flight still end and the body still steps consistently.
        for _ in 0..10 {
            tc.step();
        }
        tc.check();
        assert_eq!(tc.transitions_in_flight(), 0);
    }

    /// Two bodies given the same calls stay bit-identical through automatic renumberings.
    #[test]
    fn automatic_renumbering_is_deterministic() {
        let (mut a, mut b) = (scattered_body(), scattered_body());
        for _ in 0..20 {
            a.step();
            b.step();
        }
        assert_eq!(by_node(&a), by_node(&b));
        assert_eq!(a.particle_nodes(), b.particle_nodes());
    }
}
