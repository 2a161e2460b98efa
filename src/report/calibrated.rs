//! The calibrated model: the model file and its URDF rewritten with every identified value in
//! place of its nominal one, loadable by every legwise command.
//!
//! Joint-origin parameters go into the URDF (`OUT.urdf`, beside `OUT.yaml` and named by its
//! `urdf` field); actuator gains and offsets and platform attachments into the model file. The
//! model file's header comments say where the values came from and give each parameter's σ.
//! This module makes the texts; the command line writes them (never over an input). The texts
//! are loaded as the model loader loads a model file before they are given out: a calibrated
//! model that would not load is refused with the loader's reason, never written.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::identify::estimate::StrategyResult;
use crate::model::file::{CalibrationEntry, ModelFile};
use crate::model::instrument::Instrument;
use crate::model::joint::ORIGIN_COMPONENTS;
use crate::model::params::ParamTarget;
use crate::model::Mechanism;
use crate::report::{RealValues, Report};

/// What the calibrated model is made from.
#[derive(Debug, Clone, Copy)]
pub struct Calibration<'a> {
    /// The model that was identified.
    pub mechanism: &'a Mechanism,
    /// The result whose values are written.
    pub result: &'a StrategyResult,
    /// Where the measurements came from (a file, or a description of the simulation).
    pub source: &'a str,
    /// Real parameters of a simulation: written as `simulation.real` so that the calibrated
    /// model simulates the same real mechanism (and instrument).
    pub real: Option<&'a RealValues>,
    /// A note for the header, e.g. which of several results this is.
    pub note: Option<&'a str>,
}

/// The two files of a calibrated model.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CalibratedFiles {
    /// The model file (YAML), naming the URDF.
    pub yaml: String,
    /// The URDF.
    pub urdf: String,
}

/// A calibrated model on its own, the identified model cloned: what [`Report::calibrated_files`]
/// writes, kept by a caller that outlives the report (the Python module's report).
#[derive(Debug, Clone)]
pub struct CalibratedModel {
    mechanism: Mechanism,
    result: StrategyResult,
    source: String,
    real: Option<RealValues>,
    note: Option<String>,
}

impl CalibratedModel {
    /// The model that was identified.
    pub fn mechanism(&self) -> &Mechanism {
        &self.mechanism
    }

    /// The name of the strategy whose values it holds.
    pub fn strategy(&self) -> &'static str {
        self.result.strategy.name()
    }

    /// The calibrated model file and URDF, the model file naming the URDF `urdf_name`.
    ///
    /// # Errors
    /// As [`calibrated_files`].
    pub fn files(&self, urdf_name: &str) -> Result<CalibratedFiles> {
        calibrated_files(&self.calibration(), urdf_name)
    }

    /// What the model is made from.
    fn calibration(&self) -> Calibration<'_> {
        Calibration {
            mechanism: &self.mechanism,
            result: &self.result,
            source: &self.source,
            real: self.real.as_ref(),
            note: self.note.as_deref(),
        }
    }
}

impl Report<'_> {
    /// The calibrated model of the report's [`Report::calibrated_result`] (`None` without a
    /// result); with several results, its header says which one it holds.
    pub fn calibrated_model(&self) -> Option<CalibratedModel> {
        let result = self.calibrated_result()?;
        let note = (self.results.len() > 1).then(|| {
            format!(
                "Several strategies ran; this is the {} result.",
                result.strategy.name()
            )
        });
        Some(CalibratedModel {
            mechanism: self.mechanism.clone(),
            result: result.clone(),
            source: self.source.clone(),
            real: self.real.clone(),
            note,
        })
    }

    /// Why the calibrated model of this report would not load (the model loader's reason), if
    /// it would not; `None` when it loads, and when there is no result or its texts cannot be
    /// made (the model file cannot be read again).
    pub fn calibrated_model_refused(&self) -> Option<String> {
        let model = self.calibrated_model()?;
        let files = texts(&model.calibration(), CHECK_URDF_NAME).ok()?;
        refusal(&model.calibration(), &files, CHECK_URDF_NAME)
    }

    /// The files of [`Report::calibrated_model`], its model file naming the URDF `urdf_name`.
    ///
    /// # Errors
    /// As [`calibrated_files`].
    pub fn calibrated_files(&self, urdf_name: &str) -> Result<Option<CalibratedFiles>> {
        self.calibrated_model()
            .map(|model| model.files(urdf_name))
            .transpose()
    }
}

/// The URDF path of the calibrated model file `out`: beside it, extension `urdf`.
///
/// # Errors
/// [`Error::Invalid`] when `out` itself has the extension `urdf` (both files would coincide).
pub fn urdf_path(out: &Path) -> Result<PathBuf> {
    if out.extension().is_some_and(|e| e == "urdf") {
        return Err(Error::Invalid(format!(
            "{}: --calibrated needs another extension than .urdf (the URDF is written beside it)",
            out.display()
        )));
    }
    Ok(out.with_extension("urdf"))
}

/// The calibrated model file and URDF; the model file names the URDF `urdf_name` (a path
/// relative to the model file: normally the file name of [`urdf_path`]). Both are loaded as
/// [`Mechanism::parse`] loads a model before they are given out.
///
/// # Errors
/// The model file or the URDF cannot be read again, or the model cannot be serialised;
/// [`Error::Invalid`] with the loader's reason when the calibrated model would not load (an
/// estimate the model refuses: a gain of 6.4e14, a length moved by more than the mechanism's
/// size).
pub fn calibrated_files(calibration: &Calibration<'_>, urdf_name: &str) -> Result<CalibratedFiles> {
    let files = texts(calibration, urdf_name)?;
    match refusal(calibration, &files, urdf_name) {
        Some(reason) => Err(Error::Invalid(format!("{reason}; it is not written"))),
        None => Ok(files),
    }
}

/// The URDF name the calibrated model names when it is only checked, not written.
const CHECK_URDF_NAME: &str = "calibrated.urdf";

/// The calibrated model's texts, unchecked.
fn texts(calibration: &Calibration<'_>, urdf_name: &str) -> Result<CalibratedFiles> {
    let values = calibrated_values(calibration);
    Ok(CalibratedFiles {
        urdf: calibrated_urdf(calibration.mechanism, calibration.source, &values)?,
        yaml: calibrated_yaml(calibration, &values, urdf_name)?,
    })
}

/// Why the model loader refuses the calibrated model `files` (its model file naming the URDF
/// `urdf_name`), if it does: every check of [`Mechanism::parse`], the kinematic ones included.
fn refusal(
    calibration: &Calibration<'_>,
    files: &CalibratedFiles,
    urdf_name: &str,
) -> Option<String> {
    let yaml = Path::new("calibrated model");
    let error = Mechanism::parse(&files.yaml, yaml, &files.urdf, Path::new(urdf_name)).err()?;
    let reason = match error {
        Error::Model { field, message, .. } => format!("field `{field}`: {message}"),
        Error::Urdf { message, .. } => format!("its URDF: {message}"),
        other => other.to_string(),
    };
    Some(format!(
        "the calibrated model ({} result) would not load: {reason}",
        calibration.result.strategy.name()
    ))
}

/// A parameter's calibrated value, its σ and the σ's degrees of freedom.
type Calibrated = (f64, Option<f64>, Option<usize>);

/// Per leg, every parameter's calibrated value, σ and the σ's degrees of freedom (the nominal
/// value and no σ for legs the result did not identify).
fn calibrated_values(calibration: &Calibration<'_>) -> Vec<Vec<Calibrated>> {
    calibration
        .mechanism
        .legs
        .iter()
        .map(
            |leg| match calibration.result.legs.iter().find(|e| e.leg == leg.name) {
                Some(estimate) => estimate
                    .parameters
                    .iter()
                    .map(|p| (p.estimate, p.std, p.degrees_of_freedom))
                    .collect(),
                None => leg.params.iter().map(|p| (p.nominal, None, None)).collect(),
            },
        )
        .collect()
}

/// The URDF of `mechanism` with the joint origins at `values` (per leg, every parameter's value
/// and σ, model order), its header naming `source`.
///
/// # Errors
/// The URDF cannot be read again or written.
pub fn calibrated_urdf(
    mechanism: &Mechanism,
    source: &str,
    values: &[Vec<Calibrated>],
) -> Result<String> {
    let urdf_error = |message: String| Error::Urdf {
        path: mechanism.urdf_path.clone(),
        message,
    };
    let mut robot =
        urdf_rs::read_file(&mechanism.urdf_path).map_err(|e| urdf_error(e.to_string()))?;
    for (leg, leg_values) in mechanism.legs.iter().zip(values) {
        for (param, &(value, _, _)) in leg.params.iter().zip(leg_values) {
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
        source.replace("--", "- -")
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
    values: &[Vec<Calibrated>],
    urdf_name: &str,
) -> Result<String> {
    let mechanism = calibration.mechanism;
    let mut file = ModelFile::read(&mechanism.model_path)?;
    file.urdf = urdf_name.to_string();
    set_leg_values(&mut file, mechanism, values);
    // The identified parameters moved: relations to quantities they broke go (a factor set of
    // the firmware's terms is the imported model's, not the calibrated one's).
    let moved: Vec<&str> = mechanism
        .legs
        .iter()
        .zip(values)
        .flat_map(|(leg, v)| leg.params.iter().zip(v))
        .filter(|(p, &(value, _, _))| value.to_bits() != p.nominal.to_bits())
        .map(|(p, _)| p.name.as_str())
        .collect();
    crate::model::quantities::drop_broken_relations(&mut file, &moved);
    let instrument = calibration.result.instrument.as_ref();
    if let (Some(block), Some(model), Some(estimate)) =
        (file.instrument.as_mut(), &mechanism.instrument, instrument)
    {
        let value = |k: usize| estimate.parameters[k].estimate;
        for (c, component) in model.frame_components().iter().enumerate() {
            block
                .frame
                .pose
                .insert(component.to_string(), value(Instrument::FRAME + c));
        }
        for (k, target) in block.targets.iter_mut().enumerate() {
            for (c, v) in target.offset.iter_mut().enumerate() {
                *v = value(model.offset_index(k) + c);
            }
        }
    }
    // Identified from measurements, the real mechanism is not known; the simulation block keeps
    // the one the model's own simulation draws (its seed), instrument frame included: the
    // calibrated model's nominal values have moved, and a perturbation drawn around them would
    // be another mechanism.
    let own = match (calibration.real, &mechanism.simulation) {
        (None, Some(simulation)) => Some(RealValues {
            legs: crate::measure::simulate::real_parameters(mechanism, simulation, simulation.seed),
            instrument: mechanism.instrument.as_ref().map(|instrument| {
                crate::measure::observe_simulate::real_shared(
                    instrument,
                    simulation,
                    simulation.seed,
                )
            }),
        }),
        _ => None,
    };
    if let (Some(real), Some(simulation)) =
        (calibration.real.or(own.as_ref()), file.simulation.as_mut())
    {
        let mut values: BTreeMap<String, f64> = mechanism
            .legs
            .iter()
            .zip(&real.legs)
            .flat_map(|(leg, phi)| leg.params.iter().map(|p| p.name.clone()).zip(phi.clone()))
            .collect();
        if let (Some(model), Some(shared)) = (&mechanism.instrument, &real.instrument) {
            for (p, &value) in model.parameters.iter().zip(shared) {
                values.insert(p.name.clone(), value);
            }
        }
        simulation.real = values;
        simulation.perturbation = None;
    }
    file.calibration = calibration_entry(calibration.result);
    let body = serde_saphyr::to_string(&file).map_err(|e| Error::Yaml {
        path: mechanism.model_path.clone(),
        message: format!("cannot write the calibrated model: {e}"),
    })?;
    Ok(format!("{}{body}", header(calibration, values, urdf_name)))
}

/// Writes the actuator gains and offsets and the attachments of `values` (per leg, model order)
/// into the model file `file` of `mechanism` (joint origins go into the URDF).
pub fn set_leg_values(file: &mut ModelFile, mechanism: &Mechanism, values: &[Vec<Calibrated>]) {
    for (leg, leg_values) in mechanism.legs.iter().zip(values) {
        let Some(entry) = file.legs.iter_mut().find(|e| e.name == leg.name) else {
            continue;
        };
        for (param, &(value, _, _)) in leg.params.iter().zip(leg_values) {
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
}

/// The comment block at the top of the calibrated model file.
fn header(calibration: &Calibration<'_>, values: &[Vec<Calibrated>], urdf_name: &str) -> String {
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
    let instrument = result.instrument.as_ref();
    lines.push(format!(
        "{urdf_name}, actuator gains and offsets and attachments{} below.",
        if instrument.is_some() {
            ", the instrument's frame and target offsets"
        } else {
            ""
        }
    ));
    if calibration.real.is_some() || calibration.mechanism.simulation.is_some() {
        lines.push(
            "simulation.real lists the simulated real values, so that simulating this model simulates the same mechanism."
                .into(),
        );
    }
    lines.push(
        "Values (SI units) with their standard deviation σ = σ̂ √diag (CᵀC)⁻¹ and the half width \
         of their 95 % interval, t·σ with Student's t on σ̂'s degrees of freedom:"
            .into(),
    );
    for p in instrument.iter().flat_map(|i| &i.parameters) {
        let status = match (p.identified, p.std) {
            (false, _) => "fixed (not identified)".to_string(),
            (true, Some(s)) => uncertainty(s, p.degrees_of_freedom, p.unit),
            (true, None) => "σ unknown (registered by the first stage, or no redundancy)".into(),
        };
        lines.push(format!(
            "  instrument: {} = {} {}, nominal was {}; {status}",
            p.name, p.estimate, p.unit, p.nominal
        ));
    }
    for (leg, leg_values) in mechanism.legs.iter().zip(values) {
        for (param, &(value, std, dof)) in leg.params.iter().zip(leg_values) {
            let unit = param.unit;
            let status = match (param.identified, std) {
                (false, _) => "fixed (not identified)".to_string(),
                (true, Some(s)) => uncertainty(s, dof, unit),
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
/// `σ = … unit; 95 %: ± … unit (t on ν degrees of freedom)` for a σ on `dof` degrees of freedom.
fn uncertainty(std: f64, dof: Option<usize>, unit: impl std::fmt::Display) -> String {
    match dof {
        Some(dof) => {
            let half = crate::identify::statistics::half_width95(std, dof);
            format!(
                "σ = {std:.3e} {unit}; 95 %: ± {half:.3e} {unit} (t on {dof} degrees of freedom)"
            )
        }
        None => format!("σ = {std:.3e} {unit}"),
    }
}

/// What the result calibrated: every identified parameter's estimate and their covariance
/// (through an instrument the declared noise's, not scaled by the residuals' ŝ:
/// [`StrategyResult::declared_full_covariance`]), for `identify --prior` to take as a prior;
/// `None` without a covariance.
fn calibration_entry(result: &StrategyResult) -> Option<CalibrationEntry> {
    let (parameters, covariance) = result.declared_full_covariance()?;
    let legs = result.legs.iter().flat_map(|l| &l.parameters);
    let all: Vec<_> = legs
        .chain(result.instrument.iter().flat_map(|i| &i.parameters))
        .collect();
    let estimates = parameters
        .iter()
        .map(|name| {
            all.iter()
                .find(|p| p.identified && &p.name == name)
                .map(|p| p.estimate)
        })
        .collect::<Option<Vec<f64>>>()?;
    let rows = (0..covariance.nrows())
        .map(|i| covariance.row(i).iter().copied().collect())
        .collect();
    Some(CalibrationEntry {
        parameters,
        estimates,
        covariance: rows,
    })
}
