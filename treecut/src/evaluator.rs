//! The budgeted evaluator: priorities in, a batch of refine/coarse operations out.
//!
//! Based on the split and merge queues of Duchaineau, Wolinsky, Sigeti, Miller, Aldrich and
//! Mineev-Weinstein, "ROAMing Terrain: Real-time Optimally Adapting Meshes", IEEE
//! Visualization 1997: greedy splits from a max-queue and merges from a min-queue of priorities,
//! here over a tree cut instead of a triangle bintree and under a node or cost budget.
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
//!
//! Where the batch runs as transitions that lock their neighbourhood (`softbody`'s TreeCut soft
//! body), [`Evaluator::evaluate_with_locks`] is told what each operation locks and plans only
//! operations that can begin after the ones before them, so the batch it returns is the batch
//! that runs.

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
    ///
    /// The merges that bring an over-budget cut back within its budget count too: where
    /// operations run as transitions, each one costs simulation time while it blends, so a
    /// budget that shrinks is met over several calls rather than by one burst of transitions.
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
    /// Nodes at or below this priority are never refined (see [`Evaluator::set_refine_floor`]).
    refine_floor: f32,
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
    /// Nodes locked by the operations of this batch (see [`Evaluator::evaluate_with_locks`]),
    /// indexed by node; `batch_locked` lists them for the reset.
    blocked: Vec<bool>,
    batch_locked: Vec<NodeId>,
    /// What the held merges of a swap would lock (they are not applied yet).
    held_locks: Vec<NodeId>,
    /// What one operation locks, as the caller's rule answers.
    op_locks: Vec<NodeId>,
    ops: Vec<Op>,
}

/// The caller's lock rule: appends to its second argument what beginning an operation locks.
type LockRule<'a> = &'a dyn Fn(Op, &mut Vec<NodeId>);

/// Read-only inputs of one evaluation, bundled to keep helper signatures short.
struct Inputs<'a> {
    h: &'a Hierarchy,
    cut: &'a Cut,
    priorities: &'a [f32],
    costs: Option<&'a [f32]>,
    locks: Option<LockRule<'a>>,
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
            refine_floor: f32::NEG_INFINITY,
            split: BinaryHeap::new(),
            merge: BinaryHeap::new(),
            overlay: Vec::new(),
            merged_priority: Vec::new(),
            touched: Vec::new(),
            held: Vec::new(),
            skipped: Vec::new(),
            blocked: Vec::new(),
            batch_locked: Vec::new(),
            held_locks: Vec::new(),
            op_locks: Vec::new(),
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

    /// Refines only nodes whose priority is above `floor` (−∞, the default: any node, as the
    /// budget allows). For priorities with an absolute meaning — estimated on-screen error in
    /// pixels under an error bound — a node whose error is already acceptable must not be
    /// refined just because the budget has room left (room left by candidates that a lock
    /// kept from refining, for one).
    pub fn set_refine_floor(&mut self, floor: f32) {
        self.refine_floor = floor;
    }

    /// Proposes the batch of operations that best spends `budget` given a priority per node, for
    /// a caller that applies it at once ([`Cut::refine`], [`Cut::coarse`]).
    ///
    /// `priorities` and `costs` are indexed by [`NodeId::index`] over the whole hierarchy; only
    /// the entries of active nodes are read. `costs` is needed for [`Budget::Cost`] and ignored
    /// otherwise. The operations are valid when applied in order, never touch a locked node, and
    /// never undo each other within a batch. Children created by a refine are not refined again in
    /// the same batch: their priorities are not known until the caller measures them. If the cut
    /// was within budget, every prefix of the batch is too.
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
        let inputs = self.validate(h, cut, priorities, costs, budget, None)?;
        self.run(&inputs, budget);
        Ok(&self.ops)
    }

    /// As [`Evaluator::evaluate`], for a caller that begins the operations one after the other
    /// as transitions that lock nodes until they end, and refuses to begin one on a locked node
    /// ([`Cut::lock`], [`CutError::Locked`](crate::CutError::Locked)).
    ///
    /// `locks(op, out)` appends to `out` the nodes that beginning `op` now would lock
    /// (duplicates allowed). `softbody`'s `TreeCutSoftBody::would_lock` answers it for the
    /// TreeCut soft body, which locks an operation's nodes and every simulated node next to
    /// them, and whose cut carries the locks of the transitions in flight.
    ///
    /// The batch returned then begins in full, in the order returned, and stays within the
    /// budget after each operation (if the cut was within it): no operation names a node locked
    /// in `cut` (in or next to a transition in flight) or locked by an earlier operation of the
    /// batch (with softbody's rule: next to one). Why the caller needs this: an operation
    /// refused half-way through a batch would leave the rest of the batch unbalanced, e.g. the
    /// refine of a swap without the merge that made room for it.
    ///
    /// The plan is the one [`Evaluator::evaluate`] makes, with three differences. A merge that
    /// an earlier operation locks is passed over for the next one in the queue. A refine that
    /// fits the budget outright but that an earlier operation locks (or a merge of the same
    /// swap, made next to it) is left out but keeps the room it needs: that room is not given
    /// to nodes that matter less, so the node is refined at a later call, once the transitions
    /// next to it end, rather than having to win its place back by a swap against the
    /// hysteresis. A refine that needs a swap and that an earlier operation of the batch locks
    /// is passed over without merging anything for it: those merges would coarsen their
    /// families a whole interval before the refine could begin (on the perception scenes at
    /// 30% of the nodes they left the cut about 85 nodes under its budget after the first
    /// evaluations; the partly off-screen net's on-screen RMS went from 4.66 to 2.05 px
    /// without them). Locks also slow merging: a
    /// parent merged in this batch is locked, so its own parent is not merged too, and an
    /// over-budget cut merges at most one family per neighbourhood (and `max_ops` in all) per
    /// call.
    ///
    /// The evaluator asks only about operations that can begin, and asks before the batch's
    /// earlier operations have begun, so the answer must not depend on them. It does not for a
    /// rule whose locks cover everything next to what an operation changes (softbody's): a later
    /// operation of the batch is never next to an earlier one, so its neighbours are the same
    /// before and after.
    pub fn evaluate_with_locks(
        &mut self,
        h: &Hierarchy,
        cut: &Cut,
        priorities: &[f32],
        costs: Option<&[f32]>,
        budget: Budget,
        locks: &dyn Fn(Op, &mut Vec<NodeId>),
    ) -> Result<&[Op], EvalError> {
        let inputs = self.validate(h, cut, priorities, costs, budget, Some(locks))?;
        self.run(&inputs, budget);
        Ok(&self.ops)
    }

    /// The planning loop shared by both entry points; leaves the batch in `self.ops`.
    fn run(&mut self, inputs: &Inputs<'_>, budget: Budget) {
        let (h, cut) = (inputs.h, inputs.cut);
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
            if !h.is_leaf(n)
                && !cut.is_locked(n)
                && inputs.priorities[n.index()] > self.refine_floor
            {
                split.push((Priority(inputs.priorities[n.index()]), Reverse(n)));
                min_delta = min_delta.min(inputs.refine_delta(n));
            }
            if let Some(p) = h.parent(n)
                && h.children(p).first() == Some(n)
                && let Some(key) = self.merge_key(inputs, p)
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
        // on only refines that fit outright are taken, which matters when fanouts differ. A swap
        // that failed for want of merges the locks allow says nothing about other splits.
        let mut swaps_exhausted = false;
        while self.ops.len() < self.settings.max_ops {
            if spent > limit + eps {
                match self.pop_merge(inputs) {
                    Some((_, p)) => spent -= self.apply_coarse(inputs, p),
                    None => break,
                }
                continue;
            }
            let Some((ps, s)) = self.peek_split(inputs) else {
                break;
            };
            let delta = inputs.refine_delta(s);
            if spent + delta <= limit + eps {
                self.split.pop();
                spent += self.refine_or_claim(inputs, s);
                continue;
            }
            if swaps_exhausted {
                if spent + min_delta > limit + eps {
                    break;
                }
                self.split.pop();
                continue;
            }
            // A split an earlier operation of this batch locks cannot begin now: merging parents
            // to make room for it would coarsen them an interval early for nothing (a swap's
            // room is not kept for later, unlike a refine that fits outright).
            if self.blocked[s.index()] {
                self.split.pop();
                continue;
            }
            // Swap: free room by merging parents that matter clearly less than `s`. The merges
            // begin first, in the order held, then `s`.
            let mut freed = 0f64;
            let mut lock_refused = false;
            let room = self.settings.max_ops - self.ops.len();
            while spent + delta - freed > limit + eps && self.held.len() + 1 < room {
                let Some((km, m)) = self.pop_merge(inputs) else {
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
                if !self.hold_locks(inputs, m) {
                    self.skipped.push((km, m));
                    lock_refused = true;
                    continue;
                }
                freed += inputs.refine_delta(m);
                self.held.push((km, m));
            }
            self.held_locks.clear();
            let fits = spent + delta - freed <= limit + eps;
            for (k, m) in self.skipped.drain(..) {
                self.merge.push(Reverse((k, m)));
            }
            if !fits {
                for (k, m) in self.held.drain(..) {
                    self.merge.push(Reverse((k, m)));
                }
                swaps_exhausted |= !lock_refused;
                self.split.pop();
                continue;
            }
            let held = std::mem::take(&mut self.held);
            for &(_, m) in &held {
                spent -= self.apply_coarse(inputs, m);
            }
            self.held = held;
            self.held.clear();
            self.split.pop();
            spent += self.refine_or_claim(inputs, s);
        }
    }

    /// Refines `n`, or, if an earlier operation of this batch locks it, leaves it out and keeps
    /// the room it needs (see [`Evaluator::evaluate_with_locks`]); returns the budget spent or
    /// kept.
    fn refine_or_claim(&mut self, inputs: &Inputs<'_>, n: NodeId) -> f64 {
        if self.blocked[n.index()] {
            inputs.refine_delta(n)
        } else {
            self.apply_refine(inputs, n)
        }
    }

    /// With a lock rule, checks that merging `m` can follow the merges held so far (none of them
    /// locks `m` or its children), and if so adds what it locks to the held locks. Always true
    /// without a rule.
    fn hold_locks(&mut self, inputs: &Inputs<'_>, m: NodeId) -> bool {
        let Some(rule) = inputs.locks else {
            return true;
        };
        let kids = inputs.h.children(m);
        if self.held_locks.iter().any(|&x| x == m || kids.contains(x)) {
            return false;
        }
        rule(Op::Coarse(m), &mut self.held_locks);
        true
    }

    /// Records the locks that beginning `op` takes (nothing without a lock rule).
    fn lock(&mut self, inputs: &Inputs<'_>, op: Op) {
        let Some(rule) = inputs.locks else {
            return;
        };
        let mut out = std::mem::take(&mut self.op_locks);
        out.clear();
        rule(op, &mut out);
        for &n in &out {
            if let Some(b) = self.blocked.get_mut(n.index())
                && !*b
            {
                *b = true;
                self.batch_locked.push(n);
            }
        }
        self.op_locks = out;
    }

    fn validate<'a>(
        &self,
        h: &'a Hierarchy,
        cut: &'a Cut,
        priorities: &'a [f32],
        costs: Option<&'a [f32]>,
        budget: Budget,
        locks: Option<LockRule<'a>>,
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
            locks,
        })
    }

    fn reset(&mut self, len: usize) {
        if self.overlay.len() != len {
            self.overlay = vec![UNCHANGED; len];
            self.merged_priority = vec![0.0; len];
            self.blocked = vec![false; len];
        } else {
            for n in self.touched.drain(..) {
                self.overlay[n.index()] = UNCHANGED;
            }
            for n in self.batch_locked.drain(..) {
                self.blocked[n.index()] = false;
            }
        }
        self.touched.clear();
        self.batch_locked.clear();
        self.held_locks.clear();
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

    /// Whether `n` is locked, in the cut or by an earlier operation of this batch.
    #[inline]
    fn locked(&self, cut: &Cut, n: NodeId) -> bool {
        cut.is_locked(n) || self.blocked[n.index()]
    }

    /// Whether `p` may be merged now: unlocked, off the cut, children all active, unlocked and not
    /// created by a refine of this batch (that would undo it).
    fn mergeable(&self, inputs: &Inputs<'_>, p: NodeId) -> bool {
        let cut = inputs.cut;
        !self.locked(cut, p)
            && !self.on_cut(cut, p)
            && inputs.h.children(p).all(|k| {
                self.on_cut(cut, k)
                    && !self.locked(cut, k)
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
        self.lock(inputs, Op::Refine(n));
        inputs.refine_delta(n)
    }

    /// Records a coarse of `p` in the overlay; returns the budget it frees. The grandparent may
    /// become mergeable in turn (unless a lock rule locks `p`).
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
        self.lock(inputs, Op::Coarse(p));
        if let Some(g) = inputs.h.parent(p) {
            self.push_merge_candidate(inputs, g);
        }
        inputs.refine_delta(p)
    }
}
