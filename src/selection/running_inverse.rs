//! M⁻¹ of the current design, kept up to date by the D engines' rank-one or block updates.

use nalgebra::DMatrix;

use super::linalg::spd_inverse;
use super::pool::Pool;

/// A design point entering or leaving the design: the sign of its term in M = Σ C_jᵀC_j.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Change {
    /// The point joins the design (+C_jᵀC_j).
    Add,
    /// The point leaves the design (−C_jᵀC_j).
    Remove,
}

impl Change {
    /// `value` with the change's sign (kept for an addition, flipped for a removal).
    pub(super) fn signed(self, value: f64) -> f64 {
        match self {
            Change::Add => value,
            Change::Remove => -value,
        }
    }
}

/// M⁻¹ of the current design: the ridge alone at the start of the greedy construction, then
/// updated by each engine's Sherman–Morrison or Woodbury formulas.
pub(super) struct RunningInverse {
    /// M⁻¹ of the current design (with the ridge during the greedy phase).
    pub(super) minv: DMatrix<f64>,
    /// Whether M⁻¹ was recomputed once the greedy design reached n rows.
    refreshed: bool,
}

impl RunningInverse {
    /// diag(1/ridge), the inverse of the ridge start M = ε·diag(Σ c∘c)/K.
    pub(super) fn ridge_start(pool: &Pool) -> Self {
        Self {
            minv: pool.ridge_inverse(),
            refreshed: false,
        }
    }

    /// Once, when the greedy `design` first reaches n rows: recomputes M⁻¹ (with the ridge)
    /// from scratch, since the ridge's large entries have cancelled in the updates. Returns
    /// whether M⁻¹ was replaced.
    pub(super) fn refresh(&mut self, pool: &Pool, design: &[usize]) -> bool {
        if self.refreshed || design.len() * pool.b < pool.n {
            return false;
        }
        self.refreshed = true;
        match spd_inverse(&pool.gram(design, true)) {
            Some(minv) => {
                self.minv = minv;
                true
            }
            None => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::RunningInverse;
    use crate::selection::pool::Pool;
    use crate::selection::SelectionOptions;

    /// M⁻¹ is recomputed once, when the greedy design first has n rows (three candidates of
    /// two rows for n = 6), and never again.
    #[test]
    fn the_inverse_is_refreshed_once_when_the_design_first_has_n_rows() {
        let candidates: Vec<DMatrix<f64>> = (0..8)
            .map(|j| DMatrix::from_fn(2, 6, |r, c| ((j * 7 + r * 3 + c * 5) % 11) as f64 - 5.0))
            .collect();
        let options = SelectionOptions {
            count: 4,
            ..Default::default()
        };
        let pool = Pool::new(&candidates, &options).unwrap();
        let mut inverse = RunningInverse::ridge_start(&pool);
        assert!(!inverse.refresh(&pool, &[0, 1]), "4 rows of 6");
        assert!(inverse.refresh(&pool, &[0, 1, 2]), "6 rows: refreshed");
        assert!(!inverse.refresh(&pool, &[0, 1, 2]), "once only");
        assert!(!inverse.refresh(&pool, &[0, 1, 2, 3]));
        let mut late = RunningInverse::ridge_start(&pool);
        assert!(
            late.refresh(&pool, &[0, 1, 2, 3]),
            "8 rows, first call: refreshed"
        );
    }
}
