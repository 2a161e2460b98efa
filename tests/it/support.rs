//! Shared helpers for the integration tests.
use std::path::PathBuf;

use legwise::model::Mechanism;

/// Absolute path of a file in the crate.
pub(crate) fn crate_path(relative: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(relative)
}

/// Loads a bundled model by file name (`5r.yaml`).
pub(crate) fn bundled(name: &str) -> Mechanism {
    Mechanism::load(&crate_path(&format!("models/{name}"))).expect("bundled model loads")
}

/// Every bundled model (`models/*.yaml`).
#[allow(dead_code)]
pub(crate) fn bundled_models() -> Vec<Mechanism> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(crate_path("models"))
        .expect("models/ exists")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    paths.sort();
    paths
        .iter()
        .map(|p| Mechanism::load(p).expect("bundled model loads"))
        .collect()
}
