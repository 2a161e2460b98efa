//! The report of `legwise select`: the selected design in words (each leg's observability
//! indices and its optimality certificate, the shared set's), and the pose file to measure.

use std::fmt::Write as _;

use crate::error::Result;
use crate::measure::{file, observations, MeasuredPose, MeasurementSet};
use crate::model::mechanism::SelectionCriterion;
use crate::model::Mechanism;
use crate::selection::design::ExperimentDesign;
use crate::selection::forward_design::ForwardDesign;

/// Which of a design's pose sets go into the pose file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sets {
    /// Each leg's own poses (divide and conquer).
    pub per_leg: bool,
    /// The shared poses (traditional).
    pub shared: bool,
}

/// The text of `design`, selected with `count` poses per leg by `criterion`, for the sets
/// `sets`.
pub fn selection_text(
    mechanism: &Mechanism,
    design: &ExperimentDesign,
    (count, criterion): (usize, SelectionCriterion),
    sets: Sets,
) -> String {
    let mut text = super::title("select", mechanism);
    let _ = writeln!(
        text,
        "{} feasible candidate poses (grid {} m); criterion {:?}; {} poses per leg",
        design.candidates, design.spacing, criterion, count
    );
    for leg_design in design.legs.iter().filter(|_| sets.per_leg) {
        let o = &leg_design.observability;
        let _ = writeln!(
            text,
            "  leg {}: O1 {:.4}, O2 {:.3e}, O3 {:.4}, O4 {:.3e}, O5 {:.4}; condition {:.1}; Kiefer-Wolfowitz {:.2} (n = {})",
            mechanism.legs[leg_design.leg].name,
            o.indices[0], o.indices[1], o.indices[2], o.indices[3], o.indices[4],
            o.condition, leg_design.selection.certificate, o.singular_values.len()
        );
    }
    if let Some(shared) = &design.shared {
        let o = &shared.stacked;
        let _ = writeln!(
            text,
            "  shared (all legs): O1 {:.4}, O3 {:.4}; condition {:.1}",
            o.indices[0], o.indices[2], o.condition
        );
    }
    text
}

/// The pose file of `design`'s `sets` in the measurement CSV layout `mechanism` reads, with
/// what the user fills in: the readings, or through an instrument the poses to command and the
/// target coordinates and readings to fill in.
///
/// # Errors
/// The instrument's template cannot be written.
pub fn pose_file(
    mechanism: &Mechanism,
    design: &ExperimentDesign,
    sets: Sets,
) -> Result<(String, &'static str)> {
    let legs = mechanism.legs.len();
    let mut set = MeasurementSet::new(None, legs);
    let mut push = |leg: Option<usize>, poses: &[[f64; 6]]| {
        for &pose in poses {
            let row = MeasuredPose {
                line: None,
                leg,
                pose,
            };
            set.push(row, &vec![None; legs]);
        }
    };
    for leg_design in design.legs.iter().filter(|_| sets.per_leg) {
        push(Some(leg_design.leg), &leg_design.poses);
    }
    if let Some(shared) = design.shared.as_ref().filter(|_| sets.shared) {
        push(None, &shared.poses);
    }
    Ok(if mechanism.instrument.is_some() {
        (
            observations::template_csv(mechanism, &set, 0)?,
            "command the pose.* columns, fill in the target coordinates and the readings",
        )
    } else {
        (file::to_csv(mechanism, &set), "fill in the readings")
    })
}

/// The report of a forward model's selected rows ([`ForwardDesign`]).
pub fn forward_selection_text(
    mechanism: &Mechanism,
    design: &ForwardDesign,
    criterion: SelectionCriterion,
) -> String {
    let mut text = super::title("select", mechanism);
    let o = &design.observability;
    // Only a target that declares `touch` moves the grid's poses (onto the nominal surface).
    let touches = mechanism
        .forward_instrument()
        .is_some_and(|instrument| instrument.targets.iter().any(|t| t.touch.is_some()));
    let spacing = design.spacing;
    let candidates = if touches {
        format!(
            "distinct candidate rows (grid {spacing} m, each at its touch on the nominal surface)"
        )
    } else {
        format!("candidate rows (grid {spacing} m, one at each feasible pose of the grid)")
    };
    let _ = writeln!(
        text,
        "{} {}; criterion {:?}; {} rows of every leg's reading (forward kinematics: the legs \
         and the instrument identified together)",
        design.candidates,
        candidates,
        criterion,
        design.poses.len()
    );
    if !design.measured_poses.is_empty() {
        let _ = writeln!(
            text,
            "then {} rows whose platform pose is measured (ids m1…; selected on what such rows \
             see, from the grid's poses on home's side of the touch surface)",
            design.measured_poses.len()
        );
    }
    let _ = writeln!(
        text,
        "  joint problem ({} unknowns): O1 {:.4}, O3 {:.4e}; condition {:.1}, column-scaled {:.1}; \
         Kiefer-Wolfowitz {:.2}",
        o.singular_values.len(),
        o.indices[0],
        o.indices[2],
        o.condition,
        o.scaled_condition,
        design.selection.certificate
    );
    text
}

/// The pose file of a forward design: one row per selected pose, the commanded `pose.*`
/// columns filled, the instrument's coordinates and the readings to fill in (left empty, the
/// readings are the nominal model's inverse kinematics of the commanded pose).
///
/// # Errors
/// A model without an instrument.
pub fn forward_pose_file(mechanism: &Mechanism, design: &ForwardDesign) -> Result<String> {
    let legs = mechanism.legs.len();
    let mut set = MeasurementSet::new(None, legs);
    for pose in design.commanded() {
        let row = MeasuredPose {
            line: None,
            leg: None,
            pose,
        };
        set.push(row, &vec![None; legs]);
    }
    observations::template_csv(mechanism, &set, design.measured_poses.len())
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::forward_selection_text;
    use crate::identify::observability::analyse;
    use crate::model::mechanism::SelectionCriterion;
    use crate::model::Mechanism;
    use crate::selection::forward_design::ForwardDesign;
    use crate::selection::Selection;

    fn bundled(name: &str) -> Mechanism {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models")
            .join(name);
        Mechanism::load(&path).expect("bundled model")
    }

    /// A design of two rows over two unknowns from a pool of 7 candidates, grid 0.025 m.
    fn design() -> ForwardDesign {
        let names = vec!["p".to_string(), "q".to_string()];
        ForwardDesign {
            candidates: 7,
            spacing: 0.025,
            poses: vec![[0.0, 0.0, 0.6, 0.0, 0.0, 0.0]; 2],
            measured_poses: Vec::new(),
            observability: analyse(&DMatrix::identity(2, 2), &names),
            selection: Selection {
                indices: vec![0, 1],
                sweeps: 1,
                exchanges: 0,
                excursions: 0,
                log_det: 0.0,
                engine: "E",
                certificate: 2.0,
            },
        }
    }

    #[test]
    fn the_candidates_are_said_to_be_touches_only_where_a_target_touches() {
        let first_line = |model: &str| {
            let text = forward_selection_text(&bundled(model), &design(), SelectionCriterion::E);
            text.lines().nth(1).expect("the pool's line").to_string()
        };
        // One tracker reflector: the grid's poses are the candidates, nothing touches.
        assert_eq!(
            first_line("hexapod-reflector.yaml"),
            "7 candidate rows (grid 0.025 m, one at each feasible pose of the grid); criterion \
             E; 2 rows of every leg's reading (forward kinematics: the legs and the instrument \
             identified together)"
        );
        // A bed probe (`touch: 0.0`): each pose lowered onto the nominal bed.
        assert_eq!(
            first_line("delta-probe.yaml"),
            "7 distinct candidate rows (grid 0.025 m, each at its touch on the nominal \
             surface); criterion E; 2 rows of every leg's reading (forward kinematics: the legs \
             and the instrument identified together)"
        );
    }
}
