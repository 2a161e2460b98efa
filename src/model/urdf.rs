//! The URDF: a streaming pre-scan (`urdf_scan.rs`: well-formed XML, bounded nesting, one
//! `<robot>`, joints as urdf-rs reads them, where each `<link>` and `<joint>` is declared), then
//! urdf-rs, then the structural checks urdf-rs leaves out (unique names, declared links). Every
//! error names the file and, where one exists, the line.

use std::collections::HashMap;
use std::path::Path;

use crate::error::{Error, Result};

pub use super::urdf_scan::MAX_XML_DEPTH;
use super::urdf_scan::{scan, Declaration};

/// Parses URDF text; `path` is only used in messages.
///
/// # Errors
/// [`Error::Urdf`]: XML that is not well-formed or nests deeper than [`MAX_XML_DEPTH`] (with
/// the line), what urdf-rs rejects, a link or joint name declared twice, or a joint whose parent
/// or child link is not declared (with the line).
pub fn parse(text: &str, path: &Path) -> Result<urdf_rs::Robot> {
    parse_noting_axes(text, path).map(|(robot, _)| robot)
}

/// As [`parse`], with the names of the moving joints that have no `<axis>` element (urdf-rs
/// gives them the axis x, as the URDF specification says), for messages.
///
/// # Errors
/// As [`parse`].
pub(crate) fn parse_noting_axes(text: &str, path: &Path) -> Result<(urdf_rs::Robot, Vec<String>)> {
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
    Ok((robot, declarations.implicit_axes))
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
