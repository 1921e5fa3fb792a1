//! Shared pieces of the report's figures, drawn with `plotters` (SVG backend).

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// A chart over (sim seconds or unit box, rows or unit box) on an SVG string.
pub type Chart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A colour from `0xRRGGBB`.
pub const fn hex(c: u32) -> RGBColor {
    RGBColor((c >> 16) as u8, (c >> 8) as u8, c as u8)
}

/// Text of `size` px in `colour`, anchored at its left (or `h`) and vertical centre.
pub fn text_style(size: u32, colour: &RGBColor, h: HPos) -> TextStyle<'static> {
    ("sans-serif", size)
        .into_font()
        .color(colour)
        .pos(Pos::new(h, VPos::Center))
}

/// A filled rectangle from `(x0, y0)` to `(x1, y1)`, at least a hair wide.
pub fn bar(x0: f64, x1: f64, y0: f64, y1: f64, colour: RGBColor) -> Rectangle<(f64, f64)> {
    Rectangle::new([(x0, y0), (x1.max(x0), y1)], colour.filled())
}

/// A straight line.
pub fn line(a: (f64, f64), b: (f64, f64), colour: RGBColor, width: u32) -> PathElement<(f64, f64)> {
    PathElement::new(vec![a, b], colour.stroke_width(width))
}
