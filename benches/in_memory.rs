//! The library's own time for what the Python module asks of it, with a stable id
//! (docs/benchmarks.md): `in_memory/5r/identify` — `cli::identify_in_memory` on the 5R's
//! simulated measurements given as CSV text (the command's parser and checks, the reader, divide
//! and conquer with Levenberg–Marquardt, the JSON and terminal reports), as `legwise.identify`
//! runs it without Python. `python/benchmarks/overhead.py` runs this benchmark and times the
//! Python calls beside it.
//! Run: `cargo bench --bench in_memory`.
use std::hint::black_box;
use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use legwise::cli::{identify_in_memory, simulate_in_memory};

/// The 5R's model file.
fn model() -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("models/5r.yaml");
    path.to_string_lossy().into_owned()
}

fn identify(c: &mut Criterion) {
    let arguments = vec!["--model".to_string(), model()];
    let (csv, _) = simulate_in_memory(&arguments).expect("the 5R simulates");
    let mut group = c.benchmark_group("in_memory/5r");
    group.bench_function("identify", |b| {
        b.iter(|| identify_in_memory(black_box(&arguments), Some(black_box(&csv))).unwrap())
    });
    group.finish();
}

criterion_group!(benches, identify);
criterion_main!(benches);
