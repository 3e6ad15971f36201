//! The immutable multi-resolution hierarchy: one arena of nodes, breadth first from the root.

use glam::Vec3;

use crate::{NodeId, NodeRange};

/// Sentinel for "no parent" in the arena.
pub(crate) const NO_PARENT: u32 = u32::MAX;

/// Per-node topology, stored in one arena slot.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NodeLinks {
    pub(crate) parent: u32,
    pub(crate) first_child: u32,
    pub(crate) child_count: u32,
    pub(crate) level: u32,
    /// Range into `Hierarchy::vertex_order` of the finest-level vertices this node covers.
    pub(crate) vertex_start: u32,
    pub(crate) vertex_end: u32,
}

/// A multi-resolution hierarchy over the vertices of a cloth, immutable once built.
///
/// Leaves are the finest-level (mesh) vertices, at level 0; every child sits exactly one level below
/// its parent, so each level is a complete partition of the vertices. A parent's rest position is
/// the mass-weighted centroid of its children and its mass their sum. Each node also knows its
/// same-level neighbours (nodes joined to it by at least one finest-level mesh edge), which is what
/// a simulation needs to connect nodes of different levels.
#[derive(Clone, Debug)]
pub struct Hierarchy {
    pub(crate) links: Vec<NodeLinks>,
    pub(crate) rest_position: Vec<Vec3>,
    pub(crate) mass: Vec<f32>,
    /// Finest-level vertices in leaf order (every subtree is a contiguous run).
    pub(crate) vertex_order: Vec<u32>,
    /// Leaf node of each vertex.
    pub(crate) leaf_of_vertex: Vec<NodeId>,
    /// Same-level neighbour lists, CSR.
    pub(crate) neighbour_offsets: Vec<u32>,
    pub(crate) neighbours: Vec<NodeId>,
    /// First node of each level (level 0 = leaves); `level_start[l]..level_end(l)`.
    pub(crate) level_ranges: Vec<NodeRange>,
    pub(crate) leaf_edges: Vec<[u32; 2]>,
}

impl Hierarchy {
    /// Number of nodes, all levels together.
    #[inline]
    pub fn len(&self) -> usize {
        self.links.len()
    }

    /// Always false: a hierarchy holds at least its root.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.links.is_empty()
    }

    /// The root, covering every vertex.
    #[inline]
    pub fn root(&self) -> NodeId {
        NodeId::from_raw(0)
    }

    /// Whether `n` is a node of this hierarchy.
    #[inline]
    pub fn contains(&self, n: NodeId) -> bool {
        n.index() < self.links.len()
    }

    /// The parent of `n`, `None` for the root.
    #[inline]
    pub fn parent(&self, n: NodeId) -> Option<NodeId> {
        let p = self.links[n.index()].parent;
        (p != NO_PARENT).then_some(NodeId::from_raw(p))
    }

    /// The children of `n`, contiguous in the arena; empty for a leaf.
    #[inline]
    pub fn children(&self, n: NodeId) -> NodeRange {
        let l = &self.links[n.index()];
        NodeRange {
            start: l.first_child,
            end: l.first_child + l.child_count,
        }
    }

    /// Number of children of `n`.
    #[inline]
    pub fn child_count(&self, n: NodeId) -> usize {
        self.links[n.index()].child_count as usize
    }

    /// Whether `n` is a finest-level vertex.
    #[inline]
    pub fn is_leaf(&self, n: NodeId) -> bool {
        self.links[n.index()].child_count == 0
    }

    /// Level of `n`: 0 for leaves, one more per step towards the root.
    #[inline]
    pub fn level(&self, n: NodeId) -> u32 {
        self.links[n.index()].level
    }

    /// Depth of `n`: 0 for the root, one more per step towards the leaves.
    #[inline]
    pub fn depth(&self, n: NodeId) -> u32 {
        self.level_count() - 1 - self.level(n)
    }

    /// Number of levels (the root's level plus one).
    #[inline]
    pub fn level_count(&self) -> u32 {
        self.level_ranges.len() as u32
    }

    /// The nodes of `level`, contiguous in the arena.
    #[inline]
    pub fn nodes_at_level(&self, level: u32) -> NodeRange {
        self.level_ranges[level as usize]
    }

    /// Rest position of `n`: the mass-weighted centroid of the vertices it covers.
    #[inline]
    pub fn rest_position(&self, n: NodeId) -> Vec3 {
        self.rest_position[n.index()]
    }

    /// Rest positions of all nodes, indexed by [`NodeId::index`].
    #[inline]
    pub fn rest_positions(&self) -> &[Vec3] {
        &self.rest_position
    }

    /// Mass of `n`: the sum of its vertices' masses.
    #[inline]
    pub fn mass(&self, n: NodeId) -> f32 {
        self.mass[n.index()]
    }

    /// The finest-level (mesh) vertices `n` covers; each subtree's vertices are one contiguous run.
    #[inline]
    pub fn vertices(&self, n: NodeId) -> &[u32] {
        let l = &self.links[n.index()];
        &self.vertex_order[l.vertex_start as usize..l.vertex_end as usize]
    }

    /// Number of finest-level vertices (leaves).
    #[inline]
    pub fn vertex_count(&self) -> usize {
        self.leaf_of_vertex.len()
    }

    /// The leaf node that stands for mesh vertex `v`.
    #[inline]
    pub fn leaf_of_vertex(&self, v: u32) -> NodeId {
        self.leaf_of_vertex[v as usize]
    }

    /// The mesh vertex a leaf stands for, `None` for an inner node.
    #[inline]
    pub fn vertex_of_leaf(&self, n: NodeId) -> Option<u32> {
        let l = &self.links[n.index()];
        (l.child_count == 0).then(|| self.vertex_order[l.vertex_start as usize])
    }

    /// Same-level nodes joined to `n` by at least one finest-level mesh edge.
    #[inline]
    pub fn level_neighbours(&self, n: NodeId) -> &[NodeId] {
        let i = n.index();
        &self.neighbours[self.neighbour_offsets[i] as usize..self.neighbour_offsets[i + 1] as usize]
    }

    /// The ancestor of `n` at `level` (`n` itself at its own level).
    ///
    /// # Panics
    /// If `level` is below `n`'s level or above the root's.
    #[inline]
    pub fn ancestor_at_level(&self, n: NodeId, level: u32) -> NodeId {
        assert!(level >= self.level(n) && level < self.level_count());
        let mut a = n;
        for _ in self.level(n)..level {
            a = NodeId::from_raw(self.links[a.index()].parent);
        }
        a
    }

    /// Whether `ancestor` is `n` or one of its ancestors.
    #[inline]
    pub fn is_ancestor_or_self(&self, ancestor: NodeId, n: NodeId) -> bool {
        let la = self.level(ancestor);
        la >= self.level(n) && self.ancestor_at_level(n, la) == ancestor
    }

    /// Whether two disjoint nodes of any levels touch: some finest-level mesh edge joins a vertex of
    /// `a` to a vertex of `b`.
    ///
    /// Runs in O(neighbours × level difference): the finer node's same-level neighbours are lifted
    /// to the coarser node's level. Returns false when one contains the other.
    pub fn adjacent(&self, a: NodeId, b: NodeId) -> bool {
        let (fine, coarse) = if self.level(a) <= self.level(b) {
            (a, b)
        } else {
            (b, a)
        };
        let lc = self.level(coarse);
        if self.ancestor_at_level(fine, lc) == coarse {
            return false;
        }
        self.level_neighbours(fine)
            .iter()
            .any(|&x| self.ancestor_at_level(x, lc) == coarse)
    }

    /// The finest-level mesh edges (vertex pairs, smaller index first) that define adjacency.
    #[inline]
    pub fn leaf_edges(&self) -> &[[u32; 2]] {
        &self.leaf_edges
    }

    /// Diagonal of the rest bounding box, the length scale errors are measured against.
    pub fn rest_diagonal(&self) -> f32 {
        let leaves = self.nodes_at_level(0);
        let pts = &self.rest_position[leaves.start as usize..leaves.end as usize];
        let (lo, hi) = pts.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        (hi - lo).length()
    }
}
