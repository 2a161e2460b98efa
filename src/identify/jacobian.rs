//! The identification Jacobian of a leg, by dual numbers through the implicit function theorem.
//!
//! For each identified parameter, one forward pass in `Dual64` seeded on that parameter through
//! [`reading_at_solution`] (one Newton step from the f64 solution) gives the exact derivative
//! `∂ψ/∂φ_j`. The Newton iterations themselves are never differentiated.

use num_dual::Dual64;

use crate::error::KinematicsError;
use crate::kinematics::inverse::{reading_at_solution, solve_leg};
use crate::model::leg::LegModel;

/// Predicted reading and its gradient with respect to the parameters listed in `columns`
/// (indices into the leg's parameter vector), at full parameter vector `phi` and pose `pose`.
///
/// # Errors
/// The leg cannot reach the pose on its home branch.
pub fn reading_gradient(
    leg: &LegModel,
    phi: &[f64],
    columns: &[usize],
    pose: &[f64; 6],
    home_pose: &[f64; 6],
) -> Result<(f64, Vec<f64>), KinematicsError> {
    let solution = solve_leg(leg, &leg.geometry(phi), pose, home_pose)?;
    let pose_dual = pose.map(Dual64::from);
    let mut phi_dual: Vec<Dual64> = phi.iter().map(|&v| Dual64::from(v)).collect();
    let mut gradient = Vec::with_capacity(columns.len());
    let mut value = f64::NAN;
    for &column in columns {
        phi_dual[column].eps = 1.0;
        let reading = reading_at_solution(leg, &leg.geometry(&phi_dual), &pose_dual, &solution);
        phi_dual[column].eps = 0.0;
        value = reading.re;
        gradient.push(reading.eps);
    }
    if columns.is_empty() {
        value = reading_at_solution(leg, &leg.geometry(phi), pose, &solution);
    }
    Ok((value, gradient))
}
