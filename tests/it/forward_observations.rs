//! Forward observations (`instrument.kinematics: forward`): what an instrument saw predicted
//! from every leg's reading through the forward kinematics — a bed probe's heights on the delta
//! (models/delta-probe.yaml), one reflector's position on the hexapod
//! (models/hexapod-reflector.yaml). The Jacobian of the implicit-function derivatives against
//! central differences of the residuals, exact recovery at zero noise, the rank check naming
//! what heights cannot see, and bad input.

use legwise::identify::problem::IdentificationProblem;
use legwise::identify::result::{Strategy, StrategyResult};
use legwise::measure::observations::{self, Observations};
use legwise::measure::simulate::SimulationOptions;
use legwise::measure::Measurements;
use legwise::model::mechanism::SelectionCriterion;
use legwise::model::Mechanism;
use legwise::pipeline::{simulate, PoseSource, SimulationSettings};
use legwise::selection::forward_design::select_forward;
use nalgebra::{DMatrix, DVector};

use crate::instrument_support::identify_shared;
use crate::support::{bundled, crate_path, with_identified, without_priors};

/// `text` loaded as a model file beside models/delta.urdf.
pub(crate) fn parse_model(text: &str) -> legwise::error::Result<Mechanism> {
    let urdf = std::fs::read_to_string(crate_path("models/delta.urdf")).unwrap();
    Mechanism::parse(
        text,
        std::path::Path::new("probe.yaml"),
        &urdf,
        std::path::Path::new("delta.urdf"),
    )
}

/// The model's simulated experiment (random rows; noise scaled by `noise_scale`).
fn experiment(mechanism: &Mechanism, noise_scale: f64) -> (Observations, Vec<Vec<f64>>, Vec<f64>) {
    experiment_at(mechanism, noise_scale, PoseSource::Random, None)
}

/// The model's simulated experiment at `poses` (random rows of simulation seed `seed`, or the
/// selected ones), noise scaled by `noise_scale`.
pub(crate) fn experiment_at(
    mechanism: &Mechanism,
    noise_scale: f64,
    poses: PoseSource,
    seed: Option<u64>,
) -> (Observations, Vec<Vec<f64>>, Vec<f64>) {
    let settings = SimulationSettings {
        options: SimulationOptions {
            noise_scale,
            seed,
            ..Default::default()
        },
        poses,
        grid: None,
    };
    let simulated = simulate(mechanism, &settings).expect("simulates");
    let Measurements::Targets(observations) = simulated.measurements else {
        panic!("a forward model is measured through its instrument");
    };
    let shared = simulated.real.instrument.expect("the real instrument");
    (observations, simulated.real.legs, shared)
}

/// `mechanism` with every held parameter's real value (legs and instrument) at its nominal
/// one: the model is exact, and every identified parameter can be recovered.
pub(crate) fn exact(mechanism: &Mechanism) -> Mechanism {
    mechanism.edited(|parts| {
        let mut held: Vec<String> = parts
            .legs
            .iter()
            .flat_map(|l| l.params.iter().filter(|p| !p.identified))
            .map(|p| p.name.clone())
            .collect();
        if let Some(instrument) = &parts.instrument {
            let shared = instrument.parameters.iter().filter(|p| !p.identified);
            held.extend(shared.map(|p| p.name.clone()));
        }
        if let Some(simulation) = parts.simulation.as_mut() {
            for name in held {
                simulation.real.remove(&name);
            }
        }
    })
}

/// The probe model's held parameters: tower 1, t2x, rods, gains, the bed's height and tilts.
const EVERYTHING_HELD: &[&str] = &[
    "t1x",
    "t1y",
    "t2x",
    "L1",
    "L2",
    "L3",
    "k1",
    "k2",
    "k3",
    "frame_z",
    "frame_roll",
    "frame_pitch",
];

/// `mechanism` with the named leg and instrument parameters identified too.
fn freed(mechanism: &Mechanism, names: &[&str]) -> Mechanism {
    with_identified(mechanism, names, true)
}

/// The largest gap between the problem's Jacobian at `x` and central differences of its
/// residuals, each column relative to its largest entry.
pub(crate) fn jacobian_gap(problem: &IdentificationProblem<'_>, x: &DVector<f64>) -> f64 {
    let (_, jacobian) = problem.residuals_and_jacobian(x).expect("evaluates");
    let mut worst = 0.0f64;
    for j in 0..x.len() {
        // The forward kinematics closes to about 1e-13 of the mechanism's size: a step of 1e-5
        // keeps its round-off, over the step, below the tolerance.
        let h = 1e-5 * x[j].abs().max(1e-1);
        let (mut up, mut down) = (x.clone(), x.clone());
        up[j] += h;
        down[j] -= h;
        let difference =
            (problem.residuals(&up).unwrap() - problem.residuals(&down).unwrap()) / (2.0 * h);
        let column = jacobian.column(j);
        // A column that is zero by structure (a translating effector: the offset along x and y)
        // is judged against the whole Jacobian's scale.
        let scale = column.amax().max(1e-3 * jacobian.amax());
        let gap = (column - difference).amax() / scale;
        worst = worst.max(gap);
    }
    worst
}

#[test]
fn forward_jacobians_match_central_differences_for_heights_and_positions() {
    let probe = bundled("delta-probe.yaml");
    let everything = freed(&probe, EVERYTHING_HELD);
    // The nozzle's offset freed too: a distance's derivative along it (zero: the effector only
    // translates) comes from both of its rows.
    let distances = bundled("delta-probe-distances.yaml");
    let offset_free = freed(&distances, &["target_x", "target_y", "target_z"]);
    let models = [
        probe,
        everything,
        distances,
        offset_free,
        bundled("hexapod-reflector.yaml"),
    ];
    for mechanism in models {
        let (observations, _, _) = experiment(&mechanism, 1.0);
        let problem = IdentificationProblem::through_instrument(&mechanism, &observations)
            .expect("a forward problem");
        // Away from the nominal parameters too: every column moved a little.
        let start = problem.start();
        let moved = DVector::from_fn(start.len(), |j, _| start[j] + 1e-4 * ((j % 5) as f64 - 2.0));
        for x in [start, moved] {
            let gap = jacobian_gap(&problem, &x);
            assert!(
                gap <= 1e-6,
                "{}: Jacobian against central differences {gap:.2e}",
                mechanism.name
            );
        }
    }
}

/// Every identified parameter of `result` (legs and instrument) within `tolerance` of its real
/// value; returns how many.
pub(crate) fn assert_recovered(
    result: &StrategyResult,
    (legs, shared): (&[Vec<f64>], &[f64]),
    tolerance: f64,
) -> usize {
    let mut count = 0;
    for (leg, estimate) in result.legs.iter().enumerate() {
        for (p, param) in estimate.parameters.iter().enumerate() {
            if param.identified {
                let real = legs[leg][p];
                assert!(
                    (param.estimate - real).abs() <= tolerance,
                    "{} = {} but real {real}",
                    param.name,
                    param.estimate
                );
                count += 1;
            }
        }
    }
    let instrument = result
        .instrument
        .as_ref()
        .expect("the instrument's estimate");
    for (k, param) in instrument.parameters.iter().enumerate() {
        if param.identified {
            assert!(
                (param.estimate - shared[k]).abs() <= tolerance,
                "{} = {} but real {}",
                param.name,
                param.estimate,
                shared[k]
            );
            count += 1;
        }
    }
    count
}

#[test]
fn at_zero_noise_both_forward_models_recover_every_identified_parameter() {
    for (model, identified) in [
        ("delta-probe.yaml", 6),
        ("delta-probe-distances.yaml", 9),
        ("hexapod-reflector.yaml", 45),
    ] {
        let mechanism = exact(&bundled(model));
        let (observations, legs, shared) = experiment(&mechanism, 0.0);
        let result = identify_shared(&mechanism, &observations, Strategy::Joint)
            .unwrap_or_else(|e| panic!("{model}: {e}"));
        let count = assert_recovered(&result, (&legs, &shared), 1e-9);
        assert_eq!(count, identified, "{model}: parameters identified");
    }
}

/// log det(JᵀJ) of `problem`'s Jacobian at its start (nominal parameters).
fn log_det_at_start(problem: &IdentificationProblem<'_>) -> f64 {
    let (_, jacobian) = problem.residuals_and_jacobian(&problem.start()).unwrap();
    let information = jacobian.tr_mul(&jacobian);
    2.0 * information
        .cholesky()
        .expect("a full-rank design")
        .l()
        .diagonal()
        .iter()
        .map(|v| v.ln())
        .sum::<f64>()
}

#[test]
fn selected_probe_points_see_more_than_random_ones_and_the_design_is_what_the_csv_gives() {
    let probe = bundled("delta-probe.yaml");
    let design = select_forward(&probe, None, 37, SelectionCriterion::D).unwrap();
    assert_eq!(design.poses.len(), 37);
    // Every selected touch is on the nominal bed (the nozzle 0.02 m under the effector).
    for pose in &design.poses {
        assert!((pose[2] - 0.02).abs() < 1e-12, "{pose:?}");
    }
    // The design's pose file, its heights filled in (0: the nominal bed), read back: readings
    // from the commanded poses by the nominal model, every row's forward kinematics from home.
    let csv = legwise::report::selection::forward_pose_file(&probe, &design).unwrap();
    let filled: String = csv
        .lines()
        .enumerate()
        .map(|(i, line)| match i {
            0 => format!("{line}\n"),
            _ => {
                let mut cells: Vec<&str> = line.split(',').collect();
                cells[4] = "0";
                format!("{}\n", cells.join(","))
            }
        })
        .collect();
    let directory = tempfile::tempdir().unwrap();
    let path = directory.path().join("selected.csv");
    std::fs::write(&path, filled).unwrap();
    let read = observations::read(&path, &probe).unwrap();
    let selected =
        log_det_at_start(&IdentificationProblem::through_instrument(&probe, &read).unwrap());
    assert!(
        (selected - design.selection.log_det).abs() <= 1e-8 * selected.abs().max(1.0),
        "the design's log det {} against the CSV's {selected}",
        design.selection.log_det
    );
    // Random touches (the simulation's, five seeds) see less: a smaller det(JᵀJ).
    for seed in 1..=5 {
        let (random, _, _) = experiment_at(&probe, 0.0, PoseSource::Random, Some(seed));
        let random =
            log_det_at_start(&IdentificationProblem::through_instrument(&probe, &random).unwrap());
        assert!(
            selected > random + 0.1,
            "seed {seed}: selected log det {selected}, random {random}"
        );
    }
}

#[test]
fn at_zero_noise_selected_rows_recover_every_identified_parameter() {
    for (model, identified) in [("delta-probe.yaml", 6), ("delta-probe-distances.yaml", 9)] {
        let mechanism = exact(&bundled(model));
        let (observations, legs, shared) =
            experiment_at(&mechanism, 0.0, PoseSource::Selected, None);
        assert_eq!(observations.rows.len(), 37, "{model}");
        let result = identify_shared(&mechanism, &observations, Strategy::Joint)
            .unwrap_or_else(|e| panic!("{model}: {e}"));
        let count = assert_recovered(&result, (&legs, &shared), 1e-9);
        assert_eq!(count, identified, "{model}: parameters identified");
    }
}

/// The rank check's message on `model` with every tower position, rod, gain, carriage
/// offset and the bed's height and tilts free (18 unknowns).
fn everything_free_message(model: &str) -> String {
    // On the data alone (the rods' prior in delta-probe.yaml removed).
    let everything = freed(&without_priors(&bundled(model)), EVERYTHING_HELD);
    let (observations, _, _) = experiment(&everything, 1.0);
    identify_shared(&everything, &observations, Strategy::Joint)
        .expect_err("the printer's place cannot be identified")
        .to_string()
}

/// The motions a rank check's message names as unseen, and the least seen one after them.
fn motions_named(message: &str) -> (String, String) {
    let unseen = message
        .split("the observations cannot see these motions of the reached points: ")
        .nth(1)
        .and_then(|rest| rest.split(';').next())
        .unwrap_or_else(|| panic!("no unseen motions: {message}"));
    let least = message
        .split("the least seen after them: ")
        .nth(1)
        .and_then(|rest| rest.split(" (column-scaled").next())
        .unwrap_or_else(|| panic!("no least seen motion: {message}"));
    (unseen.to_string(), least.to_string())
}

#[test]
fn with_rods_gains_and_every_tower_free_the_rank_check_names_what_heights_cannot_see() {
    let message = everything_free_message("delta-probe.yaml");
    // 18 unknowns; heights cannot see where the printer stands in x and y, how it is turned
    // about z, nor the z datum; a common scale of every length and gain only nearly (the held
    // effector joints and nozzle offset are lengths too).
    assert!(message.contains("rank 14 of 18"), "{message}");
    for name in ["t1x", "t2y", "frame_z", "h0_1"] {
        assert!(message.contains(name), "{name} named: {message}");
    }
    let (unseen, least) = motions_named(&message);
    assert_eq!(
        unseen,
        "translation along x, translation along y, translation along z, rotation about z"
    );
    assert!(least.starts_with("≈ scale ("), "{least}");
}

#[test]
fn with_distances_the_rank_check_finds_scale_seen() {
    let message = everything_free_message("delta-probe-distances.yaml");
    // Distances see the printer's size: the same four rigid motions stay unseen, scale is no
    // longer what is least seen.
    assert!(message.contains("rank 14 of 18"), "{message}");
    let (unseen, least) = motions_named(&message);
    assert_eq!(
        unseen,
        "translation along x, translation along y, translation along z, rotation about z"
    );
    assert!(!least.contains("scale"), "{least}");
}

#[test]
fn forward_rows_need_every_reading_and_no_leg_label() {
    let mechanism = bundled("delta-probe.yaml");
    let path = std::path::Path::new("probe.csv");
    let header = "leg,z.nozzle,C1,C2,C3\n";
    let missing = format!("{header},0.0,0.27,0.28,\n");
    let message = observations::parse(&missing, path, &mechanism)
        .expect_err("a missing reading")
        .to_string();
    assert!(
        message.contains("probe.csv") && message.contains("line 2") && message.contains("`C3`"),
        "{message}"
    );
    let labelled = format!("{header}leg1,0.0,0.27,0.28,0.29\n");
    let message = observations::parse(&labelled, path, &mechanism)
        .expect_err("a labelled row")
        .to_string();
    assert!(message.contains("line 2, column `leg`"), "{message}");
}

#[test]
fn a_row_whose_forward_kinematics_does_not_close_is_named() {
    let mechanism = bundled("delta-probe.yaml");
    let text = "z.nozzle,C1,C2,C3\n0.0,0.29,0.29,0.29\n0.0,0.29,0.29,5.0\n";
    let observations =
        observations::parse(text, std::path::Path::new("probe.csv"), &mechanism).unwrap();
    let message = identify_shared(&mechanism, &observations, Strategy::Joint)
        .expect_err("a reading beyond reach")
        .to_string();
    assert!(message.contains("measurement line 3"), "{message}");
}

#[test]
fn coordinates_and_touches_are_for_forward_models_only() {
    let base = std::fs::read_to_string(crate_path("models/delta-probe.yaml")).unwrap();
    let inverse = base.replace("  kinematics: forward\n", "");
    let message = parse_model(&inverse)
        .expect_err("[z] needs forward")
        .to_string();
    assert!(
        message.contains("instrument.targets[0].measures")
            && message.contains("kinematics: forward"),
        "{message}"
    );
    let position = base.replace(
        "measures: [z], touch: 0.0",
        "measures: position, touch: 0.0",
    );
    let message = parse_model(&position)
        .expect_err("a touch of three coordinates")
        .to_string();
    assert!(message.contains("instrument.targets[0].touch"), "{message}");
    let unknown = base.replace("kinematics: forward", "kinematics: sideways");
    let message = parse_model(&unknown)
        .expect_err("an unknown kind")
        .to_string();
    assert!(
        message.contains("instrument.kinematics") && message.contains("sideways"),
        "{message}"
    );
}

#[test]
fn distance_rows_round_trip_through_the_csv_and_name_missing_rows() {
    let mechanism = bundled("delta-probe-distances.yaml");
    let (observations, _, _) = experiment(&mechanism, 1.0);
    assert_eq!(observations.distances.len(), 12);
    let text = observations::to_csv(&mechanism, &observations).unwrap();
    let path = std::path::Path::new("distances.csv");
    let read = observations::parse(&text, path, &mechanism).unwrap();
    assert_eq!(read.rows.len(), observations.rows.len());
    for (a, b) in read.distances.iter().zip(&observations.distances) {
        assert_eq!((a.rows, a.value), (b.rows, b.value));
    }
    let direct = identify_shared(&mechanism, &observations, Strategy::Joint).unwrap();
    let through = identify_shared(&mechanism, &read, Strategy::Joint).unwrap();
    let estimates = |r: &StrategyResult| -> Vec<f64> {
        r.legs
            .iter()
            .flat_map(|l| l.parameters.iter().map(|p| p.estimate))
            .collect()
    };
    assert_eq!(estimates(&direct), estimates(&through));
    // A distance naming a row that is not there; one joining a row to itself.
    let header = text.lines().next().unwrap();
    let row = text.lines().nth(1).unwrap();
    let cells = header.split(',').count();
    let distance_row = |from: &str, to: &str| {
        let mut line = vec![""; cells - 3];
        line.extend([from, to, "0.05"]);
        line.join(",")
    };
    let missing = format!("{header}\n{row}\n{}\n", distance_row("t1", "t99"));
    let message = observations::parse(&missing, path, &mechanism)
        .expect_err("no row t99")
        .to_string();
    assert!(
        message.contains("line 3, column `to`") && message.contains("`t99`"),
        "{message}"
    );
    let itself = format!("{header}\n{row}\n{}\n", distance_row("t1", "t1"));
    let message = observations::parse(&itself, path, &mechanism)
        .expect_err("a row to itself")
        .to_string();
    assert!(message.contains("line 3, column `to`"), "{message}");
}

/// A distance row whose distance is empty (a NaN from Python) is named by its `distance` cell,
/// not as a missing reading of the first leg.
#[test]
fn a_distance_row_without_its_distance_names_the_distance_column() {
    let mechanism = bundled("delta-probe-distances.yaml");
    let (observations, _, _) = experiment(&mechanism, 1.0);
    let text = observations::to_csv(&mechanism, &observations).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    // The columns end with `from`, `to`, `distance`: a distance row names a `to`.
    let at = lines
        .iter()
        .position(|l| {
            l.rsplit(',')
                .nth(1)
                .is_some_and(|to| !to.is_empty() && to != "to")
        })
        .expect("a distance row");
    let emptied = lines[at].rsplit_once(',').unwrap().0.to_string() + ",";
    lines[at] = &emptied;
    let path = std::path::Path::new("distances.csv");
    let message = observations::parse(&(lines.join("\n") + "\n"), path, &mechanism)
        .expect_err("a distance row without its distance")
        .to_string();
    assert!(
        message.starts_with(&format!(
            "distances.csv: line {}, column `distance`: missing distance",
            at + 1
        )),
        "{message}"
    );
}

#[test]
fn readings_may_be_logged_as_the_commanded_pose_of_the_nominal_model() {
    use legwise::kinematics::platform::forward;
    let mechanism = bundled("delta-probe.yaml");
    let (observations, _, _) = experiment(&mechanism, 1.0);
    let nominal = mechanism.nominal_parameters();
    // Each row as a controller running the nominal model logs it: the pose it commanded (the
    // nominal forward kinematics of the readings), no reading.
    let mut text = String::from("z.nozzle,C1,C2,C3,pose.x,pose.y,pose.z\n");
    for row in &observations.rows {
        let readings: Vec<f64> = row.readings.iter().map(|r| r.unwrap()).collect();
        let pose = forward(&mechanism, &nominal, &readings).unwrap();
        text.push_str(&format!(
            "{},,,,{},{},{}\n",
            row.observed[0], pose[0], pose[1], pose[2]
        ));
    }
    let path = std::path::Path::new("commanded.csv");
    let read = observations::parse(&text, path, &mechanism).unwrap();
    for (a, b) in read.rows.iter().zip(&observations.rows) {
        for (x, y) in a.readings.iter().zip(&b.readings) {
            let (x, y) = (x.unwrap(), y.unwrap());
            assert!((x - y).abs() <= 1e-12, "reading {x} against {y}");
        }
    }
    let direct = identify_shared(&mechanism, &observations, Strategy::Joint).unwrap();
    let commanded = identify_shared(&mechanism, &read, Strategy::Joint).unwrap();
    for (a, b) in commanded.parameters().zip(direct.parameters()) {
        assert!(
            (a.estimate - b.estimate).abs() <= 1e-9,
            "{}: {} against {}",
            a.name,
            a.estimate,
            b.estimate
        );
    }
    // A commanded pose the nominal model cannot reach: named by its line and column.
    let beyond =
        "z.nozzle,C1,C2,C3,pose.x,pose.y,pose.z\n0.0,,,,0.0,0.0,0.03\n0.0,,,,0.5,0.0,0.03\n";
    let message = observations::parse(beyond, path, &mechanism)
        .expect_err("beyond reach")
        .to_string();
    assert!(
        message.contains("commanded.csv")
            && message.contains("line 3, column `pose.x`")
            && message.contains("cannot reach the commanded pose"),
        "{message}"
    );
    // A commanded pose with a coordinate missing.
    let partial = "z.nozzle,C1,C2,C3,pose.x,pose.y,pose.z\n0.0,,,,0.01,,0.03\n";
    let message = observations::parse(partial, path, &mechanism)
        .expect_err("pose.y missing")
        .to_string();
    assert!(message.contains("line 2, column `pose.y`"), "{message}");
}

/// The nozzle's position at `readings` with every leg's parameters `params` (the bed frame is
/// the base frame: the probe models hold it at zero), by legwise's forward kinematics.
fn nozzle(mechanism: &Mechanism, params: &[Vec<f64>], readings: &[f64]) -> [f64; 3] {
    let pose = legwise::kinematics::platform::forward(mechanism, params, readings).unwrap();
    [pose[0], pose[1], pose[2] - 0.02]
}

#[test]
fn the_predicted_position_sigma_is_the_covariance_carried_by_central_differences() {
    use legwise::evaluate::accuracy::{map_slice, result_parameters};
    use legwise::kinematics::inverse::predict_reading;
    for model in ["delta-probe.yaml", "delta-probe-distances.yaml"] {
        let mechanism = bundled(model);
        let (observations, _, _) = experiment(&mechanism, 1.0);
        let result = identify_shared(&mechanism, &observations, Strategy::Joint).unwrap();
        let instrument = result.instrument.as_ref().unwrap();
        let reported = instrument.predicted_position.as_ref().expect("predicted");

        let covariance = instrument.covariance.as_ref().expect("a covariance");
        // The unknowns: every identified leg parameter (the bed is held).
        let params = result_parameters(&mechanism, &result);
        let unknowns: Vec<(usize, usize)> = mechanism
            .legs
            .iter()
            .enumerate()
            .flat_map(|(l, leg)| leg.identified().into_iter().map(move |c| (l, c)))
            .collect();
        assert_eq!(unknowns.len(), covariance.nrows(), "{model}");
        let home = mechanism.home_pose;
        // The workspace sample: the map's lattice on every slice of the cylinder (z from 0
        // to 0.1 m, shrunk by 0.95 about 0.05) at the grid's spacing, where the nozzle (0.02 m
        // under the effector) is above the bed.
        let spacing = mechanism.workspace.grid.unwrap();
        let grid: Vec<[f64; 6]> = (0..5)
            .flat_map(|k| {
                let z = 0.05 + (k as f64 - 2.0) * spacing;
                map_slice(&mechanism, spacing, 0.95, (z, 0.05 + (z - 0.05) / 0.95)).unwrap()
            })
            .filter(|pose| pose[2] - 0.02 > 0.0)
            .collect();
        assert_eq!(grid.len(), 180, "{model}");
        let mut jacobian = DMatrix::zeros(3 * grid.len(), unknowns.len());
        let mut motions = DMatrix::zeros(3 * grid.len(), 3);
        for (i, pose) in grid.iter().enumerate() {
            let readings: Vec<f64> = mechanism
                .legs
                .iter()
                .zip(&params)
                .map(|(leg, phi)| predict_reading(leg, phi, pose, &home).unwrap())
                .collect();
            for (j, &(l, c)) in unknowns.iter().enumerate() {
                let h = 1e-6;
                let (mut up, mut down) = (params.clone(), params.clone());
                up[l][c] += h;
                down[l][c] -= h;
                let (a, b) = (
                    nozzle(&mechanism, &up, &readings),
                    nozzle(&mechanism, &down, &readings),
                );
                for k in 0..3 {
                    jacobian[(3 * i + k, j)] = (a[k] - b[k]) / (2.0 * h);
                }
            }
            // What a probe cannot see: the bed frame moved along x, y and turned about z moves
            // the nozzle, seen from it, by -e_x, -e_y and -(e_z × m).
            let m = nozzle(&mechanism, &params, &readings);
            motions[(3 * i, 0)] = -1.0;
            motions[(3 * i + 1, 1)] = -1.0;
            motions[(3 * i, 2)] = m[1];
            motions[(3 * i + 1, 2)] = -m[0];
        }
        // The least-squares fit by the motions from the normal equations (three independent
        // columns; nalgebra's SVD solve of this 540 × 3 matrix was seen to go wrong).
        let normal = (motions.transpose() * &motions).try_inverse().unwrap();
        let along = normal * motions.transpose() * &jacobian;
        let seen = &jacobian - &motions * along;
        let sigmas: Vec<f64> = (0..grid.len())
            .map(|i| {
                let block = seen.rows(3 * i, 3).into_owned();
                (&block * covariance * block.transpose()).trace().sqrt()
            })
            .collect();
        let rms = (sigmas.iter().map(|s| s * s).sum::<f64>() / sigmas.len() as f64).sqrt();
        let max = sigmas.iter().copied().fold(0.0, f64::max);
        assert_eq!(reported.points, grid.len(), "{model}");
        for (what, ours, theirs) in [("RMS", rms, reported.rms), ("max", max, reported.max)] {
            assert!(
                (ours - theirs).abs() <= 1e-6 * theirs,
                "{model}: predicted σ {what} {theirs} against {ours} by central differences"
            );
        }
        assert_eq!(reported.tolerance, Some(1e-4));
    }
}

#[test]
fn observations_made_in_memory_with_a_distance_to_a_missing_row_are_refused() {
    let mechanism = bundled("delta-probe-distances.yaml");
    let (mut observations, _, _) = experiment(&mechanism, 1.0);
    observations.distances[0].rows = [0, observations.rows.len() + 5];
    let message = identify_shared(&mechanism, &observations, Strategy::Joint)
        .expect_err("a distance to a missing row")
        .to_string();
    assert!(
        message.contains("a distance joins two different rows"),
        "{message}"
    );
    // Evaluating them is refused alike (not an index out of range), and so is a distance of
    // no finite length.
    let evaluate = legwise::evaluate::through_instrument::evaluate_observed;
    let message = evaluate(&mechanism, &observations)
        .expect_err("a distance to a missing row")
        .to_string();
    assert!(
        message.contains("distance 0: a distance joins"),
        "{message}"
    );
    let (mut observations, _, _) = experiment(&mechanism, 1.0);
    observations.distances[1].value = f64::NAN;
    let message = evaluate(&mechanism, &observations)
        .expect_err("a NaN distance")
        .to_string();
    assert!(
        message.contains("distance 1: a distance joins"),
        "{message}"
    );
    let (mut observations, _, _) = experiment(&mechanism, 1.0);
    observations.rows[3].readings.pop();
    let message = identify_shared(&mechanism, &observations, Strategy::Joint)
        .expect_err("a row with two readings")
        .to_string();
    assert!(
        message.contains("row 3: 2 readings for the 3 legs"),
        "{message}"
    );
}

#[test]
fn evaluate_reports_the_error_of_held_out_distances() {
    use legwise::evaluate::through_instrument::evaluate_observed;
    let model = bundled("delta-probe-distances.yaml");
    // Held-out rows of the real printer without noise: the real model explains every distance.
    let (held_out, legs, _) = experiment_at(&exact(&model), 0.0, PoseSource::Random, Some(42));
    assert_eq!(held_out.distances.len(), 12);
    let real = exact(&model).edited(|parts| {
        for (leg, values) in parts.legs.iter_mut().zip(&legs) {
            for (p, &value) in leg.params.iter_mut().zip(values) {
                p.nominal = value;
            }
        }
    });
    let exact_fit = evaluate_observed(&real, &held_out).unwrap();
    assert_eq!(exact_fit.distances, 12);
    assert!(exact_fit.distance_error.unwrap().max <= 1e-12);
    // The nominal printer misjudges them: |its distance − the measured one|, recomputed from
    // its forward kinematics and the nozzle's offset.
    let nominal = evaluate_observed(&model, &held_out).unwrap();
    let params = model.nominal_parameters();
    let readings = |r: usize| -> Vec<f64> {
        held_out.rows[r]
            .readings
            .iter()
            .map(|v| v.unwrap())
            .collect()
    };
    let errors: Vec<f64> = held_out
        .distances
        .iter()
        .map(|d| {
            let [a, b] = d.rows.map(|r| nozzle(&model, &params, &readings(r)));
            let length = (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
            (length - d.value).abs()
        })
        .collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    let stats = nominal.distance_error.unwrap();
    assert!(
        (stats.rms - rms).abs() <= 1e-12 * rms,
        "{} vs {rms}",
        stats.rms
    );
    assert!(
        rms > 1e-4,
        "the nominal printer is a fraction of a millimetre off: {rms}"
    );
    // The JSON report carries them (docs/report.md); an evaluation without distances does not.
    let json = legwise::report::evaluation::evaluation_json(&nominal, None);
    assert_eq!(json["distances"], 12);
    assert_eq!(json["distance_error_m"]["rms"].as_f64(), Some(stats.rms));
    let probe = bundled("delta-probe.yaml");
    let (heights, _, _) = experiment_at(&probe, 0.0, PoseSource::Random, None);
    let no_distances = evaluate_observed(&probe, &heights).unwrap();
    let json = legwise::report::evaluation::evaluation_json(&no_distances, None);
    assert!(json.get("distances").is_none() && json.get("distance_error_m").is_none());
}

#[test]
fn a_distance_carries_the_noise_of_its_rows_readings_as_perturbing_the_data_shows() {
    // Noisy readings: a distance and the touches of its two rows move with the same readings.
    let mechanism = bundled("delta-probe-distances.yaml").edited(|parts| {
        if let Some(noise) = parts.noise.as_mut() {
            noise.reading = 2e-5;
        }
    });
    let (data, _, _) = experiment(&mechanism, 1.0);
    assert!(!data.distances.is_empty());
    let problem = IdentificationProblem::through_instrument(&mechanism, &data).unwrap();
    let x = problem.start();
    let noise = mechanism.noise.expect("declared noise");
    let (_, jacobian) = problem.residuals_and_jacobian(&x).unwrap();
    let loadings = problem.noise_loadings(&x, &noise).unwrap();
    let w = crate::mixed_observations::loadings_by_perturbation(&mechanism, &data, &x, &noise);
    let v = &w * w.transpose();
    // V itself (its correlations included), then Jᵀ V J, both ways.
    let touches = jacobian.nrows() - data.distances.len();
    for (k, distance) in data.distances.iter().enumerate() {
        let d = touches + k;
        for (row, other) in distance.rows.iter().enumerate() {
            let by_data = v[(d, *other)];
            assert!(by_data.abs() > 1e-14, "distance {k}, row {row}: correlated");
        }
    }
    let meat = loadings.meat(&jacobian);
    let by_data = jacobian.transpose() * &v * &jacobian;
    let gap = (&meat - &by_data).amax() / by_data.amax();
    assert!(gap <= 1e-6, "Jᵀ V J: {gap:.2e} relative");
    let variances = loadings.variances();
    for (i, variance) in variances.iter().enumerate() {
        let expected = v[(i, i)];
        assert!(
            (variance - expected).abs() <= 1e-6 * expected,
            "residual {i}: variance {variance:.6e} vs {expected:.6e} from the data"
        );
    }
}
