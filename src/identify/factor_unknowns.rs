//! A factor set's change of unknowns (src/identify/factor_set.rs): the problem's unknowns `x`
//! as a function `x = g(θ)` of the set's factors `θ` (a factor itself, or a derived parameter's
//! expression of the quantities), its derivative by dual numbers, and the problem seen in the
//! factors with the factors' priors as rows after the data's.

use nalgebra::{DMatrix, DVector};
use num_dual::Dual64;

use super::problem::IdentificationProblem;

/// Where a problem unknown comes from.
#[derive(Debug, Clone)]
pub(super) enum Source {
    /// The `k`-th factor itself.
    Factor(usize),
    /// A derived parameter: its expression over the quantities (`values`: every quantity's
    /// value, the set's ones replaced by their factor).
    Derived(crate::model::expression::Expression),
}

/// The change of unknowns `x = g(θ)`.
#[derive(Debug, Clone)]
pub(super) struct Unknowns {
    /// Per problem unknown.
    pub(super) sources: Vec<Source>,
    /// Every quantity's nominal value.
    pub(super) quantities: Vec<f64>,
    /// For each quantity, the factor it is (if in the set).
    pub(super) factor_of_quantity: Vec<Option<usize>>,
}

impl Unknowns {
    /// `g(θ)`.
    pub(super) fn x(&self, theta: &DVector<f64>) -> DVector<f64> {
        let values = self.quantity_values(theta.as_slice(), |v| v);
        DVector::from_iterator(
            self.sources.len(),
            self.sources.iter().map(|s| match s {
                Source::Factor(k) => theta[*k],
                Source::Derived(e) => e.eval(&values),
            }),
        )
    }

    /// `g(θ)`, refused where an expression leaves its domain (`sqrt` of a negative, …): a
    /// solver's trial step there is a failed step, not NaN residuals.
    pub(super) fn finite_x(
        &self,
        theta: &DVector<f64>,
    ) -> std::result::Result<DVector<f64>, argmin::core::Error> {
        let x = self.x(theta);
        match x.iter().all(|v| v.is_finite()) {
            true => Ok(x),
            false => Err(argmin::core::ArgminError::InvalidParameter {
                text: format!(
                    "the factors {:?} put a derived parameter outside its expression's domain",
                    theta.as_slice()
                ),
            }
            .into()),
        }
    }

    /// `∂g/∂θ`, one dual pass per factor.
    pub(super) fn jacobian(&self, theta: &DVector<f64>) -> DMatrix<f64> {
        let mut g = DMatrix::zeros(self.sources.len(), theta.len());
        for k in 0..theta.len() {
            let seeded: Vec<Dual64> = (0..theta.len())
                .map(|j| match j == k {
                    true => Dual64::from_re(theta[j]).derivative(),
                    false => Dual64::from_re(theta[j]),
                })
                .collect();
            let values = self.quantity_values(&seeded, Dual64::from_re);
            for (i, source) in self.sources.iter().enumerate() {
                g[(i, k)] = match source {
                    Source::Factor(j) => f64::from(*j == k),
                    Source::Derived(e) => e.eval(&values).eps,
                };
            }
        }
        g
    }

    /// Every quantity's value: the factor's where the set fits it, else nominal (`lift`ed).
    fn quantity_values<T: Copy>(&self, theta: &[T], lift: impl Fn(f64) -> T) -> Vec<T> {
        self.quantities
            .iter()
            .zip(&self.factor_of_quantity)
            .map(|(&nominal, factor)| factor.map_or_else(|| lift(nominal), |k| theta[k]))
            .collect()
    }
}

/// A factor's prior: factor `k` is `mean ± sigma` before any measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct FactorPrior {
    pub(super) factor: usize,
    pub(super) mean: f64,
    pub(super) sigma: f64,
}

/// The set's problem seen in its factors: residuals `r(g(θ))`, Jacobian `∂r/∂x · ∂g/∂θ`, then
/// a row `(θ_k − μ_k)/σ_k` per prior (the data's rows weighted by the declared noise: the fit
/// is the maximum a posteriori one).
#[derive(Debug, Clone)]
pub(super) struct InFactors<'p, 'm> {
    pub(super) problem: &'p IdentificationProblem<'m>,
    pub(super) unknowns: &'p Unknowns,
    pub(super) priors: &'p [FactorPrior],
}

impl InFactors<'_, '_> {
    /// `r` (the data's rows) with the priors' rows at `theta` after them.
    fn with_prior_rows(&self, r: DVector<f64>, theta: &DVector<f64>) -> DVector<f64> {
        let m = r.len();
        let mut all = r.resize_vertically(m + self.priors.len(), 0.0);
        for (k, p) in self.priors.iter().enumerate() {
            all[m + k] = (theta[p.factor] - p.mean) / p.sigma;
        }
        all
    }

    /// `c` (the data's Jacobian in the factors) with the priors' rows after them.
    pub(super) fn with_prior_jacobian(&self, c: DMatrix<f64>) -> DMatrix<f64> {
        let m = c.nrows();
        let mut all = c.resize_vertically(m + self.priors.len(), 0.0);
        for (k, p) in self.priors.iter().enumerate() {
            all[(m + k, p.factor)] = 1.0 / p.sigma;
        }
        all
    }
}

impl argmin::core::Operator for InFactors<'_, '_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;

    fn apply(&self, theta: &Self::Param) -> std::result::Result<Self::Output, argmin::core::Error> {
        let r = self.problem.residuals(&self.unknowns.finite_x(theta)?)?;
        Ok(self.with_prior_rows(r, theta))
    }
}

impl argmin::core::Jacobian for InFactors<'_, '_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;

    fn jacobian(
        &self,
        theta: &Self::Param,
    ) -> std::result::Result<Self::Jacobian, argmin::core::Error> {
        let (_, c) = self
            .problem
            .residuals_and_jacobian(&self.unknowns.finite_x(theta)?)?;
        Ok(self.with_prior_jacobian(c * self.unknowns.jacobian(theta)))
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DVector;

    use super::{Source, Unknowns};
    use crate::model::expression::Expression;

    /// `∂g/∂θ` from the expressions' dual numbers against central differences of `g`: a
    /// factor is its own column, a derived unknown follows every factor its expression uses,
    /// and a quantity outside the set stays at its nominal value.
    #[test]
    fn the_change_of_unknowns_derivative_is_its_central_difference() {
        let names = ["radius", "angle", "rod", "held"];
        let expression = |t: &str| Source::Derived(Expression::parse(t, &names).unwrap());
        let unknowns = Unknowns {
            sources: vec![
                expression("radius * cos(angle)"),
                Source::Factor(1),
                expression("held + sqrt(rod^2 - radius^2)"),
                expression("held * 2"),
            ],
            quantities: vec![0.175, 3.66, 0.3, 0.25],
            factor_of_quantity: vec![Some(0), Some(2), Some(1), None],
        };
        let theta = DVector::from_vec(vec![0.17, 0.31, 3.7]);
        let x = unknowns.x(&theta);
        assert!((x[0] - 0.17 * 3.7f64.cos()).abs() < 1e-15);
        assert!((x[1] - 0.31).abs() < 1e-15);
        assert!((x[2] - (0.25 + (0.31f64.powi(2) - 0.17f64.powi(2)).sqrt())).abs() < 1e-15);
        assert!((x[3] - 0.5).abs() < 1e-15);
        let g = unknowns.jacobian(&theta);
        let h = 1e-6;
        for k in 0..3 {
            let (mut up, mut down) = (theta.clone(), theta.clone());
            up[k] += h;
            down[k] -= h;
            let fd = (unknowns.x(&up) - unknowns.x(&down)) / (2.0 * h);
            for i in 0..4 {
                assert!(
                    (g[(i, k)] - fd[i]).abs() < 1e-8,
                    "({i}, {k}): {} vs {}",
                    g[(i, k)],
                    fd[i]
                );
            }
        }
        assert!(g[(3, 0)].abs() < 1e-15 && (g[(1, 1)] - 1.0).abs() < 1e-15);
        // A rod shorter than the radius: sqrt of a negative, refused rather than NaN.
        assert!(unknowns.finite_x(&theta).is_ok());
        let short = DVector::from_vec(vec![0.17, 0.1, 3.7]);
        let error = unknowns.finite_x(&short).unwrap_err().to_string();
        assert!(error.contains("outside its expression's domain"), "{error}");
    }
}
