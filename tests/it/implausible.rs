//! Issue 39, "Why 6": estimates the model itself would refuse, and inputs of a forward model
//! that passed without a word. Each case runs the real binary in a directory of fixtures made
//! from the bundled models and must not end in exit 0: an implausible estimate is a warning
//! (terminal and JSON) with exit 3 and no calibrated model written; a bad input is one line,
//! exit 2, nothing written.
use std::fs;
use std::path::Path;
use std::process::{Command, Output};

use legwise::{Measurements, Mechanism, Settings};

use super::cli::text;
use super::support::crate_path;

/// Runs `legwise args` in `dir`.
fn run_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// Copies every bundled model and URDF into `dir`.
fn copy_models(dir: &Path) {
    for entry in fs::read_dir(crate_path("models")).unwrap() {
        let path = entry.unwrap().path();
        fs::copy(&path, dir.join(path.file_name().unwrap())).unwrap();
    }
}

/// A bundled model copied into `dir` as `name` with `from` replaced by `to` (once; it must be
/// there).
fn edited(dir: &Path, model: &str, name: &str, from: &str, to: &str) {
    let original = fs::read_to_string(crate_path(&format!("models/{model}"))).unwrap();
    assert!(original.contains(from), "{model} holds {from:?}");
    fs::write(dir.join(name), original.replacen(from, to, 1)).unwrap();
}

/// `legwise simulate --model MODEL --out OUT` in `dir` (extra arguments after), which must
/// succeed; the file's lines.
fn simulated(dir: &Path, model: &str, out: &str, extra: &[&str]) -> Vec<String> {
    let mut args = vec!["simulate", "--model", model, "--out", out];
    args.extend(extra);
    let run = run_in(dir, &args);
    assert!(run.status.success(), "{args:?}: {}", text(&run.stderr));
    fs::read_to_string(dir.join(out))
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect()
}

/// The 5R's simulated rows with every reading of leg1's encoder stuck at 1.0.
fn stuck_encoder(dir: &Path) {
    let lines = simulated(dir, "5r.yaml", "5r-sim.csv", &[]);
    let header: Vec<&str> = lines[0].split(',').collect();
    let a1 = header.iter().position(|c| *c == "A1").unwrap();
    let mut csv = lines[0].clone() + "\n";
    for line in &lines[1..] {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        if !cells[a1].is_empty() {
            cells[a1] = "1.0".into();
        }
        csv += &(cells.join(",") + "\n");
    }
    fs::write(dir.join("stuck.csv"), csv).unwrap();
}

/// The fixtures of every case.
fn fixtures(dir: &Path) {
    copy_models(dir);
    stuck_encoder(dir);
    // A 3-RPR whose real base joint 1 stands 5 cm from nominal, measured; the bundled model
    // declares a perturbation of 2 mm (10 σ: 2 cm).
    edited(
        dir,
        "3rpr.yaml",
        "3rpr-far.yaml",
        "seed: 7",
        "seed: 7\n  real: {a1x: 0.05}",
    );
    simulated(
        dir,
        "3rpr-far.yaml",
        "3rpr-far.csv",
        &["--noise-scale", "0"],
    );
    // Lengths of a forward model's instrument block in millimetres.
    let probe = "delta-probe.yaml";
    edited(dir, probe, "touch-mm.yaml", "touch: 0.0", "touch: 2.0");
    edited(
        dir,
        probe,
        "tolerance-mm.yaml",
        "tolerance: 1.0e-4",
        "tolerance: 100",
    );
    let offset = "offset: [0.0, 0.0, -0.02]";
    edited(
        dir,
        probe,
        "offset-mm.yaml",
        offset,
        "offset: [0.0, 0.0, -20]",
    );
    let distances = "delta-probe-distances.yaml";
    let block = "distances: {target: nozzle, noise: 2.0e-5, simulate: 12}";
    let huge = "distances: {target: nozzle, noise: 2.0e-5, simulate: 1000000}";
    edited(dir, distances, "simulate-huge.yaml", block, huge);
    let many = "distances: {target: nozzle, noise: 2.0e-5, simulate: 1000}";
    edited(dir, distances, "simulate-many.yaml", block, many);
    let noise = "distances: {target: nozzle, noise: 20, simulate: 12}";
    edited(dir, distances, "noise-mm.yaml", block, noise);
    // The same touch twice under two ids; a distance given twice, and reversed.
    let lines = simulated(dir, distances, "probe.csv", &[]);
    let touch = lines.iter().find(|l| l.contains(",t5,")).unwrap();
    let again = touch.replace(",t5,", ",t99,");
    let mut twice = lines.clone();
    twice.insert(8, again);
    fs::write(dir.join("touch-twice.csv"), twice.join("\n") + "\n").unwrap();
    let distance = lines.last().unwrap().clone();
    assert!(
        distance.starts_with(",,,,,,t"),
        "a distance row: {distance}"
    );
    let mut repeated = lines.clone();
    repeated.push(distance.clone());
    fs::write(dir.join("distance-twice.csv"), repeated.join("\n") + "\n").unwrap();
    let mut cells: Vec<&str> = distance.split(',').collect();
    cells.swap(6, 7);
    let mut reversed = lines.clone();
    reversed.push(cells.join(","));
    fs::write(
        dir.join("distance-reversed.csv"),
        reversed.join("\n") + "\n",
    )
    .unwrap();
}

/// How a case must end.
enum Ends {
    /// Exit 2 with exactly this one line on standard error.
    Refused(&'static str),
    /// Exit 3, standard error holding each of these as warnings.
    Untrusted(&'static [&'static str]),
}

fn cases() -> Vec<(&'static [&'static str], Ends)> {
    use Ends::*;
    vec![
        (&["identify", "--model", "5r.yaml", "--measurements", "stuck.csv", "--calibrated", "cal.yaml"],
         Untrusted(&["legwise: warning: divide and conquer, leg `leg1`: k1 = "])),
        (&["identify", "--model", "3rpr.yaml", "--measurements", "3rpr-far.csv", "--calibrated", "cal.yaml"],
         Untrusted(&["legwise: warning: divide and conquer, leg `leg1`: a1x = "])),
        (&["identify", "--model", "touch-mm.yaml"],
         Refused("legwise: touch-mm.yaml: field `instrument.targets[0].touch`: a touch value of 2 m is more than the mechanism's size (0.510 m): millimetres instead of metres? (every length of a model file is in metres)")),
        (&["identify", "--model", "tolerance-mm.yaml"],
         Refused("legwise: tolerance-mm.yaml: field `instrument.tolerance`: a tolerance of 100 m is more than the mechanism's size (0.510 m): millimetres instead of metres? (every length of a model file is in metres)")),
        (&["identify", "--model", "offset-mm.yaml"],
         Refused("legwise: offset-mm.yaml: field `instrument.targets[0].offset`: an offset of 20 m is more than the mechanism's size (0.510 m): millimetres instead of metres? (every length of a model file is in metres)")),
        (&["identify", "--model", "simulate-huge.yaml"],
         Refused("legwise: simulate-huge.yaml: field `instrument.distances.simulate`: expected at most 100000 (as every simulated count), found 1000000")),
        (&["identify", "--model", "simulate-many.yaml"],
         Refused("legwise: simulate-many.yaml: field `instrument.distances.simulate`: 1000 distances between distinct pairs of 37 simulated rows, which have 666 pairs: ask for at most 666, or simulate more rows")),
        (&["identify", "--model", "noise-mm.yaml"],
         Refused("legwise: noise-mm.yaml: field `instrument.distances.noise`: a standard deviation of 20 m is more than the mechanism's size (0.510 m): millimetres instead of metres? (every length of a model file is in metres)")),
        (&["identify", "--model", "delta-probe-distances.yaml", "--measurements", "touch-twice.csv"],
         Refused("legwise: touch-twice.csv: line 9 (id `t99`): the row repeats line 6 (id `t5`) exactly (the same target coordinates, readings and measured pose): a touch entered twice counts one measurement twice and makes the standard deviations too small; keep one of them")),
        (&["identify", "--model", "delta-probe-distances.yaml", "--measurements", "distance-twice.csv"],
         Refused("legwise: distance-twice.csv: line 51, column `from`: the distance between `t3` and `t10` is given already at line 50: a distance entered twice counts one measurement twice; keep one of them (or their mean)")),
        (&["identify", "--model", "delta-probe-distances.yaml", "--measurements", "distance-reversed.csv"],
         Refused("legwise: distance-reversed.csv: line 51, column `from`: the distance between `t10` and `t3` is given already at line 50, from and to reversed: a distance entered twice counts one measurement twice; keep one of them (or their mean)")),
        (&["select", "--model", "delta-probe.yaml", "--strategy", "both", "--out", "s.csv"],
         Refused("legwise: --strategy: a model seen through the forward kinematics (`instrument.kinematics: forward`) has one set of rows, every leg's reading at each, selected for the joint problem of every leg and the instrument: drop --strategy")),
    ]
}

#[test]
fn no_case_of_why_6_ends_in_exit_0() {
    let dir = tempfile::tempdir().unwrap();
    fixtures(dir.path());
    let listing = |dir: &Path| {
        let mut names: Vec<_> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        names
    };
    for (args, ends) in cases() {
        let before = listing(dir.path());
        let out = run_in(dir.path(), args);
        let stderr = text(&out.stderr);
        assert_eq!(listing(dir.path()), before, "{args:?}: nothing written");
        match ends {
            Ends::Refused(expected) => {
                assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
                assert_eq!(stderr, format!("{expected}\n"), "{args:?}");
            }
            Ends::Untrusted(expected) => {
                assert_eq!(out.status.code(), Some(3), "{args:?}: {stderr}");
                for part in expected {
                    assert!(stderr.contains(part), "{args:?}: {part:?} in {stderr}");
                }
            }
        }
    }
}

#[test]
fn the_stuck_encoder_is_named_in_the_report_the_json_and_the_verdict_and_no_model_is_made() {
    let dir = tempfile::tempdir().unwrap();
    copy_models(dir.path());
    stuck_encoder(dir.path());
    let mechanism = Mechanism::load(&dir.path().join("5r.yaml")).unwrap();
    let data = Measurements::read(&dir.path().join("stuck.csv"), &mechanism).unwrap();
    let report = legwise::identify(&mechanism, &data, &Settings::default()).unwrap();
    // Where the fit of a stuck encoder stops is arbitrary (k1 grows without bound): the
    // values are not pinned, only that each implausible estimate is named, once.
    let k1 = "divide and conquer, leg `leg1`: k1 = ";
    let refusal = "the model would refuse it";
    let issues = report.trust_issues();
    assert!(!report.trusted());
    let named = |prefix: &str| {
        issues
            .iter()
            .filter(|i| i.starts_with(prefix) && i.contains(refusal))
            .count()
    };
    assert_eq!(named(k1), 1, "{issues:?}");
    let gamma1 = "divide and conquer, leg `leg1`: gamma1 = ";
    assert_eq!(named(gamma1), 1, "{issues:?}");
    // Named once: the calibrated model's refusal repeats the same cause and is not an issue.
    assert!(
        issues.iter().all(|i| i.contains(refusal)),
        "only implausible estimates: {issues:?}"
    );
    let k1_issue = issues.iter().find(|i| i.starts_with(k1)).unwrap();
    assert!(
        report
            .terminal_text()
            .contains(&format!("WARNING: {k1_issue}")),
        "{k1_issue}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&report.to_json().to_text().unwrap()).unwrap();
    let warnings = json["results"][0]["warnings"].as_array().unwrap();
    assert!(
        warnings.iter().any(|w| w.as_str().unwrap() == k1_issue),
        "{warnings:?}"
    );
    // The calibrated model would not load: refused with the loader's own reason.
    let refused = "the calibrated model (divide and conquer result) would not load: field \
                   `legs[0].actuator.gain`: ";
    let reason = report.calibrated_model_refused().unwrap();
    assert!(reason.starts_with(refused), "{reason}");
    assert!(reason.contains("is not a plausible value"), "{reason}");
    let error = report
        .calibrated_model()
        .unwrap()
        .files("cal.urdf")
        .unwrap_err()
        .to_string();
    assert!(error.starts_with(refused), "{error}");
    assert!(error.ends_with("; it is not written"), "{error}");
    // The other leg's estimates are plausible, and a good file's calibrated model loads.
    let good = Measurements::read(&dir.path().join("5r-sim.csv"), &mechanism).unwrap();
    let report = legwise::identify(&mechanism, &good, &Settings::default()).unwrap();
    assert!(report.trusted(), "{:?}", report.trust_issues());
    assert_eq!(report.calibrated_model_refused(), None);
}

#[test]
fn observations_made_in_memory_may_not_give_a_distance_twice() {
    use legwise::measure::observations::{DistanceRow, Observations, ObservedRow};
    let row = |reading: f64| ObservedRow {
        line: None,
        leg: None,
        observed: vec![0.0],
        readings: vec![Some(reading); 3],
        id: None,
        pose: None,
    };
    let distance = |rows: [usize; 2]| DistanceRow {
        line: None,
        rows,
        value: 0.02,
    };
    let mut set = Observations {
        source: None,
        rows: vec![row(0.25), row(0.26), row(0.27)],
        distances: vec![distance([0, 1]), distance([1, 2])],
    };
    assert!(set.check_distances().is_ok());
    set.distances.push(distance([1, 0]));
    assert_eq!(
        set.check_distances().unwrap_err().to_string(),
        "distance 2: joins rows 1 and 0, as distance 0 does: a distance given twice counts one \
         measurement twice; keep one of them"
    );
}
