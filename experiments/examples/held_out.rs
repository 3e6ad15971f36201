//! The perception experiment on scene families no default of the feedback loop was chosen on
//! (`perception::scenes::held_out`): every strategy at 30% of the nodes against the
//! full-resolution reference, on-screen error in px on a 1080-px-high view, the twin and solver
//! floors, and the cost at equal p99 against uniform cuts — the same measures as the demo's
//! perception section, on other scenes, to check that the defaults carry over.
//!
//! `cargo run --release -p slod-experiments --example held_out [-- small]` (full size about
//! half a minute on two cores; `small` is the tests' size).

use slod_experiments::perception::{
    self, PerceptionConfig, SceneScale, Strategy, scenes::held_out,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scale = match std::env::args().nth(1).as_deref() {
        Some("small") => SceneScale::Small,
        Some("tiny") => SceneScale::Tiny,
        _ => SceneScale::Full,
    };
    let config = PerceptionConfig::default();
    let shown = [
        Strategy::Feedback,
        Strategy::PaperMotionOnly,
        Strategy::StrainOnly,
        Strategy::CameraBlind,
        Strategy::Uniform,
        Strategy::Random,
        Strategy::PinAware,
    ];
    println!(
        "on-screen RMS / p99 / max px at {:.0}% of the nodes, whole run",
        config.compression * 100.0
    );
    let mut header = format!("{:<10} {:>6}", "scene", "nodes");
    for s in shown {
        header += &format!(" {:>18}", s.name());
    }
    header += &format!(" {:>7} {:>7} {:>6}", "twin", "solver", "cost");
    println!("{header}");
    for scene in held_out(scale)? {
        let outcome = perception::run_scene(&scene, &config, &|_, _, _| {})?;
        let mut line = format!("{:<10} {:>6}", scene.name, outcome.budget_nodes);
        for s in shown {
            let cell = outcome.run(s, None).map_or("-".to_string(), |r| {
                format!(
                    "{:.2}/{:.1}/{:.0}",
                    r.screen.rms_px, r.screen.p99_px, r.screen.max_px
                )
            });
            line += &format!(" {cell:>18}");
        }
        let cost = outcome
            .equal_error
            .map_or("-".to_string(), |e| format!("{:.2}", e.cost_ratio()));
        line += &format!(
            " {:>7.2} {:>7.2} {:>6}",
            outcome.twin_floor.rms_px, outcome.solver_floor.rms_px, cost
        );
        println!("{line}");
        if let Some(eb) = outcome.run(Strategy::ErrorBound, None) {
            println!(
                "{:<10} error bound {} px: p99 {:.2} max {:.2} px at {:.0} of {} nodes",
                "",
                config.bound_px,
                eb.screen.p99_px,
                eb.screen.max_px,
                eb.nodes,
                outcome.full_nodes
            );
        }
    }
    Ok(())
}
