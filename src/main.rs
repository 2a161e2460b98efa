//! The `legwise` command line.
//!
//! Exit status: 0 success; 2 bad input or usage (clap's usage errors too, on one line); 3 the
//! run finished but its result must not be trusted (each reason on standard error as a warning
//! line).
use std::io::Write;
use std::process::ExitCode;

use clap::error::ErrorKind;
use clap::{CommandFactory, Parser};
use legwise::cli::{command_name, run, usage_line, Cli, Verdict};

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
            command_name(&words())
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
    let _ = writeln!(
        std::io::stderr().lock(),
        "legwise: {}",
        usage_line(err, &words())
    );
    ExitCode::from(2)
}

/// The command line's words after the program's name.
fn words() -> Vec<String> {
    std::env::args().skip(1).collect()
}
