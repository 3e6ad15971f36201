//! Captions on finished pictures, drawn with plotters' text (ab_glyph and the bundled font)
//! straight into the picture's RGB bytes.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{FADING, GROUP, Image};
use crate::font;

/// One line of a panel's caption.
#[derive(Clone, Debug)]
pub(crate) struct Caption {
    text: String,
    size: u32,
    colour: RGBColor,
}

impl Caption {
    /// The first, larger line.
    pub(crate) fn title(text: String) -> Caption {
        Caption {
            text,
            size: 22,
            colour: RGBColor(20, 24, 40),
        }
    }

    /// A smaller grey line under it.
    pub(crate) fn sub(text: String) -> Caption {
        Caption {
            text,
            size: 17,
            colour: RGBColor(90, 95, 110),
        }
    }
}

fn rgb(c: glam::Vec3) -> RGBColor {
    let c = (c.clamp(glam::Vec3::ZERO, glam::Vec3::ONE) * 255.0).round();
    RGBColor(c.x as u8, c.y as u8, c.z as u8)
}

/// Draws the caption lines at the top left, and with `legend` the key of the link colours at
/// the bottom left.
pub(crate) fn draw_captions(
    image: &mut Image,
    lines: &[Caption],
    legend: bool,
) -> Result<(), String> {
    font::register()?;
    let (w, h) = (image.width, image.height);
    let area = BitMapBackend::with_buffer(&mut image.rgb, (w, h)).into_drawing_area();
    let mut y = 10;
    for l in lines {
        let style = TextStyle::from((font::FAMILY, l.size).into_font()).color(&l.colour);
        area.draw_text(&l.text, &style, (14, y))
            .map_err(|e| e.to_string())?;
        y += l.size as i32 + 6;
    }
    if legend {
        let style = TextStyle::from((font::FAMILY, 16).into_font()).color(&RGBColor(40, 40, 50));
        let keys = [
            (
                rgb(FADING),
                "link fading in or out (refine/coarse being blended)",
            ),
            (rgb(GROUP), "group link to a virtual parent"),
        ];
        for (k, (colour, label)) in keys.iter().enumerate() {
            let y = h as i32 - 24 - 22 * (keys.len() - 1 - k) as i32;
            area.draw(&Rectangle::new(
                [(14, y + 4), (34, y + 10)],
                colour.filled(),
            ))
            .map_err(|e| e.to_string())?;
            area.draw_text(label, &style, (42, y))
                .map_err(|e| e.to_string())?;
        }
    }
    area.present().map_err(|e| e.to_string())
}

/// Draws a centred two-line title in the top band of a composite.
pub(crate) fn draw_title(image: &mut Image, title: &str, subtitle: &str) -> Result<(), String> {
    font::register()?;
    let (w, h) = (image.width, image.height);
    let area = BitMapBackend::with_buffer(&mut image.rgb, (w, h)).into_drawing_area();
    let centre = Pos::new(HPos::Center, VPos::Top);
    let big = TextStyle::from((font::FAMILY, 22).into_font())
        .color(&RGBColor(20, 24, 40))
        .pos(centre);
    let small = TextStyle::from((font::FAMILY, 16).into_font())
        .color(&RGBColor(90, 95, 110))
        .pos(centre);
    area.draw_text(title, &big, (w as i32 / 2, 6))
        .map_err(|e| e.to_string())?;
    area.draw_text(subtitle, &small, (w as i32 / 2, 32))
        .map_err(|e| e.to_string())?;
    area.present().map_err(|e| e.to_string())
}
