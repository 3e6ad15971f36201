//! Progress bars (indicatif) for every stage longer than about a second. They draw on stderr
//! and only when it is a terminal, so piped output and the tests stay clean; each bar clears
//! itself when its stage ends, before the stage's tables are printed on stdout.

use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Whether to draw progress bars.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// Draw them on stderr when it is a terminal (what the binary does).
    Auto,
    /// Never draw them (tests, embedding).
    Hidden,
}

impl Progress {
    /// A bar of `len` units for a stage, with a short name shown in front of it.
    pub(crate) fn bar(self, len: u64, stage: &str) -> ProgressBar {
        let target = match self {
            Progress::Auto => ProgressDrawTarget::stderr(),
            Progress::Hidden => ProgressDrawTarget::hidden(),
        };
        let style = ProgressStyle::with_template(
            "{prefix:>10.bold} [{bar:32.cyan/blue}] {percent:>3}% {msg} ({elapsed}, eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
        let bar = ProgressBar::with_draw_target(Some(len), target)
            .with_style(style)
            .with_prefix(stage.to_string());
        // Keeps elapsed time and the eta moving while one long step runs.
        bar.enable_steady_tick(Duration::from_millis(200));
        bar
    }
}
