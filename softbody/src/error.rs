//! Errors of the plain solver: invalid input is refused with a reason and changes nothing.

use thiserror::Error;

/// Why the solver refused an input. Every refused call leaves the body unchanged.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum SoftBodyError {
    /// A position, force, rest length or other value was NaN or infinite.
    #[error("{what} is not finite")]
    NotFinite {
        /// Which input was bad.
        what: &'static str,
    },
    /// A particle mass was zero, negative or not finite (pin a particle instead of giving it mass 0).
    #[error("mass {mass} of particle {index} must be positive and finite")]
    BadMass {
        /// The particle (or vertex) index.
        index: usize,
        /// The offending mass.
        mass: f32,
    },
    /// A particle, link or vertex index does not exist.
    #[error("{what} index {index} out of range (len {len})")]
    OutOfRange {
        /// What kind of index it was.
        what: &'static str,
        /// The index given.
        index: usize,
        /// How many there are.
        len: usize,
    },
    /// A link would join a particle to itself.
    #[error("link joins particle {0} to itself")]
    SelfLink(usize),
    /// A link's rest length or compliance was negative, or its blend weight outside 0..=1.
    #[error("{what} = {value} is out of its range")]
    BadLinkParameter {
        /// Which parameter.
        what: &'static str,
        /// The value given.
        value: f32,
    },
    /// A solver setting was invalid (time step not positive, zero substeps or iterations, ...).
    #[error("invalid setting: {0}")]
    BadSetting(&'static str),
    /// The requested link kernel path needs a CPU feature this machine lacks.
    #[error("kernel path {0} is not supported by this CPU")]
    UnsupportedKernel(&'static str),
    /// A collider description or transform was invalid (negative radius, NaN transform, ...).
    #[error("invalid collider: {0}")]
    BadCollider(&'static str),
    /// A collider id that was removed (or never issued by this body).
    #[error("collider id is stale (removed, or from another body)")]
    StaleCollider,
    /// A builder was given too few vertices (a grid needs at least 2×2).
    #[error("degenerate input: {0}")]
    Degenerate(&'static str),
}
