//! A prepared leg's derivatives at a pose its closed-form kernel reaches, from the kernel's
//! actuated row and f64 partials alone: what a forward row's derivatives need from a leg
//! (`∂ψ/∂φ` and `∂ψ/∂X`, `X` the attachment point's world position), without solving its
//! passive joints again.

use nalgebra::{Matrix3, Vector3};

use super::PreparedLeg;
use crate::kinematics::chain::{attachment_on, Transform};
use crate::kinematics::inverse::{joints, Joints, Solution};

impl PreparedLeg<'_> {
    /// At the platform transform `platform` of a pose the leg's kernel reaches: writes the
    /// reading's derivatives with respect to the prepared columns into `gradient` (as
    /// [`Self::reading_and_gradient_on`] does) and returns the actuated row of the closure
    /// Jacobian's inverse, `∂q_a/∂X` (zero beyond the leg's closure dimensions; `∂ψ/∂X` is it
    /// over the gain). `seed`: joints on whose turn a revolute kernel reads its actuated joint
    /// (the home joints without one); the derivatives do not depend on the turn. `known`: the
    /// kernel's actuated joint and row at this very target, if evaluated already (by the
    /// forward solve that closed the pose): not evaluated again.
    ///
    /// `None` for a leg without a kernel, where the kernel leaves the pose to the generic
    /// solve, or where a pass's closed form fails: then solve the leg
    /// ([`Self::solve_warm_on`]) and take the derivatives from its solution.
    pub fn actuated_gradients(
        &self,
        platform: &Transform<f64>,
        (seed, known): (Option<&Joints>, Option<(f64, [f64; 3])>),
        gradient: &mut [f64],
    ) -> Option<[f64; 3]> {
        let kernel = self.kernel.as_ref()?;
        let (_, row) = match known {
            Some(known) => known,
            None => kernel.actuated_row(&attachment_on(platform, &self.geometry.attachment))?,
        };
        let dims = self.leg.closure_dims.min(3);
        let row: [f64; 3] = std::array::from_fn(|k| if k < dims { row[k] } else { 0.0 });
        let mut closure_inverse = Matrix3::zeros();
        for (k, &value) in row.iter().enumerate() {
            closure_inverse[(self.leg.actuated.min(2), k)] = value;
        }
        // What the passes read of a solution: its joints' turn (a dyad's), never the passive
        // joints' values nor the closure.
        let solution = Solution {
            q: seed
                .copied()
                .unwrap_or_else(|| joints(&self.leg.home_joints)),
            closure: Vector3::zeros(),
            closure_inverse,
            normalised_determinant: f64::NAN,
        };
        for pass in &self.passes {
            pass.closed_form(platform, &solution, gradient)?;
        }
        Some(row)
    }
}

#[cfg(test)]
mod tests {
    use crate::identify::jacobian::PreparedLeg;
    use crate::kinematics::chain::platform_transform;
    use crate::model::Mechanism;

    /// At poses of every bundled model whose legs have kernels, the derivatives from the
    /// actuated row equal the solved leg's (its reading's gradient, and the closure inverse's
    /// actuated row) to 1e-12, relative.
    #[test]
    fn the_actuated_gradients_equal_the_solved_legs() {
        let mut checked = 0;
        for model in ["delta-probe", "hexapod-reflector", "5r", "3rpr", "delta"] {
            let path = format!("{}/models/{model}.yaml", env!("CARGO_MANIFEST_DIR"));
            let mechanism = Mechanism::load(std::path::Path::new(&path)).unwrap();
            let home = mechanism.home_pose;
            for (l, leg) in mechanism.legs.iter().enumerate() {
                let phi = leg.nominal();
                let columns: Vec<usize> = (0..phi.len()).collect();
                let prepared = PreparedLeg::new(leg, &phi, &columns);
                if !prepared.closed_form() {
                    continue;
                }
                for step in 0..3 {
                    let mut pose = home;
                    for (c, value) in pose.iter_mut().enumerate() {
                        let size = if c < 3 { 0.01 } else { 0.02 };
                        *value += size * ((step * 7 + c * 3 + l) as f64).sin();
                    }
                    let platform = platform_transform(&pose);
                    let Ok(solution) = prepared.solve_warm_on(&platform, &pose, &home, None) else {
                        continue;
                    };
                    let mut solved = vec![0.0; columns.len()];
                    prepared.reading_and_gradient_on(&platform, &solution, &mut solved);
                    let mut closed = vec![0.0; columns.len()];
                    let row = prepared
                        .actuated_gradients(&platform, (Some(&solution.q), None), &mut closed)
                        .expect("the kernel reaches the pose");
                    let scale = solved.iter().fold(1e-3f64, |m, v| m.max(v.abs()));
                    for (a, b) in solved.iter().zip(&closed) {
                        assert!((a - b).abs() <= 1e-12 * scale, "{model} leg {l}: {a} {b}");
                    }
                    let inverse = solution.closure_inverse.row(leg.actuated);
                    let scale = inverse.amax().max(1e-3);
                    for k in 0..leg.closure_dims {
                        let (a, b) = (inverse[k], row[k]);
                        assert!((a - b).abs() <= 1e-12 * scale, "{model} leg {l}: {a} {b}");
                    }
                    checked += 1;
                }
            }
        }
        assert!(checked >= 20, "{checked} legs checked");
    }
}
