//! Priority-based LOD for skeletal animation: glTF rigs, per-keyframe bone priorities, a scheduler.
#![forbid(unsafe_code)]
#![warn(missing_docs)]
