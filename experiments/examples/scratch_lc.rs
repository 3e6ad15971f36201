use slod_experiments::perception::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    for name in [
        "net",
        "large_closeup",
        "offscreen",
        "irregular_mesh",
        "net_129",
    ] {
        let mut scene = scenes::all(SceneScale::Full)
            .unwrap()
            .into_iter()
            .find(|s| s.name == name)
            .unwrap();
        let reference = record_reference(&scene, None).unwrap();
        let nodes = (0.3 * scene.hierarchy.vertex_count() as f32) as usize;
        for mode in [
            softbody::ReconstructionMode::Smooth,
            softbody::ReconstructionMode::Mls,
        ] {
            scene.body.reconstruction = mode;
            for a in &args[1..] {
                let s = *Strategy::ALL.iter().find(|s| s.name() == a).unwrap();
                let r = run_strategy(
                    &scene,
                    &reference,
                    RunSpec {
                        strategy: s,
                        nodes,
                        bound_px: 1.0,
                        horizon: None,
                    },
                    None,
                )
                .unwrap();
                println!(
                    "{name:15} {mode:?} {:12} nodes {:.0} step {:.3} rec {:.3} rms {:.2} p99 {:.2} max {:.1} pop {:.1}",
                    s.name(),
                    r.nodes,
                    r.step_ms,
                    r.reconstruct_ms.unwrap_or(0.0),
                    r.screen.rms_px,
                    r.screen.p99_px,
                    r.screen.max_px,
                    r.screen.pop_max_px
                );
            }
        }
    }
}
