//! legwise
pub mod cli;
pub mod error;
pub mod identify;
pub mod kinematics;
pub mod measure;
pub mod model;
pub mod report;
pub mod scalar;
pub mod solver;
pub mod workspace;
