//! What `legwise sets` tells an owner on real data: each row's residual drawn where it was
//! measured (its after-fit RMS is the fit's own, by another path: the forward kinematics and
//! the instrument at the fitted values), the "What next" sentences with the figures they rest
//! on, and the model with a set's values (`with_values`).
use std::path::Path;

use legwise::evaluate::row_residuals::row_residuals;
use legwise::identify::factor_set::{fit_factor_set, model_sets};
use legwise::model::with_values::with_values;
use legwise::printer::delta_model::ModelOptions;
use legwise::printer::klipper::{KlipperConfig, KlipperDelta};
use legwise::{Measurements, Mechanism};

use crate::cli::{assert_fails_with, legwise_succeeds, text};
use crate::factor_sets::model_of;

const FLSUN: &str = "tests/data/klipper/flsun_qqs.cfg";

/// The real FLSUN QQ-S imported into `dir`: its model and its seven touches.
fn flsun(dir: &Path) -> (Mechanism, Measurements) {
    let config = KlipperConfig::read(Path::new(FLSUN)).unwrap();
    let delta = KlipperDelta::from_config(&config).unwrap().geometry();
    model_of(dir, &delta, ModelOptions::default().probe_noise)
}

#[test]
fn each_rows_residual_after_the_fit_is_the_fits_own() {
    let dir = tempfile::tempdir().unwrap();
    let (mechanism, data) = flsun(dir.path());
    let Measurements::Targets(observations) = &data else {
        panic!("touches are instrument rows")
    };
    for set in model_sets(&mechanism) {
        let fit = fit_factor_set(&mechanism, &data, &set).unwrap();
        let values: Vec<(String, f64)> = fit
            .factors
            .iter()
            .map(|f| (f.name.clone(), f.estimate))
            .collect();
        let fitted = with_values(&mechanism, &values).unwrap();
        let rows = row_residuals(&fitted, observations).unwrap();
        assert_eq!(rows.len(), 7, "{}", set.name);
        let rms = (rows.iter().map(|r| r.residual[0].powi(2)).sum::<f64>() / 7.0).sqrt();
        // Two paths to the same residuals: the fit's problem, and the forward kinematics with
        // the instrument at the fitted values; Newton's round-off apart (1e-9 of the RMS, and a
        // picometre for the set that interpolates its seven rows).
        assert!(
            (rms - fit.rms).abs() <= 1e-9 * fit.rms + 1e-12,
            "{}: {rms:e} against {:e}",
            set.name,
            fit.rms
        );
        // Every touch on the probed disc (Klipper's radius 120 mm) and at its line; rows made
        // in memory (no line) are numbered as a file's would be.
        for (k, row) in rows.iter().enumerate() {
            assert!(row.at[0].hypot(row.at[1]) <= 0.12, "{row:?}");
            assert_eq!(row.line, k + 2);
        }
        let mut unnumbered = observations.clone();
        unnumbered.rows.iter_mut().for_each(|r| r.line = None);
        let lines: Vec<usize> = row_residuals(&fitted, &unnumbered)
            .unwrap()
            .iter()
            .map(|r| r.line)
            .collect();
        assert_eq!(lines, (2..9).collect::<Vec<_>>());
    }
}

#[test]
fn a_quantity_moves_its_derived_parameters_and_a_parameter_itself() {
    let dir = tempfile::tempdir().unwrap();
    let (mechanism, _) = flsun(dir.path());
    let radius = 0.15;
    let moved = with_values(
        &mechanism,
        &[("radius".into(), radius), ("k2".into(), 1.001)],
    )
    .unwrap();
    let value = |m: &Mechanism, leg: usize, name: &str| {
        m.legs[leg]
            .params
            .iter()
            .find(|p| p.name == name)
            .unwrap()
            .nominal
    };
    let angle_a = mechanism
        .quantities
        .iter()
        .find(|q| q.name == "angle_a")
        .unwrap()
        .nominal;
    assert!((value(&moved, 0, "t1y") - radius * angle_a.sin()).abs() < 1e-15);
    assert!((value(&moved, 1, "k2") - 1.001).abs() < 1e-15);
    // h0 = endstop + sqrt(arm^2 - radius^2) follows the radius.
    let endstop = mechanism
        .quantities
        .iter()
        .find(|q| q.name == "endstop_c")
        .unwrap()
        .nominal;
    let expected = endstop + (0.28f64.powi(2) - radius * radius).sqrt();
    assert!((value(&moved, 2, "h0_3") - expected).abs() < 1e-12);
    // Untouched: the rods.
    assert!((value(&moved, 0, "L1") - value(&mechanism, 0, "L1")).abs() < 1e-15);
    let unknown = with_values(&mechanism, &[("radious".into(), 0.1)]).unwrap_err();
    assert!(
        unknown
            .to_string()
            .contains("expected a quantity or a parameter `radious`"),
        "{unknown}"
    );
    // A radius beyond the rods: sqrt of a negative, refused by name.
    let beyond = with_values(&mechanism, &[("radius".into(), 0.3)]).unwrap_err();
    assert!(
        beyond.to_string().contains("parameters.h0_1.value"),
        "{beyond}"
    );
}

#[test]
fn what_next_states_the_figures_it_rests_on() {
    let dir = tempfile::tempdir().unwrap();
    flsun(dir.path());
    let model = dir.path().join("printer.yaml");
    let probe = dir.path().join("probe.csv");
    let plots = dir.path().join("pics");
    let out = legwise_succeeds(&[
        "sets",
        "--model",
        model.to_str().unwrap(),
        "--measurements",
        probe.to_str().unwrap(),
        "--plots",
        plots.to_str().unwrap(),
    ]);
    let stdout = text(&out.stdout).replace("\n    ", " ");
    // Seven touches leave one beyond six factors: AICc cannot judge the six, shown as inf.
    let model_row = stdout.lines().find(|l| l.starts_with("model ")).unwrap();
    assert!(model_row.contains(" inf "), "{model_row}");
    for expected in [
        "The residual (RMS 7.188e-5) is 19.0 times the declared σ",
        "Only 1 row(s) beyond the 6 factors: a row left out of the fit is predicted to 7.557e-4 RMS, 10.5 times the residual",
        "`klipper-9` cannot be determined by these rows",
        "Recommended: `model`, the determined set with the fewest factors: each set the rows determine leaves at most one row beyond its factors (its AICc is infinite); more rows let the rows choose.",
    ] {
        assert!(stdout.contains(expected), "{expected}\n{stdout}");
    }
    let svg = std::fs::read_to_string(plots.join("row-residuals.svg")).unwrap();
    // Seven touches, each a filled disc and its outline, before and after.
    assert_eq!(svg.matches("<circle").count(), 28);
    assert!(
        svg.contains("before (nominal model): RMS 71.9 µm"),
        "caption"
    );
}

#[test]
fn the_sets_with_more_factors_than_the_rows_support_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rrf");
    legwise_succeeds(&[
        "printer",
        "import",
        "--rrf",
        "tests/data/rrf/config.g",
        "--override",
        "tests/data/rrf/config-override.g",
        "--probes",
        "tests/data/rrf/bed-probe.log",
        "--out",
        out.to_str().unwrap(),
        // RepRapFirmware's own factors: the model set is `rrf-6` in other coordinates.
        "--rod-prior",
        "0",
        "--gain-prior",
        "0",
    ]);
    let model = out.join("printer.yaml");
    let probe = out.join("probe.csv");
    let stdout = text(
        &legwise_succeeds(&[
            "sets",
            "--model",
            model.to_str().unwrap(),
            "--measurements",
            probe.to_str().unwrap(),
        ])
        .stdout,
    )
    .replace("\n    ", " ");
    // The table's AICc: χ² + 2k + 2k(k + 1)/(13 − k − 1), χ² = 13 (RMS / 1e-5)² (26.0 for
    // the six factors' 1.744e-7 m).
    assert!(
        stdout.contains(
            "Recommended: `model`, the lowest AICc of the sets the rows determine (26.0) (as \
             well: `rrf-6`)"
        ),
        "{stdout}"
    );
    assert!(
        stdout.contains("More factors score worse: `rrf-8` (52.0), `rrf-7` (36.4), `rrf-9` (78.0)"),
        "{stdout}"
    );
}

#[test]
fn the_residual_picture_needs_an_instrument() {
    assert_fails_with(
        &["sets", "--model", "models/5r.yaml", "--plots", "/tmp/legwise-no-plots"],
        "legwise: --plots: draws each row's residual through the instrument, and models/5r.yaml has none",
    );
    assert_fails_with(
        &["sets", "--model", "models/5r.yaml", "--png"],
        "legwise: --png: draws the pictures of --plots DIR as PNG, but no --plots is given; add --plots DIR or drop --png",
    );
}

#[test]
fn what_next_counts_the_factors_the_rows_carry_when_priors_carry_the_rest() {
    // The FLSUN imported with its rods and gains on their priors: twelve factors on seven
    // touches, about six of them carried by the touches.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("flsun");
    legwise_succeeds(&[
        "printer",
        "import",
        "--klipper",
        FLSUN,
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = text(
        &legwise_succeeds(&[
            "sets",
            "--model",
            out.join("printer.yaml").to_str().unwrap(),
            "--measurements",
            out.join("probe.csv").to_str().unwrap(),
        ])
        .stdout,
    )
    .replace("\n    ", " ");
    assert!(
        stdout.contains(
            "Only 1 row(s) beyond the 6.1 factors the rows carry (of 12, the rest resting on \
             their priors)"
        ),
        "{stdout}"
    );
}
