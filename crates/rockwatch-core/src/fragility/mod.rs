//! Fragility of one rock by multiple-stripe analysis (docs/fragility.md).
//!
//! 1. [`prepare`]: every record's IMs, computed once, unscaled ([`crate::ims::im`]); the scale factor of
//!    every (record, intensity level): `s = (level/IM_r)^(1/k)` for stripes on an IM with
//!    scaling exponent k (IM(s·record) = s^k·IM(record)), or the given factors.
//! 2. [`run_simulations`]: for every record × level × ensemble member × incidence angle, the
//!    rock is simulated in each of its directions ([`crate::simulate::simulate_outcome`]: the
//!    real-time [`crate::dynamics::RigidBlock`] stepper with early exit); a run overturns when
//!    any direction does. Runs are independent and run in parallel (rayon); results are
//!    collected in run order, so they do not depend on the number of threads.
//! 3. [`analyse`]: per IM, a lognormal fragility by maximum likelihood ([`fit`]: binomial
//!    over stripes for the stripe IM, over (record, scale) groups otherwise), percentile
//!    bootstrap confidence intervals from resampling records (seeded: replicate b uses the
//!    seed [`crate::lhs::derived_seed`]`(seed, b)`), the IMs ranked by β, and a two-IM probit
//!    surface evaluated on a grid.
//!
//! Rock input: a list of [`RockMember`]s (ensemble members), each a list of
//! [`RockDirection`]s (a planar body and the azimuth of its +x axis in the rock's frame), so a
//! mesh-derived rock with several toppling directions plugs in as more directions; or a mesh
//! rock as one 3-D rigid body ([`RockMember::Rigid3d`], [`crate::rocking3d`]), the record
//! applied along the incidence azimuth and its vertical component as up.
//! Single-component records: incidence angle φ puts the record along the azimuth φ of the
//! rock's frame; direction ψ sees `a_h·cos(φ − ψ)` (φ = 0 and 180° apply the record along +x
//! and −x: both pivots). The vertical component, when given, is applied unprojected. Every
//! component is multiplied by the run's scale factor. Units: SI (m/s², m/s, s).

pub mod file;
pub mod fit;

use rayon::prelude::*;

use crate::dynamics::{BlockOptions, BlockParams};
pub use crate::ims::rotd::HorizontalDefinition;
pub use crate::ims::Im;
use crate::ims::{compute_ims, ImError, ImOptions};
use crate::lhs::{rng_from_seed, uniform_below};
use crate::record::{Record, MAX_ABS_ACCEL_MPS2};
use crate::rocking3d::{simulate_3d_outcome, Rock3dOptions};
use crate::simulate::{simulate_outcome, SimulateError, Status};
use crate::stats::{normal_cdf, percentile_sorted, INTERVAL_95};
pub use file::{BootstrapJson, Ci95Json, ImFragilityJson};
use fit::{fit_lognormal_groups, fit_surface, FitError, LognormalFit, SurfaceFit};

/// z of a two-sided 95 % normal interval.
pub const Z_95: f64 = 1.959_963_984_540_054;
/// Default number of bootstrap replicates.
pub const DEFAULT_BOOTSTRAP: usize = 500;
/// Default points per axis of the surface grid.
pub const DEFAULT_SURFACE_GRID: usize = 41;
/// Default free vibration after each record (s), bounded; the run stops earlier once the
/// block is at rest.
pub const DEFAULT_T_EXTRA_S: f64 = 10.0;

/// One toppling direction of a rock: the planar body of that direction and the azimuth of
/// its +x axis in the rock's frame (degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RockDirection {
    pub azimuth_deg: f64,
    pub params: BlockParams,
}

/// One realisation of the rock (an ensemble member).
#[derive(Debug, Clone, PartialEq)]
pub enum RockMember {
    /// Planar bodies: one direction for a planar body given by flags or a catalogue entry;
    /// several for a rock from a mesh. The run overturns when any direction does.
    Planar { directions: Vec<RockDirection> },
    /// A mesh rock as one 3-D rigid body (docs/rocking-3d.md): `heading_deg` is the azimuth
    /// of the mesh's north axis in the rock's frame (incidence φ is the mesh azimuth
    /// φ − heading), `mu_s` ≥ `mu_k` its friction.
    Rigid3d {
        /// Shared by the members of one rock.
        body: std::sync::Arc<crate::rocking3d::RockBody>,
        heading_deg: f64,
        mu_s: f64,
        mu_k: f64,
    },
}

impl RockMember {
    /// One planar direction of the rock's frame at azimuth 0.
    #[must_use]
    pub fn planar(params: BlockParams) -> RockMember {
        RockMember::Planar {
            directions: vec![RockDirection {
                azimuth_deg: 0.0,
                params,
            }],
        }
    }

    /// Simulations per run before early exits (its directions; one 3-D body).
    #[must_use]
    pub fn simulations(&self) -> usize {
        match self {
            RockMember::Planar { directions } => directions.len(),
            RockMember::Rigid3d { .. } => 1,
        }
    }
}

/// How the records are brought to each intensity.
#[derive(Debug, Clone, PartialEq)]
pub enum Intensity {
    /// Multiple-stripe analysis: every record scaled so that IM `im` (an index into
    /// [`FragilityConfig::ims`]) equals each level (IM units).
    Stripes { im: usize, levels: Vec<f64> },
    /// Every record multiplied by each factor.
    Scales(Vec<f64>),
}

impl Intensity {
    /// Number of levels (stripes or factors).
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            Intensity::Stripes { levels, .. } => levels.len(),
            Intensity::Scales(s) => s.len(),
        }
    }

    /// True when there is no level.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// `n` values from `lo` to `hi` inclusive, evenly spaced in ln (log-spaced), as
/// `--stripes IM:lo:hi:n` and `--scales a:b:n` use.
#[must_use]
pub fn log_spaced(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![lo];
    }
    (0..n)
        .map(|k| (lo.ln() + (hi.ln() - lo.ln()) * k as f64 / (n - 1) as f64).exp())
        .collect()
}

/// Everything an analysis needs besides the records.
#[derive(Debug, Clone, PartialEq)]
pub struct FragilityConfig {
    /// The IMs fitted (at least one).
    pub ims: Vec<Im>,
    pub intensity: Intensity,
    /// The rock's ensemble members (at least one, each with at least one direction).
    pub members: Vec<RockMember>,
    /// Incidence angles φ of the records in the rock's frame (degrees, at least one).
    pub incidences_deg: Vec<f64>,
    /// Free vibration after each record (s), an upper bound (early exit at rest).
    pub t_extra_s: f64,
    pub block: BlockOptions,
    /// Bootstrap replicates (0: no confidence intervals).
    pub bootstrap: usize,
    pub seed: u64,
    /// The two IMs of the surface (indices into `ims`), if any.
    pub surface: Option<(usize, usize)>,
    /// Points per axis of the surface grid (≥ 2).
    pub surface_grid: usize,
    /// The horizontal-component definition of PGA, PGV, PGD, SA(T) and PGV/PGA (the IMs of
    /// [`Im::has_horizontal_definition`]): `Component` (one component as recorded)
    /// or, with pairs of components for every record, RotD50, RotD100 or GM.
    pub horizontal: HorizontalDefinition,
}

/// What can go wrong before the simulations (invalid configuration or records).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FragilityError {
    #[error("invalid fragility configuration: {0}")]
    Config(String),
    #[error("record {record}: {source}")]
    Ims { record: String, source: ImError },
    #[error("record {record}: {problem}")]
    Record { record: String, problem: String },
}

impl FragilityConfig {
    /// Checks the configuration.
    pub fn validate(&self) -> Result<(), FragilityError> {
        let bad = |m: String| Err(FragilityError::Config(m));
        if self.ims.is_empty() {
            return bad("no IM".into());
        }
        if self.intensity.is_empty() {
            return bad("no stripe level or scale factor".into());
        }
        match &self.intensity {
            Intensity::Stripes { im, levels } => {
                let Some(im) = self.ims.get(*im) else {
                    return bad("the stripe IM is not among the IMs".into());
                };
                if im.scale_exponent() == 0.0 {
                    return bad(format!(
                        "{} does not change when a record is scaled: stripes need an IM such \
                         as PGA, PGV or SA(T)",
                        im.name()
                    ));
                }
                if levels.iter().any(|l| !(l.is_finite() && *l > 0.0)) {
                    return bad("stripe levels must be positive and finite".into());
                }
            }
            Intensity::Scales(s) => {
                if s.iter().any(|l| !(l.is_finite() && *l > 0.0)) {
                    return bad("scale factors must be positive and finite".into());
                }
            }
        }
        if self.members.is_empty() || self.members.iter().any(|m| m.simulations() == 0) {
            return bad("the rock needs at least one member with one direction".into());
        }
        if self.incidences_deg.is_empty() || self.incidences_deg.iter().any(|a| !a.is_finite()) {
            return bad("incidence angles must be finite degrees (at least one)".into());
        }
        if !(self.t_extra_s.is_finite() && self.t_extra_s >= 0.0) {
            return bad(format!("t_extra must be ≥ 0 s, got {}", self.t_extra_s));
        }
        if let Some((a, b)) = self.surface {
            if a >= self.ims.len() || b >= self.ims.len() || a == b {
                return bad("the surface needs two different IMs of the list".into());
            }
        }
        if self.surface_grid < 2 {
            return bad("the surface grid needs at least 2 points per axis".into());
        }
        Ok(())
    }

    /// Runs per record and level: members × incidence angles.
    #[must_use]
    pub fn runs_per_cell(&self) -> usize {
        self.members.len() * self.incidences_deg.len()
    }

    /// Total number of runs.
    #[must_use]
    pub fn n_runs(&self, n_records: usize) -> usize {
        n_records * self.intensity.len() * self.runs_per_cell()
    }

    /// Total number of block-record simulations (runs × directions, before early exits
    /// across directions).
    #[must_use]
    pub fn n_simulations(&self, n_records: usize) -> usize {
        let directions: usize = self.members.iter().map(RockMember::simulations).sum();
        n_records * self.intensity.len() * self.incidences_deg.len() * directions
    }
}

/// One ground-motion record of the analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct FragilityRecord {
    /// Name for tables (file name).
    pub name: String,
    pub record: Record,
    /// The second horizontal component of a pair (m/s², orthogonal to `record`'s, 90°
    /// clockwise of it, same instants and length): the IMs of [`FragilityConfig::horizontal`]
    /// are computed from both, and an incidence φ puts the first along φ and this one along
    /// φ + 90°.
    pub second_horizontal_mps2: Option<Vec<f64>>,
}

/// The records' IMs and scale factors.
#[derive(Debug, Clone, PartialEq)]
pub struct Prepared {
    /// `ims[r][i]`: IM i of record r, unscaled (SI units).
    pub ims: Vec<Vec<f64>>,
    /// `scales[r][j]`: the factor of record r at level j.
    pub scales: Vec<Vec<f64>>,
}

impl Prepared {
    /// IM i of record r scaled by its factor at level j: `s^k·IM`.
    #[must_use]
    pub fn scaled_im(&self, config: &FragilityConfig, r: usize, j: usize, i: usize) -> f64 {
        let k = config.ims[i].scale_exponent();
        self.ims[r][i] * self.scales[r][j].powf(k)
    }
}

/// Computes every record's IMs (horizontal component as given, [`compute_ims`]) and the scale
/// factors. A record whose stripe IM is not positive cannot be scaled: an error naming it.
pub fn prepare(
    config: &FragilityConfig,
    records: &[FragilityRecord],
) -> Result<Prepared, FragilityError> {
    config.validate()?;
    if records.is_empty() {
        return Err(FragilityError::Config("no records".into()));
    }
    let options = ImOptions {
        periods_s: config.ims.iter().filter_map(Im::sa_period).collect(),
        ..ImOptions::default()
    };
    let paired = config.horizontal != HorizontalDefinition::Component;
    if let Some(single) = records
        .iter()
        .find(|r| paired && r.second_horizontal_mps2.is_none())
    {
        return Err(FragilityError::Record {
            record: single.name.clone(),
            problem: format!(
                "one horizontal component: {} needs both horizontal components of every record",
                config.horizontal.name()
            ),
        });
    }
    let ims: Vec<Vec<f64>> = records
        .par_iter()
        .map(|rec| {
            let ims_error = |source| FragilityError::Ims {
                record: rec.name.clone(),
                source,
            };
            let (x, dt) = (&rec.record.horizontal_mps2, rec.record.dt_s);
            let set = compute_ims(x, dt, &options).map_err(ims_error)?;
            config
                .ims
                .iter()
                .map(|im| match (&rec.second_horizontal_mps2, paired) {
                    (Some(y), true) if im.has_horizontal_definition() => im
                        .two_component_value(config.horizontal, x, y, dt, options.damping)
                        .map_err(ims_error),
                    _ => Ok(im.value(&set)),
                })
                .collect()
        })
        .collect::<Result<_, FragilityError>>()?;
    let mut scales = Vec::with_capacity(records.len());
    for (rec, values) in records.iter().zip(&ims) {
        let row = match &config.intensity {
            Intensity::Scales(s) => s.clone(),
            Intensity::Stripes { im, levels } => {
                let value = values[*im];
                if !(value.is_finite() && value > 0.0) {
                    return Err(FragilityError::Record {
                        record: rec.name.clone(),
                        problem: format!(
                            "{} is {value}: the record cannot be scaled to a stripe",
                            config.ims[*im].name()
                        ),
                    });
                }
                let k = config.ims[*im].scale_exponent();
                levels.iter().map(|l| (l / value).powf(1.0 / k)).collect()
            }
        };
        // The bounds every record obeys (`Record::check_bounds`) hold for its scaled copies.
        let peak = rec
            .record
            .horizontal_mps2
            .iter()
            .chain(rec.second_horizontal_mps2.iter().flatten())
            .chain(rec.record.vertical_mps2.iter().flatten())
            .fold(0.0_f64, |m, a| m.max(a.abs()));
        let largest = row.iter().copied().fold(0.0_f64, f64::max);
        if peak * largest > MAX_ABS_ACCEL_MPS2 {
            return Err(FragilityError::Record {
                record: rec.name.clone(),
                problem: format!(
                    "scaled by {largest:.4} its peak acceleration reaches {:.1} m/s², beyond \
                     ±100 g: lower the highest stripe or scale factor",
                    peak * largest
                ),
            });
        }
        scales.push(row);
    }
    Ok(Prepared { ims, scales })
}

/// How one run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RunStatus {
    Standing,
    Overturned,
    /// A direction lost contact with the ground (free flight is detected, not modelled): the
    /// run is left out of the fits and counted.
    Flight,
    /// A simulation failed (its message is in the run): left out and counted.
    Failed,
}

impl RunStatus {
    /// Name in tables.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            RunStatus::Standing => "standing",
            RunStatus::Overturned => "overturned",
            RunStatus::Flight => "flight",
            RunStatus::Failed => "failed",
        }
    }
}

/// One run: a record at one level, one ensemble member, one incidence angle.
#[derive(Debug, Clone, PartialEq)]
pub struct RunResult {
    pub record: usize,
    pub level: usize,
    pub member: usize,
    pub incidence: usize,
    /// The scale factor applied to every component.
    pub scale: f64,
    pub status: RunStatus,
    /// The direction (index in the member) that overturned, flew or failed first.
    pub direction: Option<usize>,
    /// Largest max |θ|/α over the directions simulated.
    pub max_abs_theta_over_alpha: f64,
    /// Largest max |u| (m) over the directions simulated.
    pub max_abs_slide_m: f64,
    /// The failure, if any.
    pub error: Option<String>,
}

fn run_one(
    config: &FragilityConfig,
    record: &FragilityRecord,
    scale: f64,
    member: &RockMember,
    incidence_deg: f64,
) -> (RunStatus, Option<usize>, f64, f64, Option<String>) {
    let directions = match member {
        RockMember::Planar { directions } => directions,
        RockMember::Rigid3d {
            body,
            heading_deg,
            mu_s,
            mu_k,
        } => {
            return match simulate_3d_outcome(
                crate::rocking3d::RockBody::clone(body),
                *mu_s,
                *mu_k,
                &record.record,
                record.second_horizontal_mps2.as_deref(),
                incidence_deg - heading_deg,
                scale,
                scale,
                config.t_extra_s,
                Rock3dOptions::default(),
            ) {
                Ok(o) => (
                    if o.overturned {
                        RunStatus::Overturned
                    } else {
                        RunStatus::Standing
                    },
                    o.overturned.then_some(0),
                    o.max_tilt_over_alpha,
                    o.max_slide_m,
                    None,
                ),
                Err(e) => (RunStatus::Failed, Some(0), 0.0, 0.0, Some(e.to_string())),
            };
        }
    };
    let (mut theta, mut slide) = (0.0_f64, 0.0_f64);
    for (d, dir) in directions.iter().enumerate() {
        let (sin, cos) = (incidence_deg - dir.azimuth_deg).to_radians().sin_cos();
        // A pair: the first component along the incidence φ, the second along φ + 90°; the
        // direction ψ sees x·cos(φ − ψ) − y·sin(φ − ψ). One component: x·cos(φ − ψ).
        let paired;
        let (seen, factor) = match &record.second_horizontal_mps2 {
            Some(y) => {
                paired = Record {
                    source: record.record.source.clone(),
                    dt_s: record.record.dt_s,
                    horizontal_mps2: record
                        .record
                        .horizontal_mps2
                        .iter()
                        .zip(y)
                        .map(|(a, b)| a * cos - b * sin)
                        .collect(),
                    vertical_mps2: record.record.vertical_mps2.clone(),
                };
                (&paired, scale)
            }
            None => (&record.record, scale * cos),
        };
        match simulate_outcome(
            dir.params,
            seen,
            factor,
            scale,
            config.t_extra_s,
            config.block,
        ) {
            Ok(o) => {
                theta = theta.max(o.max_abs_theta_over_alpha);
                slide = slide.max(o.max_abs_slide_m);
                match o.status {
                    Status::Overturned => {
                        return (RunStatus::Overturned, Some(d), theta, slide, None)
                    }
                    Status::Flight => return (RunStatus::Flight, Some(d), theta, slide, None),
                    Status::Ok => {}
                }
            }
            Err(e) => {
                let e: SimulateError = e;
                return (
                    RunStatus::Failed,
                    Some(d),
                    theta,
                    slide,
                    Some(e.to_string()),
                );
            }
        }
    }
    (RunStatus::Standing, None, theta, slide, None)
}

/// Simulates every run (in parallel on the current rayon pool), in the order record → level
/// → member → incidence. `progress` is called once per finished run, from any thread.
pub fn run_simulations(
    config: &FragilityConfig,
    records: &[FragilityRecord],
    prepared: &Prepared,
    progress: &(dyn Fn() + Sync),
) -> Vec<RunResult> {
    let (nj, nm, na) = (
        config.intensity.len(),
        config.members.len(),
        config.incidences_deg.len(),
    );
    let n = config.n_runs(records.len());
    (0..n)
        .into_par_iter()
        .map(|index| {
            let incidence = index % na;
            let member = (index / na) % nm;
            let level = (index / (na * nm)) % nj;
            let record = index / (na * nm * nj);
            let scale = prepared.scales[record][level];
            let (status, direction, theta, slide, error) = run_one(
                config,
                &records[record],
                scale,
                &config.members[member],
                config.incidences_deg[incidence],
            );
            progress();
            RunResult {
                record,
                level,
                member,
                incidence,
                scale,
                status,
                direction,
                max_abs_theta_over_alpha: theta,
                max_abs_slide_m: slide,
                error,
            }
        })
        .collect()
}

/// Counts of one (record, level) cell: usable runs (standing or overturned) and overturned.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CellCounts {
    pub trials: f64,
    pub events: f64,
}

/// `counts[r][j]` of the runs: flight runs left out (the criterion of the fits).
#[must_use]
pub fn cell_counts(
    config: &FragilityConfig,
    n_records: usize,
    runs: &[RunResult],
) -> Vec<Vec<CellCounts>> {
    counts_with(config, n_records, runs, FlightRuns::LeftOut)
}

/// What the counts make of a run that lost ground contact (free flight is detected, not
/// modelled: its outcome is unknown).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum FlightRuns {
    /// Not a trial (the fits' criterion).
    LeftOut,
    /// An overturn (the other bound: see [`ImFragility::median_flight_overturned`]).
    Overturned,
}

fn counts_with(
    config: &FragilityConfig,
    n_records: usize,
    runs: &[RunResult],
    flight: FlightRuns,
) -> Vec<Vec<CellCounts>> {
    let mut counts = vec![vec![CellCounts::default(); config.intensity.len()]; n_records];
    for run in runs {
        let c = &mut counts[run.record][run.level];
        match (run.status, flight) {
            (RunStatus::Standing, _) => c.trials += 1.0,
            (RunStatus::Overturned, _) | (RunStatus::Flight, FlightRuns::Overturned) => {
                c.trials += 1.0;
                c.events += 1.0;
            }
            (RunStatus::Flight, FlightRuns::LeftOut) | (RunStatus::Failed, _) => {}
        }
    }
    counts
}

/// The groups `(ln im, trials, events)` of IM i, each record weighted by `weights[r]`: one
/// group per stripe for the stripe IM (Baker's binomial likelihood over stripes), one per
/// (record, level) otherwise.
fn groups(
    config: &FragilityConfig,
    prepared: &Prepared,
    counts: &[Vec<CellCounts>],
    weights: &[f64],
    i: usize,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let nj = config.intensity.len();
    match &config.intensity {
        Intensity::Stripes { im, levels } if *im == i => {
            let mut n = vec![0.0; nj];
            let mut k = vec![0.0; nj];
            for (row, &w) in counts.iter().zip(weights) {
                for (j, c) in row.iter().enumerate() {
                    n[j] += w * c.trials;
                    k[j] += w * c.events;
                }
            }
            (levels.iter().map(|l| l.ln()).collect(), n, k)
        }
        _ => {
            let cap = counts.len() * nj;
            let (mut x, mut n, mut k) = (
                Vec::with_capacity(cap),
                Vec::with_capacity(cap),
                Vec::with_capacity(cap),
            );
            for (r, (row, &w)) in counts.iter().zip(weights).enumerate() {
                if w == 0.0 {
                    continue;
                }
                for (j, c) in row.iter().enumerate() {
                    x.push(prepared.scaled_im(config, r, j, i).ln());
                    n.push(w * c.trials);
                    k.push(w * c.events);
                }
            }
            (x, n, k)
        }
    }
}

fn surface_groups(
    config: &FragilityConfig,
    prepared: &Prepared,
    counts: &[Vec<CellCounts>],
    (a, b): (usize, usize),
) -> (Vec<[f64; 2]>, Vec<f64>, Vec<f64>) {
    let mut x = Vec::new();
    let (mut n, mut k) = (Vec::new(), Vec::new());
    for (r, row) in counts.iter().enumerate() {
        for (j, c) in row.iter().enumerate() {
            x.push([
                prepared.scaled_im(config, r, j, a).ln(),
                prepared.scaled_im(config, r, j, b).ln(),
            ]);
            n.push(c.trials);
            k.push(c.events);
        }
    }
    (x, n, k)
}

/// The fragility of one IM.
#[derive(Debug, Clone, PartialEq)]
pub struct ImFragility {
    pub im: Im,
    /// The maximum-likelihood fit, or why there is none (a scale-invariant IM with stripes
    /// or scale factors is reported as [`FitError::TooFewGroups`]-free `None` in `note`).
    pub fit: Result<LognormalFit, FitError>,
    /// Why the IM was not fitted at all (scale-invariant IMs), if so.
    pub note: Option<String>,
    /// 95 % percentile bootstrap intervals of the median and β (None without replicates).
    pub ci_median: Option<[f64; 2]>,
    pub ci_beta: Option<[f64; 2]>,
    /// The replicates' (median, β), in replicate order (failed replicates left out).
    pub bootstrap: Vec<(f64, f64)>,
    /// Replicates without a finite fit.
    pub bootstrap_failed: usize,
    /// True when the IM is the stripe IM (its groups are the stripes).
    pub is_stripe_im: bool,
    /// With runs that lost ground contact (flight): the median of the fit that counts each
    /// of them as an overturn. The fit leaves them out, which biases its median upwards
    /// where they happen (the strongest shaking) if they would have overturned; the true
    /// median lies between the two. None without flight runs (or without that fit).
    pub median_flight_overturned: Option<f64>,
}

impl ImFragility {
    /// Pointwise 95 % bootstrap band of P(overturn | im): the 2.5 and 97.5 % percentiles of
    /// the replicates' curves at `im`; None without replicates.
    #[must_use]
    pub fn band(&self, im: f64) -> Option<(f64, f64)> {
        if self.bootstrap.is_empty() || im <= 0.0 {
            return None;
        }
        let p: Vec<f64> = self
            .bootstrap
            .iter()
            .map(|(m, b)| normal_cdf((im / m).ln() / b))
            .collect();
        percentile_interval(&p).map(|[lo, hi]| (lo, hi))
    }
}

/// The two-IM surface.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// Indices of the two IMs in the configuration.
    pub ims: (usize, usize),
    pub fit: Result<SurfaceFit, FitError>,
    /// Log-spaced grid of each IM over the runs' range.
    pub grid1: Vec<f64>,
    pub grid2: Vec<f64>,
    /// `p[a][b]` = P(overturn | grid1[a], grid2[b]); empty without a fit.
    pub p: Vec<Vec<f64>>,
}

/// The result of an analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct FragilityResult {
    pub n_runs: usize,
    pub n_overturned: usize,
    pub n_flight: usize,
    pub n_failed: usize,
    /// One per configured IM, in order.
    pub ims: Vec<ImFragility>,
    /// Indices into `ims` of the fitted IMs, by increasing β (the most efficient first).
    pub ranking: Vec<usize>,
    pub surface: Option<Surface>,
}

/// Percentile bootstrap 95 % interval ([`INTERVAL_95`], type 7: [`percentile_sorted`]), or
/// None with no values.
#[must_use]
pub fn percentile_interval(values: &[f64]) -> Option<[f64; 2]> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    Some(INTERVAL_95.map(|q| percentile_sorted(&v, q)))
}

/// The bootstrap weights of replicate `b`: how many times each of `n_records` records is
/// drawn in `n_records` draws with replacement, from the seed `derived_seed(seed, b)`.
#[must_use]
pub fn bootstrap_weights(seed: u64, b: usize, n_records: usize) -> Vec<f64> {
    let mut rng = rng_from_seed(crate::lhs::derived_seed(seed, b));
    let mut w = vec![0.0; n_records];
    for _ in 0..n_records {
        w[uniform_below(&mut rng, n_records as u64) as usize] += 1.0;
    }
    w
}

/// Fits the lognormal of IM i to `counts` with record weights `weights`.
fn fit_im(
    config: &FragilityConfig,
    prepared: &Prepared,
    counts: &[Vec<CellCounts>],
    weights: &[f64],
    i: usize,
) -> Result<LognormalFit, FitError> {
    let (x, n, k) = groups(config, prepared, counts, weights, i);
    fit_lognormal_groups(&x, &n, &k)
}

/// Fits every IM, the bootstrap intervals, the ranking and the surface.
#[must_use]
pub fn analyse(
    config: &FragilityConfig,
    prepared: &Prepared,
    runs: &[RunResult],
) -> FragilityResult {
    let n_records = prepared.ims.len();
    let counts = cell_counts(config, n_records, runs);
    let any_flight = runs.iter().any(|r| r.status == RunStatus::Flight);
    let flight_counts =
        any_flight.then(|| counts_with(config, n_records, runs, FlightRuns::Overturned));
    let ones = vec![1.0; n_records];
    let fitted: Vec<usize> = (0..config.ims.len())
        .filter(|&i| config.ims[i].scale_exponent() != 0.0)
        .collect();
    // Replicates in parallel, each from its own seed; collected in replicate order.
    let replicates: Vec<Vec<Result<LognormalFit, FitError>>> = (0..config.bootstrap)
        .into_par_iter()
        .map(|b| {
            let w = bootstrap_weights(config.seed, b, n_records);
            fitted
                .iter()
                .map(|&i| fit_im(config, prepared, &counts, &w, i))
                .collect()
        })
        .collect();
    let mut ims = Vec::with_capacity(config.ims.len());
    for (i, im) in config.ims.iter().enumerate() {
        let is_stripe_im = matches!(config.intensity, Intensity::Stripes { im, .. } if im == i);
        let Some(slot) = fitted.iter().position(|&f| f == i) else {
            ims.push(ImFragility {
                im: *im,
                fit: Err(FitError::TooFewGroups),
                note: Some(format!(
                    "{} does not change when a record is scaled: not fitted alone (use it in \
                     the two-IM surface)",
                    im.name()
                )),
                ci_median: None,
                ci_beta: None,
                bootstrap: Vec::new(),
                bootstrap_failed: 0,
                is_stripe_im,
                median_flight_overturned: None,
            });
            continue;
        };
        let fit = fit_im(config, prepared, &counts, &ones, i);
        let boot: Vec<(f64, f64)> = replicates
            .iter()
            .filter_map(|r| r[slot].as_ref().ok().map(|f| (f.median, f.beta)))
            .collect();
        let failed = replicates.len() - boot.len();
        let medians: Vec<f64> = boot.iter().map(|b| b.0).collect();
        let betas: Vec<f64> = boot.iter().map(|b| b.1).collect();
        ims.push(ImFragility {
            im: *im,
            note: None,
            ci_median: percentile_interval(&medians).filter(|_| fit.is_ok()),
            ci_beta: percentile_interval(&betas).filter(|_| fit.is_ok()),
            fit,
            bootstrap: boot,
            bootstrap_failed: failed,
            is_stripe_im,
            median_flight_overturned: flight_counts
                .as_ref()
                .and_then(|c| fit_im(config, prepared, c, &ones, i).ok())
                .map(|f| f.median),
        });
    }
    let mut ranking: Vec<usize> = (0..ims.len()).filter(|&i| ims[i].fit.is_ok()).collect();
    ranking.sort_by(|&a, &b| {
        let beta = |i: usize| ims[i].fit.as_ref().map_or(f64::INFINITY, |f| f.beta);
        beta(a).total_cmp(&beta(b)).then(a.cmp(&b))
    });
    let surface = config.surface.map(|pair| {
        let (x, n, k) = surface_groups(config, prepared, &counts, pair);
        let fit = fit_surface(&x, &n, &k);
        let range = |c: usize| {
            x.iter()
                .map(|v| v[c])
                .filter(|v| v.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v), hi.max(v))
                })
        };
        let grid = |c: usize| {
            let (lo, hi) = range(c);
            if lo.is_finite() && hi > lo {
                log_spaced(lo.exp(), hi.exp(), config.surface_grid)
            } else {
                Vec::new()
            }
        };
        let (grid1, grid2) = (grid(0), grid(1));
        let p = match &fit {
            Ok(f) => grid1
                .iter()
                .map(|&a| grid2.iter().map(|&b| f.probability(a, b)).collect())
                .collect(),
            Err(_) => Vec::new(),
        };
        Surface {
            ims: pair,
            fit,
            grid1,
            grid2,
            p,
        }
    });
    let count = |s: RunStatus| runs.iter().filter(|r| r.status == s).count();
    FragilityResult {
        n_runs: runs.len(),
        n_overturned: count(RunStatus::Overturned),
        n_flight: count(RunStatus::Flight),
        n_failed: count(RunStatus::Failed),
        ims,
        ranking,
        surface,
    }
}

/// Wilson score interval of a binomial proportion k/n at `z` (95 %: [`Z_95`]); (0, 1) for
/// n = 0.
#[must_use]
pub fn wilson_interval(k: f64, n: f64, z: f64) -> (f64, f64) {
    if n <= 0.0 {
        return (0.0, 1.0);
    }
    let p = k / n;
    let z2 = z * z;
    let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
    let half = z / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
    ((centre - half).max(0.0), (centre + half).min(1.0))
}
