//! Exit codes of the real binary: 0 success, 2 bad input or usage, 3 finished but untrusted;
//! the codes and the examples in `--help`; negative numbers reach legwise's range checks.
use clap::{CommandFactory, Parser};
use legwise::cli::Cli;

use super::cli::{assert_fails_with, legwise, text};
use super::support::crate_path;

/// The example command lines of a help text: the lines after `EXAMPLES:` that are not comments,
/// split at pipes, without shell redirections.
fn examples(help: &str) -> Vec<Vec<String>> {
    let section = help
        .split("EXAMPLES:\n")
        .nth(1)
        .unwrap_or_else(|| panic!("no EXAMPLES section in\n{help}"));
    section
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .flat_map(|l| l.split('|').map(str::to_string).collect::<Vec<_>>())
        .map(|command| {
            command
                .split_whitespace()
                .filter(|w| !w.starts_with("2>") && !w.starts_with('>'))
                .map(str::to_string)
                .collect::<Vec<_>>()
        })
        .filter(|words| words.first().is_some_and(|w| w == "legwise"))
        .collect()
}

#[test]
fn every_help_documents_the_exit_codes_and_ends_with_examples_that_parse() {
    // Every subcommand clap knows, so that a new one cannot skip its examples.
    let names: Vec<String> = Cli::command()
        .get_subcommands()
        .map(|c| c.get_name().to_string())
        .collect();
    assert!(names.len() >= 4, "{names:?}");
    let mut commands = vec![vec!["--help"]];
    commands.extend(names.iter().map(|c| vec![c.as_str(), "--help"]));
    for args in commands {
        let out = legwise(&args);
        assert_eq!(out.status.code(), Some(0), "{args:?}");
        let help = text(&out.stdout);
        let status = help
            .split("EXIT STATUS:\n")
            .nth(1)
            .unwrap_or_else(|| panic!("{args:?}: no EXIT STATUS in\n{help}"));
        for code in ["0  success", "2  bad input or usage", "3  the run finished"] {
            assert!(
                status.contains(code),
                "{args:?}: `{code}` missing in\n{status}"
            );
        }
        let tail = help.rsplit("\n\n").next().unwrap();
        assert!(
            tail.starts_with("EXAMPLES:"),
            "{args:?}: help ends with\n{tail}"
        );
        let examples = examples(&help);
        assert!(examples.len() >= 2, "{args:?}: {examples:?}");
        for example in examples {
            if let Err(e) = Cli::try_parse_from(&example) {
                panic!("{args:?}: example {example:?} does not parse: {e}");
            }
            // The bundled models an example names exist (other files are the user's).
            for model in example.iter().filter(|w| w.starts_with("models/")) {
                assert!(crate_path(model).is_file(), "{args:?}: no model {model}");
            }
        }
    }
}

#[test]
fn usage_errors_exit_2() {
    for args in [
        &["identify"][..],
        &[
            "identify",
            "--model",
            "models/5r.yaml",
            "--solver",
            "newton",
        ],
        &["identify", "--model", "models/5r.yaml", "--frobnicate"],
        &["frobnicate"],
        &[],
    ] {
        let out = legwise(args);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{args:?}: {}",
            text(&out.stderr)
        );
        assert!(!text(&out.stderr).contains("panicked"), "{args:?}");
    }
}

#[test]
fn negative_and_zero_numbers_get_legwise_range_messages() {
    let cases: [(&[&str], &str); 9] = [
        (
            &[
                "identify",
                "--model",
                "models/5r.yaml",
                "--noise-scale",
                "-1",
            ],
            "legwise: --noise-scale: expected a non-negative number, found -1",
        ),
        (
            &["identify", "--model", "models/5r.yaml", "--grid", "-0.02"],
            "legwise: --grid: expected a positive number of metres, found -0.02",
        ),
        (
            &["identify", "--model", "models/5r.yaml", "--grid", "0"],
            "legwise: --grid: expected a positive number of metres, found 0",
        ),
        (
            &[
                "identify",
                "--model",
                "models/5r.yaml",
                "--poses-per-leg",
                "-3",
            ],
            "legwise: --poses-per-leg: expected between 1 and 100000, found -3",
        ),
        (
            &["identify", "--model", "models/5r.yaml", "--seed", "-1"],
            "legwise: --seed: expected an integer from 0 to 18446744073709551615, found -1",
        ),
        (
            &[
                "simulate",
                "--model",
                "models/5r.yaml",
                "--out",
                "-",
                "--noise-scale",
                "-0.5",
            ],
            "legwise: --noise-scale: expected a non-negative number, found -0.5",
        ),
        (
            &[
                "select",
                "--model",
                "models/5r.yaml",
                "--out",
                "-",
                "--grid",
                "-0.02",
            ],
            "legwise: --grid: expected a positive number of metres, found -0.02",
        ),
        (
            &[
                "select",
                "--model",
                "models/5r.yaml",
                "--out",
                "-",
                "--poses-per-leg",
                "0",
            ],
            "legwise: --poses-per-leg: expected between 1 and 100000, found 0",
        ),
        (
            &["workspace", "--model", "models/5r.yaml", "--rays", "-5"],
            "legwise: --rays: expected between 16 and 100000, found -5",
        ),
    ];
    for (args, expected) in cases {
        assert_fails_with(args, expected);
    }
}

/// One reading of 1e200 rad: its squared residual overflows, so leg1's cost and statistics are
/// infinite. The run finishes and prints its report, but exits 3 with the reasons on stderr, all
/// about leg1; leg2's fit is trusted.
#[test]
fn a_non_finite_fit_finishes_with_exit_3_and_names_the_leg() {
    let out = legwise(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/huge_reading.csv",
    ]);
    let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
    assert_eq!(out.status.code(), Some(3), "stderr {stderr}");
    assert!(stdout.contains("leg leg2 (8 readings)"), "{stdout}");
    // The non-finite values first; the noise test and the solver's stop follow from them.
    let warnings: Vec<&str> = stderr.lines().collect();
    assert!(!warnings.is_empty());
    assert!(
        warnings[0].starts_with(
            "legwise: warning: divide and conquer, leg `leg1`: not a finite number: final cost inf"
        ),
        "{stderr}"
    );
    assert!(
        warnings
            .iter()
            .all(|w| w.starts_with("legwise: warning: ") && w.contains("leg1")),
        "{stderr}"
    );
    // Two degrees of freedom (8 readings, 6 parameters): the σ are the declared noise's,
    // finite; the residuals' scale is not.
    assert!(
        warnings.contains(
            &"legwise: warning: divide and conquer, leg `leg1`: not a finite number: final cost \
              inf, σ̂ inf"
        ),
        "{stderr}"
    );
    assert!(!stderr.contains("leg2"), "{stderr}");
    // The same file without the bad reading is trusted: exit 0, nothing on stderr.
    let clean = legwise(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/noisy.csv",
    ]);
    assert_eq!(clean.status.code(), Some(0), "{}", text(&clean.stderr));
    assert_eq!(text(&clean.stderr), "");
}
