//! Identification: residual blocks, dual-number Jacobians, problems, observability, estimates.
pub mod estimate;
pub mod jacobian;
pub mod observability;
pub mod problem;
pub mod residual;
pub mod trust;
