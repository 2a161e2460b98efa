//! `legwise select`: the identification poses to measure, in the measurement CSV layout.

use super::args::{CriterionArg, SelectArgs, StrategyArg};
use super::checks;
use super::console::Console;
use super::outputs::model_inputs;
use super::verdict::Verdict;
use crate::files::Output;
use crate::model::mechanism::SelectionCriterion;
use crate::model::Mechanism;
use crate::report::selection::{
    forward_pose_file, forward_selection_text, pose_file, selection_text, Sets,
};
use crate::selection::design::ExperimentDesign;
use crate::selection::forward_design::select_forward;
use crate::study::how_many::design_sigma;

pub(super) fn run(args: &SelectArgs) -> anyhow::Result<Verdict> {
    let (poses_per_leg, mechanism) = checked(args)?;
    let inputs = model_inputs(&args.model, &mechanism);
    let output = Output::prepare("--out", &args.out, &inputs)?;
    let mut console = Console::new(output.is_stdout());
    let selection = selected(args, &mechanism, poses_per_leg)?;
    output.write("pose CSV", selection.csv.as_bytes())?;
    console.print(&selection.text)?;
    console.line(format_args!(
        "poses written to {} ({})",
        output.name(),
        selection.advice
    ))?;
    Ok(Verdict::from_reasons(mechanism.warnings.clone()))
}

/// The checks of `args` made before any work, the poses per leg asked for and the model.
///
/// # Errors
/// A bad option, or a model that does not load.
pub(super) fn checked(args: &SelectArgs) -> anyhow::Result<(Option<usize>, Mechanism)> {
    let poses_per_leg = checks::poses_per_leg(args.poses_per_leg)?;
    checks::positive_metres("--grid", args.grid)?;
    let mechanism = Mechanism::load(&args.model)?;
    if mechanism.forward_instrument().is_some() && args.strategy != StrategyArg::Dc {
        // It changed nothing, silently.
        anyhow::bail!(
            "--strategy: a model seen through the forward kinematics (`instrument.kinematics: \
             forward`) has one set of rows, every leg's reading at each, selected for the \
             joint problem of every leg and the instrument: drop --strategy"
        );
    }
    Ok((poses_per_leg, mechanism))
}

/// The selected poses of a run of `legwise select`.
#[derive(Debug, Clone)]
pub(super) struct Selection {
    /// The pose file (measurement CSV layout, readings empty).
    pub(super) csv: String,
    /// The report of the selection.
    pub(super) text: String,
    /// What to do with the file: what to fill in, then identify.
    pub(super) advice: String,
}

/// Selects the poses `args` ask for on `mechanism` (`poses_per_leg` from [`checked`]).
///
/// # Errors
/// A selection that fails (no feasible candidate, too few), or a file that cannot be made.
pub(super) fn selected(
    args: &SelectArgs,
    mechanism: &Mechanism,
    poses_per_leg: Option<usize>,
) -> anyhow::Result<Selection> {
    let count = poses_per_leg.unwrap_or(mechanism.selection.poses_per_leg);
    let shared = args.strategy != StrategyArg::Dc;
    let criterion = match args.criterion {
        Some(CriterionArg::D) => SelectionCriterion::D,
        Some(CriterionArg::A) => SelectionCriterion::A,
        Some(CriterionArg::E) => SelectionCriterion::E,
        None => mechanism.selection.criterion,
    };
    if mechanism.forward_instrument().is_some() {
        // Forward rows: every leg's reading at each, selected for the joint problem.
        let design = select_forward(mechanism, args.grid, count, criterion)?;
        let measured = match design.measured_poses.is_empty() {
            true => String::new(),
            false => format!(
                " (at the rows m1…, the measured platform pose in the columns {} instead)",
                mechanism.measured_names().join(", ")
            ),
        };
        let promise = design_text(mechanism, count, criterion, args.grid);
        return Ok(Selection {
            csv: forward_pose_file(mechanism, &design)?,
            text: forward_selection_text(mechanism, &design, criterion) + &promise,
            advice: format!(
                "command the pose.* columns and fill in what the instrument reports{measured}; \
                 leave the readings empty to take the nominal model's at the commanded pose, or \
                 log them; then `legwise identify --measurements`"
            ),
        });
    }
    let design = ExperimentDesign::select(mechanism, args.grid, count, criterion, shared)?;
    let sets = Sets {
        per_leg: args.strategy != StrategyArg::Traditional,
        shared,
    };
    let mut text = selection_text(mechanism, &design, (count, criterion), sets);
    if args.strategy == StrategyArg::Dc {
        text.push_str(&design_text(mechanism, count, criterion, args.grid));
    }
    let (csv, fill) = pose_file(mechanism, &design, sets)?;
    Ok(Selection {
        csv,
        text,
        advice: format!("{fill}, then `legwise identify --measurements`"),
    })
}

/// The selected rows' promise: the design's predicted σ over the workspace from the declared
/// noise ([`design_sigma`]), a line; empty when there is none.
fn design_text(
    mechanism: &Mechanism,
    count: usize,
    criterion: SelectionCriterion,
    grid: Option<f64>,
) -> String {
    design_sigma(mechanism, count, criterion, grid).map_or(String::new(), |p| {
        format!(
            "design: the predicted σ of `{}`'s position over the workspace ({} points) after the \
             model's own fit on these rows, from the declared noise: RMS {:.4} mm, max {:.4} mm \
             (`legwise how-many` for other counts)\n",
            p.target,
            p.points,
            p.rms * 1e3,
            p.max * 1e3
        )
    })
}
