//! The C ABI: handle-based functions over the composed systems, following the conventions of
//! DESIGN.md (prefix `slod_`, by-value generational ids, `*Desc` structs from
//! `slod_default_*_desc`, `SlodResult` codes with a thread-local message, caller-owned buffers).
//!
//! This is the only module of slod that contains `unsafe` code or `extern "C"` items. Every
//! function body runs inside `boundary::boundary`, so no panic crosses into C.
//!
//! Files by subject: [`world`] (world, versions, desc guard), [`world_budget`] (the world
//! step under one frame budget, per-object shares), [`view`] (camera, light),
//! [`cloth`] and [`cloth_query`] (adaptive cloth), [`collider`] (colliders, wind, cloth worn
//! by a character), [`rig`], [`crowd`], [`character`] and
//! [`held_skin`] (animation), [`result`] (codes and the last error).

// Declaration order is the order of the generated header: basics first, then cloth, then
// animation (separate groups, so rustfmt keeps it).
mod arena;
mod boundary;
pub mod ids;
pub mod result;

pub mod world;

pub mod world_budget;

pub mod view;

pub mod cloth;

pub mod cloth_query;

pub mod collider;

pub mod rig;

pub mod crowd;

pub mod character;

pub mod held_skin;

pub mod pose_share;

#[cfg(test)]
mod defaults_tests;

#[cfg(test)]
mod contract_tests;

#[cfg(test)]
mod collider_tests;

pub use character::*;
pub use cloth::*;
pub use cloth_query::*;
pub use collider::*;
pub use crowd::*;
pub use held_skin::*;
pub use ids::{SlodCharacterId, SlodClothId, SlodCrowdId, SlodRigId};
pub use pose_share::*;
pub use result::{SlodResult, slod_last_error, slod_result_str};
pub use rig::*;
pub use view::*;
pub use world::*;
pub use world_budget::*;
