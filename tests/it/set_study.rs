//! `legwise sets --trials`: the factor-set choice checked on simulated experiments. Each set's
//! true error is recomputed with the closed-form 5R (its inverse kinematics commanding, the
//! real mechanism's forward kinematics moving) over the study's map; the summary from the
//! outcomes; and the command's report.

use legwise::identify::factor_set::{fit_factor_set, model_sets};
use legwise::measure::simulate::SimulationOptions;
use legwise::model::with_values::with_values;
use legwise::pipeline::{simulate, PoseSource, SimulationSettings};
use legwise::study::montecarlo::trial_seed;
use legwise::study::set_study::{set_study, MAP_GRID, MAP_SCALE};

use crate::accuracy_map::{five_bar_fk, five_bar_ik};
use crate::cli::{legwise_succeeds, text};
use crate::support::bundled;

/// On the 5R's own sets (models/5r.yaml: all twelve, and three that hold some), every true
/// error a trial reports is the closed-form RMS of the real 5R's position error over the map
/// when the set's fitted model commands it, to 1e-9 relative; each standardized error is the
/// factor's error over its σ; the model's own set, unbiased, is recommended and best.
#[test]
fn each_sets_true_error_is_the_closed_form_5r_commanded_by_its_fit() {
    let mechanism = bundled("5r.yaml");
    let (trials, seed) = (3, 9);
    let result = set_study(&mechanism, trials, seed).unwrap();
    let map = legwise::evaluate::accuracy::map_grid(&mechanism, MAP_GRID, MAP_SCALE).unwrap();
    assert_eq!(result.map_points, map.len());
    for trial in &result.trials {
        assert_eq!(trial.seed, trial_seed(seed, trial.index));
        let settings = SimulationSettings {
            options: SimulationOptions {
                seed: Some(trial.seed),
                ..Default::default()
            },
            poses: PoseSource::Selected,
            grid: None,
        };
        let simulated = simulate(&mechanism, &settings).unwrap();
        let real = &simulated.real.legs;
        let outcomes = trial.outcome.as_ref().unwrap();
        let sets = model_sets(&mechanism);
        assert_eq!(outcomes.len(), sets.len());
        for (set, outcome) in sets.iter().zip(outcomes) {
            let fit = fit_factor_set(&mechanism, &simulated.measurements, set).unwrap();
            let values: Vec<(String, f64)> = fit
                .factors
                .iter()
                .map(|f| (f.name.clone(), f.estimate))
                .collect();
            let commanding = with_values(&mechanism, &values)
                .unwrap()
                .nominal_parameters();
            let errors: Vec<f64> = map
                .iter()
                .filter_map(|pose| {
                    let readings = five_bar_ik(&commanding, pose[0], pose[1])?;
                    let reached = five_bar_fk(real, readings)?;
                    Some((reached[0] - pose[0]).hypot(reached[1] - pose[1]))
                })
                .collect();
            let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
            let reported = outcome.true_error_m.unwrap();
            assert!(
                (reported / rms - 1.0).abs() < 1e-9,
                "{}: reported {reported}, closed form {rms}",
                set.name
            );
            assert_eq!(outcome.standardized_errors.len(), fit.factors.len());
            let names: Vec<&str> = mechanism
                .legs
                .iter()
                .flat_map(|l| &l.params)
                .map(|p| p.name.as_str())
                .collect();
            let truth: Vec<f64> = real.iter().flatten().copied().collect();
            for ((name, z), f) in outcome.standardized_errors.iter().zip(&fit.factors) {
                let k = names.iter().position(|n| n == name).unwrap();
                let expected = (f.estimate - truth[k]) / f.sigma;
                assert!(
                    (z - expected).abs() < 1e-9 * expected.abs().max(1.0),
                    "{name}"
                );
            }
        }
    }
    let choice = result.choice().unwrap();
    assert_eq!(choice.best_set, "model");
    assert_eq!(choice.sets[0].recommended, trials);
    assert!((choice.ratio - 1.0).abs() < 1e-15);
}

/// The command prints every set's median true error and the ratio, and refuses --trials with
/// --measurements.
#[test]
fn the_command_reports_the_choice_over_the_trials() {
    let out = legwise_succeeds(&["sets", "--model", "models/5r.yaml", "--trials", "4"]);
    let report = text(&out.stdout);
    for needle in [
        "4 simulated experiments",
        "no-gains",
        "links-offsets",
        "the best candidate in hindsight (`model`)",
    ] {
        assert!(report.contains(needle), "{needle}: {report}");
    }
    crate::cli::assert_fails_with(
        &["sets", "--model", "models/5r.yaml", "--trials", "0"],
        "legwise: --trials: expected between 1 and 100000, found 0",
    );
}
