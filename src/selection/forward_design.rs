//! Experiment design for a model seen through the forward kinematics
//! (`instrument.kinematics: forward`): the commanded poses of its rows (probe points for a
//! delta's bed probe, reflector positions for a hexapod), selected for observability with the
//! same engines as the inverse designs.
//!
//! Every feasible pose of the workspace's candidate grid is moved to its touch on the nominal
//! surface (a target declaring `touch`: a probe lowered onto the nominal bed), distinct touches
//! kept; at each, the nominal model's inverse kinematics gives the row's readings, and the
//! joint problem's Jacobian at the nominal parameters gives the candidate's block: one row per
//! coordinate the instrument reports, over every unknown the model identifies (legs and
//! instrument together: forward rows couple them all). The selection picks the model's
//! `selection.poses_per_leg` of them by its criterion (D by default). Distances between rows
//! are not designed (the simulation draws their pairs among the selected rows).

use nalgebra::DMatrix;

use super::design::selection_options;
use super::{select_columns, Selection, SelectionError};
use crate::error::{Error, Result};
use crate::evaluate::commanded_rows::commanded_rows;
use crate::identify::observability::{
    analyse, unit_columns, with_a_row_per_column, Observability, RANK_TOLERANCE,
};
use crate::identify::problem::IdentificationProblem;
use crate::measure::forward_simulate::{home_side, touched};
use crate::model::mechanism::SelectionCriterion;
use crate::model::Mechanism;
use crate::workspace::candidates::feasible_poses;

/// Touches that agree to this (metres, radians) in every coordinate are one candidate.
const SAME_TOUCH: f64 = 1e-9;

/// The selected commanded poses of a forward model's rows.
#[derive(Debug, Clone)]
pub struct ForwardDesign {
    /// Distinct candidate poses (after the touch, where a target declares one) the rows were
    /// selected from.
    pub candidates: usize,
    /// Grid spacing of the candidate pool, metres.
    pub spacing: f64,
    /// The selected commanded poses (each at its nominal touch), in pool order.
    pub poses: Vec<[f64; 6]>,
    /// With `instrument.poses`: the selected poses whose platform pose is measured (the
    /// model's `poses.simulate` of them, in pool order), after the touches.
    pub measured_poses: Vec<[f64; 6]>,
    /// Observability of the joint problem's Jacobian (nominal parameters) on the rows.
    pub observability: Observability,
    /// What the selection algorithm reports.
    pub selection: Selection,
}

/// Selects `count` commanded poses of `mechanism`'s forward rows from its candidate grid of
/// spacing `spacing` (default: the model's `workspace.grid`) by `criterion`.
///
/// # Errors
/// Not a forward model, an empty candidate pool, a touch that cannot be reached, a pool that
/// cannot identify the model's unknowns (the rank check's message, naming them), or a
/// selection failure.
pub fn select_forward(
    mechanism: &Mechanism,
    spacing: Option<f64>,
    count: usize,
    criterion: SelectionCriterion,
) -> Result<ForwardDesign> {
    let Some(instrument) = mechanism.forward_instrument() else {
        return Err(Error::Invalid(format!(
            "{}: forward pose selection needs an instrument seen through the forward \
             kinematics (`instrument.kinematics: forward`)",
            mechanism.model_path.display()
        )));
    };
    let feasible = feasible_poses(mechanism, spacing)?;
    let nominal_shared = instrument.nominal();
    // Distinct touches, each found once by its pose rounded to `SAME_TOUCH` (a grid's columns
    // lowered onto one surface coincide).
    let mut touches: Vec<[f64; 6]> = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for candidate in &feasible.candidates {
        let pose = touched(mechanism, instrument, &nominal_shared, candidate.pose)?;
        if seen.insert(pose.map(|v| (v / SAME_TOUCH).round() as i64)) {
            touches.push(pose);
        }
    }
    // The nominal model's readings at each touch it reaches, and where it closes there.
    let nominal = mechanism.nominal_parameters();
    let width = instrument.observed_len();
    let (poses, observations, configurations) =
        commanded_rows(mechanism, &nominal, &touches, width);
    let problem = IdentificationProblem::through_instrument(mechanism, &observations)?;
    let x = problem.start();
    problem.close_forward_rows_at(&x, configurations);
    let (_, jacobian) = problem.residuals_and_jacobian(&x).map_err(|e| {
        Error::Invalid(format!(
            "{}: forward pose selection: {}: {}",
            mechanism.model_path.display(),
            e.location,
            e.source
        ))
    })?;
    let names = problem.names();
    let options = selection_options(count, criterion);
    // With measured poses beside the rows, the rows need only see what they can: selected on
    // the combinations of the (column-scaled) unknowns the pool identifies.
    // Likewise with priors: what the rows cannot see rests on them.
    let priors = problem.with_priors().map_or(1, |p| p.prior_rows().len());
    let pool = match (&instrument.poses, priors) {
        (None, 0) => jacobian.clone(),
        _ => seen_combinations(&jacobian),
    };
    let selection =
        select_columns(pool.transpose(), width, &options).map_err(|error| match error {
            SelectionError::RankDeficient { .. } => {
                let pool = analyse(&jacobian, &names);
                Error::Invalid(format!(
                    "{}: forward pose selection: the candidate pool cannot identify {} (rank \
                     {} of {}; null-space directions, column-scaled: {}); hold them or add \
                     observations that see them",
                    mechanism.model_path.display(),
                    pool.unidentifiable.join(", "),
                    pool.rank,
                    names.len(),
                    pool.null_directions.join("; ")
                ))
            }
            other => Error::Invalid(format!(
                "{}: forward pose selection: {other}",
                mechanism.model_path.display()
            )),
        })?;
    let chosen = DMatrix::from_fn(selection.indices.len() * width, jacobian.ncols(), |r, c| {
        jacobian[(selection.indices[r / width] * width + r % width, c)]
    });
    let measured = instrument.poses.as_ref().map_or(0, |p| p.simulate);
    let (measured_poses, chosen) = match measured {
        0 => (Vec::new(), chosen),
        count => {
            let candidates = feasible.candidates.iter().map(|c| c.pose);
            let above = home_side(mechanism, instrument, &nominal_shared);
            let clear = candidates.filter(|p| above(p));
            let (poses, rows) =
                select_measured(mechanism, &clear.collect::<Vec<_>>(), count, criterion)?;
            let mut both = DMatrix::zeros(chosen.nrows() + rows.nrows(), chosen.ncols());
            both.rows_mut(0, chosen.nrows()).copy_from(&chosen);
            both.rows_mut(chosen.nrows(), rows.nrows()).copy_from(&rows);
            (poses, both)
        }
    };
    Ok(ForwardDesign {
        candidates: poses.len(),
        spacing: feasible.spacing,
        poses: selection.indices.iter().map(|&i| poses[i]).collect(),
        measured_poses,
        observability: analyse(&chosen, &names),
        selection,
    })
}

impl ForwardDesign {
    /// Every selected row's commanded pose: the touches, then the measured poses (the order
    /// a simulation takes them in).
    pub fn commanded(&self) -> Vec<[f64; 6]> {
        self.poses
            .iter()
            .chain(&self.measured_poses)
            .copied()
            .collect()
    }
}

/// Selects `count` of the poses `candidates` whose platform pose is to be measured, by
/// `criterion` on the combinations of the unknowns such rows see ([`seen_combinations`]):
/// each candidate's rows are every identified leg's reading predicted at the pose by the
/// nominal model (the joint problem's blocks of a measured pose). Returns the poses and their
/// Jacobian rows.
///
/// # Errors
/// No candidate the nominal model reaches, or a selection failure.
fn select_measured(
    mechanism: &Mechanism,
    candidates: &[[f64; 6]],
    count: usize,
    criterion: SelectionCriterion,
) -> Result<(Vec<[f64; 6]>, DMatrix<f64>)> {
    let nominal = mechanism.nominal_parameters();
    let (poses, mut observations, _) = commanded_rows(mechanism, &nominal, candidates, 0);
    for (row, pose) in observations.rows.iter_mut().zip(&poses) {
        row.observed = Vec::new();
        row.pose = Some(*pose);
    }
    let fail = |message: String| {
        Error::Invalid(format!(
            "{}: selection of the measured poses: {message}",
            mechanism.model_path.display()
        ))
    };
    let problem = IdentificationProblem::through_instrument(mechanism, &observations)?;
    let x = problem.start();
    let (_, jacobian) = problem
        .residuals_and_jacobian(&x)
        .map_err(|e| fail(format!("{}: {}", e.location, e.source)))?;
    // Every identified leg's reading at each candidate: that many rows a candidate.
    let width = mechanism.identified_legs().len();
    let options = selection_options(count, criterion);
    let pool = seen_combinations(&jacobian);
    let selection =
        select_columns(pool.transpose(), width, &options).map_err(|e| fail(e.to_string()))?;
    let rows = DMatrix::from_fn(selection.indices.len() * width, jacobian.ncols(), |r, c| {
        jacobian[(selection.indices[r / width] * width + r % width, c)]
    });
    Ok((selection.indices.iter().map(|&i| poses[i]).collect(), rows))
}

/// The rows of `jacobian` over the combinations of its column-scaled unknowns it identifies:
/// `J D V_r`, `D` the column scaling of the rank check ([`unit_columns`]) and `V_r` the right
/// singular vectors of `J D` whose singular values exceed 1e-8 of the largest (the rank
/// check's threshold). A D-optimal selection on it maximises the product of the selected
/// rows' information over what the pool can see.
fn seen_combinations(jacobian: &DMatrix<f64>) -> DMatrix<f64> {
    let scaled = unit_columns(jacobian);
    let svd = with_a_row_per_column(scaled.clone()).svd(false, true);
    let Some(v_t) = svd.v_t else {
        return scaled;
    };
    let largest = svd.singular_values.max();
    let kept: Vec<usize> = (0..svd.singular_values.len())
        .filter(|&k| svd.singular_values[k] > RANK_TOLERANCE * largest)
        .collect();
    let basis = DMatrix::from_fn(scaled.ncols(), kept.len(), |j, k| v_t[(kept[k], j)]);
    scaled * basis
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::platform::Configuration;

    /// The bundled bed-probe model.
    fn probe() -> Mechanism {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/delta-probe.yaml");
        Mechanism::load(&path).expect("bundled model")
    }

    /// Rows whose readings the nominal model commands at two touches, and the configurations
    /// it reaches there.
    fn commanded_touches(
        mechanism: &Mechanism,
    ) -> (
        crate::measure::observations::Observations,
        Vec<Configuration>,
    ) {
        let poses = [
            [0.01, -0.02, 0.02, 0.0, 0.0, 0.0],
            [-0.03, 0.01, 0.02, 0.0, 0.0, 0.0],
        ];
        let nominal = mechanism.nominal_parameters();
        let (kept, observations, configurations) = commanded_rows(mechanism, &nominal, &poses, 1);
        assert_eq!(kept.len(), 2, "both touches reachable");
        (observations, configurations)
    }

    /// The bundled delta's bed-probe pool is three-fold symmetric: a design point and its
    /// mirror image are equivalent, and swapping one for the other computes to 1 ± 1e-12.
    /// No such swap is taken: the exchange converges after the improving swaps, far within
    /// its sweep budget.
    #[test]
    fn a_symmetric_pool_s_exchange_takes_no_swap_that_changes_nothing() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models/delta-probe-distances.yaml");
        let mechanism = Mechanism::load(&path).expect("bundled model");
        let design = select_forward(&mechanism, None, 37, SelectionCriterion::D).unwrap();
        let selection = &design.selection;
        assert_eq!(design.candidates, 49);
        // The greedy design's two improving swaps (by 3 % and 0.19 % in det M), no more.
        assert_eq!(selection.exchanges, 2, "{selection:?}");
        assert!(selection.sweeps <= 3, "{selection:?}");
    }

    #[test]
    fn rows_closed_at_given_configurations_are_evaluated_there_without_a_solve() {
        let mechanism = probe();
        let (observations, configurations) = commanded_touches(&mechanism);
        let problem =
            || IdentificationProblem::through_instrument(&mechanism, &observations).unwrap();
        let cold = problem();
        let x = cold.start();
        let from_home = cold.residuals(&x).unwrap();
        // At the configurations the model commands: what its forward kinematics finds from home.
        let seeded = problem();
        seeded.close_forward_rows_at(&x, configurations.clone());
        let given = seeded.residuals(&x).unwrap();
        assert!(
            (&given - &from_home).amax() <= 1e-12,
            "{given} vs {from_home}"
        );
        // Moved 1 mm up, they are taken as given: the nozzle's height is 1 mm more.
        let moved = problem();
        let up = configurations
            .iter()
            .map(|c| {
                let mut c = c.clone();
                c.pose[2] += 1e-3;
                c
            })
            .collect();
        moved.close_forward_rows_at(&x, up);
        let off = moved.residuals(&x).unwrap();
        for (a, b) in off.iter().zip(from_home.iter()) {
            assert!((a - b - 1e-3).abs() <= 1e-12, "{a} vs {b}");
        }
    }
}
