//! Cuts chosen without feedback: the static baselines an adaptive cut is compared against
//! (uniform by level, random, near given vertices), and the general "grow by a key" they share.
//!
//! These are what a host uses when it wants a fixed level of detail, and what the
//! experiments use as baselines for the simulation paper's feedback loop
//! (`simulation-lod-treecut-softbody-bswdf.txt`, section 6).

use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::{Cut, CutError, Hierarchy, NodeId};

/// Refines from the root, always the node with the highest `key`, while the cut stays within
/// `nodes` nodes (a node whose children do not fit is skipped; a smaller fanout may still fit).
/// Ties go to the lower node id. O(n log n) in the cut size.
pub fn grow_cut(
    h: &Hierarchy,
    nodes: usize,
    key: impl FnMut(NodeId) -> u64,
) -> Result<Cut, CutError> {
    grow_cut_from(h, Cut::root(h), nodes, key)
}

/// [`grow_cut`] starting from `cut` (a valid cut of `h`) instead of the root: refines the
/// cut's nodes and their descendants, highest `key` first, while the cut stays within `nodes`.
pub fn grow_cut_from(
    h: &Hierarchy,
    mut cut: Cut,
    nodes: usize,
    mut key: impl FnMut(NodeId) -> u64,
) -> Result<Cut, CutError> {
    let mut heap = BinaryHeap::new();
    for &n in cut.active() {
        if !h.is_leaf(n) {
            heap.push((key(n), Reverse(n)));
        }
    }
    while let Some((_, Reverse(n))) = heap.pop() {
        if cut.len() + h.child_count(n) - 1 > nodes {
            continue;
        }
        cut.refine(h, n)?;
        for c in h.children(n) {
            if !h.is_leaf(c) {
                heap.push((key(c), Reverse(c)));
            }
        }
    }
    Ok(cut)
}

/// One seeded random `u32` per node of `h` (PCG-64 MCG from `seed`).
fn node_keys(h: &Hierarchy, seed: u64) -> Vec<u32> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    (0..h.len()).map(|_| rng.next_u32()).collect()
}

/// A cut of at most `nodes` nodes in which every region is at about the same depth: nodes of
/// coarser levels are refined first, those of one level in an order spread evenly over the
/// cloth (a fixed random key per node). O(n log n).
///
/// By level rather than by size: the quadtree of a grid whose side is not 2^k + 1 has larger
/// blocks along two edges (a 65-vertex side splits into 31 blocks of 2 and one of 3), and
/// refining the largest first would spend the whole remainder on a fine band along those
/// edges.
pub fn uniform_cut(h: &Hierarchy, nodes: usize) -> Result<Cut, CutError> {
    let keys = node_keys(h, 0x0123);
    // Coarser levels have higher level numbers (the finest is level 0).
    grow_cut(h, nodes, |n| {
        ((h.level(n) as u64) << 32) | keys[n.index()] as u64
    })
}

/// A cut of at most `nodes` nodes refined in random order (a fixed random key per node drawn
/// from `seed`). O(n log n).
pub fn random_cut(h: &Hierarchy, nodes: usize, seed: u64) -> Result<Cut, CutError> {
    let keys = node_keys(h, seed);
    grow_cut(h, nodes, |n| keys[n.index()] as u64)
}

/// A cut of at most `nodes` nodes that spends about `share` of them near `vertices` (finest
/// vertex indices, e.g. the pinned ones): a uniform cut of `(1 − share) · nodes` nodes, then
/// refined, nearest first, by each node's rest distance to the closest of `vertices` (the
/// smallest distance of any vertex it covers), until the budget is spent. A static cut that
/// knows where a held cloth is strained without simulating it. `share` is clamped to [0, 1];
/// no `vertices` gives the uniform cut. O(n·depth + n·|vertices|).
pub fn near_vertices_cut(
    h: &Hierarchy,
    nodes: usize,
    vertices: &[u32],
    share: f32,
) -> Result<Cut, CutError> {
    let share = if share.is_nan() {
        0.0
    } else {
        share.clamp(0.0, 1.0)
    };
    let base = ((1.0 - share as f64) * nodes as f64).round() as usize;
    let cut = uniform_cut(h, base.max(1))?;
    let rest = h.rest_positions();
    let targets: Vec<glam::Vec3> = vertices
        .iter()
        .filter(|&&v| (v as usize) < h.vertex_count())
        .map(|&v| rest[h.leaf_of_vertex(v).index()])
        .collect();
    if targets.is_empty() {
        return uniform_cut(h, nodes);
    }
    let vertex_distance: Vec<f32> = (0..h.vertex_count())
        .map(|v| {
            let p = rest[h.leaf_of_vertex(v as u32).index()];
            targets
                .iter()
                .map(|t| t.distance(p))
                .fold(f32::INFINITY, f32::min)
        })
        .collect();
    grow_cut_from(h, cut, nodes, |n| {
        let d = h
            .vertices(n)
            .iter()
            .map(|&v| vertex_distance[v as usize])
            .fold(f32::INFINITY, f32::min);
        // Nearer first: non-negative floats order like their bits.
        u64::from(u32::MAX - d.max(0.0).to_bits())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GridSpec;

    fn grid() -> Hierarchy {
        Hierarchy::grid(&GridSpec::horizontal(33, 33, 0.1, 0.01)).unwrap()
    }

    #[test]
    fn generated_cuts_are_valid_and_within_budget() {
        let h = grid();
        for nodes in [1, 7, 100, 500, 33 * 33, 10_000] {
            for cut in [
                uniform_cut(&h, nodes).unwrap(),
                random_cut(&h, nodes, 1).unwrap(),
                random_cut(&h, nodes, 2).unwrap(),
            ] {
                cut.check_invariant(&h).unwrap();
                assert!(cut.len() <= nodes.max(1), "{} > {nodes}", cut.len());
            }
        }
        // The whole budget: the finest cut.
        assert_eq!(uniform_cut(&h, 33 * 33).unwrap().len(), 33 * 33);
    }

    #[test]
    fn near_vertices_cut_is_valid_within_budget_and_finer_near_the_vertices() {
        let h = grid();
        let spec = GridSpec::horizontal(33, 33, 0.1, 0.01);
        let corners = [spec.vertex(0, 0), spec.vertex(32, 32)];
        for nodes in [1, 7, 100, 300, 33 * 33, 10_000] {
            for share in [0.0, 0.5, 1.0, f32::NAN] {
                let cut = near_vertices_cut(&h, nodes, &corners, share).unwrap();
                cut.check_invariant(&h).unwrap();
                assert!(cut.len() <= nodes.max(1), "{} > {nodes}", cut.len());
            }
        }
        // Half of 300 nodes near two corners: the nodes covering a corner are finer than the
        // uniform cut's there, and the centre is no finer.
        let near = near_vertices_cut(&h, 300, &corners, 0.5).unwrap();
        let uniform = uniform_cut(&h, 300).unwrap();
        assert!(near.len() > 250, "spent {} of 300", near.len());
        let level_at = |c: &Cut, v: u32| {
            let mut n = h.leaf_of_vertex(v);
            while !c.is_on_cut(n) {
                n = h.parent(n).unwrap();
            }
            h.level(n)
        };
        for &v in &corners {
            assert!(level_at(&near, v) < level_at(&uniform, v), "corner {v}");
        }
        let centre = spec.vertex(16, 16);
        assert!(level_at(&near, centre) >= level_at(&uniform, centre));
        // Share 0 is the uniform cut; no vertices too.
        let zero = near_vertices_cut(&h, 300, &corners, 0.0).unwrap();
        assert_eq!(zero.active(), uniform.active());
        let none = near_vertices_cut(&h, 300, &[], 0.5).unwrap();
        assert_eq!(none.active(), uniform.active());
    }

    #[test]
    fn uniform_cut_spans_fewer_levels_than_random() {
        let h = grid();
        let spread = |c: &Cut| {
            let levels: Vec<u32> = c.active().iter().map(|&n| h.level(n)).collect();
            levels.iter().max().unwrap() - levels.iter().min().unwrap()
        };
        let u = uniform_cut(&h, 300).unwrap();
        let r = random_cut(&h, 300, 7).unwrap();
        assert!(spread(&u) <= 1, "uniform spans {} levels", spread(&u));
        assert!(spread(&r) > spread(&u));
        // Seeded: the same seed gives the same cut, another seed another.
        let same = random_cut(&h, 300, 7).unwrap().active().to_vec();
        assert_eq!(r.active(), same);
        let other = random_cut(&h, 300, 8).unwrap().active().to_vec();
        assert_ne!(same, other);
    }
}
