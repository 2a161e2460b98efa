//! Output files of the real binary: written whole or not at all, never over an input, checked
//! before the work; `-` is standard input or output; a closed pipe ends quietly.
use std::fs;
use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Command, Stdio};

use super::cli::{assert_fails_with, legwise, text};
use super::support::crate_path;

/// The names in a directory, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// `legwise ARGS` in the crate root with `input` on standard input.
fn legwise_with_stdin(args: &[&str], input: &[u8]) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(input).unwrap();
    child.wait_with_output().unwrap()
}

#[test]
fn an_output_that_is_the_measurement_file_is_refused_and_the_file_kept() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("meas.csv");
    let original = fs::read(crate_path("tests/data/valid.csv")).unwrap();
    fs::write(&csv, &original).unwrap();
    let path = csv.to_str().unwrap();
    // The same file under another spelling is caught too (canonicalisation).
    let other_spelling = format!("{}/./meas.csv", dir.path().display());
    for json in [path, other_spelling.as_str()] {
        assert_fails_with(
            &[
                "identify",
                "--model",
                "models/5r.yaml",
                "--measurements",
                path,
                "--json",
                json,
            ],
            &format!(
                "legwise: {json}: --json would overwrite the measurement file {path} (an input \
                 of this run); choose another path"
            ),
        );
    }
    assert_eq!(fs::read(&csv).unwrap(), original);
    assert_eq!(listing(dir.path()), ["meas.csv"]);
}

#[cfg(unix)]
#[test]
fn links_to_the_model_or_its_urdf_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("5r.yaml");
    let urdf = dir.path().join("5r.urdf");
    fs::copy(crate_path("models/5r.yaml"), &model).unwrap();
    fs::copy(crate_path("models/5r.urdf"), &urdf).unwrap();
    std::os::unix::fs::symlink(&model, dir.path().join("symlink.yaml")).unwrap();
    fs::hard_link(&urdf, dir.path().join("hardlink.urdf")).unwrap();
    let model_text = fs::read(&model).unwrap();
    let urdf_text = fs::read(&urdf).unwrap();
    let model_arg = model.to_str().unwrap();
    for (out, role, input) in [
        ("5r.yaml", "model file", model_arg.to_string()),
        ("symlink.yaml", "model file", model_arg.to_string()),
        ("5r.urdf", "URDF", urdf.display().to_string()),
        ("hardlink.urdf", "URDF", urdf.display().to_string()),
    ] {
        let out = dir.path().join(out);
        let out = out.to_str().unwrap();
        assert_fails_with(
            &["simulate", "--model", model_arg, "--out", out],
            &format!(
                "legwise: {out}: --out would overwrite the {role} {input} (an input of this run); \
                 choose another path"
            ),
        );
    }
    assert_eq!(fs::read(&model).unwrap(), model_text);
    assert_eq!(fs::read(&urdf).unwrap(), urdf_text);
}

/// A run that fails after its output was checked leaves the old file whole and no temporary
/// file behind.
#[test]
fn a_failed_run_leaves_the_old_output_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("report.json");
    fs::write(&json, "{\"old\": true}\n").unwrap();
    let out = legwise(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/unreachable.csv",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("line 5"),
        "{}",
        text(&out.stderr)
    );
    assert_eq!(fs::read_to_string(&json).unwrap(), "{\"old\": true}\n");
    assert_eq!(listing(dir.path()), ["report.json"]);
}

/// An output is replaced by rename: the old file's permissions are kept, a new file gets those
/// `File::create` gives, and no temporary file remains.
#[cfg(unix)]
#[test]
fn outputs_are_replaced_whole_with_the_usual_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference");
    fs::File::create(&reference).unwrap();
    let usual = fs::metadata(&reference).unwrap().permissions().mode();
    fs::remove_file(&reference).unwrap();
    let old = dir.path().join("old.csv");
    fs::write(&old, "old contents that are longer than nothing\n").unwrap();
    fs::set_permissions(&old, fs::Permissions::from_mode(0o640)).unwrap();
    let new = dir.path().join("new.csv");
    for path in [&old, &new] {
        let out = legwise(&[
            "select",
            "--model",
            "models/3rpr.yaml",
            "--poses-per-leg",
            "6",
            "--out",
            path.to_str().unwrap(),
        ]);
        assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
        let csv = fs::read_to_string(path).unwrap();
        assert!(csv.starts_with("leg,x,y,yaw,P1,P2,P3\n"), "{csv}");
        assert_eq!(csv.lines().count(), 1 + 3 * 6);
    }
    assert_eq!(
        fs::metadata(&old).unwrap().permissions().mode() & 0o777,
        0o640
    );
    assert_eq!(fs::metadata(&new).unwrap().permissions().mode(), usual);
    assert_eq!(listing(dir.path()), ["new.csv", "old.csv"]);
}

/// An output that cannot be written fails at once, before the work: with a measurement file
/// whose line 5 is unreachable, the message is about the output, not about line 5.
#[test]
fn an_unwritable_output_fails_before_the_work() {
    let cases = [
        (
            "tests/data/no_such_dir/report.json",
            "legwise: tests/data/no_such_dir/report.json: --json: the directory \
             tests/data/no_such_dir does not exist",
        ),
        (
            "tests/data/valid.csv/report.json",
            "legwise: tests/data/valid.csv/report.json: --json: tests/data/valid.csv is not a \
             directory",
        ),
        (
            "tests/data",
            "legwise: tests/data: --json: is a directory; expected a file path",
        ),
    ];
    for (json, expected) in cases {
        assert_fails_with(
            &[
                "identify",
                "--model",
                "models/5r.yaml",
                "--measurements",
                "tests/data/unreachable.csv",
                "--json",
                json,
            ],
            expected,
        );
    }
    // A directory that exists but takes no new file (even for root): /proc.
    if Path::new("/proc/self").exists() {
        let out = legwise(&[
            "identify",
            "--model",
            "models/5r.yaml",
            "--measurements",
            "tests/data/unreachable.csv",
            "--json",
            "/proc/report.json",
        ]);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(
            stderr
                .starts_with("legwise: /proc/report.json: --json: cannot create a file in /proc: "),
            "{stderr}"
        );
        assert!(!stderr.contains(".tmp"), "{stderr}");
    }
}

#[test]
fn simulate_out_dash_writes_the_csv_to_stdout_and_the_summary_to_stderr() {
    let out = legwise(&[
        "simulate",
        "--model",
        "models/5r.yaml",
        "--poses",
        "random",
        "--out",
        "-",
    ]);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let rows: Vec<&str> = stdout.lines().collect();
    assert_eq!(rows[0], "leg,x,y,A1,A2");
    assert_eq!(rows.len(), 1 + 3 * 18, "18 per leg and 18 shared");
    for row in &rows[1..] {
        let cells: Vec<&str> = row.split(',').collect();
        assert_eq!(cells.len(), 5, "{row}");
        assert!(
            cells[1..3].iter().all(|c| c.parse::<f64>().is_ok()),
            "{row}"
        );
    }
    assert!(
        stderr.ends_with("wrote 54 measured poses to standard output\n"),
        "{stderr}"
    );
    assert!(!Path::new(&crate_path("-")).exists(), "no file named `-`");
}

#[test]
fn identify_json_dash_writes_only_json_to_stdout() {
    let out = legwise(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/noisy.csv",
        "--json",
        "-",
    ]);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let report: serde_json::Value = serde_json::from_str(&stdout).expect("stdout is JSON");
    assert_eq!(report["results"].as_array().unwrap().len(), 1);
    assert!(stderr.contains("leg leg1 (8 readings)"), "{stderr}");
}

#[test]
fn measurements_dash_reads_stdin_and_names_it_in_errors() {
    let noisy = fs::read(crate_path("tests/data/noisy.csv")).unwrap();
    let args = [
        "identify",
        "--model",
        "models/5r.yaml",
        "--measurements",
        "-",
    ];
    let out = legwise_with_stdin(&args, &noisy);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(
        stdout.contains("measurements: standard input\n"),
        "{stdout}"
    );
    assert!(stdout.contains("leg leg2 (8 readings)"), "{stdout}");
    // The same rows from the file give the same report, line for line after the source line.
    let from_file = text(
        &legwise(&[
            "identify",
            "--model",
            "models/5r.yaml",
            "--measurements",
            "tests/data/noisy.csv",
        ])
        .stdout,
    );
    let tables = |s: &str| -> Vec<String> {
        s.lines()
            .filter(|l| {
                l.split_whitespace()
                    .next()
                    .is_some_and(|w| w == "l1" || w == "gamma2")
            })
            .map(str::to_string)
            .collect()
    };
    assert_eq!(tables(&stdout), tables(&from_file));
    assert_eq!(tables(&stdout).len(), 2);

    let nan = fs::read(crate_path("tests/data/nan_cell.csv")).unwrap();
    let out = legwise_with_stdin(&args, &nan);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        text(&out.stderr),
        "legwise: <stdin>: line 4, column `A1`: expected a finite number in SI units (radians or \
         metres), found `NaN`\n"
    );
}

/// `legwise simulate --out - | head -3`: the reader goes away after three lines of a CSV
/// (2400 rows, about 180 kB) larger than a pipe's buffer (64 kB on Linux), so the write meets
/// the closed pipe; legwise ends quietly with exit 0, without a panic. The same for
/// `--out /dev/stdout`, which is standard output.
#[test]
fn a_pipe_closed_early_ends_quietly() {
    for out in ["-", "/dev/stdout"] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_legwise"))
            .args([
                "simulate",
                "--model",
                "models/5r.yaml",
                "--poses",
                "random",
                "--poses-per-leg",
                "800",
                "--out",
                out,
            ])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut reader = BufReader::new(child.stdout.take().unwrap());
        let mut head = String::new();
        for _ in 0..3 {
            reader.read_line(&mut head).unwrap();
        }
        drop(reader);
        let result = child.wait_with_output().unwrap();
        let stderr = text(&result.stderr);
        assert_eq!(head.lines().next(), Some("leg,x,y,A1,A2"));
        assert_eq!(result.status.code(), Some(0), "{out}: {stderr}");
        assert!(!stderr.contains("panicked"), "{out}: {stderr}");
        assert!(!stderr.contains("legwise:"), "{out}: {stderr}");
    }
}

/// The terminal report to a reader that has gone: no panic, the run's own exit code.
#[test]
fn a_closed_terminal_pipe_does_not_panic() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args([
            "identify",
            "--model",
            "models/5r.yaml",
            "--measurements",
            "tests/data/noisy.csv",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let result = child.wait_with_output().unwrap();
    assert_eq!(result.status.code(), Some(0), "{}", text(&result.stderr));
    assert_eq!(text(&result.stderr), "");
}

/// A special file is written in place, never replaced by a renamed temporary file (as root, a
/// rename would turn /dev/null into a regular file).
#[cfg(unix)]
#[test]
fn a_special_file_output_is_written_in_place() {
    use std::os::unix::fs::FileTypeExt;
    let out = legwise(&[
        "select",
        "--model",
        "models/3rpr.yaml",
        "--poses-per-leg",
        "6",
        "--out",
        "/dev/null",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("poses written to /dev/null"));
    let null = fs::metadata("/dev/null").unwrap();
    assert!(null.file_type().is_char_device());
    assert_eq!(fs::read("/dev/null").unwrap(), b"");
}

/// A read-only output file is refused, not replaced by the rename (which the directory's
/// permissions would allow).
#[cfg(unix)]
#[test]
fn a_read_only_output_is_refused() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("keep.csv");
    fs::write(&csv, "keep me\n").unwrap();
    fs::set_permissions(&csv, fs::Permissions::from_mode(0o444)).unwrap();
    let path = csv.to_str().unwrap();
    assert_fails_with(
        &["simulate", "--model", "models/5r.yaml", "--out", path],
        &format!(
            "legwise: {path}: --out: the file is read-only; expected a writable file or a new path"
        ),
    );
    assert_eq!(fs::read_to_string(&csv).unwrap(), "keep me\n");
    assert_eq!(listing(dir.path()), ["keep.csv"]);
}

/// The library side of `-`: measurements written to any writer read back from any reader
/// exactly, and a reader's errors carry the name it was given.
#[test]
fn measurements_round_trip_through_any_writer_and_reader() {
    use legwise::measure::file::{read_from, write_to};
    use legwise::measure::simulate::{simulate, SimulationOptions};
    let mech = super::support::bundled("5r.yaml");
    let options = SimulationOptions {
        poses_per_leg: Some(7),
        ..SimulationOptions::default()
    };
    let set = simulate(&mech, options).unwrap().measurements;
    let mut bytes = Vec::new();
    write_to(&mut bytes, &mech, &set).unwrap();
    let back = read_from(&bytes[..], Path::new("<memory>"), &mech).unwrap();
    assert_eq!(back.len(), 3 * 7);
    for ((a, a_readings), (b, b_readings)) in set.rows().zip(back.rows()) {
        assert_eq!((a.leg, a.pose, a_readings), (b.leg, b.pose, b_readings));
    }
    let error = read_from(&b"leg,x,y,A1\n"[..], Path::new("<memory>"), &mech).unwrap_err();
    assert_eq!(
        error.to_string(),
        "<memory>: header: missing column `A2`; expected the columns leg, x, y, A1, A2"
    );
}

/// A measurement file of `rows` leg1 rows (row `k` at line `k + 2`, x = k µm), with the lines
/// of `replaced` given instead.
fn long_csv(rows: usize, replaced: &[(usize, &str)]) -> String {
    let mut text = String::from("leg,x,y,A1,A2\n");
    for k in 0..rows {
        let line = k + 2;
        match replaced.iter().find(|(l, _)| *l == line) {
            Some((_, row)) => text.push_str(row),
            None => text.push_str(&format!(
                "leg1,{},1.1,{},",
                k as f64 * 1e-6,
                2.0 + k as f64 * 1e-7
            )),
        }
        text.push('\n');
    }
    text
}

#[test]
fn a_long_file_is_read_in_row_order_and_its_first_error_in_file_order_is_named() {
    use legwise::measure::file::parse;
    let mech = super::support::bundled("5r.yaml");
    let path = Path::new("long.csv");
    // Rows in several reading batches, blank rows among them.
    let blank = [(9_000, ",,,,"), (40_001, " , ,,,")];
    let set = parse(&long_csv(50_000, &blank), path, &mech).unwrap();
    assert_eq!(set.len(), 50_000 - 2);
    let mut expected_line = 2;
    for (pose, readings) in set.rows() {
        if blank.iter().any(|(l, _)| *l == expected_line) {
            expected_line += 1;
        }
        let k = expected_line - 2;
        assert_eq!(pose.line, Some(expected_line));
        assert_eq!(pose.leg, Some(0));
        let x = format!("{}", k as f64 * 1e-6).parse::<f64>().unwrap();
        assert_eq!(pose.pose[0].to_bits(), x.to_bits());
        let reading = format!("{}", 2.0 + k as f64 * 1e-7).parse::<f64>().unwrap();
        assert_eq!(readings, [Some(reading), None]);
        expected_line += 1;
    }
    assert_eq!(expected_line, 50_002);
    // A bad cell before a row of the wrong length (both past the first batch): the cell.
    let bad_cell = (30_001, "leg1,abc,1.1,2.0,");
    let short_row = (35_000, "leg1,0.1");
    let error = parse(&long_csv(50_000, &[bad_cell, short_row]), path, &mech).unwrap_err();
    assert_eq!(
        error.to_string(),
        "long.csv: line 30001, column `x`: expected a finite number in metres, found `abc`"
    );
    // The row of the wrong length first: that row, and no later cell.
    let early_short = (20_000, "leg1,0.1");
    let error = parse(&long_csv(50_000, &[early_short, bad_cell]), path, &mech).unwrap_err();
    assert_eq!(
        error.to_string(),
        "long.csv: line 20000: expected 5 fields, found 2"
    );
    // A bad cell in the first batch and a wrong row in a later one: the cell.
    let first = (3, "leg1,0.0,1.1,,");
    let error = parse(&long_csv(50_000, &[first, short_row]), path, &mech).unwrap_err();
    assert_eq!(
        error.to_string(),
        "long.csv: line 3, column `A1`: the row belongs to leg `leg1` but its reading is empty"
    );
}

/// `legwise ARGS` with standard output on /dev/full (every write fails: no space left), which
/// must end with exit 2; its standard error.
#[cfg(target_os = "linux")]
fn exit_2_on_a_full_standard_output(args: &[&str]) -> String {
    let full = fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let result = Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::from(full))
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let stderr = text(&result.stderr);
    assert_eq!(result.status.code(), Some(2), "{args:?}: {stderr}");
    stderr
}

/// Standard output that fails otherwise than by a closed pipe (a full disk: /dev/full) is an
/// error naming the output, exit 2; only a reader that has gone ends quietly.
#[cfg(target_os = "linux")]
#[test]
fn a_standard_output_that_cannot_be_written_is_exit_2() {
    let args = ["simulate", "--model", "models/5r.yaml", "--out", "-"];
    let stderr = exit_2_on_a_full_standard_output(&args);
    assert!(
        stderr.contains("legwise: --out (standard output): cannot write the measurement CSV"),
        "{stderr}"
    );
}

/// A named pipe given as the output is written in place; when its reader leaves early the
/// run ends quietly with exit 0, as on standard output.
#[cfg(unix)]
#[test]
fn a_named_pipe_whose_reader_leaves_ends_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.csv");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    // More than a pipe's buffer (see `a_pipe_closed_early_ends_quietly`).
    let child = Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(["simulate", "--model", "models/5r.yaml", "--poses", "random"])
        .args(["--poses-per-leg", "800", "--out", fifo.to_str().unwrap()])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Opening blocks until legwise opens its end: a thread, so that a run that fails before
    // opening fails the assertions below instead of hanging the test.
    let reader = std::thread::spawn(move || {
        let mut reader = BufReader::new(fs::File::open(&fifo).unwrap());
        let mut head = String::new();
        reader.read_line(&mut head).unwrap();
        head
    });
    let result = child.wait_with_output().unwrap();
    let stderr = text(&result.stderr);
    assert_eq!(result.status.code(), Some(0), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(reader.join().unwrap(), "leg,x,y,A1,A2\n");
}

/// `--calibrated` and `--json` naming one file under two spellings relative to the working
/// directory (`cal.yaml` and `./cal.yaml`) are refused before the work.
#[test]
fn two_outputs_naming_one_file_relative_to_the_working_directory_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = crate_path("models/5r.yaml");
    let csv = crate_path("tests/data/noisy.csv");
    for (calibrated, json) in [("cal.yaml", "./cal.yaml"), ("./cal.yaml", "cal.urdf")] {
        let result = Command::new(env!("CARGO_BIN_EXE_legwise"))
            .args(["identify", "--model", model.to_str().unwrap()])
            .args(["--measurements", csv.to_str().unwrap()])
            .args(["--calibrated", calibrated, "--json", json])
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stderr = text(&result.stderr);
        assert_eq!(
            result.status.code(),
            Some(2),
            "{calibrated} {json}: {stderr}"
        );
        assert_eq!(
            stderr,
            format!(
                "legwise: {json}: --calibrated and --json would write the same file; choose \
                 another path\n"
            )
        );
        assert!(listing(dir.path()).is_empty());
    }
}

/// The terminal report on a standard output that fails otherwise than by a closed pipe (a
/// full disk) is an error naming standard output, exit 2, not a quiet end.
#[cfg(target_os = "linux")]
#[test]
fn a_terminal_report_that_cannot_be_written_is_exit_2() {
    let stderr = exit_2_on_a_full_standard_output(&["identify", "--model", "models/5r.yaml"]);
    assert!(stderr.starts_with("legwise: standard output: "), "{stderr}");
}
