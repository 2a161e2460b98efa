//! The selection's constants, options, result and errors (shared by [`super`]'s entry points
//! and its engines).

/// Ridge factor ε of the start M = ε·diag(Σ_j c_j∘c_j)/K of the greedy construction.
///
/// # Reference
/// docs/method.md §6 (the ridge start).
pub const RIDGE: f64 = 1e-9;

/// A swap is accepted only if it improves the criterion by more than this relative amount
/// (for D: Δ > 1 + `ACCEPT`).
///
/// Well above the round-off of a swap ratio computed from M⁻¹ (about the condition number of
/// M times ε): swapping a design point for an equivalent candidate (a symmetric pool's mirror
/// image) computes to 1 ± 1e-12 on the bundled delta's bed-probe pool, and such a swap, which
/// changes nothing, must not be taken. A real improvement is many orders larger.
///
/// # Reference
/// docs/method.md §6 (the exchange phase).
pub const ACCEPT: f64 = 1e-9;

/// Longest DETMAX excursion tried once no single swap improves the design.
///
/// # Reference
/// docs/method.md §6 (DETMAX, Mitchell 1974: excursions of length 1..k).
pub const EXCURSION_LENGTH: usize = 4;

/// Design criterion of the selection.
///
/// # Reference
/// docs/method.md §5 (O1, O3, A-optimality) and §6.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Criterion {
    /// D-optimality: maximise det(CᵀC), i.e. the observability index O1 (default). The
    /// selected set is invariant to a column scaling (change of parameter units).
    #[default]
    D,
    /// A-optimality: minimise tr (CᵀC)⁻¹ = Σ 1/s_i².
    A,
    /// E-optimality: maximise the smallest singular value s_min of C (O3).
    E,
}

/// Options of [`select`](super::select) and [`select_naive`](super::select_naive).
///
/// # Reference
/// docs/method.md §6.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SelectionOptions {
    /// Number N of poses to select.
    pub count: usize,
    /// Design criterion.
    pub criterion: Criterion,
    /// Maximum number of exchange sweeps (0: greedy construction only). Default 50.
    pub max_sweeps: usize,
    /// Whether a candidate may be selected more than once (measured repeatedly). Default false.
    pub allow_replicates: bool,
}

impl Default for SelectionOptions {
    /// N = 18 (the paper's design size), D-optimal, 50 sweeps, no replicates.
    fn default() -> Self {
        Self {
            count: 18,
            criterion: Criterion::D,
            max_sweeps: 50,
            allow_replicates: false,
        }
    }
}

/// The result of a selection.
///
/// # Reference
/// docs/method.md §6 (the Kiefer–Wolfowitz value).
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Indices of the selected candidates, sorted (repeated if replicates are allowed).
    pub indices: Vec<usize>,
    /// Exchange sweeps run; the last one is the one that found no improving swap, unless the
    /// limit was reached.
    pub sweeps: usize,
    /// Exchanges (single swaps) applied in all sweeps.
    pub exchanges: usize,
    /// DETMAX excursions (add L best, then remove L least useful points, L ≥ 2) that improved
    /// the design after the single swaps had converged.
    pub excursions: usize,
    /// log det(CᵀC) of the selected design.
    pub log_det: f64,
    /// The engine that evaluated the trial designs: `rank-one D` (one row per candidate),
    /// `separable D` (rows with disjoint column supports), `block D`, `A`, `E`, or `naive` (the
    /// from-scratch reference of [`select_naive`](super::select_naive)).
    pub engine: &'static str,
    /// Kiefer–Wolfowitz certificate max_j N·tr(C_j M⁻¹ C_jᵀ) over the pool, M = CᵀC of the
    /// design (N·d(c_j) for one row per candidate). It is ≥ n; it equals n iff the design is
    /// D-optimal as an approximate design, and n / certificate bounds its D-efficiency from
    /// below.
    pub certificate: f64,
}

/// Why a selection failed.
///
/// # Reference
/// docs/method.md §6 and §7 (identifiability).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SelectionError {
    /// Fewer distinct candidates than poses requested (without replicates), or none at all.
    #[error("{requested} poses requested but the pool has only {available} candidates")]
    TooFewCandidates {
        /// Candidates in the pool.
        available: usize,
        /// Poses requested.
        requested: usize,
    },
    /// The requested poses give fewer rows than parameters, so no design has full rank.
    #[error("{poses} poses give {rows} rows, fewer than the {n} parameters")]
    TooFewRows {
        /// Poses requested.
        poses: usize,
        /// Rows they give.
        rows: usize,
        /// Parameters.
        n: usize,
    },
    /// The whole pool cannot reach full rank (some parameters are not identifiable from any
    /// design on it).
    #[error("the candidate pool has rank {rank} < {n} parameters")]
    RankDeficient {
        /// Numerical rank of the column-scaled stacked pool.
        rank: usize,
        /// Parameters.
        n: usize,
    },
    /// The selected design is numerically singular although the pool has full rank.
    #[error("the selected design is singular (rank {rank} < {n}); select more poses")]
    SingularDesign {
        /// Numerical rank of the column-scaled design.
        rank: usize,
        /// Parameters.
        n: usize,
    },
    /// A candidate has another shape than the first one.
    #[error("candidate {index} is {rows}×{cols}, expected {expected_rows}×{expected_cols}")]
    ShapeMismatch {
        /// Index of the candidate.
        index: usize,
        /// Its rows.
        rows: usize,
        /// Its columns.
        cols: usize,
        /// Rows of the first candidate.
        expected_rows: usize,
        /// Columns of the first candidate.
        expected_cols: usize,
    },
    /// The candidates have no rows or no columns.
    #[error("candidates are {rows}×{cols}: need at least one row and one parameter")]
    Empty {
        /// Rows per candidate.
        rows: usize,
        /// Columns (parameters).
        cols: usize,
    },
    /// A candidate has a NaN or infinite entry.
    #[error("candidate {index} has a non-finite entry")]
    NonFinite {
        /// Index of the candidate.
        index: usize,
    },
}
