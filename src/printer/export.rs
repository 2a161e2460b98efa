//! A calibrated delta as a firmware's values (the fit is common: [`fit_delta`] with the
//! firmware's [`FirmwareTerms`]); Klipper's here: `delta_radius`, each tower's `angle`, `arm_length`
//! and `position_endstop`, fitted so that Klipper's kinematics come closest to the calibrated
//! model over the bed, and what that leaves (the part Klipper cannot express: gains, a bed tilt).
//!
//! The fit: on a grid of nozzle positions `X` over the bed (in the bed's frame, the frame the
//! probe defines), the calibrated model's inverse kinematics gives the carriage readings `s`;
//! Klipper with values `q`, reading `s`, puts the nozzle at `p(q, s)` (the three rod spheres
//! meeting below the carriages) in its own frame. The values minimise `Σ |p(q, s) + c − X|²`
//! over `q` and a shift `c` of Klipper's origin in the bed plane (a probe cannot see where the
//! printer stands): Gauss–Newton on central differences, started from the closed form (the
//! towers' circumcircle, the rods, the endstop heights), which is exact for a model Klipper can
//! express.

use std::fmt::Write as _;

use nalgebra::{DMatrix, DVector, Point3, Vector3};

use crate::error::{Error, Result};
use crate::kinematics::chain::platform_transform_f64;
use crate::kinematics::inverse::predict_reading;
use crate::model::Mechanism;

use super::klipper::TOWERS;

/// Klipper's delta values, in Klipper's units (mm, degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KlipperValues {
    /// `delta_radius`, mm.
    pub radius: f64,
    /// Each tower's `angle`, degrees.
    pub angles: [f64; 3],
    /// Each tower's `arm_length`, mm.
    pub arms: [f64; 3],
    /// Each tower's `position_endstop`, mm.
    pub endstops: [f64; 3],
    /// Each stepper's `rotation_distance`, mm: the current one scaled by the calibrated gain,
    /// when the export was given the current ones.
    pub rotation_distances: Option<[f64; 3]>,
}

/// The export of a calibrated model.
#[derive(Debug, Clone)]
pub struct KlipperExport {
    /// The fitted values.
    pub values: KlipperValues,
    /// Klipper's origin in the bed frame (x, y), m.
    pub origin: [f64; 2],
    /// RMS over the grid of the nozzle's distance between Klipper's and the calibrated model, m.
    pub rms_loss: f64,
    /// Its largest value over the grid, m.
    pub max_loss: f64,
    /// The RMS loss of the closed-form start (the towers' circumcircle, rods, endstop heights),
    /// m: what the least squares improved on.
    pub start_rms_loss: f64,
    /// Number of grid points.
    pub points: usize,
}

/// One grid point: the nozzle in the bed frame and the calibrated model's readings there.
struct Sample {
    nozzle: Vector3<f64>,
    readings: [f64; 3],
}

/// A named parameter's nominal (calibrated) value in leg `leg`.
fn value(mechanism: &Mechanism, leg: usize, name: &str) -> Result<f64> {
    let model = &mechanism.legs[leg];
    model
        .params
        .iter()
        .find(|p| p.name == name)
        .map(|p| p.nominal)
        .ok_or_else(|| {
            Error::Invalid(format!(
                "{}: leg `{}` has no parameter `{name}`: the Klipper export reads a model written by \
                 `legwise printer import --klipper` (or its calibrated copy)",
                mechanism.model_path.display(),
                model.name
            ))
        })
}

/// The gains `k1 k2 k3` of an imported (calibrated) model.
///
/// # Errors
/// A leg without its gain parameter (not an imported printer).
pub fn calibrated_gains(mechanism: &Mechanism) -> Result<[f64; 3]> {
    if mechanism.legs.len() != 3 {
        return Err(Error::Invalid(format!(
            "{}: expected the three legs of a linear delta, found {}",
            mechanism.model_path.display(),
            mechanism.legs.len()
        )));
    }
    let mut gains = [1.0; 3];
    for (i, gain) in gains.iter_mut().enumerate() {
        *gain = value(mechanism, i, &format!("k{}", i + 1))?;
    }
    Ok(gains)
}

/// What a firmware's parameters can express beyond the common ones (a radius, three tower
/// angles, three endstop heights, an origin).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FirmwareTerms {
    /// One diagonal rod for the three towers (Marlin's `M665 L`) rather than three.
    pub one_rod: bool,
    /// A bed tilt: the carriage heights add `a x + b y` (RepRapFirmware's `M666 A B`).
    pub tilt: bool,
    /// Each carriage's travel per step (Klipper's per-stepper `rotation_distance`, the others'
    /// `M92 X Y Z`): the carriage heights are `A_i + g_i s_i` rather than `A_i + s_i`. Only
    /// when the export knows the firmware's current step settings (`--firmware-config`).
    pub gains: bool,
}

impl FirmwareTerms {
    /// The same terms with the gains expressible (`gains`) or not.
    pub fn with_gains(self, gains: bool) -> Self {
        FirmwareTerms { gains, ..self }
    }
}

/// Klipper: three rods, no tilt; the gains through `rotation_distance` when the export knows it.
pub const KLIPPER_TERMS: FirmwareTerms = FirmwareTerms {
    one_rod: false,
    tilt: false,
    gains: false,
};

/// A firmware-neutral fit, in SI units: the closest delta a firmware with [`FirmwareTerms`] can
/// express.
#[derive(Debug, Clone)]
pub struct DeltaFit {
    /// The delta radius, m.
    pub radius: f64,
    /// Each tower's angle, rad (as fitted, not wrapped).
    pub angles: [f64; 3],
    /// Each tower's rod, m (equal with [`FirmwareTerms::one_rod`]).
    pub arms: [f64; 3],
    /// Each carriage's height at its endstop, m, in the firmware's frame (the bed at z = 0).
    pub carriage_tops: [f64; 3],
    /// The tilt `[a, b]` (0 without [`FirmwareTerms::tilt`]).
    pub tilt: [f64; 2],
    /// Each carriage's travel per step relative to the step setting the readings were taken
    /// with (1 without [`FirmwareTerms::gains`]): the firmware's step setting is scaled by it.
    pub gains: [f64; 3],
    /// The firmware's origin in the bed frame (x, y), m.
    pub origin: [f64; 2],
    /// RMS over the grid of the nozzle's distance between the firmware's and the calibrated
    /// model, m.
    pub rms_loss: f64,
    /// Its largest value over the grid, m.
    pub max_loss: f64,
    /// The RMS loss of the closed-form start, m.
    pub start_rms_loss: f64,
    /// Number of grid points.
    pub points: usize,
}

impl DeltaFit {
    /// Tower `i`'s endstop as the nozzle's height at the centre with the carriages at their
    /// endstops, m: `carriage_top_i − sqrt(L_i² − radius²)`.
    pub fn endstop(&self, i: usize) -> f64 {
        self.carriage_tops[i] - (self.arms[i].powi(2) - self.radius.powi(2)).sqrt()
    }
}

/// Fits Klipper's values to `mechanism` (a model from `legwise printer import`, calibrated or
/// not) over the bed disc of radius `bed_radius` (m), at the bed and `bed_radius / 2` above it.
/// With the steppers' current `rotation_distance`s (mm, the ones the model's readings were taken
/// with), the gains are fitted too and written as new `rotation_distance`s; without, they are
/// held at 1 and what they carry is part of the loss.
///
/// # Errors
/// As [`fit_delta`].
pub fn fit_klipper(
    mechanism: &Mechanism,
    bed_radius: f64,
    rotation_distances: Option<[f64; 3]>,
) -> Result<KlipperExport> {
    let terms = KLIPPER_TERMS.with_gains(rotation_distances.is_some());
    let fit = fit_delta(mechanism, bed_radius, terms)?;
    let values = KlipperValues {
        radius: fit.radius * 1e3,
        angles: std::array::from_fn(|i| fit.angles[i].to_degrees().rem_euclid(360.0)),
        arms: std::array::from_fn(|i| fit.arms[i] * 1e3),
        endstops: std::array::from_fn(|i| fit.endstop(i) * 1e3),
        rotation_distances: rotation_distances
            .map(|r| std::array::from_fn(|i| r[i] * fit.gains[i])),
    };
    Ok(KlipperExport {
        values,
        origin: fit.origin,
        rms_loss: fit.rms_loss,
        max_loss: fit.max_loss,
        start_rms_loss: fit.start_rms_loss,
        points: fit.points,
    })
}

/// Fits the values of a firmware with `terms` to `mechanism` (a model from
/// `legwise printer import`, calibrated or not) over the bed disc of radius `bed_radius` (m),
/// at the bed and `bed_radius / 2` above it.
///
/// # Errors
/// Not an imported delta (three legs, the parameters it names, an instrument with a target),
/// a grid point the calibrated model cannot reach, or a fit that does not converge.
pub fn fit_delta(mechanism: &Mechanism, bed_radius: f64, terms: FirmwareTerms) -> Result<DeltaFit> {
    let path = mechanism.model_path.display().to_string();
    if mechanism.legs.len() != 3 {
        return Err(Error::Invalid(format!(
            "{path}: expected the three legs of a linear delta, found {}",
            mechanism.legs.len()
        )));
    }
    let Some(instrument) = mechanism
        .instrument
        .as_ref()
        .filter(|i| i.spatial && !i.targets.is_empty())
    else {
        return Err(Error::Invalid(format!(
            "{path}: field `instrument`: expected the bed and the nozzle target of an imported printer"
        )));
    };
    let shared = instrument.nominal();
    let frame: [f64; 6] = std::array::from_fn(|k| shared[k]);
    let at = instrument.offset_index(0);
    let nozzle_offset = Vector3::new(shared[at], shared[at + 1], shared[at + 2]);
    let bed = platform_transform_f64(&frame);
    let params = mechanism.nominal_parameters();

    // The closed-form start: q = [cx, cy, radius, angles (3), rods (3), carriage tops (3),
    // tilt a, b, gains (3)].
    let mut towers = [[0.0; 2]; 3];
    let mut q = DVector::zeros(17);
    for (i, tower) in towers.iter_mut().enumerate() {
        let n = i + 1;
        *tower = [
            value(mechanism, i, &format!("t{n}x"))?
                - value(mechanism, i, &format!("e{n}x"))?
                - nozzle_offset.x,
            value(mechanism, i, &format!("t{n}y"))?
                - value(mechanism, i, &format!("e{n}y"))?
                - nozzle_offset.y,
        ];
        q[6 + i] = value(mechanism, i, &format!("L{n}"))?;
        q[9 + i] = value(mechanism, i, &format!("h0_{n}"))? - frame[2] - nozzle_offset.z;
        q[14 + i] = if terms.gains {
            value(mechanism, i, &format!("k{n}"))?
        } else {
            1.0
        };
    }
    let (centre, radius) = circumcircle(&towers).ok_or_else(|| {
        Error::Invalid(format!(
            "{path}: the three towers are on one line: no delta_radius"
        ))
    })?;
    q[0] = centre[0];
    q[1] = centre[1];
    q[2] = radius;
    for i in 0..3 {
        q[3 + i] = (towers[i][1] - centre[1]).atan2(towers[i][0] - centre[0]);
    }
    if terms.tilt {
        // The bed's normal n = R e_z; the firmware's plane z = a x + b y has n ∝ (−a, −b, 1).
        let normal = bed.rotation * Vector3::z();
        q[12] = -normal.x / normal.z;
        q[13] = -normal.y / normal.z;
    }
    // The free values and how they fill q: one rod ties the three, no tilt holds a, b at 0.
    let mut free: Vec<usize> = (0..6).collect();
    free.extend(if terms.one_rod {
        vec![6]
    } else {
        vec![6, 7, 8]
    });
    free.extend(9..12);
    if terms.tilt {
        free.extend([12, 13]);
    }
    if terms.gains {
        free.extend(14..17);
    }
    if terms.one_rod {
        let mean = (q[6] + q[7] + q[8]) / 3.0;
        for k in 6..9 {
            q[k] = mean;
        }
    }
    let expand = |p: &DVector<f64>| -> DVector<f64> {
        let mut full = q.clone();
        for (k, &j) in free.iter().enumerate() {
            full[j] = p[k];
        }
        if terms.one_rod {
            full[7] = full[6];
            full[8] = full[6];
        }
        full
    };
    let mut p = DVector::from_iterator(free.len(), free.iter().map(|&j| q[j]));

    // The grid over the bed, and the calibrated model's readings there.
    let step = bed_radius / 8.0;
    let mut samples = Vec::new();
    for level in [0.0, 0.5 * bed_radius] {
        for a in -8..=8 {
            for b in -8..=8 {
                let (x, y) = (f64::from(a) * step, f64::from(b) * step);
                if x.hypot(y) > bed_radius * (1.0 + 1e-9) {
                    continue;
                }
                let nozzle = Vector3::new(x, y, level);
                let base = bed * Point3::from(nozzle);
                let platform = base.coords - nozzle_offset;
                let pose = [platform.x, platform.y, platform.z, 0.0, 0.0, 0.0];
                let mut readings = [0.0; 3];
                for (i, leg) in mechanism.legs.iter().enumerate() {
                    readings[i] =
                        predict_reading::<f64>(leg, &params[i], &pose, &mechanism.home_pose)
                            .map_err(|e| {
                                Error::Invalid(format!(
                                "{path}: the bed grid point ({x:.4}, {y:.4}, {level:.4}) m: {e}"
                            ))
                            })?;
                }
                samples.push(Sample { nozzle, readings });
            }
        }
    }

    // Gauss–Newton on central differences.
    let residuals = |p: &DVector<f64>| -> Option<DVector<f64>> {
        let q = expand(p);
        let mut r = DVector::zeros(3 * samples.len());
        for (k, sample) in samples.iter().enumerate() {
            let f = firmware_forward(&q, &sample.readings)?;
            r[3 * k] = f.x + q[0] - sample.nozzle.x;
            r[3 * k + 1] = f.y + q[1] - sample.nozzle.y;
            r[3 * k + 2] = f.z - sample.nozzle.z;
        }
        Some(r)
    };
    let unreachable = || {
        Error::Invalid(format!(
            "{path}: the firmware's kinematics cannot reach the bed grid with the fitted values"
        ))
    };
    let mut r = residuals(&p).ok_or_else(unreachable)?;
    let start_rms_loss = rms(&r, samples.len());
    for _ in 0..50 {
        let mut jacobian = DMatrix::zeros(r.len(), p.len());
        for (k, &j) in free.iter().enumerate() {
            // Angles, tilts and gains are dimensionless: an absolute step.
            let h = if (3..6).contains(&j) || j >= 12 {
                1e-7
            } else {
                1e-7 * p[k].abs().max(0.01)
            };
            let mut plus = p.clone();
            plus[k] += h;
            let mut minus = p.clone();
            minus[k] -= h;
            let rp = residuals(&plus).ok_or_else(unreachable)?;
            let rm = residuals(&minus).ok_or_else(unreachable)?;
            jacobian.set_column(k, &((rp - rm) / (2.0 * h)));
        }
        let svd = jacobian.svd(true, true);
        let delta = svd
            .solve(&(-&r), 1e-12)
            .map_err(|e| Error::Invalid(format!("{path}: the firmware fit failed: {e}")))?;
        let trial = &p + &delta;
        let Some(rt) = residuals(&trial) else { break };
        if rt.norm() > r.norm() {
            break;
        }
        p = trial;
        r = rt;
        if delta.amax() < 1e-13 {
            break;
        }
    }
    let q = expand(&p);
    let distances: Vec<f64> = (0..samples.len())
        .map(|k| Vector3::new(r[3 * k], r[3 * k + 1], r[3 * k + 2]).norm())
        .collect();
    Ok(DeltaFit {
        radius: q[2],
        angles: [q[3], q[4], q[5]],
        arms: [q[6], q[7], q[8]],
        carriage_tops: [q[9], q[10], q[11]],
        tilt: [q[12], q[13]],
        gains: [q[14], q[15], q[16]],
        origin: [q[0], q[1]],
        rms_loss: rms(&r, samples.len()),
        max_loss: distances.iter().copied().fold(0.0, f64::max),
        start_rms_loss,
        points: samples.len(),
    })
}

/// RMS over `points` of the norm of each point's three residuals.
fn rms(r: &DVector<f64>, points: usize) -> f64 {
    (r.norm_squared() / points as f64).sqrt()
}

/// The firmware's nozzle position for readings `s` with values `q` = [cx, cy, radius, angles
/// (rad), rods, endstop carriage heights, tilt a, b, gains] (m): the point below the carriages at
/// each rod's length from its carriage `(radius cos θ_i, radius sin θ_i, h_i = A_i + g_i s_i)`,
/// lowered by the tilt `a x + b y`. `None` out of reach.
fn firmware_forward(q: &DVector<f64>, s: &[f64; 3]) -> Option<Vector3<f64>> {
    let centres: [Vector3<f64>; 3] = std::array::from_fn(|i| {
        Vector3::new(
            q[2] * q[3 + i].cos(),
            q[2] * q[3 + i].sin(),
            q[9 + i] + q[14 + i] * s[i],
        )
    });
    let p = trilaterate(&centres, &[q[6], q[7], q[8]])?;
    Some(Vector3::new(p.x, p.y, p.z - q[12] * p.x - q[13] * p.y))
}

/// The lower of the two points at distances `r` from the three `centres`.
pub fn trilaterate(centres: &[Vector3<f64>; 3], r: &[f64; 3]) -> Option<Vector3<f64>> {
    let d21 = centres[1] - centres[0];
    let d31 = centres[2] - centres[0];
    let d = d21.norm();
    let ex = d21 / d;
    let i = ex.dot(&d31);
    let ey = (d31 - ex * i).try_normalize(1e-15)?;
    let ez = ex.cross(&ey);
    let j = ey.dot(&d31);
    let x = (r[0] * r[0] - r[1] * r[1] + d * d) / (2.0 * d);
    let y = (r[0] * r[0] - r[2] * r[2] + i * i + j * j) / (2.0 * j) - i * x / j;
    let z2 = r[0] * r[0] - x * x - y * y;
    if z2.is_nan() || z2 < 0.0 {
        return None;
    }
    let base = centres[0] + ex * x + ey * y;
    let a = base + ez * z2.sqrt();
    let b = base - ez * z2.sqrt();
    Some(if a.z < b.z { a } else { b })
}

/// The circle through three points: centre and radius (`None` on one line).
fn circumcircle(p: &[[f64; 2]; 3]) -> Option<([f64; 2], f64)> {
    let [ax, ay] = p[0];
    let [bx, by] = p[1];
    let [cx, cy] = p[2];
    let d = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by));
    if d.abs() < 1e-18 {
        return None;
    }
    let a2 = ax * ax + ay * ay;
    let b2 = bx * bx + by * by;
    let c2 = cx * cx + cy * cy;
    let ux = (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / d;
    let uy = (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / d;
    Some(([ux, uy], (ax - ux).hypot(ay - uy)))
}

/// The values as a Klipper SAVE_CONFIG block (9 decimals: Klipper writes 6 and reads any).
pub fn save_config_block(values: &KlipperValues) -> String {
    let mut out = String::from(
        "#*# <---------------------- SAVE_CONFIG ---------------------->\n\
         #*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n#*#\n",
    );
    let _ = writeln!(
        out,
        "#*# [printer]\n#*# delta_radius = {:.9}\n#*#",
        values.radius
    );
    for (i, tower) in TOWERS.iter().enumerate() {
        let _ = writeln!(
            out,
            "#*# [{tower}]\n#*# angle = {:.9}\n#*# arm_length = {:.9}\n#*# position_endstop = {:.9}\n#*#",
            values.angles[i], values.arms[i], values.endstops[i]
        );
    }
    out
}

/// The steppers' new `rotation_distance`s, if any, as the lines to set in printer.cfg's
/// `[stepper_a|b|c]` sections (comments: a SAVE_CONFIG block's value does not override a
/// section's, and every stepper section holds its `rotation_distance`).
pub fn stepper_settings(values: &KlipperValues) -> String {
    let Some(r) = values.rotation_distances else {
        return String::new();
    };
    let mut out = String::from(
        "# Set in printer.cfg's stepper sections, not in the SAVE_CONFIG block (Klipper reads a\n\
         # section's own value over the block's):\n",
    );
    for (i, tower) in TOWERS.iter().enumerate() {
        let _ = writeln!(out, "#   [{tower}] rotation_distance: {:.9}", r[i]);
    }
    out
}
