//! Does the world budget settle on the street at budgets and solver settings no
//! default was chosen on? The street of `slod-demo world` (sixteen cloths, 1,000 characters, a
//! flying camera) under a deterministic cost-unit budget of 20%, 40%, 60% and 80% of its
//! full-detail frame, with the cloths at 16, 32 (the default) and 48 substeps: the frame the
//! cold start reached the target (the median of the next ten frames within ±10%), the frame it
//! settled (from which ≥ 95% of frames are within ±10%), that fraction, and the operations
//! undone within 30 frames. Deterministic: the same figures on any machine.
//!
//! `cargo run --release -p slod-experiments --example world_settling [-- FRAMES]` (300 frames
//! by default; about 20 s).

use std::path::Path;

use slod_experiments::world::{WorldConfig, full_detail_units, load_rig, run_cost_units};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let frames: u32 = match std::env::args().nth(1) {
        Some(a) => a.parse()?,
        None => 300,
    };
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf");
    let rig = load_rig(&assets)?;
    println!("substeps  budget  reached  settled  within  undone");
    for substeps in [16, 32, 48] {
        let config = WorldConfig {
            cloth_substeps: substeps,
            ..WorldConfig::standard(&assets)
        };
        let full = full_detail_units(&config, &rig)?;
        for fraction in [0.2, 0.4, 0.6, 0.8] {
            let run = run_cost_units(&config, &rig, fraction * full, frames, 0, &mut |_, _, _| {})?;
            let show = |f: Option<usize>| f.map_or("never".to_string(), |f| f.to_string());
            println!(
                "{substeps:>8}  {:>5.0}%  {:>7}  {:>7}  {:>5.1}%  {:>5.2}%",
                fraction * 100.0,
                show(run.settle.reached_after),
                show(run.settle.settled_after),
                run.settle.within_fraction * 100.0,
                run.undone_fraction * 100.0
            );
        }
    }
    Ok(())
}
