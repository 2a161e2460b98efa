//! The robot's usable workspace (region, margin, ranges) and candidate poses.
pub mod candidates;
pub mod contour;
pub mod design;
pub mod miw;
pub mod picture;
pub mod pose_selection;
pub mod region;
