//! Summary statistics of a set of errors: RMS, median, 95th percentile and maximum.

use serde::Serialize;

/// Summary of a set of non-negative errors (metres or radians).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorStats {
    /// Root mean square.
    pub rms: f64,
    /// Median (mean of the two middle values for an even count).
    pub median: f64,
    /// 95th percentile (linear interpolation between order statistics).
    pub p95: f64,
    /// Largest error.
    pub max: f64,
}

impl ErrorStats {
    /// Statistics of `errors`; `None` for an empty set or a non-finite error.
    pub fn of(errors: &[f64]) -> Option<Self> {
        if errors.is_empty() || errors.iter().any(|e| !e.is_finite()) {
            return None;
        }
        let mut sorted = errors.to_vec();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let quantile = |q: f64| {
            let position = q * (n - 1) as f64;
            let below = position.floor() as usize;
            let above = (below + 1).min(n - 1);
            let weight = position - below as f64;
            sorted[below] + weight * (sorted[above] - sorted[below])
        };
        Some(Self {
            rms: (sorted.iter().map(|e| e * e).sum::<f64>() / n as f64).sqrt(),
            median: quantile(0.5),
            p95: quantile(0.95),
            max: sorted[n - 1],
        })
    }
}
