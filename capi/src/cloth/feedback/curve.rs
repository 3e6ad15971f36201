//! [`BoundCurve`]: how many nodes a cloth under an error bound would head to at *other* bounds,
//! read off the estimates of its last measurement, so that a world budget can choose the bound
//! that meets its target instead of feeling its way there.
//!
//! Based on the error-bound rule of `Feedback::error_priorities` (this project's; the
//! simulation-LOD paper, `simulation-lod-treecut-softbody-bswdf.txt`, section 5, budgets nodes
//! or time, not error): a node on the cut whose estimate `e` exceeds the refine fraction `r` of
//! the bound is refined, and its children are expected to be refined again as long as the
//! estimate halved per level stays above it; a parent whose estimate stays under the merge
//! fraction `m` of the bound is merged. Both are thresholds in the bound, so the projected node
//! count is a step function of the bound: a refine candidate adds `min(4^(k+1), leaves) −
//! min(4^k, leaves)` nodes for every bound under `e · 2^−k / r` (k = 0 … its level − 1), a merge
//! candidate removes `children − 1` nodes for every bound over `e / m`. Between the two lies
//! the merge hysteresis, where moving the bound changes nothing: a controller that only sees
//! how cost answered its last move cannot tell how far away the next merge is (the world's
//! controller crept through that zone for 100 frames at 48 substeps); this curve says.

/// Resolution of the curve: bins per factor two of the bound (1/16 of an octave: 4.4%).
const BINS_PER_OCTAVE: f32 = 16.0;
/// The curve covers bounds from 2^`LOWEST_OCTAVE` px (thresholds below count as there)...
const LOWEST_OCTAVE: f32 = -16.0;
/// ... to 2^`HIGHEST_OCTAVE` px.
const HIGHEST_OCTAVE: f32 = 16.0;
/// Bins between the two.
const BINS: usize = ((HIGHEST_OCTAVE - LOWEST_OCTAVE) * BINS_PER_OCTAVE) as usize;

/// The node count a cloth's error-bound loop projects as a function of its bound (see the
/// module docs), from one measurement. The thresholds are binned on a log scale (1/16 of an
/// octave) rather than sorted: a 129² cloth has ~65,000 of them, and sorting them took 2.3 ms
/// here (an evaluation of that cloth takes ~4 ms) against 0.2 ms to bin them; between bin
/// edges the count is interpolated.
///
/// Built with [`BoundCurve::start`], then [`BoundCurve::add_refine`] and
/// [`BoundCurve::add_merge`] per candidate, then [`BoundCurve::finish`] once; read with
/// [`BoundCurve::nodes_at`]. A cloth under a world's shared bound builds its own at every
/// evaluation (the world's controller reads it).
#[derive(Clone, Debug, PartialEq)]
pub struct BoundCurve {
    /// Nodes on the cut at the measurement.
    cut: usize,
    /// Per bin: nodes refine events of thresholds in the bin add. After `finish`, per bin
    /// edge: the nodes added at that bound (events of thresholds above it).
    refine: Vec<f64>,
    /// Per bin: nodes merge events of thresholds in the bin remove. After `finish`, per bin
    /// edge: the nodes removed at that bound (events of thresholds below it).
    merge: Vec<f64>,
}

impl Default for BoundCurve {
    fn default() -> Self {
        BoundCurve {
            cut: 0,
            refine: vec![0.0; BINS + 1],
            merge: vec![0.0; BINS + 1],
        }
    }
}

/// The position of `px` on the bins' scale (bin edge `k` is at `k`), clamped to the range.
/// The scale is an f32's bits read as a number: its exponent and the top of its mantissa, so
/// log2 linearised within each octave (monotone; at most 0.09 octave from the true logarithm),
/// which costs a shift instead of a logarithm per event.
fn position(px: f32) -> f32 {
    // 2^23 mantissa steps per octave, BINS_PER_OCTAVE bins.
    let per_bin = (1u32 << 23) as f32 / BINS_PER_OCTAVE;
    let lowest = (127.0 + LOWEST_OCTAVE) * BINS_PER_OCTAVE;
    let p = px.max(f32::MIN_POSITIVE).to_bits() as f32 / per_bin - lowest;
    p.clamp(0.0, BINS as f32)
}

impl BoundCurve {
    /// Empties the curve for a cut of `cut` nodes (the projection is `cut` at every bound until
    /// events are added).
    pub fn start(&mut self, cut: usize) {
        self.cut = cut;
        self.refine.iter_mut().for_each(|v| *v = 0.0);
        self.merge.iter_mut().for_each(|v| *v = 0.0);
    }

    /// The bin of a threshold of `px`.
    fn bin(px: f32) -> usize {
        (position(px) as usize).min(BINS - 1)
    }

    /// A refine candidate: a node of estimate `px`, `level` levels above the leaves, covering
    /// `leaves` finest vertices, refined while its estimate halved per level exceeds
    /// `refine_fraction` of the bound.
    pub fn add_refine(&mut self, px: f32, level: u32, leaves: u64, refine_fraction: f32) {
        let (mut e, mut covered) = (px / refine_fraction, 1u64);
        for _ in 0..level {
            let next = covered.saturating_mul(4).min(leaves);
            if next > covered {
                self.refine[Self::bin(e)] += (next - covered) as f64;
            }
            covered = next;
            e *= 0.5;
        }
    }

    /// A merge candidate: a parent of estimate `px` with `children` children, merged while its
    /// estimate stays under `merge_fraction` of the bound.
    pub fn add_merge(&mut self, px: f32, children: u64, merge_fraction: f32) {
        if children > 1 {
            self.merge[Self::bin(px / merge_fraction)] += (children - 1) as f64;
        }
    }

    /// Sums the bins into counts per bin edge (call once after adding the events, before
    /// [`BoundCurve::nodes_at`]).
    pub fn finish(&mut self) {
        // Edge k: refine events in bins k and above, merge events in bins below k.
        let mut sum = 0.0;
        for v in self.refine.iter_mut().rev() {
            sum += *v;
            *v = sum;
        }
        sum = 0.0;
        for v in self.merge.iter_mut() {
            let here = *v;
            *v = sum;
            sum += here;
        }
    }

    /// Nodes on the cut at the measurement.
    pub fn cut(&self) -> usize {
        self.cut
    }

    /// The node count the loop heads to under a bound of `px` (≥ 1), interpolated between
    /// the bin edges around it.
    pub fn nodes_at(&self, px: f32) -> f64 {
        let p = position(px);
        let k = (p as usize).min(BINS - 1);
        let t = (p - k as f32) as f64;
        let at = |k: usize| self.cut as f64 + self.refine[k] - self.merge[k];
        (at(k) * (1.0 - t) + at(k + 1) * t).max(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_at_the_thresholds_and_is_monotone() {
        let mut c = BoundCurve::default();
        c.start(100);
        // A level-2 node of estimate 2 px over 16 leaves, refine fraction 0.5: +3 under 4 px,
        // +12 more under 2 px.
        c.add_refine(2.0, 2, 16, 0.5);
        // A parent of 0.5 px with 4 children, merge fraction 0.125: −3 over 4 px.
        c.add_merge(0.5, 4, 0.125);
        c.finish();
        assert_eq!(c.nodes_at(1.0), 115.0);
        assert_eq!(c.nodes_at(3.0), 103.0);
        assert_eq!(c.nodes_at(3.9), 103.0);
        assert_eq!(c.nodes_at(4.5), 97.0);
        let mut last = f64::INFINITY;
        for i in 1..200 {
            let n = c.nodes_at(i as f32 * 0.05);
            assert!(n <= last, "not monotone at {}", i as f32 * 0.05);
            last = n;
        }
    }

    #[test]
    fn a_refine_never_projects_past_the_leaves() {
        let mut c = BoundCurve::default();
        c.start(10);
        // Level 3 but only 6 leaves: +3, then +2, then nothing.
        c.add_refine(100.0, 3, 6, 0.5);
        c.finish();
        assert_eq!(c.nodes_at(1e-3), 15.0);
        assert_eq!(c.nodes_at(1e6), 10.0);
    }
}
