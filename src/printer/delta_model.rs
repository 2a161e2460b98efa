//! The legwise model of a linear delta printer: `printer.yaml`, `printer.urdf` and the probe's
//! measurement CSV, generated from a firmware-neutral [`DeltaGeometry`] (every length in metres
//! in the files, angles in rad) that each firmware's reader fills in.
//!
//! Leg `i` (1, 2, 3 = the towers at 210°, 330°, 90°: Klipper's a, b, c, RepRapFirmware's and
//! Marlin's X, Y, Z): the carriage `C{i}`, a prismatic joint along the vertical line through the
//! tower `t_i = radius (cos θ_i, sin θ_i)`, its frame turned by `θ_i + π` so that x points to the
//! centre; the universal joint `U{i}a`, `U{i}b`; the rod `R{i}` of length `L_i`, whose end is the
//! nozzle (attachments 0: the firmwares' delta radius is already `|t_i − e_i|`). The actuator is
//! `h_i = s_i + h0_i` with `h0_i` the carriage height at the endstop; the bed is the instrument
//! frame and the nozzle its target.

use std::fmt::Write as _;

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

/// Default σ of the probe's height, m (a typical `PROBE_ACCURACY` standard deviation).
pub const DEFAULT_PROBE_NOISE: f64 = 1.0e-5;
/// Default σ of a `DELTA_ANALYZE` distance, m (calipers on a printed part).
pub const DEFAULT_DISTANCE_NOISE: f64 = 2.0e-5;

/// Touches `legwise select` picks for an imported printer: with the rods and gains on their
/// priors, 37 of the 49 candidates leave a lower print error than 18 on both the example printer
/// and a larger real geometry (docs/printers.md §10).
pub const SELECTED_TOUCHES: usize = 37;

/// Default prior σ of each rod's length, m (rods cut or printed to a jig).
pub const DEFAULT_ROD_PRIOR: f64 = 2.0e-4;
/// Default prior σ of each carriage's gain (belt pitch and pulley against the firmware's step
/// setting).
pub const DEFAULT_GAIN_PRIOR: f64 = 1.0e-3;

/// Options of the generated model.
#[derive(Debug, Clone, Copy)]
pub struct ModelOptions {
    /// σ of the probe's height, m (the model's `noise.z`).
    pub probe_noise: f64,
    /// σ of a measured distance, m (`instrument.distances.noise`, with distances only).
    pub distance_noise: f64,
    /// Prior σ of each rod, m: the rods are identified on it from heights alone (0: held; with
    /// distances they are identified without a prior).
    pub rod_prior: f64,
    /// Prior σ of each carriage's gain: identified on it where the file gives the step settings
    /// (0: held).
    pub gain_prior: f64,
}

impl ModelOptions {
    /// The firmware's own factors only (Klipper's six, RepRapFirmware's and Marlin's): rods and
    /// gains held, as `--rod-prior 0 --gain-prior 0`.
    pub fn firmware_factors() -> Self {
        ModelOptions {
            rod_prior: 0.0,
            gain_prior: 0.0,
            ..ModelOptions::default()
        }
    }
}

impl Default for ModelOptions {
    fn default() -> Self {
        ModelOptions {
            probe_noise: DEFAULT_PROBE_NOISE,
            distance_noise: DEFAULT_DISTANCE_NOISE,
            rod_prior: DEFAULT_ROD_PRIOR,
            gain_prior: DEFAULT_GAIN_PRIOR,
        }
    }
}

/// The three files of an imported printer.
#[derive(Debug, Clone)]
pub struct PrinterFiles {
    /// `printer.yaml`.
    pub yaml: String,
    /// `printer.urdf`.
    pub urdf: String,
    /// `probe.csv`: one row per touch (`z.nozzle,C1,C2,C3,id`).
    pub csv: String,
}

/// Millimetres to metres.
const MM: f64 = 1.0e-3;

/// Tower `i`'s actuator offset `h0_i`, m: the carriage height at the endstop.
pub fn offset(delta: &DeltaGeometry, i: usize) -> f64 {
    delta.abs_endstop(i) * MM
}

/// A number written so that it reads back exactly.
fn num(v: f64) -> String {
    format!("{v:?}")
}

/// The model files of `delta`; the YAML names its URDF `urdf_name`.
pub fn printer_files(
    delta: &DeltaGeometry,
    options: &ModelOptions,
    urdf_name: &str,
) -> PrinterFiles {
    PrinterFiles {
        yaml: yaml(delta, options, urdf_name),
        urdf: urdf(delta),
        csv: csv(delta),
    }
}

fn urdf(delta: &DeltaGeometry) -> String {
    let top = (0..3).map(|i| offset(delta, i)).fold(0.0, f64::max);
    let mut out = match delta.firmware {
        Firmware::Klipper => String::from(
            "<?xml version=\"1.0\"?>\n<!-- A Klipper linear delta, generated by legwise printer import (Klipper)\n     \
             (docs/printers.md). Leg i = tower a, b, c: C{i} the carriage, prismatic along the tower\n     \
             line, x turned to the centre; U{i}a, U{i}b the universal joint; R{i} the rod (arm_length),\n     \
             its end the nozzle. Metres, radians. -->\n<robot name=\"klipper_delta\">\n  <link name=\"base\"/>\n",
        ),
        firmware => format!(
            "<?xml version=\"1.0\"?>\n<!-- A {} linear delta, generated by legwise printer import ({})\n     \
             (docs/printers.md). Leg i = tower X, Y, Z: C{{i}} the carriage, prismatic along the tower\n     \
             line, x turned to the centre; U{{i}}a, U{{i}}b the universal joint; R{{i}} the rod (M665 L),\n     \
             its end the nozzle. Metres, radians. -->\n<robot name=\"{}_delta\">\n  <link name=\"base\"/>\n",
            firmware.name(),
            firmware.name(),
            firmware.option().trim_start_matches('-')
        ),
    };
    for i in 0..3 {
        let n = i + 1;
        let [tx, ty] = delta.tower(i).map(|v| v * MM);
        let yaw = (delta.angles[i] + 180.0).to_radians();
        // Within (−π, π]: the URDF's angles stay where a reader expects radians.
        let yaw = yaw - std::f64::consts::TAU * (yaw / std::f64::consts::TAU).round();
        let rod = delta.arms[i] * MM;
        let _ = write!(
            out,
            "  <link name=\"carriage{n}\"/><link name=\"cross{n}\"/><link name=\"rod{n}\"/><link name=\"rod_end{n}\"/>\n  \
             <joint name=\"C{n}\" type=\"prismatic\">\n    <parent link=\"base\"/><child link=\"carriage{n}\"/>\n    \
             <origin xyz=\"{} {} 0\" rpy=\"0 0 {}\"/><axis xyz=\"0 0 1\"/>\n    \
             <limit lower=\"0.0\" upper=\"{}\" effort=\"100\" velocity=\"1\"/>\n  </joint>\n  \
             <joint name=\"U{n}a\" type=\"continuous\">\n    <parent link=\"carriage{n}\"/><child link=\"cross{n}\"/>\n    \
             <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/><axis xyz=\"0 1 0\"/>\n  </joint>\n  \
             <joint name=\"U{n}b\" type=\"continuous\">\n    <parent link=\"cross{n}\"/><child link=\"rod{n}\"/>\n    \
             <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/><axis xyz=\"0 0 1\"/>\n  </joint>\n  \
             <joint name=\"R{n}\" type=\"fixed\">\n    <parent link=\"rod{n}\"/><child link=\"rod_end{n}\"/>\n    \
             <origin xyz=\"{} 0 0\" rpy=\"0 0 0\"/>\n  </joint>\n",
            num(tx),
            num(ty),
            num(yaw),
            num(2.0 * top),
            num(rod)
        );
    }
    out.push_str("</robot>\n");
    out
}

fn yaml(delta: &DeltaGeometry, options: &ModelOptions, urdf_name: &str) -> String {
    let r = delta.radius * MM;
    let bed = delta.calibrate_radius.map_or(0.8 * r, |v| v * MM);
    let home_z = 0.05_f64.min(bed);
    let touch = delta.z_offset.map_or(0.0, |v| v * MM);
    let [roll, pitch] = delta.bed_roll_pitch();
    let mut out = String::new();
    if delta.firmware == Firmware::Klipper {
        let _ = write!(
            out,
            "# A Klipper linear delta with its bed probe, generated by `legwise printer import --klipper`\n\
             # (docs/printers.md): delta_radius {} mm, angles {:?} deg, arm_length {:?} mm,\n\
             # position_endstop {:?} mm. Leg i = tower a, b, c; the nozzle is the effector point; the\n\
             # carriage reading s_i = -(steps since the endstop) * step distance, h_i = k_i s_i + h0_i.\n\
             # Every value is SI: metres, radians; gains are dimensionless.\n\
             name: klipper delta with a bed probe\n",
            delta.radius, delta.angles, delta.arms, delta.endstops
        );
    } else {
        let _ = write!(
            out,
            "# A {} linear delta with its bed probe, generated by `legwise printer import {}`\n\
             # (docs/printers.md): radius {} mm, tower angles {:?} deg, rods {:?} mm, nozzle heights\n\
             # at the endstops {:?} mm, tilt {:?}. Leg i = tower X, Y, Z; the nozzle is the effector\n\
             # point; the carriage reading s_i = its travel from the endstop (the firmware's kinematics\n\
             # at the probed point), h_i = k_i s_i + h0_i. Every value is SI: metres, radians.\n\
             name: {} delta with a bed probe\n",
            delta.firmware.name(),
            delta.firmware.option(),
            delta.radius,
            delta.angles,
            delta.arms,
            delta.endstops,
            delta.tilt,
            delta.firmware.name()
        );
    }
    let _ = write!(
        out,
        "urdf: {urdf_name}\nmeasured: [x, y, z]\n\
         mode: \"rods below the carriages (elbows up)\"\nhome:\n  pose: {{x: 0.0, y: 0.0, z: {}}}\n\nlegs:\n",
        num(home_z)
    );
    for i in 0..3 {
        let n = i + 1;
        let l = delta.arms[i] * MM;
        let h0 = offset(delta, i);
        let vertical = (l * l - r * r).sqrt();
        let carriage = home_z + vertical;
        let elbow = vertical.atan2(r);
        let _ = write!(
            out,
            "  - name: leg{n}\n    chain: [C{n}, U{n}a, U{n}b, R{n}]\n    \
             actuator: {{joint: C{n}, gain: 1.0, offset: {}}}\n    attachment: [0.0, 0.0, 0.0]\n    \
             home: {{C{n}: {}, U{n}a: {}, U{n}b: 0.0}}\n",
            num(h0),
            num(carriage),
            num(elbow)
        );
    }
    let with_distances = !delta.distances.is_empty();
    let names = FirmwareNames::of(delta);
    out.push('\n');
    out.push_str(&names.quantities_yaml(delta));
    let rods_on_prior = !with_distances && options.rod_prior > 0.0;
    let gains_on_prior = delta.steps_known && options.gain_prior > 0.0;
    out.push_str(&parameters_comment(
        with_distances,
        rods_on_prior,
        gains_on_prior,
    ));
    for i in 0..3 {
        let n = i + 1;
        let tower_held = |c: &str| i == 2 || (i == 0 && c == "x");
        for c in ["x", "y"] {
            let held = if tower_held(c) {
                ", identify: false"
            } else {
                ""
            };
            let value = names.tower(i, c);
            let _ = writeln!(
                out,
                "  - {{name: t{n}{c}, joint: C{n}, origin: {c}{held}, value: \"{value}\"}}"
            );
        }
        let rod_held = if with_distances {
            String::new()
        } else if rods_on_prior {
            format!(", prior: {}", num(options.rod_prior))
        } else {
            ", identify: false".to_string()
        };
        let rod = names.rod(i);
        let _ = writeln!(
            out,
            "  - {{name: L{n}, joint: R{n}, origin: x{rod_held}, value: \"{rod}\"}}"
        );
        let gain = if gains_on_prior {
            format!("prior: {}", num(options.gain_prior))
        } else {
            "identify: false".to_string()
        };
        let _ = writeln!(
            out,
            "  - {{name: k{n}, leg: leg{n}, actuator: gain, {gain}}}"
        );
        let offset = names.offset(i);
        let _ = writeln!(
            out,
            "  - {{name: h0_{n}, leg: leg{n}, actuator: offset, value: \"{offset}\"}}"
        );
        for c in ["x", "y"] {
            let _ = writeln!(
                out,
                "  - {{name: e{n}{c}, leg: leg{n}, attachment: {c}, identify: false}}"
            );
        }
    }
    out.push_str(&names.factor_sets_yaml(with_distances));
    let _ = write!(
        out,
        "\nworkspace:\n  region: {{cylinder: {{centre: [0.0, 0.0, {}], radius: {}, height: {}}}}}\n  \
         margin: 0.0\n  grid: {}\n\n\
         # The touches `legwise select` picks (of the grid's candidates over the bed).\n\
         selection:\n  poses_per_leg: {SELECTED_TOUCHES}\n\n\
         # The probe's height sigma (--probe-noise); the carriage readings are step counts, exact.\n\
         noise: {{z: {}, readings: 0.0}}\n\n\
         # The bed is the instrument frame; the nozzle touches it at the probe's z_offset.\n\
         instrument:\n  kinematics: forward\n  tolerance: 1.0e-4\n  frame:\n    \
         pose: {{x: 0.0, y: 0.0, z: 0.0, roll: {}, pitch: {}, yaw: 0.0}}\n    identify: []\n  \
         targets:\n    - {{name: nozzle, offset: [0.0, 0.0, 0.0], measures: [z], touch: {}, identify: []}}\n",
        num(home_z),
        num(bed),
        num(2.0 * home_z),
        num((bed / 4.0).max(0.005)),
        num(options.probe_noise),
        num(roll),
        num(pitch),
        num(touch)
    );
    if with_distances {
        let _ = writeln!(
            out,
            "  distances: {{target: nozzle, noise: {}}}",
            num(options.distance_noise)
        );
    }
    out
}

/// The comment over the model's `parameters:` (and the key): what is identified and why.
fn parameters_comment(with_distances: bool, rods_on_prior: bool, gains_on_prior: bool) -> String {
    let mut out = String::from(
        "\n# phi_i = [t_ix, t_iy, L_i, k_i, h0_i] in legwise's coordinates: the firmware's six factors\n\
         # (three endstops, the radius, two tower angles) are t1y, t2x, t2y and the offsets. A probe\n\
         # cannot see where the printer stands in x, y nor its turn about z: tower c (leg3) and t1x\n\
         # are held; the bed's height and tilts are held (the offsets take them).\n",
    );
    out.push_str(if with_distances {
        "# The distances see scale: the rods are identified.\n"
    } else if rods_on_prior {
        "# Heights alone hardly see the rods: they are identified on their prior (--rod-prior).\n"
    } else {
        "# The rods are held (heights alone cannot see scale).\n"
    });
    out.push_str(if gains_on_prior {
        "# The gains (travel per step against the firmware's step setting) are identified on their\n\
         # prior (--gain-prior); `printer export --firmware-config` writes them back as the step setting.\n"
    } else {
        "# The gains are held.\n"
    });
    out.push_str(
        "# The effector joints are held: parallel rods keep the effector level, so a joint off the\n\
         # nozzle is a tower moved by as much, which the towers take.\nparameters:\n",
    );
    out
}

/// The firmware's names of the towers' quantities (Klipper's `a b c`, the others' `X Y Z`),
/// and whether one rod stands for all three.
struct FirmwareNames {
    firmware: Firmware,
    towers: [&'static str; 3],
    one_rod: bool,
}

impl FirmwareNames {
    fn of(delta: &DeltaGeometry) -> Self {
        let klipper = delta.firmware == Firmware::Klipper;
        FirmwareNames {
            firmware: delta.firmware,
            towers: if klipper {
                ["a", "b", "c"]
            } else {
                ["x", "y", "z"]
            },
            // The same number read for every tower (not nearly: one rod, or three).
            one_rod: !klipper
                && delta
                    .arms
                    .iter()
                    .all(|a| a.to_bits() == delta.arms[0].to_bits()),
        }
    }

    /// Tower `i`'s rod quantity.
    fn rod(&self, i: usize) -> String {
        match (self.firmware, self.one_rod) {
            (Firmware::Klipper, _) => format!("arm_{}", self.towers[i]),
            (_, true) => "rod".to_string(),
            (_, false) => format!("rod_{}", self.towers[i]),
        }
    }

    /// Tower `i`'s position component `c` (`x`, `y`) as an expression.
    fn tower(&self, i: usize, c: &str) -> String {
        let f = if c == "x" { "cos" } else { "sin" };
        format!("radius * {f}(angle_{})", self.towers[i])
    }

    /// Tower `i`'s carriage height at its endstop as an expression.
    fn offset(&self, i: usize) -> String {
        format!(
            "endstop_{} + sqrt({}^2 - radius^2)",
            self.towers[i],
            self.rod(i)
        )
    }

    /// The `quantities:` block: the firmware's geometry in SI units.
    fn quantities_yaml(&self, delta: &DeltaGeometry) -> String {
        let mut out = String::from(
            "# The firmware's own geometry (SI: metres, radians): the parameters below follow it in\n\
             # the firmware's factor sets (`legwise sets`); the model's own fit identifies them directly.\n\
             quantities:\n",
        );
        let _ = writeln!(
            out,
            "  - {{name: radius, value: {}, unit: m}}",
            num(delta.radius * MM)
        );
        for (i, t) in self.towers.iter().enumerate() {
            let angle = delta.angles[i].to_radians();
            let _ = writeln!(
                out,
                "  - {{name: angle_{t}, value: {}, unit: rad}}",
                num(angle)
            );
        }
        match self.firmware != Firmware::Klipper && self.one_rod {
            true => {
                let _ = writeln!(
                    out,
                    "  - {{name: rod, value: {}, unit: m}}",
                    num(delta.arms[0] * MM)
                );
            }
            false => {
                for i in 0..3 {
                    let (rod, value) = (self.rod(i), num(delta.arms[i] * MM));
                    let _ = writeln!(out, "  - {{name: {rod}, value: {value}, unit: m}}");
                }
            }
        }
        for (i, t) in self.towers.iter().enumerate() {
            let value = num(delta.endstops[i] * MM);
            let _ = writeln!(out, "  - {{name: endstop_{t}, value: {value}, unit: m}}");
        }
        out.push('\n');
        out
    }

    /// The `factor_sets:` block: the firmware's calibration factors.
    fn factor_sets_yaml(&self, with_distances: bool) -> String {
        let [a, b, c] = self.towers;
        let endstops = format!("endstop_{a}, endstop_{b}, endstop_{c}");
        let rods = (0..3).map(|i| self.rod(i)).collect::<Vec<_>>();
        let mut sets: Vec<(String, String, String)> = Vec::new();
        let mut set = |name: &str, fit: String, note: &str| {
            sets.push((name.to_string(), fit, note.to_string()));
        };
        match self.firmware {
            Firmware::Klipper => {
                let six = format!("radius, angle_{a}, angle_{b}, {endstops}");
                set(
                    "klipper-6",
                    six.clone(),
                    "DELTA_CALIBRATE: endstops, radius, two tower angles",
                );
                let note = match with_distances {
                    true => "DELTA_CALIBRATE METHOD=enhanced: also the three arms (needs the distances)",
                    false => "the enhanced method's nine factors on heights alone (Klipper asks for distances)",
                };
                set("klipper-9", format!("{six}, {}", rods.join(", ")), note);
            }
            Firmware::Rrf => {
                let four = format!("{endstops}, radius");
                let six = format!("{four}, angle_{a}, angle_{b}");
                let tilt = "frame_roll, frame_pitch";
                set("rrf-3", endstops.clone(), "G30 S3: endstop corrections");
                set("rrf-4", four, "G30 S4: and the delta radius");
                set(
                    "rrf-6",
                    six.clone(),
                    "G30 S6: and two tower angle corrections",
                );
                set("rrf-8", format!("{six}, {tilt}"), "G30 S8: and the bed tilt (here a turn of the bed, RepRapFirmware's is a shear)");
                if self.one_rod {
                    set(
                        "rrf-7",
                        format!("{six}, rod"),
                        "G30 S7: and the diagonal rod",
                    );
                    set(
                        "rrf-9",
                        format!("{six}, rod, {tilt}"),
                        "G30 S9: rod and bed tilt",
                    );
                }
            }
            Firmware::Marlin => {
                let four = format!("{endstops}, radius");
                set(
                    "marlin-4",
                    four.clone(),
                    "G33 T: height, endstops and radius, no tower angles",
                );
                set(
                    "marlin-6",
                    format!("{four}, angle_{a}, angle_{b}"),
                    "G33: height, endstops, radius and tower angles",
                );
            }
        }
        let mut out = String::from("\n# The firmware's calibration factors, fitted beside the model's own set by `legwise sets`.\nfactor_sets:\n");
        for (name, fit, note) in sets {
            let _ = writeln!(out, "  - {{name: {name}, fit: [{fit}], note: \"{note}\"}}");
        }
        out
    }
}

fn csv(delta: &DeltaGeometry) -> String {
    let with_distances = !delta.distances.is_empty();
    let tail = if with_distances { ",,," } else { "" };
    let mut out = String::from("z.nozzle,C1,C2,C3,id");
    out.push_str(if with_distances {
        ",from,to,distance\n"
    } else {
        "\n"
    });
    let readings =
        |r: &[f64; 3]| format!("{},{},{}", num(r[0] * MM), num(r[1] * MM), num(r[2] * MM));
    for touch in &delta.touches {
        let _ = writeln!(
            out,
            "{},{},{}{tail}",
            num(touch.height_mm * MM),
            readings(&touch.readings_mm),
            touch.id
        );
    }
    // A distance: its two positions as rows of readings alone (a position already written for
    // an earlier distance is named by its row's id, not written twice), then the distance row.
    let mut written: Vec<(String, String)> = Vec::new();
    for distance in &delta.distances {
        let mut ends = Vec::new();
        for (k, ends_mm) in distance.readings_mm.iter().enumerate() {
            let cells = readings(ends_mm);
            if let Some((_, id)) = written.iter().find(|(c, _)| *c == cells) {
                ends.push(id.clone());
                continue;
            }
            let id = format!("{}_pos{}", distance.id, k + 1);
            let _ = writeln!(out, ",{cells},{id}{tail}");
            written.push((cells, id.clone()));
            ends.push(id);
        }
        let _ = writeln!(
            out,
            ",,,,,{},{},{}",
            ends[0],
            ends[1],
            num(distance.distance_mm * MM)
        );
    }
    out
}
