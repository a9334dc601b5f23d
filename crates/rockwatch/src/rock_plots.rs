//! Plots of a rock from its mesh (`rockwatch geometry`, SVG or PNG by the file's extension):
//! - the polar plot of α against azimuth: at each azimuth az (clockwise from north, north up),
//!   the angle α = atan(b/h) of a tip towards az, so the curve is the rock's stability rose and
//!   its smallest radius the weakest direction;
//! - the section of the rock in the vertical plane of one direction through its centre of
//!   mass: the mesh's outline, the ground, the contact chord between the two pivots, the pivots,
//!   the centre of mass and the lines from it to the pivots (their angles to the vertical are
//!   α±).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::number_text::short_number;
use crate::plot::{by_extension, fit_title, DrawResult, PlotError};
use rockwatch_core::mesh::contact::DirectionBody;

const CURVE: RGBColor = RGBColor(0, 114, 178);
const MARK: RGBColor = RGBColor(213, 94, 0);
const GRID: RGBColor = RGBColor(200, 200, 200);

/// Size of the polar plot and of the section (pixels; SVG user units).
const POLAR_SIZE: (u32, u32) = (700, 760);
const SECTION_SIZE: (u32, u32) = (800, 760);

/// Writes the polar plot of α against azimuth. `rose` holds the bodies of the azimuths to draw
/// (their `alpha_plus_deg` is the tip towards `azimuth_deg`), in increasing azimuth over the
/// full circle; `weakest` is the azimuth and α (degrees) to mark.
pub fn plot_alpha_rose(
    path: &Path,
    title: &str,
    rose: &[DirectionBody],
    weakest: (f64, f64),
) -> Result<(), PlotError> {
    by_extension(
        path,
        POLAR_SIZE,
        |root| draw_rose(root, title, rose, weakest),
        |root| draw_rose(root, title, rose, weakest),
    )
}

fn draw_rose<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    rose: &[DirectionBody],
    (weakest_az, weakest_alpha): (f64, f64),
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let fitted = fit_title(root, title)?;
    let (head, body) = root.split_vertically(fitted.height_px() + 24);
    fitted.draw(&head)?;
    head.draw(&Text::new(
        format!(
            "α (°) of a tip towards each azimuth; weakest {}° towards {}°",
            short_number(weakest_alpha),
            short_number(weakest_az)
        ),
        (10, fitted.height_px() as i32 + 2),
        ("sans-serif", 13),
    ))?;
    let alpha_max = rose
        .iter()
        .map(|d| d.alpha_plus_deg)
        .fold(0.0_f64, f64::max);
    // Rings every 5°, 10° or 20° up to the largest α.
    let ring = if alpha_max > 60.0 {
        20.0
    } else if alpha_max > 25.0 {
        10.0
    } else {
        5.0
    };
    let outer = (alpha_max / ring).ceil().max(1.0) * ring;
    let lim = outer * 1.15;
    let mut chart = ChartBuilder::on(&body)
        .margin(20)
        .build_cartesian_2d(-lim..lim, -lim..lim)?;
    // x = α sin az (east), y = α cos az (north).
    let at = |az_deg: f64, r: f64| {
        let a = az_deg.to_radians();
        (r * a.sin(), r * a.cos())
    };
    let mut r = ring;
    while r <= outer + 1e-9 {
        chart.draw_series(LineSeries::new(
            (0..=360).map(|k| at(f64::from(k), r)),
            GRID.stroke_width(1),
        ))?;
        chart.draw_series(std::iter::once(Text::new(
            format!("{}°", short_number(r)),
            at(15.0, r),
            ("sans-serif", 11),
        )))?;
        r += ring;
    }
    for k in 0..12 {
        let az = f64::from(k) * 30.0;
        chart.draw_series(LineSeries::new(
            [(0.0, 0.0), at(az, outer)],
            GRID.stroke_width(1),
        ))?;
        let label = match k {
            0 => "N".to_string(),
            3 => "E".to_string(),
            6 => "S".to_string(),
            9 => "W".to_string(),
            _ => format!("{az}°"),
        };
        chart.draw_series(std::iter::once(Text::new(
            label,
            at(az, outer * 1.07),
            ("sans-serif", 12),
        )))?;
    }
    let mut points: Vec<(f64, f64)> = rose
        .iter()
        .map(|d| at(d.azimuth_deg, d.alpha_plus_deg))
        .collect();
    if let Some(&first) = points.first() {
        points.push(first);
    }
    chart.draw_series(LineSeries::new(points, CURVE.stroke_width(2)))?;
    chart.draw_series(std::iter::once(Circle::new(
        at(weakest_az, weakest_alpha),
        5,
        MARK.filled(),
    )))?;
    chart.draw_series(LineSeries::new(
        [(0.0, 0.0), at(weakest_az, weakest_alpha)],
        MARK.stroke_width(2),
    ))?;
    root.present()?;
    Ok(())
}

/// Writes the section of the rock in the direction of `body` (`segments`: the outline from
/// [`rockwatch_core::mesh::contact::RockGeometry::section`], (s, z) in metres: s from the centre
/// of mass along the direction, z above the ground).
pub fn plot_section(
    path: &Path,
    title: &str,
    segments: &[[(f64, f64); 2]],
    body: &DirectionBody,
) -> Result<(), PlotError> {
    by_extension(
        path,
        SECTION_SIZE,
        |root| draw_section(root, title, segments, body),
        |root| draw_section(root, title, segments, body),
    )
}

fn draw_section<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    segments: &[[(f64, f64); 2]],
    body: &DirectionBody,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let fitted = fit_title(root, title)?;
    let (head, area) = root.split_vertically(fitted.height_px() + 24);
    fitted.draw(&head)?;
    head.draw(&Text::new(
        format!(
            "towards {}°: b+ = {} m, b− = {} m, h = {} m, α+ = {}°, α− = {}°",
            short_number(body.azimuth_deg),
            short_number(body.b_plus_m),
            short_number(body.b_minus_m),
            short_number(body.h_m),
            short_number(body.alpha_plus_deg),
            short_number(body.alpha_minus_deg)
        ),
        (10, fitted.height_px() as i32 + 2),
        ("sans-serif", 13),
    ))?;
    // Equal scales on both axes: one span for both, centred on the outline.
    let points = segments.iter().flatten();
    let (mut s_lo, mut s_hi, mut z_hi) = (-body.b_minus_m, body.b_plus_m, body.h_m);
    for &(s, z) in points {
        s_lo = s_lo.min(s);
        s_hi = s_hi.max(s);
        z_hi = z_hi.max(z);
    }
    let span = (s_hi - s_lo).max(z_hi) * 1.15;
    let s_mid = 0.5 * (s_lo + s_hi);
    let mut chart = ChartBuilder::on(&area)
        .margin(16)
        .x_label_area_size(32)
        .y_label_area_size(52)
        .build_cartesian_2d(
            (s_mid - span / 2.0)..(s_mid + span / 2.0),
            (-0.08 * span)..(0.92 * span),
        )?;
    chart
        .configure_mesh()
        .x_desc("along the direction from the centre of mass (m)")
        .y_desc("height above the ground (m)")
        .light_line_style(WHITE)
        .draw()?;
    chart.draw_series(LineSeries::new(
        [(s_mid - span, 0.0), (s_mid + span, 0.0)],
        RGBColor(120, 120, 120).stroke_width(1),
    ))?;
    for seg in segments {
        chart.draw_series(LineSeries::new(seg.iter().copied(), BLACK.stroke_width(1)))?;
    }
    let (minus, plus) = ((-body.b_minus_m, 0.0), (body.b_plus_m, 0.0));
    chart.draw_series(LineSeries::new([minus, plus], MARK.stroke_width(4)))?;
    let com = (0.0, body.h_m);
    for pivot in [minus, plus] {
        chart.draw_series(LineSeries::new([com, pivot], CURVE.stroke_width(1)))?;
        chart.draw_series(std::iter::once(Circle::new(pivot, 5, MARK.filled())))?;
    }
    chart.draw_series(LineSeries::new([com, (0.0, 0.0)], CURVE.stroke_width(1)))?;
    chart.draw_series(std::iter::once(Cross::new(com, 7, CURVE.stroke_width(2))))?;
    chart.draw_series(std::iter::once(Text::new(
        "centre of mass",
        (0.0 + 0.02 * span, body.h_m + 0.02 * span),
        ("sans-serif", 12),
    )))?;
    root.present()?;
    Ok(())
}
