//! The robot's usable workspace (region, margin, ranges) and candidate poses.
pub mod region;
