//! Parameter errors before and after identification, per parameter and strategy: grouped bars,
//! one panel per unit (the paper's Fig. 3). Needs the real values, so simulation only.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::canvas::{Drawn, Figure};
use super::style;
use crate::model::params::Unit;
use crate::report::Report;

/// One identified parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterLabel {
    /// Name as in the model file.
    pub name: String,
    /// Its SI unit.
    pub unit: Unit,
}

/// One bar per parameter: value minus real value, SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct BarSeries {
    /// Legend entry (`before (nominal)`, `after: divide and conquer` …).
    pub name: String,
    /// Error of each parameter, in the order of [`ParameterErrors::parameters`].
    pub errors: Vec<f64>,
}

/// The figure's data: parameters and one series per model (the first one is "before").
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterErrors {
    /// Figure title.
    pub title: String,
    /// The parameters, in bar order.
    pub parameters: Vec<ParameterLabel>,
    /// The series: before, then one per strategy.
    pub series: Vec<BarSeries>,
}

impl ParameterErrors {
    /// The identified parameters of every leg of `report`, with the nominal error and each
    /// strategy's error; `None` when a real value is unknown (measurements from a file).
    pub fn from_report(report: &Report<'_>) -> Option<Self> {
        let first = report.results.first()?;
        let mut parameters = Vec::new();
        let mut before = Vec::new();
        // (leg name, parameter index) of each bar, to find the same parameter in every result.
        let mut keys = Vec::new();
        for leg in &first.legs {
            for (p, parameter) in leg.parameters.iter().enumerate() {
                if !parameter.identified {
                    continue;
                }
                let real = report.real_value(&leg.leg, p)?;
                parameters.push(ParameterLabel {
                    name: parameter.name.clone(),
                    unit: parameter.unit,
                });
                before.push(parameter.nominal - real);
                keys.push((leg.leg.clone(), p, real));
            }
        }
        let mut series = vec![BarSeries {
            name: "before (nominal values)".into(),
            errors: before,
        }];
        for result in &report.results {
            let errors = keys
                .iter()
                .map(|(leg, p, real)| {
                    let estimate =
                        result.legs.iter().find(|l| &l.leg == leg)?.parameters[*p].estimate;
                    Some(estimate - real)
                })
                .collect::<Option<Vec<f64>>>()?;
            series.push(BarSeries {
                name: format!("after: {}", result.strategy.name()),
                errors,
            });
        }
        Some(Self {
            title: format!("{}: parameter errors (value − real)", report.mechanism.name),
            parameters,
            series,
        })
    }

    /// The units present, in a fixed order (lengths, angles, dimensionless).
    fn units(&self) -> Vec<Unit> {
        [Unit::Metre, Unit::Radian, Unit::One]
            .into_iter()
            .filter(|u| self.parameters.iter().any(|p| p.unit == *u))
            .collect()
    }
}

/// Display unit of a panel: the description and the factor from SI.
pub fn display_unit(unit: Unit) -> (&'static str, f64) {
    match unit {
        Unit::Metre => ("length error (mm)", 1e3),
        Unit::Radian => ("angle error (mrad)", 1e3),
        Unit::One => ("gain error (×10⁻³)", 1e3),
    }
}

const PANEL_HEIGHT: u32 = 300;
const TITLE_HEIGHT: u32 = 40;

impl Figure for ParameterErrors {
    fn size(&self) -> (u32, u32) {
        let bars = self.parameters.len() as u32 * self.series.len().max(1) as u32;
        let width = (200 + 18 * bars)
            .max(style::title_width(&self.title))
            .clamp(720, 2400);
        let panels = self.units().len().max(1) as u32;
        (width, TITLE_HEIGHT + 50 + panels * PANEL_HEIGHT)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        root.fill(&WHITE)?;
        let (width, _) = self.size();
        let (top, rest) = root.split_vertically(TITLE_HEIGHT);
        top.titled(&self.title, style::title())?;
        let (legend, panels_area) = rest.split_vertically(50);
        self.draw_legend(&legend, width)?;
        let units = self.units();
        let panels = panels_area.split_evenly((units.len().max(1), 1));
        for (unit, area) in units.iter().zip(panels.iter()) {
            self.draw_panel(area, *unit)?;
        }
        Ok(())
    }
}

impl ParameterErrors {
    fn draw_legend<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        width: u32,
    ) -> Drawn<DB> {
        let columns = self.series.len().max(1) as i32;
        let step = (width as i32 - 80) / columns;
        for (s, series) in self.series.iter().enumerate() {
            let x = 80 + s as i32 * step;
            area.draw(&Rectangle::new(
                [(x, 18), (x + 14, 32)],
                style::series_colour(s).filled(),
            ))?;
            area.draw(&style::legend_text(
                series.name.clone(),
                (x + 20, 25),
                style::LABEL_SIZE,
            ))?;
        }
        Ok(())
    }

    fn draw_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        unit: Unit,
    ) -> Drawn<DB> {
        let (description, factor) = display_unit(unit);
        let indices: Vec<usize> = (0..self.parameters.len())
            .filter(|&i| self.parameters[i].unit == unit)
            .collect();
        let largest = self
            .series
            .iter()
            .flat_map(|s| indices.iter().map(|&i| (s.errors[i] * factor).abs()))
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        let limit = if largest > 0.0 { 1.15 * largest } else { 1.0 };
        let count = indices.len();
        let names: Vec<String> = indices
            .iter()
            .map(|&i| self.parameters[i].name.clone())
            .collect();
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .margin_right(24)
            .x_label_area_size(30)
            .y_label_area_size(80)
            .build_cartesian_2d(-0.5..count as f64 - 0.5, -limit..limit)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .light_line_style(TRANSPARENT)
            .bold_line_style(RGBColor(225, 225, 225))
            .x_labels(count.max(1))
            .x_label_formatter(&|v| {
                let i = v.round();
                if (v - i).abs() < 1e-6 && i >= 0.0 {
                    names.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&|v| style::tick(*v, limit))
            .y_desc(description)
            .label_style(style::label())
            .axis_desc_style(style::axis_description())
            .draw()?;
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(-0.5, 0.0), (count as f64 - 0.5, 0.0)],
            BLACK.stroke_width(1),
        )))?;
        let groups = self.series.len().max(1) as f64;
        let width = 0.8 / groups;
        for (s, series) in self.series.iter().enumerate() {
            let colour = style::series_colour(s);
            chart.draw_series(indices.iter().enumerate().map(|(k, &i)| {
                let left = k as f64 - 0.4 + s as f64 * width;
                let value = series.errors[i] * factor;
                Rectangle::new([(left, 0.0), (left + 0.9 * width, value)], colour.filled())
            }))?;
        }
        Ok(())
    }
}
