//! treecut: a multi-resolution hierarchy, the cut through it, and a budgeted evaluator.
//!
//! A [`Hierarchy`] is built once (from a regular grid or any triangle mesh) and never changes. A
//! [`Cut`] is the set of active nodes: every finest-level vertex is represented by exactly one of
//! them. [`Cut::refine`] replaces a node by its children, [`Cut::coarse`] replaces children by
//! their parent, both in O(fanout). The [`Evaluator`] turns a priority per active node into a batch
//! of those operations that best spends a [`Budget`], with hysteresis so that nothing flickers. [`uniform_cut`], [`random_cut`] and
//! [`near_vertices_cut`] are the static baselines.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod build;
mod cut;
mod error;
mod evaluator;
mod generate;
mod grid;
mod hierarchy;
mod id;
mod mesh;
mod rim;

pub use cut::Cut;
pub use error::{BuildError, CutError, EvalError, InvariantError};
pub use evaluator::{Budget, Evaluator, EvaluatorSettings, MergeKey, Op};
pub use generate::{grow_cut, grow_cut_from, near_vertices_cut, random_cut, uniform_cut};
pub use grid::GridSpec;
pub use hierarchy::Hierarchy;
pub use id::{NodeId, NodeRange};
pub use mesh::DEFAULT_AREAL_DENSITY;
pub use rim::rim_vertices;

#[cfg(test)]
mod tests;
