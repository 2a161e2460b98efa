//! The dot product of two slices summed exactly as nalgebra sums that of two dynamic column
//! vectors, so that the factorisations written on slices (no view built per product, no
//! bounds check per entry) give the same bits as their first versions on nalgebra's views.

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
    use nalgebra::DVector;

    use super::{awkward, dot};

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
