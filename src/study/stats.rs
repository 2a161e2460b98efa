//! Sample statistics with 95 % confidence intervals, for the studies' per-trial values.
//!
//! * the mean: Student's t interval, `x̄ ± t₀.₉₇₅,ₙ₋₁ · s/√n`;
//! * the standard deviation: the χ² interval `[s √((n−1)/χ²₀.₉₇₅,ₙ₋₁), s √((n−1)/χ²₀.₀₂₅,ₙ₋₁)]`
//!   (exact for normal values);
//! * the root mean square `√(mean x²)`: the t interval of the mean of `x²`, its ends clamped at
//!   zero and square-rooted (the central limit theorem on `x²`; fine for the thousands of trials
//!   of a study, approximate for a handful).
//!
//! With fewer than two values an interval is undefined: its ends are NaN (the JSON report
//! writes them as `null`).

use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};

/// Confidence level of every interval.
pub const CONFIDENCE: f64 = 0.95;

/// A point estimate and its 95 % confidence interval `[low, high]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Estimate {
    /// The point estimate.
    pub value: f64,
    /// Lower end of the interval.
    pub low: f64,
    /// Upper end of the interval.
    pub high: f64,
}

impl Estimate {
    /// True when the interval lies entirely below zero.
    pub fn below_zero(&self) -> bool {
        self.high < 0.0
    }

    /// True when the interval lies entirely above zero.
    pub fn above_zero(&self) -> bool {
        self.low > 0.0
    }

    /// The estimate with every number multiplied by `factor` (a positive unit conversion).
    pub fn scaled(&self, factor: f64) -> Estimate {
        Estimate {
            value: self.value * factor,
            low: self.low * factor,
            high: self.high * factor,
        }
    }
}

/// The arithmetic mean (NaN for no values).
pub fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// The sample standard deviation (divisor `n − 1`; NaN for fewer than two values).
pub fn sample_std(values: &[f64]) -> f64 {
    let n = values.len();
    if n < 2 {
        return f64::NAN;
    }
    let m = mean(values);
    (values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
}

/// The two-sided 95 % quantile of Student's t with `n − 1` degrees of freedom (NaN for n < 2).
pub fn t_quantile(n: usize) -> f64 {
    if n < 2 {
        return f64::NAN;
    }
    StudentsT::new(0.0, 1.0, (n - 1) as f64)
        .map_or(f64::NAN, |t| t.inverse_cdf(0.5 + CONFIDENCE / 2.0))
}

/// The mean of `values` with its t interval.
pub fn mean_interval(values: &[f64]) -> Estimate {
    let n = values.len();
    let m = mean(values);
    let half = t_quantile(n) * sample_std(values) / (n as f64).sqrt();
    Estimate {
        value: m,
        low: m - half,
        high: m + half,
    }
}

/// The sample standard deviation of `values` with its χ² interval.
pub fn std_interval(values: &[f64]) -> Estimate {
    let n = values.len();
    let s = sample_std(values);
    let (low, high) = match ChiSquared::new((n.max(2) - 1) as f64) {
        Ok(chi) if n >= 2 => {
            let dof = (n - 1) as f64;
            let upper = chi.inverse_cdf(0.5 + CONFIDENCE / 2.0);
            let lower = chi.inverse_cdf(0.5 - CONFIDENCE / 2.0);
            (s * (dof / upper).sqrt(), s * (dof / lower).sqrt())
        }
        _ => (f64::NAN, f64::NAN),
    };
    Estimate {
        value: s,
        low,
        high,
    }
}

/// The root mean square of `values` with the interval of [the module docs](self).
pub fn rms_interval(values: &[f64]) -> Estimate {
    let squares: Vec<f64> = values.iter().map(|v| v * v).collect();
    let of_squares = mean_interval(&squares);
    Estimate {
        value: of_squares.value.sqrt(),
        low: of_squares.low.max(0.0).sqrt(),
        high: of_squares.high.max(0.0).sqrt(),
    }
}

/// The mean difference `a − b` of paired values with its t interval (the pairs are the trials:
/// the same draws fed to both sides). `a` and `b` have the same length.
pub fn paired_difference(a: &[f64], b: &[f64]) -> Estimate {
    let differences: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    mean_interval(&differences)
}

/// A proportion `successes / trials` with its Wilson score interval (well-behaved at 0 and 1).
pub fn proportion_interval(successes: usize, trials: usize) -> Estimate {
    if trials == 0 {
        return Estimate {
            value: f64::NAN,
            low: f64::NAN,
            high: f64::NAN,
        };
    }
    let z = statrs::distribution::Normal::new(0.0, 1.0)
        .map_or(f64::NAN, |n| n.inverse_cdf(0.5 + CONFIDENCE / 2.0));
    let n = trials as f64;
    let p = successes as f64 / n;
    let centre = (p + z * z / (2.0 * n)) / (1.0 + z * z / n);
    let half = z / (1.0 + z * z / n) * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt();
    Estimate {
        value: p,
        low: (centre - half).max(0.0),
        high: (centre + half).min(1.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_the_printed_tables() {
        // Student's t, 0.975, 4 and 29 degrees of freedom; χ² 0.025/0.975 with 4.
        assert!((t_quantile(5) - 2.776_445).abs() < 1e-5);
        assert!((t_quantile(30) - 2.045_230).abs() < 1e-5);
        let s = std_interval(&[1.0, 2.0, 3.0, 4.0, 5.0]);
        let sd = 2.5f64.sqrt();
        assert!((s.low - sd * (4.0f64 / 11.143_287).sqrt()).abs() < 1e-5);
        assert!((s.high - sd * (4.0f64 / 0.484_419).sqrt()).abs() < 1e-5);
    }

    #[test]
    fn wilson_interval_of_a_worked_example() {
        // 8 of 10: Wilson 95 % interval [0.4902, 0.9433] (z = 1.959964).
        let p = proportion_interval(8, 10);
        assert!((p.value - 0.8).abs() < 1e-15);
        assert!((p.low - 0.490_16).abs() < 1e-4 && (p.high - 0.943_32).abs() < 1e-4);
        assert!((proportion_interval(10, 10).high - 1.0).abs() < 1e-15);
    }

    #[test]
    fn fewer_than_two_values_give_no_interval() {
        let e = mean_interval(&[3.0]);
        assert!((e.value - 3.0).abs() < 1e-15);
        assert!(e.low.is_nan() && e.high.is_nan());
        assert!(std_interval(&[3.0]).low.is_nan());
    }
}
