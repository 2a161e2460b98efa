//! Every `legwise …` command (and `cargo run --release -- …`) in a code block of README.md and
//! docs/*.md parses with the command line's own parser, and every file it reads exists: in the
//! repository (`models/…`, `examples/…`), or written by an earlier command of the same page
//! (`--out`, `--calibrated`, `--json`). A renamed option or file fails here; running them all is
//! tools/doc_commands.sh's job (docs/testing.md).
use std::collections::BTreeSet;
use std::path::Path;

use clap::error::ErrorKind;
use clap::Parser;
use legwise::cli::Cli;

use crate::support::crate_path;

/// Paths the pages use for the reader's own files, not the repository's: docs/models.md's
/// walk-through of a new model (`m.yaml`).
const PLACEHOLDERS: [&str; 1] = ["m.yaml"];

/// Options whose value is a file the command reads.
const INPUTS: [&str; 4] = ["--model", "--measurements", "--against", "--poses"];

/// Options whose value is a file (or, for `--plots`, a directory) the command writes.
const OUTPUTS: [&str; 5] = ["--out", "--calibrated", "--json", "--svg", "--plots"];

/// The lines of every fenced code block of `text` that holds commands (no language, `sh`,
/// `bash`, `shell`, `console`; not a program's output in a `text` block, nor YAML, CSV, Rust
/// or Python), with their line numbers.
fn code_lines(text: &str) -> Vec<(usize, &str)> {
    let (mut inside, mut commands) = (false, false);
    let mut lines = Vec::new();
    for (k, line) in text.lines().enumerate() {
        if let Some(fence) = line.trim_start().strip_prefix("```") {
            inside = !inside;
            commands = inside && matches!(fence.trim(), "" | "sh" | "bash" | "shell" | "console");
        } else if inside && commands {
            lines.push((k + 1, line));
        }
    }
    lines
}

/// Shell words of `text`: blanks split, `'…'` and `"…"` quote.
fn words(text: &str) -> Vec<String> {
    let (mut words, mut word, mut quote, mut started) = (Vec::new(), String::new(), None, false);
    for c in text.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), c) => word.push(c),
            (None, '\'' | '"') => (quote, started) = (Some(c), true),
            (None, c) if c.is_whitespace() => {
                if started || !word.is_empty() {
                    words.push(std::mem::take(&mut word));
                }
                started = false;
            }
            (None, c) => word.push(c),
        }
    }
    if started || !word.is_empty() {
        words.push(word);
    }
    words
}

/// The legwise commands of one shell line (pipelines and `&&` lists split; comments and
/// redirections dropped): each one's arguments after the program's name. Output lines of a
/// `text` block (`legwise workspace: …`) are not commands.
fn commands(line: &str) -> Vec<Vec<String>> {
    let line = line.split(" #").next().unwrap_or_default().trim();
    if line.starts_with('#') {
        return Vec::new();
    }
    let mut found = Vec::new();
    for part in line.split(['|', ';']).flat_map(|p| p.split("&&")) {
        let part = part.trim();
        let rest = part
            .strip_prefix("legwise ")
            .or_else(|| part.strip_prefix("cargo run --release -- "));
        let Some(rest) = rest else { continue };
        let mut arguments = Vec::new();
        let mut skip = false;
        for word in words(rest) {
            if skip {
                skip = false;
            } else if matches!(word.as_str(), ">" | "2>" | "<" | ">>") {
                skip = true;
            } else if !(word.starts_with('>') || word.starts_with("2>") || word.starts_with('<')) {
                arguments.push(word);
            }
        }
        if arguments.first().is_some_and(|w| !w.ends_with(':')) {
            found.push(arguments);
        }
    }
    found
}

/// The value of each of `options` in `arguments` (`--flag value` or `--flag=value`).
fn values<'a>(arguments: &'a [String], options: &[&'a str]) -> Vec<(&'a str, &'a str)> {
    let mut found = Vec::new();
    for (k, word) in arguments.iter().enumerate() {
        for option in options {
            if word == option {
                if let Some(value) = arguments.get(k + 1) {
                    found.push((*option, value.as_str()));
                }
            } else if let Some(value) = word.strip_prefix(&format!("{option}=")) {
                found.push((*option, value));
            }
        }
    }
    found
}

/// What is wrong with the commands of the page `name`: one line each.
fn problems(name: &str) -> (usize, Vec<String>) {
    let text = std::fs::read_to_string(crate_path(name)).unwrap();
    let (mut count, mut problems) = (0, Vec::new());
    let mut written: BTreeSet<String> = BTreeSet::new();
    for (line, code) in code_lines(&text) {
        for arguments in commands(code) {
            count += 1;
            let at = format!("{name}:{line}: `legwise {}`", arguments.join(" "));
            let parsed = Cli::try_parse_from(
                std::iter::once("legwise".to_string()).chain(arguments.clone()),
            );
            if let Err(e) = parsed {
                if !matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                    let message = e.render().to_string();
                    problems.push(format!("{at}: {}", message.lines().next().unwrap_or("")));
                    continue;
                }
            }
            for (option, value) in values(&arguments, &INPUTS) {
                let a_file = option != "--poses" || value.contains('.') || value.contains('/');
                let known = value == "-"
                    || PLACEHOLDERS.contains(&value)
                    || written.contains(value)
                    // A file of a directory an earlier command wrote (`printer import --out DIR`).
                    || std::path::Path::new(value)
                        .parent()
                        .is_some_and(|dir| written.contains(dir.to_str().unwrap_or_default()))
                    || crate_path(value).exists();
                if a_file && !known {
                    problems.push(format!(
                        "{at}: {option} {value}: no such file in the repository, and no earlier \
                         command of the page writes it"
                    ));
                }
            }
            for (_, value) in values(&arguments, &OUTPUTS) {
                written.insert(value.to_string());
                // `--calibrated OUT.yaml` writes OUT.urdf beside it.
                if let Some(stem) = value.strip_suffix(".yaml") {
                    written.insert(format!("{stem}.urdf"));
                }
            }
        }
    }
    (count, problems)
}

/// README.md and every page of docs/.
fn pages() -> Vec<String> {
    let mut pages = vec!["README.md".to_string()];
    let mut docs: Vec<String> = std::fs::read_dir(crate_path("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .map(|p| format!("docs/{}", p.file_name().unwrap().to_string_lossy()))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
}

#[test]
fn every_documented_command_parses_and_names_files_that_exist() {
    let mut total = 0;
    let mut all = Vec::new();
    for page in pages() {
        let (count, problems) = problems(&page);
        total += count;
        all.extend(problems);
    }
    assert!(total >= 30, "only {total} commands found");
    assert!(all.is_empty(), "{}", all.join("\n"));
}

/// The extraction itself: pipelines, redirections, comments, quotes and output lines.
#[test]
fn commands_are_read_from_shell_lines_as_the_shell_would() {
    assert_eq!(
        commands("legwise simulate --model m.yaml --out - | legwise identify --model m.yaml --measurements -"),
        [
            ["simulate", "--model", "m.yaml", "--out", "-"],
            ["identify", "--model", "m.yaml", "--measurements", "-"]
        ]
    );
    assert_eq!(
        commands("legwise identify --model 'a b.yaml' --json - 2>/dev/null > report.json  # x"),
        [["identify", "--model", "a b.yaml", "--json", "-"]]
    );
    assert!(commands("legwise workspace: 6-UPS Gough-Stewart platform").is_empty());
    assert!(commands("#   cargo run --release -- identify --model x").is_empty());
    // A renamed option is caught; a missing file is named.
    let broken = Cli::try_parse_from(["legwise", "identify", "--modle", "models/5r.yaml"]);
    assert!(broken.is_err());
    assert!(!Path::new(&crate_path("models/5r-renamed.yaml")).exists());
}
