//! The runtime knobs the ablations and the error-bound strategy use, in one place: what each
//! strategy changes in the default feedback settings.

use slod::cloth::{ClothBudget, FeedbackSettings};

/// `settings` with the motion salience weighted 0 (strain only).
pub(crate) fn strain_only(settings: FeedbackSettings) -> FeedbackSettings {
    FeedbackSettings {
        motion_weight: 0.0,
        ..settings
    }
}

/// `settings` without the view factors (camera-blind).
pub(crate) fn camera_blind(settings: FeedbackSettings) -> FeedbackSettings {
    FeedbackSettings {
        view_dependent: false,
        ..settings
    }
}

/// `settings` without the rim weight (rim-blind).
pub(crate) fn rim_blind(settings: FeedbackSettings) -> FeedbackSettings {
    FeedbackSettings {
        rim_weight: 0.0,
        ..settings
    }
}

/// `settings` in the error-bound mode at `bound_px`.
pub(crate) fn error_bound(settings: FeedbackSettings, bound_px: f32) -> FeedbackSettings {
    FeedbackSettings {
        budget: ClothBudget::MaxErrorPx(bound_px),
        ..settings
    }
}
