//! The errors this crate reports. Every fallible function validates all of its input before it
//! writes anything, so an `Err` always means "nothing was changed".

use thiserror::Error;

/// Why a [`crate::View`] could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ViewError {
    /// Position, forward, up or field of view holds a NaN or an infinity.
    #[error("camera has a non-finite position, direction or field of view")]
    NonFinite,
    /// Width or height of the viewport is zero pixels.
    #[error("camera viewport is {width}x{height} pixels; both must be at least 1")]
    ZeroViewport {
        /// Viewport width in pixels.
        width: u32,
        /// Viewport height in pixels.
        height: u32,
    },
    /// The forward direction is (nearly) the zero vector, so the camera looks nowhere.
    #[error("camera forward direction is degenerate (length {length})")]
    DegenerateForward {
        /// Length of the forward vector that was given.
        length: f32,
    },
    /// The up vector is (nearly) zero or parallel to forward, so the image has no orientation.
    #[error("camera up vector is zero or parallel to the forward direction")]
    DegenerateUp,
    /// The vertical field of view is not strictly between 0 and π radians.
    #[error("camera vertical field of view {fov_y_radians} rad is outside (0, π)")]
    FieldOfView {
        /// The field of view that was given, in radians.
        fov_y_radians: f32,
    },
    /// The near plane is not a finite distance greater than zero.
    #[error("view near plane {near} must be finite and > 0")]
    NearPlane {
        /// The near plane that was given.
        near: f32,
    },
    /// The light is invalid (non-finite, zero direction, terms outside [0, 1] or summing past 1).
    #[error("view light: {0}")]
    Light(SalienceError),
}

/// Why a salience evaluation (or a neighbour list, or a normal estimate) was refused.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SalienceError {
    /// Two per-node slices that must have one entry per node differ in length.
    #[error("{what} has {found} entries, expected {expected}")]
    LengthMismatch {
        /// Which slice is wrong (`"velocities"`, `"normals"`, `"out"`, …).
        what: &'static str,
        /// The length it must have.
        expected: usize,
        /// The length it has.
        found: usize,
    },
    /// A range of nodes to evaluate reaches past the last node.
    #[error("node range {first}..{end} is outside the {node_count} nodes")]
    RangeOutOfBounds {
        /// First node of the range.
        first: usize,
        /// One past the last node of the range.
        end: usize,
        /// Number of nodes.
        node_count: usize,
    },
    /// The CSR offsets do not have `node_count + 1` entries.
    #[error("neighbour offsets have {found} entries, expected node count + 1 = {expected}")]
    OffsetsLength {
        /// `node_count + 1`.
        expected: usize,
        /// The number of offsets given.
        found: usize,
    },
    /// The CSR offsets do not start at 0, decrease somewhere, or do not end at `indices.len()`.
    #[error("neighbour offsets are not a valid CSR row table at node {node}")]
    OffsetsNotMonotone {
        /// The first node whose row is broken (`node_count` for a wrong final offset).
        node: usize,
    },
    /// A neighbour index names a node that does not exist.
    #[error("node {node} lists neighbour {neighbour}, but there are only {node_count} nodes")]
    NeighbourOutOfRange {
        /// The node whose list holds the bad index.
        node: usize,
        /// The bad index.
        neighbour: u32,
        /// Number of nodes.
        node_count: usize,
    },
    /// More nodes or neighbour entries than a `u32` index can address.
    #[error("{count} entries do not fit a u32 index")]
    TooManyEntries {
        /// The count that overflowed.
        count: usize,
    },
    /// A parameter is NaN, infinite or outside its documented range.
    #[error("parameter {name} = {value} is invalid: {expected}")]
    InvalidParameter {
        /// The parameter's field path, e.g. `"local_motion.half_saturation_deg_per_s"`.
        name: &'static str,
        /// The value that was given.
        value: f32,
        /// What it must be.
        expected: &'static str,
    },
    /// The object's centre or velocity is not finite.
    #[error("object motion (centre or velocity) is not finite")]
    NonFiniteObjectMotion,
    /// A light was given but no normals: Lambertian shading needs the surface normal.
    #[error("a light needs per-node normals, but none were given")]
    LightWithoutNormals,
    /// The light's position or direction is not finite, or its direction is zero.
    #[error("light direction or position is not finite, or the direction is zero")]
    InvalidLight,
}
