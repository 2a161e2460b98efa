//! Identification: residual blocks, dual-number Jacobians, problems, observability, estimates,
//! the statistics of each fit, robust losses and the trust verdict.
pub mod estimate;
pub mod factor_set;
mod factor_unknowns;
mod fit;
pub mod gauges;
pub mod held_test;
pub mod jacobian;
pub mod observability;
pub mod problem;
pub mod residual;
pub mod result;
pub mod robust;
pub mod sandwich;
pub mod set_choice;
pub mod shared_estimate;
pub mod shared_outliers;
mod shared_priors;
pub mod shared_weights;
mod solve_from;
pub mod statistics;
pub mod trust;
pub mod two_stage;
