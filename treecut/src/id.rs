//! Index newtypes: a node of the hierarchy, and a contiguous run of them.

use std::fmt;

/// A node of a [`crate::Hierarchy`], addressed by its index in the hierarchy's arena.
///
/// Nodes are stored breadth first from the root (`NodeId(0)`), so a node's children are contiguous
/// and every level is a contiguous run.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct NodeId(pub u32);

impl NodeId {
    /// The id of the node stored at `index` in the arena.
    #[inline]
    pub fn new(index: usize) -> Self {
        debug_assert!(index <= u32::MAX as usize);
        NodeId(index as u32)
    }

    /// The node's index in the arena, for indexing per-node arrays.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

impl fmt::Debug for NodeId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "n{}", self.0)
    }
}

impl fmt::Display for NodeId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "node {}", self.0)
    }
}

/// A contiguous run of node ids (a node's children, or one level of the hierarchy).
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct NodeRange {
    /// First id of the run.
    pub start: u32,
    /// One past the last id of the run.
    pub end: u32,
}

impl NodeRange {
    /// Number of ids in the run.
    #[inline]
    pub fn len(&self) -> usize {
        (self.end - self.start) as usize
    }

    /// Whether the run holds no id.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }

    /// Whether `n` lies in the run.
    #[inline]
    pub fn contains(&self, n: NodeId) -> bool {
        n.0 >= self.start && n.0 < self.end
    }

    /// The first id, if any.
    #[inline]
    pub fn first(&self) -> Option<NodeId> {
        (!self.is_empty()).then_some(NodeId(self.start))
    }
}

impl Iterator for NodeRange {
    type Item = NodeId;

    #[inline]
    fn next(&mut self) -> Option<NodeId> {
        if self.start < self.end {
            self.start += 1;
            Some(NodeId(self.start - 1))
        } else {
            None
        }
    }

    #[inline]
    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.len(), Some(self.len()))
    }
}

impl DoubleEndedIterator for NodeRange {
    #[inline]
    fn next_back(&mut self) -> Option<NodeId> {
        if self.start < self.end {
            self.end -= 1;
            Some(NodeId(self.end))
        } else {
            None
        }
    }
}

impl ExactSizeIterator for NodeRange {}
