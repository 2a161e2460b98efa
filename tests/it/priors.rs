//! Priors (`prior:` on a parameter): the joint fit with priors is the maximum a posteriori one,
//! checked against an independent Gauss–Newton solve of the data's rows augmented with the
//! prior rows (central differences of the data's residuals, the prior's rows written here);
//! its σ, the data's share, what rests on the priors, and the refusals.

use legwise::identify::problem::IdentificationProblem;
use legwise::identify::result::{FitOptions, Strategy, StrategyResult, Weighting};
use legwise::measure::observations::Observations;
use legwise::measure::Measurements;
use legwise::model::Mechanism;
use legwise::pipeline::{identify_one, PoseSource};
use legwise::solver::SolverKind;
use nalgebra::{DMatrix, DVector};

use crate::forward_observations::{experiment_at, parse_model};
use crate::support::crate_path;

/// The rods' prior σ (0.2 mm, a datasheet's tolerance).
const ROD_PRIOR: f64 = 2e-4;

/// The probe's declared σ on a height (models/delta-probe.yaml's `noise`).
const PROBE_SIGMA: f64 = 1e-5;

/// models/delta-probe.yaml with the rods identified, each with a prior of σ `ROD_PRIOR`, and
/// the towers that define the base frame (t1x, t1y, t2x) likewise with `tower_prior` when
/// given.
fn rods_with_priors(tower_prior: Option<f64>) -> Mechanism {
    let mut text = std::fs::read_to_string(crate_path("models/delta-probe.yaml")).unwrap();
    // The model's rods carry their prior already: identified, they take it.
    for i in 1..=3 {
        let held = format!(
            "{{name: L{i}, joint: R{i}, origin: x, identify: false, prior: {ROD_PRIOR:.1e}}}"
        );
        assert!(text.contains(&held), "{held}");
        text = text.replace(&held, &held.replace("identify: false, ", ""));
    }
    if let Some(sigma) = tower_prior {
        for (name, joint, axis) in [("t1x", "C1", "x"), ("t1y", "C1", "y"), ("t2x", "C2", "x")] {
            let held = format!("{{name: {name}, joint: {joint}, origin: {axis}, identify: false}}");
            assert!(text.contains(&held), "{held}");
            let freed = held.replace("identify: false", &format!("prior: {sigma:e}"));
            text = text.replace(&held, &freed);
        }
    }
    parse_model(&text).expect("the model with priors loads")
}

/// The joint fit with `options`.
fn fit(mechanism: &Mechanism, observations: &Observations, options: FitOptions) -> StrategyResult {
    try_fit(mechanism, observations, options).expect("the fit succeeds")
}

fn try_fit(
    mechanism: &Mechanism,
    observations: &Observations,
    options: FitOptions,
) -> legwise::error::Result<StrategyResult> {
    identify_one(
        mechanism,
        &Measurements::Targets(observations.clone()),
        Strategy::Joint,
        SolverKind::LevenbergMarquardt,
        options,
    )
}

/// The estimate's identified unknowns in the problem's order (legs in model order, then the
/// instrument's), with each one's σ and prior.
fn unknowns(result: &StrategyResult) -> Vec<(f64, f64, Option<f64>)> {
    let legs = result.legs.iter().flat_map(|l| &l.parameters);
    let shared = result.instrument.iter().flat_map(|i| &i.parameters);
    legs.chain(shared)
        .filter(|p| p.identified)
        .map(|p| (p.estimate, p.std.expect("a σ"), p.prior))
        .collect()
}

/// Central differences of the data's residuals at `x`.
fn difference_jacobian(problem: &IdentificationProblem<'_>, x: &DVector<f64>) -> DMatrix<f64> {
    let r = problem.residuals(x).unwrap();
    let mut jacobian = DMatrix::zeros(r.len(), x.len());
    for j in 0..x.len() {
        let h = 1e-6 * x[j].abs().max(1e-2);
        let (mut up, mut down) = (x.clone(), x.clone());
        up[j] += h;
        down[j] -= h;
        let column =
            (problem.residuals(&up).unwrap() - problem.residuals(&down).unwrap()) / (2.0 * h);
        jacobian.set_column(j, &column);
    }
    jacobian
}

/// The data's rows (each height over the probe's σ) and the prior rows `(x_j − μ_j)/σ_j`
/// stacked, and their Jacobian.
fn augmented(
    problem: &IdentificationProblem<'_>,
    x: &DVector<f64>,
    priors: &[(usize, f64, f64)],
) -> (DVector<f64>, DMatrix<f64>) {
    let r = problem.residuals(x).unwrap() / PROBE_SIGMA;
    let jacobian = difference_jacobian(problem, x) / PROBE_SIGMA;
    let (m, n) = jacobian.shape();
    let mut stacked_r = r.resize_vertically(m + priors.len(), 0.0);
    let mut stacked = jacobian.resize_vertically(m + priors.len(), 0.0);
    for (k, &(j, mean, sigma)) in priors.iter().enumerate() {
        stacked_r[m + k] = (x[j] - mean) / sigma;
        stacked[(m + k, j)] = 1.0 / sigma;
    }
    assert_eq!(stacked.ncols(), n);
    (stacked_r, stacked)
}

/// With the rods freed and a 0.2 mm prior each, legwise's joint fit is the minimum of the
/// data's weighted squares plus the priors' (`Σ (r_i/σ_z)² + Σ ((L_j − L⁰)/σ_L)²`), which an
/// independent Gauss–Newton solve of the augmented rows finds: the same estimate to 1e-6 of
/// its σ, the same σ (the augmented rows' `ŝ² (AᵀA)⁻¹`, `ŝ²` on `m + p − n` degrees of
/// freedom) to 1e-4, and each rod's data share `1 − σ²/σ_L²`. Without the priors the same rows
/// give another estimate: the prior rows are in the fit.
#[test]
fn the_fit_with_priors_is_the_least_squares_optimum_of_the_rows_augmented_with_the_priors() {
    let mechanism = rods_with_priors(None);
    let (observations, _, _) = experiment_at(&mechanism, 1.0, PoseSource::Selected, Some(7));
    let result = fit(&mechanism, &observations, FitOptions::default());
    let problem = IdentificationProblem::through_instrument(&mechanism, &observations).unwrap();
    assert!(problem.prior_rows().is_empty(), "priors are asked for");
    let names = problem.names();
    let start = problem.start();
    let priors: Vec<(usize, f64, f64)> = names
        .iter()
        .enumerate()
        .filter(|(_, n)| n.starts_with('L'))
        .map(|(j, _)| (j, start[j], ROD_PRIOR))
        .collect();
    assert_eq!(priors.len(), 3, "{names:?}");
    // Gauss–Newton on the augmented rows from the nominal model.
    let mut x = start.clone();
    for _ in 0..20 {
        let (r, a) = augmented(&problem, &x, &priors);
        let step = (a.transpose() * &a)
            .cholesky()
            .expect("the augmented rows see every unknown")
            .solve(&(a.transpose() * r));
        x -= &step;
        if step.amax() < 1e-14 {
            break;
        }
    }
    let estimates = unknowns(&result);
    assert_eq!(estimates.len(), x.len());
    // Both stop at their own tolerance: a millionth of the estimate's σ apart at most.
    for (j, (estimate, sigma, _)) in estimates.iter().enumerate() {
        let gap = (estimate - x[j]).abs();
        assert!(
            gap < 1e-6 * sigma,
            "{}: legwise {estimate} vs augmented {}",
            names[j],
            x[j]
        );
    }
    let (r, a) = augmented(&problem, &x, &priors);
    let (m, n) = a.shape();
    let scale = r.norm_squared() / (m - n) as f64;
    let covariance = (a.transpose() * &a).try_inverse().unwrap() * scale;
    for (j, (_, sigma, prior)) in estimates.iter().enumerate() {
        let expected = covariance[(j, j)].sqrt();
        assert!(
            (sigma / expected - 1.0).abs() < 1e-4,
            "{}: σ {sigma} vs {expected}",
            names[j]
        );
        let is_rod = priors.iter().any(|p| p.0 == j);
        assert_eq!(prior.is_some(), is_rod, "{}", names[j]);
    }
    // Each rod's data share, from the declared noise's covariance (not scaled by ŝ).
    let declared = (a.transpose() * &a).try_inverse().unwrap();
    let rods = result.legs.iter().flat_map(|l| &l.parameters);
    for (p, &(j, _, _)) in rods.filter(|p| p.prior.is_some()).zip(&priors) {
        let share = p.data_share.unwrap();
        let expected = 1.0 - declared[(j, j)] / ROD_PRIOR.powi(2);
        assert!(
            (share - expected).abs() < 1e-6,
            "{}: {share} vs {expected}",
            p.name
        );
        assert!(share > 0.0 && share < 1.0);
    }
    // The report counts the data's rows; its RMS is theirs alone.
    let instrument = result.instrument.as_ref().unwrap();
    let data = problem.residuals(&x).unwrap();
    assert_eq!(instrument.rows, data.len());
    let rms = (data.norm_squared() / data.len() as f64).sqrt();
    assert!(
        (instrument.rms / rms - 1.0).abs() < 1e-6,
        "{} vs {rms}",
        instrument.rms
    );
    // The noise test counts the prior rows: m + p − n degrees of freedom.
    let test = instrument.noise_test.as_ref().unwrap();
    assert_eq!(test.degrees_of_freedom, m - n);
    assert!((test.chi_squared / r.norm_squared() - 1.0).abs() < 1e-6);
}

/// Heights on a level bed cannot see where the printer stands in x and y, nor how it is turned
/// about z: with the towers that define the base frame freed too, without priors the rank
/// check refuses them; with a prior each the fit goes through, and the report names the
/// directions the data alone cannot see, which rest on the priors.
#[test]
fn what_the_data_cannot_see_rests_on_the_priors_and_is_named() {
    let mechanism = rods_with_priors(Some(1e-3));
    let (observations, _, _) = experiment_at(&mechanism, 1.0, PoseSource::Selected, Some(3));
    let result = fit(&mechanism, &observations, FitOptions::default());
    let unseen = &result
        .instrument
        .as_ref()
        .unwrap()
        .observability
        .resting_on_prior;
    assert_eq!(unseen.len(), 3, "x, y and the turn about z: {unseen:?}");
    assert!(unseen.iter().all(|d| d.contains("t1")), "{unseen:?}");
    let without = mechanism.edited(|parts| {
        for p in parts.legs.iter_mut().flat_map(|l| l.params.iter_mut()) {
            p.prior = None;
        }
    });
    let error = try_fit(&without, &observations, FitOptions::default())
        .unwrap_err()
        .to_string();
    assert!(error.contains("rank-deficient"), "{error}");
    // A parameter the data see well keeps most of its information from them; the rods, which
    // the data cannot tell from the gains, keep less.
    let share = |name: &str| {
        let p = result.legs.iter().flat_map(|l| &l.parameters);
        p.clone()
            .find(|p| p.name == name)
            .unwrap()
            .data_share
            .unwrap()
    };
    assert!(share("L1") < 0.9, "{}", share("L1"));
}

/// Priors are weighed against the data by the declared noise: refused, naming the parameter's
/// prior, in an unweighted or robust fit and in the two-stage comparison; a model's prior σ
/// that is not a finite positive number is refused by field.
#[test]
fn priors_without_the_declared_noise_to_weigh_them_are_refused() {
    let mechanism = rods_with_priors(None);
    let (observations, _, _) = experiment_at(&mechanism, 1.0, PoseSource::Selected, Some(3));
    let unweighted = FitOptions {
        weights: Weighting::Unweighted,
        ..FitOptions::default()
    };
    let error = try_fit(&mechanism, &observations, unweighted)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("prior of `L1`") && error.contains("--weights none"),
        "{error}"
    );
    let robust = FitOptions {
        robust: Some(legwise::identify::robust::RobustLoss::Huber),
        ..FitOptions::default()
    };
    let error = try_fit(&mechanism, &observations, robust)
        .unwrap_err()
        .to_string();
    assert!(error.contains("--robust"), "{error}");
    let two_stage = identify_one(
        &mechanism,
        &Measurements::Targets(observations.clone()),
        Strategy::TwoStage,
        SolverKind::LevenbergMarquardt,
        FitOptions::default(),
    );
    assert!(two_stage.is_err());
    let text = std::fs::read_to_string(crate_path("models/delta-probe.yaml")).unwrap();
    for bad in ["0.0", "-1.0e-4", ".nan", ".inf"] {
        let edited = text.replace(
            "{name: L1, joint: R1, origin: x, identify: false, prior: 2.0e-4}",
            &format!("{{name: L1, joint: R1, origin: x, prior: {bad}}}"),
        );
        assert_ne!(edited, text);
        let error = parse_model(&edited).unwrap_err().to_string();
        assert!(
            error.contains("parameters[2].prior") && error.contains("finite positive"),
            "{bad}: {error}"
        );
    }
}

/// A leg fitted on its own (divide and conquer, at measured poses) takes no prior: a model
/// whose identified parameter carries one is refused by field rather than fitted without it.
#[test]
fn a_leg_fit_at_measured_poses_refuses_a_prior_rather_than_dropping_it() {
    let text = std::fs::read_to_string(crate_path("models/5r.yaml")).unwrap();
    let urdf = std::fs::read_to_string(crate_path("models/5r.urdf")).unwrap();
    let mechanism = Mechanism::parse(
        &text,
        std::path::Path::new("5r.yaml"),
        &urdf,
        std::path::Path::new("5r.urdf"),
    )
    .unwrap();
    let first = mechanism.legs[0]
        .params
        .iter()
        .find(|p| p.identified)
        .unwrap()
        .name
        .clone();
    let with_prior = mechanism.edited(|parts| {
        let p = parts.legs[0]
            .params
            .iter_mut()
            .find(|p| p.name == first)
            .unwrap();
        p.prior = Some(1e-3);
    });
    let settings = legwise::pipeline::SimulationSettings::default();
    let simulated = legwise::pipeline::simulate(&with_prior, &settings).unwrap();
    let error = legwise::pipeline::identify_one(
        &with_prior,
        &simulated.measurements,
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
        FitOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains(&format!("prior of `{first}`")), "{error}");
}

/// The set `rods` of models/delta-probe.yaml (its six and the rods, each rod on its 0.2 mm
/// prior) fitted in its factors and the joint fit of the model with the rods identified: two
/// ways of adding the prior rows (to the set's factors, to the problem's unknowns), one optimum.
/// The estimates agree to 1e-6 of their σ; the joint fit's σ are the set's (the declared
/// noise's) times one common scale ŝ. The set's effective factors are the trace of the data's
/// hat matrix, which is also `n − Σ σ²/σ_prior²` over the priors: the six factors without a
/// prior count 1 each, a rod its data share.
#[test]
fn a_factor_set_on_priors_fits_what_the_joint_fit_with_the_same_priors_fits() {
    let mechanism = Mechanism::load(&crate_path("models/delta-probe.yaml")).unwrap();
    let (observations, _, _) = experiment_at(&mechanism, 1.0, PoseSource::Selected, Some(11));
    let data = Measurements::Targets(observations.clone());
    let set = mechanism
        .factor_sets
        .iter()
        .find(|s| s.name == "rods")
        .unwrap();
    let fit = legwise::identify::factor_set::fit_factor_set(&mechanism, &data, set).unwrap();
    let freed = crate::support::with_identified(&mechanism, &["L1", "L2", "L3"], true);
    let joint = fit_joint(&freed, &observations);
    let by_name = |name: &str| {
        let mut all = joint.legs.iter().flat_map(|l| &l.parameters);
        all.find(|p| p.name == name).unwrap().clone()
    };
    let mut scales = Vec::new();
    for f in &fit.factors {
        let p = by_name(&f.name);
        let sigma = p.std.unwrap();
        assert!(
            (p.estimate - f.estimate).abs() < 1e-6 * sigma,
            "{}: joint {} vs set {}",
            f.name,
            p.estimate,
            f.estimate
        );
        assert_eq!(p.prior, f.prior, "{}", f.name);
        scales.push(sigma / f.sigma);
    }
    let first = scales[0];
    assert!(
        scales.iter().all(|s| (s / first - 1.0).abs() < 1e-6),
        "{scales:?}"
    );
    let shares: f64 = fit
        .factors
        .iter()
        .map(|f| f.data_share().unwrap_or(1.0))
        .sum();
    assert!(
        (fit.effective_factors - shares).abs() < 1e-9,
        "{} vs {shares}",
        fit.effective_factors
    );
    assert!(fit.effective_factors > 6.0 && fit.effective_factors < 9.0);
    let expected = fit.chi_square + 2.0 * fit.effective_factors;
    assert!((fit.information - expected).abs() < 1e-9);
    // The scale: the heights' RMS in the probe's σ over the rows the data leave free.
    let rows = fit.rows as f64;
    let chi_square = rows * (fit.rms / PROBE_SIGMA).powi(2);
    let scale = (chi_square / (rows - fit.effective_factors)).sqrt();
    assert!(
        (fit.scale() / scale - 1.0).abs() < 1e-9,
        "{} vs {scale}",
        fit.scale()
    );
    assert_eq!(
        fit.degrees_of_freedom,
        fit.rows - fit.effective_factors.round() as usize
    );
}

/// The joint fit with the default options.
fn fit_joint(mechanism: &Mechanism, observations: &Observations) -> StrategyResult {
    fit(mechanism, observations, FitOptions::default())
}

/// The estimates of every identified parameter of a JSON report, by name: (estimate, σ).
fn json_estimates(path: &std::path::Path) -> Vec<(String, f64, f64)> {
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let legs = report["results"][0]["legs"].as_array().unwrap();
    legs.iter()
        .flat_map(|l| l["parameters"].as_array().unwrap())
        .filter(|p| !p["fixed"].as_bool().unwrap())
        .map(|p| {
            let name = p["name"].as_str().unwrap().to_string();
            (
                name,
                p["identified"].as_f64().unwrap(),
                p["std"].as_f64().unwrap(),
            )
        })
        .collect()
}

/// A previous calibration as the prior (`identify --prior CAL.yaml`, CAL written by
/// `--calibrated` with its estimates and the declared noise's covariance): calibrating on a
/// first set of touches, then on a second with the first's calibration as the prior, gives the
/// fit of both sets together, to 1e-3 of a σ (the rest is the model's curvature between the
/// two linearisations). The prior is the fit's; the report names its rows.
#[test]
fn a_calibration_then_its_prior_on_new_touches_is_the_fit_of_both() {
    use crate::cli::{legwise, legwise_succeeds, text};
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name);
    let arg = |name: &str| path(name).to_str().unwrap().to_string();
    let model = "models/delta-probe.yaml";
    for (seed, out) in [("5", "a.csv"), ("6", "b.csv")] {
        legwise_succeeds(&[
            "simulate",
            "--model",
            model,
            "--seed",
            seed,
            "--out",
            &arg(out),
        ]);
    }
    let a = std::fs::read_to_string(path("a.csv")).unwrap();
    let b = std::fs::read_to_string(path("b.csv")).unwrap();
    // Both sets in one file, the second's row ids renamed (ids are unique in a file).
    let second: Vec<String> = b
        .lines()
        .skip(1)
        .map(|l| l.replace(",t", ",second-t"))
        .collect();
    std::fs::write(path("ab.csv"), format!("{a}{}\n", second.join("\n"))).unwrap();
    let (cal, ab) = (arg("cal.yaml"), arg("ab.csv"));
    legwise_succeeds(&[
        "identify",
        "--model",
        model,
        "--measurements",
        &arg("a.csv"),
        "--calibrated",
        &cal,
    ]);
    let calibrated = std::fs::read_to_string(&cal).unwrap();
    assert!(calibrated.contains("calibration:") && calibrated.contains("covariance:"));
    let out = legwise_succeeds(&[
        "identify",
        "--model",
        model,
        "--measurements",
        &arg("b.csv"),
        "--prior",
        &cal,
        "--json",
        &arg("seq.json"),
    ]);
    assert!(
        text(&out.stdout).contains("priors: 6 rows"),
        "{}",
        text(&out.stdout)
    );
    legwise_succeeds(&[
        "identify",
        "--model",
        model,
        "--measurements",
        &ab,
        "--json",
        &arg("ab.json"),
    ]);
    let (sequential, joint) = (
        json_estimates(&path("seq.json")),
        json_estimates(&path("ab.json")),
    );
    assert_eq!(sequential.len(), 6);
    for ((name, s, _), (other, j, sigma)) in sequential.iter().zip(&joint) {
        assert_eq!(name, other);
        assert!(
            (s - j).abs() < 1e-3 * sigma,
            "{name}: {s} vs {j} (σ {sigma})"
        );
    }
    // Without the calibration block, or naming a parameter the model lacks: refused by field.
    let bare = std::fs::read_to_string("models/delta-probe.yaml").unwrap();
    std::fs::write(path("bare.yaml"), bare).unwrap();
    let out = legwise(&[
        "identify",
        "--model",
        model,
        "--measurements",
        &ab,
        "--prior",
        &arg("bare.yaml"),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("field `calibration`"),
        "{}",
        text(&out.stderr)
    );
    std::fs::write(
        path("other.yaml"),
        calibrated.replace("- h0_1\n", "- h0_9\n"),
    )
    .unwrap();
    let out = legwise(&[
        "identify",
        "--model",
        model,
        "--measurements",
        &ab,
        "--prior",
        &arg("other.yaml"),
    ]);
    assert!(
        text(&out.stderr).contains("calibration.parameters[0]")
            && text(&out.stderr).contains("`h0_9`"),
        "{}",
        text(&out.stderr)
    );
    // A leg fitted on its own takes no prior: the 5R's own calibration refused as one.
    let five = arg("5r-cal.yaml");
    legwise_succeeds(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--calibrated",
        &five,
    ]);
    let out = legwise(&["identify", "--model", "models/5r.yaml", "--prior", &five]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("--prior"),
        "{}",
        text(&out.stderr)
    );
}

/// Through a tracker (legs in groups of their own, the frame the border), a previous
/// calibration's rows couple the legs: the problem becomes one group and the fit still goes
/// through, its estimates within a σ of the fit without the prior.
#[test]
fn a_calibration_prior_through_a_tracker_couples_the_legs() {
    use crate::cli::{legwise_succeeds, text};
    let dir = tempfile::tempdir().unwrap();
    let arg = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let model = "models/5r-tracker.yaml";
    legwise_succeeds(&[
        "identify",
        "--model",
        model,
        "--calibrated",
        &arg("cal.yaml"),
        "--json",
        &arg("a.json"),
    ]);
    let out = legwise_succeeds(&[
        "identify",
        "--model",
        model,
        "--prior",
        &arg("cal.yaml"),
        "--json",
        &arg("b.json"),
    ]);
    let report = text(&out.stdout);
    assert!(
        report.contains("priors:") && !report.contains("two-stage"),
        "{report}"
    );
    // The same rows again with their own calibration as the prior: within a σ of it.
    let (alone, with_prior) = (
        json_estimates(&dir.path().join("a.json")),
        json_estimates(&dir.path().join("b.json")),
    );
    assert!(!alone.is_empty());
    for ((name, a, sigma), (other, b, _)) in alone.iter().zip(&with_prior) {
        assert_eq!(name, other);
        assert!((a - b).abs() < *sigma, "{name}: {a} vs {b} (σ {sigma})");
    }
}
