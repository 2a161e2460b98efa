//! The workspace picture: the singularity-free region of the home modes, the singular curves,
//! the maximal inscribed workspace (MIW) and, optionally, a set of poses, with axes in metres.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::canvas::{Drawn, Figure};
use super::style;
use crate::model::Mechanism;
use crate::report::tidy;
use crate::workspace::limits::has_limits;
use crate::workspace::miw::{Miw, SingularityMargin};
use crate::workspace::miw3d::Miw3d;
use crate::workspace::singular::{singular_curves, SingularCurves};

/// A set of poses drawn with one marker colour.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseGroup {
    /// Legend entry (`leg1 poses`, `shared poses` …).
    pub name: String,
    /// Positions x, y (m).
    pub points: Vec<[f64; 2]>,
}

/// The picture's data.
#[derive(Debug, Clone, PartialEq)]
pub struct WorkspaceFigure {
    /// Figure title.
    pub title: String,
    /// Boundary of the singularity-free region seen from the MIW centre (m), closed implicitly.
    pub region: Vec<[f64; 2]>,
    /// Serial (type I) singular curves: polylines (m).
    pub serial: Vec<Vec<[f64; 2]>>,
    /// Parallel (type II) singular curves: polylines (m).
    pub parallel: Vec<Vec<[f64; 2]>>,
    /// MIW centre (m).
    pub miw_centre: [f64; 2],
    /// MIW radius (m).
    pub miw_radius: f64,
    /// Poses to draw.
    pub poses: Vec<PoseGroup>,
    /// The part of the plane shown, `(lo, hi)` (m).
    pub bounds: ([f64; 2], [f64; 2]),
    /// The names of the horizontal and vertical coordinates (`x`, `y`; `x`, `z` …), in metres.
    pub axes: [String; 2],
    /// Legend entry of the region's fill.
    pub region_label: String,
    /// Legend entry of the serial curves.
    pub serial_label: String,
    /// Legend entry of the MIW's circle.
    pub miw_label: String,
    /// The instrument's touch surfaces crossing the plane: segments (m), with their legend
    /// entry.
    pub surfaces: Vec<([[f64; 2]; 2], String)>,
}

/// Legend entry of the serial curves of a mechanism without joint limits.
pub const SERIAL_LABEL: &str =
    "serial (type I) singularity: a leg stretched, folded or out of reach";
/// Legend entry of the serial curves of a mechanism with joint limits.
pub const SERIAL_OR_LIMIT_LABEL: &str =
    "serial (type I) singularity or joint limit: a leg stretched, folded, out of reach or a joint at the end of its range";

/// Fill of the singularity-free region.
pub const REGION: RGBColor = RGBColor(216, 240, 208);
/// Serial singular curves.
pub const SERIAL: RGBColor = RGBColor(192, 57, 43);
/// Parallel singular curves.
pub const PARALLEL: RGBColor = RGBColor(36, 85, 195);
/// A touch surface (a bed).
pub const SURFACE: RGBColor = RGBColor(120, 78, 30);

const PLOT: u32 = 640;
const Y_LABELS: u32 = 72;
const X_LABELS: u32 = 48;
const MARGIN: u32 = 16;
const CAPTION: u32 = 34;
/// Height of the legend under a planar figure's plot (pixels): room for its five rows at
/// most.
pub const LEGEND: u32 = 110;

impl WorkspaceFigure {
    /// The bounds widened to the plot's aspect (a metre as long in x as in y).
    fn square_bounds(&self) -> ([f64; 2], [f64; 2]) {
        let (lo, hi) = self.bounds;
        let span = [(hi[0] - lo[0]).max(1e-9), (hi[1] - lo[1]).max(1e-9)];
        let side = span[0].max(span[1]);
        let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        (
            [centre[0] - 0.5 * side, centre[1] - 0.5 * side],
            [centre[0] + 0.5 * side, centre[1] + 0.5 * side],
        )
    }
}

impl Figure for WorkspaceFigure {
    fn size(&self) -> (u32, u32) {
        let (width, height) = self.plot_size();
        (width, height + LEGEND)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        root.fill(&WHITE)?;
        let (_, height) = self.size();
        let (plot_area, legend_area) = root.split_vertically(height - LEGEND);
        self.draw_plot(&plot_area)?;
        self.draw_legend(&legend_area, std::slice::from_ref(self), style::LABEL_SIZE)
    }
}

impl WorkspaceFigure {
    /// Size of the plot without its legend (pixels).
    pub fn plot_size(&self) -> (u32, u32) {
        (
            PLOT + Y_LABELS + 2 * MARGIN,
            PLOT + X_LABELS + CAPTION + 2 * MARGIN,
        )
    }

    /// The plot (titled by `title`), without the legend.
    ///
    /// # Errors
    /// The backend fails to draw.
    pub fn draw_plot<DB: DrawingBackend>(&self, plot_area: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        let (lo, hi) = self.square_bounds();
        let mut chart = ChartBuilder::on(plot_area)
            .caption(&self.title, style::caption())
            .margin(MARGIN)
            .x_label_area_size(X_LABELS)
            .y_label_area_size(Y_LABELS)
            .build_cartesian_2d(lo[0]..hi[0], lo[1]..hi[1])?;
        chart
            .configure_mesh()
            .x_desc(format!("{} (m)", self.axes[0]))
            .y_desc(format!("{} (m)", self.axes[1]))
            .x_label_formatter(&|v| style::tick(*v, hi[0] - lo[0]))
            .y_label_formatter(&|v| style::tick(*v, hi[1] - lo[1]))
            .label_style(style::label())
            .axis_desc_style(style::axis_description())
            .x_labels(8)
            .y_labels(8)
            .light_line_style(TRANSPARENT)
            .bold_line_style(RGBColor(225, 225, 225))
            .draw()?;
        let region: Vec<(f64, f64)> = self.region.iter().map(|p| (p[0], p[1])).collect();
        let plot = chart.plotting_area();
        plot.draw(&Polygon::new(region.clone(), REGION.filled()))?;
        let mut outline = region;
        if let Some(&first) = outline.first() {
            outline.push(first);
        }
        plot.draw(&PathElement::new(
            outline,
            RGBColor(74, 138, 58).stroke_width(1),
        ))?;
        for (curves, colour) in [(&self.serial, SERIAL), (&self.parallel, PARALLEL)] {
            chart.draw_series(curves.iter().map(|curve| {
                PathElement::new(
                    curve.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>(),
                    colour.stroke_width(2),
                )
            }))?;
        }
        for ([a, b], _) in &self.surfaces {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(a[0], a[1]), (b[0], b[1])],
                SURFACE.stroke_width(3),
            )))?;
        }
        let circle: Vec<(f64, f64)> = (0..=360)
            .map(|k| {
                let angle = std::f64::consts::TAU * f64::from(k) / 360.0;
                (
                    self.miw_centre[0] + self.miw_radius * angle.cos(),
                    self.miw_centre[1] + self.miw_radius * angle.sin(),
                )
            })
            .collect();
        // Dashed, so that a singular curve under the circle stays visible.
        chart.draw_series(DashedLineSeries::new(circle, 8, 5, BLACK.stroke_width(2)))?;
        chart.draw_series(std::iter::once(
            EmptyElement::at((self.miw_centre[0], self.miw_centre[1]))
                + PathElement::new(vec![(-6, 0), (6, 0)], BLACK.stroke_width(2))
                + PathElement::new(vec![(0, -6), (0, 6)], BLACK.stroke_width(2)),
        ))?;
        for (g, group) in self.poses.iter().enumerate() {
            let colour = style::AFTER[g % style::AFTER.len()];
            chart.draw_series(
                group
                    .points
                    .iter()
                    .map(|p| style::marker((p[0], p[1]), colour)),
            )?;
        }
        Ok(())
    }

    /// The legend's rows for `panels` (this figure, or the slices drawn beside it): the
    /// region, the serial and parallel curves where any panel has some, the MIW, and one row
    /// for the pose groups if there are any.
    fn legend_rows(&self, panels: &[WorkspaceFigure]) -> u32 {
        let serial = panels.iter().any(|p| !p.serial.is_empty());
        let parallel = panels.iter().any(|p| !p.parallel.is_empty());
        2 + u32::from(serial)
            + u32::from(parallel)
            + surface_labels(panels).len() as u32
            + u32::from(!self.poses.is_empty())
    }

    /// Height (pixels) of the legend of `panels` (see [`WorkspaceFigure::draw_legend`]) in
    /// text of `size` (plotters' size, as in [`style::label`]); a planar figure's legend fits
    /// in [`LEGEND`] at [`style::LABEL_SIZE`].
    pub fn legend_height(&self, panels: &[WorkspaceFigure], size: f64) -> u32 {
        let unit = |v: f64| (v * size / style::LABEL_SIZE).round() as u32;
        unit(4.0) + self.legend_rows(panels) * unit(20.0) + unit(8.0)
    }

    /// The legend in text of `size` (plotters' size, [`style::LABEL_SIZE`] under a planar figure;
    /// swatches and rows scale with it): the region, the serial and parallel curves where any
    /// of `panels` (this figure, or the slices drawn beside it) has some, the MIW and the pose
    /// groups, each entry's text centred on its swatch.
    ///
    /// # Errors
    /// The backend fails to draw.
    pub fn draw_legend<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        panels: &[WorkspaceFigure],
        size: f64,
    ) -> Drawn<DB> {
        let serial = panels.iter().any(|p| !p.serial.is_empty());
        let parallel = panels.iter().any(|p| !p.parallel.is_empty());
        // Lengths drawn for text of style::LABEL_SIZE, scaled to `size`.
        let unit = |v: f64| (v * size / style::LABEL_SIZE).round() as i32;
        let x0 = (MARGIN + Y_LABELS) as i32;
        // The middle of row k.
        let row = |k: i32| unit(4.0) + unit(20.0) * k + unit(7.0);
        let text = |s: String, x: i32, y: i32| style::legend_text(s, (x + unit(26.0), y), size);
        let stroke = unit(2.0).max(1) as u32;
        let line = |x: i32, y: i32, colour: RGBColor| {
            PathElement::new(
                vec![(x, y), (x + unit(20.0), y)],
                colour.stroke_width(stroke),
            )
        };
        area.draw(&Rectangle::new(
            [
                (x0, row(0) - unit(7.0)),
                (x0 + unit(20.0), row(0) + unit(7.0)),
            ],
            REGION.filled(),
        ))?;
        area.draw(&text(self.region_label.clone(), x0, row(0)))?;
        // Only the curves drawn, one row each, without a gap for the others.
        let mut next = 1;
        if serial {
            area.draw(&line(x0, row(next), SERIAL))?;
            area.draw(&text(self.serial_label.clone(), x0, row(next)))?;
            next += 1;
        }
        if parallel {
            area.draw(&line(x0, row(next), PARALLEL))?;
            area.draw(&text(
                "parallel (type II) singularity: the platform gains a freedom".into(),
                x0,
                row(next),
            ))?;
            next += 1;
        }
        // Two dashes, as the MIW's dashed circle.
        for (a, b) in [(0.0, 8.0), (13.0, 20.0)] {
            let dash = vec![(x0 + unit(a), row(next)), (x0 + unit(b), row(next))];
            area.draw(&PathElement::new(dash, BLACK.stroke_width(stroke)))?;
        }
        area.draw(&text(self.miw_label.clone(), x0, row(next)))?;
        next += 1;
        for label in surface_labels(panels) {
            area.draw(&line(x0, row(next), SURFACE))?;
            area.draw(&text(label, x0, row(next)))?;
            next += 1;
        }
        let mut x = x0;
        for (g, group) in self.poses.iter().enumerate() {
            let colour = style::AFTER[g % style::AFTER.len()];
            area.draw(&style::marker((x + unit(10.0), row(next)), colour))?;
            let label = format!("{} ({})", group.name, group.points.len());
            let width = unit(40.0) + unit(8.0) * label.chars().count() as i32;
            area.draw(&text(label, x, row(next)))?;
            x += width;
        }
        Ok(())
    }
}

/// The legend entries of the touch surfaces any of `panels` draws, each once.
fn surface_labels(panels: &[WorkspaceFigure]) -> Vec<String> {
    let mut labels: Vec<String> = Vec::new();
    for (_, label) in panels.iter().flat_map(|p| &p.surfaces) {
        if !labels.contains(label) {
            labels.push(label.clone());
        }
    }
    labels
}

/// Grid cells per side sampled to trace the singular curves of the picture.
pub const GRID: usize = 120;

/// The workspace picture of `miw`, with the singular curves of `margin` over the region around
/// it, and `poses` drawn on top.
pub fn workspace_figure(
    margin: &SingularityMargin<'_>,
    miw: &Miw,
    title: &str,
    poses: Vec<PoseGroup>,
) -> WorkspaceFigure {
    let (bounds, SingularCurves { serial, parallel }) =
        around(margin, &miw.boundary, &poses, miw.centre, GRID);
    WorkspaceFigure {
        title: title.to_string(),
        region: miw.boundary.clone(),
        serial,
        parallel,
        miw_centre: miw.centre,
        miw_radius: miw.radius,
        poses,
        bounds,
        axes: ["x".into(), "y".into()],
        region_label:
            "singularity-free region of the home working and assembly modes, seen from the MIW centre"
                .into(),
        serial_label: serial_label(margin.mechanism()),
        miw_label: format!(
            "MIW: centre ({}, {}) m, radius {:.4} m",
            tidy(miw.centre[0], 4),
            tidy(miw.centre[1], 4),
            miw.radius
        ),
        surfaces: Vec::new(),
    }
}

/// The part of the plane shown around the `region`'s boundary and the `poses` (their bounding
/// box padded by a quarter of its larger side), with the singular curves of `margin` there,
/// traced from `centre` on `cells × cells` cells.
fn around(
    margin: &SingularityMargin<'_>,
    region: &[[f64; 2]],
    poses: &[PoseGroup],
    centre: [f64; 2],
    cells: usize,
) -> (([f64; 2], [f64; 2]), SingularCurves) {
    let points = poses.iter().flat_map(|g| g.points.iter());
    let (lo, hi) = style::bounding_box(region.iter().chain(points).copied());
    let pad = 0.25 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let (lo, hi) = ([lo[0] - pad, lo[1] - pad], [hi[0] + pad, hi[1] + pad]);
    ((lo, hi), singular_curves(margin, (lo, hi), centre, cells))
}

/// The serial curves' legend entry: they include the joint limits where the mechanism has any.
fn serial_label(mechanism: &Mechanism) -> String {
    if mechanism.legs.iter().any(has_limits) {
        SERIAL_OR_LIMIT_LABEL.into()
    } else {
        SERIAL_LABEL.into()
    }
}

/// Grid cells per side of a spatial slice's singular curves (three slices are drawn).
pub const SLICE_GRID: usize = 80;

/// The picture of one slice of a spatial mechanism's workspace through the home position, in
/// the plane of the position coordinates `axes` (`margin` set on that plane with
/// [`SingularityMargin::in_plane`]): the region's `boundary` there (from
/// [`crate::workspace::miw3d::slice`]), its singular curves, the 3-D MIW's cross-section and the
/// `poses` (projected on the plane).
pub fn slice_figure(
    margin: &SingularityMargin<'_>,
    boundary: Vec<[f64; 2]>,
    axes: [usize; 2],
    miw: &Miw3d,
    poses: Vec<PoseGroup>,
) -> WorkspaceFigure {
    const NAMES: [&str; 3] = ["x", "y", "z"];
    let centre = [miw.centre[axes[0]], miw.centre[axes[1]]];
    let (bounds, SingularCurves { serial, parallel }) =
        around(margin, &boundary, &poses, centre, SLICE_GRID);
    let fixed = 3 - axes[0] - axes[1];
    let c = miw.centre.map(|v| tidy(v, 4));
    let mut figure = WorkspaceFigure {
        title: format!(
            "slice {} = {} m",
            NAMES[fixed],
            tidy(miw.centre[fixed], 4)
        ),
        region: boundary,
        serial,
        parallel,
        miw_centre: centre,
        miw_radius: miw.radius,
        poses,
        bounds,
        axes: [NAMES[axes[0]].into(), NAMES[axes[1]].into()],
        region_label: "singularity-free region of the home working and assembly modes at the home orientation, seen from the home position".into(),
        serial_label: serial_label(margin.mechanism()),
        miw_label: format!(
            "3-D MIW: a ball about ({}, {}, {}) m, radius {:.4} m (its cross-section)",
            c[0], c[1], c[2], miw.radius
        ),
        surfaces: Vec::new(),
    };
    let shown = figure.square_bounds();
    figure.surfaces = miw
        .surfaces
        .iter()
        .filter_map(|surface| {
            let segment = surface.trace(miw.centre, axes, shown)?;
            let label = format!(
                "touch surface of target `{}`: the platform positions where it touches (the platform stays on the home side)",
                surface.target
            );
            Some((segment, label))
        })
        .collect();
    figure
}
