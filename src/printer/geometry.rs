//! A linear delta printer in the firmwares' common terms, whatever file it came from: its
//! geometry (mm, degrees, as the firmwares write them), its probe touches and measured distances,
//! and the firmware it was read from. Each firmware's reader fills in a [`DeltaGeometry`];
//! [`super::delta_model`] writes the legwise model of it.

/// The firmware a geometry was read from (its name in the generated files' comments).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Firmware {
    /// Klipper (`printer.cfg`).
    Klipper,
    /// RepRapFirmware (`config.g`, `config-override.g`).
    Rrf,
    /// Marlin (`M503` output).
    Marlin,
}

impl Firmware {
    /// The firmware's name as written in messages.
    pub fn name(self) -> &'static str {
        match self {
            Firmware::Klipper => "Klipper",
            Firmware::Rrf => "RepRapFirmware",
            Firmware::Marlin => "Marlin",
        }
    }

    /// The `legwise printer import` option that reads it.
    pub fn option(self) -> &'static str {
        match self {
            Firmware::Klipper => "--klipper",
            Firmware::Rrf => "--rrf",
            Firmware::Marlin => "--marlin",
        }
    }
}

/// One probe touch: the nozzle's height above the bed and the carriage readings there.
#[derive(Debug, Clone, PartialEq)]
pub struct Touch {
    /// The row's id (`height0`, `P3`, `line 12`, …).
    pub id: String,
    /// The nozzle's height above the bed at the touch, mm.
    pub height_mm: f64,
    /// Each carriage's reading, mm: its travel from the endstop (0 there, down negative).
    pub readings_mm: [f64; 3],
}

/// One measured distance between the nozzle at two positions.
#[derive(Debug, Clone, PartialEq)]
pub struct Distance {
    /// The distance's id (`distance0`, …).
    pub id: String,
    /// The distance, mm.
    pub distance_mm: f64,
    /// The carriage readings at its two ends, mm.
    pub readings_mm: [[f64; 3]; 2],
}

/// A linear delta in the firmwares' common terms (mm, degrees), whatever file it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct DeltaGeometry {
    /// The firmware it was read from.
    pub firmware: Firmware,
    /// The delta radius, mm: each tower's horizontal distance from the centre to its rod's
    /// effector end (`|t_i − e_i|`).
    pub radius: f64,
    /// Each tower's angle about the centre, degrees (nominally 210, 330, 90).
    pub angles: [f64; 3],
    /// Each tower's diagonal rod, mm.
    pub arms: [f64; 3],
    /// Each tower's endstop as the nozzle's height (mm) with the carriages at their endstops and
    /// the nozzle at the centre (Klipper's `position_endstop`; RepRapFirmware `H + M666`,
    /// Marlin `H − M851 Z − M666`).
    pub endstops: [f64; 3],
    /// The firmware's bed tilt `[a, b]` (dimensionless): its carriage heights add `a x + b y`,
    /// (RepRapFirmware's `M666 A B` / 100; 0 for the others).
    pub tilt: [f64; 2],
    /// The nozzle's height above the bed when the probe triggers, mm, if known.
    pub z_offset: Option<f64>,
    /// The radius of the probed disc, mm, if the firmware keeps one.
    pub calibrate_radius: Option<f64>,
    /// The probe touches.
    pub touches: Vec<Touch>,
    /// Measured distances (Klipper's `DELTA_ANALYZE`).
    pub distances: Vec<Distance>,
    /// Whether the file gives each carriage's step setting (Klipper's `rotation_distance`,
    /// `M92`): then `printer export --firmware-config` can write calibrated gains, and the model
    /// identifies them (on their prior).
    pub steps_known: bool,
}

impl DeltaGeometry {
    /// Tower `i`'s position in the firmware's frame, mm.
    pub fn tower(&self, i: usize) -> [f64; 2] {
        let a = self.angles[i].to_radians();
        [self.radius * a.cos(), self.radius * a.sin()]
    }

    /// Tower `i`'s carriage height at its endstop, mm: `endstop_i + sqrt(L_i² − radius²)`.
    pub fn abs_endstop(&self, i: usize) -> f64 {
        self.endstops[i] + (self.arms[i].powi(2) - self.radius.powi(2)).sqrt()
    }

    /// The firmware's inverse kinematics: carriage `i`'s height with the nozzle at `p` (mm, the
    /// firmware's coordinates): `z + a x + b y + sqrt(L_i² − (x − t_ix)² − (y − t_iy)²)`;
    /// `None` out of the rod's reach.
    pub fn carriage_height(&self, i: usize, p: [f64; 3]) -> Option<f64> {
        let [tx, ty] = self.tower(i);
        let vertical = self.arms[i].powi(2) - (p[0] - tx).powi(2) - (p[1] - ty).powi(2);
        (vertical > 0.0).then(|| p[2] + self.tilt[0] * p[0] + self.tilt[1] * p[1] + vertical.sqrt())
    }

    /// The carriage readings (mm) with the nozzle at `p` (mm, the firmware's coordinates): each
    /// carriage's height minus its height at the endstop. `None` out of reach.
    pub fn readings_at(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        let mut out = [0.0; 3];
        for (i, r) in out.iter_mut().enumerate() {
            *r = self.carriage_height(i, p)? - self.abs_endstop(i);
        }
        Some(out)
    }

    /// The bed's pose in the base frame as legwise's `(roll, pitch)`, rad: the plane
    /// `z = a x + b y` on which the firmware's `z = 0` lies (the firmware shears its frame,
    /// legwise turns the bed: the two agree to first order in the tilt).
    pub fn bed_roll_pitch(&self) -> [f64; 2] {
        let [a, b] = self.tilt;
        // The bed's normal ∝ (−a, −b, 1) = Rz·Ry(pitch)·Rx(roll)·e_z
        // = (cos r sin p, −sin r, cos r cos p).
        let pitch = (-a).atan();
        let roll = (b * pitch.cos()).atan();
        // `+ 0.0`: a level bed is written `0.0`, not `-0.0`.
        [roll + 0.0, pitch + 0.0]
    }
}
