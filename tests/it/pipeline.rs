//! The library's one entry point: the model chooses the pipeline, the settings are data (the
//! noise scale never written into the mechanism), and what a pipeline does not offer is
//! refused with a message naming it.
use legwise::measure::observations::Observations;
use legwise::measure::{MeasurementSet, Measurements, STDIN_NAME};
use legwise::pipeline::{identify_one, simulate, MapSettings};
use legwise::{identify, run, FitOptions, Settings, SolverKind, Strategy};

use crate::support::{bundled, crate_path};

/// A noise-free simulation of the model's default experiment.
fn quiet() -> Settings {
    let mut settings = Settings::default();
    settings.simulation.options.noise_scale = 0.0;
    settings
}

#[test]
fn the_model_chooses_the_pipeline_and_its_default_strategies() {
    let plain = bundled("5r.yaml");
    let tracker = bundled("5r-tracker.yaml");
    let report = run(&plain, &quiet()).unwrap();
    let strategies: Vec<Strategy> = report.results.iter().map(|r| r.strategy).collect();
    assert_eq!(strategies, [Strategy::DivideAndConquer]);
    assert!(report.results[0].instrument.is_none());
    let report = run(&tracker, &quiet()).unwrap();
    let strategies: Vec<Strategy> = report.results.iter().map(|r| r.strategy).collect();
    assert_eq!(strategies, [Strategy::Joint, Strategy::TwoStage]);
    assert!(report.results.iter().all(|r| r.instrument.is_some()));
    assert!(matches!(report.measurements, Measurements::Targets(_)));
    // At zero noise the joint fit recovers every leg parameter the simulation perturbed.
    let real = report.real.as_ref().unwrap();
    for leg in &report.results[0].legs {
        let l = tracker.leg_index(&leg.leg).unwrap();
        for (p, &value) in leg.parameters.iter().zip(&real.legs[l]) {
            assert!(
                (p.estimate - value).abs() < 1e-9,
                "{}: {} vs {value}",
                p.name,
                p.estimate
            );
        }
    }
}

#[test]
fn a_joint_result_splits_into_leg_blocks_that_add_up_to_the_fit() {
    let tracker = bundled("5r-tracker.yaml");
    let report = run(&tracker, &Settings::default()).unwrap();
    for result in &report.results {
        let instrument = result.instrument.as_ref().unwrap();
        let rows: usize = result.legs.iter().map(|l| l.measurements).sum();
        assert_eq!(rows, instrument.rows);
        let [run] = result.runs.as_slice() else {
            panic!("one run of all legs: {:?}", result.runs);
        };
        assert_eq!(run.legs.len(), result.legs.len());
        let cost: f64 = result.legs.iter().map(|l| l.final_cost).sum();
        assert!((cost - run.final_cost).abs() <= 1e-12 * run.final_cost);
        let before: f64 = result.legs.iter().map(|l| l.initial_cost).sum();
        assert!((before - run.initial_cost).abs() <= 1e-12 * run.initial_cost);
        // ½‖r‖² over the rows, and the RMS of the same residuals.
        let squares: f64 = result
            .legs
            .iter()
            .flat_map(|l| &l.residuals)
            .map(|r| r.residual * r.residual)
            .sum();
        assert!((0.5 * squares - run.final_cost).abs() <= 1e-12 * run.final_cost);
        let rms = (squares / instrument.rows as f64).sqrt();
        assert!((rms - instrument.rms).abs() <= 1e-12 * rms);
    }
    // The verdict judges the joint result only: the two-stage result's misfit (its frame
    // registered from 6 rows per leg) rejects the declared noise without making the run
    // untrusted.
    let two_stage = report.results[1].instrument.as_ref().unwrap();
    assert!(two_stage.noise_test.as_ref().unwrap().rejected);
    assert!(report.trusted(), "{:?}", report.trust_issues());
}

#[test]
fn the_noise_scale_is_the_fits_data_not_the_mechanisms() {
    let plain = bundled("5r.yaml");
    let declared = *plain.noise.as_ref().unwrap();
    let mut settings = Settings::default();
    settings.simulation.options.noise_scale = 3.0;
    let report = run(&plain, &settings).unwrap();
    assert_eq!(
        report.results[0].options.noise_scale.to_bits(),
        3.0f64.to_bits()
    );
    let expected = report.results[0].options.expected_noise(&plain).unwrap();
    assert_eq!(
        expected.reading.to_bits(),
        (3.0 * declared.reading).to_bits()
    );
    assert_eq!(
        plain.noise.unwrap().reading.to_bits(),
        declared.reading.to_bits()
    );
    // Given measurements, the fit expects the noise as declared.
    let data = report.measurements.clone();
    let given = identify(&plain, &data, &Settings::default()).unwrap();
    assert_eq!(
        given.results[0].options.noise_scale.to_bits(),
        1.0f64.to_bits()
    );
}

#[test]
fn what_a_pipeline_does_not_offer_is_refused_by_name() {
    let plain = bundled("5r.yaml");
    let tracker = bundled("5r-tracker.yaml");
    let simulated = simulate(&plain, &quiet().simulation).unwrap();
    let settings = Settings {
        map: Some(MapSettings {
            grid_m: 0.02,
            scale: 0.95,
        }),
        ..Settings::default()
    };
    let error = identify(&plain, &simulated.measurements, &settings).unwrap_err();
    assert_eq!(
        error.to_string(),
        "the accuracy map needs the real parameters, known only in simulation"
    );
    // Platform poses for a model measured through an instrument, and the reverse.
    let poses = Measurements::Readings(MeasurementSet::new(None, 2));
    let fit = FitOptions::default();
    let lm = SolverKind::LevenbergMarquardt;
    let error = identify_one(&tracker, &poses, Strategy::Joint, lm, fit).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("its measurements are the targets' coordinates"),
        "{error}"
    );
    let targets = simulate(&tracker, &quiet().simulation)
        .unwrap()
        .measurements;
    let gn = SolverKind::GaussNewton;
    let error = identify_one(&tracker, &targets, Strategy::Joint, gn, fit).unwrap_err();
    assert!(error.to_string().contains("not by Gauss-Newton"), "{error}");
    let error = identify_one(&tracker, &targets, Strategy::DivideAndConquer, lm, fit).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("identified through it (joint or two-stage)"),
        "{error}"
    );
    let error =
        identify_one(&plain, &simulated.measurements, Strategy::Joint, lm, fit).unwrap_err();
    assert!(
        error.to_string().contains("needs an `instrument` block"),
        "{error}"
    );
    let empty = Measurements::Targets(Observations::default());
    assert!(identify_one(&tracker, &empty, Strategy::Joint, lm, fit).is_err());
}

#[test]
fn measurements_read_by_the_models_layout_say_where_they_came_from() {
    let plain = bundled("5r.yaml");
    let path = crate_path("examples/data/5r.csv");
    let data = Measurements::read(&path, &plain).unwrap();
    assert!(matches!(data, Measurements::Readings(_)));
    assert_eq!(data.origin(), Some(path.display().to_string()));
    assert_eq!(data.rows(), 54);
    let text = std::fs::read(&path).unwrap();
    let stdin = Measurements::read_from(text.as_slice(), STDIN_NAME.as_ref(), &plain).unwrap();
    assert_eq!(stdin.origin().as_deref(), Some("standard input"));
    assert_eq!(stdin.to_csv(&plain).unwrap(), data.to_csv(&plain).unwrap());
    let tracker = bundled("5r-tracker.yaml");
    let path = crate_path("examples/data/5r-tracker.csv");
    let data = Measurements::read(&path, &tracker).unwrap();
    assert!(matches!(data, Measurements::Targets(_)));
    assert!(data.poses().is_none());
    assert_eq!(data.rows(), 54);
    assert_eq!(
        data.to_csv(&tracker).unwrap(),
        std::fs::read_to_string(&path).unwrap()
    );
}

/// Readings ten times noisier than the model declares: the χ² test rejects the declared noise,
/// so the report must not be trusted (the command line exits 3), and says why.
#[test]
fn a_report_whose_residuals_reject_the_declared_noise_is_not_trusted() {
    let plain = bundled("5r.yaml");
    let mut noisy = quiet().simulation;
    noisy.options.noise_scale = 10.0;
    let data = simulate(&plain, &noisy).unwrap().measurements;
    let report = identify(&plain, &data, &Settings::default()).unwrap();
    let issues = report.trust_issues();
    assert!(!report.trusted());
    assert!(!issues.is_empty());
    assert!(
        issues
            .iter()
            .all(|i| i.contains("reject the declared noise")),
        "{issues:?}"
    );
    // The same data identified expecting ten times the declared noise is trusted.
    let mut expecting = Settings::default();
    expecting.fit.noise_scale = 10.0;
    let report = identify(&plain, &data, &expecting).unwrap();
    assert!(report.trusted(), "{:?}", report.trust_issues());
}

/// A result's parameters: the instrument's block first (through an instrument), then each
/// identified leg's, every parameter once, in model order.
#[test]
fn a_results_parameters_are_the_instruments_then_each_legs() {
    for model in ["5r.yaml", "5r-tracker.yaml"] {
        let mechanism = bundled(model);
        let report = run(&mechanism, &quiet()).unwrap();
        let result = &report.results[0];
        let names: Vec<&str> = result.parameters().map(|p| p.name.as_str()).collect();
        let mut expected: Vec<&str> = Vec::new();
        if let Some(instrument) = &mechanism.instrument {
            expected.extend(instrument.parameters.iter().map(|p| p.name.as_str()));
        }
        for leg in mechanism.legs.iter() {
            expected.extend(leg.params.iter().map(|p| p.name.as_str()));
        }
        assert_eq!(names, expected, "{model}");
    }
}

/// The calibrated model says which strategy it holds when several ran, and only then: the
/// tracker model runs two (joint, two-stage), the plain 5R one.
#[test]
fn the_calibrated_header_names_the_strategy_only_when_several_ran() {
    let note =
        "Several strategies ran; this is the joint (legs and instrument, Schur complement) result.";
    let (tracker_model, plain_model) = (bundled("5r-tracker.yaml"), bundled("5r.yaml"));
    let tracker = run(&tracker_model, &quiet()).unwrap();
    assert_eq!(tracker.results.len(), 2);
    let files = tracker.calibrated_files("5r.urdf").unwrap().unwrap();
    assert!(files.yaml.contains(note), "{}", files.yaml);
    let plain = run(&plain_model, &quiet()).unwrap();
    assert_eq!(plain.results.len(), 1);
    let files = plain.calibrated_files("5r.urdf").unwrap().unwrap();
    assert!(
        !files.yaml.contains("Several strategies ran"),
        "{}",
        files.yaml
    );
    assert!(files.yaml.contains("5r.urdf"));
}
