//! Priority-based LOD for skeletal animation: glTF rigs, per-keyframe bone priorities, a
//! scheduler that decides per bone and frame whether to interpolate, and a crowd that spends
//! interpolation where the camera can see it.
//!
//! The pieces, in the order data flows:
//! - [`Rig`] — a [`Skeleton`], its [`Clip`]s and [`Skin`]s, imported from glTF
//!   ([`Rig::from_gltf_path`]) or built in code. Constant channels are folded away at load time.
//! - [`SubPriorities`] — static per-keyframe priorities of every animated bone (thesis ch. 10–12,
//!   with its two defects fixed), combined with [`PriorityWeights`];
//!   [`analysis::derive_weights`] fits the weights to measured pose error.
//! - [`Crowd`] — characters sharing an `Arc<Rig>`; [`LodMode`] and the frame's
//!   [`salience::View`] give each its camera ratio Ω; the [`scheduler`] turns priority × Ω into an update period per bone (the
//!   thesis' reading), [`LodMode::Budget`] spends a fixed number of interpolations per frame over
//!   the crowd, and [`LodMode::ErrorBound`] holds a bone only while its measured on-screen drift
//!   stays under a pixel bound; [`Crowd::advance`] samples, holds and concatenates (skipping
//!   subtrees that held); [`Crowd::pose_error`] measures the cost against full-rate evaluation.
//!
//! The thesis' crowd test and other experiments live in the `slod-experiments` crate.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod analysis;
mod clip;
mod crowd;
mod error;
mod ids;
mod import;
mod lod;
mod pose_error;
mod priority;
mod rig;
mod sampling;
pub mod scheduler;
mod skeleton;
mod transform;

pub use clip::{ChannelDesc, ChannelStats, Clip, ClipOptions, Interpolation, Keys, Property};
pub use crowd::{Crowd, FrameStats, PrioritySource};
pub use error::{BuildError, CrowdError, ImportError};
pub use ids::{BoneId, CharacterId, ClipId, SkinId};
pub use import::{ImportOptions, ImportReport};
pub use lod::{LodMode, omega_from_distance, omega_from_pixels};
pub use pose_error::{ErrorSum, PoseError};
pub use priority::{Factor, PriorityWeights, SubPriorities};
pub use rig::{Rig, Skin};
pub use scheduler::{SchedulerParams, update_period};
pub use skeleton::{BoneDesc, MAX_BONES, Skeleton};
pub use transform::{Transform, align_hemisphere, interpolate_rotation, rotation_angle};
