//! `legwise workspace`.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use super::args::WorkspaceArgs;
use super::console::Console;
use super::outputs::{input, model_inputs};
use super::verdict::Verdict;
use crate::files::Output;
use crate::measure::file;
use crate::model::Mechanism;
use crate::report::plots::Format;
use crate::report::workspace::workspace_report;

pub(super) fn run(args: &WorkspaceArgs) -> anyhow::Result<Verdict> {
    let rays = super::checks::count("--rays", args.rays, 16, 100_000)?;
    let mechanism = Mechanism::load(&args.model)?;
    let (path, format) = picture_path(args)?;
    let mut inputs = model_inputs(&args.model, &mechanism);
    inputs.extend(args.poses.as_deref().map(|path| input("pose file", path)));
    let output = Output::prepare("--out", &path, &inputs)?;
    let read_poses = |poses: &Path| file::read_poses(poses, &mechanism);
    let pose_set = args.poses.as_deref().map(read_poses).transpose()?;
    let mut console = Console::new(output.is_stdout());
    let (text, picture) = workspace_report(&mechanism, rays, pose_set.as_ref(), format)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.model.display()))?;
    output.write("picture", &picture)?;
    console.print(&text)?;
    console.line(format_args!("picture written to {}", output.name()))?;
    Ok(Verdict::from_reasons(mechanism.warnings.clone()))
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
            let stem = args.model.file_stem().unwrap_or(OsStr::new("model"));
            let name = format!("{}-workspace.{}", stem.to_string_lossy(), png.extension());
            Ok((PathBuf::from(name), png))
        }
    }
}
