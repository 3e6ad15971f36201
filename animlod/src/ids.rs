//! Index newtypes: a bone of a skeleton, a clip and a skin of a rig, and a character of a crowd.

use std::fmt;

slod_core::index_type! {
    /// A bone of a [`crate::Skeleton`]. Bones are stored parents first, so a bone's id is larger
    /// than its parent's.
    pub struct BoneId, "bone "
}
slod_core::index_type! {
    /// A clip (one glTF animation) of a [`crate::Rig`].
    pub struct ClipId, "clip "
}
slod_core::index_type! {
    /// A skin of a [`crate::Rig`]: a list of joints with their inverse bind matrices.
    pub struct SkinId, "skin "
}

/// A character of a [`crate::Crowd`]: a slot index and the generation of the slot when the
/// character was added. A removed character's id goes stale and is refused from then on, even
/// after its slot is reused. Generations start at 1, so an all-zero id is never valid (a C caller
/// can use it as "null").
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct CharacterId {
    index: u32,
    generation: u32,
}

impl CharacterId {
    /// Rebuilds an id from its two parts (for foreign-language wrappers). Validated on use.
    #[inline]
    pub fn from_raw(index: u32, generation: u32) -> Self {
        CharacterId { index, generation }
    }

    /// The slot index of the character.
    #[inline]
    pub fn index(self) -> u32 {
        self.index
    }

    /// The generation of the slot when the character was added.
    #[inline]
    pub fn generation(self) -> u32 {
        self.generation
    }
}

impl fmt::Debug for CharacterId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "character {}v{}", self.index, self.generation)
    }
}

impl fmt::Display for CharacterId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self, f)
    }
}
