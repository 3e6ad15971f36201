//! The header's documented limits are the checked ones, and the error names the argument at
//! fault (spacing, grid extent, gravity length, optional crowd statistics).

use super::*;

fn last() -> String {
    let mut buf = [0 as std::ffi::c_char; 512];
    let mut n = 0;
    // SAFETY: `buf` is valid for its length, `n` for a write.
    unsafe { slod_last_error(buf.as_mut_ptr(), buf.len(), &mut n) };
    // SAFETY: slod_last_error NUL-terminates within `buf`.
    unsafe { std::ffi::CStr::from_ptr(buf.as_ptr()) }
        .to_string_lossy()
        .into_owned()
}

struct World(*mut SlodWorld);
impl World {
    fn new() -> World {
        let mut w = std::ptr::null_mut();
        // SAFETY: valid desc and out pointer.
        let r = unsafe { slod_world_create(&slod_default_world_desc(), &mut w) };
        assert_eq!(r, SlodResult::Ok);
        World(w)
    }
    fn grid(&self, desc: &SlodClothDesc) -> (SlodResult, String) {
        let mut id = SlodClothId::default();
        // SAFETY: live world, valid desc and out pointer.
        let r = unsafe { slod_cloth_create_grid(self.0, desc, &mut id) };
        (r, last())
    }
}
impl World {
    /// A bundled rig loaded into the world and a crowd of it.
    fn crowd_of(&self, file: &str) -> (SlodRigId, SlodCrowdId) {
        let path = format!("{}/../assets/gltf/{file}", env!("CARGO_MANIFEST_DIR"));
        let bytes = std::fs::read(path).unwrap();
        let (mut rig, mut crowd) = (SlodRigId::default(), SlodCrowdId::default());
        // SAFETY: live world; valid buffer and out pointers.
        unsafe {
            assert_eq!(
                slod_rig_load_memory(self.0, bytes.as_ptr(), bytes.len(), &mut rig),
                SlodResult::Ok
            );
            assert_eq!(
                slod_crowd_create(self.0, rig, &slod_default_crowd_desc(), &mut crowd),
                SlodResult::Ok
            );
        }
        (rig, crowd)
    }
}

impl World {
    /// The 289 vertex positions of a 17 × 17 cloth.
    fn positions_17(&self, id: SlodClothId) -> Vec<f32> {
        let mut out = vec![0f32; 3 * 289];
        let mut len = 0;
        // SAFETY: live world, a buffer of 289 positions and a valid out pointer.
        let r = unsafe { slod_cloth_vertex_positions(self.0, id, out.as_mut_ptr(), 289, &mut len) };
        assert_eq!((r, len), (SlodResult::Ok, 289));
        out
    }
}

impl Drop for World {
    fn drop(&mut self) {
        // SAFETY: created by slod_world_create, destroyed once.
        unsafe { slod_world_destroy(self.0) };
    }
}

#[test]
fn grid_limits_are_the_documented_ones() {
    let w = World::new();
    let small = SlodClothDesc {
        columns: 5,
        rows: 5,
        ..slod_default_cloth_desc()
    };
    // The documented spacing range [1e-6, 1e4]: both ends accepted, outside refused naming it.
    for spacing in [1.0e-6, 1.0e4] {
        let (r, msg) = w.grid(&SlodClothDesc { spacing, ..small });
        assert_eq!(r, SlodResult::Ok, "spacing {spacing}: {msg}");
    }
    for spacing in [1.0e-12, 0.0, 2.0e4, f32::NAN] {
        let (r, msg) = w.grid(&SlodClothDesc { spacing, ..small });
        assert_eq!(r, SlodResult::InvalidArgument, "spacing {spacing}");
        assert!(msg.contains("desc.spacing"), "spacing {spacing}: {msg}");
    }
    // A grid reaching beyond ±SLOD_MAX_COORDINATE is refused (400 × 1e4 m = 4e6 m).
    let (r, msg) = w.grid(&SlodClothDesc {
        columns: 400,
        rows: 2,
        spacing: 1.0e4,
        ..small
    });
    assert_eq!(r, SlodResult::InvalidArgument);
    assert!(msg.contains("desc.spacing"), "{msg}");
    // Gravity is limited by its length, not per component.
    let mut d = small;
    d.solver.gravity = [8.0e3, 8.0e3, 0.0];
    let (r, msg) = w.grid(&d);
    assert_eq!(r, SlodResult::InvalidArgument);
    assert!(msg.contains("desc.solver.gravity"), "{msg}");
    d.solver.gravity = [0.0, -9.999e3, 0.0];
    assert_eq!(w.grid(&d).0, SlodResult::Ok);
}

#[test]
fn crowd_statistics_are_optional() {
    let w = World::new();
    let (_, crowd) = w.crowd_of("GDQuest_GDBot.glb");
    // SAFETY: live world and crowd; NULL statistics are allowed.
    unsafe {
        assert_eq!(
            slod_crowd_advance(w.0, crowd, 0.016, std::ptr::null_mut()),
            SlodResult::Ok,
            "{}",
            last()
        );
    }
}

#[test]
fn shared_poses_refuse_bad_input_and_change_nothing() {
    let w = World::new();
    let (_, crowd) = w.crowd_of("Fox.glb");
    let mut ids = [SlodCharacterId::default(); 2];
    // SAFETY: live world; valid buffers and out pointers throughout; the share is destroyed
    // once, at the end.
    unsafe {
        for (i, id) in ids.iter_mut().enumerate() {
            let mut d = slod_default_character_desc();
            d.time = 0.01 * i as f32;
            assert_eq!(slod_character_create(w.0, crowd, &d, id), SlodResult::Ok);
        }
        let mut share = std::ptr::null_mut();
        assert_eq!(
            slod_pose_share_create(w.0, ids[0], 0, &mut share),
            SlodResult::InvalidArgument
        );
        assert!(last().contains("capacity"), "{}", last());
        assert_eq!(
            slod_pose_share_create(w.0, ids[0], 8, &mut share),
            SlodResult::Ok
        );
        // A bound of 10^4 px shares the whole clip: both characters ask for one pose.
        let mut poses = [SlodSharedPose::default(); 2];
        let mut has = [false; 2];
        for i in 0..2 {
            assert_eq!(
                slod_pose_share_request(w.0, ids[i], share, 1.0e4, &mut poses[i], &mut has[i]),
                SlodResult::Ok
            );
        }
        assert_eq!(has, [true, true]);
        assert_eq!(poses[0], poses[1]);
        assert_eq!(
            slod_pose_share_request(w.0, ids[0], share, f32::NAN, &mut poses[0], &mut has[0]),
            SlodResult::InvalidArgument
        );
        // A bucket past the finest level: refused, flags and kept poses unchanged.
        let mut bad = poses;
        bad[1].level = 12;
        let mut flags = [1u8, 1];
        let mut stats = SlodPoseShareStats::default();
        assert_eq!(
            slod_pose_share_prepare(share, bad.as_ptr(), flags.as_mut_ptr(), 2, &mut stats),
            SlodResult::InvalidArgument
        );
        assert_eq!((flags, stats), ([1, 1], SlodPoseShareStats::default()));
        let mut n = 0;
        assert_eq!(
            slod_pose_share_vertices(
                share,
                poses[0],
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                0,
                &mut n
            ),
            SlodResult::InvalidArgument,
            "not prepared yet"
        );
        assert_eq!(
            slod_pose_share_prepare(share, poses.as_ptr(), flags.as_mut_ptr(), 2, &mut stats),
            SlodResult::Ok
        );
        assert_eq!(flags, [1, 1]);
        assert_eq!((stats.poses_used, stats.poses_skinned), (1, 1));
        assert_eq!(
            slod_pose_share_vertices(
                share,
                poses[0],
                std::ptr::null_mut(),
                std::ptr::null_mut(),
                0,
                &mut n
            ),
            SlodResult::Ok
        );
        let (mut p, mut q) = (vec![0.0f32; 3 * n], vec![0.0f32; 3 * n]);
        assert_eq!(
            slod_pose_share_vertices(
                share,
                poses[0],
                p.as_mut_ptr(),
                q.as_mut_ptr(),
                n - 1,
                &mut n
            ),
            SlodResult::BufferTooSmall
        );
        assert_eq!(
            slod_pose_share_vertices(share, poses[0], p.as_mut_ptr(), q.as_mut_ptr(), n, &mut n),
            SlodResult::Ok
        );
        assert!(p.iter().chain(&q).all(|x| x.is_finite()));
        assert_eq!(
            slod_character_set_pose_shared(w.0, ids[1], true),
            SlodResult::Ok
        );
        assert_eq!(
            slod_crowd_advance(w.0, crowd, 0.016, std::ptr::null_mut()),
            SlodResult::Ok
        );
        assert_eq!(
            slod_character_set_pose_shared(w.0, ids[1], false),
            SlodResult::Ok
        );
        slod_pose_share_destroy(share);
    }
}

/// `reconstruction` takes the three `SlodReconstruction` values and refuses anything else by
/// name, creating nothing; the modes place the finest vertices of a coarse cut differently (the
/// field reaches the cloth) and all keep a pinned-free cloth finite.
#[test]
fn cloth_reconstruction_mode_is_checked_and_reaches_the_cloth() {
    let w = World::new();
    let small = SlodClothDesc {
        columns: 9,
        rows: 9,
        initial_level: 2,
        ..slod_default_cloth_desc()
    };
    assert_eq!(small.reconstruction, SlodReconstruction::Mls as u32);
    for bad in [3, 7, u32::MAX] {
        let mut id = SlodClothId::default();
        // SAFETY: live world, valid desc and out pointer.
        let r = unsafe {
            slod_cloth_create_grid(
                w.0,
                &SlodClothDesc {
                    reconstruction: bad,
                    ..small
                },
                &mut id,
            )
        };
        assert_eq!(r, SlodResult::InvalidArgument, "{bad}");
        assert!(last().contains("desc.reconstruction"), "{bad}: {}", last());
        assert_eq!(id, SlodClothId::default(), "nothing created");
    }
    let mut shapes = Vec::new();
    for mode in [
        SlodReconstruction::Mls,
        SlodReconstruction::Smooth,
        SlodReconstruction::Rigid,
    ] {
        let mut id = SlodClothId::default();
        let mut out = vec![0f32; 3 * 81];
        let mut len = 0;
        // SAFETY: live world, valid desc, buffers of the stated sizes and out pointers.
        unsafe {
            let desc = SlodClothDesc {
                reconstruction: mode as u32,
                ..small
            };
            assert_eq!(slod_cloth_create_grid(w.0, &desc, &mut id), SlodResult::Ok);
            for _ in 0..20 {
                assert_eq!(slod_cloth_step(w.0, id), SlodResult::Ok);
            }
            assert_eq!(
                slod_cloth_vertex_positions(w.0, id, out.as_mut_ptr(), 81, &mut len),
                SlodResult::Ok
            );
        }
        assert_eq!(len, 81);
        assert!(out.iter().all(|x| x.is_finite()), "{mode:?}");
        shapes.push(out);
    }
    assert_ne!(
        shapes[0], shapes[1],
        "MLS and smooth place vertices differently"
    );
    assert_ne!(
        shapes[1], shapes[2],
        "smooth and rigid place vertices differently"
    );
}

/// `slod_cloth_evaluate_ahead` runs the evaluation the next step is due to run, once, and the
/// run is the same as stepping alone; a NULL output is refused with nothing run.
#[test]
fn evaluation_ahead_is_the_steps_own_across_the_abi() {
    let w = World::new();
    let desc = net_17();
    let feedback = slod_default_feedback_desc();
    let mut ids = [SlodClothId::default(); 2];
    // SAFETY: live world, valid descs and out pointers.
    unsafe {
        for id in &mut ids {
            assert_eq!(slod_cloth_create_grid(w.0, &desc, id), SlodResult::Ok);
            assert_eq!(slod_cloth_set_feedback(w.0, *id, &feedback), SlodResult::Ok);
        }
    }
    let (mut ran, mut evaluated) = (0, false);
    for step in 0..20 {
        // SAFETY: live world, ids of it, valid out pointers.
        unsafe {
            assert_eq!(
                slod_cloth_evaluate_ahead(w.0, ids[0], std::ptr::null_mut()),
                SlodResult::NullArgument
            );
            assert_eq!(
                slod_cloth_evaluate_ahead(w.0, ids[0], &mut evaluated),
                SlodResult::Ok
            );
            assert_eq!(evaluated, step % feedback.interval == 0, "step {step}");
            ran += evaluated as u32;
            assert_eq!(
                slod_cloth_evaluate_ahead(w.0, ids[0], &mut evaluated),
                SlodResult::Ok
            );
            assert!(!evaluated, "once per step");
            assert_eq!(slod_cloth_step(w.0, ids[0]), SlodResult::Ok);
            assert_eq!(slod_cloth_step(w.0, ids[1]), SlodResult::Ok);
        }
    }
    assert_eq!(ran, 20 / feedback.interval);
    assert_eq!(w.positions_17(ids[0]), w.positions_17(ids[1]));
}

/// A 17 × 17 cloth starting at level 1.
fn net_17() -> SlodClothDesc {
    SlodClothDesc {
        columns: 17,
        rows: 17,
        initial_level: 1,
        ..slod_default_cloth_desc()
    }
}

/// The feedback desc's `overlap_step`: 1 with `parallel` 1 (the measurement on the world's
/// threads beside the solver) and with `parallel` 0 (one after the other) give the same
/// positions, which are not those of the sequential loop; 2 is refused and changes nothing.
#[test]
fn overlapped_evaluation_across_the_abi() {
    let w = World::new();
    let desc = net_17();
    let base = SlodFeedbackDesc {
        budget_kind: SlodClothBudget::MaxErrorPx as u32,
        budget_value: 0.5,
        interval: 3,
        ..slod_default_feedback_desc()
    };
    assert_eq!(base.overlap_step, 0, "off by default");
    let descs = [(1, 1), (1, 0), (0, 0)].map(|(overlap_step, parallel)| SlodFeedbackDesc {
        overlap_step,
        parallel,
        ..base
    });
    let mut ids = [SlodClothId::default(); 3];
    // SAFETY: live world, valid descs and out pointers.
    unsafe {
        for (id, fd) in ids.iter_mut().zip(&descs) {
            assert_eq!(slod_cloth_create_grid(w.0, &desc, id), SlodResult::Ok);
            assert_eq!(slod_cloth_set_feedback(w.0, *id, fd), SlodResult::Ok);
        }
        let bad = SlodFeedbackDesc {
            overlap_step: 2,
            ..base
        };
        assert_eq!(
            slod_cloth_set_feedback(w.0, ids[2], &bad),
            SlodResult::InvalidArgument
        );
        assert!(last().contains("desc.overlap_step"), "{}", last());
        // Held by two corners of one edge: it swings and bends.
        for id in ids {
            let at = w.positions_17(id);
            for v in [0usize, 16] {
                let [x, y, z] = [at[3 * v], at[3 * v + 1], at[3 * v + 2]];
                assert_eq!(
                    slod_cloth_pin_vertex(w.0, id, v as u32, x, y, z),
                    SlodResult::Ok
                );
            }
        }
        for _ in 0..30 {
            for id in ids {
                assert_eq!(slod_cloth_step(w.0, id), SlodResult::Ok);
            }
        }
    }
    let [spawned, inline, sequential] = ids.map(|id| w.positions_17(id));
    assert!(spawned == inline, "the threads changed the results");
    assert!(spawned != sequential, "the overlap changed nothing");
}

/// `slod_cloth_evaluate_ahead_part` measures the next step's evaluation in parts under an error
/// bound (nothing under another budget), refuses a NaN fraction and a NULL output, and the run
/// is the same as stepping alone.
#[test]
fn evaluation_in_parts_across_the_abi() {
    let w = World::new();
    let desc = net_17();
    let feedback = SlodFeedbackDesc {
        budget_kind: SlodClothBudget::MaxErrorPx as u32,
        budget_value: 1.0,
        ..slod_default_feedback_desc()
    };
    let mut ids = [SlodClothId::default(); 3];
    // SAFETY: live world, valid descs and out pointers.
    unsafe {
        for id in &mut ids {
            assert_eq!(slod_cloth_create_grid(w.0, &desc, id), SlodResult::Ok);
        }
        for id in &ids[..2] {
            assert_eq!(slod_cloth_set_feedback(w.0, *id, &feedback), SlodResult::Ok);
        }
        let other = slod_default_feedback_desc();
        assert_eq!(slod_cloth_set_feedback(w.0, ids[2], &other), SlodResult::Ok);
    }
    let mut ran = false;
    let mut parts = 0;
    for step in 0..20 {
        // SAFETY: live world, ids of it, valid out pointers.
        unsafe {
            assert_eq!(
                slod_cloth_evaluate_ahead_part(w.0, ids[0], 0.5, std::ptr::null_mut()),
                SlodResult::NullArgument
            );
            assert_eq!(
                slod_cloth_evaluate_ahead_part(w.0, ids[0], f32::NAN, &mut ran),
                SlodResult::InvalidArgument
            );
            for f in [0.25, 0.5] {
                assert_eq!(
                    slod_cloth_evaluate_ahead_part(w.0, ids[0], f, &mut ran),
                    SlodResult::Ok
                );
                assert_eq!(ran, step % feedback.interval == 0, "step {step}");
                parts += ran as u32;
            }
            assert_eq!(
                slod_cloth_evaluate_ahead_part(w.0, ids[2], 0.5, &mut ran),
                SlodResult::Ok
            );
            assert!(!ran, "not split under a compression budget");
            for id in ids {
                assert_eq!(slod_cloth_step(w.0, id), SlodResult::Ok);
            }
        }
    }
    assert_eq!(parts, 2 * 20 / feedback.interval);
    assert_eq!(w.positions_17(ids[0]), w.positions_17(ids[1]));
}
