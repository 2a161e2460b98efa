//! The three parsers under property-based fuzzing, inside the test suite: mutated copies of the
//! bundled model file, URDF and a valid measurement CSV must give `Ok` or a one-line error,
//! never a panic, an abort or a non-finite value. The mutations insert, delete and replace
//! text with tokens that broke parsers before (huge numbers, NaN, deep XML nesting, stray
//! delimiters) and arbitrary characters.
//!
//! `cargo test` runs a few cases per parser (fast); `LEGWISE_FUZZ_CASES=20000 cargo test --test
//! it fuzz` runs many. The coverage-guided fuzzers (cargo-fuzz) are in `fuzz/`; see
//! docs/fuzzing.md.
use std::path::Path;

use legwise::model::Mechanism;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::Config;

use crate::support::crate_path;

/// Cases per parser: `LEGWISE_FUZZ_CASES`, default 48.
fn config() -> Config {
    let cases = std::env::var("LEGWISE_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(48);
    Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    }
}

/// Text that broke or could break a parser.
const TOKENS: &[&str] = &[
    "",
    "0",
    "-1",
    "1e308",
    "-1.7976931348623157e308",
    "1e-320",
    "NaN",
    ".nan",
    "inf",
    ".inf",
    "\n",
    "\r\n",
    " ",
    "\t",
    ",",
    ",,",
    ":",
    ": ",
    "- ",
    "{",
    "}",
    "[",
    "]",
    "\"",
    "'",
    "#",
    "&a",
    "*a",
    "!!str",
    "identify: false",
    "leg1",
    "leg2",
    "A1",
    "B1",
    "P1",
    "<",
    ">",
    "/>",
    "</joint>",
    "<joint name=\"A1\" type=\"continuous\">",
    "<link name=\"base\"/>",
    "<x><x><x><x><x><x><x><x><x><x><x><x><x><x><x><x>",
    "&amp;",
    "&#0;",
    "<!DOCTYPE a [<!ENTITY e \"x\">]>",
    "é",
    "\u{0}",
];

/// One edit: at a position, delete up to `delete` characters, then insert a token or
/// arbitrary characters.
#[derive(Debug, Clone)]
struct Edit {
    at: Index,
    delete: usize,
    insert: Insert,
}

#[derive(Debug, Clone)]
enum Insert {
    Token(Index),
    Chars(Vec<char>),
    Repeat(Index, usize),
}

fn edits() -> impl Strategy<Value = Vec<Edit>> {
    let insert = prop_oneof![
        4 => any::<Index>().prop_map(Insert::Token),
        2 => prop::collection::vec(any::<char>(), 0..6).prop_map(Insert::Chars),
        1 => (any::<Index>(), 1usize..300).prop_map(|(i, n)| Insert::Repeat(i, n)),
    ];
    prop::collection::vec(
        (any::<Index>(), 0usize..12, insert).prop_map(|(at, delete, insert)| Edit {
            at,
            delete,
            insert,
        }),
        1..6,
    )
}

/// `text` with `edits` applied (positions on character boundaries).
fn mutate(text: &str, edits: &[Edit]) -> String {
    let mut chars: Vec<char> = text.chars().collect();
    for edit in edits {
        let at = edit.at.index(chars.len() + 1);
        let end = (at + edit.delete).min(chars.len());
        let inserted: Vec<char> = match &edit.insert {
            Insert::Token(i) => TOKENS[i.index(TOKENS.len())].chars().collect(),
            Insert::Chars(c) => c.clone(),
            Insert::Repeat(i, n) => TOKENS[i.index(TOKENS.len())].repeat(*n).chars().collect(),
        };
        chars.splice(at..end, inserted);
    }
    chars.into_iter().collect()
}

fn bundled_text(name: &str) -> String {
    std::fs::read_to_string(crate_path(name)).expect("bundled file reads")
}

/// An error must be one non-empty line.
fn check_message(message: &str, input: &str) {
    assert!(
        !message.is_empty() && !message.contains('\n'),
        "message {message:?} for input:\n{input}"
    );
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn a_mutated_model_file_loads_or_fails_with_one_line(edits in edits()) {
        let (model, urdf) = (bundled_text("models/5r.yaml"), bundled_text("models/5r.urdf"));
        let text = mutate(&model, &edits);
        if let Err(err) = Mechanism::parse(&text, Path::new("m.yaml"), &urdf, Path::new("5r.urdf")) {
            check_message(&err.to_string(), &text);
        }
    }

    #[test]
    fn a_mutated_urdf_loads_or_fails_with_one_line(edits in edits()) {
        let (model, urdf) = (bundled_text("models/5r.yaml"), bundled_text("models/5r.urdf"));
        let text = mutate(&urdf, &edits);
        if let Err(err) = Mechanism::parse(&model, Path::new("5r.yaml"), &text, Path::new("m.urdf")) {
            check_message(&err.to_string(), &text);
        }
    }

    #[test]
    fn a_mutated_measurement_file_reads_or_fails_with_one_line(edits in edits()) {
        let mechanism = crate::support::bundled("5r.yaml");
        let text = mutate(&bundled_text("tests/data/valid.csv"), &edits);
        match legwise::measure::file::parse(&text, Path::new("m.csv"), &mechanism) {
            Ok(set) => {
                for (pose, readings) in set.rows() {
                    prop_assert!(pose.pose.iter().all(|v| v.is_finite()), "{text}");
                    prop_assert!(readings.iter().flatten().all(|v| v.is_finite()), "{text}");
                }
            }
            Err(err) => check_message(&err.to_string(), &text),
        }
    }
}

// ---- regressions found by this harness ----

/// A quoted CSV cell spanning lines was quoted verbatim in the message (several lines).
#[test]
fn a_multi_line_cell_is_quoted_on_one_line() {
    let mechanism = crate::support::bundled("5r.yaml");
    let text = "leg,x,y,A1,A2\n,0.1,1.0,\"2.0\n,0.2\",2.1\n";
    let err = legwise::measure::file::parse(text, Path::new("m.csv"), &mechanism)
        .expect_err("not a number");
    assert_eq!(
        err.to_string(),
        "m.csv: line 2, column `A1`: expected a finite number in SI units (radians or metres), \
         found `2.0\\n,0.2`"
    );
}

/// quick-xml quotes a mismatched end tag verbatim, line breaks included.
#[test]
fn a_mismatched_end_tag_spanning_lines_is_quoted_on_one_line() {
    let model = bundled_text("models/5r.yaml");
    let urdf = "<robot name=\"r\">\n<link name=\"a\">\n</lin\nk>\n</robot>\n";
    let err = Mechanism::parse(&model, Path::new("5r.yaml"), urdf, Path::new("m.urdf"))
        .expect_err("not well-formed");
    assert_eq!(
        err.to_string(),
        "m.urdf: line 3: not well-formed XML: ill-formed document: expected `</link>`, but \
         `</lin\\nk>` was found"
    );
}
