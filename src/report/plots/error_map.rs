//! The position-error map over the workspace, before and after identification (the paper's
//! Fig. 4): one colour map per model with its own colour bar in millimetres, the
//! non-assemblable grid points in grey and the measured (identification) poses on top.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::canvas::{Drawn, Figure};
use super::style;
use crate::evaluate::accuracy::{AccuracyMap, ErrorStats};

/// One grid point of a map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapCell {
    /// Target position x (m).
    pub x: f64,
    /// Target position y (m).
    pub y: f64,
    /// Position error (m); `None` where the mechanism cannot be assembled.
    pub error_m: Option<f64>,
}

/// One model's map.
#[derive(Debug, Clone, PartialEq)]
pub struct MapPanel {
    /// Caption (`before (nominal model)` …); the RMS is appended when drawn.
    pub title: String,
    /// The grid points.
    pub cells: Vec<MapCell>,
}

/// The figure: panels side by side, the grid spacing and the measured poses.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorMapFigure {
    /// Figure title.
    pub title: String,
    /// Grid spacing (m): the side of each coloured square.
    pub grid_m: f64,
    /// One panel per model.
    pub panels: Vec<MapPanel>,
    /// Measured poses (x, y in m), drawn on every panel.
    pub poses: Vec<[f64; 2]>,
}

impl MapPanel {
    /// The panel of an accuracy map.
    pub fn from_map(title: &str, map: &AccuracyMap) -> Self {
        Self {
            title: title.to_string(),
            cells: map
                .points
                .iter()
                .map(|p| MapCell {
                    x: p.pose[0],
                    y: p.pose[1],
                    error_m: p.position_error,
                })
                .collect(),
        }
    }

    /// The statistics of the assembled points (m), as the terminal and JSON reports give them.
    fn stats(&self) -> Option<ErrorStats> {
        let errors: Vec<f64> = self.cells.iter().filter_map(|c| c.error_m).collect();
        ErrorStats::of(&errors)
    }

    /// The top of the colour scale (mm): the 99th percentile of the errors, so that a few
    /// points near a singularity do not darken the whole map (colours saturate above it).
    fn colour_top_mm(&self) -> f64 {
        let mut errors: Vec<f64> = self
            .cells
            .iter()
            .filter_map(|c| c.error_m)
            .filter(|e| e.is_finite())
            .collect();
        errors.sort_by(f64::total_cmp);
        let index = (errors.len().saturating_sub(1) as f64 * 0.99).round() as usize;
        let top = errors.get(index).map(|e| 1e3 * e);
        top.filter(|top| *top > 0.0).unwrap_or(1.0)
    }
}

/// Colour of the non-assemblable grid points.
pub const NOT_ASSEMBLABLE: RGBColor = RGBColor(200, 200, 200);

const PANEL: u32 = 560;
const BAR: u32 = 124;
const TITLE: u32 = 44;
const FOOTER: u32 = 36;
const Y_LABELS: u32 = style::MAP_FRAME.2;
const X_LABELS: u32 = style::MAP_FRAME.1;
const MARGIN: u32 = style::MAP_FRAME.0;
const CAPTION: u32 = 30;

impl ErrorMapFigure {
    /// Bounds (lo, hi) of the cells and poses, padded by half a cell and widened to the plot's
    /// aspect so that a metre is as long in x as in y.
    fn bounds(&self, plot: (f64, f64)) -> ([f64; 2], [f64; 2]) {
        let half = 0.5 * self.grid_m;
        let points = self
            .panels
            .iter()
            .flat_map(|p| p.cells.iter().map(|c| [c.x, c.y]))
            .chain(self.poses.iter().copied());
        let (lo, hi) = style::bounding_box(points);
        let (lo, hi) = (lo.map(|v| v - half), hi.map(|v| v + half));
        if !lo[0].is_finite() {
            return ([0.0, 0.0], [1.0, 1.0]);
        }
        let span = [(hi[0] - lo[0]).max(1e-9), (hi[1] - lo[1]).max(1e-9)];
        let per_pixel = (span[0] / plot.0).max(span[1] / plot.1);
        let wanted = [per_pixel * plot.0, per_pixel * plot.1];
        let extra = [0, 1].map(|k| 0.5 * (wanted[k] - span[k]));
        (
            [lo[0] - extra[0], lo[1] - extra[1]],
            [hi[0] + extra[0], hi[1] + extra[1]],
        )
    }
}

impl Figure for ErrorMapFigure {
    fn size(&self) -> (u32, u32) {
        let panels = self.panels.len().max(1) as u32;
        (panels * (PANEL + BAR), TITLE + PANEL + FOOTER)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        root.fill(&WHITE)?;
        let (top, rest) = root.split_vertically(TITLE);
        top.titled(&self.title, style::title())?;
        let (body, footer) = rest.split_vertically(PANEL);
        let plot = (
            f64::from(PANEL - Y_LABELS - 2 * MARGIN),
            f64::from(PANEL - X_LABELS - CAPTION - 2 * MARGIN),
        );
        let bounds = self.bounds(plot);
        let areas = body.split_evenly((1, self.panels.len().max(1)));
        for (panel, area) in self.panels.iter().zip(areas.iter()) {
            let (map_area, bar_area) = area.split_horizontally(PANEL);
            let top_mm = panel.colour_top_mm();
            self.draw_map(&map_area, panel, bounds, top_mm)?;
            draw_colour_bar(&bar_area, top_mm)?;
        }
        self.draw_footer(&footer)
    }
}

impl ErrorMapFigure {
    fn draw_map<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        panel: &MapPanel,
        (lo, hi): ([f64; 2], [f64; 2]),
        top_mm: f64,
    ) -> Drawn<DB> {
        let caption = match panel.stats() {
            Some(stats) => format!(
                "{}: RMS {} mm, max {} mm",
                panel.title,
                style::short_number(1e3 * stats.rms),
                style::short_number(1e3 * stats.max)
            ),
            None => format!("{}: no assemblable point", panel.title),
        };
        let mut chart = style::xy_map(area, caption, (lo, hi))?;
        let half = 0.5 * self.grid_m;
        chart.draw_series(panel.cells.iter().map(|cell| {
            let colour = match cell.error_m {
                Some(e) if e.is_finite() => {
                    ViridisRGB::get_color_normalized((1e3 * e).min(top_mm), 0.0, top_mm)
                }
                _ => NOT_ASSEMBLABLE,
            };
            Rectangle::new(
                [
                    (cell.x - half, cell.y - half),
                    (cell.x + half, cell.y + half),
                ],
                colour.filled(),
            )
        }))?;
        chart.draw_series(
            self.poses
                .iter()
                .map(|p| style::marker((p[0], p[1]), WHITE)),
        )?;
        Ok(())
    }

    fn draw_footer<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        let y = 12;
        area.draw(&style::marker((80, y + 7), WHITE))?;
        area.draw(&style::legend_text(
            format!("measured poses ({})", self.poses.len()),
            (92, y + 7),
            style::LABEL_SIZE,
        ))?;
        area.draw(&Rectangle::new(
            [(320, y), (334, y + 14)],
            NOT_ASSEMBLABLE.filled(),
        ))?;
        area.draw(&style::legend_text(
            "cannot be assembled".to_string(),
            (342, y + 7),
            style::LABEL_SIZE,
        ))?;
        area.draw(&style::legend_text(
            format!(
                "grid {} mm; colour: position error of the real mechanism commanded by the model, saturating at the 99th percentile of each map",
                style::short_number(self.grid_m * 1e3)
            ),
            (520, y + 7),
            style::LABEL_SIZE,
        ))?;
        Ok(())
    }
}

/// A vertical colour bar from 0 to `top_mm` millimetres.
fn draw_colour_bar<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, top_mm: f64) -> Drawn<DB> {
    let mut chart = ChartBuilder::on(area)
        .margin_top(MARGIN + CAPTION + 8)
        .margin_bottom(MARGIN + X_LABELS)
        .margin_right(8)
        .y_label_area_size(0)
        .right_y_label_area_size(60)
        .build_cartesian_2d(0.0..1.0, 0.0..top_mm)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_label_formatter(&|v| style::short_number(*v))
        .y_desc("position error (mm)")
        .label_style(style::label())
        .axis_desc_style(style::axis_description())
        .draw()?;
    let steps = 128;
    chart.draw_series((0..steps).map(|k| {
        let (a, b) = (
            top_mm * k as f64 / steps as f64,
            top_mm * (k + 1) as f64 / steps as f64,
        );
        Rectangle::new(
            [(0.0, a), (1.0, b)],
            ViridisRGB::get_color_normalized(0.5 * (a + b), 0.0, top_mm).filled(),
        )
    }))?;
    Ok(())
}
