//! Why a demo run stopped: a bad command line (exit code 2, with the usage) or a failure while
//! running (exit code 1). Library errors keep their own messages.

use std::path::PathBuf;

use thiserror::Error;

/// Everything that can stop a run.
#[derive(Debug, Error)]
pub(crate) enum DemoError {
    /// The command line is wrong; the message says how.
    #[error("{0}")]
    Usage(String),
    /// The adaptive cloth or the net experiment refused its configuration.
    #[error("net experiment: {0}")]
    Cloth(#[from] slod::cloth::ClothError),
    /// The TreeCut soft body refused an operation of the timing loops.
    #[error("TreeCut soft body: {0}")]
    TreeCut(#[from] softbody::TreeCutError),
    /// The plain soft body refused its settings.
    #[error("soft body: {0}")]
    SoftBody(#[from] softbody::SoftBodyError),
    /// The hierarchy could not be built.
    #[error("hierarchy: {0}")]
    Hierarchy(#[from] treecut::BuildError),
    /// The crowd refused its configuration.
    #[error("crowd: {0}")]
    Crowd(#[from] animlod::CrowdError),
    /// The rig could not be turned into the thesis' character.
    #[error("rig: {0}")]
    Rig(#[from] animlod::BuildError),
    /// The glTF file could not be read as a rig.
    #[error("cannot load {path}: {source}")]
    Import {
        /// The file.
        path: PathBuf,
        /// Why.
        source: animlod::ImportError,
    },
    /// The rig has no animation to play.
    #[error("{0}")]
    Clip(String),
    /// Writing an output file failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Encoding a picture or drawing a plot failed.
    #[error("cannot draw {path}: {reason}")]
    Draw {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A measurement loop found the library behaving against its documented contract.
    #[error("internal: {0}")]
    Internal(String),
    /// Serialising the report failed.
    #[error("cannot serialise the report: {0}")]
    Json(#[from] serde_json::Error),
}

impl DemoError {
    /// An I/O error on `path`.
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> DemoError {
        DemoError::Io {
            path: path.into(),
            source,
        }
    }

    /// A drawing error on `path`.
    pub(crate) fn draw(path: impl Into<PathBuf>, reason: impl std::fmt::Display) -> DemoError {
        DemoError::Draw {
            path: path.into(),
            reason: format!("{reason}"),
        }
    }
}
