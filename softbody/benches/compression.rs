//! Step time against compression (the paper's Table 2: 10.08 ms with no compression, 8.40 ms
//! at 75 % of the nodes, 4.80 ms at 30 %; Bullet's plain soft body 11.09 ms).
//!
//! The paper's net: 79×54 = 4266 nodes, corners pinned, gravity, 20 iterations, dt 1/60.
//! `plain` is the plain solver with the same links the TreeCut body has at its finest cut
//! (structural + shear); `tc_100` is the TreeCut body at the finest cut; `tc_75` and `tc_30`
//! use cuts with 75 % and 30 % of the nodes, spread uniformly (uniform level-1 cut with
//! level-1 nodes refined in a scattered order until the count is reached). `tc_75_blending`
//! keeps about 25 transitions in flight, as the paper's runs did.
//! Times are the thread's CPU time (`support/cpu_time.rs`), robust to a shared machine.
//! `reconstruct tc_30/*` times a step and the reconstruction a renderer reads after it
//! (the step alone is `tc_30`).
#[path = "support/cpu_time.rs"]
mod cpu_time;

use cpu_time::ThreadTime;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use softbody::treecut::{Cut, GridSpec, Hierarchy, NodeId};
use softbody::{GridCloth, ReconstructionMode, SolverSettings, TreeCutSettings, TreeCutSoftBody};
use std::hint::black_box;

const COLS: u32 = 79;
const ROWS: u32 = 54;

fn spec() -> GridSpec {
    GridSpec::horizontal(COLS, ROWS, 0.02, 1.0)
}

fn solver() -> SolverSettings {
    SolverSettings {
        dt: 1.0 / 60.0,
        substeps: 1,
        iterations: 20,
        gravity: Vec3::new(0.0, -9.81, 0.0),
        damping: 0.1,
        // One thread: the benches measure the calling thread's CPU time.
        parallel_min_links: 0,
    }
}

fn corners() -> [u32; 4] {
    [0, COLS - 1, COLS * (ROWS - 1), COLS * ROWS - 1]
}

fn scattered(h: &Hierarchy, level: u32) -> Vec<NodeId> {
    let mut v: Vec<NodeId> = h.nodes_at_level(level).collect();
    v.sort_by_key(|p| p.raw().wrapping_mul(2654435761) >> 8);
    v
}

fn cut_with(h: &Hierarchy, fraction: f32) -> Cut {
    if fraction >= 1.0 {
        return Cut::finest(h);
    }
    let target = (fraction * h.vertex_count() as f32) as usize;
    let mut cut = Cut::uniform(h, 1);
    for p in scattered(h, 1) {
        if cut.len() >= target {
            break;
        }
        cut.refine(h, p).unwrap();
    }
    cut
}

fn tc(fraction: f32) -> TreeCutSoftBody {
    let s = spec();
    let h = Hierarchy::grid(&s).unwrap();
    let cut = cut_with(&h, fraction);
    let settings = TreeCutSettings {
        solver: solver(),
        blend_steps: 25,
        ..TreeCutSettings::default()
    };
    let mut tc = TreeCutSoftBody::new(h, cut, settings).unwrap();
    for v in corners() {
        tc.pin_vertex(v, s.position(v % COLS, v / COLS)).unwrap();
    }
    for _ in 0..30 {
        tc.step();
    }
    tc
}

/// Begins a refine or a coarse on the next node of `order` (from `*next` on, cyclically) that
/// takes one.
fn begin_next(body: &mut TreeCutSoftBody, order: &[NodeId], next: &mut usize) {
    for _ in 0..order.len() {
        let p = order[*next % order.len()];
        *next += 1;
        let ok = if body.cut().is_on_cut(p) {
            body.begin_refine(p)
        } else {
            body.begin_coarse(p)
        };
        if ok.is_ok() {
            break;
        }
    }
}

fn bench(c: &mut Criterion<ThreadTime>) {
    let s = spec();
    let g = GridCloth {
        cols: s.cols,
        rows: s.rows,
        origin: s.origin,
        u: s.u,
        v: s.v,
        vertex_mass: s.vertex_mass,
        shear: true,
        bend: false,
        material: Default::default(),
    };
    let mut plain = g.build(solver()).unwrap();
    for p in g.corners() {
        plain.set_pinned(p, true).unwrap();
    }
    c.bench_function(
        &format!(
            "plain ({} nodes, {} links)",
            plain.particle_count(),
            plain.link_count()
        ),
        |b| b.iter(|| black_box(&mut plain).step()),
    );
    for (name, fraction) in [("tc_100", 1.0f32), ("tc_75", 0.75), ("tc_30", 0.30)] {
        let mut body = tc(fraction);
        let label = format!(
            "{name} ({} nodes, {} links)",
            body.particle_count(),
            body.link_count()
        );
        c.bench_function(&label, |b| b.iter(|| black_box(&mut body).step()));
    }
    // 75 % with transitions in flight: every step begins one refine or coarse on a scattered
    // level-1 node, so with blend_steps = 25 about 25 are blending at any time.
    let mut body = tc(0.75);
    let order = scattered(body.hierarchy(), 1);
    let mut next = 0usize;
    let label = format!("tc_75_blending ({} nodes)", body.particle_count());
    c.bench_function(&label, |b| {
        b.iter(|| {
            begin_next(&mut body, &order, &mut next);
            black_box(&mut body).step();
        });
    });
    eprintln!(
        "tc_75_blending: {} transitions in flight at the end",
        body.transitions_in_flight()
    );
    after_operations(c);
    reconstruction(c);
}

/// The reconstruction a renderer pays every frame, in the default (MLS) and the smooth mode, on
/// the paper's net at 30 % of the nodes (a scattered mixed cut): `steady` re-reads a body whose
/// topology did not change (the weight table is kept; each iteration steps first),
/// `after_operation` a body that began a refine or coarse since (the table is rebuilt).
/// Throughput: finest vertices.
fn reconstruction(c: &mut Criterion<ThreadTime>) {
    let mut group = c.benchmark_group("reconstruct tc_30");
    let mut body = tc(0.30);
    let mut out = vec![Vec3::ZERO; body.hierarchy().vertex_count()];
    group.throughput(Throughput::Elements(out.len() as u64));
    let order = scattered(body.hierarchy(), 1);
    let mut next = 0usize;
    for (name, mode) in [
        ("mls", ReconstructionMode::Mls),
        ("smooth", ReconstructionMode::Smooth),
    ] {
        group.bench_function(format!("{name}/steady"), |b| {
            b.iter(|| {
                body.step();
                body.reconstruct_with(mode, black_box(&mut out)).unwrap();
            });
        });
        group.bench_function(format!("{name}/after_operation"), |b| {
            b.iter(|| {
                begin_next(&mut body, &order, &mut next);
                body.step();
                body.reconstruct_with(mode, black_box(&mut out)).unwrap();
            });
        });
    }
    group.finish();
}

/// A 75 % cut reached by operations (from the uniform level-1 cut: scattered level-1 nodes
/// refined while the body is below 75 % of the nodes and coarsened while above, three passes,
/// each transition ended at once), stepped with the particles as the operations left them
/// (`scattered`) and after a spatial renumbering (`renumbered`), beside the same cut built at
/// once (`built`), on the paper's net and on a 257×257 net (where the particles outgrow the
/// L2 cache). Times are thread CPU time (as in the `step` bench); the throughput line is CPU
/// ns per link-iteration: the target is `renumbered` within 10 % of `built`.
fn after_operations(c: &mut Criterion<ThreadTime>) {
    for (cols, rows) in [(COLS, ROWS), (257, 257)] {
        let s = GridSpec::horizontal(cols, rows, 0.02, 1.0);
        let corners = [0, cols - 1, cols * (rows - 1), cols * rows - 1];
        let settings = TreeCutSettings {
            solver: solver(),
            blend_steps: 0,
            ..TreeCutSettings::default()
        };
        let body = |cut: &dyn Fn(&Hierarchy) -> Cut| {
            let h = Hierarchy::grid(&s).unwrap();
            let c = cut(&h);
            let mut tc = TreeCutSoftBody::new(h, c, settings).unwrap();
            tc.set_auto_renumber(false);
            for &v in &corners {
                tc.pin_vertex(v, s.position(v % cols, v / cols)).unwrap();
            }
            tc
        };
        let built = body(&|h| cut_with(h, 0.75));
        let target = built.particle_count();
        let mut ops = body(&|h| Cut::uniform(h, 1));
        let order = scattered(ops.hierarchy(), 1);
        for &p in order.iter().cycle().take(order.len() * 3) {
            let below = ops.particle_count() < target;
            let begun = if ops.cut().is_on_cut(p) {
                below && ops.begin_refine(p).is_ok()
            } else {
                !below && ops.begin_coarse(p).is_ok()
            };
            if begun {
                ops.end_finished();
            }
        }
        let mut renumbered = ops.clone();
        renumbered.renumber_particles();
        let mut group = c.benchmark_group(format!(
            "tc_75_after_ops {cols}x{rows} ({} nodes, {} links)",
            ops.particle_count(),
            ops.link_count()
        ));
        for (name, mut body) in [
            ("built", built),
            ("scattered", ops),
            ("renumbered", renumbered),
        ] {
            let it = u64::from(body.settings().solver.iterations * body.settings().solver.substeps);
            group.throughput(Throughput::Elements(body.link_count() as u64 * it));
            group.bench_function(name, |b| b.iter(|| black_box(&mut body).step()));
        }
        group.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(ThreadTime);
    targets = bench
}
criterion_main!(benches);
