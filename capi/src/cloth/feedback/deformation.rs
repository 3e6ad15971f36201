//! Deformation, the feature the paper's BSWDF lacks (see [`super::Feedback`]): each
//! particle's mean relative link length change `|ℓ/ℓ₀ − 1|`, weighted by link blend weight and
//! by whether the particle is in view, added to its motion salience.

use glam::Vec3;
use salience::{BswdfParams, View};
use softbody::TreeCutSoftBody;

/// Reused per-particle sums of link strain and link weight.
#[derive(Clone, Debug, Default)]
pub(super) struct Strain {
    /// Per particle: summed weighted link strain and summed link weight.
    sums: Vec<(f32, f32)>,
}

impl Strain {
    /// Adds `weight ×` each particle's mean link strain (times its view factor) to `salience`.
    pub(super) fn add_to(
        &mut self,
        body: &TreeCutSoftBody,
        positions: &[Vec3],
        salience: &mut [f32],
        params: &BswdfParams,
        weight: f32,
        view: &View,
    ) {
        let n = positions.len();
        self.sums.clear();
        self.sums.resize(n, (0.0, 0.0));
        for l in body.links() {
            let (a, b) = (l.a.raw() as usize, l.b.raw() as usize);
            if l.rest <= 0.0 || l.weight <= 0.0 {
                continue;
            }
            let e = l.weight * (positions[a].distance(positions[b]) / l.rest - 1.0).abs();
            for p in [a, b] {
                self.sums[p].0 += e;
                self.sums[p].1 += l.weight;
            }
        }
        for ((s, &(sum, w)), &x) in salience.iter_mut().zip(&self.sums).zip(positions) {
            if w <= 0.0 {
                continue;
            }
            let seen = if view.is_in_view(x, params.view_margin) {
                1.0
            } else {
                params.outside_view_weight
            };
            *s += weight * (sum / w) * seen;
        }
    }
}
