//! One solver step of Bullet-style cloths (the issue's `step` benchmark).
//!
//! * `bullet65` / `bullet129`: 65×65 and 129×129 grids built like Bullet's cloth from a
//!   triangle mesh (triangle edges + distance-2 bend links), 20 iterations, dt 1/60, four
//!   corners pinned. Bullet itself on the same cloths: `python3 bench/peers/bullet_cloth.py`.
//! * `paper`: the seed paper's net, 4266 nodes (a 79×54 grid) with structural links only.
//!
//! Each runs once per kernel path this CPU supports (`…/avx512`, `…/avx2`, `…/lanes4`,
//! `…/scalar`). Times are the thread's CPU time (see `support/cpu_time.rs`: on a shared machine wall
//! time counts waiting for a core), and the throughput line is CPU nanoseconds per
//! link-iteration. Quick run:
//! `cargo bench -p softbody --bench step -- --warm-up-time 1 --measurement-time 2`.
//!
//! `threads/…`: the same cloths (and `bullet257`; `bullet129 32x1` and `bullet257 32x1` at the
//! default 32 substeps × 1 iteration) on a rayon pool of 1 and of 2 threads with the
//! default `SolverSettings::parallel_min_links`, in *wall* time (CPU time would count one
//! thread only); the throughput line is wall nanoseconds per link-iteration. Run
//! `cargo bench -p softbody --bench step -- threads --warm-up-time 1 --measurement-time 3` and
//! compare `…/1` with `…/2` of the same run (on a shared machine only the ratio means much).
//! `…/2 bodies on 2` steps two independent copies side by side on the 2-thread pool: its
//! throughput against `…/1` is the most two threads can give in that run window.
#[path = "support/cpu_time.rs"]
mod cpu_time;

use cpu_time::ThreadTime;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use softbody::{GridCloth, KernelPath, SoftBody, SolverSettings};
use std::hint::black_box;

/// One thread: the per-path benches measure the calling thread's CPU time, which would miss
/// the work of other threads.
fn settings() -> SolverSettings {
    SolverSettings {
        dt: 1.0 / 60.0,
        substeps: 1,
        iterations: 20,
        gravity: Vec3::new(0.0, -9.81, 0.0),
        damping: 0.0,
        parallel_min_links: 0,
    }
}

/// [`settings`] with the default parallel rule.
fn threaded() -> SolverSettings {
    SolverSettings {
        parallel_min_links: SolverSettings::DEFAULT_PARALLEL_MIN_LINKS,
        ..settings()
    }
}

fn grid(cols: u32, rows: u32) -> GridCloth {
    let mut g = GridCloth::square(cols, 1.0 / (cols - 1) as f32, 1.0 / (cols * rows) as f32);
    g.rows = rows;
    g
}

fn pinned(mut body: SoftBody, g: &GridCloth) -> SoftBody {
    for c in g.corners() {
        body.set_pinned(c, true).unwrap();
    }
    // Let it sag a little so the links are not all at rest length.
    for _ in 0..30 {
        body.step();
    }
    body
}

/// Benchmarks one body on every supported kernel path (widest first).
fn per_path(c: &mut Criterion<ThreadTime>, name: &str, body: &SoftBody) {
    let mut group = c.benchmark_group(name);
    let iterations = u64::from(body.settings().iterations * body.settings().substeps);
    group.throughput(Throughput::Elements(body.link_count() as u64 * iterations));
    let mut paths: Vec<KernelPath> = KernelPath::supported().collect();
    paths.reverse();
    for path in paths {
        let mut body = body.clone();
        body.set_kernel_path(path).unwrap();
        group.bench_function(path.name(), |b| b.iter(|| black_box(&mut body).step()));
    }
    group.finish();
}

fn bench(c: &mut Criterion<ThreadTime>) {
    for n in [65u32, 129] {
        let g = grid(n, n);
        let body = pinned(g.build_bullet(settings()).unwrap(), &g);
        per_path(
            c,
            &format!("bullet{n} ({} links)", body.link_count()),
            &body,
        );
    }
    let mut g = grid(79, 54);
    g.shear = false;
    let body = pinned(g.build(settings()).unwrap(), &g);
    let name = format!(
        "paper ({} nodes, {} links)",
        body.particle_count(),
        body.link_count()
    );
    per_path(c, &name, &body);
}

/// The default solver settings (32 substeps × 1 iteration) without damping, as [`settings`].
fn defaults() -> SolverSettings {
    SolverSettings {
        dt: 1.0 / 60.0,
        gravity: Vec3::new(0.0, -9.81, 0.0),
        damping: 0.0,
        ..SolverSettings::default()
    }
}

/// The bodies of the thread comparison: Bullet cloths at 65², 129² and 257² (1 substep × 20
/// iterations), at 129² and 257² also with the default 32 substeps × 1 iteration
/// (`bullet129 32x1 …`), and the paper's net.
fn thread_bodies() -> Vec<(String, SoftBody)> {
    let mut bodies = Vec::new();
    for n in [65u32, 129, 257] {
        let g = grid(n, n);
        let body = pinned(g.build_bullet(threaded()).unwrap(), &g);
        bodies.push((format!("bullet{n} ({} links)", body.link_count()), body));
    }
    for n in [129u32, 257] {
        let g = grid(n, n);
        let body = pinned(g.build_bullet(defaults()).unwrap(), &g);
        let name = format!("bullet{n} 32x1 ({} links)", body.link_count());
        bodies.push((name, body));
    }
    let mut g = grid(79, 54);
    g.shear = false;
    let body = pinned(g.build(threaded()).unwrap(), &g);
    bodies.push((format!("paper ({} links)", body.link_count()), body));
    bodies
}

/// One step on a pool of 1 and of 2 threads, wall time (the default parallel rule decides
/// whether a body's batches are split at all).
fn bench_threads(c: &mut Criterion) {
    let pools: Vec<(usize, rayon::ThreadPool)> = [1, 2]
        .into_iter()
        .map(|t| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(t).build();
            (t, pool.unwrap())
        })
        .collect();
    for (name, body) in thread_bodies() {
        let mut group = c.benchmark_group(format!("threads/{name}"));
        let iterations = u64::from(body.settings().iterations * body.settings().substeps);
        group.throughput(Throughput::Elements(body.link_count() as u64 * iterations));
        let links = body.link_count() as u64 * iterations;
        for (threads, pool) in &pools {
            let mut body = body.clone();
            group.bench_function(threads.to_string(), |b| {
                pool.install(|| b.iter(|| black_box(&mut body).step()));
            });
        }
        // The ceiling of the moment: two bodies, each on one thread, stepped side by side on
        // the 2-thread pool (nothing shared, no synchronisation). On a machine whose cores are
        // partly taken by other jobs this is what 2 threads can give at best.
        group.throughput(Throughput::Elements(2 * links));
        let mut pair = [body.clone(), body.clone()].map(|mut b| {
            let mut s = *b.settings();
            s.parallel_min_links = 0;
            b.set_settings(s).unwrap();
            b
        });
        group.bench_function("2 bodies on 2", |b| {
            pools[1].1.install(|| {
                b.iter(|| {
                    let [x, y] = &mut pair;
                    rayon::join(|| x.step(), || y.step())
                });
            });
        });
        group.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(ThreadTime);
    targets = bench
}
criterion_group!(threads, bench_threads);
criterion_main!(benches, threads);
