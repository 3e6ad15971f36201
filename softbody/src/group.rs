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
//! small sequential pass after the coloured batches (deterministic). All links of one group
//! share one blend weight.
//!
//! # Four groups at a time
//! A group's links form one dependency chain: each waits for the centroid the previous one
//! moved (a square root and two divisions): about 16 ns per link and substep against 1.5 ns for
//! a link of a colour batch, so a cut that reshapes spent a fifth of its time there (sixty
//! transitions and 500 group links in flight on the perception net's cold start). Live groups
//! are therefore taken four at a time, in slot order, and their links interleaved (the first
//! link of each, then the second of each, ...): four independent chains the core overlaps. Each
//! link's arithmetic is unchanged; what changes is the order of the sequential sweep, which is
//! fixed (deterministic) and as valid a Gauss–Seidel order as one group after the other — and,
//! for groups without a particle in common, the very same computation (test
//! `interleaved_sweep_matches_one_group_after_another`). Two groups may share a neighbour (a
//! node next to two transitions is locked by both); their links on it then run in another
//! sequence, as under a different colouring. On that cold start (the net's first 30 steps at
//! 30% of its nodes, one thread's CPU time, best of five): 0.464 → 0.410 ms per step.

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

    /// The start of a sweep over this group's links: its generalised inverse mass
    /// `W_group = Σ f_i² w_i` and centroid.
    #[inline]
    fn sweep_start<P: Particles + ?Sized>(&self, p: &P) -> Sweep {
        let mut w_group = 0.0f32;
        let mut c = Vec3A::ZERO;
        for (&m, &f) in self.members.iter().zip(&self.fractions) {
            let pm = p.get(m as usize);
            w_group += f * f * pm.w;
            c += Vec3A::from_vec4(pm) * f;
        }
        Sweep {
            w_group,
            c,
            moved: Vec3A::ZERO,
        }
    }

    /// Solves link `k` of this group in the sweep `sw`. Solving a link moves every member by
    /// `-w_i f_i Δλ n`, which moves the centroid by `-W_group Δλ n`, so the centroid is carried
    /// along instead of recomputed per link and the members are moved once, by the sum, at the
    /// end ([`Group::sweep_end`]): the same sweep as moving them link by link (up to rounding),
    /// at one pass over the members instead of two per link.
    #[inline(always)]
    fn solve_link<P: Particles + ?Sized>(
        &mut self,
        k: usize,
        sw: &mut Sweep,
        p: &mut P,
        inv_h2: f32,
    ) {
        let weight = self.weight;
        let t = &mut self.targets[k];
        let q = p.get(t.particle as usize);
        let d = Vec3A::from_vec4(q) - sw.c;
        let len = d.length().max(LENGTH_FLOOR);
        let wq = q.w;
        let at = t.compliance * inv_h2;
        let cc = len - t.rest;
        let dl =
            (-(weight * cc) - at * t.lambda) / (weight * (wq + sw.w_group) + at).max(DENOM_FLOOR);
        t.lambda += dl;
        let n = d * (dl / len);
        p.set(t.particle as usize, q + n.extend(0.0) * wq);
        sw.c -= n * sw.w_group;
        sw.moved += n;
    }

    /// Moves the members by the sweep's summed correction.
    #[inline]
    fn sweep_end<P: Particles + ?Sized>(&self, sw: &Sweep, p: &mut P) {
        if sw.moved != Vec3A::ZERO {
            for (&m, &f) in self.members.iter().zip(&self.fractions) {
                let pm = p.get(m as usize);
                p.set(m as usize, pm - sw.moved.extend(0.0) * (pm.w * f));
            }
        }
    }

    /// One sequential sweep over this group's links alone.
    pub(crate) fn solve<P: Particles + ?Sized>(&mut self, p: &mut P, inv_h2: f32) {
        let mut sw = self.sweep_start(p);
        for k in 0..self.targets.len() {
            self.solve_link(k, &mut sw, p, inv_h2);
        }
        self.sweep_end(&sw, p);
    }
}

/// The running state of one group's sweep: its generalised inverse mass, its centroid (moved
/// by each link solved) and the correction its members take at the end.
#[derive(Clone, Copy, Debug)]
struct Sweep {
    w_group: f32,
    c: Vec3A,
    moved: Vec3A,
}

/// Four groups' sweeps side by side: link `k` of each in turn (a group out of links skips), four
/// independent dependency chains in registers.
#[inline]
fn solve_four<P: Particles + ?Sized>(g: [&mut Group; 4], p: &mut P, inv_h2: f32) {
    let [g0, g1, g2, g3] = g;
    let (mut s0, mut s1, mut s2, mut s3) = (
        g0.sweep_start(p),
        g1.sweep_start(p),
        g2.sweep_start(p),
        g3.sweep_start(p),
    );
    let (n0, n1, n2, n3) = (
        g0.targets.len(),
        g1.targets.len(),
        g2.targets.len(),
        g3.targets.len(),
    );
    let common = n0.min(n1).min(n2).min(n3);
    for k in 0..common {
        g0.solve_link(k, &mut s0, p, inv_h2);
        g1.solve_link(k, &mut s1, p, inv_h2);
        g2.solve_link(k, &mut s2, p, inv_h2);
        g3.solve_link(k, &mut s3, p, inv_h2);
    }
    for k in common..n0.max(n1).max(n2).max(n3) {
        if k < n0 {
            g0.solve_link(k, &mut s0, p, inv_h2);
        }
        if k < n1 {
            g1.solve_link(k, &mut s1, p, inv_h2);
        }
        if k < n2 {
            g2.solve_link(k, &mut s2, p, inv_h2);
        }
        if k < n3 {
            g3.solve_link(k, &mut s3, p, inv_h2);
        }
    }
    g0.sweep_end(&s0, p);
    g1.sweep_end(&s1, p);
    g2.sweep_end(&s2, p);
    g3.sweep_end(&s3, p);
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

    /// One sweep over every live group's links: four groups at a time, in slot order, their
    /// links interleaved (see the module docs).
    pub(crate) fn solve<P: Particles + ?Sized>(&mut self, p: &mut P, inv_h2: f32) {
        let mut live = self.groups.iter_mut().filter(|g| g.live);
        loop {
            let (Some(g0), g1, g2, g3) = (live.next(), live.next(), live.next(), live.next())
            else {
                return;
            };
            match (g1, g2, g3) {
                (Some(g1), Some(g2), Some(g3)) => solve_four([g0, g1, g2, g3], p, inv_h2),
                (g1, g2, _) => {
                    for g in [Some(g0), g1, g2].into_iter().flatten() {
                        g.solve(p, inv_h2);
                    }
                }
            }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Groups over disjoint particles (members and neighbours), seven of them (a chunk of four,
    /// then three) with a freed slot between: the interleaved sweep computes exactly, bit for
    /// bit, what solving the groups one after the other computes, and linear momentum is
    /// conserved (no member pinned: every link's corrections cancel in the mass-weighted sum).
    #[test]
    fn interleaved_sweep_matches_one_group_after_another() {
        let mut store = GroupStore::default();
        let mut p: Vec<Vec4> = Vec::new();
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut unit = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        for g in 0..8u32 {
            let mut members = Vec::new();
            for _ in 0..2 + g % 3 {
                members.push(p.len() as u32);
                p.push(Vec4::new(unit(), unit(), unit(), 0.5 + unit()));
            }
            let masses: Vec<f32> = members.iter().map(|_| 0.5 + unit()).collect();
            let id = store.create(&members, &masses, 0.25 + 0.75 * unit());
            for _ in 0..1 + (g * 3) % 9 {
                let q = p.len() as u32;
                p.push(Vec4::new(unit() + 1.0, unit(), unit() - 1.0, 0.5 + unit()));
                store.get_mut(id).targets.push(GroupTarget {
                    particle: q,
                    rest: 0.5 * unit(),
                    compliance: 1e-4 * unit(),
                    lambda: 0.0,
                });
            }
        }
        store.remove(GroupId(3));
        let momentum = |p: &[Vec4]| {
            p.iter().fold(glam::DVec3::ZERO, |acc, v| {
                acc + v.truncate().as_dvec3() / f64::from(v.w)
            })
        };
        let (mut one, mut all) = (store.clone(), store.clone());
        let (mut p_one, mut p_all) = (p.clone(), p.clone());
        for _ in 0..3 {
            for g in one.groups.iter_mut().filter(|g| g.live) {
                g.solve(p_one.as_mut_slice(), 3600.0);
            }
            all.solve(p_all.as_mut_slice(), 3600.0);
        }
        let bits = |p: &[Vec4]| -> Vec<[u32; 4]> {
            p.iter().map(|v| v.to_array().map(f32::to_bits)).collect()
        };
        assert_eq!(bits(&p_all), bits(&p_one));
        assert_ne!(bits(&p_all), bits(&p), "the sweeps moved something");
        let lambdas = |s: &GroupStore| -> Vec<u32> {
            s.groups
                .iter()
                .flat_map(|g| g.targets.iter().map(|t| t.lambda.to_bits()))
                .collect()
        };
        assert_eq!(lambdas(&all), lambdas(&one));
        let (before, after) = (momentum(&p), momentum(&p_all));
        assert!(
            (after - before).length() < 1e-4 * before.length(),
            "{before} {after}"
        );
    }
}
