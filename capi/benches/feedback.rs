//! The closed loop's costs on the paper's 65×65 swinging net: one step of the full-resolution
//! cloth, one step of the adaptive cloth at 75% and 30% (evaluation amortised over its
//! interval), and one feedback evaluation on its own (salience, normals, evaluator, operations),
//! by node budget and under a 1 px on-screen error bound; and one feedback interval (five steps,
//! one of them evaluating) under the bound with the evaluation before the solver and overlapped
//! with it (`FeedbackSettings::overlap_step`, on the rayon pool).

use criterion::{Criterion, criterion_group, criterion_main};
use slod::cloth::{AdaptiveCloth, ClothBudget, FeedbackSettings};
use slod_experiments::net::NetConfig;
use softbody::TreeCutSettings;

fn cloth(config: &NetConfig, budget: Option<ClothBudget>) -> AdaptiveCloth {
    cloth_with(config, budget, false)
}

fn cloth_with(config: &NetConfig, budget: Option<ClothBudget>, overlap: bool) -> AdaptiveCloth {
    let spec = config.grid();
    let n = config.size;
    let mut c = AdaptiveCloth::grid(&spec, 0, TreeCutSettings::default()).unwrap();
    for (i, j) in [(0, 0), (n - 1, 0), (0, n - 1), (n - 1, n - 1)] {
        c.body_mut()
            .pin_vertex(spec.vertex(i, j), spec.position(i, j))
            .unwrap();
    }
    if let Some(budget) = budget {
        c.set_feedback(Some(FeedbackSettings {
            budget,
            overlap_step: overlap,
            parallel: overlap,
            ..config.feedback
        }))
        .unwrap();
    }
    // Into the swing, with the cut adapted.
    for _ in 0..240 {
        c.step(&config.view).unwrap();
    }
    c
}

fn bench(c: &mut Criterion) {
    let config = NetConfig::paper().unwrap();
    let mut g = c.benchmark_group("net65");
    for (name, compression) in [
        ("full", None),
        ("feedback75", Some(0.75)),
        ("feedback30", Some(0.3)),
    ] {
        let mut cl = cloth(&config, compression.map(ClothBudget::Compression));
        g.bench_function(format!("step/{name}"), |b| {
            b.iter(|| cl.step(&config.view).unwrap());
        });
    }
    for compression in [1.0, 0.3] {
        let mut cl = cloth(&config, Some(ClothBudget::Compression(compression)));
        g.bench_function(format!("evaluate/{}", (compression * 100.0) as u32), |b| {
            b.iter(|| cl.evaluate(&config.view).unwrap());
        });
    }
    // The error-bound mode measures each node's on-screen deviation as well.
    let mut cl = cloth(&config, Some(ClothBudget::MaxErrorPx(1.0)));
    g.bench_function("evaluate/error1px", |b| {
        b.iter(|| cl.evaluate(&config.view).unwrap());
    });
    for (name, overlap) in [("before", false), ("overlapped", true)] {
        let mut cl = cloth_with(&config, Some(ClothBudget::MaxErrorPx(1.0)), overlap);
        g.bench_function(format!("interval/error1px/{name}"), |b| {
            b.iter(|| {
                for _ in 0..config.feedback.interval {
                    cl.step(&config.view).unwrap();
                }
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
