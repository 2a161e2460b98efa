//! Slices of a spatial mechanism's workspace side by side (x–y, x–z, y–z through the home
//! position), each a [`WorkspaceFigure`] with its own axes in metres, under one title and one
//! legend.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::canvas::{Drawn, Figure};
use super::style;
use super::workspace::WorkspaceFigure;

/// The picture's data.
#[derive(Debug, Clone, PartialEq)]
pub struct SlicesFigure {
    /// Figure title.
    pub title: String,
    /// One panel per slice, captioned by its own title (`slice z = 0.6 m` …).
    pub panels: Vec<WorkspaceFigure>,
}

const TITLE: u32 = 44;
/// Text size of the legend (plotters' size): larger than a planar figure's, as the picture is
/// three plots wide and shown shrunk.
const LEGEND_TEXT: f64 = 18.0;

impl SlicesFigure {
    /// Height of the legend under the plots (pixels).
    fn legend_height(&self) -> u32 {
        self.panels
            .first()
            .map_or(0, |first| first.legend_height(&self.panels, LEGEND_TEXT))
    }
}

impl Figure for SlicesFigure {
    fn size(&self) -> (u32, u32) {
        let (width, height) = self
            .panels
            .first()
            .map_or((600, 600), WorkspaceFigure::plot_size);
        (
            width * self.panels.len().max(1) as u32,
            TITLE + height + self.legend_height(),
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        root.fill(&WHITE)?;
        let (_, height) = self.size();
        let (top, rest) = root.split_vertically(TITLE);
        top.titled(&self.title, style::title())?;
        let (body, legend) = rest.split_vertically(height - TITLE - self.legend_height());
        let areas = body.split_evenly((1, self.panels.len().max(1)));
        for (panel, area) in self.panels.iter().zip(areas.iter()) {
            panel.draw_plot(area)?;
        }
        if let Some(first) = self.panels.first() {
            first.draw_legend(&legend, &self.panels, LEGEND_TEXT)?;
        }
        Ok(())
    }
}
