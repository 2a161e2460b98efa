//! The calibrated model: the model file and its URDF rewritten with every identified value in
//! place of its nominal one, loadable by every legwise command.
//!
//! Joint-origin parameters go into the URDF (`OUT.urdf`, beside `OUT.yaml` and named by its
//! `urdf` field); actuator gains and offsets and platform attachments into the model file. The
//! model file's header comments say where the values came from and give each parameter's σ.
//! Outputs never overwrite an input, and each file is written through a temporary file renamed
//! into place.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::identify::estimate::StrategyResult;
use crate::model::file::ModelFile;
use crate::model::joint::ORIGIN_COMPONENTS;
use crate::model::params::ParamTarget;
use crate::model::Mechanism;

/// What the calibrated model is made from.
#[derive(Debug, Clone, Copy)]
pub struct Calibration<'a> {
    /// The model that was identified.
    pub mechanism: &'a Mechanism,
    /// The result whose values are written.
    pub result: &'a StrategyResult,
    /// Where the measurements came from (a file, or a description of the simulation).
    pub source: &'a str,
    /// Real parameters of a simulation (per leg, model order): written as `simulation.real` so
    /// that the calibrated model simulates the same real mechanism.
    pub real: Option<&'a [Vec<f64>]>,
    /// A note for the header, e.g. which of several results this is.
    pub note: Option<&'a str>,
}

/// Writes the calibrated model to `out` (YAML) and its URDF beside it (`out` with extension
/// `urdf`); returns the URDF path. `inputs` are further files that must not be overwritten (the
/// measurement file); the model and its URDF are always protected.
///
/// # Errors
/// An output that is an input (after canonicalisation), an output whose extension is `urdf`,
/// an unreadable model or URDF, or a failed write.
pub fn write_calibrated(
    calibration: &Calibration<'_>,
    out: &Path,
    inputs: &[&Path],
) -> Result<PathBuf> {
    let mechanism = calibration.mechanism;
    if out.extension().is_some_and(|e| e == "urdf") {
        return Err(Error::Invalid(format!(
            "--calibrated {}: the model file needs another extension than .urdf (the URDF is written beside it)",
            out.display()
        )));
    }
    let urdf_out = out.with_extension("urdf");
    let mut protected = vec![
        mechanism.model_path.as_path(),
        mechanism.urdf_path.as_path(),
    ];
    protected.extend_from_slice(inputs);
    refuse_overwriting_inputs(&[out, &urdf_out], &protected)?;
    let values = calibrated_values(calibration);
    let urdf_text = calibrated_urdf(calibration, &values)?;
    let yaml_text = calibrated_yaml(calibration, &values, &urdf_out)?;
    write_atomically(&urdf_out, &urdf_text)?;
    write_atomically(out, &yaml_text)?;
    Ok(urdf_out)
}

/// Fails if one of `outputs` is one of `inputs` (compared after canonicalisation; an output that
/// does not exist yet is compared through its canonical parent directory).
///
/// # Errors
/// [`Error::Invalid`] naming the output and the input it would overwrite.
pub fn refuse_overwriting_inputs(outputs: &[&Path], inputs: &[&Path]) -> Result<()> {
    let inputs: Vec<(PathBuf, &Path)> = inputs.iter().map(|p| (canonical(p), *p)).collect();
    for output in outputs {
        let target = canonical(output);
        if let Some((_, input)) = inputs.iter().find(|(c, _)| *c == target) {
            return Err(Error::Invalid(format!(
                "{}: refusing to overwrite an input file ({})",
                output.display(),
                input.display()
            )));
        }
    }
    Ok(())
}

/// The canonical form of a path that may not exist yet.
fn canonical(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match (parent.canonicalize(), path.file_name()) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => path.to_path_buf(),
    }
}

/// Writes `text` to a temporary file beside `path`, then renames it into place.
///
/// # Errors
/// [`Error::Io`] naming `path`.
pub fn write_atomically(path: &Path, text: &str) -> Result<()> {
    let name = path.file_name().map_or_else(
        || "output".to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let temporary = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
    let io = |error| Error::Io {
        path: path.to_path_buf(),
        error,
    };
    std::fs::write(&temporary, text).map_err(io)?;
    std::fs::rename(&temporary, path).map_err(|error| {
        let _ = std::fs::remove_file(&temporary);
        io(error)
    })
}

/// Per leg, every parameter's calibrated value and σ (the nominal value and no σ for legs the
/// result did not identify).
fn calibrated_values(calibration: &Calibration<'_>) -> Vec<Vec<(f64, Option<f64>)>> {
    calibration
        .mechanism
        .legs
        .iter()
        .map(
            |leg| match calibration.result.legs.iter().find(|e| e.leg == leg.name) {
                Some(estimate) => estimate
                    .parameters
                    .iter()
                    .map(|p| (p.estimate, p.std))
                    .collect(),
                None => leg.params.iter().map(|p| (p.nominal, None)).collect(),
            },
        )
        .collect()
}

/// The URDF with the identified joint origins.
fn calibrated_urdf(
    calibration: &Calibration<'_>,
    values: &[Vec<(f64, Option<f64>)>],
) -> Result<String> {
    let mechanism = calibration.mechanism;
    let urdf_error = |message: String| Error::Urdf {
        path: mechanism.urdf_path.clone(),
        message,
    };
    let mut robot =
        urdf_rs::read_file(&mechanism.urdf_path).map_err(|e| urdf_error(e.to_string()))?;
    for (leg, leg_values) in mechanism.legs.iter().zip(values) {
        for (param, &(value, _)) in leg.params.iter().zip(leg_values) {
            if let ParamTarget::JointOrigin { joint, component } = param.target {
                let name = &leg.joints[joint].name;
                let urdf_joint = robot
                    .joints
                    .iter_mut()
                    .find(|j| &j.name == name)
                    .ok_or_else(|| urdf_error(format!("joint `{name}` not found")))?;
                match component {
                    0..=2 => urdf_joint.origin.xyz.0[component] = value,
                    _ => urdf_joint.origin.rpy.0[component - 3] = value,
                }
            }
        }
    }
    let text = urdf_rs::write_to_string(&robot).map_err(|e| urdf_error(e.to_string()))?;
    let comment = format!(
        "<!-- Calibrated URDF written by legwise {}: the joint origins hold the values identified\n     from {} (see the model file beside it). -->\n",
        env!("CARGO_PKG_VERSION"),
        calibration.source.replace("--", "- -")
    );
    Ok(match text.strip_prefix("<?xml") {
        Some(_) => match text.find("?>") {
            Some(end) => format!("{}\n{comment}{}", &text[..end + 2], &text[end + 2..]),
            None => format!("{comment}{text}"),
        },
        None => format!("<?xml version=\"1.0\"?>\n{comment}{text}"),
    })
}

/// The model file with the identified actuator and attachment values and the new URDF name.
fn calibrated_yaml(
    calibration: &Calibration<'_>,
    values: &[Vec<(f64, Option<f64>)>],
    urdf_out: &Path,
) -> Result<String> {
    let mechanism = calibration.mechanism;
    let mut file = ModelFile::read(&mechanism.model_path)?;
    file.urdf = urdf_out
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    for (leg, leg_values) in mechanism.legs.iter().zip(values) {
        let Some(entry) = file.legs.iter_mut().find(|e| e.name == leg.name) else {
            continue;
        };
        for (param, &(value, _)) in leg.params.iter().zip(leg_values) {
            match param.target {
                ParamTarget::Gain => entry.actuator.gain = value,
                ParamTarget::Offset => entry.actuator.offset = value,
                ParamTarget::Attachment { component } => {
                    entry.attachment.get_or_insert(leg.attachment)[component] = value
                }
                ParamTarget::JointOrigin { .. } => {}
            }
        }
    }
    if let (Some(real), Some(simulation)) = (calibration.real, file.simulation.as_mut()) {
        simulation.real = mechanism
            .legs
            .iter()
            .zip(real)
            .flat_map(|(leg, phi)| leg.params.iter().map(|p| p.name.clone()).zip(phi.clone()))
            .collect::<BTreeMap<_, _>>();
        simulation.perturbation = None;
    }
    let body = serde_saphyr::to_string(&file).map_err(|e| Error::Yaml {
        path: mechanism.model_path.clone(),
        message: format!("cannot write the calibrated model: {e}"),
    })?;
    Ok(format!("{}{body}", header(calibration, values, urdf_out)))
}

/// The comment block at the top of the calibrated model file.
fn header(
    calibration: &Calibration<'_>,
    values: &[Vec<(f64, Option<f64>)>],
    urdf_out: &Path,
) -> String {
    let mechanism = calibration.mechanism;
    let result = calibration.result;
    let mut lines = vec![
        format!(
            "Calibrated model written by legwise {} (identify --calibrated).",
            env!("CARGO_PKG_VERSION")
        ),
        format!("Identified from: {}", calibration.source),
        format!(
            "Strategy: {}; solver: {}.",
            result.strategy.name(),
            result.solver.name()
        ),
    ];
    if let Some(note) = calibration.note {
        lines.push(note.to_string());
    }
    lines.push(format!(
        "Original model: {}. Every identified value replaces its nominal one: joint origins in",
        mechanism.model_path.display()
    ));
    lines.push(format!(
        "{}, actuator gains and offsets and attachments below.",
        urdf_out.file_name().map_or_else(
            || urdf_out.display().to_string(),
            |n| n.to_string_lossy().into_owned()
        )
    ));
    if calibration.real.is_some() {
        lines.push(
            "simulation.real lists the simulated real values, so that simulating this model simulates the same mechanism."
                .into(),
        );
    }
    lines.push("Values (SI units) with their standard deviation σ = σ̂ √diag (CᵀC)⁻¹:".into());
    for (leg, leg_values) in mechanism.legs.iter().zip(values) {
        for (param, &(value, std)) in leg.params.iter().zip(leg_values) {
            let unit = param.unit;
            let status = match (param.identified, std) {
                (false, _) => "fixed (not identified)".to_string(),
                (true, Some(s)) => format!("σ = {s:.3e} {unit}"),
                (true, None) => "σ unknown (no redundancy, or the leg was not identified)".into(),
            };
            let origin = match param.target {
                ParamTarget::JointOrigin { joint, component } => format!(
                    " (joint {} origin {})",
                    leg.joints[joint].name, ORIGIN_COMPONENTS[component]
                ),
                _ => String::new(),
            };
            lines.push(format!(
                "  {}: {} = {value} {unit}{origin}, nominal was {}; {status}",
                leg.name, param.name, param.nominal
            ));
        }
    }
    lines
        .iter()
        .map(|line| format!("# {line}\n"))
        .collect::<String>()
}
