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
