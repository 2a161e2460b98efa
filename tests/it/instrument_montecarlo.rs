//! `legwise montecarlo` on a model with an instrument block: each trial draws the real legs and
//! the real instrument frame and target offsets, simulates what the instrument reports, and
//! identifies jointly and in two stages. Bit-identical for a seed whatever the thread count;
//! every statistic recomputed here from the per-trial values; at zero noise the joint
//! identification recovers every trial's own draw.
use serde_json::Value;

use crate::montecarlo::{assert_estimate, montecarlo_json, t_interval, CHI2_5, TRIALS};

/// A per-trial array of numbers, `None` for `null` (a σ the fit did not give).
fn optional_numbers(value: &Value) -> Vec<Option<f64>> {
    value
        .as_array()
        .expect("an array")
        .iter()
        .map(Value::as_f64)
        .collect()
}

#[test]
fn one_and_two_threads_agree_and_every_statistic_follows_from_the_trials() {
    let model = "models/5r-tracker.yaml";
    let one = montecarlo_json(model, 1, &[]);
    let two = montecarlo_json(model, 2, &[]);
    assert!(
        one == two,
        "the JSON reports differ between 1 and 2 threads"
    );
    let report: Value = serde_json::from_str(&one).unwrap();
    assert_eq!(report["failed"], 0);
    let names: Vec<&str> = report["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    // The identified frame first, then the legs' identified parameters (model order).
    assert_eq!(
        names,
        [
            "frame_x",
            "frame_y",
            "frame_yaw",
            "l1",
            "L1",
            "k1",
            "gamma1",
            "l2",
            "L2",
            "A2x",
            "k2",
            "gamma2"
        ]
    );
    let trials = report["per_trial"].as_array().unwrap();
    assert_eq!(trials.len(), TRIALS);
    let arms: Vec<&str> = report["arms"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["arm"].as_str().unwrap())
        .collect();
    assert_eq!(arms, ["joint", "two_stage"]);
    let per_trial = |arm: &str, key: &str, p: usize| -> Vec<Option<f64>> {
        trials
            .iter()
            .map(|t| optional_numbers(&t["arms"][arm][key])[p])
            .collect()
    };
    for arm in report["arms"].as_array().unwrap() {
        let key = arm["arm"].as_str().unwrap();
        assert_eq!(
            arm["poses"], 36,
            "both arms measure the 18 poses of each leg"
        );
        for (p, stats) in arm["parameters"].as_array().unwrap().iter().enumerate() {
            let what = format!("{key} {}", names[p]);
            let errors: Vec<f64> = per_trial(key, "errors", p)
                .into_iter()
                .map(|e| e.expect("an error"))
                .collect();
            assert_estimate(
                &stats["mean_error"],
                t_interval(&errors),
                &format!("{what} mean"),
            );
            let (m, _, _) = t_interval(&errors);
            let ss = errors.iter().map(|e| (e - m) * (e - m)).sum::<f64>();
            let std = (
                (ss / 5.0).sqrt(),
                (ss / CHI2_5.1).sqrt(),
                (ss / CHI2_5.0).sqrt(),
            );
            assert_estimate(&stats["std_error"], std, &format!("{what} std"));
            let squares: Vec<f64> = errors.iter().map(|e| e * e).collect();
            let (ms, lo, hi) = t_interval(&squares);
            // The low end is the square root of a difference (mean square minus half-width):
            // compared on the scale of the mean square, as the printed quantile has 7 digits.
            let reported = &stats["rms_error"];
            let value = reported["value"].as_f64().unwrap();
            let ends = optional_numbers(&reported["ci95"]);
            let (low, high) = (ends[0].unwrap(), ends[1].unwrap());
            assert!((value - ms.sqrt()).abs() <= 1e-9 * ms.sqrt(), "{what} RMS");
            assert!(
                (high - hi.sqrt()).abs() <= 1e-6 * hi.sqrt(),
                "{what} RMS high"
            );
            assert!(
                (low * low - lo.max(0.0)).abs() <= 1e-6 * ms,
                "{what} RMS low"
            );
            // Every fit gives every identified parameter a σ, the two-stage registration too.
            let predicted: Vec<f64> = per_trial(key, "predicted_std", p)
                .into_iter()
                .map(|s| s.unwrap())
                .collect();
            assert!(predicted.iter().all(|s| *s > 0.0), "{what}");
            assert_estimate(&stats["predicted_std"], t_interval(&predicted), &what);
        }
        let map: Vec<f64> = trials
            .iter()
            .map(|t| t["arms"][key]["map_rms_m"].as_f64().unwrap())
            .collect();
        assert_estimate(&arm["map_rms_m"], t_interval(&map), &format!("{key} map"));
    }
    let map = |arm: &str| -> Vec<f64> {
        trials
            .iter()
            .map(|t| t["arms"][arm]["map_rms_m"].as_f64().unwrap())
            .collect()
    };
    let comparisons = report["comparisons"].as_array().unwrap();
    assert_eq!(comparisons.len(), 1);
    let comparison = &comparisons[0];
    assert_eq!(
        (&comparison["first"], &comparison["second"]),
        (&Value::from("joint"), &Value::from("two_stage"))
    );
    let differences: Vec<f64> = map("joint")
        .iter()
        .zip(map("two_stage"))
        .map(|(a, b)| a - b)
        .collect();
    let (_, lo, hi) = t_interval(&differences);
    assert_estimate(
        &comparison["map_rms_difference_m"],
        t_interval(&differences),
        "difference",
    );
    let sentence = comparison["sentence"].as_str().unwrap();
    let expected = if hi < 0.0 {
        "joint is more accurate than two-stage"
    } else if lo > 0.0 {
        "Two-stage is more accurate than joint"
    } else {
        "No significant difference between joint and two-stage"
    };
    assert!(
        sentence.starts_with(expected),
        "{sentence} for [{lo}, {hi}]"
    );
    assert_eq!(report["verdict"], comparison["sentence"]);
    // The trials draw the frame anew; the legs' real values are the model's own.
    let real = |p: usize| -> Vec<f64> {
        trials
            .iter()
            .map(|t| t["real"][p].as_f64().unwrap())
            .collect()
    };
    let frame_x = real(0);
    assert!(
        frame_x.windows(2).all(|w| (w[0] - w[1]).abs() > 1e-6),
        "{frame_x:?}"
    );
    assert!(real(3).iter().all(|&l1| (l1 - 0.7507).abs() < 1e-15));
}

#[test]
fn without_noise_the_joint_identification_recovers_each_trials_own_draw() {
    let report: Value = serde_json::from_str(&montecarlo_json(
        "models/3rpr-tracker.yaml",
        2,
        &["--noise-scale", "0"],
    ))
    .unwrap();
    assert_eq!(report["failed"], 0);
    let trials = report["per_trial"].as_array().unwrap();
    let names = report["parameters"].as_array().unwrap();
    assert_eq!(
        names.len(),
        6 + 12,
        "frame, targets and the legs' identified ones"
    );
    let nominal: Vec<f64> = trials
        .iter()
        .map(|t| t["nominal_map_rms_m"].as_f64().unwrap())
        .collect();
    assert!(
        nominal.windows(2).all(|w| (w[0] - w[1]).abs() > 1e-9),
        "a new real mechanism per trial: {nominal:?}"
    );
    let mut reals = Vec::new();
    for trial in trials {
        let joint = &trial["arms"]["joint"];
        for (p, e) in optional_numbers(&joint["errors"]).iter().enumerate() {
            let e = e.unwrap();
            assert!(e.abs() < 1e-9, "{}: error {e}", names[p]["name"]);
        }
        let map = joint["map_rms_m"].as_f64().unwrap();
        assert!(map < 1e-9, "joint map RMS {map}");
        reals.push(trial["real"][0].as_f64().unwrap());
    }
    assert!(
        reals.windows(2).all(|w| (w[0] - w[1]).abs() > 1e-6)
            && reals.iter().all(|x| (x - 1.5).abs() > 1e-6),
        "frame_x drawn per trial: {reals:?}"
    );
    // The two-stage registration with the nominal legs is biased even without noise.
    let two_stage = optional_numbers(&trials[0]["arms"]["two_stage"]["errors"]);
    assert!(two_stage[0].unwrap().abs() > 1e-6, "{two_stage:?}");
    assert!(report["verdict"]
        .as_str()
        .unwrap()
        .starts_with("joint is more accurate than two-stage"));
}

#[test]
fn the_pictures_show_both_arms() {
    let directory = tempfile::tempdir().unwrap();
    let out = crate::cli::legwise(&[
        "montecarlo",
        "--model",
        "models/5r-tracker.yaml",
        "--trials",
        "3",
        "--map",
        "0.2",
        "--plots",
        directory.path().to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        crate::cli::text(&out.stderr)
    );
    let svg = std::fs::read_to_string(directory.path().join("montecarlo-errors.svg")).unwrap();
    let texts = crate::support::svg_texts(&svg);
    let labels = [
        "joint",
        "two-stage",
        "frame_x error (mm)",
        "l1 error (mm)",
        "fraction of trials",
    ];
    for label in labels {
        assert!(texts.iter().any(|t| t == label), "{label}: {texts:?}");
    }
}
