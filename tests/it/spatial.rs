//! The spatial models (models/delta.yaml, models/hexapod.yaml) against closed forms written
//! here from the mechanisms' definitions alone: a hexapod leg's length is |p + R·b − a|, a delta
//! carriage sits a rod length from its effector joint. The model files must match the
//! definitions; leg IK, the dual-number Jacobian, zero-noise identification and the strategies
//! are checked against those closed forms; bad spatial input is refused with a clear message.
use std::f64::consts::PI;
use std::path::Path;

use legwise::identify::estimate::{identify, Strategy};
use legwise::identify::jacobian::reading_gradient;
use legwise::kinematics::inverse::predict_reading;
use legwise::measure::{MeasuredPose, MeasurementSet};
use legwise::model::Mechanism;
use legwise::selection::candidates::candidate_pool;
use legwise::solver::SolverKind;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::cli::{legwise, text};
use crate::support::{bundled, crate_path};

// ---------------------------------------------------------------- closed forms

/// `R = Rz(yaw)·Ry(pitch)·Rx(roll)` (fixed axes), written out.
pub(crate) fn rotation(roll: f64, pitch: f64, yaw: f64) -> [[f64; 3]; 3] {
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let (sy, cy) = yaw.sin_cos();
    let rz = [[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]];
    let ry = [[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]];
    let rx = [[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]];
    product(&product(&rz, &ry), &rx)
}

fn product(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// The platform point `p + R·b` of a pose `[x, y, z, roll, pitch, yaw]`.
pub(crate) fn platform_point(pose: &[f64; 6], b: [f64; 3]) -> [f64; 3] {
    let r = rotation(pose[3], pose[4], pose[5]);
    std::array::from_fn(|i| pose[i] + (0..3).map(|k| r[i][k] * b[k]).sum::<f64>())
}

/// Hexapod leg reading for `phi = [ax, ay, az, bx, by, bz, k, rho0]`: `(|p + R·b − a| − rho0) / k`.
pub(crate) fn hexapod_reading(phi: &[f64], pose: &[f64; 6]) -> f64 {
    let point = platform_point(pose, [phi[3], phi[4], phi[5]]);
    let length = (0..3)
        .map(|i| (point[i] - phi[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    (length - phi[7]) / phi[6]
}

/// Delta carriage reading for `phi = [tx, ty, L, k, h0, ex, ey]` (effector joint at height 0 in
/// the effector frame): the carriage height `h` on the line through (tx, ty) parallel to z with
/// `|(tx, ty, h) − (p + e)| = L`, above the effector; reading `(h − h0) / k`.
pub(crate) fn delta_reading(phi: &[f64], pose: &[f64; 6]) -> f64 {
    let (dx, dy) = (phi[0] - pose[0] - phi[5], phi[1] - pose[1] - phi[6]);
    let height = pose[2] + (phi[2].powi(2) - dx * dx - dy * dy).sqrt();
    (height - phi[4]) / phi[3]
}

// ---------------------------------------------------------------- the definitions

const DELTA_ANGLES: [f64; 3] = [90.0, 210.0, 330.0];
const HEXAPOD_BASE: [f64; 6] = [350.0, 10.0, 110.0, 130.0, 230.0, 250.0];
const HEXAPOD_PLATFORM: [f64; 6] = [310.0, 50.0, 70.0, 170.0, 190.0, 290.0];

pub(crate) fn on_circle(radius: f64, degrees: f64) -> (f64, f64) {
    let angle = degrees * PI / 180.0;
    (radius * angle.cos(), radius * angle.sin())
}

/// Nominal delta leg `i` (0-based): towers at 0.175 m, effector joints at 0.035 m, rods 0.3 m.
fn delta_nominal(i: usize) -> Vec<f64> {
    let (tx, ty) = on_circle(0.175, DELTA_ANGLES[i]);
    let (ex, ey) = on_circle(0.035, DELTA_ANGLES[i]);
    vec![tx, ty, 0.3, 1.0, 0.0, ex, ey]
}

/// Nominal hexapod leg `i` (0-based): a at 0.5 m, z = 0; b at 0.25 m; k = 1, rho0 = 0.5 m.
fn hexapod_nominal(i: usize) -> Vec<f64> {
    let (ax, ay) = on_circle(0.5, HEXAPOD_BASE[i]);
    let (bx, by) = on_circle(0.25, HEXAPOD_PLATFORM[i]);
    vec![ax, ay, 0.0, bx, by, 0.0, 1.0, 0.5]
}

/// A spatial model with its closed-form reading and nominal geometry.
pub(crate) struct Spatial {
    pub(crate) file: &'static str,
    pub(crate) reading: fn(&[f64], &[f64; 6]) -> f64,
    nominal: fn(usize) -> Vec<f64>,
    names: &'static [&'static str],
}

pub(crate) const MODELS: [Spatial; 2] = [
    Spatial {
        file: "delta.yaml",
        reading: delta_reading,
        nominal: delta_nominal,
        names: &["t{}x", "t{}y", "L{}", "k{}", "h0_{}", "e{}x", "e{}y"],
    },
    Spatial {
        file: "hexapod.yaml",
        reading: hexapod_reading,
        nominal: hexapod_nominal,
        names: &[
            "a{}x", "a{}y", "a{}z", "b{}x", "b{}y", "b{}z", "k{}", "rho0_{}",
        ],
    },
];

/// Poses spread over each model's declared workspace, drawn here (not by legwise): the delta's
/// cylinder (radius 0.08 m about z, z in [0, 0.1] m), the hexapod's box (|x|, |y| <= 0.05 m,
/// z in [0.55, 0.65] m, each angle within ±0.15 rad).
pub(crate) fn spread_poses(file: &str, count: usize, seed: u64) -> Vec<[f64; 6]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut poses = Vec::new();
    while poses.len() < count {
        let pose = if file == "delta.yaml" {
            let (x, y) = (rng.random_range(-0.08..0.08), rng.random_range(-0.08..0.08));
            if f64::hypot(x, y) > 0.08 {
                continue;
            }
            [x, y, rng.random_range(0.0..0.1), 0.0, 0.0, 0.0]
        } else {
            let mut pose = [0.0; 6];
            for (c, value) in pose.iter_mut().enumerate() {
                *value = match c {
                    0 | 1 => rng.random_range(-0.05..0.05),
                    2 => rng.random_range(0.55..0.65),
                    _ => rng.random_range(-0.15..0.15),
                };
            }
            pose
        };
        poses.push(pose);
    }
    poses
}

/// Every leg's real parameter vector (the model's `simulation.real`, nominal where absent).
pub(crate) fn real_parameters(mech: &Mechanism) -> Vec<Vec<f64>> {
    let real = &mech.simulation.as_ref().expect("a simulation block").real;
    mech.legs
        .iter()
        .map(|leg| {
            leg.params
                .iter()
                .map(|p| real.get(&p.name).copied().unwrap_or(p.nominal))
                .collect()
        })
        .collect()
}

/// Shared rows (every reading) at `poses`, from the closed form with parameters `params`.
pub(crate) fn closed_form_rows(
    model: &Spatial,
    params: &[Vec<f64>],
    poses: &[[f64; 6]],
    noise: f64,
) -> MeasurementSet {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    MeasurementSet::from_rows(
        None,
        params.len(),
        poses.iter().map(|pose| {
            let row = MeasuredPose {
                line: None,
                leg: None,
                pose: *pose,
            };
            let readings = params
                .iter()
                .map(|phi| {
                    let error = noise * rng.random_range(-1.0..1.0);
                    Some((model.reading)(phi, pose) + error)
                })
                .collect();
            (row, readings)
        }),
    )
}

// ---------------------------------------------------------------- the model files

#[test]
fn the_model_files_hold_the_declared_geometry() {
    for model in &MODELS {
        let mech = bundled(model.file);
        assert_eq!(
            mech.legs.len(),
            if model.file == "delta.yaml" { 3 } else { 6 }
        );
        for (i, leg) in mech.legs.iter().enumerate() {
            assert_eq!(leg.name, format!("leg{}", i + 1));
            let names: Vec<String> = model
                .names
                .iter()
                .map(|n| n.replace("{}", &(i + 1).to_string()))
                .collect();
            let actual: Vec<&str> = leg.params.iter().map(|p| p.name.as_str()).collect();
            assert_eq!(actual, names, "{} parameter names and order", model.file);
            for (p, expected) in leg.params.iter().zip((model.nominal)(i)) {
                assert!(
                    (p.nominal - expected).abs() < 1e-9,
                    "{} {}: nominal {} vs {expected}",
                    model.file,
                    p.name,
                    p.nominal
                );
            }
            let frozen: Vec<&str> = leg
                .params
                .iter()
                .filter(|p| !p.identified)
                .map(|p| p.name.as_str())
                .collect();
            let expected_frozen = if model.file == "delta.yaml" {
                vec![names[5].as_str(), names[6].as_str()]
            } else {
                vec![]
            };
            assert_eq!(frozen, expected_frozen, "{}", model.file);
        }
        let actuated = if model.file == "delta.yaml" { "C" } else { "P" };
        let expected: Vec<String> = (1..=mech.legs.len())
            .map(|i| format!("{actuated}{i}"))
            .collect();
        assert_eq!(mech.actuated_names(), expected);
        // The real geometry is a realistic perturbation: about a millimetre, gains about 1e-3.
        for (leg, real) in mech.legs.iter().zip(real_parameters(&mech)) {
            for (p, value) in leg.params.iter().zip(real) {
                let error = (value - p.nominal).abs();
                assert!(error < 5e-3, "{} {}: {error}", model.file, p.name);
                assert!(error > 0.0 || !p.identified, "{}: not perturbed", p.name);
            }
        }
    }
}

// ---------------------------------------------------------------- leg kinematics

#[test]
fn leg_inverse_kinematics_closes_on_every_leg_at_spread_poses() {
    for model in &MODELS {
        let mech = bundled(model.file);
        let real = real_parameters(&mech);
        for pose in spread_poses(model.file, 40, 1) {
            for (l, leg) in mech.legs.iter().enumerate() {
                for phi in [leg.nominal(), real[l].clone()] {
                    let reading = predict_reading(leg, &phi, &pose, &mech.home_pose)
                        .unwrap_or_else(|e| panic!("{} {} at {pose:?}: {e}", model.file, leg.name));
                    let expected = (model.reading)(&phi, &pose);
                    assert!(
                        (reading - expected).abs() < 1e-10,
                        "{} {} at {pose:?}: legwise {reading} vs closed form {expected}",
                        model.file,
                        leg.name
                    );
                }
            }
        }
    }
}

#[test]
fn the_dual_number_jacobian_matches_central_differences_of_the_closed_form() {
    for model in &MODELS {
        let mech = bundled(model.file);
        for pose in spread_poses(model.file, 10, 2) {
            for leg in &mech.legs {
                let phi = leg.nominal();
                let columns: Vec<usize> = (0..phi.len()).collect();
                let (_, gradient) =
                    reading_gradient(leg, &phi, &columns, &pose, &mech.home_pose).unwrap();
                for (j, g) in gradient.iter().enumerate() {
                    let h = 1e-6;
                    let (mut plus, mut minus) = (phi.clone(), phi.clone());
                    plus[j] += h;
                    minus[j] -= h;
                    let difference = ((model.reading)(&plus, &pose)
                        - (model.reading)(&minus, &pose))
                        / (2.0 * h);
                    assert!(
                        (g - difference).abs() <= 1e-6 * g.abs().max(1.0),
                        "{} {} ∂s/∂{}: dual {g} vs central difference {difference}",
                        model.file,
                        leg.name,
                        leg.params[j].name
                    );
                }
            }
        }
    }
}

// ---------------------------------------------------------------- identification

#[test]
fn zero_noise_identification_recovers_the_real_geometry_with_both_strategies() {
    for model in &MODELS {
        let mech = bundled(model.file);
        let real = real_parameters(&mech);
        let data = closed_form_rows(model, &real, &spread_poses(model.file, 40, 3), 0.0);
        for strategy in [Strategy::DivideAndConquer, Strategy::Traditional] {
            let result = identify(&mech, &data, strategy, SolverKind::LevenbergMarquardt)
                .unwrap_or_else(|e| panic!("{} {strategy:?}: {e}", model.file));
            assert_eq!(result.legs.len(), mech.legs.len());
            for (l, estimate) in result.legs.iter().enumerate() {
                for (p, param) in estimate.parameters.iter().enumerate() {
                    assert!(
                        (param.estimate - real[l][p]).abs() <= 1e-9,
                        "{} {strategy:?} {}: {} but real {}",
                        model.file,
                        param.name,
                        param.estimate,
                        real[l][p]
                    );
                }
            }
        }
    }
}

#[test]
fn divide_and_conquer_equals_all_legs_on_the_same_noisy_poses() {
    for model in &MODELS {
        let mech = bundled(model.file);
        let data = closed_form_rows(
            model,
            &real_parameters(&mech),
            &spread_poses(model.file, 30, 4),
            1e-5,
        );
        let dc = identify(
            &mech,
            &data,
            Strategy::DivideAndConquer,
            SolverKind::GaussNewton,
        )
        .unwrap();
        let all = identify(&mech, &data, Strategy::Traditional, SolverKind::GaussNewton).unwrap();
        for (a, b) in dc.legs.iter().zip(&all.legs) {
            for (p, q) in a.parameters.iter().zip(&b.parameters) {
                assert!(
                    (p.estimate - q.estimate).abs() <= 1e-10 * (1.0 + p.estimate.abs()),
                    "{} {}: D&C {} vs all legs {}",
                    model.file,
                    p.name,
                    p.estimate,
                    q.estimate
                );
            }
        }
        // The noise is visible: the data are not exact, so the agreement is not trivial.
        assert!(dc.legs.iter().all(|leg| leg.final_cost > 0.0));
    }
}

/// Loads a bundled model after replacing text in it (and optionally in its URDF).
pub(crate) fn edited(
    file: &str,
    edits: &[(&str, &str)],
    urdf_edits: &[(&str, &str)],
) -> legwise::error::Result<Mechanism> {
    let path = crate_path(&format!("models/{file}"));
    let urdf_path = path.with_extension("urdf");
    let mut model = std::fs::read_to_string(&path).unwrap();
    let mut urdf = std::fs::read_to_string(&urdf_path).unwrap();
    for (from, to) in edits {
        assert!(model.contains(from), "{file} holds {from:?}");
        model = model.replace(from, to);
    }
    for (from, to) in urdf_edits {
        assert!(urdf.contains(from), "the URDF holds {from:?}");
        urdf = urdf.replace(from, to);
    }
    Mechanism::parse(&model, Path::new(file), &urdf, &urdf_path)
}

#[test]
fn freed_delta_effector_joints_are_reported_unidentifiable_by_name() {
    let mech = edited("delta.yaml", &[(", identify: false", "")], &[]).unwrap();
    assert!(mech
        .legs
        .iter()
        .all(|leg| leg.params.iter().all(|p| p.identified)));
    let model = &MODELS[0];
    let data = closed_form_rows(
        model,
        &real_parameters(&mech),
        &spread_poses(model.file, 40, 5),
        0.0,
    );
    let error = identify(
        &mech,
        &data,
        Strategy::DivideAndConquer,
        SolverKind::GaussNewton,
    )
    .expect_err("t − e is all a translating effector shows")
    .to_string();
    assert!(error.contains("leg `leg1`"), "{error}");
    assert!(error.contains("rank-deficient"), "{error}");
    assert!(error.contains("rank 5 of 7"), "{error}");
    assert!(error.contains("e1x") && error.contains("e1y"), "{error}");
}

// ---------------------------------------------------------------- bad spatial input

#[test]
fn a_chain_with_too_many_unknowns_is_refused_with_the_counts() {
    // The rod's fixed end becomes a revolute: four moving joints for three equations.
    let error = edited(
        "delta.yaml",
        &[],
        &[(
            "<joint name=\"R1\" type=\"fixed\">",
            "<joint name=\"R1\" type=\"continuous\"><axis xyz=\"0 0 1\"/>",
        )],
    )
    .expect_err("four unknowns")
    .to_string();
    assert_eq!(
        error,
        "delta.yaml: field `legs[0].chain`: leg `leg1` has 4 moving joints (C1, U1a, U1b, R1) \
         but 3 closure equations (its tip meets its attachment in x, y and z, since z is \
         measured); a leg needs as many moving joints as closure equations: too many unknowns: \
         make a joint `fixed`, or end the chain at the attachment point and leave out the joints \
         that only turn about it (a spherical joint at the platform)"
    );
    // Without z measured, the same chain has 2 equations.
    let error = edited(
        "hexapod.yaml",
        &[
            (
                "measured: [x, y, z, roll, pitch, yaw]",
                "measured: [x, y, roll, pitch, yaw]",
            ),
            ("z: 0.6, ", ""),
        ],
        &[],
    )
    .expect_err("three unknowns, two equations")
    .to_string();
    assert!(
        error.contains("leg `leg1` has 3 moving joints (U1a, U1b, P1) but 2 closure equations"),
        "{error}"
    );
}

#[test]
fn a_degenerate_platform_is_refused_at_load() {
    // Every platform joint at the platform's centre: the platform turns freely about it.
    let mech = bundled("hexapod.yaml");
    let mut edits: Vec<(String, String)> = Vec::new();
    let model = std::fs::read_to_string(crate_path("models/hexapod.yaml")).unwrap();
    for line in model
        .lines()
        .filter(|l| l.trim_start().starts_with("attachment:"))
    {
        let start = line.find('[').unwrap();
        let end = line.find(']').unwrap();
        edits.push((line[start..=end].to_string(), "[0.0, 0.0, 0.0]".to_string()));
    }
    assert_eq!(edits.len(), mech.legs.len());
    let edits: Vec<(&str, &str)> = edits
        .iter()
        .map(|(a, b)| (a.as_str(), b.as_str()))
        .collect();
    let error = edited("hexapod.yaml", &edits, &[])
        .expect_err("degenerate")
        .to_string();
    assert!(
        error.starts_with(
            "hexapod.yaml: field `legs[*].attachment`: the platform is degenerate at the home pose"
        ),
        "{error}"
    );
}

#[test]
fn spatial_regions_are_validated() {
    let cases: [(&str, &str, &str); 5] = [
        (
            "region: {cylinder: {centre: [0.0, 0.0, 0.05], radius: 0.08, height: 0.1}}",
            "region: {cylinder: {centre: [0.0, 0.0, 0.05], radius: 0.08, height: 0.0}}",
            "field `workspace.region.cylinder`: expected a finite centre [x, y, z], a positive radius and a positive height (metres)",
        ),
        (
            "region: {cylinder: {centre: [0.0, 0.0, 0.05], radius: 0.08, height: 0.1}}",
            "region: {polyhedron: {vertices: [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0]]}}",
            "field `workspace.region.polyhedron`: the vertices enclose no volume",
        ),
        (
            "region: {cylinder: {centre: [0.0, 0.0, 0.05], radius: 0.08, height: 0.1}}",
            "region: {ball: {centre: [0.0, 0.0, 0.05], radius: 0.08}}\n  ranges: {z: [0.0, 0.1]}",
            "field `workspace.ranges.z`: z is given by the spatial region",
        ),
        (
            "region: {cylinder: {centre: [0.0, 0.0, 0.05], radius: 0.08, height: 0.1}}",
            "region: {cuboid: {min: [-0.05, -0.05, 0.1], max: [0.05, 0.05, 0.0]}}",
            "field `workspace.region.cuboid`: expected finite corners [x, y, z] with min < max",
        ),
        (
            "region: {cylinder: {centre: [0.0, 0.0, 0.05], radius: 0.08, height: 0.1}}",
            "region: {ball: {centre: [0.0, 0.0], radius: 0.08}}",
            "delta.yaml: line",
        ),
    ];
    for (from, to, expected) in cases {
        let error = edited("delta.yaml", &[(from, to)], &[])
            .expect_err(to)
            .to_string();
        assert!(error.contains(expected), "{to}: {error}");
    }
    // A spatial region on a planar model.
    let error = edited(
        "3rpr.yaml",
        &[(
            "region: {disc: {centre: [0.0, 0.0], radius: 0.2}}",
            "region: {ball: {centre: [0.0, 0.0, 0.0], radius: 0.2}}",
        )],
        &[],
    )
    .expect_err("no z")
    .to_string();
    assert!(
        error.contains("a spatial region (ball, cuboid, cylinder, polyhedron) needs `z`"),
        "{error}"
    );
}

#[test]
// The cells are decimal literals: parsed, they must be exactly the same doubles.
#[allow(clippy::float_cmp)]
fn spatial_measurement_columns_are_read_and_a_missing_coordinate_is_named() {
    use legwise::measure::file::parse;
    let delta = bundled("delta.yaml");
    let csv = "leg,x,y,z,C1,C2,C3\nleg2,0.01,-0.02,0.05,,0.3,\n,0.0,0.0,0.06,0.31,0.32,0.33\n";
    let data = parse(csv, Path::new("d.csv"), &delta).unwrap();
    assert_eq!(data.len(), 2);
    assert_eq!(data.poses()[0].leg, Some(1));
    assert_eq!(data.poses()[0].pose, [0.01, -0.02, 0.05, 0.0, 0.0, 0.0]);
    assert_eq!(data.readings(0), [None, Some(0.3), None]);
    assert_eq!(data.readings(1), [Some(0.31), Some(0.32), Some(0.33)]);
    let hexapod = bundled("hexapod.yaml");
    let csv = "leg,x,y,z,roll,pitch,yaw,P1,P2,P3,P4,P5,P6\n\
               leg6,0.01,0.02,0.61,0.1,-0.1,0.05,,,,,,0.2\n";
    let data = parse(csv, Path::new("h.csv"), &hexapod).unwrap();
    assert_eq!(data.poses()[0].pose, [0.01, 0.02, 0.61, 0.1, -0.1, 0.05]);
    assert_eq!(data.poses()[0].leg, Some(5));
    let csv = "leg,x,y,z,roll,pitch,P1,P2,P3,P4,P5,P6\nleg6,0.01,0.02,0.61,0.1,-0.1,,,,,,0.2\n";
    let error = parse(csv, Path::new("h.csv"), &hexapod)
        .unwrap_err()
        .to_string();
    assert_eq!(
        error,
        "h.csv: header: missing column `yaw`; expected the columns leg, x, y, z, roll, pitch, yaw, P1, P2, P3, P4, P5, P6"
    );
}

// ---------------------------------------------------------------- the workspace in 3-D

#[test]
fn the_delta_candidates_fill_its_cylinder_on_a_3d_grid() {
    let mech = bundled("delta.yaml");
    let pool = candidate_pool(&mech, None).unwrap();
    // The lattice of spacing 0.02 m from the cylinder's lower corner (-0.08, -0.08, 0), counted
    // here: 9 × 9 points of the square, those within 0.08 m of the axis, times 6 heights.
    let spacing = 0.02;
    let in_disc = (0..9)
        .flat_map(|i| (0..9).map(move |j| (i, j)))
        .filter(|&(i, j)| {
            let (x, y) = (-0.08 + i as f64 * spacing, -0.08 + j as f64 * spacing);
            x.hypot(y) <= 0.08 + 1e-12
        })
        .count();
    assert_eq!(pool.inside, in_disc * 6);
    let mut heights: Vec<f64> = pool.candidates.iter().map(|c| c.pose[2]).collect();
    heights.sort_by(f64::total_cmp);
    heights.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    assert_eq!(heights.len(), 6, "{heights:?}");
    for candidate in &pool.candidates {
        let p = candidate.pose;
        assert!(p[0].hypot(p[1]) <= 0.08 + 1e-12 && (-1e-12..=0.1 + 1e-12).contains(&p[2]));
        assert_eq!(&p[3..], &[0.0; 3]);
    }
}

#[test]
fn the_hexapod_candidates_are_a_3d_grid_times_orientation_levels() {
    let mech = bundled("hexapod.yaml");
    let pool = candidate_pool(&mech, None).unwrap();
    // 5 × 5 × 5 positions (0.025 m in the 0.1 m cube) × 5³ orientations.
    assert_eq!(pool.inside, 125 * 125);
    for candidate in &pool.candidates {
        let p = candidate.pose;
        assert!(p[0].abs() <= 0.05 + 1e-12 && p[1].abs() <= 0.05 + 1e-12);
        assert!((0.55 - 1e-12..=0.65 + 1e-12).contains(&p[2]));
        assert!(p[3..].iter().all(|a| a.abs() <= 0.15 + 1e-12));
    }
    let extreme = |c: usize| {
        pool.candidates
            .iter()
            .map(|k| k.pose[c])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    assert!(
        (extreme(5) - 0.15).abs() < 1e-12,
        "the yaw levels reach the range's end"
    );
}

// ---------------------------------------------------------------- the command line

#[test]
fn identify_recovers_the_delta_from_the_command_line_at_zero_noise() {
    let out = legwise(&[
        "identify",
        "--model",
        "models/delta.yaml",
        "--noise-scale",
        "0",
        "--json",
        "-",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let text = report.to_string();
    let after: Vec<f64> = find_numbers(&report, "parameter_error_rms_after");
    assert_eq!(after.len(), 3, "{text}");
    assert!(after.iter().all(|e| *e <= 1e-9), "{after:?}");
}

/// Every number under key `key`, anywhere in the JSON document.
fn find_numbers(value: &serde_json::Value, key: &str) -> Vec<f64> {
    match value {
        serde_json::Value::Object(map) => map
            .iter()
            .flat_map(|(k, v)| {
                if k == key {
                    v.as_f64().into_iter().collect()
                } else {
                    find_numbers(v, key)
                }
            })
            .collect(),
        serde_json::Value::Array(items) => {
            items.iter().flat_map(|v| find_numbers(v, key)).collect()
        }
        _ => Vec::new(),
    }
}

#[test]
fn a_polyhedron_region_gives_the_same_candidates_as_the_cuboid_it_spans() {
    let corners: Vec<String> = (0..8)
        .map(|k| {
            let pick = |bit: usize, low: f64, high: f64| if k >> bit & 1 == 0 { low } else { high };
            format!(
                "[{}, {}, {}]",
                pick(0, -0.05, 0.05),
                pick(1, -0.05, 0.05),
                pick(2, 0.55, 0.65)
            )
        })
        .collect();
    let polyhedron = format!(
        "region: {{polyhedron: {{vertices: [{}]}}}}",
        corners.join(", ")
    );
    let cuboid = "region: {cuboid: {min: [-0.05, -0.05, 0.55], max: [0.05, 0.05, 0.65]}}";
    // A coarser grid and fewer angle levels keep the pools small: 3³ positions × 2³ angles.
    let coarse = [
        ("grid: 0.025", "grid: 0.05"),
        ("range_levels: 5", "range_levels: 2"),
    ];
    let by_cuboid = edited("hexapod.yaml", &coarse, &[]).unwrap();
    let mut edits = coarse.to_vec();
    edits.push((cuboid, polyhedron.as_str()));
    let by_polyhedron = edited("hexapod.yaml", &edits, &[]).unwrap();
    let a = candidate_pool(&by_cuboid, None).unwrap();
    let b = candidate_pool(&by_polyhedron, None).unwrap();
    assert_eq!(a.inside, 27 * 8);
    assert_eq!(a.inside, b.inside);
    let poses = |pool: &legwise::selection::candidates::CandidatePool| -> Vec<[f64; 6]> {
        pool.candidates.iter().map(|c| c.pose).collect()
    };
    assert_eq!(poses(&a), poses(&b));
}

#[test]
fn bad_spatial_models_exit_2_with_one_line_naming_the_file() {
    let directory = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| std::fs::write(directory.path().join(name), text).unwrap();
    let model = std::fs::read_to_string(crate_path("models/delta.yaml")).unwrap();
    let urdf = std::fs::read_to_string(crate_path("models/delta.urdf")).unwrap();
    write(
        "delta.urdf",
        &urdf.replace(
            "<joint name=\"R2\" type=\"fixed\">",
            "<joint name=\"R2\" type=\"continuous\"><axis xyz=\"0 0 1\"/>",
        ),
    );
    write("delta.yaml", &model);
    let path = directory.path().join("delta.yaml");
    let out = legwise(&["identify", "--model", path.to_str().unwrap()]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with(&format!(
            "legwise: {}: field `legs[1].chain`: leg `leg2` has 4 moving joints (C2, U2a, U2b, R2) but 3 closure equations",
            path.display()
        )),
        "{stderr}"
    );
    // The hexapod's measurements without a yaw column.
    let csv = directory.path().join("no-yaw.csv");
    std::fs::write(
        &csv,
        "leg,x,y,z,roll,pitch,P1,P2,P3,P4,P5,P6\n,0,0,0.6,0,0,0.2,0.2,0.2,0.2,0.2,0.2\n",
    )
    .unwrap();
    let out = legwise(&[
        "identify",
        "--model",
        "models/hexapod.yaml",
        "--measurements",
        csv.to_str().unwrap(),
    ]);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert_eq!(
        stderr,
        format!(
            "legwise: {}: header: missing column `yaw`; expected the columns leg, x, y, z, roll, pitch, yaw, P1, P2, P3, P4, P5, P6\n",
            csv.display()
        )
    );
}

#[test]
fn the_calibrated_delta_reloads_with_the_real_geometry_and_its_cylinder() {
    let directory = tempfile::tempdir().unwrap();
    let calibrated = directory.path().join("calibrated.yaml");
    let out = legwise(&[
        "identify",
        "--model",
        "models/delta.yaml",
        "--noise-scale",
        "0",
        "--calibrated",
        calibrated.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let original = bundled("delta.yaml");
    let reloaded = Mechanism::load(&calibrated).unwrap();
    assert_eq!(reloaded.workspace, original.workspace);
    assert_eq!(reloaded.measured, original.measured);
    for (leg, real) in reloaded.legs.iter().zip(real_parameters(&original)) {
        for (p, value) in leg.params.iter().zip(real) {
            assert!(
                (p.nominal - value).abs() <= 1e-9,
                "{}: {} vs {value}",
                p.name,
                p.nominal
            );
        }
    }
}
