//! Colliders and wind on the adaptive cloth, and contact in the feedback loop: where a coarse
//! node touches a collider, refine it.
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), sections
//! 3.3–3.4 (collision shapes of new nodes) and 4 (the feedback stage chooses where detail goes).
//!
//! A coarse node collides as a sphere covering its children ([`softbody::collide`]), so where it
//! touches a collider the finest surface it stands for hovers up to that radius above it (or
//! would penetrate, were the radius smaller). That error is what a viewer sees of contact at a
//! coarse level, so a node that touched a collider since the last evaluation gets the priority
//! `weight × (pixels per metre at the node) × (its collision radius)` — in the same pixel units
//! as the screen-error priority of the salience stage — and so does its parent as a merge key,
//! which keeps a region in contact from being coarsened again.

use glam::Vec3;
use salience::View;
use softbody::{ColliderDesc, ColliderId, Colliders, Transform, Wind, WindField};

use super::adaptive::AdaptiveCloth;
use super::error::ClothError;

/// How contact raises priorities in the feedback loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSettings {
    /// Multiplies the on-screen size of a touching node's collision radius (px) to give its
    /// priority; 0 turns contact refinement off.
    pub weight: f32,
}

/// Weight 1: a touching node's priority is the pixels its surface may hover or sink by, the
/// same unit and scale as the salience stage's screen-error priorities.
impl Default for ContactSettings {
    fn default() -> Self {
        ContactSettings { weight: 1.0 }
    }
}

/// Per hierarchy node: touched a collider since the last evaluation.
#[derive(Clone, Debug, Default)]
pub(crate) struct ContactMemory {
    pub(crate) settings: ContactSettings,
    touched: Vec<bool>,
    any: bool,
}

impl ContactMemory {
    /// After a step: remembers which nodes touched a collider.
    pub(crate) fn after_step(&mut self, cloth: &softbody::TreeCutSoftBody) {
        if cloth.colliders().is_empty() {
            return;
        }
        let h = cloth.hierarchy();
        self.touched.resize(h.len(), false);
        for (&node, &t) in cloth
            .particle_nodes()
            .iter()
            .zip(cloth.body().touched_all())
        {
            if t {
                self.touched[node.index()] = true;
                self.any = true;
            }
        }
    }

    /// Whether `node` touched a collider since the last evaluation.
    pub(crate) fn touched(&self, node: treecut::NodeId) -> bool {
        self.any && self.touched.get(node.index()).copied().unwrap_or(false)
    }

    /// At an evaluation: raises the priorities of touching nodes and their parents (see the
    /// module docs). The contacts are kept until [`ContactMemory::forget`].
    pub(crate) fn raise_priorities(
        &self,
        cloth: &softbody::TreeCutSoftBody,
        priorities: &mut [f32],
        view: &View,
    ) {
        if !self.any {
            return;
        }
        let w = self.settings.weight;
        let h = cloth.hierarchy();
        let positions = cloth.particle_positions();
        for (p, &node) in cloth.particle_nodes().iter().enumerate() {
            if !self.touched[node.index()] || w <= 0.0 {
                continue;
            }
            let px = view.pixels_per_unit(positions[p].truncate());
            let own = w * px * cloth.node_collision_radius(node);
            if let Some(slot) = priorities.get_mut(node.index()) {
                *slot = slot.max(own);
            }
            if let Some(parent) = h.parent(node) {
                let key = w * px * cloth.node_collision_radius(parent);
                let slot = &mut priorities[parent.index()];
                *slot = slot.max(key);
            }
        }
    }

    /// Ends an evaluation: the contacts seen so far are forgotten.
    pub(crate) fn forget(&mut self) {
        if self.any {
            self.touched.fill(false);
            self.any = false;
        }
    }
}

impl AdaptiveCloth {
    /// Adds a collider (validated first; refused with nothing changed otherwise).
    pub fn add_collider(&mut self, desc: ColliderDesc) -> Result<ColliderId, ClothError> {
        Ok(self.body_mut().colliders_mut().add(desc)?)
    }

    /// Removes a collider; a stale id is refused.
    pub fn remove_collider(&mut self, id: ColliderId) -> Result<(), ClothError> {
        self.body_mut().colliders_mut().remove(id)?;
        Ok(())
    }

    /// Moves a kinematic collider to `transform` over the next step (friction sees the motion).
    pub fn set_collider_transform(
        &mut self,
        id: ColliderId,
        transform: Transform,
    ) -> Result<(), ClothError> {
        Ok(self
            .body_mut()
            .colliders_mut()
            .set_transform(id, transform)?)
    }

    /// The colliders.
    pub fn colliders(&self) -> &Colliders {
        self.body().colliders()
    }

    /// Sets the wind (or removes it with `None`); an invalid field is refused and the previous
    /// wind stays.
    pub fn set_wind(&mut self, field: Option<WindField>) -> Result<(), ClothError> {
        let wind = field.map(Wind::new).transpose()?;
        Ok(self.body_mut().set_wind(wind)?)
    }

    /// How contact raises priorities.
    pub fn contact_settings(&self) -> &ContactSettings {
        &self.contact().settings
    }

    /// Sets how contact raises priorities (the weight must be finite and >= 0).
    pub fn set_contact_settings(&mut self, settings: ContactSettings) -> Result<(), ClothError> {
        if !(settings.weight.is_finite() && settings.weight >= 0.0) {
            return Err(ClothError::Feedback {
                field: "contact.weight",
                reason: "must be finite and >= 0",
            });
        }
        self.contact_mut().settings = settings;
        Ok(())
    }

    /// The deepest point of `vertices` (the reconstructed finest surface) inside any collider's
    /// bare shape, in metres.
    pub fn max_penetration(&self, vertices: &[Vec3]) -> f32 {
        self.body().max_penetration(vertices)
    }

    /// Wall time of the last step's contact work (broad phase and projections), seconds.
    pub fn last_collision_seconds(&self) -> f64 {
        self.body().colliders().last_seconds()
    }
}
