//! One integration binary for all legwise tests.
mod golden;
mod jacobian;
mod solvers_agree;
mod recovery;
mod support;
