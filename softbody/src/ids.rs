//! Index newtypes for the solver's particles and links.
//!
//! Both are plain `u32` indices; the newtype keeps a particle index from being used
//! where a link index is expected.

slod_core::index_type! {
    /// Index of a particle (simulation node) in a [`crate::SoftBody`].
    ///
    /// Particle storage is dense: removing a particle moves the last one into its slot
    /// (see [`crate::SoftBody::remove_particle`]), so an id is valid until the next removal.
    pub struct ParticleId, "particle "
}

slod_core::index_type! {
    /// Stable handle of a distance link (constraint) in a [`crate::SoftBody`].
    ///
    /// Unlike particle ids, link ids never move: a removed link's id is recycled for the
    /// next link that is added (last freed, first reused, so reuse is deterministic).
    pub struct LinkId, "link "
}
