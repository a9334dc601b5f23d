//! Running the study ([`run_study`]): the pulses of every Mw–R pair, their IMs and every
//! block's response, in parallel and bit-for-bit independent of the thread count.

use super::{Pair, StudyBlock, StudyConfig, StudyError};
use crate::dynamics::Mode;
use crate::ims::{compute_ims, study_ims, ImOptions, STUDY_IM_COUNT};
use crate::lhs::derived_seed;
use crate::pulse::{sample_pulses, PulseParameters, PulseScenario};
use crate::simulate::{simulate, SimulationOptions, Status};
use rayon::prelude::*;

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
    /// The 37 study IMs in the order of [`crate::ims::STUDY_IMS`] (SI units).
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
