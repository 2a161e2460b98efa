//! Fuzz target: any bytes as a measurement CSV for the bundled 5R. Parsing must end in `Ok` (with
//! finite poses and readings) or a one-line `Err`; never a panic.
#![no_main]

use std::path::Path;
use std::sync::OnceLock;

use legwise::model::Mechanism;
use libfuzzer_sys::fuzz_target;

const MODEL: &str = include_str!("../../models/5r.yaml");
const URDF: &str = include_str!("../../models/5r.urdf");

fn mechanism() -> &'static Mechanism {
    static MECHANISM: OnceLock<Mechanism> = OnceLock::new();
    MECHANISM.get_or_init(|| {
        Mechanism::parse(MODEL, Path::new("5r.yaml"), URDF, Path::new("5r.urdf"))
            .expect("the bundled 5R loads")
    })
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match legwise::measure::file::parse(text, Path::new("fuzz.csv"), mechanism()) {
        Ok(set) => {
            for (pose, readings) in set.rows() {
                assert!(pose.pose.iter().all(|v| v.is_finite()), "non-finite pose");
                assert!(
                    readings.iter().flatten().all(|v| v.is_finite()),
                    "non-finite reading"
                );
            }
        }
        Err(err) => assert!(!err.to_string().contains('\n'), "multi-line message: {err}"),
    }
});
