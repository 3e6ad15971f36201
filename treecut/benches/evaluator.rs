//! One evaluation on a 5k-node cut where every priority changed since the last call.
use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use treecut::{Budget, Cut, Evaluator, EvaluatorSettings, GridSpec, Hierarchy};

fn bench(c: &mut Criterion) {
    let h = Hierarchy::grid(&GridSpec::horizontal(129, 129, 0.01, 1.0)).unwrap();
    // Level 1 of a 129x129 grid: 64x64 = 4096 nodes, plus some refined to reach about 5k.
    let mut cut = Cut::uniform(&h, 1);
    let some: Vec<_> = cut.active().iter().copied().step_by(4).take(300).collect();
    for n in some {
        cut.refine(&h, n).unwrap();
    }
    let n = cut.len();
    let mut ev = Evaluator::new(EvaluatorSettings {
        hysteresis: 0.02,
        max_ops: 64,
        ..Default::default()
    });
    // Sixteen unrelated priority fields, cycled so every call sees all priorities changed.
    let fields: Vec<Vec<f32>> = (0..16u64)
        .map(|f| {
            (0..h.len() as u64)
                .map(|i| ((i * 2654435761 + f * 40503) % 10007) as f32 / 10007.0)
                .collect()
        })
        .collect();
    let mut frame = 0usize;
    c.bench_function(&format!("evaluate_{n}_nodes_all_changed"), |b| {
        b.iter(|| {
            frame += 1;
            let prio = &fields[frame % fields.len()];
            let ops = ev
                .evaluate(&h, &cut, black_box(prio), None, Budget::Nodes(n))
                .unwrap();
            black_box(ops.len())
        });
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
