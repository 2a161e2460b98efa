//! Experiment design: the identification poses of each leg (divide and conquer) and the shared
//! poses of all legs (traditional), selected from the candidate pool for observability.
//!
//! # Reference
//! Durango et al. 2010, §4 (Eq. 6–7); docs/method.md §6 (a D-optimal exchange algorithm in the
//! spirit of Sun & Hollerbach 2008 / DETMAX).

use nalgebra::DMatrix;

use super::{select_columns, Criterion, Selection, SelectionError, SelectionOptions};
use crate::error::{Error, Result};
use crate::identify::observability::{analyse, Observability};
use crate::model::mechanism::SelectionCriterion;
use crate::model::Mechanism;
use crate::selection::candidates::CandidatePool;

/// The selected poses of one leg.
#[derive(Debug, Clone)]
pub struct LegDesign {
    /// Index of the leg.
    pub leg: usize,
    /// The selected poses.
    pub poses: Vec<[f64; 6]>,
    /// Indices of the selected candidates in the pool.
    pub indices: Vec<usize>,
    /// Observability of the leg's identification Jacobian (nominal parameters) on the poses.
    pub observability: Observability,
    /// What the selection algorithm reports (sweeps, exchanges, certificate).
    pub selection: Selection,
}

/// The selected shared poses of all legs (traditional strategy).
#[derive(Debug, Clone)]
pub struct SharedDesign {
    /// The selected poses.
    pub poses: Vec<[f64; 6]>,
    /// Indices of the selected candidates in the pool.
    pub indices: Vec<usize>,
    /// Each identified leg's observability on the shared poses (legs with every parameter fixed
    /// are left out).
    pub legs: Vec<Observability>,
    /// Observability of the stacked (block-diagonal) Jacobian.
    pub stacked: Observability,
    /// What the selection algorithm reports.
    pub selection: Selection,
}

/// The selection options of a design of `count` poses by `criterion`.
pub(super) fn selection_options(count: usize, criterion: SelectionCriterion) -> SelectionOptions {
    SelectionOptions {
        count,
        criterion: match criterion {
            SelectionCriterion::D => Criterion::D,
            SelectionCriterion::A => Criterion::A,
            SelectionCriterion::E => Criterion::E,
        },
        max_sweeps: 50,
        allow_replicates: false,
    }
}

fn names(mechanism: &Mechanism, leg: usize) -> Vec<String> {
    mechanism.legs[leg].identified_names()
}

/// Rows of leg `leg` at all candidates, as the columns of one matrix; a candidate whose row
/// has another length than the first one's is a shape mismatch.
fn leg_columns(pool: &CandidatePool, leg: usize) -> Result<DMatrix<f64>, SelectionError> {
    let n = pool.candidates.first().map_or(0, |c| c.rows[leg].len());
    if let Some(index) = pool.candidates.iter().position(|c| c.rows[leg].len() != n) {
        return Err(SelectionError::ShapeMismatch {
            index,
            rows: 1,
            cols: pool.candidates[index].rows[leg].len(),
            expected_rows: 1,
            expected_cols: n,
        });
    }
    Ok(DMatrix::from_fn(n, pool.candidates.len(), |p, j| {
        pool.candidates[j].rows[leg][p]
    }))
}

/// The poses of the candidates `indices`.
fn poses_of(pool: &CandidatePool, indices: &[usize]) -> Vec<[f64; 6]> {
    indices.iter().map(|&i| pool.candidates[i].pose).collect()
}

/// Rows of leg `leg` at the candidates `indices`, stacked.
fn leg_rows(pool: &CandidatePool, leg: usize, indices: &[usize]) -> DMatrix<f64> {
    let n = pool.candidates.first().map_or(0, |c| c.rows[leg].len());
    DMatrix::from_fn(indices.len(), n, |i, j| {
        pool.candidates[indices[i]].rows[leg][j]
    })
}

/// The error for a mechanism none of whose parameters is identified: there is nothing to
/// select poses for (or to identify).
pub fn nothing_identified(mechanism: &Mechanism) -> Error {
    Error::Model {
        path: mechanism.model_path.clone(),
        field: "parameters".into(),
        message: "every parameter has `identify: false`: there is nothing to select poses for \
                  or to identify; set `identify: true` (the default) on the parameters to \
                  identify"
            .into(),
    }
}

/// Selects `count` poses for each leg with identified parameters from the pool (divide and
/// conquer).
///
/// # Errors
/// No identified parameter at all ([`nothing_identified`]), too few candidates, or a pool that
/// cannot identify some parameters of a leg (named).
pub fn divide_and_conquer(
    mechanism: &Mechanism,
    pool: &CandidatePool,
    count: usize,
    criterion: SelectionCriterion,
) -> Result<Vec<LegDesign>> {
    if mechanism.identified_legs().is_empty() {
        return Err(nothing_identified(mechanism));
    }
    let all: Vec<usize> = (0..pool.candidates.len()).collect();
    mechanism
        .identified_legs()
        .into_iter()
        .map(|leg| {
            let names = names(mechanism, leg);
            let selection = leg_columns(pool, leg)
                .and_then(|columns| {
                    select_columns(columns, 1, &selection_options(count, criterion))
                })
                .map_err(|err| {
                    selection_error(
                        mechanism,
                        pool,
                        leg,
                        err,
                        || leg_rows(pool, leg, &all),
                        &names,
                    )
                })?;
            let observability = analyse(&leg_rows(pool, leg, &selection.indices), &names);
            Ok(LegDesign {
                leg,
                poses: poses_of(pool, &selection.indices),
                indices: selection.indices.clone(),
                observability,
                selection,
            })
        })
        .collect()
}

/// Selects `count` shared poses for all legs at once (traditional: block-diagonal rows).
///
/// # Errors
/// No identified parameter at all ([`nothing_identified`]), too few candidates, or a pool that
/// cannot identify some parameters (named).
pub fn traditional(
    mechanism: &Mechanism,
    pool: &CandidatePool,
    count: usize,
    criterion: SelectionCriterion,
) -> Result<SharedDesign> {
    let (included, widths) = shared_layout(mechanism);
    let Some(&first) = included.first() else {
        return Err(nothing_identified(mechanism));
    };
    let (legs, total) = (included.len(), widths.iter().sum());
    let all_names: Vec<String> = included.iter().flat_map(|&l| names(mechanism, l)).collect();
    let stack = |indices: &[usize]| {
        let mut matrix = DMatrix::zeros(indices.len() * legs, total);
        for (k, &i) in indices.iter().enumerate() {
            for r in 0..legs {
                for (p, value) in shared_entries(pool, (&included, &widths), i, r) {
                    matrix[(k * legs + r, p)] = value;
                }
            }
        }
        matrix
    };
    let columns = shared_columns(mechanism, pool);
    let all: Vec<usize> = (0..pool.candidates.len()).collect();
    let selection =
        select_columns(columns, legs, &selection_options(count, criterion)).map_err(|err| {
            let leg = included.iter().zip(&widths).find_map(|(&l, &width)| {
                (analyse(&leg_rows(pool, l, &all), &names(mechanism, l)).rank < width).then_some(l)
            });
            match leg {
                Some(l) => selection_error(
                    mechanism,
                    pool,
                    l,
                    err,
                    || leg_rows(pool, l, &all),
                    &names(mechanism, l),
                ),
                None => selection_error(mechanism, pool, first, err, || stack(&all), &all_names),
            }
        })?;
    Ok(SharedDesign {
        poses: poses_of(pool, &selection.indices),
        indices: selection.indices.clone(),
        legs: included
            .iter()
            .map(|&l| analyse(&leg_rows(pool, l, &selection.indices), &names(mechanism, l)))
            .collect(),
        stacked: analyse(&stack(&selection.indices), &all_names),
        selection,
    })
}

/// The identified legs of the traditional design and their numbers of identified parameters.
fn shared_layout(mechanism: &Mechanism) -> (Vec<usize>, Vec<usize>) {
    let included = mechanism.identified_legs();
    let widths = included
        .iter()
        .map(|&l| mechanism.legs[l].identified().len())
        .collect();
    (included, widths)
}

/// The entries (column, value) of row r of candidate i's block-diagonal legs × total block in
/// the traditional design: leg `included[r]`'s row, in the columns of that leg's parameters
/// (`included` and `widths` from [`shared_layout`]).
fn shared_entries<'p>(
    pool: &'p CandidatePool,
    (included, widths): (&[usize], &[usize]),
    i: usize,
    r: usize,
) -> impl Iterator<Item = (usize, f64)> + 'p {
    let offset: usize = widths[..r].iter().sum();
    let row = &pool.candidates[i].rows[included[r]];
    (0..widths[r]).map(move |j| (offset + j, row[j]))
}

/// The candidates of the traditional design as the columns of one matrix (column i·legs + r:
/// row r of candidate i's block-diagonal block), as [`select_columns`] takes them.
pub(super) fn shared_columns(mechanism: &Mechanism, pool: &CandidatePool) -> DMatrix<f64> {
    let (included, widths) = shared_layout(mechanism);
    let legs = included.len();
    let mut columns = DMatrix::zeros(widths.iter().sum(), pool.candidates.len() * legs);
    for i in 0..pool.candidates.len() {
        for r in 0..legs {
            for (p, value) in shared_entries(pool, (&included, &widths), i, r) {
                columns[(p, i * legs + r)] = value;
            }
        }
    }
    columns
}

/// Turns a selection failure into an error; a rank-deficient pool names the parameters.
fn selection_error(
    mechanism: &Mechanism,
    pool: &CandidatePool,
    leg: usize,
    error: SelectionError,
    pool_rows: impl Fn() -> DMatrix<f64>,
    names: &[String],
) -> Error {
    match error {
        SelectionError::RankDeficient { .. } => {
            let observability = analyse(&pool_rows(), names);
            Error::Unidentifiable {
                file: None,
                leg: mechanism.legs[leg].name.clone(),
                rank: observability.rank,
                n: names.len(),
                params: format!(
                    "{} — the candidate pool cannot identify them (null-space directions, column-scaled: {})",
                    observability.unidentifiable.join(", "),
                    observability.null_directions.join("; ")
                ),
            }
        }
        SelectionError::NonFinite { index } => {
            let (name, value) = mechanism
                .legs
                .iter()
                .flat_map(|l| &l.params)
                .map(|p| (p.name.as_str(), p.nominal))
                .fold(
                    ("", 0.0f64),
                    |a, b| if b.1.abs() > a.1.abs() { b } else { a },
                );
            Error::Invalid(format!(
                "{}: the identification Jacobian overflows at candidate pose {}: the nominal \
                 parameters are too large to compute with (largest: {name} = {value:e})",
                mechanism.model_path.display(),
                mechanism.pose_text(&pool.candidates[index].pose)
            ))
        }
        other => Error::Invalid(format!(
            "pose selection for leg `{}`: {other}",
            mechanism.legs[leg].name
        )),
    }
}

/// Selected identification poses of a mechanism: per leg (divide and conquer) and, if asked,
/// shared (traditional).
#[derive(Debug, Clone)]
pub struct ExperimentDesign {
    /// The candidate pool the poses were selected from.
    pub candidates: usize,
    /// Grid spacing of the pool, metres.
    pub spacing: f64,
    /// Per identified leg (legs with every parameter fixed get no poses of their own).
    pub legs: Vec<LegDesign>,
    /// Number of legs of the mechanism.
    pub leg_count: usize,
    /// Shared by all legs, when requested.
    pub shared: Option<SharedDesign>,
}

impl ExperimentDesign {
    /// Selects `count` poses per leg (and `count` shared poses if `shared`) on a grid of spacing
    /// `spacing` (default: the model's), with `criterion`.
    ///
    /// # Errors
    /// [`nothing_identified`] first (before the pool is built), then as
    /// [`crate::selection::candidates::candidate_pool`], [`divide_and_conquer`] and [`traditional`].
    pub fn select(
        mechanism: &Mechanism,
        spacing: Option<f64>,
        count: usize,
        criterion: SelectionCriterion,
        shared: bool,
    ) -> Result<Self> {
        if mechanism.identified_legs().is_empty() {
            return Err(nothing_identified(mechanism));
        }
        let pool = crate::selection::candidates::candidate_pool(mechanism, spacing)?;
        let legs = divide_and_conquer(mechanism, &pool, count, criterion)?;
        let shared = if shared {
            Some(traditional(mechanism, &pool, count, criterion)?)
        } else {
            None
        };
        Ok(Self {
            leg_count: mechanism.legs.len(),
            candidates: pool.candidates.len(),
            spacing: pool.spacing,
            legs,
            shared,
        })
    }

    /// The true poses for a simulated experiment (shared poses empty if not designed).
    pub fn pose_sets(&self) -> crate::measure::simulate::PoseSets {
        crate::measure::simulate::PoseSets {
            per_leg: (0..self.leg_count)
                .map(|leg| {
                    self.legs
                        .iter()
                        .find(|d| d.leg == leg)
                        .map(|d| d.poses.clone())
                        .unwrap_or_default()
                })
                .collect(),
            shared: self
                .shared
                .as_ref()
                .map(|s| s.poses.clone())
                .unwrap_or_default(),
        }
    }
}
