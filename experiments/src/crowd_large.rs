//! Large crowds and the whole per-character pipeline a host pays for (sampling, local→model
//! concatenation, the skinning palette, CPU skinning), with and without LOD, measured with the
//! rotation-aware error (joint origins and tips, pixels through a 1080-px-high view).
//! Extends the thesis' crowd test (`animation-lod-bone-priority-thesis.txt`, chapter 13) to
//! thousands of characters of a real rig, several clips and phases, 2–200 m in front of a
//! camera that stands outside the crowd.
//!
//! Threads: the crowd is split into a fixed number of shards (independent [`Crowd`]s, each
//! character always in the same shard) advanced in parallel on a rayon pool. Every LOD mode
//! used here decides per character, so a character's pose does not depend on the shard count,
//! and the shard count does not depend on the thread count: one thread and many give the same
//! poses, which [`run_large`] checks.

use std::sync::Arc;
use std::time::Instant;

use glam::{Mat4, Vec3};
use rayon::prelude::*;
use salience::View;

use animlod::{
    BuildError, CharacterId, Crowd, CrowdError, ErrorSum, HeldSkin, KeyUpdate, LodMode, PoseShare,
    Rig, SharedPose, SkinBlendJob, SkinHoldJob, SkinHoldLayout, SkinId, SkinningJob,
};

use crate::crowd::rig_height;
use crate::rng::Rng;

/// Shards a large crowd is split into (a fixed count, so results do not depend on threads).
pub const SHARDS: usize = 32;

/// A large-crowd scene.
#[derive(Clone, Debug, PartialEq)]
pub struct LargeSetup {
    /// Characters.
    pub characters: usize,
    /// Nearest character distance from the camera (m).
    pub near_m: f32,
    /// Farthest character distance (m).
    pub far_m: f32,
    /// The LOD mode of the LOD crowd.
    pub lod: LodMode,
    /// Frames run before measuring.
    pub warmup_frames: usize,
    /// Frames measured.
    pub frames: usize,
    /// Frame step (s).
    pub dt: f32,
    /// Viewport height (px); 16:9, 60° vertical field of view.
    pub viewport_height: u32,
    /// Seed of positions, clips and phases.
    pub seed: u64,
    /// Pipeline only: with `Some(px)`, the LOD side keeps exact poses (`lod` is ignored, the
    /// crowd runs at full detail) and skins with held joints ([`SkinHoldJob`]) within `px`
    /// pixels at every vertex.
    pub held_joints_px: Option<f32>,
    /// With held joints: whether refreshed joints hold a matrix predicted ahead
    /// ([`SkinHoldJob::predict`]) or the exact one (the default).
    pub held_joints_predict: bool,
    /// Whole pipeline only, with held joints: `Some(mib)` lets characters far enough away
    /// share the skinned pose of their clip's phase bucket ([`PoseShare`], as many poses kept
    /// across frames as fit in `mib` MiB) within the same bound; the others are skinned with
    /// held joints.
    pub shared_poses_mib: Option<usize>,
}

impl LargeSetup {
    /// `characters` from 2 to 200 m, centred key holds within 1 px, 1080 px high.
    pub fn new(characters: usize) -> LargeSetup {
        LargeSetup {
            characters,
            near_m: 2.0,
            far_m: 200.0,
            lod: LodMode::KeyHold { max_error_px: 1.0 },
            warmup_frames: 10,
            frames: 20,
            dt: 1.0 / 60.0,
            viewport_height: 1080,
            seed: 11,
            held_joints_px: None,
            held_joints_predict: false,
            shared_poses_mib: None,
        }
    }

    /// The camera: at the origin, 1.6 m up, looking along −z; every character stands in front.
    pub fn view(&self) -> Result<View, CrowdError> {
        let h = self.viewport_height.max(1);
        let w = (h as f32 * 16.0 / 9.0).round() as u32;
        Ok(View::new(
            Vec3::new(0.0, 1.6, 0.0),
            Vec3::NEG_Z,
            Vec3::Y,
            60f32.to_radians(),
            w,
            h,
        )?)
    }
}

/// A real rig scaled to 1.8 m.
pub fn metric_rig(rig: &Rig) -> Result<Rig, BuildError> {
    animlod::build::scaled(rig, 1.8 / rig_height(rig)?)
}

/// One large-crowd measurement: whole-pipeline frame cost (sampling, concatenation, palette)
/// with and without LOD, and the on-screen error.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LargeRow {
    /// Characters.
    pub characters: usize,
    /// Nearest and farthest character distance (m).
    pub near_m: f32,
    /// Farthest character distance (m).
    pub far_m: f32,
    /// Threads of the parallel run.
    pub threads: usize,
    /// Mean frame time at full detail on one thread (ms): sample + concatenate + palette of
    /// every character.
    pub full_ms: f64,
    /// Mean frame time with LOD on one thread (ms): the palette only for characters whose pose
    /// changed (a held character keeps last frame's).
    pub lod_ms: f64,
    /// Mean frame time with LOD on one thread (ms), alternating frames with the parallel run
    /// (the reference of the speed-up; `lod_ms` alternates frames with the full-detail crowd).
    pub lod_serial_ms: f64,
    /// Mean frame time with LOD on `threads` threads (ms).
    pub lod_parallel_ms: f64,
    /// One-thread over `threads`-thread median frame time: on a shared virtual machine some
    /// frames lose a core to the hypervisor for milliseconds (a run of frames then takes half
    /// again as long), which the mean carries and the median does not.
    pub parallel_speedup_median: f64,
    /// Mean on-screen error (px) over visible joints (origins and tips) and frames.
    pub mean_error_px: f32,
    /// Largest on-screen error (px).
    pub max_error_px: f32,
    /// Root mean square on-screen error (px).
    pub rms_error_px: f32,
    /// Fraction of the full-detail bone interpolations the LOD crowd spent.
    pub interpolated_fraction: f64,
    /// Fraction of characters whose pose changed per frame with LOD (palette and skinning
    /// recomputed).
    pub changed_fraction: f64,
    /// Whole pipeline with shared poses: fraction of character-frames measured that showed a
    /// shared phase-bucket pose ([`LargeSetup::shared_poses_mib`]); 0 otherwise.
    pub shared_fraction: f64,
    /// Whether the parallel run gave bit-identical poses to the one-thread run.
    pub deterministic: bool,
}

impl LargeRow {
    /// The row's times and error: `(full_ms, lod_ms)` of the one-thread lockstep with full
    /// detail, the serial/parallel `lockstep`, the `error` over the measured frames (the
    /// fractions and the determinism check are left at their defaults).
    fn timed(
        setup: &LargeSetup,
        threads: usize,
        (full_ms, lod_ms): (f64, f64),
        lockstep: &Lockstep,
        error: &animlod::PoseError,
    ) -> LargeRow {
        LargeRow {
            characters: setup.characters,
            near_m: setup.near_m,
            far_m: setup.far_m,
            threads: threads.max(1),
            full_ms,
            lod_ms,
            lod_serial_ms: lockstep.serial_ms,
            lod_parallel_ms: lockstep.parallel_ms,
            parallel_speedup_median: lockstep.median_speedup,
            mean_error_px: error.mean_px,
            max_error_px: error.max_px,
            rms_error_px: error.rms_px,
            ..LargeRow::default()
        }
    }

    /// `lod_ms / full_ms`.
    pub fn cost_ratio(&self) -> f64 {
        if self.full_ms > 0.0 {
            self.lod_ms / self.full_ms
        } else {
            0.0
        }
    }

    /// One-thread LOD time over parallel LOD time, both of the LOD crowd run alone.
    pub fn parallel_speedup(&self) -> f64 {
        if self.lod_parallel_ms > 0.0 {
            self.lod_serial_ms / self.lod_parallel_ms
        } else {
            0.0
        }
    }
}

/// A crowd split into shards, plus each character's palettes (every skin's joints, one after
/// the other) of its two key poses (`[from, to]`, see [`Crowd::key_poses`]; outside the
/// interpolated mode only `to` is used).
struct Sharded {
    shards: Vec<Crowd>,
    ids: Vec<Vec<CharacterId>>,
    palettes: Vec<Vec<[Vec<Mat4>; 2]>>,
}

/// Writes every skin's palette of a character's key pose (`later`: `to`) into `out`.
fn key_palette(
    crowd: &Crowd,
    id: CharacterId,
    later: bool,
    out: &mut [Mat4],
) -> Result<(), CrowdError> {
    let mut at = 0;
    for s in 0..crowd.rig().skins().len() {
        at += crowd.key_skinning_matrices(id, SkinId::new(s), later, &mut out[at..])?;
    }
    Ok(())
}

impl Sharded {
    /// Every character of `setup` (positions, clips, phases from its seed) in `SHARDS` crowds.
    fn new(rig: &Arc<Rig>, setup: &LargeSetup, lod: LodMode) -> Result<Sharded, CrowdError> {
        let view = setup.view()?;
        let clips = crate::crowd::playable_clips(rig);
        let mut shards: Vec<Crowd> = (0..SHARDS).map(|_| Crowd::new(rig.clone())).collect();
        let mut ids = vec![Vec::new(); SHARDS];
        let mut r = Rng::new(setup.seed);
        // Half the horizontal field of view's tangent (60° vertical).
        let tan_x = view.width_px() as f32 / view.height_px() as f32 * 30f32.to_radians().tan();
        for i in 0..setup.characters {
            let d = r.range(setup.near_m, setup.far_m);
            let x = r.range(-0.9, 0.9) * d * tan_x;
            let clip = clips[i % clips.len()];
            let phase = r.next_f32();
            let s = i % SHARDS;
            let id = shards[s].add_character(Vec3::new(x, 0.0, -d), clip)?;
            let duration = rig.clip(clip).map_or(0.0, |c| c.duration());
            shards[s].set_time(id, phase * duration)?;
            ids[s].push(id);
        }
        for c in &mut shards {
            c.set_lod(lod)?;
        }
        let palettes = ids
            .iter()
            .map(|v| {
                v.iter()
                    .map(|_| {
                        let joints: usize = rig.skins().iter().map(|s| s.joints.len()).sum();
                        [vec![Mat4::IDENTITY; joints], vec![Mat4::IDENTITY; joints]]
                    })
                    .collect()
            })
            .collect();
        Ok(Sharded {
            shards,
            ids,
            palettes,
        })
    }

    /// Advances every shard and rebuilds the palettes a host needs: with `reuse`, only those
    /// of key poses that changed ([`KeyUpdate`]; a GPU host blends the two palettes in its
    /// vertex shader); without, the current pose's of every character. Returns interpolations
    /// and the characters whose palettes were rebuilt.
    fn frame(&mut self, dt: f32, view: &View, reuse: bool) -> Result<(u64, u64), CrowdError> {
        let results: Vec<Result<(u64, u64), CrowdError>> = self
            .shards
            .par_iter_mut()
            .zip(self.ids.par_iter())
            .zip(self.palettes.par_iter_mut())
            .map(|((crowd, ids), palettes)| {
                let st = crowd.advance(dt, view)?;
                let mut changed = 0;
                for (&id, [from, to]) in ids.iter().zip(palettes.iter_mut()) {
                    let update = if reuse {
                        crowd.key_poses(id)?.update
                    } else {
                        KeyUpdate::Advanced
                    };
                    match update {
                        KeyUpdate::Unchanged => continue,
                        KeyUpdate::Advanced => std::mem::swap(from, to),
                        KeyUpdate::Restarted => key_palette(crowd, id, false, from)?,
                    }
                    key_palette(crowd, id, true, to)?;
                    changed += 1;
                }
                Ok((st.bones_interpolated, changed))
            })
            .collect();
        results.into_iter().try_fold((0, 0), |(a, b), r| {
            let (x, y) = r?;
            Ok((a + x, b + y))
        })
    }

    fn poses(&self) -> Vec<Mat4> {
        let mut out = Vec::new();
        for (crowd, ids) in self.shards.iter().zip(&self.ids) {
            for &id in ids {
                out.extend_from_slice(crowd.model_matrices(id).unwrap_or(&[]));
            }
        }
        out
    }
}

/// Frames of each side per turn of [`Lockstep::run`]. Frame by frame (one), each frame started
/// while the other pool's workers were still spinning idle on this 2-core machine and woke its
/// own, and the two sides' data evicted each other's every frame: the shared-pose
/// 1,000-character pipeline read 1.15–1.53× on two threads over six runs, 1.90–1.93× in turns
/// of four (two runs of `crowd_large held 0.6 1000` with `SHARED_MIB=64`).
const LOCKSTEP_BLOCK: usize = 4;

/// Frame times of a one-thread run and a parallel run advanced in lockstep (a few frames of
/// one, then the same frames of the other, so a change of machine load hits both alike).
struct Lockstep {
    serial_ms: f64,
    parallel_ms: f64,
    median_speedup: f64,
}

impl Lockstep {
    /// Runs `serial` on the one-thread pool `one` and `parallel` on `many`, in turns of
    /// [`LOCKSTEP_BLOCK`] frames each, for `setup.warmup_frames + setup.frames` frames each,
    /// and keeps the measured ones but the first of each turn (it pays for the other pool's
    /// workers going idle and its own waking).
    fn run(
        setup: &LargeSetup,
        (one, many): (&rayon::ThreadPool, &rayon::ThreadPool),
        mut serial: impl FnMut() -> Result<(), CrowdError> + Send,
        mut parallel: impl FnMut() -> Result<(), CrowdError> + Send,
    ) -> Result<Lockstep, CrowdError> {
        let (mut serial_ms, mut parallel_ms) = (Vec::new(), Vec::new());
        let total = setup.warmup_frames + setup.frames;
        let mut first = 0;
        while first < total {
            let end = (first + LOCKSTEP_BLOCK).min(total);
            for (pool, side, times) in [
                (
                    one,
                    &mut serial as &mut (dyn FnMut() -> Result<(), CrowdError> + Send),
                    &mut serial_ms,
                ),
                (many, &mut parallel, &mut parallel_ms),
            ] {
                for f in first..end {
                    let t = Instant::now();
                    pool.install(&mut *side)?;
                    if f >= setup.warmup_frames && f > first {
                        times.push(t.elapsed().as_secs_f64() * 1e3);
                    }
                }
            }
            first = end;
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(0.0)
        };
        let (serial_mean, parallel_mean) = (mean(&serial_ms), mean(&parallel_ms));
        let (ms, mp) = (median(&mut serial_ms), median(&mut parallel_ms));
        Ok(Lockstep {
            serial_ms: serial_mean,
            parallel_ms: parallel_mean,
            median_speedup: if mp > 0.0 { ms / mp } else { 0.0 },
        })
    }
}

fn pool(threads: usize) -> Result<rayon::ThreadPool, CrowdError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|_| CrowdError::InvalidArgument {
            what: "threads",
            reason: "could not start a thread pool",
        })
}

/// Runs a large crowd: full detail and LOD in lockstep on one thread (times and error), then
/// the LOD crowd again on `threads` threads (time, and whether its poses equal the one-thread
/// run's).
pub fn run_large(
    rig: &Arc<Rig>,
    setup: &LargeSetup,
    threads: usize,
) -> Result<LargeRow, CrowdError> {
    let view = setup.view()?;
    let one = pool(1)?;
    let (full_ms, lod_ms, sum, spent, changed, poses) = one.install(|| {
        let mut full = Sharded::new(rig, setup, LodMode::Off)?;
        let mut lod = Sharded::new(rig, setup, setup.lod)?;
        for _ in 0..setup.warmup_frames {
            full.frame(setup.dt, &view, false)?;
            lod.frame(setup.dt, &view, true)?;
        }
        let (mut tf, mut tl) = (0.0f64, 0.0f64);
        let mut sum = ErrorSum::default();
        let (mut done, mut all, mut changed) = (0u64, 0u64, 0u64);
        for _ in 0..setup.frames {
            let t0 = Instant::now();
            let (f, _) = full.frame(setup.dt, &view, false)?;
            let t1 = Instant::now();
            let (l, c) = lod.frame(setup.dt, &view, true)?;
            let t2 = Instant::now();
            tf += (t1 - t0).as_secs_f64();
            tl += (t2 - t1).as_secs_f64();
            (done, all, changed) = (done + l, all + f, changed + c);
            let sk = rig.skeleton();
            for s in 0..SHARDS {
                for (&a, &b) in full.ids[s].iter().zip(&lod.ids[s]) {
                    sum.add_pose(
                        sk,
                        lod.shards[s].model_matrices(b)?,
                        full.shards[s].model_matrices(a)?,
                        &full.shards[s].world_transform(a)?,
                        &view,
                    );
                }
            }
        }
        let frames = setup.frames.max(1) as f64;
        Ok::<_, CrowdError>((
            tf * 1e3 / frames,
            tl * 1e3 / frames,
            sum.finish(),
            done as f64 / all.max(1) as f64,
            changed as f64 / (frames * setup.characters.max(1) as f64),
            lod.poses(),
        ))
    })?;
    // The LOD crowd without the full-detail one, on one thread and on `threads`, frame by frame
    // in lockstep (a change of machine load hits both alike): the speed-up compares like with
    // like.
    let many = pool(threads.max(1))?;
    let mut serial = Sharded::new(rig, setup, setup.lod)?;
    let mut parallel = Sharded::new(rig, setup, setup.lod)?;
    let lockstep = Lockstep::run(
        setup,
        (&one, &many),
        || serial.frame(setup.dt, &view, true).map(|_| ()),
        || parallel.frame(setup.dt, &view, true).map(|_| ()),
    )?;
    let parallel_poses = parallel.poses();
    Ok(LargeRow {
        interpolated_fraction: spent,
        changed_fraction: changed,
        deterministic: poses == parallel_poses,
        ..LargeRow::timed(setup, threads, (full_ms, lod_ms), &lockstep, &sum)
    })
}

/// Per-frame cost of each stage of the pipeline (ms, summed over the crowd).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stages {
    /// Sampling (key search, interpolation, local matrices).
    pub sample_ms: f64,
    /// Local → model concatenation.
    pub concat_ms: f64,
    /// Skinning palette (model × inverse bind).
    pub palette_ms: f64,
    /// CPU linear-blend skinning of the rig's meshes (positions and normals), including
    /// `blend_ms`.
    pub skin_ms: f64,
    /// Of `skin_ms`: blending the two skinned key poses ([`SkinBlendJob`]; interpolated mode
    /// only).
    pub blend_ms: f64,
}

/// The pipeline measured on one thread, without and with LOD.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PipelineRow {
    /// Characters.
    pub characters: usize,
    /// Vertices skinned per character.
    pub vertices: usize,
    /// Full detail, every stage for every character every frame.
    pub full: Stages,
    /// With LOD: only key poses that changed are skinned; the output blends two skinned copies.
    pub lod: Stages,
    /// Vertices skinned with LOD over vertices skinned at full detail (a skinned key pose
    /// counts all its vertices; blends are not skinning).
    pub lod_skinned_fraction: f64,
    /// Mean on-screen error (px) with LOD, at every skinned vertex in view against the
    /// full-detail crowd's skinned vertex.
    pub mean_error_px: f32,
    /// Largest on-screen error (px) with LOD at a skinned vertex.
    pub max_error_px: f32,
    /// Largest on-screen error (px) with LOD at bone origins and tips (the model matrices the
    /// crowd hands out; 0 with held joints, whose poses are exact).
    pub max_bone_tip_error_px: f32,
}

/// One character's skinned output on the host: the skinned key poses (`[from, to]`, positions
/// and normals of every mesh one after the other) and the blended output.
struct HostSkin {
    keys: [(Vec<Vec3>, Vec<Vec3>); 2],
    out: (Vec<Vec3>, Vec<Vec3>),
    /// Which buffer shows now: 0 or 1 a key copy, 2 `out`.
    shown: usize,
}

impl HostSkin {
    /// The skinned positions shown now.
    fn positions(&self) -> &[Vec3] {
        match self.shown {
            0 | 1 => &self.keys[self.shown].0,
            _ => &self.out.0,
        }
    }
}

/// The host side of skinning with held joints: one layout per mesh, one held state per
/// character and mesh.
struct HeldHost {
    max_error_px: f32,
    layouts: Vec<SkinHoldLayout>,
    states: Vec<Vec<HeldSkin>>,
}

/// Skins every mesh of the rig into `out` (positions and normals, mesh after mesh), each with
/// the palette `write_palette` writes for its skin; returns the seconds spent on palettes and
/// on skinning.
fn skin_meshes(
    rig: &Rig,
    palette: &mut Vec<Mat4>,
    out: &mut (Vec<Vec3>, Vec<Vec3>),
    mut write_palette: impl FnMut(SkinId, &mut [Mat4]) -> Result<usize, CrowdError>,
) -> Result<(f64, f64), CrowdError> {
    let (mut at, mut palette_s, mut skin_s) = (0, 0.0, 0.0);
    for mesh in rig.meshes() {
        let joints = rig.skin(mesh.skin).map_or(0, |s| s.joints.len());
        palette.resize(joints, Mat4::IDENTITY);
        let t0 = Instant::now();
        write_palette(mesh.skin, palette)?;
        let t1 = Instant::now();
        let v = mesh.vertex_count();
        SkinningJob {
            mesh,
            palette,
            positions: &mut out.0[at..at + v],
            normals: &mut out.1[at..at + v],
        }
        .run()?;
        palette_s += (t1 - t0).as_secs_f64();
        skin_s += t1.elapsed().as_secs_f64();
        at += v;
    }
    Ok((palette_s, skin_s))
}

/// Skins every mesh of a character's key pose (`later`: `to`) into `out`.
fn skin_key(
    rig: &Rig,
    crowd: &Crowd,
    id: CharacterId,
    later: bool,
    palette: &mut Vec<Mat4>,
    out: &mut (Vec<Vec3>, Vec<Vec3>),
) -> Result<(), CrowdError> {
    skin_meshes(rig, palette, out, |skin, p| {
        crowd.key_skinning_matrices(id, skin, later, p)
    })?;
    Ok(())
}

/// What skinning with held joints needs besides the character: one layout per mesh, the
/// on-screen bound and whether refreshed joints hold a predicted matrix.
#[derive(Clone, Copy)]
struct HeldSpec<'a> {
    layouts: &'a [SkinHoldLayout],
    max_error_px: f32,
    predict: bool,
}

/// Skins every mesh of one character with held joints into `out` (positions and normals, mesh
/// after mesh): exact palettes every frame, and only vertices of joints that moved past the
/// bound at their vertices skinned again ([`SkinHoldJob`]). `states` holds one [`HeldSkin`] per
/// mesh. Returns the seconds spent on palettes and on skinning, and the vertices skinned.
fn skin_held(
    rig: &Rig,
    crowd: &Crowd,
    id: CharacterId,
    spec: HeldSpec<'_>,
    states: &mut [HeldSkin],
    palette: &mut Vec<Mat4>,
    out: &mut (Vec<Vec3>, Vec<Vec3>),
) -> Result<(f64, f64, u64), CrowdError> {
    let ppu = crowd.pixels_per_unit(id)?;
    let tolerance = if ppu > 0.0 {
        spec.max_error_px / ppu
    } else {
        f32::INFINITY
    };
    let (mut at, mut palette_s, mut skin_s, mut skinned) = (0, 0.0, 0.0, 0u64);
    for ((mesh, layout), state) in rig.meshes().iter().zip(spec.layouts).zip(states) {
        palette.resize(layout.joint_count(), Mat4::IDENTITY);
        let t0 = Instant::now();
        crowd.skinning_matrices(id, mesh.skin, palette)?;
        let t1 = Instant::now();
        let v = mesh.vertex_count();
        let done = SkinHoldJob {
            mesh,
            layout,
            palette,
            tolerance,
            predict: spec.predict,
            state,
            positions: &mut out.0[at..at + v],
            normals: &mut out.1[at..at + v],
        }
        .run()?;
        palette_s += (t1 - t0).as_secs_f64();
        skin_s += t1.elapsed().as_secs_f64();
        skinned += done.vertices_skinned as u64;
        at += v;
    }
    Ok((palette_s, skin_s, skinned))
}

/// Adds the on-screen error of every skinned vertex in view: `shown[i]` against
/// `reference[i]`, both in the character's model space, placed in the world by `world`.
fn add_vertex_errors(
    sum: &mut ErrorSum,
    world: &glam::Affine3A,
    view: &View,
    shown: &[Vec3],
    reference: &[Vec3],
) {
    for (p, q) in shown.iter().zip(reference) {
        let (p, q) = (world.transform_point3(*p), world.transform_point3(*q));
        let seen = view.is_in_view(q, 0.0).then(|| view.pixels_per_unit(q));
        sum.add(p.distance(q), seen);
    }
}

/// The layouts of held-joint skinning, one per mesh of `rig`.
fn held_layouts(rig: &Rig) -> Result<Vec<SkinHoldLayout>, CrowdError> {
    rig.meshes()
        .iter()
        .map(|m| SkinHoldLayout::new(m, rig.skin(m.skin).map_or(0, |s| s.joints.len())))
        .collect()
}

/// One LOD mode's side of the pipeline measurement: the crowd, the host's skinned output and
/// the stage times so far.
struct PipelineRun {
    s: Sharded,
    /// Whether the host keeps one skinned copy per key pose (the LOD side) or skins the current
    /// pose of every character every frame (full detail).
    keyed: bool,
    out: Vec<(Vec<Vec3>, Vec<Vec3>)>,
    host: Vec<HostSkin>,
    palette: Vec<Mat4>,
    stages: Stages,
    /// Vertices skinned in measured frames.
    skinned: u64,
    /// Skinning with held joints (the LOD side of [`LargeSetup::held_joints_px`]).
    held: Option<HeldHost>,
    /// Whether a frame ran (the host skinned its first poses).
    primed: bool,
}

impl PipelineRun {
    fn new(
        rig: &Arc<Rig>,
        setup: &LargeSetup,
        lod: LodMode,
        keyed: bool,
        held_px: Option<f32>,
    ) -> Result<Self, CrowdError> {
        let mut s = Sharded::new(rig, setup, lod)?;
        s.shards.iter_mut().for_each(|c| c.set_stage_timing(true));
        let vertices: usize = rig.meshes().iter().map(|m| m.vertex_count()).sum();
        let n = setup.characters;
        let buffer = || (vec![Vec3::ZERO; vertices], vec![Vec3::ZERO; vertices]);
        let (out, host) = if keyed {
            let host = (0..n)
                .map(|_| HostSkin {
                    keys: [buffer(), buffer()],
                    out: buffer(),
                    shown: 1,
                })
                .collect();
            (Vec::new(), host)
        } else {
            ((0..n).map(|_| buffer()).collect(), Vec::new())
        };
        let held = match held_px {
            Some(max_error_px) => {
                let layouts = held_layouts(rig)?;
                let states = (0..n)
                    .map(|_| layouts.iter().map(HeldSkin::new).collect())
                    .collect();
                Some(HeldHost {
                    max_error_px,
                    layouts,
                    states,
                })
            }
            None => None,
        };
        Ok(PipelineRun {
            s,
            keyed,
            out,
            host,
            palette: Vec::new(),
            stages: Stages::default(),
            skinned: 0,
            held,
            primed: false,
        })
    }

    /// One frame: advance, then the host's palettes and skinning; times added when `measured`.
    fn frame(
        &mut self,
        rig: &Rig,
        setup: &LargeSetup,
        view: &View,
        measured: bool,
    ) -> Result<(), CrowdError> {
        let mut st = animlod::FrameStats::default();
        let (mut palette_s, mut skin_s, mut blend_s) = (0.0f64, 0.0f64, 0.0f64);
        let mut ci = 0;
        let palette = &mut self.palette;
        let vertices: u64 = rig.meshes().iter().map(|m| m.vertex_count() as u64).sum();
        for (crowd, ids) in self.s.shards.iter_mut().zip(&self.s.ids) {
            st += crowd.advance(setup.dt, view)?;
            for &id in ids {
                if let Some(held) = &mut self.held {
                    let spec = HeldSpec {
                        layouts: &held.layouts,
                        max_error_px: held.max_error_px,
                        predict: setup.held_joints_predict,
                    };
                    let (p, k, done) = skin_held(
                        rig,
                        crowd,
                        id,
                        spec,
                        &mut held.states[ci],
                        palette,
                        &mut self.out[ci],
                    )?;
                    palette_s += p;
                    skin_s += k;
                    if measured {
                        self.skinned += done;
                    }
                } else if self.keyed {
                    let t0 = Instant::now();
                    let h = &mut self.host[ci];
                    let keys = crowd.key_poses(id)?;
                    // The host skins both key poses of every character on its first frame (the
                    // crowd's first advance after adding a character reports `Restarted` too).
                    let update = if self.primed {
                        keys.update
                    } else {
                        KeyUpdate::Restarted
                    };
                    match update {
                        KeyUpdate::Unchanged => {}
                        KeyUpdate::Advanced => {
                            h.keys.swap(0, 1);
                            skin_key(rig, crowd, id, true, palette, &mut h.keys[1])?;
                        }
                        KeyUpdate::Restarted => {
                            skin_key(rig, crowd, id, false, palette, &mut h.keys[0])?;
                            skin_key(rig, crowd, id, true, palette, &mut h.keys[1])?;
                        }
                    }
                    if measured {
                        self.skinned += match update {
                            KeyUpdate::Unchanged => 0,
                            KeyUpdate::Advanced => vertices,
                            KeyUpdate::Restarted => 2 * vertices,
                        };
                    }
                    let t1 = Instant::now();
                    if crowd.pose_changed(id)? || update == KeyUpdate::Restarted {
                        h.shown = if keys.weight <= 0.0 {
                            0
                        } else if keys.weight >= 1.0 {
                            1
                        } else {
                            let [a, b] = &h.keys;
                            SkinBlendJob {
                                from: (&a.0, &a.1),
                                to: (&b.0, &b.1),
                                weight: keys.weight,
                                positions: &mut h.out.0,
                                normals: &mut h.out.1,
                            }
                            .run()?;
                            2
                        };
                    }
                    skin_s += t0.elapsed().as_secs_f64();
                    blend_s += t1.elapsed().as_secs_f64();
                } else {
                    let (p, k) = skin_meshes(rig, palette, &mut self.out[ci], |skin, p| {
                        crowd.skinning_matrices(id, skin, p)
                    })?;
                    palette_s += p;
                    skin_s += k;
                    if measured {
                        self.skinned += vertices;
                    }
                }
                ci += 1;
            }
        }
        self.primed = true;
        if measured {
            let x = &mut self.stages;
            x.sample_ms += st.sample_ns as f64 * 1e-6;
            x.concat_ms += st.concat_ns as f64 * 1e-6;
            x.palette_ms += palette_s * 1e3;
            x.skin_ms += skin_s * 1e3;
            x.blend_ms += blend_s * 1e3;
        }
        Ok(())
    }

    /// Character `ci`'s skinned positions shown now (skeleton model space).
    fn shown(&self, ci: usize) -> &[Vec3] {
        if self.keyed && self.held.is_none() {
            self.host[ci].positions()
        } else {
            &self.out[ci].0
        }
    }

    /// The stage times per measured frame.
    fn per_frame(&self, frames: usize) -> Stages {
        let f = frames.max(1) as f64;
        let x = &self.stages;
        Stages {
            sample_ms: x.sample_ms / f,
            concat_ms: x.concat_ms / f,
            palette_ms: x.palette_ms / f,
            skin_ms: x.skin_ms / f,
            blend_ms: x.blend_ms / f,
        }
    }
}

/// Measures every stage of the pipeline for `setup.characters` characters on one thread, with
/// LOD off and with `setup.lod`, the two advanced in lockstep (a frame of one, then the same
/// frame of the other, so that a change of machine load hits both alike). With LOD the host
/// keeps its skinned output per key pose ([`Crowd::key_poses`]): it skins only key poses that
/// changed, blends the two skinned copies when the weight is strictly between 0 and 1 (at 0 or
/// 1 a copy is the output), and reuses everything for a character whose pose did not change
/// (palette time is part of `skin_ms` there; `palette_ms` counts LOD off's palettes). With
/// [`LargeSetup::held_joints_px`] the LOD crowd keeps exact poses and the host skins with held
/// joints ([`SkinHoldJob`]; palettes of every character every frame). The error compares the
/// skinned vertices the two hosts show every measured frame (and, beside it, the crowds' model
/// matrices at bone origins and tips).
pub fn run_pipeline(rig: &Arc<Rig>, setup: &LargeSetup) -> Result<PipelineRow, CrowdError> {
    let view = setup.view()?;
    let vertices: usize = rig.meshes().iter().map(|m| m.vertex_count()).sum();
    let mut full = PipelineRun::new(rig, setup, LodMode::Off, false, None)?;
    let (lod_mode, keyed) = match setup.held_joints_px {
        Some(_) => (LodMode::Off, false),
        None => (setup.lod, true),
    };
    let mut lod = PipelineRun::new(rig, setup, lod_mode, keyed, setup.held_joints_px)?;
    let (mut sum, mut tips) = (ErrorSum::default(), ErrorSum::default());
    let sk = rig.skeleton();
    for frame in 0..setup.warmup_frames + setup.frames {
        let measured = frame >= setup.warmup_frames;
        full.frame(rig, setup, &view, measured)?;
        lod.frame(rig, setup, &view, measured)?;
        if measured {
            let mut ci = 0;
            for s in 0..SHARDS {
                let (a, b) = (&full.s.shards[s], &lod.s.shards[s]);
                for (&x, &y) in full.s.ids[s].iter().zip(&lod.s.ids[s]) {
                    let world = a.world_transform(x)?;
                    tips.add_pose(
                        sk,
                        b.model_matrices(y)?,
                        a.model_matrices(x)?,
                        &world,
                        &view,
                    );
                    add_vertex_errors(&mut sum, &world, &view, lod.shown(ci), full.shown(ci));
                    ci += 1;
                }
            }
        }
    }
    let (e, t) = (sum.finish(), tips.finish());
    Ok(PipelineRow {
        characters: setup.characters,
        vertices,
        full: full.per_frame(setup.frames),
        lod: lod.per_frame(setup.frames),
        lod_skinned_fraction: lod.skinned as f64 / full.skinned.max(1) as f64,
        mean_error_px: e.mean_px,
        max_error_px: e.max_px,
        max_bone_tip_error_px: t.max_px,
    })
}

/// One character's host side of the whole pipeline: its shard and id, its skinned output
/// (positions and normals of every mesh, one after the other) and its held state per mesh
/// (held joints only).
struct HostCharacter {
    shard: usize,
    id: CharacterId,
    out: (Vec<Vec3>, Vec<Vec3>),
    states: Vec<HeldSkin>,
    /// This frame's shared pose, if the character shows one (then `out` is stale).
    shared: Option<SharedPose>,
}

/// The whole pipeline of a sharded crowd (sample, concatenate, palette, skin every character
/// every frame), at full detail or skinned with held joints, on whichever threads the current
/// pool has: the shards advance in parallel, then the characters are skinned in parallel (a
/// finer grain than shards: near characters cost more to skin than far ones). A character's
/// output depends only on its own shard's crowd and its own host state, so any thread count
/// gives the same vertices.
struct Whole {
    s: Sharded,
    chars: Vec<HostCharacter>,
    layouts: Vec<SkinHoldLayout>,
    /// Held joints within this many pixels; `None`: every vertex skinned every frame.
    held_px: Option<f32>,
    predict: bool,
    /// Shared phase-bucket poses (with held joints and [`LargeSetup::shared_poses_mib`]).
    share: Option<PoseShare>,
    /// Characters that showed a shared pose in the last frame.
    shared_last: u64,
    /// Per shard, its characters' range in `chars` (they are stored shard by shard).
    spans: Vec<std::ops::Range<usize>>,
}

impl Whole {
    fn new(rig: &Arc<Rig>, setup: &LargeSetup, held_px: Option<f32>) -> Result<Whole, CrowdError> {
        let s = Sharded::new(rig, setup, LodMode::Off)?;
        let layouts = held_layouts(rig)?;
        let vertices: usize = rig.meshes().iter().map(|m| m.vertex_count()).sum();
        let mut chars = Vec::with_capacity(setup.characters);
        let mut spans = Vec::with_capacity(s.ids.len());
        for (shard, ids) in s.ids.iter().enumerate() {
            spans.push(chars.len()..chars.len() + ids.len());
            for &id in ids {
                chars.push(HostCharacter {
                    shard,
                    id,
                    out: (vec![Vec3::ZERO; vertices], vec![Vec3::ZERO; vertices]),
                    states: match held_px {
                        Some(_) => layouts.iter().map(HeldSkin::new).collect(),
                        None => Vec::new(),
                    },
                    shared: None,
                });
            }
        }
        Ok(Whole {
            s,
            chars,
            layouts,
            held_px,
            predict: setup.held_joints_predict,
            shared_last: 0,
            spans,
            share: match (held_px, setup.shared_poses_mib) {
                (Some(_), Some(mib)) => {
                    let mut share = PoseShare::new(rig.clone(), 1, true)?;
                    share.set_capacity((mib << 20) / share.bytes_per_pose())?;
                    Some(share)
                }
                _ => None,
            },
        })
    }

    /// One frame (in parallel on the current pool); returns the vertices skinned. The shards
    /// advance; the characters choose their shared poses; then the shared poses are skinned
    /// beside the crowds being told who shares (each shard its own characters) and every other
    /// character being skinned (a character's own skinning does not read the shared poses):
    /// fewer regions, fewer times a thread waits for the others or for the host to wake it.
    fn frame(&mut self, rig: &Rig, dt: f32, view: &View) -> Result<u64, CrowdError> {
        self.s
            .shards
            .par_iter_mut()
            .try_for_each(|crowd| crowd.advance(dt, view).map(|_| ()))?;
        let spec = self.held_px.map(|max_error_px| HeldSpec {
            layouts: &self.layouts,
            max_error_px,
            predict: self.predict,
        });
        let mut used = Vec::new();
        if let (Some(share), Some(px)) = (&mut self.share, self.held_px) {
            let shards = &self.s.shards;
            // Which characters may show their phase bucket's pose (a pure function of each
            // character); their poses are skinned once for all who share them, below.
            let share_ref = &*share;
            let poses: Vec<Result<Option<SharedPose>, CrowdError>> = self
                .chars
                .par_iter()
                .map(|c| {
                    let crowd = &shards[c.shard];
                    let ppu = crowd.pixels_per_unit(c.id)?;
                    let tolerance = if ppu > 0.0 { px / ppu } else { f32::INFINITY };
                    share_ref.pose_for(crowd.clip(c.id)?, crowd.time(c.id)?, tolerance)
                })
                .collect();
            let mut poses = poses.into_iter().collect::<Result<Vec<_>, _>>()?;
            share.keep_worthwhile(&mut poses);
            for (c, p) in self.chars.iter_mut().zip(poses) {
                c.shared = p;
            }
            self.shared_last = self.chars.iter().filter(|c| c.shared.is_some()).count() as u64;
            used = self.chars.iter().filter_map(|c| c.shared).collect();
        }
        let shards = &mut self.s.shards;
        let chars = &mut self.chars;
        let spans = &self.spans;
        let share = &mut self.share;
        let sharing = share.is_some();
        let mut skin_all = || -> Result<Vec<Result<u64, CrowdError>>, CrowdError> {
            if sharing {
                // The crowds skip the poses of characters that show a shared one, and evaluate
                // those that stop sharing at once (their own pose is skinned just below).
                let flags = &*chars;
                shards
                    .par_iter_mut()
                    .zip(spans.par_iter())
                    .try_for_each(|(crowd, span)| {
                        flags[span.clone()]
                            .iter()
                            .try_for_each(|c| crowd.set_pose_shared(c.id, c.shared.is_some()))
                    })?;
            }
            let shards = &*shards;
            Ok(chars
                .par_iter_mut()
                .map_init(Vec::new, |palette, c| {
                    let crowd = &shards[c.shard];
                    Ok(match spec {
                        Some(_) if c.shared.is_some() => {
                            // Shows a shared pose: its own output goes stale.
                            c.states.iter_mut().for_each(HeldSkin::reset);
                            0
                        }
                        Some(spec) => {
                            skin_held(rig, crowd, c.id, spec, &mut c.states, palette, &mut c.out)?.2
                        }
                        None => {
                            skin_meshes(rig, palette, &mut c.out, |skin, p| {
                                crowd.skinning_matrices(c.id, skin, p)
                            })?;
                            c.out.0.len() as u64
                        }
                    })
                })
                .collect())
        };
        let (prepared, done) = match share {
            Some(share) => {
                let (p, d) = rayon::join(|| share.prepare(&used), skin_all);
                (p?.vertices_skinned, d?)
            }
            None => (0, skin_all()?),
        };
        done.into_iter().try_fold(prepared, |a, d| Ok(a + d?))
    }

    /// A character's skinned positions and normals this frame (its shared pose's if it shows
    /// one).
    fn output<'a>(&'a self, c: &'a HostCharacter) -> (&'a [Vec3], &'a [Vec3]) {
        c.shared
            .zip(self.share.as_ref())
            .and_then(|(p, s)| s.skinned(p))
            .unwrap_or((&c.out.0, &c.out.1))
    }

    /// The on-screen error of this pipeline's skinned vertices against `reference`'s (same
    /// setup), at every vertex in view (in parallel on the current pool).
    fn error_against(&self, reference: &Whole, view: &View) -> Result<ErrorSum, CrowdError> {
        let sums: Vec<Result<ErrorSum, CrowdError>> = self
            .chars
            .par_iter()
            .zip(reference.chars.par_iter())
            .map(|(a, b)| {
                let mut sum = ErrorSum::default();
                let world = reference.s.shards[b.shard].world_transform(b.id)?;
                add_vertex_errors(&mut sum, &world, view, self.output(a).0, &b.out.0);
                Ok(sum)
            })
            .collect();
        sums.into_iter().try_fold(ErrorSum::default(), |mut a, s| {
            a.merge(&s?);
            Ok(a)
        })
    }

    /// Whether two pipelines' skinned outputs (positions and normals) are bit-identical.
    fn same_output(&self, other: &Whole) -> bool {
        let same = |x: &[Vec3], y: &[Vec3]| {
            x.len() == y.len()
                && x.iter()
                    .zip(y)
                    .all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits))
        };
        self.chars.len() == other.chars.len()
            && self.chars.iter().zip(&other.chars).all(|(a, b)| {
                let (x, y) = (self.output(a), other.output(b));
                a.shared == b.shared && same(x.0, y.0) && same(x.1, y.1)
            })
    }
}

/// The whole pipeline of a large crowd (sample, concatenate, palette and CPU-skin every
/// character every frame; the host's cost, not only the animation's), skinned with held
/// joints within `setup.held_joints_px` (required) against full detail: both on one thread in
/// lockstep (times, and the error at every skinned vertex in view), then the held-joint
/// pipeline alone on one thread and on `threads` threads in lockstep (the speed-up, and whether
/// the two skinned every vertex bit-identically). `interpolated_fraction` is 1 (poses are
/// exact); `changed_fraction` is the fraction of vertices skinned (shared poses' included).
/// With [`LargeSetup::shared_poses_mib`], characters far enough away show the skinned pose of
/// their clip's phase bucket instead ([`PoseShare`]; the crowd skips their poses), within the
/// same bound.
pub fn run_pipeline_large(
    rig: &Arc<Rig>,
    setup: &LargeSetup,
    threads: usize,
) -> Result<LargeRow, CrowdError> {
    let px = setup.held_joints_px.ok_or(CrowdError::InvalidArgument {
        what: "held_joints_px",
        reason: "the whole-pipeline measurement skins with held joints: give a bound",
    })?;
    let view = setup.view()?;
    let (one, many) = (pool(1)?, pool(threads.max(1))?);
    let frames = setup.frames.max(1) as f64;
    let (full_ms, lod_ms, sum, skinned, shared) = {
        let mut full = Whole::new(rig, setup, None)?;
        let mut lod = Whole::new(rig, setup, Some(px))?;
        let (mut tf, mut tl, mut sum) = (0.0f64, 0.0f64, ErrorSum::default());
        let (mut done, mut all, mut shared) = (0u64, 0u64, 0u64);
        for frame in 0..setup.warmup_frames + setup.frames {
            let t0 = Instant::now();
            let f = one.install(|| full.frame(rig, setup.dt, &view))?;
            let t1 = Instant::now();
            let l = one.install(|| lod.frame(rig, setup.dt, &view))?;
            let t2 = Instant::now();
            if frame >= setup.warmup_frames {
                shared += lod.shared_last;
                tf += (t1 - t0).as_secs_f64();
                tl += (t2 - t1).as_secs_f64();
                (done, all) = (done + l, all + f);
                sum.merge(&many.install(|| lod.error_against(&full, &view))?);
            }
        }
        (
            tf * 1e3 / frames,
            tl * 1e3 / frames,
            sum.finish(),
            done as f64 / all.max(1) as f64,
            shared as f64 / (frames * setup.characters.max(1) as f64),
        )
    };
    let mut serial = Whole::new(rig, setup, Some(px))?;
    let mut parallel = Whole::new(rig, setup, Some(px))?;
    let lockstep = Lockstep::run(
        setup,
        (&one, &many),
        || serial.frame(rig, setup.dt, &view).map(|_| ()),
        || parallel.frame(rig, setup.dt, &view).map(|_| ()),
    )?;
    Ok(LargeRow {
        interpolated_fraction: 1.0,
        changed_fraction: skinned,
        shared_fraction: shared,
        deterministic: serial.same_output(&parallel) && serial.s.poses() == parallel.s.poses(),
        ..LargeRow::timed(setup, threads, (full_ms, lod_ms), &lockstep, &sum)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn gdbot() -> Arc<Rig> {
        let path =
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf/GDQuest_GDBot.glb");
        Arc::new(metric_rig(&animlod::build::import_path(&path).unwrap()).unwrap())
    }

    #[test]
    fn large_crowd_is_deterministic_across_threads_and_within_the_bound() {
        let rig = gdbot();
        let mut setup = LargeSetup::new(300);
        (setup.warmup_frames, setup.frames) = (3, 8);
        let row = run_large(&rig, &setup, 2).unwrap();
        println!("{row:?} cost {:.2}", row.cost_ratio());
        assert!(row.deterministic);
        assert!(row.max_error_px <= 1.1, "{row:?}");
        assert!(row.interpolated_fraction < 1.0);
    }

    #[test]
    fn pipeline_stages_are_measured_and_held_characters_skip_skinning() {
        let rig = gdbot();
        let mut setup = LargeSetup::new(24);
        (setup.warmup_frames, setup.frames) = (2, 4);
        let row = run_pipeline(&rig, &setup).unwrap();
        println!("{row:?}");
        assert!(row.vertices > 0);
        let (f, l) = (row.full, row.lod);
        assert!(f.sample_ms > 0.0 && f.concat_ms > 0.0 && f.palette_ms > 0.0 && f.skin_ms > 0.0);
        assert!(l.skin_ms > 0.0 && row.lod_skinned_fraction < 1.0, "{row:?}");
        assert!(row.max_error_px <= 1.1, "{row:?}");
    }

    #[test]
    fn held_joints_stay_within_the_bound_at_every_skinned_vertex() {
        let rig = gdbot();
        let mut setup = LargeSetup::new(24);
        (setup.warmup_frames, setup.frames) = (2, 8);
        setup.held_joints_px = Some(1.0);
        for predict in [false, true] {
            setup.held_joints_predict = predict;
            let row = run_pipeline(&rig, &setup).unwrap();
            println!("{row:?}");
            // The bound holds at every vertex (pixels per unit taken at the bounding sphere's
            // nearest point, the vertex's own pixels per unit no larger).
            assert!(row.max_error_px <= 1.001, "{row:?}");
            assert!(row.mean_error_px > 0.0, "{row:?}");
            // Poses are exact; only skinning holds, and it skips vertices.
            assert_eq!(row.max_bone_tip_error_px, 0.0);
            assert!(row.lod_skinned_fraction > 0.0 && row.lod_skinned_fraction < 0.8);
        }
    }

    #[test]
    fn held_joints_stay_within_the_bound_on_every_bundled_rig() {
        for name in [
            "Fox.glb",
            "RobotExpressive.glb",
            "Godot_PlatformerRobot.glb",
            "SimpleSkin.gltf",
        ] {
            let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../assets/gltf")
                .join(name);
            let base = animlod::build::import_path(&path).unwrap();
            // SimpleSkin's joints sit on one line with no height: kept at its own size.
            let rig = Arc::new(metric_rig(&base).unwrap_or(base));
            if rig.meshes().is_empty() || crate::crowd::playable_clips(&rig).is_empty() {
                continue;
            }
            let mut setup = LargeSetup::new(16);
            (setup.warmup_frames, setup.frames) = (2, 8);
            setup.held_joints_px = Some(1.0);
            let row = run_pipeline(&rig, &setup).unwrap();
            println!("{name}: {row:?}");
            assert!(row.max_error_px <= 1.001, "{name}: {row:?}");
            assert!(row.lod_skinned_fraction < 1.0, "{name}: {row:?}");
        }
    }

    #[test]
    fn whole_pipeline_with_held_joints_is_deterministic_across_threads_and_within_the_bound() {
        let rig = gdbot();
        let mut setup = LargeSetup::new(48);
        (setup.warmup_frames, setup.frames) = (2, 6);
        setup.held_joints_px = Some(0.6);
        let row = run_pipeline_large(&rig, &setup, 2).unwrap();
        println!("{row:?} cost {:.2}", row.cost_ratio());
        assert!(row.deterministic);
        assert!(row.max_error_px <= 0.601, "{row:?}");
        assert!(row.mean_error_px > 0.0, "{row:?}");
        // Fewer vertices skinned than full detail's.
        assert!(
            row.changed_fraction > 0.0 && row.changed_fraction < 0.8,
            "{row:?}"
        );
        // Far characters sharing phase-bucket poses: the same bound at every skinned vertex,
        // the same vertices on every thread count, and, once a clip cycle has filled the kept
        // poses, fewer vertices skinned.
        setup.shared_poses_mib = Some(16);
        setup.warmup_frames = 90;
        let shared = run_pipeline_large(&rig, &setup, 2).unwrap();
        println!("{shared:?} cost {:.2}", shared.cost_ratio());
        assert!(shared.deterministic);
        assert!(shared.max_error_px <= 0.601, "{shared:?}");
        assert!(shared.shared_fraction > 0.2, "{shared:?}");
        assert!(shared.changed_fraction < row.changed_fraction, "{shared:?}");
        setup.held_joints_px = None;
        assert!(run_pipeline_large(&rig, &setup, 2).is_err());
    }
}
