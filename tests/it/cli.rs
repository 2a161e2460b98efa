//! The real `legwise` binary: bad input exits with code 2 and one `legwise: FILE: …` line on
//! stderr; good input exits 0 and reports every parameter without NaN. Paths are given
//! relative to the crate root, as a user would type them.
use std::process::{Command, Output};

use serde_json::Value;

/// Runs `legwise ARGS` in the crate root.
pub(crate) fn legwise(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the legwise binary runs")
}

/// Runs `legwise` with `args` and checks it exits 0 (its standard error shown otherwise).
pub(crate) fn legwise_succeeds(args: &[&str]) -> Output {
    let out = legwise(args);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{args:?}: {}",
        text(&out.stderr)
    );
    out
}

/// Output bytes as text (legwise writes UTF-8).
pub(crate) fn text(bytes: &[u8]) -> String {
    String::from_utf8(bytes.to_vec()).expect("UTF-8 output")
}

/// Asserts a failed run: exit code 2, nothing on stdout, exactly `expected` (one line) on stderr.
pub(crate) fn assert_fails_with(args: &[&str], expected: &str) {
    let out = legwise(args);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: stderr {stderr:?}");
    assert_eq!(stderr, format!("{expected}\n"), "{args:?}");
    assert_eq!(stderr.lines().count(), 1, "{args:?}: {stderr:?}");
    // NaN may appear only quoting the offending cell.
    assert!(
        !stderr.replace("`NaN`", "").contains("NaN"),
        "{args:?}: {stderr:?}"
    );
    assert_eq!(text(&out.stdout), "", "{args:?}");
}

/// Asserts a successful run and returns its stdout, checked to hold no NaN or infinity.
fn assert_succeeds(args: &[&str]) -> String {
    let out = legwise(args);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{args:?}: stderr {stderr:?}");
    assert_eq!(stderr, "", "{args:?}");
    for word in stdout.split(|c: char| c.is_whitespace() || ",;:()[]".contains(c)) {
        let word = word.to_lowercase();
        assert!(
            !["nan", "inf", "-inf", "infinity"].contains(&word.as_str()),
            "{args:?}: `{word}` in\n{stdout}"
        );
    }
    stdout
}

/// Asserts that a terminal report has a table row for each parameter.
fn assert_reports(stdout: &str, names: &[&str]) {
    for name in names {
        assert!(
            stdout
                .lines()
                .any(|l| l.split_whitespace().next() == Some(name)),
            "no row for `{name}` in\n{stdout}"
        );
    }
}

/// Asserts that every parameter row of a divide-and-conquer LM report on the model's seeded
/// simulation prints the library's estimate, std and real value, and the errors as
/// `nominal − real` and `identified − real`.
fn assert_rows_match_the_library(stdout: &str, model: &str) {
    use legwise::identify::estimate::{identify, Strategy};
    use legwise::measure::simulate::{simulate_at, SimulationOptions};
    let mech = legwise::model::Mechanism::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(model),
    )
    .unwrap();
    // The command's default experiment: the model's selected poses, simulated with its seed.
    let design = legwise::selection::design::ExperimentDesign::select(
        &mech,
        None,
        mech.selection.poses_per_leg,
        mech.selection.criterion,
        true,
    )
    .unwrap();
    let experiment = simulate_at(&mech, &design.pose_sets(), SimulationOptions::default()).unwrap();
    let result = identify(
        &mech,
        &experiment.measurements,
        Strategy::DivideAndConquer,
        legwise::solver::SolverKind::LevenbergMarquardt,
    )
    .unwrap();
    let near = |printed: f64, value: f64, relative: f64| {
        (printed - value).abs() <= relative * value.abs() + 1e-9
    };
    for (leg, estimate) in result.legs.iter().enumerate() {
        for (p, param) in estimate.parameters.iter().enumerate() {
            let row: Vec<f64> = stdout
                .lines()
                .find(|l| l.split_whitespace().next() == Some(param.name.as_str()))
                .unwrap_or_else(|| panic!("no row for `{}` in\n{stdout}", param.name))
                .split_whitespace()
                .skip(2)
                .map(|w| w.parse().unwrap())
                .collect();
            let real = experiment.real[leg][p];
            let [nominal, identified, std, half, printed_real, before, after] = row[..] else {
                panic!("row of `{}`: {row:?}", param.name);
            };
            let what = &param.name;
            assert!(
                near(nominal, param.nominal, 0.0),
                "{what} nominal {nominal}"
            );
            assert!(
                near(identified, param.estimate, 0.0),
                "{what}: {identified} vs library {}",
                param.estimate
            );
            assert!(near(std, param.std.unwrap(), 6e-3), "{what} std {std}");
            let t = param.half_width95().unwrap() / param.std.unwrap();
            assert!(
                near(half, t * param.std.unwrap(), 6e-3),
                "{what} ± 95 % {half}"
            );
            assert!(near(printed_real, real, 0.0), "{what} real {printed_real}");
            assert!(
                near(before, param.nominal - real, 6e-3),
                "{what} error {before}"
            );
            assert!(
                near(after, param.estimate - real, 6e-3),
                "{what} error {after}"
            );
        }
    }
}

const PARAMETERS_5R: [&str; 12] = [
    "l1", "L1", "A1x", "A1y", "k1", "gamma1", "l2", "L2", "A2x", "A2y", "k2", "gamma2",
];

#[test]
fn bad_input_exits_with_code_2_and_one_line_naming_the_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("never-written.csv");
    let cases: [(&[&str], &str); 5] = [
        (
            &["identify", "--model", "tests/data/5r_syntax_error.yaml"],
            "legwise: tests/data/5r_syntax_error.yaml: line 12 column 6: while parsing a block \
             mapping, did not find expected key",
        ),
        (
            &[
                "simulate",
                "--model",
                "tests/data/5r_unknown_field.yaml",
                "--out",
                out.to_str().unwrap(),
            ],
            "legwise: tests/data/5r_unknown_field.yaml: line 12 column 27: legs[0].actuator: \
             unknown field `gian`, expected one of joint, gain, offset",
        ),
        (
            &["workspace", "--model", "tests/data/5r_missing_urdf.yaml"],
            "legwise: tests/data/5r_missing_urdf.yaml: field `urdf`: URDF file \
             `tests/data/no_such_robot.urdf` not found",
        ),
        (
            &[
                "identify",
                "--model",
                "models/5r.yaml",
                "--measurements",
                "tests/data/nan_cell.csv",
            ],
            "legwise: tests/data/nan_cell.csv: line 4, column `A1`: expected a finite number in \
             SI units (radians or metres), found `NaN`",
        ),
        (
            &[
                "identify",
                "--model",
                "models/5r.yaml",
                "--measurements",
                "tests/data/unreachable.csv",
            ],
            "legwise: tests/data/unreachable.csv: line 5: leg `leg1` cannot reach the pose \
             (closure residual 1.204e0 m after 40 Newton iterations)",
        ),
    ];
    for (args, expected) in cases {
        assert_fails_with(args, expected);
    }
    assert!(!out.exists());
}

#[test]

fn a_missing_measurement_file_is_reported_once() {
    let os_message = std::fs::read_to_string("/nonexistent/legwise/no_such_measurements.csv")
        .expect_err("missing")
        .to_string();
    assert_fails_with(
        &[
            "identify",
            "--model",
            "models/5r.yaml",
            "--measurements",
            "tests/data/no_such_measurements.csv",
        ],
        &format!("legwise: tests/data/no_such_measurements.csv: {os_message}"),
    );
}

#[test]

fn a_rank_deficient_pose_set_names_the_file_and_the_parameters() {
    assert_fails_with(
        &[
            "identify",
            "--model",
            "models/5r.yaml",
            "--measurements",
            "tests/data/five_poses.csv",
        ],
        "legwise: tests/data/five_poses.csv: leg `leg1`: rank-deficient identification: rank 5 \
         of 6 parameters; cannot be identified: gamma1 (only 5 measurements for 6 parameters)",
    );
}

#[test]

fn a_leg_without_rows_names_the_file() {
    assert_fails_with(
        &[
            "identify",
            "--model",
            "models/5r.yaml",
            "--measurements",
            "tests/data/no_leg2_rows.csv",
        ],
        "legwise: tests/data/no_leg2_rows.csv: leg `leg2`: no measurements (rows labelled \
         `leg2`, or shared rows with its reading when none is labelled)",
    );
}

#[test]
fn identify_5r_reports_every_parameter() {
    let stdout = assert_succeeds(&["identify", "--model", "models/5r.yaml"]);
    assert_reports(&stdout, &PARAMETERS_5R);
    assert_rows_match_the_library(&stdout, "models/5r.yaml");
}

#[test]
fn identify_3rpr_reports_every_parameter() {
    let stdout = assert_succeeds(&["identify", "--model", "models/3rpr.yaml"]);
    let names: Vec<String> = (1..=3)
        .flat_map(|i| {
            [
                format!("a{i}x"),
                format!("a{i}y"),
                format!("b{i}x"),
                format!("b{i}y"),
                format!("k{i}"),
                format!("rho0_{i}"),
            ]
        })
        .collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    assert_reports(&stdout, &names);
    assert_rows_match_the_library(&stdout, "models/3rpr.yaml");
}

/// Noise-free simulated measurements written as CSV, identified back from the file: the JSON
/// report holds every parameter with finite values, equal to the model's `simulation.real`.
#[test]
fn simulate_then_identify_from_the_csv_writes_a_complete_json_report() {
    let dir = tempfile::tempdir().expect("temp dir");
    let csv = dir.path().join("m.csv");
    let json = dir.path().join("r.json");
    let (csv_arg, json_arg) = (csv.to_str().unwrap(), json.to_str().unwrap());
    assert_succeeds(&[
        "simulate",
        "--model",
        "models/5r.yaml",
        "--out",
        csv_arg,
        "--noise-scale",
        "0",
    ]);
    let stdout = assert_succeeds(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--measurements",
        csv_arg,
        "--solver",
        "gn",
        "--json",
        json_arg,
    ]);
    assert_reports(&stdout, &PARAMETERS_5R);
    let report_text = std::fs::read_to_string(&json).expect("JSON report written");
    assert!(!report_text.contains("NaN"));
    let report: Value = serde_json::from_str(&report_text).expect("valid JSON");
    let real = [
        0.7507, 1.0995, -0.4988, 0.0028, 1.004, 0.0048, 0.7559, 1.0959, 0.4961, 0.0066, -0.9984,
        3.1418,
    ];
    let results = report["results"].as_array().expect("results");
    assert_eq!(results.len(), 1);
    // The library on the same file: the JSON carries its stds (tiny: the data are noise-free).
    let mech = legwise::model::Mechanism::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/5r.yaml"),
    )
    .unwrap();
    let data = legwise::measure::file::read(&csv, &mech).unwrap();
    let library = legwise::identify::estimate::identify(
        &mech,
        &data,
        legwise::identify::estimate::Strategy::DivideAndConquer,
        legwise::solver::SolverKind::GaussNewton,
    )
    .unwrap();
    let stds: Vec<f64> = library
        .legs
        .iter()
        .flat_map(|l| l.parameters.iter().map(|p| p.std.unwrap()))
        .collect();
    let mut seen = Vec::new();
    for leg in results[0]["legs"].as_array().expect("legs") {
        for p in leg["parameters"].as_array().expect("parameters") {
            let name = p["name"].as_str().expect("name");
            for key in ["nominal", "identified", "std"] {
                assert!(
                    p[key].as_f64().is_some_and(f64::is_finite),
                    "{name}.{key} = {}",
                    p[key]
                );
            }
            let expected = real[PARAMETERS_5R.iter().position(|n| *n == name).unwrap()];
            let identified = p["identified"].as_f64().unwrap();
            let std = p["std"].as_f64().unwrap();
            let library_std = stds[seen.len()];
            assert!(
                std > 0.0 && std < 1e-8 && (std - library_std).abs() <= 1e-9 * library_std,
                "{name}: std {std} vs library {library_std}"
            );
            assert!(
                (identified - expected).abs() < 1e-8,
                "{name}: {identified} vs real {expected}"
            );
            seen.push(name.to_string());
        }
    }
    assert_eq!(seen, PARAMETERS_5R);
}

#[test]
fn workspace_prints_the_5r_miw_and_writes_the_picture() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("miw.svg");
    let stdout = assert_succeeds(&[
        "workspace",
        "--model",
        "models/5r.yaml",
        "--rays",
        "360",
        "--svg",
        svg.to_str().unwrap(),
    ]);
    assert!(
        stdout.contains("centre  x = 0.0000000 m, y = 1.0956"),
        "{stdout}"
    );
    assert!(stdout.contains("radius  0.6456"), "{stdout}");
    let picture = std::fs::read_to_string(&svg).unwrap();
    assert!(
        picture.starts_with("<svg")
            && picture.contains("x (m)")
            && picture.trim_end().ends_with("</svg>")
    );
    // The MIW as drawn, read back through the axes' tick labels: its centre (the cross) and
    // its radius (the dashed circle's extent) in metres, to two pixels.
    let (to_x, to_y) = tick_scales(&picture);
    let pixel = to_x.1.abs().max(to_y.1.abs());
    let black = black_wide_polylines(&picture);
    let cross: Vec<&Vec<(f64, f64)>> = black
        .iter()
        .filter(|p| {
            p.len() == 2
                && (p[0].0 - p[1].0).abs().to_bits() == 12f64.to_bits()
                && p[0].1.to_bits() == p[1].1.to_bits()
        })
        .collect();
    assert_eq!(cross.len(), 1, "one horizontal bar of the centre's cross");
    let centre = (
        to_x.0 + to_x.1 * 0.5 * (cross[0][0].0 + cross[0][1].0),
        to_y.0 + to_y.1 * cross[0][0].1,
    );
    assert!(centre.0.abs() <= 2.0 * pixel, "{centre:?}");
    assert!((centre.1 - 1.0956477).abs() <= 2.0 * pixel, "{centre:?}");
    let dashes: Vec<f64> = black
        .iter()
        .filter(|p| p.len() > 2)
        .flat_map(|p| p.iter().map(|q| q.0))
        .collect();
    let (left, right) = dashes
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
    let radius = 0.5 * (right - left) * to_x.1.abs();
    assert!((radius - 0.6456477).abs() <= 2.0 * pixel, "{radius}");
}

/// The affine maps (value at pixel 0, value per pixel) of a plot's x and y axes, from its
/// numeric tick labels: the y labels are right-aligned (`text-anchor="end"`) at their tick's
/// height, the x labels centred under their tick.
fn tick_scales(svg: &str) -> ((f64, f64), (f64, f64)) {
    let attribute = |tag: &str, name: &str| -> Option<f64> {
        let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
        tag[start..].split('"').next()?.parse().ok()
    };
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    for chunk in svg.split("<text").skip(1) {
        let Some(end) = chunk.find('>') else { continue };
        let tag = &chunk[..end];
        let Some(value) = chunk[end + 1..]
            .split("</text>")
            .next()
            .and_then(|t| t.trim().parse::<f64>().ok())
        else {
            continue;
        };
        if tag.contains("rotate") {
            continue;
        }
        if tag.contains("text-anchor=\"end\"") {
            ys.push((attribute(tag, "y").unwrap(), value));
        } else if tag.contains("text-anchor=\"middle\"") {
            xs.push((attribute(tag, "x").unwrap(), value));
        }
    }
    let fit = |ticks: &[(f64, f64)], axis: &str| {
        assert!(ticks.len() >= 3, "{axis} ticks: {ticks:?}");
        let (first, last) = (ticks[0], ticks[ticks.len() - 1]);
        let per_pixel = (last.1 - first.1) / (last.0 - first.0);
        // Every tick on the same line, to a pixel (plotters rounds positions to pixels).
        for &(at, value) in ticks {
            assert!((first.1 + per_pixel * (at - first.0) - value).abs() <= per_pixel.abs());
        }
        (first.1 - per_pixel * first.0, per_pixel)
    };
    (fit(&xs, "x"), fit(&ys, "y"))
}

/// The points of every black polyline of width 2 (the MIW's dashes and its centre's cross).
fn black_wide_polylines(svg: &str) -> Vec<Vec<(f64, f64)>> {
    svg.split("<polyline")
        .skip(1)
        .filter_map(|chunk| {
            let tag = &chunk[..chunk.find('>')?];
            if !tag.contains("stroke=\"#000000\" stroke-width=\"2\"") {
                return None;
            }
            let start = tag.find("points=\"")? + 8;
            let points = tag[start..].split('"').next()?;
            Some(
                points
                    .split_whitespace()
                    .map(|p| {
                        let (x, y) = p.split_once(',').unwrap();
                        (x.parse().unwrap(), y.parse().unwrap())
                    })
                    .collect(),
            )
        })
        .collect()
}

#[test]
fn select_writes_the_poses_to_measure_with_empty_readings() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("poses.csv");
    let stdout = assert_succeeds(&[
        "select",
        "--model",
        "models/5r.yaml",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(stdout.contains("leg leg1: O1 "), "{stdout}");
    let csv = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows[0], "leg,x,y,A1,A2");
    assert_eq!(rows.len(), 1 + 2 * 18);
    assert!(
        rows[1..].iter().all(|r| r.ends_with(",,")),
        "readings are left empty"
    );
    assert_eq!(rows.iter().filter(|r| r.starts_with("leg2,")).count(), 18);
}

#[test]
fn counts_out_of_range_are_refused_before_any_work() {
    assert_fails_with(
        &[
            "identify",
            "--model",
            "models/5r.yaml",
            "--poses-per-leg",
            "1000000000",
        ],
        "legwise: --poses-per-leg: expected between 1 and 100000, found 1000000000",
    );
    assert_fails_with(
        &[
            "select",
            "--model",
            "models/5r.yaml",
            "--out",
            "unused.csv",
            "--poses-per-leg",
            "0",
        ],
        "legwise: --poses-per-leg: expected between 1 and 100000, found 0",
    );
    assert_fails_with(
        &["workspace", "--model", "models/5r.yaml", "--rays", "8"],
        "legwise: --rays: expected between 16 and 100000, found 8",
    );
}

/// The first line of every command's terminal report names the command, the mechanism and its
/// model file.
#[test]
fn each_report_starts_with_the_command_the_mechanism_and_the_model_file() {
    let name = "planar 3-RPR parallel mechanism";
    for (args, command) in [
        (&["identify", "--model", "models/3rpr.yaml"][..], "identify"),
        (
            &["select", "--model", "models/3rpr.yaml", "--out", "-"][..],
            "select",
        ),
        (
            &["workspace", "--model", "models/3rpr.yaml", "--out", "-"][..],
            "workspace",
        ),
    ] {
        let out = legwise(args);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{args:?}: {}",
            text(&out.stderr)
        );
        // `--out -` writes the poses or the picture on standard output, the report on standard
        // error.
        let report = if command == "identify" {
            text(&out.stdout)
        } else {
            String::from_utf8_lossy(&out.stderr).into_owned()
        };
        let first = report.lines().next().unwrap_or_default();
        assert_eq!(
            first,
            format!("legwise {command}: {name} (models/3rpr.yaml)"),
            "{args:?}"
        );
    }
}

/// `--weights` reaches the fit: `none` is the unweighted fit, `noise` and the default (the 5R
/// declares its noise) the weighted one; the JSON says which, and the estimates differ.
#[test]
fn the_weights_option_chooses_the_fit() {
    let run = |extra: &[&str]| -> Value {
        let mut args = vec!["identify", "--model", "models/5r.yaml", "--json", "-"];
        args.extend(extra);
        let out = legwise(&args);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{extra:?}: {}",
            text(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let first = |json: &Value| json["results"][0]["legs"][0]["parameters"][0]["identified"].clone();
    let (default, noise, none) = (
        run(&[]),
        run(&["--weights", "noise"]),
        run(&["--weights", "none"]),
    );
    for (json, expected) in [(&default, "noise"), (&noise, "noise"), (&none, "none")] {
        assert_eq!(json["results"][0]["weights"], expected);
    }
    assert_eq!(first(&default), first(&noise));
    assert_ne!(first(&default), first(&none));
}

/// A leg without a noise test says why: the run scaled the declared noise to zero, or the model
/// declares none.
#[test]
fn a_missing_noise_test_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let quiet = dir.path().join("quiet.yaml");
    let model = std::fs::read_to_string(crate::support::crate_path("models/5r.yaml")).unwrap();
    let line = model.lines().find(|l| l.starts_with("noise:")).unwrap();
    std::fs::write(&quiet, model.replace(line, "")).unwrap();
    std::fs::copy(
        crate::support::crate_path("models/5r.urdf"),
        dir.path().join("5r.urdf"),
    )
    .unwrap();
    for (model, extra, reason) in [
        (
            "models/5r.yaml",
            "0",
            "the declared noise is scaled to zero by --noise-scale 0",
        ),
        (
            quiet.to_str().unwrap(),
            "1",
            "the model declares no `noise:` block",
        ),
    ] {
        let out = legwise(&["identify", "--model", model, "--noise-scale", extra]);
        assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
        let expected = format!("  noise test: not done ({reason})");
        assert_eq!(
            text(&out.stdout).matches(&expected).count(),
            2,
            "{}",
            text(&out.stdout)
        );
    }
}

/// The closing line names the JSON file it wrote, and is not printed when the JSON went to
/// standard output (the report then goes to standard error, and says nothing of itself).
#[test]
fn the_json_s_destination_is_said_only_for_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("r.json");
    let out = legwise(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--json",
        file.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let said = format!("\nJSON report written to {}\n", file.display());
    assert!(text(&out.stdout).ends_with(&said), "{}", text(&out.stdout));
    let out = legwise(&["identify", "--model", "models/5r.yaml", "--json", "-"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(
        !text(&out.stderr).contains("written to"),
        "{}",
        text(&out.stderr)
    );
}
