//! Cloth lifetime and control over the C ABI: the grid and mesh descs, create/destroy, step,
//! explicit refine/coarse, pins and the feedback loop's settings. Queries are in `cloth_query`.

use glam::Vec3;
use softbody::{Material, ReconstructionMode, SolverSettings, TreeCutError, TreeCutSettings};
use treecut::{BuildError, GridSpec, Hierarchy, NodeId};

use super::arena::RawId;
use super::boundary::{arg, arg_mut, boundary, slice, write_out};
use super::ids::SlodClothId;
use super::result::{FfiError, SlodResult};
use super::world::{ClothEntry, SLOD_DESC_GUARD, SlodWorld, check_guard};
use crate::cloth::{AdaptiveCloth, ClothBudget, ClothError, FeedbackSettings, PriorityModel};

/// Most finest-level vertices a cloth may have (grid or mesh).
pub const SLOD_MAX_CLOTH_VERTICES: u32 = 1 << 22;
/// Most triangles a mesh cloth may have.
pub const SLOD_MAX_CLOTH_TRIANGLES: u32 = 1 << 24;
/// Largest magnitude of any position coordinate slod accepts (centres, vertices, anchors,
/// character positions), in world units.
pub const SLOD_MAX_COORDINATE: f32 = 1.0e6;
/// The node index meaning "no node" (the parent of the root).
pub const SLOD_NO_NODE: u32 = u32::MAX;
/// Steps within which an operation undoing an earlier one on the same node counts as undone
/// (`SlodClothStats::undone_ops`).
pub const SLOD_UNDO_WINDOW_STEPS: u32 = 30;
const _: () = assert!(SLOD_UNDO_WINDOW_STEPS as u64 == crate::cloth::UNDO_WINDOW_STEPS);

/// Time stepping and material of a cloth (part of `SlodClothDesc`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodSolverDesc {
    /// Seconds advanced by one `slod_cloth_step`, in (0, 1].
    pub dt: f32,
    /// Substeps per step, 1..=1024 (more substeps converge stiffer than more iterations).
    pub substeps: u32,
    /// Constraint sweeps per substep, 1..=1024.
    pub iterations: u32,
    /// Gravity acceleration in m/s² (finite, length |g| <= 1e4).
    pub gravity: [f32; 3],
    /// Velocity damping rate in 1/s, in [0, 1e4].
    pub damping: f32,
    /// Compliance (inverse stiffness, m/N) of every link, in [0, 1e6]; the same at every
    /// resolution, so coarse and fine cuts are the same material.
    pub stretch_compliance: f32,
    /// Steps over which a refine or coarse blends old links out and new ones in, 0..=65536.
    pub blend_steps: u32,
    /// A colour batch of at least this many links is split across the world's worker threads
    /// (same results, bit for bit); 0 = one thread. Ignored (one thread) in a world created with
    /// `worker_threads` 1. The default splits cloths of about 129×129 vertices and up.
    pub parallel_min_links: u32,
}

/// How to build a cloth. Get one from `slod_default_cloth_desc` and change what you need.
///
/// The grid fields (`columns` … `axis_v`) are used by `slod_cloth_create_grid` only;
/// `solver` and `initial_level` by both creation functions.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodClothDesc {
    /// Set by `slod_default_cloth_desc`; do not change.
    pub guard: u32,
    /// Vertices along `axis_u` (>= 2; columns × rows <= `SLOD_MAX_CLOTH_VERTICES`). Vertex
    /// (i, j) has index `j * columns + i`.
    pub columns: u32,
    /// Vertices along `axis_v` (>= 2).
    pub rows: u32,
    /// Distance between neighbouring vertices, in [1e-6, 1e4]; the whole grid (centre ± half
    /// its extent) must lie within ±`SLOD_MAX_COORDINATE`.
    pub spacing: f32,
    /// Mass of the whole cloth in kg, in (0, 1e9], spread evenly over the vertices.
    pub total_mass: f32,
    /// Rest position of the grid's centre.
    pub center: [f32; 3],
    /// Direction of the columns (normalised by slod; finite, non-zero).
    pub axis_u: [f32; 3],
    /// Direction of the rows (normalised by slod; finite, non-zero, not parallel to `axis_u`).
    pub axis_v: [f32; 3],
    /// Time stepping and material.
    pub solver: SlodSolverDesc,
    /// Level of the initial cut: 0 = every finest vertex simulated, 1 = one node per 2×2
    /// block, … (clamped to the coarsest level).
    pub initial_level: u32,
    /// How `slod_cloth_vertex_positions` places the finest vertices: a `SlodReconstruction`
    /// value (default `SLOD_RECONSTRUCTION_MLS`). Used by both creation functions.
    pub reconstruction: u32,
}

/// How a cloth's finest vertices are placed from its simulated nodes for the renderer (values
/// of `SlodClothDesc::reconstruction`). Every mode is exact where the cut is at the finest
/// level, puts pinned vertices on their anchors and keeps vertices out of the cloth's colliders.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodReconstruction {
    /// A quadratic least-squares fit to each coarse node and its linked neighbours (the
    /// default): as close as `SMOOTH` to the full-resolution cloth, a quarter of its cost.
    Mls = 0,
    /// Each coarse node's shape-matching rotation, blended with its neighbours'.
    Smooth = 1,
    /// Each coarse node's shape-matching rotation alone (cracks between patches).
    Rigid = 2,
}

impl SlodReconstruction {
    fn of(mode: ReconstructionMode) -> Self {
        match mode {
            ReconstructionMode::Mls => SlodReconstruction::Mls,
            ReconstructionMode::Smooth => SlodReconstruction::Smooth,
            ReconstructionMode::Rigid => SlodReconstruction::Rigid,
        }
    }
}

/// What the feedback loop's budget counts (values of `SlodFeedbackDesc::budget_kind`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodClothBudget {
    /// At most `budget_value` simulated nodes (an integer >= 1).
    Nodes = 0,
    /// `budget_value` is the fraction of the finest node count simulated, in (0, 1]
    /// (0.3 simulates 30% of the nodes).
    Compression = 1,
    /// `budget_value` is a target wall time per step in milliseconds (> 0, <= 1e6); a controller
    /// moves the node budget to hold it (results then depend on the machine's speed).
    TargetStepMs = 2,
    /// `budget_value` is an on-screen error bound in pixels of the world's view (> 0, <= 1e6):
    /// the loop spends the fewest nodes that keep each node's estimated on-screen deviation
    /// under it (the crowd's `SLOD_LOD_MODE_ERROR_BOUND` means the same). Deviation outside the
    /// view counts as seen while any of the cloth is in view (it reaches the screen through the
    /// cloth's motion), unless a world budget moves the bound; the BSWDF's
    /// `outside_view_weight` weighs it otherwise.
    MaxErrorPx = 3,
}

/// How salience becomes a node's priority (values of `SlodFeedbackDesc::priority`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodPriorityModel {
    /// Salience times the node's projected radius in pixels (the default).
    ScreenError = 0,
    /// The BSWDF salience alone, as in the paper.
    Salience = 1,
    /// Screen error plus the node's estimated on-screen deviation in pixels.
    ScreenDeviation = 2,
}

/// Settings of a cloth's feedback loop. Get one from `slod_default_feedback_desc`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodFeedbackDesc {
    /// Set by `slod_default_feedback_desc`; do not change.
    pub guard: u32,
    /// A `SlodClothBudget` value.
    pub budget_kind: u32,
    /// The budget's value; its meaning and range depend on `budget_kind`.
    pub budget_value: f64,
    /// Evaluate every `interval` steps, 1..=100000 (the paper's k).
    pub interval: u32,
    /// Most refine/coarse operations begun per evaluation, 0..=1048576; 0 (the default) scales
    /// the limit with the cut: a tenth of the node budget at each evaluation (at least one),
    /// 64 under `SLOD_CLOTH_BUDGET_MAX_ERROR_PX` and `SLOD_CLOTH_BUDGET_TARGET_STEP_MS`, which
    /// move the cut at a fixed pace.
    pub max_ops: u32,
    /// Minimum priority gain for moving detail, as a multiple of the simulated nodes' mean
    /// priority (finite, >= 0; default 1.5): keeps nodes from flickering.
    pub hysteresis: f32,
    /// Salience memory in seconds, in [0, 1e4] (0 turns it off).
    pub memory_seconds: f32,
    /// Weight of deformation (link strain) next to motion in the salience, in [0, 1e6]
    /// (0 turns it off; default 20: a 5% stretch weighs like fully salient motion).
    pub deformation_weight: f32,
    /// A `SlodPriorityModel` value.
    pub priority: u32,
    /// 1 lets the evaluation use the world's worker threads (the salience split over them, the
    /// measurement of `overlap_step` run beside the solver), 0 does not (ignored by a world
    /// created with one worker thread).
    pub parallel: u32,
    /// Weight of the BSWDF's motion salience, in [0, 1e6] (default 1; 0 leaves only the
    /// deformation term).
    pub motion_weight: f32,
    /// 1 (default): the camera shapes the cut; 0: salience and priorities are measured through a
    /// canonical face-on view instead (an ablation; the error-bound budget always uses the
    /// world's view).
    pub view_dependent: u32,
    /// Weight of the rim, in [0, 1e6] (default 3; 0 turns it off): on nodes covering a vertex
    /// on the cloth's boundary the stretch term of the priority (and of the error-bound
    /// estimate) counts `1 + rim_weight` times (a coarse, strained rim changes the motion of the
    /// whole cloth).
    pub rim_weight: f32,
    /// Flicker control: the fraction of operations the loop lets be undone within 30 steps, in
    /// [0, 1) (default 0.01; 0 turns it off). Undone operations raise the hysteresis (by up to
    /// ×64, decaying with a half-life of 2 s of simulated time) until they are that rare.
    pub flicker_target: f32,
    /// 1: an evaluation's measurement (most of its work) runs while its step's solver runs (on
    /// another of the world's worker threads when `parallel` is 1), and the refines and
    /// coarses it chose begin after that step instead of before it (one step later); 0
    /// (default): before the solver, on the step's thread, as the paper's loop. Results do not
    /// depend on threads (with `parallel` 0, or a world with one worker thread, the two run one
    /// after the other: the same results, no overlap). For a cloth stepped with
    /// `slod_cloth_step`, to shorten the steps that evaluate; `slod_world_step` steps its
    /// cloths in parallel already.
    pub overlap_step: u32,
}

/// The default cloth: the paper's swinging net (65×65 vertices 2 m wide, 1 kg, horizontal in
/// the XZ plane around the origin), solver at 60 Hz with 32 substeps, starting at level 1.
///
/// Returns a value the host owns; change fields, then pass it to a creation function.
#[unsafe(no_mangle)]
pub extern "C" fn slod_default_cloth_desc() -> SlodClothDesc {
    let s = TreeCutSettings::default();
    SlodClothDesc {
        guard: SLOD_DESC_GUARD,
        columns: 65,
        rows: 65,
        spacing: 2.0 / 64.0,
        total_mass: 1.0,
        center: [0.0; 3],
        axis_u: [1.0, 0.0, 0.0],
        axis_v: [0.0, 0.0, 1.0],
        solver: SlodSolverDesc {
            dt: s.solver.dt,
            substeps: s.solver.substeps,
            iterations: s.solver.iterations,
            gravity: s.solver.gravity.to_array(),
            damping: s.solver.damping,
            stretch_compliance: s.material.stretch_compliance,
            blend_steps: s.blend_steps,
            parallel_min_links: s.solver.parallel_min_links,
        },
        initial_level: 1,
        reconstruction: SlodReconstruction::of(s.reconstruction) as u32,
    }
}

/// The default feedback settings (the Rust defaults): 30% compression, evaluated every 5 steps,
/// hysteresis 1.5 × the mean priority, at most 64 operations per evaluation, 0.5 s salience memory, deformation weight
/// 20, screen-error priority, serial.
///
/// Returns a value the host owns; change fields, then pass it to `slod_cloth_set_feedback`.
#[unsafe(no_mangle)]
pub extern "C" fn slod_default_feedback_desc() -> SlodFeedbackDesc {
    let f = FeedbackSettings::default();
    let (budget_kind, budget_value) = match f.budget {
        ClothBudget::Nodes(n) => (SlodClothBudget::Nodes, n as f64),
        ClothBudget::Compression(c) => (SlodClothBudget::Compression, c as f64),
        ClothBudget::TargetStepMs(ms) => (SlodClothBudget::TargetStepMs, ms as f64),
        ClothBudget::MaxErrorPx(px) => (SlodClothBudget::MaxErrorPx, px as f64),
    };
    SlodFeedbackDesc {
        guard: SLOD_DESC_GUARD,
        budget_kind: budget_kind as u32,
        budget_value,
        interval: f.interval,
        max_ops: f.max_ops as u32,
        hysteresis: f.hysteresis,
        memory_seconds: f.memory_seconds,
        deformation_weight: f.deformation_weight,
        priority: match f.priority {
            PriorityModel::ScreenError => SlodPriorityModel::ScreenError,
            PriorityModel::Salience => SlodPriorityModel::Salience,
            PriorityModel::ScreenDeviation => SlodPriorityModel::ScreenDeviation,
        } as u32,
        parallel: u32::from(f.parallel),
        motion_weight: f.motion_weight,
        view_dependent: u32::from(f.view_dependent),
        rim_weight: f.rim_weight,
        flicker_target: f.flicker_target.unwrap_or(0.0),
        overlap_step: u32::from(f.overlap_step),
    }
}

/// Checks `lo <= v <= hi` with `v` finite, naming the argument.
pub(crate) fn in_range(v: f32, lo: f32, hi: f32, name: &'static str) -> Result<(), FfiError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(FfiError::invalid(
            name,
            format!("{v} is not finite or outside [{lo}, {hi}]"),
        ))
    }
}

/// Checks a position: finite, every coordinate within `SLOD_MAX_COORDINATE`.
pub(crate) fn position(p: [f32; 3], name: &'static str) -> Result<Vec3, FfiError> {
    if p.iter()
        .all(|c| c.is_finite() && c.abs() <= SLOD_MAX_COORDINATE)
    {
        Ok(Vec3::from(p))
    } else {
        Err(FfiError::invalid(
            name,
            format!("{p:?} is not finite or beyond ±{SLOD_MAX_COORDINATE}"),
        ))
    }
}

fn check_u32(v: u32, lo: u32, hi: u32, name: &'static str) -> Result<(), FfiError> {
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(FfiError::invalid(
            name,
            format!("{v} is outside [{lo}, {hi}]"),
        ))
    }
}

impl SlodSolverDesc {
    /// [`SlodSolverDesc::to_settings`] as `world` runs them: one thread in a world created with
    /// one worker thread (whose cloths must not touch rayon's process-wide pool, e.g. after
    /// `fork`).
    fn to_world_settings(self, world: &SlodWorld) -> Result<TreeCutSettings, FfiError> {
        let mut settings = self.to_settings()?;
        if !world.parallel_allowed() {
            settings.solver.parallel_min_links = 0;
        }
        Ok(settings)
    }

    pub(super) fn to_settings(self) -> Result<TreeCutSettings, FfiError> {
        in_range(self.dt, f32::MIN_POSITIVE, 1.0, "desc.solver.dt")?;
        check_u32(self.substeps, 1, 1024, "desc.solver.substeps")?;
        check_u32(self.iterations, 1, 1024, "desc.solver.iterations")?;
        let g = Vec3::from(self.gravity);
        if !(g.is_finite() && g.length() <= 1.0e4) {
            return Err(FfiError::invalid(
                "desc.solver.gravity",
                format!("{g} is not finite or longer than 1e4"),
            ));
        }
        in_range(self.damping, 0.0, 1.0e4, "desc.solver.damping")?;
        in_range(
            self.stretch_compliance,
            0.0,
            1.0e6,
            "desc.solver.stretch_compliance",
        )?;
        check_u32(self.blend_steps, 0, 1 << 16, "desc.solver.blend_steps")?;
        Ok(TreeCutSettings {
            solver: SolverSettings {
                dt: self.dt,
                substeps: self.substeps,
                iterations: self.iterations,
                gravity: Vec3::from(self.gravity),
                damping: self.damping,
                parallel_min_links: self.parallel_min_links,
            },
            material: Material {
                stretch_compliance: self.stretch_compliance,
                ..Material::default()
            },
            blend_steps: self.blend_steps,
            ..TreeCutSettings::default()
        })
    }
}

impl SlodClothDesc {
    /// The solver's settings with the reconstruction mode, for `world`.
    fn settings(&self, world: &SlodWorld) -> Result<TreeCutSettings, FfiError> {
        let reconstruction = match self.reconstruction {
            r if r == SlodReconstruction::Mls as u32 => ReconstructionMode::Mls,
            r if r == SlodReconstruction::Smooth as u32 => ReconstructionMode::Smooth,
            r if r == SlodReconstruction::Rigid as u32 => ReconstructionMode::Rigid,
            r => {
                return Err(FfiError::invalid(
                    "desc.reconstruction",
                    format!("{r} is not a SlodReconstruction value"),
                ));
            }
        };
        Ok(TreeCutSettings {
            reconstruction,
            ..self.solver.to_world_settings(world)?
        })
    }

    fn grid_spec(&self) -> Result<GridSpec, FfiError> {
        check_u32(self.columns, 2, SLOD_MAX_CLOTH_VERTICES, "desc.columns")?;
        check_u32(self.rows, 2, SLOD_MAX_CLOTH_VERTICES, "desc.rows")?;
        if self.columns as u64 * self.rows as u64 > SLOD_MAX_CLOTH_VERTICES as u64 {
            return Err(FfiError::invalid(
                "desc.rows",
                format!("columns × rows exceeds {SLOD_MAX_CLOTH_VERTICES} vertices"),
            ));
        }
        in_range(self.spacing, 1.0e-6, 1.0e4, "desc.spacing")?;
        in_range(self.total_mass, f32::MIN_POSITIVE, 1.0e9, "desc.total_mass")?;
        let center = position(self.center, "desc.center")?;
        let axis = |a: [f32; 3], name| {
            let v = Vec3::from(a);
            if v.is_finite() && v.length() > 1.0e-6 && v.length().is_finite() {
                Ok(v.normalize())
            } else {
                Err(FfiError::invalid(name, "must be finite and non-zero"))
            }
        };
        let u = axis(self.axis_u, "desc.axis_u")?;
        let v = axis(self.axis_v, "desc.axis_v")?;
        if u.cross(v).length() < 1.0e-3 {
            return Err(FfiError::invalid("desc.axis_v", "parallel to axis_u"));
        }
        let (u, v) = (u * self.spacing, v * self.spacing);
        let half = 0.5 * (self.columns - 1) as f32 * u + 0.5 * (self.rows - 1) as f32 * v;
        let across = 0.5 * (self.columns - 1) as f32 * u - 0.5 * (self.rows - 1) as f32 * v;
        for corner in [
            center + half,
            center - half,
            center + across,
            center - across,
        ] {
            if !(corner.is_finite() && corner.abs().max_element() <= SLOD_MAX_COORDINATE) {
                return Err(FfiError::invalid(
                    "desc.spacing",
                    format!(
                        "the grid reaches {corner}, beyond ±{SLOD_MAX_COORDINATE} (centre ± half \
                         the extent)"
                    ),
                ));
            }
        }
        Ok(GridSpec {
            cols: self.columns,
            rows: self.rows,
            origin: center - half,
            u,
            v,
            vertex_mass: self.total_mass / (self.columns as f32 * self.rows as f32),
        })
    }
}

/// The desc behind a pointer, guard checked.
///
/// # Safety
/// `desc` NULL or valid for a read.
unsafe fn read_desc(desc: *const SlodClothDesc) -> Result<SlodClothDesc, FfiError> {
    // SAFETY: forwarded from the caller's contract.
    let desc = *unsafe { arg(desc, "desc") }?;
    check_guard(desc.guard, "desc")?;
    Ok(desc)
}

/// A hierarchy or cloth error from creation, naming the argument at fault.
fn build_error(e: ClothError) -> FfiError {
    match e {
        ClothError::Build(b) => {
            let name = match b {
                BuildError::Empty(_) | BuildError::BadGridSize { .. } => "vertex_count",
                BuildError::NonFinitePosition(_) => "positions",
                BuildError::InvalidMass { .. } | BuildError::MassCountMismatch { .. } => "masses",
                BuildError::BadGridAxes => "desc.axis_u",
                _ => "triangles",
            };
            FfiError::invalid(name, b)
        }
        other => FfiError::invalid("desc", other),
    }
}

/// An error from an operation on a live cloth: state conflicts are `REFUSED`.
pub(crate) fn cloth_error(e: ClothError) -> FfiError {
    match e {
        ClothError::Body(TreeCutError::VertexOutOfRange { vertex, count }) => FfiError::invalid(
            "vertex",
            format!("{vertex} is out of range ({count} vertices)"),
        ),
        other => FfiError::Refused(other.to_string()),
    }
}

fn insert(world: &mut SlodWorld, cloth: AdaptiveCloth) -> SlodClothId {
    world
        .cloths
        .insert(ClothEntry {
            cloth,
            contacts: Default::default(),
        })
        .into()
}

/// Creates a grid cloth (a quadtree hierarchy over `columns × rows` vertices) and writes its id.
///
/// Ownership: the world owns the cloth; destroy it with `slod_cloth_destroy` or with the world.
/// The desc is copied. Threads: mutates the world. Errors: `SLOD_RESULT_INVALID_ARGUMENT` names
/// the bad desc field (`desc` for a missing guard); nothing is created.
///
/// # Safety
/// `world` NULL or a live world; `desc` NULL or valid; `out_cloth` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_create_grid(
    world: *mut SlodWorld,
    desc: *const SlodClothDesc,
    out_cloth: *mut SlodClothId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid desc.
        let desc = unsafe { read_desc(desc) }?;
        let spec = desc.grid_spec()?;
        let settings = desc.settings(world)?;
        if out_cloth.is_null() {
            return Err(FfiError::Null("out_cloth"));
        }
        let cloth =
            AdaptiveCloth::grid(&spec, desc.initial_level, settings).map_err(build_error)?;
        let id = insert(world, cloth);
        // SAFETY: checked non-NULL; valid for a write per the caller contract.
        unsafe { write_out(out_cloth, id, "out_cloth") }
    })
}

/// Creates a cloth from the host's own triangle mesh and writes its id.
///
/// `positions` holds `vertex_count` rest positions as 3 floats each (x, y, z; stride 3
/// floats), `triangles` holds `triangle_count` index triples (stride 3 indices), `masses` is NULL (each vertex gets a third of its triangles'
/// area times 1 kg/m²) or holds `vertex_count` masses (finite, > 0). The mesh must be
/// connected and use every vertex. Uses `desc->solver` and `desc->initial_level`; the grid
/// fields are ignored. Vertex indices are the host's: pins, reconstructed positions and
/// `slod_cloth_vertex_count` follow them.
///
/// Ownership: the arrays are read during the call only (the host keeps them); the world owns the
/// cloth. Threads: mutates the world. Errors: `SLOD_RESULT_INVALID_ARGUMENT` names the bad
/// argument (`positions`, `triangles`, `masses`, `vertex_count`, a desc field); nothing is created.
///
/// # Safety
/// `world` NULL or a live world; `desc` NULL or valid; `positions` valid for `3 × vertex_count`
/// float reads, `triangles` for `3 × triangle_count` index reads, `masses` NULL or valid for `vertex_count`
/// reads; `out_cloth` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_create_mesh(
    world: *mut SlodWorld,
    desc: *const SlodClothDesc,
    positions: *const f32,
    vertex_count: usize,
    triangles: *const u32,
    triangle_count: usize,
    masses: *const f32,
    out_cloth: *mut SlodClothId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid desc.
        let desc = unsafe { read_desc(desc) }?;
        let settings = desc.settings(world)?;
        // Sizes first: a huge count is refused before its pointer is touched.
        if vertex_count < 3 || vertex_count > SLOD_MAX_CLOTH_VERTICES as usize {
            return Err(FfiError::invalid(
                "vertex_count",
                format!("{vertex_count} is outside [3, {SLOD_MAX_CLOTH_VERTICES}]"),
            ));
        }
        if triangle_count == 0 || triangle_count > SLOD_MAX_CLOTH_TRIANGLES as usize {
            return Err(FfiError::invalid(
                "triangle_count",
                format!("{triangle_count} is outside [1, {SLOD_MAX_CLOTH_TRIANGLES}]"),
            ));
        }
        // SAFETY: caller contract: valid for `3 × vertex_count` float reads (NULL checked
        // inside); `[f32; 3]` has the size of 3 floats and the alignment of one, so the same
        // memory read as `vertex_count` triples is the same reads.
        let positions = unsafe { slice(positions.cast::<[f32; 3]>(), vertex_count, "positions") }?;
        // SAFETY: as above, for `3 × triangle_count` u32 reads as `[u32; 3]` triples.
        let triangles =
            unsafe { slice(triangles.cast::<[u32; 3]>(), triangle_count, "triangles") }?;
        let masses = if masses.is_null() {
            None
        } else {
            // SAFETY: caller contract: a non-NULL `masses` is valid for `vertex_count` reads.
            let m = unsafe { slice(masses, vertex_count, "masses") }?;
            for &x in m {
                in_range(x, f32::MIN_POSITIVE, 1.0e9, "masses")?;
            }
            Some(m)
        };
        if out_cloth.is_null() {
            return Err(FfiError::Null("out_cloth"));
        }
        let mut points = Vec::with_capacity(vertex_count);
        for &p in positions {
            points.push(position(p, "positions")?);
        }
        let cloth = if desc.initial_level == 0 {
            AdaptiveCloth::from_mesh(&points, triangles, masses, settings).map_err(build_error)?
        } else {
            let h = Hierarchy::from_mesh(&points, triangles, masses)
                .map_err(|e| build_error(e.into()))?;
            // The same orientation `from_mesh` uses: the area-weighted mean normal.
            let mut normal = Vec3::ZERO;
            for t in triangles {
                let [a, b, c] = t.map(|i| points[i as usize]);
                normal += (b - a).cross(c - a);
            }
            let cut = treecut::Cut::uniform(&h, desc.initial_level);
            AdaptiveCloth::new(h, cut, settings, normal).map_err(build_error)?
        };
        let id = insert(world, cloth);
        // SAFETY: checked non-NULL; valid for a write per the caller contract.
        unsafe { write_out(out_cloth, id, "out_cloth") }
    })
}

/// Destroys a cloth; its id (and every copy) is stale afterwards.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID` if `cloth` is not a live cloth of
/// this world (nothing happens).
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_destroy(
    world: *mut SlodWorld,
    cloth: SlodClothId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        world.cloths.remove(RawId::from(cloth), "cloth")?;
        super::world_budget::forget_cloth(world, RawId::from(cloth));
        Ok(())
    })
}

/// The live cloth behind an id.
pub(crate) fn cloth_mut(
    world: &mut SlodWorld,
    id: SlodClothId,
) -> Result<&mut ClothEntry, FfiError> {
    world.cloths.get_mut(RawId::from(id), "cloth")
}

/// Advances a cloth by one step of `desc.solver.dt` seconds.
///
/// The cloth sees the world's current view (camera and light). With feedback on, every
/// `interval` steps the step also measures salience and begins the refines and coarses the
/// evaluator chose; transitions whose blend is done end inside the step. A cloth worn by a
/// character (`slod_cloth_pin_vertex_to_bone`, `slod_cloth_collider_attach_to_bone`) first
/// moves its bone pins and colliders to the character's current pose. Threads: mutates the
/// world; with feedback `parallel` the salience stage uses the world's worker threads. Errors:
/// `SLOD_RESULT_STALE_ID` (also when the character wearing the cloth was destroyed: release it
/// with `slod_cloth_detach_character`); `SLOD_RESULT_REFUSED` if the feedback stage refused its
/// inputs (nothing stepped; with the desc's `overlap_step`, a refusal after the measurement
/// began is reported after the step ran, its operations not begun).
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_step(world: *mut SlodWorld, cloth: SlodClothId) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        on_world_threads(world, cloth, |c, view| c.step(view))
    })
}

/// Runs `f` on a cloth with the world's view, on the world's threads, after moving a worn
/// cloth's bone pins and colliders to its character's pose (what a step or its evaluation sees).
fn on_world_threads<T: Send>(
    world: &mut SlodWorld,
    cloth: SlodClothId,
    f: impl FnOnce(&mut AdaptiveCloth, &salience::View) -> Result<T, ClothError> + Send,
) -> Result<T, FfiError> {
    super::collider::follow_character(world, cloth)?;
    let view = world.view;
    let pool = world.pool.as_ref();
    let entry = world.cloths.get_mut(RawId::from(cloth), "cloth")?;
    let c = &mut entry.cloth;
    SlodWorld::run(pool, || f(c, &view)).map_err(cloth_error)
}

/// Runs now the feedback evaluation the cloth's next `slod_cloth_step` is due to run, and that
/// step then skips it; writes whether one ran (false: none due, or one already ran ahead).
///
/// For a host whose frames are shorter than the cloth's step (a 120 Hz host stepping a 60 Hz
/// cloth every other frame): an evaluation costs most of a step, and run in the step's frame
/// it makes that frame the longest; run in the frame between, it evens the two. Nothing of the
/// cloth moves between its steps, so the evaluation measures the state the step would, seen
/// through the world's current view, and its refines and coarses begin now, to blend from the
/// next step on. `slod_world_step` spreads its cloths' evaluations over its frames itself (in
/// parts: `slod_cloth_evaluate_ahead_part`).
/// Threads: mutates the world; with feedback `parallel` the salience stage uses the world's
/// worker threads. Errors: `SLOD_RESULT_STALE_ID`; `SLOD_RESULT_REFUSED` if the feedback stage
/// refused its inputs (`*out_evaluated` then false); `SLOD_RESULT_NULL_ARGUMENT` for a NULL
/// `out_evaluated` (nothing run).
///
/// # Safety
/// `world` NULL or a live world; `out_evaluated` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_evaluate_ahead(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    out_evaluated: *mut bool,
) -> SlodResult {
    boundary(|| {
        if out_evaluated.is_null() {
            return Err(FfiError::Null("out_evaluated"));
        }
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: non-NULL (checked above), valid for a write per the caller contract.
        unsafe { out_evaluated.write(false) };
        let ran = on_world_threads(world, cloth, |c, view| c.evaluate_ahead(view))?;
        // SAFETY: as above.
        unsafe { write_out(out_evaluated, ran.is_some(), "out_evaluated") }
    })
}

/// Measures now part of the evaluation the cloth's next `slod_cloth_step` is due to run: its
/// nodes up to `fraction` of them (in [0, 1]), and writes whether a part ran (false: none due,
/// one already ran ahead, or the cloth's feedback budget is not
/// `SLOD_CLOTH_BUDGET_MAX_ERROR_PX`, whose measurement alone is split).
///
/// For a host whose frames are a fraction of the cloth's step (a 240 Hz host stepping a 60 Hz
/// cloth every fourth frame): call it on the frames between two steps with 1/4, 2/4, 3/4 and
/// the step finishes the rest, so the evaluation's cost is spread evenly over the four frames
/// instead of landing on one. Nothing of the cloth moves between its steps, so every part
/// measures one state, through the first part's view: the result is the evaluation
/// `slod_cloth_evaluate_ahead` would have run at the first part. Anything that changes the
/// cloth in between (pins, refine, coarse) drops the parts and the step measures again.
/// `slod_world_step` does this itself for its cloths: over the frames between their steps when
/// its `dt` is shorter than theirs, else half in the frame before each evaluating step.
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`; `SLOD_RESULT_INVALID_ARGUMENT`
/// for a NaN `fraction` (nothing run); `SLOD_RESULT_NULL_ARGUMENT` for a NULL `out_ran`.
///
/// # Safety
/// `world` NULL or a live world; `out_ran` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_evaluate_ahead_part(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    fraction: f32,
    out_ran: *mut bool,
) -> SlodResult {
    boundary(|| {
        if out_ran.is_null() {
            return Err(FfiError::Null("out_ran"));
        }
        if fraction.is_nan() {
            return Err(FfiError::invalid("fraction", "must be a number in [0, 1]"));
        }
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: non-NULL (checked above), valid for a write per the caller contract.
        unsafe { out_ran.write(false) };
        let ran = on_world_threads(world, cloth, |c, view| {
            c.evaluate_ahead_part(view, fraction)
        })?;
        // SAFETY: as above.
        unsafe { write_out(out_ran, ran.is_some(), "out_ran") }
    })
}

fn check_node(entry: &ClothEntry, node: u32) -> Result<NodeId, FfiError> {
    let len = entry.cloth.hierarchy().len();
    if (node as usize) < len {
        Ok(NodeId::from_raw(node))
    } else {
        Err(FfiError::invalid(
            "node",
            format!("{node} is not a node of this cloth ({len} nodes)"),
        ))
    }
}

/// Begins refining hierarchy node `node` (replacing it by its children over `blend_steps` steps).
///
/// Node indices come from `slod_cloth_active_nodes` / `slod_cloth_node_ids` /
/// `slod_cloth_node_info`. Threads: mutates the world. Errors: `SLOD_RESULT_INVALID_ARGUMENT` for
/// an index outside the hierarchy; `SLOD_RESULT_REFUSED` (nothing changed) if the node is not on
/// the cut, is a leaf, or is locked by a transition in flight.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_refine(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    node: u32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let entry = cloth_mut(world, cloth)?;
        let n = check_node(entry, node)?;
        entry.cloth.refine(n).map_err(cloth_error)
    })
}

/// Begins coarsening hierarchy node `node` (replacing its children, all on the cut, by it).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_INVALID_ARGUMENT` for an index outside the
/// hierarchy; `SLOD_RESULT_REFUSED` (nothing changed) unless all its children are on the cut and
/// neither they nor it are locked.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_coarse(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    node: u32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let entry = cloth_mut(world, cloth)?;
        let n = check_node(entry, node)?;
        entry.cloth.coarse(n).map_err(cloth_error)
    })
}

/// Pins finest vertex `vertex` at (`x`, `y`, `z`), or moves its pin there.
///
/// The node covering the vertex becomes a kinematic anchor reaching the new position over the
/// next step; pins follow their vertex through refines and coarses. Threads: mutates the world.
/// Errors: `SLOD_RESULT_INVALID_ARGUMENT` for a vertex out of range or a coordinate not finite or
/// beyond `SLOD_MAX_COORDINATE`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_pin_vertex(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    vertex: u32,
    x: f32,
    y: f32,
    z: f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let entry = cloth_mut(world, cloth)?;
        let anchor = position([x, y, z], "anchor (x, y, z)")?;
        entry
            .cloth
            .body_mut()
            .pin_vertex(vertex, anchor)
            .map_err(|e| cloth_error(e.into()))
    })
}

/// Releases the pin of finest vertex `vertex` (no effect if it is not pinned).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_INVALID_ARGUMENT` for a vertex out of range.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_unpin_vertex(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    vertex: u32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let entry = cloth_mut(world, cloth)?;
        entry
            .cloth
            .body_mut()
            .unpin_vertex(vertex)
            .map_err(|e| cloth_error(e.into()))
    })
}

impl SlodFeedbackDesc {
    pub(super) fn to_settings(self, parallel_allowed: bool) -> Result<FeedbackSettings, FfiError> {
        check_guard(self.guard, "desc")?;
        let v = self.budget_value;
        let budget = match self.budget_kind {
            0 => {
                if !(v.is_finite() && v >= 1.0 && v <= u32::MAX as f64 && v.fract() == 0.0) {
                    return Err(FfiError::invalid(
                        "desc.budget_value",
                        format!("{v} is not a whole node count in [1, 2^32)"),
                    ));
                }
                ClothBudget::Nodes(v as usize)
            }
            1 => {
                if !(v.is_finite() && v > 0.0 && v <= 1.0) {
                    return Err(FfiError::invalid(
                        "desc.budget_value",
                        format!("compression {v} is outside (0, 1]"),
                    ));
                }
                ClothBudget::Compression(v as f32)
            }
            2 => {
                if !(v.is_finite() && v > 0.0 && v <= 1.0e6) {
                    return Err(FfiError::invalid(
                        "desc.budget_value",
                        format!("target {v} ms is outside (0, 1e6]"),
                    ));
                }
                ClothBudget::TargetStepMs(v as f32)
            }
            3 => {
                if !(v.is_finite() && v > 0.0 && v <= 1.0e6) {
                    return Err(FfiError::invalid(
                        "desc.budget_value",
                        format!("error bound {v} px is outside (0, 1e6]"),
                    ));
                }
                ClothBudget::MaxErrorPx(v as f32)
            }
            k => {
                return Err(FfiError::invalid(
                    "desc.budget_kind",
                    format!("{k} is not a SlodClothBudget value"),
                ));
            }
        };
        check_u32(self.interval, 1, 100_000, "desc.interval")?;
        check_u32(self.max_ops, 0, 1 << 20, "desc.max_ops")?;
        in_range(self.hysteresis, 0.0, f32::MAX, "desc.hysteresis")?;
        in_range(self.memory_seconds, 0.0, 1.0e4, "desc.memory_seconds")?;
        in_range(
            self.deformation_weight,
            0.0,
            1.0e6,
            "desc.deformation_weight",
        )?;
        let priority = match self.priority {
            0 => PriorityModel::ScreenError,
            1 => PriorityModel::Salience,
            2 => PriorityModel::ScreenDeviation,
            p => {
                return Err(FfiError::invalid(
                    "desc.priority",
                    format!("{p} is not a SlodPriorityModel value"),
                ));
            }
        };
        check_u32(self.parallel, 0, 1, "desc.parallel")?;
        in_range(self.motion_weight, 0.0, 1.0e6, "desc.motion_weight")?;
        check_u32(self.view_dependent, 0, 1, "desc.view_dependent")?;
        in_range(self.rim_weight, 0.0, 1.0e6, "desc.rim_weight")?;
        check_u32(self.overlap_step, 0, 1, "desc.overlap_step")?;
        if !(self.flicker_target.is_finite() && (0.0..1.0).contains(&self.flicker_target)) {
            return Err(FfiError::invalid(
                "desc.flicker_target",
                format!("{} is not finite or outside [0, 1)", self.flicker_target),
            ));
        }
        let settings = FeedbackSettings {
            interval: self.interval,
            budget,
            hysteresis: self.hysteresis,
            max_ops: self.max_ops as usize,
            priority,
            memory_seconds: self.memory_seconds,
            deformation_weight: self.deformation_weight,
            parallel: self.parallel == 1 && parallel_allowed,
            motion_weight: self.motion_weight,
            view_dependent: self.view_dependent == 1,
            rim_weight: self.rim_weight,
            flicker_target: (self.flicker_target > 0.0).then_some(self.flicker_target),
            overlap_step: self.overlap_step == 1,
            ..FeedbackSettings::default()
        };
        settings
            .validate()
            .map_err(|e| FfiError::invalid("desc", e))?;
        Ok(settings)
    }
}

/// Turns a cloth's feedback loop on (or changes its settings).
///
/// From the next step on the cloth measures what the world's view sees every `interval` steps
/// and moves its cut under the budget (set the camera with `slod_world_set_camera`; until then
/// the world's default view is used). Threads: mutates the world. Errors:
/// `SLOD_RESULT_INVALID_ARGUMENT` names the bad desc field. Nothing changes on error.
///
/// # Safety
/// `world` NULL or a live world; `desc` NULL or valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_set_feedback(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    desc: *const SlodFeedbackDesc,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid desc.
        let desc = *unsafe { arg(desc, "desc") }?;
        let parallel = world.parallel_allowed();
        let entry = cloth_mut(world, cloth)?;
        let settings = desc.to_settings(parallel)?;
        entry
            .cloth
            .set_feedback(Some(settings))
            .map_err(cloth_error)
    })
}

/// Turns a cloth's feedback loop off; the cut stays where it is (no effect if it was off).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_disable_feedback(
    world: *mut SlodWorld,
    cloth: SlodClothId,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        cloth_mut(world, cloth)?
            .cloth
            .set_feedback(None)
            .map_err(cloth_error)
    })
}
