//! The XPBD distance-link kernel: one sweep over a colour batch of links.
//!
//! Based on: M. Macklin, M. Müller, N. Chentanez, "XPBD: Position-Based Simulation of
//! Compliant Constrained Dynamics", Motion in Games 2016, section 3 (the compliant
//! constraint update with its Lagrange multiplier); substeps as in Macklin et al., "Small Steps
//! in Physics Simulation", SCA 2019.
//!
//! Per link (`w` = blend weight, `α̃ = α/h²`, `W = w_a + w_b` inverse masses):
//!
//! ```text
//! d = x_b - x_a,  len = |d|,  C = len - rest
//! Δλ = (-w·C - α̃·λ) / (w·W + α̃)      (XPBD with stiffness scaled by w: α̃/w, multiplied through by w)
//! λ += Δλ,  x_a -= w_a·Δλ·d/len,  x_b += w_b·Δλ·d/len
//! ```
//!
//! computed with a single division, `s = Δλ/len = (-w·C - α̃·λ) / ((w·W + α̃)·len)`, as
//! the divider is the slowest unit on this loop's dependency chain.
//!
//! A weight of 0 gives `Δλ = -α̃·λ/α̃ = -λ = 0` (λ starts each substep at 0): no effect,
//! without a branch. The denominator and the length have small floors so that links
//! between two pinned particles, or of zero length, stay finite instead of dividing by 0.
//!
//! Links are stored in blocks of four (array of structures of arrays, [`Block`]): one block
//! holds everything the lane code needs for four links in 112 contiguous bytes, and
//! removing a link touches two blocks instead of seven columns. Within a colour batch no
//! two links share a particle, so the links are independent: the result does not depend on
//! their order, and four of them are computed at once in SSE lanes (gather, transpose,
//! lane-wise sqrt/div, scatter). The lane code and the scalar code for a batch's last
//! partial block perform the same IEEE operations in the same order, so a link gives
//! bit-identical results wherever it sits in the batch — which is what makes swap-removal
//! of other links harmless.

use glam::{Mat4, Vec4};

/// Floor for the constraint denominator `w·W + α̃` (two pinned ends with zero compliance).
pub(crate) const DENOM_FLOOR: f32 = 1e-12;
/// Floor for a link's current length (coincident ends).
pub(crate) const LENGTH_FLOOR: f32 = 1e-12;

/// Four links, one per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(16))]
pub(crate) struct Block {
    pub(crate) a: [u32; 4],
    pub(crate) b: [u32; 4],
    pub(crate) rest: [f32; 4],
    pub(crate) compliance: [f32; 4],
    pub(crate) weight: [f32; 4],
    pub(crate) lambda: [f32; 4],
    /// Stable id of each lane's link (`u32`, see [`crate::LinkId`]).
    pub(crate) id: [u32; 4],
}

impl Block {
    /// Copies lane `from` of `src` into lane `to` of `self`.
    #[inline]
    pub(crate) fn copy_lane(&mut self, to: usize, src: &Block, from: usize) {
        self.a[to] = src.a[from];
        self.b[to] = src.b[from];
        self.rest[to] = src.rest[from];
        self.compliance[to] = src.compliance[from];
        self.weight[to] = src.weight[from];
        self.lambda[to] = src.lambda[from];
        self.id[to] = src.id[from];
    }
}

/// Solves lane `k` of a block alone; the reference arithmetic that the lane code reproduces.
#[inline(always)]
pub(crate) fn solve_lane(p: &mut [Vec4], blk: &mut Block, k: usize, inv_h2: f32) {
    let (ia, ib) = (blk.a[k] as usize, blk.b[k] as usize);
    let pa = p[ia];
    let pb = p[ib];
    let d = pb - pa;
    let len = (d.x * d.x + d.y * d.y + d.z * d.z).sqrt().max(LENGTH_FLOOR);
    let (wa, wb) = (pa.w, pb.w);
    let (weight, lambda) = (blk.weight[k], blk.lambda[k]);
    let at = blk.compliance[k] * inv_h2;
    let c = len - blk.rest[k];
    let den = (weight * (wa + wb) + at).max(DENOM_FLOOR);
    // One division: s = Δλ/len, and Δλ = s·len.
    let s = (-(weight * c) - at * lambda) / (den * len);
    blk.lambda[k] = lambda + s * len;
    // Fourth lane 0: the correction must not touch the inverse mass.
    let dd = d.truncate().extend(0.0);
    p[ia] = pa - dd * (wa * s);
    p[ib] = pb + dd * (wb * s);
}

/// Lane-wise square root (SSE `sqrtps` once LLVM merges the lanes; IEEE-exact either way).
#[inline(always)]
fn sqrt4(v: Vec4) -> Vec4 {
    Vec4::new(v.x.sqrt(), v.y.sqrt(), v.z.sqrt(), v.w.sqrt())
}

/// The four-lane body: gathers a full block's particles, computes lane-wise, scatters.
#[inline(always)]
fn solve_block(p: &mut [Vec4], blk: &mut Block, inv_h2: f32) {
    let ia = blk.a.map(|i| i as usize);
    let ib = blk.b.map(|i| i as usize);
    let pa = [p[ia[0]], p[ia[1]], p[ia[2]], p[ia[3]]];
    let pb = [p[ib[0]], p[ib[1]], p[ib[2]], p[ib[3]]];
    let d = [pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2], pb[3] - pa[3]];
    // Columns are links; after the transpose the rows are dx, dy, dz of four links.
    let t = Mat4::from_cols(d[0], d[1], d[2], d[3]).transpose();
    let (dx, dy, dz) = (t.x_axis, t.y_axis, t.z_axis);
    let wa = Vec4::new(pa[0].w, pa[1].w, pa[2].w, pa[3].w);
    let wb = Vec4::new(pb[0].w, pb[1].w, pb[2].w, pb[3].w);
    let len = sqrt4(dx * dx + dy * dy + dz * dz).max(Vec4::splat(LENGTH_FLOOR));
    let at = Vec4::from_array(blk.compliance) * inv_h2;
    let wk = Vec4::from_array(blk.weight);
    let lk = Vec4::from_array(blk.lambda);
    let cc = len - Vec4::from_array(blk.rest);
    let den = (wk * (wa + wb) + at).max(Vec4::splat(DENOM_FLOOR));
    let s = (-(wk * cc) - at * lk) / (den * len);
    blk.lambda = (lk + s * len).to_array();
    let sa = (wa * s).to_array();
    let sb = (wb * s).to_array();
    for k in 0..4 {
        let dd = d[k].truncate().extend(0.0);
        p[ia[k]] = pa[k] - dd * sa[k];
        p[ib[k]] = pb[k] + dd * sb[k];
    }
}

/// One sweep over a batch of `len` links (in `blocks`) that share no particle.
pub(crate) fn solve_batch(p: &mut [Vec4], blocks: &mut [Block], len: usize, inv_h2: f32) {
    let full = len / 4;
    for blk in &mut blocks[..full] {
        solve_block(p, blk, inv_h2);
    }
    if let Some(last) = blocks.get_mut(full) {
        for k in 0..len % 4 {
            solve_lane(p, last, k, inv_h2);
        }
    }
}

/// One sweep over links that may share particles: strictly in order, one lane at a time.
pub(crate) fn solve_ordered(p: &mut [Vec4], blocks: &mut [Block], len: usize, inv_h2: f32) {
    for i in 0..len {
        solve_lane(p, &mut blocks[i / 4], i % 4, inv_h2);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lane path and the scalar path give the same bits for the same link.
    #[test]
    fn lanes_match_scalar_bitwise() {
        let mut p: Vec<Vec4> = (0..16)
            .map(|i| {
                let f = i as f32;
                Vec4::new(
                    f * 0.37 + (f * 1.3).sin(),
                    (f * 0.7).cos(),
                    f * 0.05,
                    1.0 / (1.0 + f),
                )
            })
            .collect();
        p[3].w = 0.0;
        let original = p.clone();
        let blk = Block {
            a: [0, 2, 4, 6],
            b: [1, 3, 5, 7],
            rest: [0.3, 0.5, 0.1, 0.9],
            compliance: [0.0, 1e-4, 1e-3, 0.0],
            weight: [1.0, 0.5, 0.0, 0.25],
            lambda: [0.01, -0.02, 0.0, 0.3],
            id: [0, 1, 2, 3],
        };
        let (mut lanes, mut scalar) = (blk, blk);
        let mut pv = p.clone();
        solve_batch(&mut pv, std::slice::from_mut(&mut lanes), 4, 3600.0);
        for k in 0..4 {
            solve_lane(&mut p, &mut scalar, k, 3600.0);
        }
        for (x, y) in pv.iter().zip(&p) {
            assert_eq!(
                x.to_array().map(f32::to_bits),
                y.to_array().map(f32::to_bits)
            );
        }
        assert_eq!(
            lanes.lambda.map(f32::to_bits),
            scalar.lambda.map(f32::to_bits)
        );
        // The weight-0 link (lane 2: particles 4, 5) did not move its particles; the others did.
        assert_eq!(pv[4], original[4]);
        assert_eq!(pv[5], original[5]);
        assert_ne!(pv[0], original[0]);
        // The pinned particle 3 did not move, and no inverse mass changed.
        assert_eq!(pv[3], original[3]);
        assert!(pv.iter().zip(&original).all(|(x, y)| x.w == y.w));
    }
}
