//! Inputs that used to pass in silence (exit 0 with a meaningless or unintended result): each
//! is now a clear one-line message and exit 2, or, where the run finishes but its result must
//! not be trusted, warnings and exit 3. One table of cases, run through the real binary in a
//! directory of fixtures made from the bundled models.
use std::fs;
use std::path::Path;
use std::process::Command;

use super::cli::text;
use super::support::crate_path;

/// A bundled model file copied into `dir` as `name` with `from` replaced by `to` (once, and it
/// must be there), its URDF beside it.
fn edited_model(dir: &Path, model: &str, name: &str, from: &str, to: &str) {
    let original = fs::read_to_string(crate_path(&format!("models/{model}"))).unwrap();
    assert!(original.contains(from), "{model} holds {from:?}");
    fs::write(dir.join(name), original.replacen(from, to, 1)).unwrap();
    for urdf in ["5r.urdf", "3rpr.urdf"] {
        fs::copy(crate_path(&format!("models/{urdf}")), dir.join(urdf)).unwrap();
    }
}

/// The fixtures: edited models and measurement files (held-out rows in degrees, rows that
/// cannot be assembled, a CRLF file with blank lines and a bad cell).
fn fixtures(dir: &Path) {
    edited_model(dir, "5r.yaml", "5r.yaml", "name:", "name:");
    edited_model(
        dir,
        "5r.yaml",
        "offset-degrees.yaml",
        "offset: 3.141592653589793",
        "offset: 180",
    );
    edited_model(
        dir,
        "5r.yaml",
        "home-degrees.yaml",
        "A1: 2.2529, B1: -1.7673",
        "A1: 129.08, B1: -101.26",
    );
    edited_model(
        dir,
        "3rpr.yaml",
        "range-degrees.yaml",
        "yaw: [-0.5235987756, 0.5235987756]",
        "yaw: [-30, 30]",
    );
    edited_model(
        dir,
        "5r.yaml",
        "type-error.yaml",
        "pose: {x: 0.0,",
        "pose: {x: abc,",
    );
    edited_model(
        dir,
        "5r.yaml",
        "offset-1e308.yaml",
        "offset: 3.141592653589793",
        "offset: 1e308",
    );
    edited_model(
        dir,
        "5r.yaml",
        "radius-1e308.yaml",
        "radius: 0.6456521739",
        "radius: 1e308",
    );
    edited_model(
        dir,
        "5r-tracker.yaml",
        "yaw-1e308.yaml",
        "yaw: 0.4}",
        "yaw: 1e308}",
    );
    // Held-out rows: every reading of a random experiment, in degrees; and readings at which
    // the 5R cannot close (its two elbows 2.5 m apart, farther than two driven links).
    let held = dir.join("held-out.csv");
    let out = Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args([
            "simulate",
            "--model",
            "models/5r.yaml",
            "--poses",
            "random",
            "--out",
        ])
        .arg(&held)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out.stderr));
    let rows: Vec<Vec<String>> = fs::read_to_string(&held)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    let rewrite = |name: &str, cell: &dyn Fn(usize, &str) -> String| {
        let mut csv = rows[0].join(",") + "\n";
        for row in &rows[1..] {
            let cells: Vec<String> = row.iter().enumerate().map(|(c, v)| cell(c, v)).collect();
            csv += &(cells.join(",") + "\n");
        }
        fs::write(dir.join(name), csv).unwrap();
    };
    rewrite("degrees.csv", &|c, v| match (c, v.parse::<f64>()) {
        (3 | 4, Ok(r)) => (r.to_degrees()).to_string(),
        _ => v.to_string(),
    });
    rewrite("apart.csv", &|c, v| match (c, v.is_empty()) {
        (3 | 4, false) => std::f64::consts::PI.to_string(),
        _ => v.to_string(),
    });
    fs::write(
        dir.join("crlf.csv"),
        "leg,x,y,A1,A2\r\n\r\nleg1,0.0,1.1,2.2,\r\n\r\nleg1,0.0,abc,2.2,\r\n",
    )
    .unwrap();
}

/// How a case must end.
enum Ends {
    /// Exit 2 with exactly this one line on standard error (`{dir}`: the fixtures).
    Refused(&'static str),
    /// Exit 3 with standard error holding each of these.
    Untrusted(&'static [&'static str]),
}

const NOISY: &str = "{crate}/tests/data/noisy.csv";

/// The cases: the arguments (`{dir}`: the fixtures' directory, `{crate}`: the crate's) and how
/// each must end.
fn cases() -> Vec<(&'static [&'static str], Ends)> {
    use Ends::*;
    vec![
        // Simulation options with measurements.
        (&["identify", "--model", "5r.yaml", "--measurements", NOISY, "--seed", "3"],
         Refused("legwise: --seed: a simulation option, but the measurements are read from {crate}/tests/data/noisy.csv; drop --seed (or --measurements, to simulate)")),
        (&["identify", "--model", "5r.yaml", "--measurements", NOISY, "--noise-scale", "2"],
         Refused("legwise: --noise-scale: a simulation option, but the measurements are read from {crate}/tests/data/noisy.csv; drop --noise-scale (or --measurements, to simulate)")),
        (&["identify", "--model", "5r.yaml", "--measurements", NOISY, "--poses-per-leg", "5"],
         Refused("legwise: --poses-per-leg: a simulation option, but the measurements are read from {crate}/tests/data/noisy.csv; drop --poses-per-leg (or --measurements, to simulate)")),
        (&["identify", "--model", "5r.yaml", "--measurements", NOISY, "--poses", "random"],
         Refused("legwise: --poses: a simulation option, but the measurements are read from {crate}/tests/data/noisy.csv; drop --poses (or --measurements, to simulate)")),
        (&["identify", "--model", "5r.yaml", "--measurements", NOISY, "--grid", "0.01"],
         Refused("legwise: --grid: a simulation option, but the measurements are read from {crate}/tests/data/noisy.csv; drop --grid (or --measurements, to simulate)")),
        // Evaluations that cannot be trusted.
        (&["evaluate", "--model", "5r.yaml", "--measurements", "degrees.csv"],
         Untrusted(&["legwise: warning: 5r.yaml on degrees.csv: column `A1`: revolute reading", "readings in degrees instead of radians?"])),
        (&["evaluate", "--model", "5r.yaml", "--measurements", "apart.csv"],
         Untrusted(&["legwise: warning: 5r.yaml on apart.csv: no row can be assembled by the model's forward kinematics (lines "])),
        // Output paths naming a directory.
        (&["simulate", "--model", "5r.yaml", "--out", "new/"],
         Refused("legwise: new/: --out: expected a file path, found a directory path (it ends in a separator)")),
        (&["identify", "--model", "5r.yaml", "--json", "report/"],
         Refused("legwise: report/: --json: expected a file path, found a directory path (it ends in a separator)")),
        (&["identify", "--model", "5r.yaml", "--calibrated", "cal/"],
         Refused("legwise: cal/: --calibrated: expected a file path, found a directory path (it ends in a separator)")),
        // Angles in degrees in the model file.
        (&["identify", "--model", "offset-degrees.yaml"],
         Untrusted(&["legwise: warning: offset-degrees.yaml: legs[1].actuator.offset: 180 rad is beyond ±2π: an angle in degrees instead of radians?"])),
        (&["simulate", "--model", "home-degrees.yaml", "--out", "h.csv"],
         Untrusted(&["legwise: warning: home-degrees.yaml: legs[0].home.A1: 129.08 rad is beyond ±2π", "legwise: warning: home-degrees.yaml: legs[0].home.B1: -101.26 rad is beyond ±2π"])),
        (&["select", "--model", "range-degrees.yaml", "--poses-per-leg", "6", "--out", "s.csv"],
         Untrusted(&["legwise: warning: range-degrees.yaml: workspace.ranges.yaw: 30 rad is beyond ±2π"])),
        // Negative numbers.
        (&["identify", "--model", "5r.yaml", "--map", "-0.01"],
         Refused("legwise: --map: expected a positive grid spacing in metres, found -0.01")),
        (&["identify", "--model", "5r.yaml", "--map", "0.05", "--map-scale", "-1"],
         Refused("legwise: --map-scale: expected a fraction of the workspace region in (0, 1], found -1")),
        // A map grid too coarse for the region: every Monte Carlo trial failed on it.
        (&["montecarlo", "--model", "{crate}/models/delta.yaml", "--trials", "7", "--map", "0.2"],
         Refused("legwise: --map: a spacing of 0.2 m puts no grid point in the workspace region (scaled by 0.95); choose a finer grid")),
        // Type errors and absurd values in the model file.
        (&["identify", "--model", "type-error.yaml"],
         Refused("legwise: type-error.yaml: line 10 column 13: home.pose.x: expected a number, found `abc`")),
        (&["identify", "--model", "offset-1e308.yaml"],
         Refused("legwise: offset-1e308.yaml: field `legs[1].actuator.offset`: 1e308 is not a plausible value; legwise reads metres, radians and gains, and expects magnitudes up to 1e6")),
        (&["identify", "--model", "radius-1e308.yaml"],
         Refused("legwise: radius-1e308.yaml: field `workspace.region.disc.radius`: 1e308 is not a plausible value; legwise reads metres, radians and gains, and expects magnitudes up to 1e6")),
        (&["identify", "--model", "yaw-1e308.yaml"],
         Refused("legwise: yaw-1e308.yaml: field `instrument.frame.pose.yaw`: 1e308 is not a plausible value; legwise reads metres, radians and gains, and expects magnitudes up to 1e6")),
        // Usage errors on one line.
        (&["identify", "--model", "5r.yaml", "--bogus"],
         Refused("legwise: unexpected argument '--bogus' found; a similar argument exists: '--robust'; see `legwise identify --help`")),
        (&["identify", "--strategy", "foo", "--model", "5r.yaml"],
         Refused("legwise: invalid value 'foo' for '--strategy <STRATEGY>' (possible values: dc, traditional, both); see `legwise identify --help`")),
        (&["identify"],
         Refused("legwise: the following required arguments were not provided: --model <MODEL>; see `legwise identify --help`")),
        (&["idnetify"],
         Refused("legwise: unrecognized subcommand 'idnetify'; a similar subcommand exists: 'identify'; see `legwise --help`")),
        // A CRLF file with blank lines: the line an editor shows.
        (&["identify", "--model", "5r.yaml", "--measurements", "crlf.csv"],
         Refused("legwise: crlf.csv: line 5, column `y`: expected a finite number in metres, found `abc`")),
    ]
}

#[test]
fn no_input_of_the_list_passes_in_silence() {
    let dir = tempfile::tempdir().unwrap();
    fixtures(dir.path());
    let here = env!("CARGO_MANIFEST_DIR");
    let fill = |s: &str| s.replace("{crate}", here);
    for (args, ends) in cases() {
        let args: Vec<String> = args.iter().map(|a| fill(a)).collect();
        let before: Vec<_> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        let out = Command::new(env!("CARGO_BIN_EXE_legwise"))
            .args(&args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stderr = text(&out.stderr);
        match ends {
            Ends::Refused(expected) => {
                assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
                assert_eq!(stderr, fill(expected) + "\n", "{args:?}");
                let after: Vec<_> = fs::read_dir(dir.path())
                    .unwrap()
                    .map(|e| e.unwrap().file_name())
                    .collect();
                assert_eq!(after, before, "{args:?}: refused, nothing written");
            }
            Ends::Untrusted(expected) => {
                assert_eq!(out.status.code(), Some(3), "{args:?}: {stderr}");
                for part in expected {
                    assert!(stderr.contains(part), "{args:?}: {part:?} in {stderr}");
                }
            }
        }
    }
}
