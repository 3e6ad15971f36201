//! The world step under one frame budget: `slod_world_step` advances every crowd and cloth of a
//! world by one frame seen through the world's camera, spending one budget (milliseconds, or
//! deterministic cost units) by on-screen benefit; per-object shares let a host force an object
//! to full detail (as APEX's `forcePhysicalLod`) or keep its own settings. The Rust side is
//! [`crate::world`].

use super::arena::RawId;
use super::boundary::{arg, arg_mut, boundary, write_out};
use super::cloth::{cloth_error, in_range};
use super::crowd::crowd_error;
use super::ids::{SlodClothId, SlodCrowdId};
use super::result::{FfiError, SlodResult};
use super::world::{SLOD_DESC_GUARD, SlodWorld, check_guard};
use crate::world::{
    BudgetShare, BudgetTarget, CostModel, ObjectKey, ObjectKind, WorldBudget, WorldError,
};

/// What a world frame may spend (values of `SlodWorldBudgetDesc::target_kind`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodWorldBudgetKind {
    /// No world budget: every object keeps its own settings; `slod_world_step` only steps them
    /// (in parallel). The default.
    None = 0,
    /// `target_ms` milliseconds of wall time per frame (> 0, <= 1e6). The shared error bound
    /// follows measured time, so results depend on the machine and its load.
    Milliseconds = 1,
    /// `target_units` cost units per frame (> 0, finite), counted from the work done (see
    /// `SlodCostModel`): the same calls give bit-identical results on any machine and with any
    /// thread count.
    CostUnits = 2,
}

/// How one object takes part in the world budget (values of `share` in
/// `slod_world_set_cloth_share` / `slod_world_set_crowd_share`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlodBudgetShare {
    /// Spends the world budget: its error bound is the world's divided by `weight` (> 0,
    /// finite; 1 = as its pixels say, 2 = the detail of an object twice as large on screen).
    /// The default for every object.
    Shared = 0,
    /// Always at full detail (the cloth's finest cut, the crowd with LOD off); its cost still
    /// counts, so the others give way.
    FullDetail = 1,
    /// Keeps its own budget or LOD mode; the world steps it and counts its cost.
    Own = 2,
}

/// What each kind of work costs in cost units (modelled nanoseconds on one core). Only the
/// ratios matter for a budget; the defaults were measured on the project's reference machine.
/// Every field is finite and >= 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodCostModel {
    /// A cloth step whatever its work, ns.
    pub cloth_step: f64,
    /// One link solved once (per substep per iteration), ns.
    pub link_iteration: f64,
    /// One simulated node through one substep, ns.
    pub node_substep: f64,
    /// One refine/coarse transition in flight through one step, ns: the part that does not
    /// depend on the cloth's substeps.
    pub transition: f64,
    /// One refine/coarse transition in flight through one substep, ns (its blended links are
    /// solved in every substep).
    pub transition_substep: f64,
    /// One simulated node through one feedback evaluation, ns.
    pub evaluation_node: f64,
    /// One bone sampled and interpolated, ns.
    pub bone_sampled: f32,
    /// One bone's model matrix recomputed, ns.
    pub bone_concatenated: f32,
    /// One character advanced, ns.
    pub character: f32,
}

impl SlodCostModel {
    fn from_model(m: &CostModel) -> SlodCostModel {
        SlodCostModel {
            cloth_step: m.cloth.fixed * 1e9,
            link_iteration: m.cloth.link_iteration * 1e9,
            node_substep: m.cloth.node_substep * 1e9,
            transition: m.cloth.transition * 1e9,
            transition_substep: m.cloth.transition_substep * 1e9,
            evaluation_node: m.cloth.evaluated_node * 1e9,
            bone_sampled: m.bone_sampled,
            bone_concatenated: m.bone_concatenated,
            character: m.character,
        }
    }

    fn to_model(self) -> CostModel {
        CostModel {
            cloth: crate::cloth::CostModel {
                fixed: self.cloth_step * 1e-9,
                link_iteration: self.link_iteration * 1e-9,
                node_substep: self.node_substep * 1e-9,
                transition: self.transition * 1e-9,
                transition_substep: self.transition_substep * 1e-9,
                evaluated_node: self.evaluation_node * 1e-9,
            },
            bone_sampled: self.bone_sampled,
            bone_concatenated: self.bone_concatenated,
            character: self.character,
        }
    }
}

/// Settings of a world's frame budget. Get one from `slod_default_world_budget_desc`, set
/// `target_kind` and its target, and pass it to `slod_world_set_budget`.
///
/// One on-screen error bound in pixels is shared by every object with the `SHARED` share: each
/// cloth refines where its estimated on-screen error exceeds it, each crowd holds bones until
/// their drift reaches it; a controller moves the bound every `update_frames` frames so that
/// a frame costs the target.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlodWorldBudgetDesc {
    /// Set by `slod_default_world_budget_desc`; do not change.
    pub guard: u32,
    /// A `SlodWorldBudgetKind` value.
    pub target_kind: u32,
    /// Target wall time per frame, ms (for `SLOD_WORLD_BUDGET_KIND_MILLISECONDS`).
    pub target_ms: f32,
    /// Target cost units per frame (for `SLOD_WORLD_BUDGET_KIND_COST_UNITS`).
    pub target_units: f64,
    /// Threads the world step uses: 0 = all of the world's worker threads (see
    /// `SlodWorldDesc::worker_threads`; a world created with 1 runs serially), 1 = the calling
    /// thread only, n >= 2 = a pool of n threads owned by the budget (at most 1024).
    pub threads: u32,
    /// The bound the controller starts from, px (> 0).
    pub initial_error_px: f32,
    /// Smallest bound the controller may set, px (> 0).
    pub min_error_px: f32,
    /// Largest bound, px (>= min_error_px).
    pub max_error_px: f32,
    /// Frames between controller updates (>= 1; the cloths' feedback interval; times the frames
    /// per cloth step when frames are shorter than the cloths' step).
    pub update_frames: u32,
    /// Fraction of the measured log-ratio the bound moves per update, in (0, 1].
    pub gain: f32,
    /// Relative distance from the target inside which the bound stays, in [0, 1).
    pub deadband: f32,
    /// Largest factor the bound changes by per update (> 1).
    pub max_change: f32,
    /// Most solver steps a cloth takes per frame when `dt` exceeds its own step (>= 1).
    pub max_cloth_steps: u32,
    /// How work is counted in cost units.
    pub cost: SlodCostModel,
    /// After each phase of a frame the worker threads spin up to this long, ms, waiting for
    /// the next phase instead of sleeping (all of them between phases, all but one after the
    /// frame; [0, 1000]; 0 = never; default 1).
    /// Waking a sleeping thread can take milliseconds on a virtual machine; after the frame's
    /// last phase the spin lasts until the next `slod_world_step` or this limit.
    pub spin_wait_ms: f32,
}

/// The default world budget: no target (`SLOD_WORLD_BUDGET_KIND_NONE`), the Rust defaults for
/// every other field (the bound starts at 1 px, moves within [0.05, 200] px every 5 frames).
///
/// Returns a value the host owns; set `target_kind` and `target_ms` or `target_units`.
#[unsafe(no_mangle)]
pub extern "C" fn slod_default_world_budget_desc() -> SlodWorldBudgetDesc {
    let d = WorldBudget::default();
    SlodWorldBudgetDesc {
        guard: SLOD_DESC_GUARD,
        target_kind: SlodWorldBudgetKind::None as u32,
        target_ms: 0.0,
        target_units: 0.0,
        threads: d.threads as u32,
        initial_error_px: d.initial_error_px,
        min_error_px: d.min_error_px,
        max_error_px: d.max_error_px,
        update_frames: d.update_frames,
        gain: d.gain,
        deadband: d.deadband,
        max_change: d.max_change,
        max_cloth_steps: d.max_cloth_steps,
        cost: SlodCostModel::from_model(&d.cost),
        spin_wait_ms: d.spin_wait_ms,
    }
}

impl SlodWorldBudgetDesc {
    /// The Rust settings, or an error naming the bad field. `serial_world`: the world was
    /// created with one worker thread, so "all threads" means one.
    pub(crate) fn to_budget(self, serial_world: bool) -> Result<WorldBudget, FfiError> {
        check_guard(self.guard, "desc")?;
        let target = match self.target_kind {
            k if k == SlodWorldBudgetKind::None as u32 => BudgetTarget::None,
            k if k == SlodWorldBudgetKind::Milliseconds as u32 => {
                in_range(self.target_ms, f32::MIN_POSITIVE, 1e6, "desc.target_ms")?;
                BudgetTarget::Milliseconds(self.target_ms)
            }
            k if k == SlodWorldBudgetKind::CostUnits as u32 => {
                if !(self.target_units.is_finite() && self.target_units > 0.0) {
                    return Err(FfiError::invalid(
                        "desc.target_units",
                        "must be finite and > 0",
                    ));
                }
                BudgetTarget::CostUnits(self.target_units)
            }
            k => {
                return Err(FfiError::invalid(
                    "desc.target_kind",
                    format!("{k} is not a SlodWorldBudgetKind value"),
                ));
            }
        };
        let threads = match self.threads {
            0 if serial_world => 1,
            n => n as usize,
        };
        let budget = WorldBudget {
            target,
            threads,
            initial_error_px: self.initial_error_px,
            min_error_px: self.min_error_px,
            max_error_px: self.max_error_px,
            update_frames: self.update_frames,
            gain: self.gain,
            deadband: self.deadband,
            max_change: self.max_change,
            max_cloth_steps: self.max_cloth_steps,
            cost: self.cost.to_model(),
            spin_wait_ms: self.spin_wait_ms,
            ..WorldBudget::default()
        };
        budget.validate().map_err(world_error)?;
        Ok(budget)
    }
}

/// The C side of a world error.
pub(crate) fn world_error(e: WorldError) -> FfiError {
    match e {
        WorldError::Setting { field, reason } => FfiError::invalid(field, reason),
        WorldError::NoSuchObject => FfiError::StaleId("object"),
        WorldError::Threads(m) => FfiError::Refused(format!("cannot start worker threads: {m}")),
        WorldError::Cloth(e) => cloth_error(e),
        WorldError::Crowd(e) => crowd_error(e),
    }
}

fn cloth_key(id: RawId) -> ObjectKey {
    ObjectKey::new(ObjectKind::Cloth, id.index1, id.generation)
}

fn crowd_key(id: RawId) -> ObjectKey {
    ObjectKey::new(ObjectKind::Crowd, id.index1, id.generation)
}

/// Forgets a destroyed object's share (called by the destroy functions).
pub(crate) fn forget_cloth(world: &mut SlodWorld, id: RawId) {
    world.budget.forget(cloth_key(id));
}

/// Forgets a destroyed crowd's share.
pub(crate) fn forget_crowd(world: &mut SlodWorld, id: RawId) {
    world.budget.forget(crowd_key(id));
}

/// Sets the world's frame budget (validated and copied). The controller keeps its bound when
/// only the target value changes.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_INVALID_ARGUMENT` naming the field (a target
/// <= 0 or NaN, an unknown kind, a bad range, ...) and nothing changes; `SLOD_RESULT_REFUSED`
/// if the budget's own threads cannot start.
///
/// # Safety
/// `world` NULL or a live world; `desc` NULL or a valid desc.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_world_set_budget(
    world: *mut SlodWorld,
    desc: *const SlodWorldBudgetDesc,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        // SAFETY: caller contract: NULL or a valid desc.
        let desc = *unsafe { arg(desc, "desc") }?;
        let budget = desc.to_budget(!world.parallel_allowed())?;
        world.budget.set_settings(budget).map_err(world_error)
    })
}

fn share_from(share: u32, weight: f32) -> Result<BudgetShare, FfiError> {
    let s = match share {
        s if s == SlodBudgetShare::Shared as u32 => BudgetShare::Shared { weight },
        s if s == SlodBudgetShare::FullDetail as u32 => BudgetShare::FullDetail,
        s if s == SlodBudgetShare::Own as u32 => BudgetShare::Own,
        s => {
            return Err(FfiError::invalid(
                "share",
                format!("{s} is not a SlodBudgetShare value"),
            ));
        }
    };
    s.validate().map_err(world_error)?;
    Ok(s)
}

/// Sets how a cloth takes part in the world budget: `SLOD_BUDGET_SHARE_SHARED` with `weight`
/// (> 0, finite), `_FULL_DETAIL` (weight ignored) or `_OWN` (weight ignored: the cloth keeps
/// the feedback settings the host gave it). Takes effect at the next `slod_world_step`.
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`; `SLOD_RESULT_INVALID_ARGUMENT`
/// for an unknown share or a bad weight (nothing changes).
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_world_set_cloth_share(
    world: *mut SlodWorld,
    cloth: SlodClothId,
    share: u32,
    weight: f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let raw = RawId::from(cloth);
        world.cloths.get(raw, "cloth")?;
        let s = share_from(share, weight)?;
        world
            .budget
            .set_share(cloth_key(raw), s)
            .map_err(world_error)
    })
}

/// Sets how a crowd takes part in the world budget (see `slod_world_set_cloth_share`; `_OWN`
/// keeps the crowd's own LOD mode, `_FULL_DETAIL` plays it with LOD off).
///
/// Threads: mutates the world. Errors: `SLOD_RESULT_STALE_ID`; `SLOD_RESULT_INVALID_ARGUMENT`
/// for an unknown share or a bad weight (nothing changes).
///
/// # Safety
/// `world` NULL or a live world.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_world_set_crowd_share(
    world: *mut SlodWorld,
    crowd: SlodCrowdId,
    share: u32,
    weight: f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        let raw = RawId::from(crowd);
        world.crowds.get(raw, "crowd")?;
        let s = share_from(share, weight)?;
        world
            .budget
            .set_share(crowd_key(raw), s)
            .map_err(world_error)
    })
}

/// What one `slod_world_step` did.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlodWorldStepStats {
    /// Frames stepped so far, this one included.
    pub frame: u64,
    /// Wall time of the frame, ms.
    pub wall_ms: f64,
    /// Wall time of the crowd phase, ms.
    pub crowd_ms: f64,
    /// Wall time of the cloth phase, ms.
    pub cloth_ms: f64,
    /// Modelled cost of the frame, cost units.
    pub cost_units: f64,
    /// What the controller measured (ms or units, as the target; 0 without a budget).
    pub measured: f64,
    /// The shared error bound the frame ran under, px.
    pub error_bound_px: f32,
    /// Threads the frame could use.
    pub threads: u32,
    /// Cloths stepped.
    pub cloths: u32,
    /// Crowds advanced.
    pub crowds: u32,
    /// Solver steps over all cloths.
    pub cloth_steps: u32,
    /// Feedback evaluations over all cloths.
    pub evaluations: u32,
    /// Simulated nodes over all cloths after the frame.
    pub cloth_nodes: u64,
    /// Finest nodes over all cloths.
    pub cloth_full_nodes: u64,
    /// Bones interpolated over all crowds.
    pub bones_interpolated: u64,
    /// Animated bones over all crowds.
    pub bones_animated: u64,
}

/// Advances every crowd by `dt` seconds and every cloth through `dt` seconds of its own solver
/// steps (at most `max_cloth_steps`), seen through the world's camera and light, under the
/// world's budget: crowds first (split across the threads), then cloths worn by characters
/// follow their new poses, then all cloths step in parallel (a world with no worn cloth runs
/// its crowds and cloths in one phase on the threads, as `World::step` does). Writes what the frame did to
/// `*out_stats` when it is not NULL.
///
/// Use it instead of calling `slod_crowd_advance` and `slod_cloth_step` per object. Threads:
/// mutates the world; runs on the world's worker threads (or the budget's own). Errors:
/// `SLOD_RESULT_INVALID_ARGUMENT` for a `dt` outside [0, 3600] or NaN (nothing changes); an
/// object that fails (a stale character a cloth is worn by, ...) is reported with its code
/// after every other object has advanced, and the statistics are written anyway.
///
/// # Safety
/// `world` NULL or a live world; `out_stats` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_world_step(
    world: *mut SlodWorld,
    dt: f32,
    out_stats: *mut SlodWorldStepStats,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world used by this thread only.
        let world = unsafe { arg_mut(world, "world") }?;
        in_range(dt, 0.0, 3600.0, "dt")?;
        let mut frame = world.budget.begin_frame();
        let view = world.view;
        let worn = world.cloths.iter_mut().any(|(_, e)| e.contacts.is_worn());
        let mut followed = Ok(());
        if !worn {
            // No cloth follows a character: crowds and cloths share one phase on the threads
            // (`FrameBudgeter::advance_together`), as `World::step` does.
            let SlodWorld {
                pool,
                budget,
                crowds,
                cloths,
                ..
            } = &mut *world;
            SlodWorld::run(pool.as_ref(), || {
                budget.advance_together(
                    &mut frame,
                    dt,
                    &view,
                    crowds.iter_mut().map(|(id, c)| (crowd_key(id), c)),
                    cloths
                        .iter_mut()
                        .map(|(id, e)| (cloth_key(id), &mut e.cloth)),
                );
            });
        } else {
            {
                let SlodWorld {
                    pool,
                    budget,
                    crowds,
                    ..
                } = &mut *world;
                SlodWorld::run(pool.as_ref(), || {
                    budget.advance_crowds(
                        &mut frame,
                        dt,
                        &view,
                        crowds.iter_mut().map(|(id, c)| (crowd_key(id), c)),
                    );
                });
            }
            // Worn cloths follow their characters' new poses before stepping.
            for id in world.cloths.ids() {
                if let Err(e) = super::collider::follow_character(world, id.into())
                    && followed.is_ok()
                {
                    followed = Err(e);
                }
            }
            let SlodWorld {
                pool,
                budget,
                cloths,
                ..
            } = &mut *world;
            SlodWorld::run(pool.as_ref(), || {
                budget.step_cloths(
                    &mut frame,
                    dt,
                    &view,
                    cloths
                        .iter_mut()
                        .map(|(id, e)| (cloth_key(id), &mut e.cloth)),
                );
            });
        }
        let outcome = world.budget.end_frame(frame);
        let s = *world.budget.last_stats();
        if !out_stats.is_null() {
            let stats = SlodWorldStepStats {
                frame: s.frame,
                wall_ms: s.wall_ms,
                crowd_ms: s.crowd_ms,
                cloth_ms: s.cloth_ms,
                cost_units: s.cost_units,
                measured: s.measured,
                error_bound_px: s.error_bound_px,
                threads: s.threads,
                cloths: s.cloths,
                crowds: s.crowds,
                cloth_steps: s.cloth_steps,
                evaluations: s.evaluations,
                cloth_nodes: s.cloth_nodes,
                cloth_full_nodes: s.cloth_full_nodes,
                bones_interpolated: s.bones_interpolated,
                bones_animated: s.bones_animated,
            };
            // SAFETY: checked non-NULL; valid for a write per the caller contract.
            unsafe { write_out(out_stats, stats, "out_stats") }?;
        }
        followed?;
        outcome.map(|_| ()).map_err(world_error)
    })
}

/// Writes the world budget's current shared error bound, px, to `*out_px`.
///
/// Threads: reads the world only.
///
/// # Safety
/// `world` NULL or a live world; `out_px` NULL or valid for a write.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn slod_world_error_bound(
    world: *const SlodWorld,
    out_px: *mut f32,
) -> SlodResult {
    boundary(|| {
        // SAFETY: caller contract: NULL or a live world.
        let world = unsafe { arg(world, "world") }?;
        // SAFETY: caller contract: NULL or valid for a write.
        unsafe { write_out(out_px, world.budget.error_bound_px(), "out_px") }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ffi::{
        SlodClothDesc, slod_cloth_create_grid, slod_default_cloth_desc, slod_default_world_desc,
        slod_world_create, slod_world_destroy,
    };

    #[test]
    fn default_budget_desc_is_the_rust_default() {
        let d = slod_default_world_budget_desc();
        let back = d.to_budget(false).unwrap();
        let rust = WorldBudget::default();
        // The cloth's costs cross as nanoseconds: equal up to the rounding of × 1e9 / 1e9.
        let (a, b) = (back.cost.cloth, rust.cost.cloth);
        for (x, y) in [
            (a.fixed, b.fixed),
            (a.link_iteration, b.link_iteration),
            (a.node_substep, b.node_substep),
            (a.transition, b.transition),
            (a.transition_substep, b.transition_substep),
            (a.evaluated_node, b.evaluated_node),
        ] {
            assert!((x - y).abs() <= 1e-12 * y.abs(), "{x} vs {y}");
        }
        let cost = WorldBudget {
            cost: crate::world::CostModel {
                cloth: b,
                ..back.cost
            },
            ..back
        };
        assert_eq!(cost, rust);
    }

    #[test]
    fn bad_budgets_and_shares_are_refused_and_change_nothing() {
        // SAFETY: valid desc and out pointer; the world is destroyed at the end.
        unsafe {
            let mut w = std::ptr::null_mut();
            assert_eq!(
                slod_world_create(&slod_default_world_desc(), &mut w),
                SlodResult::Ok
            );
            let good = SlodWorldBudgetDesc {
                target_kind: SlodWorldBudgetKind::Milliseconds as u32,
                target_ms: 4.0,
                ..slod_default_world_budget_desc()
            };
            assert_eq!(slod_world_set_budget(w, &good), SlodResult::Ok);
            let before = *(*w).budget.settings();
            for bad in [
                SlodWorldBudgetDesc {
                    target_ms: 0.0,
                    ..good
                },
                SlodWorldBudgetDesc {
                    target_ms: f32::NAN,
                    ..good
                },
                SlodWorldBudgetDesc {
                    target_kind: 7,
                    ..good
                },
                SlodWorldBudgetDesc {
                    target_kind: SlodWorldBudgetKind::CostUnits as u32,
                    target_units: -1.0,
                    ..good
                },
                SlodWorldBudgetDesc { guard: 0, ..good },
                SlodWorldBudgetDesc {
                    threads: 5000,
                    ..good
                },
                SlodWorldBudgetDesc {
                    min_error_px: 0.0,
                    ..good
                },
                SlodWorldBudgetDesc {
                    spin_wait_ms: -1.0,
                    ..good
                },
                SlodWorldBudgetDesc {
                    spin_wait_ms: f32::INFINITY,
                    ..good
                },
            ] {
                assert_ne!(slod_world_set_budget(w, &bad), SlodResult::Ok, "{bad:?}");
                assert_eq!(*(*w).budget.settings(), before);
            }
            assert_eq!(
                slod_world_set_budget(w, std::ptr::null()),
                SlodResult::NullArgument
            );
            let mut cloth = SlodClothId::default();
            let desc = SlodClothDesc {
                columns: 9,
                rows: 9,
                ..slod_default_cloth_desc()
            };
            assert_eq!(slod_cloth_create_grid(w, &desc, &mut cloth), SlodResult::Ok);
            assert_eq!(
                slod_world_set_cloth_share(w, cloth, 9, 1.0),
                SlodResult::InvalidArgument
            );
            assert_eq!(
                slod_world_set_cloth_share(w, cloth, SlodBudgetShare::Shared as u32, 0.0),
                SlodResult::InvalidArgument
            );
            assert_eq!(
                slod_world_set_crowd_share(w, SlodCrowdId::default(), 0, 1.0),
                SlodResult::StaleId
            );
            assert_eq!(
                slod_world_step(w, f32::NAN, std::ptr::null_mut()),
                SlodResult::InvalidArgument
            );
            assert_eq!((*w).budget.last_stats().frame, 0);
            let mut stats = SlodWorldStepStats::default();
            assert_eq!(slod_world_step(w, 1.0 / 60.0, &mut stats), SlodResult::Ok);
            assert_eq!((stats.frame, stats.cloths, stats.cloth_steps), (1, 1, 1));
            assert!(stats.cost_units > 0.0);
            slod_world_destroy(w);
        }
    }
}
