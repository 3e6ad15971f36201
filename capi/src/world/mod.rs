//! The world: many cloths and crowds stepped together under one frame budget, spent by
//! on-screen benefit, on all cores.
//!
//! An engine does not have one cloth: it has a scene and one frame time to spend. [`World`]
//! holds cloths and crowds; [`World::step`] advances all of them by one frame seen through one
//! [`View`], under a [`WorldBudget`]: milliseconds of wall time, or (deterministic) cost units.
//! By subject: [`budget`] (targets, cost model, per-object shares, settings, errors),
//! [`controller`] (the shared error bound that holds the target) and [`frame`] (one frame:
//! shares applied, objects stepped in parallel, cost counted), which the C world
//! (`slod_world_step`) uses as well.
//!
//! Determinism: with [`BudgetTarget::CostUnits`] or no budget, the same calls give
//! bit-identical results with any thread count (cloths are independent of each other, a
//! crowd's characters of each other, and the controller sees counted work). With
//! [`BudgetTarget::Milliseconds`] the bound follows measured time and results depend on the
//! machine.

pub mod budget;
pub mod controller;
pub mod frame;
mod jobs;
#[cfg(test)]
mod tests;
mod timefit;
mod warm;

use salience::View;
use slod_core::{Arena, Handle};

pub use budget::{BudgetShare, BudgetTarget, CostModel, FrameClock, WorldBudget, WorldError};
pub use controller::{ClothResponse, ErrorBoundController};
pub use frame::{FrameBudgeter, ObjectFrame, ObjectKey, ObjectKind, WorldStepStats};

use crate::cloth::AdaptiveCloth;
use animlod::Crowd;

/// Names a cloth in a [`World`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ClothKey(Handle);

/// Names a crowd in a [`World`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CrowdKey(Handle);

impl ClothKey {
    /// The budget's key for this cloth.
    pub fn object(self) -> ObjectKey {
        ObjectKey::new(ObjectKind::Cloth, self.0.index(), self.0.generation())
    }
}

impl CrowdKey {
    /// The budget's key for this crowd.
    pub fn object(self) -> ObjectKey {
        ObjectKey::new(ObjectKind::Crowd, self.0.index(), self.0.generation())
    }
}

/// Cloths and crowds stepped together under one frame budget (see the module docs).
#[derive(Debug)]
pub struct World {
    cloths: Arena<AdaptiveCloth>,
    crowds: Arena<Crowd>,
    budget: FrameBudgeter,
}

impl World {
    /// An empty world with these budget settings (validated).
    pub fn new(budget: WorldBudget) -> Result<World, WorldError> {
        Ok(World {
            cloths: Arena::default(),
            crowds: Arena::default(),
            budget: FrameBudgeter::new(budget)?,
        })
    }

    /// Adds a cloth; it takes part in the budget with [`BudgetShare::default`].
    pub fn add_cloth(&mut self, cloth: AdaptiveCloth) -> ClothKey {
        ClothKey(self.cloths.insert(cloth))
    }

    /// Adds a crowd; it takes part in the budget with [`BudgetShare::default`].
    pub fn add_crowd(&mut self, crowd: Crowd) -> CrowdKey {
        CrowdKey(self.crowds.insert(crowd))
    }

    /// Removes a cloth and returns it.
    pub fn remove_cloth(&mut self, key: ClothKey) -> Result<AdaptiveCloth, WorldError> {
        let c = self.cloths.remove(key.0).ok_or(WorldError::NoSuchObject)?;
        self.budget.forget(key.object());
        Ok(c)
    }

    /// Removes a crowd and returns it.
    pub fn remove_crowd(&mut self, key: CrowdKey) -> Result<Crowd, WorldError> {
        let c = self.crowds.remove(key.0).ok_or(WorldError::NoSuchObject)?;
        self.budget.forget(key.object());
        Ok(c)
    }

    /// A cloth.
    pub fn cloth(&self, key: ClothKey) -> Option<&AdaptiveCloth> {
        self.cloths.get(key.0)
    }

    /// A cloth, mutably (pins, colliders, wind, its own feedback settings).
    pub fn cloth_mut(&mut self, key: ClothKey) -> Option<&mut AdaptiveCloth> {
        self.cloths.get_mut(key.0)
    }

    /// A crowd.
    pub fn crowd(&self, key: CrowdKey) -> Option<&Crowd> {
        self.crowds.get(key.0)
    }

    /// A crowd, mutably (characters, clips, its own LOD mode).
    pub fn crowd_mut(&mut self, key: CrowdKey) -> Option<&mut Crowd> {
        self.crowds.get_mut(key.0)
    }

    /// Every cloth with its key, in slot order.
    pub fn cloths(&self) -> impl Iterator<Item = (ClothKey, &AdaptiveCloth)> + '_ {
        self.cloths.iter().map(|(h, c)| (ClothKey(h), c))
    }

    /// Every crowd with its key, in slot order.
    pub fn crowds(&self) -> impl Iterator<Item = (CrowdKey, &Crowd)> + '_ {
        self.crowds.iter().map(|(h, c)| (CrowdKey(h), c))
    }

    /// Sets how an object takes part in the budget (refused for an object not in the world or
    /// an invalid weight; nothing changes then).
    pub fn set_share(&mut self, key: ObjectKey, share: BudgetShare) -> Result<(), WorldError> {
        let (index, generation) = key.slot();
        let handle = Handle::from_raw(index, generation);
        let live = match key.kind {
            ObjectKind::Cloth => self.cloths.contains(handle),
            ObjectKind::Crowd => self.crowds.contains(handle),
        };
        if !live {
            return Err(WorldError::NoSuchObject);
        }
        self.budget.set_share(key, share)
    }

    /// The budget: settings, the shared bound, the last frame's statistics per object.
    pub fn budget(&self) -> &FrameBudgeter {
        &self.budget
    }

    /// Replaces the budget settings (refused, with nothing changed, if invalid).
    pub fn set_budget(&mut self, budget: WorldBudget) -> Result<(), WorldError> {
        self.budget.set_settings(budget)
    }

    /// Advances every crowd by `dt` seconds and every cloth through `dt` seconds of its own
    /// solver steps, seen through `view`, under the budget, in one phase on the threads: the
    /// crowds (each split across the threads) beside the cloths, largest first
    /// ([`FrameBudgeter::advance_together`]). When `dt` is shorter than the cloths' step (a
    /// host at 120 Hz, cloths at 60 Hz) the cloths take their steps on different frames, about
    /// an equal share of the cloth work on each ([`FrameBudgeter::step_cloths`]). An object
    /// that fails is reported as the error after every other object has advanced.
    pub fn step(&mut self, dt: f32, view: &View) -> Result<WorldStepStats, WorldError> {
        if !(dt.is_finite() && (0.0..=3600.0).contains(&dt)) {
            return Err(WorldError::Setting {
                field: "dt",
                reason: "must be finite and in [0, 3600] s",
            });
        }
        let mut frame = self.budget.begin_frame();
        self.budget.advance_together(
            &mut frame,
            dt,
            view,
            self.crowds
                .iter_mut()
                .map(|(h, c)| (CrowdKey(h).object(), c)),
            self.cloths
                .iter_mut()
                .map(|(h, c)| (ClothKey(h).object(), c)),
        );
        self.budget.end_frame(frame)
    }
}
