//! Factor sets (`quantities:`, derived parameters, `factor_sets:`, `legwise sets`): a
//! firmware's own factors fitted on its own touches recover the printer behind them; the
//! model's own set is the default fit; a printer inside a set is recovered exactly at zero
//! noise; bad quantities, expressions and sets are refused naming the field.
use std::path::Path;

use legwise::identify::factor_set::{fit_factor_set, model_sets, FactorSetFit};
use legwise::pipeline::identify_one;
use legwise::printer::delta_model::{printer_files, DeltaGeometry, ModelOptions, Touch};
use legwise::printer::klipper::{KlipperConfig, KlipperDelta};
use legwise::{FitOptions, Measurements, Mechanism, SolverKind, Strategy};

use crate::cli::{legwise_succeeds, text};

const CFG: &str = "tests/data/klipper/printer.cfg";

/// The printer behind tests/data/klipper/printer.cfg's touches (make_printer_cfg.py): mm, deg.
const REAL_RADIUS: f64 = 175.15;
const REAL_ANGLES: [f64; 3] = [210.25, 329.8, 90.0];
const REAL_ENDSTOPS: [f64; 3] = [297.36, 296.93, 297.10];

/// Writes the model of `delta` into `dir` and loads it with its probe file.
pub(crate) fn model_of(dir: &Path, delta: &DeltaGeometry, noise: f64) -> (Mechanism, Measurements) {
    let options = ModelOptions {
        probe_noise: noise,
        ..ModelOptions::firmware_factors()
    };
    let files = printer_files(delta, &options, "printer.urdf");
    std::fs::write(dir.join("printer.yaml"), &files.yaml).unwrap();
    std::fs::write(dir.join("printer.urdf"), &files.urdf).unwrap();
    std::fs::write(dir.join("probe.csv"), &files.csv).unwrap();
    let mechanism = Mechanism::load(&dir.join("printer.yaml")).unwrap();
    let data = Measurements::read(&dir.join("probe.csv"), &mechanism).unwrap();
    (mechanism, data)
}

/// The Klipper printer.cfg's geometry (SAVE_CONFIG over the sections) and its touches.
fn klipper_cfg() -> DeltaGeometry {
    let config = KlipperConfig::read(Path::new(CFG)).unwrap();
    KlipperDelta::from_config(&config).unwrap().geometry()
}

fn fitted(mechanism: &Mechanism, data: &Measurements, name: &str) -> FactorSetFit {
    let sets = model_sets(mechanism);
    let set = sets.iter().find(|s| s.name == name).expect("the set");
    fit_factor_set(mechanism, data, set).unwrap()
}

fn factor(fit: &FactorSetFit, name: &str) -> f64 {
    fit.factors
        .iter()
        .find(|f| f.name == name)
        .expect(name)
        .estimate
}

/// Klipper's DELTA_CALIBRATE fits six factors on seven touches. The printer.cfg's touches were
/// made by a printer inside those six (its SAVE_CONFIG is the geometry before calibration):
/// fitted in Klipper's own terms, the six come back to Klipper's step rounding (0.001 step of
/// 0.0125 mm), angle c held at its 90°.
#[test]
fn klippers_six_factors_on_its_touches_are_the_printer_behind_them() {
    let dir = tempfile::tempdir().unwrap();
    let (mechanism, data) = model_of(dir.path(), &klipper_cfg(), 1e-5);
    let fit = fitted(&mechanism, &data, "klipper-6");
    assert_eq!((fit.rows, fit.degrees_of_freedom), (7, 1));
    // A height's variance is the probe's whatever the factors: one weighted solve.
    assert_eq!(fit.weightings, 1);
    assert_eq!(fit.observability.rank, 6);
    assert!(
        (factor(&fit, "radius") * 1e3 - REAL_RADIUS).abs() < 1e-4,
        "{fit:?}"
    );
    for (k, tower) in ["a", "b"].iter().enumerate() {
        let angle = factor(&fit, &format!("angle_{tower}")).to_degrees();
        assert!((angle - REAL_ANGLES[k]).abs() < 1e-4, "{tower}: {angle}");
    }
    for (k, tower) in ["a", "b", "c"].iter().enumerate() {
        let endstop = factor(&fit, &format!("endstop_{tower}")) * 1e3;
        assert!(
            (endstop - REAL_ENDSTOPS[k]).abs() < 1e-4,
            "{tower}: {endstop}"
        );
    }
    // The residual is the step rounding's, far below the declared 10 µm.
    assert!(fit.rms < 1e-6, "{}", fit.rms);
    // σ from the declared noise: every factor's is finite and positive.
    assert!(fit
        .factors
        .iter()
        .all(|f| f.sigma > 0.0 && f.sigma.is_finite()));
}

/// A real printer: an FLSUN QQ-S whose SAVE_CONFIG block (tests/data/klipper/flsun_qqs.cfg,
/// from a public NixOS configuration) holds the values Klipper's DELTA_CALIBRATE computed from
/// the seven stable positions saved beside them. Klipper's six factors fitted by legwise on
/// those positions, from those values, stay at them to 1e-4 mm and 1e-4° (Klipper writes six
/// decimals and stops at its own tolerance); the rods are the file's 280 mm.
#[test]
fn a_real_save_config_is_klippers_six_factors_on_its_own_touches() {
    let dir = tempfile::tempdir().unwrap();
    let config = KlipperConfig::read(Path::new("tests/data/klipper/flsun_qqs.cfg")).unwrap();
    let delta = KlipperDelta::from_config(&config).unwrap().geometry();
    let (mechanism, data) = model_of(dir.path(), &delta, 1e-5);
    let fit = fitted(&mechanism, &data, "klipper-6");
    assert_eq!((fit.rows, fit.observability.rank), (7, 6));
    let saved_angles = [210.181908, 329.784204];
    let saved_endstops = [372.971746, 373.433577, 373.629930];
    let radius = factor(&fit, "radius") * 1e3;
    assert!((radius - 141.553523).abs() < 1e-4, "radius {radius} mm");
    for (k, tower) in ["a", "b"].iter().enumerate() {
        let angle = factor(&fit, &format!("angle_{tower}")).to_degrees();
        assert!((angle - saved_angles[k]).abs() < 1e-4, "{tower}: {angle}°");
    }
    for (k, tower) in ["a", "b", "c"].iter().enumerate() {
        let endstop = factor(&fit, &format!("endstop_{tower}")) * 1e3;
        assert!(
            (endstop - saved_endstops[k]).abs() < 1e-4,
            "{tower}: {endstop} mm"
        );
    }
    // A real probe on a real printer: the residual (72 µm RMS) is far above the declared
    // 10 µm, and the fit says so.
    assert!(
        fit.rms > 5e-5 && fit.scale() > 10.0,
        "{} {}",
        fit.rms,
        fit.scale()
    );
}

/// The model's own set through the change of unknowns (the identity here) is the default
/// joint fit: the same estimates and the same σ (the pipeline's covariance is its own code).
#[test]
fn the_model_set_is_the_default_fit() {
    let dir = tempfile::tempdir().unwrap();
    let (mechanism, data) = model_of(dir.path(), &klipper_cfg(), 1e-5);
    let fit = fitted(&mechanism, &data, "model");
    let result = identify_one(
        &mechanism,
        &data,
        Strategy::Joint,
        SolverKind::LevenbergMarquardt,
        FitOptions::default(),
    )
    .unwrap();
    assert_eq!(fit.factors.len(), 6);
    for f in &fit.factors {
        let p = result
            .parameters()
            .find(|p| p.name == f.name)
            .expect("the same name");
        assert!(
            (f.estimate - p.estimate).abs() < 1e-10,
            "{}: {} vs {}",
            f.name,
            f.estimate,
            p.estimate
        );
        let std = p.std.expect("a σ");
        assert!(
            (f.sigma / std - 1.0).abs() < 1e-6,
            "{}: {} vs {std}",
            f.name,
            f.sigma
        );
    }
}

/// Touches made by a printer whose geometry differs from the model's only in Klipper's six
/// factors, without rounding: the six are recovered to round-off, whichever way the towers
/// and endstops were off.
#[test]
fn a_printer_inside_the_set_is_recovered_exactly_at_zero_noise() {
    let nominal = DeltaGeometry {
        touches: Vec::new(),
        distances: Vec::new(),
        ..klipper_cfg()
    };
    let real = DeltaGeometry {
        radius: nominal.radius + 0.83,
        angles: [
            nominal.angles[0] - 0.4,
            nominal.angles[1] + 0.27,
            nominal.angles[2],
        ],
        endstops: [
            nominal.endstops[0] + 0.61,
            nominal.endstops[1] - 0.35,
            nominal.endstops[2] + 0.12,
        ],
        ..nominal.clone()
    };
    let touch_height = nominal.z_offset.unwrap_or(0.0);
    let mut touches = Vec::new();
    for (k, (r, a)) in [
        (0.0, 0.0),
        (45.0, 30.0),
        (45.0, 150.0),
        (45.0, 270.0),
        (80.0, 90.0),
        (80.0, 210.0),
        (80.0, 330.0),
        (70.0, 10.0),
    ]
    .iter()
    .enumerate()
    {
        let a = f64::to_radians(*a);
        let p = [r * a.cos(), r * a.sin(), touch_height];
        touches.push(Touch {
            id: format!("t{k}"),
            height_mm: touch_height,
            readings_mm: real.readings_at(p).unwrap(),
        });
    }
    let dir = tempfile::tempdir().unwrap();
    let (mechanism, data) = model_of(dir.path(), &DeltaGeometry { touches, ..nominal }, 1e-5);
    let fit = fitted(&mechanism, &data, "klipper-6");
    assert!(fit.rms < 1e-12, "{}", fit.rms);
    assert!((factor(&fit, "radius") - real.radius * 1e-3).abs() < 1e-11);
    for (k, t) in ["a", "b", "c"].iter().enumerate() {
        let e = factor(&fit, &format!("endstop_{t}"));
        assert!((e - real.endstops[k] * 1e-3).abs() < 1e-11, "{t}");
        if k < 2 {
            let angle = factor(&fit, &format!("angle_{t}"));
            assert!((angle - real.angles[k].to_radians()).abs() < 1e-10, "{t}");
        }
    }
}

/// The nozzle position (mm) where `delta`'s carriages read `readings` (mm): Newton on the
/// firmware's inverse kinematics, from above the bed's centre.
fn nozzle_at(delta: &DeltaGeometry, readings: [f64; 3]) -> [f64; 3] {
    let mut p = [0.0, 0.0, 0.0];
    for _ in 0..50 {
        let f = |p: [f64; 3]| {
            let r = delta.readings_at(p).unwrap();
            [r[0] - readings[0], r[1] - readings[1], r[2] - readings[2]]
        };
        let r = f(p);
        let h = 1e-6;
        let j = nalgebra::Matrix3::from_fn(|i, k| {
            let (mut up, mut down) = (p, p);
            up[k] += h;
            down[k] -= h;
            (f(up)[i] - f(down)[i]) / (2.0 * h)
        });
        let step = j.lu().solve(&nalgebra::Vector3::from(r)).unwrap();
        for k in 0..3 {
            p[k] -= step[k];
        }
    }
    p
}

/// The leave-one-out error against refits: eleven touches of a printer inside Klipper's six
/// factors, heights off by a few µm; each touch left out, the six refitted on the others
/// (through legwise), the left-out touch's height predicted by an independent forward
/// kinematics of the refitted geometry. The closed form `r_i / (1 − h_ii)` is first order:
/// it agrees with the refits to 1e-3.
#[test]
fn the_leave_one_out_error_is_the_refits() {
    let nominal = DeltaGeometry {
        touches: Vec::new(),
        distances: Vec::new(),
        ..klipper_cfg()
    };
    let real = DeltaGeometry {
        radius: nominal.radius - 0.4,
        endstops: [
            nominal.endstops[0] + 0.3,
            nominal.endstops[1],
            nominal.endstops[2] - 0.2,
        ],
        ..nominal.clone()
    };
    let height = nominal.z_offset.unwrap_or(0.0);
    let errors = [3.0, -5.0, 2.0, 7.0, -4.0, 1.0, -6.0, 4.0, -2.0, 5.0, -3.0];
    let touches: Vec<Touch> = errors
        .iter()
        .enumerate()
        .map(|(k, e)| {
            let (r, a) = (75.0 * (k % 4) as f64 / 3.0, (k as f64 * 137.5).to_radians());
            Touch {
                id: format!("t{k}"),
                height_mm: height + e * 1e-3,
                readings_mm: real
                    .readings_at([r * a.cos(), r * a.sin(), height])
                    .unwrap(),
            }
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let all = DeltaGeometry {
        touches: touches.clone(),
        ..nominal.clone()
    };
    let (mechanism, data) = model_of(dir.path(), &all, 1e-5);
    let fit = fitted(&mechanism, &data, "klipper-6");
    let closed = fit.leave_one_out.expect("every touch has room");
    let mut sum = 0.0;
    for left in 0..touches.len() {
        let mut others = touches.clone();
        let out = others.remove(left);
        let (mechanism, data) = model_of(
            dir.path(),
            &DeltaGeometry {
                touches: others,
                ..nominal.clone()
            },
            1e-5,
        );
        let refit = fitted(&mechanism, &data, "klipper-6");
        let mut refitted = nominal.clone();
        refitted.radius = factor(&refit, "radius") * 1e3;
        refitted.angles[0] = factor(&refit, "angle_a").to_degrees();
        refitted.angles[1] = factor(&refit, "angle_b").to_degrees();
        for (k, t) in ["a", "b", "c"].iter().enumerate() {
            refitted.endstops[k] = factor(&refit, &format!("endstop_{t}")) * 1e3;
        }
        let predicted = nozzle_at(&refitted, out.readings_mm)[2];
        sum += ((predicted - out.height_mm) * 1e-3).powi(2);
    }
    let refits = (sum / touches.len() as f64).sqrt();
    // Every touch has the probe's σ (10 µm): χ² = m (RMS / σ)², the scale √(χ² / dof), the
    // criterion χ² + 2 × 6.
    let m = touches.len() as f64;
    let chi_square = m * (fit.rms / 1e-5).powi(2);
    assert_eq!(fit.degrees_of_freedom, touches.len() - 6);
    assert!(
        (fit.scale() / (chi_square / (m - 6.0)).sqrt() - 1.0).abs() < 1e-9,
        "{}",
        fit.scale()
    );
    assert!(
        (fit.information - (chi_square + 12.0)).abs() < 1e-9 * chi_square,
        "{}",
        fit.information
    );
    // Corrected for the few rows: + 2 × 6 × 7 / (m − 7).
    let corrected = chi_square + 12.0 + 84.0 / (m - 7.0);
    assert!(
        (fit.information_corrected - corrected).abs() < 1e-9 * corrected,
        "{}",
        fit.information_corrected
    );
    assert!((closed / refits - 1.0).abs() < 1e-3, "{closed} vs {refits}");
    assert!(closed > fit.rms, "{closed} vs {}", fit.rms);
}

/// `legwise sets` on an imported printer: the model's row and Klipper's two sets, each
/// factor with its σ; nine factors on heights alone cannot see scale.
#[test]
fn sets_prints_the_table_of_an_imported_printer() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    legwise_succeeds(&["printer", "import", "--klipper", CFG, "--out", d]);
    let model = format!("{d}/printer.yaml");
    let csv = format!("{d}/probe.csv");
    let json = format!("{d}/sets.json");
    let out = legwise_succeeds(&[
        "sets",
        "--model",
        &model,
        "--measurements",
        &csv,
        "--json",
        &json,
    ]);
    let stdout = text(&out.stdout);
    for row in [
        "model ",
        "klipper-6 ",
        "klipper-9 ",
        "DELTA_CALIBRATE",
        "endstop_a",
    ] {
        assert!(stdout.contains(row), "{row}: {stdout}");
    }
    let value: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let sets = value.as_array().unwrap();
    assert_eq!(sets.len(), 3);
    assert_eq!(sets[1]["name"], "klipper-6");
    assert_eq!(sets[1]["rank"], 6);
    // Seven touches cannot hold nine factors: every one of the seven heights is used, two
    // directions are left, and no σ is claimed.
    assert_eq!(sets[2]["rank"], 7, "{}", sets[2]);
    assert_eq!(sets[2]["unidentifiable"].as_array().unwrap().len(), 2);
    assert!(sets[2]["factors"]
        .as_array()
        .unwrap()
        .iter()
        .all(|f| f["sigma"].is_null()));
    // The calibrated model states its geometry in legwise's terms: the firmware's quantities
    // no longer describe it and go, with the sets in them; it loads. (A 1 µm probe: the fit
    // is trusted, so the calibrated model is written.)
    legwise_succeeds(&[
        "printer",
        "import",
        "--klipper",
        CFG,
        "--out",
        d,
        "--probe-noise",
        "1e-6",
    ]);
    let cal = format!("{d}/cal.yaml");
    let out = crate::cli::legwise(&[
        "identify",
        "--model",
        &model,
        "--measurements",
        &csv,
        "--calibrated",
        &cal,
    ]);
    assert!(std::path::Path::new(&cal).exists(), "{}", text(&out.stderr));
    let written = std::fs::read_to_string(&cal).unwrap();
    assert!(
        !written.contains("quantities") && !written.contains("factor_sets"),
        "{written}"
    );
    Mechanism::load(Path::new(&cal)).expect("the calibrated model loads");
}

/// A copy of delta-probe.yaml with `quantities` and `factor_sets` blocks and `edit` applied
/// to its text; the load's error message.
fn load_error(extra: &str, edit: impl Fn(String) -> String) -> String {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string("models/delta-probe.yaml").unwrap();
    std::fs::copy("models/delta.urdf", dir.path().join("delta.urdf")).unwrap();
    let path = dir.path().join("copy.yaml");
    // The model's own `factor_sets` block gives way to the test's.
    let block = text
        .find("factor_sets:")
        .expect("delta-probe.yaml has sets");
    let end = block + text[block..].find("\n\n").expect("a blank line after them");
    let text = format!("{}{}", &text[..block], &text[end..]);
    std::fs::write(&path, edit(text) + extra).unwrap();
    match Mechanism::load(&path) {
        Ok(_) => "loaded".to_string(),
        Err(e) => e.to_string(),
    }
}

const QUANTITIES: &str = "
quantities:
  - {name: rod, value: 0.3, unit: m}
  - {name: ring, value: 0.175, unit: m}
";

/// An edit of a model file's text.
type Edit = Box<dyn Fn(String) -> String>;

#[test]
fn bad_quantities_expressions_and_sets_name_the_field() {
    let with = |parameter: &str, value: &str| {
        let parameter = parameter.to_string();
        let value = value.to_string();
        move |text: String| {
            text.replace(
                &format!("{{name: {parameter}, "),
                &format!("{{name: {parameter}, value: \"{value}\", "),
            )
        }
    };
    // Well formed: one rod for three legs, loads.
    let shared = |t: String| with("L1", "rod")(with("L2", "rod")(with("L3", "rod")(t)));
    assert_eq!(load_error(QUANTITIES, shared), "loaded");
    let set = "factor_sets:\n  - {name: one-rod, fit: [rod, h0_1]}\n";
    let shared = |t: String| with("L1", "rod")(with("L2", "rod")(t));
    assert_eq!(load_error(&format!("{QUANTITIES}{set}"), shared), "loaded");
    let cases: Vec<(String, Edit, &str)> = vec![
        (QUANTITIES.into(), Box::new(with("L1", "rod * 2")), "`parameters[2].value`: `rod * 2` is 0.6 at the quantities' values, but `L1` is 0.3"),
        (QUANTITIES.into(), Box::new(with("L1", "rod +")), "`parameters[2].value`: `rod +`: at character 6: expected a number, a name or `(`, found the end"),
        (QUANTITIES.into(), Box::new(with("L1", "rods")), "`rods` is not a quantity; expected one of rod, ring"),
        ("\nquantities:\n  - {name: rod, value: 0.3, unit: mm}\n".into(), Box::new(|t| t), "`quantities[0].unit`: `mm` is not one of m, rad, 1"),
        ("\nquantities:\n  - {name: L1, value: 0.3, unit: m}\n".into(), Box::new(|t| t), "`quantities[0].name`: `L1` is already the name of a quantity or a parameter"),
        ("\nquantities:\n  - {name: 2rod, value: 0.3, unit: m}\n".into(), Box::new(|t| t), "`quantities[0].name`: `2rod` cannot be written in an expression"),
        (format!("{QUANTITIES}factor_sets:\n  - {{name: s, fit: [rod, L1]}}\n"), Box::new(with("L1", "rod")), "`factor_sets[0].fit[1]`: `L1` follows `rod`, which the set fits too"),
        (format!("{QUANTITIES}factor_sets:\n  - {{name: s, fit: [rods]}}\n"), Box::new(|t| t), "`factor_sets[0].fit[0]`: `rods` is no quantity, parameter or instrument parameter"),
        (format!("{QUANTITIES}factor_sets:\n  - {{name: s, fit: [rod, rod]}}\n"), Box::new(|t| t), "`factor_sets[0].fit[1]`: `rod` is listed twice"),
        (format!("{QUANTITIES}factor_sets:\n  - {{name: s, fit: []}}\n"), Box::new(|t| t), "`factor_sets[0].fit`: expected at least one"),
    ];
    for (extra, edit, expected) in cases {
        let message = load_error(&extra, edit);
        assert!(
            message.contains(expected),
            "expected `{expected}` in: {message}"
        );
        assert!(message.contains("copy.yaml"), "{message}");
    }
}

#[test]
fn the_import_identifies_rods_and_gains_on_their_priors_where_the_firmware_takes_them() {
    let rows = |delta: &DeltaGeometry, options: &ModelOptions| -> Vec<String> {
        let yaml = printer_files(delta, options, "printer.urdf").yaml;
        yaml.lines()
            .filter(|l| l.contains("{name: L1,") || l.contains("{name: k1,"))
            .map(str::to_string)
            .collect()
    };
    let klipper = klipper_cfg();
    assert!(klipper.steps_known);
    assert_eq!(
        rows(&klipper, &ModelOptions::default()),
        [
            "  - {name: L1, joint: R1, origin: x, prior: 0.0002, value: \"arm_a\"}",
            "  - {name: k1, leg: leg1, actuator: gain, prior: 0.001}"
        ]
    );
    // Step settings unknown (an M92 missing): the gains are held, the rods still on priors.
    let unknown = DeltaGeometry {
        steps_known: false,
        ..klipper.clone()
    };
    let held = rows(&unknown, &ModelOptions::default());
    assert_eq!(
        held[1],
        "  - {name: k1, leg: leg1, actuator: gain, identify: false}"
    );
    // A prior of 0 holds the factor: the firmware's own six.
    let six = rows(&klipper, &ModelOptions::firmware_factors());
    assert_eq!(
        six,
        [
            "  - {name: L1, joint: R1, origin: x, identify: false, value: \"arm_a\"}",
            "  - {name: k1, leg: leg1, actuator: gain, identify: false}"
        ]
    );
    // The identification on the priors: the data's rows and one prior row for each rod and
    // gain.
    let dir = tempfile::tempdir().unwrap();
    let files = printer_files(&klipper, &ModelOptions::default(), "printer.urdf");
    std::fs::write(dir.path().join("printer.yaml"), &files.yaml).unwrap();
    std::fs::write(dir.path().join("printer.urdf"), &files.urdf).unwrap();
    let mechanism = Mechanism::load(&dir.path().join("printer.yaml")).unwrap();
    let priors: Vec<&str> = mechanism
        .legs
        .iter()
        .flat_map(|l| &l.params)
        .filter(|p| p.prior.is_some() && p.identified)
        .map(|p| p.name.as_str())
        .collect();
    assert_eq!(priors, ["L1", "k1", "L2", "k2", "L3", "k3"]);
}
