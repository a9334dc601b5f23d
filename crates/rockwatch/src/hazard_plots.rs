//! Plots of `rockwatch hazard` (docs/hazard.md), each as SVG and PNG through
//! [`crate::plot::both_formats`]:
//! - `hazard_curves`: the hazard curve(s) λ_H(im) on log–log axes, the band between the
//!   fractile curves shaded, over the fragility P(overturn | im) with its pointwise 95 %
//!   bootstrap band (the two factors of λ = ∫ P |dλ_H|);
//! - `hazard_deaggregation`: the contribution to λ by IM level, dλ/d(ln im) = P·k·λ_H (the
//!   integrand; its area over ln im is λ), the continuations beyond the curve's levels shaded;
//! - `hazard_survival`: P(survival) = exp(−λt) against the age t with the band of λ's interval,
//!   each exposure age T ± σ marked with its E_T[exp(−λT)] and interval.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::number_text::short_number;
use crate::plot::{
    both_formats, draw_band, draw_legend, fit_title, log_ticks, DrawResult, PlotError,
};
use rockwatch_core::fragility::percentile_interval;
use rockwatch_core::hazard::{rate_density, ExposureAge, HazardCurve, Lognormal, OverturnRate};

const CENTRAL: RGBColor = RGBColor(0, 114, 178);
const FRACTILE: RGBColor = RGBColor(86, 180, 233);
const FRAGILITY: RGBColor = RGBColor(213, 94, 0);
const MARK: RGBColor = RGBColor(0, 158, 115);

/// Size of each figure (pixels; SVG user units).
const SIZE: (u32, u32) = (1000, 760);
/// Points of each drawn curve.
const GRID_POINTS: usize = 200;

/// What the hazard plots show. Every IM value is in the fragility's unit; `to_shown`
/// converts it to the axes' `unit`.
#[derive(Debug, Clone)]
pub struct HazardFigures<'a> {
    /// Title prefix (the fragility file and its IM).
    pub title: String,
    /// The IM's name.
    pub im: String,
    /// Unit of the IM axes, and the factor from the fragility's unit to it.
    pub unit: String,
    pub to_shown: f64,
    /// The hazard curves (in the fragility's unit), each with its label and whether λ comes
    /// from it (the central curve).
    pub curves: Vec<(&'a HazardCurve, String, bool)>,
    /// Whether the non-central curves are fractiles whose envelope is shaded.
    pub fractile_band: bool,
    /// The fitted fragility and its bootstrap replicates (may be empty).
    pub fragility: Lognormal,
    pub replicates: &'a [Lognormal],
    /// λ of the central curve and the fitted fragility, and λ's 95 % interval (1/yr).
    pub rate: &'a OverturnRate,
    pub rate_interval: Option<[f64; 2]>,
    /// Each exposure age with its P(survival) and that probability's interval.
    pub ages: Vec<(ExposureAge, f64, Option<[f64; 2]>)>,
}

impl HazardFigures<'_> {
    /// The central curve.
    fn central(&self) -> Option<&HazardCurve> {
        self.curves.iter().find(|c| c.2).map(|c| c.0)
    }

    /// IM range of the plots (fragility unit): the curves' levels and the fragility's median
    /// ± 4β (where P is 3e-5 from 0 or 1).
    fn im_range(&self) -> (f64, f64) {
        let (m, b) = (self.fragility.median, self.fragility.beta);
        self.curves.iter().fold(
            (m * (-4.0 * b).exp(), m * (4.0 * b).exp()),
            |(lo, hi), (c, _, _)| (lo.min(c.levels[0]), hi.max(c.levels[c.levels.len() - 1])),
        )
    }
}

/// `n` log-spaced values from `lo` to `hi`.
fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| (lo.ln() + (hi / lo).ln() * k as f64 / (n - 1) as f64).exp())
        .collect()
}

/// Writes the three figures into `dir` (`hazard_curves`, `hazard_deaggregation`,
/// `hazard_survival`, each `.svg` and `.png`); returns the paths written.
pub fn write_hazard_plots(dir: &Path, f: &HazardFigures) -> Result<Vec<PathBuf>, PlotError> {
    let mut written = both_formats(
        &dir.join("hazard_curves"),
        SIZE,
        |root| draw_curves(root, f),
        |root| draw_curves(root, f),
    )?;
    written.extend(both_formats(
        &dir.join("hazard_deaggregation"),
        SIZE,
        |root| draw_deaggregation(root, f),
        |root| draw_deaggregation(root, f),
    )?);
    written.extend(both_formats(
        &dir.join("hazard_survival"),
        SIZE,
        |root| draw_survival(root, f),
        |root| draw_survival(root, f),
    )?);
    Ok(written)
}

/// The legend box of every panel.
fn draw_curves<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, f: &HazardFigures) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let fitted = fit_title(
        root,
        &format!(
            "{}: hazard curve{} × fragility, λ = {} per year",
            f.title,
            if f.curves.len() > 1 { "s" } else { "" },
            short_number(f.rate.annual_rate)
        ),
    )?;
    let (head, body) = root.split_vertically(fitted.height_px());
    fitted.draw(&head)?;
    let (top, bottom) = body.split_vertically(body.dim_in_pixel().1 * 11 / 20);
    let s = f.to_shown;
    let (lo, hi) = f.im_range();
    let grid = log_grid(lo, hi, GRID_POINTS);
    let (x_lo, x_hi) = (lo * s, hi * s);
    // Hazard panel: every curve over the whole range (its power-law continuation beyond its
    // levels), its levels as points.
    let (mut y_lo, mut y_hi) = (f64::INFINITY, 0.0_f64);
    for (c, _, _) in &f.curves {
        for &x in &grid {
            let r = c.rate(x);
            if r.is_finite() && r > 0.0 {
                y_lo = y_lo.min(r);
                y_hi = y_hi.max(r);
            }
        }
    }
    if !(y_lo > 0.0 && y_hi > y_lo) {
        return Ok(());
    }
    let mut chart = ChartBuilder::on(&top)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x_lo..x_hi)
                .log_scale()
                .with_key_points(log_ticks(x_lo, x_hi)),
            (y_lo..y_hi)
                .log_scale()
                .with_key_points(log_ticks(y_lo, y_hi)),
        )?;
    chart
        .configure_mesh()
        .x_desc(format!("{} ({})", f.im, f.unit))
        .x_label_formatter(&|x| short_number(*x))
        .y_label_formatter(&|y| short_number(*y))
        .y_desc("annual rate of exceedance (1/yr)")
        .label_style(("sans-serif", 13))
        .draw()?;
    let others: Vec<&HazardCurve> = f.curves.iter().filter(|c| !c.2).map(|c| c.0).collect();
    if f.fractile_band && others.len() > 1 {
        let envelope = |x: f64, pick: fn(f64, f64) -> f64| {
            others.iter().map(|c| c.rate(x)).reduce(pick).unwrap_or(0.0)
        };
        let mut band: Vec<(f64, f64)> = grid
            .iter()
            .map(|&x| (x * s, envelope(x, f64::max)))
            .collect();
        band.extend(grid.iter().rev().map(|&x| (x * s, envelope(x, f64::min))));
        draw_band(
            &mut chart,
            band,
            FRACTILE.mix(0.25).filled(),
            "between the fractile curves",
        )?;
    }
    for (c, label, central) in &f.curves {
        let (colour, width) = curve_style(*central);
        chart
            .draw_series(LineSeries::new(
                grid.iter().map(|&x| (x * s, c.rate(x))),
                colour.stroke_width(width),
            ))?
            .label(if *central {
                format!("{label} (λ from it)")
            } else {
                label.clone()
            })
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(width))
            });
        chart.draw_series(
            c.levels
                .iter()
                .zip(&c.annual_rates)
                .filter(|(&x, _)| x >= lo && x <= hi)
                .map(|(&x, &r)| Circle::new((x * s, r), 2, colour.filled())),
        )?;
    }
    draw_legend(&mut chart, Some(SeriesLabelPosition::UpperRight), 13)?;
    // Fragility panel.
    let mut chart = ChartBuilder::on(&bottom)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x_lo..x_hi)
                .log_scale()
                .with_key_points(log_ticks(x_lo, x_hi)),
            0.0..1.0,
        )?;
    chart
        .configure_mesh()
        .x_desc(format!("{} ({})", f.im, f.unit))
        .x_label_formatter(&|x| short_number(*x))
        .y_desc("P(overturn | IM)")
        .label_style(("sans-serif", 13))
        .draw()?;
    if !f.replicates.is_empty() {
        let band_at = |x: f64| {
            let p: Vec<f64> = f.replicates.iter().map(|r| r.probability(x)).collect();
            percentile_interval(&p).unwrap_or([0.0, 0.0])
        };
        let bands: Vec<[f64; 2]> = grid.iter().map(|&x| band_at(x)).collect();
        let mut band: Vec<(f64, f64)> = grid
            .iter()
            .zip(&bands)
            .map(|(&x, b)| (x * s, b[1]))
            .collect();
        band.extend(grid.iter().zip(&bands).rev().map(|(&x, b)| (x * s, b[0])));
        draw_band(
            &mut chart,
            band,
            FRAGILITY.mix(0.2).filled(),
            format!("95 % bootstrap band ({} replicates)", f.replicates.len()),
        )?;
    }
    chart
        .draw_series(LineSeries::new(
            grid.iter().map(|&x| (x * s, f.fragility.probability(x))),
            FRAGILITY.stroke_width(2),
        ))?
        .label(format!(
            "fragility: median {} {}, β = {}",
            short_number(f.fragility.median * s),
            f.unit,
            short_number(f.fragility.beta)
        ))
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], FRAGILITY.stroke_width(2)));
    draw_legend(&mut chart, Some(SeriesLabelPosition::UpperLeft), 13)?;
    root.present()?;
    Ok(())
}

fn draw_deaggregation<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    f: &HazardFigures,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let Some(central) = f.central() else {
        return Ok(());
    };
    let fitted = fit_title(
        root,
        &format!(
            "{}: contribution to λ by {} level, dλ/d(ln {}) — λ = {} per year, {:.1} % from \
             beyond the curve's levels",
            f.title,
            f.im,
            f.im,
            short_number(f.rate.annual_rate),
            100.0 * f.rate.extrapolated_fraction
        ),
    )?;
    let (head, body) = root.split_vertically(fitted.height_px());
    fitted.draw(&head)?;
    let s = f.to_shown;
    let (lo, hi) = f.im_range();
    let grid = log_grid(lo, hi, 2 * GRID_POINTS);
    let density = |c: &HazardCurve, x: f64| rate_density(c, &f.fragility, x);
    let y_hi = f
        .curves
        .iter()
        .flat_map(|(c, _, _)| grid.iter().map(|&x| density(c, x)))
        .fold(0.0_f64, f64::max);
    if !(y_hi > 0.0 && y_hi.is_finite()) {
        return Ok(());
    }
    let (x_lo, x_hi) = (lo * s, hi * s);
    let mut chart = ChartBuilder::on(&body)
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(
            (x_lo..x_hi)
                .log_scale()
                .with_key_points(log_ticks(x_lo, x_hi)),
            0.0..1.05 * y_hi,
        )?;
    chart
        .configure_mesh()
        .x_desc(format!("{} ({})", f.im, f.unit))
        .x_label_formatter(&|x| short_number(*x))
        .y_label_formatter(&|y| short_number(*y))
        .y_desc(format!("dλ/d(ln {}) (1/yr)", f.im))
        .label_style(("sans-serif", 13))
        .draw()?;
    // The continuations beyond the central curve's levels.
    let (first, last) = (central.levels[0], central.levels[central.levels.len() - 1]);
    let beyond = RGBColor(150, 150, 150).mix(0.2);
    let mut shaded = false;
    for (a, b) in [(lo, first), (last, hi)] {
        if b > a {
            let drawn = chart.draw_series(std::iter::once(Rectangle::new(
                [(a * s, 0.0), (b * s, 1.05 * y_hi)],
                beyond.filled(),
            )))?;
            if !shaded {
                drawn
                    .label("beyond the curve's levels (power-law continuation)")
                    .legend(move |(x, y)| {
                        Rectangle::new([(x, y - 5), (x + 20, y + 5)], beyond.filled())
                    });
                shaded = true;
            }
        }
    }
    let mut area: Vec<(f64, f64)> = vec![(x_lo, 0.0)];
    area.extend(grid.iter().map(|&x| (x * s, density(central, x))));
    area.push((x_hi, 0.0));
    chart.draw_series(std::iter::once(Polygon::new(
        area,
        CENTRAL.mix(0.2).filled(),
    )))?;
    for (c, label, is_central) in &f.curves {
        let (colour, width) = curve_style(*is_central);
        chart
            .draw_series(LineSeries::new(
                grid.iter().map(|&x| (x * s, density(c, x))),
                colour.stroke_width(width),
            ))?
            .label(label.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(width))
            });
    }
    // The central curve's levels as ticks along the axis.
    chart.draw_series(
        central
            .levels
            .iter()
            .filter(|&&x| x >= lo && x <= hi)
            .map(|&x| {
                PathElement::new(
                    vec![(x * s, 0.0), (x * s, 0.03 * y_hi)],
                    BLACK.stroke_width(1),
                )
            }),
    )?;
    draw_legend(&mut chart, Some(SeriesLabelPosition::UpperRight), 13)?;
    root.present()?;
    Ok(())
}

fn draw_survival<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, f: &HazardFigures) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let lambda = f.rate.annual_rate;
    let fitted = fit_title(
        root,
        &format!(
            "{}: P(survival) against exposure age, λ = {} per year{}",
            f.title,
            short_number(lambda),
            f.rate_interval.map_or(String::new(), |[a, b]| format!(
                " (95 %: {} to {})",
                short_number(a),
                short_number(b)
            ))
        ),
    )?;
    let (head, body) = root.split_vertically(fitted.height_px());
    fitted.draw(&head)?;
    let t_max = f
        .ages
        .iter()
        .map(|(a, _, _)| a.mean_years + 3.0 * a.sigma_years)
        .fold(0.0_f64, f64::max)
        * 1.5;
    let t_max = if t_max > 0.0 {
        t_max
    } else {
        3.0 / lambda.max(1e-300)
    };
    let mut chart = ChartBuilder::on(&body)
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_max, 0.0..1.0)?;
    chart
        .configure_mesh()
        .x_desc("exposure age (years)")
        .x_label_formatter(&|x| short_number(*x))
        .y_desc("P(survival)")
        .label_style(("sans-serif", 13))
        .draw()?;
    let ages: Vec<f64> = (0..GRID_POINTS)
        .map(|k| t_max * k as f64 / (GRID_POINTS - 1) as f64)
        .collect();
    let mut labelled = false;
    for (age, _, _) in &f.ages {
        if age.sigma_years > 0.0 {
            let (a, b) = (
                (age.mean_years - age.sigma_years).max(0.0),
                age.mean_years + age.sigma_years,
            );
            let drawn = chart.draw_series(std::iter::once(Rectangle::new(
                [(a, 0.0), (b, 1.0)],
                MARK.mix(0.12).filled(),
            )))?;
            if !labelled {
                drawn.label("T ± σ").legend(|(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 20, y + 5)], MARK.mix(0.12).filled())
                });
                labelled = true;
            }
        }
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(age.mean_years, 0.0), (age.mean_years, 1.0)],
            MARK.stroke_width(1),
        )))?;
    }
    if let Some([lo, hi]) = f.rate_interval {
        let mut band: Vec<(f64, f64)> = ages.iter().map(|&t| (t, (-lo * t).exp())).collect();
        band.extend(ages.iter().rev().map(|&t| (t, (-hi * t).exp())));
        draw_band(
            &mut chart,
            band,
            CENTRAL.mix(0.2).filled(),
            "95 % interval of λ",
        )?;
    }
    chart
        .draw_series(LineSeries::new(
            ages.iter().map(|&t| (t, (-lambda * t).exp())),
            CENTRAL.stroke_width(2),
        ))?
        .label("exp(−λt)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], CENTRAL.stroke_width(2)));
    for (age, _, range) in &f.ages {
        if let Some([a, b]) = range {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(age.mean_years, *a), (age.mean_years, *b)],
                MARK.stroke_width(2),
            )))?;
        }
    }
    chart
        .draw_series(
            f.ages
                .iter()
                .map(|(age, p, _)| Circle::new((age.mean_years, *p), 5, MARK.filled())),
        )?
        .label("E_T[exp(−λT)] at each age, its 95 % interval")
        .legend(|(x, y)| Circle::new((x + 10, y), 4, MARK.filled()));
    draw_legend(&mut chart, Some(SeriesLabelPosition::UpperRight), 13)?;
    root.present()?;
    Ok(())
}

/// The colour and width of a hazard curve: the curve λ comes from stands out, the fractiles do
/// not.
fn curve_style(central: bool) -> (RGBColor, u32) {
    if central {
        (CENTRAL, 2)
    } else {
        (FRACTILE, 1)
    }
}
