//! Priority-based LOD for skeletal animation: glTF rigs, per-keyframe bone priorities, a
//! scheduler that decides per bone and frame whether to interpolate, and a crowd that spends
//! interpolation where the camera can see it.
//!
//! The pieces, in the order data flows:
//! - The build step, [`build`] (offline, once per rig): glTF import ([`build::import_path`]) or
//!   parts built in code ([`build::rig`]); constant channels are folded away; each clip's
//!   priority table — static per-keyframe priorities of every animated bone (thesis
//!   ch. 10–12, with its two defects fixed) and measured hold error rates — is computed; and
//!   [`build::analysis::derive_weights`] fits the [`PriorityWeights`] to measured pose error.
//! - [`Rig`] — the plain runtime data the build step produces: a [`Skeleton`], its [`Clip`]s,
//!   [`Skin`]s and [`SkinnedMesh`]es, and one priority table per clip.
//! - [`Crowd`] — characters sharing an `Arc<Rig>`; [`LodMode`] and the frame's
//!   [`salience::View`] give each its camera ratio Ω; the scheduler turns priority × Ω into an
//!   update period per bone (the thesis' reading), [`LodMode::Budget`] spends a fixed budget of
//!   interpolations per frame over the crowd, and [`LodMode::ErrorBound`] holds a bone only while
//!   the drift of it and its held ancestors stays under a pixel bound, and
//!   [`LodMode::Interpolated`] / [`LodMode::KeyHold`] evaluate whole key poses at intervals
//!   bounded by the build step's velocity tables and blend between them or hold each over a
//!   window centred on its time ([`Crowd::key_poses`] tells a host which skinned copies to
//!   recompute); [`Crowd::advance`]
//!   samples, holds and concatenates (skipping subtrees that held); [`Crowd::pose_changed`]
//!   says when a character's skinned output can be reused; [`Crowd::pose_error`] measures the
//!   cost against full-rate evaluation at every joint's origin and tip ([`Skeleton::tip`]).
//! - [`SkinningJob`] — CPU linear-blend skinning of a [`SkinnedMesh`] with a character's palette
//!   ([`Crowd::skinning_matrices`]); [`SkinBlendJob`] blends two skinned key poses;
//!   [`SkinHoldJob`] skins with held joints: each joint keeps its matrix until it moves some
//!   vertex of it past a bound (pixels over [`Crowd::pixels_per_unit`]), checked exactly at the
//!   corners of the joint's vertex box every frame, and only the vertices of refreshed joints
//!   are skinned again ([`SkinHoldLayout`] per mesh, [`HeldSkin`] per character and mesh).
//!
//! The thesis' crowd test and other experiments live in the `slod-experiments` crate.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod build;
mod clip;
mod crowd;
mod error;
mod ids;
mod lod;
mod mesh;
mod pose_error;
mod pose_share;
mod priority;
mod rig;
mod sampling;
mod scheduler;
mod skeleton;
mod skin_hold;
mod transform;

pub use build::{ImportOptions, ImportReport};
pub use clip::{ChannelDesc, ChannelStats, Clip, ClipOptions, Interpolation, Keys, Property};
pub use crowd::{Crowd, FrameStats, KeyPoses, KeyUpdate, PrioritySource};
pub use error::{BuildError, CrowdError, ImportError};
pub use ids::{BoneId, CharacterId, ClipId, SkinId};
pub use lod::LodMode;
pub use mesh::{SkinBlendJob, SkinnedMesh, SkinningJob};
pub use pose_error::{ErrorSum, PoseError};
pub use pose_share::{MAX_LEVEL, PoseShare, PrepareStats, SAMPLES_PER_FINEST, SharedPose};
pub use priority::{Factor, PriorityWeights};
pub use rig::{Rig, Skin};
pub use scheduler::SchedulerParams;
pub use skeleton::{BoneDesc, MAX_BONES, Skeleton};
pub use skin_hold::{HeldSkin, SkinHoldJob, SkinHoldLayout, SkinHoldStats};
pub use transform::Transform;
