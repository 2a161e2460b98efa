//! How the predicted σ falls with the number of measured rows (`legwise how-many`): one curve
//! per series (the design's RMS and max over the workspace, identify's RMS), millimetres against
//! rows, a marker at each count computed.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::canvas::{Drawn, Figure};
use super::style;

/// One curve: its legend and its points `(rows, σ in m)`.
#[derive(Debug, Clone, PartialEq)]
pub struct CountSeries {
    /// Legend entry.
    pub name: String,
    /// `(rows, σ m)`, in increasing rows.
    pub points: Vec<(usize, f64)>,
}

/// The figure.
#[derive(Debug, Clone, PartialEq)]
pub struct CountCurve {
    /// Figure title.
    pub title: String,
    /// The model's own count (a vertical mark), if any.
    pub model_count: Option<usize>,
    /// The curves.
    pub series: Vec<CountSeries>,
}

const WIDTH: u32 = 900;
const HEIGHT: u32 = 560;
const TITLE: u32 = 44;
const LEGEND: u32 = 36;

impl Figure for CountCurve {
    fn size(&self) -> (u32, u32) {
        (WIDTH, HEIGHT)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        root.fill(&WHITE)?;
        let (top, rest) = root.split_vertically(TITLE);
        top.titled(&self.title, style::title())?;
        let (plot, legend) = rest.split_vertically(HEIGHT - TITLE - LEGEND);
        let points = self.series.iter().flat_map(|s| s.points.iter());
        let x_hi = points.clone().map(|p| p.0).max().unwrap_or(1).max(1) as f64 * 1.05;
        let y_hi = points
            .map(|p| p.1 * 1e3)
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        let y_hi = if y_hi > 0.0 { y_hi * 1.1 } else { 1.0 };
        let mut chart = ChartBuilder::on(&plot)
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(80)
            .build_cartesian_2d(0.0..x_hi, 0.0..y_hi)?;
        chart
            .configure_mesh()
            .x_desc("rows measured")
            .y_desc("predicted σ over the workspace (mm)")
            .y_label_formatter(&|v| style::short_number(*v))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .label_style(style::label())
            .axis_desc_style(style::axis_description())
            .draw()?;
        if let Some(n) = self.model_count {
            let n = n as f64;
            chart.draw_series(LineSeries::new(
                [(n, 0.0), (n, y_hi)],
                RGBColor(120, 120, 120).stroke_width(2),
            ))?;
        }
        for (k, series) in self.series.iter().enumerate() {
            let colour = style::series_colour(k);
            let xy: Vec<(f64, f64)> = series
                .points
                .iter()
                .map(|&(n, s)| (n as f64, s * 1e3))
                .filter(|p| p.1.is_finite())
                .collect();
            chart.draw_series(LineSeries::new(xy.clone(), colour.stroke_width(2)))?;
            chart.draw_series(xy.into_iter().map(|p| Circle::new(p, 4, colour.filled())))?;
            let x = 80 + 260 * k as i32;
            legend.draw(&PathElement::new(
                vec![(x, 16), (x + 24, 16)],
                colour.stroke_width(2),
            ))?;
            legend.draw(&style::legend_text(
                series.name.clone(),
                (x + 30, 16),
                style::LABEL_SIZE,
            ))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{CountCurve, CountSeries};
    use crate::report::plots::{render, Format};

    #[test]
    fn every_count_is_a_marker_on_its_curve() {
        let figure = CountCurve {
            title: "t".into(),
            model_count: Some(18),
            series: vec![
                CountSeries {
                    name: "design RMS".into(),
                    points: vec![(9, 3e-5), (18, 2e-5), (37, 1.5e-5)],
                },
                CountSeries {
                    name: "design max".into(),
                    points: vec![(9, 4e-5), (18, 3e-5), (37, 2e-5)],
                },
            ],
        };
        let svg = String::from_utf8(render(&figure, Format::Svg).unwrap()).unwrap();
        assert_eq!(svg.matches("<circle").count(), 6);
        assert!(svg.contains("design RMS") && svg.contains("design max"));
    }
}
