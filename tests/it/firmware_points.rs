//! `legwise printer points` (src/printer/points.rs): the touches `legwise select` picks for an
//! imported printer, written as the firmware's probing commands; the log the firmware prints
//! for them, simulated here on a printer whose bed is not flat, imported back gives the selected
//! touches (RepRapFirmware's bed.g and Marlin's G30 lines; Klipper's `[delta_calibrate]`
//! points through a simulated SAVE_CONFIG block); bad selections name the file and the line.
// The values read from the files are compared exactly: they are the files' decimals.
#![allow(clippy::float_cmp)]
use std::path::Path;

use legwise::printer::delta_model::DeltaGeometry;
use legwise::printer::export::trilaterate;
use legwise::printer::klipper::{KlipperConfig, KlipperDelta};
use legwise::printer::marlin::MarlinDelta;
use legwise::printer::rrf::RrfDelta;
use nalgebra::Vector3;

use crate::cli::{assert_fails_with, legwise, legwise_succeeds, text};

const RRF_CONFIG: &str = "tests/data/rrf/config.g";
const RRF_OVERRIDE: &str = "tests/data/rrf/config-override.g";
const RRF_LOG: &str = "tests/data/rrf/bed-probe.log";
const MARLIN_M503: &str = "tests/data/marlin/m503.txt";
const MARLIN_LOG: &str = "tests/data/marlin/g30.log";
const KLIPPER_CFG: &str = "tests/data/klipper/printer.cfg";

/// The simulated bed's height under the nozzle at `(x, y)` (mm): a plane, tilted and raised.
fn bed(x: f64, y: f64) -> f64 {
    0.031 + 4e-4 * x - 7e-4 * y
}

/// Imports `import` into `dir`, selects its touches and writes them with `printer points`
/// `points` (the firmware's option and files); returns the selected nozzle points (mm) and the
/// commands written.
fn select_and_write(dir: &Path, import: &[&str], points: &[&str]) -> (Vec<[f64; 2]>, String) {
    let d = dir.to_str().unwrap();
    let mut args = vec!["printer", "import"];
    args.extend_from_slice(import);
    args.extend_from_slice(&["--out", d]);
    legwise_succeeds(&args);
    let model = format!("{d}/printer.yaml");
    let selected = format!("{d}/selected.csv");
    legwise_succeeds(&["select", "--model", &model, "--out", &selected]);
    let out = format!("{d}/commands.g");
    let mut args = vec!["printer", "points"];
    args.extend_from_slice(points);
    args.extend_from_slice(&["--model", &model, "--selected", &selected, "--out", &out]);
    let run = legwise_succeeds(&args);
    assert!(
        text(&run.stderr).contains("touches of"),
        "{}",
        text(&run.stderr)
    );
    let csv = std::fs::read_to_string(&selected).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (cx, cy) = (col("pose.x"), col("pose.y"));
    let touches = csv
        .lines()
        .skip(1)
        .map(|l| {
            let cells: Vec<f64> = l.split(',').map(|c| c.parse().unwrap_or(0.0)).collect();
            [cells[cx] * 1e3, cells[cy] * 1e3]
        })
        .collect();
    (touches, std::fs::read_to_string(&out).unwrap())
}

/// The number after `key` in a G-code line (`X12.5` → 12.5).
fn word(line: &str, key: char) -> f64 {
    line.split(';')
        .next()
        .unwrap()
        .split_whitespace()
        .find_map(|w| w.strip_prefix(key))
        .unwrap()
        .parse()
        .unwrap()
}

/// The nozzle (mm) where each imported touch's readings put it, by the firmware's kinematics.
fn nozzles(geometry: &DeltaGeometry) -> Vec<Vector3<f64>> {
    geometry
        .touches
        .iter()
        .map(|t| {
            let centres: [Vector3<f64>; 3] = std::array::from_fn(|i| {
                let [x, y] = geometry.tower(i);
                Vector3::new(x, y, t.readings_mm[i] + geometry.abs_endstop(i))
            });
            trilaterate(&centres, &geometry.arms).unwrap()
        })
        .collect()
}

/// Each imported touch at its point `selected` (1e-6 mm) and its height on the simulated bed
/// plus the trigger height (to the log's 0.001 mm).
fn assert_round_trip(geometry: &DeltaGeometry, selected: &[[f64; 2]], trigger: f64) {
    let got = nozzles(geometry);
    assert_eq!(got.len(), selected.len());
    for (p, s) in got.iter().zip(selected) {
        assert!(
            (p.x - s[0]).abs() < 1e-6 && (p.y - s[1]).abs() < 1e-6,
            "nozzle {p:?} mm, selected {s:?} mm"
        );
        let want = bed(s[0], s[1]) + trigger;
        assert!((p.z - want).abs() < 5.1e-4, "z {} vs {want}", p.z);
    }
}

#[test]
fn rrf_bed_g_of_the_selection_round_trips_through_its_log() {
    let dir = tempfile::tempdir().unwrap();
    let (selected, bed_g) = select_and_write(
        dir.path(),
        &[
            "--rrf",
            RRF_CONFIG,
            "--override",
            RRF_OVERRIDE,
            "--probes",
            RRF_LOG,
        ],
        &["--rrf", RRF_CONFIG, "--override", RRF_OVERRIDE],
    );
    assert!(selected.len() >= 7, "{} touches", selected.len());
    // The probe (G31 X0 Y15) at each point: the nozzle 15 mm short of it in y.
    let g30: Vec<&str> = bed_g.lines().filter(|l| l.starts_with("G30")).collect();
    assert_eq!(g30.len(), selected.len());
    let mut log = String::from("G28\n");
    let mut heights = Vec::new();
    for (k, (line, s)) in g30.iter().zip(&selected).enumerate() {
        assert!(line.starts_with(&format!("G30 P{k} ")), "{line}");
        assert_eq!(line.contains(" S-1"), k + 1 == g30.len(), "{line}");
        assert_eq!(word(line, 'Z'), -99999.0);
        let (x, y) = (word(line, 'X'), word(line, 'Y') - 15.0);
        assert!((x - s[0]).abs() < 1e-6 && (y - s[1]).abs() < 1e-6, "{line}");
        // The firmware stops the nozzle G31 Z above the bed and reports its height minus
        // G31 Z (the bed's height under it), to 0.001 mm.
        heights.push(format!("{:.3}", bed(x, y)));
        log.push_str(line);
        log.push('\n');
    }
    log.push_str(&format!(
        "G32 bed probe heights: {}, mean 0.000, deviation from mean 0.100\n",
        heights.join(" ")
    ));
    let log_path = dir.path().join("bed.log");
    std::fs::write(&log_path, log).unwrap();
    let delta = RrfDelta::read(
        Path::new(RRF_CONFIG),
        Some(Path::new(RRF_OVERRIDE)),
        Some(&log_path),
    )
    .unwrap();
    assert_round_trip(&delta.geometry, &selected, 1.2);
}

#[test]
fn marlin_g30_lines_of_the_selection_round_trip_through_the_log() {
    let dir = tempfile::tempdir().unwrap();
    // The example's report with the probe 20.5 mm left of and 10.25 mm behind the nozzle.
    let m503 = dir.path().join("m503.txt");
    let report = std::fs::read_to_string(MARLIN_M503).unwrap();
    let report = report.replace("M851 X0.00 Y0.00 Z-0.60", "M851 X-20.50 Y10.25 Z-0.60");
    std::fs::write(&m503, report).unwrap();
    let m503_name = m503.to_str().unwrap();
    let models = dir.path().join("model");
    let (selected, lines) = select_and_write(
        &models,
        &["--marlin", m503_name, "--probes", MARLIN_LOG],
        &["--marlin", m503_name],
    );
    assert!(selected.len() >= 7, "{} touches", selected.len());
    let offset = MarlinDelta::read(&m503, None).unwrap().probe_offset;
    assert_eq!(offset, [-20.5, 10.25, -0.6]);
    let g30: Vec<&str> = lines.lines().filter(|l| l.starts_with("G30")).collect();
    assert_eq!(g30.len(), selected.len());
    let mut log = String::from("Send: G28\nRecv: ok\n");
    let mut commanded = Vec::new();
    for (line, s) in g30.iter().zip(&selected) {
        let (x, y) = (word(line, 'X'), word(line, 'Y'));
        // To 0.01 mm, as Marlin prints them.
        assert!(
            (x - offset[0] - s[0]).abs() <= 0.005 + 1e-9
                && (y - offset[1] - s[1]).abs() <= 0.005 + 1e-9,
            "{line}"
        );
        // Marlin reports the probe's z at the trigger: the nozzle's height plus M851 Z, the
        // bed's height under the nozzle.
        let z = bed(x - offset[0], y - offset[1]);
        commanded.push([x - offset[0], y - offset[1]]);
        log.push_str(&format!(
            "Send: {}\nRecv: Bed X: {x:.2} Y: {y:.2} Z: {z:.3}\nRecv: ok\n",
            line.split(';').next().unwrap().trim()
        ));
    }
    let log_path = dir.path().join("g30.log");
    std::fs::write(&log_path, log).unwrap();
    let delta = MarlinDelta::read(&m503, Some(&log_path)).unwrap();
    // The touches where the commands put the nozzle: each within 0.005 mm of the selection.
    assert_round_trip(&delta.geometry, &commanded, -offset[2]);
    assert!(commanded.iter().zip(&selected).any(|(c, s)| c != s));
}

#[test]
fn klipper_points_are_the_selected_nozzle_points_in_delta_calibrate() {
    let dir = tempfile::tempdir().unwrap();
    let (selected, section) = select_and_write(
        dir.path(),
        &["--klipper", KLIPPER_CFG],
        &["--klipper", KLIPPER_CFG],
    );
    let body: Vec<&str> = section.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(body[0], "[delta_calibrate]");
    assert_eq!(body[1], "radius: 50");
    let at = body.iter().position(|l| *l == "points:").unwrap();
    let points: Vec<[f64; 2]> = body[at + 1..]
        .iter()
        .map(|l| {
            assert!(l.starts_with("    "), "{l}");
            let (x, y) = l.trim().split_once(", ").unwrap();
            [x.parse().unwrap(), y.parse().unwrap()]
        })
        .collect();
    assert_eq!(points.len(), selected.len());
    for (p, s) in points.iter().zip(&selected) {
        assert!((p[0] - s[0]).abs() < 1e-6 && (p[1] - s[1]).abs() < 1e-6);
    }
}

#[test]
fn klipper_delta_calibrate_of_the_points_round_trips_through_save_config() {
    let dir = tempfile::tempdir().unwrap();
    let (selected, section) = select_and_write(
        dir.path(),
        &["--klipper", KLIPPER_CFG],
        &["--klipper", KLIPPER_CFG],
    );
    let at = section.find("points:\n").unwrap();
    let points: Vec<[f64; 2]> = section[at + 8..]
        .lines()
        .map(|l| {
            let (x, y) = l.trim().split_once(", ").unwrap();
            [x.parse().unwrap(), y.parse().unwrap()]
        })
        .collect();
    assert_eq!(points.len(), selected.len());
    // DELTA_CALIBRATE on the example printer over the simulated bed: at each point the nozzle
    // stops z_offset (1.2 mm) above the bed, and SAVE_CONFIG keeps z_offset as heightN and the
    // steps since each endstop, (endstop carriage height − carriage height) / step distance, to
    // 0.001 step, as heightN_pos.
    let text = std::fs::read_to_string(KLIPPER_CFG).unwrap();
    let delta =
        KlipperDelta::from_config(&KlipperConfig::read(Path::new(KLIPPER_CFG)).unwrap()).unwrap();
    let geometry = delta.geometry();
    let mut cfg = text[..text.find("#*# [delta_calibrate]").unwrap()].to_string();
    cfg.push_str("#*# [delta_calibrate]\n");
    for (k, [x, y]) in points.iter().enumerate() {
        let p = [*x, *y, bed(*x, *y) + 1.2];
        let steps: Vec<String> = (0..3)
            .map(|i| {
                let h = geometry.carriage_height(i, p).unwrap();
                format!(
                    "{:.3}",
                    (geometry.abs_endstop(i) - h) / delta.step_distances[i]
                )
            })
            .collect();
        cfg.push_str(&format!(
            "#*# height{k} = 1.2\n#*# height{k}_pos = {}\n",
            steps.join(",")
        ));
    }
    let path = dir.path().join("probed.cfg");
    std::fs::write(&path, cfg).unwrap();
    let back = KlipperDelta::from_config(&KlipperConfig::read(&path).unwrap()).unwrap();
    // 0.001 step of 0.0125 mm: each carriage to 6.25e-6 mm; the nozzle within 1e-5 mm
    // measured, 5e-5 mm asserted.
    let got = nozzles(&back.geometry());
    assert_eq!(got.len(), selected.len());
    for (p, s) in got.iter().zip(&selected) {
        let e = (p.x - s[0]).hypot(p.y - s[1]);
        assert!(e < 5e-5, "nozzle {p:?} mm, selected {s:?} mm");
        assert!((p.z - bed(s[0], s[1]) - 1.2).abs() < 5e-5, "{p:?}");
    }
}

#[test]
fn bad_selections_name_the_file_and_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let rrf = format!("{d}/rrf");
    let marlin = format!("{d}/marlin");
    legwise_succeeds(&[
        "printer",
        "import",
        "--rrf",
        RRF_CONFIG,
        "--override",
        RRF_OVERRIDE,
        "--probes",
        RRF_LOG,
        "--out",
        &rrf,
    ]);
    legwise_succeeds(&[
        "printer",
        "import",
        "--marlin",
        MARLIN_M503,
        "--probes",
        MARLIN_LOG,
        "--out",
        &marlin,
    ]);
    let model = format!("{rrf}/printer.yaml");
    let case = |name: &str, text: &str| {
        let path = format!("{d}/{name}");
        std::fs::write(&path, text).unwrap();
        path
    };
    let points = |selected: &str| {
        [
            "printer",
            "points",
            "--rrf",
            RRF_CONFIG,
            "--model",
            &model,
            "--selected",
            selected,
            "--out",
            "-",
        ]
        .map(String::from)
    };
    let run = |selected: &str, expected: &str| {
        let args = points(selected);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        assert_fails_with(&args, expected);
    };
    let header = "leg,pose.x,pose.y,pose.z,z.nozzle,C1,C2,C3,id";
    // Marlin's selection (its touch 0.6 mm above the bed) given with RepRapFirmware's model.
    let other = format!("{d}/marlin_selected.csv");
    legwise_succeeds(&[
        "select",
        "--model",
        &format!("{marlin}/printer.yaml"),
        "--out",
        &other,
    ]);
    let out = legwise(
        &points(&other)
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.starts_with(&format!("legwise: {other}: line 2: touch t1: pose.z: expected the model's touch height there, 0.0012 m, found 0.0006 m")),
        "{stderr}"
    );
    let outside = case(
        "outside.csv",
        &format!("{header}\n,0.0,0.14,0.0012,,,,,t1\n"),
    );
    run(
        &outside,
        &format!(
            "legwise: {outside}: line 2: touch t1: the nozzle at (0.000, 140.000) mm is 140.000 mm from the \
             bed's centre, outside the printer's radius 135.000 mm ({model} `workspace.region`)"
        ),
    );
    let empty = case("empty.csv", &format!("{header}\n"));
    run(
        &empty,
        &format!(
            "legwise: {empty}: no touch rows (ids t1, t2, …): expected the file `legwise select --model {model}` writes"
        ),
    );
    let five_r = case("five_r.csv", "leg,pose.x,pose.y,C1,C2\n1,0.1,0.2,,\n");
    run(
        &five_r,
        &format!(
            "legwise: {five_r}: line 1: expected the header `legwise select --model {model}` writes, \
             `{header}`, found `leg,pose.x,pose.y,C1,C2` (a selection of another model?)"
        ),
    );
    let word = case("word.csv", &format!("{header}\n,abc,0.0,0.0012,,,,,t1\n"));
    run(
        &word,
        &format!("legwise: {word}: line 2: pose.x: expected a number (m), found `abc`"),
    );
}
