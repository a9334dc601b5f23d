//! One IM from the two horizontal components of a record, in the definitions of the
//! ground-motion models that hazard curves are computed with (Boore 2010, BSSA 100(4)):
//!
//! - **RotD50**: the two components `x(t)`, `y(t)` (orthogonal, same instants) rotated by
//!   θ = 0°, 1°, …, 179°: `r_θ(t) = x(t)·cos θ + y(t)·sin θ`; the peak `max_t |r_θ(t)|` of each
//!   of the 180 rotated components; RotD50 is their median (the mean of the 90th and 91st
//!   sorted values), RotD100 their largest. Independent of the sensor's orientation.
//! - **GM** (geometric mean of the as-recorded components, GMRotI50's predecessor):
//!   `sqrt(max|x| · max|y|)`: depends on the orientation.
//! - **component**: one component as recorded, `max|x|`.
//!
//! For a response quantity (velocity, displacement, an oscillator's relative displacement)
//! the rotation applies to its time series: the quantities are linear in the record, so the
//! velocity of a rotated record is the rotated velocities. SA(T) = ω²·(the definition applied
//! to the oscillator's relative displacement u(t)), ω = 2π/T. Units: those of the series.
//!
//! Closed forms (checked in the tests): for `x = A cos ωt`, `y = B sin ωt` (an ellipse,
//! A ≥ B) the rotated peak is `sqrt(A²cos²θ + B²sin²θ)`, so RotD100 = A and RotD50 =
//! `sqrt((A² + B²)/2)` (θ = 45° and 135° are the middle values): A for a circular motion,
//! A/√2 for a unidirectional one; GM = `sqrt(A·B)`.

use super::spectrum::NigamJennings;
use super::ImError;

/// Rotation angles of RotD: 0° to 179° in steps of 1° (Boore 2010).
pub const ROTATION_ANGLES: usize = 180;

/// How the two horizontal components of a record make one IM.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HorizontalDefinition {
    /// One component as recorded (the rock sees it along an incidence azimuth).
    #[default]
    Component,
    /// Median over rotation angles of the rotated component's peak (Boore 2010): the
    /// component of the NGA-West2 models and most OpenQuake GMPEs of active regions.
    RotD50,
    /// Largest peak over rotation angles.
    RotD100,
    /// Geometric mean of the two as-recorded peaks.
    GeoMean,
}

impl HorizontalDefinition {
    /// Name in outputs: `component`, `RotD50`, `RotD100`, `GM`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            HorizontalDefinition::Component => "component",
            HorizontalDefinition::RotD50 => "RotD50",
            HorizontalDefinition::RotD100 => "RotD100",
            HorizontalDefinition::GeoMean => "GM",
        }
    }

    /// Parses a name, case-insensitively (`component`, `rotd50`, `rotd100`, `gm`,
    /// `geomean`).
    #[must_use]
    pub fn parse(text: &str) -> Option<HorizontalDefinition> {
        match text.trim().to_ascii_lowercase().as_str() {
            "component" | "as-recorded" => Some(HorizontalDefinition::Component),
            "rotd50" => Some(HorizontalDefinition::RotD50),
            "rotd100" => Some(HorizontalDefinition::RotD100),
            "gm" | "geomean" | "geometric-mean" => Some(HorizontalDefinition::GeoMean),
            _ => None,
        }
    }

    /// The IM of the series `x`, `y` (two orthogonal horizontal components of one quantity,
    /// same instants; any unit) in this definition. `Component` uses `x` only.
    #[must_use]
    pub fn combine(self, x: &[f64], y: &[f64]) -> f64 {
        match self {
            HorizontalDefinition::Component => peak(x),
            HorizontalDefinition::GeoMean => (peak(x) * peak(y)).sqrt(),
            HorizontalDefinition::RotD100 => rotated_peaks(x, y).into_iter().fold(0.0, f64::max),
            HorizontalDefinition::RotD50 => {
                let mut peaks = rotated_peaks(x, y);
                peaks.sort_by(f64::total_cmp);
                let mid = ROTATION_ANGLES / 2;
                0.5 * (peaks[mid - 1] + peaks[mid])
            }
        }
    }
}

/// `max |s_i|` (0 for an empty series).
fn peak(s: &[f64]) -> f64 {
    s.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

/// The peaks `max_t |x cos θ + y sin θ|` for θ = 0°, 1°, …, 179° (the shorter series bounds
/// the instants).
#[must_use]
pub fn rotated_peaks(x: &[f64], y: &[f64]) -> Vec<f64> {
    (0..ROTATION_ANGLES)
        .map(|k| {
            let (s, c) = (k as f64).to_radians().sin_cos();
            x.iter()
                .zip(y)
                .fold(0.0_f64, |m, (a, b)| m.max((a * c + b * s).abs()))
        })
        .collect()
}

/// Velocity (m/s) and displacement (m) of the acceleration `accel_mps2` (m/s², every `dt_s`
/// s): cumulative trapezoids from 0, as [`super::offline::velocity_displacement_peaks`].
#[must_use]
pub fn velocity_displacement(accel_mps2: &[f64], dt_s: f64) -> (Vec<f64>, Vec<f64>) {
    let mut v = Vec::with_capacity(accel_mps2.len());
    let mut d = Vec::with_capacity(accel_mps2.len());
    let (mut vi, mut di) = (0.0_f64, 0.0_f64);
    v.push(vi);
    d.push(di);
    for w in accel_mps2.windows(2) {
        let v_next = vi + 0.5 * dt_s * (w[0] + w[1]);
        di += 0.5 * dt_s * (vi + v_next);
        vi = v_next;
        v.push(vi);
        d.push(di);
    }
    (v, d)
}

/// Relative displacement u(t) (m) of the oscillator of period `period_s` (s) and damping
/// ratio `damping` under `accel_mps2` (the exact piecewise-linear solution of
/// [`NigamJennings`], at rest at the start): its peak times ω² is SA(T).
pub fn oscillator_displacement(
    accel_mps2: &[f64],
    dt_s: f64,
    period_s: f64,
    damping: f64,
) -> Result<Vec<f64>, ImError> {
    let nj = NigamJennings::new(period_s, damping, dt_s)?;
    let mut u = Vec::with_capacity(accel_mps2.len());
    let (mut ui, mut vi) = (0.0_f64, 0.0_f64);
    u.push(ui);
    for w in accel_mps2.windows(2) {
        (ui, vi) = nj.step(ui, vi, w[0], w[1]);
        u.push(ui);
    }
    Ok(u)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ims::{compute_ims, response, ImOptions, DEFAULT_DAMPING};

    /// `x = A cos ωt`, `y = B sin ωt` over whole periods, 2000 samples a period.
    fn ellipse(a: f64, b: f64) -> (Vec<f64>, Vec<f64>) {
        let n = 4000;
        let w = 2.0 * std::f64::consts::PI / 2000.0;
        (
            (0..n).map(|i| a * (w * i as f64).cos()).collect(),
            (0..n).map(|i| b * (w * i as f64).sin()).collect(),
        )
    }

    fn close(got: f64, want: f64) {
        assert!(
            (got - want).abs() <= 1e-5 * want.abs(),
            "{got} vs {want} (closed form)"
        );
    }

    #[test]
    fn rotd_and_gm_of_elliptical_motions_match_their_closed_forms() {
        for (a, b) in [(3.0, 3.0), (2.0, 0.0), (4.0, 1.5), (1.0, 2.5)] {
            let (x, y) = ellipse(a, b);
            close(
                HorizontalDefinition::RotD50.combine(&x, &y),
                ((a * a + b * b) / 2.0_f64).sqrt(),
            );
            close(
                HorizontalDefinition::RotD100.combine(&x, &y),
                f64::max(a, b),
            );
            close(
                HorizontalDefinition::GeoMean.combine(&x, &y),
                (a * b).sqrt(),
            );
            close(HorizontalDefinition::Component.combine(&x, &y), a);
        }
        // Unidirectional: A·cos 45° = A/√2; circular: the amplitude.
        let (x, y) = ellipse(2.0, 0.0);
        close(
            HorizontalDefinition::RotD50.combine(&x, &y),
            2.0 * std::f64::consts::FRAC_1_SQRT_2,
        );
    }

    #[test]
    fn rotd50_does_not_depend_on_the_sensor_orientation_but_gm_does() {
        // A motion that is neither circular nor along an axis, turned by 30°: RotD50 (an
        // integer number of the 1° steps) is the same; GM changes.
        let n = 3000;
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 * 0.01;
                (-0.2 * t).exp() * (2.1 * t).sin() + 0.3 * (7.3 * t).cos()
            })
            .collect();
        let y: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 * 0.01;
                0.6 * (-0.1 * t).exp() * (3.7 * t + 0.4).sin()
            })
            .collect();
        let (s, c) = 30f64.to_radians().sin_cos();
        let xr: Vec<f64> = x.iter().zip(&y).map(|(a, b)| a * c + b * s).collect();
        let yr: Vec<f64> = x.iter().zip(&y).map(|(a, b)| -a * s + b * c).collect();
        let d = HorizontalDefinition::RotD50;
        let (before, after) = (d.combine(&x, &y), d.combine(&xr, &yr));
        assert!((before - after).abs() < 1e-12 * before, "{before} {after}");
        let g = HorizontalDefinition::GeoMean;
        assert!((g.combine(&x, &y) - g.combine(&xr, &yr)).abs() > 1e-3);
    }

    #[test]
    fn response_series_rotate_with_the_record() {
        // A unidirectional record along x: every rotated response is |cos θ| times the
        // component's, so RotD50 of PGV and of SA(T) is the one-component value (computed by
        // compute_ims and spectrum::response, not from these series) times cos 45°.
        let dt = 0.01;
        let x: Vec<f64> = (0..1500)
            .map(|i| {
                let t = i as f64 * dt;
                3.0 * (-0.3 * t).exp() * (5.0 * t).sin() * (1.0 - (-t).exp())
            })
            .collect();
        let zero = vec![0.0; x.len()];
        let one = compute_ims(&x, dt, &ImOptions::default()).unwrap();
        let (v, _) = velocity_displacement(&x, dt);
        let (v0, _) = velocity_displacement(&zero, dt);
        let d = HorizontalDefinition::RotD50;
        let r = std::f64::consts::FRAC_1_SQRT_2;
        close(d.combine(&v, &v0), one.pgv_mps * r);
        let period = 0.7;
        let u = oscillator_displacement(&x, dt, period, DEFAULT_DAMPING).unwrap();
        let w = 2.0 * std::f64::consts::PI / period;
        let sa = response(&x, dt, period, DEFAULT_DAMPING).unwrap().sa_mps2;
        close(w * w * d.combine(&u, &zero), sa * r);
    }
}
