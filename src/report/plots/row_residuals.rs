//! Each measured row's residual drawn where it was taken, before and after a fit: one panel
//! per model, a disc per row coloured by its signed residual (blue below the model, red above)
//! on one symmetric scale shared by the panels, with its colour bar in micrometres. For a bed
//! probe: each touch above or below the bed the model expects, before and after calibration.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::canvas::{Drawn, Figure};
use super::style;

/// One model's residuals.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualPanel {
    /// Caption (`before (nominal model)` …); the RMS is appended when drawn.
    pub title: String,
    /// Each row: where (x, y in m) and its residual (m).
    pub rows: Vec<([f64; 2], f64)>,
}

/// The figure: panels side by side on the same axes and colour scale.
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualFigure {
    /// Figure title.
    pub title: String,
    /// What the residual is (`height residual`), for the colour bar.
    pub quantity: String,
    /// One panel per model.
    pub panels: Vec<ResidualPanel>,
}

const PANEL: u32 = 520;
const BAR: u32 = 130;
const TITLE: u32 = 44;
const FOOTER: u32 = 30;
const Y_LABELS: u32 = style::MAP_FRAME.2;
const X_LABELS: u32 = style::MAP_FRAME.1;
const MARGIN: u32 = style::MAP_FRAME.0;
const CAPTION: u32 = 30;
const DISC: i32 = 7;

impl ResidualPanel {
    /// RMS of the residuals (m).
    fn rms(&self) -> f64 {
        let n = self.rows.len().max(1) as f64;
        (self.rows.iter().map(|(_, r)| r * r).sum::<f64>() / n).sqrt()
    }
}

impl ResidualFigure {
    /// The colour scale's half-width (µm): the largest residual of any panel.
    fn top_um(&self) -> f64 {
        let top = self
            .panels
            .iter()
            .flat_map(|p| p.rows.iter().map(|(_, r)| r.abs() * 1e6))
            .filter(|r| r.is_finite())
            .fold(0.0, f64::max);
        if top > 0.0 {
            top
        } else {
            1.0
        }
    }

    /// Bounds of the rows, padded and squared to the plot's aspect.
    fn bounds(&self, plot: (f64, f64)) -> ([f64; 2], [f64; 2]) {
        let points = self
            .panels
            .iter()
            .flat_map(|p| p.rows.iter().map(|(at, _)| *at));
        let (lo, hi) = style::bounding_box(points);
        if !lo[0].is_finite() {
            return ([-1.0, -1.0], [1.0, 1.0]);
        }
        let span = [(hi[0] - lo[0]).max(1e-6), (hi[1] - lo[1]).max(1e-6)];
        let pad = 0.08 * span[0].max(span[1]);
        let (lo, hi) = (lo.map(|v| v - pad), hi.map(|v| v + pad));
        let span = [hi[0] - lo[0], hi[1] - lo[1]];
        let per_pixel = (span[0] / plot.0).max(span[1] / plot.1);
        let extra = [0, 1].map(|k| 0.5 * (per_pixel * [plot.0, plot.1][k] - span[k]));
        (
            [lo[0] - extra[0], lo[1] - extra[1]],
            [hi[0] + extra[0], hi[1] + extra[1]],
        )
    }
}

/// A diverging colour for `value` in `[-top, top]`: blue through white to red.
pub fn diverging(value: f64, top: f64) -> RGBColor {
    let t = (value / top).clamp(-1.0, 1.0);
    let mix =
        |a: u8, b: u8, w: f64| (f64::from(a) + (f64::from(b) - f64::from(a)) * w).round() as u8;
    let (white, blue, red) = ((247, 247, 247), (33, 102, 172), (178, 24, 43));
    let (end, w) = if t < 0.0 { (blue, -t) } else { (red, t) };
    RGBColor(
        mix(white.0, end.0, w),
        mix(white.1, end.1, w),
        mix(white.2, end.2, w),
    )
}

impl Figure for ResidualFigure {
    fn size(&self) -> (u32, u32) {
        let panels = self.panels.len().max(1) as u32;
        (panels * PANEL + BAR, TITLE + PANEL + FOOTER)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        root.fill(&WHITE)?;
        let (top, rest) = root.split_vertically(TITLE);
        top.titled(&self.title, style::title())?;
        let (body, footer) = rest.split_vertically(PANEL);
        let (panels_area, bar_area) =
            body.split_horizontally(PANEL * self.panels.len().max(1) as u32);
        let plot = (
            f64::from(PANEL - Y_LABELS - 2 * MARGIN),
            f64::from(PANEL - X_LABELS - CAPTION - 2 * MARGIN),
        );
        let (lo, hi) = self.bounds(plot);
        let top_um = self.top_um();
        let areas = panels_area.split_evenly((1, self.panels.len().max(1)));
        for (panel, area) in self.panels.iter().zip(areas.iter()) {
            let caption = format!(
                "{}: RMS {} µm",
                panel.title,
                style::short_number(panel.rms() * 1e6)
            );
            let mut chart = style::xy_map(area, caption, (lo, hi))?;
            chart.draw_series(panel.rows.iter().map(|(at, r)| {
                Circle::new((at[0], at[1]), DISC, diverging(r * 1e6, top_um).filled())
            }))?;
            chart.draw_series(
                panel
                    .rows
                    .iter()
                    .map(|(at, _)| Circle::new((at[0], at[1]), DISC, BLACK.stroke_width(1))),
            )?;
        }
        draw_bar(&bar_area, top_um, &self.quantity)?;
        footer.draw(&style::legend_text(
            "each disc a measured row, where the model puts it; red: measured above the model, blue: below; one colour scale for every panel".to_string(),
            (80, 15),
            style::LABEL_SIZE,
        ))?;
        Ok(())
    }
}

/// A vertical colour bar from `-top_um` to `top_um`.
fn draw_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    top_um: f64,
    quantity: &str,
) -> Drawn<DB> {
    let mut chart = ChartBuilder::on(area)
        .margin_top(MARGIN + CAPTION + 8)
        .margin_bottom(MARGIN + X_LABELS)
        .margin_right(8)
        .y_label_area_size(0)
        .right_y_label_area_size(70)
        .build_cartesian_2d(0.0..1.0, -top_um..top_um)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(7)
        .y_label_formatter(&|v| style::short_number(*v))
        .y_desc(format!("{quantity} (µm)"))
        .label_style(style::label())
        .axis_desc_style(style::axis_description())
        .draw()?;
    let steps = 128;
    chart.draw_series((0..steps).map(|k| {
        let a = -top_um + 2.0 * top_um * k as f64 / steps as f64;
        let b = -top_um + 2.0 * top_um * (k + 1) as f64 / steps as f64;
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            diverging(0.5 * (a + b), top_um).filled(),
        )
    }))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{diverging, ResidualFigure, ResidualPanel};
    use crate::report::plots::{render, Format};

    #[test]
    fn the_scale_is_white_at_zero_and_saturates_at_the_ends() {
        let top = 10.0;
        assert_eq!(
            diverging(0.0, top),
            plotters::style::RGBColor(247, 247, 247)
        );
        assert_eq!(
            diverging(-10.0, top),
            plotters::style::RGBColor(33, 102, 172)
        );
        assert_eq!(diverging(25.0, top), plotters::style::RGBColor(178, 24, 43));
        // Half-way is half-way in each channel.
        assert_eq!(diverging(5.0, top).0, 213);
    }

    #[test]
    fn the_figure_draws_every_row_and_its_rms() {
        let figure = ResidualFigure {
            title: "t".into(),
            quantity: "height residual".into(),
            panels: vec![
                ResidualPanel {
                    title: "before".into(),
                    rows: vec![([0.0, 0.0], 3e-6), ([0.01, 0.0], -4e-6)],
                },
                ResidualPanel {
                    title: "after".into(),
                    rows: vec![([0.0, 0.0], 0.0), ([0.01, 0.0], 0.0)],
                },
            ],
        };
        let svg = String::from_utf8(render(&figure, Format::Svg).unwrap()).unwrap();
        // RMS of 3 and 4 µm: 3.54 µm; 0 after.
        assert!(svg.contains("before: RMS 3.54 µm"), "{svg}");
        assert!(svg.contains("after: RMS 0 µm"));
        assert_eq!(
            svg.matches("<circle").count(),
            8,
            "two rows, filled and outlined, two panels"
        );
    }
}
