//! Property tests over random grids, meshes and operation sequences.

use glam::Vec3;
use proptest::prelude::*;

use crate::*;

/// A jittered grid triangulated with a random diagonal per quad, as a general triangle mesh.
fn mesh(cols: u32, rows: u32, seed: u64) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut s = seed | 1;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f32 / (1u64 << 53) as f32
    };
    let mut p = Vec::new();
    for j in 0..rows {
        for i in 0..cols {
            p.push(Vec3::new(
                i as f32 + 0.3 * rnd(),
                0.2 * rnd(),
                j as f32 + 0.3 * rnd(),
            ));
        }
    }
    let mut t = Vec::new();
    for j in 0..rows - 1 {
        for i in 0..cols - 1 {
            let a = j * cols + i;
            let (b, c, d) = (a + 1, a + cols, a + cols + 1);
            if rnd() < 0.5 {
                t.push([a, b, d]);
                t.push([a, d, c]);
            } else {
                t.push([a, b, c]);
                t.push([b, d, c]);
            }
        }
    }
    (p, t)
}

fn hierarchy(kind: bool, cols: u32, rows: u32, seed: u64) -> Hierarchy {
    if kind {
        Hierarchy::grid(&GridSpec::horizontal(cols, rows, 0.1, 2.0)).unwrap()
    } else {
        let (p, t) = mesh(cols.max(2), rows.max(2), seed);
        Hierarchy::from_mesh(&p, &t, None).unwrap()
    }
}

fn sorted(c: &Cut) -> Vec<NodeId> {
    let mut a = c.active().to_vec();
    a.sort();
    a
}

/// Applies a pseudo-random refine or coarse (or a refused one) and checks what must hold.
fn random_op(h: &Hierarchy, cut: &mut Cut, pick: usize, refine: bool) {
    let n = NodeId::new(pick % h.len());
    let before = cut.clone();
    let r = if refine {
        cut.refine(h, n)
    } else {
        cut.coarse(h, n)
    };
    if r.is_err() {
        assert_eq!(*cut, before, "refused {n:?} changed the cut: {r:?}");
    } else {
        // coarse(refine(n)) and refine(coarse(p)) restore the set of active nodes.
        let mut undo = cut.clone();
        if refine {
            undo.coarse(h, n).unwrap();
        } else {
            undo.refine(h, n).unwrap();
        }
        assert_eq!(sorted(&undo), sorted(&before));
    }
    cut.check_invariant(h).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn cut_invariant_under_random_ops(
        grid in any::<bool>(), cols in 1u32..24, rows in 1u32..24, seed in any::<u64>(),
        ops in proptest::collection::vec((any::<usize>(), any::<bool>(), any::<bool>()), 1..200),
    ) {
        let h = hierarchy(grid, cols, rows, seed);
        let mut cut = Cut::root(&h);
        cut.check_invariant(&h).unwrap();
        for (pick, refine, lock) in ops {
            random_op(&h, &mut cut, pick, refine);
            if lock {
                let n = cut.active()[pick % cut.len()];
                cut.lock(n);
                let before = cut.clone();
                if !h.is_leaf(n) {
                    prop_assert_eq!(cut.refine(&h, n), Err(CutError::Locked(n)));
                }
                if let Some(p) = h.parent(n) {
                    prop_assert!(cut.coarse(&h, p).is_err());
                }
                prop_assert_eq!(&cut, &before);
                cut.unlock(n).unwrap();
            }
        }
    }

    #[test]
    fn masses_and_centroids_hold_at_every_level(
        grid in any::<bool>(), cols in 2u32..30, rows in 2u32..30, seed in any::<u64>(),
    ) {
        let h = hierarchy(grid, cols, rows, seed);
        for level in 0..h.level_count() {
            let total: f64 = h.nodes_at_level(level).map(|n| h.mass(n) as f64).sum();
            let leaves: f64 = h.nodes_at_level(0).map(|n| h.mass(n) as f64).sum();
            prop_assert!((total - leaves).abs() <= 1e-5 * leaves);
            let covered: usize = h.nodes_at_level(level).map(|n| h.vertices(n).len()).sum();
            prop_assert_eq!(covered, h.vertex_count());
        }
        for n in (0..h.len()).map(NodeId::new).filter(|&n| !h.is_leaf(n)) {
            let kids = h.children(n);
            prop_assert!(kids.len() >= 2, "{:?} has a single child", n);
            let m: f32 = kids.map(|k| h.mass(k)).sum();
            prop_assert!((m - h.mass(n)).abs() <= 1e-5 * m);
            let c = kids.fold(Vec3::ZERO, |a, k| a + h.rest_position(k) * h.mass(k)) / m;
            prop_assert!(c.distance(h.rest_position(n)) <= 1e-4 * (1.0 + c.length()));
            for k in kids {
                prop_assert_eq!(h.parent(k), Some(n));
                prop_assert_eq!(h.level(k) + 1, h.level(n));
            }
            // Vertex runs of the children tile the parent's.
            let run: Vec<u32> = kids.flat_map(|k| h.vertices(k).to_vec()).collect();
            prop_assert_eq!(run.as_slice(), h.vertices(n));
        }
    }

    #[test]
    fn adjacency_matches_brute_force(
        grid in any::<bool>(), cols in 2u32..12, rows in 2u32..12, seed in any::<u64>(),
        a in any::<usize>(), b in any::<usize>(),
    ) {
        let h = hierarchy(grid, cols, rows, seed);
        let (a, b) = (NodeId::new(a % h.len()), NodeId::new(b % h.len()));
        let disjoint = !h.is_ancestor_or_self(a, b) && !h.is_ancestor_or_self(b, a);
        let brute = disjoint && h.leaf_edges().iter().any(|&[u, v]| {
            let (ua, va) = (h.vertices(a).contains(&u), h.vertices(a).contains(&v));
            let (ub, vb) = (h.vertices(b).contains(&u), h.vertices(b).contains(&v));
            (ua && vb) || (va && ub)
        });
        prop_assert_eq!(h.adjacent(a, b), brute);
        prop_assert_eq!(h.adjacent(b, a), brute);
    }

    #[test]
    fn evaluator_respects_budget_cap_and_locks(
        grid in any::<bool>(), cols in 2u32..30, rows in 2u32..30, seed in any::<u64>(),
        budget in 1usize..900, max_ops in 1usize..40, rounds in 1usize..12,
        use_cost in any::<bool>(),
    ) {
        let h = hierarchy(grid, cols, rows, seed);
        let mut cut = Cut::root(&h);
        let mut ev = Evaluator::new(EvaluatorSettings { hysteresis: 0.05, max_ops, ..Default::default() });
        let costs: Vec<f32> = (0..h.len()).map(|i| 1.0 + (i % 3) as f32).collect();
        let limit = budget as f32 * 1.5;
        for r in 0..rounds {
            let prio: Vec<f32> = (0..h.len())
                .map(|i| ((i as u64 * 2654435761 + seed + r as u64 * 97) % 1000) as f32 / 1000.0)
                .collect();
            // Lock a few active nodes: the evaluator must never touch them.
            let locked: Vec<NodeId> = cut.active().iter().copied().step_by(7).collect();
            for &n in &locked { cut.lock(n); }
            let spend = |c: &Cut| -> f32 {
                if use_cost { c.active().iter().map(|n| costs[n.index()]).sum() } else { c.len() as f32 }
            };
            let before = spend(&cut);
            let b = if use_cost { Budget::Cost { limit } } else { Budget::Nodes(budget) };
            let lim = if use_cost { limit } else { budget as f32 };
            let ops = ev.evaluate(&h, &cut, &prio, Some(&costs), b).unwrap().to_vec();
            prop_assert!(ops.len() <= max_ops);
            for op in &ops {
                match *op {
                    Op::Refine(n) => {
                        prop_assert!(!cut.is_locked(n));
                        cut.refine(&h, n).unwrap();
                    }
                    Op::Coarse(p) => {
                        prop_assert!(!cut.is_locked(p));
                        prop_assert!(h.children(p).all(|k| !cut.is_locked(k)));
                        cut.coarse(&h, p).unwrap();
                    }
                }
            }
            cut.check_invariant(&h).unwrap();
            let after = spend(&cut);
            if before <= lim + 1e-3 {
                prop_assert!(after <= lim + 1e-3, "went over budget: {} -> {} > {}", before, after, lim);
            } else {
                prop_assert!(after <= before);
            }
            for &n in &locked { cut.unlock(n).unwrap(); }
        }
    }

    #[test]
    fn constant_priorities_converge_then_stop(
        grid in any::<bool>(), cols in 2u32..40, rows in 2u32..40, seed in any::<u64>(),
        budget in 1usize..2000, value in 0f32..1.0, parent_key in any::<bool>(),
    ) {
        let h = hierarchy(grid, cols, rows, seed);
        let mut cut = Cut::root(&h);
        let merge_key = if parent_key { MergeKey::Parent } else { MergeKey::MaxOfChildren };
        let mut ev = Evaluator::new(EvaluatorSettings { hysteresis: 0.0, max_ops: 16, merge_key });
        let prio = vec![value; h.len()];
        let mut quiet = false;
        for _ in 0..h.len() + 2 {
            let ops = ev.evaluate(&h, &cut, &prio, None, Budget::Nodes(budget)).unwrap().to_vec();
            if ops.is_empty() { quiet = true; break; }
            for op in ops {
                match op {
                    Op::Refine(n) => cut.refine(&h, n).unwrap(),
                    Op::Coarse(p) => cut.coarse(&h, p).unwrap(),
                }
            }
        }
        prop_assert!(quiet, "never converged");
        // Once quiet it stays quiet, and no further refine would have fitted.
        prop_assert!(ev.evaluate(&h, &cut, &prio, None, Budget::Nodes(budget)).unwrap().is_empty());
        prop_assert!(cut.len() <= budget.max(1));
        let fits = cut.active().iter().any(|&n| !h.is_leaf(n) && cut.len() + h.child_count(n) - 1 <= budget);
        prop_assert!(!fits, "stopped with room left");
    }
}

#[test]
fn swaps_need_to_beat_the_threshold() {
    let h = Hierarchy::grid(&GridSpec::horizontal(9, 9, 1.0, 1.0)).unwrap();
    let mut cut = Cut::uniform(&h, 1);
    let budget = Budget::Nodes(cut.len());
    let mut prio = vec![0.5f32; h.len()];
    let hot = cut.active()[3];
    prio[hot.index()] = 0.54;
    let mut ev = Evaluator::new(EvaluatorSettings {
        hysteresis: 0.05,
        max_ops: 8,
        ..Default::default()
    });
    assert!(
        ev.evaluate(&h, &cut, &prio, None, budget)
            .unwrap()
            .is_empty()
    );
    prio[hot.index()] = 0.6;
    let ops = ev.evaluate(&h, &cut, &prio, None, budget).unwrap().to_vec();
    assert!(ops.contains(&Op::Refine(hot)), "{ops:?}");
    for op in ops {
        match op {
            Op::Refine(n) => cut.refine(&h, n).unwrap(),
            Op::Coarse(p) => cut.coarse(&h, p).unwrap(),
        }
    }
    // Children inherit nothing: with their priorities at the field's value the cut stays put.
    for k in h.children(hot) {
        prio[k.index()] = 0.5;
    }
    assert!(
        ev.evaluate(&h, &cut, &prio, None, budget)
            .unwrap()
            .is_empty()
    );
}

#[test]
fn bad_meshes_are_refused() {
    let p = [Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::new(5.0, 0.0, 5.0)];
    assert!(matches!(
        Hierarchy::from_mesh(&[], &[], None),
        Err(BuildError::Empty(_))
    ));
    assert!(matches!(
        Hierarchy::from_mesh(&p[..3], &[], None),
        Err(BuildError::Empty(_))
    ));
    assert!(matches!(
        Hierarchy::from_mesh(&p[..3], &[[0, 1, 7]], None),
        Err(BuildError::IndexOutOfRange { index: 7, .. })
    ));
    assert!(matches!(
        Hierarchy::from_mesh(&[Vec3::NAN, Vec3::X, Vec3::Z], &[[0, 1, 2]], None),
        Err(BuildError::NonFinitePosition(0))
    ));
    assert!(matches!(
        Hierarchy::from_mesh(&p, &[[0, 1, 2]], None),
        Err(BuildError::Disconnected {
            components: 2,
            example: 3
        })
    ));
    assert!(matches!(
        Hierarchy::from_mesh(&p[..3], &[[0, 1, 1]], None),
        Err(BuildError::DegenerateTriangle(0))
    ));
    assert!(matches!(
        Hierarchy::from_mesh(&p[..3], &[[0, 1, 2]], Some(&[1.0, -1.0, 1.0])),
        Err(BuildError::InvalidMass { vertex: 1, .. })
    ));
    assert!(matches!(
        Hierarchy::grid(&GridSpec {
            cols: 0,
            ..GridSpec::horizontal(3, 3, 1.0, 1.0)
        }),
        Err(BuildError::BadGridSize { .. })
    ));
    assert!(matches!(
        Hierarchy::grid(&GridSpec {
            v: Vec3::X,
            ..GridSpec::horizontal(3, 3, 1.0, 1.0)
        }),
        Err(BuildError::BadGridAxes)
    ));
}

#[test]
fn odd_grids_have_no_single_child_and_levels_partition() {
    for (c, r) in [(65, 65), (7, 3), (1, 9), (64, 31), (1, 1)] {
        let h = Hierarchy::grid(&GridSpec::horizontal(c, r, 1.0, 1.0)).unwrap();
        assert_eq!(h.vertex_count(), (c * r) as usize);
        assert_eq!(h.nodes_at_level(h.level_count() - 1).len(), 1);
        for l in 0..h.level_count() {
            Cut::uniform(&h, l).check_invariant(&h).unwrap();
        }
        for n in (0..h.len()).map(NodeId::new) {
            assert_ne!(h.child_count(n), 1);
        }
    }
}

/// Both ends of an odd side are pairs (its group of three sits in the middle; a side of 3 or 5
/// cannot), so the two free edges of a square cloth are reconstructed alike: the nodes above
/// the corner leaves cover 2 × 2 vertices at all four corners, where the group of three at the
/// end gave one edge's nodes a centroid a whole spacing in from it (half a spacing at the other).
#[test]
fn odd_grids_keep_pairs_at_both_edges() {
    for side in [7u32, 9, 17, 33, 65, 129] {
        let spec = GridSpec::horizontal(side, side, 1.0, 1.0);
        let h = Hierarchy::grid(&spec).unwrap();
        let s = side - 1;
        for (i, j) in [(0, 0), (s, 0), (0, s), (s, s)] {
            let n = h.ancestor_at_level(h.leaf_of_vertex(spec.vertex(i, j)), 1);
            assert_eq!(h.vertices(n).len(), 4, "side {side}, corner ({i}, {j})");
            let centroid = (spec.position(i.min(s - 1), j.min(s - 1))
                + spec.position(i.max(1), j.max(1)))
                * 0.5;
            assert!(h.rest_position(n).distance(centroid) < 1e-4);
        }
    }
}

#[test]
fn from_nodes_checks_coverage() {
    let h = Hierarchy::grid(&GridSpec::horizontal(5, 5, 1.0, 1.0)).unwrap();
    let l1: Vec<NodeId> = h.nodes_at_level(1).collect();
    assert!(Cut::from_nodes(&h, &l1).is_ok());
    assert!(matches!(
        Cut::from_nodes(&h, &l1[1..]),
        Err(CutError::NotACut(_, 0))
    ));
    let mut twice = l1.clone();
    twice.push(h.children(l1[0]).first().unwrap());
    assert!(matches!(
        Cut::from_nodes(&h, &twice),
        Err(CutError::NotACut(_, 2))
    ));
}

/// With priorities that shrink with the node (screen-space error), children are each worth
/// less than their parent was. Keyed by the children, a merge of a just-refined parent looks
/// cheap and any equal candidate swaps with it: flicker. Keyed by the parent's own value, the
/// swap must beat what the refine gained.
#[test]
fn parent_merge_keys_keep_size_scaled_refines() {
    let h = Hierarchy::grid(&GridSpec::horizontal(9, 9, 1.0, 1.0)).unwrap();
    let prio: Vec<f32> = (0..h.len())
        .map(|i| h.vertices(NodeId::new(i)).len() as f32)
        .collect();
    for (merge_key, flickers) in [(MergeKey::MaxOfChildren, true), (MergeKey::Parent, false)] {
        let mut cut = Cut::uniform(&h, 1);
        let hot = cut.active()[12];
        cut.refine(&h, hot).unwrap();
        let budget = Budget::Nodes(cut.len());
        let mut ev = Evaluator::new(EvaluatorSettings {
            hysteresis: 0.5,
            max_ops: 8,
            merge_key,
        });
        let ops = ev.evaluate(&h, &cut, &prio, None, budget).unwrap();
        assert_eq!(
            ops.contains(&Op::Coarse(hot)),
            flickers,
            "{merge_key:?}: {ops:?}"
        );
    }
}

// --- Batches for callers whose operations run as locking transitions ---

/// What an operation changes: the refined node, or the merged parent.
fn region(op: Op) -> NodeId {
    op.node()
}

/// Whether two regions overlap or touch (some mesh edge joins them).
fn touch(h: &Hierarchy, a: NodeId, b: NodeId) -> bool {
    h.is_ancestor_or_self(a, b) || h.is_ancestor_or_self(b, a) || h.adjacent(a, b)
}

/// The lock rule of softbody's TreeCut soft body, by brute force over the cut: beginning an
/// operation locks its nodes (the refined node's children; the merged parent and its children)
/// and every active node next to what it changes.
fn neighbourhood_locks(h: &Hierarchy, cut: &Cut, op: Op, out: &mut Vec<NodeId>) {
    match op {
        Op::Refine(n) => out.extend(h.children(n)),
        Op::Coarse(p) => {
            out.push(p);
            out.extend(h.children(p));
        }
    }
    out.extend(
        cut.active()
            .iter()
            .copied()
            .filter(|&a| h.adjacent(a, region(op))),
    );
}

fn sorted_locks(h: &Hierarchy, cut: &Cut, op: Op) -> Vec<NodeId> {
    let mut v = Vec::new();
    neighbourhood_locks(h, cut, op, &mut v);
    v.sort();
    v.dedup();
    v
}

/// A transition in flight, as the test simulates softbody's: what it changes, what it locked,
/// and how many more rounds it runs.
struct InFlight {
    op: Op,
    locked: Vec<NodeId>,
    rounds_left: u32,
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Given the lock rule, every batch begins in full on a cut whose transitions lock their
    /// neighbourhoods: no operation touches (overlaps or is next to) a transition in flight or
    /// another operation of the batch, what the rule said before the batch is what the
    /// operation locks when it begins, and the budget holds after every operation.
    #[test]
    fn locked_batches_begin_in_full_and_fit(
        grid in any::<bool>(), cols in 2u32..18, rows in 2u32..18, seed in any::<u64>(),
        budget_frac in 0.05f32..1.0, max_ops in 1usize..24, hysteresis in 0f32..0.3,
        parent_key in any::<bool>(), use_cost in any::<bool>(), rounds in 4usize..20,
    ) {
        let h = hierarchy(grid, cols, rows, seed);
        let mut cut = Cut::uniform(&h, (seed % 3) as u32);
        let merge_key = if parent_key { MergeKey::Parent } else { MergeKey::MaxOfChildren };
        let mut ev = Evaluator::new(EvaluatorSettings { hysteresis, max_ops, merge_key });
        let costs: Vec<f32> = (0..h.len()).map(|i| 1.0 + (i % 3) as f32).collect();
        let nodes = ((h.vertex_count() as f32 * budget_frac) as usize).max(1);
        let (budget, limit) = if use_cost {
            let limit = nodes as f32 * 2.0;
            (Budget::Cost { limit }, limit)
        } else {
            (Budget::Nodes(nodes), nodes as f32)
        };
        let spend = |c: &Cut| -> f32 {
            if use_cost { c.active().iter().map(|n| costs[n.index()]).sum() } else { c.len() as f32 }
        };
        let mut in_flight: Vec<InFlight> = Vec::new();
        for r in 0..rounds {
            // Transitions that are done end and release their locks.
            in_flight.retain_mut(|t| {
                if t.rounds_left == 0 {
                    for &n in &t.locked { cut.unlock(n).unwrap(); }
                    false
                } else {
                    t.rounds_left -= 1;
                    true
                }
            });
            let prio: Vec<f32> = (0..h.len())
                .map(|i| ((i as u64 * 2654435761 + seed + r as u64 * 97) % 1000) as f32 / 1000.0)
                .collect();
            let before = cut.clone();
            let rule = |op: Op, out: &mut Vec<NodeId>| neighbourhood_locks(&h, &before, op, out);
            let ops = ev
                .evaluate_with_locks(&h, &before, &prio, Some(&costs), budget, &rule)
                .unwrap()
                .to_vec();
            prop_assert!(ops.len() <= max_ops);
            let promised: Vec<Vec<NodeId>> =
                ops.iter().map(|&op| sorted_locks(&h, &before, op)).collect();
            let within = spend(&before) <= limit + 1e-3;
            for (i, &op) in ops.iter().enumerate() {
                for t in &in_flight {
                    prop_assert!(!touch(&h, region(op), region(t.op)),
                        "{:?} touches {:?}, in flight", op, t.op);
                }
                for &e in &ops[..i] {
                    prop_assert!(!touch(&h, region(op), region(e)),
                        "{:?} touches {:?} of the same batch", op, e);
                }
                // Begin it as softbody would: checked against the locks, then locking.
                let locked = sorted_locks(&h, &cut, op);
                prop_assert_eq!(&locked, &promised[i], "{:?} locks differently once begun", op);
                let before_op = spend(&cut);
                match op {
                    Op::Refine(n) => prop_assert_eq!(cut.refine(&h, n), Ok(())),
                    Op::Coarse(p) => prop_assert_eq!(cut.coarse(&h, p), Ok(())),
                }
                for &n in &locked { cut.lock(n); }
                in_flight.push(InFlight { op, locked, rounds_left: (seed >> (i % 60)) as u32 % 3 });
                // Never above the budget, or while above it (the start was), never growing.
                let after = spend(&cut);
                prop_assert!(after <= limit + 1e-3 || (!within && after <= before_op),
                    "{:?} went over budget: {} -> {} > {}", op, before_op, after, limit);
            }
            cut.check_invariant(&h).unwrap();
        }
    }
}

/// Two neighbours both worth refining, room for both: a batch for transitions refines the
/// first only (the second is locked by it) and keeps the second's room free rather than give
/// it to a node that matters less; once the first transition ends, the second is refined.
#[test]
fn a_locked_refine_keeps_its_room() {
    let h = Hierarchy::grid(&GridSpec::horizontal(17, 17, 1.0, 1.0)).unwrap();
    let mut cut = Cut::uniform(&h, 1);
    let active = cut.active().to_vec();
    let a = active[20];
    let b = *h
        .level_neighbours(a)
        .iter()
        .find(|&&b| !h.is_leaf(b) && h.child_count(b) <= h.child_count(a))
        .unwrap();
    let c = *active
        .iter()
        .find(|&&c| !touch(&h, c, a) && !touch(&h, c, b) && h.child_count(c) == h.child_count(b))
        .unwrap();
    let mut prio = vec![0.1f32; h.len()];
    prio[a.index()] = 0.9;
    prio[b.index()] = 0.8;
    prio[c.index()] = 0.5;
    let grow = |n: NodeId| h.child_count(n) - 1;
    let budget = Budget::Nodes(cut.len() + grow(a) + grow(b));
    // No swaps: only refines that fit outright.
    let mut ev = Evaluator::new(EvaluatorSettings {
        hysteresis: 10.0,
        max_ops: 8,
        ..Default::default()
    });
    let plain = ev.evaluate(&h, &cut, &prio, None, budget).unwrap().to_vec();
    assert_eq!(plain, vec![Op::Refine(a), Op::Refine(b)]);
    let rule = |op: Op, out: &mut Vec<NodeId>| neighbourhood_locks(&h, &cut, op, out);
    let locked = ev
        .evaluate_with_locks(&h, &cut, &prio, None, budget, &rule)
        .unwrap()
        .to_vec();
    assert_eq!(locked, vec![Op::Refine(a)], "c must not take b's room");
    // Begin a, let its transition end, then b follows.
    let locks = sorted_locks(&h, &cut, Op::Refine(a));
    assert!(locks.contains(&b));
    cut.refine(&h, a).unwrap();
    for k in h.children(a) {
        prio[k.index()] = 0.1;
    }
    let rule = |op: Op, out: &mut Vec<NodeId>| neighbourhood_locks(&h, &cut, op, out);
    let ops = ev
        .evaluate_with_locks(&h, &cut, &prio, None, budget, &rule)
        .unwrap()
        .to_vec();
    assert_eq!(ops, vec![Op::Refine(b)]);
}

/// A swap whose only worthwhile merge is next to the node to refine: softbody would refuse the
/// refine once the merge began, so the batch holds the merge alone, the room it frees kept for
/// the refine, which fits outright at the next call.
#[test]
fn a_swap_next_to_its_merge_completes_at_the_next_call() {
    let h = Hierarchy::grid(&GridSpec::horizontal(17, 17, 1.0, 1.0)).unwrap();
    let mut cut = Cut::uniform(&h, 1);
    let (s, m) = cut
        .active()
        .iter()
        .filter(|&&s| !h.is_leaf(s))
        .find_map(|&s| {
            let m = h
                .level_neighbours(s)
                .iter()
                .filter_map(|&y| h.parent(y))
                .find(|&m| Some(m) != h.parent(s) && h.child_count(m) >= h.child_count(s))?;
            Some((s, m))
        })
        .unwrap();
    let mut prio = vec![0.5f32; h.len()];
    prio[s.index()] = 0.9;
    for k in h.children(m) {
        prio[k.index()] = 0.1;
    }
    let budget = Budget::Nodes(cut.len());
    let mut ev = swap_evaluator();
    let plain = ev.evaluate(&h, &cut, &prio, None, budget).unwrap().to_vec();
    assert_eq!(plain, vec![Op::Coarse(m), Op::Refine(s)]);
    let rule = |op: Op, out: &mut Vec<NodeId>| neighbourhood_locks(&h, &cut, op, out);
    let locked = ev
        .evaluate_with_locks(&h, &cut, &prio, None, budget, &rule)
        .unwrap()
        .to_vec();
    assert_eq!(locked, vec![Op::Coarse(m)]);
    assert!(sorted_locks(&h, &cut, Op::Coarse(m)).contains(&s));
    cut.coarse(&h, m).unwrap();
    prio[m.index()] = 0.1;
    let rule = |op: Op, out: &mut Vec<NodeId>| neighbourhood_locks(&h, &cut, op, out);
    let ops = ev
        .evaluate_with_locks(&h, &cut, &prio, None, budget, &rule)
        .unwrap()
        .to_vec();
    assert_eq!(ops, vec![Op::Refine(s)]);
}

/// Without a lock rule nothing changes: `evaluate_with_locks` with a rule that locks nothing
/// plans exactly what `evaluate` plans.
#[test]
fn a_rule_that_locks_nothing_plans_as_evaluate() {
    let h = Hierarchy::grid(&GridSpec::horizontal(33, 33, 1.0, 1.0)).unwrap();
    let mut cut = Cut::uniform(&h, 2);
    let mut ev = Evaluator::new(EvaluatorSettings {
        hysteresis: 0.05,
        max_ops: 16,
        ..Default::default()
    });
    for round in 0..20u64 {
        let prio: Vec<f32> = (0..h.len() as u64)
            .map(|i| ((i * 2654435761 + round * 40503) % 1000) as f32 / 1000.0)
            .collect();
        let budget = Budget::Nodes(200 + 40 * (round as usize % 5));
        let plain = ev.evaluate(&h, &cut, &prio, None, budget).unwrap().to_vec();
        let none = ev
            .evaluate_with_locks(&h, &cut, &prio, None, budget, &|_, _| {})
            .unwrap()
            .to_vec();
        assert_eq!(plain, none);
        for op in plain {
            match op {
                Op::Refine(n) => cut.refine(&h, n).unwrap(),
                Op::Coarse(p) => cut.coarse(&h, p).unwrap(),
            }
        }
    }
}

/// Two neighbours both worth a swap, the budget full: a batch for transitions merges a family
/// for the first and refines it, but merges nothing for the second, which the first's refine
/// locks (a merge for a refine that cannot begin would coarsen that family an interval early
/// for nothing); without locks both swaps are planned.
#[test]
fn a_swap_does_not_merge_for_a_split_the_batch_locks() {
    let h = Hierarchy::grid(&GridSpec::horizontal(17, 17, 1.0, 1.0)).unwrap();
    let cut = Cut::uniform(&h, 1);
    let (a, b) = cut
        .active()
        .iter()
        .filter(|&&a| !h.is_leaf(a))
        .find_map(|&a| {
            let locks = sorted_locks(&h, &cut, Op::Refine(a));
            let b = cut
                .active()
                .iter()
                .copied()
                .find(|&b| b != a && !h.is_leaf(b) && locks.contains(&b))?;
            Some((a, b))
        })
        .unwrap();
    // Two families to merge, touching neither a nor b nor each other.
    let apart = |m: NodeId, x: NodeId| !touch(&h, m, x) && h.children(m).all(|k| !touch(&h, k, x));
    let mut far: Vec<NodeId> = Vec::new();
    for m in h.nodes_at_level(2) {
        if far.len() < 2
            && [a, b]
                .iter()
                .chain(&far)
                .all(|&x| apart(m, x) && apart(x, m))
        {
            far.push(m);
        }
    }
    assert_eq!(far.len(), 2);
    let mut prio = vec![0.5f32; h.len()];
    prio[a.index()] = 0.9;
    prio[b.index()] = 0.8;
    // Whichever merge key the settings use: the parent's or its children's.
    for &m in &far {
        prio[m.index()] = 0.1;
        for k in h.children(m) {
            prio[k.index()] = 0.1;
        }
    }
    let budget = Budget::Nodes(cut.len());
    let mut ev = swap_evaluator();
    let plain = ev.evaluate(&h, &cut, &prio, None, budget).unwrap().to_vec();
    assert_eq!(
        plain
            .iter()
            .filter(|op| matches!(op, Op::Coarse(_)))
            .count(),
        2,
        "{plain:?}"
    );
    assert!(plain.contains(&Op::Refine(a)) && plain.contains(&Op::Refine(b)));
    let rule = |op: Op, out: &mut Vec<NodeId>| neighbourhood_locks(&h, &cut, op, out);
    let locked = ev
        .evaluate_with_locks(&h, &cut, &prio, None, budget, &rule)
        .unwrap()
        .to_vec();
    assert_eq!(locked.len(), 2, "{locked:?}");
    assert!(
        matches!(locked[0], Op::Coarse(m) if far.contains(&m)),
        "{locked:?}"
    );
    assert_eq!(locked[1], Op::Refine(a));
}

/// The evaluator of the swap tests: hysteresis 0.45 (a merge at 0.1 pays for a split at 0.9 or
/// 0.8, one at 0.5 does not), up to 8 operations per batch.
fn swap_evaluator() -> Evaluator {
    Evaluator::new(EvaluatorSettings {
        hysteresis: 0.45,
        max_ops: 8,
        ..Default::default()
    })
}
