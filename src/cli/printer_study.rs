//! `legwise printer study`: a thin shell over [`crate::printer::study`].

use std::fmt::Write as _;

use super::args::PrinterStudyArgs;
use super::checks;
use super::outputs::model_inputs;
use super::verdict::Verdict;
use crate::error::Error;
use crate::files::Output;
use crate::model::Mechanism;
use crate::printer::study::{
    klipper_calibration, PrinterStudy, PrinterStudyOptions, PrinterStudyResult, Spread,
};

/// Most printers of one study.
const MAX_PRINTERS: usize = 100_000;

pub(super) fn run(args: &PrinterStudyArgs) -> anyhow::Result<Verdict> {
    let printers = checks::count("--printers", args.printers, 1, MAX_PRINTERS)?;
    let seed = checks::seed("--seed", Some(args.seed))?.unwrap_or(1);
    let touches = checks::poses_per_leg(args.touches)?;
    let map_grid = checks::positive_metres("--map", Some(args.map))?.unwrap_or(args.map);
    let spread = Spread {
        length: checks::non_negative("--spread-length", args.spread_length)?,
        angle: checks::non_negative("--spread-angle", args.spread_angle)?,
        gain: checks::non_negative("--spread-gain", args.spread_gain)?,
    };
    let mechanism = Mechanism::load(&args.model)?;
    let inputs = model_inputs(&args.model, &mechanism);
    let json = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    let firmware = match args.klipper {
        true => Some(klipper_calibration(&mechanism)?),
        false => None,
    };
    let options = PrinterStudyOptions {
        touches,
        spread,
        map_grid,
        compare_sets: args.sets,
        ..PrinterStudyOptions::new(printers, seed)
    };
    let study = PrinterStudy::prepare(&mechanism, firmware, options)?;
    let result = study.run();
    if let Some(json) = &json {
        let text = serde_json::to_string_pretty(&study_json(&result))? + "\n";
        json.write("JSON study", text.as_bytes())?;
    }
    let text = study_text(&result)?;
    if json.as_ref().is_some_and(Output::is_stdout) {
        eprint!("{text}");
    } else {
        print!("{text}");
    }
    let mut reasons = mechanism.warnings.clone();
    let failed = result
        .printers
        .iter()
        .filter(|p| p.outcome.is_err())
        .count();
    if failed > 0 {
        reasons.push(format!(
            "{failed} of {} printers failed (their reasons are in the report)",
            result.printers.len()
        ));
    }
    Ok(Verdict::from_reasons(reasons))
}

/// The study as JSON: the options, the summary and every printer.
fn study_json(result: &PrinterStudyResult) -> serde_json::Value {
    let o = &result.options;
    let printers: Vec<serde_json::Value> = result
        .printers
        .iter()
        .map(|p| match &p.outcome {
            Ok(outcome) => {
                let mut value = serde_json::json!({"index": p.index, "seed": p.seed});
                if let (Some(map), Ok(serde_json::Value::Object(fields))) =
                    (value.as_object_mut(), serde_json::to_value(outcome))
                {
                    map.extend(fields);
                }
                value
            }
            Err(reason) => serde_json::json!({"index": p.index, "seed": p.seed, "failed": reason}),
        })
        .collect();
    serde_json::json!({
        "firmware": result.firmware,
        "printers": o.printers,
        "seed": o.seed,
        "spread": {"length_m": o.spread.length, "angle_rad": o.spread.angle, "gain": o.spread.gain},
        "firmware_touches": result.firmware_touches,
        "legwise_touches": result.legwise_touches,
        "map_points": result.map_points,
        "map_grid_m": o.map_grid,
        "summary": result.summary(),
        "choice": result.choice(),
        "per_printer": printers,
    })
}

/// The study as text.
fn study_text(result: &PrinterStudyResult) -> Result<String, Error> {
    let o = &result.options;
    let mut t = String::new();
    let w = |e: std::fmt::Error| Error::Invalid(e.to_string());
    writeln!(
        t,
        "legwise printer study: {} simulated printers (seed {}; lengths σ {} m, bed tilt σ {} rad, \
         gains σ {}), print error RMS over {} map points ({} m grid) in the frame the probe defines",
        o.printers, o.seed, o.spread.length, o.spread.angle, o.spread.gain, result.map_points, o.map_grid
    )
    .map_err(w)?;
    let Some(s) = result.summary() else {
        writeln!(t, "no printer succeeded:").map_err(w)?;
        for p in &result.printers {
            if let Err(reason) = &p.outcome {
                writeln!(t, "  printer {}: {reason}", p.index).map_err(w)?;
            }
        }
        return Ok(t);
    };
    let um = |m: f64| m * 1e6;
    writeln!(
        t,
        "  median print error (µm) over {} printers:",
        s.succeeded
    )
    .map_err(w)?;
    writeln!(
        t,
        "    imported values                          {:>8.1}",
        um(s.nominal_median)
    )
    .map_err(w)?;
    if let (Some(name), Some(firmware)) = (&result.firmware, s.firmware_median) {
        writeln!(
            t,
            "    {} ({} touches)  {:>8.1}",
            name,
            result.firmware_touches,
            um(firmware)
        )
        .map_err(w)?;
    }
    if let Some(legwise) = s.legwise_median {
        writeln!(
            t,
            "    legwise ({} touches), exported             {:>8.1}",
            result.legwise_touches,
            um(legwise)
        )
        .map_err(w)?;
    }
    writeln!(
        t,
        "    legwise's calibrated model itself        {:>8.1}{}",
        um(s.legwise_model_median),
        match result.firmware {
            Some(_) => String::new(),
            None => format!(" ({} touches)", result.legwise_touches),
        }
    )
    .map_err(w)?;
    if let (Some(ratio), Some(better)) = (s.ratio, s.legwise_better) {
        writeln!(
            t,
            "  legwise / firmware: {:.3} (median against median); legwise better on {:.0} % of the printers",
            ratio,
            100.0 * better
        )
        .map_err(w)?;
    }
    if let (Some(median), Some(max)) = (s.export_loss_median, s.export_loss_max) {
        writeln!(
            t,
            "  lost in the export (the calibrated model against the firmware values closest to it, RMS over \
             the bed): median {:.2} µm, max {:.2} µm",
            um(median),
            um(max)
        )
        .map_err(w)?;
    }
    if let Some(choice) = result.choice() {
        writeln!(
            t,
            "  every set on legwise's touches (median print error over the printers whose touches \
             determine it; how often legwise recommends it: the lowest AICc of the sets the touches determine within the tolerance):"
        )
        .map_err(w)?;
        for set in &choice.sets {
            writeln!(
                t,
                "    {:<14} {:>2} factors  determined {:>5}  {:>8} µm  recommended {:>5}",
                set.name,
                set.factors,
                set.determined,
                // `-` for a set no printer determined.
                Some(um(set.median_true_error_m))
                    .filter(|v| v.is_finite())
                    .map_or("-".to_string(), |v| format!("{v:.1}")),
                set.recommended
            )
            .map_err(w)?;
            if let Some(line) = set.spread_line() {
                writeln!(t, "{line}").map_err(w)?;
            }
        }
        writeln!(t, "{}", choice.comparison_line("µm", "printer")).map_err(w)?;
    }
    for p in &result.printers {
        if let Err(reason) = &p.outcome {
            writeln!(t, "  printer {} failed: {reason}", p.index).map_err(w)?;
        }
    }
    Ok(t)
}
