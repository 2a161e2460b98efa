//! The `legwise` command line.
//!
//! Exit status: 0 success; 2 bad input or usage (clap's usage errors too, on one line); 3 the
//! run finished but its result must not be trusted (each reason on standard error as a warning
//! line).
use std::io::Write;
use std::process::ExitCode;

use clap::error::ErrorKind;
use clap::{CommandFactory, Parser};
use legwise::cli::{run, Cli, Verdict};

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(err) => return usage(&err),
    };
    let outcome = run(cli);
    // Standard error may be closed too; there is nowhere left to complain then.
    let mut stderr = std::io::stderr().lock();
    match outcome {
        Ok(Verdict::Trusted) => ExitCode::SUCCESS,
        Ok(Verdict::Untrusted(reasons)) => {
            for reason in reasons {
                let _ = writeln!(stderr, "legwise: warning: {reason}");
            }
            ExitCode::from(3)
        }
        Err(err) => {
            let _ = writeln!(stderr, "legwise: {err:#}");
            ExitCode::from(2)
        }
    }
}

/// `--help` and `--version` as clap prints them (exit 0); a usage error as one line
/// `legwise: …` on standard error, exit 2.
fn usage(err: &clap::Error) -> ExitCode {
    if err.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
        let commands: Vec<String> = Cli::command()
            .get_subcommands()
            .map(|c| c.get_name().to_string())
            .collect();
        let _ = writeln!(
            std::io::stderr().lock(),
            "legwise: a command is needed: {}; see `{} --help`",
            commands.join(", "),
            command_name()
        );
        return ExitCode::from(2);
    }
    let informational = matches!(
        err.kind(),
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion
    );
    if informational {
        let _ = err.print();
        return ExitCode::from(u8::try_from(err.exit_code()).unwrap_or(2));
    }
    let _ = writeln!(std::io::stderr().lock(), "legwise: {}", one_line(err));
    ExitCode::from(2)
}

/// clap's usage error on one line: its message, the possible values and its tip, then where
/// the usage is shown (`legwise COMMAND --help`) in place of clap's usage block.
fn one_line(err: &clap::Error) -> String {
    if let Some(word) = single_dash_word().filter(|_| err.kind() == ErrorKind::UnknownArgument) {
        return format!(
            "unexpected argument `{word}`: long options take two dashes (`-{word}`); see `{} \
             --help`",
            command_name()
        );
    }
    let text = err.render().to_string();
    let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
    let first = lines.next().unwrap_or("invalid usage");
    let mut line = first.strip_prefix("error: ").unwrap_or(first).to_string();
    for extra in lines {
        if let Some(values) = extra.strip_prefix('[').and_then(|v| v.strip_suffix(']')) {
            line.push_str(&format!(" ({values})"));
        } else if let Some(tip) = extra.strip_prefix("tip: ") {
            line.push_str(&format!("; {tip}"));
        } else if !extra.starts_with("Usage: ") && !extra.starts_with("For more information") {
            line.push_str(&format!(" {extra}"));
        }
    }
    format!("{line}; see `{} --help`", command_name())
}

/// The first argument that looks like a long option typed with one dash (`-model`), which
/// clap reads as the short options `-m -o -d …`.
fn single_dash_word() -> Option<String> {
    std::env::args().skip(1).find(|word| {
        word.strip_prefix('-').is_some_and(|rest| {
            rest.len() > 1
                && rest.starts_with(|c: char| c.is_ascii_lowercase())
                && rest.chars().all(|c| c.is_ascii_lowercase() || c == '-')
        })
    })
}

/// `legwise` and the subcommand the command line names, if any.
fn command_name() -> String {
    let given = std::env::args().nth(1).unwrap_or_default();
    let known = Cli::command();
    let sub = known.get_subcommands().find(|c| c.get_name() == given);
    match sub {
        Some(sub) => format!("legwise {}", sub.get_name()),
        None => "legwise".to_string(),
    }
}
