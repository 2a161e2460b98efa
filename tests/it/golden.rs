//! Golden values of the bundled 5R (docs/method.md §9).
use approx::assert_relative_eq;
use legwise::kinematics::inverse::predict_reading;

use crate::support::bundled;

const MIW_CENTRE: [f64; 6] = [0.0, 1.0956521739130435, 0.0, 0.0, 0.0, 0.0];

#[test]
fn readings_at_the_miw_centre_match_the_golden_values() {
    let mech = bundled("5r.yaml");
    for leg in &mech.legs {
        let psi = predict_reading(leg, &leg.nominal(), &MIW_CENTRE, &mech.home_pose).unwrap();
        assert_relative_eq!(psi, 2.2528832244, epsilon = 1e-9);
    }
}

#[test]
fn forward_kinematics_golden_values_hold_with_nominal_and_real_parameters() {
    use legwise::kinematics::platform::forward;
    use legwise::measure::simulate::real_parameters;
    let mech = bundled("5r.yaml");
    let readings = [2.2528832244, 2.2528832244];
    let nominal = mech.nominal_parameters();
    let pose = forward(&mech, &nominal, &readings).unwrap();
    assert_relative_eq!(pose[0], 0.0, epsilon = 1e-9);
    assert_relative_eq!(pose[1], 1.0956521739, epsilon = 1e-9);
    let simulation = mech.simulation.as_ref().unwrap();
    let real = real_parameters(&mech, simulation, simulation.seed);
    let pose = forward(&mech, &real, &readings).unwrap();
    assert_relative_eq!(pose[0], -0.0070014795, epsilon = 1e-9);
    assert_relative_eq!(pose[1], 1.0908703413, epsilon = 1e-9);
    let error = (pose[0].powi(2) + (pose[1] - 1.0956521739).powi(2)).sqrt();
    assert_relative_eq!(error, 8.4786e-3, epsilon = 1e-7);
}

#[test]
fn identification_jacobian_rows_match_the_closed_form_golden_rows() {
    use legwise::identify::jacobian::reading_gradient;
    let mech = bundled("5r.yaml");
    let cases = [
        (
            MIW_CENTRE,
            [
                [
                    -0.2653426423,
                    1.3594794944,
                    1.2022875474,
                    0.6345779299,
                    -2.2528832244,
                    -1.0,
                ],
                [
                    -0.2653426423,
                    1.3594794944,
                    -1.2022875474,
                    0.6345779299,
                    2.2528832244,
                    1.0,
                ],
            ],
        ),
        (
            [0.2, 1.3, 0.0, 0.0, 0.0, 0.0],
            [
                [
                    0.3398194472,
                    1.3759560438,
                    1.1641703502,
                    0.7334592218,
                    -1.8834508571,
                    -1.0,
                ],
                [
                    0.0060606687,
                    1.3333471077,
                    -0.9782967393,
                    0.9059525370,
                    2.3132736910,
                    1.0,
                ],
            ],
        ),
    ];
    for (pose, rows) in cases {
        for (leg, row) in mech.legs.iter().zip(rows) {
            let (_, gradient) = reading_gradient(
                leg,
                &leg.nominal(),
                &leg.identified(),
                &pose,
                &mech.home_pose,
            )
            .unwrap();
            for (g, expected) in gradient.iter().zip(row) {
                assert_relative_eq!(*g, expected, epsilon = 1e-9);
            }
        }
    }
}

#[test]
fn singularity_measures_match_the_closed_forms_of_the_5r() {
    use legwise::kinematics::singularity::{serial_measure, ParallelMeasure};
    let mech = bundled("5r.yaml");
    let nominal = mech.nominal_parameters();
    let parallel = ParallelMeasure::new(&mech, nominal.clone()).unwrap();
    // At the MIW centre: B1 = (−0.97281, 0.58219), B2 = (0.97281, 0.58219) (docs/method.md §9).
    let (p, b1, b2): ([f64; 2], [f64; 2], [f64; 2]) =
        ([0.0, 1.0956521739], [-0.97281, 0.58219], [0.97281, 0.58219]);
    let u1 = [(p[0] - b1[0]) / 1.1, (p[1] - b1[1]) / 1.1];
    let u2 = [(p[0] - b2[0]) / 1.1, (p[1] - b2[1]) / 1.1];
    let s_ii = (u1[0] * u2[1] - u1[1] * u2[0]).abs();
    assert_relative_eq!(parallel.at(&MIW_CENTRE).unwrap(), s_ii, epsilon = 1e-4);
    // Serial measure of leg 1: l sin β / |P − A1|, β between A1→B1 and B1→P.
    let a1b1 = [(b1[0] + 0.5) / 0.75, b1[1] / 0.75];
    let sin_beta = (a1b1[0] * u1[1] - a1b1[1] * u1[0]).abs();
    let reach = (0.5f64.powi(2) + p[1].powi(2)).sqrt();
    let serial = serial_measure(&mech, 0, &nominal[0], &MIW_CENTRE).unwrap();
    assert_relative_eq!(serial, 0.75 * sin_beta / reach, epsilon = 1e-4);
    // The type-II locus crosses the symmetry axis at (0, 0.45) (docs/method.md §9).
    let near = |y: f64| parallel.at(&[0.0, y, 0.0, 0.0, 0.0, 0.0]).unwrap();
    assert!(near(0.46) > 0.0 && near(0.44) < 0.0 && near(0.4501).abs() < 1e-3);
}
