//! legwise from Rust: identify a mechanism from a measurement CSV and print each result's
//! verdict and each parameter ± σ; the run's verdict (the command's exit 3) last.
//!
//! ```sh
//! cargo run --example library                                  # the 5R, divide and conquer
//! cargo run --example library -- models/5r-tracker.yaml examples/data/5r-tracker.csv  # joint
//! ```
use legwise::{identify, Measurements, Mechanism, Settings};

fn main() -> Result<(), legwise::Error> {
    let arg = |i, default: &str| std::env::args().nth(i).unwrap_or(default.into());
    let mechanism = Mechanism::load(arg(1, "models/5r.yaml").as_ref())?;
    let data = Measurements::read(arg(2, "examples/data/5r.csv").as_ref(), &mechanism)?;
    let report = identify(&mechanism, &data, &Settings::default())?;
    for result in &report.results {
        let trusted = report.result_trusted(result);
        println!("{} (trusted: {trusted})", result.strategy.name());
        for p in result.parameters().filter(|p| p.identified) {
            let (name, value, std) = (&p.name, p.estimate, p.std.unwrap_or(f64::NAN));
            println!("  {name:<10} {value:>12.6} ± {std:.1e} {}", p.unit);
        }
    }
    println!("run trusted: {}", report.trusted());
    Ok(())
}
