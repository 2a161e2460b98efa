//! The plausibility check of prismatic readings (3-RPR legs, in metres): readings entered in
//! millimetres put the joint far beyond 100 times the mechanism's size, and the warning names
//! the count, the first and the largest offending value with their lines — found here by
//! scanning the rows, not by the check. The bundled 3-RPR's size is 0.7 m (base radius 0.5 m
//! plus platform radius 0.2 m, larger than its workspace disc's 0.57 m bounding-box
//! diagonal), so a joint value ρ = k·s + ρ₀ = s + 0.2 beyond 70 m is implausible.
use legwise::measure::checks::check;
use legwise::measure::file::read;
use legwise::measure::MeasurementSet;

use crate::support::{bundled, crate_path};

fn clean_3rpr() -> (legwise::model::Mechanism, MeasurementSet) {
    let mechanism = bundled("3rpr.yaml");
    let data = read(&crate_path("tests/data/stats_3rpr_clean.csv"), &mechanism).unwrap();
    (mechanism, data)
}

#[test]
fn prismatic_readings_in_millimetres_are_named_first_and_largest() {
    let (mechanism, clean) = clean_3rpr();
    assert!(check(&mechanism, &clean).unwrap().is_empty());
    let mut millimetres = clean.clone();
    for i in 0..millimetres.len() {
        for reading in millimetres.readings_mut(i) {
            *reading = reading.map(|r| r * 1000.0);
        }
    }
    let warnings = check(&mechanism, &millimetres).unwrap();
    let names = mechanism.actuated_names();
    assert_eq!(warnings.len(), names.len(), "{warnings:?}");
    for (l, (warning, name)) in warnings.iter().zip(&names).enumerate() {
        let rows: Vec<(usize, f64)> = millimetres
            .rows()
            .filter_map(|(p, readings)| readings[l].map(|r| (p.line.unwrap(), r)))
            .filter(|&(_, r)| {
                let joint = r + 0.2;
                assert!(
                    (joint.abs() - 70.0).abs() > 1.0,
                    "{joint} too close to the limit"
                );
                joint.abs() > 70.0
            })
            .collect();
        assert!(rows.len() > 20, "most rows offend");
        let first = rows[0];
        let largest = rows
            .iter()
            .copied()
            .reduce(|a, b| if b.1.abs() > a.1.abs() { b } else { a })
            .unwrap();
        assert_ne!(first.0, largest.0, "a test that tells first from largest");
        let expected = format!(
            "column `{name}`: prismatic reading {} values, first {} at line {}, largest {} at \
             line {} puts the joint (gain · reading + offset) beyond 100 times the mechanism's \
             size (0.700 m): readings in millimetres instead of metres?",
            rows.len(),
            first.1,
            first.0,
            largest.1,
            largest.0
        );
        assert_eq!(warning, &expected);
    }
}

#[test]
fn one_prismatic_reading_in_millimetres_is_named_alone() {
    let (mechanism, clean) = clean_3rpr();
    let mut one = clean.clone();
    let index = (0..one.len())
        .position(|i| one.readings(i)[1].is_some())
        .unwrap()
        + 2;
    assert!(one.readings(index)[1].is_some(), "a leg2 row");
    let value = one.readings(index)[1].unwrap() * 1000.0;
    one.readings_mut(index)[1] = Some(value);
    let line = one.poses()[index].line.unwrap();
    let warnings = check(&mechanism, &one).unwrap();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    let name = mechanism.actuated_names()[1];
    assert!(
        warnings[0].starts_with(&format!(
            "column `{name}`: prismatic reading {value} at line {line} puts the joint"
        )),
        "{}",
        warnings[0]
    );
}
