//! When Newton's method on a closure has converged: the stopping rules shared by the legs'
//! inverse kinematics and the mechanism's forward kinematics.

/// A residual within this many tolerances that no longer halves is at its round-off floor.
const STALL_TOLERANCES: f64 = 1e3;

/// Whether Newton's iterate has converged: its closure `residual` is at most `tolerance`, or it
/// has stalled at its round-off floor (below [`STALL_TOLERANCES`] tolerances, and no better than
/// half the `previous` iteration's residual). A closure whose round-off exceeds the tolerance
/// (a mechanism far from the world origin, a chain of long links) then still converges,
/// while a residual still falling fast is given the next step.
pub(crate) fn converged(residual: f64, previous: f64, tolerance: f64) -> bool {
    let stalled = residual < STALL_TOLERANCES * tolerance && residual >= 0.5 * previous;
    residual <= tolerance || stalled
}

/// A step at most this relative length is round-off (four units in the last place).
const ROUND_OFF_STEP: f64 = 4.0 * f64::EPSILON;

/// Whether a (polishing) Newton `step` on the joints `q` moves some joint by more than
/// round-off: more than [`ROUND_OFF_STEP`] times its magnitude, or than [`ROUND_OFF_STEP`]
/// itself for a joint of magnitude below 1 (radians or metres).
pub(crate) fn beyond_round_off(q: &[f64], step: &[f64]) -> bool {
    q.iter()
        .zip(step)
        .any(|(value, delta)| delta.abs() > ROUND_OFF_STEP * value.abs().max(1.0))
}

#[cfg(test)]
mod tests {
    use super::{beyond_round_off, converged};

    #[test]
    fn a_residual_at_or_below_the_tolerance_has_converged_whatever_came_before() {
        let tolerance = 2e-13;
        for previous in [f64::INFINITY, 1.0, 1e-12, 1e-20] {
            assert!(converged(tolerance, previous, tolerance), "{previous}");
            assert!(
                converged(0.5 * tolerance, previous, tolerance),
                "{previous}"
            );
            assert!(converged(0.0, previous, tolerance), "{previous}");
        }
    }

    #[test]
    fn a_residual_below_a_thousand_tolerances_has_converged_once_it_stops_halving() {
        let tolerance = 2e-13;
        let residual = 10.0 * tolerance;
        // Still halving (or the first iteration): another step.
        assert!(!converged(residual, f64::INFINITY, tolerance));
        assert!(!converged(
            residual,
            2.0 * residual * (1.0 + 1e-12),
            tolerance
        ));
        // Exactly half the previous residual, or worse: the round-off floor.
        assert!(converged(residual, 2.0 * residual, tolerance));
        assert!(converged(residual, 1.5 * residual, tolerance));
        assert!(converged(residual, residual, tolerance));
        assert!(converged(residual, 0.5 * residual, tolerance));
        // The same just below the limit of a thousand tolerances …
        let near = 1e3 * tolerance * (1.0 - 1e-12);
        assert!(converged(near, near, tolerance));
        assert!(!converged(near, 2.5 * near, tolerance));
    }

    #[test]
    fn a_residual_of_a_thousand_tolerances_or_more_has_not_converged() {
        let tolerance = 2e-13;
        for residual in [1e3 * tolerance, 1e3 * tolerance * (1.0 + 1e-12), 1e-6, 1.0] {
            assert!(!converged(residual, residual, tolerance), "{residual}");
            assert!(
                !converged(residual, 0.1 * residual, tolerance),
                "{residual}"
            );
        }
    }

    #[test]
    fn a_step_beyond_four_units_in_the_last_place_is_not_round_off() {
        let eps = f64::EPSILON;
        // Joints below 1 in magnitude: an absolute 4ε.
        assert!(!beyond_round_off(&[0.5, -0.25], &[4.0 * eps, -4.0 * eps]));
        assert!(beyond_round_off(&[0.5, -0.25], &[0.0, -4.5 * eps]));
        assert!(beyond_round_off(&[0.0], &[4.5 * eps]));
        // Larger joints: relative to their magnitude.
        assert!(!beyond_round_off(&[1e3], &[-4e3 * eps]));
        assert!(!beyond_round_off(&[-1e3, 2.0], &[3e3 * eps, 8.0 * eps]));
        assert!(beyond_round_off(&[-1e3, 2.0], &[3e3 * eps, 8.5 * eps]));
        assert!(beyond_round_off(&[1e3], &[4.5e3 * eps]));
        // No joints, no step.
        assert!(!beyond_round_off(&[], &[]));
    }
}
