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
//! Units: slide in m, rotation in rad, IMs in the SI units of [`STUDY_IM_UNITS`].

pub mod fragility;

pub mod regression;

use rayon::prelude::*;

use crate::dynamics::{BlockParams, Mode, ParamError};
use crate::fragility::fit::FitError;
pub use crate::ims::STUDY_IM_UNITS;
use crate::ims::{compute_ims, study_ims, ImError, ImOptions, STUDY_IM_COUNT, STUDY_IM_NAMES};
use crate::lhs::derived_seed;
use crate::pulse::{sample_pulses, PulseError, PulseParameters, PulseScenario};
use crate::simulate::{simulate, SimulationOptions, Status};
use fragility::{fit_lognormal, LognormalFragility};
use regression::{
    linear_fit, log_log_fit, multiple_fit, residual_dependence_p, residuals, LinearFit, MultipleFit,
};

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

/// The demand measure (DM) regressed for a block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DemandMeasure {
    /// max |u|, the largest slip of the contact point relative to the ground (m).
    Slide,
    /// max |θ|, the largest rotation (rad).
    Theta,
}

impl DemandMeasure {
    /// Column name (with unit) in the CSV outputs.
    #[must_use]
    pub fn column(self) -> &'static str {
        match self {
            DemandMeasure::Slide => "max_abs_slide_m",
            DemandMeasure::Theta => "max_abs_theta_rad",
        }
    }

    /// Axis label for people.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            DemandMeasure::Slide => "max |slide| (m)",
            DemandMeasure::Theta => "max |θ| (rad)",
        }
    }

    /// Short name (`slide` or `theta`).
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            DemandMeasure::Slide => "slide",
            DemandMeasure::Theta => "theta",
        }
    }

    /// The DM of a response (m or rad).
    #[must_use]
    pub fn of(self, r: &BlockResponse) -> f64 {
        match self {
            DemandMeasure::Slide => r.max_abs_slide_m,
            DemandMeasure::Theta => r.max_abs_theta_rad,
        }
    }
}

/// A block of the study with the DM regressed for it.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyBlock {
    /// Name used in file names, tables and JSON (letters, digits, `-`, `_`).
    pub name: String,
    /// Geometry and friction.
    pub params: BlockParams,
    /// The demand measure of its regressions.
    pub dm: DemandMeasure,
}

impl StudyBlock {
    /// The seed's sliding block: α = 45°, μs = μk = 0.1, DM = max |slide|. The seed gives no
    /// size; R = 1.12 m is the block of its Figure 2 (pure sliding).
    pub fn seed_sliding() -> Result<Self, StudyError> {
        Self::from_r_alpha(
            "sliding",
            1.12,
            45f64.to_radians(),
            0.1,
            0.1,
            DemandMeasure::Slide,
        )
    }

    /// The seed's rocking block: α = 11.31°, μs = 1.5, μk = 1.0, DM = max |θ|. The seed gives
    /// no size; R = 3.29 m is the block of its Figure 2 (pure rocking).
    pub fn seed_rocking() -> Result<Self, StudyError> {
        Self::from_r_alpha(
            "rocking",
            3.29,
            11.31f64.to_radians(),
            1.5,
            1.0,
            DemandMeasure::Theta,
        )
    }

    fn from_r_alpha(
        name: &str,
        r_m: f64,
        alpha_rad: f64,
        mu_s: f64,
        mu_k: f64,
        dm: DemandMeasure,
    ) -> Result<Self, StudyError> {
        let params =
            BlockParams::from_r_alpha(r_m, alpha_rad, mu_s, mu_k, None).map_err(|source| {
                StudyError::Block {
                    name: name.to_string(),
                    source,
                }
            })?;
        Ok(StudyBlock {
            name: name.to_string(),
            params,
            dm,
        })
    }

    /// Parses `NAME:key=value,key=value,…`. Keys: `r` (half-diagonal, m) with `alpha-deg` or
    /// `alpha` (rad), or `width` and `height` (m); `mu-s`, `mu-k` (μk defaults to μs);
    /// `restitution` (optional, in [0, 1]); `dm` = `slide` or `theta` (default: `theta` when
    /// the block can rock before it slides, μs > tan α, else `slide`).
    /// Example: `slide-rock:r=1.5,alpha-deg=10,mu-s=0.2,mu-k=0.19`.
    pub fn parse_spec(spec: &str) -> Result<Self, StudyError> {
        let bad = |problem: String| StudyError::BlockSpec {
            spec: spec.to_string(),
            problem,
        };
        let (name, rest) = spec
            .split_once(':')
            .ok_or_else(|| bad("expected NAME:key=value,... ".to_string()))?;
        let name = name.trim();
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(bad(format!(
                "block name {name:?} must be non-empty letters, digits, '-' or '_'"
            )));
        }
        let mut r = None;
        let mut alpha_rad = None;
        let mut width = None;
        let mut height = None;
        let mut mu_s = None;
        let mut mu_k = None;
        let mut restitution = None;
        let mut dm = None;
        for item in rest.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| bad(format!("{item:?} is not key=value")))?;
            let (key, value) = (key.trim(), value.trim());
            if key == "dm" {
                dm = Some(match value {
                    "slide" => DemandMeasure::Slide,
                    "theta" => DemandMeasure::Theta,
                    _ => return Err(bad(format!("dm must be slide or theta, got {value:?}"))),
                });
                continue;
            }
            let number: f64 = value
                .parse()
                .map_err(|_| bad(format!("{key} = {value:?} is not a number")))?;
            let slot = match key {
                "r" => &mut r,
                "alpha" => &mut alpha_rad,
                "alpha-deg" => {
                    alpha_rad = Some(number.to_radians());
                    continue;
                }
                "width" => &mut width,
                "height" => &mut height,
                "mu-s" => &mut mu_s,
                "mu-k" => &mut mu_k,
                "restitution" => &mut restitution,
                _ => {
                    return Err(bad(format!(
                        "unknown key {key:?} (known: r, alpha, alpha-deg, width, height, \
                         mu-s, mu-k, restitution, dm)"
                    )))
                }
            };
            *slot = Some(number);
        }
        let mu_s = mu_s.ok_or_else(|| bad("mu-s is required".to_string()))?;
        let mu_k = mu_k.unwrap_or(mu_s);
        let result = match (r, alpha_rad, width, height) {
            (Some(r), Some(a), None, None) => {
                BlockParams::from_r_alpha(r, a, mu_s, mu_k, restitution)
            }
            (None, None, Some(w), Some(h)) => {
                BlockParams::from_width_height(w, h, mu_s, mu_k, restitution)
            }
            _ => {
                return Err(bad(
                    "give either r with alpha (or alpha-deg), or width with height".to_string(),
                ))
            }
        };
        let params = result.map_err(|source| StudyError::Block {
            name: name.to_string(),
            source,
        })?;
        let dm = dm.unwrap_or(
            if params.mu_s > params.plus.tan_alpha.min(params.minus.tan_alpha) {
                DemandMeasure::Theta
            } else {
                DemandMeasure::Slide
            },
        );
        Ok(StudyBlock {
            name: name.to_string(),
            params,
            dm,
        })
    }
}

/// Which responses are left out of the regressions (the seed drops "excessive" responses).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ExclusionRule {
    /// Exclude runs in which the block overturned (default true).
    pub exclude_overturned: bool,
    /// Exclude runs with max |slide| above this (m); `f64::INFINITY` disables it.
    pub max_slide_m: f64,
    /// Exclude runs with max |θ| above this (rad); `f64::INFINITY` disables it.
    pub max_theta_rad: f64,
}

impl Default for ExclusionRule {
    fn default() -> Self {
        ExclusionRule {
            exclude_overturned: true,
            max_slide_m: DEFAULT_MAX_SLIDE_M,
            max_theta_rad: f64::INFINITY,
        }
    }
}

/// The configuration of a study.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyConfig {
    /// Moment magnitudes Mw.
    pub magnitudes: Vec<f64>,
    /// Rupture distances R (km).
    pub distances_km: Vec<f64>,
    /// Pulses per Mw–R pair.
    pub pulses_per_pair: usize,
    /// Seed of the whole study.
    pub seed: u64,
    /// Sampling interval of the pulse records (s).
    pub dt_s: f64,
    /// Zeros appended to each pulse for its IMs (s).
    pub im_pad_s: f64,
    /// Free vibration simulated after each pulse (s).
    pub t_extra_s: f64,
    /// The blocks.
    pub blocks: Vec<StudyBlock>,
    /// Exclusion rule of the regressions.
    pub exclusion: ExclusionRule,
    /// Smallest max |slide| counted as a response (m): below it, "no response".
    pub slide_floor_m: f64,
    /// Smallest max |θ| counted as a response (rad).
    pub theta_floor_rad: f64,
    /// Number of best vector IMs reported per block.
    pub vector_top: usize,
    /// IM of the fragility curves (`None`: the IM of largest likelihood).
    pub fragility_im: Option<String>,
}

impl StudyConfig {
    /// The seed's study: 5 magnitudes × 3 distances × 250 pulses, its sliding and rocking
    /// blocks, and this crate's defaults for everything the seed does not state.
    pub fn seed_default() -> Result<Self, StudyError> {
        Ok(StudyConfig {
            magnitudes: DEFAULT_MAGNITUDES.to_vec(),
            distances_km: DEFAULT_DISTANCES_KM.to_vec(),
            pulses_per_pair: DEFAULT_PULSES_PER_PAIR,
            seed: 1,
            dt_s: DEFAULT_DT_S,
            im_pad_s: DEFAULT_IM_PAD_S,
            t_extra_s: DEFAULT_T_EXTRA_S,
            blocks: vec![StudyBlock::seed_sliding()?, StudyBlock::seed_rocking()?],
            exclusion: ExclusionRule::default(),
            slide_floor_m: DEFAULT_SLIDE_FLOOR_M,
            theta_floor_rad: DEFAULT_THETA_FLOOR_RAD,
            vector_top: DEFAULT_VECTOR_TOP,
            fragility_im: None,
        })
    }

    /// The Mw–R pairs, magnitude-major (all distances of the first magnitude first).
    #[must_use]
    pub fn pairs(&self) -> Vec<Pair> {
        self.magnitudes
            .iter()
            .flat_map(|&mw| self.distances_km.iter().map(move |&r_km| Pair { mw, r_km }))
            .collect()
    }

    /// The response floor of a DM (m or rad).
    #[must_use]
    pub fn floor(&self, dm: DemandMeasure) -> f64 {
        match dm {
            DemandMeasure::Slide => self.slide_floor_m,
            DemandMeasure::Theta => self.theta_floor_rad,
        }
    }

    /// Checks every value (counts, finiteness, unique block names, known fragility IM).
    pub fn validate(&self) -> Result<(), StudyError> {
        let bad = |m: String| Err(StudyError::Config(m));
        if self.magnitudes.is_empty() || self.distances_km.is_empty() {
            return bad("at least one magnitude and one distance are needed".into());
        }
        if self.pulses_per_pair == 0 || self.pulses_per_pair > 1_000_000 {
            return bad(format!(
                "pulses per pair must be in 1..=1000000, got {}",
                self.pulses_per_pair
            ));
        }
        if !(self.dt_s.is_finite() && self.dt_s > 0.0 && self.dt_s <= 0.1) {
            return bad(format!("dt must be in (0, 0.1] s, got {}", self.dt_s));
        }
        for (name, v) in [("im pad", self.im_pad_s), ("t_extra", self.t_extra_s)] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(format!(
                    "{name} must be a finite number of seconds >= 0, got {v}"
                ));
            }
        }
        for (name, v) in [
            ("slide floor", self.slide_floor_m),
            ("theta floor", self.theta_floor_rad),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return bad(format!("{name} must be a positive finite number, got {v}"));
            }
        }
        for (name, v) in [
            ("max slide", self.exclusion.max_slide_m),
            ("max theta", self.exclusion.max_theta_rad),
        ] {
            if v.is_nan() || v <= 0.0 {
                return bad(format!("{name} must be > 0 (or inf to disable), got {v}"));
            }
        }
        if self.blocks.is_empty() {
            return bad("no blocks to study".into());
        }
        for (i, b) in self.blocks.iter().enumerate() {
            if self.blocks[..i].iter().any(|o| o.name == b.name) {
                return bad(format!("two blocks are named {:?}", b.name));
            }
        }
        if let Some(im) = &self.fragility_im {
            if !STUDY_IM_NAMES.contains(&im.as_str()) {
                return bad(format!("unknown fragility IM {im:?}"));
            }
        }
        for pair in self.pairs() {
            PulseScenario::new(pair.mw, pair.r_km).map_err(|source| StudyError::Pulse {
                mw: pair.mw,
                r_km: pair.r_km,
                source,
            })?;
        }
        Ok(())
    }
}

/// A magnitude–distance pair.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Pair {
    /// Moment magnitude.
    pub mw: f64,
    /// Rupture distance (km).
    pub r_km: f64,
}

impl Pair {
    /// Label in the seed's style: `M6.5-R10`, `M7-R5`.
    #[must_use]
    pub fn label(&self) -> String {
        format!("M{}-R{}", self.mw, self.r_km)
    }
}

/// One pulse of the study and its IMs.
#[derive(Debug, Clone, PartialEq)]
pub struct PulseCase {
    /// 1-based id in study order (pair-major).
    pub id: usize,
    /// Index into [`StudyConfig::pairs`].
    pub pair_index: usize,
    /// Moment magnitude.
    pub mw: f64,
    /// Rupture distance (km).
    pub r_km: f64,
    /// The drawn pulse parameters.
    pub parameters: PulseParameters,
    /// M&P amplitude A (m/s).
    pub amplitude_mps: f64,
    /// Pulse duration γ·Tp (s).
    pub duration_s: f64,
    /// The 37 study IMs in the order of [`STUDY_IM_NAMES`] (units [`STUDY_IM_UNITS`]).
    pub ims: [f64; STUDY_IM_COUNT],
}

/// How a block's simulation ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ResponseStatus {
    /// Standing at the end.
    Ok,
    /// Overturned.
    Overturned,
    /// Lost contact without overturning (run stopped).
    Flight,
    /// The simulation failed (reported in `error`).
    Failed,
}

impl ResponseStatus {
    /// Name in the outputs.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            ResponseStatus::Ok => "ok",
            ResponseStatus::Overturned => "overturned",
            ResponseStatus::Flight => "flight",
            ResponseStatus::Failed => "failed",
        }
    }
}

/// The response of one block to one pulse.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockResponse {
    /// How the run ended.
    pub status: ResponseStatus,
    /// max |u| before any overturn (m).
    pub max_abs_slide_m: f64,
    /// max |θ| before any overturn (rad).
    pub max_abs_theta_rad: f64,
    /// Whether |θ| exceeded α at some time (even if the block recovered).
    pub exceeded_alpha: bool,
    /// Moving modes visited, in order of first visit (empty: the block stayed at rest).
    pub modes: Vec<Mode>,
    /// The simulation error, if it failed.
    pub error: Option<String>,
}

impl BlockResponse {
    /// The modes visited joined by `+` (`"rest"` if none), e.g. `"slide+slide-rock"`.
    #[must_use]
    pub fn modes_label(&self) -> String {
        if self.modes.is_empty() {
            "rest".to_string()
        } else {
            self.modes
                .iter()
                .map(|m| m.as_str())
                .collect::<Vec<_>>()
                .join("+")
        }
    }
}

/// Pulses, IMs and responses of a study.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyData {
    /// The Mw–R pairs ([`StudyConfig::pairs`]).
    pub pairs: Vec<Pair>,
    /// All pulses, pair-major.
    pub cases: Vec<PulseCase>,
    /// `responses[case][block]`, blocks in the order of [`StudyConfig::blocks`].
    pub responses: Vec<Vec<BlockResponse>>,
}

fn respond(
    block: &StudyBlock,
    record: &crate::record::Record,
    options: &SimulationOptions,
) -> BlockResponse {
    match simulate(block.params, record, options) {
        Ok(sim) => {
            let s = sim.summary;
            let mut modes: Vec<Mode> = Vec::new();
            for &(_, m) in &s.modes {
                if m != Mode::Rest && !modes.contains(&m) {
                    modes.push(m);
                }
            }
            BlockResponse {
                status: match s.status {
                    Status::Ok => ResponseStatus::Ok,
                    Status::Overturned => ResponseStatus::Overturned,
                    Status::Flight => ResponseStatus::Flight,
                },
                max_abs_slide_m: s.max_abs_slide,
                max_abs_theta_rad: s.max_abs_theta,
                exceeded_alpha: s.exceeded_alpha,
                modes,
                error: None,
            }
        }
        Err(e) => BlockResponse {
            status: ResponseStatus::Failed,
            max_abs_slide_m: f64::NAN,
            max_abs_theta_rad: f64::NAN,
            exceeded_alpha: false,
            modes: Vec::new(),
            error: Some(e.to_string()),
        },
    }
}

/// Generates the pulses, computes their IMs and simulates every block, in parallel on the
/// current rayon pool. `progress` is called once per finished pulse (from any thread).
pub fn run_study(
    config: &StudyConfig,
    progress: &(dyn Fn() + Sync),
) -> Result<StudyData, StudyError> {
    config.validate()?;
    let pairs = config.pairs();
    let mut drawn = Vec::with_capacity(pairs.len() * config.pulses_per_pair);
    for (pair_index, pair) in pairs.iter().enumerate() {
        let pulse_error = |source| StudyError::Pulse {
            mw: pair.mw,
            r_km: pair.r_km,
            source,
        };
        let scenario = PulseScenario::new(pair.mw, pair.r_km).map_err(pulse_error)?;
        let sampled = sample_pulses(
            &scenario,
            config.pulses_per_pair,
            derived_seed(config.seed, pair_index),
        )
        .map_err(pulse_error)?;
        drawn.extend(sampled.into_iter().map(|s| (pair_index, s)));
    }
    let im_options = ImOptions::default();
    let sim_options = SimulationOptions {
        t_extra_s: config.t_extra_s,
        ..SimulationOptions::default()
    };
    let results: Result<Vec<(PulseCase, Vec<BlockResponse>)>, StudyError> = drawn
        .par_iter()
        .enumerate()
        .map(|(index, (pair_index, sampled))| {
            let id = index + 1;
            let pair = pairs[*pair_index];
            let pulse_error = |source| StudyError::Pulse {
                mw: pair.mw,
                r_km: pair.r_km,
                source,
            };
            let padded = sampled
                .pulse
                .to_record_padded(config.dt_s, config.im_pad_s)
                .map_err(pulse_error)?;
            let im_set = compute_ims(&padded.horizontal_mps2, config.dt_s, &im_options)
                .map_err(|source| StudyError::Ims { id, source })?;
            let ims = study_ims(&im_set).map(|(_, v)| v);
            let record = sampled.pulse.to_record(config.dt_s).map_err(pulse_error)?;
            let responses = config
                .blocks
                .iter()
                .map(|b| respond(b, &record, &sim_options))
                .collect();
            progress();
            Ok((
                PulseCase {
                    id,
                    pair_index: *pair_index,
                    mw: pair.mw,
                    r_km: pair.r_km,
                    parameters: sampled.parameters,
                    amplitude_mps: sampled.pulse.amplitude_mps(),
                    duration_s: sampled.pulse.duration_s(),
                    ims,
                },
                responses,
            ))
        })
        .collect();
    let (cases, responses) = results?.into_iter().unzip();
    Ok(StudyData {
        pairs,
        cases,
        responses,
    })
}

/// Why a run is left out of the regressions (or `Used`), and how it is drawn in the plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Category {
    /// Used, DM ≥ the response floor.
    Responding,
    /// Used, DM below the response floor (in the linear regressions, not the log–log ones).
    NoResponse,
    /// Excluded: overturned.
    Overturned,
    /// Excluded: flight.
    Flight,
    /// Excluded: the simulation failed.
    Failed,
    /// Excluded: max |slide| above the threshold.
    SlideAbove,
    /// Excluded: max |θ| above the threshold.
    ThetaAbove,
}

impl Category {
    /// Whether the run enters the regressions.
    #[must_use]
    pub fn is_used(self) -> bool {
        matches!(self, Category::Responding | Category::NoResponse)
    }

    /// Name in the outputs (`responding`, `no-response`, …).
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Category::Responding => "responding",
            Category::NoResponse => "no-response",
            Category::Overturned => "overturned",
            Category::Flight => "flight",
            Category::Failed => "failed",
            Category::SlideAbove => "slide-above-max",
            Category::ThetaAbove => "theta-above-max",
        }
    }
}

/// Classifies one response under the exclusion rule and the response floor of `dm`.
/// Order of the tests: failed, overturned, flight, slide above, θ above, then used.
#[must_use]
pub fn categorize(r: &BlockResponse, dm: DemandMeasure, config: &StudyConfig) -> Category {
    let rule = &config.exclusion;
    match r.status {
        ResponseStatus::Failed => return Category::Failed,
        ResponseStatus::Overturned if rule.exclude_overturned => return Category::Overturned,
        ResponseStatus::Flight => return Category::Flight,
        _ => {}
    }
    if r.max_abs_slide_m > rule.max_slide_m {
        Category::SlideAbove
    } else if r.max_abs_theta_rad > rule.max_theta_rad {
        Category::ThetaAbove
    } else if dm.of(r) >= config.floor(dm) {
        Category::Responding
    } else {
        Category::NoResponse
    }
}

/// Counts of the runs of one block by category.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct CategoryCounts {
    pub responding: usize,
    pub no_response: usize,
    pub overturned: usize,
    pub flight: usize,
    pub failed: usize,
    pub slide_above_max: usize,
    pub theta_above_max: usize,
}

impl CategoryCounts {
    /// Runs used in the regressions.
    #[must_use]
    pub fn used(&self) -> usize {
        self.responding + self.no_response
    }

    /// Runs excluded from the regressions.
    #[must_use]
    pub fn excluded(&self) -> usize {
        self.overturned + self.flight + self.failed + self.slide_above_max + self.theta_above_max
    }

    fn add(&mut self, c: Category) {
        match c {
            Category::Responding => self.responding += 1,
            Category::NoResponse => self.no_response += 1,
            Category::Overturned => self.overturned += 1,
            Category::Flight => self.flight += 1,
            Category::Failed => self.failed += 1,
            Category::SlideAbove => self.slide_above_max += 1,
            Category::ThetaAbove => self.theta_above_max += 1,
        }
    }
}

/// Efficiency and sufficiency of one scalar IM for one block.
#[derive(Debug, Clone, PartialEq)]
pub struct ImScore {
    /// Index into [`STUDY_IM_NAMES`].
    pub im_index: usize,
    /// DM ~ IM over all used runs.
    pub linear: Option<LinearFit>,
    /// ln DM ~ ln IM over the responding runs (IM > 0).
    pub log: Option<LinearFit>,
    /// R² of DM ~ IM per pair (`None`: undefined, e.g. no run responded).
    pub r2_by_pair: Vec<Option<f64>>,
    /// R² of ln DM ~ ln IM per pair.
    pub r2_log_by_pair: Vec<Option<f64>>,
    /// Standard deviation of the defined per-pair linear R² (the seed's sufficiency criterion).
    pub r2_pair_sd: f64,
    /// max − min of the defined per-pair linear R².
    pub r2_pair_range: f64,
    /// Luco–Cornell p-value of the log–log residuals on Mw.
    pub p_mw_log: f64,
    /// Luco–Cornell p-value of the log–log residuals on R.
    pub p_r_log: f64,
    /// Same test on the linear residuals, on Mw.
    pub p_mw_linear: f64,
    /// Same test on the linear residuals, on R.
    pub p_r_linear: f64,
}

impl ImScore {
    /// Stable name of the IM.
    #[must_use]
    pub fn name(&self) -> &'static str {
        STUDY_IM_NAMES[self.im_index]
    }

    /// Unit of the IM.
    #[must_use]
    pub fn unit(&self) -> &'static str {
        STUDY_IM_UNITS[self.im_index]
    }

    /// Overall linear R² (NaN if undefined).
    #[must_use]
    pub fn r2(&self) -> f64 {
        self.linear.map_or(f64::NAN, |f| f.r2)
    }

    /// Overall log–log R² (NaN if undefined).
    #[must_use]
    pub fn r2_log(&self) -> f64 {
        self.log.map_or(f64::NAN, |f| f.r2)
    }
}

/// A vector IM (two IMs) for one block.
#[derive(Debug, Clone, PartialEq)]
pub struct VectorScore {
    /// Indices of the two IMs in [`STUDY_IM_NAMES`].
    pub ims: [usize; 2],
    /// DM ~ IM1 + IM2 over the used runs.
    pub linear: Option<MultipleFit>,
    /// ln DM ~ ln IM1 + ln IM2 over the responding runs with both IMs > 0.
    pub log: Option<MultipleFit>,
    /// Larger overall linear R² of the two IMs alone.
    pub best_scalar_r2: f64,
    /// Larger overall log–log R² of the two IMs alone.
    pub best_scalar_r2_log: f64,
}

/// The fragility of overturning of one block.
#[derive(Debug, Clone, PartialEq)]
pub struct FragilityAnalysis {
    /// Runs in the fragility sample (every run whose simulation succeeded).
    pub n: usize,
    /// Overturned runs among them.
    pub n_overturned: usize,
    /// Fit for every IM, in the order of [`STUDY_IM_NAMES`].
    pub fits: Vec<Result<LognormalFragility, FitError>>,
    /// The selected curve (`None`: no IM gave a fit; see `note`).
    pub selected: Option<LognormalFragility>,
    /// How the curve was selected, or why there is none.
    pub note: String,
}

/// The analysis of one block.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockAnalysis {
    /// Index into [`StudyConfig::blocks`].
    pub block_index: usize,
    /// Block name.
    pub name: String,
    /// The DM regressed.
    pub dm: DemandMeasure,
    /// Category of every run, in case order.
    pub categories: Vec<Category>,
    /// Counts by category.
    pub counts: CategoryCounts,
    /// Scalar IMs sorted by overall linear R², best first (undefined last, then IM order).
    pub ranking: Vec<ImScore>,
    /// Vector IMs: the `vector_top` best pairs by linear R², then the named pairs
    /// (PHA with PGV/PGA, the best ASI with CAV) if not already listed.
    pub vector: Vec<VectorScore>,
    /// Fragility of overturning.
    pub fragility: FragilityAnalysis,
}

/// The analysis of a whole study.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyAnalysis {
    pub blocks: Vec<BlockAnalysis>,
}

fn sd_and_range(values: &[f64]) -> (f64, f64) {
    if values.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    (var.sqrt(), hi - lo)
}

/// Sorts by a key, descending, NaN last, stable.
pub fn sort_desc_by<T>(items: &mut [T], key: impl Fn(&T) -> f64) {
    items.sort_by(|a, b| {
        let (ka, kb) = (key(a), key(b));
        match (ka.is_nan(), kb.is_nan()) {
            (true, true) => std::cmp::Ordering::Equal,
            (true, false) => std::cmp::Ordering::Greater,
            (false, true) => std::cmp::Ordering::Less,
            (false, false) => kb.total_cmp(&ka),
        }
    });
}

fn score_im(
    im_index: usize,
    used: &[usize],
    data: &StudyData,
    dm_values: &[f64],
    floor: f64,
) -> ImScore {
    let x: Vec<f64> = used.iter().map(|&i| data.cases[i].ims[im_index]).collect();
    let y: Vec<f64> = used.iter().map(|&i| dm_values[i]).collect();
    let mw: Vec<f64> = used.iter().map(|&i| data.cases[i].mw).collect();
    let r: Vec<f64> = used.iter().map(|&i| data.cases[i].r_km).collect();
    let linear = linear_fit(&x, &y);
    let log = log_log_fit(&x, &y, floor);
    let (p_mw_linear, p_r_linear) = linear.map_or((f64::NAN, f64::NAN), |f| {
        let res = residuals(&f, &x, &y);
        (
            residual_dependence_p(&res, &mw),
            residual_dependence_p(&res, &r),
        )
    });
    let (p_mw_log, p_r_log) = log.map_or((f64::NAN, f64::NAN), |f| {
        // The responding subset with its Mw and R.
        let keep: Vec<usize> = (0..x.len())
            .filter(|&k| x[k] > 0.0 && y[k] >= floor && y[k] > 0.0)
            .collect();
        let lx: Vec<f64> = keep.iter().map(|&k| x[k].ln()).collect();
        let ly: Vec<f64> = keep.iter().map(|&k| y[k].ln()).collect();
        let res = residuals(&f, &lx, &ly);
        let kmw: Vec<f64> = keep.iter().map(|&k| mw[k]).collect();
        let kr: Vec<f64> = keep.iter().map(|&k| r[k]).collect();
        (
            residual_dependence_p(&res, &kmw),
            residual_dependence_p(&res, &kr),
        )
    });
    let mut r2_by_pair = Vec::with_capacity(data.pairs.len());
    let mut r2_log_by_pair = Vec::with_capacity(data.pairs.len());
    for p in 0..data.pairs.len() {
        let (px, py): (Vec<f64>, Vec<f64>) = used
            .iter()
            .zip(x.iter().zip(&y))
            .filter(|(&i, _)| data.cases[i].pair_index == p)
            .map(|(_, (&a, &b))| (a, b))
            .unzip();
        r2_by_pair.push(linear_fit(&px, &py).map(|f| f.r2));
        r2_log_by_pair.push(log_log_fit(&px, &py, floor).map(|f| f.r2));
    }
    let defined: Vec<f64> = r2_by_pair.iter().flatten().copied().collect();
    let (r2_pair_sd, r2_pair_range) = sd_and_range(&defined);
    ImScore {
        im_index,
        linear,
        log,
        r2_by_pair,
        r2_log_by_pair,
        r2_pair_sd,
        r2_pair_range,
        p_mw_log,
        p_r_log,
        p_mw_linear,
        p_r_linear,
    }
}

fn vector_score(
    a: usize,
    b: usize,
    used: &[usize],
    data: &StudyData,
    dm_values: &[f64],
    floor: f64,
    scalar: &[ImScore],
) -> VectorScore {
    let x1: Vec<f64> = used.iter().map(|&i| data.cases[i].ims[a]).collect();
    let x2: Vec<f64> = used.iter().map(|&i| data.cases[i].ims[b]).collect();
    let y: Vec<f64> = used.iter().map(|&i| dm_values[i]).collect();
    let linear = multiple_fit(&[&x1, &x2], &y);
    let keep: Vec<usize> = (0..y.len())
        .filter(|&k| x1[k] > 0.0 && x2[k] > 0.0 && y[k] >= floor && y[k] > 0.0)
        .collect();
    let l1: Vec<f64> = keep.iter().map(|&k| x1[k].ln()).collect();
    let l2: Vec<f64> = keep.iter().map(|&k| x2[k].ln()).collect();
    let ly: Vec<f64> = keep.iter().map(|&k| y[k].ln()).collect();
    let log = multiple_fit(&[&l1, &l2], &ly);
    let by_index = |i: usize| scalar.iter().find(|s| s.im_index == i);
    let best = |f: fn(&ImScore) -> f64| {
        [a, b]
            .iter()
            .filter_map(|&i| by_index(i).map(f))
            .filter(|v| !v.is_nan())
            .fold(f64::NAN, f64::max)
    };
    VectorScore {
        ims: [a, b],
        linear,
        log,
        best_scalar_r2: best(ImScore::r2),
        best_scalar_r2_log: best(ImScore::r2_log),
    }
}

fn fragility_analysis(
    config: &StudyConfig,
    data: &StudyData,
    block_index: usize,
) -> FragilityAnalysis {
    let sample: Vec<usize> = (0..data.cases.len())
        .filter(|&i| data.responses[i][block_index].status != ResponseStatus::Failed)
        .collect();
    let event: Vec<bool> = sample
        .iter()
        .map(|&i| data.responses[i][block_index].status == ResponseStatus::Overturned)
        .collect();
    let n_overturned = event.iter().filter(|&&e| e).count();
    let fits: Vec<_> = (0..STUDY_IM_COUNT)
        .map(|j| {
            let im: Vec<f64> = sample.iter().map(|&i| data.cases[i].ims[j]).collect();
            fit_lognormal(STUDY_IM_NAMES[j], STUDY_IM_UNITS[j], &im, &event)
        })
        .collect();
    let (selected, note) = match &config.fragility_im {
        Some(name) => {
            let j = STUDY_IM_NAMES.iter().position(|n| n == name).unwrap_or(0);
            match &fits[j] {
                Ok(f) => (Some(f.clone()), format!("IM {name} chosen by the user")),
                Err(e) => (None, format!("no curve for IM {name}: {e}")),
            }
        }
        None => {
            // Largest likelihood among the IMs that are positive for every run (equal n).
            let best = fits
                .iter()
                .filter_map(|f| f.as_ref().ok())
                .filter(|f| f.n == sample.len() && f.b > 0.0)
                .fold(None::<&LognormalFragility>, |acc, f| match acc {
                    Some(a) if a.log_likelihood >= f.log_likelihood => Some(a),
                    _ => Some(f),
                });
            match best {
                Some(f) => (
                    Some(f.clone()),
                    format!(
                        "IM of largest likelihood among the {} IMs fitted to all {} runs",
                        fits.iter()
                            .filter(|r| r.as_ref().is_ok_and(|f| f.n == sample.len()))
                            .count(),
                        sample.len()
                    ),
                ),
                None => {
                    let reason = fits.iter().find_map(|f| f.as_ref().err()).map_or_else(
                        || "no IM gave an increasing curve".to_string(),
                        |e| e.to_string(),
                    );
                    (None, format!("no fragility curve: {reason}"))
                }
            }
        }
    };
    FragilityAnalysis {
        n: sample.len(),
        n_overturned,
        fits,
        selected,
        note,
    }
}

/// Analyses one block: categories, scalar and vector regressions, fragility.
#[must_use]
pub fn analyse_block(config: &StudyConfig, data: &StudyData, block_index: usize) -> BlockAnalysis {
    let block = &config.blocks[block_index];
    let dm = block.dm;
    let floor = config.floor(dm);
    let categories: Vec<Category> = data
        .responses
        .iter()
        .map(|r| categorize(&r[block_index], dm, config))
        .collect();
    let mut counts = CategoryCounts::default();
    for &c in &categories {
        counts.add(c);
    }
    let used: Vec<usize> = (0..categories.len())
        .filter(|&i| categories[i].is_used())
        .collect();
    let dm_values: Vec<f64> = data
        .responses
        .iter()
        .map(|r| dm.of(&r[block_index]))
        .collect();
    let mut ranking: Vec<ImScore> = (0..STUDY_IM_COUNT)
        .into_par_iter()
        .map(|j| score_im(j, &used, data, &dm_values, floor))
        .collect();
    sort_desc_by(&mut ranking, ImScore::r2);

    let all_pairs: Vec<(usize, usize)> = (0..STUDY_IM_COUNT)
        .flat_map(|a| ((a + 1)..STUDY_IM_COUNT).map(move |b| (a, b)))
        .collect();
    let mut vectors: Vec<VectorScore> = all_pairs
        .par_iter()
        .map(|&(a, b)| vector_score(a, b, &used, data, &dm_values, floor, &ranking))
        .collect();
    sort_desc_by(&mut vectors, |v| {
        v.linear.as_ref().map_or(f64::NAN, |f| f.r2)
    });
    let mut vector: Vec<VectorScore> = vectors.iter().take(config.vector_top).cloned().collect();
    let index_of = |name: &str| STUDY_IM_NAMES.iter().position(|n| *n == name);
    let best_asi = ranking
        .iter()
        .find(|s| s.name().starts_with("asi_"))
        .map(|s| s.im_index);
    let named = [
        index_of("pha").zip(index_of("pgv_pga")),
        best_asi.zip(index_of("cav")),
    ];
    for (a, b) in named.into_iter().flatten() {
        let key = [a.min(b), a.max(b)];
        if !vector.iter().any(|v| v.ims == key) {
            if let Some(v) = vectors.iter().find(|v| v.ims == key) {
                vector.push(v.clone());
            }
        }
    }

    BlockAnalysis {
        block_index,
        name: block.name.clone(),
        dm,
        categories,
        counts,
        ranking,
        vector,
        fragility: fragility_analysis(config, data, block_index),
    }
}

/// Analyses every block of a study.
#[must_use]
pub fn analyse(config: &StudyConfig, data: &StudyData) -> StudyAnalysis {
    StudyAnalysis {
        blocks: (0..config.blocks.len())
            .map(|b| analyse_block(config, data, b))
            .collect(),
    }
}
