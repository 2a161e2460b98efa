//! One integration binary for all legwise tests.
mod bad_input;
mod cli;
mod exit_codes;
mod files;
mod fuzz;
mod golden;
mod jacobian;
mod kinematics;
mod mgh;
mod nist;
mod recovery;
mod selection;
mod solvers_agree;
mod statistics_trust;
mod support;
mod workspace;
