//! The `legwise` command line.
//!
//! Exit status: 0 success; 2 bad input or usage (clap's usage errors too); 3 the run finished
//! but its result must not be trusted (each reason on standard error as a warning line).
use std::io::Write;
use std::process::ExitCode;

use clap::Parser;
use legwise::cli::{run, Cli, Verdict};

fn main() -> ExitCode {
    let outcome = run(Cli::parse());
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
