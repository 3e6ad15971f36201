//! Index newtypes for the solver's particles and links.
//!
//! Both are plain `u32` indices; the newtype keeps a particle index from being used
//! where a link index is expected.

/// Index of a particle (simulation node) in a [`crate::SoftBody`].
///
/// Particle storage is dense: removing a particle moves the last one into its slot
/// (see [`crate::SoftBody::remove_particle`]), so an id is valid until the next removal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ParticleId(pub u32);

impl ParticleId {
    /// Makes an id from a `usize` index.
    #[inline]
    pub fn new(index: usize) -> Self {
        Self(index as u32)
    }
    /// The index as `usize`.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Stable handle of a distance link (constraint) in a [`crate::SoftBody`].
///
/// Unlike particle ids, link ids never move: a removed link's id is recycled for the
/// next link that is added (last freed, first reused, so reuse is deterministic).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct LinkId(pub u32);

impl LinkId {
    /// Makes an id from a `usize` index.
    #[inline]
    pub fn new(index: usize) -> Self {
        Self(index as u32)
    }
    /// The index as `usize`.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}
