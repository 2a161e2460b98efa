//! The small square solves of the kernels' forward Newton: `a x = b` over the leading `m`
//! rows and columns of fixed 6 × 6 storage (`m` the mechanism's measured pose coordinates),
//! with the determinant of the block with its columns scaled to unit norm (how near singular
//! the pose is). Each size is its own monomorphised loop nest, so that the elimination of a
//! three-leg mechanism runs over 3 × 3 storage, not over bounds read at every step; the
//! arithmetic, and so every bit of the result, is the same at every size.

/// The solution `x` of `a x = b` over the first `m` rows and columns (Gaussian elimination with
/// partial pivoting; Cramer's rule for two) and the determinant of `a`'s block with its columns
/// scaled to unit norm; `None` if the block is singular, `m` is above 6 or the solution is not
/// finite (an empty block, `m = 0`, solves to zeros with determinant 1).
pub(crate) fn solve_small(a: [[f64; 6]; 6], b: [f64; 6], m: usize) -> Option<([f64; 6], f64)> {
    match m {
        0 => solve_fixed::<0>(&a, &b),
        1 => solve_fixed::<1>(&a, &b),
        2 => solve_two(&a, &b),
        3 => solve_fixed::<3>(&a, &b),
        4 => solve_fixed::<4>(&a, &b),
        5 => solve_fixed::<5>(&a, &b),
        6 => solve_fixed::<6>(&a, &b),
        _ => None,
    }
}

/// [`solve_small`] of `M` rows and columns by elimination with partial pivoting.
fn solve_fixed<const M: usize>(a: &[[f64; 6]; 6], b: &[f64; 6]) -> Option<([f64; 6], f64)> {
    let mut a: [[f64; M]; M] = std::array::from_fn(|i| std::array::from_fn(|j| a[i][j]));
    let mut b: [f64; M] = std::array::from_fn(|i| b[i]);
    let scales: f64 = (0..M)
        .map(|k| {
            let norm = a.iter().map(|row| row[k] * row[k]).sum::<f64>().sqrt();
            norm.max(f64::MIN_POSITIVE)
        })
        .product();
    let mut determinant = 1.0;
    for k in 0..M {
        let pivot = (k..M).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if a[pivot][k] == 0.0 {
            return None;
        }
        if pivot != k {
            a.swap(pivot, k);
            b.swap(pivot, k);
            determinant = -determinant;
        }
        determinant *= a[k][k];
        let pivot_row = a[k];
        for i in k + 1..M {
            let factor = a[i][k] / pivot_row[k];
            for (value, &above) in a[i][k..].iter_mut().zip(&pivot_row[k..]) {
                *value -= factor * above;
            }
            b[i] -= factor * b[k];
        }
    }
    let mut x = [0.0; 6];
    for k in (0..M).rev() {
        let sum: f64 = (k + 1..M).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - sum) / a[k][k];
    }
    x.iter()
        .all(|v| v.is_finite())
        .then_some((x, determinant / scales))
}

/// [`solve_small`] of two rows and columns, by Cramer's rule (the pose of a planar two-leg
/// mechanism: a block near enough to singular for Cramer's rule to lose accuracy is left to the
/// stacked solve anyway).
fn solve_two(a: &[[f64; 6]; 6], b: &[f64; 6]) -> Option<([f64; 6], f64)> {
    let ([a00, a01], [a10, a11]) = ([a[0][0], a[0][1]], [a[1][0], a[1][1]]);
    let determinant = a00 * a11 - a01 * a10;
    if determinant == 0.0 {
        return None;
    }
    let mut x = [0.0; 6];
    x[0] = (b[0] * a11 - a01 * b[1]) / determinant;
    x[1] = (a00 * b[1] - a10 * b[0]) / determinant;
    let norm = |p: f64, q: f64| (p * p + q * q).sqrt().max(f64::MIN_POSITIVE);
    let scales = norm(a00, a10) * norm(a01, a11);
    x.iter()
        .all(|v| v.is_finite())
        .then_some((x, determinant / scales))
}
