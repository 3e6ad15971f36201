//! The one font of every caption and plot label, compiled into the binary so pictures look the
//! same on every machine, fonts installed or not: an ASCII (+ a few symbols) subset of DejaVu
//! Sans 2.37, renamed "Slod Demo Sans" as its licence asks of modified copies
//! (`demo/assets/FONT-LICENSE.txt`). Registered with plotters under the family `sans-serif`,
//! the family plotters' charts use by default.

use std::sync::OnceLock;

use plotters::style::FontStyle;

/// The font file.
static FONT: &[u8] = include_bytes!("../assets/SlodDemoSans.ttf");

/// The family name every caption and chart uses.
pub(crate) const FAMILY: &str = "sans-serif";

/// Registers the font once; later calls return the first result.
pub(crate) fn register() -> Result<(), String> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font(FAMILY, FontStyle::Normal, FONT)
            .map_err(|_| "the bundled font does not parse".to_string())
    })
    .clone()
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_bundled_font_registers() {
        assert_eq!(super::register(), Ok(()));
        assert_eq!(super::register(), Ok(()));
    }
}
