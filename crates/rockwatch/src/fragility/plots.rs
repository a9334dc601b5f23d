//! Plots of a rock's fragility, as SVG and PNG: for every fitted IM the lognormal curve with
//! its 95 % bootstrap band and the observed fractions with their 95 % Wilson intervals (per
//! stripe for the stripe IM, per log-spaced IM bin otherwise); the two-IM surface as filled
//! probability levels with the 10, 50 and 90 % contours (marching squares on the grid) and the
//! observed (record, level) cells coloured by their fraction overturned.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::report::{im_slug, stripe_fractions};
use crate::number_text::short_number;
use crate::plot::{
    both_formats, draw_band, draw_colour_bar, draw_legend, fit_title, log_ticks, DrawResult,
    PlotError,
};
use crate::units::AccelUnits;
use rockwatch_core::fragility::{
    cell_counts, wilson_interval, FragilityConfig, FragilityResult, ImFragility, Prepared,
    RunResult, Surface, Z_95,
};

const CURVE: RGBColor = RGBColor(0, 114, 178);
const POINTS: RGBColor = RGBColor(213, 94, 0);

/// Observed fractions `(im, k, n, lo, hi)` of IM i: per stripe for the stripe IM, else in 10
/// log-spaced bins of the (record, level) cells' IM values; each record (per stripe) or cell
/// (per bin) counts as one trial, weighted by its fraction overturned.
fn fractions(
    config: &FragilityConfig,
    prepared: &Prepared,
    runs: &[RunResult],
    i: usize,
    f: &ImFragility,
) -> Vec<(f64, f64, f64, f64, f64)> {
    if f.is_stripe_im {
        return stripe_fractions(config, prepared, runs);
    }
    let counts = cell_counts(config, prepared.ims.len(), runs);
    let mut cells = Vec::new();
    for (r, row) in counts.iter().enumerate() {
        for (j, c) in row.iter().enumerate() {
            let x = prepared.scaled_im(config, r, j, i);
            if x > 0.0 && x.is_finite() && c.trials > 0.0 {
                // Each (record, level) cell is one trial weighted by its fraction.
                cells.push((x, c.events / c.trials, 1.0));
            }
        }
    }
    let (lo, hi) = cells.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), c| {
        (lo.min(c.0), hi.max(c.0))
    });
    if !(lo.is_finite() && hi > lo) {
        return Vec::new();
    }
    let bins = 10;
    let width = (hi.ln() - lo.ln()) / bins as f64;
    let mut acc = vec![(0.0, 0.0, 0.0); bins];
    for (x, k, n) in cells {
        let b = (((x.ln() - lo.ln()) / width) as usize).min(bins - 1);
        acc[b].0 += n * x.ln();
        acc[b].1 += k;
        acc[b].2 += n;
    }
    acc.into_iter()
        .filter(|a| a.2 > 0.0)
        .map(|(sx, k, n)| {
            let (l, h) = wilson_interval(k, n, Z_95);
            ((sx / n).exp(), k, n, l, h)
        })
        .collect()
}

fn draw_curve<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    f: &ImFragility,
    points: &[(f64, f64, f64, f64, f64)],
    units: AccelUnits,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let Ok(fit) = &f.fit else { return Ok(()) };
    let name = f.im.name();
    // Computations in SI; the axis and the title in the shown unit (x / div).
    let (unit, div) = units.show(f.im.unit());
    let (mut lo, mut hi) = (
        fit.median * (-2.5 * fit.beta).exp(),
        fit.median * (2.5 * fit.beta).exp(),
    );
    for p in points {
        lo = lo.min(p.0 * 0.9);
        hi = hi.max(p.0 * 1.1);
    }
    let fitted = fit_title(
        root,
        &format!(
            "{title}: P(overturn | {name}), median {} {unit}, β = {}",
            short_number(fit.median / div),
            short_number(fit.beta)
        ),
    )?;
    let (head, body) = root.split_vertically(fitted.height_px());
    fitted.draw(&head)?;
    let (x_lo, x_hi) = (lo / div, hi / div);
    let mut chart = ChartBuilder::on(&body)
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(
            (x_lo..x_hi)
                .log_scale()
                .with_key_points(log_ticks(x_lo, x_hi)),
            0.0..1.0,
        )?;
    chart
        .configure_mesh()
        .x_desc(format!("{name} ({unit})"))
        .x_label_formatter(&|x| short_number(*x))
        .y_desc("probability of overturning")
        .label_style(("sans-serif", 13))
        .draw()?;
    let n = 150;
    let grid: Vec<f64> = (0..n)
        .map(|k| (lo.ln() + (hi.ln() - lo.ln()) * k as f64 / (n - 1) as f64).exp())
        .collect();
    if f.band(grid[0]).is_some() {
        let mut band: Vec<(f64, f64)> = grid
            .iter()
            .filter_map(|&x| f.band(x).map(|b| (x / div, b.1)))
            .collect();
        band.extend(
            grid.iter()
                .rev()
                .filter_map(|&x| f.band(x).map(|b| (x / div, b.0))),
        );
        draw_band(
            &mut chart,
            band,
            CURVE.mix(0.2).filled(),
            "95 % bootstrap band (records resampled)",
        )?;
    }
    let phi = |x: f64| rockwatch_core::stats::normal_cdf((x / fit.median).ln() / fit.beta);
    chart
        .draw_series(LineSeries::new(
            grid.iter().map(|&x| (x / div, phi(x))),
            CURVE.stroke_width(2),
        ))?
        .label("lognormal, maximum likelihood")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], CURVE.stroke_width(2)));
    chart.draw_series(points.iter().map(|p| {
        PathElement::new(
            vec![(p.0 / div, p.3), (p.0 / div, p.4)],
            POINTS.stroke_width(1),
        )
    }))?;
    chart
        .draw_series(
            points
                .iter()
                .map(|p| Circle::new((p.0 / div, p.1 / p.2), 4, POINTS.filled())),
        )?
        .label(if f.is_stripe_im {
            "fraction per stripe, 95 % Wilson interval (records as trials)"
        } else {
            "fraction per IM bin, 95 % Wilson interval (record-levels as trials)"
        })
        .legend(|(x, y)| Circle::new((x + 10, y), 4, POINTS.filled()));
    // Upper left: a fragility curve rises to the right, so that corner holds no data.
    draw_legend(&mut chart, Some(SeriesLabelPosition::UpperLeft), 14)?;
    root.present()?;
    Ok(())
}

/// Colour of a probability (white → blue).
fn shade(p: f64) -> RGBColor {
    let t = p.clamp(0.0, 1.0);
    let mix = |a: u8, b: u8| (f64::from(a) + (f64::from(b) - f64::from(a)) * t).round() as u8;
    RGBColor(mix(247, 8), mix(251, 48), mix(255, 107))
}

/// Contour segments of level `c` on the grid (marching squares, linear interpolation along
/// the cell edges, in log coordinates of both IMs).
fn contour(s: &Surface, c: f64) -> Vec<[(f64, f64); 2]> {
    let (g1, g2, p) = (&s.grid1, &s.grid2, &s.p);
    let mut segments = Vec::new();
    for a in 0..g1.len().saturating_sub(1) {
        for b in 0..g2.len().saturating_sub(1) {
            // Corners counter-clockwise: (a,b), (a+1,b), (a+1,b+1), (a,b+1).
            let corners = [(a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1)];
            let mut crossings = Vec::with_capacity(4);
            for e in 0..4 {
                let (i0, j0) = corners[e];
                let (i1, j1) = corners[(e + 1) % 4];
                let (v0, v1) = (p[i0][j0], p[i1][j1]);
                if (v0 < c) != (v1 < c) {
                    let t = (c - v0) / (v1 - v0);
                    let x = (g1[i0].ln() + t * (g1[i1].ln() - g1[i0].ln())).exp();
                    let y = (g2[j0].ln() + t * (g2[j1].ln() - g2[j0].ln())).exp();
                    crossings.push((x, y));
                }
            }
            // 2 crossings: one segment; 4 (a saddle): pair them in order.
            for pair in crossings.chunks(2) {
                if let [u, v] = pair {
                    segments.push([*u, *v]);
                }
            }
        }
    }
    segments
}

/// Width of the colour bar's column right of the surface (pixels).
const COLOUR_BAR_PX: u32 = 110;
/// Height of the legend's strip under the surface (pixels).
const LEGEND_PX: u32 = 44;

fn draw_surface<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    config: &FragilityConfig,
    s: &Surface,
    cells: &[(f64, f64, f64)],
    units: AccelUnits,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let Ok(fit) = &s.fit else { return Ok(()) };
    let (g1, g2) = (&s.grid1, &s.grid2);
    let (Some(&x0), Some(&x1), Some(&y0), Some(&y1)) =
        (g1.first(), g1.last(), g2.first(), g2.last())
    else {
        return Ok(());
    };
    let (im1, im2) = (&config.ims[s.ims.0], &config.ims[s.ims.1]);
    // The fit is in SI (its coefficients multiply ln of SI values); the axes show `units`.
    let ((u1, d1), (u2, d2)) = (units.show(im1.unit()), units.show(im2.unit()));
    let fitted = fit_title(
        root,
        &format!(
            "{title}: P(overturn | {}, {}) = Φ({} + {} ln {} + {} ln {}), IMs in SI units",
            im1.name(),
            im2.name(),
            short_number(fit.coef[0]),
            short_number(fit.coef[1]),
            im1.name(),
            short_number(fit.coef[2]),
            im2.name()
        ),
    )?;
    let (head, body) = root.split_vertically(fitted.height_px());
    fitted.draw(&head)?;
    let (body_w, body_h) = body.dim_in_pixel();
    let (left, bar) = body.split_horizontally(body_w.saturating_sub(COLOUR_BAR_PX));
    let (plot_area, legend) = left.split_vertically(body_h.saturating_sub(LEGEND_PX));
    draw_colour_bar(&bar, shade, "P(overturn)")?;
    let (x0, x1, y0, y1) = (x0 / d1, x1 / d1, y0 / d2, y1 / d2);
    let mut chart = ChartBuilder::on(&plot_area)
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x0..x1).log_scale().with_key_points(log_ticks(x0, x1)),
            (y0..y1).log_scale().with_key_points(log_ticks(y0, y1)),
        )?;
    chart
        .configure_mesh()
        .x_desc(format!("{} ({u1})", im1.name()))
        .y_desc(format!("{} ({u2})", im2.name()))
        .x_label_formatter(&|x| short_number(*x))
        .y_label_formatter(&|y| short_number(*y))
        .label_style(("sans-serif", 13))
        .draw()?;
    // Cells centred on the grid points, edges at the geometric midpoints.
    let edges = |g: &[f64], d: f64| -> Vec<f64> {
        let mut e = vec![g[0] / d];
        e.extend(g.windows(2).map(|w| (w[0] * w[1]).sqrt() / d));
        e.push(g[g.len() - 1] / d);
        e
    };
    let (e1, e2) = (edges(g1, d1), edges(g2, d2));
    chart.draw_series((0..g1.len()).flat_map(|a| {
        let (e1, e2) = (&e1, &e2);
        (0..g2.len()).map(move |b| {
            Rectangle::new(
                [(e1[a], e2[b]), (e1[a + 1], e2[b + 1])],
                shade(s.p[a][b]).filled(),
            )
        })
    }))?;
    // The observed (record, level) cells: fraction overturned as the fill, on the same scale.
    let shown: Vec<(f64, f64, f64)> = cells
        .iter()
        .map(|c| (c.0 / d1, c.1 / d2, c.2))
        .filter(|c| c.0 >= x0 && c.0 <= x1 && c.1 >= y0 && c.1 <= y1)
        .collect();
    chart.draw_series(
        shown
            .iter()
            .map(|c| Circle::new((c.0, c.1), 4, shade(c.2).filled())),
    )?;
    chart.draw_series(
        shown
            .iter()
            .map(|c| Circle::new((c.0, c.1), 4, BLACK.stroke_width(1))),
    )?;
    let levels = [
        (0.1, RGBColor(0, 158, 115)),
        (0.5, RGBColor(0, 0, 0)),
        (0.9, POINTS),
    ];
    for (level, colour) in levels {
        chart.draw_series(contour(s, level).into_iter().map(|seg| {
            PathElement::new(
                seg.iter().map(|p| (p.0 / d1, p.1 / d2)).collect::<Vec<_>>(),
                colour.stroke_width(2),
            )
        }))?;
    }
    // The legend under the chart, not over it: the surface's every corner is data (the
    // high-probability one is where the 90 % contour runs).
    let text = |label: &str, x: i32| Text::new(label.to_string(), (x, 14), ("sans-serif", 13));
    legend.draw(&Circle::new((30, 20), 4, BLACK.stroke_width(1)))?;
    legend.draw(&text("runs: fraction overturned per record and level", 40))?;
    for (k, (level, colour)) in levels.iter().enumerate() {
        let x = 380 + 110 * k as i32;
        legend.draw(&PathElement::new(
            [(x, 20), (x + 20, 20)],
            colour.stroke_width(2),
        ))?;
        legend.draw(&text(&format!("P = {level}"), x + 26))?;
    }
    root.present()?;
    Ok(())
}

/// Writes `fragility_<IM>.svg/.png` for every fitted IM and `surface_<IM1>_<IM2>.svg/.png`
/// when the surface was fitted; returns the paths.
pub fn write_plots(
    out_dir: &Path,
    title: &str,
    config: &FragilityConfig,
    prepared: &Prepared,
    runs: &[RunResult],
    result: &FragilityResult,
    units: AccelUnits,
) -> Result<Vec<PathBuf>, PlotError> {
    let mut written = Vec::new();
    for (i, f) in result.ims.iter().enumerate() {
        if f.fit.is_err() {
            continue;
        }
        let points = fractions(config, prepared, runs, i, f);
        let stem = out_dir.join(format!("fragility_{}", im_slug(&f.im.name())));
        written.extend(both_formats_curve(&stem, title, f, &points, units)?);
    }
    if let Some(s) = &result.surface {
        if s.fit.is_ok() && !s.p.is_empty() {
            let stem = out_dir.join(format!(
                "surface_{}_{}",
                im_slug(&config.ims[s.ims.0].name()),
                im_slug(&config.ims[s.ims.1].name())
            ));
            let counts = cell_counts(config, prepared.ims.len(), runs);
            let mut cells = Vec::new();
            for (r, row) in counts.iter().enumerate() {
                for (j, c) in row.iter().enumerate() {
                    if c.trials > 0.0 {
                        cells.push((
                            prepared.scaled_im(config, r, j, s.ims.0),
                            prepared.scaled_im(config, r, j, s.ims.1),
                            c.events / c.trials,
                        ));
                    }
                }
            }
            written.extend(both_formats_surface(
                &stem, title, config, s, &cells, units,
            )?);
        }
    }
    Ok(written)
}

fn both_formats_curve(
    stem: &Path,
    title: &str,
    f: &ImFragility,
    points: &[(f64, f64, f64, f64, f64)],
    units: AccelUnits,
) -> Result<Vec<PathBuf>, PlotError> {
    both_formats(
        stem,
        (900, 600),
        |root| draw_curve(root, title, f, points, units),
        |root| draw_curve(root, title, f, points, units),
    )
}

fn both_formats_surface(
    stem: &Path,
    title: &str,
    config: &FragilityConfig,
    s: &Surface,
    cells: &[(f64, f64, f64)],
    units: AccelUnits,
) -> Result<Vec<PathBuf>, PlotError> {
    both_formats(
        stem,
        (900, 700),
        |root| draw_surface(root, title, config, s, cells, units),
        |root| draw_surface(root, title, config, s, cells, units),
    )
}
