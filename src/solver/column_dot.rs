//! The dot product of two slices summed exactly as nalgebra sums that of two dynamic column
//! vectors, so that the factorisations and products written on slices (no view built per
//! product, no bounds check per entry) give the same bits as their first versions on
//! nalgebra's views; and the products `AᵀB`, `AᵀA` and `Aᵀr` of column-major matrices built
//! from it as nalgebra's `tr_mul`, `gemm_tr` and `gemv_tr` build them.

use nalgebra::{DMatrix, DVector};

/// `a · b` in nalgebra's order: eight running sums over blocks of eight, added pairwise into
/// the result (0 and 4, 1 and 5, 2 and 6, 3 and 7), then the tail in order. Bit for bit the
/// `dot` of two `DVector`s (or column views) and, with `b = a`, their `norm_squared`.
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    let mut sums = [0.0; 8];
    for (x, y) in a.chunks_exact(8).zip(b.chunks_exact(8)) {
        for lane in 0..8 {
            sums[lane] += x[lane] * y[lane];
        }
    }
    let mut result = 0.0;
    result += sums[0] + sums[4];
    result += sums[1] + sums[5];
    result += sums[2] + sums[6];
    result += sums[3] + sums[7];
    let done = a.len() / 8 * 8;
    for (x, y) in a[done..].iter().zip(&b[done..]) {
        result += x * y;
    }
    result
}

/// Column `j` of the column-major `a`.
fn column(a: &DMatrix<f64>, j: usize) -> &[f64] {
    let m = a.nrows();
    &a.as_slice()[j * m..(j + 1) * m]
}

/// `aᵀb`: entry `(i, j)` the dot product of column `i` of `a` and column `j` of `b`, as
/// nalgebra's `a.tr_mul(b)`, bit for bit.
pub(crate) fn transpose_times(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    debug_assert_eq!(a.nrows(), b.nrows());
    DMatrix::from_fn(a.ncols(), b.ncols(), |i, j| dot(column(a, i), column(b, j)))
}

/// `target += aᵀa` for a symmetric `target`, as nalgebra's `target.gemm_tr(1.0, a, a, 1.0)`
/// bit for bit: each product below the diagonal is the one above it (the same dot product,
/// each term's factors swapped), computed once.
pub(crate) fn add_gram(target: &mut DMatrix<f64>, a: &DMatrix<f64>) {
    let n = a.ncols();
    debug_assert_eq!(target.shape(), (n, n));
    for j in 0..n {
        for i in 0..=j {
            let product = dot(column(a, i), column(a, j));
            target[(i, j)] += product;
            if i != j {
                target[(j, i)] += product;
            }
        }
    }
}

/// `target += aᵀr`, as nalgebra's `target.gemv_tr(1.0, a, r, 1.0)` bit for bit.
pub(crate) fn add_transpose_times(target: &mut DVector<f64>, a: &DMatrix<f64>, r: &DVector<f64>) {
    debug_assert_eq!((a.nrows(), a.ncols()), (r.len(), target.len()));
    for (i, value) in target.iter_mut().enumerate() {
        *value += dot(column(a, i), r.as_slice());
    }
}

/// The bits of `values`: what the bit-for-bit tests of the slice products compare.
#[cfg(test)]
pub(crate) fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

/// Values of every magnitude and sign from a fixed recurrence (no two sums alike): the
/// inputs of the bit-for-bit tests of the slice factorisations.
#[cfg(test)]
pub(crate) fn awkward(count: usize, seed: u64) -> Vec<f64> {
    let mut state = seed;
    (0..count)
        .map(|_| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            let unit = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            unit * 10f64.powi((state % 7) as i32 - 3)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::{add_gram, add_transpose_times, awkward, bits, dot, transpose_times};

    /// The products are nalgebra's `tr_mul`, `gemm_tr` and `gemv_tr`, bit for bit, on row
    /// counts around the dot product's blocks of eight, accumulated onto non-zero (symmetric)
    /// matrices and vectors.
    #[test]
    fn the_products_are_nalgebras() {
        for (m, n, k, seed) in [
            (1, 1, 1, 1),
            (7, 3, 2, 2),
            (8, 4, 5, 3),
            (23, 6, 3, 4),
            (300, 9, 4, 5),
        ] {
            let a = DMatrix::from_vec(m, n, awkward(m * n, seed));
            let b = DMatrix::from_vec(m, k, awkward(m * k, seed + 10));
            let r = DVector::from_vec(awkward(m, seed + 20));
            assert_eq!(
                bits(transpose_times(&a, &b).as_slice()),
                bits(a.tr_mul(&b).as_slice())
            );
            let start = DMatrix::from_vec(n, n, awkward(n * n, seed + 30));
            let symmetric = &start + start.transpose();
            let (mut ours, mut theirs) = (symmetric.clone(), symmetric);
            add_gram(&mut ours, &a);
            theirs.gemm_tr(1.0, &a, &a, 1.0);
            assert_eq!(bits(ours.as_slice()), bits(theirs.as_slice()), "{m}x{n}");
            let start = DVector::from_vec(awkward(n, seed + 40));
            let (mut ours, mut theirs) = (start.clone(), start);
            add_transpose_times(&mut ours, &a, &r);
            theirs.gemv_tr(1.0, &a, &r, 1.0);
            assert_eq!(bits(ours.as_slice()), bits(theirs.as_slice()), "{m}x{n}");
        }
    }

    /// nalgebra's dot product and squared norm, bit for bit, at every length around its blocks
    /// of eight.
    #[test]
    fn the_dot_product_sums_as_nalgebras() {
        for len in 0..41 {
            let (a, b) = (awkward(len, 1), awkward(len, 2));
            let expected = DVector::from_vec(a.clone()).dot(&DVector::from_vec(b.clone()));
            assert_eq!(dot(&a, &b).to_bits(), expected.to_bits(), "length {len}");
            let norm = DVector::from_vec(a.clone()).norm_squared();
            assert_eq!(dot(&a, &a).to_bits(), norm.to_bits(), "length {len}");
        }
    }
}
