//! Delta printers in their firmware's own files: import a Klipper `printer.cfg`, a
//! RepRapFirmware `config.g` or a Marlin `M503` report (with a probe log) as a legwise model and
//! measurement CSV, and export a calibrated model as the firmware's values.
//!
//! * [`klipper`]: the `printer.cfg` reader (sections, `key: value` / `key = value`, comments,
//!   the `#*#` SAVE_CONFIG block's values where the sections above do not set the key, as
//!   Klipper reads it) and the delta it describes;
//! * [`geometry`]: a delta in the firmwares' common terms, with its touches and distances;
//! * [`delta_model`]: the legwise model (YAML + URDF) and probe CSV written for that geometry;
//! * [`export`]: the firmware values whose kinematics come closest to a calibrated model;
//! * [`gcode`]: G-code lines (RepRapFirmware's and Marlin's files and logs);
//! * [`rrf`], [`marlin`]: their readers and writers over the same geometry;
//! * [`points`]: the touches `legwise select` picks, as the firmware's probing commands.
//!
//! The conventions (Klipper's docs/Config_Reference.md and klippy/kinematics/delta.py; formulas
//! only, no code) are in docs/printers.md and [`CONVENTIONS`].

pub mod delta_model;
pub mod export;
pub mod gcode;
pub mod geometry;
pub mod klipper;
pub mod marlin;
pub mod points;
pub mod rrf;
pub mod study;

/// The conventions of the import and export, as printed by `legwise printer import`.
pub const CONVENTIONS: &str = "\
conventions (Klipper linear delta; docs/printers.md):
  towers: leg1 = stepper_a (angle default 210 deg), leg2 = stepper_b (330), leg3 = stepper_c (90);
    tower i at delta_radius * (cos angle_i, sin angle_i) in Klipper's frame (the base frame)
  delta_radius: horizontal distance from a tower's carriage line to its rod's effector end
    (|t_i - e_i|): the effector joints sit at the nozzle (attachments 0)
  carriage height: h_i = z + sqrt(arm_length_i^2 - (x - t_ix)^2 - (y - t_iy)^2), (x, y, z) the nozzle
  reading: s_i = -(steps since the endstop) * step_distance_i (m; 0 at the endstop, down negative),
    step_distance = rotation_distance / (full_steps_per_rotation * microsteps * gear_ratio)
  actuator: h_i = k_i * s_i + h0_i, k_i = 1, h0_i = position_endstop_i + sqrt(arm_length_i^2 - delta_radius^2)
  probe: heightN (the nozzle's height above the bed at the trigger, the probe's z_offset) at the
    stable position heightN_pos (steps since the endstop per tower); the bed is the instrument frame
  distances: distanceN between the nozzle at distanceN_pos1 and at distanceN_pos2 (DELTA_ANALYZE)
  units: mm -> m, degrees -> rad";
