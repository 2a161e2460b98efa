//! One integration binary for all legwise tests.
mod golden;
mod recovery;
mod support;
