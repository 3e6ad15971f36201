//! The thesis' own claims, tested at equal cost (`animation-lod-bone-priority-thesis.txt`,
//! chapters 11–14): per-bone priorities against updating every bone of a character alike, and
//! the analysis pass's derived weights in sample (fitted on the clip judged) and out of sample
//! (fitted on the rig's other clips). Each weighting is run at the same fraction of full-detail
//! bone interpolations ([`animlod::build::analysis::evaluate_at_cost`]) and its on-screen error
//! measured at joint origins and tips.

use std::sync::Arc;

use animlod::build::analysis::{CostSetup, derive_weights, evaluate_at_cost};
use animlod::{ClipId, CrowdError, PriorityWeights, Rig};

/// One weighting judged on one clip.
#[derive(Clone, Debug, PartialEq)]
pub struct AblationRow {
    /// The clip judged.
    pub clip: String,
    /// `equal` (the thesis' 1/6 each), `uniform` (every bone alike: the user factor only, all
    /// 1), `derived_in_sample`, `derived_out_of_sample`.
    pub weighting: &'static str,
    /// Fraction of full-detail interpolations spent.
    pub update_fraction: f32,
    /// Mean on-screen error (px).
    pub mean_px: f32,
    /// RMS on-screen error (px).
    pub rms_px: f32,
    /// Largest on-screen error (px).
    pub max_px: f32,
}

/// Every bone of a character alike: only the user factor, which is 1 for every bone.
pub const UNIFORM: PriorityWeights = PriorityWeights {
    translation: 0.0,
    rotation: 0.0,
    scale: 0.0,
    descendants: 0.0,
    depth: 0.0,
    user: 1.0,
};

/// Judges the four weightings on each of `clips` of `rig` at `update_fraction` of full detail
/// (Ω = ½, `characters` at spread phases, `frames` frames).
pub fn run(
    rig: &Arc<Rig>,
    clips: &[ClipId],
    update_fraction: f32,
    characters: usize,
    frames: usize,
) -> Result<Vec<AblationRow>, CrowdError> {
    let all: Vec<ClipId> = (0..rig.clips().len())
        .map(ClipId::new)
        .filter(|&c| rig.clip(c).is_some_and(|c| c.animated_bone_count() > 0))
        .collect();
    let mut rows = Vec::new();
    for &clip in clips {
        let others: Vec<ClipId> = all.iter().copied().filter(|&c| c != clip).collect();
        let in_sample = derive_weights(rig, &[clip]).weights;
        let out_of_sample = if others.is_empty() {
            in_sample
        } else {
            derive_weights(rig, &others).weights
        };
        let weightings = [
            ("equal", PriorityWeights::EQUAL),
            ("uniform", UNIFORM),
            ("derived_in_sample", in_sample),
            ("derived_out_of_sample", out_of_sample),
        ];
        let setup = CostSetup {
            clip,
            omega: 0.5,
            update_fraction,
            characters,
            frames,
        };
        let results = evaluate_at_cost(rig, &weightings.map(|w| w.1), &setup)?;
        let name = rig
            .clip(clip)
            .map_or_else(String::new, |c| c.name().to_string());
        for ((label, _), r) in weightings.iter().zip(results) {
            rows.push(AblationRow {
                clip: name.clone(),
                weighting: label,
                update_fraction: r.update_fraction,
                mean_px: r.error.mean_px,
                rms_px: r.error.rms_px,
                max_px: r.error.max_px,
            });
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn every_weighting_is_judged_at_the_same_cost() {
        let path =
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf/GDQuest_GDBot.glb");
        let rig = Arc::new(animlod::build::import_path(&path).unwrap());
        let walk = rig.clip_by_name("walk").unwrap();
        let rows = run(&rig, &[walk], 0.35, 4, 48).unwrap();
        assert_eq!(rows.len(), 4);
        for r in &rows {
            println!("{r:?}");
            assert!((r.update_fraction - 0.35).abs() < 0.02, "{r:?}");
            assert!(r.mean_px.is_finite() && r.mean_px > 0.0);
        }
        // On GDBot's walk the per-bone priorities (derived in sample) beat treating every bone
        // alike at equal cost.
        let get = |w: &str| rows.iter().find(|r| r.weighting == w).unwrap();
        assert!(get("derived_in_sample").rms_px < get("uniform").rms_px);
    }
}
