//! The world scene at quick scale under the deterministic cost-unit budget: it settles on the
//! issue's targets, it does not depend on the thread count, and it spends detail where the
//! pixels are.

use std::path::Path;
use std::sync::{Arc, OnceLock};

use super::*;

fn config() -> WorldConfig {
    WorldConfig::quick(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf"))
}

fn rig() -> Arc<Rig> {
    static RIG: OnceLock<Arc<Rig>> = OnceLock::new();
    RIG.get_or_init(|| load_rig(&config().assets).unwrap())
        .clone()
}

/// The cost-unit target of the quick scene: the configured fraction of the full-detail frame.
fn target_units() -> f64 {
    static UNITS: OnceLock<f64> = OnceLock::new();
    let c = config();
    *UNITS.get_or_init(|| c.cost_fraction * full_detail_units(&c, &rig()).unwrap())
}

fn run(threads: usize) -> BudgetedRun {
    let c = config();
    run_cost_units(
        &c,
        &rig(),
        target_units(),
        c.cost_frames,
        threads,
        &mut |_, _, _| {},
    )
    .unwrap()
}

/// The two-thread run, shared by the tests that only read it.
fn two_threads() -> &'static BudgetedRun {
    static RUN: OnceLock<BudgetedRun> = OnceLock::new();
    RUN.get_or_init(|| run(2))
}

#[test]
fn the_street_has_the_issues_cloths() {
    let cloths = street_cloths();
    assert_eq!(cloths.len(), 16);
    let count = |side| cloths.iter().filter(|p| p.side == side).count();
    assert_eq!([count(65), count(49), count(33), count(17)], [2, 4, 5, 5]);
    for kind in [ClothKind::Flag, ClothKind::Curtain, ClothKind::Cape] {
        assert!(cloths.iter().any(|p| p.kind == kind));
    }
    assert!(cloths.iter().any(|p| p.side_sign < 0.0) && cloths.iter().any(|p| p.side_sign > 0.0));
    let (near, far) = cloths.iter().fold((f32::MAX, 0f32), |(a, b), p| {
        (a.min(p.along_m), b.max(p.along_m))
    });
    assert!(near >= 2.0 && far <= 60.0, "{near}..{far} m");
}

#[test]
fn settle_finds_the_first_frame_that_holds() {
    let mut trace = vec![2.0; 30];
    trace.extend(std::iter::repeat_n(1.0, 200));
    // One excursion after settling is allowed (1 of 200 frames).
    trace[100] = 1.5;
    let s = settle(&trace, 1.0);
    assert_eq!(s.settled_after, Some(30));
    // Reached once the median of the next ten frames is within: six of ten at frame 26.
    assert_eq!(s.reached_after, Some(26));
    assert!((s.within_fraction - 199.0 / 200.0).abs() < 1e-12);
    // A lucky last frame is not settling.
    let mut never = vec![2.0; 200];
    never[199] = 1.0;
    assert_eq!(settle(&never, 1.0).settled_after, None);
    // Reached but never settled (every tenth frame out): the fraction counts from the frame it
    // was reached, not the cold start before it.
    let mut loose = vec![2.0; 50];
    loose.extend((0..200).map(|f| if f % 10 == 9 { 1.5 } else { 1.0 }));
    let s = settle(&loose, 1.0);
    assert_eq!((s.settled_after, s.reached_after), (None, Some(46)));
    assert!((s.within_fraction - 180.0 / 204.0).abs() < 1e-12, "{s:?}");
}

/// The issue's controller targets on the real scene (quick scale), with the deterministic
/// clock: the cost reaches the target within 60 frames, then stays within ±10% on ≥ 95% of the
/// frames, with < 1% of operations undone.
#[test]
fn cost_unit_budget_settles_on_the_street() {
    let r = two_threads();
    let trace: Vec<String> = r
        .frames
        .iter()
        .map(|f| format!("{:.0}/{:.2}", f.measured, f.bound_px))
        .collect();
    let settled = r.settle.settled_after;
    assert!(
        settled.is_some_and(|f| f <= 60),
        "settled after {settled:?} frames; target {:.0}; cost/bound per frame: {trace:?}",
        r.target
    );
    assert!(
        r.settle.within_fraction >= 0.95,
        "within 10% on {:.1}% of frames after settling; cost/bound: {trace:?}",
        100.0 * r.settle.within_fraction
    );
    assert!(r.operations > 0, "the budget refined nothing");
    assert!(
        r.undone_fraction < 0.01,
        "{:.2}% of {} operations undone",
        100.0 * r.undone_fraction,
        r.operations
    );
}

/// Under a cost-unit budget one thread and two give the same costs and bounds, frame by frame.
#[test]
fn cost_unit_budget_does_not_depend_on_threads() {
    let one = run(1);
    let two = two_threads();
    assert_eq!(one.threads, 1);
    assert_eq!(two.threads, 2);
    let costs = |r: &BudgetedRun| r.frames.iter().map(|f| f.cost_units).collect::<Vec<_>>();
    let bounds = |r: &BudgetedRun| r.frames.iter().map(|f| f.bound_px).collect::<Vec<_>>();
    assert_eq!(costs(&one), costs(two));
    assert_eq!(bounds(&one), bounds(two));
}

/// Detail goes where the pixels are: in-view cloths nearer than 15 m simulate a larger
/// fraction of their nodes than in-view cloths beyond 30 m.
#[test]
fn near_cloths_get_more_detail_than_far_ones() {
    let r = two_threads();
    let (near, far) = (
        r.near_detail_fraction.unwrap(),
        r.far_detail_fraction.unwrap(),
    );
    assert!(near > far, "near {near:.3}, far {far:.3}");
}
