//! Pictures of a Monte Carlo study: the distribution of each error over the trials, one
//! outlined histogram per strategy, one panel per quantity (the map's RMS position error, then
//! each parameter's error).

use plotters::coord::Shift;
use plotters::prelude::*;

use super::montecarlo::MonteCarlo;
use crate::model::params::Unit;
use crate::report::plots::canvas::{Drawn, Figure};
use crate::report::plots::style;

/// One panel: a quantity's values per series.
#[derive(Debug, Clone, PartialEq)]
pub struct HistogramPanel {
    /// Caption (the quantity and its unit).
    pub caption: String,
    /// `(legend name, values)` per series.
    pub series: Vec<(String, Vec<f64>)>,
}

/// Outlined histograms in a grid of panels.
#[derive(Debug, Clone, PartialEq)]
pub struct Histograms {
    /// Figure title.
    pub title: String,
    /// The panels, row by row.
    pub panels: Vec<HistogramPanel>,
}

const COLUMNS: usize = 3;
const PANEL: (u32, u32) = (420, 300);
const HEADER: u32 = 70;
const BINS: usize = 30;

/// Bin counts of `values` over `[lo, hi]` as fractions of the sample, in `BINS` bins.
fn fractions(values: &[f64], lo: f64, hi: f64) -> Vec<f64> {
    let mut counts = vec![0usize; BINS];
    let width = (hi - lo) / BINS as f64;
    for &v in values.iter().filter(|v| v.is_finite()) {
        let bin = (((v - lo) / width).floor().max(0.0) as usize).min(BINS - 1);
        counts[bin] += 1;
    }
    let n = values.len().max(1) as f64;
    counts.into_iter().map(|c| c as f64 / n).collect()
}

fn range(panel: &HistogramPanel) -> (f64, f64) {
    let (lo, hi) = panel
        .series
        .iter()
        .flat_map(|(_, v)| v.iter())
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    if hi - lo <= 1e-300_f64.max(1e-12 * lo.abs().max(hi.abs())) {
        let pad = lo.abs().max(1e-12);
        return (lo - pad, hi + pad);
    }
    (lo, hi)
}

impl Figure for Histograms {
    fn size(&self) -> (u32, u32) {
        let rows = self.panels.len().div_ceil(COLUMNS).max(1) as u32;
        (PANEL.0 * COLUMNS as u32, HEADER + PANEL.1 * rows)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        root.fill(&WHITE)?;
        let (header, body) = root.split_vertically(HEADER);
        header.draw(&Text::new(self.title.clone(), (16, 8), style::title()))?;
        let names: Vec<&str> = self
            .panels
            .first()
            .map(|p| p.series.iter().map(|(n, _)| n.as_str()).collect())
            .unwrap_or_default();
        for (s, name) in names.iter().enumerate() {
            let x = 16 + 260 * s as i32;
            let colour = style::AFTER[s % style::AFTER.len()];
            header.draw(&PathElement::new(
                vec![(x, 50), (x + 24, 50)],
                colour.stroke_width(2),
            ))?;
            header.draw(&style::legend_text(
                name.to_string(),
                (x + 30, 50),
                style::LABEL_SIZE,
            ))?;
        }
        let rows = self.panels.len().div_ceil(COLUMNS).max(1);
        let cells = body.split_evenly((rows, COLUMNS));
        for (panel, cell) in self.panels.iter().zip(cells) {
            let (lo, hi) = range(panel);
            let width = (hi - lo) / BINS as f64;
            let heights: Vec<Vec<f64>> = panel
                .series
                .iter()
                .map(|(_, v)| fractions(v, lo, hi))
                .collect();
            let top = heights.iter().flatten().fold(0.0f64, |a, &b| a.max(b)) * 1.1;
            let mut chart = ChartBuilder::on(&cell)
                .caption(&panel.caption, style::caption())
                .margin(8)
                .x_label_area_size(30)
                .y_label_area_size(58)
                .build_cartesian_2d(lo..hi, 0.0..top.max(1e-9))?;
            chart
                .configure_mesh()
                .x_labels(style::label_count(lo, hi, 4))
                .y_labels(4)
                .y_desc("fraction of trials")
                .x_label_formatter(&|v| style::tick(*v, hi - lo))
                .y_label_formatter(&|v| style::tick(*v, top))
                .label_style(style::label())
                .light_line_style(RGBColor(235, 235, 235))
                .draw()?;
            for (s, bins) in heights.iter().enumerate() {
                let mut steps = vec![(lo, 0.0)];
                for (b, &h) in bins.iter().enumerate() {
                    let x0 = lo + b as f64 * width;
                    steps.push((x0, h));
                    steps.push((x0 + width, h));
                }
                steps.push((hi, 0.0));
                let colour = style::AFTER[s % style::AFTER.len()];
                chart.draw_series(LineSeries::new(steps, colour.stroke_width(2)))?;
            }
        }
        Ok(())
    }
}

/// The display unit of a parameter error: mm, mrad, or ×10⁻³ for a gain.
fn display_unit(unit: Unit) -> &'static str {
    match unit {
        Unit::Metre => "mm",
        Unit::Radian => "mrad",
        Unit::One => "10⁻³",
    }
}

/// The error distributions of a study: the map's RMS position error, then each parameter.
pub fn error_distributions(study: &MonteCarlo) -> Histograms {
    let values: Vec<_> = study
        .trials
        .iter()
        .filter_map(|t| t.outcome.as_ref().ok())
        .collect();
    let series = |pick: &dyn Fn(usize) -> Vec<f64>| -> Vec<(String, Vec<f64>)> {
        study
            .arms
            .iter()
            .enumerate()
            .map(|(a, arm)| (arm.arm.name().to_string(), pick(a)))
            .collect()
    };
    let mut panels = vec![HistogramPanel {
        caption: "RMS position error over the map (mm)".into(),
        series: series(&|a| values.iter().map(|v| v.arms[a].map_rms * 1e3).collect()),
    }];
    for (p, parameter) in study.parameters.iter().enumerate() {
        panels.push(HistogramPanel {
            caption: format!(
                "{} error ({})",
                parameter.name,
                display_unit(parameter.unit)
            ),
            series: series(&|a| values.iter().map(|v| v.arms[a].errors[p] * 1e3).collect()),
        });
    }
    Histograms {
        title: format!(
            "{}: error distributions over {} Monte Carlo trials",
            study.mechanism, study.succeeded
        ),
        panels,
    }
}
