//! All intensity measures of a whole record (see the table in [`super`] for the definitions).

use super::spectrum::{
    centi_to_s, check_damping, check_dt, check_period, period_grid_s, response_spectrum,
    spectral_intensities, SpectralIntensities, SpectralValues, DEFAULT_DAMPING, STUDY_RANGES,
};
use super::{ImError, HUSID_FRACTIONS};
use crate::record::STANDARD_GRAVITY_MPS2;

/// Default periods (s) at which SA, PSV and SV are reported: 0.1 0.2 0.3 0.5 1.0 1.5 2.0 2.5 3.0.
pub const DEFAULT_SA_PERIODS_S: [f64; 9] = [0.1, 0.2, 0.3, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0];

/// Default low-pass cutoff of the EDA filter (Hz).
pub const EDA_CUTOFF_HZ: f64 = 9.0;

/// Options of [`compute_ims`].
#[derive(Debug, Clone, PartialEq)]
pub struct ImOptions {
    /// Damping ratio of every spectral IM (default 0.05).
    pub damping: f64,
    /// Periods (s) at which SA, PSV and SV are reported in [`ImSet::spectral`], in this order.
    pub periods_s: Vec<f64>,
    /// Cutoff (Hz) of the EDA low-pass filter (default 9 Hz).
    pub eda_cutoff_hz: f64,
}

impl Default for ImOptions {
    fn default() -> Self {
        ImOptions {
            damping: DEFAULT_DAMPING,
            periods_s: DEFAULT_SA_PERIODS_S.to_vec(),
            eda_cutoff_hz: EDA_CUTOFF_HZ,
        }
    }
}

/// Every IM of one component of a record, in SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct ImSet {
    /// Sampling interval (s).
    pub dt_s: f64,
    /// Number of samples.
    pub npts: usize,
    /// Damping ratio of the spectral IMs.
    pub damping: f64,
    /// Peak ground acceleration `max |a_i|` (m/s²), the seed's PHA.
    pub pga_mps2: f64,
    /// Peak ground velocity (m/s), the seed's PHV.
    pub pgv_mps: f64,
    /// Peak ground displacement (m), the seed's PHD.
    pub pgd_m: f64,
    /// Cumulative absolute velocity `∫|a|dt` (m/s).
    pub cav_mps: f64,
    /// Arias intensity `π/(2g)·∫a²dt` (m/s).
    pub arias_mps: f64,
    /// Time (s from the first sample) at which the Husid curve first reaches 5 %.
    pub t5_s: f64,
    /// Time (s) at which the Husid curve first reaches 75 %.
    pub t75_s: f64,
    /// Time (s) at which the Husid curve first reaches 95 %.
    pub t95_s: f64,
    /// Significant duration `t75 − t5` (s).
    pub d5_75_s: f64,
    /// Significant duration `t95 − t5` (s).
    pub d5_95_s: f64,
    /// RMS acceleration over t5..t95, `sqrt(0.90·∫a²dt / D5-95)` (m/s²).
    pub a_rms_mps2: f64,
    /// Characteristic intensity `a_rms^1.5·sqrt(D5-95)` (m^1.5·s^-2.5).
    pub ic: f64,
    /// Sustained maximum acceleration: 3rd-largest absolute half-cycle peak (m/s²).
    pub sma_mps2: f64,
    /// Effective design acceleration: peak of the 9 Hz zero-phase low-passed record (m/s²).
    pub eda_mps2: f64,
    /// Predominant period: period of the SA peak on the 0.10–3.00 s grid, step 0.01 s (s);
    /// the shortest such period on ties (0.10 s for a record of zeros).
    pub tp_s: f64,
    /// PGV/PGA (s); 0 when PGA = 0.
    pub pgv_pga_s: f64,
    /// Effective peak velocity (ATC 3-06) (m/s): the arithmetic mean of the PSV at the 41 grid
    /// periods 0.80, 0.81, …, 1.20 s, divided by 2.5 (the spectral amplification of ATC 3-06).
    pub epv_mps: f64,
    /// SA, PSV and SV at [`ImOptions::periods_s`], in that order.
    pub spectral: Vec<SpectralValues>,
    /// ASI, SI and VSI over each of [`STUDY_RANGES`], in that order.
    pub study_intensities: [SpectralIntensities; 8],
    /// The spectrum on the 0.10..=3.00 s grid (step 0.01 s, 291 periods).
    pub grid_spectrum: Vec<SpectralValues>,
}

/// Validates a record: non-empty, `dt_s` positive and finite, every sample finite.
pub fn check_record(accel_mps2: &[f64], dt_s: f64) -> Result<(), ImError> {
    check_dt(dt_s)?;
    if accel_mps2.is_empty() {
        return Err(ImError::Empty);
    }
    match accel_mps2.iter().position(|a| !a.is_finite()) {
        Some(index) => Err(ImError::NonFinite {
            index,
            value: accel_mps2[index],
        }),
        None => Ok(()),
    }
}

/// Computes every IM of the record `accel_mps2` (m/s², sampled every `dt_s` s, used as given).
pub fn compute_ims(accel_mps2: &[f64], dt_s: f64, options: &ImOptions) -> Result<ImSet, ImError> {
    check_record(accel_mps2, dt_s)?;
    check_damping(options.damping)?;
    for &t in &options.periods_s {
        check_period(t)?;
    }

    let pga_mps2 = accel_mps2.iter().fold(0.0_f64, |m, a| m.max(a.abs()));
    let (pgv_mps, pgd_m) = velocity_displacement_peaks(accel_mps2, dt_s);
    let cav_mps = accel_mps2
        .windows(2)
        .fold(0.0, |sum, w| sum + 0.5 * dt_s * (w[0].abs() + w[1].abs()));
    let energy = cumulative_energy(accel_mps2, dt_s);
    let total = energy.last().copied().unwrap_or(0.0);
    let arias_mps = std::f64::consts::PI / (2.0 * STANDARD_GRAVITY_MPS2) * total;
    let [t5_s, t75_s, t95_s] = HUSID_FRACTIONS.map(|p| husid_time(&energy, p, dt_s));
    let d5_95_s = t95_s - t5_s;
    let (a_rms_mps2, ic) = rms_and_characteristic(total, d5_95_s);

    let grid_spectrum = response_spectrum(accel_mps2, dt_s, &period_grid_s(1), options.damping)?;
    let spectral = options
        .periods_s
        .iter()
        .map(|&t| match grid_spectrum.iter().find(|p| p.period_s == t) {
            Some(p) => Ok(*p),
            None => super::spectrum::response(accel_mps2, dt_s, t, options.damping),
        })
        .collect::<Result<Vec<_>, _>>()?;
    let study_intensities = STUDY_RANGES.map(|r| spectral_intensities(&grid_spectrum, r));
    let tp_s = grid_spectrum
        .iter()
        .fold((0.0, f64::NEG_INFINITY), |(tp, peak), p| {
            if p.sa_mps2 > peak {
                (p.period_s, p.sa_mps2)
            } else {
                (tp, peak)
            }
        })
        .0;
    let (epv_from, epv_to) = (centi_to_s(80), centi_to_s(120));
    let epv_band: Vec<f64> = grid_spectrum
        .iter()
        .filter(|p| p.period_s >= epv_from && p.period_s <= epv_to)
        .map(|p| p.psv_mps)
        .collect();
    let epv_mps = epv_band.iter().sum::<f64>() / epv_band.len() as f64 / 2.5;

    Ok(ImSet {
        dt_s,
        npts: accel_mps2.len(),
        damping: options.damping,
        pga_mps2,
        pgv_mps,
        pgd_m,
        cav_mps,
        arias_mps,
        t5_s,
        t75_s,
        t95_s,
        d5_75_s: t75_s - t5_s,
        d5_95_s,
        a_rms_mps2,
        ic,
        sma_mps2: sustained_maximum_acceleration(accel_mps2),
        eda_mps2: effective_design_acceleration(accel_mps2, dt_s, options.eda_cutoff_hz)?,
        tp_s,
        pgv_pga_s: if pga_mps2 > 0.0 {
            pgv_mps / pga_mps2
        } else {
            0.0
        },
        epv_mps,
        spectral,
        study_intensities,
        grid_spectrum,
    })
}

/// Peaks of `|v|` (m/s) and `|d|` (m), v and d being cumulative trapezoids of the
/// acceleration and of v, both starting at 0.
#[must_use]
pub fn velocity_displacement_peaks(accel_mps2: &[f64], dt_s: f64) -> (f64, f64) {
    let (mut v, mut d) = (0.0_f64, 0.0_f64);
    let (mut pgv, mut pgd) = (0.0_f64, 0.0_f64);
    for w in accel_mps2.windows(2) {
        let v_next = v + 0.5 * dt_s * (w[0] + w[1]);
        d += 0.5 * dt_s * (v + v_next);
        v = v_next;
        pgv = pgv.max(v.abs());
        pgd = pgd.max(d.abs());
    }
    (pgv, pgd)
}

/// Cumulative trapezoid of `a²` (m²/s³): `E_0 = 0`, `E_{i+1} = E_i + dt·(a_i² + a_{i+1}²)/2`.
#[must_use]
pub fn cumulative_energy(accel_mps2: &[f64], dt_s: f64) -> Vec<f64> {
    let mut energy = Vec::with_capacity(accel_mps2.len());
    let mut e = 0.0_f64;
    energy.push(e);
    for w in accel_mps2.windows(2) {
        e += 0.5 * dt_s * (w[0] * w[0] + w[1] * w[1]);
        energy.push(e);
    }
    energy
}

/// First time (s) at which the Husid curve `energy/total` reaches `fraction`, by linear
/// interpolation between the bracketing samples; 0 when the total is 0.
#[must_use]
pub fn husid_time(energy: &[f64], fraction: f64, dt_s: f64) -> f64 {
    let total = energy.last().copied().unwrap_or(0.0);
    if total <= 0.0 {
        return 0.0;
    }
    let target = fraction * total;
    match energy.iter().position(|&e| e >= target) {
        Some(i) if i > 0 => {
            let (e0, e1) = (energy[i - 1], energy[i]);
            dt_s * ((i - 1) as f64 + (target - e0) / (e1 - e0))
        }
        _ => 0.0,
    }
}

/// `(a_rms, Ic)` from the total `∫a²dt` (m²/s³) and D5-95 (s): `a_rms = sqrt(0.90·total/D)`
/// (m/s²), `Ic = a_rms^1.5·sqrt(D)`; both 0 when D5-95 is not positive.
#[must_use]
pub fn rms_and_characteristic(total_energy: f64, d5_95_s: f64) -> (f64, f64) {
    if d5_95_s > 0.0 {
        let a_rms = (0.90 * total_energy / d5_95_s).sqrt();
        (a_rms, a_rms.powf(1.5) * d5_95_s.sqrt())
    } else {
        (0.0, 0.0)
    }
}

/// Sustained maximum acceleration (m/s²): the 3rd-largest absolute half-cycle peak, a
/// half-cycle being a run of consecutive samples of the same non-zero sign (a zero sample
/// ends a run); 0 when there are fewer than three half-cycles.
#[must_use]
pub fn sustained_maximum_acceleration(accel_mps2: &[f64]) -> f64 {
    let mut peaks = Vec::new();
    let mut run: Option<(bool, f64)> = None;
    for &a in accel_mps2 {
        let sign = (a != 0.0).then_some(a > 0.0);
        match (run, sign) {
            (Some((s, peak)), Some(now)) if s == now => run = Some((s, peak.max(a.abs()))),
            _ => {
                if let Some((_, peak)) = run {
                    peaks.push(peak);
                }
                run = sign.map(|s| (s, a.abs()));
            }
        }
    }
    if let Some((_, peak)) = run {
        peaks.push(peak);
    }
    peaks.sort_by(|a, b| b.total_cmp(a));
    peaks.get(2).copied().unwrap_or(0.0)
}

/// Effective design acceleration (m/s²): peak of `|low_pass_zero_phase(a, dt, cutoff_hz)|`
/// over the record's samples.
pub fn effective_design_acceleration(
    accel_mps2: &[f64],
    dt_s: f64,
    cutoff_hz: f64,
) -> Result<f64, ImError> {
    Ok(low_pass_zero_phase(accel_mps2, dt_s, cutoff_hz)?
        .iter()
        .fold(0.0_f64, |m, a| m.max(a.abs())))
}

/// Zero-phase low-pass filter used for EDA: a 4th-order Butterworth low-pass (two
/// second-order sections, bilinear transform with the cutoff pre-warped, so the digital
/// response is `|H(f)|² = 1/(1 + (tan(π f dt)/tan(π f_c dt))⁸)`), run forward and then
/// backward (filtfilt). The result has zero phase and amplitude gain `|H(f)|²`:
/// 1 at 0 Hz, 0.5 (−6 dB) at the cutoff, falling as `f⁻¹⁶` well above it.
///
/// The record is taken as zero outside its span: the forward pass starts from rest and runs
/// on past the last sample over zeros until its impulse response has decayed below 1e-16
/// (40 time constants of the slowest pole); the backward pass starts from rest at the end of
/// that tail. The output has the record's length.
///
/// When the cutoff is at or above the Nyquist frequency `1/(2dt)` the record holds no
/// content above it and is returned unchanged.
pub fn low_pass_zero_phase(
    accel_mps2: &[f64],
    dt_s: f64,
    cutoff_hz: f64,
) -> Result<Vec<f64>, ImError> {
    check_dt(dt_s)?;
    if !(cutoff_hz.is_finite() && cutoff_hz > 0.0) {
        return Err(ImError::BadCutoff(cutoff_hz));
    }
    if cutoff_hz * dt_s >= 0.5 {
        return Ok(accel_mps2.to_vec());
    }
    let k = (std::f64::consts::PI * cutoff_hz * dt_s).tan();
    const ORDER: usize = 4;
    let sections: [Biquad; ORDER / 2] = std::array::from_fn(|j| {
        // Analog prototype pole pair damping: ζ_j = sin(π(2j+1)/(2n)).
        let zeta = (std::f64::consts::PI * (2 * j + 1) as f64 / (2 * ORDER) as f64).sin();
        Biquad::low_pass(k, zeta)
    });
    // Slowest analog pole decays as exp(−ω_c·sin(π/(2n))·t); ω_c = 2·tan(π f_c dt)/dt.
    let sigma = 2.0 * k / dt_s * (std::f64::consts::PI / (2 * ORDER) as f64).sin();
    let tail = (40.0 / (sigma * dt_s)).ceil() as usize + 4 * ORDER;
    let mut work: Vec<f64> = accel_mps2
        .iter()
        .copied()
        .chain(std::iter::repeat_n(0.0, tail))
        .collect();
    for section in &sections {
        section.filter_in_place(work.iter_mut());
    }
    for section in &sections {
        section.filter_in_place(work.iter_mut().rev());
    }
    work.truncate(accel_mps2.len());
    Ok(work)
}

/// A second-order IIR section `y = (b0 + b1 z⁻¹ + b2 z⁻²)/(1 + a1 z⁻¹ + a2 z⁻²) x`.
#[derive(Debug, Clone, Copy)]
struct Biquad {
    b: [f64; 3],
    a: [f64; 2],
}

impl Biquad {
    /// Bilinear transform of `1/(s² + 2ζs + 1)` with `s` normalised by the pre-warped cutoff
    /// (`k = tan(π f_c dt)`).
    fn low_pass(k: f64, zeta: f64) -> Self {
        let k2 = k * k;
        let a0 = 1.0 + 2.0 * zeta * k + k2;
        Biquad {
            b: [k2 / a0, 2.0 * k2 / a0, k2 / a0],
            a: [2.0 * (k2 - 1.0) / a0, (1.0 - 2.0 * zeta * k + k2) / a0],
        }
    }

    /// Filters the samples in iteration order from rest (transposed direct form II).
    fn filter_in_place<'a>(&self, samples: impl Iterator<Item = &'a mut f64>) {
        let (mut s1, mut s2) = (0.0, 0.0);
        for x in samples {
            let y = self.b[0] * *x + s1;
            s1 = self.b[1] * *x - self.a[0] * y + s2;
            s2 = self.b[2] * *x - self.a[1] * y;
            *x = y;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sma_counts_half_cycles_not_samples() {
        // Half-cycles: [3, 5] → 5, [-2] → 2, 0 ends, [1] → 1, [-4, -1] → 4.
        let a = [3.0, 5.0, -2.0, 0.0, 1.0, -4.0, -1.0];
        assert_eq!(sustained_maximum_acceleration(&a), 2.0);
        assert_eq!(sustained_maximum_acceleration(&[1.0, -1.0]), 0.0);
    }

    #[test]
    fn husid_time_of_constant_record_is_linear() {
        let a = vec![2.0; 101];
        let e = cumulative_energy(&a, 0.01);
        assert!((husid_time(&e, 0.05, 0.01) - 0.05).abs() < 1e-12);
        assert!((husid_time(&e, 0.95, 0.01) - 0.95).abs() < 1e-12);
    }

    #[test]
    fn zero_record_has_zero_ims() {
        let ims = compute_ims(&[0.0; 50], 0.01, &ImOptions::default()).unwrap();
        assert_eq!(ims.pga_mps2, 0.0);
        assert_eq!(ims.t95_s, 0.0);
        assert_eq!(ims.a_rms_mps2, 0.0);
        assert_eq!(ims.pgv_pga_s, 0.0);
        assert_eq!(ims.epv_mps, 0.0);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let opts = ImOptions::default();
        assert_eq!(compute_ims(&[], 0.01, &opts), Err(ImError::Empty));
        assert_eq!(compute_ims(&[1.0], 0.0, &opts), Err(ImError::BadDt(0.0)));
        assert!(matches!(
            compute_ims(&[1.0, f64::NAN], 0.01, &opts),
            Err(ImError::NonFinite { index: 1, .. })
        ));
        let bad_period = ImOptions {
            periods_s: vec![-1.0],
            ..ImOptions::default()
        };
        assert_eq!(
            compute_ims(&[1.0], 0.01, &bad_period),
            Err(ImError::BadPeriod(-1.0))
        );
    }

    #[test]
    fn low_pass_keeps_constant() {
        // DC gain 1: the middle of a long constant record passes unchanged.
        let y = low_pass_zero_phase(&[1.0; 2000], 0.005, 9.0).unwrap();
        assert!((y[1000] - 1.0).abs() < 1e-12);
    }
}
