//! How the declared noise reaches the residuals of a [`SharedProblem`]: each residual's
//! sensitivity to its measurement's target coordinates, through the reading's Newton step and
//! the pose fit (docs/method.md §13, "Statistics").

use argmin::core::Error as ArgminError;
use nalgebra::DVector;

use super::evaluation::attachment_gradient;
use super::SharedProblem;
use crate::identify::shared_covariance::NoiseLoadings;
use crate::model::mechanism::MeasurementNoise;

impl SharedProblem<'_> {
    /// The loadings of the declared `noise` on every residual at `x` (rows in group order):
    /// per residual, its measurement (the row of the observations: a shared row's residuals of
    /// several legs share it) and `σ_i ∂ψ/∂m_i` over the row's target coordinates `m_i` (σ of
    /// the coordinate of the same name: x, y, z, roll, pitch, yaw), `∂ψ/∂m_i` by the chain rule
    /// through the reading's Newton step and the pose fit (dual numbers in `m_i`).
    ///
    /// # Errors
    /// A leg cannot reach a fitted pose.
    pub fn noise_loadings(
        &self,
        x: &DVector<f64>,
        noise: &MeasurementNoise,
    ) -> Result<NoiseLoadings, ArgminError> {
        let shared = self.shared_values(x);
        let sigmas: Vec<f64> = self
            .instrument
            .targets
            .iter()
            .flat_map(|t| t.pose_indices())
            .map(|&c| noise.pose[c])
            .collect();
        let phis = self.leg_parameters(x);
        let mut rows = Vec::new();
        let mut gradient = vec![0.0; sigmas.len()];
        self.evaluated(x.as_slice(), false, |evaluation| {
            for ((group, phi), values) in self.groups.iter().zip(&phis).zip(&evaluation.groups) {
                let leg = &self.mechanism.legs[group.leg];
                let geometry = leg.geometry(phi);
                let solved = group.rows.iter().zip(&values.poses).zip(&values.solutions);
                for ((row, pose), solution) in solved {
                    let c = attachment_gradient(
                        leg.actuated,
                        leg.closure_dims,
                        geometry.gain,
                        solution,
                    );
                    self.observed_gradient(
                        &shared,
                        &row.observed,
                        (pose, &geometry.attachment),
                        &c,
                        &mut gradient,
                    );
                    let loading = gradient.iter().zip(&sigmas).map(|(d, s)| d * s).collect();
                    rows.push((row.source, loading));
                }
            }
        })
        .map_err(ArgminError::msg)?;
        Ok(NoiseLoadings {
            reading: noise.reading,
            rows,
        })
    }

    /// Expected variance of every residual at `x` (rows in group order) under the declared
    /// `noise`: `σ_q² + Σ_i (∂ψ/∂m_i)² σ_i²` ([`Self::noise_loadings`]).
    ///
    /// # Errors
    /// A leg cannot reach a fitted pose.
    pub fn row_variances(
        &self,
        x: &DVector<f64>,
        noise: &MeasurementNoise,
    ) -> Result<Vec<f64>, ArgminError> {
        Ok(self.noise_loadings(x, noise)?.variances())
    }
}
