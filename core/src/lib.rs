//! The small pieces every slod crate shares, at the bottom of the workspace so that each crate
//! states them once:
//!
//! * [`index_type!`] — an index newtype (`NodeId`, `BoneId`, …): a `u32` with a private field,
//!   so an index of one kind cannot be used where another is expected and no crate reaches
//!   into the raw value by accident.
//! * [`Arena`] — a generational arena: values addressed by [`Handle`]s (slot index plus
//!   generation) that go stale when their value is removed, even after the slot is reused.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod arena;
mod index;

pub use arena::{Arena, Generations, Handle};
