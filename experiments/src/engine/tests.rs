//! The engine scenes at a small size: they run, they keep the cloth out of the colliders, and
//! runs are deterministic.

use super::*;

fn assets() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf")
}

#[test]
fn every_scene_runs_and_keeps_the_reference_out_of_its_colliders() {
    let config = EngineConfig {
        steps: 40,
        ..EngineConfig::quick(&assets())
    };
    let scenes = run_engine(&config, &mut |_, _, _, _| {}).unwrap();
    assert_eq!(scenes.len(), 4);
    for s in &scenes {
        assert!(s.colliders >= 1);
        let reference = &s.runs[0];
        assert_eq!(reference.strategy, "reference");
        assert!(
            reference.max_penetration_mm <= s.thickness_mm + 1.0,
            "{}: reference penetrates {} mm",
            s.name,
            reference.max_penetration_mm
        );
        for r in &s.runs[1..] {
            assert!(r.nodes < reference.nodes, "{}: {} nodes", s.name, r.nodes);
            assert!(r.screen.rms_px.is_finite());
        }
    }
    let cape = scenes.iter().find(|s| s.name == "cape_walk").unwrap();
    assert_eq!(cape.colliders, 10);
}

#[test]
fn scene_runs_are_bit_identical() {
    let config = EngineConfig {
        steps: 30,
        scenes: vec![SceneKind::CapeWalk, SceneKind::FlagWind],
        ..EngineConfig::quick(&assets())
    };
    let a = run_engine(&config, &mut |_, _, _, _| {}).unwrap();
    let b = run_engine(&config, &mut |_, _, _, _| {}).unwrap();
    for (x, y) in a.iter().zip(&b) {
        for (p, q) in x.runs.iter().zip(&y.runs) {
            let bits = |v: &[Vec3]| {
                v.iter()
                    .map(|p| p.to_array().map(f32::to_bits))
                    .collect::<Vec<_>>()
            };
            assert_eq!(
                bits(&p.final_surface),
                bits(&q.final_surface),
                "{} {}",
                x.name,
                p.strategy
            );
        }
    }
}
