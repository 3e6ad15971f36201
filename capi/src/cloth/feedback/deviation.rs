//! On-screen deviation: an estimate, in pixels of the frame's [`View`], of how far the surface a
//! node stands for is from what the node can represent — the error a viewer would see if the
//! node stays as it is (for a simulated node) or if its children were merged into it (for a
//! merge candidate). It drives [`super::ClothBudget::MaxErrorPx`].
//!
//! Based on: the simulation-LOD paper (`simulation-lod-treecut-softbody-bswdf.txt`), section 5
//! (the feedback stage ranks nodes for refine/coarse), with the view-dependent refinement
//! criterion of Koh, Narain and O'Brien, "View-dependent adaptive cloth simulation" (SCA 2014,
//! section 4: refine where the projected size of the geometric error exceeds a pixel
//! tolerance); the rotation fit is shape matching (Müller et al. 2005, via [`softbody::shape`]).
//!
//! # The estimate
//! A simulated node `p` carries its region rigidly (up to the reconstruction's blending). What a
//! rigid patch cannot show is bending and non-uniform stretch. Fit the best rotation `R` that
//! maps `p`'s rest neighbourhood onto its current one (offsets from `p`); the residual
//! `ρ_q = (x_q − x_p) − R (x̄_q − x̄_p)` of each neighbour `q` is the deformation at the
//! neighbourhood's scale `d` (mean rest distance to the neighbours). For a smooth deformation
//! (curvature κ) the residual grows as `κ d² / 2` and the deviation inside the node's own
//! radius `r` as `κ r² / 2`, so the node's error is `max_q |ρ_q|⊥ · (r / d)²`, where `⊥` keeps
//! only the part across the view ray (a deviation along the ray does not move a pixel). Times
//! the pixels per unit at `x_p` it is pixels on screen. Out of view it is weighted by the
//! BSWDF's `outside_view_weight` when it ranks nodes for a node or time budget. Under an error
//! bound it counts in full while any of the cloth is in view, at its own pixels per unit capped
//! by the largest of the part in view: a bound promises the error a viewer sees, and the error
//! of a region out of view reaches the screen through the cloth's dynamics (an unseen coarse
//! region drags the seen one), at the seen part's scale at most (the cap also keeps a point
//! beside or behind the eye from reading as huge). A cloth wholly out of view drags nothing
//! that is seen and keeps the outside weight. So does a cloth whose bound a world moves: there
//! the bound is the world's exchange rate between error and cost across objects, not a promise
//! to the viewer, and the world spends its budget on what is seen (counted as seen, its
//! cost-unit controller on the world test scene held the band less well: the camera flies
//! past partly seen cloths).
//! Measured (perception `offscreen` scene, 1 px bound, 65², 200 steps): at the outside weight
//! 0.1 the measured p99 / max were 2.56 / 6.2 px at 3,051 nodes; counted as seen, 0.48 / 0.8 px
//! at 4,059 of 4,225 (weight 0.5: 0.85 / 2.0 px, 3,742 nodes). The close-up: 4.39 / 27.5 →
//! 3.39 / 21.4 px at +0.3% nodes. Scenes seen whole are unchanged.
//!
//! Two more terms join it. *Stretch*: a node whose links are strained by `ε` on average spreads
//! that stretch evenly over its region, misplacing it by about `ε · r`; on the rim (a node
//! covering a boundary vertex) this term counts `1 + rim_weight` times, since a held sheet's
//! stretch concentrates there and a coarse rim node moves the whole sheet (see
//! `FeedbackSettings::rim_weight`). *Latency*: the
//! neighbourhood's relative velocity across the ray, times the time the cut needs to respond
//! (an evaluation interval plus a refine's blend), is deformation that will appear before a
//! refine could show it; it is scaled like the bending residual.
//!
//! A merge candidate (a parent whose children are all simulated) gets its children's largest
//! estimate scaled to its own radius (`(r_parent / r_child)²`, the same model), so refining and
//! merging are judged by one measure; thresholds are fractions of the host's pixel bound — no
//! constant fitted to one scene.

use glam::{Mat3, Quat, Vec3};
use salience::View;
use softbody::shape::{accumulate, rotation_of};

/// What one estimate looks at: the particles now (copies: a measurement may run while the
/// body steps), node sizes and the view.
#[derive(Clone, Copy, Debug)]
pub(super) struct Frame<'a> {
    /// The cloth's hierarchy.
    pub(super) hierarchy: &'a treecut::Hierarchy,
    /// The hierarchy node of each particle.
    pub(super) nodes: &'a [treecut::NodeId],
    /// Particle positions.
    pub(super) positions: &'a [Vec3],
    /// Particle velocities.
    pub(super) velocities: &'a [Vec3],
    /// How long an error lasts before the cut can respond, in seconds (one evaluation interval
    /// plus the blend of a refine).
    pub(super) latency: f32,
    /// Rest radius per hierarchy node.
    pub(super) node_radius: &'a [f32],
    /// The frame's view.
    pub(super) view: &'a View,
    /// Weight of an error outside the view (the BSWDF's `outside_view_weight`).
    pub(super) outside_weight: f32,
    /// Count an error outside the view as seen, at the pixels per unit of the cloth's part in
    /// view (capped by its own), while any of the cloth is in view: under an error bound (see
    /// [`Deviation::measure`]).
    pub(super) outside_as_seen: bool,
    /// Per hierarchy node: whether it is a refinable node on the rim (empty: none).
    pub(super) rim: &'a [bool],
    /// The stretch term of a rim node counts `1 + rim_weight` times.
    pub(super) rim_weight: f32,
}

/// What a measurement split over calls carries between them (see [`Deviation::begin`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Progress {
    /// The stamp of the evaluation before this one (whose estimates are held and inherited).
    previous: u32,
    /// This one's stamp (set when it ends).
    current: u32,
    /// The largest pixels per unit of the cloth's part in view.
    seen_ppu: f32,
}

/// Reused buffers: a warm-start rotation per hierarchy node, and the last estimates.
#[derive(Clone, Debug)]
pub(super) struct Deviation {
    rotations: Vec<Quat>,
    /// Per hierarchy node: the estimate (px) at the evaluation stamped in `stamps`.
    remembered: Vec<f32>,
    stamps: Vec<u32>,
    evaluation: u32,
    /// Per particle: estimated on-screen error (px) of keeping its node as it is.
    pub(super) particle_px: Vec<f32>,
}

/// The unit ray from the eye through `at` (zero at the eye).
#[inline]
fn ray_through(view: &View, at: Vec3) -> Vec3 {
    (at - view.position()).normalize_or_zero()
}

/// The part of `v` across `ray` (a unit vector or zero).
#[inline]
fn across_ray(ray: Vec3, v: Vec3) -> Vec3 {
    v - ray * v.dot(ray)
}

impl Deviation {
    /// Buffers for a hierarchy of `len` nodes.
    pub(super) fn new(len: usize) -> Deviation {
        Deviation {
            rotations: vec![Quat::IDENTITY; len],
            remembered: vec![0.0; len],
            stamps: vec![0; len],
            evaluation: 0,
            particle_px: Vec::new(),
        }
    }

    /// Estimates every particle's on-screen error into [`Deviation::particle_px`];
    /// `offsets`/`neighbours` are the particles' neighbour table (CSR). Each estimate is the
    /// larger of the current one and the last one decayed by `decay` (a peak hold, as the
    /// salience memory: a swing's turning point would otherwise read as a calm surface, and the
    /// cut would flicker with the swing's period). A node just refined or coarsened inherits its
    /// parent's or children's last estimate scaled to its radius (`(r / r_source)²`).
    pub(super) fn measure(&mut self, frame: &Frame<'_>, csr: (&[u32], &[u32]), decay: f32) {
        let mut progress = self.begin(frame);
        self.measure_range(frame, csr, decay, &mut progress, frame.nodes.len());
        self.end(frame, progress);
    }

    /// Starts a measurement that [`Deviation::measure_range`] carries out in parts (the
    /// particles in order) and [`Deviation::end`] closes: the whole of
    /// [`Deviation::measure`], split over calls on a body that does not change between them.
    pub(super) fn begin(&mut self, frame: &Frame<'_>) -> Progress {
        // The stamp moves on only when the measurement ends: one dropped half-way leaves the
        // last one's estimates in place for the next.
        let previous = self.evaluation;
        let current = previous.wrapping_add(1).max(1);
        let Frame {
            nodes,
            positions,
            node_radius,
            view,
            outside_as_seen,
            ..
        } = *frame;
        // The largest pixels per unit of the cloth's part in view (0: none in view).
        let seen_ppu = if outside_as_seen {
            nodes
                .iter()
                .zip(positions)
                .filter(|&(n, &x)| view.sphere_in_view(x, node_radius[n.index()]))
                .map(|(_, &x)| view.pixels_per_unit(x))
                .filter(|v| v.is_finite())
                .fold(0.0, f32::max)
        } else {
            0.0
        };
        self.particle_px.clear();
        Progress {
            previous,
            current,
            seen_ppu,
        }
    }

    /// Particles measured so far in the measurement begun by [`Deviation::begin`].
    pub(super) fn measured(&self) -> usize {
        self.particle_px.len()
    }

    /// Estimates the particles from the next one not yet measured up to `upto` (exclusive).
    pub(super) fn measure_range(
        &mut self,
        frame: &Frame<'_>,
        (offsets, neighbours): (&[u32], &[u32]),
        decay: f32,
        progress: &mut Progress,
        upto: usize,
    ) {
        let Progress {
            previous, seen_ppu, ..
        } = *progress;
        let Frame {
            hierarchy: h,
            nodes,
            positions,
            velocities,
            latency,
            node_radius,
            view,
            outside_weight,
            rim,
            rim_weight,
            ..
        } = *frame;
        let from = self.particle_px.len();
        for (p, &node) in nodes.iter().enumerate().take(upto).skip(from) {
            let (x_p, rest_p) = (positions[p], h.rest_position(node));
            let around = &neighbours[offsets[p] as usize..offsets[p + 1] as usize];
            let mut cov = Mat3::ZERO;
            let (mut spacing, mut strain, mut v_mean) = (0.0, 0.0, Vec3::ZERO);
            for &q in around {
                let rest_q = h.rest_position(nodes[q as usize]);
                let offset = positions[q as usize] - x_p;
                accumulate(&mut cov, offset, rest_q - rest_p);
                let d = rest_q.distance(rest_p);
                spacing += d;
                if d > 0.0 {
                    strain += (offset.length() / d - 1.0).abs();
                }
                v_mean += velocities[q as usize];
            }
            if around.is_empty() || spacing <= 0.0 {
                self.particle_px.push(0.0);
                continue;
            }
            let k = around.len() as f32;
            let (spacing, strain) = (spacing / k, strain / k);
            let v_rel = velocities[p] - v_mean / k;
            let r = rotation_of(&cov, self.rotations[node.index()]);
            self.rotations[node.index()] = r;
            let ray = ray_through(view, x_p);
            let mut worst = 0f32;
            for &q in around {
                let rest_q = h.rest_position(nodes[q as usize]);
                let residual = (positions[q as usize] - x_p) - r * (rest_q - rest_p);
                worst = worst.max(across_ray(ray, residual).length_squared());
            }
            let worst = worst.sqrt();
            let radius = node_radius[node.index()];
            // Bending the node cannot show, plus the relative motion that adds to it before the
            // cut can respond, both scaled from the neighbourhood to the node's radius; plus
            // the stretch across the node (strain × radius), which a coarse node spreads evenly.
            let drift = across_ray(ray, v_rel).length() * latency;
            let stretch = if rim.get(node.index()) == Some(&true) {
                1.0 + rim_weight
            } else {
                1.0
            };
            let world = (worst + drift) * (radius / spacing).powi(2) + stretch * strain * radius;
            let ppu = view.pixels_per_unit(x_p);
            let px = world
                * if view.sphere_in_view(x_p, radius) {
                    ppu
                } else if seen_ppu > 0.0 {
                    ppu.min(seen_ppu)
                } else {
                    ppu * outside_weight
                };
            let px = if px.is_finite() { px } else { 0.0 };
            let held = self.last(h, node, previous, node_radius) * decay;
            self.particle_px.push(px.max(held));
        }
    }

    /// Closes a measurement every particle of which was measured: the estimates become the
    /// ones the next measurement holds and inherits from.
    pub(super) fn end(&mut self, frame: &Frame<'_>, progress: Progress) {
        self.evaluation = progress.current;
        for (p, &node) in frame.nodes.iter().enumerate() {
            self.remembered[node.index()] = self.particle_px[p];
            self.stamps[node.index()] = self.evaluation;
        }
    }

    /// `node`'s estimate at the last measurement that ended: its own, else (a node whose level
    /// changed since) its parent's or its children's largest, scaled to its radius.
    pub(super) fn estimate(
        &self,
        h: &treecut::Hierarchy,
        node: treecut::NodeId,
        radius: &[f32],
    ) -> f32 {
        self.last(h, node, self.evaluation, radius)
    }

    /// `node`'s estimate at evaluation `previous`: its own, else its parent's or its children's
    /// largest, scaled to its radius; 0 if none was made.
    fn last(
        &self,
        h: &treecut::Hierarchy,
        node: treecut::NodeId,
        previous: u32,
        radius: &[f32],
    ) -> f32 {
        let live = |n: treecut::NodeId| {
            (self.stamps[n.index()] == previous).then(|| self.remembered[n.index()])
        };
        let scaled = |from: treecut::NodeId, px: f32| {
            let r = radius[from.index()];
            if r > 0.0 {
                px * (radius[node.index()] / r).powi(2)
            } else {
                0.0
            }
        };
        if let Some(px) = live(node) {
            return px;
        }
        if let Some(parent) = h.parent(node)
            && let Some(px) = live(parent)
        {
            return scaled(parent, px);
        }
        h.children(node)
            .filter_map(|c| live(c).map(|px| scaled(c, px)))
            .fold(0.0, f32::max)
    }
}
