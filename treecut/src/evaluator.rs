//! The budgeted evaluator: priorities in, a batch of refine/coarse operations out.
//!
//! Two priority queues, as in ROAM: a max-queue of nodes to split (refine), keyed by the node's
//! priority, and a min-queue of parents to merge (coarse), keyed by the largest priority among the
//! children (a parent may only be merged when none of its children matters). While under budget
//! the most important node is refined; when a refine does not fit, the least important parents
//! are merged to make room, but only if the refined node's priority beats each merged parent's by
//! more than the hysteresis threshold; once swaps stop paying, only refines that fit outright are
//! taken (fanouts may differ). Because a swap needs
//! a strict gain of more than the threshold, the reverse swap cannot follow while priorities stay
//! the same: nothing flickers.

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;

use crate::{Cut, EvalError, Hierarchy, NodeId};

/// One operation proposed by the evaluator, to be applied in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Op {
    /// Replace this active node by its children.
    Refine(NodeId),
    /// Replace this parent's children, all active, by the parent.
    Coarse(NodeId),
}

impl Op {
    /// The node the operation names (the refined node, or the coarsened parent).
    pub fn node(self) -> NodeId {
        match self {
            Op::Refine(n) | Op::Coarse(n) => n,
        }
    }
}

/// What the cut may spend.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// At most this many active nodes.
    Nodes(usize),
    /// At most this total cost, summing a per-node cost given to [`Evaluator::evaluate`] (for
    /// example each node's incident link count, or a cost fitted to measured step times).
    Cost {
        /// Largest total cost of the active nodes.
        limit: f32,
    },
}

/// Where a parent's merge priority (the value of keeping it refined) comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MergeKey {
    /// The largest priority among its children: a parent may only be merged when none of its
    /// children matters. Right when priorities do not depend on the level (e.g. a salience
    /// value per point).
    #[default]
    MaxOfChildren,
    /// The parent's own entry in the priority slice, which the caller fills for every parent
    /// whose children are all active. Right when a priority measures what refining that node
    /// gains (e.g. screen-space error, which shrinks with the node): a refine candidate's gain and
    /// a merge candidate's loss are then both measured at the parent's level, so a refine is not
    /// undone just because its children are individually worth less than their parent was.
    Parent,
}

/// Settings of an [`Evaluator`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EvaluatorSettings {
    /// A refine that needs merges to fit must beat each merged parent's priority by more than this.
    pub hysteresis: f32,
    /// Most operations proposed per call, to bound the work of applying them in one frame.
    pub max_ops: usize,
    /// Where merge priorities come from.
    pub merge_key: MergeKey,
}

impl Default for EvaluatorSettings {
    fn default() -> Self {
        EvaluatorSettings {
            hysteresis: 0.05,
            max_ops: 64,
            merge_key: MergeKey::MaxOfChildren,
        }
    }
}

/// A priority ordered totally (NaN is refused before any comparison).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Priority(f32);
impl Eq for Priority {}
impl PartialOrd for Priority {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Priority {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// Overlay states: how a node's membership changed within the batch being built.
const UNCHANGED: u8 = 0;
const ADDED_BY_REFINE: u8 = 1;
const ADDED_BY_COARSE: u8 = 2;
const REMOVED: u8 = 3;

/// Turns priorities into refine/coarse batches under a budget; reuses its buffers between calls.
#[derive(Clone, Debug)]
pub struct Evaluator {
    settings: EvaluatorSettings,
    /// Max-queue of split candidates; ties go to the lower id.
    split: BinaryHeap<(Priority, Reverse<NodeId>)>,
    /// Min-queue of merge candidates; ties go to the lower id.
    merge: BinaryHeap<Reverse<(Priority, NodeId)>>,
    overlay: Vec<u8>,
    /// Effective priority of parents merged within this batch (their children's maximum).
    merged_priority: Vec<f32>,
    touched: Vec<NodeId>,
    held: Vec<(Priority, NodeId)>,
    skipped: Vec<(Priority, NodeId)>,
    ops: Vec<Op>,
}

/// Read-only inputs of one evaluation, bundled to keep helper signatures short.
struct Inputs<'a> {
    h: &'a Hierarchy,
    cut: &'a Cut,
    priorities: &'a [f32],
    costs: Option<&'a [f32]>,
}

impl Inputs<'_> {
    /// Change in spent budget if `n` were refined (negated: what merging `n` frees).
    fn refine_delta(&self, n: NodeId) -> f64 {
        match self.costs {
            None => self.h.child_count(n) as f64 - 1.0,
            Some(c) => {
                let kids: f64 = self.h.children(n).map(|k| c[k.index()] as f64).sum();
                kids - c[n.index()] as f64
            }
        }
    }
}

impl Evaluator {
    /// An evaluator with the given settings.
    pub fn new(settings: EvaluatorSettings) -> Evaluator {
        Evaluator {
            settings,
            split: BinaryHeap::new(),
            merge: BinaryHeap::new(),
            overlay: Vec::new(),
            merged_priority: Vec::new(),
            touched: Vec::new(),
            held: Vec::new(),
            skipped: Vec::new(),
            ops: Vec::new(),
        }
    }

    /// The settings in use.
    pub fn settings(&self) -> EvaluatorSettings {
        self.settings
    }

    /// Replaces the settings (for example when a controller moves the hysteresis).
    pub fn set_settings(&mut self, settings: EvaluatorSettings) {
        self.settings = settings;
    }

    /// Proposes the batch of operations that best spends `budget` given a priority per node.
    ///
    /// `priorities` and `costs` are indexed by [`NodeId::index`] over the whole hierarchy; only
    /// the entries of active nodes are read. `costs` is needed for [`Budget::Cost`] and ignored
    /// otherwise. The operations are valid when applied in order, never touch a locked node, and
    /// never undo each other within a batch. Children created by a refine are not refined again in
    /// the same batch: their priorities are not known until the caller measures them.
    ///
    /// If the cut is over budget, parents are merged (least important first) without hysteresis
    /// until it fits, the operation cap is reached, or nothing can be merged.
    pub fn evaluate(
        &mut self,
        h: &Hierarchy,
        cut: &Cut,
        priorities: &[f32],
        costs: Option<&[f32]>,
        budget: Budget,
    ) -> Result<&[Op], EvalError> {
        let inputs = self.validate(h, cut, priorities, costs, budget)?;
        let limit = match budget {
            Budget::Nodes(n) => n as f64,
            Budget::Cost { limit } => limit as f64,
        };
        self.reset(h.len());
        let mut spent = 0f64;
        // Candidates are gathered into the heaps' own buffers and heapified in O(n), reusing the
        // allocations of the previous call.
        let mut split = std::mem::take(&mut self.split).into_vec();
        let mut merge = std::mem::take(&mut self.merge).into_vec();
        // The smallest budget growth any candidate refine would cost: once swaps stop paying
        // and even that does not fit, no candidate left can be taken, so the loop ends instead
        // of popping the whole queue.
        let mut min_delta = f64::INFINITY;
        for &n in cut.active() {
            spent += match inputs.costs {
                None => 1.0,
                Some(c) => c[n.index()] as f64,
            };
            if !h.is_leaf(n) && !cut.is_locked(n) {
                split.push((Priority(priorities[n.index()]), Reverse(n)));
                min_delta = min_delta.min(inputs.refine_delta(n));
            }
            if let Some(p) = h.parent(n)
                && h.children(p).first() == Some(n)
                && let Some(key) = self.merge_key(&inputs, p)
            {
                merge.push(Reverse((Priority(key), p)));
            }
        }
        self.split = BinaryHeap::from(split);
        self.merge = BinaryHeap::from(merge);
        // Guards float accumulation in cost budgets; node budgets are exact integers.
        let eps = 1e-6 * limit.abs().max(1.0);
        let threshold = self.settings.hysteresis;
        // Once a swap fails, every lower split would fail it too (its gain is smaller): from then
        // on only refines that fit outright are taken, which matters when fanouts differ.
        let mut swaps_exhausted = false;
        while self.ops.len() < self.settings.max_ops {
            if spent > limit + eps {
                match self.pop_merge(&inputs) {
                    Some((_, p)) => spent -= self.apply_coarse(&inputs, p),
                    None => break,
                }
                continue;
            }
            let Some((ps, s)) = self.peek_split(&inputs) else {
                break;
            };
            let delta = inputs.refine_delta(s);
            if spent + delta <= limit + eps {
                self.split.pop();
                spent += self.apply_refine(&inputs, s);
                continue;
            }
            if swaps_exhausted {
                if spent + min_delta > limit + eps {
                    break;
                }
                self.split.pop();
                continue;
            }
            // Swap: free room by merging parents that matter clearly less than `s`.
            let mut freed = 0f64;
            let room = self.settings.max_ops - self.ops.len();
            while spent + delta - freed > limit + eps && self.held.len() + 1 < room {
                let Some((km, m)) = self.pop_merge(&inputs) else {
                    break;
                };
                if Some(m) == h.parent(s) {
                    self.skipped.push((km, m));
                    continue;
                }
                if km.0 + threshold >= ps.0 {
                    self.skipped.push((km, m));
                    break;
                }
                freed += inputs.refine_delta(m);
                self.held.push((km, m));
            }
            let fits = spent + delta - freed <= limit + eps;
            for (k, m) in self.skipped.drain(..) {
                self.merge.push(Reverse((k, m)));
            }
            if !fits {
                for (k, m) in self.held.drain(..) {
                    self.merge.push(Reverse((k, m)));
                }
                swaps_exhausted = true;
                self.split.pop();
                continue;
            }
            let held = std::mem::take(&mut self.held);
            for &(_, m) in &held {
                spent -= self.apply_coarse(&inputs, m);
            }
            self.held = held;
            self.held.clear();
            self.split.pop();
            spent += self.apply_refine(&inputs, s);
        }
        Ok(&self.ops)
    }

    fn validate<'a>(
        &self,
        h: &'a Hierarchy,
        cut: &'a Cut,
        priorities: &'a [f32],
        costs: Option<&'a [f32]>,
        budget: Budget,
    ) -> Result<Inputs<'a>, EvalError> {
        if cut.hierarchy_len() != h.len() {
            return Err(EvalError::WrongHierarchy);
        }
        if priorities.len() != h.len() {
            return Err(EvalError::LengthMismatch {
                what: "priorities",
                got: priorities.len(),
                expected: h.len(),
            });
        }
        if !(self.settings.hysteresis.is_finite() && self.settings.hysteresis >= 0.0) {
            return Err(EvalError::InvalidHysteresis);
        }
        let costs = match budget {
            Budget::Nodes(_) => None,
            Budget::Cost { limit } => {
                if !(limit.is_finite() && limit >= 0.0) {
                    return Err(EvalError::InvalidBudget);
                }
                let c = costs.ok_or(EvalError::MissingCosts)?;
                if c.len() != h.len() {
                    return Err(EvalError::LengthMismatch {
                        what: "costs",
                        got: c.len(),
                        expected: h.len(),
                    });
                }
                if let Some(i) = c.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
                    return Err(EvalError::InvalidCost(NodeId::new(i)));
                }
                Some(c)
            }
        };
        if let Some(&n) = cut
            .active()
            .iter()
            .find(|n| !priorities[n.index()].is_finite())
        {
            return Err(EvalError::NonFinitePriority(n));
        }
        if self.settings.merge_key == MergeKey::Parent
            && let Some(p) = cut
                .active()
                .iter()
                .filter_map(|&n| h.parent(n))
                .find(|p| !priorities[p.index()].is_finite())
        {
            return Err(EvalError::NonFinitePriority(p));
        }
        Ok(Inputs {
            h,
            cut,
            priorities,
            costs,
        })
    }

    fn reset(&mut self, len: usize) {
        if self.overlay.len() != len {
            self.overlay = vec![UNCHANGED; len];
            self.merged_priority = vec![0.0; len];
        } else {
            for n in self.touched.drain(..) {
                self.overlay[n.index()] = UNCHANGED;
            }
        }
        self.touched.clear();
        self.split.clear();
        self.merge.clear();
        self.held.clear();
        self.skipped.clear();
        self.ops.clear();
    }

    #[inline]
    fn on_cut(&self, cut: &Cut, n: NodeId) -> bool {
        match self.overlay[n.index()] {
            UNCHANGED => cut.is_on_cut(n),
            REMOVED => false,
            _ => true,
        }
    }

    #[inline]
    fn priority(&self, inputs: &Inputs<'_>, n: NodeId) -> f32 {
        if self.overlay[n.index()] == ADDED_BY_COARSE {
            self.merged_priority[n.index()]
        } else {
            inputs.priorities[n.index()]
        }
    }

    #[inline]
    fn mark(&mut self, n: NodeId, state: u8) {
        if self.overlay[n.index()] == UNCHANGED {
            self.touched.push(n);
        }
        self.overlay[n.index()] = state;
    }

    /// Whether `p` may be merged now: unlocked, off the cut, children all active, unlocked and not
    /// created by a refine of this batch (that would undo it).
    fn mergeable(&self, inputs: &Inputs<'_>, p: NodeId) -> bool {
        let cut = inputs.cut;
        !cut.is_locked(p)
            && !self.on_cut(cut, p)
            && inputs.h.children(p).all(|k| {
                self.on_cut(cut, k)
                    && !cut.is_locked(k)
                    && self.overlay[k.index()] != ADDED_BY_REFINE
            })
    }

    /// The merge priority of `p` (its children's largest, or its own entry), if `p` may be
    /// merged now.
    fn merge_key(&self, inputs: &Inputs<'_>, p: NodeId) -> Option<f32> {
        self.mergeable(inputs, p)
            .then(|| match self.settings.merge_key {
                MergeKey::Parent => inputs.priorities[p.index()],
                MergeKey::MaxOfChildren => inputs
                    .h
                    .children(p)
                    .map(|k| self.priority(inputs, k))
                    .fold(f32::NEG_INFINITY, f32::max),
            })
    }

    fn push_merge_candidate(&mut self, inputs: &Inputs<'_>, p: NodeId) {
        if let Some(key) = self.merge_key(inputs, p) {
            self.merge.push(Reverse((Priority(key), p)));
        }
    }

    fn pop_merge(&mut self, inputs: &Inputs<'_>) -> Option<(Priority, NodeId)> {
        while let Some(Reverse((k, p))) = self.merge.pop() {
            if self.mergeable(inputs, p) {
                return Some((k, p));
            }
        }
        None
    }

    fn peek_split(&mut self, inputs: &Inputs<'_>) -> Option<(Priority, NodeId)> {
        while let Some(&(k, Reverse(n))) = self.split.peek() {
            if self.overlay[n.index()] == UNCHANGED && inputs.cut.is_on_cut(n) {
                return Some((k, n));
            }
            self.split.pop();
        }
        None
    }

    /// Records a refine of `n` in the overlay; returns the budget it spends.
    fn apply_refine(&mut self, inputs: &Inputs<'_>, n: NodeId) -> f64 {
        self.mark(n, REMOVED);
        for k in inputs.h.children(n) {
            self.mark(k, ADDED_BY_REFINE);
        }
        self.ops.push(Op::Refine(n));
        inputs.refine_delta(n)
    }

    /// Records a coarse of `p` in the overlay; returns the budget it frees. The grandparent may
    /// become mergeable in turn.
    fn apply_coarse(&mut self, inputs: &Inputs<'_>, p: NodeId) -> f64 {
        let key = inputs
            .h
            .children(p)
            .map(|k| self.priority(inputs, k))
            .fold(f32::NEG_INFINITY, f32::max);
        for k in inputs.h.children(p) {
            self.mark(k, REMOVED);
        }
        self.mark(p, ADDED_BY_COARSE);
        self.merged_priority[p.index()] = key;
        self.ops.push(Op::Coarse(p));
        if let Some(g) = inputs.h.parent(p) {
            self.push_merge_candidate(inputs, g);
        }
        inputs.refine_delta(p)
    }
}
