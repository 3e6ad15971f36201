//! Shared poses: characters that play the same clip at nearly the same phase share one skinned
//! output, when the on-screen error allows.
//!
//! Beyond the thesis (`animation-lod-bone-priority-thesis.txt`, chapters 11–13, saves work per
//! bone and per character); crowd renderers have long shared work across characters instead:
//! animation instancing plays a few baked copies of a clip and has many characters draw each
//! copy (Dudash, "Skinned Instancing", NVIDIA, 2007; Beacco et al., "A Survey of Real-Time
//! Crowd Rendering", Computer Graphics Forum 35(8), 2016, §4 on animation LOD and shared
//! poses). Here the sharing is decided at run time, per character and frame, by the error a
//! viewer would see:
//!
//! - A clip's time line is cut into dyadic phase buckets (level `L`: `2^L` buckets of equal
//!   length, `L` = 0..=[`MAX_LEVEL`]). Every character whose phase falls in a bucket can show
//!   the pose at the bucket's centre instead of its own.
//! - For every bucket the largest displacement of any skinned vertex between a pose in the
//!   bucket and the centre's pose is measured once per rig, from the skinning palettes: a
//!   vertex skinned with `Σ w_k P_k` instead of `Σ w_k C_k` moves at most
//!   `max_k |(P_k − C_k) p|`, and over the bind-space box around the vertices joint `k` moves
//!   that is largest at a corner of the box (see [`crate::SkinHoldJob`]). Poses are sampled at
//!   [`SAMPLES_PER_FINEST`] times per finest bucket; half the largest displacement between
//!   neighbouring samples is added for the times between them.
//! - A character whose tolerance (its on-screen bound over its pixels per model unit) admits a
//!   bucket takes the coarsest such bucket; its output is that bucket's skinned vertices,
//!   computed once for every character that shares it and kept for later frames (a bucket's
//!   pose never changes). Characters too near for any bucket are skinned on their own.
//!
//! Every vertex is then within the tolerance of its exact position (up to the sampling above).
//! The pose moves in steps of a bucket (a lower frame rate for distant characters, as in the
//! thesis' holds), each step at most twice the tolerance on screen. Results do not depend on
//! the thread count: a bucket's vertices are a function of the bucket alone, and entries are
//! added and evicted in a fixed order.

use std::collections::HashMap;
use std::sync::Arc;

use glam::{Affine3A, Mat4, Vec3};
use rayon::prelude::*;

use crate::clip::{Cursor, TrsScratch};
use crate::error::{CrowdError, invalid};
use crate::ids::ClipId;
use crate::mesh::SkinningJob;
use crate::rig::Rig;
use crate::skin_hold::{SkinHoldLayout, corner_error2};

/// Finest bucket level: `2^MAX_LEVEL` buckets per clip (about 2 ms each on a one-second clip:
/// finer than a frame, so a character 60-100 m away shares poses mostly with its own earlier
/// cycles and with other characters' through the kept poses). On 1,000 characters 2-200 m away
/// within 0.6 px, with held joints for the rest and 2,048 poses kept, whole-pipeline cost fell
/// from 0.39 to 0.26 of full detail on Fox and from 0.53 to 0.34 on RobotExpressive going
/// from 7 to 9 levels.
pub const MAX_LEVEL: u8 = 9;

/// Pose samples per finest bucket when the deviations are measured (even, so that every
/// bucket's centre is a sample).
pub const SAMPLES_PER_FINEST: usize = 4;

/// One phase bucket of one clip: the pose characters in it share.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SharedPose {
    /// The clip.
    pub clip: ClipId,
    /// Bucket level: the clip is cut into `2^level` buckets.
    pub level: u8,
    /// Bucket index at that level, from the clip's start.
    pub bucket: u32,
}

/// A bucket's skinned output and when it was last asked for.
#[derive(Clone, Debug)]
struct Entry {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    last_used: u64,
}

/// What one [`PoseShare::prepare`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PrepareStats {
    /// Distinct shared poses asked for this frame.
    pub poses_used: u32,
    /// Of those, poses skinned this frame (the rest were kept from earlier frames).
    pub poses_skinned: u32,
    /// Vertices skinned for them (every mesh of the rig, per pose skinned).
    pub vertices_skinned: u64,
    /// Poses dropped to stay within the capacity (least recently used first).
    pub poses_evicted: u32,
}

/// Shared skinned poses of one rig's clips (see the module docs): which bucket a character may
/// share, and the buckets' skinned vertices, kept across frames up to a capacity.
#[derive(Clone, Debug)]
pub struct PoseShare {
    rig: Arc<Rig>,
    /// Per clip, per level, per bucket: the largest vertex displacement (model units) of a pose
    /// in the bucket from its centre's.
    deviation: Vec<Vec<Vec<f32>>>,
    entries: HashMap<SharedPose, Entry>,
    /// Buffers of evicted poses, reused by the next poses skinned: a pose's positions and
    /// normals are hundreds of kilobytes, which the allocator maps and the kernel zero-fills
    /// page by page on every fresh allocation (and serialises between threads), so skinning into
    /// new buffers cost about three times the skinning itself on two threads.
    spare: Vec<Entry>,
    capacity: usize,
    frame: u64,
    vertices: usize,
    /// Whether [`PoseShare::prepare`] skins on the current rayon pool.
    parallel: bool,
}

/// Per-thread scratch of a pose evaluation.
#[derive(Default)]
struct Eval {
    cursors: Vec<Cursor>,
    trs: TrsScratch,
    locals: Vec<Affine3A>,
    models: Vec<Mat4>,
}

impl Eval {
    /// Every mesh's palette (model × inverse bind of its skin's joints) at `time` of `clip`.
    fn palettes(&mut self, rig: &Rig, clip: ClipId, time: f32, out: &mut [Vec<Mat4>]) {
        let n = rig.bone_count();
        self.locals.resize(n, Affine3A::IDENTITY);
        self.models.resize(n, Mat4::IDENTITY);
        rig.clips()[clip.index()].sample_locals(
            time,
            &mut self.cursors,
            &mut self.trs,
            &mut self.locals,
        );
        rig.skeleton()
            .model_matrices(&self.locals, &mut self.models);
        for (mesh, p) in rig.meshes().iter().zip(out) {
            let skin = &rig.skins()[mesh.skin.index()];
            p.resize(skin.joints.len(), Mat4::IDENTITY);
            crate::crowd::palette(skin, &self.models, p);
        }
    }
}

/// Largest vertex displacement between skinning with palettes `a` and `b` (per mesh), over
/// every joint's box.
fn displacement(layouts: &[SkinHoldLayout], a: &[Vec<Mat4>], b: &[Vec<Mat4>]) -> f32 {
    let mut worst = 0.0f32;
    for ((l, pa), pb) in layouts.iter().zip(a).zip(b) {
        for ((bx, ma), mb) in l.joint_boxes().iter().zip(pa).zip(pb) {
            if let Some((lo, hi)) = *bx {
                worst = worst.max(corner_error2(&(*ma - *mb), lo, hi));
            }
        }
    }
    worst.sqrt()
}

impl PoseShare {
    /// The shared poses of `rig`, keeping at most `capacity` skinned poses (each holds a
    /// position and a normal per vertex of every mesh). Measures every clip's bucket
    /// deviations (tens of milliseconds per rig), with `parallel` on the current rayon pool,
    /// else on the calling thread; `parallel` also applies to [`PoseShare::prepare`] (see
    /// [`PoseShare::set_parallel`]). Refused for a rig without a skinned mesh or a zero
    /// capacity.
    pub fn new(rig: Arc<Rig>, capacity: usize, parallel: bool) -> Result<PoseShare, CrowdError> {
        if rig.meshes().is_empty() {
            return Err(invalid("rig", "has no skinned mesh to share"));
        }
        if capacity == 0 {
            return Err(invalid("capacity", "must be at least 1"));
        }
        let layouts = rig
            .meshes()
            .iter()
            .map(|m| SkinHoldLayout::new(m, rig.skins()[m.skin.index()].joints.len()))
            .collect::<Result<Vec<_>, _>>()?;
        let clips = (0..rig.clips().len()).map(ClipId::new).collect::<Vec<_>>();
        let deviation = if parallel {
            clips
                .par_iter()
                .map(|&clip| clip_deviation(&rig, &layouts, clip))
                .collect()
        } else {
            clips
                .iter()
                .map(|&clip| clip_deviation(&rig, &layouts, clip))
                .collect()
        };
        let vertices = rig.meshes().iter().map(|m| m.vertex_count()).sum();
        Ok(PoseShare {
            rig,
            deviation,
            entries: HashMap::new(),
            spare: Vec::new(),
            capacity,
            frame: 0,
            vertices,
            parallel,
        })
    }

    /// Bytes one kept pose takes (a position and a normal per vertex of every mesh), to size
    /// the capacity from a memory budget.
    pub fn bytes_per_pose(&self) -> usize {
        self.vertices * 2 * std::mem::size_of::<Vec3>() + std::mem::size_of::<Entry>()
    }

    /// The most poses kept across frames.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Sets the most poses kept across frames (at least 1); the excess goes at the next
    /// [`PoseShare::prepare`].
    pub fn set_capacity(&mut self, capacity: usize) -> Result<(), CrowdError> {
        if capacity == 0 {
            return Err(invalid("capacity", "must be at least 1"));
        }
        self.capacity = capacity;
        Ok(())
    }

    /// Whether [`PoseShare::prepare`] skins missing poses on the current rayon pool (results
    /// are the same either way) or on the calling thread (a host that runs its own threads).
    pub fn set_parallel(&mut self, on: bool) {
        self.parallel = on;
    }

    /// The rig.
    pub fn rig(&self) -> &Arc<Rig> {
        &self.rig
    }

    /// The coarsest bucket a character playing `clip` at `time` (seconds, within the clip) may
    /// share with every vertex within `tolerance` model units of its exact position, or `None`
    /// when even the finest bucket moves a vertex farther. Refused for an unknown clip or a
    /// non-finite time; a NaN or negative tolerance shares nothing.
    pub fn pose_for(
        &self,
        clip: ClipId,
        time: f32,
        tolerance: f32,
    ) -> Result<Option<SharedPose>, CrowdError> {
        let dev = self
            .deviation
            .get(clip.index())
            .ok_or(CrowdError::UnknownClip(clip))?;
        if !time.is_finite() {
            return Err(invalid("time", "must be finite"));
        }
        let duration = self.rig.clips()[clip.index()].duration();
        let phase = if duration > 0.0 {
            (time / duration).clamp(0.0, 1.0)
        } else {
            0.0
        };
        for (level, buckets) in dev.iter().enumerate() {
            let count = buckets.len();
            let bucket = ((phase * count as f32) as usize).min(count - 1);
            if buckets[bucket] <= tolerance {
                return Ok(Some(SharedPose {
                    clip,
                    level: level as u8,
                    bucket: bucket as u32,
                }));
            }
        }
        Ok(None)
    }

    /// The clip time of a bucket's pose (its centre).
    pub fn time_of(&self, pose: SharedPose) -> f32 {
        let duration = self
            .rig
            .clip(pose.clip)
            .map_or(0.0, |c| c.duration().max(0.0));
        (pose.bucket as f32 + 0.5) * duration / (1u64 << pose.level) as f32
    }

    /// The largest displacement of a vertex (model units) between a pose in the bucket and the
    /// bucket's shared pose; `None` for a bucket this rig does not have.
    pub fn deviation(&self, pose: SharedPose) -> Option<f32> {
        self.deviation
            .get(pose.clip.index())?
            .get(pose.level as usize)?
            .get(pose.bucket as usize)
            .copied()
    }

    /// Keeps, of every character's candidate pose (one entry per character, `None` for none),
    /// only those worth sharing this frame: a pose already kept, or asked for by two
    /// characters or more, or, while the capacity has room, any (coarsest levels first, then
    /// in bucket order). The others are set to `None`: a pose skinned for one character and
    /// then dropped costs a whole skinning, more than skinning that character with held joints.
    /// Returns how many candidates were dropped.
    pub fn keep_worthwhile(&self, candidates: &mut [Option<SharedPose>]) -> usize {
        let mut wanted: Vec<SharedPose> = candidates.iter().flatten().copied().collect();
        wanted.sort_unstable_by_key(|p| (p.level, p.clip, p.bucket));
        let mut room = self.capacity.saturating_sub(self.entries.len());
        let mut granted = std::collections::HashSet::new();
        let mut i = 0;
        while i < wanted.len() {
            let p = wanted[i];
            let users = wanted[i..].iter().take_while(|&&q| q == p).count();
            if self.entries.contains_key(&p) || users >= 2 {
                granted.insert(p);
            } else if room > 0 {
                room -= 1;
                granted.insert(p);
            }
            i += users;
        }
        let mut dropped = 0;
        for c in candidates.iter_mut() {
            if c.is_some_and(|p| !granted.contains(&p)) {
                *c = None;
                dropped += 1;
            }
        }
        dropped
    }

    /// Makes every pose in `poses` (duplicates allowed) available to [`PoseShare::skinned`]
    /// for this frame: skins those not kept from earlier frames (on the current rayon pool if
    /// parallel, see [`PoseShare::set_parallel`]), then drops the least recently used others beyond the capacity (never one
    /// asked for now; the capacity grows for a frame that needs more). Refused, changing
    /// nothing, for a pose this rig does not have.
    pub fn prepare(&mut self, poses: &[SharedPose]) -> Result<PrepareStats, CrowdError> {
        if let Some(p) = poses.iter().find(|&&p| self.deviation(p).is_none()) {
            return Err(invalid(
                "pose",
                if self.rig.clip(p.clip).is_none() {
                    "names an unknown clip"
                } else {
                    "names a level or bucket the clip does not have"
                },
            ));
        }
        self.frame += 1;
        let mut wanted = poses.to_vec();
        wanted.sort_unstable();
        wanted.dedup();
        let missing: Vec<SharedPose> = wanted
            .iter()
            .copied()
            .filter(|p| !self.entries.contains_key(p))
            .collect();
        let rig = &self.rig;
        let times: Vec<f32> = missing.iter().map(|&p| self.time_of(p)).collect();
        let vertices = self.vertices;
        // One buffer per pose to skin: an evicted pose's where there is one.
        let buffers: Vec<Option<Entry>> = (0..missing.len()).map(|_| self.spare.pop()).collect();
        let init = || (Eval::default(), vec![Vec::new(); rig.meshes().len()]);
        let skin =
            |(eval, palettes): &mut (Eval, Vec<Vec<Mat4>>),
             ((&pose, &time), buffer): ((&SharedPose, &f32), Option<Entry>)| {
                eval.palettes(rig, pose.clip, time, palettes);
                let mut e = buffer.unwrap_or_else(|| Entry {
                    positions: vec![Vec3::ZERO; vertices],
                    normals: vec![Vec3::ZERO; vertices],
                    last_used: 0,
                });
                // Every vertex is overwritten below; the lengths only need to match.
                e.positions.resize(vertices, Vec3::ZERO);
                e.normals.resize(vertices, Vec3::ZERO);
                let mut at = 0;
                for (mesh, palette) in rig.meshes().iter().zip(palettes.iter()) {
                    let v = mesh.vertex_count();
                    SkinningJob {
                        mesh,
                        palette,
                        positions: &mut e.positions[at..at + v],
                        normals: &mut e.normals[at..at + v],
                    }
                    .run()?;
                    at += v;
                }
                Ok(e)
            };
        let skinned: Vec<Result<Entry, CrowdError>> = if self.parallel {
            missing
                .par_iter()
                .zip(&times)
                .zip(buffers)
                .map_init(init, skin)
                .collect()
        } else {
            let mut scratch = init();
            missing
                .iter()
                .zip(&times)
                .zip(buffers)
                .map(|x| skin(&mut scratch, x))
                .collect()
        };
        let mut stats = PrepareStats {
            poses_used: wanted.len() as u32,
            poses_skinned: missing.len() as u32,
            vertices_skinned: (missing.len() * vertices) as u64,
            poses_evicted: 0,
        };
        for (pose, e) in missing.into_iter().zip(skinned) {
            self.entries.insert(pose, e?);
        }
        for p in &wanted {
            if let Some(e) = self.entries.get_mut(p) {
                e.last_used = self.frame;
            }
        }
        if self.entries.len() > self.capacity {
            let mut old: Vec<(u64, SharedPose)> = self
                .entries
                .iter()
                .filter(|(_, e)| e.last_used < self.frame)
                .map(|(&p, e)| (e.last_used, p))
                .collect();
            old.sort_unstable();
            let excess = self.entries.len() - self.capacity;
            for &(_, p) in old.iter().take(excess) {
                if let Some(e) = self.entries.remove(&p) {
                    self.spare.push(e);
                }
                stats.poses_evicted += 1;
            }
            // Keep as many spare buffers as one frame's skinning used (a frame that skins more
            // than it evicted allocates the rest).
            self.spare.truncate(stats.poses_skinned.max(1) as usize);
        }
        Ok(stats)
    }

    /// A prepared pose's skinned positions and normals (every mesh of the rig, in order, in
    /// model space), or `None` if it is not kept.
    pub fn skinned(&self, pose: SharedPose) -> Option<(&[Vec3], &[Vec3])> {
        self.entries
            .get(&pose)
            .map(|e| (e.positions.as_slice(), e.normals.as_slice()))
    }

    /// Skinned poses kept.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether no skinned pose is kept.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// Per level, per bucket: the largest vertex displacement from the bucket centre's pose (see
/// the module docs).
fn clip_deviation(rig: &Rig, layouts: &[SkinHoldLayout], clip: ClipId) -> Vec<Vec<f32>> {
    let duration = rig.clips()[clip.index()].duration().max(0.0);
    let n = (1usize << MAX_LEVEL) * SAMPLES_PER_FINEST;
    let mut eval = Eval::default();
    let palettes: Vec<Vec<Vec<Mat4>>> = (0..=n)
        .map(|s| {
            let mut p = vec![Vec::new(); rig.meshes().len()];
            eval.palettes(rig, clip, duration * s as f32 / n as f32, &mut p);
            p
        })
        .collect();
    let step: Vec<f32> = palettes
        .windows(2)
        .map(|w| displacement(layouts, &w[0], &w[1]))
        .collect();
    (0..=MAX_LEVEL)
        .map(|level| {
            let buckets = 1usize << level;
            let per = n / buckets;
            (0..buckets)
                .map(|i| {
                    let (start, centre) = (i * per, i * per + per / 2);
                    let far = (start..=start + per)
                        .map(|s| displacement(layouts, &palettes[s], &palettes[centre]))
                        .fold(0.0f32, f32::max);
                    let between = step[start..start + per].iter().copied().fold(0.0, f32::max);
                    far + 0.5 * between
                })
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build::tests::asset;
    use crate::mesh::skin_vertex;

    fn fox() -> Arc<Rig> {
        Arc::new(crate::build::import_path(&asset("Fox.glb")).unwrap())
    }

    #[test]
    fn a_shared_pose_is_within_its_deviation_of_every_phase_in_its_bucket() {
        let rig = fox();
        let share = PoseShare::new(rig.clone(), 64, true).unwrap();
        let mut eval = Eval::default();
        let mut exact = vec![Vec::new(); rig.meshes().len()];
        let mut shared = exact.clone();
        for clip in (0..rig.clips().len()).map(ClipId::new) {
            let duration = rig.clip(clip).unwrap().duration();
            // Phases off the measurement samples (an irrational step).
            for k in 0..97 {
                let t = duration * (k as f32 * 0.618_034).fract();
                for tol in [0.0, 1e-3, 1e-2, 0.1, 1.0, 100.0] {
                    let Some(p) = share.pose_for(clip, t, tol).unwrap() else {
                        continue;
                    };
                    let dev = share.deviation(p).unwrap();
                    assert!(dev <= tol);
                    let w = duration / (1u64 << p.level) as f32;
                    let tc = share.time_of(p);
                    assert!((t - tc).abs() <= 0.5 * w * (1.0 + 1e-4) + 1e-6);
                    eval.palettes(&rig, clip, t, &mut exact);
                    eval.palettes(&rig, clip, tc, &mut shared);
                    for (mesh, (a, b)) in rig.meshes().iter().zip(exact.iter().zip(&shared)) {
                        for v in 0..mesh.vertex_count() {
                            let d = skin_vertex(mesh, a, v).0 - skin_vertex(mesh, b, v).0;
                            assert!(d.length() <= dev * 1.001 + 1e-5, "{p:?} t {t}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn coarser_buckets_for_larger_tolerances_and_none_below_the_finest() {
        let rig = fox();
        let share = PoseShare::new(rig.clone(), 8, true).unwrap();
        let clip = rig.clip_by_name("Walk").unwrap();
        let t = 0.37;
        let mut last = 0;
        for tol in [1e-3f32, 1e-2, 0.1, 1.0, 10.0, 1e3] {
            if let Some(p) = share.pose_for(clip, t, tol).unwrap() {
                assert!(p.level as i32 <= last || last == 0);
                last = p.level as i32;
            }
        }
        // The whole clip within a huge tolerance; nothing within zero on a moving clip.
        assert_eq!(share.pose_for(clip, t, 1e6).unwrap().unwrap().level, 0);
        assert_eq!(share.pose_for(clip, t, 0.0).unwrap(), None);
        assert!(share.pose_for(ClipId::new(99), t, 1.0).is_err());
        assert!(share.pose_for(clip, f32::NAN, 1.0).is_err());
    }

    #[test]
    fn prepared_poses_are_kept_evicted_least_recent_first_and_thread_independent() {
        let rig = fox();
        let mut share = PoseShare::new(rig.clone(), 3, true).unwrap();
        let clip = rig.clip_by_name("Walk").unwrap();
        let pose = |bucket| SharedPose {
            clip,
            level: MAX_LEVEL,
            bucket,
        };
        let st = share.prepare(&[pose(1), pose(2), pose(1)]).unwrap();
        assert_eq!((st.poses_used, st.poses_skinned), (2, 2));
        let st = share.prepare(&[pose(2), pose(3)]).unwrap();
        assert_eq!((st.poses_skinned, st.poses_evicted), (1, 0));
        // Over capacity: the least recently used (bucket 1) goes.
        let st = share.prepare(&[pose(4)]).unwrap();
        assert_eq!((st.poses_skinned, st.poses_evicted), (1, 1));
        assert!(share.skinned(pose(1)).is_none());
        assert!(share.skinned(pose(2)).is_some() && share.skinned(pose(4)).is_some());
        // A frame needing more than the capacity keeps them all.
        let all: Vec<SharedPose> = (10..16).map(pose).collect();
        share.prepare(&all).unwrap();
        assert!(all.iter().all(|&p| share.skinned(p).is_some()));
        // Bad input changes nothing.
        let before = share.len();
        let bad = SharedPose {
            clip,
            level: MAX_LEVEL + 1,
            bucket: 0,
        };
        assert!(share.prepare(&[pose(20), bad]).is_err());
        assert_eq!(share.len(), before);
        // The same deviations and vertices on the calling thread alone and on the pool.
        let mut other = PoseShare::new(rig.clone(), 16, false).unwrap();
        assert_eq!(other.deviation, share.deviation);
        other.prepare(&all).unwrap();
        for &p in &all {
            let (a, b) = (share.skinned(p).unwrap(), other.skinned(p).unwrap());
            assert_eq!(a.0, b.0);
            assert_eq!(a.1, b.1);
        }
        // Poses skinned into the buffers of evicted ones are the poses skinned afresh.
        let more: Vec<SharedPose> = (30..36).map(pose).collect();
        assert!(!share.spare.is_empty(), "evictions left buffers to reuse");
        share.prepare(&more).unwrap();
        let mut fresh = PoseShare::new(rig.clone(), 16, false).unwrap();
        fresh.prepare(&more).unwrap();
        for &p in &more {
            assert_eq!(share.skinned(p), fresh.skinned(p));
        }
    }

    #[test]
    fn every_bundled_rig_shares_within_its_deviation() {
        for file in [
            "GDQuest_GDBot.glb",
            "Fox.glb",
            "RobotExpressive.glb",
            "Godot_PlatformerRobot.glb",
            "SimpleSkin.gltf",
        ] {
            let rig = Arc::new(crate::build::import_path(&asset(file)).unwrap());
            let mut share = PoseShare::new(rig.clone(), 4, true).unwrap();
            let (_, radius) = rig.bounds();
            let mut poses = Vec::new();
            for clip in (0..rig.clips().len()).map(ClipId::new) {
                let duration = rig.clip(clip).unwrap().duration();
                for tol in [0.001, 0.01, 0.1].map(|f| f * radius.max(1e-3)) {
                    let t = 0.37 * duration;
                    if let Some(p) = share.pose_for(clip, t, tol).unwrap() {
                        assert!(share.deviation(p).unwrap() <= tol, "{file}");
                        poses.push(p);
                    }
                }
            }
            // A looping clip of a moving rig always shares at a tenth of its radius.
            assert!(!poses.is_empty(), "{file}");
            share.prepare(&poses).unwrap();
            for &p in &poses {
                let (pos, nrm) = share.skinned(p).unwrap();
                assert!(pos.iter().chain(nrm).all(|v| v.is_finite()), "{file}");
            }
        }
    }
}
