//! The usable workspace: the MIW of the bundled 5R (docs/method.md §8, §9).
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

#[test]
fn the_5r_candidate_pool_is_the_grid_inside_the_usable_disc() {
    use legwise::workspace::candidates::candidate_pool;
    let mech = bundled("5r.yaml");
    let pool = candidate_pool(&mech, None).unwrap();
    // The lattice from the usable disc's lower-left corner, counted independently.
    let (centre, radius) = ([0.0, 1.0956521739], 0.95 * 0.6456521739);
    let lattice = (0..=61)
        .flat_map(|i| (0..=61).map(move |j| (i, j)))
        .filter(|&(i, j)| {
            let x = -radius + 0.02 * i as f64 - centre[0];
            let y = centre[1] - radius + 0.02 * j as f64 - centre[1];
            x * x + y * y <= radius * radius - 1e-12
        })
        .count();
    assert_eq!(pool.inside, lattice);
    // docs/method.md §9: about 2950 (3268 at f = 1, which this alignment reproduces exactly).
    assert!(
        pool.inside.abs_diff(2953) <= 1,
        "{} grid points",
        pool.inside
    );
    assert_eq!(
        pool.candidates.len() + pool.unreachable + pool.near_serial + pool.near_parallel,
        pool.inside
    );
    assert_eq!(
        pool.candidates.len(),
        pool.inside,
        "every point of the usable disc is feasible"
    );
    // The usable disc's closest approach to the type-II singularity is its bottom point, where
    // docs/method.md §9 gives min |s_II| = 0.058; no candidate is closer.
    use legwise::kinematics::singularity::ParallelMeasure;
    let nominal = mech.nominal_parameters();
    let measure = ParallelMeasure::new(&mech, nominal).unwrap();
    let bottom = measure
        .at(&[0.0, centre[1] - radius, 0.0, 0.0, 0.0, 0.0])
        .unwrap();
    assert!(
        (bottom - 0.058).abs() < 1e-3,
        "s_II at the bottom point {bottom}"
    );
    let smallest = pool
        .candidates
        .iter()
        .filter_map(|c| c.parallel)
        .fold(f64::INFINITY, f64::min);
    assert!(
        smallest >= bottom,
        "min parallel measure over the pool {smallest}"
    );
}

#[test]
fn the_3rpr_candidate_pool_varies_the_orientation() {
    use legwise::workspace::candidates::candidate_pool;
    let mech = bundled("3rpr.yaml");
    let pool = candidate_pool(&mech, None).unwrap();
    // docs/method.md §10: a 0.05 m grid in the 0.2 m disc (49 points) × 9 orientations.
    assert_eq!(pool.inside, 441);
    assert_eq!(
        pool.candidates.len(),
        441,
        "the disc is type-II-free for |yaw| <= 30 deg"
    );
    let yaws: std::collections::BTreeSet<i64> = pool
        .candidates
        .iter()
        .map(|c| (c.pose[5] * 1e6).round() as i64)
        .collect();
    assert_eq!(yaws.len(), 9);
}
