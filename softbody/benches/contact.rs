//! What contact costs: one step of a 65² TreeCut cloth (default settings: 32 substeps) resting
//! in full contact, against the same cloth without colliders.
//!
//! * `free`: no colliders (hanging from two corners).
//! * `draped`: the cloth lying over a sphere and a ground plane (every node in contact).
//! * `draped+8 far`: the same plus eight capsules away from the cloth (the broad phase's cost).
//! * `cape10`: the cloth hanging against ten capsules and spheres (a body), most nodes touching.
//! * `windy`: the free cloth in gusty wind (normals, gusts and the wind force every step; the
//!   same colliders as `free`, none).
use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Quat, Vec3};
use softbody::treecut::{Cut, GridSpec, Hierarchy};
use softbody::{
    ColliderDesc, Shape, Transform, TreeCutSettings, TreeCutSoftBody, Wind, WindField,
    grid_triangles,
};
use std::hint::black_box;

fn cloth(spec: &GridSpec) -> TreeCutSoftBody {
    let h = Hierarchy::grid(spec).unwrap();
    let cut = Cut::finest(&h);
    TreeCutSoftBody::new(h, cut, TreeCutSettings::default()).unwrap()
}

fn add(body: &mut TreeCutSoftBody, shape: Shape, transform: Transform) {
    body.colliders_mut()
        .add(ColliderDesc {
            shape,
            transform,
            ..ColliderDesc::default()
        })
        .unwrap();
}

fn settle(body: &mut TreeCutSoftBody, steps: u32) {
    for _ in 0..steps {
        body.step();
    }
}

fn bench(c: &mut Criterion) {
    let mut flat = GridSpec::horizontal(65, 65, 2.0 / 64.0, 0.5);
    flat.origin.y = 1.1;
    let mut free = cloth(&flat);
    free.pin_vertex(0, flat.position(0, 0)).unwrap();
    free.pin_vertex(64, flat.position(64, 0)).unwrap();
    settle(&mut free, 60);
    let mut windy = free.clone();
    c.bench_function("free (4225 nodes, no colliders)", |b| {
        b.iter(|| black_box(&mut free).step());
    });
    windy.set_surface(&grid_triangles(65, 65)).unwrap();
    let wind = WindField {
        velocity: Vec3::new(1.0, 0.0, 6.0),
        ..WindField::default()
    };
    windy.set_wind(Some(Wind::new(wind).unwrap())).unwrap();
    settle(&mut windy, 30);
    c.bench_function("windy (4225 nodes, gusty wind)", |b| {
        b.iter(|| black_box(&mut windy).step());
    });

    let mut draped = cloth(&flat);
    add(
        &mut draped,
        Shape::Sphere { radius: 0.5 },
        Transform::from_position(Vec3::new(0.0, 0.5, 0.0)),
    );
    add(
        &mut draped,
        Shape::Plane,
        Transform::plane(Vec3::ZERO, Vec3::Y),
    );
    settle(&mut draped, 150);
    c.bench_function("draped (sphere + ground)", |b| {
        b.iter(|| black_box(&mut draped).step());
    });
    for k in 0..8 {
        add(
            &mut draped,
            Shape::Capsule {
                radius: 0.1,
                half_length: 0.3,
            },
            Transform::from_position(Vec3::new(5.0 + k as f32, 1.0, 0.0)),
        );
    }
    c.bench_function("draped+8 far (10 colliders)", |b| {
        b.iter(|| black_box(&mut draped).step());
    });

    let cape = GridSpec {
        cols: 65,
        rows: 65,
        origin: Vec3::new(-0.25, 0.83, -0.2),
        u: Vec3::X * (0.5 / 64.0),
        v: -Vec3::Y * (0.6 / 64.0),
        vertex_mass: 0.15 / 4225.0,
    };
    let mut worn = cloth(&cape);
    for i in 0..65 {
        worn.pin_vertex(cape.vertex(i, 0), cape.position(i, 0))
            .unwrap();
    }
    let capsule = |radius, half_length| Shape::Capsule {
        radius,
        half_length,
    };
    let tilt = |x: f32, y: f32, z: f32, a: f32| Transform {
        position: Vec3::new(x, y, z),
        rotation: Quat::from_rotation_z(a),
    };
    let body = [
        (capsule(0.15, 0.1), tilt(0.0, 0.7, 0.0, 0.0)),
        (Shape::Sphere { radius: 0.16 }, tilt(0.0, 1.1, 0.0, 0.0)),
        (capsule(0.05, 0.08), tilt(0.25, 0.72, 0.0, 0.6)),
        (capsule(0.05, 0.08), tilt(-0.25, 0.72, 0.0, -0.6)),
        (capsule(0.045, 0.06), tilt(0.32, 0.6, 0.05, 0.3)),
        (capsule(0.045, 0.06), tilt(-0.32, 0.6, 0.05, -0.3)),
        (capsule(0.07, 0.06), tilt(0.13, 0.42, 0.0, 0.0)),
        (capsule(0.07, 0.06), tilt(-0.13, 0.42, 0.0, 0.0)),
        (capsule(0.06, 0.08), tilt(0.13, 0.25, 0.0, 0.0)),
        (capsule(0.06, 0.08), tilt(-0.13, 0.25, 0.0, 0.0)),
    ];
    for (shape, t) in body {
        add(&mut worn, shape, t);
    }
    // Press the cape against the body.
    let mut s = worn.settings().solver;
    s.gravity = Vec3::new(0.0, -9.81, 4.0);
    worn.set_solver_settings(s).unwrap();
    settle(&mut worn, 120);
    c.bench_function("cape10 (10 body colliders)", |b| {
        b.iter(|| black_box(&mut worn).step());
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
