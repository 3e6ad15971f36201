//! Error types: building skeletons and clips, importing glTF, and driving a crowd. Every refused
//! operation leaves the object it was called on unchanged.

use std::path::PathBuf;

use crate::ids::{BoneId, CharacterId, ClipId, SkinId};

/// Why a skeleton or a clip could not be built from the given data.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// A skeleton needs at least one bone.
    #[error("a skeleton needs at least one bone")]
    EmptySkeleton,
    /// More bones than the index type can address.
    #[error("{0} bones is more than the supported maximum of {max}", max = crate::skeleton::MAX_BONES)]
    TooManyBones(usize),
    /// Bones must be listed parents first.
    #[error("{bone} lists a parent that does not come before it")]
    ParentNotBefore {
        /// The offending bone.
        bone: BoneId,
    },
    /// A channel targets a bone the skeleton does not have.
    #[error("a channel targets {bone}, but the skeleton has {bones} bones")]
    UnknownBone {
        /// The target.
        bone: BoneId,
        /// Number of bones in the skeleton.
        bones: usize,
    },
    /// Two channels of one clip target the same property of the same bone.
    #[error("two channels target the {property} of {bone}")]
    DuplicateChannel {
        /// The bone.
        bone: BoneId,
        /// `translation`, `rotation` or `scale`.
        property: &'static str,
    },
    /// A channel has no key.
    #[error("a channel of {bone} has no key")]
    NoKeys {
        /// The bone.
        bone: BoneId,
    },
    /// The number of values does not match the number of key times.
    #[error("a channel of {bone} has {times} key times but {values} values (expected {expected})")]
    KeyCountMismatch {
        /// The bone.
        bone: BoneId,
        /// Number of key times.
        times: usize,
        /// Number of values given.
        values: usize,
        /// Number of values expected.
        expected: usize,
    },
    /// Key times must be finite and never decrease.
    #[error("the key times of a channel of {bone} are not finite and non-decreasing")]
    BadKeyTimes {
        /// The bone.
        bone: BoneId,
    },
    /// A value (key, rest transform, matrix) is NaN or infinite, or a rotation has zero length.
    #[error("non-finite or degenerate value in {what}")]
    NonFinite {
        /// Where.
        what: String,
    },
}

/// Why a glTF file could not be imported. Malformed input always ends here, never in a panic.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The file (or a buffer file it references) could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The path that failed.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The binary container (.glb) is truncated or malformed.
    #[error("malformed .glb container: {0}")]
    Container(String),
    /// The JSON is not valid glTF.
    #[error("invalid glTF JSON: {0}")]
    Json(String),
    /// The file requires an extension that changes how animation data is stored.
    #[error("required extension {0} is not supported")]
    UnsupportedExtension(String),
    /// A buffer is missing, too short or cannot be decoded.
    #[error("buffer {index}: {reason}")]
    Buffer {
        /// glTF buffer index.
        index: usize,
        /// What is wrong.
        reason: String,
    },
    /// An accessor has the wrong type, points outside its buffer, or holds bad values.
    #[error("accessor {index}: {reason}")]
    Accessor {
        /// glTF accessor index.
        index: usize,
        /// What is wrong.
        reason: String,
    },
    /// The node hierarchy is malformed (bad index, a node with two parents, a cycle).
    #[error("node hierarchy: {0}")]
    Hierarchy(String),
    /// A skin is malformed.
    #[error("skin {index}: {reason}")]
    Skin {
        /// glTF skin index.
        index: usize,
        /// What is wrong.
        reason: String,
    },
    /// An animation channel or sampler is malformed.
    #[error("animation {animation}: {reason}")]
    Animation {
        /// glTF animation index.
        animation: usize,
        /// What is wrong.
        reason: String,
    },
    /// The file has no skin, so there is no skeleton to animate.
    #[error("the file has no skin")]
    NoSkin,
    /// The data passed the importer's checks but a skeleton or clip could not be built from it.
    #[error(transparent)]
    Build(#[from] BuildError),
    /// A dependency panicked on this input; the panic was caught.
    #[error("parser panicked on malformed input: {0}")]
    Panicked(String),
}

/// Why a crowd refused an operation. The crowd is unchanged after any error.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CrowdError {
    /// The id names no live character (removed, never added, or from another crowd).
    #[error("{0} is not a live character of this crowd")]
    StaleCharacter(CharacterId),
    /// The rig has no such clip.
    #[error("the rig has no {0}")]
    UnknownClip(ClipId),
    /// The rig has no such skin.
    #[error("the rig has no {0}")]
    UnknownSkin(SkinId),
    /// The rig has no such bone.
    #[error("the rig has no {0}")]
    UnknownBone(BoneId),
    /// A number is NaN, infinite or out of its allowed range.
    #[error("invalid {what}: {reason}")]
    InvalidArgument {
        /// Which argument.
        what: &'static str,
        /// The allowed range.
        reason: &'static str,
    },
    /// An output slice is shorter than needed.
    #[error("output holds {given} matrices but {needed} are needed")]
    BufferTooSmall {
        /// Length needed.
        needed: usize,
        /// Length given.
        given: usize,
    },
    /// Character slots exhausted.
    #[error("too many characters")]
    TooManyCharacters,
    /// A view could not be built from the values given.
    #[error("view: {0}")]
    View(#[from] salience::ViewError),
}

/// Shorthand for argument checks.
pub(crate) fn invalid(what: &'static str, reason: &'static str) -> CrowdError {
    CrowdError::InvalidArgument { what, reason }
}
