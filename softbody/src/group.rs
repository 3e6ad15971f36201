//! Group links: distance links from one particle to the mass-weighted centroid of a group.
//!
//! TreeCut transitions never simulate a parent and its children at once. While a node is
//! being refined or coarsened, the parent exists only *virtually*, as the centroid
//! `c = Σ f_i x_i` (`f_i = m_i / M`) of its real children, and the parent's links to a
//! neighbour `q` become group links `C = |x_q - c| - rest`. The gradient is `n` for `q`
//! and `-f_i n` for child `i`, so the XPBD generalised inverse mass is
//! `W = w_q + Σ f_i² w_i` (`= w_q + 1/M` when no child is pinned) and the corrections
//! `Δx_q = w_q Δλ n`, `Δx_i = -w_i f_i Δλ n` conserve linear momentum exactly like a plain
//! link. Unpinned children all move by the same vector: the group behaves like the parent
//! particle it stands for, without a rigid coupling.
//!
//! There are few group links (transitions in flight × neighbours), so they are solved in a
//! small sequential pass after the coloured batches, in creation order (deterministic).
//! All links of one group share one blend weight.

use crate::kernel::{DENOM_FLOOR, LENGTH_FLOOR, Particles};
use glam::{Vec3A, Vec4};

/// Handle of a group in a body's group table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct GroupId(pub u32);

/// One link of a group: the single particle and the constraint data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct GroupTarget {
    pub(crate) particle: u32,
    pub(crate) rest: f32,
    pub(crate) compliance: f32,
    pub(crate) lambda: f32,
}

/// A set of particles standing for one virtual node, and its links to other particles.
#[derive(Clone, Debug, Default)]
pub(crate) struct Group {
    pub(crate) live: bool,
    pub(crate) members: Vec<u32>,
    pub(crate) fractions: Vec<f32>,
    pub(crate) targets: Vec<GroupTarget>,
    pub(crate) weight: f32,
}

impl Group {
    /// Mass-weighted centroid of the members.
    #[inline]
    pub(crate) fn centroid(&self, p: &[Vec4]) -> Vec3A {
        let mut c = Vec3A::ZERO;
        for (&m, &f) in self.members.iter().zip(&self.fractions) {
            c += Vec3A::from_vec4(p[m as usize]) * f;
        }
        c
    }

    /// One sequential sweep over this group's links. Solving a link moves every member by
    /// `-w_i f_i Δλ n`, which moves the centroid by `-W_group Δλ n` (`W_group = Σ f_i² w_i`), so
    /// the centroid is carried along instead of recomputed per link and the members are moved
    /// once, by the sum, at the end: the same sweep as moving them link by link (up to
    /// rounding), at one pass over the members instead of two per link.
    pub(crate) fn solve<P: Particles + ?Sized>(&mut self, p: &mut P, inv_h2: f32) {
        let mut w_group = 0.0f32;
        let mut c = Vec3A::ZERO;
        for (&m, &f) in self.members.iter().zip(&self.fractions) {
            let pm = p.get(m as usize);
            w_group += f * f * pm.w;
            c += Vec3A::from_vec4(pm) * f;
        }
        let weight = self.weight;
        let mut moved = Vec3A::ZERO;
        for t in &mut self.targets {
            let q = p.get(t.particle as usize);
            let d = Vec3A::from_vec4(q) - c;
            let len = d.length().max(LENGTH_FLOOR);
            let wq = q.w;
            let at = t.compliance * inv_h2;
            let cc = len - t.rest;
            let dl =
                (-(weight * cc) - at * t.lambda) / (weight * (wq + w_group) + at).max(DENOM_FLOOR);
            t.lambda += dl;
            let n = d * (dl / len);
            p.set(t.particle as usize, q + n.extend(0.0) * wq);
            c -= n * w_group;
            moved += n;
        }
        if moved != Vec3A::ZERO {
            for (&m, &f) in self.members.iter().zip(&self.fractions) {
                let pm = p.get(m as usize);
                p.set(m as usize, pm - moved.extend(0.0) * (pm.w * f));
            }
        }
    }
}

/// The table of groups of a body; freed slots are reused last-freed-first.
#[derive(Clone, Debug, Default)]
pub(crate) struct GroupStore {
    pub(crate) groups: Vec<Group>,
    free: Vec<u32>,
    live: usize,
}

impl GroupStore {
    /// Creates a group with the given members and mass fractions, no targets, weight `weight`.
    pub(crate) fn create(&mut self, members: &[u32], masses: &[f32], weight: f32) -> GroupId {
        let id = match self.free.pop() {
            Some(i) => i,
            None => {
                self.groups.push(Group::default());
                (self.groups.len() - 1) as u32
            }
        };
        let g = &mut self.groups[id as usize];
        g.live = true;
        g.members.clear();
        g.members.extend_from_slice(members);
        let total: f32 = masses.iter().sum();
        g.fractions.clear();
        g.fractions.extend(masses.iter().map(|m| m / total));
        g.targets.clear();
        g.weight = weight;
        self.live += 1;
        GroupId(id)
    }

    pub(crate) fn get(&self, id: GroupId) -> &Group {
        &self.groups[id.0 as usize]
    }
    pub(crate) fn get_mut(&mut self, id: GroupId) -> &mut Group {
        &mut self.groups[id.0 as usize]
    }

    /// Frees a group (its storage is kept for reuse).
    pub(crate) fn remove(&mut self, id: GroupId) {
        let g = &mut self.groups[id.0 as usize];
        debug_assert!(g.live);
        g.live = false;
        self.free.push(id.0);
        self.live -= 1;
    }

    /// Number of live group links (targets over all live groups).
    pub(crate) fn link_count(&self) -> usize {
        self.groups
            .iter()
            .filter(|g| g.live)
            .map(|g| g.targets.len())
            .sum()
    }

    /// Whether any group is live.
    pub(crate) fn is_empty(&self) -> bool {
        self.live == 0
    }

    pub(crate) fn reset_lambdas(&mut self) {
        for g in self.groups.iter_mut().filter(|g| g.live) {
            for t in &mut g.targets {
                t.lambda = 0.0;
            }
        }
    }

    pub(crate) fn solve<P: Particles + ?Sized>(&mut self, p: &mut P, inv_h2: f32) {
        for g in self.groups.iter_mut().filter(|g| g.live) {
            g.solve(p, inv_h2);
        }
    }

    /// Rewrites references to particle `from` into `to` (a particle moved by swap-removal).
    pub(crate) fn rename_particle(&mut self, from: u32, to: u32) {
        for g in self.groups.iter_mut().filter(|g| g.live) {
            for m in &mut g.members {
                if *m == from {
                    *m = to;
                }
            }
            for t in &mut g.targets {
                if t.particle == from {
                    t.particle = to;
                }
            }
        }
    }

    /// Renames every particle `p` to `new_of_old[p]` (a renumbering of all particles).
    pub(crate) fn remap_particles(&mut self, new_of_old: &[u32]) {
        for g in self.groups.iter_mut().filter(|g| g.live) {
            for m in &mut g.members {
                *m = new_of_old[*m as usize];
            }
            for t in &mut g.targets {
                t.particle = new_of_old[t.particle as usize];
            }
        }
    }

    /// Whether particle `p` takes part in any live group.
    pub(crate) fn references(&self, p: u32) -> bool {
        self.groups
            .iter()
            .filter(|g| g.live)
            .any(|g| g.members.contains(&p) || g.targets.iter().any(|t| t.particle == p))
    }
}
