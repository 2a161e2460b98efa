//! The robot's usable workspace, geometry only: the region's geometry (the only user of parry),
//! the feasible candidate poses (the selection module adds their identification rows and
//! selects from them), the MIW, the singular curves and the instrument's touch surfaces (the
//! report module pictures them). It uses the model, the kinematics and what the instrument
//! reports of a target (`measure::targets`), never the modules above it.
pub mod candidates;
pub mod contour;
pub mod limits;
pub mod miw;
pub mod miw3d;
pub mod region;
pub mod singular;
pub mod touch_surface;
