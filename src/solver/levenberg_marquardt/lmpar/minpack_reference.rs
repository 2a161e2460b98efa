//! `lm_step` against MINPACK's own `lmpar` (cminpack 1.3.6, called on the same `R`, permutation,
//! scaling, `Qᵀr`, trust radius and starting λ by `tools/minpack_lmpar_reference.py`): the λ
//! iteration's path is seen only through its end point, so the end point is compared exactly.

use nalgebra::{DMatrix, DVector};

use super::Scratch;

/// One call of MINPACK `lmpar` and what it returned.
struct MinpackCase {
    what: &'static str,
    /// `R`, row by row.
    r: &'static [f64],
    /// Column `j` of `J P` is column `perm[j]` of `J` (0-based).
    perm: &'static [usize],
    /// The scaling `D`, in parameter order.
    diag: &'static [f64],
    qtr: &'static [f64],
    delta: f64,
    lambda0: f64,
    /// MINPACK's `par` on return.
    lambda: f64,
    /// MINPACK's `x` on return, in parameter order.
    step: &'static [f64],
}

const CASES: &[MinpackCase] = &[
    MinpackCase {
        what: "full rank, λ iterated from 0",
        r: &[3.0, 1.0, 0.5, 0.0, 2.0, 0.3, 0.0, 0.0, 0.7],
        perm: &[2, 0, 1],
        diag: &[1.0, 2.0, 0.5],
        qtr: &[1.0, -2.0, 0.5],
        delta: 0.1,
        lambda0: 0.0,
        lambda: 47.99393869923546,
        step: &[
            -0.06523371176402855,
            0.0004850904040072613,
            0.1521525743007052,
        ],
    },
    MinpackCase {
        what: "full rank, λ iterated from the last one",
        r: &[3.0, 1.0, 0.5, 0.0, 2.0, 0.3, 0.0, 0.0, 0.7],
        perm: &[2, 0, 1],
        diag: &[1.0, 2.0, 0.5],
        qtr: &[1.0, -2.0, 0.5],
        delta: 0.1,
        lambda0: 5.0,
        lambda: 48.029450751345394,
        step: &[
            -0.06518600250499104,
            0.0004850141037999819,
            0.15208146466710643,
        ],
    },
    MinpackCase {
        what: "full rank, the Gauss–Newton step fits",
        r: &[3.0, 1.0, 0.5, 0.0, 2.0, 0.3, 0.0, 0.0, 0.7],
        perm: &[2, 0, 1],
        diag: &[1.0, 2.0, 0.5],
        qtr: &[1.0, -2.0, 0.5],
        delta: 100.0,
        lambda0: 5.0,
        lambda: 0.0,
        step: &[-1.1071428571428572, 0.7142857142857143, 0.5833333333333334],
    },
    MinpackCase {
        what: "Gauss–Newton step exactly 10 % longer than the region",
        r: &[1.0, 0.0, 0.0, 1.0],
        perm: &[0, 1],
        diag: &[1.0, 1.0],
        qtr: &[11.0, 0.0],
        delta: 10.0,
        lambda0: 0.0,
        lambda: 0.0,
        step: &[11.0, 0.0],
    },
    MinpackCase {
        what: "rank 2 of 3, Δ=0.05",
        r: &[2.0, 1.0, 0.3, 0.0, 1.0, 0.2, 0.0, 0.0, 0.0],
        perm: &[1, 2, 0],
        diag: &[1.0, 0.5, 2.0],
        qtr: &[1.0, 1.0, 1.0],
        delta: 0.05,
        lambda0: 0.0,
        lambda: 66.69162225260278,
        step: &[
            0.006571218753135607,
            0.09590457586160368,
            0.006715514443581947,
        ],
    },
    MinpackCase {
        what: "rank 2 of 3, Δ=0.2",
        r: &[2.0, 1.0, 0.3, 0.0, 1.0, 0.2, 0.0, 0.0, 0.0],
        perm: &[1, 2, 0],
        diag: &[1.0, 0.5, 2.0],
        qtr: &[1.0, 1.0, 1.0],
        delta: 0.2,
        lambda0: 0.0,
        lambda: 6.006642027329805,
        step: &[
            0.04411636201599307,
            0.34060319155633145,
            0.04982352765192368,
        ],
    },
    MinpackCase {
        what: "rank 2 of 3, Δ=0.5",
        r: &[2.0, 1.0, 0.3, 0.0, 1.0, 0.2, 0.0, 0.0, 0.0],
        perm: &[1, 2, 0],
        diag: &[1.0, 0.5, 2.0],
        qtr: &[1.0, 1.0, 1.0],
        delta: 0.5,
        lambda0: 0.0,
        lambda: 0.8731818932840227,
        step: &[0.1825051677380177, 0.34254081766027855, 0.22277925939658028],
    },
    MinpackCase {
        what: "rank 2 of 3, Δ=1",
        r: &[2.0, 1.0, 0.3, 0.0, 1.0, 0.2, 0.0, 0.0, 0.0],
        perm: &[1, 2, 0],
        diag: &[1.0, 0.5, 2.0],
        qtr: &[1.0, 1.0, 1.0],
        delta: 1.0,
        lambda0: 0.0,
        lambda: 0.2479947682329256,
        step: &[0.3765223435400153, 0.2066069603065994, 0.46742469567022854],
    },
    MinpackCase {
        what: "rank 2 of 3, Δ=2",
        r: &[2.0, 1.0, 0.3, 0.0, 1.0, 0.2, 0.0, 0.0, 0.0],
        perm: &[1, 2, 0],
        diag: &[1.0, 0.5, 2.0],
        qtr: &[1.0, 1.0, 1.0],
        delta: 2.0,
        lambda0: 0.0,
        lambda: 0.0,
        step: &[0.0, 0.0, 1.0],
    },
    MinpackCase {
        what: "zero gradient, Gauss–Newton step outside the region",
        r: &[1e-200, 0.0, 0.0, 1e-200],
        perm: &[0, 1],
        diag: &[1.0, 1.0],
        qtr: &[1e-200, 1e-200],
        delta: 0.1,
        lambda0: 0.0,
        lambda: 2.2250738585072014e-308,
        step: &[4.4942328371557895e-93, 4.4942328371557895e-93],
    },
    MinpackCase {
        what: "zero gradient, restart above the smallest normal number",
        r: &[1e-100, 0.0, 0.0, 0.0, 3e-100, 0.0, 0.0, 0.0, 0.0],
        perm: &[0, 1, 2],
        diag: &[6.7e-20, 2e-19, 1.0],
        qtr: &[1e-230, 2e-230, 1.0],
        delta: 1e-150,
        lambda0: 0.0,
        lambda: 3.1262146004612558e-161,
        step: &[6.651776734746091e-132, 4.4759890930098654e-132, 0.0],
    },
    MinpackCase {
        what: "rank 1 of 2, the region unreachable",
        r: &[1.0, 1.0, 0.0, 0.0],
        perm: &[0, 1],
        diag: &[1.0, 1.0],
        qtr: &[1.0, 0.0],
        delta: 0.85,
        lambda0: 0.0,
        lambda: 1.4142135623730954e-21,
        step: &[0.5, 0.5],
    },
    MinpackCase {
        what: "rank 1 of 2, the region unreachable, pivoted and scaled",
        r: &[2.0, 1.0, 0.0, 0.0],
        perm: &[1, 0],
        diag: &[0.5, 2.0],
        qtr: &[1.0, 0.0],
        delta: 0.7,
        lambda0: 0.0,
        lambda: 2.2360679774997902e-21,
        step: &[0.8, 0.09999999999999998],
    },
];

/// A scratch holding `R`, the permutation, the permuted scaling and `Qᵀr`, as `factorize`
/// and the solver leave them before `lm_step`.
fn scratch(case: &MinpackCase) -> Scratch {
    let n = case.qtr.len();
    Scratch {
        jq: DMatrix::from_row_slice(n, n, case.r),
        perm: case.perm.to_vec(),
        qtr: DVector::from_column_slice(case.qtr),
        d_perm: DVector::from_fn(n, |j, _| case.diag[case.perm[j]]),
        damped: DMatrix::zeros(n, n),
        damped_rhs: DVector::zeros(n),
        z: DVector::zeros(n),
        y: DVector::zeros(n),
        step: DVector::zeros(n),
        ..Scratch::default()
    }
}

fn close(found: f64, expected: f64) -> bool {
    (found - expected).abs() <= 1e-13 * expected.abs()
}

#[test]
fn the_damped_step_and_its_lambda_are_minpacks() {
    for case in CASES {
        let mut s = scratch(case);
        let (lambda, dnorm) = s
            .lm_step(case.delta, case.lambda0)
            .unwrap_or_else(|| panic!("{}: no step", case.what));
        assert!(
            close(lambda, case.lambda),
            "{}: λ = {lambda:e}, MINPACK {:e}",
            case.what,
            case.lambda
        );
        for (k, (&found, &expected)) in s.step.iter().zip(case.step).enumerate() {
            assert!(
                close(found, expected),
                "{}: step[{k}] = {found:e}, MINPACK {expected:e}",
                case.what
            );
        }
        let expected_dnorm = case
            .step
            .iter()
            .zip(case.diag)
            .map(|(p, d)| (p * d).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            (dnorm - expected_dnorm).abs() <= 1e-13 * expected_dnorm,
            "{}: ‖D p‖ = {dnorm:e}, expected {expected_dnorm:e}",
            case.what
        );
    }
}
