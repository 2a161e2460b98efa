//! `legwise select`: the identification poses to measure, in the measurement CSV layout.

use super::SelectArgs;
use crate::measure::{file, MeasuredPose, MeasurementSet};
use crate::model::Mechanism;
use crate::workspace::design::ExperimentDesign;

pub(super) fn run(args: &SelectArgs) -> anyhow::Result<()> {
    let mechanism = Mechanism::load(&args.model)?;
    super::check_poses_per_leg(args.poses_per_leg)?;
    let count = args
        .poses_per_leg
        .unwrap_or(mechanism.selection.poses_per_leg);
    let shared = args.strategy != super::StrategyArg::Dc;
    let criterion = args
        .criterion
        .map_or(mechanism.selection.criterion, |c| c.criterion());
    let design = ExperimentDesign::select(&mechanism, args.grid, count, criterion, shared)?;
    println!(
        "legwise select: {} ({})",
        mechanism.name,
        mechanism.model_path.display()
    );
    println!(
        "{} feasible candidate poses (grid {} m); criterion {:?}; {} poses per leg",
        design.candidates, design.spacing, criterion, count
    );
    let legs = mechanism.legs.len();
    let mut poses = Vec::new();
    if args.strategy != super::StrategyArg::Traditional {
        for leg_design in &design.legs {
            let o = &leg_design.observability;
            println!(
                "  leg {}: O1 {:.4}, O2 {:.3e}, O3 {:.4}, O4 {:.3e}, O5 {:.4}; condition {:.1}; Kiefer-Wolfowitz {:.2} (n = {})",
                mechanism.legs[leg_design.leg].name,
                o.indices[0], o.indices[1], o.indices[2], o.indices[3], o.indices[4],
                o.condition, leg_design.selection.certificate, o.singular_values.len()
            );
            poses.extend(leg_design.poses.iter().map(|&pose| MeasuredPose {
                line: None,
                leg: Some(leg_design.leg),
                pose,
                readings: vec![None; legs],
            }));
        }
    }
    if let Some(shared) = &design.shared {
        let o = &shared.stacked;
        println!(
            "  shared (all legs): O1 {:.4}, O3 {:.4}; condition {:.1}",
            o.indices[0], o.indices[2], o.condition
        );
        poses.extend(shared.poses.iter().map(|&pose| MeasuredPose {
            line: None,
            leg: None,
            pose,
            readings: vec![None; legs],
        }));
    }
    file::write(
        &args.out,
        &mechanism,
        &MeasurementSet {
            source: None,
            poses,
        },
    )?;
    println!(
        "poses written to {} (fill in the readings, then `legwise identify --measurements`)",
        args.out.display()
    );
    Ok(())
}
