//! Keeping a pool's workers awake across the short gaps of a frame.
//!
//! A rayon worker that finds no work spins for some microseconds and then sleeps on a futex;
//! the next job wakes it. On a virtual machine waking a sleeping thread whose virtual CPU went
//! idle waits for the hypervisor: measured on this project's 2-core VM (a thread woken through
//! a condition variable after 0.2–3 ms asleep: `cargo run --release -p slod-experiments
//! --example wake_latency`), 20–78 µs at the median but **0.4–2.6 ms at the 99th percentile
//! and up to 3.8 ms** (runs on different days) — most of a 4 ms frame. A world frame wakes the
//! pool at least twice (the crowd phase, the cloth phase), and on the street scene one worker
//! started the cloth phase 1.5–4.5 ms late in about one frame in eight, the frame then ran on
//! one thread for that long, and only 16–19% of frames stayed within ±10% of a 4 ms target
//! (29–37% with a 1 ms spin, 52–73% with 10 ms, three interleaved runs each). Engines' job
//! systems spin briefly before sleeping for the same reason.
//!
//! [`KeepWarm`] runs spinning jobs on a pool until the next phase begins or a time limit
//! passes: the frame budget arms every worker after a phase (the calling thread waits while a
//! phase runs) and all but one after the frame (the host's thread needs a core; spinning all
//! of them there measured worse, 50% against 61–77% within ±10%). The spin costs a core for at
//! most that limit per gap; between phases the gap is microseconds, after a frame it is the
//! host's own time between world steps.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Spinning jobs on a pool, released together (see the module docs).
#[derive(Debug, Default)]
pub(crate) struct KeepWarm {
    /// Bumped to release the spinners of the last [`KeepWarm::arm`].
    epoch: Arc<AtomicU64>,
}

impl KeepWarm {
    /// Releases any spinners now (the next phase is about to begin, or the pool goes).
    pub(crate) fn release(&self) {
        self.epoch.fetch_add(1, Ordering::AcqRel);
    }

    /// Starts `workers` jobs on `pool` (`None`: the current rayon pool) that each spin until
    /// [`KeepWarm::release`] or for `limit`, whichever comes first. Nothing for a zero limit or
    /// no workers.
    pub(crate) fn arm(&self, pool: Option<&rayon::ThreadPool>, workers: usize, limit: Duration) {
        if limit.is_zero() || workers == 0 {
            return;
        }
        let epoch = self.epoch.fetch_add(1, Ordering::AcqRel) + 1;
        for _ in 0..workers {
            let flag = Arc::clone(&self.epoch);
            let spin = move || {
                let until = Instant::now() + limit;
                'spin: loop {
                    // The clock is read once per 64 checks of the flag (a read costs about
                    // as much as 20 of them).
                    for _ in 0..64 {
                        if flag.load(Ordering::Acquire) != epoch {
                            break 'spin;
                        }
                        std::hint::spin_loop();
                    }
                    if Instant::now() >= until {
                        break;
                    }
                }
            };
            match pool {
                Some(p) => p.spawn(spin),
                None => rayon::spawn(spin),
            }
        }
    }
}

impl Drop for KeepWarm {
    fn drop(&mut self) {
        self.release();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether a job that needs one worker of `pool` finishes within `limit` (a spinner that
    /// never ended would hold every worker and the job would never start).
    fn runs_within(pool: &Arc<rayon::ThreadPool>, limit: Duration) -> bool {
        let (tx, rx) = std::sync::mpsc::channel();
        let p = Arc::clone(pool);
        std::thread::spawn(move || {
            let _ = tx.send(p.install(|| 7));
        });
        rx.recv_timeout(limit) == Ok(7)
    }

    #[test]
    fn spinners_end_on_release_or_at_their_limit() {
        let pool = Arc::new(
            rayon::ThreadPoolBuilder::new()
                .num_threads(2)
                .build()
                .unwrap(),
        );
        let warm = KeepWarm::default();
        // Released: the pool is free long before the ten-minute limit.
        warm.arm(Some(&pool), 2, Duration::from_secs(600));
        warm.release();
        assert!(runs_within(&pool, Duration::from_secs(60)));
        // Not released: free once the 20 ms limit has passed.
        warm.arm(Some(&pool), 2, Duration::from_millis(20));
        assert!(runs_within(&pool, Duration::from_secs(60)));
    }
}
