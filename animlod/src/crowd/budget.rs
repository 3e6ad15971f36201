//! The crowd budget ([`LodMode::Budget`]): a histogram over log-spaced score bins finds, in one
//! pass, which bones take the frame's interpolations.

use super::frame::step_row;
use super::*;

/// Histogram bins of the budget's scores: bin 0 holds zero scores (never updated), bins
/// 1..=256 cover 2^-32 to 2^32 in quarter octaves.
const SCORE_BINS: usize = 257;

/// The histogram bin of a score, monotone in the score. Branch-free (a select for scores that
/// are zero, negative or NaN), so that the budget's per-bone pass vectorises.
#[inline(always)]
fn score_bin(score: f32) -> u16 {
    let bits = score.to_bits();
    let exponent = ((bits >> 23) & 0xFF) as i32 - 127;
    let quarter = ((bits >> 21) & 3) as i32;
    let bin = 1 + (exponent + 32).clamp(0, 63) * 4 + quarter;
    // `score > 0.0` is false for NaN.
    if score > 0.0 { bin as u16 } else { 0 }
}

impl Crowd {
    /// The budget's cut: every bone whose score falls in a histogram bin above the returned bin
    /// interpolates, and up to the returned count of those in the bin itself. Score = projected
    /// radius × priority integrated over the time held (priority read as a drift rate), a proxy
    /// for the on-screen error the hold has built up; spending the budget on the highest scores
    /// each frame greedily minimises the total on-screen error. With
    /// [`PrioritySource::HoldError`] the priority is the measured drift rate, so the score is
    /// the predicted pixel error itself (up to a constant). A histogram over log-spaced bins (4 per octave) finds the cut in one pass
    /// instead of a selection over every bone of the crowd.
    pub(super) fn budget_cut(&mut self, budget: u32) -> (usize, u32) {
        let n = self.stride;
        let floor = self.params.min_priority;
        // Four interleaved histograms: consecutive bones often share a bin, and one counter
        // incremented back to back would serialise on memory.
        let mut hist = [[0u32; SCORE_BINS]; 4];
        let buf = &mut self.scratch.row;
        self.scratch.bins.resize(self.chars.len() * n, 0);
        self.scratch.top_bin.resize(self.chars.len(), 0);
        for (d, c) in self.chars.iter().enumerate() {
            let clip = &self.rig.clips()[c.clip.index()];
            let slots = clip.animated.len();
            let bins = &mut self.scratch.bins[d * n..d * n + slots];
            if c.pose_shared {
                // Shows a shared pose: scores zero, never admitted.
                bins.fill(0);
                self.scratch.top_bin[d] = 0;
                continue;
            }
            let row = step_row(
                &self.tables[c.clip.index()],
                slots,
                self.rig.priorities[c.clip.index()].segment_count(),
                c,
                buf,
            );
            let drift = &mut self.drift[d * n..d * n + slots];
            // Two passes: the drifts and bins (vectorised), then the histogram (a scatter).
            let (step, size) = (c.step, c.size_px);
            for ((e, &p), bin) in drift.iter_mut().zip(row).zip(bins.iter_mut()) {
                *e += step * p.max(floor);
                *bin = score_bin(*e * size);
            }
            self.scratch.top_bin[d] = bins.iter().copied().max().unwrap_or(0);
            let [h0, h1, h2, h3] = &mut hist;
            let mut quads = bins.chunks_exact(4);
            for q in &mut quads {
                h0[q[0] as usize] += 1;
                h1[q[1] as usize] += 1;
                h2[q[2] as usize] += 1;
                h3[q[3] as usize] += 1;
            }
            for &b in quads.remainder() {
                h0[b as usize] += 1;
            }
        }
        let mut admitted = 0u32;
        for bin in (1..SCORE_BINS).rev() {
            let count = hist[0][bin] + hist[1][bin] + hist[2][bin] + hist[3][bin];
            if admitted + count >= budget {
                return (bin, budget - admitted);
            }
            admitted += count;
        }
        // Everything with a positive score fits.
        (1, u32::MAX)
    }
}
