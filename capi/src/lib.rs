//! slod composed: the adaptive cloth (the simulation paper's closed loop) and the animation
//! crowd for Rust users, and the C ABI over them.
//!
//! Rust users work with [`cloth::AdaptiveCloth`] and [`animlod::Crowd`] directly; C and C++ hosts
//! use the same through `include/slod.h`, generated from [`ffi`].
#![warn(missing_docs)]

pub mod cloth;
pub mod ffi;
pub mod world;

pub use animlod;
pub use salience;
pub use softbody;
pub use treecut;
