//! The `legwise` command line.
use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    match legwise::cli::run(legwise::cli::Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("legwise: {err:#}");
            // 3: the run finished but its result must not be trusted.
            let untrusted = err.downcast_ref::<legwise::cli::Untrusted>().is_some();
            ExitCode::from(if untrusted { 3 } else { 2 })
        }
    }
}
