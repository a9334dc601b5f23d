//! Ground-motion intensity measures (IMs), offline (whole record) and running (streaming).
//!
//! Definitions follow `spec/intensity-measures.md` exactly; in short (`a_i` in m/s²,
//! `t_i = i·dt`, the record used as given: no padding, no mean removal, no filtering; every
//! time integral is the trapezoidal rule on the samples; cumulative integrals start at 0;
//! g = 9.80665 m/s²):
//!
//! | name | definition | unit |
//! |---|---|---|
//! | PGA (= PHA) | `max |a_i|` | m/s² |
//! | PGV (= PHV), PGD (= PHD) | peaks of `|v|`, `|d|`, v and d cumulative trapezoids from 0 | m/s, m |
//! | CAV | `∫|a|dt` | m/s |
//! | Arias `Ia` | `π/(2g)·∫a²dt` | m/s |
//! | t5, t75, t95 | first time the Husid curve reaches 5/75/95 %, linear interpolation | s |
//! | D5-75, D5-95 | `t75 − t5`, `t95 − t5` | s |
//! | a_rms | `sqrt(0.90·∫a²dt / D5-95)` | m/s² |
//! | Ic | `a_rms^1.5·sqrt(D5-95)` | m^1.5·s^-2.5 |
//! | SMA | 3rd-largest absolute half-cycle peak (0 with fewer than 3 half-cycles) | m/s² |
//! | SA(T), PSV(T), SV(T) | 5 %-damped, exact piecewise-linear SDOF ([`spectrum`]) | m/s², m/s, m/s |
//! | ASI, SI, VSI over `[T1, T2]` | `∫SA dT`, `∫PSV dT`, `∫SV dT`, trapezoid on the 0.01 s grid | m/s, m, m |
//! | PGV/PGA | ratio (0 when PGA = 0) | s |
//! | EDA | peak of the record low-pass filtered at 9 Hz (see [`offline::low_pass_zero_phase`]) | m/s² |
//! | Tp | period of the peak of the 5 %-damped SA on the 0.10–3.00 s grid | s |
//! | EPV | mean 5 %-damped PSV over 0.80–1.20 s on the grid, divided by 2.5 (ATC 3-06) | m/s |
//!
//! Signs: IMs are peaks or integrals of magnitudes and are ≥ 0 whatever the sign convention
//! of the input component.
//!
//! [`Im`] names one IM everywhere (its spellings, unit, scaling and OpenQuake IMT: [`im`]);
//! [`offline::compute_ims`] gives every IM of a whole record; [`study_ims`] the values of the 37
//! IMs of the seed's study ([`STUDY_IMS`]); [`running::RunningIms`] keeps the running values of one
//! component sample by sample, equal to the offline values over the samples received so far.

pub mod baseline;
pub mod im;
pub mod offline;
pub mod rotd;
pub mod running;
pub mod spectrum;

pub use im::{Im, ImNameError, ImUnit, ImUnitError, KNOWN_IMS, STUDY_IMS, STUDY_IM_COUNT};
pub use offline::{compute_ims, low_pass_zero_phase, ImOptions, ImSet, DEFAULT_SA_PERIODS_S};
pub use running::{RunningConfig, RunningIms};
pub use spectrum::{
    response, response_spectrum, spectral_intensities, NigamJennings, PeriodRange,
    SpectralIntensities, SpectralValues, DEFAULT_DAMPING, STUDY_RANGES,
};

/// Problems with the input of an IM computation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ImError {
    /// The record has no samples.
    #[error("the record has no samples")]
    Empty,
    /// The sampling interval is not a positive finite number.
    #[error("sampling interval must be a positive finite number of seconds, got {0}")]
    BadDt(f64),
    /// An oscillator period is not a positive finite number up to 100 s.
    #[error("period must be a positive number of seconds up to 100, got {0}")]
    BadPeriod(f64),
    /// The damping ratio is outside `[0, 1)`.
    #[error("damping ratio must be in [0, 1), got {0}")]
    BadDamping(f64),
    /// A period range is malformed.
    #[error("bad period range {0}")]
    BadRange(String),
    /// The low-pass cutoff frequency is not a positive finite number.
    #[error("low-pass cutoff must be a positive finite frequency, got {0} Hz")]
    BadCutoff(f64),
    /// A sample is NaN or infinite.
    #[error("sample {index} is not finite ({value})")]
    NonFinite { index: usize, value: f64 },
}

/// Husid fractions of the significant-duration times t5, t75 and t95.
pub const HUSID_FRACTIONS: [f64; 3] = [0.05, 0.75, 0.95];

/// The 37 IMs of the seed's study as `(IM, value in SI units)`, in the order of [`STUDY_IMS`]
/// (units [`Im::unit`]): PHA, PHV, PHD, SMA, EDA, Tp, PGV/PGA, D5-95, a_rms, Ic, Arias, CAV,
/// EPV, then SI, ASI and VSI over the eight study ranges.
#[must_use]
pub fn study_ims(ims: &ImSet) -> [(Im, f64); STUDY_IM_COUNT] {
    let scalars = [
        ims.pga_mps2,
        ims.pgv_mps,
        ims.pgd_m,
        ims.sma_mps2,
        ims.eda_mps2,
        ims.tp_s,
        ims.pgv_pga_s,
        ims.d5_95_s,
        ims.a_rms_mps2,
        ims.ic,
        ims.arias_mps,
        ims.cav_mps,
        ims.epv_mps,
    ];
    let mut values = [0.0; STUDY_IM_COUNT];
    values[..13].copy_from_slice(&scalars);
    for (j, si) in ims.study_intensities.iter().enumerate() {
        values[13 + j] = si.si_m;
        values[21 + j] = si.asi_mps;
        values[29 + j] = si.vsi_m;
    }
    std::array::from_fn(|i| (STUDY_IMS[i], values[i]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn study_names_match_ranges() {
        for (j, range) in STUDY_RANGES.iter().enumerate() {
            assert_eq!(
                STUDY_IMS[13 + j].study_name(),
                format!("si_{}", range.label())
            );
            assert_eq!(
                STUDY_IMS[21 + j].study_name(),
                format!("asi_{}", range.label())
            );
            assert_eq!(
                STUDY_IMS[29 + j].study_name(),
                format!("vsi_{}", range.label())
            );
        }
    }
}
