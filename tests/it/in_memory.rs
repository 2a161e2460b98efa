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
    // The command line's own line (after `legwise: `), not clap's multi-line block.
    let command = std::process::Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(["identify", "--model", model, "--strategy", "nonsense"])
        .output()
        .unwrap();
    assert_eq!(
        String::from_utf8_lossy(&command.stderr),
        format!("legwise: {error}\n")
    );
    assert!(
        error.to_string().contains("'nonsense' for '--strategy")
            && error.to_string().ends_with("see `legwise identify --help`"),
        "{error}"
    );
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

/// `legwise ARGS` as a process: its status code, standard output and standard error.
fn command(args: &[&str]) -> (Option<i32>, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(args)
        .output()
        .unwrap();
    let text = |bytes: &[u8]| String::from_utf8_lossy(bytes).into_owned();
    (out.status.code(), text(&out.stdout), text(&out.stderr))
}

/// The 5R calibrated from the bundled example data by `legwise identify --calibrated
/// DIR/NAME` (the command must succeed): the model file's path.
fn calibrated_by_command(dir: &std::path::Path, name: &str) -> std::path::PathBuf {
    let (model, data) = (
        crate_path("models/5r.yaml"),
        crate_path("examples/data/5r.csv"),
    );
    let out = dir.join(name);
    let fit = [
        "identify",
        "--model",
        model.to_str().unwrap(),
        "--measurements",
        data.to_str().unwrap(),
        "--calibrated",
        out.to_str().unwrap(),
    ];
    let (status, _, stderr) = command(&fit);
    assert_eq!(status, Some(0), "{stderr}");
    out
}

#[test]
fn a_selection_in_memory_is_the_file_the_command_writes() {
    use legwise::cli::select_in_memory;
    let dir = tempfile::tempdir().unwrap();
    // Per-leg poses of an inverse model; forward rows (touches) of a bed probe.
    for (name, options) in [
        ("models/5r.yaml", &["--strategy", "both"][..]),
        ("models/delta-probe.yaml", &[][..]),
    ] {
        let model = crate_path(name);
        let model = model.to_str().unwrap();
        let out = dir.path().join("poses.csv");
        let mut words = vec!["select", "--model", model, "--out", out.to_str().unwrap()];
        words.extend(options);
        let (status, stdout, stderr) = command(&words);
        assert_eq!(status, Some(0), "{stderr}");
        let mut in_memory = vec!["--model", model];
        in_memory.extend(options);
        let (csv, text) = select_in_memory(&arguments(&in_memory)).unwrap();
        assert_eq!(csv, std::fs::read_to_string(&out).unwrap(), "{name}");
        assert!(stdout.starts_with(&text), "{name}: {text}\n---\n{stdout}");
    }
    let model = crate_path("models/5r.yaml");
    let error = select_in_memory(&arguments(&[
        "--model",
        model.to_str().unwrap(),
        "--grid",
        "0",
    ]))
    .expect_err("a zero grid");
    assert!(error.to_string().starts_with("--grid"), "{error}");
}

#[test]
fn an_evaluation_in_memory_is_the_commands_json() {
    use legwise::cli::{evaluate_in_memory, simulate_in_memory};
    let dir = tempfile::tempdir().unwrap();
    let model = crate_path("models/5r.yaml");
    let model = model.to_str().unwrap();
    let calibrated = calibrated_by_command(dir.path(), "cal.yaml");
    let calibrated = calibrated.to_str().unwrap();
    let (held, _) = simulate_in_memory(&arguments(&[
        "--model", model, "--seed", "11", "--poses", "random",
    ]))
    .unwrap();
    let held_path = dir.path().join("held.csv");
    std::fs::write(&held_path, &held).unwrap();
    let held_path = held_path.to_str().unwrap();
    let (status, stdout, stderr) = command(&[
        "evaluate",
        "--model",
        calibrated,
        "--against",
        model,
        "--measurements",
        held_path,
        "--json",
        "-",
    ]);
    assert_eq!(status, Some(0), "{stderr}");
    let options = ["--model", calibrated, "--against", model];
    let from_text = evaluate_in_memory(&arguments(&options), Some(&held)).unwrap();
    let mut from_file = options.to_vec();
    from_file.extend(["--measurements", held_path]);
    let from_file = evaluate_in_memory(&arguments(&from_file), None).unwrap();
    assert_eq!(
        from_file.json, stdout,
        "the file read in memory: the command's JSON"
    );
    assert_eq!(from_file.text.trim_end(), stderr.trim_end());
    let renamed = stdout.replace(held_path, MEMORY_NAME);
    assert_eq!(
        from_text.json, renamed,
        "the CSV text: the same JSON, named <memory>"
    );
    assert!(from_text.trust_issues.is_empty());
    let bad = held.replacen('\n', "\nleg1,x,0,0,0,0,\n", 1);
    let error = evaluate_in_memory(&arguments(&options), Some(&bad)).expect_err("a bad cell");
    let message = format!("{error:#}");
    assert!(
        message.contains(MEMORY_NAME) && message.contains("line 2"),
        "{message}"
    );
    let error = evaluate_in_memory(
        &arguments(&["--model", model, "--json", "e.json"]),
        Some(&held),
    )
    .expect_err("writes a file");
    assert!(error.to_string().starts_with("--json"), "{error}");
    let given = format!("--measurements={held_path}");
    for both in [
        vec!["--model", model, &given],
        vec!["--model", model, "--measurements", held_path],
    ] {
        let error = evaluate_in_memory(&arguments(&both), Some(&held)).expect_err("two sources");
        assert!(error.to_string().starts_with("--measurements"), "{error}");
    }
}

#[test]
fn the_calibrated_model_written_from_memory_is_the_commands() {
    let dir = tempfile::tempdir().unwrap();
    let model = crate_path("models/5r.yaml");
    let model = model.to_str().unwrap();
    let data = crate_path("examples/data/5r.csv");
    let data = data.to_str().unwrap();
    let by_command = calibrated_by_command(dir.path(), "command.yaml");
    let outputs = identify_in_memory(
        &arguments(&["--model", model, "--measurements", data]),
        None,
    )
    .unwrap();
    let in_memory = dir.path().join("memory.yaml");
    let said = outputs.write_calibrated(&in_memory).unwrap();
    assert!(
        said.starts_with("calibrated model (divide and conquer result) written to")
            && said.ends_with("memory.urdf"),
        "{said}"
    );
    let read = |path: &std::path::Path| std::fs::read_to_string(path).unwrap();
    assert_eq!(
        read(&in_memory).replace("memory.urdf", "command.urdf"),
        read(&by_command),
        "the same model file, naming its own URDF"
    );
    assert_eq!(
        read(&in_memory.with_extension("urdf")),
        read(&by_command.with_extension("urdf"))
    );
    let error = outputs
        .write_calibrated(std::path::Path::new(model))
        .expect_err("over the model file");
    assert!(error.to_string().contains("model file"), "{error}");
    let huge = crate_path("tests/data/huge_reading.csv");
    let untrusted = identify_in_memory(
        &arguments(&["--model", model, "--measurements", huge.to_str().unwrap()]),
        None,
    )
    .unwrap();
    let out = dir.path().join("untrusted.yaml");
    let error = untrusted.write_calibrated(&out).expect_err("untrusted");
    assert!(
        error.to_string().contains("must not be trusted") && error.to_string().contains("leg1"),
        "{error}"
    );
    assert!(!out.exists());
}
