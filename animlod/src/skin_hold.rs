//! Skinning with held joints: a character's skinned vertices are recomputed only where a
//! skinning matrix moved farther than the on-screen bound since the vertices were last
//! skinned, with the error measured at the vertices themselves.
//!
//! Follows the thesis' holds (`animation-lod-bone-priority-thesis.txt`, chapters 11–13: a bone
//! keeps its last transform until updating it is worth it) and its "vertex processing LOD"
//! (section 8.3: spend per-vertex work where it shows), moved from local bone transforms to the
//! skinning palette: each joint shows a *held* matrix, and the vertices it moves keep the
//! output they were skinned to. The error is measured where a viewer sees it, at the skinned
//! vertices (as ACL measures compression error at virtual vertices; Frechette, "Animation
//! Compression Library", 2017–), and it is measured exactly every frame rather than predicted:
//!
//! - A vertex skinned with held matrices `H_k` instead of the exact `P_k` is off by
//!   `|Σ w_k (H_k − P_k) p| ≤ Σ w_k |(H_k − P_k) p| ≤ max_k |(H_k − P_k) p|` (weights sum to 1).
//! - `|(H_k − P_k) p|` is a convex function of the bind-space position `p`, so over the box
//!   around every vertex joint `k` moves it is largest at one of the box's eight corners.
//!
//! So a joint whose eight corners all stay within the tolerance keeps its held matrix, and every
//! vertex is within the tolerance of its exact skinned position. A joint past the tolerance is
//! refreshed (its held matrix becomes the exact one), and the vertex chunks it touches are
//! skinned again with the held palette; a joint whose chunks are all being skinned anyway is
//! refreshed too, for nothing. The output always equals skinning the mesh with the held
//! palette, so it is as consistent as any skinned mesh (no seams between held and fresh
//! vertices beyond the bound itself). A host skinning on the GPU gains nothing from this (the
//! whole palette is uploaded either way); a CPU host skips the vertices of slow joints.

use glam::{Mat4, Vec3, Vec3A};

use crate::error::{CrowdError, invalid};
use crate::mesh::{SkinnedMesh, skin_vertex};

/// Most distinct joints a vertex chunk may name (a chunk is skinned again when any of them is
/// refreshed).
const CHUNK_JOINTS: usize = 4;

/// Most vertices in one chunk (finer chunks skip more vertices, coarser ones cost less to
/// track; on GDBot 16 skinned about a tenth fewer vertices than 64 at the same bound, 256 a
/// sixth more).
const CHUNK_VERTICES: u32 = 16;

/// A run of consecutive vertices and the joints that move them.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Chunk {
    start: u32,
    end: u32,
    count: u8,
    joints: [u16; CHUNK_JOINTS],
}

/// What [`SkinHoldJob`] needs to know about one mesh, computed once: per skin joint the
/// bind-space box around the vertices it moves (a weight above 0), and the mesh's vertices in
/// runs ("chunks") of consecutive vertices moved by at most eight joints.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinHoldLayout {
    joints: usize,
    vertices: usize,
    /// Per joint: (min, max) of the bind-space box, `None` for a joint that moves no vertex.
    boxes: Vec<Option<(Vec3, Vec3)>>,
    chunks: Vec<Chunk>,
    /// Per joint: its chunks, `joint_chunks[chunk_start[j]..chunk_start[j + 1]]`.
    chunk_start: Vec<u32>,
    joint_chunks: Vec<u32>,
}

impl SkinHoldLayout {
    /// The layout of `mesh`, whose skin has `skin_joints` joints. Refused for a joint index at
    /// or past `skin_joints`.
    pub fn new(mesh: &SkinnedMesh, skin_joints: usize) -> Result<SkinHoldLayout, CrowdError> {
        let n = mesh.vertex_count();
        if mesh.joints.len() != n || mesh.weights.len() != n || n > u32::MAX as usize {
            return Err(invalid("mesh", "attribute lengths differ"));
        }
        let mut boxes: Vec<Option<(Vec3, Vec3)>> = vec![None; skin_joints];
        let mut chunks: Vec<Chunk> = Vec::new();
        for v in 0..n {
            let p = mesh.positions[v];
            let mut cur = chunks
                .last()
                .copied()
                .filter(|c| c.end - c.start < CHUNK_VERTICES);
            for (&j, &w) in mesh.joints[v].iter().zip(&mesh.weights[v]) {
                if w <= 0.0 {
                    continue;
                }
                let b = boxes
                    .get_mut(j as usize)
                    .ok_or(invalid("mesh", "joint index beyond its skin"))?;
                *b = Some(b.map_or((p, p), |(lo, hi)| (lo.min(p), hi.max(p))));
                if let Some(c) = &mut cur
                    && !c.joints[..c.count as usize].contains(&j)
                {
                    if (c.count as usize) < CHUNK_JOINTS {
                        c.joints[c.count as usize] = j;
                        c.count += 1;
                    } else {
                        cur = None;
                    }
                }
            }
            match cur {
                Some(mut c) => {
                    c.end = v as u32 + 1;
                    *chunks.last_mut().expect("cur came from the last chunk") = c;
                }
                None => {
                    let mut c = Chunk {
                        start: v as u32,
                        end: v as u32 + 1,
                        count: 0,
                        joints: [0; CHUNK_JOINTS],
                    };
                    for (&j, &w) in mesh.joints[v].iter().zip(&mesh.weights[v]) {
                        if w > 0.0 && !c.joints[..c.count as usize].contains(&j) {
                            c.joints[c.count as usize] = j;
                            c.count += 1;
                        }
                    }
                    chunks.push(c);
                }
            }
        }
        let mut per_joint = vec![Vec::new(); skin_joints];
        for (i, c) in chunks.iter().enumerate() {
            for &j in &c.joints[..c.count as usize] {
                per_joint[j as usize].push(i as u32);
            }
        }
        let mut chunk_start = Vec::with_capacity(skin_joints + 1);
        let mut joint_chunks = Vec::new();
        chunk_start.push(0);
        for list in per_joint {
            joint_chunks.extend(list);
            chunk_start.push(joint_chunks.len() as u32);
        }
        Ok(SkinHoldLayout {
            joints: skin_joints,
            vertices: n,
            boxes,
            chunks,
            chunk_start,
            joint_chunks,
        })
    }

    /// Joints of the skin the layout was made for.
    pub fn joint_count(&self) -> usize {
        self.joints
    }

    /// Vertices of the mesh the layout was made for.
    pub fn vertex_count(&self) -> usize {
        self.vertices
    }

    /// Vertex chunks (runs of consecutive vertices skinned again together).
    pub fn chunk_count(&self) -> usize {
        self.chunks.len()
    }

    /// Per joint: the bind-space box around the vertices it moves (`None` for a joint that
    /// moves none).
    pub(crate) fn joint_boxes(&self) -> &[Option<(Vec3, Vec3)>] {
        &self.boxes
    }

    /// The chunks joint `j` moves vertices of.
    #[inline]
    fn chunks_of(&self, j: usize) -> &[u32] {
        &self.joint_chunks[self.chunk_start[j] as usize..self.chunk_start[j + 1] as usize]
    }
}

/// One character's held skinning state for one mesh: the held palette and scratch. Starts
/// unprimed: the first [`SkinHoldJob`] skins every vertex with the exact palette.
#[derive(Clone, Debug, Default)]
pub struct HeldSkin {
    held: Vec<Mat4>,
    /// The exact palette of the last job (the step to this one predicts the next).
    previous: Vec<Mat4>,
    refresh: Vec<u8>,
    dirty: Vec<u8>,
    primed: bool,
}

impl HeldSkin {
    /// A state for a mesh of `layout`.
    pub fn new(layout: &SkinHoldLayout) -> HeldSkin {
        HeldSkin {
            held: vec![Mat4::IDENTITY; layout.joints],
            previous: vec![Mat4::IDENTITY; layout.joints],
            refresh: vec![0; layout.joints],
            dirty: vec![0; layout.chunks.len()],
            primed: false,
        }
    }

    /// Makes the next job skin every vertex with the exact palette (after a jump in time, a
    /// change of clip, or output buffers the host rewrote).
    pub fn reset(&mut self) {
        self.primed = false;
    }

    /// The palette the output was skinned with (one matrix per joint; meaningless before the
    /// first job).
    pub fn held_palette(&self) -> &[Mat4] {
        &self.held
    }
}

/// What one [`SkinHoldJob`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SkinHoldStats {
    /// Joints whose held matrix was replaced by the exact one.
    pub joints_refreshed: u32,
    /// Vertices skinned again.
    pub vertices_skinned: u32,
}

impl std::ops::AddAssign for SkinHoldStats {
    fn add_assign(&mut self, o: Self) {
        self.joints_refreshed += o.joints_refreshed;
        self.vertices_skinned += o.vertices_skinned;
    }
}

/// One character's skinning of one mesh with held joints: joints whose held matrix is within
/// `tolerance` (model units, at every vertex they move) of the exact `palette` keep it; the
/// others are refreshed, and the vertex chunks they touch are skinned again. Afterwards every
/// output vertex is within `tolerance` of skinning with `palette` (a host passes its on-screen
/// bound over [`crate::Crowd::pixels_per_unit`]).
#[derive(Debug)]
pub struct SkinHoldJob<'a> {
    /// The mesh.
    pub mesh: &'a SkinnedMesh,
    /// Its layout ([`SkinHoldLayout::new`]).
    pub layout: &'a SkinHoldLayout,
    /// This frame's exact skinning matrices (model × inverse bind), one per joint.
    pub palette: &'a [Mat4],
    /// Largest displacement of a vertex from its exact skinned position (model units, ≥ 0;
    /// infinite holds every joint).
    pub tolerance: f32,
    /// Whether a refreshed joint holds a matrix predicted ahead along its last step (a
    /// centred hold: its error falls from the tolerance through zero before it rises again,
    /// about twice the hold of the exact matrix for steady motion) rather than the exact one.
    pub predict: bool,
    /// The character's held state for this mesh.
    pub state: &'a mut HeldSkin,
    /// Output positions (kept from the last job where not skinned again).
    pub positions: &'a mut [Vec3],
    /// Output normals (likewise).
    pub normals: &'a mut [Vec3],
}

impl SkinHoldJob<'_> {
    /// Runs the job. Refused, changing nothing, when the layout was made for another mesh, the
    /// state for another layout, the palette or an output is too short, or the tolerance is
    /// NaN or negative.
    pub fn run(self) -> Result<SkinHoldStats, CrowdError> {
        let (m, l) = (self.mesh, self.layout);
        let n = m.vertex_count();
        if l.vertices != n {
            return Err(invalid("layout", "was made for another mesh"));
        }
        let s = self.state;
        if s.held.len() != l.joints
            || s.previous.len() != l.joints
            || s.dirty.len() != l.chunks.len()
        {
            return Err(invalid("held skin", "was made for another layout"));
        }
        for (needed, given) in [
            (l.joints, self.palette.len()),
            (n, self.positions.len()),
            (n, self.normals.len()),
        ] {
            if given < needed {
                return Err(CrowdError::BufferTooSmall { needed, given });
            }
        }
        if self.tolerance.is_nan() || self.tolerance < 0.0 {
            return Err(invalid("tolerance", "must be >= 0"));
        }
        let palette = &self.palette[..l.joints];
        let (pos, nrm) = (self.positions, self.normals);
        if !s.primed {
            s.held.copy_from_slice(palette);
            s.previous.copy_from_slice(palette);
            for v in 0..n {
                (pos[v], nrm[v]) = skin_vertex(m, palette, v);
            }
            s.primed = true;
            return Ok(SkinHoldStats {
                joints_refreshed: l.joints as u32,
                vertices_skinned: n as u32,
            });
        }
        let tol2 = self.tolerance * self.tolerance;
        let mut any = false;
        for ((r, b), (h, p)) in s
            .refresh
            .iter_mut()
            .zip(&l.boxes)
            .zip(s.held.iter().zip(palette))
        {
            *r = match b {
                Some((lo, hi)) => (corner_error2(&(*h - *p), *lo, *hi) > tol2) as u8,
                None => 0,
            };
            any |= *r != 0;
        }
        if !any {
            if self.predict {
                s.previous.copy_from_slice(palette);
            }
            return Ok(SkinHoldStats::default());
        }
        s.dirty.fill(0);
        for (j, &r) in s.refresh.iter().enumerate() {
            if r != 0 {
                for &c in l.chunks_of(j) {
                    s.dirty[c as usize] = 1;
                }
            }
        }
        // A joint whose vertices are all skinned again anyway is refreshed for nothing.
        let mut stats = SkinHoldStats::default();
        for (j, (b, exact)) in l.boxes.iter().zip(palette).enumerate() {
            // A joint that moves no vertex is never checked nor refreshed.
            let Some((lo, hi)) = *b else { continue };
            if s.refresh[j] != 0 || l.chunks_of(j).iter().all(|&c| s.dirty[c as usize] != 0) {
                s.held[j] = if self.predict {
                    ahead(exact, &s.previous[j], lo, hi, self.tolerance)
                } else {
                    *exact
                };
                stats.joints_refreshed += 1;
            }
        }
        if self.predict {
            s.previous.copy_from_slice(palette);
        }
        for (c, &d) in l.chunks.iter().zip(&s.dirty) {
            if d != 0 {
                for v in c.start as usize..c.end as usize {
                    (pos[v], nrm[v]) = skin_vertex(m, &s.held, v);
                }
                stats.vertices_skinned += c.end - c.start;
            }
        }
        Ok(stats)
    }
}

/// Most steps a held matrix is predicted ahead (beyond a few frames the last step says little
/// about the motion; a nearly still joint is not pushed a whole tolerance off by noise).
const MAX_AHEAD_STEPS: f32 = 8.0;

/// Share of the tolerance a predicted matrix may be off when it is taken (the rest is margin
/// for motion that is not steady).
const AHEAD_SHARE: f32 = 0.9;

/// The matrix held for a joint refreshed at `now` whose exact matrix was `before` one step ago:
/// extrapolated along that step as far as keeps every vertex within [`AHEAD_SHARE`] of the
/// tolerance now (at most [`MAX_AHEAD_STEPS`] steps), so that for steady motion the held
/// matrix is passed half-way through the hold (the error is checked exactly every frame
/// either way).
#[inline]
fn ahead(now: &Mat4, before: &Mat4, lo: Vec3, hi: Vec3, tolerance: f32) -> Mat4 {
    let step = *now - *before;
    let per_step = corner_error2(&step, lo, hi).sqrt();
    if per_step.is_nan() || per_step <= 0.0 || !tolerance.is_finite() {
        return *now;
    }
    let k = (AHEAD_SHARE * tolerance / per_step).min(MAX_AHEAD_STEPS);
    *now + step * k
}

/// The largest squared length of `d · (x, y, z, 1)` over the eight corners of the box
/// `[lo, hi]` (`d` an affine difference of two palette matrices).
#[inline]
pub(crate) fn corner_error2(d: &Mat4, lo: Vec3, hi: Vec3) -> f32 {
    let (x, y, z, w) = (
        Vec3A::from_vec4(d.x_axis),
        Vec3A::from_vec4(d.y_axis),
        Vec3A::from_vec4(d.z_axis),
        Vec3A::from_vec4(d.w_axis),
    );
    let base = x * lo.x + y * lo.y + z * lo.z + w;
    let (ex, ey, ez) = (x * (hi.x - lo.x), y * (hi.y - lo.y), z * (hi.z - lo.z));
    let mut worst = 0.0f32;
    for corner in [
        base,
        base + ex,
        base + ey,
        base + ez,
        base + ex + ey,
        base + ex + ez,
        base + ey + ez,
        base + ex + ey + ez,
    ] {
        worst = worst.max(corner.length_squared());
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ids::SkinId;
    use crate::mesh::SkinningJob;
    use glam::Quat;

    /// A strip of vertices along x, each moved by two of three joints.
    fn strip() -> SkinnedMesh {
        let n = 200;
        let positions: Vec<Vec3> = (0..n)
            .map(|i| Vec3::new(i as f32 * 0.01, 0.0, 0.0))
            .collect();
        let joints = (0..n)
            .map(|i| {
                if i < n / 2 {
                    [0, 1, 0, 0]
                } else {
                    [1, 2, 0, 0]
                }
            })
            .collect();
        let weights = (0..n)
            .map(|i| {
                let t = (i % (n / 2)) as f32 / (n / 2) as f32;
                [1.0 - t, t, 0.0, 0.0]
            })
            .collect();
        SkinnedMesh {
            name: "strip".into(),
            skin: SkinId::new(0),
            normals: vec![Vec3::Y; n],
            positions,
            joints,
            weights,
        }
        .validated(3)
        .unwrap()
    }

    fn palette(t: f32) -> Vec<Mat4> {
        vec![
            Mat4::from_translation(Vec3::new(0.0, 0.01 * t, 0.0)),
            Mat4::from_quat(Quat::from_rotation_z(0.3 * t)),
            Mat4::from_translation(Vec3::new(0.0, 0.0, 0.5 * t)),
        ]
    }

    fn exact(m: &SkinnedMesh, p: &[Mat4]) -> Vec<Vec3> {
        let (mut pos, mut nrm) = (
            vec![Vec3::ZERO; m.vertex_count()],
            vec![Vec3::ZERO; m.vertex_count()],
        );
        SkinningJob {
            mesh: m,
            palette: p,
            positions: &mut pos,
            normals: &mut nrm,
        }
        .run()
        .unwrap();
        pos
    }

    /// Vertices skinned over 100 frames of steady motion, checking every frame that each
    /// vertex is within the tolerance of exact skinning and that the output is the mesh skinned
    /// with the held palette.
    fn run_strip(predict: bool) -> usize {
        let m = strip();
        let layout = SkinHoldLayout::new(&m, 3).unwrap();
        let mut state = HeldSkin::new(&layout);
        let n = m.vertex_count();
        let (mut pos, mut nrm) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        let tol = 0.02;
        let mut skinned = 0;
        for f in 0..100 {
            let p = palette(f as f32 * 0.01);
            let st = SkinHoldJob {
                mesh: &m,
                layout: &layout,
                palette: &p,
                tolerance: tol,
                predict,
                state: &mut state,
                positions: &mut pos,
                normals: &mut nrm,
            }
            .run()
            .unwrap();
            skinned += st.vertices_skinned as usize;
            let want = exact(&m, &p);
            let worst = pos
                .iter()
                .zip(&want)
                .map(|(a, b)| a.distance(*b))
                .fold(0.0, f32::max);
            assert!(worst <= tol * 1.0001, "frame {f}: {worst}");
            let held = exact(&m, state.held_palette());
            for (a, b) in pos.iter().zip(&held) {
                assert!(a.abs_diff_eq(*b, 1e-5));
            }
        }
        skinned
    }

    #[test]
    fn every_vertex_stays_within_the_tolerance_and_prediction_holds_longer() {
        let n = strip().vertex_count();
        let (exact_holds, predicted) = (run_strip(false), run_strip(true));
        // Every vertex moves, yet far fewer than 100 frames' worth were skinned; holding a
        // matrix predicted half a hold ahead skins fewer still.
        assert!(exact_holds < 100 * n / 2, "{exact_holds}");
        assert!(
            predicted > n && predicted < exact_holds,
            "{predicted} {exact_holds}"
        );
    }

    #[test]
    fn zero_tolerance_is_exact_and_infinite_holds_everything() {
        let m = strip();
        let layout = SkinHoldLayout::new(&m, 3).unwrap();
        let n = m.vertex_count();
        for (tol, moves) in [(0.0, true), (f32::INFINITY, false)] {
            let mut state = HeldSkin::new(&layout);
            let (mut pos, mut nrm) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
            for f in 0..3 {
                let p = palette(f as f32);
                SkinHoldJob {
                    mesh: &m,
                    layout: &layout,
                    palette: &p,
                    tolerance: tol,
                    predict: false,
                    state: &mut state,
                    positions: &mut pos,
                    normals: &mut nrm,
                }
                .run()
                .unwrap();
            }
            let first = exact(&m, &palette(0.0));
            let last = exact(&m, &palette(2.0));
            let want = if moves { &last } else { &first };
            for (a, b) in pos.iter().zip(want) {
                assert!(a.abs_diff_eq(*b, 1e-5), "{tol}: {a} {b}");
            }
        }
    }

    #[test]
    fn bad_input_is_refused_and_changes_nothing() {
        let m = strip();
        let layout = SkinHoldLayout::new(&m, 3).unwrap();
        assert!(SkinHoldLayout::new(&m, 2).is_err());
        let mut state = HeldSkin::new(&layout);
        let n = m.vertex_count();
        let (mut pos, mut nrm) = (vec![Vec3::ONE; n], vec![Vec3::ONE; n]);
        let p = palette(1.0);
        for (tol, pal) in [(f32::NAN, &p[..]), (-1.0, &p[..]), (0.1, &p[..2])] {
            let r = SkinHoldJob {
                mesh: &m,
                layout: &layout,
                palette: pal,
                tolerance: tol,
                predict: false,
                state: &mut state,
                positions: &mut pos,
                normals: &mut nrm,
            }
            .run();
            assert!(r.is_err());
        }
        let mut short = vec![Vec3::ONE; n - 1];
        let r = SkinHoldJob {
            mesh: &m,
            layout: &layout,
            palette: &p,
            tolerance: 0.1,
            predict: true,
            state: &mut state,
            positions: &mut short,
            normals: &mut nrm,
        }
        .run();
        assert!(matches!(r, Err(CrowdError::BufferTooSmall { .. })));
        assert!(pos.iter().chain(&nrm).all(|v| *v == Vec3::ONE));
        assert!(!state.primed);
    }
}
