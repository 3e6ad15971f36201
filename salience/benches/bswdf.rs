//! BSWDF throughput on a 100k-node cloth (a 317 × 317 grid, 8 neighbours per interior node):
//! the evaluation alone (target under 1 ms on one core), with normals and a light, and the
//! one-off validation of the neighbour table. With `--features rayon`, also the parallel entry.
use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use salience::{
    BswdfJob, BswdfParams, Light, NeighbourLists, Neighbours, Nodes, ObjectMotion, Sidedness, View,
    evaluate,
};

const SIDE: u32 = 317; // 100 489 nodes

struct Cloth {
    positions: Vec<Vec3>,
    velocities: Vec<Vec3>,
    normals: Vec<Vec3>,
    lists: NeighbourLists,
}

fn cloth() -> Cloth {
    let h = 1.0 / SIDE as f32;
    let mut positions = Vec::new();
    let mut velocities = Vec::new();
    let mut normals = Vec::new();
    for k in 0..SIDE * SIDE {
        let (x, y) = ((k % SIDE) as f32 * h - 0.5, (k / SIDE) as f32 * h - 0.5);
        let z = 0.05 * (8.0 * x).sin() * (6.0 * y).cos();
        positions.push(Vec3::new(x, y, z));
        velocities.push(Vec3::new(0.3, 0.0, (5.0 * x + 3.0 * y).sin()));
        normals.push(Vec3::new(-0.4 * (8.0 * x).cos(), 0.3 * (6.0 * y).sin(), 1.0).normalize());
    }
    let mut edges = Vec::new();
    for y in 0..SIDE {
        for x in 0..SIDE {
            let k = y * SIDE + x;
            if x + 1 < SIDE {
                edges.push([k, k + 1]);
            }
            if y + 1 < SIDE {
                edges.push([k, k + SIDE]);
                if x + 1 < SIDE {
                    edges.push([k, k + SIDE + 1]);
                }
                if x > 0 {
                    edges.push([k, k + SIDE - 1]);
                }
            }
        }
    }
    let lists = NeighbourLists::from_undirected_edges(positions.len(), &edges).unwrap();
    Cloth {
        positions,
        velocities,
        normals,
        lists,
    }
}

fn bench(c: &mut Criterion) {
    let cloth = cloth();
    let n = cloth.positions.len();
    let camera = View::look_at(
        Vec3::new(0.3, 0.4, 1.5),
        Vec3::ZERO,
        Vec3::Y,
        0.9,
        1920,
        1080,
    )
    .unwrap();
    let params = BswdfParams {
        sides: Sidedness::TwoSided,
        ..BswdfParams::default()
    };
    let sun = Light::directional(Vec3::new(0.2, 1.0, 0.8), 0.3, 0.7);
    let object = ObjectMotion::mean_of(&cloth.positions, &cloth.velocities).unwrap();
    let neighbours = cloth.lists.as_neighbours();
    let mut out = vec![0.0f32; n];

    let mut group = c.benchmark_group("bswdf_100k");
    group.throughput(Throughput::Elements(n as u64));
    let cases: [(&str, Option<&Light>, bool); 3] = [
        ("motion_only", None, false),
        ("normals", None, true),
        ("normals_light", Some(&sun), true),
    ];
    for (name, light, with_normals) in cases {
        let view = camera.with_light(light.copied()).unwrap();
        let job = BswdfJob {
            view: &view,
            object,
            params: &params,
            nodes: Nodes {
                positions: &cloth.positions,
                velocities: &cloth.velocities,
                normals: with_normals.then_some(&cloth.normals[..]),
            },
            neighbours,
        };
        group.bench_function(name, |b| {
            b.iter(|| {
                evaluate(black_box(&job), &mut out).unwrap();
                black_box(&out);
            });
        });
    }
    #[cfg(feature = "rayon")]
    {
        let view = camera.with_light(Some(sun)).unwrap();
        let job = BswdfJob {
            view: &view,
            object,
            params: &params,
            nodes: Nodes {
                positions: &cloth.positions,
                velocities: &cloth.velocities,
                normals: Some(&cloth.normals),
            },
            neighbours,
        };
        group.bench_function("normals_light_parallel", |b| {
            b.iter(|| {
                salience::evaluate_parallel(black_box(&job), &mut out).unwrap();
                black_box(&out);
            });
        });
    }
    group.bench_function("validate_neighbours", |b| {
        b.iter(|| {
            Neighbours::new(
                black_box(neighbours.offsets()),
                black_box(neighbours.indices()),
                n,
            )
            .unwrap()
        });
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
