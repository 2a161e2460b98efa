//! How the declared noise of the instrument's target coordinates reaches the residuals of a
//! problem seen through it (docs/method.md §13, "Statistics").

use argmin::core::Error as ArgminError;
use nalgebra::DVector;

use super::sighted::reading_pose_gradient;
use super::{BlockError, IdentificationProblem};
use crate::identify::sandwich::NoiseLoadings;
use crate::model::instrument::Instrument;
use crate::model::mechanism::MeasurementNoise;

impl IdentificationProblem<'_> {
    /// The loadings of the declared `noise` on every residual at `x` (rows in the problem's
    /// order), through an instrument: per residual, its measurement (the row of the
    /// observations: a shared row's residuals of several legs share it) and `σ_i ∂ψ/∂m_i`
    /// over the row's target coordinates `m_i` (σ of the coordinate of the same name: x, y, z,
    /// roll, pitch, yaw), `∂ψ/∂m_i` by the chain rule through the reading's Newton step and the
    /// pose fit (dual numbers in `m_i`).
    ///
    /// # Errors
    /// A problem without an instrument; a leg cannot reach a fitted pose.
    ///
    /// The prior rows follow the data's, each a measurement of its own loading its σ alone
    /// (the readings' own noise is then carried as a loading of each data row: it is not the
    /// priors').
    pub fn noise_loadings(
        &self,
        x: &DVector<f64>,
        noise: &MeasurementNoise,
    ) -> Result<NoiseLoadings, ArgminError> {
        let data = self.data_noise_loadings(x, noise)?;
        if self.prior_rows().is_empty() {
            return Ok(data);
        }
        // `scaled` by 1 moves `σ_q` into a loading of each data row's own.
        let mut loadings = if data.reading == 0.0 {
            data
        } else {
            data.scaled(&[])
        };
        let fresh = loadings.fresh_measurement();
        let priors = self.prior_rows().iter().enumerate();
        loadings
            .rows
            .extend(priors.map(|(k, p)| (fresh + k, vec![p.sigma])));
        Ok(loadings)
    }

    /// The data rows' loadings (of [`Self::noise_loadings`]).
    fn data_noise_loadings(
        &self,
        x: &DVector<f64>,
        noise: &MeasurementNoise,
    ) -> Result<NoiseLoadings, ArgminError> {
        let sighted = self
            .sighted
            .as_ref()
            .ok_or_else(|| ArgminError::msg("the problem sees no instrument"))?;
        if self.forward.is_some() {
            // A forward row's readings reach all its coordinates: their noise is in the
            // row's loadings, none left for each residual on its own. The blocks of measured
            // poses first, as the residuals.
            let mut rows = self.measured_pose_loadings(x, noise)?;
            let (forward, also) = self.forward_loadings(x, noise)?;
            let first = rows.len();
            rows.extend(forward);
            let also = also
                .into_iter()
                .map(|(r, m, w)| (first + r, m, w))
                .collect();
            return Ok(NoiseLoadings {
                reading: 0.0,
                rows,
                also,
            });
        }
        let shared = self.shared_values(x);
        let home = &self.mechanism.home_pose;
        let sigmas = coordinate_sigmas(sighted.instrument, noise);
        let rows = self.map_solved(x, |index, leg, placed, solution| {
            let row = &sighted.rows[index];
            let d = reading_pose_gradient(leg, &placed.pose, solution);
            // The row's loading, written in place: its gradient, then times each σ.
            let mut loading = vec![0.0; sigmas.len()];
            sighted.observed_gradient((&shared, home), &row.observed, &d, &mut loading);
            for (value, sigma) in loading.iter_mut().zip(&sigmas) {
                *value *= sigma;
            }
            (row.source, loading)
        })?;
        Ok(NoiseLoadings {
            reading: noise.reading,
            rows,
            also: Vec::new(),
        })
    }

    /// Expected variance of every residual at `x` (rows in the problem's order) under the
    /// declared `noise`, through an instrument: `σ_q² + Σ_i (∂ψ/∂m_i)² σ_i²`
    /// ([`Self::noise_loadings`]).
    ///
    /// # Errors
    /// As [`Self::noise_loadings`].
    pub fn row_variances(
        &self,
        x: &DVector<f64>,
        noise: &MeasurementNoise,
    ) -> Result<Vec<f64>, ArgminError> {
        Ok(self.noise_loadings(x, noise)?.variances())
    }
}

impl IdentificationProblem<'_> {
    /// The loadings of a forward problem's blocks of measured poses at `x`, laid out as the
    /// forward rows' ([`Self::forward_loadings`]: the row's target coordinates, a distance's
    /// σ, then one reading per leg) and then the pose coordinates: a block of leg `l` reads
    /// `−σ_q` at its reading (the residual is `ψ_l(P) − s_l`, the row's forward residuals
    /// share that reading) and `σ_c ∂ψ_l/∂P_c` at each pose coordinate `c` (the
    /// `instrument.poses` noise times the noise's scale; the legs of one row share its pose).
    /// Empty without blocks.
    ///
    /// # Errors
    /// A leg cannot reach its measured pose.
    fn measured_pose_loadings(
        &self,
        x: &DVector<f64>,
        noise: &MeasurementNoise,
    ) -> Result<Vec<(usize, Vec<f64>)>, BlockError> {
        let (Some(forward), Some(sighted)) = (&self.forward, &self.sighted) else {
            return Ok(Vec::new());
        };
        if self.blocks.is_empty() {
            return Ok(Vec::new());
        }
        let instrument = sighted.instrument;
        let pose_sigmas = instrument
            .poses
            .as_ref()
            .map_or([0.0; 6], |p| p.noise.map(|s| s * noise.scale));
        let before = coordinate_sigmas(instrument, noise).len() + 1;
        let legs = self.mechanism.legs.len();
        let measured = &self.mechanism.measured;
        self.map_solved(x, |index, leg, placed, solution| {
            let mut loading = vec![0.0; before + legs + 6];
            loading[before + self.blocks[index].leg] = -noise.reading;
            let gradient = leg.pose_gradient_of(&placed.pose, solution, measured);
            for c in 0..6 {
                loading[before + legs + c] = gradient[c] * pose_sigmas[c];
            }
            (forward.block_sources[index], loading)
        })
    }
}

/// The declared σ of every target coordinate of a measurement row, in row order (the noise of
/// the pose coordinate of the same name).
pub(super) fn coordinate_sigmas(instrument: &Instrument, noise: &MeasurementNoise) -> Vec<f64> {
    instrument
        .targets
        .iter()
        .flat_map(|t| t.pose_indices())
        .map(|&c| noise.pose[c])
        .collect()
}
