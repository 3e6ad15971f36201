//! Prints the crowd pipeline and large-crowd measurements of issue 13 for one LOD mode:
//! `cargo run --release -p slod-experiments --example crowd_large -- [interpolated|key-hold|error-bound|held]
//! [max_error_px] [characters...]` (default: interpolated 1 px, 1000 and 10000 characters).
//! `held`: the whole pipeline (skinning included) with held joints, on one thread and on every
//! core; with `SHARED_MIB=N` in the environment, far characters share phase-bucket poses
//! (`animlod::PoseShare`, N MiB of them kept). `RIG=path.glb` runs another rig (scaled to 1.8 m)
//! instead of GDBot.
use std::path::PathBuf;
use std::sync::Arc;

use animlod::LodMode;
use slod_experiments::crowd_large::{
    LargeRow, LargeSetup, metric_rig, run_large, run_pipeline, run_pipeline_large,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let px: f32 = args.get(1).map_or(Ok(1.0), |a| a.parse())?;
    let lod = match args.first().map(String::as_str) {
        Some("error-bound") => LodMode::ErrorBound { max_error_px: px },
        Some("key-hold") => LodMode::KeyHold { max_error_px: px },
        _ => LodMode::Interpolated { max_error_px: px },
    };
    let sizes: Vec<usize> = if args.len() > 2 {
        args[2..]
            .iter()
            .map(|a| a.parse())
            .collect::<Result<_, _>>()?
    } else {
        vec![1000, 10_000]
    };
    let path = std::env::var("RIG").map(PathBuf::from).unwrap_or_else(|_| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf/GDQuest_GDBot.glb")
    });
    let rig = Arc::new(metric_rig(&animlod::build::import_path(&path)?)?);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    if args.first().map(String::as_str) == Some("held") {
        for n in sizes {
            let mut s = LargeSetup::new(n);
            s.held_joints_px = Some(px);
            s.shared_poses_mib = std::env::var("SHARED_MIB")
                .ok()
                .map(|c| c.parse())
                .transpose()?;
            (s.warmup_frames, s.frames) = if n >= 10_000 { (3, 6) } else { (5, 15) };
            print_row(
                &format!("whole pipeline, held joints {px} px, {n}"),
                &run_pipeline_large(&rig, &s, threads)?,
            );
        }
        return Ok(());
    }
    let mut setup = LargeSetup::new(100);
    setup.lod = lod;
    (setup.warmup_frames, setup.frames) = (10, 30);
    let p = run_pipeline(&rig, &setup)?;
    let total = |s: &slod_experiments::crowd_large::Stages| {
        s.sample_ms + s.concat_ms + s.palette_ms + s.skin_ms
    };
    println!("mode {lod:?}");
    println!(
        "pipeline {} chars x {} vertices: full {:.3} ms {:?}\n  lod {:.3} ms {:?}\n  cost {:.3}, skinned {:.3}, mean {:.4} px, max {:.3} px",
        p.characters,
        p.vertices,
        total(&p.full),
        p.full,
        total(&p.lod),
        p.lod,
        total(&p.lod) / total(&p.full),
        p.lod_skinned_fraction,
        p.mean_error_px,
        p.max_error_px
    );
    for n in sizes {
        let mut s = LargeSetup::new(n);
        s.lod = lod;
        (s.warmup_frames, s.frames) = if n >= 10_000 { (5, 10) } else { (10, 30) };
        print_row(&format!("large {n}"), &run_large(&rig, &s, threads)?);
    }
    Ok(())
}

fn print_row(what: &str, r: &LargeRow) {
    println!(
        "{what}: full {:.2} ms lod {:.2} ms cost {:.3}, mean {:.4} px max {:.3} px, interp {:.3}, changed {:.3}, {} threads {:.2} ms speed-up {:.2}, same {}",
        r.full_ms,
        r.lod_ms,
        r.cost_ratio(),
        r.mean_error_px,
        r.max_error_px,
        r.interpolated_fraction,
        r.changed_fraction,
        r.threads,
        r.lod_parallel_ms,
        r.parallel_speedup(),
        r.deterministic
    );
}
