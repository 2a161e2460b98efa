//! One integration binary for all legwise tests.
mod golden;
mod jacobian;
mod kinematics;
mod recovery;
mod solvers_agree;
mod support;
mod workspace;
mod bad_input;
mod cli;
