//! The thesis' crowd test (chapter 13), reusable by benchmarks and demos: characters of a
//! 153-bone rig in a grid or at random positions, the camera swept from near to far, and for each
//! distance the frame cost with and without LOD and the on-screen pose error.
//!
//! Two crowds run in lockstep: one at full detail (the reference — full-rate evaluation) and one
//! under the LOD mode tested. Frame costs are the median wall time of [`Crowd::advance`] over the
//! measured frames; errors compare the two crowds' joint positions every frame.
//!
//! Scene scale: the thesis gives its LOD range, [200, 1700], without units or character size. We
//! read it as centimetres — a person 180 units tall — which is the only reading under which the
//! range spans what a camera can see (a character fills the view at 200 and is ~100 px tall at
//! 1700 with a 60° field of view on a 1080-pixel viewport). [`thesis_rig`] scales a real rig to
//! that height.

use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;

use salience::View;

use animlod::{
    BuildError, ClipId, Crowd, CrowdError, ErrorSum, LodMode, PriorityWeights, Rig, SchedulerParams,
};

use crate::median;
use crate::rig::grown_to;
use crate::rng::Rng;

/// The thesis' bone count per character.
pub const THESIS_BONES: usize = 153;

/// The thesis' LOD range.
pub const THESIS_RANGE: LodMode = LodMode::Range {
    min: 200.0,
    max: 1700.0,
};

/// Character height (scene units) used to express a real rig in the thesis' units.
pub const THESIS_HEIGHT: f32 = 180.0;

/// Where the characters stand (on the ground plane `y = 0`, centred on the origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Layout {
    /// A square grid with this spacing between neighbours.
    Grid {
        /// Distance between neighbouring characters.
        spacing: f32,
    },
    /// Uniformly random positions in a square of this side (a cube in the thesis, flattened to
    /// the ground so characters stand on it).
    Random {
        /// Side of the square.
        side: f32,
        /// Seed of the generator.
        seed: u64,
    },
}

/// One run of the crowd test.
#[derive(Clone, Debug, PartialEq)]
pub struct CrowdExperiment {
    /// Number of characters.
    pub characters: usize,
    /// Their placement.
    pub layout: Layout,
    /// The clip they play (each at its own random phase).
    pub clip: ClipId,
    /// The LOD mode under test.
    pub lod: LodMode,
    /// Scheduler parameters of the LOD crowd.
    pub scheduler: SchedulerParams,
    /// Priority weights of the LOD crowd.
    pub weights: PriorityWeights,
    /// Priority source of the LOD crowd.
    pub source: animlod::PrioritySource,
    /// Camera distances (the camera looks along −z, at the height of the characters'
    /// bounding-sphere centre); see `camera_outside` for where they are measured from.
    pub distances: Vec<f32>,
    /// Whether distances are measured from the crowd's front edge (the nearest character's
    /// bounding sphere), so the camera is always outside the crowd and every character is in
    /// front of it; otherwise from the crowd's centre, as the thesis did, which puts the camera
    /// inside the crowd at short distances (part of the "saving" there is then culling).
    pub camera_outside: bool,
    /// Frames run before measuring, at each distance.
    pub warmup_frames: usize,
    /// Frames measured at each distance.
    pub frames: usize,
    /// Frame step in seconds.
    pub dt: f32,
    /// Vertical field of view (radians).
    pub fov_y: f32,
    /// Viewport height in pixels.
    pub viewport_height: f32,
    /// Viewport width over height.
    pub aspect: f32,
    /// Near plane distance.
    pub near: f32,
    /// Seed for the characters' phases.
    pub seed: u64,
}

impl CrowdExperiment {
    /// The experiment's view from `eye` along −z (its field of view, viewport and near plane).
    pub fn view_from(&self, eye: Vec3) -> Result<View, CrowdError> {
        let height = self.viewport_height.round().max(1.0) as u32;
        let width = (self.viewport_height * self.aspect).round().max(1.0) as u32;
        Ok(
            View::new(eye, Vec3::NEG_Z, Vec3::Y, self.fov_y, width, height)?
                .with_near(self.near)?,
        )
    }

    /// The thesis' setup: 100 characters in a grid (spacing 150 units), the thesis' range
    /// [200, 1700], the camera from 100 to 3000 units, 60 Hz, a 60° 16:9 view 1080 pixels high
    /// with its near plane at 10 units.
    pub fn thesis(clip: ClipId) -> CrowdExperiment {
        CrowdExperiment {
            characters: 100,
            layout: Layout::Grid { spacing: 150.0 },
            clip,
            lod: THESIS_RANGE,
            scheduler: SchedulerParams::default(),
            weights: PriorityWeights::EQUAL,
            source: animlod::PrioritySource::Factors,
            distances: vec![
                100.0, 200.0, 400.0, 600.0, 800.0, 1000.0, 1200.0, 1400.0, 1600.0, 1800.0, 2000.0,
                2500.0, 3000.0,
            ],
            camera_outside: true,
            warmup_frames: 30,
            frames: 120,
            dt: 1.0 / 60.0,
            fov_y: 60f32.to_radians(),
            viewport_height: 1080.0,
            aspect: 16.0 / 9.0,
            near: 10.0,
            seed: 1,
        }
    }
}

/// Results at one camera distance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SweepRow {
    /// Camera distance from the crowd's centre.
    pub distance: f32,
    /// Median frame time at full detail (ms).
    pub full_ms: f64,
    /// Median frame time with LOD (ms).
    pub lod_ms: f64,
    /// Mean bone interpolations per frame at full detail.
    pub full_interpolated: f64,
    /// Mean bone interpolations per frame with LOD.
    pub lod_interpolated: f64,
    /// Mean budget units spent per frame with LOD (budget mode; see
    /// [`animlod::FrameStats::budget_units`]), 0 in other modes.
    pub lod_budget_units: f64,
    /// Mean model-space concatenations per frame with LOD.
    pub lod_concatenated: f64,
    /// Mean number of characters with nothing interpolated per frame.
    pub frozen: f64,
    /// Mean Ω over characters and frames (1 in budget mode).
    pub mean_ratio: f64,
    /// Mean on-screen joint error (pixels) over visible joints and frames.
    pub mean_px: f32,
    /// Largest on-screen joint error (pixels).
    pub max_px: f32,
    /// Root mean square on-screen error (pixels) over visible joints and frames.
    pub rms_px: f32,
    /// Mean number of characters whose bounding sphere is in view per frame.
    pub visible: f64,
    /// Median frame time (ms) of a third crowd that only culls: full detail for every visible
    /// character, nothing for the others. `lod_ms / cull_ms` is the saving of LOD beyond
    /// culling.
    pub cull_ms: f64,
    /// Mean joint error in scene units.
    pub mean_units: f32,
    /// Largest joint error in scene units.
    pub max_units: f32,
}

impl SweepRow {
    /// LOD frame time over full-detail frame time.
    pub fn cost_ratio(&self) -> f64 {
        if self.full_ms > 0.0 {
            self.lod_ms / self.full_ms
        } else {
            0.0
        }
    }
}

/// A real rig turned into the thesis' character: replicated to [`THESIS_BONES`] bones (if it has
/// fewer) and scaled to [`THESIS_HEIGHT`] units tall (height of its rest-pose joints).
pub fn thesis_rig(rig: &Rig) -> Result<Rig, BuildError> {
    // Copies stand a fifth of the rig's height apart around the original.
    let grown = if rig.bone_count() < THESIS_BONES {
        grown_to(rig, THESIS_BONES, 0.2 * rig_height(rig)?)?
    } else {
        rig.clone()
    };
    let height = rig_height(&grown)?;
    animlod::build::scaled(&grown, THESIS_HEIGHT / height)
}

/// The clips of `rig` that last longer than an instant (clip 0 if none does): what a crowd of
/// it plays, spread over characters.
pub fn playable_clips(rig: &Rig) -> Vec<ClipId> {
    let clips: Vec<ClipId> = (0..rig.clips().len())
        .map(ClipId::new)
        .filter(|&c| rig.clip(c).is_some_and(|c| c.duration() > 0.0))
        .collect();
    if clips.is_empty() {
        vec![ClipId::new(0)]
    } else {
        clips
    }
}

/// Height of a rig: the vertical extent of its joints in the rest pose (model units).
pub fn rig_height(rig: &Rig) -> Result<f32, BuildError> {
    let sk = rig.skeleton();
    let model = sk.rest_model_matrices();
    let ys = sk
        .bones()
        .filter(|&b| sk.is_joint(b))
        .map(|b| model[b.index()].w_axis.y);
    let (lo, hi) = ys.fold((f32::MAX, f32::MIN), |(lo, hi), y| (lo.min(y), hi.max(y)));
    let height = hi - lo;
    if height.is_nan() || height <= 0.0 {
        return Err(BuildError::NonFinite {
            what: "rig height".into(),
        });
    }
    Ok(height)
}

/// Character positions for a layout, centred on the origin.
pub fn positions(layout: Layout, count: usize) -> Vec<Vec3> {
    match layout {
        Layout::Grid { spacing } => {
            let side = (count as f32).sqrt().ceil().max(1.0) as usize;
            let half = (side - 1) as f32 * 0.5;
            (0..count)
                .map(|i| {
                    Vec3::new(
                        ((i % side) as f32 - half) * spacing,
                        0.0,
                        ((i / side) as f32 - half) * spacing,
                    )
                })
                .collect()
        }
        Layout::Random { side, seed } => {
            let mut r = Rng::new(seed);
            (0..count)
                .map(|_| {
                    Vec3::new(
                        (r.next_f32() - 0.5) * side,
                        0.0,
                        (r.next_f32() - 0.5) * side,
                    )
                })
                .collect()
        }
    }
}

/// Builds the two crowds (full detail and LOD) of an experiment.
pub fn build_crowds(rig: &Arc<Rig>, cfg: &CrowdExperiment) -> Result<(Crowd, Crowd), CrowdError> {
    let duration = rig
        .clip(cfg.clip)
        .ok_or(CrowdError::UnknownClip(cfg.clip))?
        .duration();
    let mut full = Crowd::new(rig.clone());
    let mut lod = Crowd::new(rig.clone());
    lod.set_lod(cfg.lod)?;
    lod.set_scheduler(cfg.scheduler)?;
    lod.set_priority_weights(cfg.weights)?;
    lod.set_priority_source(cfg.source);
    let mut phase = Rng::new(cfg.seed);
    for p in positions(cfg.layout, cfg.characters) {
        let t = phase.next_f32() * duration;
        for c in [&mut full, &mut lod] {
            let id = c.add_character(p, cfg.clip)?;
            c.set_time(id, t)?;
        }
    }
    Ok((full, lod))
}

/// A LOD mode that only culls: Ω = 1 for every character whose bounding sphere is in view
/// (projected radius above 0), Ω = 0 for the others.
pub const CULL_ONLY: LodMode = LodMode::PixelSize {
    full_detail_px: 1e-9,
    freeze_below_px: 0.0,
};

/// Runs the sweep: at each distance, the crowds (full detail, LOD, and culling only) are warmed
/// up then measured frame by frame.
pub fn run(rig: &Arc<Rig>, cfg: &CrowdExperiment) -> Result<Vec<SweepRow>, CrowdError> {
    if !(cfg.dt.is_finite() && cfg.dt >= 0.0) {
        return Err(CrowdError::InvalidArgument {
            what: "dt",
            reason: "must be finite and non-negative",
        });
    }
    let (mut full, mut lod) = build_crowds(rig, cfg)?;
    let mut cull = full.clone();
    cull.set_lod(CULL_ONLY)?;
    let (center, radius) = rig.bounds();
    let front = if cfg.camera_outside {
        full.character_ids()
            .map(|id| full.position(id).map(|p| p.z + center.z + radius))
            .collect::<Result<Vec<_>, _>>()?
            .into_iter()
            .fold(f32::MIN, f32::max)
    } else {
        0.0
    };
    let sk = rig.skeleton();
    let ids: Vec<_> = full.character_ids().collect();
    let lod_ids: Vec<_> = lod.character_ids().collect();
    let mut rows = Vec::with_capacity(cfg.distances.len());
    for &distance in &cfg.distances {
        let view = cfg.view_from(Vec3::new(0.0, center.y, front.max(0.0) + distance))?;
        for _ in 0..cfg.warmup_frames {
            full.advance(cfg.dt, &view)?;
            lod.advance(cfg.dt, &view)?;
            cull.advance(cfg.dt, &view)?;
        }
        let (mut tf, mut tl, mut tc) = (
            Vec::with_capacity(cfg.frames),
            Vec::with_capacity(cfg.frames),
            Vec::with_capacity(cfg.frames),
        );
        let mut row = SweepRow {
            distance,
            ..SweepRow::default()
        };
        let mut sum = ErrorSum::default();
        for _ in 0..cfg.frames {
            let t0 = Instant::now();
            let sf = full.advance(cfg.dt, &view)?;
            let t1 = Instant::now();
            let sl = lod.advance(cfg.dt, &view)?;
            let t2 = Instant::now();
            let sc = cull.advance(cfg.dt, &view)?;
            let t3 = Instant::now();
            tf.push((t1 - t0).as_secs_f64() * 1e3);
            tl.push((t2 - t1).as_secs_f64() * 1e3);
            tc.push((t3 - t2).as_secs_f64() * 1e3);
            row.visible += (sc.characters - sc.characters_frozen) as f64;
            row.full_interpolated += sf.bones_interpolated as f64;
            row.lod_interpolated += sl.bones_interpolated as f64;
            row.lod_budget_units += sl.budget_units as f64;
            row.lod_concatenated += sl.bones_concatenated as f64;
            row.frozen += sl.characters_frozen as f64;
            for (&a, &b) in ids.iter().zip(&lod_ids) {
                row.mean_ratio += lod.ratio(b)? as f64;
                let world = full.world_transform(a)?;
                sum.add_pose(
                    sk,
                    lod.model_matrices(b)?,
                    full.model_matrices(a)?,
                    &world,
                    &view,
                );
            }
        }
        let frames = cfg.frames.max(1) as f64;
        row.full_ms = median(&mut tf);
        row.lod_ms = median(&mut tl);
        row.cull_ms = median(&mut tc);
        row.visible /= frames;
        row.full_interpolated /= frames;
        row.lod_interpolated /= frames;
        row.lod_budget_units /= frames;
        row.lod_concatenated /= frames;
        row.frozen /= frames;
        row.mean_ratio /= frames * ids.len().max(1) as f64;
        let e = sum.finish();
        row.mean_px = e.mean_px;
        row.max_px = e.max_px;
        row.rms_px = e.rms_px;
        row.mean_units = e.mean;
        row.max_units = e.max;
        rows.push(row);
    }
    Ok(rows)
}

/// Formats rows as a plain-text table.
pub fn format_table(rows: &[SweepRow]) -> String {
    let mut s = String::from(
        "distance  visible  full ms  cull ms   lod ms  cost  interp/frame (full)  concat/frame  frozen  mean Ω  mean px  max px\n",
    );
    for r in rows {
        s += &format!(
            "{:8.0} {:8.1} {:8.4} {:8.4} {:8.4} {:5.2} {:8.0} ({:6.0}) {:13.0} {:7.1} {:7.3} {:8.3} {:7.2}\n",
            r.distance,
            r.visible,
            r.full_ms,
            r.cull_ms,
            r.lod_ms,
            r.cost_ratio(),
            r.lod_interpolated,
            r.full_interpolated,
            r.lod_concatenated,
            r.frozen,
            r.mean_ratio,
            r.mean_px,
            r.max_px
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn asset(name: &str) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../assets/gltf")
            .join(name)
    }

    fn thesis() -> (Arc<Rig>, ClipId) {
        let base = animlod::build::import_path(&asset("GDQuest_GDBot.glb")).unwrap();
        let rig = Arc::new(thesis_rig(&base).unwrap());
        let clip = rig.clip_by_name("walk").unwrap();
        (rig, clip)
    }

    #[test]
    fn thesis_rig_is_153_bones_180_units_tall() {
        let (rig, _) = thesis();
        assert_eq!(rig.bone_count(), THESIS_BONES);
        let sk = rig.skeleton();
        let model = sk.rest_model_matrices();
        let ys: Vec<f32> = sk
            .bones()
            .filter(|&b| sk.is_joint(b))
            .map(|b| model[b.index()].w_axis.y)
            .collect();
        let h = ys.iter().copied().fold(f32::MIN, f32::max)
            - ys.iter().copied().fold(f32::MAX, f32::min);
        assert!((h - THESIS_HEIGHT).abs() < 1e-2, "{h}");
        // Copies stand apart: every copied joint is a tenth of the height or more from its
        // original.
        for b in sk.bones().filter(|&b| sk.is_joint(b)) {
            if let Some((orig, _)) = sk.name(b).split_once('#') {
                let o = sk.find(orig).unwrap();
                let d = model[b.index()]
                    .w_axis
                    .truncate()
                    .distance(model[o.index()].w_axis.truncate());
                assert!(d > 0.1 * THESIS_HEIGHT, "{} is {d} from {orig}", sk.name(b));
            }
        }
        // Scaling keeps the constant channels constant (the tolerance is relative).
        let base = animlod::build::import_path(&asset("GDQuest_GDBot.glb")).unwrap();
        let walk = |r: &Rig| {
            r.clip(r.clip_by_name("walk").unwrap())
                .unwrap()
                .stats()
                .constant
        };
        assert_eq!(
            walk(&animlod::build::scaled(&base, 100.0).unwrap()),
            walk(&base)
        );
    }

    #[test]
    fn error_bound_meets_the_pixel_targets_at_every_distance() {
        // The targets for the crowd test: mean error under 0.5 px and maximum under 2 px at every
        // distance, measured at joint origins and tips with the camera outside the crowd. The
        // thesis' own distance range cannot meet them (it freezes characters 100 px tall); the
        // error-bounded mode does — its bound covers every point now (held chains sum their
        // drift), so the maximum stays near 1 px. What that costs is measured, not assumed:
        // with rotation counted, a 1 px bound needs most bones near the camera and about half
        // far away, and those are the bones near the root, so only "no more far than near" is
        // asserted here.
        let (rig, clip) = thesis();
        let mut cfg = CrowdExperiment::thesis(clip);
        cfg.lod = LodMode::ErrorBound { max_error_px: 1.0 };
        cfg.distances = vec![100.0, 600.0, 1400.0, 3000.0];
        cfg.warmup_frames = 10;
        cfg.frames = 40;
        for layout in [
            Layout::Grid { spacing: 150.0 },
            Layout::Random {
                side: 1500.0,
                seed: 7,
            },
        ] {
            cfg.layout = layout;
            let rows = run(&rig, &cfg).unwrap();
            for r in &rows {
                assert!(
                    r.mean_px < 0.5 && r.max_px < 1.1,
                    "{layout:?}\n{}",
                    format_table(&rows)
                );
                assert!(r.lod_interpolated <= r.full_interpolated);
            }
            // Farther away, no more interpolations are needed for the same pixel bound. (Not
            // many fewer: the bones due first sit high in the hierarchy, and picking them out
            // would re-concatenate most of the skeleton, so the crowd's cost model sends most
            // characters through the block path, every bone at once, which costs less.)
            let (near, far) = (&rows[0], rows.last().unwrap());
            assert!(
                far.lod_interpolated <= near.lod_interpolated
                    && far.lod_concatenated < near.lod_concatenated,
                "{}",
                format_table(&rows)
            );
        }
        // The thesis' range at the same distances: everything beyond 1700 is frozen.
        cfg.lod = THESIS_RANGE;
        cfg.layout = Layout::Grid { spacing: 150.0 };
        let rows = run(&rig, &cfg).unwrap();
        let far = rows.last().unwrap();
        assert_eq!(far.lod_interpolated, 0.0);
        assert!(
            far.max_px > 2.0,
            "a frozen walk 60 px tall is visibly wrong: {}",
            far.max_px
        );
    }

    #[test]
    fn layouts() {
        let g = positions(Layout::Grid { spacing: 10.0 }, 100);
        assert_eq!(g.len(), 100);
        assert_eq!(g[0], Vec3::new(-45.0, 0.0, -45.0));
        assert_eq!(g[99], Vec3::new(45.0, 0.0, 45.0));
        let r = positions(
            Layout::Random {
                side: 100.0,
                seed: 3,
            },
            50,
        );
        assert!(
            r.iter()
                .all(|p| p.x.abs() <= 50.0 && p.z.abs() <= 50.0 && p.y == 0.0)
        );
        assert_eq!(
            r,
            positions(
                Layout::Random {
                    side: 100.0,
                    seed: 3
                },
                50
            )
        );
    }
}
