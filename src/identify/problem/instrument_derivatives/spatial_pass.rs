//! The derivatives of a spatial instrument's report of target positions (a tracker's
//! reflectors, a probe's height) in closed form, every column at once: the report of target `k`
//! at pose `(p, R_P)` is `m = R_fᵀ v`, `v = p + R_P t_k − f`, so
//!
//! * `∂m/∂p = R_fᵀ`, `∂m/∂θ = R_fᵀ (∂R_P/∂θ) t_k` for a pose angle `θ`;
//! * `∂m/∂f = −R_fᵀ`, `∂m/∂α = (∂R_f/∂α)ᵀ v` for a frame angle `α`;
//! * `∂m/∂t_k = R_fᵀ R_P`, nothing for the other targets' offsets.
//!
//! The same derivatives as the dual-number passes to round-off (a test compares them), without
//! carrying a lane per column through every product. A target reporting its orientation keeps
//! the dual-number passes.

use nalgebra::{Matrix3, Vector3};

use super::{Derivatives, Pass, PoseFunction, PreparedFunction, Seed};
use crate::kinematics::pose_derivative::pose_derivatives;
use crate::measure::targets::SpatialFrame;
use crate::model::instrument::{Instrument, Measures};

impl<'a> PreparedFunction<'a> {
    /// The closed-form pass of `f` for the columns `seeds` at the shared values `shared`
    /// ([`SpatialPass::new`]), if it has one.
    pub(super) fn closed_form_pass(
        f: PoseFunction<'a>,
        shared: &[f64],
        seeds: Vec<Seed>,
    ) -> Option<Box<dyn Pass + 'a>> {
        let pass = SpatialPass::new(f, shared, seeds)?;
        Some(Box::new(pass))
    }
}

/// The closed-form pass of a spatial report (see the module).
struct SpatialPass<'a> {
    instrument: &'a Instrument,
    seeds: Vec<Seed>,
    shared: Vec<f64>,
    frame: SpatialFrame<f64>,
    /// `∂R_f/∂α` for the frame's roll, pitch and yaw.
    frame_turns: [Matrix3<f64>; 3],
    /// Whether a seed is a pose angle (the platform's rotation derivatives are then needed).
    angles: bool,
    /// Whether a seed is a frame angle (`v` is then needed).
    frame_angles: bool,
    /// Whether a seed is a target's offset (`R_fᵀ R_P` is then needed).
    offsets: bool,
}

impl<'a> SpatialPass<'a> {
    /// The pass of `f` at the shared values `shared` for the columns `seeds`, if `f` is a
    /// spatial instrument's report whose targets all report positions (or some of their
    /// coordinates); `None` otherwise (the dual-number passes do it).
    fn new(f: PoseFunction<'a>, shared: &[f64], seeds: Vec<Seed>) -> Option<Self> {
        let PoseFunction::Report(instrument) = f else {
            return None;
        };
        if !instrument.spatial {
            return None;
        }
        let positions = instrument
            .targets
            .iter()
            .all(|t| matches!(t.measures, Measures::Position | Measures::Coordinates(_)));
        if !positions {
            return None;
        }
        let mut frame_pose = [0.0; 6];
        frame_pose[3..].copy_from_slice(&shared[FRAME + 3..FRAME + 6]);
        let turns = pose_derivatives(&frame_pose, &[3, 4, 5]);
        let shared_index = |k: &Seed| match *k {
            Seed::Shared { k, .. } => Some(k),
            Seed::Pose(_) => None,
        };
        let seeded = |first: usize, end: usize| {
            (seeds.iter().filter_map(shared_index)).any(|k| (first..end).contains(&k))
        };
        Some(Self {
            instrument,
            angles: seeds.iter().any(|s| matches!(s, Seed::Pose(c) if *c >= 3)),
            frame_angles: seeded(FRAME + 3, FRAME + 6),
            offsets: seeded(FRAME + 6, usize::MAX),
            seeds,
            shared: shared.to_vec(),
            frame: SpatialFrame::new(shared),
            frame_turns: [0, 1, 2].map(|i| turns[i].rotation),
        })
    }
}

impl Pass for SpatialPass<'_> {
    fn evaluate(
        &self,
        (pose, platform): (&[f64; 6], &Matrix3<f64>),
        out: &mut Derivatives,
        first: bool,
    ) {
        if first {
            let f = PoseFunction::Report(self.instrument);
            f.write(
                (&self.shared, Some(&self.frame)),
                (platform, pose),
                &mut out.values,
            );
        }
        let platform_turns = self.angles.then(|| pose_derivatives(pose, &[3, 4, 5]));
        let transposed = self.frame.transposed();
        let p = Vector3::new(pose[0], pose[1], pose[2]);
        let width = out.width;
        // ∂m/∂t_k = R_fᵀ R_P, every target's (when an offset is seeded).
        let by_offset = if self.offsets {
            transposed * platform
        } else {
            Matrix3::zeros()
        };
        let mut o = 0;
        for (k, target) in self.instrument.targets.iter().enumerate() {
            let offset = self.instrument.offset_index(k);
            let t = Vector3::from_column_slice(&self.shared[offset..offset + 3]);
            // `v` (when a frame angle is seeded).
            let v = if self.frame_angles {
                p + platform * t - self.frame.origin()
            } else {
                Vector3::zeros()
            };
            // R_fᵀ (∂R_P/∂θ) t for each pose angle θ.
            let by_angle = platform_turns
                .as_ref()
                .map(|turns| [0, 1, 2].map(|i| transposed * (turns[i].rotation * t)));
            for &c in target.pose_indices() {
                for seed in &self.seeds {
                    match *seed {
                        Seed::Pose(q) if q < 3 => out.by_pose[o][q] = transposed[(c, q)],
                        Seed::Pose(q) => {
                            let by_angle = by_angle.as_ref().expect("a pose angle is seeded");
                            out.by_pose[o][q] = by_angle[q - 3][c];
                        }
                        Seed::Shared { j, k: index } => {
                            out.by_shared[o * width + j] = match index {
                                i if i < FRAME + 3 => -transposed[(c, i - FRAME)],
                                i if i < FRAME + 6 => {
                                    self.frame_turns[i - FRAME - 3].column(c).dot(&v)
                                }
                                i if (offset..offset + 3).contains(&i) => {
                                    by_offset[(c, i - offset)]
                                }
                                _ => 0.0,
                            };
                        }
                    }
                }
                o += 1;
            }
        }
    }
}

/// The frame's first index among the shared parameters.
const FRAME: usize = Instrument::FRAME;

#[cfg(test)]
mod tests {
    use super::super::{Derivatives, PoseFunction, PreparedFunction};
    use crate::model::Mechanism;

    /// The closed-form derivatives of a spatial report of positions equal the dual-number
    /// passes' to 1e-15 of each output's scale, and its values are theirs bit for bit: a probe's
    /// height (the delta, which does not turn) and a reflector's position (the hexapod, every
    /// pose coordinate measured), every shared parameter identified, at perturbed shared values
    /// and poses; and with each shared parameter identified alone.
    #[test]
    fn the_closed_form_report_derivatives_equal_the_dual_passes() {
        for model in ["delta-probe", "hexapod-reflector"] {
            let path = format!("{}/models/{model}.yaml", env!("CARGO_MANIFEST_DIR"));
            let mechanism = Mechanism::load(std::path::Path::new(&path)).unwrap();
            let instrument = mechanism.instrument.as_ref().unwrap();
            let mut shared = instrument.nominal();
            for (i, value) in shared.iter_mut().enumerate() {
                *value += 0.01 * (i as f64 + 1.0).sin();
            }
            let every: Vec<usize> = (0..shared.len()).collect();
            let measured = &mechanism.measured;
            let f = PoseFunction::Report(instrument);
            // Every shared parameter identified, and each alone (what a column needs is formed
            // for it whatever else is seeded).
            let alone = every.iter().map(|&k| vec![k]);
            for identified in std::iter::once(every.clone()).chain(alone) {
                let at = (&shared[..], &identified[..]);
                let closed = PreparedFunction::with_passes(f, at, (measured, true), true);
                let dual = PreparedFunction::with_passes(f, at, (measured, true), false);
                assert_eq!(closed.passes.len(), 1, "{model}");
                assert!(identified.len() == 1 || dual.passes.len() > 1, "{model}");
                for step in 0..3 {
                    let mut pose = mechanism.home_pose;
                    for (c, value) in pose.iter_mut().enumerate() {
                        if measured.contains(&c) {
                            *value += 0.01 * (step as f64) * (1.0 + c as f64).cos();
                        }
                    }
                    let (mut a, mut b) = (Derivatives::default(), Derivatives::default());
                    closed.at(&pose, &mut a);
                    dual.at(&pose, &mut b);
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&a.values), bits(&b.values), "{model}");
                    for o in 0..a.values.len() {
                        let (x, y) = (&a.by_pose[o], &b.by_pose[o]);
                        let (u, v) = (a.by_shared(o), b.by_shared(o));
                        let scale = x.iter().chain(u).map(|d| d.abs()).fold(1.0, f64::max);
                        let all = x.iter().zip(y).chain(u.iter().zip(v));
                        for (k, (p, q)) in all.enumerate() {
                            assert!((p - q).abs() <= 1e-15 * scale, "{model} {o} {k}: {p} {q}");
                        }
                    }
                }
            }
        }
    }
}
