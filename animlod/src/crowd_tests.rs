//! Crowd tests on real rigs: ids, refused inputs, the scheduler contract, concatenation
//! skipping, the budget, and pose error against full-rate evaluation.

use std::sync::Arc;

use glam::{Mat4, Vec3};

use super::*;
use crate::build::tests::asset;
use crate::{ClipId, LodMode, PriorityWeights, Rig, SchedulerParams};
use salience::View;

fn gdbot() -> Arc<Rig> {
    Arc::new(crate::build::import_path(&asset("GDQuest_GDBot.glb")).unwrap())
}

fn walk(rig: &Rig) -> ClipId {
    rig.clip_by_name("walk").unwrap()
}

/// A crowd of `n` characters on a line, at spread phases.
fn crowd(rig: &Arc<Rig>, n: usize) -> (Crowd, Vec<CharacterId>) {
    let clip = walk(rig);
    let mut c = Crowd::new(rig.clone());
    let d = rig.clip(clip).unwrap().duration();
    let ids = (0..n)
        .map(|i| {
            let id = c
                .add_character(Vec3::new(i as f32 * 2.0, 0.0, 0.0), clip)
                .unwrap();
            c.set_time(id, d * i as f32 / n as f32).unwrap();
            id
        })
        .collect();
    (c, ids)
}

/// A view that sees the line of characters `crowd` builds (from 12 units in front).
fn view() -> View {
    View::look_at(
        Vec3::new(3.0, 1.0, 12.0),
        Vec3::new(3.0, 1.0, 0.0),
        Vec3::Y,
        60f32.to_radians(),
        1920,
        1080,
    )
    .unwrap()
}

/// A 1920×1080 camera at `eye` looking down −z, 60° field of view.
fn looking_down_z(eye: Vec3) -> View {
    View::new(eye, Vec3::NEG_Z, Vec3::Y, 60f32.to_radians(), 1920, 1080).unwrap()
}

fn snapshot(c: &Crowd) -> Vec<(CharacterId, f32, Vec<Mat4>)> {
    c.character_ids()
        .map(|id| {
            (
                id,
                c.time(id).unwrap(),
                c.model_matrices(id).unwrap().to_vec(),
            )
        })
        .collect()
}

#[test]
fn ids_are_generational_and_removal_keeps_the_others() {
    let rig = gdbot();
    let (mut c, ids) = crowd(&rig, 3);
    c.advance(0.1, &view()).unwrap();
    let keep0 = c.model_matrices(ids[0]).unwrap().to_vec();
    let keep2 = c.model_matrices(ids[2]).unwrap().to_vec();
    c.remove_character(ids[1]).unwrap();
    assert_eq!(c.len(), 2);
    assert_eq!(c.model_matrices(ids[0]).unwrap(), &keep0[..]);
    assert_eq!(c.model_matrices(ids[2]).unwrap(), &keep2[..]);
    for e in [
        c.remove_character(ids[1]).unwrap_err(),
        c.model_matrices(ids[1]).unwrap_err(),
        c.set_position(ids[1], Vec3::ZERO).unwrap_err(),
        c.pose_error(ids[1], &view()).unwrap_err(),
    ] {
        assert_eq!(e, CrowdError::StaleCharacter(ids[1]));
    }
    // The slot is reused with a new generation; the old id stays stale.
    let new = c.add_character(Vec3::ZERO, walk(&rig)).unwrap();
    assert_eq!(new.index(), ids[1].index());
    assert_ne!(new, ids[1]);
    assert!(!c.contains(ids[1]) && c.contains(new));
    assert!(!c.contains(CharacterId::from_raw(0, 0)));
    assert!(!c.contains(CharacterId::from_raw(99, 1)));
}

#[test]
fn refused_inputs_leave_the_crowd_unchanged() {
    let rig = gdbot();
    let (mut c, ids) = crowd(&rig, 2);
    c.advance(0.05, &view()).unwrap();
    let before = snapshot(&c);
    let (lod, w) = (c.lod(), *c.priority_weights());
    let mut out = vec![Mat4::IDENTITY; 3];
    assert!(c.advance(f32::NAN, &view()).is_err());
    assert!(c.advance(-0.1, &view()).is_err());
    assert!(c.advance(f32::INFINITY, &view()).is_err());
    assert!(
        c.add_character(Vec3::new(f32::NAN, 0.0, 0.0), walk(&rig))
            .is_err()
    );
    assert_eq!(
        c.add_character(Vec3::ZERO, ClipId::from_raw(99))
            .unwrap_err(),
        CrowdError::UnknownClip(ClipId::from_raw(99))
    );
    assert!(c.set_position(ids[0], Vec3::INFINITY).is_err());
    assert!(c.set_clip(ids[0], ClipId::from_raw(99)).is_err());
    assert!(c.set_time(ids[0], f32::NAN).is_err());
    assert!(c.set_speed(ids[0], -1.0).is_err());
    assert_eq!(
        c.skinning_matrices(ids[0], SkinId::from_raw(5), &mut out)
            .unwrap_err(),
        CrowdError::UnknownSkin(SkinId::from_raw(5))
    );
    assert_eq!(
        c.skinning_matrices(ids[0], SkinId::from_raw(0), &mut out)
            .unwrap_err(),
        CrowdError::BufferTooSmall {
            needed: 63,
            given: 3
        }
    );
    assert!(
        c.set_lod(LodMode::Range {
            min: 10.0,
            max: 5.0
        })
        .is_err()
    );
    assert!(
        c.set_lod(LodMode::ErrorBound { max_error_px: 0.0 })
            .is_err()
    );
    assert!(
        c.set_priority_weights(PriorityWeights::from_array([0.0; 6]))
            .is_err()
    );
    assert!(
        c.set_priority_weights(PriorityWeights::from_array([1.0, -1.0, 0.0, 0.0, 0.0, 0.0]))
            .is_err()
    );
    assert!(c.set_user_priority(BoneId::from_raw(500), 1.0).is_err());
    assert!(c.set_user_priority(BoneId::from_raw(0), f32::NAN).is_err());
    assert!(
        c.set_scheduler(SchedulerParams {
            period_scale: -1.0,
            ..SchedulerParams::default()
        })
        .is_err()
    );
    assert_eq!(snapshot(&c), before);
    assert_eq!((c.lod(), *c.priority_weights()), (lod, w));
    assert_eq!(c.len(), 2);
}

#[test]
fn full_detail_matches_an_independent_reference() {
    let rig = gdbot();
    let (mut c, ids) = crowd(&rig, 4);
    let clip = rig.clip(walk(&rig)).unwrap();
    let animated = clip.animated_bone_count() as u64;
    for _ in 0..37 {
        let st = c.advance(1.0 / 60.0, &view()).unwrap();
        assert_eq!(st.bones_interpolated, 4 * animated);
        assert_eq!(st.bones_held, 0);
        assert_eq!(st.bones_constant, 4 * (rig.bone_count() as u64 - animated));
    }
    // Reference: the clip's sampled pose through the skeleton's own model-space pass.
    let sk = rig.skeleton();
    for &id in &ids {
        let pose = clip.sample_pose(c.time(id).unwrap());
        let locals: Vec<_> = pose.iter().map(|t| t.to_affine()).collect();
        let mut reference = vec![Mat4::IDENTITY; sk.len()];
        sk.model_matrices(&locals, &mut reference);
        for (a, b) in c.model_matrices(id).unwrap().iter().zip(&reference) {
            assert!(a.abs_diff_eq(*b, 1e-5));
        }
        assert_eq!(c.pose_error(id, &view()).unwrap().max, 0.0);
    }
    // Skinning matrices are model × inverse bind.
    let mut out = vec![Mat4::IDENTITY; 63];
    assert_eq!(
        c.skinning_matrices(ids[0], SkinId::from_raw(0), &mut out)
            .unwrap(),
        63
    );
    let skin = &rig.skins()[0];
    let models = c.model_matrices(ids[0]).unwrap();
    for ((o, j), ib) in out.iter().zip(&skin.joints).zip(&skin.inverse_bind) {
        assert_eq!(*o, models[j.index()] * *ib);
    }
}

#[test]
fn scheduler_contract() {
    let rig = gdbot();
    let animated = rig.clip(walk(&rig)).unwrap().animated_bone_count() as u64;
    // Ω = 1: every animated bone every frame, no error.
    let (mut c, _) = crowd(&rig, 3);
    c.set_lod(LodMode::Ratio(1.0)).unwrap();
    for _ in 0..20 {
        assert_eq!(
            c.advance(1.0 / 60.0, &view()).unwrap().bones_interpolated,
            3 * animated
        );
    }
    assert_eq!(c.total_pose_error(&view()).max, 0.0);
    // Ω = 0: nothing interpolates, nothing is concatenated, the pose does not move.
    c.set_lod(LodMode::Ratio(0.0)).unwrap();
    let before = snapshot(&c);
    for _ in 0..20 {
        let st = c.advance(1.0 / 60.0, &view()).unwrap();
        assert_eq!(
            (
                st.bones_interpolated,
                st.bones_concatenated,
                st.characters_frozen
            ),
            (0, 0, 3)
        );
    }
    for ((_, _, a), (_, _, b)) in snapshot(&c).iter().zip(&before) {
        assert_eq!(a, b);
    }
    assert!(c.total_pose_error(&view()).max > 0.0);
    // Fewer updates as Ω falls (total over two loops of the clip, same start state).
    let mut last = u64::MAX;
    for k in (1..20).rev() {
        let (mut c, _) = crowd(&rig, 3);
        c.set_lod(LodMode::Ratio(k as f32 / 20.0)).unwrap();
        let total: u64 = (0..96)
            .map(|_| c.advance(1.0 / 60.0, &view()).unwrap().bones_interpolated)
            .sum();
        assert!(total <= last, "Ω = {}: {total} > {last}", k as f32 / 20.0);
        last = total;
    }
    // Fewer updates as priority falls: user priority only, all bones at 1 vs most at 0.25.
    let count = |low: f32| {
        let (mut c, _) = crowd(&rig, 3);
        c.set_priority_weights(PriorityWeights::from_array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0]))
            .unwrap();
        for b in 1..rig.bone_count() {
            c.set_user_priority(BoneId::new(b), low).unwrap();
        }
        c.set_lod(LodMode::Ratio(0.5)).unwrap();
        (0..96)
            .map(|_| c.advance(1.0 / 60.0, &view()).unwrap().bones_interpolated)
            .sum::<u64>()
    };
    assert!(count(0.25) < count(1.0));
}

#[test]
fn held_subtrees_skip_concatenation_and_stay_consistent() {
    let rig = gdbot();
    let (mut c, ids) = crowd(&rig, 4);
    c.set_lod(LodMode::Ratio(0.3)).unwrap();
    let sk = rig.skeleton();
    let mut skipped = 0;
    for _ in 0..60 {
        let before = snapshot(&c);
        let st = c.advance(1.0 / 60.0, &view()).unwrap();
        let changed: u64 = snapshot(&c)
            .iter()
            .zip(&before)
            .map(|((_, _, a), (_, _, b))| a.iter().zip(b).filter(|(x, y)| x != y).count() as u64)
            .sum();
        assert!(changed <= st.bones_concatenated);
        skipped += 4 * sk.len() as u64 - st.bones_concatenated;
        // Every model matrix equals the concatenation of the stored (partly held) locals: skipping
        // never leaves a stale matrix behind.
        for &id in &ids {
            let d = c.dense(id).unwrap();
            let mut reference = vec![Mat4::IDENTITY; sk.len()];
            sk.model_matrices(&c.locals[c.span(d)], &mut reference);
            for (a, b) in c.model_matrices(id).unwrap().iter().zip(&reference) {
                assert!(a.abs_diff_eq(*b, 1e-4));
            }
        }
    }
    assert!(skipped > 0);
}

#[test]
fn error_shrinks_as_omega_grows() {
    let rig = gdbot();
    let mut errors = Vec::new();
    for omega in [0.2f32, 0.5, 0.8, 1.0] {
        let (mut c, _) = crowd(&rig, 4);
        c.set_lod(LodMode::Ratio(omega)).unwrap();
        let mut sum = ErrorSum::default();
        for _ in 0..96 {
            c.advance(1.0 / 60.0, &view()).unwrap();
            c.accumulate_pose_error(&view(), &mut sum);
        }
        errors.push(sum.finish().mean);
    }
    assert!(errors.windows(2).all(|w| w[1] <= w[0]), "{errors:?}");
    assert_eq!(errors[3], 0.0);
}

#[test]
fn error_bound_holds_per_bone_drift_under_the_bound() {
    // One character, camera looking at it: a single held bone may move a joint at most
    // `max_error_px` on screen (chains of held bones add up, so the total is checked loosely).
    let rig = gdbot();
    let (mut c, ids) = crowd(&rig, 1);
    let cam = looking_down_z(Vec3::new(0.0, 1.0, 30.0));
    c.set_lod(LodMode::ErrorBound { max_error_px: 1.0 })
        .unwrap();
    let mut held = 0;
    for _ in 0..200 {
        let st = c.advance(1.0 / 60.0, &cam).unwrap();
        held += st.bones_held;
        let e = c.pose_error(ids[0], &cam).unwrap();
        assert!(e.max_px < 2.0, "{e:?}");
    }
    assert!(held > 0);
    // Behind the camera, nothing animates.
    c.set_position(ids[0], Vec3::new(0.0, 0.0, 40.0)).unwrap();
    assert_eq!(c.advance(1.0 / 60.0, &cam).unwrap().bones_interpolated, 0);
}

#[test]
fn budget_caps_updates_and_favours_the_near_character() {
    let rig = gdbot();
    let clip = walk(&rig);
    let animated = rig.clip(clip).unwrap().animated_bone_count() as u32;
    let mut c = Crowd::new(rig.clone());
    let near = c.add_character(Vec3::new(0.0, 0.0, -5.0), clip).unwrap();
    let far = c.add_character(Vec3::new(0.0, 0.0, -60.0), clip).unwrap();
    c.set_time(far, 0.3).unwrap();
    c.set_time(near, 0.3).unwrap();
    let cam = looking_down_z(Vec3::new(0.0, 1.0, 0.0));
    // An eighth of the two characters' bones: under what LOD off's path would cost (a sixth).
    let budget = (animated / 4).max(1);
    c.set_lod(LodMode::Budget {
        bone_updates_per_frame: budget,
    })
    .unwrap();
    let (mut near_err, mut far_err) = (ErrorSum::default(), ErrorSum::default());
    let mut lod_off_frames = 0;
    for frame in 0..120 {
        let st = c.advance(1.0 / 60.0, &cam).unwrap();
        // The budget's units are never overspent, except on frames that take LOD off's path
        // (every bone, a sixth of each character's counted) because the cost model priced
        // picking at LOD off's cost or more; a character whose picks would cost more than
        // its block path interpolates all of its bones and counts at most a sixth.
        let lod_off = 2 * u64::from(animated.div_ceil(6));
        if st.budget_units > budget as u64 {
            assert_eq!(st.budget_units, lod_off, "{st:?}");
            assert_eq!(st.bones_interpolated, 2 * u64::from(animated), "{st:?}");
            lod_off_frames += 1;
        }
        assert!(st.budget_units <= st.bones_interpolated, "{st:?}");
        if frame > 10 {
            assert!(st.bones_interpolated >= budget as u64, "{st:?}");
            let (n, f) = (
                c.pose_error(near, &cam).unwrap(),
                c.pose_error(far, &cam).unwrap(),
            );
            near_err.add(n.mean, None);
            far_err.add(f.mean, None);
        }
    }
    // Two 64-bone characters whose admitted bones sit high in the hierarchy: picking them
    // re-concatenates most of the skeleton, so the budget runs LOD off's path on most frames
    // and tries again every 30.
    assert!(
        lod_off_frames > 0 && lod_off_frames < 110,
        "{lod_off_frames}"
    );
    // Same clip and phase: the near character (8× larger on screen) gets the larger share, so
    // its error in scene units is smaller.
    assert!(near_err.finish().mean < far_err.finish().mean);
    // A budget of zero freezes everyone.
    c.set_lod(LodMode::Budget {
        bone_updates_per_frame: 0,
    })
    .unwrap();
    assert_eq!(c.advance(1.0 / 60.0, &cam).unwrap().bones_interpolated, 0);
}

#[test]
fn playback_controls() {
    let rig = gdbot();
    let (mut c, ids) = crowd(&rig, 1);
    let d = rig.clip(walk(&rig)).unwrap().duration();
    c.set_time(ids[0], d * 2.5).unwrap();
    assert!((c.time(ids[0]).unwrap() - d * 0.5).abs() < 1e-5);
    c.set_speed(ids[0], 0.0).unwrap();
    let before = snapshot(&c);
    c.advance(0.3, &view()).unwrap();
    assert_eq!(snapshot(&c), before);
    c.set_speed(ids[0], 2.0).unwrap();
    c.advance(0.1, &view()).unwrap();
    assert!((c.time(ids[0]).unwrap() - (d * 0.5 + 0.2)).abs() < 1e-5);
    let idle = rig.clip_by_name("Idle").unwrap();
    c.set_clip(ids[0], idle).unwrap();
    assert_eq!(
        (c.clip(ids[0]).unwrap(), c.time(ids[0]).unwrap()),
        (idle, 0.0)
    );
    assert_eq!(c.pose_error(ids[0], &view()).unwrap().max, 0.0);
    // Long runs rebase the clock without disturbing playback.
    c.set_lod(LodMode::Ratio(0.5)).unwrap();
    for _ in 0..2000 {
        c.advance(0.5, &view()).unwrap();
    }
    assert!(c.chars[0].clock <= CLOCK_REBASE);
    assert!(c.pose_error(ids[0], &view()).unwrap().max < 1.0);
}

#[test]
fn a_character_showing_a_shared_pose_is_skipped_and_evaluated_in_full_when_it_stops() {
    for lod in [
        LodMode::Off,
        LodMode::ErrorBound { max_error_px: 1.0 },
        LodMode::KeyHold { max_error_px: 1.0 },
        LodMode::Budget {
            bone_updates_per_frame: 40,
        },
    ] {
        let rig = gdbot();
        let (mut a, ids) = crowd(&rig, 3);
        let (mut b, _) = crowd(&rig, 3);
        a.set_lod(lod).unwrap();
        b.set_lod(lod).unwrap();
        let animated = rig.clip(walk(&rig)).unwrap().animated_bone_count() as u64;
        a.set_pose_shared(ids[1], true).unwrap();
        assert!(a.pose_shared(ids[1]).unwrap() && !a.pose_shared(ids[0]).unwrap());
        let frozen = a.model_matrices(ids[1]).unwrap().to_vec();
        for _ in 0..20 {
            let st = a.advance(1.0 / 60.0, &view()).unwrap();
            b.advance(1.0 / 60.0, &view()).unwrap();
            assert!(
                st.characters_frozen >= 1 && st.bones_held >= animated,
                "{lod:?} {st:?}"
            );
            // Its clock runs on; its pose is not touched.
            assert_eq!(a.time(ids[1]).unwrap(), b.time(ids[1]).unwrap());
            assert_eq!(a.model_matrices(ids[1]).unwrap(), frozen.as_slice());
        }
        // Stopping evaluates it at its current time at once: LOD off's pose.
        a.set_pose_shared(ids[1], false).unwrap();
        let (mut off, _) = crowd(&rig, 3);
        for _ in 0..20 {
            off.advance(1.0 / 60.0, &view()).unwrap();
        }
        assert_eq!(
            a.model_matrices(ids[1]).unwrap(),
            off.model_matrices(ids[1]).unwrap(),
            "{lod:?}"
        );
        assert!(
            a.set_pose_shared(CharacterId::from_raw(99, 0), true)
                .is_err()
        );
    }
}

/// The error-bound mode never costs more than LOD off: 20 GDBot characters 5–62 m away at a
/// 1 px bound pick nearly every bone one by one, which the cost model prices at LOD off's
/// cost or more, so the next 30 frames take LOD off's path (every bone, LOD off's exact poses)
/// and then it tries again; at 3 px the bound is cheaper and never falls back.
#[test]
fn a_dear_error_bound_takes_lod_offs_path() {
    let rig = gdbot();
    let clip = walk(&rig);
    let all = 20 * rig.clip(clip).unwrap().animated_bone_count() as u64;
    let cam = looking_down_z(Vec3::new(0.0, 1.0, 0.0));
    let make = |lod| {
        let mut c = Crowd::new(rig.clone());
        for k in 0..20 {
            let at = Vec3::new((k % 5) as f32 - 2.0, 0.0, -5.0 - 3.0 * k as f32);
            let id = c.add_character(at, clip).unwrap();
            c.set_time(id, 0.1 * k as f32).unwrap();
        }
        c.set_lod(lod).unwrap();
        c
    };
    let mut off = make(LodMode::Off);
    let mut dear = make(LodMode::ErrorBound { max_error_px: 1.0 });
    let mut cheap = make(LodMode::ErrorBound { max_error_px: 3.0 });
    let (mut lod_off_frames, mut bound_frames) = (0, 0);
    for _ in 0..70 {
        off.advance(1.0 / 60.0, &cam).unwrap();
        let st = dear.advance(1.0 / 60.0, &cam).unwrap();
        if st.bones_interpolated == all {
            lod_off_frames += 1;
            assert_eq!(snapshot(&dear), snapshot(&off));
        } else {
            bound_frames += 1;
        }
        assert!(cheap.advance(1.0 / 60.0, &cam).unwrap().bones_interpolated < all);
    }
    assert!(
        lod_off_frames >= 30 && bound_frames >= 2,
        "{lod_off_frames} / {bound_frames}"
    );
}
