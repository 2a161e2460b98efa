//! The covariance of an unweighted least-squares fit whose rows' noise differs from row to row
//! (docs/method.md §13, "Statistics"; docs/statistics.md, "Weights").
//!
//! With pose noise each row's residual variance depends on the row (through the reading's
//! gradient with respect to the pose); through an instrument, besides, the residuals of one
//! measurement (a shared row read by several legs) share its targets' noise: the residual
//! noise is `e = ε_q + W ε_m`, `ε_q` each reading's own noise (variance `σ_q²`), `ε_m` the
//! targets' coordinates (unit variance after scaling), `W` the [`NoiseLoadings`]. Its covariance
//! `V = σ_q² I + W Wᵀ` is block-diagonal, one block per measurement. The unweighted fit's
//! estimate moves by `A Jᵀ e` (`A = (JᵀJ)⁻¹`), so its covariance is the sandwich
//! `A (Jᵀ V J) A`, `Jᵀ V J = Σ_B J_Bᵀ V_B J_B` over the measurements `B` (`J_B` their rows of
//! the Jacobian, `V_B` their block of `V`).
//!
//! `V` is scaled by `ŝ² = ‖r‖² / tr((I − H) V)`, `H = J A Jᵀ`: the residuals' sum of squares
//! over its expectation under the declared noise (`r = (I − H) e`, so `E‖r‖² = tr((I − H) V)`).
//! With the noise declared right `ŝ² ≈ 1`; a noise level declared wrong by a common factor
//! scales the σ as the residuals say; and with equal variances on every row (`V = σ² I`)
//! the covariance is exactly the homoscedastic `σ̂² A`, `σ̂² = ‖r‖²/(m − n)`, which is also what
//! is reported without a declared noise. With fewer than
//! [`SCALE_DOF`] residual degrees of freedom ŝ is too uncertain
//! to scale by: the report's covariance ([`reported_covariance`]) is then the declared noise's,
//! `A (Jᵀ V J) A`.

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};

/// The fewest residual degrees of freedom from which a declared noise's σ are scaled by the
/// residuals' ŝ (docs/statistics.md, "Few degrees of freedom"). With `ν` of them, `ŝ²` is a
/// `χ²_ν / ν` draw: the σ it scales have `E[(error/σ)²] = ν / (ν − 2)`, more than 1.1² below 12
/// (infinite at 1 or 2, the firmware-sized fits of 7 touches for 6 factors), and the relative
/// spread of ŝ is `1/√(2ν)`, 20 % at 12. Below it the σ are the declared noise's, unscaled (ŝ
/// is still reported, and the χ² test still says whether the declared noise holds).
pub const SCALE_DOF: usize = 12;

/// Whether σ on `dof` residual degrees of freedom are scaled by the residuals' ŝ (with a
/// declared noise; without one ŝ is all there is).
pub fn scaled_by_residuals(dof: usize) -> bool {
    dof >= SCALE_DOF
}

/// How the declared noise reaches the residuals (rows in the problem's order): through an
/// instrument, or from the measured poses ([`super::statistics::row_loadings`]).
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseLoadings {
    /// The declared reading noise `σ_q` (each residual's own, independent of the others).
    pub reading: f64,
    /// Per residual: the index of its measurement (residuals with the same index share the
    /// noise of the same target coordinates) and, per target coordinate `m_i`,
    /// `σ_i ∂r/∂m_i`.
    pub rows: Vec<(usize, Vec<f64>)>,
    /// Loadings of some residuals on the noise of other measurements, laid out as those
    /// measurements' own rows' loadings: `(residual, measurement, loading)`. A forward model's
    /// distance between two rows moves with both rows' readings, which their own residuals
    /// read too: the distance's residual is correlated with theirs.
    pub also: Vec<(usize, usize, Vec<f64>)>,
}

impl NoiseLoadings {
    /// Each residual's expected variance, `σ_q² + Σ_i (σ_i ∂r/∂m_i)²` over every measurement
    /// it loads on (the diagonal of `V`).
    pub fn variances(&self) -> Vec<f64> {
        let mut variances = self.own_variances();
        for (residual, _, w) in &self.also {
            variances[*residual] += w.iter().map(|wi| wi.powi(2)).sum::<f64>();
        }
        variances
    }

    /// The same noise on the residuals of a weighted fit, residual `i` times `scales[i]`
    /// (`√w_i`; a missing scale counts as 1): every loading of the residual times its scale,
    /// the readings' own noise `σ_q` carried as a loading of each residual on a measurement of
    /// its own (so that it scales with it). `V` becomes `S V S`, and [`covariance`] of the
    /// weighted residuals and Jacobian is then the weighted fit's sandwich.
    pub fn scaled(&self, scales: &[f64]) -> NoiseLoadings {
        let scale = |i: usize| scales.get(i).copied().unwrap_or(1.0);
        let times = |w: &[f64], s: f64| w.iter().map(|v| v * s).collect::<Vec<f64>>();
        let mut also: Vec<(usize, usize, Vec<f64>)> = self
            .also
            .iter()
            .map(|(r, m, w)| (*r, *m, times(w, scale(*r))))
            .collect();
        if self.reading != 0.0 {
            let fresh = self.fresh_measurement();
            for i in 0..self.rows.len() {
                also.push((i, fresh + i, vec![self.reading * scale(i)]));
            }
        }
        NoiseLoadings {
            reading: 0.0,
            rows: self
                .rows
                .iter()
                .enumerate()
                .map(|(i, (m, w))| (*m, times(w, scale(i))))
                .collect(),
            also,
        }
    }

    /// The first measurement index no residual loads on (one past the largest).
    pub fn fresh_measurement(&self) -> usize {
        let own = self.rows.iter().map(|(m, _)| *m);
        let others = self.also.iter().map(|(_, m, _)| *m);
        own.chain(others).max().map_or(0, |m| m + 1)
    }

    /// The same noise on the residuals `kept` only (in that order; a dropped row's residuals
    /// left out, with their loadings on other measurements).
    pub fn restricted(&self, kept: &[usize]) -> NoiseLoadings {
        let position = |i: usize| kept.iter().position(|&k| k == i);
        NoiseLoadings {
            reading: self.reading,
            rows: kept.iter().map(|&i| self.rows[i].clone()).collect(),
            also: self
                .also
                .iter()
                .filter_map(|(r, m, w)| position(*r).map(|k| (k, *m, w.clone())))
                .collect(),
        }
    }

    /// Each residual's variance from its own measurement, `σ_q² + Σ_i (σ_i ∂r/∂m_i)²`.
    fn own_variances(&self) -> Vec<f64> {
        self.rows
            .iter()
            .map(|(_, w)| w.iter().fold(self.reading.powi(2), |v, wi| v + wi.powi(2)))
            .collect()
    }

    /// `Jᵀ V J` for the Jacobian `jacobian` (rows in the loadings' order): the sum over the
    /// measurements of `J_Bᵀ V_B J_B`, `V_B = σ_q² I + W_B W_Bᵀ` over the residuals `B` that
    /// load on the measurement (its own rows, then the others' loadings on it, [`Self::also`];
    /// `σ_q²` only on a residual's own measurement), as many operations as forming `JᵀJ`, a
    /// measurement being read by a few legs.
    pub fn meat(&self, jacobian: &DMatrix<f64>) -> DMatrix<f64> {
        let n = jacobian.ncols();
        // The loadings on each measurement, in row order (a deterministic sum): the residual,
        // its loading, and whether it is its own measurement.
        let mut measurements: BTreeMap<usize, Vec<Loading<'_>>> = BTreeMap::new();
        for (a, (measurement, w)) in self.rows.iter().enumerate() {
            let entry = measurements.entry(*measurement).or_default();
            entry.push((a, w.as_slice(), true));
        }
        for (a, measurement, w) in &self.also {
            let entry = measurements.entry(*measurement).or_default();
            entry.push((*a, w.as_slice(), false));
        }
        let mut meat = DMatrix::zeros(n, n);
        // Measurements of one row (every row of a plain leg): `v_i J_iᵀ J_i`, summed as
        // `Sᵀ S` with `S` their rows scaled by `√v_i`, one matrix in all rather than a few per
        // row.
        let single = |rows: &Vec<Loading<'_>>| rows.len() == 1 && rows[0].2;
        let singles: Vec<usize> = measurements
            .values()
            .filter(|rows| single(rows))
            .map(|rows| rows[0].0)
            .collect();
        if !singles.is_empty() {
            let variances = self.own_variances();
            let scaled = DMatrix::from_fn(singles.len(), n, |k, j| {
                variances[singles[k]].sqrt() * jacobian[(singles[k], j)]
            });
            meat += scaled.tr_mul(&scaled);
        }
        for rows in measurements.values().filter(|rows| !single(rows)) {
            let block = DMatrix::from_fn(rows.len(), n, |i, j| jacobian[(rows[i].0, j)]);
            let v = DMatrix::from_fn(rows.len(), rows.len(), |i, k| {
                let ((_, wi, own), (_, wk, _)) = (rows[i], rows[k]);
                let shared: f64 = wi.iter().zip(wk).map(|(x, y)| x * y).sum();
                shared
                    + if i == k && own {
                        self.reading.powi(2)
                    } else {
                        0.0
                    }
            });
            meat += block.tr_mul(&(v * &block));
        }
        meat
    }
}

/// The covariance the report gives: [`covariance`], but with `loadings` and fewer than
/// [`SCALE_DOF`] residual degrees of freedom the declared noise's
/// sandwich `A (Jᵀ V J) A`, unscaled by ŝ (docs/statistics.md, "Few degrees of freedom").
pub fn reported_covariance(
    r: &DVector<f64>,
    jacobian: &DMatrix<f64>,
    loadings: Option<&NoiseLoadings>,
) -> Option<DMatrix<f64>> {
    let (m, n) = jacobian.shape();
    let by_residuals = m <= n || scaled_by_residuals(m - n);
    sandwich(r, jacobian, loadings, by_residuals)
}

/// [`reported_covariance`] and, beside it, the declared noise's covariance `A (Jᵀ V J) A` (not
/// scaled by ŝ: what the data determine whatever their residuals say of the noise level), from
/// one sandwich: `(reported, declared)`; `None` as [`covariance`].
pub fn reported_and_declared_covariance(
    r: &DVector<f64>,
    jacobian: &DMatrix<f64>,
    loadings: &NoiseLoadings,
) -> Option<(DMatrix<f64>, DMatrix<f64>)> {
    let (m, n) = jacobian.shape();
    if m <= n || loadings.rows.len() != m {
        return None;
    }
    let (declared, scale) = declared_sandwich(r, jacobian, loadings)?;
    let reported = &declared
        * if scaled_by_residuals(m - n) {
            scale
        } else {
            1.0
        };
    Some((reported, declared))
}

/// A residual's loading on one measurement: the residual, the loading, and whether the
/// measurement is the residual's own (its reading's own noise `σ_q` counted there).
type Loading<'a> = (usize, &'a [f64], bool);

/// The covariance of the unweighted least-squares estimate with residuals `r` and Jacobian
/// `jacobian`: the sandwich `ŝ² A (Jᵀ V J) A` of the module's documentation with `loadings`,
/// else `σ̂² A`; `None` without redundancy (`m ≤ n`), with a singular `JᵀJ` or a residual
/// noise whose expected sum of squares is not positive.
pub fn covariance(
    r: &DVector<f64>,
    jacobian: &DMatrix<f64>,
    loadings: Option<&NoiseLoadings>,
) -> Option<DMatrix<f64>> {
    sandwich(r, jacobian, loadings, true)
}

/// [`covariance`], with the sandwich scaled by ŝ² (`by_residuals`) or not (the declared
/// noise's).
fn sandwich(
    r: &DVector<f64>,
    jacobian: &DMatrix<f64>,
    loadings: Option<&NoiseLoadings>,
    by_residuals: bool,
) -> Option<DMatrix<f64>> {
    let (m, n) = jacobian.shape();
    if m <= n || loadings.is_some_and(|l| l.rows.len() != m) {
        return None;
    }
    let inverse = jacobian.tr_mul(jacobian).try_inverse()?;
    let Some(loadings) = loadings else {
        return Some(inverse * (r.norm_squared() / (m - n) as f64));
    };
    let (declared, scale) = declared_sandwich(r, jacobian, loadings)?;
    Some(declared * if by_residuals { scale } else { 1.0 })
}

/// The declared noise's sandwich `A (Jᵀ V J) A` and the residuals' scale `ŝ² = ‖r‖² / tr((I −
/// H) V)`; `None` with a singular `JᵀJ` or an expected sum of squares that is not positive.
fn declared_sandwich(
    r: &DVector<f64>,
    jacobian: &DMatrix<f64>,
    loadings: &NoiseLoadings,
) -> Option<(DMatrix<f64>, f64)> {
    let inverse = jacobian.tr_mul(jacobian).try_inverse()?;
    let meat = loadings.meat(jacobian);
    // tr((I − H) V) = tr V − tr(A Jᵀ V J).
    let expected = loadings.variances().iter().sum::<f64>() - (&inverse * &meat).trace();
    if !(expected > 0.0 && expected.is_finite()) {
        return None;
    }
    Some((&inverse * meat * &inverse, r.norm_squared() / expected))
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::{covariance, reported_covariance, NoiseLoadings};

    /// A small Jacobian and residuals.
    fn problem() -> (DVector<f64>, DMatrix<f64>) {
        let jacobian =
            DMatrix::from_row_slice(5, 2, &[1.0, 0.2, 0.5, -1.0, 2.0, 0.3, -0.7, 1.1, 0.4, 0.9]);
        let r = DVector::from_vec(vec![0.3, -0.1, 0.25, 0.05, -0.2]);
        (r, jacobian)
    }

    #[test]
    fn equal_variances_give_the_homoscedastic_covariance() {
        let (r, jacobian) = problem();
        let plain = covariance(&r, &jacobian, None).unwrap();
        let expected =
            (jacobian.transpose() * &jacobian).try_inverse().unwrap() * (r.norm_squared() / 3.0);
        assert!((&plain - &expected).amax() <= 1e-15 * expected.amax());
        // Only reading noise: V = σ_q² I, whatever σ_q.
        let loadings = NoiseLoadings {
            reading: 0.37,
            rows: (0..5).map(|a| (a, vec![0.0, 0.0])).collect(),
            also: Vec::new(),
        };
        let sandwich = covariance(&r, &jacobian, Some(&loadings)).unwrap();
        assert!((&sandwich - &expected).amax() <= 1e-14 * expected.amax());
    }

    #[test]
    fn no_covariance_without_redundancy_matching_loadings_or_a_positive_expected_noise() {
        let (r, jacobian) = problem();
        let loadings = |rows: usize, reading: f64, w: f64| NoiseLoadings {
            reading,
            rows: (0..rows).map(|a| (a, vec![w, -w])).collect(),
            also: Vec::new(),
        };
        // As many rows as unknowns: no residual degree of freedom, with or without loadings.
        let square = jacobian.rows(0, 2).into_owned();
        let r2 = r.rows(0, 2).into_owned();
        assert!(covariance(&r2, &square, None).is_none());
        assert!(covariance(&r2, &square, Some(&loadings(2, 0.1, 0.2))).is_none());
        // One loading too many or too few.
        assert!(covariance(&r, &jacobian, Some(&loadings(6, 0.1, 0.2))).is_none());
        assert!(covariance(&r, &jacobian, Some(&loadings(4, 0.1, 0.2))).is_none());
        // No declared noise at all: the expected sum of squares is zero.
        assert!(covariance(&r, &jacobian, Some(&loadings(5, 0.0, 0.0))).is_none());
        // The same with a noise: a covariance.
        assert!(covariance(&r, &jacobian, Some(&loadings(5, 0.1, 0.2))).is_some());
        assert!(covariance(&r, &jacobian, Some(&loadings(5, 0.0, 0.2))).is_some());
    }

    #[test]
    fn the_sandwich_is_the_dense_formula_with_correlated_rows() {
        let (r, jacobian) = problem();
        // Rows 0 and 1 are one measurement, 2 to 4 another; two target coordinates.
        let w = [[0.5, -0.2], [0.3, 0.4], [1.0, 0.0], [-0.6, 0.8], [0.1, 0.1]];
        let measurement = [0, 0, 3, 3, 3];
        let loadings = NoiseLoadings {
            reading: 0.2,
            rows: (0..5).map(|a| (measurement[a], w[a].to_vec())).collect(),
            also: Vec::new(),
        };
        let mut v = DMatrix::identity(5, 5) * 0.04;
        for a in 0..5 {
            for b in 0..5 {
                if measurement[a] == measurement[b] {
                    v[(a, b)] += w[a][0] * w[b][0] + w[a][1] * w[b][1];
                }
            }
        }
        // The pseudo-inverse by SVD: A Jᵀ, and H = J A Jᵀ.
        let pinv = jacobian.clone().pseudo_inverse(1e-14).unwrap();
        let h = &jacobian * &pinv;
        let scale = r.norm_squared() / ((DMatrix::identity(5, 5) - h) * &v).trace();
        let expected = &pinv * &v * pinv.transpose() * scale;
        let sandwich = covariance(&r, &jacobian, Some(&loadings)).unwrap();
        assert!(
            (&sandwich - &expected).amax() <= 1e-12 * expected.amax(),
            "{sandwich} against {expected}"
        );
        // The diagonal V alone (rows taken as separate measurements) is not the same.
        let separate = NoiseLoadings {
            rows: (0..5).map(|a| (a, w[a].to_vec())).collect(),
            also: Vec::new(),
            ..loadings
        };
        let diagonal = covariance(&r, &jacobian, Some(&separate)).unwrap();
        assert!((&diagonal - &expected).amax() > 0.05 * expected.amax());
    }

    #[test]
    fn loadings_on_other_measurements_are_the_dense_formula_too() {
        let (r, jacobian) = problem();
        // Rows 0, 1 one measurement, 2 and 3 one each, 4 its own (a distance between the
        // measurements of rows 0 and 2: it loads on both, laid out as their rows' loadings).
        let w = [[0.5, -0.2], [0.3, 0.4], [1.0, 0.0], [-0.6, 0.8], [0.1, 0.0]];
        let measurement = [0, 0, 3, 7, 9];
        let also = [(4, 0, [0.0, 0.7]), (4, 3, [0.0, -0.45])];
        let loadings = NoiseLoadings {
            reading: 0.2,
            rows: (0..5).map(|a| (measurement[a], w[a].to_vec())).collect(),
            also: also.iter().map(|(a, m, l)| (*a, *m, l.to_vec())).collect(),
        };
        // V = σ_q² I + W Wᵀ, W over every measurement's two sources.
        let sources = |m: usize| [0, 3, 7, 9].iter().position(|&k| k == m).unwrap() * 2;
        let mut big_w = DMatrix::<f64>::zeros(5, 8);
        for a in 0..5 {
            for k in 0..2 {
                big_w[(a, sources(measurement[a]) + k)] += w[a][k];
            }
        }
        for (a, m, l) in also {
            for k in 0..2 {
                big_w[(a, sources(m) + k)] += l[k];
            }
        }
        let v = DMatrix::identity(5, 5) * 0.04 + &big_w * big_w.transpose();
        let meat = loadings.meat(&jacobian);
        let expected = jacobian.transpose() * &v * &jacobian;
        assert!(
            (&meat - &expected).amax() <= 1e-14 * expected.amax(),
            "{meat} {expected}"
        );
        let variances = loadings.variances();
        for a in 0..5 {
            assert!((variances[a] - v[(a, a)]).abs() <= 1e-15, "{a}");
        }
        // The cross terms matter: without them the meat differs.
        let uncorrelated = NoiseLoadings {
            also: Vec::new(),
            ..loadings.clone()
        };
        assert!((uncorrelated.meat(&jacobian) - &expected).amax() > 0.01 * expected.amax());
        assert!(covariance(&r, &jacobian, Some(&loadings)).is_some());
    }

    #[test]
    fn the_weighted_fits_sandwich_is_the_dense_formula() {
        let (r, jacobian) = problem();
        let w = [[0.5, -0.2], [0.3, 0.4], [1.0, 0.0], [-0.6, 0.8], [0.1, 0.0]];
        let measurement = [0, 0, 3, 7, 9];
        let also = [(4, 0, [0.0, 0.7])];
        let loadings = NoiseLoadings {
            reading: 0.2,
            rows: (0..5).map(|a| (measurement[a], w[a].to_vec())).collect(),
            also: also.iter().map(|(a, m, l)| (*a, *m, l.to_vec())).collect(),
        };
        // V of the plain residuals, dense: σ_q² I plus every pair's shared loadings.
        let all: Vec<(usize, usize, Vec<f64>)> = (0..5)
            .map(|a| (a, measurement[a], w[a].to_vec()))
            .chain(also.iter().map(|(a, m, l)| (*a, *m, l.to_vec())))
            .collect();
        let mut v = DMatrix::identity(5, 5) * 0.04;
        for (a, ma, la) in &all {
            for (b, mb, lb) in &all {
                if ma == mb {
                    v[(*a, *b)] += la.iter().zip(lb).map(|(x, y)| x * y).sum::<f64>();
                }
            }
        }
        // Weights: A_w = (Jᵀ W J)⁻¹, the estimate's covariance A_w Jᵀ W V W J A_w, scaled by
        // ŝ² = ‖√W r‖² / tr((I − H_w) √W V √W).
        let scales = [1.5, 0.7, 2.0, 1.1, 0.4];
        let s = DMatrix::from_diagonal(&DVector::from_row_slice(&scales));
        let (jw, rw) = (&s * &jacobian, &s * &r);
        let a = (jw.transpose() * &jw).try_inverse().unwrap();
        let vw = &s * &v * &s;
        let h = &jw * &a * jw.transpose();
        let scale = rw.norm_squared() / ((DMatrix::identity(5, 5) - h) * &vw).trace();
        let expected = &a * jw.transpose() * &vw * &jw * &a * scale;
        let sandwich = covariance(&rw, &jw, Some(&loadings.scaled(&scales))).unwrap();
        assert!(
            (&sandwich - &expected).amax() <= 1e-12 * expected.amax(),
            "{sandwich} against {expected}"
        );
        // Scaling the loadings matters: the plain ones on the weighted rows differ.
        let plain = covariance(&rw, &jw, Some(&loadings)).unwrap();
        assert!((&plain - &expected).amax() > 0.05 * expected.amax());
        // Unit scales change nothing.
        let unit = covariance(&r, &jacobian, Some(&loadings.scaled(&[1.0; 5]))).unwrap();
        let same = covariance(&r, &jacobian, Some(&loadings)).unwrap();
        assert!((&unit - &same).amax() <= 1e-14 * same.amax());
    }

    #[test]
    fn few_degrees_of_freedom_report_the_declared_noises_covariance() {
        let (r, jacobian) = problem();
        let loadings = NoiseLoadings {
            reading: 0.2,
            rows: (0..5).map(|a| (a, vec![0.1 * a as f64])).collect(),
            also: Vec::new(),
        };
        // 3 degrees of freedom, below SCALE_DOF: unscaled, the scaled one over ŝ².
        let scaled = covariance(&r, &jacobian, Some(&loadings)).unwrap();
        let reported = reported_covariance(&r, &jacobian, Some(&loadings)).unwrap();
        let inverse = jacobian.tr_mul(&jacobian).try_inverse().unwrap();
        let declared = &inverse * loadings.meat(&jacobian) * &inverse;
        assert!((&reported - &declared).amax() <= 1e-14 * declared.amax());
        assert!((&reported - &scaled).amax() > 0.05 * scaled.amax());
        // Zero residuals (an exact fit) keep the declared noise's covariance, not zero.
        let exact = reported_covariance(&(r.clone() * 0.0), &jacobian, Some(&loadings)).unwrap();
        assert!((&exact - &declared).amax() <= 1e-14 * declared.amax());
        // Without a declared noise σ̂ is all there is.
        let plain = reported_covariance(&r, &jacobian, None).unwrap();
        assert_eq!(plain, covariance(&r, &jacobian, None).unwrap());
        // With enough rows (12 degrees of freedom) the report scales by ŝ².
        let tall = DMatrix::from_fn(14, 2, |i, j| ((i * 3 + j * 5) % 7) as f64 - 3.0 + j as f64);
        let rt = DVector::from_fn(14, |i, _| ((i * 11) % 5) as f64 * 0.1 - 0.2);
        let lt = NoiseLoadings {
            reading: 0.2,
            rows: (0..14).map(|a| (a, vec![0.05])).collect(),
            also: Vec::new(),
        };
        let a = reported_covariance(&rt, &tall, Some(&lt)).unwrap();
        let b = covariance(&rt, &tall, Some(&lt)).unwrap();
        assert!((&a - &b).amax() <= 1e-15 * b.amax());
    }
}
