//! The URDF: a streaming pre-scan (quick-xml) that bounds the element nesting and records where
//! each `<link>` and `<joint>` is declared, then urdf-rs, then the structural checks urdf-rs
//! leaves out (unique names, declared links). Every error names the file and, where one exists,
//! the line.

use std::collections::HashMap;
use std::path::Path;

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::error::{Error, Result};

/// Deepest element nesting accepted. A URDF nests a handful of levels
/// (`robot/link/visual/geometry/mesh`); urdf-rs parses recursively, so an absurdly deep
/// document would overflow the stack instead of failing.
pub const MAX_XML_DEPTH: usize = 100;

/// A `<link>` or `<joint>` child of `<robot>`: its name and line.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Declaration {
    name: String,
    line: usize,
}

/// Where the links and joints are declared, in document order.
#[derive(Debug, Default)]
struct Declarations {
    links: Vec<Declaration>,
    joints: Vec<Declaration>,
}

/// Parses URDF text; `path` is only used in messages.
///
/// # Errors
/// [`Error::Urdf`]: XML that is not well-formed or nests deeper than [`MAX_XML_DEPTH`] (with
/// the line), what urdf-rs rejects, a link or joint name declared twice, or a joint whose parent
/// or child link is not declared (with the line).
pub fn parse(text: &str, path: &Path) -> Result<urdf_rs::Robot> {
    let fail = |message: String| Error::Urdf {
        path: path.to_path_buf(),
        message,
    };
    let declarations = scan(text).map_err(fail)?;
    let robot = urdf_rs::read_from_string(text).map_err(|err| {
        fail(crate::error::first_line(
            &err.to_string(),
            "custom: ",
            "invalid URDF",
        ))
    })?;
    check_unique("link", &declarations.links).map_err(fail)?;
    check_unique("joint", &declarations.joints).map_err(fail)?;
    let line_of = |name: &str| {
        declarations
            .joints
            .iter()
            .find(|d| d.name == name)
            .map_or(String::new(), |d| format!("line {}: ", d.line))
    };
    let links: std::collections::HashSet<&str> =
        robot.links.iter().map(|l| l.name.as_str()).collect();
    for joint in &robot.joints {
        for (role, link) in [("parent", &joint.parent.link), ("child", &joint.child.link)] {
            if !links.contains(link.as_str()) {
                return Err(fail(format!(
                    "{}joint `{}`: its {role} link `{link}` is not declared (no <link name=\"{link}\"> in the file)",
                    line_of(&joint.name),
                    joint.name
                )));
            }
        }
    }
    Ok(robot)
}

/// A name declared twice: `line N: joint `A1` is declared twice (first on line M)`.
fn check_unique(kind: &str, declarations: &[Declaration]) -> Result<(), String> {
    let mut first: HashMap<&str, usize> = HashMap::new();
    for declaration in declarations {
        if let Some(line) = first.insert(&declaration.name, declaration.line) {
            return Err(format!(
                "line {}: {kind} `{}` is declared twice (first on line {line}); {kind} names must be unique",
                declaration.line, declaration.name
            ));
        }
    }
    Ok(())
}

/// 1-based line numbers of increasing byte offsets, counted incrementally (linear in the text,
/// however many elements it holds).
struct Lines<'a> {
    text: &'a [u8],
    offset: usize,
    line: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Self {
            text: text.as_bytes(),
            offset: 0,
            line: 1,
        }
    }

    /// The line of byte `position` (positions before the last one asked give that one's line).
    fn at(&mut self, position: u64) -> usize {
        let end = usize::try_from(position)
            .unwrap_or(usize::MAX)
            .min(self.text.len());
        if end > self.offset {
            self.line += self.text[self.offset..end]
                .iter()
                .filter(|&&b| b == b'\n')
                .count();
            self.offset = end;
        }
        self.line
    }
}

/// Streams through the XML once: checks it is well-formed and nests at most
/// [`MAX_XML_DEPTH`] elements deep, and records the `<link>` and `<joint>` children of the root.
fn scan(text: &str) -> Result<Declarations, String> {
    let mut reader = Reader::from_str(text);
    let mut lines = Lines::new(text);
    let mut depth = 0usize;
    let mut declarations = Declarations::default();
    loop {
        let start = reader.buffer_position();
        let event = match reader.read_event() {
            Ok(event) => event,
            Err(err) => {
                let line = lines.at(reader.error_position());
                return Err(format!("line {line}: not well-formed XML: {err}"));
            }
        };
        match event {
            Event::Start(ref element) | Event::Empty(ref element) => {
                let line = lines.at(start);
                if depth >= MAX_XML_DEPTH {
                    return Err(format!(
                        "line {line}: element <{}> is nested {} levels deep; at most \
                         {MAX_XML_DEPTH} are accepted (a URDF needs fewer than 10)",
                        String::from_utf8_lossy(element.name().as_ref()),
                        depth + 1
                    ));
                }
                record(element, depth, line, &mut declarations)?;
                if matches!(event, Event::Start(_)) {
                    depth += 1;
                }
            }
            Event::End(_) => depth = depth.saturating_sub(1),
            Event::Eof => break,
            _ => {}
        }
    }
    if depth > 0 {
        return Err(format!(
            "line {}: not well-formed XML: {depth} element(s) not closed at the end of the file",
            lines.at(text.len() as u64)
        ));
    }
    Ok(declarations)
}

/// Records a `<link>` or `<joint>` child of the root element (at `depth` 1) with its line.
fn record(
    element: &BytesStart<'_>,
    depth: usize,
    line: usize,
    declarations: &mut Declarations,
) -> Result<(), String> {
    let list = match (depth, element.name().as_ref()) {
        (1, b"link") => &mut declarations.links,
        (1, b"joint") => &mut declarations.joints,
        _ => return Ok(()),
    };
    let name = element
        .try_get_attribute("name")
        .map_err(|err| format!("line {line}: not well-formed XML: {err}"))?
        .map(|attribute| attribute.unescape_value().map(|v| v.into_owned()))
        .transpose()
        .map_err(|err| format!("line {line}: not well-formed XML: {err}"))?;
    if let Some(name) = name {
        list.push(Declaration { name, line });
    }
    Ok(())
}
