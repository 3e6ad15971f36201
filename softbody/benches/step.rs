//! One solver step of Bullet-style cloths (the issue's `step` benchmark).
//!
//! * `bullet65` / `bullet129`: 65×65 and 129×129 grids built like Bullet's cloth from a
//!   triangle mesh (triangle edges + distance-2 bend links), 20 iterations, dt 1/60, four
//!   corners pinned. Bullet itself on the same cloths: `python3 bench/peers/bullet_cloth.py`.
//! * `paper`: the seed paper's net, 4266 nodes (a 79×54 grid) with structural links only.
//!
//! Each runs once per kernel path this CPU supports (`…/avx512`, `…/avx2`, `…/lanes4`,
//! `…/scalar`); the throughput is in link-iterations, so `1 / (elements per second)` is the
//! cost of one link-iteration. Quick run:
//! `cargo bench -p softbody --bench step -- --warm-up-time 1 --measurement-time 2`.
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use softbody::{GridCloth, KernelPath, SoftBody, SolverSettings};
use std::hint::black_box;

fn settings() -> SolverSettings {
    SolverSettings {
        dt: 1.0 / 60.0,
        substeps: 1,
        iterations: 20,
        gravity: Vec3::new(0.0, -9.81, 0.0),
        damping: 0.0,
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
fn per_path(c: &mut Criterion, name: &str, body: &SoftBody) {
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

fn bench(c: &mut Criterion) {
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

criterion_group!(benches, bench);
criterion_main!(benches);
