//! The robot's usable workspace (region, margin, ranges) and candidate poses; the poses are
//! selected from the candidates by [`crate::selection`].
pub mod candidates;
pub mod contour;
pub mod limits;
pub mod miw;
pub mod miw3d;
pub mod picture;
pub mod region;
