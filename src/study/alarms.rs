//! How often a fit's checks of bad data fire on data that have none (a Monte Carlo study's
//! false alarms): outlier flags, noise-test rejections, and a predicted σ above the model's
//! tolerance.

use crate::identify::estimate::StrategyResult;
use crate::identify::statistics::NoiseTest;

/// How often one fit's checks of bad data fired: its leg fits tested for outliers and those
/// that flagged a row, its noise tests (each leg's, the instrument's) and those that rejected
/// the declared noise.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct Alarms {
    /// Leg fits whose rows were tested for outliers.
    pub outlier_tests: usize,
    /// Of those, the fits that flagged at least one row.
    pub flagged: usize,
    /// Noise tests run (one per leg with redundancy and a declared noise; one for the
    /// instrument's fit as a whole).
    pub noise_tests: usize,
    /// Of those, the tests that rejected the declared noise.
    pub rejected: usize,
    /// Fits with a predicted σ of the target and a tolerance to hold it to (seen through the
    /// forward kinematics, with the model's `instrument.tolerance`).
    pub tolerance_tests: usize,
    /// Of those, the fits whose predicted σ exceeded the tolerance (the warning and exit 3 of
    /// `legwise identify`).
    pub above_tolerance: usize,
}

impl Alarms {
    /// The checks of `result` and how often they fired.
    pub fn of(result: &StrategyResult) -> Self {
        let mut alarms = Self::default();
        for leg in &result.legs {
            let statistics = &leg.statistics;
            if statistics.outlier_threshold.is_some() {
                alarms.outlier_tests += 1;
                alarms.flagged += usize::from(!statistics.outliers.is_empty());
            }
            alarms.count_noise_test(statistics.noise_test.as_ref());
        }
        if let Some(instrument) = &result.instrument {
            alarms.count_noise_test(instrument.noise_test.as_ref());
            let predicted = instrument.predicted_position.as_ref();
            if let Some((max, tolerance)) = predicted.and_then(|p| Some((p.max, p.tolerance?))) {
                alarms.tolerance_tests += 1;
                alarms.above_tolerance += usize::from(max > tolerance);
            }
        }
        alarms
    }

    fn count_noise_test(&mut self, test: Option<&NoiseTest>) {
        if let Some(test) = test {
            self.noise_tests += 1;
            self.rejected += usize::from(test.rejected);
        }
    }
}

impl std::ops::Add for Alarms {
    type Output = Self;

    /// The counts of both, summed.
    fn add(self, other: Self) -> Self {
        Self {
            outlier_tests: self.outlier_tests + other.outlier_tests,
            flagged: self.flagged + other.flagged,
            noise_tests: self.noise_tests + other.noise_tests,
            rejected: self.rejected + other.rejected,
            tolerance_tests: self.tolerance_tests + other.tolerance_tests,
            above_tolerance: self.above_tolerance + other.above_tolerance,
        }
    }
}
