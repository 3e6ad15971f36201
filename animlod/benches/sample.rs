//! Full-detail playback (sampling + local-to-model) throughput in bones per second, and the cost
//! of a held bone.
//!
//! Each iteration advances a crowd of 64 characters (different phases) by one 60 Hz frame.
//! "bones" counts every bone of every character; "held" counts the animated bones that the
//! scheduler considered and held.
//!
//! The `_all_channels` cases import with constant-channel detection off: every keyed channel of
//! every bone is sampled and every bone's local matrix composed, as in a runtime without that
//! optimisation (ozz-animation samples every track); the other cases skip constant channels.
use std::path::PathBuf;
use std::sync::Arc;

use animlod::{ClipOptions, Crowd, ImportOptions, LodMode, Rig};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use slod_experiments::rig::grown_to;

const CHARACTERS: usize = 64;

fn rig(name: &str, options: &ImportOptions) -> Rig {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../assets/gltf")
        .join(name);
    animlod::build::import_path_with(&path, options).expect("asset")
}

fn crowd(rig: Arc<Rig>, clip: &str, lod: LodMode) -> Crowd {
    let clip = rig.clip_by_name(clip).expect("clip");
    let duration = rig.clip(clip).unwrap().duration();
    let mut c = Crowd::new(rig);
    for i in 0..CHARACTERS {
        let id = c
            .add_character(Vec3::new(i as f32, 0.0, 0.0), clip)
            .unwrap();
        c.set_time(id, duration * i as f32 / CHARACTERS as f32)
            .unwrap();
    }
    c.set_lod(lod).unwrap();
    c
}

fn bench(c: &mut Criterion) {
    let keep = ImportOptions::default();
    let all = ImportOptions {
        clip: ClipOptions::SAMPLE_ALL,
    };
    let gdbot = Arc::new(rig("GDQuest_GDBot.glb", &keep));
    let cases = [
        ("gdbot_walk", gdbot.clone(), "walk"),
        (
            "gdbot_walk_all_channels",
            Arc::new(rig("GDQuest_GDBot.glb", &all)),
            "walk",
        ),
        (
            "gdbot153_walk",
            Arc::new(grown_to(&gdbot, 153, 0.3).unwrap()),
            "walk",
        ),
        (
            "gdbot153_walk_all_channels",
            Arc::new(grown_to(&rig("GDQuest_GDBot.glb", &all), 153, 0.3).unwrap()),
            "walk",
        ),
        ("fox_walk", Arc::new(rig("Fox.glb", &keep)), "Walk"),
        (
            "robot_running",
            Arc::new(rig("RobotExpressive.glb", &keep)),
            "Running",
        ),
    ];
    // Off and Ratio modes ignore the view beyond measuring it.
    let view = salience::View::default();
    let mut g = c.benchmark_group("sample");
    for (name, rig, clip) in &cases {
        let bones = rig.bone_count();
        g.throughput(Throughput::Elements((CHARACTERS * bones) as u64));
        let mut full = crowd(rig.clone(), clip, LodMode::Off);
        g.bench_function(format!("full/{name}"), |b| {
            b.iter(|| full.advance(1.0 / 60.0, &view).unwrap());
        });
    }
    for (name, rig, clip) in &cases {
        let animated = rig
            .clip(rig.clip_by_name(clip).unwrap())
            .unwrap()
            .animated_bone_count();
        g.throughput(Throughput::Elements((CHARACTERS * animated) as u64));
        // Ω tiny but non-zero: every animated bone goes through the scheduler and holds.
        let mut held = crowd(rig.clone(), clip, LodMode::Ratio(1e-9));
        held.advance(1.0 / 60.0, &view).unwrap();
        g.bench_function(format!("held/{name}"), |b| {
            b.iter(|| held.advance(1.0 / 60.0, &view).unwrap());
        });
        // Ω = 0: the character is frozen and skipped whole.
        let mut frozen = crowd(rig.clone(), clip, LodMode::Ratio(0.0));
        g.bench_function(format!("frozen/{name}"), |b| {
            b.iter(|| frozen.advance(1.0 / 60.0, &view).unwrap());
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
