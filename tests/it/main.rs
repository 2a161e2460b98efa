//! One integration binary for all legwise tests.
mod golden;
mod support;
