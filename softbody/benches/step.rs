//! One solver step of Bullet-style cloths (the issue's `step` benchmark).
//!
//! * `bullet65` / `bullet129`: 65×65 and 129×129 grids built like Bullet's cloth from a
//!   triangle mesh (triangle edges + distance-2 bend links), 20 iterations, dt 1/60, four
//!   corners pinned. Peer: Bullet 5.1 ms and 42 ms per step on this kind of machine.
//! * `paper`: the seed paper's net, 4266 nodes (a 79×54 grid) with structural links only.
use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use softbody::{GridCloth, SoftBody, SolverSettings};
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

fn bench(c: &mut Criterion) {
    for n in [65u32, 129] {
        let g = grid(n, n);
        let mut body = pinned(g.build_bullet(settings()).unwrap(), &g);
        let name = format!("bullet{n} ({} links)", body.link_count());
        c.bench_function(&name, |b| b.iter(|| black_box(&mut body).step()));
    }
    let mut g = grid(79, 54);
    g.shear = false;
    let mut body = pinned(g.build(settings()).unwrap(), &g);
    let name = format!(
        "paper ({} nodes, {} links)",
        body.particle_count(),
        body.link_count()
    );
    c.bench_function(&name, |b| b.iter(|| black_box(&mut body).step()));
}

criterion_group!(benches, bench);
criterion_main!(benches);
