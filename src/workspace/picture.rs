//! An SVG picture of the singularity-free region, the singular curves and the MIW. Plain SVG
//! text: no fonts or system libraries are needed to write it.

use std::fmt::Write;

use super::miw::{Miw, SingularityMargin};

/// Grid cells per side used to trace the singular curves.
const GRID: usize = 140;

/// Draws the MIW picture: the singularity-free region seen from the MIW centre (green), the
/// zero crossings of the serial measures (red: a leg stretched, folded or out of reach) and of
/// the parallel measure (blue), and the maximal inscribed circle.
pub fn miw_svg(margin: &SingularityMargin<'_>, miw: &Miw, title: &str) -> String {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &miw.boundary {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let pad = 0.25 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let (lo, hi) = ([lo[0] - pad, lo[1] - pad], [hi[0] + pad, hi[1] + pad]);
    let size = 640.0;
    let scale = size / (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let x = |v: f64| 20.0 + (v - lo[0]) * scale;
    let y = |v: f64| 40.0 + (hi[1] - v) * scale;
    let mut svg = String::new();
    let width = 40.0 + (hi[0] - lo[0]) * scale;
    let height = 80.0 + (hi[1] - lo[1]) * scale;
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(svg, r#"<text x="20" y="24">{}</text>"#, escape(title));
    let points: Vec<String> = miw
        .boundary
        .iter()
        .map(|p| format!("{:.2},{:.2}", x(p[0]), y(p[1])))
        .collect();
    let _ = writeln!(
        svg,
        r##"<polygon points="{}" fill="#d8f0d0" stroke="#4a8a3a" stroke-width="1"/>"##,
        points.join(" ")
    );
    // Singular curves: zero crossings of the measures between neighbouring grid points.
    let step = [(hi[0] - lo[0]) / GRID as f64, (hi[1] - lo[1]) / GRID as f64];
    let sample = margin.sample_grid(lo, step, GRID + 1);
    for i in 0..=GRID {
        for j in 0..=GRID {
            for (di, dj) in [(1, 0), (0, 1)] {
                let (a, b) = (i + di, j + dj);
                if a > GRID || b > GRID {
                    continue;
                }
                let here = [
                    lo[0] + (i as f64 + 0.5 * di as f64) * step[0],
                    lo[1] + (j as f64 + 0.5 * dj as f64) * step[1],
                ];
                let (serial, parallel) = crossing(sample[i][j], sample[a][b]);
                if serial {
                    let _ = writeln!(
                        svg,
                        r##"<circle cx="{:.2}" cy="{:.2}" r="1.1" fill="#c0392b"/>"##,
                        x(here[0]),
                        y(here[1])
                    );
                }
                if parallel {
                    let _ = writeln!(
                        svg,
                        r##"<circle cx="{:.2}" cy="{:.2}" r="1.1" fill="#2455c3"/>"##,
                        x(here[0]),
                        y(here[1])
                    );
                }
            }
        }
    }
    let _ = writeln!(
        svg,
        r##"<circle cx="{:.2}" cy="{:.2}" r="{:.2}" fill="none" stroke="black" stroke-width="2"/>"##,
        x(miw.centre[0]),
        y(miw.centre[1]),
        miw.radius * scale
    );
    let _ = writeln!(
        svg,
        r##"<path d="M {:.2} {:.2} h 10 m -5 -5 v 10" stroke="black" transform="translate(-5 0)"/>"##,
        x(miw.centre[0]),
        y(miw.centre[1])
    );
    let legend = format!(
        "MIW centre ({:.6}, {:.6}) m, radius {:.6} m",
        crate::report::tidy(miw.centre[0], 6),
        crate::report::tidy(miw.centre[1], 6),
        miw.radius
    );
    let _ = writeln!(
        svg,
        r#"<text x="20" y="{:.0}">{}</text>"#,
        height - 30.0,
        escape(&legend)
    );
    let key =
        "green: singularity-free region; red: serial (type I) limits; blue: parallel (type II)";
    let _ = writeln!(svg, r#"<text x="20" y="{:.0}">{key}</text>"#, height - 12.0);
    svg.push_str("</svg>\n");
    svg
}

/// Does the serial / parallel measure cross zero (or a leg lose reach) between two samples?
fn crossing(a: Option<(f64, f64)>, b: Option<(f64, f64)>) -> (bool, bool) {
    match (a, b) {
        (Some((sa, pa)), Some((sb, pb))) => (sa * sb <= 0.0, pa * pb <= 0.0),
        (None, None) => (false, false),
        _ => (true, false),
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
