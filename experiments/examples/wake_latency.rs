//! How long a sleeping thread takes to wake on this machine: the figure behind
//! `WorldBudget::spin_wait_ms` (`slod::world`).
//!
//! A helper thread waits on a condition variable; the main thread sleeps for a gap (so the
//! helper's core may go idle, as a world's workers do between frames), signals it, and then
//! works for 3 ms (as a frame does). The helper stamps when it woke. Printed: percentiles of
//! signal-to-wake latency for a few gaps. On a virtual machine a thread whose virtual CPU went
//! idle waits for the hypervisor to run it again; on this project's 2-core VM the 99th
//! percentile was 0.4–2.6 ms (runs on different days) against a 20–78 µs median.
//!
//! `cargo run --release -p slod-experiments --example wake_latency [-- ROUNDS]`

use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// Wake latencies, µs, of `rounds` signals each sent `gap` after the last round's work.
fn latencies(gap: Duration, rounds: usize) -> Vec<f64> {
    // (round signalled, when it was signalled)
    let state = Arc::new((Mutex::new((0usize, Instant::now())), Condvar::new()));
    let woke = Arc::new(Mutex::new(Vec::with_capacity(rounds)));
    let helper = {
        let (state, woke) = (Arc::clone(&state), Arc::clone(&woke));
        std::thread::spawn(move || {
            for k in 1..=rounds {
                let (lock, cv) = &*state;
                let mut s = lock.lock().unwrap_or_else(|e| e.into_inner());
                while s.0 < k {
                    s = cv.wait(s).unwrap_or_else(|e| e.into_inner());
                }
                let sent = s.1;
                drop(s);
                let us = sent.elapsed().as_secs_f64() * 1e6;
                woke.lock().unwrap_or_else(|e| e.into_inner()).push(us);
            }
        })
    };
    for k in 1..=rounds {
        std::thread::sleep(gap);
        {
            let (lock, cv) = &*state;
            let mut s = lock.lock().unwrap_or_else(|e| e.into_inner());
            *s = (k, Instant::now());
            cv.notify_one();
        }
        // The frame's own work.
        let t = Instant::now();
        let mut x = 1.0f64;
        while t.elapsed() < Duration::from_millis(3) {
            x = std::hint::black_box(x * 1.000_001);
        }
    }
    helper.join().expect("the helper thread");
    let mut v = std::mem::take(&mut *woke.lock().unwrap_or_else(|e| e.into_inner()));
    v.sort_by(f64::total_cmp);
    v
}

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(300)
        .max(10);
    println!("wake latency of a sleeping thread, {rounds} rounds per gap (µs)");
    println!(
        "{:>8} {:>8} {:>8} {:>8} {:>8}",
        "gap ms", "p50", "p90", "p99", "max"
    );
    for gap_ms in [0.2, 1.0, 3.0] {
        let v = latencies(Duration::from_secs_f64(gap_ms * 1e-3), rounds);
        let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
        println!(
            "{gap_ms:>8.1} {:>8.0} {:>8.0} {:>8.0} {:>8.0}",
            q(0.5),
            q(0.9),
            q(0.99),
            v[v.len() - 1]
        );
    }
}
