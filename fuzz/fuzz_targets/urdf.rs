//! Fuzz target: any bytes as the URDF, with the bundled 5R model file. The XML pre-scan,
//! urdf-rs and the cross-checks must end in `Ok` or a one-line `Err`; never a panic, abort or
//! stack overflow.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

const MODEL: &str = include_str!("../../models/5r.yaml");

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Err(err) =
        legwise::model::Mechanism::parse(MODEL, Path::new("5r.yaml"), text, Path::new("fuzz.urdf"))
    {
        assert!(!err.to_string().contains('\n'), "multi-line message: {err}");
    }
});
