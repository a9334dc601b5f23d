//! Plots of the study, as SVG and PNG: DM against the five best IMs for each block on log–log
//! axes (like the seed's Figures 4 and 5 and the PSDA habit: responding and excluded runs in
//! different colours, the log–log regression line; the zero-response runs, DM below the
//! response floor, in a strip under each axis at their IM) and the fragility curve of overturning with its
//! 95 % band and the observed fractions.
//!
//! PNG text uses the font bundled with the crate ([`crate::plot::ensure_font`]), so the
//! plots render on a machine with no fonts installed.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::report::display_name;
use crate::number_text::short_number;
use crate::plot::{both_formats, draw_legend, fit_title, log_ticks, DrawResult, PlotError};
use crate::units::AccelUnits;
use rockwatch_core::study::fragility::Z_95;
use rockwatch_core::study::{BlockAnalysis, Category, StudyAnalysis, StudyConfig, StudyData};

/// Size of the scatter figure (pixels).
const SCATTER_SIZE: (u32, u32) = (1500, 950);
/// Size of the fragility figure (pixels).
const FRAGILITY_SIZE: (u32, u32) = (900, 600);

/// Marker colour of a category (the seed's colours: blue response, orange none, yellow
/// overturned; other exclusions grey).
fn category_colour(c: Category) -> RGBColor {
    match c {
        Category::Responding => RGBColor(0, 114, 178),
        Category::NoResponse => RGBColor(230, 159, 0),
        Category::Overturned => RGBColor(204, 170, 0),
        _ => RGBColor(150, 150, 150),
    }
}

const FIT_COLOUR: RGBColor = RGBColor(0, 158, 115);

fn legend_entries() -> [(Category, &'static str); 4] {
    [
        (Category::Responding, "response (used)"),
        (Category::NoResponse, "no response (strip below each axis)"),
        (Category::Overturned, "overturned (excluded)"),
        (Category::SlideAbove, "other exclusion"),
    ]
}

fn draw_scatter<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    config: &StudyConfig,
    data: &StudyData,
    block: &BlockAnalysis,
    units: AccelUnits,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let params = &config.blocks[block.block_index].params;
    let title = fit_title(
        root,
        &format!(
            "Block {}: {} vs the five best IMs — R = {} m, α = {}°, μs = {}, μk = {}",
            block.name,
            block.dm.label(),
            short_number(params.plus.half_diagonal_m),
            short_number(params.alpha_rad.to_degrees()),
            short_number(params.mu_s),
            short_number(params.mu_k)
        ),
    )?;
    let (head, body) = root.split_vertically(title.height_px());
    title.draw(&head)?;
    let cells = body.split_evenly((2, 3));
    let dm_of = |i: usize| block.dm.of(&data.responses[i][block.block_index]);
    // Log–log axes: y from the response floor (runs below it, "no response", go to the strip
    // under the axis) to the largest used DM; excluded runs above it sit on the top edge.
    let floor = config.floor(block.dm);
    let y_max = (0..data.cases.len())
        .filter(|&i| block.categories[i].is_used())
        .map(dm_of)
        .filter(|v| v.is_finite())
        .fold(floor, f64::max)
        * 1.3;
    for (cell, score) in cells.iter().zip(block.ranking.iter().take(5)) {
        let j = score.im_index;
        // The IM axis in the unit shown (--units): x / div of the SI value.
        let (unit, div) = units.show(score.unit());
        let im_of = |i: usize| data.cases[i].ims[j] / div;
        let (x_min, x_max) = (0..data.cases.len())
            .map(im_of)
            .filter(|v| v.is_finite() && *v > 0.0)
            .fold((f64::INFINITY, 0.0_f64), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        if !(x_min.is_finite() && x_max > x_min) {
            continue;
        }
        let (x_min, x_max) = (x_min / 1.1, x_max * 1.1);
        let n_nonpositive = data.cases.iter().filter(|c| c.ims[j] <= 0.0).count();
        // The strip of zero-response runs: 16 % of the cell, under the log–log chart.
        let (_, ch) = cell.dim_in_pixel();
        let (main, strip) = cell.split_vertically(ch * 84 / 100);
        let mut chart = ChartBuilder::on(&main)
            .caption(
                format!(
                    "{} — R² = {:.3}, R²(log) = {:.3}",
                    display_name(score.im()),
                    score.r2(),
                    score.r2_log()
                ),
                ("sans-serif", 16),
            )
            .margin(10)
            .margin_bottom(0)
            .x_label_area_size(0)
            .y_label_area_size(60)
            .build_cartesian_2d((x_min..x_max).log_scale(), (floor..y_max).log_scale())?;
        chart
            .configure_mesh()
            .y_desc(block.dm.label())
            .y_label_formatter(&|y| short_number(*y))
            .light_line_style(WHITE)
            .label_style(("sans-serif", 12))
            .draw()?;
        // Draw order: exclusions, then responding (the data of interest on top).
        for pass in [false, true] {
            let points = (0..data.cases.len()).filter_map(|i| {
                let c = block.categories[i];
                if c == Category::NoResponse || (c == Category::Responding) != pass {
                    return None;
                }
                let (x, y) = (im_of(i), dm_of(i));
                if !(x.is_finite() && x > 0.0 && y.is_finite() && y >= floor) {
                    return None;
                }
                Some(Circle::new(
                    (x, y.min(y_max)),
                    2,
                    category_colour(c).mix(0.6).filled(),
                ))
            });
            chart.draw_series(points)?;
        }
        if let Some(fit) = score.log {
            // ln DM = intercept + slope·ln IM over the responding runs.
            // Sampled along x and clipped to the axis (a straight line on log–log axes).
            let line = (0..=100).filter_map(|k| {
                let x = (x_min.ln() + (x_max.ln() - x_min.ln()) * f64::from(k) / 100.0).exp();
                let y = (fit.intercept + fit.slope * (x * div).ln()).exp();
                (y >= floor && y <= y_max).then_some((x, y))
            });
            chart.draw_series(LineSeries::new(line, FIT_COLOUR.stroke_width(2)))?;
        }
        // The strip: runs with DM below the floor (no motion counted) at their IM, spread
        // vertically by a deterministic jitter so that they do not hide each other.
        let n_none = block
            .categories
            .iter()
            .filter(|c| **c == Category::NoResponse)
            .count();
        let mut strip_chart = ChartBuilder::on(&strip)
            .margin(10)
            .margin_top(2)
            .x_label_area_size(35)
            .y_label_area_size(60)
            .build_cartesian_2d((x_min..x_max).log_scale(), 0.0..1.0)?;
        strip_chart
            .configure_mesh()
            .x_labels(8)
            .x_label_formatter(&|x| short_number(*x))
            .disable_y_mesh()
            .disable_y_axis()
            .light_line_style(WHITE)
            .x_desc(format!(
                "{} ({}){}",
                display_name(score.im()),
                unit,
                if n_nonpositive > 0 {
                    format!(" — {n_nonpositive} runs with IM ≤ 0 not shown")
                } else {
                    String::new()
                }
            ))
            .label_style(("sans-serif", 12))
            .draw()?;
        strip_chart.draw_series(std::iter::once(Text::new(
            format!("no response ({n_none})"),
            (x_min, 0.95),
            ("sans-serif", 11),
        )))?;
        strip_chart.draw_series((0..data.cases.len()).filter_map(|i| {
            let x = im_of(i);
            (block.categories[i] == Category::NoResponse && x > 0.0 && x.is_finite()).then(|| {
                let jitter = 0.15 + 0.5 * ((i as f64) * 0.618_033_988_75).fract();
                Circle::new(
                    (x, jitter),
                    2,
                    category_colour(Category::NoResponse).mix(0.6).filled(),
                )
            })
        }))?;
    }
    // Legend in the sixth cell.
    if let Some(cell) = cells.get(5) {
        let c = &block.counts;
        let mut y = 40;
        for (cat, label) in legend_entries() {
            cell.draw(&Circle::new((40, y), 5, category_colour(cat).filled()))?;
            cell.draw(&Text::new(label, (55, y - 8), ("sans-serif", 16)))?;
            y += 28;
        }
        cell.draw(&PathElement::new(
            vec![(30, y), (50, y)],
            FIT_COLOUR.stroke_width(2),
        ))?;
        cell.draw(&Text::new(
            "log–log fit (responding runs)",
            (55, y - 8),
            ("sans-serif", 16),
        ))?;
        y += 40;
        for line in [
            format!("{} pulses", data.cases.len()),
            format!(
                "used {} (responding {}, none {})",
                c.used(),
                c.responding,
                c.no_response
            ),
            format!(
                "excluded {} (overturned {}, other {})",
                c.excluded(),
                c.overturned,
                c.excluded() - c.overturned
            ),
        ] {
            cell.draw(&Text::new(line, (30, y), ("sans-serif", 15)))?;
            y += 24;
        }
    }
    root.present()?;
    Ok(())
}

fn draw_fragility<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    data: &StudyData,
    block: &BlockAnalysis,
    units: AccelUnits,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let Some(curve) = &block.fragility.selected else {
        return Ok(());
    };
    let j = rockwatch_core::ims::STUDY_IMS
        .iter()
        .position(|im| *im == curve.im)
        .unwrap_or(0);
    let values: Vec<(f64, bool)> = (0..data.cases.len())
        .filter(|&i| block.categories[i] != Category::Failed)
        .map(|i| {
            (
                data.cases[i].ims[j],
                data.responses[i][block.block_index].status
                    == rockwatch_core::study::ResponseStatus::Overturned,
            )
        })
        .filter(|(v, _)| *v > 0.0 && v.is_finite())
        .collect();
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), (v, _)| {
            (lo.min(*v), hi.max(*v))
        });
    if !(lo.is_finite() && hi > lo) {
        return Ok(());
    }
    // Computations in SI; the axis and the title in the unit shown (x / div).
    let (unit, div) = units.show(&curve.im_unit);
    let title = fit_title(
        root,
        &format!(
            "Block {}: P(overturn | {}) — median {} {unit}, β = {}",
            block.name,
            display_name(curve.im),
            short_number(curve.median / div),
            short_number(curve.beta)
        ),
    )?;
    let (head, body) = root.split_vertically(title.height_px());
    title.draw(&head)?;
    let mut chart = ChartBuilder::on(&body)
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(
            ((lo / div)..(hi / div))
                .log_scale()
                .with_key_points(log_ticks(lo / div, hi / div)),
            0.0..1.0,
        )?;
    chart
        .configure_mesh()
        .x_desc(format!("{} ({unit})", display_name(curve.im)))
        .x_label_formatter(&|x| short_number(*x))
        .y_desc("probability of overturning")
        .label_style(("sans-serif", 13))
        .draw()?;
    let n = 120;
    let grid: Vec<f64> = (0..n)
        .map(|k| (lo.ln() + (hi.ln() - lo.ln()) * k as f64 / (n - 1) as f64).exp())
        .collect();
    let mut band: Vec<(f64, f64)> = grid
        .iter()
        .map(|&x| (x / div, curve.band(x, Z_95).1))
        .collect();
    band.extend(grid.iter().rev().map(|&x| (x / div, curve.band(x, Z_95).0)));
    chart
        .draw_series(std::iter::once(Polygon::new(
            band,
            RGBColor(0, 114, 178).mix(0.2).filled(),
        )))?
        .label("95 % band (delta method)")
        .legend(|(x, y)| {
            Rectangle::new(
                [(x, y - 5), (x + 20, y + 5)],
                RGBColor(0, 114, 178).mix(0.2).filled(),
            )
        });
    chart
        .draw_series(LineSeries::new(
            grid.iter().map(|&x| (x / div, curve.probability(x))),
            RGBColor(0, 114, 178).stroke_width(2),
        ))?
        .label("lognormal MLE")
        .legend(|(x, y)| {
            PathElement::new(
                vec![(x, y), (x + 20, y)],
                RGBColor(0, 114, 178).stroke_width(2),
            )
        });
    // Observed fractions in 12 log-spaced bins.
    let bins = 12;
    let width = (hi.ln() - lo.ln()) / bins as f64;
    let mut counts = vec![(0usize, 0usize); bins];
    for (v, e) in &values {
        let k = (((v.ln() - lo.ln()) / width) as usize).min(bins - 1);
        counts[k].0 += 1;
        counts[k].1 += usize::from(*e);
    }
    chart
        .draw_series(
            counts
                .iter()
                .enumerate()
                .filter(|(_, c)| c.0 > 0)
                .map(|(k, c)| {
                    let x = (lo.ln() + (k as f64 + 0.5) * width).exp();
                    Circle::new(
                        (x / div, c.1 as f64 / c.0 as f64),
                        4,
                        RGBColor(213, 94, 0).filled(),
                    )
                }),
        )?
        .label("observed fraction (binned)")
        .legend(|(x, y)| Circle::new((x + 10, y), 4, RGBColor(213, 94, 0).filled()));
    draw_legend(&mut chart, Some(SeriesLabelPosition::UpperLeft), 14)?;
    root.present()?;
    Ok(())
}

/// Writes `scatter_<block>.svg/.png` for every block and `fragility_<block>.svg/.png` for
/// every block with a fragility curve; returns the paths.
pub fn write_plots(
    out_dir: &Path,
    config: &StudyConfig,
    data: &StudyData,
    analysis: &StudyAnalysis,
    units: AccelUnits,
) -> Result<Vec<PathBuf>, PlotError> {
    std::fs::create_dir_all(out_dir).map_err(|e| PlotError::new(out_dir, &e))?;
    let mut written = Vec::new();
    for block in &analysis.blocks {
        let stem = out_dir.join(format!("scatter_{}", block.name));
        written.extend(both_formats(
            &stem,
            SCATTER_SIZE,
            |root| draw_scatter(root, config, data, block, units),
            |root| draw_scatter(root, config, data, block, units),
        )?);
        if block.fragility.selected.is_some() {
            let stem = out_dir.join(format!("fragility_{}", block.name));
            written.extend(both_formats(
                &stem,
                FRAGILITY_SIZE,
                |root| draw_fragility(root, data, block, units),
                |root| draw_fragility(root, data, block, units),
            )?);
        }
    }
    Ok(written)
}
