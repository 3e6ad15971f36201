//! One refine and one coarse on cuts of about 5k, 50k and 500k active nodes (constant time).
use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use treecut::{Cut, GridSpec, Hierarchy, NodeId};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("treecut_ops");
    for side in [71u32, 224, 708] {
        let h = Hierarchy::grid(&GridSpec::horizontal(side, side, 0.01, 1.0)).unwrap();
        let mut cut = Cut::finest(&h);
        // Node in the middle of the level-1 nodes: its children are all on the finest cut.
        let level1 = h.nodes_at_level(1);
        let parent = NodeId::from_raw(level1.start + level1.len() as u32 / 2);
        let n = cut.len();
        g.bench_with_input(BenchmarkId::new("coarse_then_refine", n), &n, |b, _| {
            b.iter(|| {
                cut.coarse(&h, black_box(parent)).unwrap();
                cut.refine(&h, black_box(parent)).unwrap();
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
