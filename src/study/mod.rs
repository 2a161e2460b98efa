//! Studies over many simulated experiments: the Monte Carlo comparison of the identification
//! strategies, with confidence intervals.
//!
//! * [`stats`] — means, standard deviations and RMS values with their 95 % intervals, paired
//!   differences;
//! * [`montecarlo`] — the study itself (`legwise montecarlo`): the same draws fed to divide and
//!   conquer and to the traditional strategy, trials in parallel, bit-identical for a seed (its
//!   arms, one trial, the verdict's sentence and the false alarms in files of their own);
//! * [`report`] — its terminal and JSON renderings;
//! * [`plots`] — the error distributions per strategy;
//! * [`set_outcomes`], [`set_study`] — the factor sets judged on simulated experiments, and the
//!   set the rows recommend against the best in hindsight (`legwise sets --trials`);
//! * [`how_many`] — the predicted σ against the number of poses.
mod alarms;
mod arm;
pub mod how_many;
pub mod montecarlo;
pub mod plots;
pub mod report;
pub mod set_outcomes;
pub mod set_study;
pub mod stats;
mod verdict;
