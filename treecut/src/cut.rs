//! The cut: which nodes are active, with O(1) membership and O(fanout) refine and coarse.
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), section 3.2 (the TreeCut: a cut through a
//! multi-resolution hierarchy that refine and coarse move).

use crate::{CutError, Hierarchy, InvariantError, NodeId};

/// Marks a node that is not on the cut in [`Cut::slot`].
const OFF: u32 = u32::MAX;

/// The set of active nodes of a [`Hierarchy`]: every leaf's path to the root crosses it exactly once.
///
/// Membership is O(1) (a slot per node into a dense active list); [`Cut::refine`] and
/// [`Cut::coarse`] cost O(fanout) whatever the size of the cut. Nodes taking part in a transition
/// are locked with a counter, so several transitions can hold the same node.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cut {
    /// Position of each node in `active`, or `OFF`.
    slot: Vec<u32>,
    /// Dense list of active nodes; order changes on refine and coarse (swap-remove then push).
    active: Vec<NodeId>,
    /// Lock count per node.
    locks: Vec<u32>,
}

impl Cut {
    fn empty(h: &Hierarchy) -> Cut {
        Cut {
            slot: vec![OFF; h.len()],
            active: Vec::new(),
            locks: vec![0; h.len()],
        }
    }

    /// The coarsest cut: the root alone.
    pub fn root(h: &Hierarchy) -> Cut {
        let mut c = Cut::empty(h);
        c.insert(h.root());
        c
    }

    /// The finest cut: every leaf.
    pub fn finest(h: &Hierarchy) -> Cut {
        Cut::uniform(h, 0)
    }

    /// Every node of `level` (clamped to the root's level): each level partitions the vertices.
    pub fn uniform(h: &Hierarchy, level: u32) -> Cut {
        let mut c = Cut::empty(h);
        for n in h.nodes_at_level(level.min(h.level_count() - 1)) {
            c.insert(n);
        }
        c
    }

    /// A cut from an explicit node list, checked to cover every leaf exactly once.
    pub fn from_nodes(h: &Hierarchy, nodes: &[NodeId]) -> Result<Cut, CutError> {
        let mut c = Cut::empty(h);
        let mut cover = vec![0u32; h.vertex_count()];
        for &n in nodes {
            if !h.contains(n) {
                return Err(CutError::OutOfRange(n));
            }
            if c.is_on_cut(n) {
                return Err(CutError::NotACut(n, 2));
            }
            for &v in h.vertices(n) {
                cover[v as usize] += 1;
            }
            c.insert(n);
        }
        if let Some(v) = cover.iter().position(|&k| k != 1) {
            return Err(CutError::NotACut(h.leaf_of_vertex(v as u32), cover[v]));
        }
        Ok(c)
    }

    #[inline]
    fn insert(&mut self, n: NodeId) {
        self.slot[n.index()] = self.active.len() as u32;
        self.active.push(n);
    }

    #[inline]
    fn remove(&mut self, n: NodeId) {
        let s = self.slot[n.index()] as usize;
        self.active.swap_remove(s);
        if let Some(&moved) = self.active.get(s) {
            self.slot[moved.index()] = s as u32;
        }
        self.slot[n.index()] = OFF;
    }

    /// Number of active nodes.
    #[inline]
    pub fn len(&self) -> usize {
        self.active.len()
    }

    /// Never true for a valid cut; present for API symmetry.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.active.is_empty()
    }

    /// The active nodes. Their order changes with every refine and coarse.
    #[inline]
    pub fn active(&self) -> &[NodeId] {
        &self.active
    }

    /// Number of nodes of the hierarchy this cut was made for.
    #[inline]
    pub fn hierarchy_len(&self) -> usize {
        self.slot.len()
    }

    /// Whether `n` is active. O(1); false for ids outside the hierarchy.
    #[inline]
    pub fn is_on_cut(&self, n: NodeId) -> bool {
        self.slot.get(n.index()).is_some_and(|&s| s != OFF)
    }

    /// Whether `n` is held by a transition.
    #[inline]
    pub fn is_locked(&self, n: NodeId) -> bool {
        self.locks.get(n.index()).is_some_and(|&l| l > 0)
    }

    /// Adds one lock to `n` (a transition that involves it begins).
    ///
    /// # Panics
    /// If `n` is outside the hierarchy.
    #[inline]
    pub fn lock(&mut self, n: NodeId) {
        self.locks[n.index()] += 1;
    }

    /// Removes one lock from `n`; refused if it holds none.
    pub fn unlock(&mut self, n: NodeId) -> Result<(), CutError> {
        match self.locks.get_mut(n.index()) {
            None => Err(CutError::OutOfRange(n)),
            Some(0) => Err(CutError::NotLocked(n)),
            Some(l) => {
                *l -= 1;
                Ok(())
            }
        }
    }

    /// Checks that `n` could be refined now: on the cut, not a leaf, not locked.
    pub fn can_refine(&self, h: &Hierarchy, n: NodeId) -> Result<(), CutError> {
        if !h.contains(n) || n.index() >= self.slot.len() {
            return Err(CutError::OutOfRange(n));
        }
        if !self.is_on_cut(n) {
            return Err(CutError::NotOnCut(n));
        }
        if h.is_leaf(n) {
            return Err(CutError::IsLeaf(n));
        }
        if self.is_locked(n) {
            return Err(CutError::Locked(n));
        }
        Ok(())
    }

    /// Checks that `parent` could be coarsened now: all its children on the cut and none of them,
    /// nor the parent, locked.
    pub fn can_coarse(&self, h: &Hierarchy, parent: NodeId) -> Result<(), CutError> {
        if !h.contains(parent) || parent.index() >= self.slot.len() {
            return Err(CutError::OutOfRange(parent));
        }
        if h.is_leaf(parent) {
            return Err(CutError::IsLeaf(parent));
        }
        let kids = h.children(parent);
        if !kids.clone().all(|k| self.is_on_cut(k)) {
            return Err(CutError::ChildrenNotOnCut(parent));
        }
        if self.is_locked(parent) {
            return Err(CutError::Locked(parent));
        }
        if let Some(k) = kids.clone().find(|&k| self.is_locked(k)) {
            return Err(CutError::Locked(k));
        }
        Ok(())
    }

    /// Replaces active node `n` by its children. O(fanout). Refused, changing nothing, if `n` is
    /// not on the cut, is a leaf or is locked.
    pub fn refine(&mut self, h: &Hierarchy, n: NodeId) -> Result<(), CutError> {
        self.can_refine(h, n)?;
        self.remove(n);
        for k in h.children(n) {
            self.insert(k);
        }
        Ok(())
    }

    /// Replaces the children of `parent`, all active, by `parent`. O(fanout). Refused, changing
    /// nothing, if a child is not on the cut or anything involved is locked.
    pub fn coarse(&mut self, h: &Hierarchy, parent: NodeId) -> Result<(), CutError> {
        self.can_coarse(h, parent)?;
        for k in h.children(parent) {
            self.remove(k);
        }
        self.insert(parent);
        Ok(())
    }

    /// Verifies the cut invariant: every leaf's path to the root crosses the cut exactly once, and
    /// the active list agrees with the per-node membership. O(leaves × depth): for tests and debug
    /// checks, not for the frame loop.
    pub fn check_invariant(&self, h: &Hierarchy) -> Result<(), InvariantError> {
        if self.slot.len() != h.len() {
            return Err(InvariantError::WrongHierarchy {
                cut: self.slot.len(),
                hierarchy: h.len(),
            });
        }
        for (i, &n) in self.active.iter().enumerate() {
            if self.slot[n.index()] != i as u32 {
                return Err(InvariantError::Bookkeeping(n));
            }
        }
        let on = self.slot.iter().filter(|&&s| s != OFF).count();
        if on != self.active.len() {
            let n = (0..h.len())
                .map(NodeId::new)
                .find(|&n| self.is_on_cut(n) && !self.active.contains(&n))
                .unwrap_or_default();
            return Err(InvariantError::Bookkeeping(n));
        }
        for leaf in h.nodes_at_level(0) {
            let mut crossings = u32::from(self.is_on_cut(leaf));
            let mut a = leaf;
            while let Some(p) = h.parent(a) {
                crossings += u32::from(self.is_on_cut(p));
                a = p;
            }
            if crossings != 1 {
                return Err(InvariantError::Crossings { leaf, crossings });
            }
        }
        Ok(())
    }
}
