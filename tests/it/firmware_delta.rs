//! Printer firmware's delta calibration beside legwise's, on the bed-probe data of
//! models/delta-probe.yaml.
//!
//! Firmware fits a fixed parametrisation to probe heights: three endstop corrections, one
//! delta radius, angle corrections of two towers, one diagonal rod (3, 4, 6 or 7 factors in
//! RepRapFirmware's numbering; Marlin's G33 and Klipper's DELTA_CALIBRATE fit similar sets by
//! other iterations, Klipper by coordinate descent). The firmware model here is written
//! independently of legwise's kinematics (closed-form inverse kinematics and trilateration),
//! checked against legwise's forward and inverse kinematics, and fitted as RepRapFirmware fits
//! it: Gauss–Newton on the normal equations, the Jacobian by central differences of ±0.2 mm and
//! ±0.2° (its `ComputeDerivative`), iterated here to convergence where it stops after two.
//!
//! The firmware's heights are its nozzle's z at the touch readings, over a bed flat at z = 0 of
//! its own frame: RepRapFirmware's 3, 4, 6 and 7 factors have no bed tilt (8 and 9 add one),
//! and the endstop corrections absorb a tilt to first order (the firmware's frame tilts with
//! them). legwise's default set for the probe (the bed's tilts held) is then the same model in
//! other coordinates, and the test finds the same fit.
//!
//! Every fit is judged by what a printer owner sees: the gauge-free position error over the
//! workspace. Nozzle points are commanded on a 5 mm grid over r ≤ 0.08 m, 30 mm above the bed,
//! in the calibrated model's own bed frame; the calibrated model's inverse kinematics gives the
//! readings; the real printer (the simulation's real legs and bed) puts the nozzle where its
//! forward kinematics says, seen in the real bed frame. The error is that minus the commanded
//! point after removing the best in-plane rigid motion (x, y and the turn about the bed's
//! normal), which a probe cannot see; the figure is the RMS of the 3-D error.

use std::f64::consts::PI;

use legwise::evaluate::accuracy::result_parameters;
use legwise::identify::result::{FitOptions, Strategy, StrategyResult};
use legwise::identify::trust::trust_issues;
use legwise::kinematics::inverse::predict_reading;
use legwise::kinematics::platform::{forward, ForwardKinematics};
use legwise::measure::observations::Observations;
use legwise::measure::simulate::SimulationOptions;
use legwise::measure::Measurements;
use legwise::model::Mechanism;
use legwise::pipeline::{identify_one, simulate, PoseSource, SimulationSettings};
use legwise::solver::SolverKind;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use crate::support::{bundled, with_identified, without_priors};

/// The nozzle's offset under the effector centre (the model's target), m.
const NOZZLE: f64 = -0.02;
/// The towers' nominal angles, degrees: tower 1 at the back (RepRapFirmware's Z tower), towers
/// 2 and 3 at the front left and right (its X and Y towers, the two whose angles it corrects).
const TOWER_DEGREES: [f64; 3] = [90.0, 210.0, 330.0];
/// The nominal delta radius: the horizontal distance from an effector joint to its tower line
/// (tower radius 0.175 m minus effector joint radius 0.035 m).
const DELTA_RADIUS: f64 = 0.14;
/// The nominal diagonal rod, m.
const ROD: f64 = 0.3;
/// RepRapFirmware's finite-difference perturbations of the seven factors (endstops ×3, delta
/// radius, X and Y tower angle corrections, diagonal): 0.2 mm and 0.2°, in SI.
const PERTURBATIONS: [f64; 7] = [
    2e-4,
    2e-4,
    2e-4,
    2e-4,
    0.2 * PI / 180.0,
    0.2 * PI / 180.0,
    2e-4,
];

/// A firmware delta: one rod length, towers on one circle (the delta radius) at 90°, 210° and
/// 330° plus angle corrections, carriage height = reading + endstop correction (gain 1).
#[derive(Debug, Clone, Copy)]
struct Firmware {
    /// Endstop corrections: carriage height minus reading, per tower, m.
    endstops: [f64; 3],
    /// Delta radius, m.
    radius: f64,
    /// Tower angle corrections, rad (tower 1's is never fitted).
    corrections: [f64; 3],
    /// Diagonal rod length, m.
    rod: f64,
}

impl Firmware {
    fn nominal() -> Self {
        Firmware {
            endstops: [0.0; 3],
            radius: DELTA_RADIUS,
            corrections: [0.0; 3],
            rod: ROD,
        }
    }

    /// The firmware's factors moved by `step` (the first `step.len()` of endstops ×3, radius,
    /// tower 2's and tower 3's angle corrections, rod).
    fn adjusted(&self, step: &[f64]) -> Self {
        let mut moved = *self;
        for (j, &v) in step.iter().enumerate() {
            match j {
                0..=2 => moved.endstops[j] += v,
                3 => moved.radius += v,
                4 | 5 => moved.corrections[j - 3] += v,
                _ => moved.rod += v,
            }
        }
        moved
    }

    /// Where tower `i`'s line would be for an effector shrunk to its centre (the tower's
    /// position minus its effector joint's), m.
    fn tower(&self, i: usize) -> [f64; 2] {
        let angle = TOWER_DEGREES[i].to_radians() + self.corrections[i];
        [self.radius * angle.cos(), self.radius * angle.sin()]
    }

    /// Inverse kinematics: the readings that put the nozzle at `nozzle` (None out of reach).
    fn readings(&self, nozzle: [f64; 3]) -> Option<[f64; 3]> {
        let centre = [nozzle[0], nozzle[1], nozzle[2] - NOZZLE];
        let mut readings = [0.0; 3];
        for (i, reading) in readings.iter_mut().enumerate() {
            let [tx, ty] = self.tower(i);
            let drop2 = self.rod * self.rod - (tx - centre[0]).powi(2) - (ty - centre[1]).powi(2);
            if drop2 <= 0.0 {
                return None;
            }
            *reading = centre[2] + drop2.sqrt() - self.endstops[i];
        }
        Some(readings)
    }

    /// Forward kinematics by trilateration: the nozzle for `readings`, the effector below the
    /// carriages (None when the rods cannot meet).
    fn nozzle(&self, readings: [f64; 3]) -> Option<[f64; 3]> {
        let carriages: [[f64; 3]; 3] = std::array::from_fn(|i| {
            let [tx, ty] = self.tower(i);
            [tx, ty, readings[i] + self.endstops[i]]
        });
        // Spheres of equal radius: |p − P_i|² = rod², differences against P_1 are planes
        // 2 (P_i − P_1)·p = |P_i|² − |P_1|², i = 2, 3: x and y as affine functions of z.
        let squared = |p: &[f64; 3]| p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
        let p1 = carriages[0];
        let row = |i: usize| {
            let pi = carriages[i];
            (
                2.0 * (pi[0] - p1[0]),
                2.0 * (pi[1] - p1[1]),
                2.0 * (pi[2] - p1[2]),
                squared(&pi) - squared(&p1),
            )
        };
        let (a1, b1, c1, d1) = row(1);
        let (a2, b2, c2, d2) = row(2);
        let det = a1 * b2 - a2 * b1;
        // x = xz z + x0, y = yz z + y0.
        let (x0, xz) = ((d1 * b2 - d2 * b1) / det, (-c1 * b2 + c2 * b1) / det);
        let (y0, yz) = ((a1 * d2 - a2 * d1) / det, (-a1 * c2 + a2 * c1) / det);
        let (u, v) = (x0 - p1[0], y0 - p1[1]);
        let a = xz * xz + yz * yz + 1.0;
        let b = 2.0 * (xz * u + yz * v - p1[2]);
        let c = u * u + v * v + p1[2] * p1[2] - self.rod * self.rod;
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        // The lower root (the effector under the carriages), without cancellation.
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        let z = (q / a).min(c / q);
        Some([xz * z + x0, yz * z + y0, z + NOZZLE])
    }

    /// The legwise parameter vectors (one per leg of models/delta-probe.yaml) of this delta:
    /// each tower at its firmware position plus its effector joint.
    fn legwise_parameters(&self, mechanism: &Mechanism) -> Vec<Vec<f64>> {
        mechanism
            .legs
            .iter()
            .enumerate()
            .map(|(i, leg)| {
                let n = i + 1;
                let nominal = |name: &str| {
                    leg.params
                        .iter()
                        .find(|p| p.name == name)
                        .map(|p| p.nominal)
                        .expect("a delta parameter")
                };
                let [tx, ty] = self.tower(i);
                let (ex, ey) = (nominal(&format!("e{n}x")), nominal(&format!("e{n}y")));
                leg.params
                    .iter()
                    .map(|p| match p.name.as_str() {
                        name if name == format!("t{n}x") => tx + ex,
                        name if name == format!("t{n}y") => ty + ey,
                        name if name == format!("L{n}") => self.rod,
                        name if name == format!("k{n}") => 1.0,
                        name if name == format!("h0_{n}") => self.endstops[i],
                        _ => p.nominal,
                    })
                    .collect()
            })
            .collect()
    }
}

/// One probe touch: every carriage reading and the height the probe reported.
#[derive(Debug, Clone, Copy)]
struct Touch {
    readings: [f64; 3],
    reported: f64,
}

fn touches(observations: &Observations) -> Vec<Touch> {
    observations
        .rows
        .iter()
        .map(|row| {
            let r: Vec<f64> = row
                .readings
                .iter()
                .map(|s| s.expect("every reading"))
                .collect();
            Touch {
                readings: [r[0], r[1], r[2]],
                reported: row.observed[0],
            }
        })
        .collect()
}

/// The firmware's height residuals: its nozzle height at each touch's readings, over a bed
/// flat at z = 0 of its own frame, minus the reported height.
fn height_residuals(model: &Firmware, touches: &[Touch]) -> DVector<f64> {
    DVector::from_iterator(
        touches.len(),
        touches
            .iter()
            .map(|t| model.nozzle(t.readings).expect("the firmware's rods meet")[2] - t.reported),
    )
}

/// A firmware fit: the model, its residual RMS (m) and the Gauss–Newton iterations taken.
struct FirmwareFit {
    model: Firmware,
    rms: f64,
    iterations: usize,
}

/// RepRapFirmware's `factors`-factor calibration from the nominal delta: Gauss–Newton on the
/// normal equations, its Jacobian by central differences of its perturbations, iterated until
/// the step is below 1e-12 (m or rad).
fn fit_firmware(touches: &[Touch], factors: usize) -> FirmwareFit {
    let mut model = Firmware::nominal();
    let mut iterations = 0;
    while iterations < 50 {
        iterations += 1;
        let r = height_residuals(&model, touches);
        let mut jacobian = DMatrix::zeros(touches.len(), factors);
        for j in 0..factors {
            let mut step = vec![0.0; factors];
            step[j] = PERTURBATIONS[j];
            let hi = height_residuals(&model.adjusted(&step), touches);
            step[j] = -PERTURBATIONS[j];
            let lo = height_residuals(&model.adjusted(&step), touches);
            jacobian.set_column(j, &((hi - lo) / (2.0 * PERTURBATIONS[j])));
        }
        let normal = jacobian.transpose() * &jacobian;
        let step = normal
            .lu()
            .solve(&(-(jacobian.transpose() * r)))
            .expect("the normal equations are regular");
        model = model.adjusted(step.as_slice());
        if step.amax() < 1e-12 {
            break;
        }
    }
    let r = height_residuals(&model, touches);
    FirmwareFit {
        model,
        rms: (r.norm_squared() / r.len() as f64).sqrt(),
        iterations,
    }
}

/// `Rz(yaw) Ry(pitch) Rx(roll)`.
fn rotation(roll: f64, pitch: f64, yaw: f64) -> Matrix3<f64> {
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let (sy, cy) = yaw.sin_cos();
    let rz = Matrix3::new(cy, -sy, 0.0, sy, cy, 0.0, 0.0, 0.0, 1.0);
    let ry = Matrix3::new(cp, 0.0, sp, 0.0, 1.0, 0.0, -sp, 0.0, cp);
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cr, -sr, 0.0, sr, cr);
    rz * ry * rx
}

/// The bed frame and the nozzle offset of an instrument vector (frame x y z roll pitch yaw,
/// then the nozzle's offset x y z).
struct Bed {
    origin: Vector3<f64>,
    rotation: Matrix3<f64>,
    nozzle: Vector3<f64>,
}

impl Bed {
    fn of(shared: &[f64]) -> Self {
        Bed {
            origin: Vector3::new(shared[0], shared[1], shared[2]),
            rotation: rotation(shared[3], shared[4], shared[5]),
            nozzle: Vector3::new(shared[6], shared[7], shared[8]),
        }
    }
}

/// The real printer of one experiment: its forward kinematics (legwise's, at the simulation's
/// real legs) and its bed.
struct RealPrinter<'m> {
    kinematics: ForwardKinematics<'m>,
    bed: Bed,
}

impl RealPrinter<'_> {
    /// Where the real nozzle goes for `readings`, in the real bed frame.
    fn nozzle_on_bed(&self, readings: &[f64; 3]) -> Vector3<f64> {
        let pose = self
            .kinematics
            .solve(readings)
            .expect("the real delta reaches");
        let nozzle = Vector3::new(pose[0], pose[1], pose[2]) + self.bed.nozzle;
        self.bed.rotation.transpose() * (nozzle - self.bed.origin)
    }
}

/// The commanded nozzle points: a 5 mm grid over r ≤ 0.08 m, 30 mm above the bed.
fn commanded_grid() -> Vec<Vector3<f64>> {
    let mut points = Vec::new();
    for i in -16i32..=16 {
        for j in -16i32..=16 {
            let (x, y) = (0.005 * f64::from(i), 0.005 * f64::from(j));
            if x * x + y * y <= 0.08 * 0.08 + 1e-12 {
                points.push(Vector3::new(x, y, 0.03));
            }
        }
    }
    points
}

/// The RMS of `reached − commanded` after the least-squares in-plane rigid motion (x, y and
/// the turn about the bed's normal) of the reached points.
fn gauge_free_rms(reached: &[Vector3<f64>], commanded: &[Vector3<f64>]) -> f64 {
    let n = reached.len() as f64;
    let centroid = |points: &[Vector3<f64>]| {
        points
            .iter()
            .fold([0.0, 0.0], |s, p| [s[0] + p.x / n, s[1] + p.y / n])
    };
    let (a0, b0) = (centroid(reached), centroid(commanded));
    let (mut dot, mut cross) = (0.0, 0.0);
    for (a, b) in reached.iter().zip(commanded) {
        let (ax, ay, bx, by) = (a.x - a0[0], a.y - a0[1], b.x - b0[0], b.y - b0[1]);
        dot += ax * bx + ay * by;
        cross += ax * by - ay * bx;
    }
    let (s, c) = cross.atan2(dot).sin_cos();
    let sum: f64 = reached
        .iter()
        .zip(commanded)
        .map(|(a, b)| {
            let (ax, ay, bx, by) = (a.x - a0[0], a.y - a0[1], b.x - b0[0], b.y - b0[1]);
            (c * ax - s * ay - bx).powi(2) + (s * ax + c * ay - by).powi(2) + (a.z - b.z).powi(2)
        })
        .sum();
    (sum / n).sqrt()
}

/// The gauge-free error (m) of a calibrated model given by its inverse kinematics `readings`
/// (commanded nozzle point in its bed frame → readings).
fn workspace_error(
    real: &RealPrinter<'_>,
    commanded: &[Vector3<f64>],
    readings: impl Fn(&Vector3<f64>) -> [f64; 3],
) -> f64 {
    let reached: Vec<Vector3<f64>> = commanded
        .iter()
        .map(|c| real.nozzle_on_bed(&readings(c)))
        .collect();
    gauge_free_rms(&reached, commanded)
}

/// A firmware model's readings for a commanded nozzle point in its frame (its bed).
fn firmware_readings(model: &Firmware) -> impl Fn(&Vector3<f64>) -> [f64; 3] + '_ {
    |c| {
        model
            .readings([c.x, c.y, c.z])
            .expect("within the firmware's reach")
    }
}

/// A legwise model's readings for a commanded nozzle point in its bed frame: the point in the
/// base frame, the effector under it, legwise's inverse kinematics of every leg.
fn legwise_readings<'a>(
    mechanism: &'a Mechanism,
    params: &'a [Vec<f64>],
    bed: &'a Bed,
) -> impl Fn(&Vector3<f64>) -> [f64; 3] + 'a {
    move |c| {
        let centre = bed.origin + bed.rotation * c - bed.nozzle;
        let pose = [centre.x, centre.y, centre.z, 0.0, 0.0, 0.0];
        let mut readings = [0.0; 3];
        for (l, leg) in mechanism.legs.iter().enumerate() {
            readings[l] = predict_reading(leg, &params[l], &pose, &mechanism.home_pose)
                .expect("within legwise's reach");
        }
        readings
    }
}

/// The instrument estimate of a legwise result, as an instrument vector.
fn estimated_shared(result: &StrategyResult) -> Vec<f64> {
    result
        .instrument
        .as_ref()
        .expect("an instrument estimate")
        .parameters
        .iter()
        .map(|p| p.estimate)
        .collect()
}

#[test]
fn the_firmware_delta_matches_legwise_kinematics() {
    let mechanism = bundled("delta-probe.yaml");
    let perturbed = Firmware {
        endstops: [1.2e-3, -0.7e-3, 0.4e-3],
        radius: 0.1413,
        corrections: [0.0, 3e-3, -2e-3],
        rod: 0.2994,
    };
    for model in [Firmware::nominal(), perturbed] {
        let params = model.legwise_parameters(&mechanism);
        for (x, y) in [(0.0, 0.0), (0.08, 0.0), (-0.03, 0.06), (0.02, -0.075)] {
            for z in [0.0, 0.03, 0.06] {
                let nozzle = [x, y, z];
                let readings = model.readings(nozzle).expect("reachable");
                // legwise's forward kinematics of the firmware's readings: the effector centre.
                let pose = forward(&mechanism, &params, &readings).expect("legwise reaches");
                let back = model.nozzle(readings).expect("the rods meet");
                for k in 0..3 {
                    let centre = nozzle[k] - if k == 2 { NOZZLE } else { 0.0 };
                    assert!(
                        (pose[k] - centre).abs() <= 1e-12,
                        "{model:?} at {nozzle:?}: legwise's forward {pose:?}"
                    );
                    assert!(
                        (back[k] - nozzle[k]).abs() <= 1e-12,
                        "{model:?} at {nozzle:?}: trilateration {back:?}"
                    );
                }
                // legwise's inverse kinematics gives the firmware's readings back.
                for (l, leg) in mechanism.legs.iter().enumerate() {
                    let reading =
                        predict_reading(leg, &params[l], &pose, &mechanism.home_pose).unwrap();
                    assert!(
                        (reading - readings[l]).abs() <= 1e-12,
                        "{model:?} at {nozzle:?}: leg {l} reads {reading}, not {}",
                        readings[l]
                    );
                }
            }
        }
    }
}

/// One fit's figures, one per experiment: gauge-free workspace error and residual RMS, m.
#[derive(Default)]
struct Figures {
    workspace: Vec<f64>,
    residual: Vec<f64>,
}

impl Figures {
    fn push(&mut self, workspace: f64, residual: f64) {
        self.workspace.push(workspace);
        self.residual.push(residual);
    }

    fn workspace(&self) -> f64 {
        mean(&self.workspace)
    }

    fn residual(&self) -> f64 {
        mean(&self.residual)
    }
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

fn largest(values: &[f64]) -> f64 {
    values.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

/// RepRapFirmware's factor counts compared.
const FACTORS: [usize; 4] = [3, 4, 6, 7];
/// Seeded experiments averaged.
const EXPERIMENTS: u64 = 20;

/// Every fit's figures over the experiments.
#[derive(Default)]
struct Table {
    /// Firmware with 3, 4, 6, 7 factors.
    firmware: [Figures; 4],
    /// legwise, the model's identified set (towers, carriage offsets; the bed's tilts held at
    /// 0): the firmware 6-factor model in other coordinates.
    legwise: Figures,
    /// legwise with the bed's tilts identified too.
    tilts_free: Figures,
    /// legwise with L1, L2, L3 free as well.
    rods_free: Figures,
    /// The nominal model, nothing fitted.
    nominal: Figures,
    /// The firmware's Gauss–Newton iterations, at most.
    iterations: usize,
    /// The smallest and largest rod of the rods-free fits, m.
    rods: [f64; 2],
    /// Experiments whose legwise fit is flagged by the predicted position σ above the model's
    /// tolerance: default set, rods free, tilts free.
    flagged: [usize; 3],
}

impl Table {
    fn print(&self, noise_scale: f64) {
        let um = 1e6;
        eprintln!(
            "noise scale {noise_scale}: gauge-free position error over r <= 0.08 m, 30 mm above \
             the bed (mean and worst of {EXPERIMENTS} experiments), height residual RMS (mean):"
        );
        let line = |name: &str, f: &Figures| {
            eprintln!(
                "  {name:<30} {:7.1} µm (worst {:7.1})   residual {:6.2} µm",
                f.workspace() * um,
                largest(&f.workspace) * um,
                f.residual() * um
            );
        };
        for (f, factors) in self.firmware.iter().zip(FACTORS) {
            line(&format!("firmware {factors}-factor"), f);
        }
        line("legwise default set", &self.legwise);
        line("legwise, bed tilts free too", &self.tilts_free);
        line("legwise, L1 L2 L3 free too", &self.rods_free);
        line("nominal model", &self.nominal);
        eprintln!(
            "  firmware Gauss-Newton iterations to a 1e-12 step: at most {}; rods of the \
             rods-free fits {:.5} to {:.5} m",
            self.iterations, self.rods[0], self.rods[1]
        );
    }
}

/// Every fit over the [`EXPERIMENTS`] seeded experiments of models/delta-probe.yaml at
/// `noise_scale`.
fn side_by_side(noise_scale: f64) -> Table {
    let probe = bundled("delta-probe.yaml");
    let tilts_free = with_identified(&probe, &["frame_roll", "frame_pitch"], true);
    // The rods freed on the data alone (the model's 0.2 mm prior removed).
    let rods_free = with_identified(&without_priors(&probe), &["L1", "L2", "L3"], true);
    let nominal_params = probe.nominal_parameters();
    let nominal_bed = Bed::of(&probe.instrument.as_ref().expect("a bed").nominal());
    let commanded = commanded_grid();
    let mut table = Table {
        rods: [f64::INFINITY, f64::NEG_INFINITY],
        ..Table::default()
    };
    for seed in 1..=EXPERIMENTS {
        let settings = SimulationSettings {
            options: SimulationOptions {
                seed: Some(seed),
                noise_scale,
                poses_per_leg: None,
            },
            poses: PoseSource::Random,
            grid: None,
        };
        let simulated = simulate(&probe, &settings).expect("simulates");
        let Measurements::Targets(observations) = simulated.measurements else {
            panic!("the probe's heights");
        };
        let real = RealPrinter {
            kinematics: ForwardKinematics::new(&probe, &simulated.real.legs),
            bed: Bed::of(simulated.real.instrument.as_ref().expect("the real bed")),
        };
        let touches = touches(&observations);

        for (figures, &factors) in table.firmware.iter_mut().zip(&FACTORS) {
            let fit = fit_firmware(&touches, factors);
            table.iterations = table.iterations.max(fit.iterations);
            let error = workspace_error(&real, &commanded, firmware_readings(&fit.model));
            figures.push(error, fit.rms);
        }

        let data = Measurements::Targets(observations);
        for (k, (mechanism, figures)) in [
            (&probe, &mut table.legwise),
            (&rods_free, &mut table.rods_free),
            (&tilts_free, &mut table.tilts_free),
        ]
        .into_iter()
        .enumerate()
        {
            let result = identify_one(
                mechanism,
                &data,
                Strategy::Joint,
                SolverKind::LevenbergMarquardt,
                FitOptions::default(),
            )
            .expect("legwise identifies");
            let issues = trust_issues(std::slice::from_ref(&result));
            if issues
                .iter()
                .any(|i| i.contains("above the model's tolerance"))
            {
                table.flagged[k] += 1;
            }
            let params = result_parameters(mechanism, &result);
            if std::ptr::eq(mechanism, &rods_free) {
                let rods = result
                    .parameters()
                    .filter(|p| p.name.starts_with('L'))
                    .map(|p| p.estimate);
                for rod in rods {
                    table.rods[0] = table.rods[0].min(rod);
                    table.rods[1] = table.rods[1].max(rod);
                }
            }
            let bed = Bed::of(&estimated_shared(&result));
            let readings = legwise_readings(mechanism, &params, &bed);
            let error = workspace_error(&real, &commanded, readings);
            let rms = result.instrument.as_ref().expect("an instrument").rms;
            figures.push(error, rms);
        }

        // The nominal model, through legwise's inverse kinematics; the firmware's nominal delta
        // (no factor fitted) must agree with it, frames and all (the URDF's towers are rounded
        // to 1e-10 m).
        let readings = legwise_readings(&probe, &nominal_params, &nominal_bed);
        let error = workspace_error(&real, &commanded, readings);
        let as_firmware =
            workspace_error(&real, &commanded, firmware_readings(&Firmware::nominal()));
        assert!(
            (error - as_firmware).abs() <= 1e-9,
            "nominal: {error} through legwise, {as_firmware} through the firmware model"
        );
        let residual = height_residuals(&Firmware::nominal(), &touches);
        let rms = (residual.norm_squared() / residual.len() as f64).sqrt();
        table.nominal.push(error, rms);
    }
    table
}

/// Asserts that every experiment's `a − b` of two figures lies in `[low, high]` (m); `what`
/// names the comparison.
fn assert_each_within(what: &str, a: &[f64], b: &[f64], low: f64, high: f64) {
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (low..=high).contains(&(x - y)),
            "{what}: experiment {}: {x:.4e} − {y:.4e} = {:.3e} outside [{low:.1e}, {high:.1e}]",
            k + 1,
            x - y
        );
    }
}

#[test]
fn firmware_factors_and_legwise_fits_side_by_side_over_the_workspace() {
    let noisy = side_by_side(1.0);
    noisy.print(1.0);
    let exact = side_by_side(0.0);
    exact.print(0.0);
    let um = 1e-6;
    let [f3, f4, f6, f7] = &noisy.firmware;

    // legwise's default set (the bed's tilts held) is the firmware's 6-factor model in other
    // coordinates
    // (its towers placed by t2y t3x t3y instead of a radius and two angles): the same least-
    // squares minimum (residuals equal to 1e-17 m measured), the same workspace error but for
    // the grid sampled in another gauge (0.35 µm measured).
    for table in [&noisy, &exact] {
        let f6 = &table.firmware[2];
        let (held, firmware) = (&table.legwise, f6);
        let what = "residual, legwise's default set − 6 factors";
        assert_each_within(what, &held.residual, &firmware.residual, -1e-10, 1e-10);
        let what = "workspace error, legwise's default set − 6 factors";
        assert_each_within(
            what,
            &held.workspace,
            &firmware.workspace,
            -2.0 * um,
            2.0 * um,
        );
    }

    // Nested models: every freed factor lowers the residual, in every experiment.
    for (what, more, fewer) in [
        ("rods free − default set", &noisy.rods_free, &noisy.legwise),
        (
            "tilts free − default set",
            &noisy.tilts_free,
            &noisy.legwise,
        ),
        ("7 − 6 factors", f7, f6),
        ("4 − 3 factors", f4, f3),
    ] {
        let what = format!("residual, {what}");
        assert_each_within(&what, &more.residual, &fewer.residual, -1.0, 1e-12);
    }
    // The full fits leave the probe's noise (10 µm, 29 to 31 degrees of freedom of 37 rows:
    // 8.1 to 8.7 µm measured); the nominal model 227 µm, 3 and 4 factors 67 µm (the towers
    // stand 1 to 2 mm from nominal: only the angle corrections move them).
    for (name, fit) in [
        ("6 factors", f6),
        ("7 factors", f7),
        ("default set", &noisy.legwise),
        ("tilts free", &noisy.tilts_free),
        ("rods free", &noisy.rods_free),
    ] {
        let rms = fit.residual();
        assert!(
            (7.0 * um..=10.0 * um).contains(&rms),
            "{name}: residual {rms}"
        );
    }
    for (name, fit, floor) in [
        ("3 factors", f3, 40.0),
        ("4 factors", f4, 40.0),
        ("nominal", &noisy.nominal, 100.0),
    ] {
        let rms = fit.residual();
        assert!(rms > floor * um, "{name}: residual {rms}");
    }

    // Over the workspace: calibration takes the nominal 537 µm to 24.5 µm with 6 factors and
    // legwise's default set (the same model); 3 and 4 factors stay above 400 µm (17 times the
    // 6 factors' error).
    let (nominal, six, default) = (
        noisy.nominal.workspace(),
        f6.workspace(),
        noisy.legwise.workspace(),
    );
    assert!(nominal > 400.0 * um, "nominal: {nominal}");
    assert!(six < 40.0 * um, "6 factors: {six}");
    assert!(default < 40.0 * um, "default set: {default}");
    for (name, fit) in [("3 factors", f3), ("4 factors", f4)] {
        let error = fit.workspace();
        assert!(error > 10.0 * six, "{name}: {error} against {six}");
    }

    // The bed's tilts identified too, against the 6 factors. Without noise that is the better
    // model in every experiment (13.1 against 14.2 µm measured: its bed tilt is the real one,
    // while the endstops absorb a tilt only to first order). With noise it loses 16.3 µm on
    // average: the two tilts are nearly collinear with the endstops' differences, and the extra
    // freedom spreads the probe's noise over the workspace (why the model holds them).
    assert_each_within(
        "workspace error without noise, tilts free − 6 factors",
        &exact.tilts_free.workspace,
        &exact.firmware[2].workspace,
        -1.0,
        0.0,
    );
    let cost = noisy.tilts_free.workspace() - six;
    assert!(
        (5.0 * um..=25.0 * um).contains(&cost),
        "tilts free − 6 factors: {cost}"
    );

    // A rod length freed: a lower residual in every experiment (above), a worse workspace.
    // Heights barely see a common scale: freed with every rod, legwise's rods wander over
    // 0.297-0.304 m and the workspace error is 5.6 times the default set's on average (one
    // experiment of 20 slightly better); the firmware's one diagonal gives 3.6 times the 6
    // factors' error.
    let rods = noisy.rods_free.workspace();
    assert!(rods > 3.0 * default, "rods free: {rods} against {default}");
    // The rods-free fit is not reported as a success: its predicted position σ over the
    // workspace exceeds the model's tolerance and the result is flagged (exit 3) in every
    // experiment, the default set's never (the tilts-free fit's σ borders on it: 1 of 20
    // flagged, measured).
    assert_eq!(
        noisy.flagged[..2],
        [0, EXPERIMENTS as usize],
        "experiments flagged: default set, rods free"
    );
    let spread = noisy.rods[1] - noisy.rods[0];
    assert!(spread > 0.005, "rods from {:?}", noisy.rods);
    let seven = f7.workspace();
    assert!(seven > 2.0 * six, "7 factors: {seven} against {six}");
}

/// legwise's own error in the frame the observations define (the map's `observed_frame`) is
/// this test's gauge-free error, computed independently (exact in-plane Procrustes here, the
/// linearised motion of the held frame components there), on one experiment's default fit.
#[test]
fn the_observed_frame_error_of_the_map_is_the_gauge_free_error() {
    use legwise::evaluate::observed_frame::observed_frame_error;
    let probe = bundled("delta-probe.yaml");
    let settings = SimulationSettings {
        options: SimulationOptions {
            seed: Some(1),
            noise_scale: 1.0,
            poses_per_leg: None,
        },
        poses: PoseSource::Random,
        grid: None,
    };
    let simulated = simulate(&probe, &settings).expect("simulates");
    let real_shared = simulated.real.instrument.clone().expect("the real bed");
    let real = RealPrinter {
        kinematics: ForwardKinematics::new(&probe, &simulated.real.legs),
        bed: Bed::of(&real_shared),
    };
    let result = identify_one(
        &probe,
        &simulated.measurements,
        Strategy::Joint,
        SolverKind::LevenbergMarquardt,
        FitOptions::default(),
    )
    .expect("legwise identifies");
    let params = result_parameters(&probe, &result);
    let shared = estimated_shared(&result);
    let bed = Bed::of(&shared);
    let commanded = commanded_grid();
    let readings = legwise_readings(&probe, &params, &bed);
    let ours = workspace_error(&real, &commanded, &readings);
    // The same commanded points as the map's targets (effector poses in the base frame) and
    // the poses the real delta reaches there.
    let targets: Vec<[f64; 6]> = commanded
        .iter()
        .map(|c| {
            let centre = bed.origin + bed.rotation * c - bed.nozzle;
            [centre.x, centre.y, centre.z, 0.0, 0.0, 0.0]
        })
        .collect();
    let reached: Vec<Option<[f64; 6]>> = commanded
        .iter()
        .map(|c| real.kinematics.solve(&readings(c)).ok())
        .collect();
    let instrument = probe.instrument.as_ref().expect("a bed");
    let theirs = observed_frame_error(instrument, (&shared, &real_shared), &targets, &reached)
        .expect("reached");
    assert_eq!(theirs.target, "nozzle");
    assert_eq!(theirs.aligned, ["along x", "along y", "about z"]);
    let rms = theirs.position_error.rms;
    assert!(
        (rms - ours).abs() <= 1e-3 * ours,
        "observed-frame RMS {rms} against the gauge-free {ours}"
    );
}
