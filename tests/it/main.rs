//! One integration binary for all legwise tests.
mod accuracy_map;
mod bad_input;
mod calibrated;
mod cli;
mod evaluate;
mod golden;
mod jacobian;
mod kinematics;
mod plots;
mod recovery;
mod selection;
mod solvers_agree;
mod support;
mod workspace;
