//! `legwise workspace`.

use std::fmt::Write as _;
use std::path::PathBuf;

use super::console::Console;
use super::output::Output;
use super::{Verdict, WorkspaceArgs};
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;
use crate::workspace::miw::{maximal_inscribed_workspace, MiwOptions, SingularityMargin};
use crate::workspace::picture::miw_svg;

pub(super) fn run(args: &WorkspaceArgs) -> anyhow::Result<Verdict> {
    let rays = super::checks::count("--rays", args.rays, 16, 100_000)?;
    let mechanism = Mechanism::load(&args.model)?;
    let path = args.svg.clone().unwrap_or_else(|| {
        let stem = args
            .model
            .file_stem()
            .map_or("model".into(), |s| s.to_string_lossy().into_owned());
        PathBuf::from(format!("{stem}-workspace.svg"))
    });
    let output = Output::prepare(
        "--svg",
        &path,
        &super::model_inputs(&args.model, &mechanism),
    )?;
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
    output.write("picture", miw_svg(&margin, &miw, &title).as_bytes())?;
    console.print(&text)?;
    console.line(format_args!("picture written to {}", output.name()))?;
    Ok(Verdict::Trusted)
}
