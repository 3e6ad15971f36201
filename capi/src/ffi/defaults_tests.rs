//! The C defaults are the Rust defaults: every `slod_default_*_desc` converts to exactly the
//! `Default` of the settings it describes (field by field, through `PartialEq`), and each LOD
//! mode's preset fields convert to that mode's `LodMode::DEFAULT_*`.

use animlod::LodMode;
use softbody::TreeCutSettings;

use super::*;
use crate::cloth::FeedbackSettings;

#[test]
fn cloth_desc_is_the_rust_default() {
    let desc = slod_default_cloth_desc();
    let settings = desc.solver.to_settings().unwrap();
    let rust = TreeCutSettings::default();
    assert_eq!(settings.solver, rust.solver);
    assert_eq!(settings.material, rust.material);
    assert_eq!(settings.blend_steps, rust.blend_steps);
    assert_eq!(settings, rust);
}

#[test]
fn feedback_desc_is_the_rust_default() {
    let desc = slod_default_feedback_desc();
    // Both values of `parallel_allowed` give the default, since the default is serial.
    for allowed in [false, true] {
        assert_eq!(
            desc.to_settings(allowed).unwrap(),
            FeedbackSettings::default()
        );
    }
}

#[test]
fn lod_desc_presets_are_the_rust_defaults() {
    let desc = slod_default_lod_desc();
    assert_eq!(desc.to_mode("lod").unwrap(), LodMode::default());
    assert_eq!(
        slod_default_crowd_desc().lod.to_mode("lod").unwrap(),
        LodMode::default()
    );
    for (value, rust) in [
        (SlodLodMode::Range, LodMode::DEFAULT_RANGE),
        (SlodLodMode::PixelSize, LodMode::DEFAULT_PIXEL_SIZE),
        (SlodLodMode::Budget, LodMode::DEFAULT_BUDGET),
        (SlodLodMode::ErrorBound, LodMode::DEFAULT_ERROR_BOUND),
        (SlodLodMode::Ratio, LodMode::DEFAULT_RATIO),
        (SlodLodMode::Interpolated, LodMode::DEFAULT_INTERPOLATED),
        (SlodLodMode::KeyHold, LodMode::DEFAULT_KEY_HOLD),
    ] {
        let d = SlodLodDesc {
            mode: value as u32,
            ..desc
        };
        assert_eq!(d.to_mode("lod").unwrap(), rust, "{value:?}");
    }
}
