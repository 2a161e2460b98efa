//! The forward rows of an [`IdentificationProblem`](super::IdentificationProblem) as data:
//! every leg's reading and what the instrument saw at each row, the distances between rows, and
//! what the problem keeps between evaluations (each row's configuration, the latest
//! evaluation). Their evaluation is `problem/forward.rs`'s.

use std::sync::{Arc, Mutex};

use nalgebra::DMatrix;

use super::pose_moves::RowsMoves;
use crate::kinematics::kernel::LegKernel;
use crate::kinematics::platform::Configuration;
use crate::kinematics::KernelRows;

/// One forward row: every leg's reading and what the instrument reported there.
#[derive(Debug, Clone)]
pub(super) struct ForwardRow {
    /// The row's index in the observations.
    pub(super) source: usize,
    /// Line in the measurement file, if read from one.
    pub(super) line: Option<usize>,
    /// One reading per leg of the mechanism.
    pub(super) readings: Vec<f64>,
    /// The targets' coordinates, in measurement-row order (empty for a row only distances use).
    pub(super) observed: Vec<f64>,
}

/// A measured distance between the distance target's positions at two forward rows.
#[derive(Debug, Clone)]
pub(super) struct ForwardDistance {
    /// A measurement index of its own (after the observations' rows).
    pub(super) source: usize,
    /// The two rows (indices into the forward rows).
    pub(super) rows: [usize; 2],
    /// The measured distance, metres.
    pub(super) value: f64,
    /// Line of the distance row in the measurement file, if read from one.
    pub(super) line: Option<usize>,
}

/// The forward rows of a problem and their warm starts.
#[derive(Debug, Clone)]
pub(super) struct Forward {
    /// The rows (shared by the problem's clones).
    pub(super) rows: Arc<Vec<ForwardRow>>,
    /// The distances between rows.
    pub(super) distances: Arc<Vec<ForwardDistance>>,
    /// Each row's configuration at its last solve (the next one's start), shared by the
    /// problem's clones (evaluated one after the other, never at once).
    pub(super) starts: Arc<Mutex<Vec<Option<Configuration>>>>,
    /// Per residual block of a measured pose (the problem's blocks, before the forward rows'
    /// residuals), the index of its row in the observations: its measurement.
    pub(super) block_sources: Arc<Vec<usize>>,
    /// The latest evaluation, keyed by the unknowns' bits: a solver asks for the Jacobian where
    /// it has just evaluated the residuals, and the statistics again at the estimate.
    pub(super) latest: Arc<Mutex<Option<Latest>>>,
    /// Every leg's closed-form kernel ([`LegKernel::recognise`]), recognised once.
    pub(super) kernels: Arc<Vec<Option<LegKernel>>>,
}

/// The latest evaluation of a problem's forward rows.
#[derive(Debug)]
pub(super) struct Latest {
    /// The unknowns' bits.
    pub(super) key: Vec<u64>,
    /// Every row's closed pose there.
    pub(super) poses: Vec<[f64; 6]>,
    /// Every row's legs' kernel rows at its pose, where the forward solve evaluated them there
    /// (empty for poses closed elsewhere).
    pub(super) rows: Vec<Option<KernelRows>>,
    /// Every row's movements there ([`RowsMoves`]), if the Jacobian was asked for.
    pub(super) moves: Option<RowsMoves>,
    /// The evaluation (with its derivatives if they were asked for); `None` for poses closed
    /// elsewhere (known poses).
    pub(super) evaluation: Option<ForwardEvaluation>,
}

impl Forward {
    /// The forward part of a problem over `rows` and `distances`, beside blocks of measured
    /// poses from the rows `block_sources`, the mechanism's legs having the kernels `kernels`.
    pub(super) fn new(
        rows: Vec<ForwardRow>,
        distances: Vec<ForwardDistance>,
        block_sources: Vec<usize>,
        kernels: Vec<Option<LegKernel>>,
    ) -> Self {
        let starts = vec![None; rows.len()];
        Self {
            rows: Arc::new(rows),
            distances: Arc::new(distances),
            starts: Arc::new(Mutex::new(starts)),
            block_sources: Arc::new(block_sources),
            latest: Arc::new(Mutex::new(None)),
            kernels: Arc::new(kernels),
        }
    }

    /// The same rows with fresh warm starts (a derived problem starts its own), beside the
    /// blocks `keep` picks (by block index).
    pub(super) fn renewed(&self, keep: impl Fn(usize) -> bool) -> Self {
        let sources = (0..self.block_sources.len()).filter(|&i| keep(i));
        let sources = sources.map(|i| self.block_sources[i]).collect();
        let kernels = self.kernels.to_vec();
        Self::new(
            self.rows.to_vec(),
            self.distances.to_vec(),
            sources,
            kernels,
        )
    }
}

/// What one evaluation of the forward rows gives: the residuals, and on request their
/// derivatives with respect to the unknowns and to the readings.
#[derive(Debug, Clone)]
pub(super) struct ForwardEvaluation {
    /// `h(P, θ) − y`: every coordinate of each row with coordinates, then every distance.
    pub(super) residuals: Vec<f64>,
    /// `∂r/∂x` (one row per residual), if asked for.
    pub(super) jacobian: Option<DMatrix<f64>>,
    /// Every residual's `∂r/∂s` over the readings it depends on (its row's, one per leg; a
    /// distance's two rows', one after the other), residual after residual, if the Jacobian
    /// was asked for ([`Self::reading_gradient`]).
    pub(super) reading_gradients: Vec<f64>,
    /// Where each residual's part of `reading_gradients` starts (and the last one ends).
    pub(super) reading_starts: Vec<usize>,
}

impl ForwardEvaluation {
    /// Residual `i`'s `∂r/∂s` (empty without the Jacobian).
    pub(super) fn reading_gradient(&self, i: usize) -> &[f64] {
        match (self.reading_starts.get(i), self.reading_starts.get(i + 1)) {
            (Some(&start), Some(&end)) => &self.reading_gradients[start..end],
            _ => &[],
        }
    }
}
