//! The real-time block stepper: a [`RigidBlock`] advances across one input interval at a
//! time, given the ground acceleration at the interval's two ends (linearly interpolated in
//! between), with bounded work and no heap allocation.
//!
//! Inside an interval the active mode's equations are integrated by Dormand–Prince 5(4); every
//! mode change, impact, lift-off and overturn is located as a root of its event function on
//! the dense output (spec §8), not as a sign change at a step end. Rest is handled in closed
//! form: the rest-consistent set {g' > 0, −min(μs, tan α₊) g' ≤ ẍg ≤ min(μs, tan α₋) g'} is
//! convex and the input is linear, so rest holds over an interval iff it holds at both ends,
//! and the exit time is the root of a linear function.
//!
//! The body is the general planar body of docs/general-body.md; every per-pivot constant
//! (R_σ, α_σ, inertia about the pivot, impact ratio) is taken from the pivot in use.
//!
//! State vector `y = [θ (rad), θ̇ (rad/s), u (m), u̇ (m/s)]`; see spec §1 for the signs.

use std::cell::Cell;

use nalgebra::{Vector2, Vector4};

use super::equations::{
    effective_gravity, rocking, slide_rocking, sliding, GroundAccel, PivotDynamics,
};
use super::impact::{impact, ImpactKind};
use super::params::BlockParams;
use crate::ode::{locate_root, DenseStep, Dopri5, OdeError, OdeSystem, Tolerance};

/// The response mode of a block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Flat on the ground, moving with it.
    Rest,
    /// Flat, slipping (both corners in contact).
    Slide,
    /// Rotating about one corner without slip.
    Rock,
    /// Rotating about one corner while that corner slips.
    SlideRock,
    /// Fallen over (terminal).
    Overturned,
    /// Lost contact with the ground (terminal: reported, integration stops).
    Flight,
}

impl Mode {
    /// Every mode, in the order of their wire codes.
    pub const ALL: [Mode; 6] = [
        Mode::Rest,
        Mode::Slide,
        Mode::Rock,
        Mode::SlideRock,
        Mode::Overturned,
        Mode::Flight,
    ];

    /// The name used in JSON and text output (`"slide-rock"` etc.).
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Rest => "rest",
            Mode::Slide => "slide",
            Mode::Rock => "rock",
            Mode::SlideRock => "slide-rock",
            Mode::Overturned => "overturned",
            Mode::Flight => "flight",
        }
    }
}

impl std::fmt::Display for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A mode with its discrete variables: pivot corner σ and slip direction s (±1).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Rest,
    Slide { s: f64 },
    Rock { sigma: f64 },
    SlideRock { sigma: f64, s: f64 },
    Overturned,
    Flight,
}

impl Phase {
    fn mode(self) -> Mode {
        match self {
            Phase::Rest => Mode::Rest,
            Phase::Slide { .. } => Mode::Slide,
            Phase::Rock { .. } => Mode::Rock,
            Phase::SlideRock { .. } => Mode::SlideRock,
            Phase::Overturned => Mode::Overturned,
            Phase::Flight => Mode::Flight,
        }
    }
}

/// Numerical and modelling options of the stepper.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockOptions {
    /// Integrator error tolerance (θ in rad, u in m).
    pub tolerance: Tolerance,
    /// Zeno cutoff (spec §9.3): an impact whose post-impact free-rocking excursion would be
    /// below `zeno_fraction·α` lands the block flat.
    pub zeno_fraction: f64,
    /// Impacts whose pre-impact velocity corresponds to an excursion ≥ this fraction of α are
    /// counted as significant.
    pub significant_fraction: f64,
    /// Offset (s) of the right limit at which a new mode is selected (spec §7); never taken
    /// past the end of the current input interval.
    pub right_limit_s: f64,
    /// First trial step (s) after a mode change.
    pub initial_step_s: f64,
    /// Bound on integrator steps plus events within one input interval.
    pub max_work_per_interval: u32,
}

impl Default for BlockOptions {
    fn default() -> Self {
        BlockOptions {
            tolerance: Tolerance::default(),
            zeno_fraction: 1e-7,
            significant_fraction: 0.01,
            right_limit_s: 1e-9,
            initial_step_s: 1e-4,
            max_work_per_interval: 20_000,
        }
    }
}

/// Something that happened inside an interval, at data time `t_s` (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BlockEvent {
    /// The mode changed.
    ModeChange { t_s: f64, from: Mode, to: Mode },
    /// The block returned to θ = 0 and struck the ground with the other corner.
    Impact {
        t_s: f64,
        kind: ImpactKind,
        theta_dot_before: f64,
        theta_dot_after: f64,
        slip_dot_before: f64,
        slip_dot_after: f64,
        /// Pre-impact excursion ≥ `significant_fraction`·α.
        significant: bool,
        /// The impact ended rocking (Zeno cutoff or flat landing).
        landed: bool,
    },
    /// A peak of |θ| (θ̇ = 0 while rotating outward stops).
    Peak { t_s: f64, theta_rad: f64 },
    /// |θ| crossed α, upward (`true`) or downward.
    AlphaCrossing { t_s: f64, upward: bool },
}

/// Why an interval could not be completed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum AdvanceError {
    #[error("non-finite ground acceleration")]
    NonFiniteInput,
    #[error("interval length must be positive and finite, got {0} s")]
    BadInterval(f64),
    #[error("integrator failed: {0}")]
    Ode(#[from] OdeError),
    #[error("work budget of one interval exhausted at t = {t_s} s (chattering between modes?)")]
    WorkBudget { t_s: f64 },
}

/// Response extremes and counters accumulated since the block was created.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct ResponseStats {
    /// max |θ| (rad); π/2 once overturned.
    pub max_abs_theta_rad: f64,
    /// max |θ|/α_σ over time, α_σ the uplift angle of the pivot θ leans to (1 = centre of
    /// mass above the pivot); max |θ|/α for a rectangle.
    pub max_abs_theta_over_alpha: f64,
    /// max |u| (m), slip of the contact point relative to the ground, before any overturn.
    pub max_abs_slide_m: f64,
    /// |θ| exceeded α at some time.
    pub exceeded_alpha: bool,
    pub n_impacts: u32,
    pub n_impacts_significant: u32,
    pub n_flat_landings: u32,
    pub n_zeno_landings: u32,
    /// Lift-offs (free flight) detected.
    pub n_flights: u32,
    /// Mode selections where no candidate passed every consistency check (should stay 0).
    pub n_inconsistent_selections: u32,
    /// Last upward crossing of |θ| = α (s).
    pub last_alpha_upcrossing_s: Option<f64>,
    /// Time of overturn, defined as the last upward crossing of |θ| = α before the fall (s).
    pub overturn_time_s: Option<f64>,
}

/// A symmetric rest condition (spec §7): a flat body at rest stays at rest under the ground
/// acceleration (ẍg, ÿg) if the effective gravity g' = `gravity_mps2` + ÿg is positive and
/// |ẍg| ≤ `friction_limit`·g', where `friction_limit` = min(μs, tan α₊, tan α₋) covers both
/// the sliding (μs) and the rocking (tan α±) thresholds: exact for a symmetric body, a
/// sufficient condition for an asymmetric one ([`RigidBlock::rest_limit`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestLimit {
    /// min(μs, tan α) (dimensionless).
    pub friction_limit: f64,
    /// Gravity g (m/s²).
    pub gravity_mps2: f64,
}

impl RestLimit {
    /// True when rest is consistent for `ground`: g' = g + ÿg > 0 and
    /// |ẍg| ≤ fl(`friction_limit`·g'), evaluated exactly as written here (the station-wide
    /// rest check's proof relies on these operations).
    #[inline]
    #[must_use]
    pub fn holds(self, ground: GroundAccel) -> bool {
        let gp = self.gravity_mps2 + ground.vertical_mps2;
        let limit = self.friction_limit * gp;
        gp > 0.0 && ground.horizontal_mps2.abs() <= limit
    }
}

/// Everything a block at rest carries besides its parameters, options and clock: what
/// [`RigidBlock::rest_record`] keeps and [`RigidBlock::from_rest_record`] restores (an
/// ensemble member at rest is stored as this, `engine::members`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestRecord {
    /// u (m), the slip accumulated before the block came to rest.
    pub slide_m: f64,
    /// The integrator's next trial step (s): [`Dopri5::reset`] keeps a smaller one.
    pub next_step_s: f64,
}

/// Rest limits `[min(μs, tan α₊), min(μs, tan α₋)]` of a body (see [`RigidBlock`]).
#[inline]
#[must_use]
pub fn rest_limits_of(params: &BlockParams) -> [f64; 2] {
    [
        params.mu_s.min(params.plus.tan_alpha),
        params.mu_s.min(params.minus.tan_alpha),
    ]
}

/// Rest is consistent for this ground acceleration (spec §7, docs/general-body.md §6):
/// g' = `gravity_mps2` + ÿg > 0 and −`limits[0]`·g' ≤ ẍg ≤ `limits[1]`·g' (a ground pushed to
/// +x tips the body onto its −x pivot); `limits` from [`rest_limits_of`]. The one rest test of
/// a block, whether it is a [`RigidBlock`] or stored compactly at rest.
#[inline]
#[must_use]
pub fn rest_holds_with(gravity_mps2: f64, limits: [f64; 2], ground: GroundAccel) -> bool {
    let gp = gravity_mps2 + ground.vertical_mps2;
    let a = ground.horizontal_mps2;
    gp > 0.0 && a <= limits[1] * gp && -a <= limits[0] * gp
}

/// A rigid block and its full dynamic state.
#[derive(Debug, Clone)]
pub struct RigidBlock {
    params: BlockParams,
    options: BlockOptions,
    phase: Phase,
    time_s: f64,
    y: Vector4<f64>,
    integrator: Dopri5<4>,
    stats: ResponseStats,
    /// Zeno cutoff θ̇² per pivot, `[+x, −x]` (spec §9.3).
    zeno_theta_dot_sq: [f64; 2],
    /// θ̇² of a significant impact per pivot, `[+x, −x]`.
    significant_theta_dot_sq: [f64; 2],
    /// Rest limits on |ẍg|/g' towards each pivot, `[min(μs, tan α₊), min(μs, tan α₋)]`
    /// (precomputed: the rest test runs on every sample of every block at rest).
    rest_limits: [f64; 2],
}

/// The rocking mode's moving part `[θ, θ̇]` (u stays, u̇ = 0), integrated on its own.
struct RockPart<'a>(&'a ModeSystem);

impl OdeSystem<2> for RockPart<'_> {
    #[inline]
    fn derivative(&self, t: f64, y: &Vector2<f64>) -> Vector2<f64> {
        let m = self.0;
        let Phase::Rock { sigma } = m.phase else {
            return Vector2::zeros();
        };
        let d = rocking(&m.params, sigma, y[0], y[1], m.ground(t));
        Vector2::new(y[1], d.theta_ddot)
    }

    #[inline]
    fn derivative_at_step_end(&self, t: f64, y: &Vector2<f64>) -> Vector2<f64> {
        let m = self.0;
        let Phase::Rock { sigma } = m.phase else {
            return Vector2::zeros();
        };
        let d = rocking(&m.params, sigma, y[0], y[1], m.ground(t));
        m.remember(t, y[0], y[1], d);
        Vector2::new(y[1], d.theta_ddot)
    }
}

/// One accepted step with its dense output, over the full state or the rocking part.
enum Dense {
    Full(DenseStep<4>),
    Rocking {
        step: DenseStep<2>,
        slide: f64,
        slide_velocity: f64,
    },
}

impl Dense {
    #[inline]
    fn t1(&self) -> f64 {
        match self {
            Dense::Full(s) => s.t1(),
            Dense::Rocking { step, .. } => step.t1(),
        }
    }

    /// The state at the step's end (u, u̇ plus 0.0, as the full step computes them).
    #[inline]
    fn y1(&self) -> Vector4<f64> {
        match self {
            Dense::Full(s) => s.y1,
            Dense::Rocking {
                step,
                slide,
                slide_velocity,
            } => Vector4::new(step.y1[0], step.y1[1], slide + 0.0, slide_velocity + 0.0),
        }
    }

    /// The interpolated state at `t` in the step.
    #[inline]
    fn eval(&self, t: f64) -> Vector4<f64> {
        match self {
            Dense::Full(s) => s.eval(t),
            Dense::Rocking {
                step,
                slide,
                slide_velocity,
            } => {
                let y = step.eval(t);
                Vector4::new(y[0], y[1], slide + 0.0, slide_velocity + 0.0)
            }
        }
    }
}

/// Index of pivot σ in the per-pivot arrays `[+x, −x]`.
#[inline]
fn side_index(sigma: f64) -> usize {
    usize::from(sigma < 0.0)
}

// Indices of the event functions; the first four are terminal. Every event function is
// positive while the current mode is valid.
const EV_IMPACT: usize = 0; // σθ
const EV_SLIP: usize = 1; // rock: μs N − |F|; slide, slide-rock: s u̇
const EV_CONTACT: usize = 2; // N (pivot modes) or g' (slide)
const EV_OVERTURN: usize = 3; // π/2 − σθ
const EV_ALPHA: usize = 4; // σθ − α (non-terminal, both directions)
const EV_PEAK: usize = 5; // σθ̇ (non-terminal, + → −)
const N_TERMINAL: usize = 4;

/// The active mode's equations with the interval's linear input, in local time t ∈ [0, dt].
struct ModeSystem {
    params: BlockParams,
    phase: Phase,
    start: GroundAccel,
    slope: GroundAccel,
    /// The last pivot-mode evaluation: the bits of (t, θ, θ̇) and its dynamics. The event
    /// functions at a step's end take the dynamics the step's last stage (its FSAL derivative)
    /// computed at the same point instead of evaluating them again: the same numbers, one
    /// `sin_cos` and the force balance less per step.
    last: Cell<([u64; 3], PivotDynamics)>,
}

impl ModeSystem {
    fn new(params: BlockParams, phase: Phase, start: GroundAccel, slope: GroundAccel) -> Self {
        ModeSystem {
            params,
            phase,
            start,
            slope,
            // No evaluation has these bits (a NaN time never occurs).
            last: Cell::new((
                [f64::NAN.to_bits(); 3],
                PivotDynamics {
                    theta_ddot: 0.0,
                    slip_ddot: 0.0,
                    friction_per_mass: 0.0,
                    normal_per_mass: 0.0,
                },
            )),
        }
    }

    /// Remembers the pivot mode's dynamics `d` at `t`, `y` (see [`ModeSystem::last`]).
    #[inline]
    fn remember(&self, t: f64, theta: f64, theta_dot: f64, d: PivotDynamics) {
        self.last
            .set(([t.to_bits(), theta.to_bits(), theta_dot.to_bits()], d));
    }

    /// The last remembered dynamics if they were evaluated at exactly `t`, `y`.
    #[inline]
    fn recall(&self, t: f64, y: &Vector4<f64>) -> Option<PivotDynamics> {
        let (key, d) = self.last.get();
        (key == [t.to_bits(), y[0].to_bits(), y[1].to_bits()]).then_some(d)
    }

    #[inline]
    fn ground(&self, t: f64) -> GroundAccel {
        GroundAccel {
            horizontal_mps2: self.start.horizontal_mps2 + self.slope.horizontal_mps2 * t,
            vertical_mps2: self.start.vertical_mps2 + self.slope.vertical_mps2 * t,
        }
    }

    #[inline]
    fn events(&self, t: f64, y: &Vector4<f64>) -> [f64; 6] {
        let p = &self.params;
        let ground = self.ground(t);
        match self.phase {
            Phase::Slide { s } => [1.0, s * y[3], effective_gravity(p, ground), 1.0, 0.0, 0.0],
            Phase::Rock { sigma } => {
                let d = self
                    .recall(t, y)
                    .unwrap_or_else(|| rocking(p, sigma, y[0], y[1], ground));
                pivot_events(
                    p,
                    sigma,
                    y,
                    p.mu_s * d.normal_per_mass - d.friction_per_mass.abs(),
                    d.normal_per_mass,
                )
            }
            Phase::SlideRock { sigma, s } => {
                let d = self
                    .recall(t, y)
                    .unwrap_or_else(|| slide_rocking(p, sigma, s, y[0], y[1], ground));
                pivot_events(p, sigma, y, s * y[3], d.normal_per_mass)
            }
            Phase::Rest | Phase::Overturned | Phase::Flight => [1.0; 6],
        }
    }

    /// Event function `index` alone: `self.events(t, y)[index]` bit for bit. In a pivot
    /// mode the geometric events (impact σθ, overturn π/2 − σθ, α-crossing σθ − α, peak σθ̇)
    /// depend on the state only, so they are computed without the mode's dynamics (a
    /// `sin_cos` and the force balance per evaluation less while a root is located).
    #[inline]
    fn event(&self, index: usize, t: f64, y: &Vector4<f64>) -> f64 {
        match (self.phase, index) {
            (
                Phase::Rock { sigma } | Phase::SlideRock { sigma, .. },
                EV_IMPACT | EV_OVERTURN | EV_ALPHA | EV_PEAK,
            ) => geometric_event(&self.params, sigma, y, index),
            _ => self.events(t, y)[index],
        }
    }
}

/// The geometric event `index` (impact, overturn, α-crossing or peak) of a pivot mode on
/// corner `sigma`: the one definition, used by [`pivot_events`] and [`ModeSystem::event`].
#[inline]
fn geometric_event(p: &BlockParams, sigma: f64, y: &Vector4<f64>, index: usize) -> f64 {
    let st = sigma * y[0];
    match index {
        EV_IMPACT => st,
        EV_OVERTURN => std::f64::consts::FRAC_PI_2 - st,
        EV_ALPHA => st - p.side(sigma).alpha_rad,
        _ => sigma * y[1],
    }
}

#[inline]
fn pivot_events(p: &BlockParams, sigma: f64, y: &Vector4<f64>, slip: f64, normal: f64) -> [f64; 6] {
    let geometric = |index| geometric_event(p, sigma, y, index);
    [
        geometric(EV_IMPACT),
        slip,
        normal,
        geometric(EV_OVERTURN),
        geometric(EV_ALPHA),
        geometric(EV_PEAK),
    ]
}

impl OdeSystem<4> for ModeSystem {
    #[inline]
    fn derivative(&self, t: f64, y: &Vector4<f64>) -> Vector4<f64> {
        let p = &self.params;
        let ground = self.ground(t);
        match self.phase {
            Phase::Slide { s } => Vector4::new(0.0, 0.0, y[3], sliding(p, s, ground)),
            Phase::Rock { sigma } => {
                let d = rocking(p, sigma, y[0], y[1], ground);
                Vector4::new(y[1], d.theta_ddot, 0.0, 0.0)
            }
            Phase::SlideRock { sigma, s } => {
                let d = slide_rocking(p, sigma, s, y[0], y[1], ground);
                Vector4::new(y[1], d.theta_ddot, y[3], d.slip_ddot)
            }
            Phase::Rest | Phase::Overturned | Phase::Flight => Vector4::zeros(),
        }
    }

    /// As `derivative`, remembering a pivot mode's dynamics for the event functions at the
    /// step's end ([`ModeSystem::last`]).
    #[inline]
    fn derivative_at_step_end(&self, t: f64, y: &Vector4<f64>) -> Vector4<f64> {
        let p = &self.params;
        let ground = self.ground(t);
        match self.phase {
            Phase::Rock { sigma } => {
                let d = rocking(p, sigma, y[0], y[1], ground);
                self.remember(t, y[0], y[1], d);
                Vector4::new(y[1], d.theta_ddot, 0.0, 0.0)
            }
            Phase::SlideRock { sigma, s } => {
                let d = slide_rocking(p, sigma, s, y[0], y[1], ground);
                self.remember(t, y[0], y[1], d);
                Vector4::new(y[1], d.theta_ddot, y[3], d.slip_ddot)
            }
            _ => self.derivative(t, y),
        }
    }
}

#[inline]
fn sign(x: f64) -> f64 {
    if x < 0.0 {
        -1.0
    } else {
        1.0
    }
}

impl RigidBlock {
    /// A block at rest at time 0.
    #[must_use]
    pub fn new(params: BlockParams, options: BlockOptions) -> Self {
        RigidBlock {
            params,
            options,
            phase: Phase::Rest,
            time_s: 0.0,
            y: Vector4::zeros(),
            integrator: Dopri5::new(options.tolerance, options.initial_step_s),
            stats: ResponseStats::default(),
            zeno_theta_dot_sq: [
                params
                    .plus
                    .theta_dot_sq_for_excursion(options.zeno_fraction),
                params
                    .minus
                    .theta_dot_sq_for_excursion(options.zeno_fraction),
            ],
            rest_limits: rest_limits_of(&params),
            significant_theta_dot_sq: [
                params
                    .plus
                    .theta_dot_sq_for_excursion(options.significant_fraction),
                params
                    .minus
                    .theta_dot_sq_for_excursion(options.significant_fraction),
            ],
        }
    }

    /// A block released at time 0 rotated by `theta_rad` about corner sgn θ with angular
    /// velocity `theta_dot` and no slip (for free-vibration studies and tests).
    #[must_use]
    pub fn released(
        params: BlockParams,
        options: BlockOptions,
        theta_rad: f64,
        theta_dot: f64,
    ) -> Self {
        let mut block = RigidBlock::new(params, options);
        if theta_rad != 0.0 || theta_dot != 0.0 {
            let sigma = if theta_rad != 0.0 {
                sign(theta_rad)
            } else {
                sign(theta_dot)
            };
            block.phase = Phase::Rock { sigma };
            block.y = Vector4::new(theta_rad, theta_dot, 0.0, 0.0);
            block.stats.max_abs_theta_rad = theta_rad.abs();
            block.stats.max_abs_theta_over_alpha = params.theta_over_alpha(theta_rad).abs();
        }
        block
    }

    pub fn params(&self) -> &BlockParams {
        &self.params
    }
    /// Current mode.
    #[must_use]
    pub fn mode(&self) -> Mode {
        self.phase.mode()
    }
    /// Data time of the state (s), the sum of all interval lengths advanced.
    #[must_use]
    pub fn time_s(&self) -> f64 {
        self.time_s
    }
    /// θ (rad), + = clockwise about the right corner.
    #[must_use]
    pub fn theta_rad(&self) -> f64 {
        self.y[0]
    }
    /// θ̇ (rad/s).
    #[must_use]
    pub fn theta_dot(&self) -> f64 {
        self.y[1]
    }
    /// u (m): cumulative slip of the contact point relative to the ground, + to the right.
    #[must_use]
    pub fn slide_m(&self) -> f64 {
        self.y[2]
    }
    /// u̇ (m/s).
    #[must_use]
    pub fn slide_velocity_mps(&self) -> f64 {
        self.y[3]
    }
    /// Extremes and counters so far.
    #[must_use]
    pub fn stats(&self) -> &ResponseStats {
        &self.stats
    }
    /// Tells the stepper that the ground input jumps here (after a data gap or a change of
    /// sample rate): the integrator's stored derivative is stale and is dropped.
    pub fn input_discontinuity(&mut self) {
        self.integrator.reset(self.options.initial_step_s);
    }

    /// Ends a free flight once the effective gravity g + ÿg is positive again, for a monitor
    /// that must go on after a lift-off. The flight itself is not modelled (spec §10: it is
    /// detected and reported); the block is put down flat and at rest, keeping its slide u.
    /// Returns true if it landed.
    pub fn land_after_flight(&mut self, ground: GroundAccel) -> bool {
        if self.phase != Phase::Flight || effective_gravity(&self.params, ground) <= 0.0 {
            return false;
        }
        self.phase = Phase::Rest;
        self.y[0] = 0.0;
        self.y[1] = 0.0;
        self.y[3] = 0.0;
        self.integrator.reset(self.options.initial_step_s);
        true
    }

    /// Puts the block in the overturned state (restoring a persisted fallen block: a rock
    /// that fell stays fallen); θ is set to ±π/2 on the side it was leaning, + if upright.
    pub fn set_overturned(&mut self) {
        self.y[0] = sign(self.y[0]) * std::f64::consts::FRAC_PI_2;
        self.y[1] = 0.0;
        self.y[3] = 0.0;
        self.phase = Phase::Overturned;
    }

    /// The block's state as a [`RestRecord`] when it is at rest with nothing else to keep
    /// (θ = θ̇ = u̇ = +0, no stored derivative, as every way into rest leaves it); None
    /// otherwise. With its parameters, options and clock, [`RigidBlock::from_rest_record`]
    /// rebuilds a block that advances bit for bit as this one (only [`RigidBlock::stats`] and
    /// [`RigidBlock::step_counts`] start again from zero).
    #[must_use]
    pub fn rest_record(&self) -> Option<RestRecord> {
        let zero = |x: f64| x.to_bits() == 0;
        (self.phase == Phase::Rest
            && zero(self.y[0])
            && zero(self.y[1])
            && zero(self.y[3])
            && !self.integrator.has_stored_derivative())
        .then_some(RestRecord {
            slide_m: self.y[2],
            next_step_s: self.integrator.next_step(),
        })
    }

    /// A block at rest at `time_s` (s) from its [`RestRecord`] (see [`RigidBlock::rest_record`]).
    #[must_use]
    pub fn from_rest_record(
        params: BlockParams,
        options: BlockOptions,
        time_s: f64,
        record: RestRecord,
    ) -> Self {
        let mut block = RigidBlock::new(params, options);
        block.time_s = time_s;
        block.y[2] = record.slide_m;
        block.integrator = Dopri5::new(options.tolerance, record.next_step_s);
        block
    }

    /// Integrator step counters (accepted, rejected).
    #[must_use]
    pub fn step_counts(&self) -> (u64, u64) {
        (
            self.integrator.accepted_steps,
            self.integrator.rejected_steps,
        )
    }

    /// Advances the block across one input interval of length `dt_s`, the ground acceleration
    /// going linearly from `from` (at the current time) to `to` (at time + `dt_s`). Every
    /// event inside the interval is passed to `on_event` in time order. Does not allocate.
    ///
    /// On error the state is left at the point of failure (time may lag the input).
    pub fn advance(
        &mut self,
        dt_s: f64,
        from: GroundAccel,
        to: GroundAccel,
        mut on_event: impl FnMut(BlockEvent),
    ) -> Result<(), AdvanceError> {
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(AdvanceError::BadInterval(dt_s));
        }
        if !(from.is_finite() && to.is_finite()) {
            return Err(AdvanceError::NonFiniteInput);
        }
        // Fast path: a block at rest that stays at rest (the common case in a live network).
        if self.phase == Phase::Rest && self.rest_holds(to) && self.rest_holds(from) {
            self.time_s += dt_s;
            return Ok(());
        }
        let t0_abs = self.time_s;
        let system_slope = GroundAccel {
            horizontal_mps2: (to.horizontal_mps2 - from.horizontal_mps2) / dt_s,
            vertical_mps2: (to.vertical_mps2 - from.vertical_mps2) / dt_s,
        };
        let mut tau = 0.0;
        let mut work = 0u32;
        while tau < dt_s {
            work += 1;
            if work > self.options.max_work_per_interval {
                self.time_s = t0_abs + tau;
                return Err(AdvanceError::WorkBudget { t_s: self.time_s });
            }
            let system = ModeSystem::new(self.params, self.phase, from, system_slope);
            tau = match self.phase {
                Phase::Overturned | Phase::Flight => dt_s,
                Phase::Rest => self.advance_rest(&system, tau, dt_s, t0_abs, &mut on_event),
                _ => {
                    match self.integrate_until_event(
                        &system,
                        tau,
                        dt_s,
                        t0_abs,
                        &mut on_event,
                        &mut work,
                    ) {
                        Ok(t) => t,
                        Err(e) => {
                            self.time_s = t0_abs + tau;
                            return Err(e);
                        }
                    }
                }
            };
        }
        self.time_s = t0_abs + dt_s;
        Ok(())
    }

    /// Rest is consistent for this ground acceleration (spec §7, docs/general-body.md §6):
    /// g' > 0 and −min(μs, tan α₊) g' ≤ ẍg ≤ min(μs, tan α₋) g' (a ground pushed to +x tips
    /// the body onto its −x pivot).
    #[inline]
    fn rest_holds(&self, ground: GroundAccel) -> bool {
        rest_holds_with(self.params.gravity_mps2, self.rest_limits, ground)
    }

    /// A sufficient rest condition of the block (spec §7), symmetric, for a caller that checks
    /// many blocks at once: `min(μs, tan α₊, tan α₋)` on either side. When it holds, the
    /// block's own (possibly asymmetric) `rest_holds` holds too, since each side's limit is at
    /// least this one and rounding is monotone; for a symmetric body (a rectangle) the two are
    /// the same condition, bit for bit.
    #[inline]
    #[must_use]
    pub fn rest_limit(&self) -> RestLimit {
        RestLimit {
            friction_limit: self.rest_limits[0].min(self.rest_limits[1]),
            gravity_mps2: self.params.gravity_mps2,
        }
    }

    /// Moves the clock of a block at rest to `time_s` without stepping it, for a caller that
    /// has established that rest held at both ends of every input interval in between (the
    /// engine's station-wide rest check, `engine::rest_group`). The state is then bit for bit
    /// what [`advance`](Self::advance) would have left: on such an interval its at-rest path
    /// only adds the interval's length to the time, and the caller advanced its own clock by
    /// the same additions in the same order. Ignored (false) unless the block is at rest.
    pub fn stay_at_rest_until(&mut self, time_s: f64) -> bool {
        let at_rest = self.phase == Phase::Rest;
        if at_rest {
            self.time_s = time_s;
        }
        at_rest
    }

    /// Local time at which the input's right limit after an event at local time `t` is taken
    /// (spec §7): `t + right_limit_s`, but not past the end `dt` of the interval when the event
    /// lies inside it. The linear input is known only on this interval; extrapolating its
    /// slope beyond `dt` invents accelerations that never occur (across a near-step's 1e-9 s
    /// ramp, up to twice the step). Only an event exactly at `dt` looks ahead along the slope.
    #[inline]
    fn right_limit_time(&self, t: f64, dt: f64) -> f64 {
        let t_right = t + self.options.right_limit_s;
        if t < dt {
            t_right.min(dt)
        } else {
            t_right
        }
    }

    /// Rest from local time `tau`: returns the local time at which rest ends (or `dt`).
    fn advance_rest(
        &mut self,
        system: &ModeSystem,
        tau: f64,
        dt: f64,
        t0_abs: f64,
        on_event: &mut impl FnMut(BlockEvent),
    ) -> f64 {
        let p = &self.params;
        let [c_plus, c_minus] = self.rest_limits;
        // Margins c₋·g' − ẍg and c₊·g' + ẍg, linear in t; rest holds while both are ≥ 0.
        let margins = |t: f64| {
            let g = system.ground(t);
            let gp = effective_gravity(p, g);
            [
                c_minus * gp - g.horizontal_mps2,
                c_plus * gp + g.horizontal_mps2,
            ]
        };
        let (m_start, m_end) = (margins(tau), margins(dt));
        let mut exit = f64::INFINITY;
        for i in 0..2 {
            if m_end[i] < 0.0 {
                let t = if m_start[i] < 0.0 {
                    tau
                } else {
                    tau + (dt - tau) * m_start[i] / (m_start[i] - m_end[i])
                };
                exit = exit.min(t);
            }
        }
        if exit > dt {
            return dt;
        }
        let selection_t = self.right_limit_time(exit, dt);
        let new_phase = self.select_flat(system.ground(selection_t), 0.0);
        if new_phase == Phase::Rest {
            // Rest still consistent just after the computed exit (rounding): move past it.
            return selection_t.min(dt);
        }
        self.enter(new_phase, t0_abs + exit, on_event);
        exit
    }

    /// Integrates the current pivot or slide mode from local time `tau` until the next
    /// terminal event or the end of the interval; returns the local time reached.
    fn integrate_until_event(
        &mut self,
        system: &ModeSystem,
        mut tau: f64,
        dt: f64,
        t0_abs: f64,
        on_event: &mut impl FnMut(BlockEvent),
        work: &mut u32,
    ) -> Result<f64, AdvanceError> {
        let root_tol = 1e-13 * dt.max(1.0);
        let mut g_start = system.events(tau, &self.y);
        let pivoting = matches!(self.phase, Phase::Rock { .. } | Phase::SlideRock { .. });
        while tau < dt {
            *work += 1;
            if *work > self.options.max_work_per_interval {
                return Err(AdvanceError::WorkBudget { t_s: t0_abs + tau });
            }
            let step = match self.phase {
                // Rocking: u and u̇ stay put; only [θ, θ̇] is integrated (bit for bit the same
                // steps as the full state, see `Dopri5::step_leading`).
                Phase::Rock { .. } => Dense::Rocking {
                    step: self.integrator.step_leading(
                        &RockPart(system),
                        tau,
                        &Vector2::new(self.y[0], self.y[1]),
                        dt,
                    )?,
                    slide: self.y[2],
                    slide_velocity: self.y[3],
                },
                _ => Dense::Full(self.integrator.step(system, tau, &self.y, dt)?),
            };
            let t1 = step.t1();
            let y1 = step.y1();
            let g_end = system.events(t1, &y1);
            let dense = &step;
            let event_at = |i: usize| move |t: f64| system.event(i, t, &dense.eval(t));

            // Earliest terminal event in (tau, t1].
            let mut terminal: Option<(f64, usize)> = None;
            for i in 0..N_TERMINAL {
                let t_hit = if g_start[i] > 0.0 && g_end[i] <= 0.0 {
                    locate_root(event_at(i), tau, g_start[i], t1, g_end[i], root_tol)
                } else if g_start[i] < 0.0 || (g_start[i] == 0.0 && g_end[i] < 0.0) {
                    tau // already violated: act at once
                } else {
                    continue;
                };
                if terminal.is_none_or(|(t, _)| t_hit < t) {
                    terminal = Some((t_hit, i));
                }
            }
            let t_stop = terminal.map_or(t1, |(t, _)| t);

            // Non-terminal events before the stop.
            if pivoting {
                let (a0, a1) = (g_start[EV_ALPHA], g_end[EV_ALPHA]);
                if (a0 > 0.0) != (a1 > 0.0) {
                    let t_cross = if a0 > 0.0 {
                        locate_root(event_at(EV_ALPHA), tau, a0, t1, a1, root_tol)
                    } else {
                        locate_root(|t| -event_at(EV_ALPHA)(t), tau, -a0, t1, -a1, root_tol)
                    };
                    if t_cross <= t_stop {
                        let upward = a1 > 0.0;
                        if upward {
                            self.stats.exceeded_alpha = true;
                            self.stats.last_alpha_upcrossing_s = Some(t0_abs + t_cross);
                        }
                        on_event(BlockEvent::AlphaCrossing {
                            t_s: t0_abs + t_cross,
                            upward,
                        });
                    }
                }
                if g_start[EV_PEAK] > 0.0 && g_end[EV_PEAK] <= 0.0 {
                    let t_peak = locate_root(
                        event_at(EV_PEAK),
                        tau,
                        g_start[EV_PEAK],
                        t1,
                        g_end[EV_PEAK],
                        root_tol,
                    );
                    if t_peak <= t_stop {
                        let theta = step.eval(t_peak)[0];
                        self.record_extremes(theta, self.y[2]);
                        on_event(BlockEvent::Peak {
                            t_s: t0_abs + t_peak,
                            theta_rad: theta,
                        });
                    }
                }
            }

            match terminal {
                None => {
                    self.y = y1;
                    self.record_extremes(self.y[0], self.y[2]);
                    tau = t1;
                    g_start = g_end;
                }
                Some((t_hit, index)) => {
                    self.y = step.eval(t_hit);
                    self.record_extremes(self.y[0], self.y[2]);
                    let ground = system.ground(self.right_limit_time(t_hit, dt));
                    self.on_terminal(index, t0_abs + t_hit, ground, on_event);
                    return Ok(t_hit);
                }
            }
        }
        Ok(tau)
    }

    fn record_extremes(&mut self, theta: f64, slide: f64) {
        let s = &mut self.stats;
        s.max_abs_theta_rad = s.max_abs_theta_rad.max(theta.abs());
        s.max_abs_theta_over_alpha = s
            .max_abs_theta_over_alpha
            .max(self.params.theta_over_alpha(theta).abs());
        s.max_abs_slide_m = s.max_abs_slide_m.max(slide.abs());
    }

    /// Switches to `phase` at absolute time `t_s`, reporting the change.
    fn enter(&mut self, phase: Phase, t_s: f64, on_event: &mut impl FnMut(BlockEvent)) {
        let from = self.phase.mode();
        self.phase = phase;
        match phase {
            Phase::Rest => {
                self.y[0] = 0.0;
                self.y[1] = 0.0;
                self.y[3] = 0.0;
            }
            Phase::Slide { .. } => {
                self.y[0] = 0.0;
                self.y[1] = 0.0;
            }
            Phase::Rock { .. } => self.y[3] = 0.0,
            Phase::Overturned => {
                self.stats.overturn_time_s =
                    Some(self.stats.last_alpha_upcrossing_s.unwrap_or(t_s));
            }
            Phase::Flight => self.stats.n_flights += 1,
            Phase::SlideRock { .. } => {}
        }
        self.integrator.reset(self.options.initial_step_s);
        if from != phase.mode() {
            on_event(BlockEvent::ModeChange {
                t_s,
                from,
                to: phase.mode(),
            });
        }
    }

    /// Handles terminal event `index` at absolute time `t_s`; `ground` is the input just after.
    fn on_terminal(
        &mut self,
        index: usize,
        t_s: f64,
        ground: GroundAccel,
        on_event: &mut impl FnMut(BlockEvent),
    ) {
        match (index, self.phase) {
            (EV_OVERTURN, _) => self.enter(Phase::Overturned, t_s, on_event),
            (EV_CONTACT, Phase::Rock { sigma } | Phase::SlideRock { sigma, .. }) => {
                let next = self.lost_contact(sigma);
                self.enter(next, t_s, on_event);
            }
            (EV_CONTACT, _) => self.enter(Phase::Flight, t_s, on_event),
            (EV_IMPACT, Phase::Rock { sigma } | Phase::SlideRock { sigma, .. }) => {
                self.on_impact(sigma, t_s, ground, on_event);
            }
            (EV_SLIP, Phase::Slide { .. }) => {
                self.y[3] = 0.0;
                let next = self.select_flat(ground, 0.0);
                self.enter(next, t_s, on_event);
            }
            (EV_SLIP, Phase::Rock { sigma }) => {
                // Friction demand reached μs N: the pivot starts to slip (spec §8). Rock is
                // not re-tested here: the demand is rising through the limit.
                let next = self.select_slip_direction(sigma, ground);
                self.enter(next, t_s, on_event);
            }
            (EV_SLIP, Phase::SlideRock { sigma, .. }) => {
                // The pivot's slip stopped: rock if friction holds it, else slip reverses.
                self.y[3] = 0.0;
                let next = self.select_pivot(sigma, ground);
                self.enter(next, t_s, on_event);
            }
            _ => {}
        }
    }

    fn on_impact(
        &mut self,
        sigma: f64,
        t_s: f64,
        ground: GroundAccel,
        on_event: &mut impl FnMut(BlockEvent),
    ) {
        let (w0, v0) = (self.y[1], self.y[3]);
        let out = impact(&self.params, sigma, w0, v0);
        self.stats.n_impacts += 1;
        let significant = w0 * w0 >= self.significant_theta_dot_sq[side_index(sigma)];
        if significant {
            self.stats.n_impacts_significant += 1;
        }
        let zeno = out.kind != ImpactKind::FlatLanding
            && out.theta_dot * out.theta_dot < self.zeno_theta_dot_sq[side_index(out.sigma_new)];
        let landed = zeno || out.kind == ImpactKind::FlatLanding;
        self.y[0] = 0.0;
        self.y[3] = out.slip_dot;
        on_event(BlockEvent::Impact {
            t_s,
            kind: out.kind,
            theta_dot_before: w0,
            theta_dot_after: if landed { 0.0 } else { out.theta_dot },
            slip_dot_before: v0,
            slip_dot_after: out.slip_dot,
            significant,
            landed,
        });
        let next = if landed {
            if zeno {
                self.stats.n_zeno_landings += 1;
            } else {
                self.stats.n_flat_landings += 1;
            }
            self.y[1] = 0.0;
            self.select_flat(ground, out.slip_dot)
        } else {
            self.y[1] = out.theta_dot;
            if out.slip_dot == 0.0 {
                self.select_pivot(out.sigma_new, ground)
            } else {
                Phase::SlideRock {
                    sigma: out.sigma_new,
                    s: sign(out.slip_dot),
                }
            }
        };
        // The pivot changed even when the mode did not: always restart the integrator.
        self.enter(next, t_s, on_event);
    }

    /// The block on corner `sigma` loses contact (N → 0): overturned if it is beyond α and
    /// rotating outward (no restoring moment in flight, spec §10), else free flight.
    fn lost_contact(&self, sigma: f64) -> Phase {
        if sigma * self.y[0] > self.params.side(sigma).alpha_rad && sigma * self.y[1] > 0.0 {
            Phase::Overturned
        } else {
            Phase::Flight
        }
    }

    /// Mode selection for a flat block (θ = θ̇ = 0) with slip velocity `slip_dot` (spec §7):
    /// the first consistent of rest → rock → slide → slide-rock.
    fn select_flat(&mut self, ground: GroundAccel, slip_dot: f64) -> Phase {
        let p = self.params;
        let gp = effective_gravity(&p, ground);
        if gp <= 0.0 {
            return Phase::Flight;
        }
        // Flat sliding in direction s keeps the normal resultant inside the base iff
        // μk h ≤ b_s, i.e. μk ≤ tan α_s (spec §6, docs/general-body.md §5).
        let slide_possible = |s: f64| p.mu_k <= p.side(s).tan_alpha;
        if slip_dot != 0.0 {
            let s = sign(slip_dot);
            return if slide_possible(s) {
                Phase::Slide { s }
            } else {
                Phase::SlideRock { sigma: s, s }
            };
        }
        if self.rest_holds(ground) {
            return Phase::Rest;
        }
        let sigma = -sign(ground.horizontal_mps2);
        let rock = rocking(&p, sigma, 0.0, 0.0, ground);
        if sigma * rock.theta_ddot > 0.0
            && rock.normal_per_mass > 0.0
            && rock.friction_per_mass.abs() <= p.mu_s * rock.normal_per_mass
        {
            return Phase::Rock { sigma };
        }
        let s = sigma;
        if slide_possible(s) && s * sliding(&p, s, ground) > 0.0 {
            return Phase::Slide { s };
        }
        for (sg, sl) in [(sigma, s), (sigma, -s), (-sigma, s), (-sigma, -s)] {
            let d = slide_rocking(&p, sg, sl, 0.0, 0.0, ground);
            if sg * d.theta_ddot > 0.0 && sl * d.slip_ddot > 0.0 && d.normal_per_mass > 0.0 {
                return Phase::SlideRock { sigma: sg, s: sl };
            }
        }
        self.stats.n_inconsistent_selections += 1;
        if sigma * rock.theta_ddot > 0.0 {
            Phase::Rock { sigma }
        } else {
            Phase::Slide { s }
        }
    }

    /// Mode selection for a block on corner `sigma` whose pivot has no slip velocity:
    /// rock if the friction demand |F| ≤ μs N, else slide-rock against the friction force.
    fn select_pivot(&mut self, sigma: f64, ground: GroundAccel) -> Phase {
        let p = self.params;
        let (theta, theta_dot) = (self.y[0], self.y[1]);
        let rock = rocking(&p, sigma, theta, theta_dot, ground);
        if rock.normal_per_mass <= 0.0 {
            return self.lost_contact(sigma);
        }
        if rock.friction_per_mass.abs() <= p.mu_s * rock.normal_per_mass {
            return Phase::Rock { sigma };
        }
        self.select_slip_direction(sigma, ground)
    }

    /// Slide-rock on corner `sigma` for a pivot that starts to slip: the slip direction is
    /// opposite to the friction force the pivot needed (s = −sgn F), checked by s ü > 0.
    fn select_slip_direction(&mut self, sigma: f64, ground: GroundAccel) -> Phase {
        let p = self.params;
        let (theta, theta_dot) = (self.y[0], self.y[1]);
        let rock = rocking(&p, sigma, theta, theta_dot, ground);
        let s_first = -sign(rock.friction_per_mass);
        for s in [s_first, -s_first] {
            let d = slide_rocking(&p, sigma, s, theta, theta_dot, ground);
            if d.normal_per_mass > 0.0 && s * d.slip_ddot > 0.0 {
                return Phase::SlideRock { sigma, s };
            }
        }
        self.stats.n_inconsistent_selections += 1;
        Phase::SlideRock { sigma, s: s_first }
    }
}
