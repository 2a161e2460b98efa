//! The EXIT STATUS and EXAMPLES sections at the end of `--help`.

/// The exit codes, shared by every command's help.
macro_rules! exit_status {
    () => {
        "EXIT STATUS:
  0  success; warnings alone keep 0
  2  bad input or usage: one line `legwise: …` names the file, line, column or option
  3  the run finished but its result must not be trusted (a solve did not converge, the
     residuals reject the declared noise, or a reported number is not finite): one
     `legwise: warning: …` line per reason on standard error
  A closed standard output (`legwise … | head`) is not an error: the output stops there."
    };
}

/// A command's closing sections: EXIT STATUS, then EXAMPLES (`$examples`, from a newline).
macro_rules! examples {
    ($examples:literal) => {
        concat!(exit_status!(), "\n\nEXAMPLES:", $examples)
    };
}

/// `legwise --help`.
pub(super) const TOP: &str = concat!(
    "FILES:
  A path `-` means standard input for --measurements and standard output for --out, --json and
  --svg (the human-readable text then goes to standard error). Outputs are written to a
  temporary file beside the target and renamed; an output that is one of the run's inputs is
  refused. The method is described in docs/method.md.

",
    exit_status!(),
    "

EXAMPLES:
  legwise identify --model models/5r.yaml
  legwise select --model models/5r.yaml --out poses.csv
  legwise identify --model models/5r.yaml --measurements poses.csv
  legwise workspace --model models/5r.yaml
  legwise montecarlo --model models/5r.yaml --trials 1000"
);

/// `legwise identify --help`.
pub(super) const IDENTIFY: &str = examples!(
    "
  # the bundled 5R, simulated at its selected poses, divide and conquer with Levenberg-Marquardt
  legwise identify --model models/5r.yaml
  # the 3-RPR, both strategies, Gauss-Newton, noise-free, with a JSON report
  legwise identify --model models/3rpr.yaml --strategy both --solver gn --noise-scale 0 --json report.json
  # from a measurement file, or from standard input
  legwise identify --model models/5r.yaml --measurements measurements.csv
  legwise simulate --model models/5r.yaml --out - | legwise identify --model models/5r.yaml --measurements -
  # the JSON report on standard output (the terminal report goes to standard error)
  legwise identify --model models/5r.yaml --json - 2>/dev/null
  # bad data: a robust (Cauchy) loss scaled by the declared noise, or a refit without the
  # outlier rows; weighted least squares with the declared noise
  legwise identify --model models/5r.yaml --measurements measurements.csv --robust cauchy
  legwise identify --model models/5r.yaml --measurements measurements.csv --drop-outliers
  legwise identify --model models/5r.yaml --measurements measurements.csv --weights noise
  # after the fit: the calibrated model (calibrated.yaml + calibrated.urdf); in simulation the
  # accuracy map before and after, 1 cm grid over 0.95 of the workspace region
  legwise identify --model models/5r.yaml --measurements measurements.csv --calibrated calibrated.yaml
  legwise identify --model models/5r.yaml --strategy both --map 0.01 --json report.json"
);

/// `legwise select --help`.
pub(super) const SELECT: &str = examples!(
    "
  # 18 D-optimal poses per leg (the model's defaults), to measure and fill in
  legwise select --model models/5r.yaml --out poses.csv
  # one shared set for the traditional strategy, E-optimal, on a 1 cm grid
  legwise select --model models/5r.yaml --strategy traditional --criterion e --grid 0.01 --out shared.csv
  # the poses on standard output
  legwise select --model models/3rpr.yaml --poses-per-leg 12 --out -"
);

/// `legwise simulate --help`.
pub(super) const SIMULATE: &str = examples!(
    "
  # the model's simulation block at its selected poses
  legwise simulate --model models/5r.yaml --out measurements.csv
  # noise-free, at 30 random poses per leg, another seed
  legwise simulate --model models/5r.yaml --poses random --poses-per-leg 30 --seed 7 --noise-scale 0 --out m.csv
  # the CSV on standard output (the summary goes to standard error)
  legwise simulate --model models/5r.yaml --out - | head -3"
);

/// `legwise workspace --help`.
pub(super) const WORKSPACE: &str = examples!(
    "
  # the MIW of the bundled 5R and its picture 5r-workspace.svg
  legwise workspace --model models/5r.yaml
  # a finer boundary, the picture elsewhere
  legwise workspace --model models/3rpr.yaml --rays 4000 --svg 3rpr-miw.svg
  # a spatial model: the 3-D MIW (a ball at the home orientation), pictured in three slices
  legwise workspace --model models/hexapod.yaml"
);

/// `legwise sets --help`.
pub(super) const SETS: &str = examples!(
    "
  # an imported printer's own fit beside its firmware's factor sets, on its probe file
  legwise sets --model printer/printer.yaml --measurements printer/probe.csv
  # on the model's simulated experiment, the table also as JSON
  legwise sets --model printer/printer.yaml --json sets.json"
);

/// `legwise how-many --help`.
pub(super) const HOW_MANY: &str = examples!(
    "
  # the delta probe's predicted σ over the bed at 9 to 74 selected touches
  legwise how-many --model models/delta-probe.yaml
  # chosen counts
  legwise how-many --model models/delta-probe.yaml --counts 8,12,18,37"
);

/// `legwise evaluate --help`.
pub(super) const EVALUATE: &str = examples!(
    "
  # the calibrated model on poses held out of the fit, side by side with the nominal model
  legwise evaluate --model calibrated.yaml --measurements held-out.csv --against models/5r.yaml
  # the same as JSON on standard output (the terminal report goes to standard error)
  legwise evaluate --model calibrated.yaml --measurements held-out.csv --json -
  # a model with an instrument block: the file holds target coordinates, the errors are
  # where the model puts each target against where the instrument saw it
  legwise evaluate --model tracker-cal.yaml --measurements held-out.csv --against models/5r-tracker.yaml"
);

/// `legwise montecarlo --help`.
pub(super) const MONTECARLO: &str = concat!(
    exit_status!(),
    "
  With montecarlo, 3 also means that some trials failed (a fit did not converge or a pose
  could not be reached): the statistics leave them out.

EXAMPLES:
  # 10000 trials of the bundled 5R: D&C, traditional, and traditional at an equal number of
  # poses, on the same draws; the verdict with its 95 % confidence interval
  legwise montecarlo --model models/5r.yaml --trials 10000
  # another seed, Gauss-Newton, the JSON (every trial's values) and the error distributions
  legwise montecarlo --model models/3rpr.yaml --trials 2000 --seed 1 --solver gn --json mc.json --plots mc
  # a model with an instrument block: joint against two-stage identification, each trial
  # drawing the real legs and the real instrument frame and target offsets
  legwise montecarlo --model models/5r-tracker.yaml --trials 1000
  # the same results on one thread (identical for a seed whatever the thread count)
  RAYON_NUM_THREADS=1 legwise montecarlo --model models/5r.yaml --trials 100 --json -"
);

/// `legwise printer --help`.
pub(super) const PRINTER: &str = examples!(
    "
  # a Klipper delta's printer.cfg (its SAVE_CONFIG block holds DELTA_CALIBRATE's touches)
  legwise printer import --klipper printer.cfg --out mydelta --probe-noise 5e-6
  legwise identify --model mydelta/printer.yaml --measurements mydelta/probe.csv --calibrated mydelta/cal.yaml
  # the values to paste over printer.cfg's SAVE_CONFIG block, and what Klipper cannot express
  legwise printer export --klipper --calibrated mydelta/cal.yaml --out mydelta/cal.cfg
  # RepRapFirmware: config.g, config-override.g over it, and the console log of bed.g's G30 points
  legwise printer import --rrf config.g --override config-override.g --probes bed-probe.log --out rrf
  legwise printer export --rrf --calibrated rrf/cal.yaml --out rrf/cal.g
  # Marlin: an M503 report and a log of G30 X Y replies (Bed X: Y: Z:)
  legwise printer import --marlin m503.txt --probes g30.log --out marlin
  legwise printer export --marlin --calibrated marlin/cal.yaml --out marlin/cal.g
  # the touches legwise selects, as the firmware's probing commands (here RepRapFirmware's bed.g)
  legwise select --model rrf/printer.yaml --out rrf/selected.csv
  legwise printer points --rrf config.g --override config-override.g --model rrf/printer.yaml --selected rrf/selected.csv --out bed.g"
);
