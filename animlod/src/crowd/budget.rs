//! The crowd budget ([`LodMode::Budget`]): a histogram over log-spaced score bins finds, in one
//! pass, which bones take the frame's interpolations.

use super::frame::step_row;
use super::*;

/// Histogram bins of the budget's scores: bin 0 holds zero scores (never updated), bins
/// 1..=256 cover 2^-32 to 2^32 in quarter octaves.
const SCORE_BINS: usize = 257;

/// The histogram bin of a score, monotone in the score.
#[inline]
fn score_bin(score: f32) -> usize {
    if score.is_nan() || score <= 0.0 {
        return 0;
    }
    let bits = score.to_bits();
    let exponent = ((bits >> 23) & 0xFF) as i32 - 127;
    let quarter = ((bits >> 21) & 3) as usize;
    1 + (exponent + 32).clamp(0, 63) as usize * 4 + quarter
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
        for (d, c) in self.chars.iter().enumerate() {
            let clip = &self.rig.clips()[c.clip.index()];
            let slots = clip.animated.len();
            let row = step_row(
                &self.tables[c.clip.index()],
                slots,
                self.rig.priorities[c.clip.index()].segment_count(),
                c,
                buf,
            );
            let drift = &mut self.drift[d * n..d * n + slots];
            let bins = &mut self.scratch.bins[d * n..d * n + slots];
            for (i, ((e, &p), bin)) in drift.iter_mut().zip(row).zip(bins.iter_mut()).enumerate() {
                *e += c.step * p.max(floor);
                let b = score_bin(*e * c.size_px);
                *bin = b as u16;
                hist[i & 3][b] += 1;
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
