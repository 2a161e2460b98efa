//! The robot's usable workspace, geometry only: the region's geometry (the only user of parry),
//! the feasible candidate poses (the selection module adds their identification rows and
//! selects from them), the MIW and the singular curves (the report module pictures them). It
//! uses the model and the kinematics, never the modules above it.
pub mod candidates;
pub mod contour;
pub mod limits;
pub mod miw;
pub mod miw3d;
pub mod region;
pub mod singular;
