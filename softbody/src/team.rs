//! A leader thread and spinning helpers that share out *phases* of numbered runs of work: how
//! one body's colour batches are split across threads with a synchronisation cost of well under
//! a microsecond per batch.
//!
//! # Why not `rayon::join` per batch
//! A large cloth runs `substeps × iterations × colours` batches per step (360 at 20 iterations
//! and 18 colours), each a few to a few tens of microseconds of work. Forking each with
//! `rayon::join` was measured *slower* than one thread on the 2-core VM this was tuned on:
//! between two joins rayon's idle worker goes to sleep, waking it takes longer than a batch, so
//! the caller ended up solving about 88% of the runs itself and paid the fork for nothing. Here
//! the helpers stay awake (spinning, then yielding) for the whole team session and pick up each
//! phase as soon as the leader publishes it.
//!
//! # Protocol
//! One atomic *ticket* describes the current phase: a sequence number, the first run, how many
//! runs it has and how many have been claimed. Anyone (leader or helper) claims the next run
//! with a compare-and-swap, so each run is solved exactly once, by whoever gets there first;
//! [`Leader::phase`] returns when every run of the phase has been counted done. The leader never
//! waits for a helper that has not claimed anything: if no helper ever starts (a busy pool, a
//! pool of one), the leader solves every run itself, so a session cannot deadlock, whatever the
//! pool is doing. Helpers only spin while their leader is still working and leave when it ends
//! the session (also when it panics).

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

/// Bits of the ticket: `seq << 40 | start << 24 | claimed << 12 | count`.
const FIELD: u64 = (1 << 12) - 1;
/// Most runs one phase can have (the 12-bit `count` field).
pub(crate) const MAX_RUNS: usize = FIELD as usize;
/// Busy-wait rounds before a waiting helper starts yielding its core.
const SPINS: u32 = 1 << 14;

/// The shared state of one team session.
#[derive(Debug, Default)]
struct Shared {
    ticket: AtomicU64,
    done: AtomicUsize,
    stop: AtomicBool,
}

impl Shared {
    /// Claims the next unclaimed run of the current phase, if any.
    fn claim(&self) -> Option<usize> {
        let mut t = self.ticket.load(Ordering::Acquire);
        loop {
            let (claimed, count) = ((t >> 12) & FIELD, t & FIELD);
            if claimed >= count {
                return None;
            }
            match self.ticket.compare_exchange_weak(
                t,
                t + (1 << 12),
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => return Some((((t >> 24) & 0xFFFF) + claimed) as usize),
                Err(now) => t = now,
            }
        }
    }

    /// Claims and solves runs until the current phase has none left; whether it solved any.
    fn drain(&self, work: &impl Fn(usize)) -> bool {
        let mut any = false;
        while let Some(run) = self.claim() {
            work(run);
            self.done.fetch_add(1, Ordering::Release);
            any = true;
        }
        any
    }

    /// A helper: solves whatever is published until the session ends.
    fn help(&self, work: &impl Fn(usize)) {
        let mut idle = 0u32;
        loop {
            let worked = self.drain(work);
            if self.stop.load(Ordering::Acquire) {
                return;
            }
            if worked {
                idle = 0;
            } else if idle < SPINS {
                idle += 1;
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
    }
}

/// Sets `stop` when the leader's part ends, normally or by a panic, so helpers never outlive it.
struct StopOnDrop<'a>(&'a Shared);

impl Drop for StopOnDrop<'_> {
    fn drop(&mut self) {
        self.0.stop.store(true, Ordering::Release);
    }
}

/// The leader's handle in a session (see [`run`]).
pub(crate) struct Leader<'a, W> {
    shared: &'a Shared,
    work: &'a W,
    seq: std::cell::Cell<u64>,
}

impl<W: Fn(usize) + Sync> Leader<'_, W> {
    /// Solves runs `start..start + count` (`count <= MAX_RUNS`, `start < 65536`), sharing them
    /// with the helpers, and returns when all are done: everything the runs wrote is then
    /// visible to the caller, and no helper touches anything until the next phase.
    pub(crate) fn phase(&self, start: usize, count: usize) {
        debug_assert!(count <= MAX_RUNS && start < 1 << 16);
        let seq = self.seq.get().wrapping_add(1) & ((1 << 24) - 1);
        self.seq.set(seq);
        // No run of the previous phase is still in flight (it was waited for), so nobody adds to
        // `done` between this reset and the publication below.
        self.shared.done.store(0, Ordering::Relaxed);
        self.shared.ticket.store(
            (seq << 40) | ((start as u64) << 24) | count as u64,
            Ordering::Release,
        );
        self.shared.drain(self.work);
        // Only runs a helper has claimed are still in flight; should its thread have lost its
        // core, yielding after a while lets it have this one.
        let mut spins = 0u32;
        while self.shared.done.load(Ordering::Acquire) < count {
            if spins < SPINS {
                spins += 1;
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
    }
}

/// Runs `lead` on the calling thread with `helpers` helper tasks spawned on the current rayon
/// pool; they solve runs of the phases the leader publishes with [`Leader::phase`] by calling
/// `work(run)`. Returns when the leader is done and every helper has left.
pub(crate) fn run<W, R>(
    helpers: usize,
    work: &W,
    lead: impl FnOnce(&Leader<'_, W>) -> R + Send,
) -> R
where
    W: Fn(usize) + Sync,
    R: Send,
{
    let shared = Shared::default();
    rayon::scope(|s| {
        for _ in 0..helpers {
            let shared = &shared;
            s.spawn(move |_| shared.help(work));
        }
        let _stop = StopOnDrop(&shared);
        lead(&Leader {
            shared: &shared,
            work,
            seq: std::cell::Cell::new(0),
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every run of every phase is solved exactly once, and a phase's runs are all done when
    /// `phase` returns, whatever the number of helpers (none, fewer or more than the pool's
    /// threads).
    #[test]
    fn each_run_once_per_phase() {
        for (threads, helpers) in [(1, 0), (1, 3), (2, 1), (4, 3), (4, 7)] {
            let hits: Vec<AtomicUsize> = (0..40).map(|_| AtomicUsize::new(0)).collect();
            let work = |run: usize| {
                hits[run].fetch_add(1, Ordering::Relaxed);
            };
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                run(helpers, &work, |leader| {
                    for round in 1..=50 {
                        leader.phase(0, 25);
                        leader.phase(25, 15);
                        let counts: Vec<usize> =
                            hits.iter().map(|h| h.load(Ordering::Relaxed)).collect();
                        assert!(counts.iter().all(|&c| c == round), "{counts:?}");
                    }
                });
            });
        }
    }
}
