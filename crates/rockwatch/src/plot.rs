//! SVG plots of a simulation: ground acceleration, θ/α and slide against time, with the
//! response mode shaded (in the manner of the seed paper's Figures 2 and 3).

use std::path::Path;

use plotters::prelude::*;

use rockwatch_core::dynamics::{BlockParams, Mode};
use rockwatch_core::simulate::Trace;
use rockwatch_core::STANDARD_GRAVITY_MPS2;

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

/// Contiguous runs `(t_start, t_end, mode)` of the trace's modes.
fn mode_runs(trace: &Trace) -> Vec<(f64, f64, Mode)> {
    let mut runs: Vec<(f64, f64, Mode)> = Vec::new();
    for (i, (&t, &m)) in trace.t_s.iter().zip(&trace.mode).enumerate() {
        let t_prev = if i == 0 { t } else { trace.t_s[i - 1] };
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

/// Writes the three-panel SVG plot of `trace` to `path`.
pub fn plot_simulation(
    path: &Path,
    trace: &Trace,
    params: &BlockParams,
    title: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    ensure_font();
    let root = SVGBackend::new(path, (1000, 800)).into_drawing_area();
    root.fill(&WHITE)?;
    let (head, body) = root.split_vertically(48);
    head.titled(
        &format!(
            "{title} — B = {} m, H = {} m, α = {:.3} rad, μs = {}, μk = {}",
            params.width_m, params.height_m, params.alpha_rad, params.mu_s, params.mu_k
        ),
        ("sans-serif", 16),
    )?;
    let panels = body.split_evenly((3, 1));
    let t_end = trace.t_s.last().copied().unwrap_or(1.0).max(1e-9);
    let runs = mode_runs(trace);
    let accel_g: Vec<f64> = trace
        .horizontal_mps2
        .iter()
        .map(|a| a / STANDARD_GRAVITY_MPS2)
        .collect();
    let theta_over_alpha: Vec<f64> = trace
        .theta_rad
        .iter()
        .map(|t| t / params.alpha_rad)
        .collect();
    let series: [(&str, &Vec<f64>, RGBColor); 3] = [
        ("ground acceleration (g)", &accel_g, RGBColor(0, 0, 0)),
        ("θ/α", &theta_over_alpha, RGBColor(0, 114, 178)),
        ("slide u (m)", &trace.slide_m, RGBColor(0, 158, 115)),
    ];
    for (panel, (label, values, colour)) in panels.iter().zip(series) {
        let (lo, hi) = range(values.iter().copied());
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
        chart.draw_series(LineSeries::new(
            trace.t_s.iter().copied().zip(values.iter().copied()),
            colour.stroke_width(1),
        ))?;
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
