//! Shared look of the figures: colours, text sizes, number formatting, the extent of the
//! points drawn.

use plotters::element::ComposedElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::canvas::FONT;

/// Colour of the "before" series (nominal model).
pub const BEFORE: RGBColor = RGBColor(213, 94, 0);

/// Colours of the "after" series, one per strategy or model, in order (colour-blind safe).
pub const AFTER: [RGBColor; 4] = [
    RGBColor(0, 114, 178),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
];

/// The colour of series `index` when series 0 is "before" and the others come after.
pub fn series_colour(index: usize) -> RGBColor {
    match index {
        0 => BEFORE,
        i => AFTER[(i - 1) % AFTER.len()],
    }
}

/// A circle of a [`marker`], in pixels about its centre.
type Ring = Circle<(i32, i32), i32>;

/// A pose's marker at `at`: a disc of `colour` ringed in black.
pub fn marker<C, DB: DrawingBackend>(
    at: C,
    colour: RGBColor,
) -> ComposedElement<C, DB, Ring, Ring> {
    EmptyElement::at(at)
        + Circle::new((0, 0), 4, colour.filled())
        + Circle::new((0, 0), 4, BLACK.stroke_width(1))
}

/// Text of a figure's title.
pub fn title() -> TextStyle<'static> {
    (FONT, 20).into()
}

/// Pixels a figure needs across for its `title` in [`title`] text (DejaVu Sans averages
/// about 0.55 em a character), with room on both sides.
pub fn title_width(title: &str) -> u32 {
    11 * title.chars().count() as u32 + 60
}

/// Text of a panel caption.
pub fn caption() -> TextStyle<'static> {
    (FONT, 16).into()
}

/// Text of axis descriptions.
pub fn axis_description() -> TextStyle<'static> {
    (FONT, 15).into()
}

/// Size of [`label`] text (plotters' size: the SVG's font size is this over 1.24).
pub const LABEL_SIZE: f64 = 13.0;

/// Text of tick labels and legends.
pub fn label() -> TextStyle<'static> {
    (FONT, LABEL_SIZE).into()
}

/// A legend entry's `text` in text of `size` (plotters' size; [`LABEL_SIZE`] for [`label`]
/// text), starting at `x` and centred vertically on `centre`, the middle of the swatch or
/// marker drawn beside it.
pub fn legend_text(
    text: String,
    (x, centre): (i32, i32),
    size: f64,
) -> Text<'static, (i32, i32), String> {
    let style = TextStyle::from((FONT, size)).pos(Pos::new(HPos::Left, VPos::Center));
    Text::new(text, (x, centre), style)
}

/// A number with about three significant digits, without exponent for moderate values
/// (`12.3`, `0.417`, `0`, `-1.5e-5`), for tick labels.
pub fn short_number(value: f64) -> String {
    if value == 0.0 || !value.is_finite() {
        return "0".into();
    }
    let magnitude = value.abs().log10().floor() as i32;
    if !(-3..=4).contains(&magnitude) {
        return format!("{value:.1e}");
    }
    let decimals = (2 - magnitude).max(0) as usize;
    let text = format!("{value:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

/// A tick label on a linear axis spanning `span`: [`short_number`], with the round-off of the
/// tick positions (`-1.1e-16` for zero) snapped to zero.
pub fn tick(value: f64, span: f64) -> String {
    if value.abs() < 1e-9 * span.abs() {
        "0".into()
    } else {
        short_number(value)
    }
}

/// A tick label on a logarithmic axis over `[lo, hi]`: [`short_number`] when every tick of the
/// range reads without an exponent (0.001 … 10 000), else every tick with one (`1e-5`, `2e-4`,
/// `1e-3`), so that one axis never mixes `1.0e-5` and `0.001`.
pub fn log_tick(value: f64, lo: f64, hi: f64) -> String {
    if lo >= 1e-3 && hi < 1e5 {
        return short_number(value);
    }
    let text = format!("{value:.2e}");
    let (mantissa, exponent) = text.split_once('e').unwrap_or((&text, "0"));
    let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
    format!("{mantissa}e{exponent}")
}

/// The label count to ask plotters for on a linear axis over `[lo, hi]`: `wanted`, raised until
/// at least three round values fall inside the range (plotters rounds the step to 1, 2 or 5 times
/// a power of ten, and may keep a single tick: -4.8 … 5.0 with 4 asked for gives only `0`).
pub fn label_count(lo: f64, hi: f64, wanted: usize) -> usize {
    use plotters::coord::ranged1d::Ranged;
    use plotters::coord::types::RangedCoordf64;
    let axis = RangedCoordf64::from(lo..hi);
    (wanted..wanted + 12)
        .find(|&n| axis.key_points(n).len() >= 3)
        .unwrap_or(wanted)
}

/// The smallest box `(lo, hi)` holding `points` (x, y); infinite and inverted when there is
/// none.
pub fn bounding_box(points: impl IntoIterator<Item = [f64; 2]>) -> ([f64; 2], [f64; 2]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// The label areas and margin of an x–y map panel: `(margin, x labels, y labels)` pixels.
pub const MAP_FRAME: (u32, u32, u32) = (12, 44, 72);

/// The chart [`xy_map`] returns: the plane in metres on `DB`.
pub type XyMap<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A chart of the plane `x`, `y` (m) over `lo..hi` on `area`, titled, without a mesh: the
/// frame of the maps (the accuracy map's panels, the row residuals'), sized by [`MAP_FRAME`].
///
/// # Errors
/// The backend fails to draw.
pub fn xy_map<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, plotters::coord::Shift>,
    title: String,
    (lo, hi): ([f64; 2], [f64; 2]),
) -> Result<XyMap<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let (margin, x_labels, y_labels) = MAP_FRAME;
    let mut chart = ChartBuilder::on(area)
        .caption(title, caption())
        .margin(margin)
        .x_label_area_size(x_labels)
        .y_label_area_size(y_labels)
        .build_cartesian_2d(lo[0]..hi[0], lo[1]..hi[1])?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x (m)")
        .y_desc("y (m)")
        .x_label_formatter(&|v| tick(*v, hi[0] - lo[0]))
        .y_label_formatter(&|v| tick(*v, hi[1] - lo[1]))
        .label_style(label())
        .axis_desc_style(axis_description())
        .draw()?;
    Ok(chart)
}

#[cfg(test)]
mod tests {
    use super::{label_count, log_tick, short_number, tick};

    #[test]
    fn round_off_ticks_read_zero() {
        assert_eq!(tick(-1.1e-16, 1.2), "0");
        assert_eq!(tick(0.2, 1.2), "0.2");
        assert_eq!(tick(1e-7, 1e-6), "1.0e-7");
    }

    #[test]
    fn a_log_axis_writes_every_tick_alike() {
        let ticks = |lo, hi| -> Vec<String> {
            [1e-5, 1e-4, 1e-3, 0.01, 0.1, 2.5]
                .into_iter()
                .map(|v| log_tick(v, lo, hi))
                .collect()
        };
        assert_eq!(
            ticks(5e-6, 0.6),
            ["1e-5", "1e-4", "1e-3", "1e-2", "1e-1", "2.5e0"]
        );
        assert_eq!(ticks(2e-3, 3.0)[2..], ["0.001", "0.01", "0.1", "2.5"]);
    }

    #[test]
    fn a_linear_axis_gets_at_least_three_labels() {
        use plotters::coord::ranged1d::Ranged;
        use plotters::coord::types::RangedCoordf64;
        // The 200-trial gamma2 panel of the 5R: plotters keeps only `0` with 4 labels asked.
        let (lo, hi) = (-4.841, 4.992);
        assert_eq!(RangedCoordf64::from(lo..hi).key_points(4).len(), 1);
        let n = label_count(lo, hi, 4);
        assert!(RangedCoordf64::from(lo..hi).key_points(n).len() >= 3, "{n}");
        assert_eq!(label_count(0.0, 1.0, 4), 4);
    }

    #[test]
    fn short_numbers_keep_three_significant_digits() {
        assert_eq!(short_number(12.345), "12.3");
        assert_eq!(short_number(0.41666), "0.417");
        assert_eq!(short_number(-2.0), "-2");
        assert_eq!(short_number(0.0), "0");
        assert_eq!(short_number(1500.0), "1500");
        assert_eq!(short_number(1.5e-5), "1.5e-5");
    }
}
