//! The calibrated model of an identification through the instrument: as
//! [`super::calibrated`], and the instrument block's frame pose and target offsets at their
//! estimates.

use std::collections::BTreeMap;

use super::calibrated::{calibrated_urdf, set_leg_values, CalibratedFiles};
use crate::error::{Error, Result};
use crate::identify::shared_estimate::SharedEstimate;
use crate::model::file::ModelFile;
use crate::model::instrument::Instrument;
use crate::model::Mechanism;

/// The calibrated model file and URDF from `result`; the model file names the URDF
/// `urdf_name`. With `real` (a simulation's real leg and instrument values), `simulation.real`
/// lists them, so that simulating the calibrated model simulates the same mechanism.
///
/// # Errors
/// The model file or the URDF cannot be read again, or the model cannot be serialised.
pub fn calibrated_files(
    mechanism: &Mechanism,
    result: &SharedEstimate,
    source: &str,
    real: Option<(&[Vec<f64>], &[f64])>,
    urdf_name: &str,
) -> Result<CalibratedFiles> {
    let values: Vec<Vec<(f64, Option<f64>)>> = mechanism
        .legs
        .iter()
        .enumerate()
        .map(|(l, leg)| match result.legs.iter().find(|(i, _)| *i == l) {
            Some((_, estimates)) => estimates.iter().map(|p| (p.estimate, p.std)).collect(),
            None => leg.params.iter().map(|p| (p.nominal, None)).collect(),
        })
        .collect();
    let urdf = calibrated_urdf(mechanism, source, &values)?;
    let mut file = ModelFile::read(&mechanism.model_path)?;
    file.urdf = urdf_name.to_string();
    set_leg_values(&mut file, mechanism, &values);
    if let (Some(block), Some(instrument)) = (file.instrument.as_mut(), &mechanism.instrument) {
        for (c, component) in instrument.frame_components().iter().enumerate() {
            block.frame.pose.insert(
                component.to_string(),
                result.shared[Instrument::FRAME + c].estimate,
            );
        }
        for (k, target) in block.targets.iter_mut().enumerate() {
            for (c, value) in target.offset.iter_mut().enumerate() {
                *value = result.shared[instrument.offset_index(k) + c].estimate;
            }
        }
    }
    if let (Some((legs, shared)), Some(simulation)) = (real, file.simulation.as_mut()) {
        let mut real: BTreeMap<String, f64> = mechanism
            .legs
            .iter()
            .zip(legs)
            .flat_map(|(leg, phi)| leg.params.iter().map(|p| p.name.clone()).zip(phi.clone()))
            .collect();
        if let Some(instrument) = &mechanism.instrument {
            for (p, &value) in instrument.parameters.iter().zip(shared) {
                real.insert(p.name.clone(), value);
            }
        }
        simulation.real = real;
        simulation.perturbation = None;
    }
    let body = serde_saphyr::to_string(&file).map_err(|e| Error::Yaml {
        path: mechanism.model_path.clone(),
        message: format!("cannot write the calibrated model: {e}"),
    })?;
    let mut lines = vec![
        format!(
            "Calibrated model written by legwise {} (identify --calibrated).",
            env!("CARGO_PKG_VERSION")
        ),
        format!("Identified from: {source}"),
        format!("Strategy: {}.", result.strategy.name()),
        format!(
            "Original model: {}. Every identified value replaces its nominal one: joint origins in",
            mechanism.model_path.display()
        ),
        format!("{urdf_name}, actuator gains and offsets, attachments and the instrument below."),
        "Values (SI units) with their standard deviation σ:".into(),
    ];
    let all = result
        .shared
        .iter()
        .chain(result.legs.iter().flat_map(|(_, p)| p));
    for p in all {
        let status = match (p.identified, p.std) {
            (false, _) => "fixed (not identified)".to_string(),
            (true, Some(s)) => format!("σ = {s:.3e} {}", p.unit),
            (true, None) => "σ unknown".into(),
        };
        lines.push(format!(
            "  {} = {} {}, nominal was {}; {status}",
            p.name, p.estimate, p.unit, p.nominal
        ));
    }
    let header: String = lines.iter().map(|l| format!("# {l}\n")).collect();
    Ok(CalibratedFiles {
        yaml: format!("{header}{body}"),
        urdf,
    })
}
