//! Rendering a [`Figure`] to SVG or PNG bytes, with the embedded font: plotters draws the SVG,
//! and a PNG is that SVG rasterised.

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::raster::svg_to_png;
use crate::error::{Error, Result};

/// What drawing on a backend `DB` returns: nothing, or the backend's error.
pub type Drawn<DB> =
    std::result::Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A picture: its size in pixels and how to draw it on any plotters backend.
pub trait Figure {
    /// Width and height in pixels (SVG user units).
    fn size(&self) -> (u32, u32);

    /// Draws the picture on `root`, which covers [`Figure::size`].
    ///
    /// # Errors
    /// The backend's drawing errors.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn<DB>;
}

/// Picture file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Scalable vector graphics (text stays text).
    Svg,
    /// Portable network graphics: the SVG rasterised, its text drawn with the embedded font.
    Png,
}

impl Format {
    /// The file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Svg => "svg",
            Format::Png => "png",
        }
    }

    /// The format named by `path`'s extension (`.svg` or `.png`, any case).
    ///
    /// # Errors
    /// Any other extension, or none, naming the path.
    pub fn from_path(path: &Path) -> Result<Self> {
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        match extension.as_deref() {
            Some("svg") => Ok(Format::Svg),
            Some("png") => Ok(Format::Png),
            _ => Err(Error::Invalid(format!(
                "{}: cannot tell the picture format: expected a file name ending in .svg or .png",
                path.display()
            ))),
        }
    }
}

/// The font family every figure uses; registered from the embedded DejaVu Sans.
pub const FONT: &str = "sans-serif";

/// Registers the embedded fonts with plotters once: plotters lays text out (the widths that
/// centre and align it) with them.
///
/// # Errors
/// The embedded font could not be parsed (a broken build).
pub fn register_fonts() -> Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
            && plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold()).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(Error::Invalid(
            "the embedded DejaVu Sans font could not be loaded".into(),
        ))
    }
}

/// Renders `figure` as the bytes of a file in `format`: its SVG, or that very SVG rasterised
/// with resvg (the embedded fonts only, one pixel a user unit) so that both formats show the
/// same picture.
///
/// # Errors
/// A drawing error of the backend, or the rasteriser's or PNG encoder's error.
pub fn render(figure: &impl Figure, format: Format) -> Result<Vec<u8>> {
    register_fonts()?;
    let (width, height) = figure.size();
    let mut text = String::new();
    {
        let failed =
            |e: &dyn std::fmt::Display| Error::Invalid(format!("cannot draw the picture: {e}"));
        let root = SVGBackend::with_string(&mut text, (width, height)).into_drawing_area();
        figure.draw(&root).map_err(|e| failed(&e))?;
        root.present().map_err(|e| failed(&e))?;
    }
    match format {
        Format::Svg => Ok(text.into_bytes()),
        Format::Png => svg_to_png(&text, width, height),
    }
}
