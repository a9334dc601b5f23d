//! Plots of a simulation (SVG or PNG by the file's extension): ground acceleration
//! (horizontal, and vertical when the record has it), θ/α with the ±1 lines of the static
//! overturning angle, and slide against time, with the response mode shaded (in the manner of
//! the seed paper's Figures 2 and 3); the same figure of a 3-D simulation (the ground's
//! components, tilt/α, the foot's slide).

use std::error::Error;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use rockwatch_core::dynamics::{BlockParams, Mode};

use crate::number_text::block_label;
use rockwatch_core::rocking3d::{GroundAccel3d, Trace3d};
use rockwatch_core::simulate::Trace;
use rockwatch_core::STANDARD_GRAVITY_MPS2;

/// A plot could not be drawn or written.
#[derive(Debug, thiserror::Error)]
#[error("cannot draw {path}: {message}")]
pub struct PlotError {
    /// The file.
    pub path: PathBuf,
    /// What went wrong.
    pub message: String,
}

impl PlotError {
    /// `error` about the file (or directory) `path`.
    pub fn new(path: &Path, error: &dyn std::fmt::Display) -> PlotError {
        PlotError {
            path: path.to_path_buf(),
            message: error.to_string(),
        }
    }
}

/// What a drawing function returns (plotters' errors are of several types).
pub type DrawResult = Result<(), Box<dyn Error>>;

/// Draws one figure of `size` pixels into `<stem>.svg` (with `svg`) and `<stem>.png` (with
/// `png`: the same drawing on the bitmap backend); returns both paths.
pub fn both_formats(
    stem: &Path,
    size: (u32, u32),
    svg: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> DrawResult,
    png: impl FnOnce(&DrawingArea<BitMapBackend, Shift>) -> DrawResult,
) -> Result<Vec<PathBuf>, PlotError> {
    ensure_font();
    let svg_path = stem.with_extension("svg");
    let png_path = stem.with_extension("png");
    {
        let root = SVGBackend::new(&svg_path, size).into_drawing_area();
        svg(&root).map_err(|e| PlotError::new(&svg_path, &e))?;
    }
    {
        let root = BitMapBackend::new(&png_path, size).into_drawing_area();
        png(&root).map_err(|e| PlotError::new(&png_path, &e))?;
    }
    Ok(vec![svg_path, png_path])
}

/// Draws one figure of `size` pixels into `path`: PNG if it ends in `.png`, SVG if it ends in
/// `.svg` (any other extension is an error, so that the content matches the name).
pub fn by_extension(
    path: &Path,
    size: (u32, u32),
    svg: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> DrawResult,
    png: impl FnOnce(&DrawingArea<BitMapBackend, Shift>) -> DrawResult,
) -> Result<(), PlotError> {
    ensure_font();
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("svg") => svg(&SVGBackend::new(path, size).into_drawing_area()),
        Some("png") => png(&BitMapBackend::new(path, size).into_drawing_area()),
        _ => Err("the plot file must end in .svg or .png".into()),
    }
    .map_err(|e| PlotError::new(path, &e))
}

/// DejaVu Sans, subset (assets/fonts/README.md): compiled in, so text renders on machines
/// without fonts (plotters' `ab_glyph` backend uses only registered fonts).
static BUNDLED_FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans-subset.ttf");

/// Registers the bundled font as plotters' `"sans-serif"` family (once per process). Every
/// plotting function calls it first; text drawn in any other family fails.
pub fn ensure_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The bundled file is a valid TrueType font, so registration cannot fail at run time
        // (tests/study.rs renders PNG text with it; a missing font would fail those plots).
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, BUNDLED_FONT);
    });
}

/// Fill colour of each moving mode (rest is left white).
fn mode_colour(mode: Mode) -> Option<RGBAColor> {
    match mode {
        Mode::Rest => None,
        Mode::Slide => Some(RGBColor(86, 180, 233).mix(0.25)),
        Mode::Rock => Some(RGBColor(230, 159, 0).mix(0.25)),
        Mode::SlideRock => Some(RGBColor(204, 121, 167).mix(0.3)),
        Mode::Overturned => Some(RGBColor(213, 94, 0).mix(0.35)),
        Mode::Flight => Some(RGBColor(120, 120, 120).mix(0.35)),
    }
}

/// Contiguous runs `(t_start, t_end, mode)` of the modes at times `t_s`.
fn mode_runs(t_s: &[f64], modes: &[Mode]) -> Vec<(f64, f64, Mode)> {
    let mut runs: Vec<(f64, f64, Mode)> = Vec::new();
    for (i, (&t, &m)) in t_s.iter().zip(modes).enumerate() {
        let t_prev = if i == 0 { t } else { t_s[i - 1] };
        match runs.last_mut() {
            Some(run) if run.2 == m => run.1 = t,
            _ => runs.push((t_prev, t, m)),
        }
    }
    runs
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((0.0f64, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    // A flat series (e.g. no slide) still gets a readable axis of ±1e-3 units.
    let pad = (0.05 * (hi - lo)).max(1e-3);
    (lo - pad, hi + pad)
}

/// One curve of a panel: values (one per trace sample), colour, legend name.
type Series<'a> = (&'a [f64], RGBColor, &'static str);

/// One panel: the y-axis label, its curves, and horizontal reference levels.
type Panel<'a> = (&'static str, Vec<Series<'a>>, &'static [f64]);

/// Size of a simulation plot (pixels; SVG user units).
const SIZE: (u32, u32) = (1000, 800);

/// Writes the three-panel plot of `trace` to `path`: PNG if it ends in `.png`, SVG if it
/// ends in `.svg` ([`by_extension`]).
pub fn plot_simulation(
    path: &Path,
    trace: &Trace,
    params: &BlockParams,
    title: &str,
) -> Result<(), PlotError> {
    let in_g =
        |values: &[f64]| -> Vec<f64> { values.iter().map(|a| a / STANDARD_GRAVITY_MPS2).collect() };
    let horizontal_g = in_g(&trace.horizontal_mps2);
    let vertical_g = in_g(&trace.vertical_mps2);
    let theta_over_alpha: Vec<f64> = trace
        .theta_rad
        .iter()
        .map(|&t| params.theta_over_alpha(t))
        .collect();
    let mut accel: Vec<Series> = vec![(&horizontal_g, RGBColor(0, 0, 0), "horizontal")];
    if !vertical_g.is_empty() {
        accel.push((&vertical_g, RGBColor(153, 153, 153), "vertical"));
    }
    let history = History {
        title: format!("{title} — {}", block_label(params)),
        t_s: &trace.t_s,
        modes: &trace.mode,
        panels: [
            ("ground acceleration (g)", accel, &[]),
            (
                "θ/α",
                vec![(&theta_over_alpha, RGBColor(0, 114, 178), "θ/α")],
                &[-1.0, 1.0],
            ),
            (
                "slide u (m)",
                vec![(&trace.slide_m, RGBColor(0, 158, 115), "slide")],
                &[],
            ),
        ],
    };
    history.write(path)
}

/// Writes the three-panel plot of a 3-D simulation to `path` (PNG or SVG by extension): the
/// ground acceleration (east, north, up of the mesh), tilt/α with its line at 1, and the foot's
/// slide, modes shaded (docs/rocking-3d.md; [`rockwatch_core::rocking3d::report`]).
pub fn plot_simulation_3d(path: &Path, trace: &Trace3d, title: &str) -> Result<(), PlotError> {
    let component = |f: fn(&GroundAccel3d) -> f64| -> Vec<f64> {
        trace
            .ground
            .iter()
            .map(|a| f(a) / STANDARD_GRAVITY_MPS2)
            .collect()
    };
    let (east, north, up) = (
        component(|a| a.east_mps2),
        component(|a| a.north_mps2),
        component(|a| a.up_mps2),
    );
    let tilt_over_alpha: Vec<f64> = trace.view.iter().map(|v| v.theta_over_alpha).collect();
    let slide: Vec<f64> = trace.view.iter().map(|v| v.slide_m).collect();
    let modes: Vec<Mode> = trace.view.iter().map(|v| v.mode).collect();
    let mut accel: Vec<Series> = vec![
        (&east, RGBColor(0, 0, 0), "east"),
        (&north, RGBColor(0, 114, 178), "north"),
    ];
    if up.iter().any(|&a| a != 0.0) {
        accel.push((&up, RGBColor(153, 153, 153), "up"));
    }
    let history = History {
        title: title.to_string(),
        t_s: &trace.t_s,
        modes: &modes,
        panels: [
            ("ground acceleration (g)", accel, &[]),
            (
                "tilt/α",
                vec![(&tilt_over_alpha, RGBColor(0, 114, 178), "tilt/α")],
                &[1.0],
            ),
            (
                "foot slide (m)",
                vec![(&slide, RGBColor(0, 158, 115), "slide")],
                &[],
            ),
        ],
    };
    history.write(path)
}

/// A time-history figure: a title, three panels against time, the response mode shaded.
struct History<'a> {
    title: String,
    t_s: &'a [f64],
    modes: &'a [Mode],
    panels: [Panel<'a>; 3],
}

impl History<'_> {
    /// Writes the figure to `path` (PNG or SVG by extension, [`by_extension`]).
    fn write(&self, path: &Path) -> Result<(), PlotError> {
        by_extension(path, SIZE, |root| self.draw(root), |root| self.draw(root))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE)?;
        let (head, body) = root.split_vertically(48);
        head.titled(&self.title, ("sans-serif", 16))?;
        let areas = body.split_evenly((3, 1));
        let t_end = self.t_s.last().copied().unwrap_or(1.0).max(1e-9);
        let runs = mode_runs(self.t_s, self.modes);
        for (panel, (label, series, levels)) in areas.iter().zip(&self.panels) {
            let (label, levels) = (*label, *levels);
            let (lo, hi) = range(
                series
                    .iter()
                    .flat_map(|(values, _, _)| values.iter().copied())
                    .chain(levels.iter().copied()),
            );
            let mut chart = ChartBuilder::on(panel)
                .margin(8)
                .x_label_area_size(30)
                .y_label_area_size(60)
                .build_cartesian_2d(0.0..t_end, lo..hi)?;
            chart
                .configure_mesh()
                .x_desc("time (s)")
                .y_desc(label)
                .light_line_style(WHITE)
                .draw()?;
            for &(t0, t1, mode) in &runs {
                if let Some(fill) = mode_colour(mode) {
                    chart.draw_series(std::iter::once(Rectangle::new(
                        [(t0, lo), (t1, hi)],
                        fill.filled(),
                    )))?;
                }
            }
            for &level in levels {
                chart.draw_series(LineSeries::new(
                    [(0.0, level), (t_end, level)],
                    RGBColor(213, 94, 0).stroke_width(1),
                ))?;
            }
            let labelled = series.len() > 1;
            for &(values, colour, name) in series {
                let drawn = chart.draw_series(LineSeries::new(
                    self.t_s.iter().copied().zip(values.iter().copied()),
                    colour.stroke_width(1),
                ))?;
                if labelled {
                    drawn.label(name).legend(move |(x, y)| {
                        PathElement::new([(x, y), (x + 16, y)], colour.stroke_width(2))
                    });
                }
            }
            if labelled {
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.8))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 12))
                    .draw()?;
            }
        }
        // Legend of the mode colours, under the title.
        let legend = [
            Mode::Slide,
            Mode::Rock,
            Mode::SlideRock,
            Mode::Overturned,
            Mode::Flight,
        ];
        for (i, mode) in legend.iter().enumerate() {
            if let Some(fill) = mode_colour(*mode) {
                let x = 250 + 110 * i as i32;
                root.draw(&Rectangle::new([(x, 30), (x + 14, 42)], fill.filled()))?;
                root.draw(&Text::new(mode.as_str(), (x + 18, 30), ("sans-serif", 12)))?;
            }
        }
        root.present()?;
        Ok(())
    }
}
