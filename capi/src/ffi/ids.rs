//! The by-value ids of things inside a world. Each kind has its own type so C catches mixing
//! them up at compile time; the arenas catch the rest (stale, foreign, wrong-kind) at run time.

use super::arena::RawId;

macro_rules! ids {
    ($($(#[$doc:meta])* $name:ident;)*) => {$(
        $(#[$doc])*
        ///
        /// `index1` is a slot index plus one and `generation` the slot's stamp; the all-zero
        /// value is the null id, never issued. Compare ids with both fields.
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
        pub struct $name {
            /// Slot index plus one; 0 for the null id.
            pub index1: u32,
            /// Generation stamp of the slot when the id was issued.
            pub generation: u32,
        }

        impl From<RawId> for $name {
            fn from(r: RawId) -> Self {
                $name { index1: r.index1, generation: r.generation }
            }
        }

        impl From<$name> for RawId {
            fn from(id: $name) -> Self {
                RawId { index1: id.index1, generation: id.generation }
            }
        }
    )*};
}

ids! {
    /// A cloth (adaptive TreeCut soft body) in a world.
    SlodClothId;
    /// A rig loaded from glTF (skeleton, clips, skins), shared by the crowds that use it.
    SlodRigId;
    /// A crowd: characters of one rig animated together under one LOD mode.
    SlodCrowdId;
    /// A character (an animated instance) in a crowd.
    SlodCharacterId;
}
