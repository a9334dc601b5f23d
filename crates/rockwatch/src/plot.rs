//! Plots of a simulation (SVG or PNG by the file's extension): ground acceleration
//! (horizontal, and vertical when the record has it), θ/α with the ±1 lines of the static
//! overturning angle, and slide against time, with the response mode shaded (in the manner of
//! the seed paper's Figures 2 and 3); the same figure of a 3-D simulation (the ground's
//! components, tilt/α, the foot's slide).

use std::error::Error;
use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

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

/// Font size of a figure's title (pixels) when it fits; a longer title is wrapped, then set
/// smaller down to [`TITLE_MIN_PX`] ([`fit_title`]).
pub const TITLE_PX: u32 = 16;
/// Smallest font size of a title (pixels).
pub const TITLE_MIN_PX: u32 = 11;
/// Most lines of a title.
const TITLE_MAX_LINES: usize = 3;
/// Free space left and right of a title (pixels).
const TITLE_SIDE_PX: u32 = 16;

/// A title laid out to fit a width: its lines and font size (pixels).
#[derive(Debug, Clone, PartialEq)]
pub struct FittedTitle {
    /// The lines, each narrower than the width asked for.
    pub lines: Vec<String>,
    /// Font size (pixels).
    pub size_px: u32,
}

impl FittedTitle {
    /// Height of the lines (pixels), with a gap above and below.
    #[must_use]
    pub fn height_px(&self) -> u32 {
        self.lines.len() as u32 * (self.size_px + 4) + 8
    }

    /// Draws the lines centred at the top of `area`.
    pub fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let (width, _) = area.dim_in_pixel();
        let style = TextStyle::from(("sans-serif", self.size_px).into_font())
            .pos(Pos::new(HPos::Center, VPos::Top));
        for (k, line) in self.lines.iter().enumerate() {
            let y = 4 + k as i32 * (self.size_px as i32 + 4);
            area.draw(&Text::new(line.as_str(), ((width / 2) as i32, y), &style))?;
        }
        Ok(())
    }
}

/// The one title policy of every figure: `text` at [`TITLE_PX`] if it fits the width of
/// `area` (less a margin each side); else wrapped at its words into at most three lines,
/// from [`TITLE_PX`] down to [`TITLE_MIN_PX`]; a word wider than the width on its own (a
/// long path) keeps its end, after "…". No line is wider than the area, so nothing is cut.
pub fn fit_title<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
) -> Result<FittedTitle, Box<dyn Error>>
where
    DB::ErrorType: 'static,
{
    let (width, _) = area.dim_in_pixel();
    let room = width.saturating_sub(2 * TITLE_SIDE_PX).max(1);
    let mut fitted = None;
    for size_px in (TITLE_MIN_PX..=TITLE_PX).rev() {
        let font = TextStyle::from(("sans-serif", size_px).into_font());
        let fits = |s: &str| -> Result<bool, Box<dyn Error>> {
            Ok(area.estimate_text_size(s, &font)?.0 <= room)
        };
        // The pieces to wrap: the title's phrases (cut after ", " and before " — ", so that
        // "H = 2.5 m" stays whole), a phrase wider than the room cut into its words, a word
        // wider than the room shortened to its end after an ellipsis.
        let mut pieces: Vec<String> = Vec::new();
        for phrase in phrases(text) {
            if fits(&phrase)? {
                pieces.push(phrase);
                continue;
            }
            for word in phrase.split(' ').filter(|w| !w.is_empty()) {
                let mut word = word.to_string();
                while !fits(&word)? && word.chars().count() > 1 {
                    let rest: String = word.chars().skip(2).collect();
                    word = format!("…{rest}");
                }
                pieces.push(word);
            }
        }
        let mut lines: Vec<String> = Vec::new();
        for piece in pieces {
            match lines.last_mut() {
                Some(line) if fits(&format!("{line} {piece}"))? => {
                    line.push(' ');
                    line.push_str(&piece);
                }
                _ => lines.push(piece),
            }
        }
        let done = lines.len() <= TITLE_MAX_LINES;
        fitted = Some(FittedTitle { lines, size_px });
        if done {
            break;
        }
    }
    Ok(fitted.unwrap_or(FittedTitle {
        lines: Vec::new(),
        size_px: TITLE_PX,
    }))
}

/// The phrases of a title: cut after each ", " and before each " — " (the separators stay
/// with the phrase before and after), without the spaces at the cuts.
fn phrases(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for part in text.split(", ") {
        out.push(format!("{part},"));
    }
    if let Some(last) = out.last_mut() {
        last.pop();
    }
    out.into_iter()
        .flat_map(|p| {
            let mut pieces: Vec<String> = p.split(" — ").map(str::to_string).collect();
            for piece in pieces.iter_mut().skip(1) {
                *piece = format!("— {piece}");
            }
            pieces
        })
        .filter(|p| !p.trim().is_empty())
        .collect()
}

/// The one way a band is drawn: `outline` (the upper edge, then the lower edge reversed, in
/// data coordinates) filled with `fill`, and a swatch of that fill beside `label` in the legend.
pub fn draw_band<DB, X, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    outline: Vec<(f64, f64)>,
    fill: ShapeStyle,
    label: impl Into<String>,
) -> DrawResult
where
    DB: DrawingBackend,
    DB::ErrorType: 'static,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    chart
        .draw_series(std::iter::once(Polygon::new(outline, fill)))?
        .label(label)
        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], fill));
    Ok(())
}

/// The one legend style: the series' labels in a white, black-bordered box at `position`
/// (plotters' default, the upper middle, when `None`) in `font_px` sans-serif.
pub fn draw_legend<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    position: Option<SeriesLabelPosition>,
    font_px: u32,
) -> DrawResult
where
    DB: DrawingBackend + 'a,
    DB::ErrorType: 'static,
    X: Ranged,
    Y: Ranged,
{
    let mut labels = chart.configure_series_labels();
    if let Some(position) = position {
        labels.position(position);
    }
    labels
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", font_px))
        .draw()?;
    Ok(())
}

/// The one tick policy of a logarithmic axis from `lo` to `hi` (> 0): the values 1, 2 and 5
/// × 10ᵏ within the range, or 1 to 9 × 10ᵏ when those are fewer than four; over a range too
/// narrow for four of those (less than about a factor of 2), four or more evenly spaced round
/// values. plotters' own log axis labels only the powers of ten and a few others: two labels
/// over a PGV/PGA axis of 0.05 to 0.3 s.
#[must_use]
pub fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && lo.is_finite() && hi.is_finite()) {
        return Vec::new();
    }
    let within = |x: f64| x >= lo * (1.0 - 1e-9) && x <= hi * (1.0 + 1e-9);
    let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    for mantissas in [
        &[1.0, 2.0, 5.0][..],
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
    ] {
        let ticks: Vec<f64> = (k0..=k1)
            .flat_map(|k| mantissas.iter().map(move |m| m * 10f64.powi(k)))
            .filter(|&x| within(x))
            .collect();
        if ticks.len() >= 4 {
            return ticks;
        }
    }
    // Evenly spaced round values: a step of 1, 2 or 5 × 10ᵏ giving four or more.
    let raw = (hi - lo) / 4.0;
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [5.0, 2.0, 1.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|s| (hi - lo) / s >= 4.0)
        .unwrap_or(magnitude);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last)
        .map(|i| i as f64 * step)
        .filter(|&x| within(x))
        .collect()
}

/// The one colour-bar policy: a vertical bar in `area` of `colour(p)` for p from 0 (bottom)
/// to 1 (top) in 100 steps, its ticks 0, 0.2, …, 1 on the right and `label` above it.
pub fn draw_colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    colour: impl Fn(f64) -> RGBColor,
    label: &str,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let (_, height) = area.dim_in_pixel();
    let (x0, x1) = (10_i32, 30_i32);
    let (top, bottom) = (40_i32, height as i32 - 60);
    if bottom <= top {
        return Ok(());
    }
    area.draw(&Text::new(label, (4, top - 24), ("sans-serif", 13)))?;
    let steps = 100;
    let span = f64::from(bottom - top);
    for k in 0..steps {
        let p = (f64::from(k) + 0.5) / f64::from(steps);
        let y_lo = bottom - (span * f64::from(k) / f64::from(steps)).round() as i32;
        let y_hi = bottom - (span * f64::from(k + 1) / f64::from(steps)).round() as i32;
        area.draw(&Rectangle::new(
            [(x0, y_hi), (x1, y_lo)],
            colour(p).filled(),
        ))?;
    }
    area.draw(&Rectangle::new(
        [(x0, top), (x1, bottom)],
        BLACK.stroke_width(1),
    ))?;
    for k in 0..=5 {
        let p = f64::from(k) / 5.0;
        let y = bottom - (span * p).round() as i32;
        area.draw(&PathElement::new(
            [(x1, y), (x1 + 5, y)],
            BLACK.stroke_width(1),
        ))?;
        let style =
            TextStyle::from(("sans-serif", 12).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
        area.draw(&Text::new(format!("{p:.1}"), (x1 + 8, y), &style))?;
    }
    Ok(())
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
        let title = fit_title(root, &self.title)?;
        // The title's lines, then a row for the legend of the mode colours.
        let legend_y = title.height_px() as i32;
        let (head, body) = root.split_vertically(title.height_px() + 22);
        title.draw(&head)?;
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
                draw_legend(&mut chart, None, 12)?;
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
                root.draw(&Rectangle::new(
                    [(x, legend_y), (x + 14, legend_y + 12)],
                    fill.filled(),
                ))?;
                root.draw(&Text::new(
                    mode.as_str(),
                    (x + 18, legend_y),
                    ("sans-serif", 12),
                ))?;
            }
        }
        root.present()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{log_ticks, phrases};

    #[test]
    fn titles_are_cut_into_phrases_at_commas_and_dashes_only() {
        assert_eq!(
            phrases("a.AT2 × 0.5 — B = 0.58 m, H = 2.5 m, μk = 1"),
            ["a.AT2 × 0.5", "— B = 0.58 m,", "H = 2.5 m,", "μk = 1"]
        );
        assert_eq!(phrases("one"), ["one"]);
        // Joined with spaces, the phrases are the title again.
        let title = "x: P(overturn | PGA, PGV/PGA) = Φ(-1 + 2 ln PGA) — y";
        assert_eq!(phrases(title).join(" "), title);
    }

    /// Issue 20 item 26: plotters labelled a PGV/PGA axis of 0.035 to 0.25 s at 0.1 and 0.2
    /// only. The ticks are within the range, increasing, at least four, and round (1, 2, 5 ×
    /// 10ᵏ, or every 10ᵏ⁻¹ … over a narrow range).
    #[test]
    fn log_axes_get_at_least_four_round_ticks_within_the_range() {
        for (lo, hi) in [
            (0.035, 0.25),
            (0.05, 5.5),
            (0.4, 0.9),
            (1.0, 1.3),
            (2e-4, 3e-1),
            (12.0, 13.0),
        ] {
            let ticks = log_ticks(lo, hi);
            assert!(ticks.len() >= 4, "{lo}..{hi}: {ticks:?}");
            assert!(ticks.windows(2).all(|w| w[0] < w[1]), "{ticks:?}");
            assert!(
                ticks
                    .iter()
                    .all(|&t| t >= lo * 0.999_999 && t <= hi * 1.000_001),
                "{lo}..{hi}: {ticks:?}"
            );
            for t in &ticks {
                // Round: at most three significant digits (1.05 over 1 to 1.3).
                let text = crate::number_text::short_number(*t);
                let digits = text.trim_start_matches(['0', '.']).replace('.', "");
                assert!(
                    digits.trim_end_matches('0').len() <= 3,
                    "{lo}..{hi}: {t} ({text})"
                );
            }
        }
        assert_eq!(
            log_ticks(0.035, 0.25),
            vec![0.04, 0.05, 0.06, 0.07, 0.08, 0.09, 0.1, 0.2]
        );
        assert!(log_ticks(1.0, 1.0).is_empty() && log_ticks(0.0, 1.0).is_empty());
    }
}
