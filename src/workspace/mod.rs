//! The robot's usable workspace (region, margin, ranges) and candidate poses.
pub mod candidates;
pub mod miw;
pub mod picture;
pub mod region;
