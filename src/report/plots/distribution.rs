//! The distribution of position errors of one or more models on the same poses: empirical
//! cumulative distribution functions on a logarithmic millimetre axis (so that errors a hundred
//! times apart stay readable side by side).

use plotters::coord::Shift;
use plotters::prelude::*;

use super::canvas::{Drawn, Figure};
use super::style;
use crate::evaluate::accuracy::ErrorStats;

/// One model's errors.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorSample {
    /// Legend entry (the model's name or file).
    pub name: String,
    /// Position errors (m), one per assembled pose.
    pub errors_m: Vec<f64>,
}

/// The figure's data: one sample per model, the first one drawn as "before".
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorDistribution {
    /// Figure title.
    pub title: String,
    /// What an error is, singular (`position error`; `height error` for a bed probe): the x
    /// axis says it.
    pub quantity: String,
    /// The samples.
    pub samples: Vec<ErrorSample>,
}

/// Sorted finite errors in millimetres.
fn sorted_mm(errors_m: &[f64]) -> Vec<f64> {
    let mut mm: Vec<f64> = errors_m
        .iter()
        .filter(|e| e.is_finite())
        .map(|e| e * 1e3)
        .collect();
    mm.sort_by(f64::total_cmp);
    mm
}

impl ErrorDistribution {
    /// The x range (mm, positive) covering every positive error.
    fn range_mm(&self) -> (f64, f64) {
        let positive = self
            .samples
            .iter()
            .flat_map(|s| s.errors_m.iter())
            .map(|e| e * 1e3)
            .filter(|e| e.is_finite() && *e > 0.0);
        let (lo, hi) = positive.fold((f64::INFINITY, 0.0f64), |(lo, hi), e| {
            (lo.min(e), hi.max(e))
        });
        if !lo.is_finite() {
            return (1e-3, 1.0);
        }
        let (lo, hi) = (lo / 1.5, hi * 1.5);
        if hi / lo < 10.0 {
            let middle = (lo * hi).sqrt();
            (middle / 3.2, middle * 3.2)
        } else {
            (lo, hi)
        }
    }
}

const PLOT_HEIGHT: u32 = 500;
const LEGEND_ROW: u32 = 22;

impl Figure for ErrorDistribution {
    fn size(&self) -> (u32, u32) {
        (
            800,
            PLOT_HEIGHT + LEGEND_ROW * self.samples.len().max(1) as u32 + 12,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        root.fill(&WHITE)?;
        let (lo, hi) = self.range_mm();
        let (plot_area, legend_area) = root.split_vertically(PLOT_HEIGHT);
        let mut chart = ChartBuilder::on(&plot_area)
            .caption(&self.title, style::title())
            .margin(16)
            .margin_right(28)
            .x_label_area_size(48)
            .y_label_area_size(64)
            .build_cartesian_2d((lo..hi).log_scale(), 0.0..1.0)?;
        chart
            .configure_mesh()
            .x_desc(format!("{} (mm, logarithmic)", self.quantity))
            .y_desc("fraction of poses with a smaller error")
            .x_label_formatter(&|v| style::log_tick(*v, lo, hi))
            .y_label_formatter(&|v| style::tick(*v, 1.0))
            .label_style(style::label())
            .axis_desc_style(style::axis_description())
            .light_line_style(RGBColor(235, 235, 235))
            .draw()?;
        for (s, sample) in self.samples.iter().enumerate() {
            let mm = sorted_mm(&sample.errors_m);
            let y = 4 + (s as u32 * LEGEND_ROW) as i32;
            if mm.is_empty() {
                legend_area.draw(&style::legend_text(
                    format!("{}: no pose could be assembled", sample.name),
                    (112, y + 7),
                    style::LABEL_SIZE,
                ))?;
                continue;
            }
            let n = mm.len() as f64;
            let mut steps = vec![(lo, 0.0)];
            for (k, &e) in mm.iter().enumerate() {
                let x = e.clamp(lo, hi);
                steps.push((x, k as f64 / n));
                steps.push((x, (k + 1) as f64 / n));
            }
            steps.push((hi, 1.0));
            // The same statistics as the terminal and JSON reports.
            let stats = ErrorStats::of(&mm).unwrap_or(ErrorStats {
                rms: f64::NAN,
                median: f64::NAN,
                p95: f64::NAN,
                max: f64::NAN,
            });
            let colour = style::series_colour(s);
            chart.draw_series(LineSeries::new(steps, colour.stroke_width(2)))?;
            legend_area.draw(&PathElement::new(
                vec![(80, y + 7), (104, y + 7)],
                colour.stroke_width(2),
            ))?;
            legend_area.draw(&style::legend_text(
                format!(
                    "{}: RMS {} mm, p95 {} mm, max {} mm ({} poses)",
                    sample.name,
                    style::short_number(stats.rms),
                    style::short_number(stats.p95),
                    style::short_number(stats.max),
                    mm.len()
                ),
                (112, y + 7),
                style::LABEL_SIZE,
            ))?;
        }
        Ok(())
    }
}
