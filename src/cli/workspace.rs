//! `legwise workspace`.

use std::fmt::Write as _;
use std::path::PathBuf;

use super::console::Console;
use super::output::{Input, Output};
use super::{Verdict, WorkspaceArgs};
use crate::measure::{file, MeasurementSet};
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;
use crate::report::plots::workspace::PoseGroup;
use crate::report::plots::{render, Format};
use crate::workspace::miw::{maximal_inscribed_workspace, MiwOptions, SingularityMargin};
use crate::workspace::picture::workspace_figure;

pub(super) fn run(args: &WorkspaceArgs) -> anyhow::Result<Verdict> {
    let rays = super::checks::count("--rays", args.rays, 16, 100_000)?;
    let mechanism = Mechanism::load(&args.model)?;
    if !mechanism.is_planar() {
        return Err(crate::error::Error::Invalid(format!(
            "{}: `legwise workspace` is not yet available for spatial models (measured: {}{}): \
             the MIW and its picture need a planar mechanism measured in x, y and at most yaw, \
             with a disc, box or polygon region",
            args.model.display(),
            mechanism.measured_names().join(", "),
            if mechanism.workspace.region.is_spatial() {
                "; a spatial region"
            } else {
                ""
            }
        ))
        .into());
    }
    let (path, format) = picture_path(args)?;
    let mut inputs = super::model_inputs(&args.model, &mechanism);
    inputs.extend(args.poses.as_deref().map(|path| Input {
        role: "pose file",
        path,
    }));
    let output = Output::prepare("--out", &path, &inputs)?;
    let poses = match &args.poses {
        Some(poses) => pose_groups(&mechanism, &file::read_poses(poses, &mechanism)?),
        None => Vec::new(),
    };
    let mut console = Console::new(output.is_stdout());
    let options = MiwOptions {
        rays,
        ..MiwOptions::for_mechanism(&mechanism)
    };
    let miw = maximal_inscribed_workspace(&mechanism, options)?;
    let held: Vec<String> = mechanism
        .measured
        .iter()
        .filter(|&&c| c >= 2)
        .map(|&c| format!("{} = {}", COORDINATES[c], mechanism.home_pose[c]))
        .collect();
    let mut text = String::new();
    writeln!(
        text,
        "legwise workspace: {} ({})",
        mechanism.name,
        mechanism.model_path.display()
    )?;
    if let Some(mode) = &mechanism.mode {
        writeln!(text, "mode: {mode}")?;
    }
    if !held.is_empty() {
        writeln!(
            text,
            "constant-orientation region at the home values: {}",
            held.join(", ")
        )?;
    }
    writeln!(text, "maximal inscribed workspace (MIW):")?;
    writeln!(
        text,
        "  centre  x = {:.7} m, y = {:.7} m",
        crate::report::tidy(miw.centre[0], 7),
        crate::report::tidy(miw.centre[1], 7)
    )?;
    writeln!(text, "  radius  {:.7} m", miw.radius)?;
    let margin = SingularityMargin::new(&mechanism)?;
    let title = format!("{}: singularity-free region and MIW", mechanism.name);
    let figure = workspace_figure(&margin, &miw, &title, poses);
    output.write("picture", &render(&figure, format)?)?;
    console.print(&text)?;
    console.line(format_args!("picture written to {}", output.name()))?;
    Ok(Verdict::Trusted)
}

/// `--out` (`-`: standard output), its format by the extension (or `--png` for standard
/// output), checked before any work; or the default `<model name>-workspace.svg|png`.
fn picture_path(args: &WorkspaceArgs) -> anyhow::Result<(PathBuf, Format)> {
    let png = super::pictures::format(args.png);
    match &args.out {
        Some(path) if path.as_os_str() == "-" => Ok((path.clone(), png)),
        Some(path) => {
            let format = Format::from_path(path)?;
            if args.png && format != Format::Png {
                anyhow::bail!(
                    "--png: the picture {} does not end in .png; drop --png or rename it",
                    path.display()
                );
            }
            Ok((path.clone(), format))
        }
        None => {
            let stem = args
                .model
                .file_stem()
                .map_or("model".into(), |s| s.to_string_lossy().into_owned());
            Ok((
                PathBuf::from(format!("{stem}-workspace.{}", png.extension())),
                png,
            ))
        }
    }
}

/// The poses of a pose file, grouped by their leg label (shared poses last).
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
