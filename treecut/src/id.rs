//! Index newtypes: a node of the hierarchy, and a contiguous run of them.

slod_core::index_type! {
    /// A node of a [`crate::Hierarchy`], addressed by its index in the hierarchy's arena.
    ///
    /// Nodes are stored breadth first from the root (index 0), so a node's children are
    /// contiguous and every level is a contiguous run.
    pub struct NodeId, "node "
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
        n.raw() >= self.start && n.raw() < self.end
    }

    /// The first id, if any.
    #[inline]
    pub fn first(&self) -> Option<NodeId> {
        (!self.is_empty()).then_some(NodeId::from_raw(self.start))
    }
}

impl Iterator for NodeRange {
    type Item = NodeId;

    #[inline]
    fn next(&mut self) -> Option<NodeId> {
        if self.start < self.end {
            self.start += 1;
            Some(NodeId::from_raw(self.start - 1))
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
            Some(NodeId::from_raw(self.end))
        } else {
            None
        }
    }
}

impl ExactSizeIterator for NodeRange {}
