//! `legwise select`: the identification poses to measure, in the measurement CSV layout.

use std::fmt::Write as _;

use super::args::SelectArgs;
use super::console::Console;
use super::verdict::Verdict;
use crate::files::Output;
use crate::measure::{file, observations, MeasuredPose, MeasurementSet};
use crate::model::Mechanism;
use crate::selection::design::ExperimentDesign;

pub(super) fn run(args: &SelectArgs) -> anyhow::Result<Verdict> {
    let poses_per_leg = super::checks::poses_per_leg(args.poses_per_leg)?;
    super::checks::positive_metres("--grid", args.grid)?;
    let mechanism = Mechanism::load(&args.model)?;
    let output = Output::prepare(
        "--out",
        &args.out,
        &super::checks::model_inputs(&args.model, &mechanism),
    )?;
    let mut console = Console::new(output.is_stdout());
    let count = poses_per_leg.unwrap_or(mechanism.selection.poses_per_leg);
    let shared = args.strategy != super::args::StrategyArg::Dc;
    let criterion = args
        .criterion
        .map_or(mechanism.selection.criterion, |c| c.criterion());
    let design = ExperimentDesign::select(&mechanism, args.grid, count, criterion, shared)?;
    let mut text = String::new();
    writeln!(
        text,
        "legwise select: {} ({})",
        mechanism.name,
        mechanism.model_path.display()
    )?;
    writeln!(
        text,
        "{} feasible candidate poses (grid {} m); criterion {:?}; {} poses per leg",
        design.candidates, design.spacing, criterion, count
    )?;
    let legs = mechanism.legs.len();
    let mut set = MeasurementSet::new(None, legs);
    if args.strategy != super::args::StrategyArg::Traditional {
        for leg_design in &design.legs {
            let o = &leg_design.observability;
            writeln!(
                text,
                "  leg {}: O1 {:.4}, O2 {:.3e}, O3 {:.4}, O4 {:.3e}, O5 {:.4}; condition {:.1}; Kiefer-Wolfowitz {:.2} (n = {})",
                mechanism.legs[leg_design.leg].name,
                o.indices[0], o.indices[1], o.indices[2], o.indices[3], o.indices[4],
                o.condition, leg_design.selection.certificate, o.singular_values.len()
            )?;
            for &pose in &leg_design.poses {
                let leg = Some(leg_design.leg);
                let row = MeasuredPose {
                    line: None,
                    leg,
                    pose,
                };
                set.push(row, &vec![None; legs]);
            }
        }
    }
    if let Some(shared) = &design.shared {
        let o = &shared.stacked;
        writeln!(
            text,
            "  shared (all legs): O1 {:.4}, O3 {:.4}; condition {:.1}",
            o.indices[0], o.indices[2], o.condition
        )?;
        for &pose in &shared.poses {
            let row = MeasuredPose {
                line: None,
                leg: None,
                pose,
            };
            set.push(row, &vec![None; legs]);
        }
    }
    // With an instrument, the file is what `identify --measurements` reads for that model:
    // the poses to command, and the target coordinates and readings to fill in.
    let (csv, fill) = if mechanism.instrument.is_some() {
        (
            observations::template_csv(&mechanism, &set)?,
            "command the pose.* columns, fill in the target coordinates and the readings",
        )
    } else {
        (file::to_csv(&mechanism, &set), "fill in the readings")
    };
    output.write("pose CSV", csv.as_bytes())?;
    console.print(&text)?;
    console.line(format_args!(
        "poses written to {} ({fill}, then `legwise identify --measurements`)",
        output.name()
    ))?;
    Ok(Verdict::Trusted)
}
