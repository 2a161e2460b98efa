//! The poses of a simulated experiment seen through the forward kinematics
//! (`instrument.kinematics: forward`): rows of every leg's reading at random poses of the usable
//! workspace, and where a target declares a `touch`, each pose moved along the platform
//! coordinate of the target's one coordinate until the real instrument reports the touch value
//! there (a probe lowered onto the real, tilted bed).

use num_dual::Dual64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::observe_simulate::real_shared;
use super::simulate::{reachable_pose, real_parameters, setup, PoseSets, SimulationOptions};
use super::targets::{observe, observe_in};
use crate::error::{Error, Result};
use crate::kinematics::inverse::predict_reading;
use crate::model::instrument::Instrument;
use crate::model::Mechanism;

/// Newton steps a touch may take.
const TOUCH_STEPS: usize = 50;

/// The true poses of a forward experiment: shared rows (every leg's reading), none of a leg's
/// own: at the commanded poses `commanded` (a forward design's) or, without them, at
/// `poses_per_leg` random poses; each moved to its touch on the real surface. Then, with
/// `instrument.poses`, its `simulate` rows whose platform pose is measured (the last rows:
/// [`super::observe_simulate::observed_from`] measures their pose): the last `simulate` of
/// `commanded` (a design's, after its touches), or random poses on home's side of every
/// touch surface.
///
/// # Errors
/// No simulation block, no reachable pose, or a touch the real legs cannot reach (named).
pub fn forward_pose_sets(
    mechanism: &Mechanism,
    instrument: &Instrument,
    options: SimulationOptions,
    commanded: Option<&[[f64; 6]]>,
) -> Result<PoseSets> {
    let simulation = setup(mechanism)?;
    let seed = options.seed.unwrap_or(simulation.seed);
    let measured = instrument.poses.as_ref().map_or(0, |p| p.simulate);
    let rows = match commanded {
        Some(poses) => poses.len().saturating_sub(measured),
        None => options.poses_per_leg.unwrap_or(simulation.poses_per_leg),
    };
    let real = real_parameters(mechanism, simulation, seed);
    let shared = real_shared(instrument, simulation, seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(1));
    let mut poses = Vec::with_capacity(rows);
    for row in 0..rows {
        let pose = match commanded {
            Some(poses) => poses[row],
            None => reachable_pose(mechanism, &real, &mut rng)?,
        };
        let pose = touched(mechanism, instrument, &shared, pose)?;
        reaches_real(mechanism, &real, &pose).map_err(|_| Error::Model {
            path: mechanism.model_path.clone(),
            field: "instrument.targets".into(),
            message: format!(
                "simulation: the touch at pose {} is beyond the real legs' reach: check the \
                 touch value, the target's offset and the frame's height",
                mechanism.pose_text(&pose)
            ),
        })?;
        poses.push(pose);
    }
    // Then the rows of a measured pose (`instrument.poses`), at random poses on the side of
    // every touch surface where the platform starts (a probe above its bed).
    let measured = instrument.poses.as_ref().map_or(0, |p| p.simulate);
    if let Some(poses_measured) = commanded.map(|c| &c[rows..]) {
        for &pose in poses_measured {
            reaches_real(mechanism, &real, &pose)?;
            poses.push(pose);
        }
    }
    let clear = home_side(mechanism, instrument, &shared);
    let mut drawn = 0;
    while poses.len() < rows + measured {
        let pose = reachable_pose(mechanism, &real, &mut rng)?;
        drawn += 1;
        if clear(&pose) {
            poses.push(pose);
        } else if drawn > 1000 * (measured + 1) {
            return Err(Error::Model {
                path: mechanism.model_path.clone(),
                field: "instrument.poses.simulate".into(),
                message: "simulation: hardly a pose of the workspace keeps the targets on the \
                          side of their touch surface where home is: check the workspace and \
                          the touch values"
                    .into(),
            });
        }
    }
    Ok(PoseSets {
        per_leg: vec![Vec::new(); mechanism.legs.len()],
        shared: poses,
    })
}

/// Whether every real leg (parameters `real`) reaches `pose`.
///
/// # Errors
/// A leg that does not, named.
fn reaches_real(mechanism: &Mechanism, real: &[Vec<f64>], pose: &[f64; 6]) -> Result<()> {
    let home = &mechanism.home_pose;
    for (leg, phi) in mechanism.legs.iter().zip(real) {
        if let Err(error) = predict_reading(leg, phi, pose, home) {
            return Err(Error::Model {
                path: mechanism.model_path.clone(),
                field: "instrument.poses".into(),
                message: format!(
                    "simulation: the real leg `{}` cannot reach the measured pose {} ({error})",
                    leg.name,
                    mechanism.pose_text(pose)
                ),
            });
        }
    }
    Ok(())
}

/// Whether a pose puts every touching target of `instrument` (at the shared values `shared`)
/// on the side of its touch surface where it is at home (a probe above its bed): where the
/// platform can be without passing through the surface. What the instrument sees at home is
/// computed once, for every pose the returned test is asked about.
pub(crate) fn home_side<'i>(
    mechanism: &Mechanism,
    instrument: &'i Instrument,
    shared: &'i [f64],
) -> impl Fn(&[f64; 6]) -> bool + 'i {
    let home = observe(instrument, shared, &mechanism.home_pose);
    move |pose: &[f64; 6]| {
        let seen = observe(instrument, shared, pose);
        let mut at = 0;
        instrument.targets.iter().all(|target| {
            let first = at;
            at += target.pose_indices().len();
            target
                .touch
                .is_none_or(|t| (seen[first] - t) * (home[first] - t) > 0.0)
        })
    }
}

/// `pose` moved along the platform coordinate of the touching target's coordinate until the
/// instrument (at the shared values `shared`) reports the touch value (`pose` itself when no
/// target touches).
///
/// # Errors
/// The coordinate is not one the model measures, or Newton's method does not reach the touch.
pub(crate) fn touched(
    mechanism: &Mechanism,
    instrument: &Instrument,
    shared: &[f64],
    mut pose: [f64; 6],
) -> Result<[f64; 6]> {
    let mut at = 0;
    for target in &instrument.targets {
        let indices = target.pose_indices();
        if let Some(touch) = target.touch {
            let c = indices[0];
            if !mechanism.measured.contains(&c) {
                return Err(Error::Model {
                    path: mechanism.model_path.clone(),
                    field: "instrument.targets".into(),
                    message: format!(
                        "target `{}` touches along `{}`, a pose coordinate the model does not \
                         measure",
                        target.name,
                        crate::model::mechanism::COORDINATES[c]
                    ),
                });
            }
            let lifted: Vec<Dual64> = shared.iter().map(|&v| Dual64::from(v)).collect();
            let mut reached = false;
            for _ in 0..TOUCH_STEPS {
                let mut seeded = pose.map(Dual64::from);
                seeded[c] = seeded[c].derivative();
                let value = observe_in(instrument, &lifted, &seeded)[at];
                let gap = value.re - touch;
                if gap.abs() <= 1e-14 * (1.0 + touch.abs()) {
                    reached = true;
                    break;
                }
                if value.eps.abs() < 1e-9 {
                    return Err(Error::Model {
                        path: mechanism.model_path.clone(),
                        field: "instrument.targets".into(),
                        message: format!(
                            "target `{}`: moving the platform along its coordinate does not \
                             change what the instrument reports: no touch",
                            target.name
                        ),
                    });
                }
                pose[c] -= gap / value.eps;
            }
            if !reached {
                return Err(Error::Model {
                    path: mechanism.model_path.clone(),
                    field: "instrument.targets".into(),
                    message: format!(
                        "simulation: target `{}` does not reach its touch value {touch} m near \
                         pose {}",
                        target.name,
                        mechanism.pose_text(&pose)
                    ),
                });
            }
        }
        at += indices.len();
    }
    Ok(pose)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bundled model of touches and measured poses, its bed raised to `touch` (m).
    fn mixed(touch: f64) -> Mechanism {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/delta-probe-poses.yaml");
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace("touch: 0.0,", &format!("touch: {touch},"));
        let urdf_path = path.with_file_name("delta.urdf");
        let urdf = std::fs::read_to_string(&urdf_path).unwrap();
        Mechanism::parse(&text, &path, &urdf, &urdf_path).unwrap()
    }

    #[test]
    fn home_side_is_the_side_of_the_touch_surface_where_home_is() {
        // Home puts the nozzle at 0.03 m (0.02 m under the effector at 0.05), the bed at
        // 0.035 m: a nozzle at 0.032 m is on home's side, one at 0.04 m beyond the bed.
        let mechanism = mixed(0.035);
        let instrument = mechanism.instrument.as_ref().unwrap();
        let shared = instrument.nominal();
        let at = |z: f64| [0.01, -0.02, z, 0.0, 0.0, 0.0];
        let clear = home_side(&mechanism, instrument, &shared);
        assert!(clear(&at(0.052)));
        assert!(!clear(&at(0.06)));
        assert!(!clear(&at(0.055)));
    }

    #[test]
    fn a_measured_pose_the_real_legs_cannot_reach_is_named() {
        let mechanism = mixed(0.0);
        let instrument = mechanism.instrument.as_ref().unwrap();
        let mut commanded = vec![[0.0, 0.0, 0.02, 0.0, 0.0, 0.0]; 37];
        commanded.extend([[0.0, 0.0, 0.05, 0.0, 0.0, 0.0]; 5]);
        commanded.push([1.0, 0.0, 0.05, 0.0, 0.0, 0.0]);
        let options = SimulationOptions::default();
        let error = forward_pose_sets(&mechanism, instrument, options, Some(&commanded))
            .expect_err("1 m off the axis is beyond the rods")
            .to_string();
        assert!(
            error.contains("instrument.poses") && error.contains("cannot reach the measured pose"),
            "{error}"
        );
        commanded.pop();
        commanded.push([0.0, 0.0, 0.06, 0.0, 0.0, 0.0]);
        let sets = forward_pose_sets(&mechanism, instrument, options, Some(&commanded)).unwrap();
        assert_eq!(sets.shared.len(), 43);
        let bits = |pose: [f64; 6]| pose.map(f64::to_bits);
        assert_eq!(
            bits(sets.shared[42]),
            bits(commanded[42]),
            "a measured pose is taken as commanded"
        );
    }
}
