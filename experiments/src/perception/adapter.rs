//! The runtime knobs the ablations and the error-bound strategy need, in one place, so the
//! harness follows the runtime's interface in one edit.

use slod::cloth::FeedbackSettings;

/// `settings` with the motion salience weighted 0 (strain only).
pub(crate) fn strain_only(settings: FeedbackSettings) -> FeedbackSettings {
    // Pending `FeedbackSettings::motion_weight`: runs as the default loop.
    settings
}

/// `settings` without the view factors (camera-blind).
pub(crate) fn camera_blind(settings: FeedbackSettings) -> FeedbackSettings {
    // Pending `FeedbackSettings::view_dependent`: runs as the default loop.
    settings
}

/// `settings` in the error-bound mode at `bound_px`.
pub(crate) fn error_bound(settings: FeedbackSettings, bound_px: f32) -> FeedbackSettings {
    // Pending `ClothBudget::MaxErrorPx`: runs under the node budget.
    let _ = bound_px;
    settings
}
