//! The pictures: each figure's SVG holds its axis descriptions, units and legend entries (read
//! from the text, not just `<svg`), its marks match the data counted independently, a PNG is
//! its SVG rasterised with the embedded font (a decimal point on the baseline), and bad output
//! paths give clear errors.
use std::path::Path;
use std::process::Command;
use std::sync::Arc;

use legwise::identify::estimate::{identify, Strategy};
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::measure::Measurements;
use legwise::model::params::Unit;
use legwise::report::plots::canvas::Drawn;
use legwise::report::plots::distribution::{ErrorDistribution, ErrorSample};
use legwise::report::plots::error_map::{ErrorMapFigure, MapCell, MapPanel};
use legwise::report::plots::parameter_errors::{BarSeries, ParameterErrors, ParameterLabel};
use legwise::report::plots::slices::SlicesFigure;
use legwise::report::plots::workspace::{PoseGroup, WorkspaceFigure};
use legwise::report::plots::{render, style, Figure, Format};
use legwise::report::{RealValues, Report};
use legwise::solver::SolverKind;
use legwise::study::plots::{HistogramPanel, Histograms};
use plotters::coord::Shift;
use plotters::prelude::*;
use resvg::tiny_skia::{Color, Pixmap, Transform};
use resvg::usvg::{self, fontdb};

use crate::support::{bundled, svg_text_attribute, svg_texts};

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
        quantity: "position error".into(),
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

/// A logarithmic axis from 10⁻⁵ mm to 0.1 mm writes every tick with an exponent: it used to
/// mix `1.0e-5` and `0.001`.
#[test]
fn the_error_distribution_writes_its_log_ticks_alike() {
    let figure = ErrorDistribution {
        title: "height errors on held.csv".into(),
        quantity: "height error".into(),
        samples: vec![ErrorSample {
            name: "calibrated.yaml".into(),
            errors_m: vec![2e-8, 3e-7, 1e-5, 1e-4],
        }],
    };
    let texts = svg_texts(&svg(&figure));
    assert!(has(&texts, "height error (mm, logarithmic)"), "{texts:?}");
    let start = texts
        .iter()
        .position(|t| t == "height error (mm, logarithmic)")
        .unwrap();
    // The y ticks (0 … 1) come first, then the x ticks, then the legend.
    let x_ticks: Vec<&String> = texts[start + 1..]
        .iter()
        .skip_while(|t| t.parse::<f64>().is_ok_and(|v| v >= 0.0) && !t.contains('e'))
        .take_while(|t| t.parse::<f64>().is_ok())
        .collect();
    assert!(x_ticks.len() >= 4, "{texts:?}");
    assert!(
        x_ticks.iter().all(|t| t.contains('e')) && x_ticks.contains(&&"1e-3".to_string()),
        "{x_ticks:?}"
    );
}

/// The evaluation picture says what its errors are: positions, a target's positions, or the
/// heights a bed probe touches.
#[test]
fn the_evaluation_picture_names_the_errors_of_the_model() {
    use legwise::report::plots::files::error_quantity;
    for (model, quantity) in [
        ("5r.yaml", "position error"),
        ("5r-tracker.yaml", "target position error"),
        ("delta-probe.yaml", "height error"),
    ] {
        assert_eq!(error_quantity(&bundled(model)), quantity, "{model}");
    }
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("held.csv");
    let model = "models/delta-probe.yaml";
    let out = legwise(&[
        "simulate",
        "--model",
        model,
        "--seed",
        "7",
        "--out",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0));
    let plots = dir.path().join("pictures");
    let (csv, plots) = (csv.to_str().unwrap(), plots.to_str().unwrap());
    let out = legwise(&[
        "evaluate",
        "--model",
        model,
        "--measurements",
        csv,
        "--plots",
        plots,
    ]);
    assert!(
        out.status.code() != Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let svg = std::fs::read_to_string(dir.path().join("pictures/position-errors.svg")).unwrap();
    let texts = svg_texts(&svg);
    assert!(texts[0].starts_with("height errors on "), "{texts:?}");
    assert!(has(&texts, "height error (mm, logarithmic)"), "{texts:?}");
}

/// `svg` rasterised here, independently of legwise's renderer: resvg over white, with a font
/// database of the embedded DejaVu Sans regular and bold only, `sans-serif` mapped to it.
fn rasterised(svg: &str) -> Pixmap {
    let mut fonts = fontdb::Database::new();
    fonts.load_font_data(dejavu::sans::regular().to_vec());
    fonts.load_font_data(dejavu::sans::bold().to_vec());
    fonts.set_sans_serif_family("DejaVu Sans");
    let options = usvg::Options {
        fontdb: Arc::new(fonts),
        ..usvg::Options::default()
    };
    let tree = usvg::Tree::from_str(svg, &options).expect("the SVG parses");
    let size = tree.size().to_int_size();
    let mut pixmap = Pixmap::new(size.width(), size.height()).expect("a non-empty picture");
    pixmap.fill(Color::WHITE);
    resvg::render(&tree, Transform::identity(), &mut pixmap.as_mut());
    pixmap
}

/// The PNG of `figure`, decoded; checked to be the size the figure declares.
fn png(figure: &impl Figure, what: &str) -> Pixmap {
    let bytes = render(figure, Format::Png).expect("the PNG renders");
    let png = Pixmap::decode_png(&bytes).expect("a valid PNG");
    assert_eq!((png.width(), png.height()), figure.size(), "{what}: size");
    png
}

/// The PNG of `figure`, decoded; checked to be the size the figure declares and its SVG has,
/// and pixel for pixel the SVG rasterised with the embedded font alone.
fn png_of_svg(figure: &impl Figure, what: &str) -> Pixmap {
    let png = png(figure, what);
    let (width, height) = figure.size();
    let svg = svg(figure);
    assert!(
        svg.starts_with(&format!("<svg width=\"{width}\" height=\"{height}\"")),
        "{what}: the SVG is as large"
    );
    let expected = rasterised(&svg);
    let differing = png
        .pixels()
        .iter()
        .zip(expected.pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(
        differing, 0,
        "{what}: pixels differing from the rasterised SVG"
    );
    assert!(
        png.pixels().iter().all(|p| p.alpha() == 255),
        "{what}: opaque"
    );
    png
}

/// A small planar workspace picture: a square region, one serial curve, the MIW, two poses.
fn small_workspace(title: &str, axes: [&str; 2]) -> WorkspaceFigure {
    WorkspaceFigure {
        title: title.into(),
        region: vec![[-0.3, -0.3], [0.3, -0.3], [0.3, 0.3], [-0.3, 0.3]],
        serial: vec![vec![[-0.4, 0.35], [0.0, 0.45], [0.4, 0.35]]],
        parallel: vec![],
        miw_centre: [0.0, 0.0],
        miw_radius: 0.25,
        poses: vec![PoseGroup {
            name: "shared poses".into(),
            points: vec![[0.1, 0.1], [-0.1, 0.2]],
        }],
        bounds: ([-0.5, -0.5], [0.5, 0.5]),
        axes: axes.map(String::from),
        region_label: "singularity-free region".into(),
        serial_label: "serial (type I) singularity".into(),
        miw_label: "MIW: centre (0, 0) m, radius 0.25 m".into(),
        surfaces: vec![],
    }
}

fn small_slices() -> SlicesFigure {
    SlicesFigure {
        title: "test slices".into(),
        panels: vec![
            small_workspace("slice z = 0.6 m", ["x", "y"]),
            small_workspace("slice y = 0 m", ["x", "z"]),
            small_workspace("slice x = 0 m", ["y", "z"]),
        ],
    }
}

fn small_histograms() -> Histograms {
    let values = |shift: f64| (0..50).map(|k| shift + 0.01 * f64::from(k % 17)).collect();
    Histograms {
        title: "test histograms".into(),
        panels: ["l1 error (mm)", "gamma1 error (mrad)"]
            .into_iter()
            .map(|caption| HistogramPanel {
                caption: caption.into(),
                series: vec![
                    ("D&C".into(), values(0.0)),
                    ("traditional".into(), values(0.05)),
                ],
            })
            .collect(),
    }
}

/// Every kind of figure: its PNG is the rasterisation of its SVG (text included, with the
/// embedded font only), of the declared size. The old renderer (plotters' bitmap backend and
/// its own glyph placement) fails the pixel comparison.
#[test]
fn a_png_is_its_svg_rasterised_with_the_embedded_font() {
    let map = png_of_svg(&small_map(), "error map");
    // The title strip (top 40 rows) is white except for the title's glyphs: text was drawn.
    let dark = map
        .pixels()
        .iter()
        .take(40 * map.width() as usize)
        .filter(|p| p.red() < 100 && p.green() < 100 && p.blue() < 100)
        .count();
    assert!(dark > 50, "{dark} dark pixels in the title strip");
    let distribution = ErrorDistribution {
        title: "position errors on held.csv".into(),
        quantity: "position error".into(),
        samples: vec![ErrorSample {
            name: "nominal.yaml".into(),
            errors_m: vec![0.003, 0.004, 0.012],
        }],
    };
    png_of_svg(&distribution, "error distribution");
    let bars = ParameterErrors {
        title: "parameter errors (value − real)".into(),
        parameters: vec![
            ParameterLabel {
                name: "l1".into(),
                unit: Unit::Metre,
            },
            ParameterLabel {
                name: "gamma1".into(),
                unit: Unit::Radian,
            },
            ParameterLabel {
                name: "k1".into(),
                unit: Unit::One,
            },
        ],
        series: vec![BarSeries {
            name: "before (nominal values)".into(),
            errors: vec![-7e-4, -4.8e-3, -4e-3],
        }],
    };
    png_of_svg(&bars, "parameter errors");
    png_of_svg(&small_workspace("test workspace", ["x", "y"]), "workspace");
    png_of_svg(&small_slices(), "slices");
    png_of_svg(&small_histograms(), "histograms");
    png_of_svg(&Words("radius, gamma1, angle: 1.0957 m", 20.0), "words");
}

/// A picture holding one line of text of a size (plotters' size) and nothing else.
struct Words(&'static str, f64);

impl Figure for Words {
    fn size(&self) -> (u32, u32) {
        (400, 60)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn<DB> {
        root.fill(&WHITE)?;
        root.draw(&Text::new(
            self.0.to_string(),
            (10, 10),
            ("sans-serif", self.1),
        ))
    }
}

/// The glyphs of a one-line PNG text, left to right: each run of columns holding a dark
/// pixel (darker than mid-grey), as (first row, last row) of its dark pixels.
fn glyph_rows(png: &Pixmap) -> Vec<(u32, u32)> {
    let dark = |x: u32, y: u32| {
        let p = png.pixel(x, y).expect("inside");
        u32::from(p.red()) + u32::from(p.green()) + u32::from(p.blue()) < 3 * 128
    };
    let mut glyphs = Vec::new();
    let mut current: Option<(u32, u32)> = None;
    for x in 0..png.width() {
        let rows: Vec<u32> = (0..png.height()).filter(|&y| dark(x, y)).collect();
        match (rows.first(), rows.last(), current) {
            (Some(&top), Some(&bottom), Some((t, b))) => {
                current = Some((t.min(top), b.max(bottom)))
            }
            (Some(&top), Some(&bottom), None) => current = Some((top, bottom)),
            _ => glyphs.extend(current.take()),
        }
    }
    glyphs.extend(current);
    glyphs
}

/// At the sizes of the tick labels, axis descriptions and titles, a decimal point ends on the
/// baseline, as the foot of the `1` before it, and a comma hangs below it. The old renderer
/// drew both one pixel higher at the two smaller sizes: the point a raised dot (`1·0957`),
/// the comma a point.
#[test]
fn a_decimal_point_sits_on_the_baseline_and_a_comma_descends_below_it() {
    for size in [style::LABEL_SIZE, 15.0, 20.0] {
        for (text, mark) in [("1.0957", "point"), ("1,0957", "comma")] {
            let glyphs = glyph_rows(&png(&Words(text, size), text));
            assert_eq!(
                glyphs.len(),
                6,
                "{text} at {size}: one run of columns per glyph: {glyphs:?}"
            );
            let (one_top, baseline) = glyphs[0];
            let (mark_top, mark_bottom) = glyphs[1];
            assert!(mark_top > one_top + 3, "{text} at {size}: {glyphs:?}");
            if mark == "point" {
                assert_eq!(
                    mark_bottom, baseline,
                    "{text} at {size}: the point ends at row {mark_bottom}, the 1 at {baseline}"
                );
            } else {
                assert!(
                    mark_bottom > baseline,
                    "{text} at {size}: the comma ends at row {mark_bottom}, the 1 at {baseline}"
                );
            }
        }
    }
}

/// The legend of the slices (the spatial workspace picture, three plots wide and shown
/// shrunk) is in larger text than its tick labels, and at least 14 px (it was 10.5 px).
#[test]
fn the_slices_legend_is_larger_than_the_tick_labels() {
    let svg = svg(&small_slices());
    let font_size = |start: &str| svg_text_attribute(&svg, start, "font-size");
    let tick = font_size("0.2");
    for entry in [
        "singularity-free region",
        "serial (type I)",
        "MIW: centre",
        "shared poses (2)",
    ] {
        let size = font_size(entry);
        assert!(
            size >= 14.0 && size > 1.3 * tick,
            "`{entry}`: {size} px, ticks {tick} px"
        );
    }
}

/// The Monte Carlo histograms say what their height is: each panel has the rotated y-axis
/// description `fraction of trials`.
#[test]
fn each_monte_carlo_histogram_has_a_y_axis_description() {
    let svg = svg(&small_histograms());
    let descriptions = svg
        .split("<text")
        .filter(|c| {
            let (attributes, text) = c.split_once('>').unwrap_or_default();
            attributes.contains("transform=\"rotate(270")
                && text.trim_start().starts_with("fraction of trials")
        })
        .count();
    assert_eq!(descriptions, 2);
}

/// A histogram's x axis has at least three tick labels: the 200-trial gamma2 errors of the 5R
/// (-4.84 … 4.99 mrad) used to get a single `0`.
#[test]
fn a_monte_carlo_panel_has_at_least_three_x_ticks() {
    let values: Vec<f64> = (0..200)
        .map(|k| -4.841 + 9.832 * f64::from(k) / 199.0)
        .collect();
    let figure = Histograms {
        title: "test".into(),
        panels: vec![HistogramPanel {
            caption: "gamma2 error (mrad)".into(),
            series: vec![("D&C".into(), values)],
        }],
    };
    let texts = svg_texts(&svg(&figure));
    // After the caption and the y-axis description: the y ticks (fractions of 200 trials, at
    // most 0.05 here), then the x ticks.
    let start = texts
        .iter()
        .position(|t| t == "fraction of trials")
        .unwrap()
        + 1;
    let x_ticks: Vec<f64> = texts[start..]
        .iter()
        .filter_map(|t| t.parse::<f64>().ok())
        .filter(|v| v.abs() >= 1.0 || *v == 0.0)
        .collect();
    assert!(
        x_ticks.len() >= 3 && x_ticks.iter().any(|v| *v < 0.0) && x_ticks.iter().any(|v| *v > 0.0),
        "{:?}",
        &texts[start..]
    );
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

/// A shape or a text of an SVG, in document (drawing) order, with its bounding box
/// `[left, top, right, bottom]` (a text: its anchor point) and, for a text, its content.
#[derive(Debug)]
struct Element {
    text: Option<String>,
    legend: bool,
    size: f64,
    bounds: [f64; 4],
}

/// The rectangles, polylines, circles and texts of `svg`, in order.
fn drawn(svg: &str) -> Vec<Element> {
    let number = |tag: &str, name: &str| -> f64 {
        let key = format!(" {name}=\"");
        tag.split(&key)
            .nth(1)
            .and_then(|rest| rest.split('"').next())
            .and_then(|v| v.parse().ok())
            .unwrap_or(f64::NAN)
    };
    let mut elements = Vec::new();
    for chunk in svg.split('<').skip(1) {
        let (tag, rest) = chunk.split_once('>').unwrap_or((chunk, ""));
        let name = tag.split_whitespace().next().unwrap_or("");
        let bounds = match name {
            "rect" => {
                let (x, y) = (number(tag, "x"), number(tag, "y"));
                [x, y, x + number(tag, "width"), y + number(tag, "height")]
            }
            "circle" => {
                let (x, y, r) = (number(tag, "cx"), number(tag, "cy"), number(tag, "r"));
                [x - r, y - r, x + r, y + r]
            }
            "polyline" => {
                let points = tag
                    .split("points=\"")
                    .nth(1)
                    .unwrap()
                    .split('"')
                    .next()
                    .unwrap();
                let xy: Vec<[f64; 2]> = points
                    .split_whitespace()
                    .map(|p| {
                        let (x, y) = p.split_once(',').unwrap();
                        [x.parse().unwrap(), y.parse().unwrap()]
                    })
                    .collect();
                let fold = |k: usize, f: fn(f64, f64) -> f64, start: f64| {
                    xy.iter().map(|p| p[k]).fold(start, f)
                };
                [
                    fold(0, f64::min, f64::INFINITY),
                    fold(1, f64::min, f64::INFINITY),
                    fold(0, f64::max, f64::NEG_INFINITY),
                    fold(1, f64::max, f64::NEG_INFINITY),
                ]
            }
            "text" => {
                let (x, y) = (number(tag, "x"), number(tag, "y"));
                elements.push(Element {
                    text: Some(rest.trim().to_string()),
                    legend: tag.contains("dy=\"0.5ex\"") && tag.contains("text-anchor=\"start\""),
                    size: number(tag, "font-size"),
                    bounds: [x, y, x, y],
                });
                continue;
            }
            _ => continue,
        };
        elements.push(Element {
            text: None,
            legend: false,
            size: 0.0,
            bounds,
        });
    }
    elements
}

/// Every legend entry of `svg` (a text drawn at its vertical middle, left-aligned, after its
/// swatch) sits just right of its swatch and on its middle, inside the picture, and entries do
/// not overlap: side by side with room for the text before, or a text height apart. Returns the
/// entries' count.
fn assert_legend_laid_out(svg: &str, what: &str) -> usize {
    let elements = drawn(svg);
    let mut entries: Vec<(&str, f64, f64, f64)> = Vec::new();
    for (k, element) in elements.iter().enumerate() {
        let (Some(text), true) = (&element.text, element.legend) else {
            continue;
        };
        let [x, y, ..] = element.bounds;
        // The swatch: the small shapes drawn just before the text, ending within 40 px left of
        // it.
        let swatch: Vec<&Element> = elements[..k]
            .iter()
            .rev()
            .take_while(|e| {
                let [left, top, right, bottom] = e.bounds;
                e.text.is_none()
                    && bottom - top <= 3.0 * element.size
                    && right - left <= 40.0
                    && (0.0..=40.0).contains(&(x - right))
            })
            .collect();
        assert!(
            !swatch.is_empty(),
            "{what}: `{text}` has no swatch before it"
        );
        let top = swatch
            .iter()
            .map(|e| e.bounds[1])
            .fold(f64::INFINITY, f64::min);
        let bottom = swatch
            .iter()
            .map(|e| e.bounds[3])
            .fold(f64::NEG_INFINITY, f64::max);
        let right = swatch
            .iter()
            .map(|e| e.bounds[2])
            .fold(f64::NEG_INFINITY, f64::max);
        assert!(
            ((top + bottom) / 2.0 - y).abs() <= 1.0,
            "{what}: `{text}` at y {y}, its swatch from {top} to {bottom}"
        );
        assert!(
            right < x && x - right <= 16.0,
            "{what}: `{text}` at x {x}, its swatch ends at {right}"
        );
        entries.push((text, x, y, element.size));
    }
    let width: f64 = svg
        .split("width=\"")
        .nth(1)
        .and_then(|rest| rest.split('"').next())
        .and_then(|w| w.parse().ok())
        .expect("the picture's width");
    for (text, x, _, size) in &entries {
        let room = 0.45 * size * text.chars().count() as f64;
        assert!(
            x + room <= width,
            "{what}: `{text}` at x {x} runs out of the picture ({width})"
        );
    }
    for (a, b) in entries.iter().zip(entries.iter().skip(1)) {
        let same_row = (a.2 - b.2).abs() < 1.0;
        let room = 0.45 * a.3 * a.0.chars().count() as f64;
        assert!(
            if same_row {
                b.1 >= a.1 + room
            } else {
                (a.2 - b.2).abs() >= a.3
            },
            "{what}: `{}` at ({}, {}) overlaps `{}` at ({}, {})",
            b.0,
            b.1,
            b.2,
            a.0,
            a.1,
            a.2
        );
    }
    entries.len()
}

/// The legends of the pictures the commands draw: the planar workspace with its pose groups, the
/// parameter errors, the Monte Carlo histograms.
#[test]
fn every_legend_entry_sits_beside_its_swatch_without_overlapping_another() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let run = crate::cli::legwise_succeeds;
    run(&[
        "select",
        "--model",
        "models/5r.yaml",
        "--out",
        &path("poses.csv"),
    ]);
    let workspace = path("workspace.svg");
    let poses = path("poses.csv");
    run(&[
        "workspace",
        "--model",
        "models/5r.yaml",
        "--poses",
        &poses,
        "--rays",
        "64",
        "--out",
        &workspace,
    ]);
    run(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--plots",
        &path("identify"),
    ]);
    run(&[
        "montecarlo",
        "--model",
        "models/5r.yaml",
        "--trials",
        "3",
        "--map",
        "0.2",
        "--plots",
        &path("mc"),
    ]);
    for (file, entries) in [
        (workspace, 6),
        (path("identify/parameter-errors.svg"), 2),
        (path("mc/montecarlo-errors.svg"), 3),
    ] {
        let svg = std::fs::read_to_string(&file).unwrap();
        assert_eq!(assert_legend_laid_out(&svg, &file), entries, "{file}");
    }
}
