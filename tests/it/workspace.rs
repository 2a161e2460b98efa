//! The usable workspace: the MIW of the bundled 5R (algorithms.md §1.6).
use legwise::workspace::miw::{maximal_inscribed_workspace, MiwOptions};

use crate::support::bundled;

#[test]
fn the_5r_maximal_inscribed_workspace_matches_the_closed_form() {
    let mech = bundled("5r.yaml");
    let options = MiwOptions {
        rays: 360,
        ..MiwOptions::for_mechanism(&mech)
    };
    let miw = maximal_inscribed_workspace(&mech, options).unwrap();
    assert!(miw.centre[0].abs() < 1e-4, "centre {:?}", miw.centre);
    assert!(
        (miw.centre[1] - 1.0956522).abs() < 1e-4,
        "centre {:?}",
        miw.centre
    );
    assert!(
        (miw.radius - 0.6456522).abs() < 1e-4,
        "radius {}",
        miw.radius
    );
}
