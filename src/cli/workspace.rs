//! `legwise workspace`.

use std::fmt::Write as _;
use std::path::PathBuf;

use super::args::WorkspaceArgs;
use super::console::Console;
use super::verdict::Verdict;
use crate::files::{Input, Output};
use crate::measure::{file, MeasurementSet};
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;
use crate::report::plots::slices::SlicesFigure;
use crate::report::plots::workspace::PoseGroup;
use crate::report::plots::workspace::{slice_figure, workspace_figure};
use crate::report::plots::{render, Format};
use crate::workspace::miw::{maximal_inscribed_workspace, MiwOptions, SingularityMargin};
use crate::workspace::miw3d::{self, slice, spatial_inscribed_workspace, Miw3dOptions, REACH};

pub(super) fn run(args: &WorkspaceArgs) -> anyhow::Result<Verdict> {
    let rays = super::checks::count("--rays", args.rays, 16, 100_000)?;
    let mechanism = Mechanism::load(&args.model)?;
    let (path, format) = picture_path(args)?;
    let mut inputs = super::checks::model_inputs(&args.model, &mechanism);
    inputs.extend(args.poses.as_deref().map(|path| Input {
        role: "pose file",
        path,
    }));
    let output = Output::prepare("--out", &path, &inputs)?;
    let pose_set = match &args.poses {
        Some(poses) => Some(file::read_poses(poses, &mechanism)?),
        None => None,
    };
    let groups = |axes: [usize; 2]| {
        pose_set
            .as_ref()
            .map_or(Vec::new(), |set| pose_groups(&mechanism, set, axes))
    };
    let mut console = Console::new(output.is_stdout());
    if !mechanism.is_planar() {
        let figure = spatial(&mechanism, rays, &groups, &mut console)?;
        output.write("picture", &render(&figure, format)?)?;
        console.line(format_args!("picture written to {}", output.name()))?;
        return Ok(Verdict::Trusted);
    }
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
    let figure = workspace_figure(&margin, &miw, &title, groups([0, 1]));
    output.write("picture", &render(&figure, format)?)?;
    console.print(&text)?;
    console.line(format_args!("picture written to {}", output.name()))?;
    Ok(Verdict::Trusted)
}

/// The slices of a spatial workspace drawn, by their position coordinates: x–y, x–z, y–z.
const SLICES: [[usize; 2]; 3] = [[0, 1], [0, 2], [1, 2]];

/// Rays cast in each slice's plane.
const SLICE_RAYS: usize = 360;

/// A spatial mechanism: the 3-D MIW at the home orientation, printed, and the picture of three
/// slices through the home position (x–y, x–z, y–z: the region's boundary, its singular
/// curves, the ball's cross-section and the poses `groups` gives for each plane).
fn spatial(
    mechanism: &Mechanism,
    rays: usize,
    groups: &dyn Fn([usize; 2]) -> Vec<PoseGroup>,
    console: &mut Console,
) -> anyhow::Result<SlicesFigure> {
    let options = Miw3dOptions {
        rays,
        ..Miw3dOptions::for_mechanism(mechanism)
    };
    let miw = spatial_inscribed_workspace(mechanism, options)?;
    let slices = SLICES
        .iter()
        .map(|&axes| slice(mechanism, options, axes, SLICE_RAYS))
        .collect::<Result<Vec<_>, _>>()?;
    let orientation: Vec<String> = (3..6)
        .filter(|c| mechanism.measured.contains(c))
        .map(|c| format!("{} = {}", COORDINATES[c], mechanism.home_pose[c]))
        .collect();
    let mut text = String::new();
    writeln!(
        text,
        "legwise workspace: {} ({})",
        mechanism.name,
        mechanism.model_path.display()
    )?;
    if !orientation.is_empty() {
        writeln!(
            text,
            "constant-orientation region at the home values: {}",
            orientation.join(", ")
        )?;
    }
    writeln!(
        text,
        "maximal inscribed workspace (3-D MIW, a ball about the home position, {rays} rays):"
    )?;
    let [x, y, z] = miw.centre.map(|v| crate::report::tidy(v, 7));
    writeln!(text, "  centre  x = {x:.7} m, y = {y:.7} m, z = {z:.7} m")?;
    writeln!(text, "  radius  {:.7} m", miw.radius)?;
    let reach = REACH * miw3d::region_size(mechanism);
    let far = |points: &mut dyn Iterator<Item = f64>| {
        points.filter(|r| *r >= reach * (1.0 - 1e-9)).count()
    };
    let capped = far(&mut miw.boundary.iter().map(|p| {
        (0..3)
            .map(|k| (p[k] - miw.centre[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    }));
    let capped_slices: usize = slices
        .iter()
        .zip(SLICES)
        .map(|(boundary, axes)| {
            far(&mut boundary
                .iter()
                .map(|p| (p[0] - miw.centre[axes[0]]).hypot(p[1] - miw.centre[axes[1]])))
        })
        .sum();
    if capped + capped_slices > 0 {
        writeln!(
            text,
            "  {capped} of {rays} rays (and {capped_slices} of the slices' {}) met no boundary \
             within {reach:.3} m ({REACH} region sizes) and stop there",
            SLICES.len() * SLICE_RAYS
        )?;
    }
    writeln!(
        text,
        "picture: the slices z = {z:.7} m (x-y), y = {y:.7} m (x-z) and x = {x:.7} m (y-z) \
         through the home position, at the home orientation"
    )?;
    console.print(&text)?;
    let margin = SingularityMargin::new(mechanism)?;
    let panels = slices
        .into_iter()
        .zip(SLICES)
        .map(|(boundary, axes)| {
            let plane = margin.clone().in_plane(axes);
            slice_figure(&plane, boundary, axes, &miw, groups(axes))
        })
        .collect();
    Ok(SlicesFigure {
        title: format!(
            "{}: singularity-free slices through the home position and 3-D MIW",
            mechanism.name
        ),
        panels,
    })
}

/// `--out` (`-`: standard output), its format by the extension (or `--png` for standard
/// output), checked before any work; or the default `<model name>-workspace.svg|png`.
fn picture_path(args: &WorkspaceArgs) -> anyhow::Result<(PathBuf, Format)> {
    let png = crate::files::format(args.png);
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

/// The poses of a pose file, grouped by their leg label (shared poses last), in the pose
/// coordinates `axes` (x, y for a planar picture; projected on a spatial slice's plane).
fn pose_groups(mechanism: &Mechanism, set: &MeasurementSet, axes: [usize; 2]) -> Vec<PoseGroup> {
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
                .poses()
                .iter()
                .filter(|p| p.leg == leg)
                .map(|p| [p.pose[axes[0]], p.pose[axes[1]]])
                .collect();
            (!points.is_empty()).then(|| PoseGroup {
                name: format!("{name} poses{source}"),
                points,
            })
        })
        .collect()
}
