//! The View and BSWDF salience: [`View`] is the one description of who looks (camera, viewport,
//! near plane, optional light) with the view measures every slod crate uses (distance, pixels
//! per unit at a point, projected radius, angular speed, projection, in-view tests), and the
//! BSWDF turns motion, lighting and the view into a salience per node.
//!
//! The simulation-LOD paper (section 4) defines
//! `BSWDF(ωC, ωL, dC, x) = Illu(ωL, x) ∘ (GlobalMotion(ωC, dC) ⊗ LocalMotion(ωC, dC, x))` but
//! leaves the curves open. This crate fixes them from what a viewer perceives; the formula is in
//! [`bswdf`] and every constant, with its unit and the reason for its default, on
//! [`BswdfParams`].
//!
//! Everything is a pure function over slices: no state but parameters, no allocation per call,
//! and every refused call leaves its output untouched.
//!
//! ```
//! use glam::Vec3;
//! use salience::*;
//!
//! let view = View::look_at(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, Vec3::Y, 1.0, 1280, 720)?;
//! // Three nodes in a row; the middle one moves, its neighbours stand still.
//! let positions = [Vec3::new(-0.1, 0.0, 0.0), Vec3::ZERO, Vec3::new(0.1, 0.0, 0.0)];
//! let velocities = [Vec3::ZERO, Vec3::Y * 0.5, Vec3::ZERO];
//! let lists = NeighbourLists::from_undirected_edges(3, &[[0, 1], [1, 2]])?;
//! let params = BswdfParams::default();
//! let job = BswdfJob {
//!     view: &view,
//!     object: ObjectMotion::mean_of(&positions, &velocities)?,
//!     params: &params,
//!     nodes: Nodes { positions: &positions, velocities: &velocities, normals: None },
//!     neighbours: lists.as_neighbours(),
//! };
//! let mut salience = [0.0; 3];
//! evaluate(&job, &mut salience)?;
//! assert!(salience[1] > salience[0]);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bswdf;
mod curves;
mod error;
mod light;
mod motion;
mod neighbours;
mod normals;
#[cfg(feature = "rayon")]
mod parallel;
mod params;
mod view;

pub use bswdf::{BswdfJob, Nodes, evaluate, evaluate_range};
pub use curves::{PursuitCap, ResponseCurve};
pub use error::{SalienceError, ViewError};
pub use light::{Light, LightSource};
pub use motion::{GlobalMotion, ObjectMotion};
pub use neighbours::{NeighbourLists, Neighbours};
pub use normals::estimate_normals;
#[cfg(feature = "rayon")]
pub use parallel::{PARALLEL_CHUNK, evaluate_parallel};
pub use params::{BswdfParams, Sidedness};
pub use view::{DEFAULT_NEAR, MIN_VIEW_DISTANCE, View};
