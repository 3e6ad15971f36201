//! A frame's wall time as a fixed part plus a part per cost unit, fitted over recent frames:
//! what a millisecond budget needs to know how many more units fit in the time a frame has
//! left.
//!
//! A frame pays costs that do not grow with the work (waking and joining the workers, the
//! phases' bookkeeping, the crowd's per-frame setup), so the plain ratio `ms / units` of a light
//! frame overstates what one more unit costs: on the demo's world it read 2.1e-6 ms per unit
//! while the cut was coarse and 0.7e-6 once the frames held the 4 ms target, and a transition
//! allowance converted at the ratio held the cold start back (the target read as 1.9e6 units
//! at frame 5, 5.7e6 by frame 100). The marginal cost (the slope of a least-squares line
//! through recent frames, forgetting old ones) is the right conversion for "time left → units".
//!
//! Based on: recursive least squares with exponential forgetting (Ljung, "System
//! Identification: Theory for the User", 2nd ed. 1999, section 11.2), here for two parameters
//! in closed form.

/// Exponentially weighted sums of recent frames' units and milliseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct TimeFit {
    n: f64,
    su: f64,
    sm: f64,
    suu: f64,
    sum: f64,
}

/// Weight kept per frame: about the last 20 frames count.
const FORGET: f64 = 0.95;
/// The fit is trusted only when the frames' units spread by at least this fraction of their
/// mean (standard deviation over mean); steady frames say nothing about the slope.
const MIN_SPREAD: f64 = 0.05;

impl TimeFit {
    /// Adds a frame of `units` cost units that took `ms` (non-finite or non-positive values are
    /// ignored).
    pub(crate) fn add(&mut self, units: f64, ms: f64) {
        if !(units.is_finite() && ms.is_finite() && units > 0.0 && ms > 0.0) {
            return;
        }
        self.n = self.n * FORGET + 1.0;
        self.su = self.su * FORGET + units;
        self.sm = self.sm * FORGET + ms;
        self.suu = self.suu * FORGET + units * units;
        self.sum = self.sum * FORGET + units * ms;
    }

    /// Milliseconds one more unit costs: the fitted slope, kept between a quarter of and the
    /// plain ratio of the recent frames (a slope above the ratio would mean a negative fixed
    /// cost, one far below it a fit of noise); the ratio itself while the frames' units have not
    /// spread enough to fit a slope; `None` before any frame.
    pub(crate) fn marginal_ms_per_unit(&self) -> Option<f64> {
        if self.n <= 0.0 || self.su <= 0.0 {
            return None;
        }
        let (mu, mm) = (self.su / self.n, self.sm / self.n);
        let ratio = mm / mu;
        let var = (self.suu / self.n - mu * mu).max(0.0);
        if var.sqrt() < MIN_SPREAD * mu {
            return Some(ratio);
        }
        let slope = (self.sum / self.n - mu * mm) / var;
        Some(slope.clamp(0.25 * ratio, ratio))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frames that cost 0.8 ms plus 0.5e-6 ms per unit, over a ramp of units: the slope is
    /// found (not the ratio, which the fixed part inflates); steady frames give the ratio.
    #[test]
    fn finds_the_marginal_cost_under_a_fixed_one() {
        let mut fit = TimeFit::default();
        assert_eq!(fit.marginal_ms_per_unit(), None);
        for f in 0..60 {
            let units = 1.0e6 + 7.0e4 * f as f64;
            fit.add(units, 0.8 + 0.5e-6 * units);
        }
        let b = fit.marginal_ms_per_unit().unwrap();
        assert!((b - 0.5e-6).abs() < 1e-9, "{b}");
        let mut steady = TimeFit::default();
        for _ in 0..60 {
            steady.add(4.0e6, 0.8 + 0.5e-6 * 4.0e6);
        }
        let r = steady.marginal_ms_per_unit().unwrap();
        assert!((r - 2.8 / 4.0e6).abs() < 1e-12, "{r}");
        // Bad samples change nothing.
        let before = steady;
        steady.add(f64::NAN, 1.0);
        steady.add(1.0, -1.0);
        assert_eq!(steady, before);
    }
}
