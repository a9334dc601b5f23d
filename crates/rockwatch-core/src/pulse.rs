//! Synthetic near-fault velocity pulses: the Mavroeidis & Papageorgiou (2003) model with
//! parameters drawn from the Rupakhety et al. (2011) laws by Latin-hypercube sampling.
//!
//! # The pulse (M&P 2003, Eq. 15 of the seed paper)
//! Ground velocity (m/s, + along the block's +x axis, like [`Record::horizontal_mps2`]):
//!
//! ```text
//! v(t) = A · ½[1 + cos(2π·fp·(t − t0)/γ)] · cos(2π·fp·(t − t0) + ν)   for |t − t0| ≤ γ/(2·fp)
//! v(t) = 0                                                             otherwise
//! ```
//!
//! with `A > 0` the amplitude (m/s), `fp > 0` the pulse frequency (Hz; period `Tp = 1/fp`),
//! `γ` the oscillatory character (≈ number of half cycles) and `ν` the phase (rad). As in the
//! seed paper, `t0 = γ/(2·fp)` so that the pulse occupies `0 ≤ t ≤ γ/fp`
//! ([`MpPulse::duration_s`]). Valid range: M&P require **γ > 1**; this module also caps
//! γ ≤ [`GAMMA_MAX`] (an engineering bound, far above the fitted values, that keeps the
//! numerical peak search cheap). Velocity and acceleration are continuous and zero at both
//! ends; displacement is zero before the pulse and keeps its final (residual) value after.
//!
//! The peak velocity `max |v|` is *not* `A` in general (the envelope and carrier maxima do
//! not coincide unless ν = 0); [`MpPulse::with_peak_velocity`] solves for `A`.
//!
//! # Parameter laws (Rupakhety et al. 2011, as used by the seed paper)
//! * `log10 Tp[s] ~ N(−2.87 + 0.47·Mw, 0.18)`;
//! * `log10 Vp[cm/s] ~ N(−5.17 + 1.98·M − 0.14·M² − 0.10·log10(R² + 0.56²), 0.16)` with
//!   `M = min(Mw, 7)` (the law saturates at Mw 7; above it Vp depends on R only) and `R` the
//!   distance in km;
//! * `γ ~ N(1.8, 0.4)` truncated to the model's valid range `γ > 1` (the 2.3 % of the normal
//!   below 1 is removed; the upper tail is kept: P(γ > 3.5) ≈ 1e−5, far below [`GAMMA_MAX`]);
//! * `ν ~ U[−π/2, π/2]` (the seed's "π/2 to π/2" is a typo for this range);
//! * `fp = 1/Tp`, and `A` such that the pulse's peak velocity equals the drawn `Vp`.
//!
//! Draws are stratified by a 4-dimensional Latin hypercube ([`crate::lhs`]) whose margins
//! are mapped through the normal quantile (columns 0–2: Tp, Vp, γ) and linearly (column 3:
//! ν); the whole ensemble is reproducible from one `u64` seed.

use crate::lhs::{latin_hypercube, rng_from_seed, standard_normal_quantile};
use crate::record::Record;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// A rejected pulse parameter or sampling request.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PulseError {
    /// A parameter is outside its valid range.
    #[error("{name} = {value} is invalid: {requirement}")]
    InvalidParameter {
        /// Parameter name with its unit, e.g. `"fp_hz"`.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// Sampling would need more than [`MAX_RECORD_SAMPLES`] samples.
    #[error(
        "sampling {duration_s} s at dt = {dt_s} s needs more than {limit} samples: \
         use a larger dt"
    )]
    TooManySamples {
        /// Duration to sample (s).
        duration_s: f64,
        /// Requested sampling interval (s).
        dt_s: f64,
        /// The limit.
        limit: usize,
    },
}

/// Largest number of samples [`MpPulse::to_record`] will produce (400 MB of `f64`).
pub const MAX_RECORD_SAMPLES: usize = 50_000_000;

/// Largest accepted γ (engineering cap; M&P's fitted values are below ~3).
pub const GAMMA_MAX: f64 = 100.0;

/// Grid points per carrier period used to bracket the peaks of |v| before refinement.
const PEAK_GRID_PER_PERIOD: f64 = 64.0;

/// A Mavroeidis & Papageorgiou (2003) velocity pulse starting at `t = 0` (see module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MpPulse {
    amplitude_mps: f64,
    fp_hz: f64,
    gamma: f64,
    nu_rad: f64,
    /// `max |v| / A` (dimensionless, in (0, 1]), computed at construction.
    peak_factor: f64,
}

fn invalid(name: &'static str, value: f64, requirement: &'static str) -> PulseError {
    PulseError::InvalidParameter {
        name,
        value,
        requirement,
    }
}

fn check_shape(fp_hz: f64, gamma: f64, nu_rad: f64) -> Result<(), PulseError> {
    if !(fp_hz.is_finite() && fp_hz > 0.0) {
        return Err(invalid(
            "fp_hz",
            fp_hz,
            "must be a positive finite frequency (Hz)",
        ));
    }
    if !(gamma > 1.0 && gamma <= GAMMA_MAX) {
        return Err(invalid(
            "gamma",
            gamma,
            "must satisfy 1 < gamma <= 100 (M&P 2003 require gamma > 1)",
        ));
    }
    if !nu_rad.is_finite() {
        return Err(invalid("nu_rad", nu_rad, "must be a finite phase (rad)"));
    }
    if !(gamma / fp_hz).is_finite() {
        return Err(invalid(
            "fp_hz",
            fp_hz,
            "gives an infinite pulse duration gamma/fp",
        ));
    }
    Ok(())
}

/// `sin(x)/x`, with its Taylor series near 0 (error < 1e−20 for |x| < 1e−4).
fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        let x2 = x * x;
        1.0 - x2 / 6.0 + x2 * x2 / 120.0
    } else {
        x.sin() / x
    }
}

/// `∫₀ᵗ cos(k(s − T/2) + ν) ds` in the cancellation-free form `t·cos(ν + k(t − T)/2)·sinc(kt/2)`.
fn cos_integral_from_start(k: f64, nu: f64, t: f64, duration: f64) -> f64 {
    t * (nu + 0.5 * k * (t - duration)).cos() * sinc(0.5 * k * t)
}

/// Maximum of `f` on `[a, b]` by golden-section search (`f` unimodal there).
fn golden_section_max(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, tol: f64) -> f64 {
    const INV_PHI: f64 = 0.618_033_988_749_894_8;
    let mut c = b - INV_PHI * (b - a);
    let mut d = a + INV_PHI * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    let mut iterations = 0;
    while b - a > tol && iterations < 200 {
        if fc >= fd {
            b = d;
            d = c;
            fd = fc;
            c = b - INV_PHI * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + INV_PHI * (b - a);
            fd = f(d);
        }
        iterations += 1;
    }
    fc.max(fd)
}

impl MpPulse {
    /// A pulse of amplitude `amplitude_mps` (A, m/s, > 0), frequency `fp_hz` (Hz, > 0),
    /// oscillatory character `gamma` (1 < γ ≤ [`GAMMA_MAX`]) and phase `nu_rad` (rad, any
    /// finite value). Errors name the offending parameter.
    pub fn new(
        amplitude_mps: f64,
        fp_hz: f64,
        gamma: f64,
        nu_rad: f64,
    ) -> Result<Self, PulseError> {
        check_shape(fp_hz, gamma, nu_rad)?;
        if !(amplitude_mps.is_finite() && amplitude_mps > 0.0) {
            return Err(invalid(
                "amplitude_mps",
                amplitude_mps,
                "must be a positive finite velocity (m/s)",
            ));
        }
        let mut pulse = MpPulse {
            amplitude_mps,
            fp_hz,
            gamma,
            nu_rad,
            peak_factor: 1.0,
        };
        pulse.peak_factor = pulse.search_peak_abs_velocity_mps() / amplitude_mps;
        Ok(pulse)
    }

    /// The pulse of shape (`fp_hz`, `gamma`, `nu_rad`) whose peak velocity `max |v|` equals
    /// `peak_velocity_mps` (m/s, > 0): `A = Vp / (max |v| of the unit-amplitude pulse)`.
    pub fn with_peak_velocity(
        peak_velocity_mps: f64,
        fp_hz: f64,
        gamma: f64,
        nu_rad: f64,
    ) -> Result<Self, PulseError> {
        if !(peak_velocity_mps.is_finite() && peak_velocity_mps > 0.0) {
            return Err(invalid(
                "peak_velocity_mps",
                peak_velocity_mps,
                "must be a positive finite velocity (m/s)",
            ));
        }
        let unit = MpPulse::new(1.0, fp_hz, gamma, nu_rad)?;
        Ok(MpPulse {
            amplitude_mps: peak_velocity_mps / unit.peak_factor,
            ..unit
        })
    }

    /// Amplitude A (m/s).
    #[must_use]
    pub fn amplitude_mps(&self) -> f64 {
        self.amplitude_mps
    }

    /// Pulse frequency fp (Hz).
    #[must_use]
    pub fn fp_hz(&self) -> f64 {
        self.fp_hz
    }

    /// Pulse period Tp = 1/fp (s).
    #[must_use]
    pub fn period_s(&self) -> f64 {
        1.0 / self.fp_hz
    }

    /// Oscillatory character γ (dimensionless, > 1).
    #[must_use]
    pub fn gamma(&self) -> f64 {
        self.gamma
    }

    /// Phase ν (rad).
    #[must_use]
    pub fn nu_rad(&self) -> f64 {
        self.nu_rad
    }

    /// Duration γ/fp (s): the pulse is non-zero only on `0 ≤ t ≤ duration_s()`.
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.gamma / self.fp_hz
    }

    /// Centre of the envelope t0 = γ/(2·fp) (s).
    #[must_use]
    pub fn center_time_s(&self) -> f64 {
        0.5 * self.duration_s()
    }

    /// Peak ground velocity max |v(t)| (m/s); equals `A` only for special (γ, ν).
    #[must_use]
    pub fn peak_velocity_mps(&self) -> f64 {
        self.amplitude_mps * self.peak_factor
    }

    /// `(τ, ω, Ω) = (t − t0, 2π·fp, 2π·fp/γ)` when `t` is inside the pulse.
    fn phase(&self, t_s: f64) -> Option<(f64, f64, f64)> {
        (0.0..=self.duration_s()).contains(&t_s).then(|| {
            let omega = TAU * self.fp_hz;
            (t_s - self.center_time_s(), omega, omega / self.gamma)
        })
    }

    /// Ground velocity v(t) (m/s, + along the block's +x axis) at time `t_s` (s); 0 outside
    /// the pulse.
    #[must_use]
    pub fn velocity_mps(&self, t_s: f64) -> f64 {
        match self.phase(t_s) {
            Some((tau, omega, big_omega)) => {
                0.5 * self.amplitude_mps
                    * (1.0 + (big_omega * tau).cos())
                    * (omega * tau + self.nu_rad).cos()
            }
            None => 0.0,
        }
    }

    /// Ground acceleration a(t) = dv/dt (m/s², + along +x) at `t_s` (s), the exact derivative
    /// `−(A/2)[Ω·sin(Ωτ)·cos(ωτ+ν) + ω·(1+cos Ωτ)·sin(ωτ+ν)]`, `τ = t − t0`,
    /// `ω = 2π·fp`, `Ω = ω/γ`; 0 outside the pulse (continuous: it vanishes at both ends).
    #[must_use]
    pub fn accel_mps2(&self, t_s: f64) -> f64 {
        match self.phase(t_s) {
            Some((tau, omega, big_omega)) => {
                let carrier = omega * tau + self.nu_rad;
                -0.5 * self.amplitude_mps
                    * (big_omega * (big_omega * tau).sin() * carrier.cos()
                        + omega * (1.0 + (big_omega * tau).cos()) * carrier.sin())
            }
            None => 0.0,
        }
    }

    /// Ground displacement d(t) = ∫₀ᵗ v (m, + along +x) at `t_s` (s): 0 before the pulse,
    /// the closed-form integral during it, and the residual displacement after it.
    ///
    /// With `v = (A/2)cos(ωτ+ν) + (A/4)cos((ω+Ω)τ+ν) + (A/4)cos((ω−Ω)τ+ν)`, each term
    /// integrates to `t·cos(ν + k(t−T)/2)·sinc(kt/2)` (`T` = duration, `k` its frequency),
    /// a form free of cancellation as γ → 1 (k = ω−Ω → 0).
    #[must_use]
    pub fn displacement_m(&self, t_s: f64) -> f64 {
        if t_s.is_nan() || t_s <= 0.0 {
            return 0.0;
        }
        let duration = self.duration_s();
        let t = t_s.min(duration);
        let omega = TAU * self.fp_hz;
        let big_omega = omega / self.gamma;
        let nu = self.nu_rad;
        self.amplitude_mps
            * (0.5 * cos_integral_from_start(omega, nu, t, duration)
                + 0.25 * cos_integral_from_start(omega + big_omega, nu, t, duration)
                + 0.25 * cos_integral_from_start(omega - big_omega, nu, t, duration))
    }

    /// Residual (permanent) ground displacement after the pulse (m).
    #[must_use]
    pub fn residual_displacement_m(&self) -> f64 {
        self.displacement_m(self.duration_s())
    }

    /// max |v| by a grid of [`PEAK_GRID_PER_PERIOD`] points per carrier period, each local
    /// maximum of |v| on the grid refined by golden-section search on its two neighbouring
    /// intervals. |v| is 0 at both ends, so every maximum is interior and bracketed; refining
    /// all of them (not only the largest sample) makes the result exact to rounding.
    fn search_peak_abs_velocity_mps(&self) -> f64 {
        let duration = self.duration_s();
        let intervals = (PEAK_GRID_PER_PERIOD * self.gamma)
            .ceil()
            .max(PEAK_GRID_PER_PERIOD);
        let n = intervals as usize;
        let h = duration / intervals;
        let abs_v = |t: f64| self.velocity_mps(t).abs();
        let tol = 1e-13 * duration;
        let mut best = 0.0_f64;
        let (mut previous, mut current) = (abs_v(0.0), abs_v(h));
        for i in 1..n {
            let next = abs_v((i + 1) as f64 * h);
            if current >= previous && current >= next {
                let a = (i - 1) as f64 * h;
                let b = (i + 1) as f64 * h;
                best = best.max(current).max(golden_section_max(abs_v, a, b, tol));
            }
            previous = current;
            current = next;
        }
        best
    }

    /// Samples the acceleration at `t_i = i·dt_s`, `i = 0..=N`, with `N` the smallest count
    /// reaching the end of the pulse (to 1e−9·dt), so the last sample is at or just after
    /// `duration_s()` and the record contains the whole pulse.
    pub fn to_record(&self, dt_s: f64) -> Result<Record, PulseError> {
        self.to_record_padded(dt_s, 0.0)
    }

    /// Like [`MpPulse::to_record`], followed by `pad_s` seconds (≥ 0) of zero acceleration
    /// (e.g. to let a block's free response die out).
    pub fn to_record_padded(&self, dt_s: f64, pad_s: f64) -> Result<Record, PulseError> {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(invalid(
                "dt_s",
                dt_s,
                "must be a positive finite interval (s)",
            ));
        }
        if !(pad_s.is_finite() && pad_s >= 0.0) {
            return Err(invalid(
                "pad_s",
                pad_s,
                "must be a finite duration >= 0 (s)",
            ));
        }
        let total_s = self.duration_s() + pad_s;
        let last = (total_s / dt_s - 1e-9).ceil().max(0.0);
        if last.is_nan() || last >= MAX_RECORD_SAMPLES as f64 {
            return Err(PulseError::TooManySamples {
                duration_s: total_s,
                dt_s,
                limit: MAX_RECORD_SAMPLES,
            });
        }
        let n = last as usize + 1;
        let mut horizontal_mps2 = Vec::with_capacity(n);
        for i in 0..n {
            horizontal_mps2.push(self.accel_mps2(i as f64 * dt_s));
        }
        Ok(Record {
            source: format!(
                "Mavroeidis-Papageorgiou pulse (A = {} m/s, fp = {} Hz, gamma = {}, nu = {} rad)",
                self.amplitude_mps, self.fp_hz, self.gamma, self.nu_rad
            ),
            dt_s,
            horizontal_mps2,
            vertical_mps2: None,
        })
    }
}

/// Intercept of the Rupakhety et al. (2011) law `log10 Tp[s] = c0 + c1·Mw`.
pub const LOG10_TP_INTERCEPT: f64 = -2.87;
/// Magnitude slope of the `log10 Tp` law (per unit Mw).
pub const LOG10_TP_PER_MW: f64 = 0.47;
/// Standard deviation of `log10 Tp[s]`.
pub const SIGMA_LOG10_TP: f64 = 0.18;
/// Standard deviation of `log10 Vp[cm/s]`.
pub const SIGMA_LOG10_VP: f64 = 0.16;
/// Magnitude at which the Vp law saturates (Mw above it is replaced by it).
pub const VP_LAW_MW_CAP: f64 = 7.0;
/// Fictitious depth term of the Vp law (km): `log10(R² + 0.56²)`.
pub const VP_LAW_DEPTH_KM: f64 = 0.56;
/// Mean of the (untruncated) normal distribution of γ.
pub const GAMMA_MEAN: f64 = 1.8;
/// Standard deviation of the (untruncated) normal distribution of γ.
pub const GAMMA_SD: f64 = 0.4;
/// Lower truncation of γ: the model's validity bound, exclusive (γ > 1).
pub const GAMMA_MIN_EXCLUSIVE: f64 = 1.0;
/// Φ((1 − 1.8)/0.4) = Φ(−2): probability mass of N(1.8, 0.4) below γ = 1 (tabulated value).
const PHI_AT_GAMMA_MIN: f64 = 0.022_750_131_948_179_21;

/// Mean of `log10 Tp[s]` (Rupakhety et al. 2011): `−2.87 + 0.47·Mw`.
#[must_use]
pub fn mean_log10_tp_s(mw: f64) -> f64 {
    LOG10_TP_INTERCEPT + LOG10_TP_PER_MW * mw
}

/// Mean of `log10 Vp[cm/s]` (Rupakhety et al. 2011):
/// `−5.17 + 1.98·M − 0.14·M² − 0.10·log10(R² + 0.56²)`, `M = min(Mw, 7)`, `R` in km.
#[must_use]
pub fn mean_log10_vp_cmps(mw: f64, r_km: f64) -> f64 {
    let m = mw.min(VP_LAW_MW_CAP);
    -5.17 + 1.98 * m
        - 0.14 * m * m
        - 0.10 * (r_km * r_km + VP_LAW_DEPTH_KM * VP_LAW_DEPTH_KM).log10()
}

/// An earthquake scenario for pulse generation: moment magnitude and distance.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PulseScenario {
    mw: f64,
    r_km: f64,
}

impl PulseScenario {
    /// Validates `0 < mw ≤ 10` (moment magnitude) and `r_km ≥ 0` (km, finite).
    pub fn new(mw: f64, r_km: f64) -> Result<Self, PulseError> {
        if !(mw > 0.0 && mw <= 10.0) {
            return Err(invalid("mw", mw, "moment magnitude must be in (0, 10]"));
        }
        if !(r_km.is_finite() && r_km >= 0.0) {
            return Err(invalid(
                "r_km",
                r_km,
                "distance must be a finite number >= 0 (km)",
            ));
        }
        Ok(PulseScenario { mw, r_km })
    }

    /// Moment magnitude Mw.
    #[must_use]
    pub fn mw(&self) -> f64 {
        self.mw
    }

    /// Distance R (km).
    #[must_use]
    pub fn r_km(&self) -> f64 {
        self.r_km
    }
}

/// One draw of pulse parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PulseParameters {
    /// Pulse period Tp = 1/fp (s).
    pub tp_s: f64,
    /// Peak ground velocity of the pulse Vp (m/s).
    pub vp_mps: f64,
    /// Oscillatory character γ (> 1).
    pub gamma: f64,
    /// Phase ν (rad, in [−π/2, π/2]).
    pub nu_rad: f64,
}

impl PulseParameters {
    /// The M&P pulse with these parameters (fp = 1/Tp, A solved so that max |v| = Vp).
    pub fn pulse(&self) -> Result<MpPulse, PulseError> {
        if !(self.tp_s.is_finite() && self.tp_s > 0.0) {
            return Err(invalid(
                "tp_s",
                self.tp_s,
                "must be a positive finite period (s)",
            ));
        }
        MpPulse::with_peak_velocity(self.vp_mps, 1.0 / self.tp_s, self.gamma, self.nu_rad)
    }
}

/// Maps one Latin-hypercube row `u` (4 values in (0, 1)) to parameters for `scenario`.
fn parameters_from_unit(scenario: &PulseScenario, u: &[f64]) -> PulseParameters {
    let z_tp = standard_normal_quantile(u[0]);
    let z_vp = standard_normal_quantile(u[1]);
    // Truncated normal by inversion: u ↦ Φ⁻¹(Φ(α) + u·(1 − Φ(α))), α = (1 − μ)/σ.
    let z_gamma = standard_normal_quantile(PHI_AT_GAMMA_MIN + u[2] * (1.0 - PHI_AT_GAMMA_MIN));
    // Rounding in Φ⁻¹ may land a hair below the bound; the model needs γ strictly above it.
    let gamma = (GAMMA_MEAN + GAMMA_SD * z_gamma).max(GAMMA_MIN_EXCLUSIVE.next_up());
    let log10_tp = mean_log10_tp_s(scenario.mw) + SIGMA_LOG10_TP * z_tp;
    let log10_vp_cmps = mean_log10_vp_cmps(scenario.mw, scenario.r_km) + SIGMA_LOG10_VP * z_vp;
    PulseParameters {
        tp_s: 10f64.powf(log10_tp),
        vp_mps: 10f64.powf(log10_vp_cmps) / 100.0,
        gamma,
        nu_rad: -FRAC_PI_2 + PI * u[3],
    }
}

/// `count` parameter draws for `scenario`, stratified by a `count × 4` Latin hypercube from
/// [`crate::lhs::rng_from_seed`]`(seed)` (columns: Tp, Vp, γ, ν). Same seed, same draws.
#[must_use]
pub fn sample_pulse_parameters(
    scenario: &PulseScenario,
    count: usize,
    seed: u64,
) -> Vec<PulseParameters> {
    let lhs = latin_hypercube(count, 4, &mut rng_from_seed(seed));
    lhs.samples()
        .map(|u| parameters_from_unit(scenario, u))
        .collect()
}

/// A drawn parameter set and its pulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampledPulse {
    /// The drawn parameters.
    pub parameters: PulseParameters,
    /// The pulse built from them (peak velocity = `parameters.vp_mps`).
    pub pulse: MpPulse,
}

/// [`sample_pulse_parameters`] followed by [`PulseParameters::pulse`] for each draw.
pub fn sample_pulses(
    scenario: &PulseScenario,
    count: usize,
    seed: u64,
) -> Result<Vec<SampledPulse>, PulseError> {
    sample_pulse_parameters(scenario, count, seed)
        .into_iter()
        .map(|parameters| {
            Ok(SampledPulse {
                parameters,
                pulse: parameters.pulse()?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Shapes covering γ near the lower bound, typical and large values, and phases of both
    /// signs (fp in Hz, γ, ν in rad).
    const SHAPES: [(f64, f64, f64); 6] = [
        (0.4, 1.8, 0.0),
        (0.4, 1.8, 1.2),
        (1.5, 1.05, -1.5),
        (0.1, 2.7, -0.4),
        (2.0, 4.0, FRAC_PI_2),
        (0.7, 1.0 + 1e-9, 0.3),
    ];

    /// Composite Simpson integral of `f` on [a, b] with `n` (even) panels.
    fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
        let h = (b - a) / n as f64;
        let mut sum = f(a) + f(b);
        for k in 1..n {
            let w = if k % 2 == 1 { 4.0 } else { 2.0 };
            sum += w * f(a + k as f64 * h);
        }
        sum * h / 3.0
    }

    /// max |v| over a uniform grid of `n` intervals on the pulse (brute force).
    fn brute_force_peak_velocity(pulse: &MpPulse, n: usize) -> f64 {
        let h = pulse.duration_s() / n as f64;
        (0..=n)
            .map(|i| pulse.velocity_mps(i as f64 * h).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn acceleration_matches_central_difference_of_velocity() {
        for &(fp, gamma, nu) in &SHAPES {
            let pulse = MpPulse::new(0.8, fp, gamma, nu).unwrap();
            let duration = pulse.duration_s();
            let scale = TAU * fp * pulse.amplitude_mps(); // bound on |a|·(1 + 1/γ)/... ~ ωA
                                                          // h = 1e-5·Tp: truncation h²/6·|v'''| ≈ 7e-10·ωA, rounding 1e-16·A/h ≈ 2e-12·ωA.
            let h = 1e-5 / fp;
            for k in 1..200 {
                let t = duration * k as f64 / 200.0;
                let numeric = (pulse.velocity_mps(t + h) - pulse.velocity_mps(t - h)) / (2.0 * h);
                let analytic = pulse.accel_mps2(t);
                assert!(
                    (numeric - analytic).abs() < 1e-8 * scale,
                    "fp={fp} gamma={gamma} nu={nu} t={t}: {analytic} vs {numeric}"
                );
            }
        }
    }

    #[test]
    fn displacement_matches_numerical_integral_of_velocity() {
        for &(fp, gamma, nu) in &SHAPES {
            let pulse = MpPulse::new(0.5, fp, gamma, nu).unwrap();
            let duration = pulse.duration_s();
            let scale = pulse.amplitude_mps() * duration;
            for &fraction in &[0.05, 0.25, 0.5, 0.61, 0.9, 1.0] {
                let t = fraction * duration;
                // 20 000 Simpson panels over ≤ 4 carrier periods: error ~ h⁴ω⁴/180 ≈ 1e-15
                // relative; the velocity is C¹ so Simpson's order is intact on [0, t].
                let numeric = simpson(|s| pulse.velocity_mps(s), 0.0, t, 20_000);
                let analytic = pulse.displacement_m(t);
                assert!(
                    (numeric - analytic).abs() < 1e-10 * scale,
                    "fp={fp} gamma={gamma} nu={nu} t={t}: {analytic} vs {numeric}"
                );
            }
            // Before the pulse: zero; after: the residual, constant.
            assert_eq!(pulse.displacement_m(-1.0), 0.0);
            assert_eq!(pulse.displacement_m(0.0), 0.0);
            let residual = pulse.displacement_m(duration);
            assert_eq!(pulse.residual_displacement_m(), residual);
            assert_eq!(pulse.displacement_m(duration + 10.0), residual);
        }
    }

    #[test]
    fn displacement_derivative_is_velocity() {
        let pulse = MpPulse::new(1.0, 0.5, 2.2, 0.7).unwrap();
        let h = 1e-5;
        for k in 1..50 {
            let t = pulse.duration_s() * k as f64 / 50.0;
            let numeric = (pulse.displacement_m(t + h) - pulse.displacement_m(t - h)) / (2.0 * h);
            // Truncation h²/6·|a'| ≈ 1e-10·A·ω²; rounding 1e-16·A·T/h ≈ 1e-10·A.
            assert!((numeric - pulse.velocity_mps(t)).abs() < 1e-8, "t={t}");
        }
    }

    #[test]
    fn zero_phase_pulse_peaks_at_amplitude_at_its_centre() {
        // ν = 0: |v| ≤ A·1·1 everywhere and v(t0) = A, so the peak is exactly A.
        let pulse = MpPulse::new(0.63, 0.8, 2.1, 0.0).unwrap();
        assert!((pulse.velocity_mps(pulse.center_time_s()) - 0.63).abs() < 1e-15);
        assert!((pulse.peak_velocity_mps() - 0.63).abs() < 1e-14);
    }

    #[test]
    fn peak_velocity_matches_brute_force_maximum() {
        for &(fp, gamma, nu) in &SHAPES {
            let pulse = MpPulse::new(1.3, fp, gamma, nu).unwrap();
            // 2e6 grid intervals: the grid maximum misses the true one by at most
            // |v''|·(h/2)²/2 ≤ A·(2πγ/2e6)²/8 ≈ 1e-11·A (γ ≤ 4), and never exceeds it.
            let brute = brute_force_peak_velocity(&pulse, 2_000_000);
            let peak = pulse.peak_velocity_mps();
            assert!(
                brute <= peak * (1.0 + 1e-14),
                "fp={fp} gamma={gamma} nu={nu}"
            );
            assert!(
                peak - brute < 1e-10 * 1.3,
                "fp={fp} gamma={gamma}: {peak} vs {brute}"
            );
        }
    }

    #[test]
    fn with_peak_velocity_gives_that_peak_velocity() {
        for &(fp, gamma, nu) in &SHAPES {
            let pulse = MpPulse::with_peak_velocity(0.42, fp, gamma, nu).unwrap();
            let brute = brute_force_peak_velocity(&pulse, 2_000_000);
            assert!(
                (brute - 0.42).abs() < 1e-10,
                "fp={fp} gamma={gamma} nu={nu}: {brute}"
            );
            assert!((pulse.peak_velocity_mps() - 0.42).abs() < 1e-14);
            if nu != 0.0 {
                // The M&P peak is below A when the carrier and envelope maxima differ.
                assert!(pulse.amplitude_mps() > 0.42);
            }
        }
    }

    #[test]
    fn pulse_is_zero_outside_and_continuous_at_its_ends() {
        for &(fp, gamma, nu) in &SHAPES {
            let pulse = MpPulse::new(1.0, fp, gamma, nu).unwrap();
            let duration = pulse.duration_s();
            let omega_a = TAU * fp;
            for &t in &[-5.0, -1e-12, duration * (1.0 + 1e-12), duration + 3.0] {
                assert_eq!(pulse.velocity_mps(t), 0.0, "t={t}");
                assert_eq!(pulse.accel_mps2(t), 0.0, "t={t}");
            }
            // At and just inside each end, v and a tend to 0 (v ~ δ², a ~ δ).
            for &t in &[0.0, duration] {
                assert!(pulse.velocity_mps(t).abs() < 1e-15, "v({t})");
                assert!(pulse.accel_mps2(t).abs() < 1e-14 * omega_a, "a({t})");
            }
            let delta = 1e-6 * duration;
            for &t in &[delta, duration - delta] {
                assert!(pulse.velocity_mps(t).abs() < 1e-9, "v({t})");
                assert!(pulse.accel_mps2(t).abs() < 1e-4 * omega_a, "a({t})");
            }
            // Displacement is continuous at the end.
            let d_end = pulse.displacement_m(duration);
            assert!((pulse.displacement_m(duration - delta) - d_end).abs() < 1e-12 * duration);
        }
    }

    #[test]
    fn invalid_parameters_are_rejected_by_name() {
        let name = |r: Result<MpPulse, PulseError>| match r {
            Err(PulseError::InvalidParameter { name, .. }) => name,
            other => panic!("expected an error, got {other:?}"),
        };
        assert_eq!(name(MpPulse::new(1.0, 1.0, 1.0, 0.0)), "gamma");
        assert_eq!(name(MpPulse::new(1.0, 1.0, 0.5, 0.0)), "gamma");
        assert_eq!(name(MpPulse::new(1.0, 1.0, f64::NAN, 0.0)), "gamma");
        assert_eq!(name(MpPulse::new(1.0, 1.0, 101.0, 0.0)), "gamma");
        assert_eq!(name(MpPulse::new(1.0, 0.0, 2.0, 0.0)), "fp_hz");
        assert_eq!(name(MpPulse::new(1.0, f64::INFINITY, 2.0, 0.0)), "fp_hz");
        assert_eq!(name(MpPulse::new(1.0, 1e-320, 2.0, 0.0)), "fp_hz");
        assert_eq!(name(MpPulse::new(-1.0, 1.0, 2.0, 0.0)), "amplitude_mps");
        assert_eq!(name(MpPulse::new(1.0, 1.0, 2.0, f64::NAN)), "nu_rad");
        assert_eq!(
            name(MpPulse::with_peak_velocity(0.0, 1.0, 2.0, 0.0)),
            "peak_velocity_mps"
        );
        let message = MpPulse::new(1.0, 1.0, 0.9, 0.0).unwrap_err().to_string();
        assert!(
            message.contains("gamma = 0.9") && message.contains("gamma > 1"),
            "{message}"
        );
    }

    #[test]
    fn record_samples_the_acceleration_through_the_end_of_the_pulse() {
        let pulse = MpPulse::new(0.5, 0.5, 2.0, 0.3).unwrap(); // duration exactly 4 s
        let record = pulse.to_record(0.01).unwrap();
        assert_eq!(record.len(), 401, "0..=400 samples, the last at t = 4 s");
        assert_eq!(record.dt_s, 0.01);
        for (i, &a) in record.horizontal_mps2.iter().enumerate() {
            assert_eq!(a, pulse.accel_mps2(i as f64 * 0.01));
        }
        // A duration that is not a multiple of dt: the last sample is past the end.
        let record = pulse.to_record(0.003).unwrap();
        assert_eq!(record.len(), 1335); // ceil(4/0.003) = 1334 intervals
        assert!(record.duration_s() >= pulse.duration_s());
        let padded = pulse.to_record_padded(0.01, 1.0).unwrap();
        assert_eq!(padded.len(), 501);
        assert!(padded.horizontal_mps2[401..].iter().all(|&a| a == 0.0));
    }

    #[test]
    fn record_rejects_bad_dt_without_panicking() {
        let pulse = MpPulse::new(0.5, 0.5, 2.0, 0.3).unwrap();
        assert!(matches!(
            pulse.to_record(0.0),
            Err(PulseError::InvalidParameter { name: "dt_s", .. })
        ));
        assert!(matches!(
            pulse.to_record(f64::NAN),
            Err(PulseError::InvalidParameter { name: "dt_s", .. })
        ));
        assert!(matches!(
            pulse.to_record(1e-12),
            Err(PulseError::TooManySamples { .. })
        ));
        assert!(pulse.to_record_padded(0.01, -1.0).is_err());
    }

    #[test]
    fn rupakhety_laws_match_hand_computed_values() {
        // log10 Tp = -2.87 + 0.47·7 = 0.42.
        assert!((mean_log10_tp_s(7.0) - 0.42).abs() < 1e-12);
        assert!((mean_log10_tp_s(8.5) - 1.125).abs() < 1e-12);
        // -5.17 + 1.98·7 - 0.14·49 - 0.10·log10(100.3136) = 1.629864018...
        assert!((mean_log10_vp_cmps(7.0, 10.0) - 1.629_864_018).abs() < 1e-8);
        // Mw 6.5, R 5 km: -5.17 + 12.87 - 5.915 - 0.10·log10(25.3136) = 1.644664609...
        assert!((mean_log10_vp_cmps(6.5, 5.0) - 1.644_664_609).abs() < 1e-8);
        // Saturation above Mw 7: only the distance matters.
        assert_eq!(mean_log10_vp_cmps(8.5, 10.0), mean_log10_vp_cmps(7.0, 10.0));
    }

    #[test]
    fn truncation_constant_is_phi_of_minus_two() {
        // Φ(-2) = 0.0227501319481792 (tabulated); (1 - 1.8)/0.4 = -2.
        assert!((standard_normal_quantile(PHI_AT_GAMMA_MIN) + 2.0).abs() < 1e-12);
        assert!(((GAMMA_MIN_EXCLUSIVE - GAMMA_MEAN) / GAMMA_SD + 2.0).abs() < 1e-12);
    }

    fn mean_and_sd(values: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
        let n = values.clone().count() as f64;
        let mean = values.clone().sum::<f64>() / n;
        let var = values.map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0);
        (mean, var.sqrt())
    }

    #[test]
    fn sampled_parameter_statistics_match_the_laws() {
        let scenario = PulseScenario::new(7.0, 10.0).unwrap();
        let n = 20_000;
        let draws = sample_pulse_parameters(&scenario, n, 2019);
        assert_eq!(draws.len(), n);
        // Tolerances: 4 iid standard errors, σ/√n for means and σ/√(2n) for standard
        // deviations (normal margins; the truncated γ has kurtosis ≈ 2.9, close enough).
        // Latin-hypercube stratification only shrinks these errors for monotone margins
        // (McKay et al. 1979), so 4 SE is conservative; at n = 20 000 the γ bounds (0.011,
        // 0.008) separate the truncated moments from the untruncated ones (Δ = 0.022, 0.023).
        let sqrt_n = (n as f64).sqrt();
        let check = |label: &str, values: Vec<f64>, mean: f64, sd: f64| {
            let (m, s) = mean_and_sd(values.iter().copied());
            assert!(
                (m - mean).abs() < 4.0 * sd / sqrt_n,
                "{label}: mean {m} vs {mean}"
            );
            assert!(
                (s - sd).abs() < 4.0 * sd / (2.0f64).sqrt() / sqrt_n,
                "{label}: sd {s} vs {sd}"
            );
        };
        check(
            "log10 Tp",
            draws.iter().map(|d| d.tp_s.log10()).collect(),
            0.42,
            0.18,
        );
        check(
            "log10 Vp[cm/s]",
            draws.iter().map(|d| (d.vp_mps * 100.0).log10()).collect(),
            1.629_864_018,
            0.16,
        );
        // N(1.8, 0.4) truncated below at 1 (α = -2): λ = φ(-2)/(1 - Φ(-2)),
        // mean = 1.8 + 0.4λ, sd = 0.4·sqrt(1 + αλ - λ²), φ(-2) = 0.05399096651318806.
        let lambda = 0.053_990_966_513_188_06 / (1.0 - 0.022_750_131_948_179_21);
        check(
            "gamma",
            draws.iter().map(|d| d.gamma).collect(),
            1.8 + 0.4 * lambda,
            0.4 * (1.0 - 2.0 * lambda - lambda * lambda).sqrt(),
        );
        // ν ~ U[-π/2, π/2]: mean 0, sd π/√12 (its sd-of-sd is smaller than a normal's).
        check(
            "nu",
            draws.iter().map(|d| d.nu_rad).collect(),
            0.0,
            PI / 12f64.sqrt(),
        );
        assert!(draws.iter().all(|d| d.gamma > 1.0));
        assert!(draws.iter().all(|d| d.nu_rad.abs() <= FRAC_PI_2));
    }

    #[test]
    fn vp_saturates_above_magnitude_seven_but_tp_does_not() {
        let at = |mw| sample_pulse_parameters(&PulseScenario::new(mw, 10.0).unwrap(), 50, 3);
        let (m7, m8) = (at(7.0), at(8.0));
        for (a, b) in m7.iter().zip(&m8) {
            assert_eq!(a.vp_mps, b.vp_mps);
            // Same quantile, mean shifted by 0.47 in log10 Tp.
            assert!(((b.tp_s / a.tp_s).log10() - 0.47).abs() < 1e-12);
        }
    }

    #[test]
    fn same_seed_same_pulses_different_seed_different() {
        let scenario = PulseScenario::new(6.5, 5.0).unwrap();
        let a = sample_pulses(&scenario, 30, 1).unwrap();
        assert_eq!(a, sample_pulses(&scenario, 30, 1).unwrap());
        let b = sample_pulses(&scenario, 30, 2).unwrap();
        assert!(a.iter().zip(&b).all(|(x, y)| x.parameters != y.parameters));
    }

    #[test]
    fn sampled_pulses_peak_at_their_drawn_vp() {
        let scenario = PulseScenario::new(7.5, 15.0).unwrap();
        for sampled in sample_pulses(&scenario, 25, 77).unwrap() {
            let brute = brute_force_peak_velocity(&sampled.pulse, 400_000);
            let vp = sampled.parameters.vp_mps;
            // 4e5 intervals on ≤ ~5 half-cycles: grid error ≤ (2π·2.5/4e5)²/8 ≈ 1.5e-10·Vp.
            assert!((brute - vp).abs() < 1e-9 * vp, "{brute} vs {vp}");
            assert!((sampled.pulse.period_s() - sampled.parameters.tp_s).abs() < 1e-12);
        }
    }

    #[test]
    fn invalid_scenarios_are_rejected() {
        assert!(PulseScenario::new(0.0, 10.0).is_err());
        assert!(PulseScenario::new(f64::NAN, 10.0).is_err());
        assert!(PulseScenario::new(11.0, 10.0).is_err());
        assert!(PulseScenario::new(7.0, -1.0).is_err());
        assert!(PulseScenario::new(7.0, f64::INFINITY).is_err());
        assert!(PulseScenario::new(7.0, 0.0).is_ok());
    }
}
