//! Golden values of algorithms.md §9.6 and §2.1 for the bundled 5R.
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
    let nominal: Vec<Vec<f64>> = mech.legs.iter().map(|l| l.nominal()).collect();
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
