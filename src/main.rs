//! The `legwise` command line.
use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    match legwise::cli::run(legwise::cli::Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("legwise: {err:#}");
            ExitCode::from(2)
        }
    }
}
