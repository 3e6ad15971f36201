//! The work of one world frame on the threads: a job per crowd and per cloth, run (crowds each
//! split across the pool, cloths largest first on whichever thread is free), and each cloth
//! step's work counted in the budget's cost units. [`super::frame`] prepares the jobs (shares
//! applied, phases balanced, operations capped) and accounts for them after.

use std::time::Instant;

use salience::View;

use super::budget::{BudgetShare, WorldError};
use super::frame::ObjectKey;
use crate::cloth::{AdaptiveCloth, ClothBudget, FeedbackSettings};
use animlod::Crowd;

/// A crowd of the frame and what its advance returned.
pub(crate) struct CrowdJob<'a> {
    pub(crate) key: ObjectKey,
    pub(crate) crowd: &'a mut Crowd,
    pub(crate) bound: f32,
    pub(crate) share: BudgetShare,
    pub(crate) outcome: Result<animlod::FrameStats, animlod::CrowdError>,
}

/// Advances each crowd (each split across the current pool's threads if it allows); returns
/// the wall time spent, ms.
pub(crate) fn run_crowds(jobs: &mut [CrowdJob<'_>], dt: f32, view: &View) -> f64 {
    let t = Instant::now();
    for job in jobs.iter_mut() {
        job.outcome = job.crowd.advance(dt, view);
    }
    t.elapsed().as_secs_f64() * 1e3
}

/// Steps one cloth job through its steps, counting each step's work in `model`'s units.
fn step_job(job: &mut ClothJob<'_>, view: &View, model: crate::cloth::CostModel) {
    let mut work = StepCost::default();
    job.outcome = (|| {
        if let Some(fraction) = job.part
            && job.steps == 0
            && let Some(w) = job.cloth.evaluate_ahead_part(view, fraction)?
        {
            // A part of the next step's evaluation: its cost, not an evaluation yet.
            work.units += model.evaluation_seconds(&w) * 1e9;
        }
        for _ in 0..job.steps {
            job.cloth.step(view)?;
            let w = job.cloth.stats().last_work;
            let all = model.seconds(&w) * 1e9;
            let evaluation = model.evaluation_seconds(&w) * 1e9;
            let transitions = model.transition_seconds(&w) * 1e9;
            work.steps += 1;
            work.evaluations += (w.evaluated_nodes > 0) as u64;
            work.units += all;
            work.settled_units += all - evaluation - transitions;
            work.transition_units += transitions;
        }
        if job.split_next
            && job.steps > 0
            && let Some(w) = job.cloth.evaluate_ahead_part(view, 0.5)?
        {
            // Half of the next step's evaluation, over the state that step will see.
            work.units += model.evaluation_seconds(&w) * 1e9;
        }
        Ok(work)
    })();
}

/// The cloth jobs largest first, each behind its own lock, for threads to take in turn
/// (longest-processing-time scheduling: split in halves, as a parallel iterator over the slot
/// order does, two threads waited on each other's last large cloth).
fn largest_first<'j, 'a>(
    jobs: &'j mut [ClothJob<'a>],
) -> Vec<std::sync::Mutex<&'j mut ClothJob<'a>>> {
    let mut order: Vec<&mut ClothJob<'_>> = jobs.iter_mut().collect();
    order.sort_by_key(|j| {
        let work = j.cloth.link_count() + j.cloth.node_count();
        (std::cmp::Reverse(work * j.steps as usize), j.key)
    });
    order.into_iter().map(std::sync::Mutex::new).collect()
}

/// Takes cloth jobs from `queue` (claimed through `next`) until none is left.
fn take_cloths(
    queue: &[std::sync::Mutex<&mut ClothJob<'_>>],
    next: &std::sync::atomic::AtomicUsize,
    view: &View,
    model: crate::cloth::CostModel,
) {
    loop {
        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let Some(job) = queue.get(i) else { break };
        // Each job is taken once, so its lock is never contended.
        let mut job = job.lock().unwrap_or_else(|e| e.into_inner());
        step_job(&mut job, view, model);
    }
}

/// Steps each cloth job on `threads` threads of the current pool, largest first, each taken
/// by whichever thread is free; counts each step's work in `model`'s units. Returns the wall
/// time spent, ms.
pub(crate) fn run_cloths(
    jobs: &mut [ClothJob<'_>],
    view: &View,
    model: crate::cloth::CostModel,
    threads: usize,
) -> f64 {
    let t = Instant::now();
    if threads < 2 || jobs.len() < 2 {
        jobs.iter_mut().for_each(|job| step_job(job, view, model));
    } else {
        let queue = largest_first(jobs);
        let next = std::sync::atomic::AtomicUsize::new(0);
        rayon::scope(|s| {
            for _ in 1..threads {
                s.spawn(|_| take_cloths(&queue, &next, view, model));
            }
            take_cloths(&queue, &next, view, model);
        });
    }
    t.elapsed().as_secs_f64() * 1e3
}

/// The crowds and the cloths of a frame in one phase on `threads` threads of the current pool:
/// the crowds start first on one thread (their own parallel split spreads to any thread that
/// runs out of cloths), the cloths largest first on the others, and a thread done with the
/// crowds takes cloths too. No barrier between the two kinds: the crowds' serial parts overlap
/// the cloths' steps. Returns the crowds' own wall time and the phase's, ms. Results are those
/// of [`run_crowds`] then [`run_cloths`]: each object's work does not depend on which thread
/// does it.
pub(crate) fn run_together(
    crowds: &mut [CrowdJob<'_>],
    cloths: &mut [ClothJob<'_>],
    dt: f32,
    view: &View,
    model: crate::cloth::CostModel,
    threads: usize,
) -> (f64, f64) {
    let t = Instant::now();
    if threads < 2 || crowds.is_empty() {
        let crowd_ms = run_crowds(crowds, dt, view);
        run_cloths(cloths, view, model, threads);
        return (crowd_ms, t.elapsed().as_secs_f64() * 1e3);
    }
    let queue = largest_first(cloths);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut crowd_ms = 0.0;
    rayon::scope(|s| {
        // Spawned first: the first job another thread steals (thieves take the oldest).
        s.spawn(|_| crowd_ms = run_crowds(crowds, dt, view));
        for _ in 2..threads {
            s.spawn(|_| take_cloths(&queue, &next, view, model));
        }
        // Spawned last, so the calling thread's first pop after its own share is this one:
        // whichever thread finishes the crowds steals it and joins the cloths.
        s.spawn(|_| take_cloths(&queue, &next, view, model));
        take_cloths(&queue, &next, view, model);
    });
    (crowd_ms, t.elapsed().as_secs_f64() * 1e3)
}

/// A cloth of the frame, its steps, and what they cost.
pub(crate) struct ClothJob<'a> {
    pub(crate) key: ObjectKey,
    pub(crate) cloth: &'a mut AdaptiveCloth,
    pub(crate) steps: u32,
    /// The fraction of its next step's evaluation to have measured by the end of this frame,
    /// when it does not step in it ([`AdaptiveCloth::evaluate_ahead_part`]; see
    /// `FrameBudgeter::balance_phases`).
    pub(crate) part: Option<f32>,
    /// Whether, stepping in this frame, it measures half of its next step's evaluation after
    /// its steps ([`AdaptiveCloth::evaluate_ahead_part`]; see `FrameBudgeter::balance_phases`).
    pub(crate) split_next: bool,
    pub(crate) bound: f32,
    pub(crate) share: BudgetShare,
    pub(crate) outcome: Result<StepCost, crate::cloth::ClothError>,
}

/// What a cloth's steps of one frame cost, in cost units.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct StepCost {
    pub(crate) steps: u32,
    pub(crate) evaluations: u64,
    /// Everything.
    pub(crate) units: f64,
    /// Without the evaluations and the transitions in flight.
    pub(crate) settled_units: f64,
    /// The transitions in flight.
    pub(crate) transition_units: f64,
}

/// Puts a cloth's feedback budget where its share says: the world's bound (in place, keeping
/// the loop's state), the full cut, or untouched.
pub(crate) fn apply_cloth_share(
    cloth: &mut AdaptiveCloth,
    share: BudgetShare,
    bound: Option<f32>,
) -> Result<(), WorldError> {
    let current = cloth.feedback().map(|f| f.budget);
    match (share, bound) {
        (BudgetShare::FullDetail, _) if current != Some(ClothBudget::Compression(1.0)) => {
            let base = cloth.feedback().copied().unwrap_or_default();
            cloth.set_feedback(Some(FeedbackSettings {
                budget: ClothBudget::Compression(1.0),
                ..base
            }))?;
        }
        (BudgetShare::FullDetail, _) => {}
        (_, Some(b))
            if current != Some(ClothBudget::MaxErrorPx(b)) || !cloth.has_shared_bound() =>
        {
            cloth.set_shared_error_bound_px(b)?;
        }
        (_, Some(_)) => {}
        // The cloth's own budget: a bound the host set stays where the host puts it.
        (_, None) => cloth.clear_shared_bound(),
    }
    Ok(())
}

/// The most a cloth's step can grow by (its finest node count over its node count now).
pub(crate) fn full_ratio(c: &AdaptiveCloth) -> f64 {
    c.hierarchy().vertex_count() as f64 / c.node_count().max(1) as f64
}
