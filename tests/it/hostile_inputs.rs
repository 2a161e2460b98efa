//! A sweep of hostile inputs, tried as a new user would (issue 27 §5): model files, URDFs,
//! measurement CSVs, every option of every command, output paths, tracker and spatial models.
//! The cases are data, one a line, in `tests/data/hostile/cases.txt` (its header says the
//! columns); `fixture.rs` says how a case's directory is built from the bundled files.
//!
//! Each case runs the real binary in its own directory and must end with its exit code, never
//! a panic or a hang; exit 2 with one line `legwise: …` holding the case's text and nothing
//! written or changed in the directory; exit 3 with a `legwise: warning:` line; exit 0 without
//! a NaN or an infinity in the output. Cases marked `open: …` are known problems
//! whose fix is elsewhere: they are skipped.
//!
//! To re-run the sweep against another build and see every outcome rather than assert:
//! `HOSTILE_BIN=target/release/legwise HOSTILE_REPORT=/tmp/sweep.txt cargo test --test it
//! hostile` (open cases included; `HOSTILE_ONLY=TEXT` keeps the cases whose id holds TEXT).
mod fixture;
mod table;

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use table::Case;

/// The longest a case may run before it counts as a hang.
const TIMEOUT: Duration = Duration::from_secs(120);

/// How a run ended.
struct Outcome {
    /// The exit code (`None`: killed by a signal or by the timeout).
    code: Option<i32>,
    stdout: String,
    stderr: String,
    timed_out: bool,
    elapsed: Duration,
}

/// Runs `bin ARGS` in `dir`, with `stdin` on standard input (else nothing), killed after
/// [`TIMEOUT`].
fn run(bin: &Path, dir: &Path, args: &[String], stdin: Option<&Path>) -> Outcome {
    let start = Instant::now();
    let input = match stdin {
        Some(path) => Stdio::from(std::fs::File::open(path).expect("the stdin file")),
        None => Stdio::null(),
    };
    let mut child = Command::new(bin)
        .args(args)
        .current_dir(dir)
        .stdin(input)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the legwise binary runs");
    let drain = |mut pipe: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            pipe.read_to_end(&mut bytes).ok();
            String::from_utf8_lossy(&bytes).into_owned()
        })
    };
    let stdout = drain(Box::new(child.stdout.take().unwrap()));
    let stderr = drain(Box::new(child.stderr.take().unwrap()));
    let mut timed_out = false;
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > TIMEOUT {
            child.kill().ok();
            timed_out = true;
            break child.wait().unwrap();
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    Outcome {
        code: status.code(),
        stdout: stdout.join().unwrap(),
        stderr: stderr.join().unwrap(),
        timed_out,
        elapsed: start.elapsed(),
    }
}

/// True when `text` holds NaN or an infinity as a word outside backquotes (a quoted cell may
/// show what the file held).
fn shows_non_finite(text: &str) -> bool {
    text.split('`')
        .step_by(2)
        .flat_map(|part| part.split(|c: char| !(c.is_alphanumeric() || c == '-')))
        .any(|word| {
            ["nan", "inf", "-inf", "infinity", "-nan"].contains(&word.to_lowercase().as_str())
        })
}

/// What is wrong with how a case ended (empty: it ended as the table says).
fn problems(case: &Case, dir: &Path, outcome: &Outcome, changed: bool) -> Vec<String> {
    let mut problems = Vec::new();
    let message = fixture::fill(&case.message, dir);
    let both = format!("{}{}", outcome.stdout, outcome.stderr);
    if outcome.timed_out {
        problems.push(format!("no end after {TIMEOUT:?}"));
    }
    if outcome.code == Some(101) || outcome.stderr.contains("panicked") {
        problems.push("a panic".to_string());
    }
    if outcome.code != Some(case.exit) {
        problems.push(format!("exit {:?}, expected {}", outcome.code, case.exit));
    }
    match case.exit {
        2 => {
            let lines: Vec<&str> = outcome.stderr.lines().collect();
            if lines.len() != 1 || !lines[0].starts_with("legwise: ") {
                problems.push("standard error is not one `legwise: …` line".into());
            }
            if !outcome.stderr.contains(&message) {
                problems.push(format!("standard error does not hold `{message}`"));
            }
            if !outcome.stdout.is_empty() {
                problems.push("refused, yet standard output is not empty".into());
            }
            if changed {
                problems.push("refused, yet a file was written or changed".into());
            }
        }
        code => {
            if !both.contains(&message) {
                problems.push(format!("the output does not hold `{message}`"));
            }
            let warned = outcome
                .stderr
                .lines()
                .any(|l| l.starts_with("legwise: warning: "));
            if code == 3 && !warned {
                problems.push("exit 3 without a `legwise: warning:` line".into());
            }
            // Exit 3 may report a number that is not finite: it is one reason for 3.
            if code == 0 && shows_non_finite(&both) {
                problems.push("NaN or infinity in the output".into());
            }
        }
    }
    problems
}

/// Builds the case's directory, runs it and returns its outcome and problems.
fn try_case(bin: &Path, root: &Path, case: &Case) -> (Option<Outcome>, Vec<String>) {
    let dir = root.join(&case.id);
    fixture::populate(&dir);
    let stdin = match fixture::apply(&dir, &case.edits) {
        Ok(stdin) => stdin,
        Err(e) => return (None, vec![format!("fixture: {e}")]),
    };
    let args: Vec<String> = case.args.iter().map(|a| fixture::fill(a, &dir)).collect();
    let before = fixture::snapshot(&dir);
    let outcome = run(bin, &dir, &args, stdin.as_deref());
    let changed = fixture::snapshot(&dir) != before;
    let problems = problems(case, &dir, &outcome, changed);
    // Some cases write megabytes (a file of one row repeated): keep the disk use small.
    std::fs::remove_dir_all(&dir).ok();
    (Some(outcome), problems)
}

/// One line per case and its standard error, for `HOSTILE_REPORT`.
fn report_line(case: &Case, outcome: &Option<Outcome>, problems: &[String]) -> String {
    let verdict = match problems.is_empty() {
        true => "ok".to_string(),
        false => format!("FAIL: {}", problems.join("; ")),
    };
    let mut text = format!(
        "{} | expected {} | found {} | {} | {}\n",
        case.id, case.exit, case.found, case.note, verdict
    );
    if let Some(o) = outcome {
        text += &format!(
            "    exit {:?} in {:.2} s\n",
            o.code,
            o.elapsed.as_secs_f64()
        );
        for line in o.stderr.lines().take(6) {
            text += &format!("    ! {}\n", line.chars().take(400).collect::<String>());
        }
        for line in o.stdout.lines().take(3) {
            text += &format!("    > {}\n", line.chars().take(200).collect::<String>());
        }
    }
    text
}

#[test]
fn every_hostile_input_ends_as_its_table_says() {
    let path = crate::support::crate_path("tests/data/hostile/cases.txt");
    let cases = table::parse(&std::fs::read_to_string(path).unwrap());
    assert!(cases.len() >= 250, "{} cases", cases.len());
    let report = std::env::var_os("HOSTILE_REPORT").map(PathBuf::from);
    let only = std::env::var("HOSTILE_ONLY").unwrap_or_default();
    let bin = std::env::var_os("HOSTILE_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_legwise")));
    let chosen: Vec<&Case> = cases
        .iter()
        .filter(|c| c.id.contains(&only) && (report.is_some() || c.open().is_none()))
        .collect();
    let root = tempfile::tempdir().unwrap();
    let next = AtomicUsize::new(0);
    let results = Mutex::new(Vec::new());
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| {
                while let Some(case) = chosen.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let (outcome, problems) = try_case(&bin, root.path(), case);
                    results.lock().unwrap().push((*case, outcome, problems));
                }
            });
        }
    });
    let mut results = results.into_inner().unwrap();
    results.sort_by_key(|(case, _, _)| case.line);
    if let Some(report) = report {
        let text: String = results
            .iter()
            .map(|(case, outcome, problems)| report_line(case, outcome, problems))
            .collect();
        std::fs::write(report, text).unwrap();
        return;
    }
    let failures: Vec<String> = results
        .iter()
        .filter(|(_, _, problems)| !problems.is_empty())
        .map(|(case, outcome, problems)| {
            format!(
                "cases.txt line {}: {}",
                case.line,
                report_line(case, outcome, problems)
            )
        })
        .collect();
    assert!(
        failures.is_empty(),
        "{} of {} cases:\n{}",
        failures.len(),
        results.len(),
        failures.join("")
    );
}
