//! legwise
pub mod error;
pub mod kinematics;
pub mod model;
pub mod scalar;
pub mod workspace;
