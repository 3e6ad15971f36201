//! Why the adaptive cloth refused a call. Every refused call leaves the cloth as it was.

use thiserror::Error;

/// Errors of [`crate::cloth::AdaptiveCloth`] and the net experiment.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum ClothError {
    /// The hierarchy could not be built from the grid or mesh given.
    #[error("cloth hierarchy: {0}")]
    Build(#[from] treecut::BuildError),
    /// The soft body refused (bad settings, node not on the cut, locked, leaf, ...).
    #[error("cloth body: {0}")]
    Body(#[from] softbody::TreeCutError),
    /// The salience stage refused its inputs or parameters.
    #[error("salience: {0}")]
    Salience(#[from] salience::SalienceError),
    /// The view is not usable (NaN, zero viewport, bad field of view, degenerate directions,
    /// bad near plane or light).
    #[error("view: {0}")]
    View(#[from] salience::ViewError),
    /// The evaluator refused its inputs.
    #[error("evaluator: {0}")]
    Eval(#[from] treecut::EvalError),
    /// A feedback setting is out of range; names the field.
    #[error("feedback setting `{field}`: {reason}")]
    Feedback {
        /// The field.
        field: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// A collider, collision radius or its transform was refused (negative radius, NaN
    /// transform, stale collider id, ...).
    #[error("collider: {0}")]
    Collider(#[from] softbody::SoftBodyError),
    /// The wind field was refused.
    #[error("wind: {0}")]
    Wind(#[from] softbody::WindError),
    /// The character a cloth is worn by refused (stale character id, ...).
    #[error("character: {0}")]
    Crowd(#[from] animlod::CrowdError),
    /// A buffer has the wrong length.
    #[error("buffer `{what}` holds {got} entries, {expected} needed")]
    BufferLength {
        /// Which buffer.
        what: &'static str,
        /// Length given.
        got: usize,
        /// Length needed.
        expected: usize,
    },
}
