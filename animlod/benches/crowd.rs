//! The thesis' crowd test (chapter 13): 100 characters of 153 bones (GDBot's real skeleton and
//! walk, replicated to 153 bones and scaled to 180 units), in a grid and at random positions,
//! the camera swept from near to far. Prints, per distance and LOD mode, the frame cost with
//! and without LOD, the interpolations spent and the on-screen error; then times single frames
//! with criterion, for 100 and for 10,000 characters.
use std::path::PathBuf;
use std::sync::Arc;

use animlod::{Crowd, LodMode, PrioritySource, Rig};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use salience::View;
use slod_experiments::crowd::{self as experiment, CrowdExperiment, Layout, THESIS_RANGE};

fn thesis_rig() -> Arc<Rig> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf/GDQuest_GDBot.glb");
    let base = animlod::build::import_path(&path).expect("asset");
    Arc::new(experiment::thesis_rig(&base).expect("153-bone rig"))
}

/// (bench id, description, mode, priority source)
type Mode = (&'static str, &'static str, LodMode, PrioritySource);

/// `animated`: animated bones per character, so the budget is a quarter of full detail.
fn modes(characters: usize, animated: usize) -> Vec<Mode> {
    let budget = (characters * animated / 4) as u32;
    vec![
        (
            "thesis_range",
            "thesis range [200, 1700], equal weights",
            THESIS_RANGE,
            PrioritySource::Factors,
        ),
        (
            "pixel_size",
            "projected size (full detail at 100 px radius), measured priorities",
            LodMode::PixelSize {
                full_detail_px: 100.0,
                freeze_below_px: 1.0,
            },
            PrioritySource::HoldError,
        ),
        (
            "error_bound_1px",
            "error bound 1 px",
            LodMode::ErrorBound { max_error_px: 1.0 },
            PrioritySource::Factors,
        ),
        (
            "budget_25pct",
            "budget 25% of full detail, measured priorities",
            LodMode::Budget {
                bone_updates_per_frame: budget,
            },
            PrioritySource::HoldError,
        ),
    ]
}

fn animated(rig: &Rig) -> usize {
    rig.clip(rig.clip_by_name("walk").unwrap())
        .unwrap()
        .animated_bone_count()
}

fn print_sweeps(rig: &Arc<Rig>) {
    let clip = rig.clip_by_name("walk").unwrap();
    let frames = std::env::var("ANIMLOD_SWEEP_FRAMES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(120);
    for layout in [
        Layout::Grid { spacing: 150.0 },
        Layout::Random {
            side: 1500.0,
            seed: 1,
        },
    ] {
        for (_, name, lod, source) in modes(100, animated(rig)) {
            let mut cfg = CrowdExperiment::thesis(clip);
            cfg.layout = layout;
            cfg.lod = lod;
            cfg.source = source;
            cfg.frames = frames;
            let rows = experiment::run(rig, &cfg).expect("sweep");
            println!(
                "\n100 characters × {} bones, {layout:?}, {name}",
                rig.bone_count()
            );
            print!("{}", experiment::format_table(&rows));
        }
    }
}

fn frame_crowd(
    rig: &Arc<Rig>,
    characters: usize,
    layout: Layout,
    lod: LodMode,
    source: PrioritySource,
    distance: f32,
) -> (Crowd, View) {
    let mut cfg = CrowdExperiment::thesis(rig.clip_by_name("walk").unwrap());
    cfg.characters = characters;
    cfg.layout = layout;
    cfg.lod = lod;
    cfg.source = source;
    let (_, mut c) = experiment::build_crowds(rig, &cfg).unwrap();
    let (center, _) = rig.bounds();
    let view = cfg.view_from(Vec3::new(0.0, center.y, distance)).unwrap();
    for _ in 0..30 {
        c.advance(cfg.dt, &view).unwrap();
    }
    (c, view)
}

fn bench(c: &mut Criterion) {
    let rig = thesis_rig();
    if std::env::var_os("ANIMLOD_NO_SWEEP").is_none() {
        print_sweeps(&rig);
    }
    let bones = rig.bone_count();
    for (characters, layout, distance) in [
        (100usize, Layout::Grid { spacing: 150.0 }, 1000.0f32),
        (10_000, Layout::Grid { spacing: 150.0 }, 8000.0),
    ] {
        let mut g = c.benchmark_group(format!("crowd/{characters}x{bones}"));
        g.throughput(Throughput::Elements((characters * bones) as u64));
        let mut cases = vec![("full".to_string(), LodMode::Off, PrioritySource::Factors)];
        cases.extend(
            modes(characters, animated(&rig))
                .into_iter()
                .map(|(id, _, lod, source)| (format!("{id}@{distance}"), lod, source)),
        );
        for (name, lod, source) in cases {
            let (mut crowd, view) = frame_crowd(&rig, characters, layout, lod, source, distance);
            let st = crowd.advance(1.0 / 60.0, &view).unwrap();
            println!("{characters} characters, {name}: {st:?}");
            g.bench_function(&name, |b| {
                b.iter(|| crowd.advance(1.0 / 60.0, &view).unwrap());
            });
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
