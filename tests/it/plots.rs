//! The pictures: each figure's SVG holds its axis descriptions, units and legend entries (read
//! from the text, not just `<svg`), its marks match the data counted independently, a PNG
//! renders with the embedded font, and bad output paths give clear errors.
use std::path::Path;
use std::process::Command;

use legwise::identify::estimate::{identify, Strategy};
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::measure::Measurements;
use legwise::report::plots::distribution::{ErrorDistribution, ErrorSample};
use legwise::report::plots::error_map::{ErrorMapFigure, MapCell, MapPanel};
use legwise::report::plots::parameter_errors::ParameterErrors;
use legwise::report::plots::{render, Figure, Format};
use legwise::report::{RealValues, Report};
use legwise::solver::SolverKind;

use crate::support::{bundled, svg_texts};

/// The SVG of `figure` as text.
fn svg(figure: &impl Figure) -> String {
    let bytes = render(figure, Format::Svg).expect("the figure renders");
    let text = String::from_utf8(bytes).expect("SVG is UTF-8");
    assert!(text.starts_with("<svg") && text.trim_end().ends_with("</svg>"));
    text
}

/// `<rect>` elements filled with `colour` (`#RRGGBB`).
fn rects_filled(svg: &str, colour: &str) -> usize {
    svg.split("<rect")
        .skip(1)
        .filter(|r| {
            r.split('>')
                .next()
                .unwrap_or("")
                .contains(&format!("fill=\"{colour}\""))
        })
        .count()
}

fn has(texts: &[String], wanted: &str) -> bool {
    texts.iter().any(|t| t == wanted)
}

#[test]
fn the_parameter_error_bars_show_every_identified_parameter_per_unit_and_strategy() {
    let mech = bundled("5r.yaml");
    let noise_free = SimulationOptions {
        noise_scale: 0.0,
        ..Default::default()
    };
    let experiment = simulate(&mech, noise_free).unwrap();
    let results = [Strategy::DivideAndConquer, Strategy::Traditional]
        .into_iter()
        .map(|s| identify(&mech, &experiment.measurements, s, SolverKind::GaussNewton).unwrap())
        .collect();
    let report = Report {
        mechanism: &mech,
        source: "test".into(),
        measurements: Measurements::Readings(experiment.measurements.clone()),
        real: Some(RealValues {
            legs: experiment.real.clone(),
            instrument: None,
        }),
        results,
        maps: None,
    };
    let figure = ParameterErrors::from_report(&report).expect("real values are known");
    // Table 2: nominal l1 = 0.75, real 0.7507.
    assert_eq!(figure.parameters.len(), 12);
    assert!((figure.series[0].errors[0] - (0.75 - 0.7507)).abs() < 1e-12);
    let svg = svg(&figure);
    let texts = svg_texts(&svg);
    for wanted in [
        "length error (mm)",
        "angle error (mrad)",
        "gain error (×10⁻³)",
        "before (nominal values)",
        "after: divide and conquer",
        "after: traditional (all legs)",
        "l1",
        "A2y",
        "gamma2",
        "k1",
    ] {
        assert!(has(&texts, wanted), "`{wanted}` missing from {texts:?}");
    }
    // One bar per parameter and series, plus one legend swatch per series.
    assert_eq!(rects_filled(&svg, "#D55E00"), 12 + 1, "before bars");
    assert_eq!(
        rects_filled(&svg, "#0072B2"),
        12 + 1,
        "divide-and-conquer bars"
    );
    assert_eq!(rects_filled(&svg, "#009E73"), 12 + 1, "traditional bars");
    // From a measurement file there are no real values: no figure.
    let without_real = Report {
        real: None,
        ..report
    };
    assert!(ParameterErrors::from_report(&without_real).is_none());
}

fn small_map() -> ErrorMapFigure {
    // A 4 × 4 grid of 0.1 m; the error is 2 mm everywhere except one non-assemblable corner.
    let cells: Vec<MapCell> = (0..16)
        .map(|k| MapCell {
            x: 0.1 * f64::from(k % 4),
            y: 1.0 + 0.1 * f64::from(k / 4),
            error_m: (k != 0).then_some(0.002),
        })
        .collect();
    let after: Vec<MapCell> = cells
        .iter()
        .map(|c| MapCell {
            error_m: Some(0.0001),
            ..*c
        })
        .collect();
    ErrorMapFigure {
        title: "test map".into(),
        grid_m: 0.1,
        panels: vec![
            MapPanel {
                title: "before".into(),
                cells,
            },
            MapPanel {
                title: "after".into(),
                cells: after,
            },
        ],
        poses: vec![[0.05, 1.05], [0.15, 1.25], [0.25, 1.05]],
    }
}

#[test]
fn the_error_map_has_metre_axes_a_millimetre_colour_bar_and_the_poses() {
    let figure = small_map();
    let svg = svg(&figure);
    let texts = svg_texts(&svg);
    for wanted in [
        "test map",
        "x (m)",
        "y (m)",
        "position error (mm)",
        "before: RMS 2 mm, max 2 mm",
        "after: RMS 0.1 mm, max 0.1 mm",
        "measured poses (3)",
        "cannot be assembled",
    ] {
        assert!(has(&texts, wanted), "`{wanted}` missing from {texts:?}");
    }
    // One grey square for the non-assemblable point, one in the key.
    assert_eq!(rects_filled(&svg, "#C8C8C8"), 2);
    // Three poses on each of the two panels plus the key's marker, drawn as white discs.
    let white_discs = svg
        .split("<circle")
        .skip(1)
        .filter(|c| {
            c.split('>')
                .next()
                .unwrap_or("")
                .contains("fill=\"#FFFFFF\"")
        })
        .count();
    assert_eq!(white_discs, 2 * 3 + 1);
}

#[test]
fn the_error_distribution_names_each_model_with_its_statistics() {
    let figure = ErrorDistribution {
        title: "position errors on held.csv".into(),
        samples: vec![
            ErrorSample {
                name: "nominal.yaml".into(),
                errors_m: vec![0.003, 0.004, 0.012],
            },
            ErrorSample {
                name: "calibrated.yaml".into(),
                errors_m: vec![0.0001, 0.0002, 0.0002],
            },
        ],
    };
    let texts = svg_texts(&svg(&figure));
    // RMS √((9 + 16 + 144)/3) = 7.51 mm; p95 by interpolation 4 + 0.9·8 = 11.2 mm.
    for wanted in [
        "position errors on held.csv",
        "position error (mm, logarithmic)",
        "fraction of poses with a smaller error",
        "nominal.yaml: RMS 7.51 mm, p95 11.2 mm, max 12 mm (3 poses)",
        "calibrated.yaml: RMS 0.173 mm, p95 0.2 mm, max 0.2 mm (3 poses)",
    ] {
        assert!(has(&texts, wanted), "`{wanted}` missing from {texts:?}");
    }
}

#[test]
fn a_png_renders_with_the_embedded_font() {
    let figure = small_map();
    let bytes = render(&figure, Format::Png).expect("PNG renders");
    let decoder = png::Decoder::new(bytes.as_slice());
    let mut reader = decoder.read_info().expect("a valid PNG");
    let mut pixels = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut pixels).expect("one frame");
    assert_eq!((info.width, info.height), figure.size());
    assert_eq!(info.color_type, png::ColorType::Rgb);
    // The title strip (top 40 rows) is white except for the title's glyphs: text was drawn.
    let stride = info.width as usize * 3;
    let dark = pixels[..40 * stride]
        .chunks(3)
        .filter(|p| p.iter().all(|&c| c < 100))
        .count();
    assert!(dark > 50, "{dark} dark pixels in the title strip");
}

#[test]
fn bad_picture_paths_are_refused_before_any_work_with_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let workspace = |out: &Path| {
        legwise(&[
            "workspace",
            "--model",
            "models/5r.yaml",
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let refused = |out: std::process::Output| {
        assert_eq!(out.status.code(), Some(2));
        assert!(out.stdout.is_empty(), "nothing done");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let missing = dir.path().join("no/such/dir/ws.svg");
    let stderr = refused(workspace(&missing));
    assert!(stderr.contains("no/such/dir"), "{stderr}");
    let jpeg = dir.path().join("ws.jpg");
    let stderr = refused(workspace(&jpeg));
    assert!(
        stderr.contains("ws.jpg") && stderr.contains("ending in .svg or .png"),
        "{stderr}"
    );
    let out = legwise(&[
        "workspace",
        "--model",
        "models/5r.yaml",
        "--png",
        "--out",
        dir.path().join("ws.svg").to_str().unwrap(),
    ]);
    let stderr = refused(out);
    assert!(
        stderr.contains("--png") && stderr.contains("does not end in .png"),
        "{stderr}"
    );
    // A pose file is an input: never overwritten by the picture.
    let poses = dir.path().join("poses.svg");
    std::fs::write(&poses, "leg,x,y,A1,A2\n,0.0,1.1,,\n").unwrap();
    let out = legwise(&[
        "workspace",
        "--model",
        "models/5r.yaml",
        "--poses",
        poses.to_str().unwrap(),
        "--out",
        poses.to_str().unwrap(),
    ]);
    let stderr = refused(out);
    assert!(stderr.contains("pose file"), "{stderr}");
    assert_eq!(
        std::fs::read_to_string(&poses).unwrap(),
        "leg,x,y,A1,A2\n,0.0,1.1,,\n"
    );
}

fn legwise(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the legwise binary runs")
}

#[test]
fn identify_plots_writes_the_parameter_errors_and_the_map() {
    let dir = tempfile::tempdir().unwrap();
    let plots = dir.path().join("pictures");
    let out = legwise(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--map",
        "0.1",
        "--plots",
        plots.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for name in ["parameter-errors.svg", "accuracy-map.svg"] {
        let path = plots.join(name);
        assert!(stdout.contains(&format!("picture written to {}", path.display())));
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.starts_with("<svg"), "{name}");
    }
    let map = std::fs::read_to_string(plots.join("accuracy-map.svg")).unwrap();
    let texts = svg_texts(&map);
    assert!(texts
        .iter()
        .any(|t| t.starts_with("before (nominal model): RMS ")));
    assert!(texts
        .iter()
        .any(|t| t.starts_with("after: divide and conquer: RMS ")));
    // 18 poses per leg and 18 shared.
    assert!(has(&texts, "measured poses (54)"), "{texts:?}");
}

#[test]
fn identify_plots_needs_a_simulation_and_a_directory() {
    let out = legwise(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/valid.csv",
        "--plots",
        "unused",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("--plots") && stderr.contains("simulation"),
        "{stderr}"
    );
    assert!(!Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("unused")
        .exists());
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "").unwrap();
    let out = legwise(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--plots",
        file.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--plots expects a directory"), "{stderr}");
}

#[test]
fn evaluate_plots_draws_the_distribution_of_every_full_row() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("held.csv");
    let out = legwise(&[
        "simulate",
        "--model",
        "models/5r.yaml",
        "--poses",
        "random",
        "--seed",
        "7",
        "--out",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0));
    // Rows holding both readings (the shared poses), counted from the file itself.
    let full_rows = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .skip(1)
        .filter(|row| row.split(',').skip(3).all(|cell| !cell.is_empty()))
        .count();
    assert!(full_rows > 0);
    let plots = dir.path().join("pictures");
    let out = legwise(&[
        "evaluate",
        "--model",
        "models/5r.yaml",
        "--against",
        "models/5r.yaml",
        "--measurements",
        csv.to_str().unwrap(),
        "--plots",
        plots.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let svg = std::fs::read_to_string(plots.join("position-errors.svg")).unwrap();
    let texts = svg_texts(&svg);
    assert!(
        texts
            .iter()
            .any(|t| t.starts_with("position errors on ") && t.ends_with("held.csv")),
        "{texts:?}"
    );
    let legends: Vec<&String> = texts
        .iter()
        .filter(|t| t.starts_with("5r.yaml: RMS ") && t.ends_with(&format!("({full_rows} poses)")))
        .collect();
    assert_eq!(legends.len(), 2, "both models named: {texts:?}");
}
