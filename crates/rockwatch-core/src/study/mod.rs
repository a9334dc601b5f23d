//! The intensity-measure study of the seed paper (Knickerbocker & Wittich 2019, "INTENSITY
//! MEASURE STUDY"), reproduced and extended: which ground-motion IMs predict the sliding and
//! rocking demand of a freestanding block best (efficiency, R²) and most independently of
//! magnitude and distance (sufficiency).
//!
//! Pipeline (pure; the writers of its reports and plots are in the shell, `rockwatch::study`):
//! 1. [`run_study`]: for each Mw–R pair, `pulses_per_pair` Mavroeidis–Papageorgiou pulses by
//!    Latin hypercube ([`crate::pulse::sample_pulses`], seed derived from the study seed and
//!    the pair's index by [`crate::lhs::derived_seed`]); for every pulse the 37 study IMs
//!    ([`crate::ims::study_ims`]) of the pulse followed by `im_pad_s` of zeros, and the response
//!    of every block ([`crate::simulate::simulate`], the pulse alone followed by `t_extra_s` of
//!    free vibration). Pulses run in parallel (rayon); results are collected in pulse order, so
//!    they are bit-for-bit identical whatever the number of threads.
//! 2. [`analyse`]: for every block, the exclusion rule, then regressions DM ~ IM (linear and
//!    log–log, overall and per pair), the sufficiency tests, vector IMs and the fragility of
//!    overturning.
//!
//! Units: slide in m, rotation in rad, IMs in their SI units ([`crate::ims::Im::unit`]).

mod analysis;
mod config;
pub mod fragility;

pub mod regression;
mod run;

use crate::dynamics::ParamError;
use crate::ims::ImError;
use crate::pulse::PulseError;

/// Moment magnitudes of the seed's study.
pub const DEFAULT_MAGNITUDES: [f64; 5] = [6.5, 7.0, 7.5, 8.0, 8.5];
/// Rupture distances of the seed's study (km).
pub const DEFAULT_DISTANCES_KM: [f64; 3] = [5.0, 10.0, 15.0];
/// Pulses per Mw–R pair in the seed's study.
pub const DEFAULT_PULSES_PER_PAIR: usize = 250;
/// Sampling interval of the pulse records (s).
pub const DEFAULT_DT_S: f64 = 0.005;
/// Zeros appended to each pulse before its IMs are computed (s): an oscillator of period
/// T ≤ 3 s (the longest spectral period of the study IMs) reaches its free-vibration peak
/// within T/2 ≤ 1.5 s after the pulse ends.
pub const DEFAULT_IM_PAD_S: f64 = 2.0;
/// Free vibration simulated after each pulse (s), as `SimulationOptions::t_extra_s`.
pub const DEFAULT_T_EXTRA_S: f64 = 10.0;
/// Default exclusion threshold on max |slide| (m): larger slides are "excessive".
pub const DEFAULT_MAX_SLIDE_M: f64 = 1.0;
/// Smallest max |slide| counted as a response (m).
pub const DEFAULT_SLIDE_FLOOR_M: f64 = 1e-3;
/// Smallest max |θ| counted as a response (rad).
pub const DEFAULT_THETA_FLOOR_RAD: f64 = 1e-3;
/// Vector IMs reported per block (best by linear R²), besides the named pairs.
pub const DEFAULT_VECTOR_TOP: usize = 10;

/// Everything that can go wrong in a study (invalid configuration or input).
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// A configuration value is invalid.
    #[error("invalid study configuration: {0}")]
    Config(String),
    /// A `--block` specification could not be parsed.
    #[error("invalid block specification {spec:?}: {problem}")]
    BlockSpec { spec: String, problem: String },
    /// Invalid block parameters.
    #[error("block {name:?}: {source}")]
    Block { name: String, source: ParamError },
    /// A pulse could not be generated or sampled.
    #[error("pulse generation for Mw {mw}, R {r_km} km: {source}")]
    Pulse {
        mw: f64,
        r_km: f64,
        source: PulseError,
    },
    /// The IMs of a pulse could not be computed.
    #[error("intensity measures of pulse {id}: {source}")]
    Ims { id: usize, source: ImError },
}

pub use analysis::{
    analyse, analyse_block, categorize, sort_desc_by, BlockAnalysis, Category, CategoryCounts,
    FragilityAnalysis, ImScore, StudyAnalysis, VectorScore,
};
pub use config::{DemandMeasure, ExclusionRule, Pair, StudyBlock, StudyConfig};
pub use run::{run_study, BlockResponse, PulseCase, ResponseStatus, StudyData};
