//! Zero-noise fits are exact to round-off: their studentized residuals are ratios of round-off
//! and must not name outliers nor make a run untrusted, while a real gross error among otherwise
//! exact readings is still named.
use legwise::identify::estimate::{identify, Strategy};
use legwise::identify::statistics::exact_fit;
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::model::Mechanism;
use legwise::solver::SolverKind;

use crate::cli::{legwise, text};
use crate::support::bundled;

const MODELS: [&str; 4] = ["5r.yaml", "3rpr.yaml", "delta.yaml", "hexapod.yaml"];

/// Noise-free measurements of the model's simulation block (its seed, poses per leg).
fn noise_free(mechanism: &Mechanism) -> legwise::measure::MeasurementSet {
    let options = SimulationOptions {
        noise_scale: 0.0,
        ..SimulationOptions::default()
    };
    simulate(mechanism, options)
        .expect("simulation")
        .measurements
}

#[test]
fn exact_fit_compares_the_rms_residual_with_the_readings_and_the_declared_scatter() {
    let readings = [0.5, -0.25, 0.125, 0.4];
    // Round-off: RMS 1e-15 against readings of 0.5.
    assert!(exact_fit(&[1e-15, -1e-15, 1e-15, -1e-15], &readings, None));
    // Residuals of 1e-6 are data, not round-off, without a declared noise…
    assert!(!exact_fit(&[1e-6, -1e-6, 1e-6, -1e-6], &readings, None));
    // …but far below a declared σ of 1e-2 (variance 1e-4): 1e-6 ≤ 1e-3 · 1e-2.
    assert!(exact_fit(
        &[1e-6, -1e-6, 1e-6, -1e-6],
        &readings,
        Some(&[1e-4; 4])
    ));
    // One gross error among exact residuals: RMS 5e-4, neither round-off nor below 1e-3 · 1e-2.
    assert!(!exact_fit(
        &[0.0, 0.0, 0.0, 1e-3],
        &readings,
        Some(&[1e-4; 4])
    ));
    // The thresholds are on the RMS (a mean over the rows, not a sum): 0.9 and 1.5 times
    // the round-off threshold 1e-10 · 0.5 …
    assert!(exact_fit(&[0.45e-10; 4], &readings, None));
    assert!(!exact_fit(&[0.75e-10; 4], &readings, None));
    // … and 0.9 and 1.5 times 1e-3 · σ for σ = √(mean variance) = 1e-2 (the variances
    // differ, so a sum or a single row would give another σ).
    let variances = [0.5e-4, 1.5e-4, 0.5e-4, 1.5e-4];
    assert!(exact_fit(&[0.9e-5; 4], &readings, Some(&variances)));
    assert!(!exact_fit(&[1.5e-5; 4], &readings, Some(&variances)));
    // A declared scatter that is not finite or not positive is no scatter to compare with.
    assert!(!exact_fit(&[1e-3; 4], &readings, Some(&[f64::INFINITY; 4])));
    assert!(!exact_fit(&[1e-9; 4], &readings, Some(&[0.0; 4])));
    // All-zero readings: only zero residuals are exact.
    assert!(exact_fit(&[0.0; 4], &[0.0; 4], None));
    assert!(!exact_fit(&[1e-100; 4], &[0.0; 4], None));
}

#[test]
fn zero_noise_fits_of_the_bundled_models_name_no_outlier() {
    for file in MODELS {
        let declared = bundled(file);
        let data = noise_free(&declared);
        // As `identify --noise-scale 0` (declared noise scaled to zero) and with the declared
        // noise kept (residuals far below it).
        let zeroed = declared.edited(|zeroed| {
            if let Some(noise) = &mut zeroed.noise {
                noise.pose = [0.0; 6];
                noise.reading = 0.0;
            }
        });
        for mechanism in [&zeroed, &declared] {
            for strategy in [Strategy::DivideAndConquer, Strategy::Traditional] {
                let result = identify(mechanism, &data, strategy, SolverKind::LevenbergMarquardt)
                    .unwrap_or_else(|e| panic!("{file} {strategy:?}: {e}"));
                for leg in &result.legs {
                    assert!(
                        leg.statistics.outliers.is_empty(),
                        "{file} {strategy:?} leg {}: outliers {:?}",
                        leg.leg,
                        leg.statistics.outliers
                    );
                    assert!(leg.warnings.is_empty(), "{file}: {:?}", leg.warnings);
                }
            }
        }
    }
}

#[test]
fn a_gross_error_among_noise_free_readings_is_still_named() {
    for file in ["delta.yaml", "hexapod.yaml"] {
        let mechanism = bundled(file);
        let mut data = noise_free(&mechanism);
        // Shift the first row's first reading by 1 mm.
        let slot = data
            .readings_mut(0)
            .iter_mut()
            .flatten()
            .next()
            .expect("a reading");
        *slot += 1e-3;
        let result = identify(
            &mechanism,
            &data,
            Strategy::DivideAndConquer,
            SolverKind::LevenbergMarquardt,
        )
        .unwrap();
        let named: usize = result
            .legs
            .iter()
            .map(|l| l.statistics.outliers.len())
            .sum();
        assert!(named >= 1, "{file}: the shifted reading was not named");
    }
}

#[test]
fn identify_at_zero_noise_exits_0_without_outliers_on_every_bundled_model() {
    for file in MODELS {
        let model = format!("models/{file}");
        let out = legwise(&["identify", "--model", &model, "--noise-scale", "0"]);
        let stdout = text(&out.stdout);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{file}: {stderr}");
        assert!(
            !stdout.contains("is an outlier") && !stderr.contains("is an outlier"),
            "{file}: {stdout}{stderr}"
        );
    }
}
