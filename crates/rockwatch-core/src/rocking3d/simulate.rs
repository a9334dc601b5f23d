//! Offline 3-D simulation of a whole record through exactly the real-time API
//! ([`Rock3d::advance`], one call per input interval), followed by `t_extra_s` of zero ground
//! motion (stopped early once the rock is back at rest or has overturned: with no input a
//! rock at rest stays so).

use super::body::RockBody;
use super::ground::{GroundAccel3d, GroundMotion3d};
use super::rock::{Advance3dError, Mode3d, Rock3d, Rock3dOptions};
use crate::record::Record;
use crate::simulate::MAX_SIMULATION_STEPS;

/// Options of an offline 3-D simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Simulation3dOptions {
    /// Seconds of zero ground acceleration after the last sample.
    pub t_extra_s: f64,
    pub rock: Rock3dOptions,
}

impl Default for Simulation3dOptions {
    fn default() -> Self {
        Simulation3dOptions {
            t_extra_s: 10.0,
            rock: Rock3dOptions::default(),
        }
    }
}

/// How a 3-D simulation ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Status3d {
    /// Standing at the end (at rest or still moving).
    Ok,
    Overturned,
}

/// The response summary of one 3-D simulation (SI units; angles in rad unless named `_deg`;
/// azimuths in degrees clockwise from north; positions in the ground frame east, north, up
/// relative to the ground point below the initial centre of mass).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Summary3d {
    pub model: &'static str,
    pub status: Status3d,
    pub overturned: bool,
    /// Last upward crossing of tilt/α = 1 before the fall (s).
    pub overturn_time: Option<f64>,
    /// Largest tilt (rad) and the azimuth towards which the top had moved then.
    pub max_tilt: f64,
    pub max_tilt_azimuth_deg: f64,
    /// Largest tilt/α(d) (d the tilt azimuth, α(d) = atan(r(d)/h)) and its azimuth.
    pub max_tilt_over_alpha: f64,
    pub max_tilt_over_alpha_azimuth_deg: f64,
    pub exceeded_alpha: bool,
    /// Largest horizontal displacement of the centre of mass relative to the ground (m;
    /// includes the rocking excursion h·sin(tilt)).
    pub max_slide: f64,
    /// Horizontal displacement of the centre of mass at the end (m).
    pub residual_slide: f64,
    /// Rotation about the vertical at the end (rad, counter-clockwise seen from above) and
    /// its largest magnitude.
    pub twist: f64,
    pub max_abs_twist: f64,
    /// Final centre of mass (m) and rotation body → ground (quaternion w, x, y, z; the body
    /// frame is the resting pose's east, north, up).
    pub final_position: [f64; 3],
    pub final_rotation: [f64; 4],
    /// The rock was in free flight at some time, and when first.
    pub flight: bool,
    pub first_flight_time: Option<f64>,
    /// When rest first broke (s).
    pub first_motion_time: Option<f64>,
    /// Uplift angle (rad) of the weakest direction: min over d of atan(r(d)/h).
    pub alpha_min: f64,
    /// Simulated duration (s).
    pub duration: f64,
    pub n_steps: u64,
    pub n_rest_entries: u32,
    /// Contact solves that hit the sweep limit (should stay 0) and the most sweeps used.
    pub n_unconverged: u64,
    pub max_sweeps: u32,
}

/// Why a 3-D simulation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Simulate3dError {
    #[error("the ground motion has fewer than two samples")]
    TooShort,
    #[error("t_extra must be a finite number of seconds ≥ 0, got {0}")]
    BadExtra(f64),
    #[error(
        "{steps} input intervals (record plus t_extra at dt = {dt_s} s) exceed the limit of \
         {MAX_SIMULATION_STEPS}"
    )]
    TooManySteps { steps: f64, dt_s: f64 },
    #[error("at t = {t_s} s: {reason}")]
    Advance { t_s: f64, reason: Advance3dError },
}

/// Advances `rock` through `n` input samples at `dt_s` (`at(i)`, zero beyond the last) and
/// up to `t_extra_s` of quiet after them: one [`Rock3d::advance`] per interval, stopping once
/// the rock has overturned, or once the input has ended and it is at rest (with no input a rock
/// at rest stays so). `observe` sees the rock and its input at the start and after each
/// interval.
fn run_to_end(
    rock: &mut Rock3d,
    n: usize,
    dt_s: f64,
    t_extra_s: f64,
    at: impl Fn(usize) -> GroundAccel3d,
    mut observe: impl FnMut(&Rock3d, GroundAccel3d),
) -> Result<(), Simulate3dError> {
    if n < 2 {
        return Err(Simulate3dError::TooShort);
    }
    if !(t_extra_s.is_finite() && t_extra_s >= 0.0) {
        return Err(Simulate3dError::BadExtra(t_extra_s));
    }
    let steps = n as f64 + (t_extra_s / dt_s).ceil();
    if !(dt_s > 0.0 && steps <= MAX_SIMULATION_STEPS as f64) {
        return Err(Simulate3dError::TooManySteps { steps, dt_s });
    }
    let n_extra = (t_extra_s / dt_s).ceil() as usize;
    observe(rock, at(0));
    for i in 0..n - 1 + n_extra {
        if i + 1 >= n && rock.mode() == Mode3d::Rest {
            break;
        }
        let (from, to) = (at(i), at(i + 1));
        rock.advance(dt_s, from, to)
            .map_err(|reason| Simulate3dError::Advance {
                t_s: rock.time_s(),
                reason,
            })?;
        observe(rock, to);
        if rock.mode() == Mode3d::Overturned {
            break;
        }
    }
    Ok(())
}

/// The outcome of one run of [`simulate_3d_outcome`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome3d {
    pub overturned: bool,
    /// Largest tilt/α(d) (d the tilt azimuth).
    pub max_tilt_over_alpha: f64,
    /// Largest horizontal displacement of the centre of mass (m).
    pub max_slide_m: f64,
    /// Simulated time when the run stopped (s).
    pub duration_s: f64,
}

/// `body` (friction `mu_s`, `mu_k`) under a single-component `record` applied along the
/// azimuth `azimuth_deg` of the body frame (degrees clockwise from the mesh's north axis),
/// its horizontal component multiplied by `horizontal_factor` and its vertical one (applied
/// as up, if the record has one) by `vertical_factor`: the 3-D run of a fragility analysis,
/// with the early exits of [`run_to_end`] and no ground-motion copy. With
/// `second_horizontal` (m/s², the record's orthogonal component, same instants) the record is
/// a pair: its first component along `azimuth_deg`, the second along `azimuth_deg` + 90°
/// (clockwise), both multiplied by `horizontal_factor`.
#[allow(clippy::too_many_arguments)]
pub fn simulate_3d_outcome(
    body: RockBody,
    mu_s: f64,
    mu_k: f64,
    record: &Record,
    second_horizontal: Option<&[f64]>,
    azimuth_deg: f64,
    horizontal_factor: f64,
    vertical_factor: f64,
    t_extra_s: f64,
    options: Rock3dOptions,
) -> Result<Outcome3d, Simulate3dError> {
    let mut rock = Rock3d::new(body, mu_s, mu_k, options)
        .map_err(|reason| Simulate3dError::Advance { t_s: 0.0, reason })?;
    let (s, c) = azimuth_deg.to_radians().sin_cos();
    let at = |i: usize| {
        let a = record.horizontal_mps2.get(i).copied().unwrap_or(0.0) * horizontal_factor;
        // The second component, along azimuth + 90°: east cos, north −sin of the azimuth.
        let b = second_horizontal
            .and_then(|y| y.get(i))
            .copied()
            .unwrap_or(0.0)
            * horizontal_factor;
        let up = record
            .vertical_mps2
            .as_ref()
            .and_then(|v| v.get(i))
            .copied()
            .unwrap_or(0.0);
        GroundAccel3d {
            east_mps2: a * s + b * c,
            north_mps2: a * c - b * s,
            up_mps2: up * vertical_factor,
        }
    };
    run_to_end(
        &mut rock,
        record.len(),
        record.dt_s,
        t_extra_s,
        at,
        |_, _| {},
    )?;
    let stats = rock.stats();
    Ok(Outcome3d {
        overturned: rock.mode() == Mode3d::Overturned,
        max_tilt_over_alpha: stats.max_tilt_over_alpha,
        max_slide_m: stats.max_slide_m,
        duration_s: rock.time_s(),
    })
}

/// The time history of a 3-D simulation, one entry per input sample (and per sample of the
/// quiet tail) until the end or the overturn, in the mesh's frame ([`super::report`] for what
/// each column means).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace3d {
    /// Time (s).
    pub t_s: Vec<f64>,
    /// The ground acceleration driving the rock (m/s², east, north, up of the mesh).
    pub ground: Vec<GroundAccel3d>,
    /// The rock in the planar outputs' terms (tilt, tilt/α, foot slide, direction, mode).
    pub view: Vec<super::report::PlanarView>,
    /// Centre of mass (m, ground frame).
    pub position_m: Vec<[f64; 3]>,
    /// Rotation about the vertical (rad).
    pub twist_rad: Vec<f64>,
}

impl Trace3d {
    fn push(&mut self, rock: &Rock3d, ground: GroundAccel3d) {
        let x = rock.position();
        self.t_s.push(rock.time_s());
        self.ground.push(ground);
        self.view.push(rock.planar_view());
        self.position_m.push([x.x, x.y, x.z]);
        self.twist_rad.push(rock.twist_rad());
    }
}

/// Simulates `body` (friction `mu_s`, `mu_k`) under `motion`.
pub fn simulate_3d(
    body: RockBody,
    mu_s: f64,
    mu_k: f64,
    motion: &GroundMotion3d,
    options: &Simulation3dOptions,
) -> Result<Summary3d, Simulate3dError> {
    run_3d(body, mu_s, mu_k, motion, options, |_, _| {})
}

/// [`simulate_3d`] with its time history ([`Trace3d`]).
pub fn simulate_3d_traced(
    body: RockBody,
    mu_s: f64,
    mu_k: f64,
    motion: &GroundMotion3d,
    options: &Simulation3dOptions,
) -> Result<(Summary3d, Trace3d), Simulate3dError> {
    let mut trace = Trace3d::default();
    let summary = run_3d(body, mu_s, mu_k, motion, options, |rock, a| {
        trace.push(rock, a);
    })?;
    Ok((summary, trace))
}

fn run_3d(
    body: RockBody,
    mu_s: f64,
    mu_k: f64,
    motion: &GroundMotion3d,
    options: &Simulation3dOptions,
    observe: impl FnMut(&Rock3d, GroundAccel3d),
) -> Result<Summary3d, Simulate3dError> {
    let alpha_min = body.weakest_direction().1;
    let mut rock = Rock3d::new(body, mu_s, mu_k, options.rock)
        .map_err(|reason| Simulate3dError::Advance { t_s: 0.0, reason })?;
    let at = |i: usize| motion.samples.get(i).copied().unwrap_or_default();
    run_to_end(
        &mut rock,
        motion.len(),
        motion.dt_s,
        options.t_extra_s,
        at,
        observe,
    )?;
    let s = *rock.stats();
    let overturned = rock.mode() == Mode3d::Overturned;
    let x = rock.position();
    let q = rock.rotation();
    let q = q.quaternion();
    Ok(Summary3d {
        model: "3d",
        status: if overturned {
            Status3d::Overturned
        } else {
            Status3d::Ok
        },
        overturned,
        overturn_time: s.overturn_time_s,
        max_tilt: s.max_tilt_rad,
        max_tilt_azimuth_deg: s.max_tilt_azimuth_deg,
        max_tilt_over_alpha: s.max_tilt_over_alpha,
        max_tilt_over_alpha_azimuth_deg: s.max_tilt_over_alpha_azimuth_deg,
        exceeded_alpha: s.exceeded_alpha,
        max_slide: s.max_slide_m,
        residual_slide: x.x.hypot(x.y),
        twist: rock.twist_rad(),
        max_abs_twist: s.max_abs_twist_rad,
        final_position: [x.x, x.y, x.z],
        final_rotation: [q.w, q.i, q.j, q.k],
        flight: s.flight,
        first_flight_time: s.first_flight_s,
        first_motion_time: s.first_motion_s,
        alpha_min,
        duration: rock.time_s(),
        n_steps: s.n_steps,
        n_rest_entries: s.n_rest_entries,
        n_unconverged: s.n_unconverged,
        max_sweeps: s.max_sweeps,
    })
}
