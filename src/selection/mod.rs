//! Experiment design: choose N of K candidate poses so that the identification Jacobian of the
//! chosen poses is as informative as possible (D-, A- or E-optimal experiment design).
//!
//! The selection engines work on plain matrices (one b × n block of identification rows per
//! candidate) and know nothing of poses, their dimension or the mechanism; [`design`] builds
//! those matrices from a mechanism's candidate pool ([`crate::selection::candidates`]) and maps
//! the chosen indices back to poses.
//!
//! This is a D-optimal exchange algorithm in the spirit of Sun & Hollerbach (2008) / DETMAX
//! (Mitchell 1974), not Sun & Hollerbach's exact algorithm (whose text could not be
//! retrieved). It has two phases:
//!
//! 1. greedy sequential construction from the scale-equivariant ridge start
//!    M = ε·diag(Σ c∘c)/K (ε = [`RIDGE`]): add the candidate of largest gain, N times;
//! 2. Fedorov exchange: each sweep refactorises M = C_SᵀC_S (Cholesky), then applies the best
//!    improving swap (design point out, candidate in) per step, at most N steps per sweep,
//!    until no swap improves the criterion by more than the relative factor [`ACCEPT`]; then
//!    DETMAX excursions of length 2..=[`EXCURSION_LENGTH`] (add the L best candidates one by
//!    one, then drop the L least useful points); an improving excursion resumes the exchange.
//!
//! For the D criterion the gains come from rank-one identities (matrix determinant lemma,
//! Sherman–Morrison, the Fedorov swap ratio Δ_ij = (1+d_j)(1−d_i) + d_ij²), with a fast path
//! for one row per candidate and a block path (b × b determinants, Woodbury updates) for
//! candidates of b rows. When the b rows of every candidate live in disjoint sets of columns
//! (the stacked traditional design: leg r's row only in leg r's parameters), which is read from
//! the pool's numbers, M is block-diagonal and a separable path multiplies one rank-one factor
//! per row position instead (the same decisions, about b² times fewer flops per trial swap).
//! [`select_naive`] runs the same algorithm but evaluates every trial design from scratch; it
//! is the reference of the tests and of the benchmark.
//!
//! # Reference
//! docs/method.md §6 (identities and algorithm); §5 for the indices.

use nalgebra::DMatrix;

mod a_optimal;
mod block_d;
pub mod candidates;
pub mod design;
mod driver;
mod e_optimal;
pub mod forward_design;
mod gains;
mod linalg;
mod naive;
mod options;
mod pool;
mod rank_one_d;
mod running_inverse;
mod separable_d;
#[cfg(test)]
mod tests;

use a_optimal::AOptimal;
use block_d::BlockD;
use driver::run;
use e_optimal::EOptimal;
use linalg::log_det_spd;
use naive::Naive;
pub use options::{
    Criterion, Selection, SelectionError, SelectionOptions, ACCEPT, EXCURSION_LENGTH, RIDGE,
};
use pool::Pool;
use rank_one_d::RankOneD;
use separable_d::SeparableD;

/// Selects `options.count` candidates by greedy construction, Fedorov exchange and DETMAX
/// excursions, with rank-one (b = 1) or block (b > 1) updates for the D criterion.
///
/// `candidates` holds one b × n matrix per candidate pose (b = 1 for one leg; b = n_legs for
/// the stacked traditional design, any block structure). All candidates must have the same
/// shape. The result is deterministic (ties go to the lowest index) and, for the D criterion,
/// invariant to a scaling of the columns of all candidates.
///
/// A D-optimal exchange algorithm in the spirit of Sun & Hollerbach (2008) / DETMAX
/// (Mitchell 1974), not Sun & Hollerbach's exact algorithm. The A and E criteria use the same
/// skeleton with the criterion re-evaluated per trial (Woodbury updates for A, eigenvalues of
/// the trial M for E); E uses the D gain while the greedy design has fewer rows than
/// parameters, where s_min is still zero.
///
/// # Errors
/// See [`SelectionError`]: too few candidates or rows, inconsistent or non-finite candidates,
/// a pool of rank < n, or (rarely) a singular result.
///
/// # Reference
/// docs/method.md §6.
pub fn select(
    candidates: &[DMatrix<f64>],
    options: &SelectionOptions,
) -> Result<Selection, SelectionError> {
    select_in(&Pool::new(candidates, options)?, options)
}

/// As [`select`], with the candidates given as the columns of one n × (K·b) matrix: column
/// j·b + r is row r of candidate j (b = `rows_per_candidate`). A large pool then needs no
/// matrix per candidate.
///
/// # Errors
/// As [`select`]; a column count that is not a multiple of b is a
/// [`SelectionError::ShapeMismatch`] of the last, partial candidate.
///
/// # Reference
/// docs/method.md §6.
pub fn select_columns(
    columns: DMatrix<f64>,
    rows_per_candidate: usize,
    options: &SelectionOptions,
) -> Result<Selection, SelectionError> {
    select_in(
        &Pool::from_columns(columns, rows_per_candidate, options)?,
        options,
    )
}

/// As [`select`], but candidates of b > 1 rows are always handed to the dense block engine for
/// the D criterion, even when their rows are separable (disjoint column supports, where
/// [`select`] multiplies rank-one factors instead). The same selection up to round-off; the
/// reference of the separable engine in the tests and the benchmark.
///
/// # Errors
/// As [`select`].
///
/// # Reference
/// docs/method.md §6 (the separable pools).
#[doc(hidden)]
pub fn select_dense_blocks(
    candidates: &[DMatrix<f64>],
    options: &SelectionOptions,
) -> Result<Selection, SelectionError> {
    let pool = Pool::new(candidates, options)?;
    match (options.criterion, pool.b) {
        (Criterion::D, 2..) => run(&pool, options, &mut BlockD::new(&pool)),
        _ => select_in(&pool, options),
    }
}

/// [`select`] on a validated pool: the engine by criterion and rows per candidate (for D with
/// b > 1: the separable engine when the rows' column supports are disjoint, the dense block
/// engine otherwise).
fn select_in(pool: &Pool, options: &SelectionOptions) -> Result<Selection, SelectionError> {
    match (options.criterion, pool.b) {
        (Criterion::D, 1) => run(pool, options, &mut RankOneD::new(pool)),
        (Criterion::D, _) => match SeparableD::new(pool) {
            Some(mut separable) => run(pool, options, &mut separable),
            None => run(pool, options, &mut BlockD::new(pool)),
        },
        (Criterion::A, _) => run(pool, options, &mut AOptimal { pool }),
        (Criterion::E, _) => run(pool, options, &mut EOptimal::new(pool)),
    }
}

/// Reference implementation of [`select`]: the same greedy construction and exchange, but
/// every trial design is evaluated from scratch (CᵀC of the trial set, then its log det by
/// Cholesky for D, tr of its inverse for A, its smallest singular value for E). Slow; used
/// by the tests and the benchmark.
///
/// A D-optimal exchange algorithm in the spirit of Sun & Hollerbach (2008) / DETMAX
/// (Mitchell 1974), not Sun & Hollerbach's exact algorithm.
///
/// # Errors
/// As [`select`].
///
/// # Reference
/// docs/method.md §6 (the same algorithm, every trial design from scratch).
pub fn select_naive(
    candidates: &[DMatrix<f64>],
    options: &SelectionOptions,
) -> Result<Selection, SelectionError> {
    let pool = Pool::new(candidates, options)?;
    run(
        &pool,
        options,
        &mut Naive {
            pool: &pool,
            criterion: options.criterion,
        },
    )
}

/// log det(CᵀC) of the design made of the candidates `indices` (their rows stacked), or −∞
/// if it is (numerically) singular or empty.
///
/// # Panics
/// If an index is out of range or the candidates do not all have the same number of columns.
///
/// # Reference
/// docs/method.md §5 (O1 = det(CᵀC)^{1/(2n)}/√m) and §6.
pub fn log_det(candidates: &[DMatrix<f64>], indices: &[usize]) -> f64 {
    let Some(n) = candidates.first().map(DMatrix::ncols) else {
        return f64::NEG_INFINITY;
    };
    let mut m = DMatrix::zeros(n, n);
    for &j in indices {
        m += candidates[j].tr_mul(&candidates[j]);
    }
    log_det_spd(&m)
}
