//! The floor of one 5R leg's fit, for `identify_leg/5r/floor_*`: the same leg written by hand
//! in closed form (the law of cosines, as `benches/scipy_leg.py` writes it for scipy) with an
//! analytic Jacobian, solved (a) by legwise's own solver entry point ([`solve`]: the argmin
//! Levenberg–Marquardt and its refinement) and (b) by a fixed-size, allocation-free
//! Levenberg–Marquardt on the normal equations (Nielsen's damping update). (a) is what the
//! solver costs with an evaluation that is free of the model's generality; (b) what a leg fit
//! costs with nothing but the arithmetic. Measuring equipment, not the product: legwise never
//! writes a mechanism by hand.
use argmin::core::{Error, Jacobian, Operator};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};

/// One row: the measured tip `(x, y)` and the leg's reading.
pub(crate) type Row = (f64, f64, f64);

/// The leg's rows; the parameters are `[l, L, Ax, Ay, k, γ]`.
#[derive(Debug, Clone)]
pub(crate) struct ClosedFormLeg {
    pub(crate) rows: Vec<Row>,
}

/// The nominal parameters of models/5r.yaml's first leg (the solves' start).
pub(crate) const NOMINAL: [f64; 6] = [0.75, 1.10, -0.5, 0.0, 1.0, 0.0];

/// Row `(x, y, ψ)`'s residual (predicted minus measured reading) and its gradient: the
/// actuated angle θ = atan2(P − A) + acos((l² + r² − L²) / (2 l r)), r = |P − A| (elbow out),
/// the reading (θ − γ) / k.
#[inline]
pub(crate) fn residual_and_gradient(phi: &[f64], (x, y, psi): Row) -> (f64, [f64; 6]) {
    let (l, big_l, ax, ay, k, gamma) = (phi[0], phi[1], phi[2], phi[3], phi[4], phi[5]);
    let (dx, dy) = (x - ax, y - ay);
    let r2 = dx * dx + dy * dy;
    let r = r2.sqrt();
    let c = (l * l + r2 - big_l * big_l) / (2.0 * l * r);
    let theta = dy.atan2(dx) + c.acos();
    let d_acos = -1.0 / (1.0 - c * c).sqrt();
    let dc_dl = (l * l - r2 + big_l * big_l) / (2.0 * l * l * r);
    let dc_dbig_l = -big_l / (l * r);
    let dc_dr = (r2 - l * l + big_l * big_l) / (2.0 * l * r2);
    let inverse = 1.0 / k;
    let gradient = [
        d_acos * dc_dl * inverse,
        d_acos * dc_dbig_l * inverse,
        (dy / r2 - d_acos * dc_dr * dx / r) * inverse,
        (-dx / r2 - d_acos * dc_dr * dy / r) * inverse,
        -(theta - gamma) * inverse * inverse,
        -inverse,
    ];
    ((theta - gamma) * inverse - psi, gradient)
}

impl Operator for ClosedFormLeg {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, phi: &DVector<f64>) -> Result<DVector<f64>, Error> {
        let rows = self.rows.iter();
        let residual = |&row: &Row| residual_and_gradient(phi.as_slice(), row).0;
        Ok(DVector::from_iterator(self.rows.len(), rows.map(residual)))
    }
}

impl Jacobian for ClosedFormLeg {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, phi: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        let mut jacobian = DMatrix::zeros(self.rows.len(), 6);
        for (i, &row) in self.rows.iter().enumerate() {
            let (_, gradient) = residual_and_gradient(phi.as_slice(), row);
            for (k, g) in gradient.into_iter().enumerate() {
                jacobian[(i, k)] = g;
            }
        }
        Ok(jacobian)
    }
}

type M6 = SMatrix<f64, 6, 6>;
type V6 = SVector<f64, 6>;

/// `JᵀJ`, `Jᵀr` and `rᵀr` at `phi`.
fn normal_equations(rows: &[Row], phi: &V6) -> (M6, V6, f64) {
    let (mut normal, mut gradient, mut cost) = (M6::zeros(), V6::zeros(), 0.0);
    for &row in rows {
        let (residual, derivatives) = residual_and_gradient(phi.as_slice(), row);
        let derivatives = V6::from(derivatives);
        normal += derivatives * derivatives.transpose();
        gradient += derivatives * residual;
        cost += residual * residual;
    }
    (normal, gradient, cost)
}

/// Fixed-size Levenberg–Marquardt from `start`: damping `μ = 1e-6 · max diag(JᵀJ)` at first,
/// Nielsen's update; stops when an accepted step lowers the cost by at most 1e-12 of it, the
/// step is at most 1e-12 of the parameters, or after 100 iterations. Returns the estimate.
pub(crate) fn fixed_size_lm(rows: &[Row], start: [f64; 6]) -> [f64; 6] {
    let mut phi = V6::from(start);
    let (mut normal, mut gradient, mut cost) = normal_equations(rows, &phi);
    let mut damping = 1e-6 * (0..6).map(|i| normal[(i, i)]).fold(0.0, f64::max);
    let mut growth = 2.0;
    for _ in 0..100 {
        let mut damped = normal;
        for i in 0..6 {
            damped[(i, i)] += damping;
        }
        let Some(cholesky) = damped.cholesky() else {
            break;
        };
        let step = -cholesky.solve(&gradient);
        if step.norm() <= 1e-12 * phi.norm() {
            break;
        }
        let trial = phi + step;
        let trial_cost: f64 = rows
            .iter()
            .map(|&row| residual_and_gradient(trial.as_slice(), row).0.powi(2))
            .sum();
        let predicted = -(2.0 * step.dot(&gradient) + (step.transpose() * normal * step)[0]);
        let gain = (cost - trial_cost) / predicted;
        if gain > 0.0 {
            let converged = cost - trial_cost <= 1e-12 * cost;
            phi = trial;
            (normal, gradient, cost) = normal_equations(rows, &phi);
            damping *= (1.0f64 / 3.0).max(1.0 - (2.0 * gain - 1.0).powi(3));
            growth = 2.0;
            if converged {
                break;
            }
        } else {
            damping *= growth;
            growth *= 2.0;
        }
    }
    phi.into()
}
