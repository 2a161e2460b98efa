//! `legwise::cli::identify_in_memory` (the Python module's entry): the command's arguments and
//! checks, the measurements as CSV text, the outputs returned instead of written.

use legwise::cli::{identify_in_memory, MEMORY_NAME};

use crate::support::crate_path;

/// `words` as owned arguments.
fn arguments(words: &[&str]) -> Vec<String> {
    words.iter().map(|w| w.to_string()).collect()
}

#[test]
fn csv_text_in_memory_gives_the_report_of_the_same_file() {
    let model = crate_path("models/5r.yaml");
    let data = crate_path("examples/data/5r.csv");
    let model = model.to_str().unwrap();
    let from_file = identify_in_memory(
        &arguments(&["--model", model, "--measurements", data.to_str().unwrap()]),
        None,
    )
    .unwrap();
    let text = std::fs::read_to_string(&data).unwrap();
    let from_text = identify_in_memory(&arguments(&["--model", model]), Some(&text)).unwrap();
    let json = |j: &str| {
        let mut value: serde_json::Value = serde_json::from_str(j).unwrap();
        let name = value["measurements"].take();
        strip_seconds(&mut value);
        (name, value)
    };
    let (file_name, file_report) = json(&from_file.json);
    let (memory_name, memory_report) = json(&from_text.json);
    assert_eq!(memory_name, MEMORY_NAME);
    assert!(file_name.as_str().unwrap().ends_with("5r.csv"));
    assert_eq!(file_report, memory_report);
    assert!(from_text.trust_issues.is_empty());
    assert!(from_text.text.starts_with("legwise identify"));
}

/// `value` without its `seconds` entries (wall-clock figures).
fn strip_seconds(value: &mut serde_json::Value) {
    match value {
        serde_json::Value::Object(map) => {
            map.remove("seconds");
            map.values_mut().for_each(strip_seconds);
        }
        serde_json::Value::Array(items) => items.iter_mut().for_each(strip_seconds),
        _ => {}
    }
}

#[test]
fn in_memory_the_options_that_write_files_and_bad_input_are_refused() {
    let model = crate_path("models/5r.yaml");
    let model = model.to_str().unwrap();
    for (flag, value) in [
        ("--json", "-"),
        ("--calibrated", "c.yaml"),
        ("--plots", "p"),
    ] {
        let error = identify_in_memory(&arguments(&["--model", model, flag, value]), None)
            .expect_err("writes a file");
        assert!(error.to_string().starts_with(flag), "{error}");
    }
    let error = identify_in_memory(
        &arguments(&["--model", model, "--strategy", "nonsense"]),
        None,
    )
    .expect_err("a usage error");
    assert!(error.to_string().contains("nonsense"), "{error}");
    let bad = "leg,x,y,A1,A2\nleg1,0.1,twelve,0.2,\n";
    let error =
        identify_in_memory(&arguments(&["--model", model]), Some(bad)).expect_err("a bad cell");
    let message = format!("{error:#}");
    assert!(
        message.contains(MEMORY_NAME) && message.contains("line 2"),
        "{message}"
    );
    let data = crate_path("examples/data/5r.csv");
    let both = ["--model", model, "--measurements", data.to_str().unwrap()];
    let error = identify_in_memory(&arguments(&both), Some(bad)).expect_err("two sources");
    assert!(error.to_string().starts_with("--measurements"), "{error}");
}

#[test]
fn a_simulation_in_memory_is_the_csv_the_command_writes() {
    use legwise::cli::simulate_in_memory;
    let model = crate_path("models/5r.yaml");
    let model = model.to_str().unwrap();
    let (csv, source) =
        simulate_in_memory(&arguments(&["--model", model, "--seed", "11"])).unwrap();
    assert!(source.contains("seed 11"), "{source}");
    let mechanism = legwise::Mechanism::load(model.as_ref()).unwrap();
    let data =
        legwise::Measurements::read_from(csv.as_bytes(), "m.csv".as_ref(), &mechanism).unwrap();
    let again = data.to_csv(&mechanism).unwrap();
    assert_eq!(again, csv, "reads back to the same text");
    let (other, _) = simulate_in_memory(&arguments(&["--model", model, "--seed", "12"])).unwrap();
    assert_ne!(other, csv);
    let error = simulate_in_memory(&arguments(&["--model", model, "--noise-scale", "-1"]))
        .expect_err("a negative noise scale");
    assert!(error.to_string().contains("--noise-scale"), "{error}");
}
