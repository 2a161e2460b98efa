//! `legwise workspace`.

use std::path::{Path, PathBuf};

use super::WorkspaceArgs;
use crate::measure::{file, MeasurementSet};
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;
use crate::report::plots::workspace::PoseGroup;
use crate::report::plots::{self, Format};
use crate::workspace::miw::{maximal_inscribed_workspace, MiwOptions, SingularityMargin};
use crate::workspace::picture::workspace_figure;

pub(super) fn run(args: &WorkspaceArgs) -> anyhow::Result<()> {
    let mechanism = Mechanism::load(&args.model)?;
    if !(16..=100_000).contains(&args.rays) {
        anyhow::bail!(
            "--rays: expected between 16 and 100000, found {}",
            args.rays
        );
    }
    let path = picture_path(args)?;
    let poses = match &args.poses {
        Some(poses) => pose_groups(&mechanism, &file::read_poses(poses, &mechanism)?),
        None => Vec::new(),
    };
    let options = MiwOptions {
        rays: args.rays,
        ..MiwOptions::for_mechanism(&mechanism)
    };
    let miw = maximal_inscribed_workspace(&mechanism, options)?;
    let held: Vec<String> = mechanism
        .measured
        .iter()
        .filter(|&&c| c >= 2)
        .map(|&c| format!("{} = {}", COORDINATES[c], mechanism.home_pose[c]))
        .collect();
    println!(
        "legwise workspace: {} ({})",
        mechanism.name,
        mechanism.model_path.display()
    );
    if let Some(mode) = &mechanism.mode {
        println!("mode: {mode}");
    }
    if !held.is_empty() {
        println!(
            "constant-orientation region at the home values: {}",
            held.join(", ")
        );
    }
    println!("maximal inscribed workspace (MIW):");
    println!(
        "  centre  x = {:.7} m, y = {:.7} m",
        crate::report::tidy(miw.centre[0], 7),
        crate::report::tidy(miw.centre[1], 7)
    );
    println!("  radius  {:.7} m", miw.radius);
    let margin = SingularityMargin::new(&mechanism)?;
    let title = format!("{}: singularity-free region and MIW", mechanism.name);
    let figure = workspace_figure(&margin, &miw, &title, poses);
    let mut inputs: Vec<&Path> = vec![&args.model, &mechanism.model_path];
    inputs.extend(args.poses.as_deref());
    plots::write(&figure, &path, &inputs)
        .map_err(|e| anyhow::anyhow!("cannot write the picture: {e}"))?;
    println!("picture written to {}", path.display());
    Ok(())
}

/// `--out`, checked for a known extension before any work, or the default name.
fn picture_path(args: &WorkspaceArgs) -> anyhow::Result<PathBuf> {
    match &args.out {
        Some(path) => {
            let format = Format::from_path(path)?;
            if args.png && format != Format::Png {
                anyhow::bail!(
                    "--png: the picture {} does not end in .png; drop --png or rename it",
                    path.display()
                );
            }
            Ok(path.clone())
        }
        None => {
            let stem = args
                .model
                .file_stem()
                .map_or("model".into(), |s| s.to_string_lossy().into_owned());
            let format = if args.png { Format::Png } else { Format::Svg };
            Ok(PathBuf::from(format!(
                "{stem}-workspace.{}",
                format.extension()
            )))
        }
    }
}

/// The poses of a measurement file, grouped by their leg label (shared poses last).
fn pose_groups(mechanism: &Mechanism, set: &MeasurementSet) -> Vec<PoseGroup> {
    let source = set
        .source
        .as_ref()
        .and_then(|p| p.file_name())
        .map_or(String::new(), |n| format!(" of {}", n.to_string_lossy()));
    let labels = mechanism
        .legs
        .iter()
        .enumerate()
        .map(|(l, leg)| (Some(l), leg.name.clone()));
    labels
        .chain(std::iter::once((None, "shared".to_string())))
        .filter_map(|(leg, name)| {
            let points: Vec<[f64; 2]> = set
                .poses
                .iter()
                .filter(|p| p.leg == leg)
                .map(|p| [p.pose[0], p.pose[1]])
                .collect();
            (!points.is_empty()).then(|| PoseGroup {
                name: format!("{name} poses{source}"),
                points,
            })
        })
        .collect()
}
