//! One integration binary for all legwise tests.
mod bad_input;
mod cli;
mod golden;
mod inverse_kinematics;
mod jacobian;
mod kinematics;
mod lm_behaviour;
mod observability_values;
mod recovery;
mod selection;
mod solvers_agree;
mod statistics_independent;
mod support;
mod workspace;
