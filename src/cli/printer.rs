//! `legwise printer import|export|points`: a thin shell over [`crate::printer`].

use std::fmt::Write as _;
use std::path::Path;

use super::args::{
    PrinterArgs, PrinterCommand, PrinterExportArgs, PrinterImportArgs, PrinterPointsArgs,
};
use super::verdict::Verdict;
use crate::error::Error;
use crate::model::Mechanism;
use crate::printer::delta_model::{printer_files, DeltaGeometry, ModelOptions};
use crate::printer::klipper::{KlipperConfig, KlipperDelta};
use crate::printer::marlin::{self, MarlinDelta};
use crate::printer::points::{klipper_section, marlin_g30, read_selected, rrf_bed_g};
use crate::printer::rrf::{self, RrfDelta};
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
    print!("{}", imported(args)?);
    Ok(Verdict::Trusted)
}

/// `legwise printer import`: reads the firmware's files, writes the model's files into
/// `args.out`, and returns what the command prints (the conventions, the values read, the files
/// written).
///
/// # Errors
/// Bad options, bad firmware files (named by file, line and field), a directory that cannot be
/// written.
pub(crate) fn imported(args: &PrinterImportArgs) -> anyhow::Result<String> {
    let mut out = String::new();
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
    let geometry = read_geometry(args, &mut out)?;
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
    let _ = writeln!(
        out,
        "wrote {0}/printer.yaml, {0}/printer.urdf and {0}/probe.csv ({1} touches, probe sigma {2} m)",
        args.out.display(),
        geometry.touches.len(),
        args.probe_noise
    );
    Ok(out)
}

/// The geometry of the firmware's files; the conventions and the values read go to `out`.
fn read_geometry(args: &PrinterImportArgs, out: &mut String) -> anyhow::Result<DeltaGeometry> {
    if let Some(path) = &args.klipper {
        let config = KlipperConfig::read(path)?;
        let delta = KlipperDelta::from_config(&config)?;
        let _ = writeln!(out, "{CONVENTIONS}");
        let _ = writeln!(out,
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
        for s in &config.shadowed {
            let used = config
                .get(&s.section, &s.key)
                .map_or("", |v| v.value.as_str());
            let same = match (s.value.parse::<f64>(), used.parse::<f64>()) {
                (Ok(a), Ok(b)) => a.total_cmp(&b).is_eq(),
                _ => s.value == used,
            };
            if !same {
                let _ = writeln!(
                    out,
                    "[{}] {}: the SAVE_CONFIG block's {} (line {}) is not used: line {} above \
                     sets {used}, and Klipper reads that one (SAVE_CONFIG comments it out when it \
                     saves the key)",
                    s.section, s.key, s.value, s.line, s.used_line
                );
            }
        }
        for include in config.section_names().filter(|s| s.starts_with("include ")) {
            let _ = writeln!(out,
                "[{include}]: included files are not read (import the file with the delta's sections)"
            );
        }
        if delta.touches.is_empty() {
            let _ = writeln!(out, "no [delta_calibrate] heightN in the file: probe.csv has no rows (run DELTA_CALIBRATE and SAVE_CONFIG first)");
        }
        if !delta.distances.is_empty() {
            let _ =
                writeln!(out,
                "{} distances of DELTA_ANALYZE imported (sigma {} m): the rods are identified too",
                delta.distances.len(),
                args.distance_noise
            );
        }
        return Ok(delta.geometry());
    }
    let (geometry, steps, files) = if let Some(path) = &args.rrf {
        let delta = RrfDelta::read(path, args.overrides.as_deref(), args.probes.as_deref())?;
        let _ = writeln!(out, "{}", rrf::CONVENTIONS);
        let files = match &args.overrides {
            Some(o) => format!("{} + {}", path.display(), o.display()),
            None => path.display().to_string(),
        };
        (delta.geometry, delta.steps_per_mm, files)
    } else if let Some(path) = &args.marlin {
        let delta = MarlinDelta::read(path, args.probes.as_deref())?;
        let _ = writeln!(out, "{}", marlin::CONVENTIONS);
        (
            delta.geometry,
            delta.steps_per_mm,
            path.display().to_string(),
        )
    } else {
        unreachable!("clap requires one of --klipper, --rrf, --marlin")
    };
    let _ = writeln!(out,
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
    let _ = match &args.probes {
        Some(log) if geometry.touches.is_empty() => writeln!(out,
            "{}: no probed heights found: probe.csv has no rows (docs/printers.md lists the lines read)",
            log.display()
        ),
        Some(log) => writeln!(out, "{}: {} touches", log.display(), geometry.touches.len()),
        None => writeln!(out, "no --probes log: probe.csv has no rows"),
    };
    Ok(geometry)
}

fn export(args: &PrinterExportArgs) -> anyhow::Result<Verdict> {
    let outputs = super::printer_export::exported(args)?;
    if args.out.as_os_str() == "-" {
        print!("{}", outputs.values);
    } else {
        write(&args.out, &outputs.values)?;
    }
    eprint!("{}", outputs.summary);
    if args.out.as_os_str() != "-" {
        eprintln!(
            "wrote {}: {}",
            args.out.display(),
            if args.klipper {
                "paste its block's lines over the same keys of printer.cfg's SAVE_CONFIG block \
                 (and set the rotation_distance lines above it, if any, in the stepper sections)"
            } else {
                "send its lines to the printer (or put them in its configuration)"
            }
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
