//! Error enums: every refused build, cut operation or evaluation says exactly why.

use crate::NodeId;

/// Why a hierarchy could not be built from the given grid or mesh.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// The grid or mesh has no vertex or no triangle.
    #[error("empty input: {0}")]
    Empty(&'static str),
    /// A grid dimension is zero or the grid is too large to index with 32 bits.
    #[error(
        "grid of {cols}x{rows} vertices is not supported (each side >= 1, at most 2^30 vertices)"
    )]
    BadGridSize {
        /// Columns asked for.
        cols: u32,
        /// Rows asked for.
        rows: u32,
    },
    /// A grid axis is zero, not finite, or parallel to the other.
    #[error("grid axes must be finite, non-zero and not parallel")]
    BadGridAxes,
    /// A position is NaN or infinite.
    #[error("vertex {0} has a non-finite position")]
    NonFinitePosition(u32),
    /// A mass is not finite and positive, or the mass slice has the wrong length.
    #[error("vertex {vertex} has invalid mass {mass} (must be finite and > 0)")]
    InvalidMass {
        /// The vertex whose mass is wrong.
        vertex: u32,
        /// The mass found (area-lumped when no masses were given).
        mass: f32,
    },
    /// The mass slice does not have one entry per vertex.
    #[error("{masses} masses given for {vertices} vertices")]
    MassCountMismatch {
        /// Masses given.
        masses: usize,
        /// Vertices in the mesh.
        vertices: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index}, but the mesh has {vertices} vertices")]
    IndexOutOfRange {
        /// The offending triangle.
        triangle: u32,
        /// The out-of-range index.
        index: u32,
        /// Vertex count of the mesh.
        vertices: u32,
    },
    /// A triangle uses the same vertex twice.
    #[error("triangle {0} repeats a vertex")]
    DegenerateTriangle(u32),
    /// The mesh falls apart into several pieces (or has vertices no triangle uses).
    ///
    /// A hierarchy is one tree whose every node is a connected patch; separate pieces would need
    /// separate cloths, so the caller builds one hierarchy per piece.
    #[error(
        "mesh has {components} disconnected parts (vertex {example} is not connected to vertex 0); build one hierarchy per part"
    )]
    Disconnected {
        /// Number of connected components (unused vertices count as one each).
        components: usize,
        /// A vertex outside the component of vertex 0.
        example: u32,
    },
}

/// Why a cut operation was refused. A refused operation leaves the cut exactly as it was.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum CutError {
    /// The id is not a node of this hierarchy.
    #[error("{0} does not exist in this hierarchy")]
    OutOfRange(NodeId),
    /// The node to refine is not on the cut.
    #[error("{0} is not on the cut")]
    NotOnCut(NodeId),
    /// The node has no children to refine into or coarsen from.
    #[error("{0} is a leaf")]
    IsLeaf(NodeId),
    /// Coarsening needs every child of the parent on the cut.
    #[error("not all children of {0} are on the cut")]
    ChildrenNotOnCut(NodeId),
    /// The node (or one of the children involved) is locked by a transition in flight.
    #[error("{0} is locked by a transition in flight")]
    Locked(NodeId),
    /// Unlock of a node that holds no lock.
    #[error("{0} is not locked")]
    NotLocked(NodeId),
    /// A node list given to build a cut does not cover every leaf exactly once.
    #[error("the nodes do not form a cut: leaf {0} is covered {1} times")]
    NotACut(NodeId, u32),
}

/// A broken cut invariant, found by [`crate::Cut::check_invariant`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum InvariantError {
    /// A leaf's path to the root crosses the cut other than exactly once.
    #[error("leaf {leaf} crosses the cut {crossings} times on its way to the root")]
    Crossings {
        /// The leaf.
        leaf: NodeId,
        /// How many nodes of its root path are on the cut.
        crossings: u32,
    },
    /// The active list and the per-node membership disagree.
    #[error("active list and membership disagree at {0}")]
    Bookkeeping(NodeId),
    /// The cut was made for a hierarchy of another size.
    #[error("cut has {cut} nodes of bookkeeping but the hierarchy has {hierarchy}")]
    WrongHierarchy {
        /// Node count the cut was built for.
        cut: usize,
        /// Node count of the hierarchy given.
        hierarchy: usize,
    },
}

/// Why an evaluation was refused.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum EvalError {
    /// A per-node slice does not have one entry per hierarchy node.
    #[error("{what} has {got} entries, the hierarchy has {expected} nodes")]
    LengthMismatch {
        /// Which slice.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The hierarchy's node count.
        expected: usize,
    },
    /// An active node's priority is NaN or infinite.
    #[error("priority of {0} is not finite")]
    NonFinitePriority(NodeId),
    /// A node's cost is negative, NaN or infinite.
    #[error("cost of {0} is not finite and >= 0")]
    InvalidCost(NodeId),
    /// A cost budget was asked for without costs.
    #[error("Budget::Cost needs per-node costs")]
    MissingCosts,
    /// The budget itself is NaN or negative.
    #[error("budget limit must be finite and >= 0")]
    InvalidBudget,
    /// The hysteresis threshold is negative or not finite.
    #[error("hysteresis must be finite and >= 0")]
    InvalidHysteresis,
    /// The cut was made for another hierarchy.
    #[error("the cut was made for a hierarchy of another size")]
    WrongHierarchy,
}
