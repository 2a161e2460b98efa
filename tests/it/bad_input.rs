use legwise::identify::estimate::{identify, Strategy};
use legwise::measure::file::read;
use legwise::model::Mechanism;
use legwise::solver::SolverKind;

use crate::support::{bundled, crate_path};

#[test]
fn probe() {
    for m in ["5r_ok", "5r_syntax_error", "5r_unknown_field", "5r_missing_urdf", "5r_chain_joint_not_in_urdf", "5r_parameter_joint_not_in_urdf", "5r_broken_urdf"] {
        let r = Mechanism::load(&crate_path(&format!("tests/data/{m}.yaml")));
        println!("{m}: {:?}", r.map(|_| ()).map_err(|e| e.to_string()));
    }
    let mech = bundled("5r.yaml");
    for c in ["valid", "header_only", "non_numeric", "nan_cell", "missing_column", "unknown_leg", "short_row", "unreachable", "same_distance", "five_poses"] {
        let r = read(&crate_path(&format!("tests/data/{c}.csv")), &mech).and_then(|d| identify(&mech, &d, Strategy::DivideAndConquer, SolverKind::GaussNewton));
        println!("{c}: {:?}", r.map(|r| r.legs.iter().map(|l| l.parameters.iter().map(|p| (p.estimate, p.std)).collect::<Vec<_>>()).collect::<Vec<_>>()).map_err(|e| e.to_string()));
    }
}
