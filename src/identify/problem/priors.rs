//! A problem's priors as data: its prior rows and each unknown's prior σ (built and read by
//! `problem/prior_rows.rs`).

/// One prior row: `Σ w_j (x_j − μ_j)` over its terms, of standard deviation `sigma`.
#[derive(Debug, Clone, PartialEq)]
pub struct PriorRow {
    /// `(column, w_j, μ_j)`: the unknown's index in the problem's parameter vector, its weight
    /// and the prior's mean.
    pub terms: Vec<(usize, f64, f64)>,
    /// The row's standard deviation (a parameter's prior σ; 1 for a whitened calibration).
    pub sigma: f64,
    /// What the row is the prior of, for messages: the parameter, or the calibration file.
    pub name: String,
}

/// A prior row in a Schur group: its derivatives by the group's own columns and by the shared
/// ones, `(column, derivative)`, and its residual.
pub(super) type GroupPriorRow = (Vec<(usize, f64)>, Vec<(usize, f64)>, f64);

/// One unknown's prior σ (a parameter's own, or the calibration's `√Σ_jj`).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct PriorSigma {
    pub(super) column: usize,
    pub(super) sigma: f64,
}

/// A problem's priors: their rows, and each unknown's prior σ.
#[derive(Debug, Clone, Default)]
pub(super) struct Priors {
    pub(super) rows: Vec<PriorRow>,
    pub(super) sigmas: Vec<PriorSigma>,
}
