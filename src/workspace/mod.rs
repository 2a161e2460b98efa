//! The robot's usable workspace, geometry only: the region's geometry (the only user of parry),
//! the feasible candidate poses (selected from by [`crate::selection`]), the MIW and the
//! singular curves (pictured by [`crate::report::plots::workspace`]).
pub mod candidates;
pub mod contour;
pub mod limits;
pub mod miw;
pub mod miw3d;
pub mod region;
pub mod singular;
