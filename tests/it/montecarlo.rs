//! `legwise montecarlo`: bit-identical for a seed whatever the thread count; every reported
//! statistic recomputed here from the per-trial values of the JSON report with textbook
//! quantiles; the interval formulas on a known case; zero noise gives zero errors.
use std::process::Command;

use legwise::study::stats::{mean_interval, rms_interval, std_interval};
use serde_json::Value;

use crate::cli::{assert_fails_with, text};

/// Trials of the quick studies (with the printed quantiles below for n − 1 = 5).
pub(crate) const TRIALS: usize = 6;
/// Student's t 0.975 quantile, 5 degrees of freedom (printed tables).
pub(crate) const T_5: f64 = 2.570_582;
/// χ² quantiles 0.025 and 0.975, 5 degrees of freedom.
pub(crate) const CHI2_5: (f64, f64) = (0.831_211_6, 12.832_502);

/// Runs `legwise montecarlo` with `threads` rayon threads and returns its JSON (standard
/// output) as text.
pub(crate) fn montecarlo_json(model: &str, threads: usize, extra: &[&str]) -> String {
    let trials = TRIALS.to_string();
    let mut args = vec![
        "montecarlo",
        "--model",
        model,
        "--trials",
        &trials,
        "--map",
        "0.2",
        "--json",
        "-",
    ];
    args.extend(extra);
    let out = Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(&args)
        .env("RAYON_NUM_THREADS", threads.to_string())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the legwise binary runs");
    assert_eq!(
        out.status.code(),
        Some(0),
        "{args:?}: {}",
        text(&out.stderr)
    );
    text(&out.stdout)
}

pub(crate) fn numbers(value: &Value) -> Vec<f64> {
    value
        .as_array()
        .expect("an array")
        .iter()
        .map(|v| v.as_f64().expect("a number"))
        .collect()
}

/// `(value, low, high)` of an estimate in the report.
pub(crate) fn estimate(value: &Value) -> (f64, f64, f64) {
    let ci = numbers(&value["ci95"]);
    (value["value"].as_f64().expect("value"), ci[0], ci[1])
}

pub(crate) fn close(a: f64, b: f64, what: &str) {
    assert!(
        (a - b).abs() <= 1e-6 * b.abs() + 1e-18,
        "{what}: reported {a}, recomputed {b}"
    );
}

pub(crate) fn assert_estimate(reported: &Value, recomputed: (f64, f64, f64), what: &str) {
    let (v, l, h) = estimate(reported);
    close(v, recomputed.0, &format!("{what} value"));
    close(l, recomputed.1, &format!("{what} low"));
    close(h, recomputed.2, &format!("{what} high"));
}

/// Mean with its t interval, computed here with the printed quantile.
pub(crate) fn t_interval(x: &[f64]) -> (f64, f64, f64) {
    assert_eq!(x.len(), TRIALS);
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let s = (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0)).sqrt();
    let half = T_5 * s / n.sqrt();
    (m, m - half, m + half)
}

/// The fraction `k / n` with its 95 % Wilson score interval, computed here with the printed
/// normal quantile.
fn wilson(k: u64, n: u64) -> (f64, f64, f64) {
    let z: f64 = 1.959_963_984_540_054;
    let (k, n) = (k as f64, n as f64);
    let p = k / n;
    let centre = (p + z * z / (2.0 * n)) / (1.0 + z * z / n);
    let half = z / (1.0 + z * z / n) * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt();
    (p, centre - half, centre + half)
}

#[test]
fn one_and_two_threads_give_identical_reports_and_every_statistic_follows_from_the_trials() {
    let one = montecarlo_json("models/5r.yaml", 1, &[]);
    let two = montecarlo_json("models/5r.yaml", 2, &[]);
    assert!(
        one == two,
        "the JSON reports differ between 1 and 2 threads"
    );
    let report: Value = serde_json::from_str(&one).expect("JSON");
    assert_eq!(report["failed"], 0);
    let trials = report["per_trial"].as_array().expect("per_trial");
    assert_eq!(trials.len(), TRIALS);
    let seeds: std::collections::BTreeSet<u64> =
        trials.iter().map(|t| t["seed"].as_u64().unwrap()).collect();
    assert_eq!(seeds.len(), TRIALS, "every trial draws from its own seed");
    let per_trial = |arm: &str, key: &str, p: Option<usize>| -> Vec<f64> {
        trials
            .iter()
            .map(|t| {
                let v = &t["arms"][arm][key];
                match p {
                    Some(p) => v[p].as_f64().expect("number"),
                    None => v.as_f64().expect("number"),
                }
            })
            .collect()
    };
    let names = report["parameters"].as_array().unwrap();
    assert_eq!(names.len(), 12);
    for arm in report["arms"].as_array().unwrap() {
        let key = arm["arm"].as_str().unwrap();
        for (p, stats) in arm["parameters"].as_array().unwrap().iter().enumerate() {
            let what = format!("{key} {}", names[p]["name"]);
            let errors = per_trial(key, "errors", Some(p));
            assert_estimate(
                &stats["mean_error"],
                t_interval(&errors),
                &format!("{what} mean"),
            );
            let (m, _, _) = t_interval(&errors);
            let ss = errors.iter().map(|e| (e - m) * (e - m)).sum::<f64>();
            let s = (ss / 5.0).sqrt();
            let std = (s, (ss / CHI2_5.1).sqrt(), (ss / CHI2_5.0).sqrt());
            assert_estimate(&stats["std_error"], std, &format!("{what} std"));
            // The RMS interval is the square root of the mean square's t interval: compared
            // as squares, since near zero a root magnifies the printed quantile's rounding.
            let squares: Vec<f64> = errors.iter().map(|e| e * e).collect();
            let (ms, lo, hi) = t_interval(&squares);
            let (v, l, h) = estimate(&stats["rms_error"]);
            close(v * v, ms, &format!("{what} RMS² value"));
            assert!(
                (l * l - lo.max(0.0)).abs() <= 1e-6 * ms,
                "{what} RMS low {l} for {lo}"
            );
            close(h * h, hi, &format!("{what} RMS² high"));
            let predicted = per_trial(key, "predicted_std", Some(p));
            assert!(predicted.iter().all(|s| *s > 0.0), "{what}: a σ per fit");
            assert_estimate(&stats["predicted_std"], t_interval(&predicted), &what);
        }
        let map = per_trial(key, "map_rms_m", None);
        assert_estimate(&arm["map_rms_m"], t_interval(&map), &format!("{key} map"));
        // The checks of bad data: every leg fit of every trial tested (two legs with
        // redundancy), the counts summed over the trials, the fractions' Wilson intervals.
        let count = |field: &str| -> Vec<u64> {
            trials
                .iter()
                .map(|t| t["arms"][key]["alarms"][field].as_u64().expect("a count"))
                .collect()
        };
        assert!(count("outlier_tests").iter().all(|&c| c == 2), "{key}");
        assert!(count("noise_tests").iter().all(|&c| c == 2), "{key}");
        let alarms = &arm["alarms"];
        for (tests, fired, fraction) in [
            ("outlier_tests", "flagged", "flagged_fraction"),
            ("noise_tests", "rejected", "rejected_fraction"),
        ] {
            let (n, k) = (
                count(tests).iter().sum::<u64>(),
                count(fired).iter().sum::<u64>(),
            );
            assert_eq!(alarms[tests].as_u64(), Some(n), "{key} {tests}");
            assert_eq!(alarms[fired].as_u64(), Some(k), "{key} {fired}");
            // Fractions: to round-off (a bound at 0 may be computed as 3e-17).
            let (v, l, h) = estimate(&alarms[fraction]);
            let (rv, rl, rh) = wilson(k, n);
            for (reported, recomputed) in [(v, rv), (l, rl), (h, rh)] {
                assert!(
                    (reported - recomputed).abs() <= 1e-12,
                    "{key} {fraction}: {reported} against {recomputed}"
                );
            }
        }
    }
    let dc = per_trial("divide_and_conquer", "map_rms_m", None);
    for comparison in report["comparisons"].as_array().unwrap() {
        let other = per_trial(comparison["second"].as_str().unwrap(), "map_rms_m", None);
        let differences: Vec<f64> = dc.iter().zip(&other).map(|(a, b)| a - b).collect();
        let (d, lo, hi) = t_interval(&differences);
        assert_estimate(
            &comparison["map_rms_difference_m"],
            (d, lo, hi),
            "difference",
        );
        // The sentence follows from the interval.
        let sentence = comparison["sentence"].as_str().unwrap();
        let expected = if hi < 0.0 {
            "D&C is more accurate"
        } else if lo > 0.0 {
            "is more accurate than D&C"
        } else {
            "No significant difference"
        };
        assert!(sentence.contains(expected), "{sentence} for [{lo}, {hi}]");
    }
    assert_eq!(report["verdict"], report["comparisons"][1]["sentence"]);
    assert!(report["verdict"]
        .as_str()
        .unwrap()
        .contains("an equal number of poses"));
}

#[test]
fn the_interval_formulas_match_a_worked_example() {
    // 1..5: mean 3, s² = 2.5; t(0.975, 4) = 2.776445, χ²(4) quantiles 0.484419 and 11.143287.
    let x = [1.0, 2.0, 3.0, 4.0, 5.0];
    let m = mean_interval(&x);
    let half = 2.776_445 * (2.5f64 / 5.0).sqrt();
    assert!((m.value - 3.0).abs() < 1e-12);
    assert!((m.low - (3.0 - half)).abs() < 1e-5 && (m.high - (3.0 + half)).abs() < 1e-5);
    let s = std_interval(&x);
    assert!((s.value - 2.5f64.sqrt()).abs() < 1e-12);
    assert!((s.low - (10.0f64 / 11.143_287).sqrt()).abs() < 1e-5);
    assert!((s.high - (10.0f64 / 0.484_419).sqrt()).abs() < 1e-5);
    // RMS of 1..5 is √11; its interval is that of the mean of the squares 1, 4, 9, 16, 25.
    let r = rms_interval(&x);
    let squares = [1.0, 4.0, 9.0, 16.0, 25.0];
    let var = squares
        .iter()
        .map(|v: &f64| (v - 11.0).powi(2))
        .sum::<f64>()
        / 4.0;
    let half = 2.776_445 * (var / 5.0).sqrt();
    assert!((r.value - 11.0f64.sqrt()).abs() < 1e-12);
    assert!(
        half > 11.0,
        "this sample's interval of the mean square reaches below zero"
    );
    assert!(r.low.abs() < 1e-15, "clamped at zero: {}", r.low);
    assert!((r.high - (11.0 + half).sqrt()).abs() < 1e-5);
}

#[test]
fn without_noise_every_error_is_zero_though_the_real_mechanism_changes_between_trials() {
    // The 3-RPR draws its real parameters from its perturbation: each trial's nominal map error
    // differs, and every strategy still recovers them exactly.
    let report: Value = serde_json::from_str(&montecarlo_json(
        "models/3rpr.yaml",
        2,
        &["--noise-scale", "0"],
    ))
    .expect("JSON");
    let trials = report["per_trial"].as_array().unwrap();
    let nominal: Vec<f64> = trials
        .iter()
        .map(|t| t["nominal_map_rms_m"].as_f64().unwrap())
        .collect();
    assert!(nominal.iter().all(|&e| e > 1e-4), "{nominal:?}");
    assert!(
        nominal.windows(2).all(|w| (w[0] - w[1]).abs() > 1e-9),
        "a new real mechanism per trial: {nominal:?}"
    );
    for trial in trials {
        for (arm, values) in trial["arms"].as_object().unwrap() {
            for e in numbers(&values["errors"]) {
                assert!(e.abs() < 1e-10, "{arm}: error {e}");
            }
            let map = values["map_rms_m"].as_f64().unwrap();
            assert!(map < 1e-10, "{arm}: map RMS {map}");
        }
    }
    assert!(report["verdict"]
        .as_str()
        .unwrap()
        .starts_with("No significant difference"));
}

#[test]
fn bad_input_exits_2_and_names_the_option() {
    assert_fails_with(
        &["montecarlo", "--model", "models/5r.yaml", "--trials", "1"],
        "legwise: --trials: expected between 2 and 1000000, found 1",
    );
    assert_fails_with(
        &[
            "montecarlo",
            "--model",
            "models/5r.yaml",
            "--trials",
            "3",
            "--map",
            "0",
        ],
        "legwise: --map: expected a positive grid spacing in metres, found 0",
    );
    let out = crate::cli::legwise(&[
        "montecarlo",
        "--model",
        "models/5r.yaml",
        "--trials",
        "3",
        "--json",
        "models/5r.yaml",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("would overwrite the model file"));
}

/// A JSON estimate in metres as the terminal prints map errors: millimetres, four decimals.
fn printed_mm(estimate: &Value) -> String {
    let number = |v: &Value| {
        v.as_f64()
            .map_or("-".to_string(), |v| format!("{:.4}", v * 1e3))
    };
    format!(
        "{} [{}, {}]",
        number(&estimate["value"]),
        number(&estimate["ci95"][0]),
        number(&estimate["ci95"][1])
    )
}

/// `value [low, high]` of a JSON estimate times `factor`, as the terminal prints it (three
/// significant digits; a missing bound as `-`).
fn printed(estimate: &Value, factor: f64) -> String {
    let number = |v: &Value| {
        v.as_f64()
            .map_or("-".to_string(), |v| format!("{:.3e}", v * factor))
    };
    format!(
        "{} [{}, {}]",
        number(&estimate["value"]),
        number(&estimate["ci95"][0]),
        number(&estimate["ci95"][1])
    )
}

/// The study on the terminal (with the JSON in a file) prints the JSON's numbers: every arm's
/// line per parameter (mean, std, RMS and predicted σ of its errors), the map's RMS errors in
/// millimetres, the paired differences and the verdict.
#[test]
fn the_terminal_study_prints_the_numbers_of_its_json_report() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("study.json");
    let trials = TRIALS.to_string();
    let out = Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args([
            "montecarlo",
            "--model",
            "models/5r.yaml",
            "--trials",
            &trials,
            "--map",
            "0.2",
            "--json",
            json.to_str().unwrap(),
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the legwise binary runs");
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let report: Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).expect("JSON");
    let seed = report["seed"].as_u64().unwrap();
    assert!(
        stdout.contains(&format!("{TRIALS} trials (0 failed), seed {seed}")),
        "{stdout}"
    );
    for arm in report["arms"].as_array().unwrap() {
        let name = arm["name"].as_str().unwrap();
        for parameter in arm["parameters"].as_array().unwrap() {
            let ratio = parameter["std_error"]["value"].as_f64().unwrap()
                / parameter["predicted_std"]["value"].as_f64().unwrap();
            let line = format!(
                "    {name:<26} mean {}  std {}  RMS {}  predicted σ {}  std/σ {ratio:.3}\n",
                printed(&parameter["mean_error"], 1.0),
                printed(&parameter["std_error"], 1.0),
                printed(&parameter["rms_error"], 1.0),
                printed(&parameter["predicted_std"], 1.0)
            );
            assert!(stdout.contains(&line), "`{line}` missing from\n{stdout}");
        }
        let map = format!("    {name:<26} {}\n", printed_mm(&arm["map_rms_m"]));
        assert!(stdout.contains(&map), "`{map}` missing from\n{stdout}");
        let alarms = &arm["alarms"];
        let percent = |fired: &str, tests: &str, fraction: &str| {
            let e = &alarms[fraction];
            format!(
                "{:.2} % [{:.2}, {:.2}] ({} of {})",
                100.0 * e["value"].as_f64().unwrap(),
                100.0 * e["ci95"][0].as_f64().unwrap(),
                100.0 * e["ci95"][1].as_f64().unwrap(),
                alarms[fired],
                alarms[tests]
            )
        };
        let checks = format!(
            "    {name:<26} leg fits flagging a row {}; noise tests rejecting the declared noise \
             {}\n",
            percent("flagged", "outlier_tests", "flagged_fraction"),
            percent("rejected", "noise_tests", "rejected_fraction")
        );
        assert!(
            stdout.contains(&checks),
            "`{checks}` missing from\n{stdout}"
        );
    }
    let nominal = format!(
        "    {:<26} {}\n",
        "nominal model",
        printed_mm(&report["nominal_map_rms_m"])
    );
    assert!(stdout.contains(&nominal), "`{nominal}` missing");
    let comparisons = report["comparisons"].as_array().unwrap();
    assert!(!comparisons.is_empty());
    for c in comparisons {
        let difference = format!("{} mm\n", printed_mm(&c["map_rms_difference_m"]));
        assert!(stdout.contains(&difference), "`{difference}` missing");
    }
    let verdict = report["verdict"].as_str().unwrap();
    assert!(
        stdout.contains(&format!("\nverdict: {verdict}\n")),
        "{stdout}"
    );
}

/// The study's fits are told the declared noise times `noise_scale` (their fit options carry
/// the scale, never the model), every coordinate and the readings alike; the study's mechanism
/// and the bundled model's own noise are left as declared.
#[test]
fn the_study_scales_the_declared_noise_by_the_noise_scale() {
    use legwise::study::montecarlo::{MonteCarloOptions, Study};
    let mechanism = crate::support::bundled("5r.yaml");
    let declared = mechanism.noise.expect("the 5R declares its noise");
    for scale in [0.0, 0.5, 3.0] {
        let options = MonteCarloOptions {
            noise_scale: scale,
            map_grid: 0.2,
            ..MonteCarloOptions::new(TRIALS, 1)
        };
        let study = Study::prepare(&mechanism, options).unwrap();
        let fit = study.fit_options();
        assert_eq!(fit.noise_scale.to_bits(), scale.to_bits(), "scale {scale}");
        assert_eq!(study.mechanism().noise, Some(declared), "scale {scale}");
        match fit.expected_noise(study.mechanism()) {
            // All zero: no noise expected.
            None => assert_eq!(scale.to_bits(), 0f64.to_bits()),
            Some(noise) => {
                for (c, (&s, &d)) in noise.pose.iter().zip(&declared.pose).enumerate() {
                    assert_eq!(
                        s.to_bits(),
                        (d * scale).to_bits(),
                        "scale {scale}, coordinate {c}"
                    );
                }
                assert_eq!(
                    noise.reading.to_bits(),
                    (declared.reading * scale).to_bits()
                );
            }
        }
    }
    assert_eq!(mechanism.noise, Some(declared));
}

/// Failed trials: the first five are listed with their reason, then one line counts them all
/// when there are more; the statistics leave them out and the run exits 3. A 3-RPR whose real
/// mechanism is drawn 0.3 m / 0.3 rad / 0.3 away from the nominal one fails 7 of 12 trials
/// (8 when its legs took the generic chain's Newton from the nominal home joints, which lands
/// on the other working mode at some of the simulated poses that the closed form reaches on
/// the home one).
#[test]
fn failed_trials_are_listed_five_at_most_then_counted() {
    let dir = tempfile::tempdir().unwrap();
    let original = std::fs::read_to_string(crate::support::crate_path("models/3rpr.yaml")).unwrap();
    let wild = original.replace(
        "perturbation: {length: 0.002, angle: 0.002, gain: 0.002}",
        "perturbation: {length: 0.3, angle: 0.3, gain: 0.3}",
    );
    assert_ne!(wild, original);
    let model = dir.path().join("wild.yaml");
    std::fs::write(&model, wild).unwrap();
    std::fs::copy(
        crate::support::crate_path("models/3rpr.urdf"),
        dir.path().join("3rpr.urdf"),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args([
            "montecarlo",
            "--model",
            model.to_str().unwrap(),
            "--trials",
            "12",
        ])
        .output()
        .unwrap();
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert_eq!(
        stderr.matches("failed and is left out").count(),
        5,
        "{stderr}"
    );
    assert!(
        stderr.contains("legwise: warning: 7 of 12 trials failed in all"),
        "{stderr}"
    );
}

/// What the study counts of a fit's checks of bad data, on the bundled 5R's fixtures read as
/// `legwise identify` reads them: a clean file (nothing fires), a reading 0.1 rad off (leg1
/// flags it and rejects the noise) and readings in degrees (both legs reject the noise, no row
/// stands out).
#[test]
fn the_study_counts_the_fits_outlier_flags_and_noise_rejections() {
    use legwise::study::montecarlo::Alarms;
    use legwise::{identify, Measurements, Settings};
    let mechanism = crate::support::bundled("5r.yaml");
    for (file, flagged, rejected) in [("clean", 0, 0), ("outlier", 1, 1), ("degrees", 0, 2)] {
        let path = crate::support::crate_path(&format!("tests/data/stats_5r_{file}.csv"));
        let data = Measurements::read(&path, &mechanism).unwrap();
        let report = identify(&mechanism, &data, &Settings::default()).unwrap();
        let alarms = Alarms::of(&report.results[0]);
        assert_eq!(
            alarms,
            Alarms {
                outlier_tests: 2,
                flagged,
                noise_tests: 2,
                rejected,
                ..Alarms::default()
            },
            "{file}"
        );
    }
    // Summed over trials field by field.
    let one = Alarms {
        outlier_tests: 2,
        flagged: 1,
        noise_tests: 3,
        rejected: 1,
        tolerance_tests: 2,
        above_tolerance: 0,
    };
    let other = Alarms {
        outlier_tests: 5,
        flagged: 2,
        noise_tests: 7,
        rejected: 3,
        tolerance_tests: 4,
        above_tolerance: 1,
    };
    let sum = Alarms {
        outlier_tests: 7,
        flagged: 3,
        noise_tests: 10,
        rejected: 4,
        tolerance_tests: 6,
        above_tolerance: 1,
    };
    assert_eq!(one + other, sum);
}

/// A forward model's fits are held to its tolerance, and the study counts how often the
/// predicted σ exceeded it: never at the bundled tolerance, every time at a nanometre.
#[test]
fn the_study_counts_the_fits_above_the_models_tolerance() {
    use legwise::study::montecarlo::Alarms;
    use legwise::{run, Settings};
    let probe = crate::support::bundled("delta-probe.yaml");
    for (tolerance, above) in [(1e-4, 0), (1e-9, 1)] {
        let held = probe.edited(|parts| {
            parts.instrument.as_mut().expect("a bed").tolerance = Some(tolerance);
        });
        let report = run(&held, &Settings::default()).unwrap();
        let alarms = Alarms::of(&report.results[0]);
        assert_eq!(alarms.tolerance_tests, 1, "{tolerance}");
        assert_eq!(alarms.above_tolerance, above, "{tolerance}");
    }
    // Without a tolerance nothing is tested.
    let free = probe.edited(|parts| parts.instrument.as_mut().expect("a bed").tolerance = None);
    let report = run(&free, &Settings::default()).unwrap();
    assert_eq!(Alarms::of(&report.results[0]).tolerance_tests, 0);
}

/// `--poses FILE` measures a forward model at given commanded poses in every trial (a
/// firmware's seven probe points), and is refused with a clear message elsewhere.
#[test]
fn a_forward_study_runs_at_the_commanded_poses_of_a_file() {
    use crate::cli::{assert_fails_with, legwise, text};
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("firmware7.csv");
    let mut csv = String::from("id,pose.x,pose.y,pose.z\nc,0.0,0.0,0.05\n");
    for (k, degrees) in [30.0_f64, 90.0, 150.0, 210.0, 270.0, 330.0]
        .iter()
        .enumerate()
    {
        let (s, c) = degrees.to_radians().sin_cos();
        csv.push_str(&format!("p{k},{},{},0.05\n", 0.064 * c, 0.064 * s));
    }
    std::fs::write(&points, csv).unwrap();
    let file = points.to_str().unwrap();
    let out = legwise(&[
        "montecarlo",
        "--model",
        "models/delta-probe.yaml",
        "--trials",
        "3",
        "--poses",
        file,
    ]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(stdout.contains("poses measured: joint 7"), "{stdout}");
    assert!(
        stdout.contains("predicted σ above the model's tolerance"),
        "{stdout}"
    );
    // Not a forward model.
    let model = crate::support::crate_path("models/5r.yaml");
    let out = legwise(&[
        "montecarlo",
        "--model",
        "models/5r.yaml",
        "--trials",
        "3",
        "--poses",
        file,
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains(
            "commanded poses (--poses FILE) are for a model seen through the forward kinematics"
        ),
        "{} ({})",
        text(&out.stderr),
        model.display()
    );
    // A cell that is not a number: its line and column.
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "pose.x,pose.y,pose.z\n0.0,0.0,0.05\n0.01,abc,0.05\n").unwrap();
    let bad = bad.to_str().unwrap();
    assert_fails_with(
        &[
            "montecarlo",
            "--model",
            "models/delta-probe.yaml",
            "--trials",
            "3",
            "--poses",
            bad,
        ],
        &format!(
            "legwise: {bad}: line 3, column `pose.y`: expected a number (m or rad), found \"abc\""
        ),
    );
}
