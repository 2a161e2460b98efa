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

pub(super) fn run(args: &SelectArgs) -> anyhow::Result<Verdict> {
    let poses_per_leg = checks::poses_per_leg(args.poses_per_leg)?;
    checks::positive_metres("--grid", args.grid)?;
    let mechanism = Mechanism::load(&args.model)?;
    let inputs = model_inputs(&args.model, &mechanism);
    let output = Output::prepare("--out", &args.out, &inputs)?;
    let mut console = Console::new(output.is_stdout());
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
        let design = select_forward(&mechanism, args.grid, count, criterion)?;
        let text = forward_selection_text(&mechanism, &design, criterion);
        output.write(
            "pose CSV",
            forward_pose_file(&mechanism, &design)?.as_bytes(),
        )?;
        console.print(&text)?;
        let measured = match design.measured_poses.is_empty() {
            true => String::new(),
            false => format!(
                " (at the rows m1…, the measured platform pose in the columns {} instead)",
                mechanism.measured_names().join(", ")
            ),
        };
        console.line(format_args!(
            "poses written to {} (command the pose.* columns and fill in what the instrument \
             reports{measured}; leave the readings empty to take the nominal model's at the \
             commanded pose, or log them; then `legwise identify --measurements`)",
            output.name()
        ))?;
        return Ok(Verdict::from_reasons(mechanism.warnings.clone()));
    }
    let design = ExperimentDesign::select(&mechanism, args.grid, count, criterion, shared)?;
    let sets = Sets {
        per_leg: args.strategy != StrategyArg::Traditional,
        shared,
    };
    let text = selection_text(&mechanism, &design, (count, criterion), sets);
    let (csv, fill) = pose_file(&mechanism, &design, sets)?;
    output.write("pose CSV", csv.as_bytes())?;
    console.print(&text)?;
    console.line(format_args!(
        "poses written to {} ({fill}, then `legwise identify --measurements`)",
        output.name()
    ))?;
    Ok(Verdict::from_reasons(mechanism.warnings.clone()))
}
