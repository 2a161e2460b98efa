//! Fuzz target: any bytes as the model file (YAML), with the bundled 5R URDF. Parsing and every
//! cross-check must end in `Ok` or an `Err` whose message is one line; never a panic or abort.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

const URDF: &str = include_str!("../../models/5r.urdf");

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Err(err) =
        legwise::model::Mechanism::parse(text, Path::new("fuzz.yaml"), URDF, Path::new("5r.urdf"))
    {
        assert!(!err.to_string().contains('\n'), "multi-line message: {err}");
    }
});
