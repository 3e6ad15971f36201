//! Cloth queries over the C ABI: counts, statistics, the hierarchy, node and reconstructed vertex
//! positions, and the links for debug drawing. All copy-out (caller-owned buffers).

use std::cell::RefCell;

use glam::Vec4;
use softbody::DrawLink;
use treecut::NodeId;

use super::arena::RawId;
use super::boundary::{arg, boundary, check_copy_out, copy_out_map, write_out};
use super::cloth::{SLOD_NO_NODE, cloth_error};
use super::ids::SlodClothId;
use super::result::{FfiError, SlodResult};
use super::world::{ClothEntry, SlodWorld};
use crate::cloth::AdaptiveCloth;

/// Counters and last measurements of a cloth (`slod_cloth_stats`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlodClothStats {
    /// Steps taken.
    pub steps: u64,
    /// Feedback evaluations run.
    pub evaluations: u64,
    /// Refines begun (by feedback or explicitly).
    pub refines: u64,
    /// Coarses begun (by feedback or explicitly).
    pub coarses: u64,
    /// Operations the evaluator proposed that the body refused: always 0 (the evaluator plans
    /// around the locks of transitions in flight); kept for ABI stability.
    pub refused: u64,
    /// Operations that undid one on the same node begun within `SLOD_UNDO_WINDOW_STEPS` steps
    /// (flicker).
    pub undone_ops: u64,
    /// Wall time of the last step, evaluation included, in milliseconds.
    pub last_step_ms: f64,
    /// Wall time of the last feedback evaluation, in milliseconds.
    pub last_eval_ms: f64,
    /// Simulated nodes now.
    pub nodes: u32,
    /// Links now (plain and group links).
    pub links: u32,
    /// Refine/coarse transitions being blended now (the paper's "interpolations").
    pub interpolations: u32,
    /// The node budget of the last evaluation (0 before the first).
    pub node_budget: u32,
    /// Finest-level vertices (what `slod_cloth_vertex_positions` writes).
    pub vertices: u32,
    /// Nodes in the hierarchy (valid node indices are `0..hierarchy_nodes`).
    pub hierarchy_nodes: u32,
}

/// One hierarchy node (`slod_cloth_node_info`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlodNodeInfo {
    /// Parent node, `SLOD_NO_NODE` for the root.
    pub parent: u32,
    /// First child; the children are `first_child .. first_child + child_count`.
    pub first_child: u32,
    /// Number of children (0 for a finest-level node).
    pub child_count: u32,
    /// Level: 0 for finest-level nodes, growing towards the root.
    pub level: u32,
    /// 1 if the node is on the cut (simulated, or the parent being formed by a coarse).
    pub on_cut: u32,
    /// 1 if a transition in flight locks it (refine and coarse are refused until it ends).
    pub locked: u32,
}

/// A link for debug drawing (`slod_cloth_links`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlodDebugLink {
    /// First end, current position.
    pub a: [f32; 3],
    /// Second end, current position (the children's centroid for a group link).
    pub b: [f32; 3],
    /// Blend weight in [0, 1] (fading in or out during a transition, else 1).
    pub weight: f32,
    /// 1 for a group link to a virtual parent (a transition in flight), 0 for a plain link.
    pub group: u32,
}

/// The live cloth behind an id, read-only.
fn cloth_ref(world: &SlodWorld, id: SlodClothId) -> Result<&ClothEntry, FfiError> {
    world.cloths.get(RawId::from(id), "cloth")
}

/// Writes a cloth's statistics to `*out_stats`.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_stats` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_stats(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out_stats: *mut SlodClothStats,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let c = &cloth_ref(world, cloth)?.cloth;
        let s = c.stats();
        let stats = SlodClothStats {
            steps: s.steps,
            evaluations: s.evaluations,
            refines: s.refines,
            coarses: s.coarses,
            refused: s.refused,
            undone_ops: s.undone_ops,
            last_step_ms: s.last_step_seconds * 1e3,
            last_eval_ms: s.last_eval_seconds * 1e3,
            nodes: c.node_count() as u32,
            links: c.link_count() as u32,
            interpolations: c.interpolations() as u32,
            node_budget: s.node_budget.min(u32::MAX as usize) as u32,
            vertices: c.hierarchy().vertex_count() as u32,
            hierarchy_nodes: c.hierarchy().len() as u32,
        };
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_stats, stats, "out_stats") }
    })
}

/// Writes one count of a live cloth to `out_count`.
///
/// # Safety
/// `world` NULL or a live world; `out_count` NULL or valid for a write.
unsafe fn count(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out_count: *mut usize,
    f: fn(&AdaptiveCloth) -> usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let c = &cloth_ref(world, cloth)?.cloth;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_count, f(c), "out_count") }
    })
}

/// Writes the number of simulated nodes now (the length `slod_cloth_node_positions` needs).
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_count` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_node_count(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out_count: *mut usize,
) -> SlodResult {
    // SAFETY: forwarded caller contract.
    unsafe { count(world, cloth, out_count, |c| c.node_count()) }
}

/// Writes the number of links now, plain and group links (the length `slod_cloth_links` needs).
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_count` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_link_count(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out_count: *mut usize,
) -> SlodResult {
    // SAFETY: forwarded caller contract.
    unsafe { count(world, cloth, out_count, |c| c.link_count()) }
}

/// Writes the number of refine/coarse transitions being blended now.
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_count` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_interpolations(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out_count: *mut usize,
) -> SlodResult {
    // SAFETY: forwarded caller contract.
    unsafe { count(world, cloth, out_count, |c| c.interpolations()) }
}

/// Writes the number of finest-level vertices (the length `slod_cloth_vertex_positions` needs;
/// for a mesh cloth, the host's vertex count).
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`.
///
/// # Safety
/// `world` NULL or a live world; `out_count` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_vertex_count(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out_count: *mut usize,
) -> SlodResult {
    // SAFETY: forwarded caller contract.
    unsafe { count(world, cloth, out_count, |c| c.hierarchy().vertex_count()) }
}

/// Copies the position of every simulated node to `out`, 3 floats each (x, y, z; stride 3
/// floats).
///
/// Entry i is simulated node i; `slod_cloth_node_ids` gives its hierarchy node in the same order.
/// Buffer: copy-out (the header's rule); `cap` and `*out_len` count nodes (`out` holds
/// `3 × cap` floats) (the count changes
/// when the cut does). Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`,
/// `SLOD_RESULT_BUFFER_TOO_SMALL`, `SLOD_RESULT_NULL_ARGUMENT`.
///
/// # Safety
/// `world` NULL or a live world; `out` valid for `3 × cap` float writes (NULL if `cap` is 0);
/// `out_len` valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_node_positions(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out: *mut f32,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    // `[f32; 3]` has the size of 3 floats and the alignment of one: `3 × cap` floats are `cap`
    // triples.
    let out = out.cast::<[f32; 3]>();
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let body = cloth_ref(world, cloth)?.cloth.body();
        let xyz = |p: &Vec4| p.truncate().to_array();
        // SAFETY: caller contract: `out` valid for `cap` writes, `out_len` for one.
        unsafe { copy_out_map(body.particle_positions(), xyz, out, cap, out_len, "out") }
    })
}

/// Copies the hierarchy node of every simulated node to `out` (same order as the positions).
///
/// During a coarse in flight the children are still simulated while their parent is on the cut.
/// Buffer: copy-out, counted in nodes. Threads: reads the world only. Errors:
/// `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_BUFFER_TOO_SMALL`.
///
/// # Safety
/// `world` NULL or a live world; `out` valid for `cap` writes (NULL if `cap` is 0); `out_len`
/// valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_node_ids(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out: *mut u32,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let body = cloth_ref(world, cloth)?.cloth.body();
        let index = |n: &NodeId| n.raw();
        // SAFETY: caller contract: `out` valid for `cap` writes, `out_len` for one.
        unsafe { copy_out_map(body.particle_nodes(), index, out, cap, out_len, "out") }
    })
}

/// Copies the nodes on the cut (what `slod_cloth_refine` and, via parents, `slod_cloth_coarse`
/// address) to `out`, in no particular order.
///
/// Buffer: copy-out, counted in nodes. Threads: reads the world only. Errors:
/// `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_BUFFER_TOO_SMALL`.
///
/// # Safety
/// `world` NULL or a live world; `out` valid for `cap` writes (NULL if `cap` is 0); `out_len`
/// valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_active_nodes(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out: *mut u32,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let cut = cloth_ref(world, cloth)?.cloth.body().cut();
        let index = |n: &NodeId| n.raw();
        // SAFETY: caller contract: `out` valid for `cap` writes, `out_len` for one.
        unsafe { copy_out_map(cut.active(), index, out, cap, out_len, "out") }
    })
}

/// Writes what the hierarchy says about node `node` to `*out_info` (parent, children, level, and
/// whether it is on the cut or locked now).
///
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_INVALID_ARGUMENT`
/// for a node outside the hierarchy.
///
/// # Safety
/// `world` NULL or a live world; `out_info` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_node_info(
    world: *const SlodWorld,
    cloth: SlodClothId,
    node: u32,
    out_info: *mut SlodNodeInfo,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let body = cloth_ref(world, cloth)?.cloth.body();
        let h = body.hierarchy();
        if node as usize >= h.len() {
            return Err(FfiError::invalid(
                "node",
                format!("{node} is not a node of this cloth ({} nodes)", h.len()),
            ));
        }
        let n = NodeId::from_raw(node);
        let kids = h.children(n);
        let info = SlodNodeInfo {
            parent: h.parent(n).map_or(SLOD_NO_NODE, |p| p.raw()),
            first_child: kids.start,
            child_count: kids.len() as u32,
            level: h.level(n),
            on_cut: body.cut().is_on_cut(n) as u32,
            locked: body.cut().is_locked(n) as u32,
        };
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_info, info, "out_info") }
    })
}

/// Reconstructs every finest-level vertex from the simulated nodes (as the cloth desc's
/// `reconstruction` says) and copies the positions (3 floats each: x, y, z, stride 3 floats,
/// in vertex index order) to `out`: what a renderer draws.
///
/// A query: reading the vertices never changes what is simulated (two identical cloths stay
/// bit-identical whether or not either is read); pinned vertices are exactly at their anchors
/// at every cut, and every vertex is at least a collider's thickness out of the cloth's
/// colliders (vertices placed between coarse nodes would otherwise cut through a curved one).
/// Buffer: copy-out, counted in vertices (`slod_cloth_vertex_count`; fixed for the cloth's life;
/// `out` holds `3 × cap` floats).
/// Threads: reads the world only. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_BUFFER_TOO_SMALL`
/// (checked before any work).
///
/// # Safety
/// `world` NULL or a live world; `out` valid for `3 × cap` float writes (NULL if `cap` is 0);
/// `out_len` valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_vertex_positions(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out: *mut f32,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    // `[f32; 3]` has the size of 3 floats and the alignment of one: `3 × cap` floats are `cap`
    // triples.
    let out = out.cast::<[f32; 3]>();
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let entry = cloth_ref(world, cloth)?;
        let n = entry.cloth.hierarchy().vertex_count();
        // SAFETY: caller contract: `out_len` NULL or valid for a write.
        unsafe { check_copy_out(n, out, cap, out_len, "out") }?;
        if out.is_null() {
            return Ok(()); // sized
        }
        VERTICES.with_borrow_mut(|vertices| {
            vertices.clear();
            vertices.resize(n, glam::Vec3::ZERO);
            entry.cloth.reconstruct(vertices).map_err(cloth_error)?;
            let xyz = |v: &glam::Vec3| v.to_array();
            // SAFETY: caller contract: `out` valid for `cap >= n` writes, `out_len` for one.
            unsafe { copy_out_map(vertices, xyz, out, cap, out_len, "out") }
        })
    })
}

thread_local! {
    /// Vertices of the last `slod_cloth_vertex_positions` call on this thread (reused, like
    /// [`LINKS`], so the query allocates nothing once warm and takes a `const SlodWorld*`).
    static VERTICES: RefCell<Vec<glam::Vec3>> = const { RefCell::new(Vec::new()) };
    /// Links of the last `slod_cloth_links` call on this thread (reused: no allocation per call
    /// once warm, and no shared state, so the query can take a `const SlodWorld*`).
    static LINKS: RefCell<Vec<DrawLink>> = const { RefCell::new(Vec::new()) };
}

/// Copies every link with its blend weight to `out`, for debug drawing.
///
/// Group links join a particle to the centroid of a transition's children (the virtual parent).
/// Buffer: copy-out, counted in links (`slod_cloth_link_count`; changes with the cut). Threads:
/// reads the world only. Errors: `SLOD_RESULT_STALE_ID`, `SLOD_RESULT_BUFFER_TOO_SMALL`.
///
/// # Safety
/// `world` NULL or a live world; `out` valid for `cap` writes (NULL if `cap` is 0); `out_len`
/// valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_cloth_links(
    world: *const SlodWorld,
    cloth: SlodClothId,
    out: *mut SlodDebugLink,
    cap: usize,
    out_len: *mut usize,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        let c = &cloth_ref(world, cloth)?.cloth;
        LINKS.with(|links| {
            let mut links = links.borrow_mut();
            c.draw_links(&mut links);
            let convert = |l: &DrawLink| SlodDebugLink {
                a: l.a.to_array(),
                b: l.b.to_array(),
                weight: l.weight,
                group: l.group as u32,
            };
            // SAFETY: caller contract: `out` valid for `cap` writes, `out_len` for one.
            unsafe { copy_out_map(&links, convert, out, cap, out_len, "out") }
        })
    })
}
