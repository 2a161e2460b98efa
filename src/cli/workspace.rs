//! `legwise workspace`.

use std::path::PathBuf;

use super::args::WorkspaceArgs;
use super::console::Console;
use super::verdict::Verdict;
use crate::files::{Input, Output};
use crate::measure::file;
use crate::model::Mechanism;
use crate::report::plots::Format;
use crate::report::workspace::workspace_report;

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
    let mut console = Console::new(output.is_stdout());
    let (text, picture) = workspace_report(&mechanism, rays, pose_set.as_ref(), format)?;
    output.write("picture", &picture)?;
    console.print(&text)?;
    console.line(format_args!("picture written to {}", output.name()))?;
    Ok(Verdict::Trusted)
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
