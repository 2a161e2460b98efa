//! Pictures drawn with the plotters crate: SVG by default, PNG on request (the same SVG
//! rasterised with resvg), both with the embedded DejaVu Sans font so that no system font is
//! needed.
//!
//! Each figure is a plain data type (trivially filled from the reports) implementing
//! [`Figure`]; [`render`] turns it into the bytes of an SVG or PNG file (the command line
//! writes them through its checked outputs).
//!
//! * [`parameter_errors`] — parameter errors before and after identification (the paper's Fig. 3);
//! * [`error_map`] — the position-error map over the workspace, before and after (Fig. 4);
//! * [`distribution`] — the distribution of position errors of one or more models (ECDF);
//! * [`workspace`] — the singularity-free region, singular curves, MIW and poses;
//! * [`slices`] — slices of a spatial workspace side by side;
//! * [`files`] — which pictures `identify --plots` and `evaluate --plots` write, and where.
pub mod canvas;
pub mod count_curve;
pub mod distribution;
pub mod error_map;
pub mod files;
pub mod parameter_errors;
mod raster;
pub mod row_residuals;
pub mod slices;
pub mod style;
pub mod workspace;

pub use canvas::{render, Figure, Format};
