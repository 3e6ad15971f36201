//! The world budget on real cloths and a real crowd: it settles, it is deterministic across
//! thread counts under a cost-unit budget, it spends detail where the pixels are, it honours
//! per-object overrides, and it refuses bad settings without changing anything.

use std::sync::Arc;

use glam::Vec3;
use salience::View;
use softbody::{TreeCutSettings, WindField};
use treecut::GridSpec;

use super::*;
use crate::cloth::AdaptiveCloth;
use animlod::{Crowd, LodMode, Rig};

fn gdbot() -> Arc<Rig> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/gltf/GDQuest_GDBot.glb");
    Arc::new(animlod::build::import_path(&path).unwrap())
}

/// A hanging cloth `side` × `side` vertices, `width` m wide, its top edge pinned, its top-left
/// corner at `at`, starting at `level` (0 = finest), in a light gusty wind when `windy`.
fn hanging(side: u32, width: f32, at: Vec3, level: u32, windy: bool) -> AdaptiveCloth {
    hanging_in(side, width, at, level, if windy { 1.0 } else { 0.0 })
}

/// [`hanging`] in a wind `wind` times as strong (0: none).
fn hanging_in(side: u32, width: f32, at: Vec3, level: u32, wind: f32) -> AdaptiveCloth {
    let spec = GridSpec {
        cols: side,
        rows: side,
        origin: at,
        u: Vec3::new(width / (side - 1) as f32, 0.0, 0.0),
        v: Vec3::new(0.0, -width / (side - 1) as f32, 0.0),
        vertex_mass: 0.3 / (side * side) as f32,
    };
    let mut c = AdaptiveCloth::grid(&spec, level, TreeCutSettings::default()).unwrap();
    for i in 0..side {
        c.body_mut()
            .pin_vertex(spec.vertex(i, 0), spec.position(i, 0))
            .unwrap();
    }
    if wind > 0.0 {
        c.set_wind(Some(WindField {
            velocity: Vec3::new(1.0, 0.0, 3.0) * wind,
            gust: 0.3,
            seed: side as u64,
            ..WindField::default()
        }))
        .unwrap();
    }
    c
}

/// Twelve cloths of three sizes from 2 m to 24 m in front of the camera and a crowd of 60
/// characters from 3 m to 40 m. `level` is the cloths' starting level, `lod` the crowd's mode.
fn scene(budget: WorldBudget, level: u32, lod: LodMode) -> (World, Vec<ClothKey>, CrowdKey) {
    scene_in(budget, level, lod, 1.0)
}

/// [`scene`] with the wind `wind` times as strong.
fn scene_in(
    budget: WorldBudget,
    level: u32,
    lod: LodMode,
    wind: f32,
) -> (World, Vec<ClothKey>, CrowdKey) {
    let mut w = World::new(budget).unwrap();
    let mut keys = Vec::new();
    for (k, side) in [17u32, 33, 17, 33, 25, 17, 25, 17, 33, 17, 25, 17]
        .into_iter()
        .enumerate()
    {
        let z = -2.0 - 2.0 * k as f32;
        let x = if k % 2 == 0 { -1.6 } else { 0.4 };
        let wind = if k % 3 != 2 { wind } else { 0.0 };
        keys.push(w.add_cloth(hanging_in(side, 1.2, Vec3::new(x, 1.8, z), level, wind)));
    }
    let rig = gdbot();
    let mut crowd = Crowd::new(rig.clone());
    let clips = rig.clips().len() as u32;
    for i in 0..60u32 {
        let d = 3.0 + 37.0 * i as f32 / 59.0;
        let x = ((i * 7919) % 13) as f32 - 6.0;
        let id = crowd
            .add_character(Vec3::new(x, 0.0, -d), animlod::ClipId::from_raw(i % clips))
            .unwrap();
        crowd.set_time(id, 0.37 * i as f32).unwrap();
    }
    crowd.set_lod(lod).unwrap();
    let crowd = w.add_crowd(crowd);
    (w, keys, crowd)
}

/// The camera of frame `f`: flying slowly forward along −z, looking ahead.
fn view(f: u32) -> View {
    let eye = Vec3::new(0.0, 1.6, 3.0 - 0.02 * f as f32);
    View::look_at(
        eye,
        eye + Vec3::new(0.0, -0.1, -1.0),
        Vec3::Y,
        50f32.to_radians(),
        1920,
        1080,
    )
    .unwrap()
}

const DT: f32 = 1.0 / 60.0;

/// Cost units of one frame of the scene at full detail (finest cuts, LOD off).
fn full_detail_units() -> f64 {
    full_detail_units_at(default_substeps())
}

/// The cloths' solver substeps by default.
fn default_substeps() -> u32 {
    softbody::SolverSettings::default().substeps
}

/// [`full_detail_units`] with the cloths at `substeps`.
fn full_detail_units_at(substeps: u32) -> f64 {
    let (mut w, keys, _) = scene(WorldBudget::default(), 0, LodMode::Off);
    set_substeps(&mut w, &keys, substeps);
    w.step(DT, &view(0)).unwrap().cost_units
}

/// Sets every cloth's solver substeps.
fn set_substeps(w: &mut World, keys: &[ClothKey], substeps: u32) {
    for &k in keys {
        let c = w.cloth_mut(k).unwrap();
        let mut solver = c.body().settings().solver;
        solver.substeps = substeps;
        c.body_mut().set_solver_settings(solver).unwrap();
    }
}

struct Trace {
    costs: Vec<f64>,
    undone: u64,
    ops: u64,
}

fn run(budget: WorldBudget, frames: u32) -> (World, Trace) {
    run_at(budget, frames, default_substeps())
}

/// [`run`] with the cloths at `substeps`.
fn run_at(budget: WorldBudget, frames: u32, substeps: u32) -> (World, Trace) {
    run_in(budget, frames, substeps, 1.0)
}

/// [`run_at`] with the wind `wind` times as strong.
fn run_in(budget: WorldBudget, frames: u32, substeps: u32, wind: f32) -> (World, Trace) {
    let (mut w, keys, _) = scene_in(budget, 2, LodMode::Off, wind);
    set_substeps(&mut w, &keys, substeps);
    let mut costs = Vec::new();
    for f in 0..frames {
        costs.push(w.step(DT, &view(f)).unwrap().measured);
    }
    let (mut undone, mut ops) = (0, 0);
    for (_, c) in w.cloths() {
        undone += c.stats().undone_ops;
        ops += c.stats().refines + c.stats().coarses;
    }
    (w, Trace { costs, undone, ops })
}

/// The test of a controller on real work: from a cold start the frame cost reaches the
/// target within 60 frames and then stays within ±10% on ≥ 95% of frames, with < 1% of
/// operations undone within 30 frames — on cloths and a crowd, with a moving camera; and not
/// only at the solver settings the defaults were chosen at: with the cloths at 48 and 64
/// substeps too (their costs, error estimates and merge lags differ). Before the controller
/// read the cloths' bound curves it settled at 48 substeps only after 190 frames (35% of full
/// detail) and 193 (60%): the cloths' errors grew with the wind while the bound crept through
/// the merge hysteresis. At 16 substeps (a step half as costly, an evaluation as costly) it
/// did not hold at 60% until each evaluation was measured half in the frame before its step
/// (settled after 296 frames, 45 now). The same in a wind 2.5 times as strong, at 20% and 35%
/// of full detail (32 substeps), which did not settle within 300 frames before.
#[test]
fn cost_unit_budget_settles_on_cloths_and_a_crowd() {
    let cases = [16, default_substeps(), 48, 64]
        .into_iter()
        .flat_map(|s| [(s, 0.35, 1.0), (s, 0.6, 1.0)])
        .chain([
            (default_substeps(), 0.2, 2.5),
            (default_substeps(), 0.35, 2.5),
        ]);
    for (substeps, fraction, wind) in cases {
        let full = full_detail_units_at(substeps);
        {
            let target = fraction * full;
            let budget = WorldBudget {
                target: BudgetTarget::CostUnits(target),
                ..WorldBudget::default()
            };
            let (_, t) = run_in(budget, 300, substeps, wind);
            let within = |c: f64| (c - target).abs() <= 0.1 * target;
            // Settled: the first frame from which the cost is within 10% on at least 95% of
            // the frames (the demo's `settled_after_frames`).
            let settled = (0..t.costs.len()).find(|&f| {
                let rest = &t.costs[f..];
                rest.iter().filter(|&&c| within(c)).count() as f64 >= 0.95 * rest.len() as f64
            });
            // 60 frames is the target on its street scene (tested in
            // `slod-experiments`); here twelve small cloths start at level 2 (6% of their
            // nodes) and must refine up to 6–10× that under the transition allowance, which
            // takes up to about 75 frames.
            assert!(
                settled.is_some_and(|f| f <= 90),
                "{substeps} substeps, {fraction} of full, wind ×{wind}: settled at frame \
                 {settled:?}; costs/target {:?}",
                t.costs.iter().map(|c| c / target).collect::<Vec<_>>()
            );
            assert!(
                (t.undone as f64) < 0.01 * t.ops as f64,
                "{substeps} substeps, {fraction} of full: {} of {} operations undone",
                t.undone,
                t.ops
            );
        }
    }
}

/// A millisecond budget measured by the modelled clock behaves as the same budget in units.
#[test]
fn modelled_millisecond_clock_matches_cost_units() {
    let target = 0.4 * full_detail_units();
    let (a, ta) = run(
        WorldBudget {
            target: BudgetTarget::CostUnits(target),
            ..WorldBudget::default()
        },
        40,
    );
    let (b, tb) = run(
        WorldBudget {
            target: BudgetTarget::Milliseconds((target * 2e-6) as f32),
            clock: FrameClock::Modelled { ns_per_unit: 2.0 },
            ..WorldBudget::default()
        },
        40,
    );
    // The same run up to the rounding of the target to f32 milliseconds.
    let (ba, bb) = (a.budget().error_bound_px(), b.budget().error_bound_px());
    assert!((ba - bb).abs() <= 1e-3 * ba, "{ba} px vs {bb} px");
    for (x, y) in ta.costs.iter().zip(&tb.costs) {
        assert!((x * 2e-6 - y).abs() <= 1e-3 * y, "{x} units vs {y} ms");
    }
}

fn positions(w: &World) -> Vec<Vec3> {
    w.cloths()
        .flat_map(|(_, c)| c.body().particle_positions().iter().map(|p| p.truncate()))
        .collect()
}

/// Under a cost-unit budget the world is deterministic whatever the thread count: the same
/// positions, bounds and costs with one thread as with three.
#[test]
fn cost_unit_budget_is_deterministic_across_threads() {
    let target = 0.4 * full_detail_units();
    let go = |threads| {
        run(
            WorldBudget {
                target: BudgetTarget::CostUnits(target),
                threads,
                ..WorldBudget::default()
            },
            60,
        )
    };
    let (one, t1) = go(1);
    let (three, t3) = go(3);
    assert_eq!(t1.costs, t3.costs);
    assert_eq!(
        one.budget().error_bound_px(),
        three.budget().error_bound_px()
    );
    let (p1, p3) = (positions(&one), positions(&three));
    assert_eq!(p1.len(), p3.len());
    assert!(
        p1.iter()
            .zip(&p3)
            .all(|(a, b)| a.to_array() == b.to_array())
    );
    assert_eq!(one.budget().threads(), 1);
    assert_eq!(three.budget().threads(), 3);
}

/// The budget is spent by benefit: of two identical cloths, the one near the camera gets more
/// nodes than the one far away, and the crowd's far characters interpolate fewer bones per
/// character than its near ones would need (its bound is in pixels).
#[test]
fn near_cloth_gets_more_nodes_than_a_far_one() {
    let mut w = World::new(WorldBudget {
        target: BudgetTarget::CostUnits(1.0),
        initial_error_px: 2.0,
        // Hold the bound still: only the allocation at one bound is tested here.
        min_error_px: 2.0,
        max_error_px: 2.0,
        ..WorldBudget::default()
    })
    .unwrap();
    let near = w.add_cloth(hanging(33, 1.2, Vec3::new(-0.6, 1.8, -2.0), 2, true));
    let far = w.add_cloth(hanging(33, 1.2, Vec3::new(-0.6, 1.8, -20.0), 2, true));
    let start = w.cloth(near).unwrap().node_count();
    assert_eq!(start, w.cloth(far).unwrap().node_count());
    for _ in 0..120 {
        w.step(DT, &view(0)).unwrap();
    }
    // Nodes added since the common start (both cloths begin at level 2; the tiny target keeps
    // the transition allowance small, so the near one is still growing): the near cloth gets
    // more than twice what the far one does (measured: +78 against +17, the far one's from its
    // pinned rim; without the rim term +77 against +3).
    let n_near = w.cloth(near).unwrap().node_count() - start;
    let n_far = w.cloth(far).unwrap().node_count() - start;
    assert!(
        n_near > 2 * n_far,
        "near cloth +{n_near} nodes, far cloth +{n_far}"
    );
}

/// A cloth forced to full detail reaches the finest cut while the budget squeezes the others,
/// and a crowd forced to full detail plays with LOD off; a cloth on its own budget keeps it.
#[test]
fn overrides_force_full_detail_and_keep_own_budgets() {
    let target = 0.3 * full_detail_units();
    let (mut w, keys, crowd) = scene(
        WorldBudget {
            target: BudgetTarget::CostUnits(target),
            ..WorldBudget::default()
        },
        2,
        LodMode::Off,
    );
    w.set_share(keys[5].object(), BudgetShare::FullDetail)
        .unwrap();
    w.set_share(crowd.object(), BudgetShare::FullDetail)
        .unwrap();
    let own = crate::cloth::FeedbackSettings {
        budget: crate::cloth::ClothBudget::Nodes(40),
        ..Default::default()
    };
    w.cloth_mut(keys[4])
        .unwrap()
        .set_feedback(Some(own))
        .unwrap();
    w.set_share(keys[4].object(), BudgetShare::Own).unwrap();
    for f in 0..150 {
        w.step(DT, &view(f)).unwrap();
    }
    let forced = w.cloth(keys[5]).unwrap();
    assert_eq!(forced.node_count(), forced.hierarchy().vertex_count());
    assert_eq!(w.crowd(crowd).unwrap().lod(), LodMode::Off);
    let kept = w.cloth(keys[4]).unwrap();
    assert_eq!(kept.feedback().unwrap().budget, own.budget);
    assert!(kept.node_count() <= 40);
    // The shared cloths gave way.
    let shared = w.cloth(keys[1]).unwrap();
    assert!(shared.node_count() < shared.hierarchy().vertex_count());
}

/// Bad settings and shares are refused with the field named, and nothing changes.
#[test]
fn bad_settings_are_refused_and_change_nothing() {
    let good = WorldBudget {
        target: BudgetTarget::Milliseconds(4.0),
        ..WorldBudget::default()
    };
    let mut w = World::new(good).unwrap();
    let key = w.add_cloth(hanging(9, 1.0, Vec3::ZERO, 0, false));
    for bad in [
        BudgetTarget::Milliseconds(0.0),
        BudgetTarget::Milliseconds(-1.0),
        BudgetTarget::Milliseconds(f32::NAN),
        BudgetTarget::CostUnits(f64::INFINITY),
    ] {
        let e = w
            .set_budget(WorldBudget {
                target: bad,
                ..good
            })
            .unwrap_err();
        assert!(matches!(e, WorldError::Setting { .. }), "{e}");
        assert_eq!(w.budget().settings(), &good);
    }
    for bad in [
        WorldBudget {
            min_error_px: 0.0,
            ..good
        },
        WorldBudget {
            max_error_px: 0.01,
            ..good
        },
        WorldBudget { gain: 1.5, ..good },
        WorldBudget {
            threads: 5000,
            ..good
        },
        WorldBudget {
            cost: CostModel {
                bone_sampled: f32::NAN,
                ..CostModel::default()
            },
            ..good
        },
        WorldBudget {
            cost: CostModel {
                cloth: crate::cloth::CostModel {
                    link_iteration: -1e-9,
                    ..Default::default()
                },
                ..CostModel::default()
            },
            ..good
        },
    ] {
        assert!(w.set_budget(bad).is_err());
        assert!(World::new(bad).is_err());
        assert_eq!(w.budget().settings(), &good);
    }
    let e = w
        .set_share(key.object(), BudgetShare::Shared { weight: 0.0 })
        .unwrap_err();
    assert!(matches!(
        e,
        WorldError::Setting {
            field: "weight",
            ..
        }
    ));
    assert_eq!(w.budget().share(key.object()), BudgetShare::default());
    let removed = w.remove_cloth(key).unwrap();
    assert_eq!(
        w.set_share(key.object(), BudgetShare::FullDetail),
        Err(WorldError::NoSuchObject)
    );
    assert!(w.remove_cloth(key).is_err());
    drop(removed);
    assert!(w.step(f32::NAN, &view(0)).is_err());
    assert_eq!(w.budget().last_stats().frame, 0);
}

/// A cloth's bound curve at the bound it ran under is its own projection (up to the curve's
/// interpolation between bins 1/16 of an octave apart), and it never rises with the bound:
/// what the controller reads agrees with what the cloth will do. (The bound held still: a
/// deadband no window leaves.)
#[test]
fn bound_curves_agree_with_the_cloths_projections() {
    let target = 0.4 * full_detail_units();
    let (w, _) = run(
        WorldBudget {
            target: BudgetTarget::CostUnits(target),
            deadband: 0.999,
            ..WorldBudget::default()
        },
        60,
    );
    let mut checked = 0;
    for (_, c) in w.cloths() {
        let (Some(curve), Some(f)) = (c.bound_curve(), c.feedback()) else {
            continue;
        };
        let crate::cloth::ClothBudget::MaxErrorPx(bound) = f.budget else {
            panic!("a shared cloth runs under an error bound");
        };
        let projected = c.stats().projected_nodes as f64;
        let at = curve.nodes_at(bound);
        assert!(
            (at - projected).abs() <= 0.05 * projected + 1.0,
            "curve {at} nodes at {bound} px, projection {projected}"
        );
        let mut last = f64::INFINITY;
        for k in 0..200 {
            let n = curve.nodes_at(0.01 * 1.06f32.powi(k));
            assert!(n <= last, "the curve rises at step {k}");
            last = n;
        }
        checked += 1;
    }
    assert_eq!(checked, 12, "every cloth has a curve");
}

/// A host whose frames are shorter than its cloths' step (120 Hz frames, 60 Hz cloths) gets
/// the cloths spread over the frames: every frame steps about half of the cloth work, not all
/// of it on every other frame and none between; each cloth's simulated time stays within a
/// step of the world's however the cuts move (the groups are redrawn every controller window
/// under a cost-unit budget); the run is the same on any thread count; and at 60 Hz every
/// cloth still steps every frame.
#[test]
fn cloths_are_spread_over_frames_shorter_than_their_step() {
    let target = 0.4 * full_detail_units();
    let go = |dt: f32, threads: usize, frames: u32| {
        let (mut w, keys, _) = scene(
            WorldBudget {
                target: BudgetTarget::CostUnits(target),
                threads,
                ..WorldBudget::default()
            },
            2,
            LodMode::Off,
        );
        let mut stepped = Vec::new();
        let steps_of = |w: &World, k: ClothKey| w.cloth(k).unwrap().stats().steps;
        let mut before: Vec<u64> = keys.iter().map(|&k| steps_of(&w, k)).collect();
        for f in 0..frames {
            let view = view((f as f32 * dt / DT) as u32);
            w.step(dt, &view).unwrap();
            // Work stepped this frame: links and nodes of the cloths that stepped (a cloth may
            // also spend a frame on an evaluation ahead of its step: not counted here).
            let mut work = 0;
            for (k, b) in keys.iter().zip(&mut before) {
                let now = steps_of(&w, *k);
                if now > *b {
                    let c = w.cloth(*k).unwrap();
                    work += c.link_count() + c.node_count();
                }
                *b = now;
            }
            stepped.push(work);
        }
        let steps: Vec<u64> = keys
            .iter()
            .map(|&k| w.cloth(k).unwrap().stats().steps)
            .collect();
        (stepped, steps, positions(&w))
    };
    let frames = 300;
    let (stepped, steps, p1) = go(1.0 / 120.0, 1, frames);
    // Every frame steps some of the cloth work (without the spread: all of it, then none);
    // once the cold start's cuts have grown, the two frames of a pair step about as much
    // (measured past frame 100: median 2.2%, 88% of pairs within 10%, the largest 26%, at the
    // frames where a regrouped cloth catches up or waits a frame; with the evaluations whole
    // rather than measured in parts, which moves the cuts differently: median 1.2%, 90% within
    // 5%).
    let gaps: Vec<f64> = stepped
        .chunks(2)
        .map(|p| (p[0] as f64 - p[1] as f64).abs() / ((p[0] + p[1]) as f64 / 2.0))
        .collect();
    assert!(stepped.iter().all(|&w| w > 0), "a frame stepped no cloth");
    let late = &gaps[50..];
    let close = late.iter().filter(|&&g| g <= 0.1).count();
    assert!(
        close * 100 >= late.len() * 85,
        "pairs within 10%: {close} of {}",
        late.len()
    );
    assert!(late.iter().all(|&g| g <= 0.35), "{late:?}");
    // 300 frames of 1/120 s are 150 steps of 1/60 s: each cloth within one of that.
    for (k, &s) in steps.iter().enumerate() {
        assert!(
            s.abs_diff(150) <= 1,
            "cloth {k}: {s} steps in 150 steps' time"
        );
    }
    let (_, _, p3) = go(1.0 / 120.0, 3, frames);
    assert!(
        p1.iter()
            .zip(&p3)
            .all(|(a, b)| a.to_array() == b.to_array())
    );
    let (at_60, steps_60, _) = go(DT, 1, 20);
    assert!(at_60.windows(2).all(|w| w[0] > 0 && w[1] > 0));
    assert!(steps_60.iter().all(|&s| s == 20));
}

/// A host at 144 Hz with 60 Hz cloths: 2.4 frames per step, so a staggered cloth steps on
/// every 2.4th frame of its two groups' (not every 2nd), and the controller counts its cost at
/// that rate. Counted at one step per two frames (the groups' number) the estimate read 20%
/// high and the frame cost rested at 0.87 of the target (world tests' scene, cost units, 35%
/// of full detail, 5 s); now the mean of the frames after the first second is within 3% of
/// the target (measured 1.00 at 20–80% of full detail).
#[test]
fn staggered_cost_counts_at_the_cloths_step_rate() {
    let dt = 1.0 / 144.0;
    let frame_view = |f: u32| view((f as f32 * dt / DT) as u32);
    // Full detail at this rate: the mean over 12 frames (5 cloth steps).
    let full = {
        let (mut w, _, _) = scene(WorldBudget::default(), 0, LodMode::Off);
        (0..12)
            .map(|f| w.step(dt, &frame_view(f)).unwrap().cost_units)
            .sum::<f64>()
            / 12.0
    };
    let target = 0.35 * full;
    let (mut w, _, _) = scene(
        WorldBudget {
            target: BudgetTarget::CostUnits(target),
            ..WorldBudget::default()
        },
        2,
        LodMode::Off,
    );
    let costs: Vec<f64> = (0..720)
        .map(|f| w.step(dt, &frame_view(f)).unwrap().measured / target)
        .collect();
    let mean = costs[144..].iter().sum::<f64>() / (costs.len() - 144) as f64;
    assert!(
        (mean - 1.0).abs() <= 0.03,
        "mean frame cost {mean:.3} of the target"
    );
}

/// A cloth whose host changes it between frames (re-pinning a vertex, as a cape's pins follow
/// a character) loses a part of an evaluation measured ahead once: the world then stops
/// splitting its evaluations, instead of measuring half of one for nothing every time. A cloth
/// left alone keeps its parts.
#[test]
fn a_cloth_moved_between_frames_is_not_split() {
    let run = |touch: bool| {
        let mut w = World::new(WorldBudget {
            target: BudgetTarget::CostUnits(1e9),
            ..WorldBudget::default()
        })
        .unwrap();
        let k = w.add_cloth(hanging(17, 1.2, Vec3::new(-0.6, 1.8, -2.0), 1, true));
        let pinned = GridSpec {
            cols: 17,
            rows: 17,
            origin: Vec3::new(-0.6, 1.8, -2.0),
            u: Vec3::new(1.2 / 16.0, 0.0, 0.0),
            v: Vec3::new(0.0, -1.2 / 16.0, 0.0),
            vertex_mass: 0.3 / 289.0,
        };
        for f in 0..60 {
            if touch {
                w.cloth_mut(k)
                    .unwrap()
                    .body_mut()
                    .pin_vertex(pinned.vertex(0, 0), pinned.position(0, 0))
                    .unwrap();
            }
            w.step(DT, &view(f)).unwrap();
        }
        let c = w.cloth(k).unwrap();
        (c.parts_lost(), c.stats().evaluations)
    };
    let (lost, evaluations) = run(true);
    assert!(evaluations >= 10);
    assert_eq!(lost, 1, "split once, then not again");
    assert_eq!(run(false).0, 0);
}
