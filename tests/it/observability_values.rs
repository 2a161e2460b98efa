//! The observability analysis on small matrices whose answers are known in closed form:
//! column scaling, the condition numbers, the indices with s_min ≠ 1, a zero column, and the
//! exact text of a null direction.
//!
//! The closed-form values here are exact in binary (ratios of powers of two, zeros, infinity),
//! so exact float comparisons are the test's point.
#![allow(clippy::float_cmp)]
use legwise::identify::observability::{
    analyse, indices, sorted_singular_values, Observability, RANK_TOLERANCE, WEAK_CONDITION,
};
use nalgebra::DMatrix;

fn names(n: usize) -> Vec<String> {
    (0..n).map(|i| format!("p{i}")).collect()
}

/// (p0 − p1)/√2 up to sign; which of the two equal weights comes first is round-off.
fn symmetric(direction: &str) -> bool {
    direction == "0.707 p0 - 0.707 p1" || direction == "0.707 p1 - 0.707 p0"
}

fn close(actual: f64, expected: f64, what: &str) {
    assert!(
        (actual - expected).abs() <= 1e-12 * expected.abs().max(1.0),
        "{what}: {actual} vs {expected}"
    );
}

#[test]
fn scaling_makes_orthogonal_columns_of_any_length_perfectly_conditioned() {
    // Orthogonal columns of lengths 300 and 0.02 (e.g. metres against radians).
    let c = DMatrix::from_row_slice(3, 2, &[300.0, 0.0, 0.0, 0.02, 0.0, 0.0]);
    let o = analyse(&c, &names(2));
    close(o.singular_values[0], 300.0, "s_max");
    close(o.singular_values[1], 0.02, "s_min");
    close(o.condition, 15_000.0, "condition");
    close(o.scaled_singular_values[0], 1.0, "scaled s_max");
    close(o.scaled_singular_values[1], 1.0, "scaled s_min");
    close(o.scaled_condition, 1.0, "scaled condition");
    assert_eq!(o.rank, 2);
    assert_eq!(o.warning(), None);
    assert!(o.unidentifiable.is_empty() && o.null_directions.is_empty());
}

#[test]
fn condition_is_the_ratio_of_the_extreme_singular_values() {
    // CᵀC = [[11, −2], [−2, 6]]: eigenvalues (17 ± √41)/2.
    let c = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, 0.0, 2.0, 1.0, 1.0, 3.0, -1.0]);
    let o = analyse(&c, &names(2));
    let (big, small) = ((17.0 + 41f64.sqrt()) / 2.0, (17.0 - 41f64.sqrt()) / 2.0);
    close(o.singular_values[0], big.sqrt(), "s_max");
    close(o.singular_values[1], small.sqrt(), "s_min");
    close(o.condition, (big / small).sqrt(), "condition");
    // Scaled: unit columns with cosine −2/√(11·6) between them.
    let cosine = -2.0 / 66f64.sqrt();
    let scaled = ((1.0 + cosine.abs()) / (1.0 - cosine.abs())).sqrt();
    close(o.scaled_condition, scaled, "scaled condition");
    assert_eq!(o.rank, 2);
}

#[test]
fn a_weak_but_full_rank_design_warns_with_its_condition_and_direction() {
    // Columns 1e-5 rad apart: full rank, scaled condition ≈ 2/1e-5 = 2e5.
    let c = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 0.0, 1e-5]);
    let o = analyse(&c, &names(2));
    assert_eq!(o.rank, 2);
    assert!(o.scaled_condition > WEAK_CONDITION && o.scaled_condition.is_finite());
    assert!(o.condition.is_finite());
    assert!(symmetric(&o.weakest_direction), "{}", o.weakest_direction);
    let warning = o.warning().unwrap();
    assert_eq!(
        warning,
        format!(
            "weakly identifiable: column-scaled condition number {:.1e} (> 1e4); least observable direction {}",
            o.scaled_condition, o.weakest_direction
        )
    );
}

#[test]
fn a_nearly_dependent_column_is_rank_deficient_with_its_finite_conditions() {
    // The smallest scaled singular value is ~7e-11: positive, but below the rank tolerance.
    let c = DMatrix::from_row_slice(3, 2, &[1.0, 1.0, 0.0, 1e-10, 0.0, 0.0]);
    let o = analyse(&c, &names(2));
    assert_eq!(o.rank, 1);
    assert!(o.scaled_singular_values[1] > 0.0);
    assert!(o.singular_values[1] > 0.0);
    // Finite, non-zero singular values: the conditions are their ratios, never "infinite".
    let ratio = |s: &[f64]| s[0] / s[s.len() - 1];
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    assert!(close(o.scaled_condition, ratio(&o.scaled_singular_values)));
    assert!(close(o.condition, ratio(&o.singular_values)));
    assert!(
        o.condition > 1e9 && o.condition.is_finite(),
        "{}",
        o.condition
    );
    assert_eq!(o.null_directions.len(), 1);
    assert!(symmetric(&o.null_directions[0]), "{}", o.null_directions[0]);
    assert_eq!(o.unidentifiable.len(), 1);
}

#[test]
fn a_zero_column_is_named_without_producing_nan() {
    let c = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 2.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0]);
    let o = analyse(&c, &names(3));
    assert!(
        o.scaled_singular_values.iter().all(|s| s.is_finite()),
        "{o:?}"
    );
    assert_eq!(o.rank, 2);
    assert_eq!(o.unidentifiable, vec!["p1".to_string()]);
    assert_eq!(o.null_directions, vec!["1.000 p1".to_string()]);
    assert_eq!(o.weakest_direction, "1.000 p1");
    assert!(o.scaled_singular_values[2] < 1e-15);
    let s = &o.scaled_singular_values;
    if s[2] > 0.0 {
        assert!((o.scaled_condition - s[0] / s[2]).abs() <= 1e-12 * s[0] / s[2]);
    } else {
        assert!(o.scaled_condition.is_infinite());
    }
}

#[test]
fn a_null_direction_reads_with_signs_and_weights_largest_first() {
    // p2 = p0/3 − 2·p1/0.5 is a combination of p0 and p1; p3 is independent. Scaled, the
    // columns are e0, e1, (e0 − 2e1)/√5, so the null direction is (−1, 2, √5, 0)/√10 up to
    // sign, written largest first with the first weight positive.
    let c = DMatrix::from_row_slice(
        4,
        4,
        &[
            3.0, 0.0, 1.0, 0.0, //
            0.0, 0.5, -2.0, 0.0, //
            0.0, 0.0, 0.0, 1.0, //
            0.0, 0.0, 0.0, 1.0,
        ],
    );
    let o = analyse(&c, &names(4));
    assert_eq!(o.rank, 3);
    assert_eq!(
        o.null_directions,
        vec!["0.707 p2 + 0.632 p1 - 0.316 p0".to_string()]
    );
    assert_eq!(o.weakest_direction, o.null_directions[0]);
    assert_eq!(o.unidentifiable.len(), 1);
    assert_ne!(o.unidentifiable[0], "p3");
    assert_eq!(o.condition, f64::INFINITY);
}

#[test]
fn indices_with_a_smallest_singular_value_other_than_one() {
    let [o1, o2, o3, o4, o5] = indices(&[4.0, 2.0, 0.5], 16, 3);
    close(o1, 4f64.powf(1.0 / 3.0) / 4.0, "O1"); // (4·2·0.5)^(1/3)/√16
    close(o2, 0.125, "O2");
    close(o3, 0.5, "O3");
    close(o4, 0.0625, "O4"); // 0.5²/4
    close(o5, 1.0 / 2.75, "O5"); // 1/(1/4 + 1/2 + 2)
                                 // Only the first n values count.
    assert_eq!(indices(&[4.0, 2.0, 0.5, 0.0], 16, 3), [o1, o2, o3, o4, o5]);
    assert_eq!(indices(&[4.0, 0.0], 16, 2), [0.0; 5]);
    assert_eq!(indices(&[4.0], 16, 2), [0.0; 5]);
    assert_eq!(indices(&[], 16, 0), [0.0; 5]);
}

#[test]
fn singular_values_come_largest_first_with_zeros_for_missing_rows() {
    let c = DMatrix::from_row_slice(2, 3, &[0.0, 2.0, 0.0, 5.0, 0.0, 0.0]);
    let values = sorted_singular_values(c);
    assert_eq!(values.len(), 3);
    close(values[0], 5.0, "s0");
    close(values[1], 2.0, "s1");
    assert_eq!(values[2], 0.0);
    let tall = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 7.0, 0.0, 0.0]);
    let values = sorted_singular_values(tall);
    assert_eq!(values.len(), 2);
    close(values[0], 7.0, "s0");
    close(values[1], 1.0, "s1");
}

#[test]
fn an_all_zero_jacobian_has_rank_zero_and_infinite_conditions_not_nan() {
    let c = DMatrix::zeros(3, 2);
    let o = analyse(&c, &names(2));
    assert_eq!(o.rank, 0);
    assert_eq!(o.condition, f64::INFINITY);
    assert_eq!(o.scaled_condition, f64::INFINITY);
    assert_eq!(o.unidentifiable, names(2));
    assert_eq!(o.indices, [0.0; 5]);
}

/// The rank tolerance is relative to the largest scaled singular value. Scaled, [[1, 1], [0, ε]]
/// has unit columns at an angle ≈ ε, so s_max ≈ √2 and s_min ≈ ε/√2 (s_max·s_min = |det| ≈ ε,
/// s_max² + s_min² = 2): the ratio s_min/s_max ≈ ε/2 decides the rank, not s_min alone.
#[test]
fn the_rank_tolerance_is_relative_to_the_largest_singular_value() {
    for (epsilon, rank) in [(1.5e-8, 1), (3e-8, 2)] {
        let c = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 0.0, epsilon]);
        let o = analyse(&c, &names(2));
        let s = &o.scaled_singular_values;
        close(s[0], 2f64.sqrt(), "scaled s_max");
        assert!((s[1] / (epsilon / 2f64.sqrt()) - 1.0).abs() < 1e-6, "{s:?}");
        // ε/2 is 0.75 and 1.5 times the tolerance: one rank on each side.
        assert_eq!(epsilon / 2.0 > RANK_TOLERANCE, rank == 2);
        assert_eq!(o.rank, rank, "ε = {epsilon}");
    }
}

/// The warning is for a scaled condition strictly above the threshold.
#[test]
fn the_weak_design_warning_starts_strictly_above_the_threshold() {
    let at = |scaled_condition: f64| Observability {
        singular_values: vec![1.0, 1.0],
        scaled_singular_values: vec![1.0, 1.0],
        rank: 2,
        condition: 1.0,
        indices: [1.0; 5],
        unidentifiable: Vec::new(),
        null_directions: Vec::new(),
        scaled_condition,
        weakest_direction: "1.000 p0".into(),
        resting_on_prior: Vec::new(),
    };
    assert_eq!(at(WEAK_CONDITION).warning(), None);
    assert_eq!(at(1.0).warning(), None);
    assert!(at(WEAK_CONDITION * 1.5).warning().is_some());
}
