//! `legwise printer import --klipper` and `printer export --klipper` (src/printer): a Klipper
//! printer.cfg (tests/data/klipper/printer.cfg, written from Klipper's documented formulas by
//! make_printer_cfg.py) imported, identified and exported; the imported kinematics against an
//! independent closed-form delta; the import → export → import round trip; bad files.
use std::path::Path;

use legwise::kinematics::inverse::predict_reading;
use legwise::kinematics::platform::forward;
use legwise::printer::delta_model::{printer_files, ModelOptions};
use legwise::printer::export::fit_klipper;
use legwise::printer::klipper::{KlipperConfig, KlipperDelta};
use legwise::Mechanism;

use crate::cli::text as text_of;
use crate::cli::{assert_fails_with, legwise, legwise_succeeds, text};

const CFG: &str = "tests/data/klipper/printer.cfg";

/// A delta with every tower different (angles, rods, endstops, step distances: a gear ratio,
/// other microsteps), no SAVE_CONFIG block: the closed-form tests' printer.
const ODD: &str = "\
[printer]
kinematics = delta
delta_radius: 140.0

[stepper_a]
microsteps: 16
rotation_distance: 40
position_endstop: 250.0
arm_length: 290.0
angle: 209.5

[stepper_b]
microsteps: 32
rotation_distance: 40
gear_ratio: 3:1
arm_length: 291.5   ; inline comment
position_endstop: 251.25
angle = 331.0

[stepper_c]
microsteps: 16
rotation_distance: 32
full_steps_per_rotation: 400
arm_length: 289.25
angle: 90.75
";

/// Klipper's step distances of [`ODD`], mm, computed here: rotation_distance / (full steps ×
/// microsteps × gear ratio).
const ODD_STEPS: [f64; 3] = [
    40.0 / (200.0 * 16.0),
    40.0 / (200.0 * 32.0 * 3.0),
    32.0 / (400.0 * 16.0),
];
const ODD_R: f64 = 140.0;
const ODD_ANGLES: [f64; 3] = [209.5, 331.0, 90.75];
const ODD_ARMS: [f64; 3] = [290.0, 291.5, 289.25];
const ODD_ENDSTOPS: [f64; 3] = [250.0, 251.25, 250.0];

/// Klipper's closed form, written here: the steps since each endstop with the nozzle at `p` (mm).
fn odd_steps_at(p: [f64; 3]) -> [f64; 3] {
    steps_with_arms(p, ODD_ARMS)
}

/// As [`odd_steps_at`] with other rods `arms` (mm).
fn steps_with_arms(p: [f64; 3], arms: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| {
        let a = ODD_ANGLES[i].to_radians();
        let (tx, ty) = (ODD_R * a.cos(), ODD_R * a.sin());
        let l = arms[i];
        let carriage = (l * l - (p[0] - tx).powi(2) - (p[1] - ty).powi(2)).sqrt() + p[2];
        let top = ODD_ENDSTOPS[i] + (l * l - ODD_R * ODD_R).sqrt();
        (top - carriage) / ODD_STEPS[i]
    })
}

/// Nozzle positions over the bed, mm.
fn odd_points() -> Vec<[f64; 3]> {
    let mut points = Vec::new();
    for z in [0.0, 0.8, 30.0] {
        for (x, y) in [
            (0.0, 0.0),
            (60.0, 10.0),
            (-45.0, 50.0),
            (-20.0, -70.0),
            (75.0, -30.0),
        ] {
            points.push([x, y, z]);
        }
    }
    points
}

/// Imports `text` (as file `name` in `dir`) through the library and loads the model.
fn import(dir: &Path, name: &str, text: &str) -> (KlipperDelta, Mechanism) {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    let delta = KlipperDelta::from_config(&KlipperConfig::read(&path).unwrap()).unwrap();
    let files = printer_files(
        &delta.geometry(),
        &ModelOptions::firmware_factors(),
        "printer.urdf",
    );
    std::fs::write(dir.join("printer.yaml"), &files.yaml).unwrap();
    std::fs::write(dir.join("printer.urdf"), &files.urdf).unwrap();
    std::fs::write(dir.join("probe.csv"), &files.csv).unwrap();
    let mechanism = Mechanism::load(&dir.join("printer.yaml")).unwrap();
    (delta, mechanism)
}

#[test]
fn the_imported_kinematics_are_klippers_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    // Touches written as Klipper's SAVE_CONFIG would: heights at stable positions.
    let mut text = format!(
        "{ODD}\n#*# <---------------------- SAVE_CONFIG ---------------------->\n\
         #*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n#*# [delta_calibrate]\n"
    );
    let points = odd_points();
    for (n, p) in points.iter().enumerate() {
        let s = odd_steps_at(*p);
        text.push_str(&format!(
            "#*# height{n} = {}\n#*# height{n}_pos = {:.9},{:.9},{:.9}\n",
            p[2], s[0], s[1], s[2]
        ));
    }
    let (delta, mechanism) = import(dir.path(), "odd.cfg", &text);
    for (got, want) in delta.step_distances.iter().zip(ODD_STEPS) {
        assert!((got - want).abs() < 1e-15, "{got} vs {want}");
    }
    let params = mechanism.nominal_parameters();
    let csv = std::fs::read_to_string(dir.path().join("probe.csv")).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').take(4).map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), points.len());
    for (p, row) in points.iter().zip(&rows) {
        let steps = odd_steps_at(*p);
        let pose = [p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3, 0.0, 0.0, 0.0];
        // The reading is −steps × step distance (m), and the model's inverse kinematics at the
        // nozzle gives it back.
        assert!((row[0] - p[2] * 1e-3).abs() < 1e-15, "{row:?}");
        for i in 0..3 {
            let expected = -steps[i] * ODD_STEPS[i] * 1e-3;
            assert!((row[1 + i] - expected).abs() < 1e-12, "{p:?} tower {i}");
            let predicted =
                predict_reading::<f64>(&mechanism.legs[i], &params[i], &pose, &mechanism.home_pose)
                    .unwrap();
            assert!(
                (predicted - expected).abs() < 1e-11,
                "{p:?} tower {i}: model {predicted} Klipper {expected}"
            );
        }
        // And its forward kinematics from the CSV's readings is the nozzle.
        let reached = forward(&mechanism, &params, &row[1..4]).unwrap();
        for k in 0..3 {
            assert!(
                (reached[k] - pose[k]).abs() < 1e-9,
                "{p:?}: reached {reached:?}"
            );
        }
    }
}

/// Every leg's parameters (tower, rod, gain, offset, effector joint) of two models agree to `tol`.
fn assert_same_model(a: &Mechanism, b: &Mechanism, tol: f64) {
    let (pa, pb) = (a.nominal_parameters(), b.nominal_parameters());
    for (leg, (x, y)) in pa.iter().zip(&pb).enumerate() {
        for (k, (u, v)) in x.iter().zip(y).enumerate() {
            assert!(
                (u - v).abs() < tol,
                "leg {leg} parameter {}: {u} vs {v}",
                a.legs[leg].params[k].name
            );
        }
    }
}

#[test]
fn import_export_import_gives_the_same_model() {
    let dir = tempfile::tempdir().unwrap();
    let (_, first) = import(dir.path(), "odd.cfg", ODD);
    let fit = fit_klipper(&first, 0.08, None).unwrap();
    assert!(fit.rms_loss < 1e-10, "{}", fit.rms_loss);
    assert!(fit.origin[0].abs() < 1e-12 && fit.origin[1].abs() < 1e-12);
    let block = legwise::printer::export::save_config_block(&fit.values);
    // The exported block replaces the values of a config whose sections' own were commented
    // out by Klipper's SAVE_CONFIG.
    let stale = ODD.replace("delta_radius: 140.0", "#delta_radius: 141.0");
    assert_ne!(stale, ODD);
    let again_dir = tempfile::tempdir().unwrap();
    let (delta, again) = import(again_dir.path(), "again.cfg", &format!("{stale}\n{block}"));
    assert!((delta.radius - fit.values.radius).abs() < 1e-9);
    assert_same_model(&first, &again, 1e-9);
    for i in 0..3 {
        assert!((fit.values.angles[i] - ODD_ANGLES[i]).abs() < 1e-9);
        assert!((fit.values.arms[i] - ODD_ARMS[i]).abs() < 1e-9);
        assert!((fit.values.endstops[i] - ODD_ENDSTOPS[i]).abs() < 1e-9);
    }
}

#[test]
fn a_block_value_under_a_live_section_value_is_not_used_as_klipper_reads_it() {
    // Klipper comments out a SAVE_CONFIG value whose key the sections above still set (they
    // win): the reader does the same, and the import says so.
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "{}\n{}\n#*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n\
         #*# [printer]\n#*# delta_radius = 141.0\n#*#\n#*# [stepper_a]\n#*# microsteps = 16\n",
        ODD,
        legwise::printer::klipper::SAVE_CONFIG_MARKER
    );
    let cfg = dir.path().join("live.cfg");
    std::fs::write(&cfg, &text).unwrap();
    let config = KlipperConfig::read(&cfg).unwrap();
    assert_eq!(
        config.get("printer", "delta_radius").unwrap().value,
        "140.0"
    );
    assert_eq!(config.shadowed.len(), 2, "{:?}", config.shadowed);
    let out_dir = dir.path().join("out");
    let out = legwise_succeeds(&[
        "printer",
        "import",
        "--klipper",
        cfg.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let stdout = text_of(&out.stdout);
    let expected = format!(
        "[printer] delta_radius: the SAVE_CONFIG block's 141.0 (line {}) is not used: line {} \
         above sets 140.0",
        line_of(&text, "#*# delta_radius = 141.0"),
        line_of(&text, "delta_radius: 140.0")
    );
    assert!(stdout.contains(&expected), "{stdout}");
    // The same value in both (microsteps 16): nothing to say.
    assert!(!stdout.contains("[stepper_a] microsteps"), "{stdout}");
    assert!(stdout.contains("delta_radius 140 mm"), "{stdout}");
}

/// The 1-based line of `text` that contains `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

#[test]
fn the_export_prints_what_klipper_cannot_express() {
    let dir = tempfile::tempdir().unwrap();
    let (_, _) = import(dir.path(), "odd.cfg", ODD);
    let yaml = std::fs::read_to_string(dir.path().join("printer.yaml")).unwrap();
    // A gain 1e-3 off on tower a, and a bed tilted by 1 mrad: neither is a Klipper value.
    let edited = yaml
        .replacen("gain: 1.0", "gain: 1.001", 1)
        .replace("roll: 0.0,", "roll: 0.001,");
    assert_ne!(edited, yaml);
    std::fs::write(dir.path().join("odd-gain.yaml"), edited).unwrap();
    let mechanism = Mechanism::load(&dir.path().join("odd-gain.yaml")).unwrap();
    let fit = fit_klipper(&mechanism, 0.08, None).unwrap();
    assert!(
        fit.rms_loss > 1e-6 && fit.rms_loss < 0.5 * fit.start_rms_loss,
        "loss {} start {}",
        fit.rms_loss,
        fit.start_rms_loss
    );
    let path = dir.path().join("odd-gain.yaml");
    let out = legwise_succeeds(&[
        "printer",
        "export",
        "--klipper",
        "--calibrated",
        path.to_str().unwrap(),
        "--bed-radius",
        "0.08",
        "--out",
        "-",
    ]);
    let stderr = text(&out.stderr);
    let loss = format!("{:.3} µm RMS", fit.rms_loss * 1e6);
    assert!(stderr.contains(&loss), "{stderr}");
    assert!(
        text(&out.stdout).starts_with("#*# <----"),
        "{}",
        text(&out.stdout)
    );
}

#[test]
fn the_gains_go_out_as_rotation_distance_and_come_back() {
    let dir = tempfile::tempdir().unwrap();
    let (delta, _) = import(dir.path(), "odd.cfg", ODD);
    std::fs::write(dir.path().join("odd.cfg"), ODD).unwrap();
    let yaml = std::fs::read_to_string(dir.path().join("printer.yaml")).unwrap();
    // A calibrated printer whose carriages a and c travel 1e-3 more and 5e-4 less per step
    // than Klipper's rotation_distance says.
    let edited = yaml
        .replace("{joint: C1, gain: 1.0,", "{joint: C1, gain: 1.001,")
        .replace("{joint: C3, gain: 1.0,", "{joint: C3, gain: 0.9995,");
    assert_eq!(edited.matches("gain: 1.001").count(), 1, "{edited}");
    assert_eq!(edited.matches("gain: 0.9995").count(), 1, "{edited}");
    let path = dir.path().join("cal.yaml");
    std::fs::write(&path, edited).unwrap();
    let calibrated = Mechanism::load(&path).unwrap();
    let rotation = [40.0, 40.0, 32.0];
    let fit = fit_klipper(&calibrated, 0.08, Some(rotation)).unwrap();
    assert!(fit.rms_loss < 1e-10, "loss {:e}", fit.rms_loss);
    let written = fit.values.rotation_distances.unwrap();
    for (i, gain) in [1.001, 1.0, 0.9995].into_iter().enumerate() {
        assert!(
            (written[i] - rotation[i] * gain).abs() < 1e-9,
            "{written:?}"
        );
    }
    // Without the firmware's step settings the gains are lost and the command says so.
    let held = fit_klipper(&calibrated, 0.08, None).unwrap();
    assert!(held.rms_loss > 1e-6, "{:e}", held.rms_loss);
    let cfg = dir.path().join("odd.cfg");
    let out = legwise_succeeds(&[
        "printer",
        "export",
        "--klipper",
        "--calibrated",
        path.to_str().unwrap(),
        "--bed-radius",
        "0.08",
        "--firmware-config",
        cfg.to_str().unwrap(),
        "--out",
        "-",
    ]);
    let values = text(&out.stdout);
    // Not in the block: Klipper reads a stepper section's own rotation_distance over the
    // block's. The lines to set there come first.
    let settings: Vec<&str> = values
        .lines()
        .filter(|l| l.contains("rotation_distance"))
        .collect();
    let expected = [
        format!(
            "#   [stepper_a] rotation_distance: {:.9}",
            rotation[0] * 1.001
        ),
        "#   [stepper_b] rotation_distance: 40.000000000".to_string(),
        format!(
            "#   [stepper_c] rotation_distance: {:.9}",
            rotation[2] * 0.9995
        ),
    ];
    assert_eq!(settings, expected, "{values}");
    let block = &values[values
        .find(legwise::printer::klipper::SAVE_CONFIG_MARKER)
        .unwrap()..];
    assert!(
        text(&out.stderr).contains("0.000 µm RMS"),
        "{}",
        text(&out.stderr)
    );
    let out = legwise_succeeds(&[
        "printer",
        "export",
        "--klipper",
        "--calibrated",
        path.to_str().unwrap(),
        "--bed-radius",
        "0.08",
        "--out",
        "-",
    ]);
    assert!(
        text(&out.stderr)
            .contains("note: the calibrated gains [1.001000, 1.000000, 0.999500] are not exported"),
        "{}",
        text(&out.stderr)
    );
    // The owner sets the new rotation_distances in the stepper sections and pastes the block:
    // Klipper's new step distances take the gains, and for every nozzle position the
    // re-imported model asks for the same step counts as the calibrated one.
    let mut sections = ODD.to_string();
    for (old, new) in [
        (
            "microsteps: 16\nrotation_distance: 40\n",
            format!("microsteps: 16\nrotation_distance: {:.9}\n", 40.0 * 1.001),
        ),
        (
            "rotation_distance: 32",
            format!("rotation_distance: {:.9}", 32.0 * 0.9995),
        ),
    ] {
        assert_eq!(sections.matches(old).count(), 1, "{old}");
        sections = sections.replacen(old, &new, 1);
    }
    let again_dir = tempfile::tempdir().unwrap();
    let (again_delta, again) = import(
        again_dir.path(),
        "again.cfg",
        &format!("{sections}\n{block}"),
    );
    let (p_cal, p_new) = (calibrated.nominal_parameters(), again.nominal_parameters());
    for p in [[0.0, 0.0, 0.0], [0.05, -0.03, 0.0], [-0.06, 0.02, 0.04]] {
        let pose = [p[0], p[1], p[2], 0.0, 0.0, 0.0];
        for i in 0..3 {
            let steps = |m: &Mechanism, params: &[Vec<f64>], step: f64| {
                -predict_reading::<f64>(&m.legs[i], &params[i], &pose, &m.home_pose).unwrap()
                    / (step * 1e-3)
            };
            let before = steps(&calibrated, &p_cal, delta.step_distances[i]);
            let after = steps(&again, &p_new, again_delta.step_distances[i]);
            assert!(
                (before - after).abs() < 1e-6,
                "{p:?} tower {i}: {before} steps calibrated, {after} re-imported"
            );
        }
    }
}

/// The values of a SAVE_CONFIG block, read back by the importer's reader.
fn exported(path: &Path) -> KlipperConfig {
    KlipperConfig::read(path).unwrap()
}

#[test]
fn import_identify_export_recovers_the_printer_behind_the_touches() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    // Klipper's six alone (rods and gains held): what DELTA_CALIBRATE's seven touches carry.
    let six = ["--rod-prior", "0", "--gain-prior", "0"];
    let mut args = vec!["printer", "import", "--klipper", CFG, "--out", d];
    args.extend(six);
    let out = legwise_succeeds(&args);
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("leg1 = stepper_a (angle default 210 deg)"),
        "{stdout}"
    );
    assert!(stdout.contains("7 touches"), "{stdout}");
    let model = format!("{d}/printer.yaml");
    let csv = format!("{d}/probe.csv");
    // Seven touches (DELTA_CALIBRATE's default) at the default 10 µm probe: the fit runs and
    // says its predicted σ over the bed exceeds the 0.1 mm tolerance (exit 3).
    let out = legwise(&["identify", "--model", &model, "--measurements", &csv]);
    assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
    assert!(text(&out.stderr)
        .contains("reaches 0.1166 mm (RMS 0.0852 mm), above the model's tolerance"));
    // The touches are exact to Klipper's 0.001 step: with a 1 µm probe the fit is trusted, and
    // its export is the real printer of make_printer_cfg.py.
    let mut args = vec!["printer", "import", "--klipper", CFG, "--out", d];
    args.extend(["--probe-noise", "1e-6"]);
    args.extend(six);
    legwise_succeeds(&args);
    let cal = format!("{d}/cal.yaml");
    legwise_succeeds(&[
        "identify",
        "--model",
        &model,
        "--measurements",
        &csv,
        "--calibrated",
        &cal,
    ]);
    let cfg = format!("{d}/cal.cfg");
    legwise_succeeds(&[
        "printer",
        "export",
        "--klipper",
        "--calibrated",
        &cal,
        "--out",
        &cfg,
    ]);
    let block = exported(Path::new(&cfg));
    let f = |s: &str, k: &str| block.float(s, k).unwrap().unwrap();
    assert!((f("printer", "delta_radius") - 175.15).abs() < 1e-3);
    let angle_c = f("stepper_c", "angle");
    for (tower, endstop, angle) in [
        ("stepper_a", 297.36, 210.25),
        ("stepper_b", 296.93, 329.8),
        ("stepper_c", 297.10, 90.0),
    ] {
        assert!(
            (f(tower, "position_endstop") - endstop).abs() < 1e-3,
            "{tower}"
        );
        assert!((f(tower, "arm_length") - 333.0).abs() < 1e-9, "{tower}");
        // A probe cannot see a turn about the bed's normal: the angles between towers.
        assert!(
            ((f(tower, "angle") - angle_c) - (angle - 90.0)).abs() < 1e-3,
            "{tower}"
        );
    }
}

#[test]
fn bad_printer_cfgs_name_file_line_section_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let case = |name: &str, text: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().to_string()
    };
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let no_arm = case("no_arm.cfg", &ODD.replace("arm_length: 290.0\n", ""));
    assert_fails_with(
        &["printer", "import", "--klipper", &no_arm, "--out", out],
        &format!(
            "legwise: {no_arm}: line 5: [stepper_a]: missing `arm_length` (the diagonal rod length, mm); \
             Klipper needs it and legwise does not guess it"
        ),
    );
    let no_radius = case("no_radius.cfg", &ODD.replace("delta_radius: 140.0\n", ""));
    assert_fails_with(
        &["printer", "import", "--klipper", &no_radius, "--out", out],
        &format!(
            "legwise: {no_radius}: line 1: [printer]: missing `delta_radius` (the tower radius, mm); \
             Klipper needs it and legwise does not guess it"
        ),
    );
    let cartesian = case(
        "cartesian.cfg",
        &ODD.replace("kinematics = delta", "kinematics = corexy"),
    );
    assert_fails_with(
        &["printer", "import", "--klipper", &cartesian, "--out", out],
        &format!("legwise: {cartesian}: line 2: [printer] `kinematics`: expected `delta`, found `corexy`"),
    );
    let short_pos = case(
        "short_pos.cfg",
        &format!("{ODD}[delta_calibrate]\nheight0 = 0.5\nheight0_pos = 1.0,2.0\n"),
    );
    assert_fails_with(
        &["printer", "import", "--klipper", &short_pos, "--out", out],
        &format!(
            "legwise: {short_pos}: line 28: [delta_calibrate] `height0_pos`: expected 3 numbers separated by commas, found `1.0,2.0`"
        ),
    );
    let bad_number = case(
        "bad_number.cfg",
        &ODD.replace("delta_radius: 140.0", "delta_radius: 140,0"),
    );
    assert_fails_with(
        &["printer", "import", "--klipper", &bad_number, "--out", out],
        &format!("legwise: {bad_number}: line 3: [printer] `delta_radius`: expected a number, found `140,0`"),
    );
    let noise = [
        "printer",
        "import",
        "--klipper",
        CFG,
        "--out",
        out,
        "--probe-noise",
        "-1",
    ];
    assert_fails_with(
        &noise,
        "legwise: --probe-noise: expected a positive σ in metres, found -1",
    );
}

#[test]
fn delta_analyze_distances_free_the_rods() {
    // A printer whose rods are not the file's: touches at three heights and six distances
    // between touch points (DELTA_ANALYZE's `distanceN`, `distanceN_pos1`, `distanceN_pos2`).
    let real_arms = [ODD_ARMS[0] + 0.6, ODD_ARMS[1] - 0.4, ODD_ARMS[2] + 0.3];
    let points = odd_points();
    let mut file = format!(
        "{ODD}\n#*# <---------------------- SAVE_CONFIG ---------------------->\n\
         #*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n#*# [delta_calibrate]\n"
    );
    let fmt = |s: [f64; 3]| format!("{:.9},{:.9},{:.9}", s[0], s[1], s[2]);
    for (n, p) in points.iter().enumerate() {
        let s = steps_with_arms(*p, real_arms);
        file.push_str(&format!(
            "#*# height{n} = {}\n#*# height{n}_pos = {}\n",
            p[2],
            fmt(s)
        ));
    }
    for (n, (a, b)) in [(0, 1), (2, 3), (1, 4), (5, 8), (7, 12), (3, 14)]
        .into_iter()
        .enumerate()
    {
        let (pa, pb): ([f64; 3], [f64; 3]) = (points[a], points[b]);
        let d =
            ((pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2) + (pa[2] - pb[2]).powi(2)).sqrt();
        file.push_str(&format!(
            "#*# distance{n} = {d:.12}\n#*# distance{n}_pos1 = {}\n#*# distance{n}_pos2 = {}\n",
            fmt(steps_with_arms(pa, real_arms)),
            fmt(steps_with_arms(pb, real_arms))
        ));
    }
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("analyze.cfg");
    std::fs::write(&cfg, file).unwrap();
    let d = dir.path().to_str().unwrap();
    let out = legwise_succeeds(&[
        "printer",
        "import",
        "--klipper",
        cfg.to_str().unwrap(),
        "--out",
        d,
    ]);
    assert!(text(&out.stdout).contains("6 distances of DELTA_ANALYZE imported"));
    let csv = std::fs::read_to_string(dir.path().join("probe.csv")).unwrap();
    assert!(
        csv.starts_with("z.nozzle,C1,C2,C3,id,from,to,distance\n"),
        "{csv}"
    );
    assert!(csv.contains(",,,,,distance0_pos1,distance0_pos2,"), "{csv}");
    let (model, cal, out_cfg) = (
        format!("{d}/printer.yaml"),
        format!("{d}/cal.yaml"),
        format!("{d}/cal.cfg"),
    );
    let csv = format!("{d}/probe.csv");
    legwise_succeeds(&[
        "identify",
        "--model",
        &model,
        "--measurements",
        &csv,
        "--calibrated",
        &cal,
    ]);
    legwise_succeeds(&[
        "printer",
        "export",
        "--klipper",
        "--calibrated",
        &cal,
        "--out",
        &out_cfg,
    ]);
    let block = exported(Path::new(&out_cfg));
    for (i, tower) in ["stepper_a", "stepper_b", "stepper_c"]
        .into_iter()
        .enumerate()
    {
        let arm = block.float(tower, "arm_length").unwrap().unwrap();
        assert!(
            (arm - real_arms[i]).abs() < 1e-5,
            "{tower}: {arm} vs {}",
            real_arms[i]
        );
        let endstop = block.float(tower, "position_endstop").unwrap().unwrap();
        assert!(
            (endstop - ODD_ENDSTOPS[i]).abs() < 1e-5,
            "{tower}: {endstop}"
        );
    }
    let radius = block.float("printer", "delta_radius").unwrap().unwrap();
    assert!((radius - ODD_R).abs() < 1e-5, "{radius}");
}

#[test]
fn a_bed_radius_that_is_not_a_positive_length_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    import(dir.path(), "odd.cfg", ODD);
    let model = dir.path().join("printer.yaml");
    for radius in ["0", "-0.05", "NaN", "inf"] {
        let shown = match radius {
            "NaN" => "NaN".to_string(),
            "inf" => "inf".to_string(),
            r => r.parse::<f64>().unwrap().to_string(),
        };
        let out = legwise(&[
            "printer",
            "export",
            "--klipper",
            "--calibrated",
            model.to_str().unwrap(),
            "--bed-radius",
            radius,
            "--out",
            "-",
        ]);
        assert_eq!(out.status.code(), Some(2), "{radius}");
        assert_eq!(
            text(&out.stderr),
            format!("legwise: --bed-radius: expected a positive radius in metres, found {shown}\n"),
            "{radius}"
        );
    }
    // A small positive radius is a disc like any other.
    legwise_succeeds(&[
        "printer",
        "export",
        "--klipper",
        "--calibrated",
        model.to_str().unwrap(),
        "--bed-radius",
        "0.01",
        "--out",
        "-",
    ]);
}
