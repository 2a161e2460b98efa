//! Observability of an identification: singular values, numerical rank, condition number,
//! observability indices, and the parameters that cannot be identified.
//!
//! # Reference
//! docs/method.md §5 (indices O1–O5) and §7 (rank with scaled columns, pivoted elimination).

use nalgebra::{DMatrix, SVD};

/// Relative singular-value threshold on the column-scaled Jacobian below which a direction is
/// not identifiable.
pub const RANK_TOLERANCE: f64 = 1e-8;

/// Column-scaled condition number above which an identification is reported as weak: the
/// weakest direction is determined ~10⁴ times worse than the best one.
pub const WEAK_CONDITION: f64 = 1e4;

/// What the singular values of an identification Jacobian say.
#[derive(Debug, Clone, PartialEq)]
pub struct Observability {
    /// Singular values of C in SI units, largest first.
    pub singular_values: Vec<f64>,
    /// Singular values of C with unit-norm columns, largest first.
    pub scaled_singular_values: Vec<f64>,
    /// Numerical rank of the column-scaled C.
    pub rank: usize,
    /// Condition number s_max / s_min of C: a finite number whenever the smallest singular value
    /// is non-zero (a rank-deficient C has a huge one), infinite only when it is zero or the
    /// ratio overflows.
    pub condition: f64,
    /// Observability indices O1..O5 of C (docs/method.md §5; O1 divided by √m).
    pub indices: [f64; 5],
    /// Parameters that cannot be identified (pivoted Gram–Schmidt on the scaled columns).
    pub unidentifiable: Vec<String>,
    /// Null-space directions, e.g. `0.707 l1 - 0.707 L1`.
    pub null_directions: Vec<String>,
    /// Condition number of the column-scaled C (as [`Observability::condition`]).
    pub scaled_condition: f64,
    /// The least observable direction (column-scaled), e.g. `0.71 k1 + 0.70 gamma1`.
    pub weakest_direction: String,
    /// With priors: the directions the data alone cannot see (null-space directions of the
    /// data's rows, column-scaled), which rest on the priors; empty without.
    pub resting_on_prior: Vec<String>,
}

impl Observability {
    /// A warning when the design is full-rank but weak (scaled condition above [`WEAK_CONDITION`]).
    pub fn warning(&self) -> Option<String> {
        (self.scaled_condition > WEAK_CONDITION).then(|| {
            format!(
                "weakly identifiable: column-scaled condition number {:.1e} (> {:.0e}); least observable direction {}",
                self.scaled_condition, WEAK_CONDITION, self.weakest_direction
            )
        })
    }
}

/// Analyses identification Jacobian `c` (rows = measurements) whose columns are `names`.
pub fn analyse(c: &DMatrix<f64>, names: &[String]) -> Observability {
    let (m, n) = c.shape();
    let singular_values = sorted_singular_values(c.clone());
    // One m × n working copy at a time (a large problem's Jacobian is tens of megabytes): the
    // SVD takes the scaled copy, which the rare rank-deficient case builds again.
    let svd = with_a_row_per_column(unit_columns(c)).svd(false, true);
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let scaled_singular_values: Vec<f64> = order.iter().map(|&i| svd.singular_values[i]).collect();
    let largest = scaled_singular_values.first().copied().unwrap_or(0.0);
    let rank = scaled_singular_values
        .iter()
        .filter(|&&s| s > RANK_TOLERANCE * largest)
        .count();
    let mut null_directions = Vec::new();
    let weakest_direction = match (&svd.v_t, order.last()) {
        (Some(v_t), Some(&i)) => direction(v_t.row(i).iter().copied(), names),
        _ => String::new(),
    };
    let scaled_condition = condition_number(&scaled_singular_values, n);
    if let Some(v_t) = &svd.v_t {
        for &i in order.iter().skip(rank) {
            null_directions.push(direction(v_t.row(i).iter().copied(), names));
        }
    }
    let unidentifiable = pivoted_deficient_columns(c, rank)
        .into_iter()
        .map(|j| names[j].clone())
        .collect();
    let condition = condition_number(&singular_values, n);
    Observability {
        indices: indices(&singular_values, m, n),
        singular_values,
        scaled_singular_values,
        rank,
        condition,
        unidentifiable,
        null_directions,
        scaled_condition,
        weakest_direction,
        resting_on_prior: Vec::new(),
    }
}

/// The rank [`analyse`] finds in `c` (its column-scaled singular values above
/// [`RANK_TOLERANCE`] times the largest), from the singular values alone: no right singular
/// vectors, no directions or indices, for a check that needs only the rank. `None` for a
/// matrix with a non-finite entry (then [`analyse`] decides).
pub fn scaled_rank(c: &DMatrix<f64>) -> Option<usize> {
    if c.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let values = with_a_row_per_column(unit_columns(c))
        .svd(false, false)
        .singular_values;
    let largest = values.max();
    Some(
        values
            .iter()
            .filter(|&&s| s > RANK_TOLERANCE * largest)
            .count(),
    )
}

/// `c` with zero rows appended up to one row per column. A thin SVD of fewer rows than
/// columns has a right singular vector per row only: the directions it leaves out (singular
/// value 0, the null space's completion) would be missing from the null directions and the
/// weakest one. Zero rows change no singular value but add those zeros and their vectors.
pub(crate) fn with_a_row_per_column(c: DMatrix<f64>) -> DMatrix<f64> {
    let n = c.ncols();
    match c.nrows().cmp(&n) {
        std::cmp::Ordering::Less => c.resize_vertically(n, 0.0),
        _ => c,
    }
}

/// s_max / s_min over the first `n` singular values (largest first): finite whenever s_min is
/// non-zero, infinite when it is zero (or for `n = 0`).
fn condition_number(singular_values: &[f64], n: usize) -> f64 {
    match (
        singular_values.first(),
        n.checked_sub(1).and_then(|i| singular_values.get(i)),
    ) {
        (Some(&largest), Some(&smallest)) if smallest > 0.0 => largest / smallest,
        _ => f64::INFINITY,
    }
}

/// `c` with every non-zero column scaled to unit norm. Each column is first divided by its
/// largest magnitude, so that the norm neither underflows (entries of 1e-300, whose squares are
/// 0) nor overflows (1e200): the scaling is the same whatever the units of the parameters.
pub fn unit_columns(c: &DMatrix<f64>) -> DMatrix<f64> {
    let mut scaled = c.clone();
    for mut column in scaled.column_iter_mut() {
        let largest = column.amax();
        if largest > 0.0 && largest.is_finite() {
            column /= largest;
            let norm = column.norm();
            column /= norm;
        }
    }
    scaled
}

/// Singular values, largest first (zeros appended when there are fewer rows than columns).
/// Entries far from 1 (1e-300 or 1e200) neither underflow nor overflow: nalgebra's SVD scales
/// the matrix by its largest magnitude itself (the unit test at extreme magnitudes checks it).
/// A matrix with a NaN or infinite entry has no singular values: n NaNs (nalgebra's SVD would
/// iterate on it for ever), which no rank count or index takes for a number.
pub fn sorted_singular_values(c: DMatrix<f64>) -> Vec<f64> {
    let n = c.ncols();
    if c.iter().any(|v| !v.is_finite()) {
        return vec![f64::NAN; n];
    }
    // The matrix itself goes into the decomposition (`singular_values()` would decompose a
    // copy of it).
    let mut values: Vec<f64> = SVD::new(c, false, false)
        .singular_values
        .iter()
        .copied()
        .collect();
    values.sort_by(|a, b| b.total_cmp(a));
    values.resize(n, 0.0);
    values
}

/// O1 = (Π s)^(1/n)/√m, O2 = s_min/s_max, O3 = s_min, O4 = s_min²/s_max, O5 = 1/Σ(1/s).
pub fn indices(singular_values: &[f64], m: usize, n: usize) -> [f64; 5] {
    if n == 0 || singular_values.len() < n {
        return [0.0; 5];
    }
    let (max, min) = (singular_values[0], singular_values[n - 1]);
    if min <= 0.0 {
        return [0.0; 5];
    }
    let log_mean = singular_values[..n].iter().map(|s| s.ln()).sum::<f64>() / n as f64;
    [
        log_mean.exp() / (m as f64).sqrt(),
        min / max,
        min,
        min * min / max,
        1.0 / singular_values[..n].iter().map(|s| 1.0 / s).sum::<f64>(),
    ]
}

/// Greedy column-norm-pivoted Gram–Schmidt on the unit columns of `c`: after `rank` pivots,
/// the remaining columns are (numerically) combinations of the pivoted ones (none at full
/// rank).
fn pivoted_deficient_columns(c: &DMatrix<f64>, rank: usize) -> Vec<usize> {
    let n = c.ncols();
    if rank >= n {
        return Vec::new();
    }
    let mut residual = unit_columns(c);
    let mut remaining: Vec<usize> = (0..n).collect();
    for _ in 0..rank.min(n) {
        let (position, &pivot) = remaining
            .iter()
            .enumerate()
            .max_by(|a, b| {
                residual
                    .column(*a.1)
                    .norm()
                    .total_cmp(&residual.column(*b.1).norm())
            })
            .unwrap_or((0, &0));
        remaining.remove(position);
        let q = residual.column(pivot).normalize();
        for &j in &remaining {
            let projection = q.dot(&residual.column(j));
            let updated = residual.column(j) - &q * projection;
            residual.set_column(j, &updated);
        }
    }
    remaining.sort_unstable();
    remaining
}

fn direction(components: impl Iterator<Item = f64>, names: &[String]) -> String {
    let mut terms: Vec<(f64, &String)> = components
        .zip(names)
        .filter(|(v, _)| v.abs() >= 0.05)
        .collect();
    terms.sort_by(|a, b| b.0.abs().total_cmp(&a.0.abs()));
    // The direction's sign is arbitrary: its largest component is shown positive. (Every
    // shown component is at least 0.05 in magnitude, never zero.)
    let flip = terms.first().is_some_and(|t| t.0.is_sign_negative());
    terms
        .iter()
        .enumerate()
        .map(|(i, (v, name))| {
            let v = if flip { -v } else { *v };
            match (i, v.is_sign_negative()) {
                (0, _) => format!("{v:.3} {name}"),
                (_, true) => format!("- {:.3} {name}", -v),
                (_, false) => format!("+ {v:.3} {name}"),
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("p{i}")).collect()
    }

    #[test]
    fn a_full_rank_matrix_has_no_unidentifiable_parameters() {
        let c = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, 0.0, 2.0, 1.0, 1.0, 3.0, -1.0]);
        let o = analyse(&c, &names(2));
        assert_eq!(o.rank, 2);
        assert!(o.unidentifiable.is_empty());
        assert!(o.null_directions.is_empty());
        // CᵀC = [[11, −2], [−2, 6]]: eigenvalues (17 ± √41)/2, the squared singular values.
        let root = 41f64.sqrt();
        let (large, small) = (((17.0 + root) / 2.0).sqrt(), ((17.0 - root) / 2.0).sqrt());
        assert!((o.singular_values[0] - large).abs() < 1e-12 * large);
        assert!((o.singular_values[1] - small).abs() < 1e-12 * large);
        assert!((o.condition - large / small).abs() < 1e-12 * large / small);
    }

    #[test]
    fn a_duplicated_column_is_named_with_its_null_direction() {
        // p2 = 2·p0: the combination p0·2 − p2... is not observable.
        let c = DMatrix::from_row_slice(
            4,
            3,
            &[1.0, 0.5, 2.0, 2.0, -1.0, 4.0, 0.0, 3.0, 0.0, 1.0, 1.0, 2.0],
        );
        let o = analyse(&c, &names(3));
        assert_eq!(o.rank, 2);
        // Equal unit columns: the pivoting takes the last of equally long ones (p2, as
        // `Iterator::max_by` does), and p0 is left as the combination; the null direction is
        // (1, 0, −1)/√2.
        assert_eq!(o.unidentifiable, vec!["p0".to_string()]);
        assert_eq!(o.null_directions, vec!["0.707 p0 - 0.707 p2"]);
        assert_eq!(o.weakest_direction, o.null_directions[0]);
        assert!(o.condition.is_infinite() && o.scaled_condition.is_infinite());
        assert!(
            o.indices.iter().all(|&v| v.to_bits() == 0),
            "{:?}",
            o.indices
        );
        // C = [a, b, 2a] has the non-zero singular values of [√5 a, b]: with |a|² = 6,
        // |b|² = 45/4 and a·b = −½ its Gram matrix [[30, −√5/2], [−√5/2, 45/4]] has trace
        // 165/4 and determinant 1345/4; the unit columns [u, v, u] those of [√2 u, v]:
        // [[2, √2 k], [√2 k, 1]] with k = a·b/(|a| |b|), eigenvalues (3 ± √(1 + 8k²))/2.
        let (t, d): (f64, f64) = (165.0 / 4.0, 1345.0 / 4.0);
        let root = (t * t - 4.0 * d).sqrt();
        let expected = [((t + root) / 2.0).sqrt(), ((t - root) / 2.0).sqrt(), 0.0];
        for (s, e) in o.singular_values.iter().zip(expected) {
            assert!(
                (s - e).abs() < 1e-12 * expected[0],
                "{:?}",
                o.singular_values
            );
        }
        let k: f64 = -0.5 / (6.0f64 * 45.0 / 4.0).sqrt();
        let root = (1.0 + 8.0 * k * k).sqrt();
        let expected = [((3.0 + root) / 2.0).sqrt(), ((3.0 - root) / 2.0).sqrt()];
        for (s, e) in o.scaled_singular_values.iter().zip(expected) {
            assert!((s - e).abs() < 1e-12, "{:?}", o.scaled_singular_values);
        }
        assert!(o.scaled_singular_values[2].abs() < 1e-12);
    }

    /// C = [[1, 0, ½], [0, 1, ¼]]: p2 = ½ p0 + ¼ p1, so (−½, −¼, 1) spans the null space; with
    /// unit columns (p2's norm is √(5/16)) it is (−½, −¼, √5/4)/√(5/8) = (−0.632, −0.316,
    /// 0.707). A thin SVD of 2 rows has no third direction: the null direction (and the weakest
    /// one, the same) must still be reported, and three scaled singular values, the last 0.
    #[test]
    fn fewer_rows_than_parameters_is_rank_deficient() {
        let c = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.5, 0.0, 1.0, 0.25]);
        let o = analyse(&c, &names(3));
        assert_eq!(o.rank, 2);
        assert_eq!(o.unidentifiable, vec!["p2".to_string()]);
        assert_eq!(o.null_directions, vec!["0.707 p2 - 0.632 p0 - 0.316 p1"]);
        assert_eq!(o.weakest_direction, o.null_directions[0]);
        assert_eq!(o.scaled_singular_values.len(), 3);
        assert_eq!(o.scaled_singular_values[2].to_bits(), 0);
        assert!(o.condition.is_infinite() && o.scaled_condition.is_infinite());
        // The unit columns' Gram matrix [[1, 0, c0], [0, 1, c1], [c0, c1, 1]] with c0 = 2/√5 and
        // c1 = 1/√5 has eigenvalues 1 and 1 ± √(c0² + c1²) = 1 ± 1: 2, 1, 0.
        let expected = [2f64.sqrt(), 1.0];
        for (s, e) in o.scaled_singular_values.iter().zip(expected) {
            assert!((s - e).abs() < 1e-12, "{:?}", o.scaled_singular_values);
        }
        // Unscaled: CᵀC has eigenvalues 0 and those of CCᵀ = [[5/4, 1/8], [1/8, 17/16]].
        let (t, d): (f64, f64) = (
            5.0 / 4.0 + 17.0 / 16.0,
            5.0 / 4.0 * 17.0 / 16.0 - 1.0 / 64.0,
        );
        let root = (t * t - 4.0 * d).sqrt();
        let expected = [((t + root) / 2.0).sqrt(), ((t - root) / 2.0).sqrt(), 0.0];
        for (s, e) in o.singular_values.iter().zip(expected) {
            assert!((s - e).abs() < 1e-12, "{:?}", o.singular_values);
        }
    }

    #[test]
    fn indices_follow_their_definitions() {
        let s = [4.0, 2.0, 1.0];
        let [o1, o2, o3, o4, o5] = indices(&s, 9, 3);
        assert!((o1 - 2.0 / 3.0).abs() < 1e-12); // (4·2·1)^(1/3) / √9
        assert!((o2 - 0.25).abs() < 1e-12);
        assert!((o3 - 1.0).abs() < 1e-12);
        assert!((o4 - 0.25).abs() < 1e-12);
        assert!((o5 - 1.0 / 1.75).abs() < 1e-12);
    }

    /// [[1, 1], [0, ε]]: s₁ s₂ = |det| = ε and s₁² + s₂² = 2 + ε², so s₁ ≈ √2, s₂ ≈ ε/√2 and
    /// the condition number is ≈ 2/ε: rank-deficient at the scaled tolerance, yet a finite,
    /// printed condition (it was "infinite" beside two non-zero singular values).
    #[test]
    fn a_numerically_rank_deficient_matrix_has_a_finite_condition_number() {
        let epsilon = 1e-10;
        let c = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 0.0, epsilon]);
        let o = analyse(&c, &names(2));
        assert_eq!(o.rank, 1);
        assert!(o.singular_values[1] > 0.0);
        assert!(
            (o.condition / (2.0 / epsilon) - 1.0).abs() < 1e-6,
            "{}",
            o.condition
        );
        // The columns (1, 0) and (1, ε)/|(1, ε)| (= (1, ε) in f64): the same ratio 2/ε.
        assert!(
            (o.scaled_condition / (2.0 / epsilon) - 1.0).abs() < 1e-6,
            "{}",
            o.scaled_condition
        );
    }

    #[test]
    fn only_a_zero_smallest_singular_value_gives_an_infinite_condition_number() {
        let c = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 2.0, 0.0]);
        assert!(analyse(&c, &names(2)).condition.is_infinite());
    }

    /// Columns of size 1e-300 (a gain of 1e300) and 1e200: squaring them under- or overflows.
    /// The analysis must not depend on the columns' scale: the rank, the unidentifiable
    /// parameter (the zero column p2) and the null direction are those of the unit matrix
    /// [e₁ e₂ 0].
    #[test]
    fn the_column_scaling_is_robust_to_extreme_magnitudes() {
        for scale in [1e-300, 1e200] {
            let c = DMatrix::from_row_slice(
                3,
                3,
                &[scale, 0.0, 0.0, 0.0, 2.0 * scale, 0.0, 0.0, 0.0, 0.0],
            );
            let o = analyse(&c, &names(3));
            assert_eq!(o.rank, 2, "scale {scale}");
            assert_eq!(o.unidentifiable, vec!["p2".to_string()], "scale {scale}");
            assert_eq!(
                o.null_directions,
                vec!["1.000 p2".to_string()],
                "scale {scale}"
            );
            // Singular values 2·scale and scale (the matrix is diagonal), largest first.
            assert!((o.singular_values[0] / (2.0 * scale) - 1.0).abs() < 1e-12);
            assert!((o.singular_values[1] / scale - 1.0).abs() < 1e-12);
        }
    }

    /// Q·diag(3, 2, 1) with Q the rotation by (3/5, 4/5) about z: a full 3 × 3 block whose
    /// singular values are exactly 3, 2 and 1. Scaled by 1e-300 or 1e200 the decomposition
    /// itself would under- or overflow (its Householder norms square the entries); the values
    /// must still be 3, 2 and 1 times the scale.
    #[test]
    fn singular_values_of_a_full_matrix_survive_extreme_magnitudes() {
        let a = [1.8, -1.6, 0.0, 2.4, 1.2, 0.0, 0.0, 0.0, 1.0];
        for scale in [1e-300, 1e200, 1.0] {
            let c = DMatrix::from_row_slice(3, 3, &a.map(|v| v * scale));
            let values = sorted_singular_values(c);
            for (value, expected) in values.iter().zip([3.0, 2.0, 1.0]) {
                assert!(
                    (value / (expected * scale) - 1.0).abs() < 1e-12,
                    "scale {scale}: {values:?}"
                );
            }
        }
    }

    #[test]
    fn a_matrix_with_a_non_finite_entry_has_no_singular_values() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut c = DMatrix::from_row_slice(4, 3, &[1.0; 12]);
            c[(2, 1)] = bad;
            let values = sorted_singular_values(c);
            assert_eq!(values.len(), 3);
            assert!(values.iter().all(|v| v.is_nan()), "{bad}: {values:?}");
        }
        // A finite matrix still gets its own.
        let c = DMatrix::from_row_slice(2, 2, &[3.0, 0.0, 0.0, 2.0]);
        assert_eq!(sorted_singular_values(c), vec![3.0, 2.0]);
    }
}
