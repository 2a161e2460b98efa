//! `legwise evaluate`.

use super::EvaluateArgs;
use crate::evaluate::held_out::evaluate;
use crate::evaluate::report::{evaluation_json, evaluation_text};
use crate::measure::file;
use crate::model::Mechanism;
use crate::report::calibrated::{refuse_overwriting_inputs, write_atomically};
use crate::report::plots::files::write_evaluate_plots;
use crate::report::plots::Format;

pub(super) fn run(args: &EvaluateArgs) -> anyhow::Result<()> {
    let mut inputs = vec![args.model.as_path(), args.measurements.as_path()];
    inputs.extend(args.against.as_deref());
    let mechanism = Mechanism::load(&args.model)?;
    let other = args.against.as_deref().map(Mechanism::load).transpose()?;
    let urdfs: Vec<_> = std::iter::once(&mechanism)
        .chain(&other)
        .map(|m| m.urdf_path.clone())
        .collect();
    inputs.extend(urdfs.iter().map(|p| p.as_path()));
    if let Some(path) = &args.json {
        refuse_overwriting_inputs(&[path], &inputs)?;
    }
    if let Some(dir) = &args.plots {
        crate::report::plots::output::check_directory(dir)?;
    }
    let evaluation = evaluate(&mechanism, &file::read(&args.measurements, &mechanism)?)?;
    let against = match &other {
        Some(other) => Some(evaluate(other, &file::read(&args.measurements, other)?)?),
        None => None,
    };
    print!(
        "{}",
        evaluation_text(&mechanism, &evaluation, against.as_ref())
    );
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&evaluation_json(&evaluation, against.as_ref()))?;
        write_atomically(path, &text)?;
        println!("\nJSON written to {}", path.display());
    }
    if let Some(dir) = &args.plots {
        let name = |path: &std::path::Path| {
            path.file_name().map_or(path.display().to_string(), |n| {
                n.to_string_lossy().into_owned()
            })
        };
        let (model, other) = (name(&args.model), args.against.as_deref().map(name));
        // The other model (typically the nominal one) is drawn first, as "before".
        let mut drawn = Vec::new();
        if let (Some(other), Some(against)) = (&other, &against) {
            drawn.push((other.as_str(), against));
        }
        drawn.push((model.as_str(), &evaluation));
        let format = if args.png { Format::Png } else { Format::Svg };
        let path = write_evaluate_plots(dir, format, &drawn, &inputs)?;
        println!("picture written to {}", path.display());
    }
    Ok(())
}
