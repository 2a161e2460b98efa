//! Unit tests of the Schur-complement Levenberg–Marquardt solver.
