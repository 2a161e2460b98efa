//! A loaded model described as JSON, for `legwise.Mechanism` (what a script needs to know of a
//! model before it builds its measurement columns or reads a report).

use legwise::measure::observe_simulate::real_shared;
use legwise::measure::simulate::real_parameters;
use legwise::Mechanism;
use serde_json::{json, Value};

/// `name`, `model`, `urdf`, `mode`, `legs` (each with its actuated joint, the reading column,
/// and its parameters), `measured` (the pose coordinates a measurement row holds), `instrument`
/// (null, or whether it is seen through the forward kinematics, its target columns and its
/// parameters) and `warnings`. A parameter's `real` is its value in the mechanism the model's
/// simulation block draws with its own seed (what `legwise simulate` without `--seed`
/// simulates), null without a simulation block.
pub(crate) fn description(mechanism: &Mechanism) -> Value {
    let actuated = mechanism.actuated_names();
    let simulation = mechanism.simulation.as_ref();
    let real_legs = simulation.map(|s| real_parameters(mechanism, s, s.seed));
    let legs: Vec<Value> = mechanism
        .legs
        .iter()
        .zip(&actuated)
        .enumerate()
        .map(|(l, (leg, joint))| {
            let parameters: Vec<Value> = leg
                .params
                .iter()
                .enumerate()
                .map(|(k, p)| {
                    let real = real_legs.as_ref().map(|r| r[l][k]);
                    parameter(&p.name, p.nominal, p.identified, &p.unit.to_string(), real)
                })
                .collect();
            json!({"name": leg.name, "actuated": joint, "parameters": parameters})
        })
        .collect();
    let instrument = mechanism.instrument.as_ref().map(|instrument| {
        let real = simulation.map(|s| real_shared(instrument, s, s.seed));
        let parameters: Vec<Value> = instrument
            .parameters
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let real = real.as_ref().map(|r| r[k]);
                parameter(&p.name, p.nominal, p.identified, &p.unit.to_string(), real)
            })
            .collect();
        json!({
            "forward": instrument.forward,
            "columns": instrument.columns(),
            "parameters": parameters,
        })
    });
    json!({
        "name": mechanism.name,
        "model": mechanism.model_path.display().to_string(),
        "urdf": mechanism.urdf_path.display().to_string(),
        "mode": mechanism.mode,
        "legs": legs,
        "measured": mechanism.measured_names(),
        "instrument": instrument,
        "warnings": mechanism.warnings,
    })
}

/// One parameter: name, nominal value (SI), identified or held, unit (`m`, `rad`, `-`), real
/// value of the simulated mechanism.
fn parameter(name: &str, nominal: f64, identified: bool, unit: &str, real: Option<f64>) -> Value {
    json!({"name": name, "nominal": nominal, "identified": identified, "unit": unit, "real": real})
}
