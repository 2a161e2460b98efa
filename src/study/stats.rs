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
use statrs::distribution::{ChiSquared, ContinuousCDF};

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
    crate::identify::statistics::student_t_975(n - 1)
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
    // A bound that cannot be computed (fewer than two values) stays NaN: `max` would make it 0.
    let root = |v: f64| if v.is_nan() { v } else { v.max(0.0).sqrt() };
    Estimate {
        value: of_squares.value.sqrt(),
        low: root(of_squares.low),
        high: root(of_squares.high),
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

    #[test]
    fn two_values_take_the_one_degree_of_freedom_quantiles() {
        // s of {1, 3} is √2; t(0.975, 1) = 12.706205; χ²(1) 0.025 and 0.975 quantiles
        // 0.000982069 and 5.023886 (printed tables).
        assert!((sample_std(&[1.0, 3.0]) - 2f64.sqrt()).abs() < 1e-15);
        assert!((t_quantile(2) - 12.706_205).abs() < 1e-5);
        let m = mean_interval(&[1.0, 3.0]);
        assert!((m.low - (2.0 - 12.706_205)).abs() < 1e-5);
        assert!((m.high - (2.0 + 12.706_205)).abs() < 1e-5);
        let s = std_interval(&[1.0, 3.0]);
        assert!((s.low - (2.0f64 / 5.023_886).sqrt()).abs() < 1e-6);
        let high = (2.0f64 / 0.000_982_069).sqrt();
        assert!(
            (s.high - high).abs() < 1e-5 * high,
            "{} against {high}",
            s.high
        );
    }

    #[test]
    fn no_values_give_no_quantile_no_spread_and_no_interval() {
        assert!(mean(&[]).is_nan());
        assert!(t_quantile(0).is_nan() && t_quantile(1).is_nan());
        assert!(sample_std(&[]).is_nan() && sample_std(&[2.0]).is_nan());
        let s = std_interval(&[]);
        assert!(s.value.is_nan() && s.low.is_nan() && s.high.is_nan());
        // Every trial failed: no RMS and no interval (it printed as [0, 0]).
        let r = rms_interval(&[]);
        assert!(r.value.is_nan() && r.low.is_nan() && r.high.is_nan());
        let one = rms_interval(&[3.0]);
        assert!((one.value - 3.0).abs() < 1e-15 && one.low.is_nan() && one.high.is_nan());
    }

    #[test]
    fn an_interval_is_below_or_above_zero_only_when_it_excludes_zero() {
        let e = |low: f64, high: f64| Estimate {
            value: (low + high) / 2.0,
            low,
            high,
        };
        // The smallest positive number: one step either side of zero.
        let tiny = f64::from_bits(1);
        assert!(e(-2.0, -tiny).below_zero());
        assert!(!e(-2.0, 0.0).below_zero());
        assert!(!e(-2.0, tiny).below_zero());
        assert!(e(tiny, 2.0).above_zero());
        assert!(!e(0.0, 2.0).above_zero());
        assert!(!e(-tiny, 2.0).above_zero());
        assert!(!e(-1.0, 1.0).below_zero() && !e(-1.0, 1.0).above_zero());
    }

    #[test]
    fn scaling_multiplies_every_number_of_an_estimate() {
        let e = Estimate {
            value: 0.002,
            low: -0.0005,
            high: 0.0045,
        }
        .scaled(1e3);
        assert!((e.value - 2.0).abs() < 1e-12);
        assert!((e.low + 0.5).abs() < 1e-12);
        assert!((e.high - 4.5).abs() < 1e-12);
    }

    #[test]
    fn a_paired_difference_is_the_t_interval_of_the_differences() {
        // a − b = 2, 3, 6: mean 11/3, s² = 13/3, half width t(0.975, 2) · √(s²/3) with
        // t(0.975, 2) = 4.302653.
        let d = paired_difference(&[3.0, 5.0, 10.0], &[1.0, 2.0, 4.0]);
        let half = 4.302_653 * (13.0f64 / 9.0).sqrt();
        assert!((d.value - 11.0 / 3.0).abs() < 1e-12);
        assert!((d.low - (11.0 / 3.0 - half)).abs() < 1e-5);
        assert!((d.high - (11.0 / 3.0 + half)).abs() < 1e-5);
    }
}
