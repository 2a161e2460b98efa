//! `legwise printer import|export|points`: a thin shell over [`crate::printer`].

use std::path::Path;

use super::args::{
    PrinterArgs, PrinterCommand, PrinterExportArgs, PrinterImportArgs, PrinterPointsArgs,
};
use super::verdict::Verdict;
use crate::error::Error;
use crate::model::region::Region;
use crate::model::Mechanism;
use crate::printer::delta_model::{printer_files, DeltaGeometry, ModelOptions};
use crate::printer::export::{calibrated_gains, fit_delta, fit_klipper, save_config_block};
use crate::printer::klipper::{KlipperConfig, KlipperDelta};
use crate::printer::marlin::{self, MarlinDelta, MarlinValues};
use crate::printer::points::{klipper_section, marlin_g30, read_selected, rrf_bed_g};
use crate::printer::rrf::{self, RrfDelta, RrfValues};
use crate::printer::CONVENTIONS;

pub(super) fn run(args: &PrinterArgs) -> anyhow::Result<Verdict> {
    match &args.command {
        PrinterCommand::Import(args) => import(args),
        PrinterCommand::Export(args) => export(args),
        PrinterCommand::Points(args) => points(args),
        PrinterCommand::Study(args) => super::printer_study::run(args),
    }
}

fn write(path: &Path, contents: &str) -> Result<(), Error> {
    std::fs::write(path, contents).map_err(|error| Error::Io {
        path: path.to_path_buf(),
        error,
    })
}

fn import(args: &PrinterImportArgs) -> anyhow::Result<Verdict> {
    if !(args.probe_noise.is_finite() && args.probe_noise > 0.0) {
        return Err(Error::Invalid(format!(
            "--probe-noise: expected a positive σ in metres, found {}",
            args.probe_noise
        ))
        .into());
    }
    if !(args.distance_noise.is_finite() && args.distance_noise > 0.0) {
        return Err(Error::Invalid(format!(
            "--distance-noise: expected a positive σ in metres, found {}",
            args.distance_noise
        ))
        .into());
    }
    for (option, value) in [
        ("--rod-prior", args.rod_prior),
        ("--gain-prior", args.gain_prior),
    ] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(Error::Invalid(format!(
                "{option}: expected a σ ≥ 0 (0 holds the factor), found {value}"
            ))
            .into());
        }
    }
    let geometry = read_geometry(args)?;
    std::fs::create_dir_all(&args.out).map_err(|error| Error::Io {
        path: args.out.clone(),
        error,
    })?;
    let options = ModelOptions {
        probe_noise: args.probe_noise,
        distance_noise: args.distance_noise,
        rod_prior: args.rod_prior,
        gain_prior: args.gain_prior,
    };
    let files = printer_files(&geometry, &options, "printer.urdf");
    write(&args.out.join("printer.yaml"), &files.yaml)?;
    write(&args.out.join("printer.urdf"), &files.urdf)?;
    write(&args.out.join("probe.csv"), &files.csv)?;
    println!(
        "wrote {0}/printer.yaml, {0}/printer.urdf and {0}/probe.csv ({1} touches, probe sigma {2} m)",
        args.out.display(),
        geometry.touches.len(),
        args.probe_noise
    );
    Ok(Verdict::Trusted)
}

/// The geometry of the firmware's files, printing the conventions and the values read.
fn read_geometry(args: &PrinterImportArgs) -> anyhow::Result<DeltaGeometry> {
    if let Some(path) = &args.klipper {
        let config = KlipperConfig::read(path)?;
        let delta = KlipperDelta::from_config(&config)?;
        println!("{CONVENTIONS}");
        println!(
            "read {}: delta_radius {} mm, angles {:?} deg, arm_length {:?} mm, position_endstop {:?} mm, \
             step distance {:?} mm, probe z_offset {}",
            path.display(),
            delta.radius,
            delta.angles,
            delta.arms,
            delta.endstops,
            delta.step_distances,
            delta
                .z_offset
                .map_or("none".to_string(), |z| format!("{z} mm"))
        );
        for include in config.section_names().filter(|s| s.starts_with("include ")) {
            println!(
                "[{include}]: included files are not read (import the file with the delta's sections)"
            );
        }
        if delta.touches.is_empty() {
            println!("no [delta_calibrate] heightN in the file: probe.csv has no rows (run DELTA_CALIBRATE and SAVE_CONFIG first)");
        }
        if !delta.distances.is_empty() {
            println!(
                "{} distances of DELTA_ANALYZE imported (sigma {} m): the rods are identified too",
                delta.distances.len(),
                args.distance_noise
            );
        }
        return Ok(delta.geometry());
    }
    let (geometry, steps, files) = if let Some(path) = &args.rrf {
        let delta = RrfDelta::read(path, args.overrides.as_deref(), args.probes.as_deref())?;
        println!("{}", rrf::CONVENTIONS);
        let files = match &args.overrides {
            Some(o) => format!("{} + {}", path.display(), o.display()),
            None => path.display().to_string(),
        };
        (delta.geometry, delta.steps_per_mm, files)
    } else if let Some(path) = &args.marlin {
        let delta = MarlinDelta::read(path, args.probes.as_deref())?;
        println!("{}", marlin::CONVENTIONS);
        (
            delta.geometry,
            delta.steps_per_mm,
            path.display().to_string(),
        )
    } else {
        unreachable!("clap requires one of --klipper, --rrf, --marlin")
    };
    println!(
        "read {files}: radius {} mm, tower angles {:?} deg, rods {:?} mm, nozzle heights at the endstops \
         {:?} mm, tilt {:?}, probe trigger height {}, M92 {}",
        geometry.radius,
        geometry.angles,
        geometry.arms,
        geometry.endstops,
        geometry.tilt,
        geometry
            .z_offset
            .map_or("none".to_string(), |z| format!("{z} mm")),
        steps.map_or("not given".to_string(), |s| format!("{s:?} steps/mm"))
    );
    match &args.probes {
        Some(log) if geometry.touches.is_empty() => println!(
            "{}: no probed heights found: probe.csv has no rows (docs/printers.md lists the lines read)",
            log.display()
        ),
        Some(log) => println!("{}: {} touches", log.display(), geometry.touches.len()),
        None => println!("no --probes log: probe.csv has no rows"),
    }
    Ok(geometry)
}

fn export(args: &PrinterExportArgs) -> anyhow::Result<Verdict> {
    let mechanism = Mechanism::load(&args.calibrated)?;
    let bed_radius = match args.bed_radius {
        Some(r) if r.is_finite() && r > 0.0 => r,
        Some(r) => {
            return Err(Error::Invalid(format!(
                "--bed-radius: expected a positive radius in metres, found {r}"
            ))
            .into())
        }
        None => match mechanism.workspace.region {
            Region::Cylinder { radius, .. } => radius,
            _ => {
                return Err(Error::Invalid(format!(
                    "{}: field `workspace.region`: expected the cylinder of an imported printer, or give --bed-radius",
                    args.calibrated.display()
                ))
                .into())
            }
        },
    };
    let steps = match &args.firmware_config {
        Some(path) => Some(firmware_steps(args, path)?),
        None => None,
    };
    if steps.is_none() {
        note_unexported_gains(&mechanism)?;
    }
    if args.klipper {
        return export_klipper(args, &mechanism, bed_radius, steps);
    }
    let (terms, name) = if args.rrf {
        (rrf::TERMS, "RepRapFirmware")
    } else {
        (marlin::TERMS, "Marlin")
    };
    let fit = fit_delta(&mechanism, bed_radius, terms.with_gains(steps.is_some()))?;
    let gains = if steps.is_some() { "" } else { "gains, " };
    let (lines, summary, lost) = if args.rrf {
        let v = RrfValues::from_fit(&fit, steps);
        (
            v.lines(),
            format!(
                "M665 L {:.6?} R {:.6} H {:.6} X Y Z {:.6?} deg; M666 X Y Z {:.6?} mm, A B {:.6?} %{}",
                v.rods,
                v.radius,
                v.height,
                v.corrections,
                v.adjustments,
                v.tilt,
                steps_text(v.steps_per_mm)
            ),
            format!("{gains}a bed tilt beyond the firmware's shear"),
        )
    } else {
        // Marlin's H counts from the probe's M851 Z: the model keeps it as the nozzle's touch
        // height (−M851 Z).
        let touch = mechanism
            .instrument
            .as_ref()
            .and_then(|i| i.targets.first())
            .and_then(|t| t.touch)
            .unwrap_or(0.0);
        let v = MarlinValues::from_fit(&fit, -touch * 1e3, steps);
        (
            v.lines(),
            format!(
                "M665 L {:.6} R {:.6} H {:.6} X Y Z {:.6?} deg A B C {:.6?} mm; M666 X Y Z {:.6?} mm (M851 Z {:.6} mm){}",
                v.rod,
                v.radius,
                v.height,
                v.trims,
                v.rod_trims,
                v.adjustments,
                -touch * 1e3,
                steps_text(v.steps_per_mm)
            ),
            format!("{gains}a bed tilt"),
        )
    };
    if args.out.as_os_str() == "-" {
        print!("{lines}");
    } else {
        write(&args.out, &lines)?;
    }
    eprintln!(
        "{name} values closest to {} over the bed (r <= {:.1} mm, {} points at 0 and {:.1} mm): {summary}",
        args.calibrated.display(),
        bed_radius * 1e3,
        fit.points,
        bed_radius * 5e2,
    );
    eprintln!(
        "lost in the export (what {name} cannot express: {lost}): {:.3} µm RMS, {:.3} µm max \
         of the nozzle's position over the bed; the firmware's origin at ({:.4}, {:.4}) mm of the bed frame",
        fit.rms_loss * 1e6,
        fit.max_loss * 1e6,
        fit.origin[0] * 1e3,
        fit.origin[1] * 1e3
    );
    if args.out.as_os_str() != "-" {
        eprintln!(
            "wrote {}: send its lines to the printer (or put them in its configuration)",
            args.out.display()
        );
    }
    Ok(Verdict::Trusted)
}

/// The step settings of the firmware file `path` the printer was imported from: Klipper's
/// steppers' `rotation_distance` (mm), or `M92 X Y Z` (steps per mm).
fn firmware_steps(args: &PrinterExportArgs, path: &Path) -> Result<[f64; 3], Error> {
    if args.klipper {
        let config = KlipperConfig::read(path)?;
        let mut out = [0.0; 3];
        for (i, tower) in crate::printer::klipper::TOWERS.iter().enumerate() {
            out[i] = config.require_float(tower, "rotation_distance", "mm per motor turn")?;
        }
        return Ok(out);
    }
    let steps = if args.rrf {
        RrfDelta::read(path, None, None)?.steps_per_mm
    } else {
        MarlinDelta::read(path, None)?.steps_per_mm
    };
    steps.ok_or_else(|| {
        Error::Invalid(format!(
            "{}: expected `M92 X Y Z` (steps per mm) to write the calibrated gains, found none",
            path.display()
        ))
    })
}

/// Says so when the calibrated model's gains differ from 1 and no firmware file was given to
/// write them.
fn note_unexported_gains(mechanism: &Mechanism) -> Result<(), Error> {
    let gains = calibrated_gains(mechanism)?;
    if gains.iter().any(|g| (g - 1.0).abs() > 1e-12) {
        eprintln!(
            "note: the calibrated gains {gains:.6?} are not exported (they count in the loss): give \
             --firmware-config with the file the printer was imported from to write them as its \
             step settings"
        );
    }
    Ok(())
}

/// The new step settings in words, if any.
fn steps_text(steps: Option<[f64; 3]>) -> String {
    steps.map_or_else(String::new, |s| format!("; M92 X Y Z {s:.6?} steps/mm"))
}

fn export_klipper(
    args: &PrinterExportArgs,
    mechanism: &Mechanism,
    bed_radius: f64,
    rotation_distances: Option<[f64; 3]>,
) -> anyhow::Result<Verdict> {
    let fit = fit_klipper(mechanism, bed_radius, rotation_distances)?;
    let block = save_config_block(&fit.values);
    if args.out.as_os_str() == "-" {
        print!("{block}");
    } else {
        write(&args.out, &block)?;
    }
    let v = &fit.values;
    eprintln!(
        "Klipper values closest to {} over the bed (r <= {:.1} mm, {} points at 0 and {:.1} mm): \
         delta_radius {:.6} mm, angle {:.6?} deg, arm_length {:.6?} mm, position_endstop {:.6?} mm{}",
        args.calibrated.display(),
        bed_radius * 1e3,
        fit.points,
        bed_radius * 5e2,
        v.radius,
        v.angles,
        v.arms,
        v.endstops,
        v.rotation_distances
            .map_or_else(String::new, |r| format!(", rotation_distance {r:.6?} mm"))
    );
    eprintln!(
        "lost in the export (what Klipper cannot express: {}a bed tilt): {:.3} µm RMS, {:.3} µm max \
         of the nozzle's position over the bed; Klipper's origin at ({:.4}, {:.4}) mm of the bed frame",
        if v.rotation_distances.is_some() { "" } else { "gains, " },
        fit.rms_loss * 1e6,
        fit.max_loss * 1e6,
        fit.origin[0] * 1e3,
        fit.origin[1] * 1e3
    );
    if args.out.as_os_str() != "-" {
        eprintln!(
            "wrote {}: paste its lines over the same keys of printer.cfg's SAVE_CONFIG block",
            args.out.display()
        );
    }
    Ok(Verdict::Trusted)
}

/// The `G30 P` points RepRapFirmware keeps on its smaller boards (MaxProbePoints).
const RRF_POINTS: usize = 32;

fn points(args: &PrinterPointsArgs) -> anyhow::Result<Verdict> {
    let mechanism = Mechanism::load(&args.model)?;
    let touches = read_selected(&args.selected, &mechanism)?;
    let source = args.selected.display().to_string();
    let (text, name, next) = if let Some(path) = &args.rrf {
        let delta = RrfDelta::read(path, args.overrides.as_deref(), None)?;
        if touches.len() > RRF_POINTS {
            eprintln!(
                "note: {} G30 P points: RepRapFirmware keeps {RRF_POINTS} on some boards \
                 (MaxProbePoints); if it refuses P{RRF_POINTS}, select fewer (--poses-per-leg)",
                touches.len()
            );
        }
        (
            rrf_bed_g(&touches, delta.probe_offset, &source),
            "RepRapFirmware",
            "run it as bed.g (G32) with the console logged, then `legwise printer import --rrf … --probes LOG`",
        )
    } else if let Some(path) = &args.marlin {
        let delta = MarlinDelta::read(path, None)?;
        let [x, y, _] = delta.probe_offset;
        (
            marlin_g30(&touches, [x, y], &source),
            "Marlin",
            "send its lines with the host's log on, then `legwise printer import --marlin … --probes LOG`",
        )
    } else if let Some(path) = &args.klipper {
        let config = KlipperConfig::read(path)?;
        let section = "delta_calibrate";
        let radius = config.require_float(section, "radius", "the probed radius, mm")?;
        let text = klipper_section(
            &touches,
            radius,
            config.float(section, "speed")?,
            config.float(section, "horizontal_move_z")?,
            &source,
        );
        (
            text,
            "Klipper",
            "put it in printer.cfg, DELTA_CALIBRATE, SAVE_CONFIG, then `legwise printer import --klipper printer.cfg`",
        )
    } else {
        unreachable!("clap requires one of --klipper, --rrf, --marlin")
    };
    if args.out.as_os_str() == "-" {
        print!("{text}");
    } else {
        write(&args.out, &text)?;
    }
    eprintln!(
        "{} touches of {} written as {name}'s probing commands to {}: {next}",
        touches.len(),
        args.selected.display(),
        if args.out.as_os_str() == "-" {
            "standard output".to_string()
        } else {
            args.out.display().to_string()
        }
    );
    Ok(Verdict::Trusted)
}
