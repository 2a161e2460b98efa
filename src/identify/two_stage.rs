//! The covariance of the two-stage strategy (docs/statistics.md, "Through an instrument"): the
//! instrument registered first from a few rows with the legs at their nominal values, then the
//! legs with the instrument held at that registration.
//!
//! The second stage's estimate moves with its rows' noise and with the registration's error,
//! and that error has two sources: the rows' noise `ε` (covariance `V`, the declared noise as
//! for the joint strategy, src/identify/sandwich.rs) and the legs' departure `δL` from the
//! nominal values the registration holds them at. Linearised, with `J₂` the legs' columns of
//! the Jacobian at the estimate, `K` the instrument's, `J₁` the registration's Jacobian on its
//! rows `R` and `E₁ = (J₁ᵀJ₁)⁻¹J₁ᵀP_R` (`P_R` picks the rows `R`):
//!
//! * the registration moves by `δθ₁ = −E₁(ε + J₂ δL)`;
//! * the second stage's rows see `ε + K δθ₁`, and its estimate moves by `−G₂(ε + K δθ₁)`,
//!   `G₂ = (J₂ᵀJ₂)⁻¹J₂ᵀ`.
//!
//! So with `M = I − K E₁` and `Σ_L` the covariance of the legs' departure from nominal, the
//! legs' covariance is `G₂ (M V Mᵀ + K E₁ J₂ Σ_L J₂ᵀ E₁ᵀ Kᵀ) G₂ᵀ` and the registration's
//! `E₁ (V + J₂ Σ_L J₂ᵀ) E₁ᵀ`: the same rows' noise moves both stages, and the registration's
//! share of it, and of the legs' error, reaches every leg.
//!
//! `Σ_L` is what the model says of its legs' departure from nominal: diagonal, each identified
//! parameter's standard deviation of the simulation's perturbation (`simulation.perturbation`,
//! by kind), zero for a parameter given its real value or without a perturbation block. The
//! part `Σ_L` does not describe (a leg error of a mechanism with declared real values) is a bias
//! of the two-stage estimate, not a spread: σ does not cover it, and the strategy's noise test
//! (its residuals against the declared noise) rejects it when it is large.
//!
//! The scale is the declared noise's own (`V` as declared), not the residuals': those carry the
//! misfit of the legs held at nominal during the registration. Without a declared noise
//! `V = I` scaled by each stage's residual variance `‖r‖² / tr((I − H) V)`, the only scale
//! there is (misfit included), and `Σ_L` is not used (its size against the noise is unknown).

use nalgebra::{DMatrix, DVector};

use super::problem::{BlockError, IdentificationProblem};
use crate::model::mechanism::MeasurementNoise;

/// The two-stage strategy's covariances: the legs' (the second stage's unknowns, in its
/// order) and the registered instrument parameters'.
#[derive(Debug, Clone, PartialEq)]
pub struct TwoStageCovariance {
    /// Over the second stage's unknowns (every leg's identified parameters).
    pub legs: DMatrix<f64>,
    /// Over the registration's unknowns (the instrument's identified parameters).
    pub registration: DMatrix<f64>,
    /// The registration's residual degrees of freedom (`|R|` minus its unknowns).
    pub registration_dof: usize,
}

/// The two-stage estimate to take the covariance of.
pub struct TwoStage<'p, 'a> {
    /// The whole problem: every leg's and the instrument's identified parameters.
    pub full: &'p IdentificationProblem<'a>,
    /// The registration (the instrument alone on the rows `rows` of `full`).
    pub registration: &'p IdentificationProblem<'a>,
    /// The rows of `full` the registration used (ascending).
    pub rows: &'p [usize],
    /// The registration's estimate.
    pub frame: &'p DVector<f64>,
    /// The second stage's estimate (the legs' unknowns).
    pub legs: &'p DVector<f64>,
    /// The standard deviation of each of the legs' unknowns' departure from its nominal value
    /// (the diagonal of `Σ_L`; zero where the model gives none).
    pub departure: &'p [f64],
}

impl TwoStage<'_, '_> {
    /// The covariances of the module's documentation under the declared `noise` (or none);
    /// `None` without redundancy in either stage, with a singular normal matrix or a residual
    /// covariance whose expected sum of squares is not positive.
    ///
    /// # Errors
    /// A leg cannot reach a pose at the estimate.
    pub fn covariance(
        &self,
        noise: Option<&MeasurementNoise>,
    ) -> Result<Option<TwoStageCovariance>, BlockError> {
        let (n2, n1) = (self.legs.len(), self.frame.len());
        let x = DVector::from_iterator(n2 + n1, self.legs.iter().chain(self.frame.iter()).copied());
        let (r2, whole) = self.full.residuals_and_jacobian(&x)?;
        let (r1, j1) = self.registration.residuals_and_jacobian(self.frame)?;
        let m = whole.nrows();
        let rows = self.rows;
        if m <= n2 || rows.len() <= n1 || j1.nrows() != rows.len() {
            return Ok(None);
        }
        let j2 = whole.columns(0, n2).into_owned();
        let k = whole.columns(n2, n1).into_owned();
        let (Some(g1), Some(g2)) = (pseudo_solve(&j1), pseudo_solve(&j2)) else {
            return Ok(None);
        };
        // E₁ = G₁ P_R over all the rows.
        let mut e1 = DMatrix::zeros(n1, m);
        for (column, &row) in rows.iter().enumerate() {
            e1.set_column(row, &g1.column(column));
        }
        // The legs move by −(G₂ M) ε with G₂ M = G₂ − (G₂ K) E₁, without the m × m matrix M.
        let g2_k = &g2 * &k;
        let legs_by_rows = &g2 - &g2_k * &e1;
        let Some(noise) = noise else {
            // V = I, each stage scaled by its residuals over their expectation:
            // tr(I − H₁) = |R| − n₁, and ‖(I − H₂) M‖²_F = (m − n₂) − 2 tr(E₁ C) + tr(CᵀC E₁E₁ᵀ)
            // with C = (I − H₂) K = K − J₂ G₂ K (so (I − H₂) M = (I − H₂) − C E₁).
            let c = &k - &j2 * &g2_k;
            let e1_e1 = &e1 * e1.transpose();
            let expected1 = (rows.len() - n1) as f64;
            let expected2 =
                (m - n2) as f64 - 2.0 * (&e1 * &c).trace() + (c.tr_mul(&c) * &e1_e1).trace();
            if !(expected2 > 0.0 && expected2.is_finite()) {
                return Ok(None);
            }
            return Ok(Some(TwoStageCovariance {
                legs: &legs_by_rows * legs_by_rows.transpose() * (r2.norm_squared() / expected2),
                registration: e1_e1 * (r1.norm_squared() / expected1),
                registration_dof: rows.len() - n1,
            }));
        };
        let Ok(loadings) = self.full.noise_loadings(&x, noise) else {
            return Ok(None);
        };
        // The registration's move by the legs' departure: −E₁ J₂ Σ_L^½ per unit departure.
        let mut by_departure = &e1 * &j2;
        if self.departure.len() == n2 {
            for (j, sigma) in self.departure.iter().enumerate() {
                by_departure.column_mut(j).scale_mut(*sigma);
            }
        } else {
            by_departure.fill(0.0);
        }
        let legs_by_departure = &g2_k * &by_departure;
        Ok(Some(TwoStageCovariance {
            legs: loadings.meat(&legs_by_rows.transpose())
                + &legs_by_departure * legs_by_departure.transpose(),
            registration: loadings.meat(&e1.transpose()) + &by_departure * by_departure.transpose(),
            registration_dof: rows.len() - n1,
        }))
    }
}

/// `(JᵀJ)⁻¹Jᵀ`, `None` when `JᵀJ` is singular.
fn pseudo_solve(jacobian: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let inverse = jacobian.tr_mul(jacobian).try_inverse()?;
    Some(inverse * jacobian.transpose())
}
