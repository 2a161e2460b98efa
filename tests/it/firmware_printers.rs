//! `legwise printer import --rrf|--marlin` and `printer export --rrf|--marlin` (src/printer):
//! RepRapFirmware's config.g + config-override.g and a bed.g probe log, Marlin's M503 report
//! and a G30 log (tests/data/rrf, tests/data/marlin; the logs written by rrf/make_logs.py from a
//! simulated printer whose geometry is not the firmware's). The readings against the firmwares'
//! closed forms written here; import → export → import round trips; import → identify → export
//! recovers the simulated printers; bad files.
// The values read from the files are compared exactly: they are the files' decimals.
#![allow(clippy::float_cmp)]
use std::path::Path;

use legwise::kinematics::platform::forward;
use legwise::printer::delta_model::{printer_files, DeltaGeometry, ModelOptions};
use legwise::printer::export::fit_delta;
use legwise::printer::marlin::{self, MarlinDelta, MarlinValues};
use legwise::printer::rrf::{self, RrfDelta, RrfValues};
use legwise::Mechanism;

use crate::cli::{assert_fails_with, legwise_succeeds, text};

const RRF_CONFIG: &str = "tests/data/rrf/config.g";
const RRF_OVERRIDE: &str = "tests/data/rrf/config-override.g";
const RRF_LOG: &str = "tests/data/rrf/bed-probe.log";
const MARLIN_M503: &str = "tests/data/marlin/m503.txt";
const MARLIN_LOG: &str = "tests/data/marlin/g30.log";

/// Writes the model files of `geometry` in `dir` and loads the model.
fn model(dir: &Path, geometry: &DeltaGeometry) -> Mechanism {
    let files = printer_files(geometry, &ModelOptions::firmware_factors(), "printer.urdf");
    std::fs::write(dir.join("printer.yaml"), &files.yaml).unwrap();
    std::fs::write(dir.join("printer.urdf"), &files.urdf).unwrap();
    std::fs::write(dir.join("probe.csv"), &files.csv).unwrap();
    Mechanism::load(&dir.join("printer.yaml")).unwrap()
}

/// A delta's carriage readings (mm) at the nozzle `p` (mm), written here from the firmwares'
/// formula: tower i at `radius (cos θ_i, sin θ_i)`, carriage height
/// `z + sqrt(L_i² − (x − t_ix)² − (y − t_iy)²)`, minus the carriage's height at its endstop
/// `endstop_i + sqrt(L_i² − radius²)`.
fn closed_form(
    radius: f64,
    angles: [f64; 3],
    rods: [f64; 3],
    ends: [f64; 3],
    p: [f64; 3],
) -> [f64; 3] {
    std::array::from_fn(|i| {
        let a = angles[i].to_radians();
        let (tx, ty) = (radius * a.cos(), radius * a.sin());
        let l = rods[i];
        p[2] + (l * l - (p[0] - tx).powi(2) - (p[1] - ty).powi(2)).sqrt()
            - ends[i]
            - (l * l - radius * radius).sqrt()
    })
}

/// Every touch's readings against [`closed_form`] at its nozzle position, and the model's
/// forward kinematics from the CSV's readings back to that nozzle.
fn assert_touches(dir: &Path, geometry: &DeltaGeometry, nozzles: &[[f64; 3]], ends: [f64; 3]) {
    let mechanism = model(dir, geometry);
    let params = mechanism.nominal_parameters();
    assert_eq!(geometry.touches.len(), nozzles.len());
    let csv = std::fs::read_to_string(dir.join("probe.csv")).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').take(4).map(|v| v.parse().unwrap()).collect())
        .collect();
    for ((touch, p), row) in geometry.touches.iter().zip(nozzles).zip(&rows) {
        let want = closed_form(geometry.radius, geometry.angles, geometry.arms, ends, *p);
        for i in 0..3 {
            assert!(
                (touch.readings_mm[i] - want[i]).abs() < 1e-9,
                "{}: tower {i}: {} vs {}",
                touch.id,
                touch.readings_mm[i],
                want[i]
            );
            assert!((row[1 + i] - want[i] * 1e-3).abs() < 1e-12);
        }
        let reached = forward(&mechanism, &params, &row[1..4]).unwrap();
        for k in 0..3 {
            assert!(
                (reached[k] - p[k] * 1e-3).abs() < 1e-9,
                "{}: reached {reached:?}, nozzle {p:?} mm",
                touch.id
            );
        }
    }
}

/// The numbers after `key` up to the next blank in `line` (`X12.5` → 12.5).
fn word(line: &str, key: char) -> f64 {
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(key))
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn rrf_import_reads_the_override_over_config_g_and_the_probe_log() {
    let delta = RrfDelta::read(
        Path::new(RRF_CONFIG),
        Some(Path::new(RRF_OVERRIDE)),
        Some(Path::new(RRF_LOG)),
    )
    .unwrap();
    let g = &delta.geometry;
    // config-override.g's M665/M666 over config.g's; config.g's M92 and G31.
    assert_eq!(g.radius, 180.5);
    assert_eq!(g.arms, [360.0; 3]);
    assert_eq!(g.angles, [210.2, 329.85, 90.0]);
    // H + M666: RepRapFirmware adds the correction to the homed carriage height.
    for (got, want) in g.endstops.iter().zip([301.55, 301.15, 301.05]) {
        assert!((got - want).abs() < 1e-12, "{got} vs {want}");
    }
    assert_eq!(g.tilt, [0.0, 0.0]);
    assert_eq!(delta.steps_per_mm, Some([80.0; 3]));
    assert_eq!(delta.probe_offset, [0.0, 15.0]);
    assert_eq!(g.z_offset, Some(1.2));
    // The log's points (the probe at X Y) and heights, read here: the nozzle stops at
    // (X − G31 X, Y − G31 Y, height + G31 Z).
    let log = std::fs::read_to_string(RRF_LOG).unwrap();
    let heights: Vec<f64> = log
        .lines()
        .find_map(|l| l.strip_prefix("G32 bed probe heights:"))
        .unwrap()
        .split(", mean")
        .next()
        .unwrap()
        .split_whitespace()
        .map(|h| h.parse().unwrap())
        .collect();
    let nozzles: Vec<[f64; 3]> = log
        .lines()
        .filter(|l| l.starts_with("G30 P"))
        .zip(&heights)
        .map(|(l, h)| [word(l, 'X'), word(l, 'Y') - 15.0, h + 1.2])
        .collect();
    assert_eq!(nozzles.len(), 13);
    let dir = tempfile::tempdir().unwrap();
    assert_touches(dir.path(), g, &nozzles, g.endstops);
}

#[test]
fn marlin_import_reads_m503_and_the_g30_log() {
    let delta = MarlinDelta::read(Path::new(MARLIN_M503), Some(Path::new(MARLIN_LOG))).unwrap();
    let g = &delta.geometry;
    assert_eq!(g.radius, 95.5);
    assert_eq!(g.arms, [217.0; 3]);
    assert_eq!(g.angles, [210.1, 329.75, 90.0]);
    // The carriage stops |M666| below its endstop, and homes the nozzle at H − M851 Z:
    // the nozzle's height at the endstops is H − M851 Z − M666.
    for (got, want) in g
        .endstops
        .iter()
        .zip([288.4 + 0.6 + 0.42, 288.4 + 0.6, 288.4 + 0.6 + 0.18])
    {
        assert!((got - want).abs() < 1e-12, "{got} vs {want}");
    }
    assert_eq!(g.z_offset, Some(0.6));
    assert_eq!(delta.probe_offset, [0.0, 0.0, -0.6]);
    // `Bed X: x Y: y Z: z`: the nozzle stops at (x, y, z − M851 Z).
    let log = std::fs::read_to_string(MARLIN_LOG).unwrap();
    let nozzles: Vec<[f64; 3]> = log
        .lines()
        .filter_map(|l| l.strip_prefix("Recv: Bed X: "))
        .map(|l| {
            let v: Vec<f64> = l
                .replace("Y:", "")
                .replace("Z:", "")
                .split_whitespace()
                .map(|t| t.parse().unwrap())
                .collect();
            [v[0], v[1], v[2] + 0.6]
        })
        .collect();
    assert_eq!(nozzles.len(), 13);
    let dir = tempfile::tempdir().unwrap();
    assert_touches(dir.path(), g, &nozzles, g.endstops);
}

#[test]
fn rrf_g30_s_minus_1_and_a_point_height_correction_h() {
    // `G30 S-1` at the last G1 X Y, `Stopped at height h mm`: the nozzle stopped at h + H; a
    // `P` point's `H` is added the same way (the firmware reports the height minus H).
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("config.g");
    std::fs::write(&config, RRF_ODD).unwrap();
    let log = dir.path().join("probe.log");
    std::fs::write(
        &log,
        "12:03:40 G1 X10 Y20 F6000
12:03:41 G30 S-1 H0.1
12:03:44 Stopped at height 0.25 mm
         G1 X-30
G30 S-1
Stopped at height -0.125 mm
         G30 P0 X40 Y40 H-0.05 Z-99999
G30 P1 X-40 Y40 Z-99999 S-1
         G32 bed probe heights: 0.010 -0.020, mean -0.005, deviation from mean 0.015
",
    )
    .unwrap();
    let delta = RrfDelta::read(&config, None, Some(&log)).unwrap();
    let ids: Vec<&str> = delta
        .geometry
        .touches
        .iter()
        .map(|t| t.id.as_str())
        .collect();
    assert_eq!(ids, ["S-1_line3", "S-1_line6", "P0_line9", "P1_line9"]);
    let nozzles = [
        [10.0, 20.0, 0.35],
        [-30.0, 20.0, -0.125],
        [40.0, 40.0 - 15.0, 0.010 + 1.2 - 0.05],
        [-40.0, 40.0 - 15.0, -0.020 + 1.2],
    ];
    assert_touches(
        dir.path(),
        &delta.geometry,
        &nozzles,
        delta.geometry.endstops,
    );
}

/// Every leg's parameters and the bed's pose of two models agree to `tol`.
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
    let (fa, fb) = (
        a.instrument.as_ref().unwrap().nominal(),
        b.instrument.as_ref().unwrap().nominal(),
    );
    for (u, v) in fa.iter().zip(&fb) {
        assert!((u - v).abs() < tol, "bed {fa:?} vs {fb:?}");
    }
}

/// A RepRapFirmware delta with three rods, three angle and endstop corrections.
const RRF_ODD: &str = "M665 L360.5:359.25:361 R180.5 H301.25 X0.2 Y-0.15 Z0.3 ; delta\n\
                       M666 X0.3 Y-0.1 Z-0.2\nG31 P500 X0 Y15 Z1.2\n";

#[test]
fn rrf_import_export_import_gives_the_same_model() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("config.g");
    std::fs::write(&config, RRF_ODD).unwrap();
    let first = model(
        dir.path(),
        &RrfDelta::read(&config, None, None).unwrap().geometry,
    );
    let fit = fit_delta(&first, 0.1, rrf::TERMS).unwrap();
    assert!(fit.rms_loss < 1e-10, "{}", fit.rms_loss);
    let values = RrfValues::from_fit(&fit, None);
    assert!((values.radius - 180.5).abs() < 1e-9);
    for i in 0..3 {
        assert!((values.rods[i] - [360.5, 359.25, 361.0][i]).abs() < 1e-9);
        assert!((values.corrections[i] - [0.2, -0.15, 0.3][i]).abs() < 1e-9);
        // The corrections' mean is 0 (RepRapFirmware's normalisation): H takes it.
        assert!((values.adjustments[i] - [0.3, -0.1, -0.2][i]).abs() < 1e-9);
    }
    assert!((values.height - 301.25).abs() < 1e-9);
    assert!(values.tilt.iter().all(|t| t.abs() < 1e-9));
    // The exported lines as config-override.g over a config.g holding other values.
    let stale = dir.path().join("stale.g");
    std::fs::write(
        &stale,
        RRF_ODD.replace("R180.5", "R170").replace("X0.3", "X1"),
    )
    .unwrap();
    let over = dir.path().join("cal.g");
    std::fs::write(&over, values.lines()).unwrap();
    let again_dir = tempfile::tempdir().unwrap();
    let again = model(
        again_dir.path(),
        &RrfDelta::read(&stale, Some(&over), None).unwrap().geometry,
    );
    assert_same_model(&first, &again, 1e-9);
    // A firmware with one rod for the three towers cannot express these: the fit says what
    // it loses.
    let one = fit_delta(
        &first,
        0.1,
        legwise::printer::export::FirmwareTerms {
            one_rod: true,
            tilt: false,
            gains: false,
        },
    )
    .unwrap();
    assert!(one.arms[0] == one.arms[1] && one.arms[1] == one.arms[2]);
    assert!(one.rms_loss > 1e-6, "{}", one.rms_loss);
}

#[test]
fn an_rrf_bed_tilt_is_exported_and_its_shear_is_the_loss() {
    // M666 A B: RepRapFirmware shears its frame (z counts along the towers), legwise turns the
    // bed: they agree on the bed, not above it.
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("config.g");
    std::fs::write(&config, RRF_ODD.replace("Z-0.2", "Z-0.2 A0.12 B-0.07")).unwrap();
    let geometry = RrfDelta::read(&config, None, None).unwrap().geometry;
    assert_eq!(geometry.tilt, [0.0012, -0.0007000000000000001]);
    let first = model(dir.path(), &geometry);
    let fit = fit_delta(&first, 0.1, rrf::TERMS).unwrap();
    let values = RrfValues::from_fit(&fit, None);
    assert!((values.tilt[0] - 0.12).abs() < 1e-4, "{:?}", values.tilt);
    assert!((values.tilt[1] + 0.07).abs() < 1e-4, "{:?}", values.tilt);
    // A shift of w · tilt at w = 50 mm above the bed: tens of µm, no more.
    assert!(
        fit.rms_loss > 1e-5 && fit.rms_loss < 1e-4,
        "{}",
        fit.rms_loss
    );
    let over = dir.path().join("cal.g");
    std::fs::write(&over, values.lines()).unwrap();
    let again_dir = tempfile::tempdir().unwrap();
    let again = model(
        again_dir.path(),
        &RrfDelta::read(&config, Some(&over), None).unwrap().geometry,
    );
    assert_same_model(&first, &again, 1e-6);
    // Without the tilt term the endstops and angles take most of the tilt (the two are nearly
    // one direction of a delta): the term helps, a little.
    let level = fit_delta(
        &first,
        0.1,
        legwise::printer::export::FirmwareTerms {
            one_rod: false,
            tilt: false,
            gains: false,
        },
    )
    .unwrap();
    assert!(
        level.rms_loss > fit.rms_loss && level.rms_loss < 1.2 * fit.rms_loss,
        "{} vs {}",
        level.rms_loss,
        fit.rms_loss
    );
}

/// A Marlin M503 report with angle trims and rod trims.
const MARLIN_ODD: &str =
    "echo:  M665 L217.00 R95.50 H288.40 S200.00 X0.10 Y-0.25 Z0.30 A0.50 B-0.25 C0.00\n\
                          echo:  M666 X-0.42 Y0.00 Z-0.18\necho:  M851 X0.00 Y0.00 Z-0.60 ; (mm)\n";

#[test]
fn marlin_import_export_import_gives_the_same_model() {
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("m503.txt");
    std::fs::write(&report, MARLIN_ODD).unwrap();
    let first = model(
        dir.path(),
        &MarlinDelta::read(&report, None).unwrap().geometry,
    );
    let fit = fit_delta(&first, 0.07, marlin::TERMS).unwrap();
    assert!(fit.rms_loss < 1e-10, "{}", fit.rms_loss);
    let values = MarlinValues::from_fit(&fit, -0.6, None);
    for i in 0..3 {
        let rod = values.rod + values.rod_trims[i];
        assert!((rod - (217.0 + [0.5, -0.25, 0.0][i])).abs() < 1e-9, "{rod}");
        assert!((values.trims[i] - [0.1, -0.25, 0.3][i]).abs() < 1e-9);
        // The largest adjustment is 0 (Marlin's normalisation): H takes it.
        assert!((values.adjustments[i] - [-0.42, 0.0, -0.18][i]).abs() < 1e-9);
        assert!(values.adjustments[i] <= 0.0);
    }
    assert!((values.height - 288.4).abs() < 1e-9);
    let lines = values.lines();
    assert!(lines.ends_with("M500\n"), "{lines}");
    // The exported lines after the report (the later value wins, as on the printer).
    let again_report = dir.path().join("again.txt");
    std::fs::write(&again_report, format!("{MARLIN_ODD}{lines}")).unwrap();
    let again_dir = tempfile::tempdir().unwrap();
    let again = model(
        again_dir.path(),
        &MarlinDelta::read(&again_report, None).unwrap().geometry,
    );
    assert_same_model(&first, &again, 1e-9);
}

/// `legwise printer import`, `identify` and `printer export` on the bundled files; returns the
/// exported lines.
fn import_identify_export(import: &[&str], firmware: &str, dir: &Path) -> (String, String, String) {
    let d = dir.to_str().unwrap();
    let mut args = vec!["printer", "import"];
    args.extend_from_slice(import);
    // The firmware's own factors (rods and gains held): what its touches are meant to carry.
    args.extend_from_slice(&[
        "--out",
        d,
        "--probe-noise",
        "1e-6",
        "--rod-prior",
        "0",
        "--gain-prior",
        "0",
    ]);
    let imported = text(&legwise_succeeds(&args).stdout);
    let (model, csv, cal, out) = (
        format!("{d}/printer.yaml"),
        format!("{d}/probe.csv"),
        format!("{d}/cal.yaml"),
        format!("{d}/cal.g"),
    );
    legwise_succeeds(&[
        "identify",
        "--model",
        &model,
        "--measurements",
        &csv,
        "--calibrated",
        &cal,
    ]);
    let exported = legwise_succeeds(&[
        "printer",
        "export",
        firmware,
        "--calibrated",
        &cal,
        "--out",
        &out,
    ]);
    let stderr = text(&exported.stderr);
    // The firmware's own factors hold the gains at 1: nothing to say about them.
    assert!(!stderr.contains("note:"), "{stderr}");
    (imported, std::fs::read_to_string(&out).unwrap(), stderr)
}

/// The numbers of parameter `key` on the line starting `command` (`L1:2:3` → [1, 2, 3]).
fn param(lines: &str, command: &str, key: char) -> Vec<f64> {
    let line = lines.lines().find(|l| l.starts_with(command)).unwrap();
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(key))
        .unwrap()
        .split(':')
        .map(|v| v.parse().unwrap())
        .collect()
}

#[test]
fn rrf_import_identify_export_recovers_the_printer_behind_the_log() {
    let dir = tempfile::tempdir().unwrap();
    let (imported, lines, stderr) = import_identify_export(
        &[
            "--rrf",
            RRF_CONFIG,
            "--override",
            RRF_OVERRIDE,
            "--probes",
            RRF_LOG,
        ],
        "--rrf",
        dir.path(),
    );
    assert!(
        imported.contains("leg1 = X (210 deg + M665 X)"),
        "{imported}"
    );
    assert!(imported.contains("bed-probe.log: 13 touches"), "{imported}");
    // make_logs.py's real printer: R 181.1, angles 210.45, 329.7, 90 (a probe sees them up to a
    // turn), H + M666 = 301.87, 300.94, 301.20; heights printed to 0.001 mm.
    let m665 = |k| param(&lines, "M665", k)[0];
    let m666 = |k| param(&lines, "M666", k)[0];
    assert!((m665('R') - 181.1).abs() < 2e-3, "{lines}");
    assert!(((m665('X') - m665('Z')) - 0.45).abs() < 2e-3, "{lines}");
    assert!(((m665('Y') - m665('Z')) + 0.3).abs() < 2e-3, "{lines}");
    assert_eq!(param(&lines, "M665", 'L'), vec![360.0]);
    for (k, want) in [('X', 301.87), ('Y', 300.94), ('Z', 301.20)] {
        assert!((m665('H') + m666(k) - want).abs() < 2e-3, "{k}: {lines}");
    }
    assert!(m666('A').abs() < 1e-6 && m666('B').abs() < 1e-6, "{lines}");
    assert!(stderr.contains("0.000 µm RMS"), "{stderr}");
}

#[test]
fn marlin_import_identify_export_recovers_the_printer_behind_the_log() {
    let dir = tempfile::tempdir().unwrap();
    let (imported, lines, _) = import_identify_export(
        &["--marlin", MARLIN_M503, "--probes", MARLIN_LOG],
        "--marlin",
        dir.path(),
    );
    assert!(
        imported.contains("leg1 = X/A (210 deg + M665 X)"),
        "{imported}"
    );
    assert!(imported.contains("g30.log: 13 touches"), "{imported}");
    // make_logs.py's real printer: R 95.95, angles 210.3, 329.6, 90, nozzle heights at the
    // endstops H − M851 Z − M666 = 289.61, 289.12, 288.83.
    let m665 = |k| param(&lines, "M665", k)[0];
    let m666 = |k| param(&lines, "M666", k)[0];
    assert!((m665('R') - 95.95).abs() < 2e-3, "{lines}");
    assert!(((m665('X') - m665('Z')) - 0.3).abs() < 2e-3, "{lines}");
    assert!(((m665('Y') - m665('Z')) + 0.4).abs() < 2e-3, "{lines}");
    assert!((m665('L') - 217.0).abs() < 1e-6, "{lines}");
    for (k, want) in [('X', 289.61), ('Y', 289.12), ('Z', 288.83)] {
        assert!(
            (m665('H') + 0.6 - m666(k) - want).abs() < 2e-3,
            "{k}: {lines}"
        );
        assert!(m666(k) <= 0.0, "{lines}");
    }
    assert!(lines.ends_with("M500\n"), "{lines}");
}

#[test]
fn bad_firmware_files_name_file_line_and_parameter() {
    let dir = tempfile::tempdir().unwrap();
    let case = |name: &str, text: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().to_string()
    };
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let no_rod = case("no_rod.g", "G90\nM665 R180 H300 ; no L\n");
    assert_fails_with(
        &["printer", "import", "--rrf", &no_rod, "--out", out],
        &format!(
            "legwise: {no_rod}: line 2: M665: missing `L` (the diagonal rod length, mm); \
             RepRapFirmware needs it and legwise does not guess it"
        ),
    );
    let bad_radius = case("bad_radius.g", "M665 L360 R18O H300\n");
    assert_fails_with(
        &["printer", "import", "--rrf", &bad_radius, "--out", out],
        &format!("legwise: {bad_radius}: line 1: M665 R: expected a number, found `18O`"),
    );
    let no_trigger = case("no_trigger.g", "M665 L360 R180 H300\n");
    assert_fails_with(
        &["printer", "import", "--rrf", &no_trigger, "--probes", RRF_LOG, "--out", out],
        &format!(
            "legwise: {no_trigger}: no G31 line: expected one with `Z` (the nozzle's height above \
             the bed when the probe triggers, mm); RepRapFirmware needs it and legwise does not guess it"
        ),
    );
    let config = case("config.g", "M665 L360 R180 H300\nG31 Z1.2\n");
    let failed = case(
        "failed.log",
        "G30 P0 X0 Y50 Z-99999\nG30 P1 X0 Y-50 Z-99999 S-1\n\
         G32 bed probe heights: 0.012 probing failed, mean 0.012, deviation from mean 0.000\n",
    );
    assert_fails_with(
        &[
            "printer", "import", "--rrf", &config, "--probes", &failed, "--out", out,
        ],
        &format!(
            "legwise: {failed}: line 3: bed probe heights: expected a height per point, found \
             `0.012 probing failed` (a point not set or failed)"
        ),
    );
    let unanswered = case(
        "unanswered.log",
        "G30 P0 X0 Y50 Z-99999\nG30 P1 X0 Y-50 Z-99999 S6\n",
    );
    assert_fails_with(
        &["printer", "import", "--rrf", &config, "--probes", &unanswered, "--out", out],
        &format!(
            "legwise: {unanswered}: line 1: G30 P: a probed point without a `G32 bed probe heights:` \
             reply after it (end the points with S-1 to print them)"
        ),
    );
    let positive = case(
        "positive.txt",
        "echo:  M665 L217 R95.5 H288.4\necho:  M666 X0.2 Y0 Z0\necho:  M851 Z-0.6\n",
    );
    assert_fails_with(
        &["printer", "import", "--marlin", &positive, "--out", out],
        &format!(
            "legwise: {positive}: line 2: M666 X: expected a value <= 0 (Marlin refuses others), found 0.2"
        ),
    );
    let no_probe = case(
        "no_probe.txt",
        "echo:  M665 L217 R95.5 H288.4\necho:  M666 X0 Y0 Z0\n",
    );
    assert_fails_with(
        &["printer", "import", "--marlin", &no_probe, "--out", out],
        &format!(
            "legwise: {no_probe}: no M851 line: expected one with `Z` (the probe's Z offset from \
             the nozzle, mm); Marlin needs it and legwise does not guess it"
        ),
    );
    let m503 = case(
        "m503.txt",
        "echo:  M665 L217 R95.5 H288.4\necho:  M666 X0 Y0 Z0\necho:  M851 Z-0.6\n",
    );
    let garbled = case("garbled.log", "Recv: Bed X: 0.00 Y: abc Z: 0.120\n");
    assert_fails_with(
        &[
            "printer", "import", "--marlin", &m503, "--probes", &garbled, "--out", out,
        ],
        &format!(
            "legwise: {garbled}: line 1: expected `Bed X: <x> Y: <y> Z: <z>` with three numbers, \
             found `Bed X: 0.00 Y: abc Z: 0.120`"
        ),
    );
}

/// A firmware file or probe log that is not a regular file (a device that never ends, a
/// directory) is refused by name before any read, as model files are: no hang, no memory
/// exhausted on `/dev/zero`.
#[test]
fn firmware_inputs_that_are_not_regular_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    for (flag, path, what) in [
        ("--klipper", "/dev/zero", "a character device"),
        ("--marlin", d, "a directory"),
        ("--rrf", "/dev/zero", "a character device"),
    ] {
        crate::cli::assert_fails_with(
            &[
                "printer",
                "import",
                flag,
                path,
                "--out",
                &format!("{d}/out"),
            ],
            &format!("legwise: {path}: not a regular file (it is {what}); expected a text file"),
        );
    }
}

#[test]
fn the_gains_go_out_as_m92_divided_by_them() {
    // The bundled RepRapFirmware and Marlin printers, calibrated with carriage X travelling
    // 1e-3 more and Z 5e-4 less per motor millimetre than the firmware believes: the export with
    // the firmware's file writes `M92` divided by the gains (80 steps/mm in both files) and
    // loses nothing; without it the loss is the gains'.
    for (firmware, import, file) in [
        ("--rrf", vec!["--rrf", RRF_CONFIG], RRF_CONFIG),
        ("--marlin", vec!["--marlin", MARLIN_M503], MARLIN_M503),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().to_str().unwrap();
        let mut args = vec!["printer", "import"];
        args.extend(&import);
        args.extend(["--out", d]);
        legwise_succeeds(&args);
        let yaml = std::fs::read_to_string(dir.path().join("printer.yaml")).unwrap();
        assert!(
            yaml.contains("{name: k1, leg: leg1, actuator: gain, prior: 0.001}"),
            "{yaml}"
        );
        let edited = yaml
            .replace("{joint: C1, gain: 1.0,", "{joint: C1, gain: 1.001,")
            .replace("{joint: C3, gain: 1.0,", "{joint: C3, gain: 0.9995,");
        let cal = dir.path().join("cal.yaml");
        std::fs::write(&cal, edited).unwrap();
        let cal = cal.to_str().unwrap();
        let export = |extra: &[&str]| {
            let mut args = vec!["printer", "export", firmware, "--calibrated", cal];
            args.extend(extra);
            args.extend(["--out", "-"]);
            legwise_succeeds(&args)
        };
        let out = export(&["--firmware-config", file]);
        let lines = text(&out.stdout);
        let steps = param(&lines, "M92", 'X')[0];
        assert!((steps - 80.0 / 1.001).abs() < 1e-8, "{firmware}: {lines}");
        assert!(
            (param(&lines, "M92", 'Z')[0] - 80.0 / 0.9995).abs() < 1e-8,
            "{firmware}: {lines}"
        );
        assert!(
            (param(&lines, "M92", 'Y')[0] - 80.0).abs() < 1e-8,
            "{lines}"
        );
        let stderr = text(&out.stderr);
        assert!(stderr.contains(" 0.000 µm RMS"), "{stderr}");
        assert!(
            stderr.contains("; M92 X Y Z [79.920080, 80.000000, 80.040020] steps/mm"),
            "{stderr}"
        );
        let out = export(&[]);
        assert!(!text(&out.stdout).contains("M92"), "{}", text(&out.stdout));
        let stderr = text(&out.stderr);
        assert!(stderr.contains("note: the calibrated gains"), "{stderr}");
        assert!(!stderr.contains(" 0.000 µm RMS"), "{stderr}");
    }
}
