//! Offline simulation of one block under a whole record, through exactly the real-time
//! stepping API ([`RigidBlock::advance`], one call per input interval), followed by
//! `t_extra_s` of free vibration with zero ground acceleration (many blocks fall only after
//! the record ends).

use crate::dynamics::{
    AdvanceError, BlockEvent, BlockOptions, BlockParams, GroundAccel, Mode, RigidBlock,
};
use crate::record::Record;

/// Options of an offline simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimulationOptions {
    /// Seconds of zero ground acceleration appended after the last sample (the input ramps
    /// from the last sample to zero over one sampling interval, then stays zero).
    pub t_extra_s: f64,
    /// Numerical options of the block stepper.
    pub block: BlockOptions,
    /// Keep the per-sample time history (for plots).
    pub keep_trace: bool,
}

impl Default for SimulationOptions {
    fn default() -> Self {
        SimulationOptions {
            t_extra_s: 10.0,
            block: BlockOptions::default(),
            keep_trace: false,
        }
    }
}

/// How a simulation ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Status {
    /// The block is standing (at rest or still moving) at the end.
    Ok,
    Overturned,
    /// The block lost contact with the ground without overturning; the run was stopped there.
    Flight,
}

/// The response summary of one simulation (SI units). Serialises to the JSON of
/// `rockwatch simulate --format json`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Summary {
    pub status: Status,
    pub overturned: bool,
    /// Last upward crossing of |θ| = α before the fall (s), if overturned.
    pub overturn_time: Option<f64>,
    pub exceeded_alpha: bool,
    /// Uplift angle α (rad): the rectangle's slenderness; for a general body the smaller of
    /// α₊ and α₋.
    pub alpha: f64,
    /// Uplift angle α₊ of the +x pivot (rad).
    pub alpha_plus: f64,
    /// Uplift angle α₋ of the −x pivot (rad).
    pub alpha_minus: f64,
    /// max |θ| (rad); π/2 when the block overturned (the side face reached the ground).
    pub max_abs_theta: f64,
    /// max |θ|/α_σ, each rotation measured against the uplift angle of its own pivot.
    pub max_abs_theta_over_alpha: f64,
    /// max |u| (m), slip of the contact point relative to the ground, before any overturn.
    pub max_abs_slide: f64,
    /// u at the end of the run (m).
    pub residual_slide: f64,
    pub n_impacts: u32,
    pub n_impacts_significant: u32,
    pub n_flat_landings: u32,
    /// `[t (s), mode]` at the start and at every mode change.
    pub modes: Vec<(f64, Mode)>,
    /// Simulated duration (s): the record plus `t_extra`, or up to the overturn or lift-off
    /// that stopped the run.
    pub duration: f64,
}

/// The per-sample time history of a simulation.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trace {
    pub t_s: Vec<f64>,
    pub horizontal_mps2: Vec<f64>,
    /// Vertical ground acceleration (m/s², + up); empty when the record has none.
    pub vertical_mps2: Vec<f64>,
    pub theta_rad: Vec<f64>,
    pub slide_m: Vec<f64>,
    pub mode: Vec<Mode>,
}

/// A finished simulation.
#[derive(Debug, Clone)]
pub struct Simulation {
    pub summary: Summary,
    pub trace: Option<Trace>,
    /// Every event, in time order.
    pub events: Vec<BlockEvent>,
}

/// Most integration intervals a simulation runs (record plus `t_extra_s`): 2·10⁷, about
/// 55 h at 100 Hz, a few minutes of CPU. Bounds the work whatever the record's sampling
/// interval and `t_extra_s`.
pub const MAX_SIMULATION_STEPS: usize = 20_000_000;

/// Why a simulation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimulateError {
    #[error("the record has fewer than two samples")]
    TooShort,
    #[error("t_extra must be a finite number of seconds ≥ 0, got {0}")]
    BadExtra(f64),
    #[error(
        "{steps} integration steps (record plus t_extra at dt = {dt_s} s) exceed the limit of \
         {MAX_SIMULATION_STEPS}: shorten t_extra or resample the record"
    )]
    TooManySteps { steps: f64, dt_s: f64 },
    #[error("at t = {t_s} s: {reason}")]
    Advance { t_s: f64, reason: AdvanceError },
}

/// The bounds every simulation checks first: a record of at least 2 samples, `t_extra_s`
/// finite and ≥ 0, at most [`MAX_SIMULATION_STEPS`] steps. Returns the number of zero-input
/// samples after the record (`t_extra_s` rounded up to whole samples).
fn extra_samples(record: &Record, t_extra_s: f64) -> Result<usize, SimulateError> {
    if record.len() < 2 {
        return Err(SimulateError::TooShort);
    }
    if !(t_extra_s.is_finite() && t_extra_s >= 0.0) {
        return Err(SimulateError::BadExtra(t_extra_s));
    }
    let dt = record.dt_s;
    // In f64: a tiny dt or a huge t_extra must not wrap or saturate before the check.
    let steps = record.len() as f64 + (t_extra_s / dt).ceil();
    if !(dt > 0.0 && steps <= MAX_SIMULATION_STEPS as f64) {
        return Err(SimulateError::TooManySteps { steps, dt_s: dt });
    }
    Ok((t_extra_s / dt).ceil() as usize)
}

/// Ground acceleration at sample `i` of `record`, its horizontal component scaled by
/// `horizontal_factor` and its vertical one by `vertical_factor` (m/s²); zero after the
/// record's end.
fn ground_sample(
    record: &Record,
    i: usize,
    horizontal_factor: f64,
    vertical_factor: f64,
) -> GroundAccel {
    if i < record.len() {
        GroundAccel {
            horizontal_mps2: horizontal_factor * record.horizontal_mps2[i],
            vertical_mps2: record
                .vertical_mps2
                .as_ref()
                .map_or(0.0, |v| vertical_factor * v[i]),
        }
    } else {
        GroundAccel::default()
    }
}

/// Simulates `params` under `record` (horizontal and optional vertical components).
pub fn simulate(
    params: BlockParams,
    record: &Record,
    options: &SimulationOptions,
) -> Result<Simulation, SimulateError> {
    let n_extra = extra_samples(record, options.t_extra_s)?;
    let dt = record.dt_s;
    let ground_at = |i: usize| ground_sample(record, i, 1.0, 1.0);

    let mut block = RigidBlock::new(params, options.block);
    let mut events = Vec::new();
    let mut modes = vec![(0.0, Mode::Rest)];
    let mut trace = options.keep_trace.then(Trace::default);
    let has_vertical = record.vertical_mps2.is_some();
    let push_trace = |trace: &mut Option<Trace>, block: &RigidBlock, a: GroundAccel| {
        if let Some(tr) = trace {
            tr.t_s.push(block.time_s());
            tr.horizontal_mps2.push(a.horizontal_mps2);
            if has_vertical {
                tr.vertical_mps2.push(a.vertical_mps2);
            }
            tr.theta_rad.push(block.theta_rad());
            tr.slide_m.push(block.slide_m());
            tr.mode.push(block.mode());
        }
    };
    push_trace(&mut trace, &block, ground_at(0));
    let n_intervals = record.len() - 1 + n_extra;
    for i in 0..n_intervals {
        let (from, to) = (ground_at(i), ground_at(i + 1));
        block
            .advance(dt, from, to, |e| {
                if let BlockEvent::ModeChange { t_s, to, .. } = e {
                    modes.push((t_s, to));
                }
                events.push(e);
            })
            .map_err(|reason| SimulateError::Advance {
                t_s: block.time_s(),
                reason,
            })?;
        push_trace(&mut trace, &block, to);
        if matches!(block.mode(), Mode::Overturned | Mode::Flight) {
            break;
        }
    }

    let stats = *block.stats();
    let status = match block.mode() {
        Mode::Overturned => Status::Overturned,
        Mode::Flight => Status::Flight,
        _ => Status::Ok,
    };
    let alpha = params.alpha_rad;
    Ok(Simulation {
        summary: Summary {
            status,
            overturned: status == Status::Overturned,
            overturn_time: stats.overturn_time_s,
            exceeded_alpha: stats.exceeded_alpha,
            alpha,
            alpha_plus: params.plus.alpha_rad,
            alpha_minus: params.minus.alpha_rad,
            max_abs_theta: stats.max_abs_theta_rad,
            max_abs_theta_over_alpha: stats.max_abs_theta_over_alpha,
            max_abs_slide: stats.max_abs_slide_m,
            residual_slide: block.slide_m(),
            n_impacts: stats.n_impacts,
            n_impacts_significant: stats.n_impacts_significant,
            n_flat_landings: stats.n_flat_landings,
            modes,
            duration: block.time_s(),
        },
        trace,
        events,
    })
}

/// The response of one block to one scaled record, as the fragility analysis needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    /// Overturned, flight (stopped there) or standing (`Status::Ok`).
    pub status: Status,
    /// max |θ|/α_σ (see [`Summary::max_abs_theta_over_alpha`]).
    pub max_abs_theta_over_alpha: f64,
    /// max |u| (m) before any overturn.
    pub max_abs_slide_m: f64,
    /// Simulated time (s) when the run stopped.
    pub duration_s: f64,
}

/// Simulates `params` under `record` with its horizontal component multiplied by
/// `horizontal_factor` and its vertical one by `vertical_factor`, through exactly
/// [`RigidBlock::advance`] (one call per input interval, as [`simulate`]), without
/// allocating and with early exits: the run stops once the block has overturned or lifted
/// off, or once the record has ended and the block is at rest (with zero ground motion it
/// stays at rest for ever), and at most `t_extra_s` after the record's end. The bounds of
/// [`simulate`] apply.
pub fn simulate_outcome(
    params: BlockParams,
    record: &Record,
    horizontal_factor: f64,
    vertical_factor: f64,
    t_extra_s: f64,
    block_options: BlockOptions,
) -> Result<Outcome, SimulateError> {
    let n_extra = extra_samples(record, t_extra_s)?;
    let dt = record.dt_s;
    let n = record.len();
    let n_intervals = n - 1 + n_extra;
    let ground_at = |i: usize| ground_sample(record, i, horizontal_factor, vertical_factor);
    let mut block = RigidBlock::new(params, block_options);
    for i in 0..n_intervals {
        if i + 1 >= n && block.mode() == Mode::Rest {
            break;
        }
        block
            .advance(dt, ground_at(i), ground_at(i + 1), |_| {})
            .map_err(|reason| SimulateError::Advance {
                t_s: block.time_s(),
                reason,
            })?;
        if matches!(block.mode(), Mode::Overturned | Mode::Flight) {
            break;
        }
    }
    let stats = block.stats();
    Ok(Outcome {
        status: match block.mode() {
            Mode::Overturned => Status::Overturned,
            Mode::Flight => Status::Flight,
            _ => Status::Ok,
        },
        max_abs_theta_over_alpha: stats.max_abs_theta_over_alpha,
        max_abs_slide_m: stats.max_abs_slide_m,
        duration_s: block.time_s(),
    })
}
