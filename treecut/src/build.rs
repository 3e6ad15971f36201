//! Assembles a hierarchy from a stack of clusterings, shared by the grid and mesh builders.
//!
//! A builder supplies the finest level (positions, masses, mesh edges) and, per level, which
//! cluster of the next coarser level each node joins. This module lays the nodes out breadth first
//! (children contiguous, each level contiguous), computes centroids, masses, vertex runs and the
//! same-level neighbour lists.

use glam::{DVec3, Vec3};

use crate::hierarchy::{Hierarchy, NO_PARENT, NodeLinks};
use crate::{NodeId, NodeRange};

/// The finest level plus the clustering of each level into the next.
pub(crate) struct LevelStack {
    pub(crate) positions: Vec<Vec3>,
    pub(crate) masses: Vec<f32>,
    /// Mesh edges between vertices, smaller index first, sorted and deduplicated.
    pub(crate) edges: Vec<[u32; 2]>,
    /// `parents[l][i]`: the cluster (node index within level l+1) of node `i` of level `l`.
    /// The last level has exactly one node.
    pub(crate) parents: Vec<Vec<u32>>,
}

/// Sorted, deduplicated edges of the quotient graph: edges whose ends fall in different clusters.
pub(crate) fn quotient_edges(edges: &[[u32; 2]], cluster: &[u32]) -> Vec<[u32; 2]> {
    let mut out: Vec<[u32; 2]> = edges
        .iter()
        .filter_map(|&[a, b]| {
            let (ca, cb) = (cluster[a as usize], cluster[b as usize]);
            (ca != cb).then(|| [ca.min(cb), ca.max(cb)])
        })
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

impl LevelStack {
    /// Lays the levels out as an arena and computes every derived per-node quantity.
    pub(crate) fn assemble(self) -> Hierarchy {
        let LevelStack {
            positions,
            masses,
            edges,
            parents,
        } = self;
        let n_levels = parents.len() + 1;
        // Node counts per level (level 0 = vertices).
        let mut counts = vec![positions.len()];
        for p in &parents {
            counts.push(p.iter().map(|&c| c as usize + 1).max().unwrap_or(0));
        }
        debug_assert_eq!(*counts.last().unwrap(), 1);

        // children[l][c]: nodes of level l grouped by their cluster c at level l+1 (counting sort,
        // stable so children keep their within-level order).
        let mut child_lists: Vec<(Vec<u32>, Vec<u32>)> = Vec::with_capacity(parents.len());
        for (l, p) in parents.iter().enumerate() {
            let nc = counts[l + 1];
            let mut offsets = vec![0u32; nc + 1];
            for &c in p {
                offsets[c as usize + 1] += 1;
            }
            for i in 0..nc {
                offsets[i + 1] += offsets[i];
            }
            let mut fill = offsets.clone();
            let mut members = vec![0u32; p.len()];
            for (i, &c) in p.iter().enumerate() {
                members[fill[c as usize] as usize] = i as u32;
                fill[c as usize] += 1;
            }
            child_lists.push((offsets, members));
        }

        // Breadth-first arena: arena_of[l][i] is the NodeId of node i of level l.
        let total: usize = counts.iter().sum();
        let mut arena_of: Vec<Vec<u32>> = counts.iter().map(|&c| vec![0u32; c]).collect();
        let mut links = vec![
            NodeLinks {
                parent: NO_PARENT,
                first_child: 0,
                child_count: 0,
                level: 0,
                vertex_start: 0,
                vertex_end: 0,
            };
            total
        ];
        // Level-local index of each arena slot, to find members again.
        let mut local = vec![0u32; total];
        let mut level_ranges = vec![NodeRange::default(); n_levels];
        let top = n_levels - 1;
        arena_of[top][0] = 0;
        links[0].level = top as u32;
        level_ranges[top] = NodeRange { start: 0, end: 1 };
        let mut next = 1u32;
        for l in (0..top).rev() {
            let (offsets, members) = &child_lists[l];
            let start = next;
            let parent_range = level_ranges[l + 1];
            for pid in parent_range.start..parent_range.end {
                let c = local[pid as usize] as usize;
                let kids = &members[offsets[c] as usize..offsets[c + 1] as usize];
                links[pid as usize].first_child = next;
                links[pid as usize].child_count = kids.len() as u32;
                for &k in kids {
                    arena_of[l][k as usize] = next;
                    local[next as usize] = k;
                    links[next as usize].parent = pid;
                    links[next as usize].level = l as u32;
                    next += 1;
                }
            }
            level_ranges[l] = NodeRange { start, end: next };
        }
        debug_assert_eq!(next as usize, total);

        // Leaves in breadth-first order are a depth-first leaf order: every subtree is contiguous.
        let leaves = level_ranges[0];
        let vertex_order: Vec<u32> = (leaves.start..leaves.end)
            .map(|id| local[id as usize])
            .collect();
        let mut leaf_of_vertex = vec![NodeId::from_raw(0); positions.len()];
        let mut rest_position = vec![Vec3::ZERO; total];
        let mut mass = vec![0f32; total];
        for (k, id) in (leaves.start..leaves.end).enumerate() {
            let v = local[id as usize] as usize;
            leaf_of_vertex[v] = NodeId::from_raw(id);
            let link = &mut links[id as usize];
            link.vertex_start = k as u32;
            link.vertex_end = k as u32 + 1;
            rest_position[id as usize] = positions[v];
            mass[id as usize] = masses[v];
        }
        // Inner nodes bottom-up (arena order reversed visits children before parents). Centroids
        // are accumulated in f64 so that a parent's rest position is the centroid of its children
        // to f32 precision even for large meshes.
        for id in (0..leaves.start as usize).rev() {
            let NodeLinks {
                first_child,
                child_count,
                ..
            } = links[id];
            let kids = first_child as usize..(first_child + child_count) as usize;
            let mut m = 0f64;
            let mut c = DVec3::ZERO;
            for k in kids.clone() {
                m += mass[k] as f64;
                c += rest_position[k].as_dvec3() * mass[k] as f64;
            }
            mass[id] = m as f32;
            rest_position[id] = (c / m).as_vec3();
            links[id].vertex_start = links[kids.start].vertex_start;
            links[id].vertex_end = links[kids.end - 1].vertex_end;
        }

        // Same-level neighbours: the edges of each quotient graph, mapped to arena ids.
        let mut adjacency: Vec<Vec<NodeId>> = vec![Vec::new(); total];
        let mut level_edges = edges.clone();
        for l in 0..n_levels {
            for &[a, b] in &level_edges {
                let (ia, ib) = (arena_of[l][a as usize], arena_of[l][b as usize]);
                adjacency[ia as usize].push(NodeId::from_raw(ib));
                adjacency[ib as usize].push(NodeId::from_raw(ia));
            }
            if l + 1 < n_levels {
                level_edges = quotient_edges(&level_edges, &parents[l]);
            }
        }
        let mut neighbour_offsets = Vec::with_capacity(total + 1);
        let mut neighbours = Vec::new();
        neighbour_offsets.push(0u32);
        for list in &mut adjacency {
            list.sort_unstable();
            neighbours.extend_from_slice(list);
            neighbour_offsets.push(neighbours.len() as u32);
        }

        Hierarchy {
            links,
            rest_position,
            mass,
            vertex_order,
            leaf_of_vertex,
            neighbour_offsets,
            neighbours,
            level_ranges,
            leaf_edges: edges,
        }
    }
}
