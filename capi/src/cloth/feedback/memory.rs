//! Salience memory (see [`super::FeedbackSettings::memory_seconds`]): the salience every node
//! had at the previous evaluation, so a region that just moved stays salient for a while, and
//! a node just refined or coarsened inherits its parent's or children's value.

use treecut::{Hierarchy, NodeId};

/// Remembered salience per hierarchy node, and the evaluation that last wrote it.
#[derive(Clone, Debug)]
pub(super) struct Memory {
    values: Vec<f32>,
    stamps: Vec<u32>,
    evaluation: u32,
}

impl Memory {
    /// Empty memory for a hierarchy of `len` nodes.
    pub(super) fn new(len: usize) -> Memory {
        Memory {
            values: vec![0.0; len],
            stamps: vec![0; len],
            evaluation: 0,
        }
    }

    /// Starts a new evaluation; returns the previous one's stamp (for [`Memory::remembered`]).
    pub(super) fn begin(&mut self) -> u32 {
        let previous = self.evaluation;
        self.evaluation = self.evaluation.wrapping_add(1).max(1);
        previous
    }

    /// Stores `node`'s salience in this evaluation.
    pub(super) fn store(&mut self, node: NodeId, salience: f32) {
        self.values[node.index()] = salience;
        self.stamps[node.index()] = self.evaluation;
    }

    /// The salience `node` had at evaluation `previous`: its own if it was simulated then,
    /// else its parent's (it was just refined) or its children's largest (just coarsened).
    pub(super) fn remembered(&self, h: &Hierarchy, node: NodeId, previous: u32) -> f32 {
        let live = |n: NodeId| (self.stamps[n.index()] == previous).then(|| self.values[n.index()]);
        if let Some(s) = live(node) {
            return s;
        }
        if let Some(s) = h.parent(node).and_then(live) {
            return s;
        }
        h.children(node).filter_map(live).fold(0.0, f32::max)
    }
}
