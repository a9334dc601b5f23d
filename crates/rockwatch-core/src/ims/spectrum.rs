//! Elastic response spectra of a linear single-degree-of-freedom (SDOF) oscillator and the
//! spectral intensities ASI, SI and VSI.
//!
//! The oscillator is `ü + 2ξωu̇ + ω²u = −a(t)` with `u(0) = u̇(0) = 0`, where `u` is the
//! displacement relative to the ground (m, same sign convention as the ground acceleration
//! `a`, m/s²), `ω = 2π/T` and `ξ` the damping ratio (5 % unless stated). Between samples
//! `a(t)` is the straight line joining them (first-order hold), and the state is advanced by
//! the exact Nigam–Jennings (1969) recursion for that input: no time-stepping error, only
//! rounding.
//!
//! From one solution: `Sd = max_k |u(t_k)|` and `SV = max_k |u̇(t_k)|` over the input instants
//! (SV is the true relative-velocity peak, not PSV), `PSV = ω·Sd` (m/s) and
//! `SA = ω²·Sd` (pseudo-spectral acceleration, m/s²).
//!
//! Period integrals use a grid of exact multiples of 0.01 s (periods are stored as integer
//! hundredths of a second, "centiseconds", and converted as `k as f64 / 100.0`, which is the
//! same `f64` as the decimal literal `0.kk`), and the trapezoidal rule over the grid points
//! inside the closed period range.

use super::ImError;

/// Default damping ratio of the response spectra (5 % of critical).
pub const DEFAULT_DAMPING: f64 = 0.05;

/// First period of the standard grid, in hundredths of a second (0.10 s).
pub const GRID_FIRST_CENTI: u32 = 10;
/// Last period of the standard grid, in hundredths of a second (3.00 s).
pub const GRID_LAST_CENTI: u32 = 300;

/// Converts a period in hundredths of a second to seconds (`k / 100`, correctly rounded, so
/// `centi_to_s(30) == 0.3`).
#[must_use]
pub fn centi_to_s(centi: u32) -> f64 {
    f64::from(centi) / 100.0
}

/// Periods (s) of the grid `0.10, 0.10 + step, …` up to 3.00 s inclusive; `step_centi` is the
/// step in hundredths of a second (1 → the standard 0.01 s grid of 291 periods).
#[must_use]
pub fn period_grid_s(step_centi: u32) -> Vec<f64> {
    let step = step_centi.max(1) as usize;
    (GRID_FIRST_CENTI..=GRID_LAST_CENTI)
        .step_by(step)
        .map(centi_to_s)
        .collect()
}

/// A closed period range `[from, to]` for the spectral intensities, in hundredths of a second.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PeriodRange {
    /// Lower end (hundredths of a second).
    pub from_centi: u32,
    /// Upper end (hundredths of a second), ≥ `from_centi`.
    pub to_centi: u32,
}

impl PeriodRange {
    /// The range `[from_centi/100, to_centi/100]` s.
    #[must_use]
    pub const fn new(from_centi: u32, to_centi: u32) -> Self {
        PeriodRange {
            from_centi,
            to_centi,
        }
    }

    /// Lower end (s).
    #[must_use]
    pub fn from_s(&self) -> f64 {
        centi_to_s(self.from_centi)
    }

    /// Upper end (s).
    #[must_use]
    pub fn to_s(&self) -> f64 {
        centi_to_s(self.to_centi)
    }

    /// True when `period_s` lies in the closed range (exact for grid periods).
    #[must_use]
    pub fn contains(&self, period_s: f64) -> bool {
        period_s >= self.from_s() && period_s <= self.to_s()
    }

    /// Label such as `"0.1-0.5"` or `"1.0-2.5"` (seconds, at least one decimal).
    #[must_use]
    pub fn label(&self) -> String {
        format!(
            "{}-{}",
            format_period_s(self.from_s()),
            format_period_s(self.to_s())
        )
    }

    /// Parses `"T1-T2"` (seconds, e.g. `"0.1-0.5"`); both ends must be multiples of 0.01 s
    /// inside 0.01..=100 s, with `T1 ≤ T2`.
    pub fn parse(text: &str) -> Result<Self, ImError> {
        let bad = |why: &str| ImError::BadRange(format!("{text:?}: {why}"));
        let (a, b) = text
            .split_once('-')
            .ok_or_else(|| bad("expected T1-T2 in seconds, e.g. 0.1-0.5"))?;
        let to_centi = |s: &str| -> Result<u32, ImError> {
            let value: f64 = s
                .trim()
                .parse()
                .map_err(|_| bad("an end is not a number"))?;
            let centi = (value * 100.0).round();
            if !(1.0..=10_000.0).contains(&centi) || (value * 100.0 - centi).abs() > 1e-6 {
                return Err(bad(
                    "ends must be multiples of 0.01 s between 0.01 and 100 s",
                ));
            }
            Ok(centi as u32)
        };
        let range = PeriodRange::new(to_centi(a)?, to_centi(b)?);
        if range.from_centi > range.to_centi {
            return Err(bad("the lower end exceeds the upper end"));
        }
        Ok(range)
    }
}

/// The eight period ranges of the seed's IM study, in this order: 0.1–0.5, 0.1–2.5, 0.5–1.0,
/// 1.0–1.5, 1.5–2.0, 2.0–2.5, 2.5–3.0 and 1.0–2.5 s.
pub const STUDY_RANGES: [PeriodRange; 8] = [
    PeriodRange::new(10, 50),
    PeriodRange::new(10, 250),
    PeriodRange::new(50, 100),
    PeriodRange::new(100, 150),
    PeriodRange::new(150, 200),
    PeriodRange::new(200, 250),
    PeriodRange::new(250, 300),
    PeriodRange::new(100, 250),
];

/// Formats a period in seconds with at least one decimal (`0.1`, `1.0`, `0.25`).
#[must_use]
pub fn format_period_s(period_s: f64) -> String {
    let text = format!("{period_s}");
    if text.contains(['.', 'e', 'E']) || !period_s.is_finite() {
        text
    } else {
        format!("{text}.0")
    }
}

/// Checks a damping ratio: `0 ≤ ξ < 1` (under-damped oscillator).
pub fn check_damping(damping: f64) -> Result<(), ImError> {
    if (0.0..1.0).contains(&damping) {
        Ok(())
    } else {
        Err(ImError::BadDamping(damping))
    }
}

/// Checks a sampling interval: positive and finite (s).
pub fn check_dt(dt_s: f64) -> Result<(), ImError> {
    if dt_s.is_finite() && dt_s > 0.0 {
        Ok(())
    } else {
        Err(ImError::BadDt(dt_s))
    }
}

/// Longest oscillator period accepted (s).
pub const MAX_PERIOD_S: f64 = 100.0;

/// Checks a period: positive, finite and at most [`MAX_PERIOD_S`] (s).
pub fn check_period(period_s: f64) -> Result<(), ImError> {
    // Above ~100 s the recursion's coefficients lose their precision (ω·dt → 0), and no
    // strong-motion use needs such periods.
    if period_s.is_finite() && period_s > 0.0 && period_s <= MAX_PERIOD_S {
        Ok(())
    } else {
        Err(ImError::BadPeriod(period_s))
    }
}

/// One step of the exact Nigam–Jennings recursion for a given period, damping and time step:
///
/// `u₁ = a11·u₀ + a12·v₀ + b11·a₀ + b12·a₁`, `v₁ = a21·u₀ + a22·v₀ + b21·a₀ + b22·a₁`,
///
/// with `u` the relative displacement (m), `v = u̇` (m/s) and `a₀, a₁` the ground
/// acceleration (m/s²) at the start and end of the step. The coefficients are those of
/// Chopra, *Dynamics of Structures*, Table 5.2.1 (m = 1, k = ω², force = −a).
///
/// Precision: the `b` coefficients subtract terms of size `1/(ω³·dt)` to obtain values of size
/// `dt²`, so their relative rounding error is about `1e-16·(ω·dt)⁻³`; for the standard grid
/// (T ≤ 3 s) and dt ≥ 0.001 s this is below 1e-8.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NigamJennings {
    pub a11: f64,
    pub a12: f64,
    pub a21: f64,
    pub a22: f64,
    pub b11: f64,
    pub b12: f64,
    pub b21: f64,
    pub b22: f64,
}

impl NigamJennings {
    /// Coefficients for period `period_s` (s), damping ratio `damping` (0 ≤ ξ < 1) and time
    /// step `dt_s` (s).
    pub fn new(period_s: f64, damping: f64, dt_s: f64) -> Result<Self, ImError> {
        check_period(period_s)?;
        check_damping(damping)?;
        check_dt(dt_s)?;
        let xi = damping;
        let w = 2.0 * std::f64::consts::PI / period_s;
        let root = (1.0 - xi * xi).sqrt();
        let wd = w * root;
        let k = w * w;
        let e = (-xi * w * dt_s).exp();
        let (s, c) = (wd * dt_s).sin_cos();
        let r = xi / root;
        // Chopra's A, B, C, D (displacement) and A', B', C', D' (velocity) for m = 1, k = ω².
        let a = e * (r * s + c);
        let b = e * s / wd;
        let cc = (2.0 * xi / (w * dt_s)
            + e * (((1.0 - 2.0 * xi * xi) / (wd * dt_s) - r) * s
                - (1.0 + 2.0 * xi / (w * dt_s)) * c))
            / k;
        let d = (1.0 - 2.0 * xi / (w * dt_s)
            + e * ((2.0 * xi * xi - 1.0) / (wd * dt_s) * s + 2.0 * xi / (w * dt_s) * c))
            / k;
        let a_v = -e * (w / root) * s;
        let b_v = e * (c - r * s);
        let c_v = (-1.0 / dt_s + e * ((w / root + xi / (dt_s * root)) * s + c / dt_s)) / k;
        let d_v = (1.0 - e * (r * s + c)) / (k * dt_s);
        // The force is −a(t), hence the minus signs on the input coefficients.
        Ok(NigamJennings {
            a11: a,
            a12: b,
            a21: a_v,
            a22: b_v,
            b11: -cc,
            b12: -d,
            b21: -c_v,
            b22: -d_v,
        })
    }

    /// Advances `(u, v)` (m, m/s) over one step whose ground acceleration goes linearly from
    /// `a0_mps2` to `a1_mps2`.
    #[inline]
    #[must_use]
    pub fn step(&self, u_m: f64, v_mps: f64, a0_mps2: f64, a1_mps2: f64) -> (f64, f64) {
        (
            self.a11 * u_m + self.a12 * v_mps + self.b11 * a0_mps2 + self.b12 * a1_mps2,
            self.a21 * u_m + self.a22 * v_mps + self.b21 * a0_mps2 + self.b22 * a1_mps2,
        )
    }
}

/// Spectral values of one oscillator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpectralValues {
    /// Oscillator period (s).
    pub period_s: f64,
    /// Peak relative displacement `Sd = max |u|` (m).
    pub sd_m: f64,
    /// Peak relative velocity `SV = max |u̇|` (m/s), the true one (not PSV).
    pub sv_mps: f64,
    /// Pseudo-spectral velocity `PSV = ω·Sd` (m/s).
    pub psv_mps: f64,
    /// Pseudo-spectral acceleration `SA = ω²·Sd` (m/s²).
    pub sa_mps2: f64,
}

impl SpectralValues {
    /// Builds the values from the peaks `Sd` (m) and `SV` (m/s) of the oscillator of period
    /// `period_s` (s).
    #[must_use]
    pub fn from_peaks(period_s: f64, sd_m: f64, sv_mps: f64) -> Self {
        let w = 2.0 * std::f64::consts::PI / period_s;
        SpectralValues {
            period_s,
            sd_m,
            sv_mps,
            psv_mps: w * sd_m,
            sa_mps2: w * w * sd_m,
        }
    }
}

/// Response of one oscillator (period `period_s` s, damping ratio `damping`) to the record
/// `accel_mps2` sampled every `dt_s` s. An empty record gives zeros.
pub fn response(
    accel_mps2: &[f64],
    dt_s: f64,
    period_s: f64,
    damping: f64,
) -> Result<SpectralValues, ImError> {
    let nj = NigamJennings::new(period_s, damping, dt_s)?;
    let (mut u, mut v) = (0.0_f64, 0.0_f64);
    let (mut sd, mut sv) = (0.0_f64, 0.0_f64);
    for pair in accel_mps2.windows(2) {
        (u, v) = nj.step(u, v, pair[0], pair[1]);
        sd = sd.max(u.abs());
        sv = sv.max(v.abs());
    }
    Ok(SpectralValues::from_peaks(period_s, sd, sv))
}

/// Response spectrum at each of `periods_s` (s), damping ratio `damping`.
pub fn response_spectrum(
    accel_mps2: &[f64],
    dt_s: f64,
    periods_s: &[f64],
    damping: f64,
) -> Result<Vec<SpectralValues>, ImError> {
    periods_s
        .iter()
        .map(|&t| response(accel_mps2, dt_s, t, damping))
        .collect()
}

/// Trapezoidal integral over period of `value(point)` across the points of `spectrum`
/// (sorted by increasing period) that lie in the closed `range`. Fewer than two points in the
/// range give 0.
pub fn integrate_over_range(
    spectrum: &[SpectralValues],
    range: PeriodRange,
    value: impl Fn(&SpectralValues) -> f64,
) -> f64 {
    let mut total = 0.0;
    let mut previous: Option<(f64, f64)> = None;
    for point in spectrum.iter().filter(|p| range.contains(p.period_s)) {
        let y = value(point);
        if let Some((t0, y0)) = previous {
            total += 0.5 * (point.period_s - t0) * (y0 + y);
        }
        previous = Some((point.period_s, y));
    }
    total
}

/// Spectral intensities over one period range (trapezoid over the grid points inside it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpectralIntensities {
    /// The period range.
    pub range: PeriodRange,
    /// Acceleration spectrum intensity `ASI = ∫ SA dT` (m/s).
    pub asi_mps: f64,
    /// Housner spectrum intensity at the spectrum's damping (5 % by default, not Housner's
    /// original 20 %): `SI = ∫ PSV dT` (m).
    pub si_m: f64,
    /// Velocity spectrum intensity `VSI = ∫ SV dT` with the true SV (m).
    pub vsi_m: f64,
}

/// ASI, SI and VSI of `spectrum` (sorted by increasing period) over `range`.
#[must_use]
pub fn spectral_intensities(
    spectrum: &[SpectralValues],
    range: PeriodRange,
) -> SpectralIntensities {
    SpectralIntensities {
        range,
        asi_mps: integrate_over_range(spectrum, range, |p| p.sa_mps2),
        si_m: integrate_over_range(spectrum, range, |p| p.psv_mps),
        vsi_m: integrate_over_range(spectrum, range, |p| p.sv_mps),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_points_are_exact_decimal_multiples() {
        let grid = period_grid_s(1);
        assert_eq!(grid.len(), 291);
        assert_eq!(grid[0], 0.1);
        assert_eq!(grid[20], 0.3);
        assert_eq!(grid[290], 3.0);
        let coarse = period_grid_s(2);
        assert_eq!(coarse.len(), 146);
        assert_eq!(coarse[1], 0.12);
    }

    #[test]
    fn range_labels_and_parsing() {
        assert_eq!(STUDY_RANGES[0].label(), "0.1-0.5");
        assert_eq!(STUDY_RANGES[7].label(), "1.0-2.5");
        assert_eq!(PeriodRange::parse("0.1-0.5"), Ok(STUDY_RANGES[0]));
        assert!(PeriodRange::parse("0.5-0.1").is_err());
        assert!(PeriodRange::parse("0.105-0.5").is_err());
        assert!(PeriodRange::parse("abc").is_err());
    }

    #[test]
    fn free_vibration_coefficients_match_closed_form() {
        // Undamped oscillator, zero input: u(t) = u0 cos ωt + v0/ω sin ωt.
        let nj = NigamJennings::new(1.0, 0.0, 0.01).unwrap();
        let w = 2.0 * std::f64::consts::PI;
        let (u, v) = nj.step(1.0, 0.0, 0.0, 0.0);
        assert!((u - (w * 0.01).cos()).abs() < 1e-14);
        assert!((v + w * (w * 0.01).sin()).abs() < 1e-13);
    }

    #[test]
    fn constant_input_converges_to_static_displacement() {
        // a = const ⇒ u → −a/ω² (1 s period, 5 %); after 200 s the transient has decayed
        // by e^(−ξωt) = e^(−63).
        let dt = 0.01;
        let nj = NigamJennings::new(1.0, 0.05, dt).unwrap();
        let (mut u, mut v) = (0.0, 0.0);
        for _ in 0..20_000 {
            (u, v) = nj.step(u, v, 1.0, 1.0);
        }
        let w = 2.0 * std::f64::consts::PI;
        assert!((u + 1.0 / (w * w)).abs() < 1e-12, "{u}");
        assert!(v.abs() < 1e-10);
    }
}
