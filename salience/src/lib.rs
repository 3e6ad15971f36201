//! BSWDF salience: turns motion, lighting and the camera into a priority per node, and the view
//! measures (distance, projected size, angular speed) that the cloth and the crowd share.
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
//! let camera = Camera::look_at(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, Vec3::Y, 1.0, 1280, 720)?;
//! // Three nodes in a row; the middle one moves, its neighbours stand still.
//! let positions = [Vec3::new(-0.1, 0.0, 0.0), Vec3::ZERO, Vec3::new(0.1, 0.0, 0.0)];
//! let velocities = [Vec3::ZERO, Vec3::Y * 0.5, Vec3::ZERO];
//! let lists = NeighbourLists::from_undirected_edges(3, &[[0, 1], [1, 2]])?;
//! let params = BswdfParams::default();
//! let view = View {
//!     camera: &camera,
//!     light: None,
//!     object: ObjectMotion::mean_of(&positions, &velocities)?,
//!     params: &params,
//! };
//! let nodes = Nodes { positions: &positions, velocities: &velocities, normals: None };
//! let mut salience = [0.0; 3];
//! evaluate(&view, &nodes, &lists.as_neighbours(), &mut salience)?;
//! assert!(salience[1] > salience[0]);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bswdf;
mod camera;
mod curves;
mod error;
mod light;
mod motion;
mod neighbours;
mod normals;
#[cfg(feature = "rayon")]
mod parallel;
mod params;

pub use bswdf::{Nodes, View, evaluate, evaluate_range};
pub use camera::{Camera, MIN_VIEW_DISTANCE};
pub use curves::{PursuitCap, ResponseCurve};
pub use error::{CameraError, SalienceError};
pub use light::{Light, LightSource};
pub use motion::{GlobalMotion, ObjectMotion};
pub use neighbours::{NeighbourLists, Neighbours};
pub use normals::estimate_normals;
#[cfg(feature = "rayon")]
pub use parallel::{PARALLEL_CHUNK, evaluate_parallel};
pub use params::{BswdfParams, Sidedness};
