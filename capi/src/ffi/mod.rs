//! The C ABI: handle-based functions over the composed systems, following the conventions of
//! DESIGN.md (prefix `slod_`, by-value generational ids, `*Desc` structs from
//! `slod_default_*_desc`, `SlodResult` codes with a thread-local message, caller-owned buffers).
//!
//! This is the only module of slod that contains `unsafe` code or `extern "C"` items. Every
//! function body runs inside [`boundary::boundary`], so no panic crosses into C.

mod arena;
mod boundary;
pub mod ids;
pub mod result;
pub mod view;
pub mod world;

pub use ids::{SlodCharacterId, SlodClothId, SlodCrowdId, SlodRigId};
pub use result::SlodResult;
pub use view::{SlodCamera, SlodLight, SlodLightKind};
pub use world::{SlodWorld, SlodWorldDesc};
