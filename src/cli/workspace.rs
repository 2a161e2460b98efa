//! `legwise workspace`.

use std::path::PathBuf;

use super::WorkspaceArgs;
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;
use crate::workspace::miw::{maximal_inscribed_workspace, MiwOptions, SingularityMargin};
use crate::workspace::picture::miw_svg;

pub(super) fn run(args: &WorkspaceArgs) -> anyhow::Result<()> {
    let mechanism = Mechanism::load(&args.model)?;
    if !(16..=100_000).contains(&args.rays) {
        anyhow::bail!(
            "--rays: expected between 16 and 100000, found {}",
            args.rays
        );
    }
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
    let path = args.svg.clone().unwrap_or_else(|| {
        let stem = args
            .model
            .file_stem()
            .map_or("model".into(), |s| s.to_string_lossy().into_owned());
        PathBuf::from(format!("{stem}-workspace.svg"))
    });
    let margin = SingularityMargin::new(&mechanism)?;
    let title = format!("{}: singularity-free region and MIW", mechanism.name);
    std::fs::write(&path, miw_svg(&margin, &miw, &title))
        .map_err(|e| anyhow::anyhow!("{}: cannot write the picture: {e}", path.display()))?;
    println!("picture written to {}", path.display());
    Ok(())
}
