//! A leader thread and spinning helpers that share out *phases* of numbered runs of work: how
//! one body's colour batches are split across threads for a fraction of a microsecond per batch.
//! A threaded [`crate::SoftBody::step`] holds one session for all its substeps: its phases are
//! the split batches of every sweep and the per-particle loops of every substep (prediction
//! with the multiplier reset, velocity update), with the sequential parts between them.
//!
//! # Why not `rayon::join` per batch
//! A large cloth runs `substeps × iterations × colours` batches per step (360 at 20 iterations
//! and 18 colours), each a few to a few tens of microseconds of work. Forked with `rayon::join`
//! per batch, the caller solved 88% of the runs itself (measured at 257², 2 threads): between
//! two joins rayon's idle worker goes to sleep, and waking it takes about as long as a batch.
//! Here the helpers stay awake (spinning, then yielding) for the whole team session and pick
//! up each phase as soon as the leader publishes it; with work this small a phase then costs
//! about 0.2–0.7 µs more than its share of the work (33² cloth with every batch split, quietest
//! samples on the loaded 2-core VM this was written on).
//!
//! # Affinity
//! Member `k` of `T` (the leader is member 0) first takes the runs `k·count/T .. (k+1)·count/T`
//! of every phase, and only then any run still unclaimed. The runs of a colour batch are
//! contiguous pieces of it, and the links of every batch are ordered alike (by particle, as the
//! builders and renumbering add them), so a member keeps solving the same region of the cloth
//! and its particles can stay in its core's cache instead of moving between cores every batch,
//! as they would if runs went to whoever came first.
//!
//! # Protocol
//! One atomic word names the current phase: a sequence number, its first run and how many runs
//! it has. A run is claimed by raising its flag to the phase's sequence number (`fetch_max`: a
//! member still looking at an older phase cannot claim a run of a newer one), so each run is
//! solved exactly once, by whoever gets there first; [`Leader::phase`] returns when every run of
//! the phase has been counted done. The leader never waits for a helper that has not claimed
//! anything: if no helper ever starts (a busy pool, a pool of one), the leader solves every run
//! itself, so a session cannot deadlock, whatever the pool is doing. Helpers only spin while
//! their leader is still working and leave when it ends the session (also when it panics).

use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

/// Most runs one phase can have (64 colour batches of these fit the 16-bit `start`).
pub(crate) const MAX_RUNS: usize = 1 << 10;
/// Busy-wait rounds before a waiting member starts yielding its core.
const SPINS: u32 = 1 << 14;

/// A value alone in its cache lines (128 bytes: two lines, for CPUs that fetch pairs), so that
/// members writing different values do not take the line from each other.
#[derive(Debug, Default)]
#[repr(align(128))]
struct Padded<T>(T);

/// The shared state of one team session. Everything a member writes often is its own line: the
/// flag of each run and each member's done count; per phase, a member that solves only its own
/// runs moves about two cache lines between cores (the phase word and its done count).
#[derive(Debug)]
struct Shared {
    /// `seq << 32 | start << 16 | count` of the current phase (`seq` 0: none yet).
    phase: Padded<AtomicU64>,
    stop: Padded<AtomicBool>,
    /// Per run of a phase: the sequence number of the last phase that claimed it.
    claimed: Vec<Padded<AtomicU64>>,
    /// Per member: how many runs it has solved in this session.
    done: Vec<Padded<AtomicUsize>>,
}

impl Shared {
    /// Solves the runs of the phase `word` that member `k` can still claim, its own first, and
    /// publishes its new total (`solved`, kept by the member).
    fn drain(&self, word: u64, k: usize, solved: &mut usize, work: &impl Fn(usize)) {
        let seq = word >> 32;
        let (start, count) = (((word >> 16) & 0xFFFF) as usize, (word & 0xFFFF) as usize);
        let own = k * count / self.done.len();
        let before = *solved;
        for i in (own..count).chain(0..own) {
            let flag = &self.claimed[i].0;
            // A plain read first: a run someone else already has costs no write to its line.
            if flag.load(Ordering::Relaxed) < seq && flag.fetch_max(seq, Ordering::AcqRel) < seq {
                work(start + i);
                *solved += 1;
            }
        }
        if *solved != before {
            self.done[k].0.store(*solved, Ordering::Release);
        }
    }

    /// Runs solved so far by all members.
    fn done(&self) -> usize {
        self.done.iter().map(|d| d.0.load(Ordering::Acquire)).sum()
    }

    /// Helper `k`: solves its share of whatever is published until the session ends.
    fn help(&self, k: usize, work: &impl Fn(usize)) {
        let (mut seen, mut idle, mut solved) = (0u64, 0u32, 0usize);
        loop {
            let word = self.phase.0.load(Ordering::Acquire);
            if word >> 32 != seen {
                seen = word >> 32;
                self.drain(word, k, &mut solved, work);
                idle = 0;
            } else if self.stop.0.load(Ordering::Acquire) {
                return;
            } else {
                idle = wait(idle);
            }
        }
    }
}

/// One round of waiting: spin a while, then yield the core; returns the new round count.
fn wait(idle: u32) -> u32 {
    if idle < SPINS {
        std::hint::spin_loop();
        idle + 1
    } else {
        std::thread::yield_now();
        idle
    }
}

/// Sets `stop` when the leader's part ends, normally or by a panic, so helpers never outlive it.
struct StopOnDrop<'a>(&'a Shared);

impl Drop for StopOnDrop<'_> {
    fn drop(&mut self) {
        self.0.stop.0.store(true, Ordering::Release);
    }
}

/// The leader's handle in a session (see [`run`]).
pub(crate) struct Leader<'a, W> {
    shared: &'a Shared,
    work: &'a W,
    seq: Cell<u64>,
    /// Runs published so far, and how many of them the leader solved.
    published: Cell<usize>,
    solved: Cell<usize>,
}

impl<W: Fn(usize) + Sync> Leader<'_, W> {
    /// Solves runs `start..start + count` (`count <= MAX_RUNS`, `start < 65536`), sharing them
    /// with the helpers, and returns when all are done: everything the runs wrote is then
    /// visible to the caller, and no helper touches anything until the next phase.
    pub(crate) fn phase(&self, start: usize, count: usize) {
        assert!(count <= self.shared.claimed.len() && start < 1 << 16);
        let seq = self.seq.get() + 1;
        self.seq.set(seq);
        self.published.set(self.published.get() + count);
        let word = (seq << 32) | ((start as u64) << 16) | count as u64;
        self.shared.phase.0.store(word, Ordering::Release);
        let mut solved = self.solved.get();
        self.shared.drain(word, 0, &mut solved, self.work);
        self.solved.set(solved);
        // Only runs a helper has claimed are still in flight; should its thread have lost its
        // core, yielding after a while lets it have this one.
        let mut idle = 0;
        while self.shared.done() < self.published.get() {
            idle = wait(idle);
        }
    }
}

/// Runs `lead` on the calling thread with `helpers` helper tasks spawned on the current rayon
/// pool; together they solve the phases of at most `max_runs` runs that the leader publishes
/// with [`Leader::phase`], calling `work(run)` once per run. Returns when the leader is done and
/// every helper has left.
pub(crate) fn run<W, R>(
    helpers: usize,
    max_runs: usize,
    work: &W,
    lead: impl FnOnce(&Leader<'_, W>) -> R + Send,
) -> R
where
    W: Fn(usize) + Sync,
    R: Send,
{
    let shared = Shared {
        phase: Padded(AtomicU64::new(0)),
        stop: Padded(AtomicBool::new(false)),
        claimed: (0..max_runs.min(MAX_RUNS))
            .map(|_| Padded(AtomicU64::new(0)))
            .collect(),
        done: (0..=helpers).map(|_| Padded(AtomicUsize::new(0))).collect(),
    };
    rayon::scope(|s| {
        for k in 1..=helpers {
            let shared = &shared;
            s.spawn(move |_| shared.help(k, work));
        }
        let _stop = StopOnDrop(&shared);
        lead(&Leader {
            shared: &shared,
            work,
            seq: Cell::new(0),
            published: Cell::new(0),
            solved: Cell::new(0),
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
                run(helpers, 25, &work, |leader| {
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
