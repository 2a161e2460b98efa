//! The command line: a thin shell over the library (clap derive).
//!
//! Every command returns a [`Verdict`]; `main` turns it and any error into the exit status
//! documented in `legwise --help`: 0 success, 2 bad input or usage, 3 finished but untrusted.
mod args;
mod checks;
mod console;
mod evaluate;
mod help;
mod how_many;
mod identify;
mod in_memory;
mod montecarlo;
mod outputs;
mod printer;
mod printer_export;
mod printer_study;
mod select;
mod sets;
mod sets_study;
mod simulate;
mod usage;
mod verdict;
mod workspace;

pub use args::*;
pub use in_memory::{
    evaluate_in_memory, identify_in_memory, printer_export_in_memory, printer_import_in_memory,
    select_in_memory, sets_in_memory, simulate_in_memory, EvaluateOutputs, IdentifyOutputs,
    MEMORY_NAME,
};
pub use printer_export::ExportOutputs;
pub use usage::{command_name, usage_line};
pub use verdict::Verdict;

/// Runs a parsed command line.
///
/// # Errors
/// Any error of the library, with context; `main` prints it on one line and exits 2.
pub fn run(cli: Cli) -> anyhow::Result<Verdict> {
    match cli.command {
        Command::Identify(args) => identify::run(&args),
        Command::Select(args) => select::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Workspace(args) => workspace::run(&args),
        Command::Evaluate(args) => evaluate::run(&args),
        Command::Montecarlo(args) => montecarlo::run(&args),
        Command::Printer(args) => printer::run(&args),
        Command::Sets(args) => sets::run(&args),
        Command::HowMany(args) => how_many::run(&args),
    }
}
