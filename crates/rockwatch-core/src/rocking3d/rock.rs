//! The real-time 3-D stepper: one [`Rock3d::advance`] per input interval.
//!
//! # State (ground frame, module doc of [`super`])
//! - `x`: centre of mass (m), starting at (0, 0, h);
//! - `q`: rotation body → ground (unit quaternion), starting at the identity;
//! - `v`: velocity of the centre of mass relative to the ground (m/s);
//! - `ω`: angular velocity (rad/s, ground axes).
//!
//! # Modes
//! - [`Mode3d::Rest`]: standing on the resting facet, fixed to the ground; not integrated. Each
//!   interval costs the closed-form test of [`RestCondition`] at its end; when it fails, the
//!   instant rest breaks is found by bisection on the interval (the rest set is convex) and
//!   the body moves from there.
//! - [`Mode3d::Moving`]: Moreau–Jean time-stepping in sub-steps of at most
//!   [`Rock3dOptions::max_step_s`], the ground acceleration linearly interpolated (its value at
//!   the sub-step's midpoint, the exact mean of the linear input). One sub-step Δt:
//!   1. free velocity v_free = v + Δt·(−a_g − g·Z); ω unchanged;
//!   2. contact candidates: every hull vertex whose height (gap) is below
//!      2·Δt·(|v_free| + |ω|·R_max) + 10⁻⁹·R_max (no cap on their number); μ = μk for a vertex
//!      whose horizontal velocity exceeds [`Rock3dOptions::slip_speed_mps`] at the start of
//!      the step, μs otherwise;
//!   3. impulses by [`super::solver`] (restitution 0, speculative gap: a vertex may fall by at
//!      most its gap), giving v⁺, ω⁺;
//!   4. x += Δt·v⁺; q ← exp(Δt·ω⁺)·q (normalised); ω ← I_w(q⁺)⁻¹·I_w(q)·ω⁺: the world angular
//!      momentum is carried over the rotation (the gyroscopic term; exact momentum in flight);
//!   5. gap stabilisation by projection: if the lowest vertex is below the ground the body is
//!      lifted by that depth (positions only: no energy is injected through velocities).
//!
//!   The body returns to rest when every resting-facet vertex is within
//!   [`Rock3dOptions::rest_gap_m`] of the ground, every point of the hull moves slower than
//!   [`Rock3dOptions::rest_speed_mps`] and the rest test holds; the pose is then snapped flat
//!   (keeping the twist and the horizontal position).
//! - [`Mode3d::Overturned`]: terminal (criteria in docs/rocking-3d.md and [`Rock3d::advance`]).

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::body::RockBody;
use super::ground::GroundAccel3d;
use super::rest::RestCondition;
use super::solver::ContactSolver;

/// A step is shortened to end at a vertex's landing only if that leaves at least this fraction
/// of [`Rock3dOptions::max_step_s`] (closer landings are caught by the speculative gap).
const MIN_SPLIT: f64 = 0.05;

/// Numerical options of the 3-D stepper.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rock3dOptions {
    /// Longest sub-step (s). Default 0.25 ms: the stepper is first order at impacts, and with
    /// exactly solved contacts a box's peak tilt/α under one-sine pulses is within about 1 %
    /// of the event-driven planar engine at 0.25 ms, but off by up to 3–4 % at 0.33–1 ms
    /// (docs/rocking-3d.md, Cost).
    pub max_step_s: f64,
    /// Impulse convergence of the contact solver, as a fraction of one step's weight impulse.
    pub solver_tolerance: f64,
    /// Most Gauss–Seidel sweeps per step.
    pub max_sweeps: u32,
    /// A contact vertex moving horizontally faster than this (m/s) uses μk.
    pub slip_speed_mps: f64,
    /// Return-to-rest thresholds: speed of every hull point (m/s) and height of every resting
    /// vertex above the ground (m).
    pub rest_speed_mps: f64,
    pub rest_gap_m: f64,
    /// The body is in flight when no contact carries an impulse and every vertex is higher
    /// than this (m).
    pub flight_gap_m: f64,
    /// Gravity (m/s²).
    pub gravity_mps2: f64,
    /// Stop (mode [`Mode3d::Overturned`]) once the rock has fallen (criteria of
    /// [`Rock3d::advance`]); `false` keeps integrating (e.g. a tumbling body in the tests).
    pub stop_at_overturn: bool,
}

impl Default for Rock3dOptions {
    fn default() -> Self {
        Rock3dOptions {
            max_step_s: 2.5e-4,
            solver_tolerance: 1e-6,
            max_sweeps: 500,
            slip_speed_mps: 1e-6,
            rest_speed_mps: 1e-5,
            rest_gap_m: 1e-6,
            flight_gap_m: 1e-6,
            gravity_mps2: crate::STANDARD_GRAVITY_MPS2,
            stop_at_overturn: true,
        }
    }
}

/// What the body is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode3d {
    Rest,
    Moving,
    Overturned,
}

/// Why an interval could not be advanced.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum Advance3dError {
    #[error("non-finite ground acceleration")]
    NonFiniteInput,
    #[error("interval length must be positive and finite, got {0} s")]
    BadInterval(f64),
    #[error("friction must satisfy 0 ≤ μk ≤ μs (finite), got μs = {0}, μk = {1}")]
    Friction(f64, f64),
}

/// Response extremes and counters since the body was created.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Stats3d {
    /// Largest tilt (rad): angle between the body's initial up axis and the vertical.
    pub max_tilt_rad: f64,
    /// Azimuth (degrees clockwise from north, [0, 360)) towards which the top had moved at
    /// the largest tilt.
    pub max_tilt_azimuth_deg: f64,
    /// Largest tilt/α(d), d the current tilt azimuth and α(d) = atan(r(d)/h) the uplift angle
    /// of that direction; 1 = centre of mass above the support polygon's edge.
    pub max_tilt_over_alpha: f64,
    /// Tilt azimuth at the largest tilt/α (degrees).
    pub max_tilt_over_alpha_azimuth_deg: f64,
    /// tilt/α exceeded 1 at some time.
    pub exceeded_alpha: bool,
    /// Last upward crossing of tilt/α = 1 (s).
    pub last_alpha_upcrossing_s: Option<f64>,
    /// Overturn time: the last upward crossing of tilt/α = 1 before the fall (s).
    pub overturn_time_s: Option<f64>,
    /// Largest horizontal displacement of the centre of mass relative to the ground (m).
    pub max_slide_m: f64,
    /// Largest |twist| (rad), rotation about the vertical (swing–twist decomposition).
    pub max_abs_twist_rad: f64,
    /// The body was in free flight at some time (no contact, every vertex above the ground).
    pub flight: bool,
    pub first_flight_s: Option<f64>,
    /// When rest first broke (s).
    pub first_motion_s: Option<f64>,
    /// When rest last broke (s).
    pub last_motion_s: Option<f64>,
    /// Time steps taken.
    pub n_steps: u64,
    /// Returns to rest.
    pub n_rest_entries: u32,
    /// Steps whose contact solve hit the sweep limit.
    pub n_unconverged: u64,
    /// Most sweeps of one step.
    pub max_sweeps: u32,
}

/// A rigid rock on a rigid horizontal ground (module doc).
#[derive(Debug, Clone)]
pub struct Rock3d {
    body: RockBody,
    rest: RestCondition,
    options: Rock3dOptions,
    mu_s: f64,
    mu_k: f64,
    mode: Mode3d,
    time_s: f64,
    x: Vector3<f64>,
    q: UnitQuaternion<f64>,
    /// The rotation matrix of `q` (kept with it: every sub-step needs it several times).
    rot: Matrix3<f64>,
    v: Vector3<f64>,
    w: Vector3<f64>,
    solver: ContactSolver,
    above_alpha: bool,
    stats: Stats3d,
}

impl Rock3d {
    /// The body at rest on its resting facet with friction `mu_s`, `mu_k`.
    pub fn new(
        body: RockBody,
        mu_s: f64,
        mu_k: f64,
        options: Rock3dOptions,
    ) -> Result<Rock3d, Advance3dError> {
        if !(mu_s.is_finite() && mu_k.is_finite() && mu_k >= 0.0 && mu_k <= mu_s) {
            return Err(Advance3dError::Friction(mu_s, mu_k));
        }
        let rest = RestCondition::new(&body, mu_s, options.gravity_mps2);
        let n = body.vertices().len();
        let x = Vector3::new(0.0, 0.0, body.h_m());
        Ok(Rock3d {
            body,
            rest,
            options,
            mu_s,
            mu_k,
            mode: Mode3d::Rest,
            time_s: 0.0,
            x,
            q: UnitQuaternion::identity(),
            rot: Matrix3::identity(),
            v: Vector3::zeros(),
            w: Vector3::zeros(),
            solver: ContactSolver::new(n),
            above_alpha: false,
            stats: Stats3d::default(),
        })
    }

    /// The body moving from the state (`x`, `q`, `v`, `w`) (module doc; m, m/s, rad/s).
    pub fn released(
        body: RockBody,
        mu_s: f64,
        mu_k: f64,
        options: Rock3dOptions,
        state: (
            Vector3<f64>,
            UnitQuaternion<f64>,
            Vector3<f64>,
            Vector3<f64>,
        ),
    ) -> Result<Rock3d, Advance3dError> {
        let mut rock = Rock3d::new(body, mu_s, mu_k, options)?;
        (rock.x, rock.q, rock.v, rock.w) = state;
        rock.set_rotation(rock.q);
        rock.mode = Mode3d::Moving;
        Ok(rock)
    }

    #[must_use]
    pub fn body(&self) -> &RockBody {
        &self.body
    }
    #[must_use]
    pub fn mode(&self) -> Mode3d {
        self.mode
    }
    #[must_use]
    pub fn time_s(&self) -> f64 {
        self.time_s
    }
    /// Centre of mass (m, ground frame).
    #[must_use]
    pub fn position(&self) -> Vector3<f64> {
        self.x
    }
    /// Rotation body → ground.
    #[must_use]
    pub fn rotation(&self) -> UnitQuaternion<f64> {
        self.q
    }
    /// Velocity of the centre of mass relative to the ground (m/s).
    #[must_use]
    pub fn velocity(&self) -> Vector3<f64> {
        self.v
    }
    /// Angular velocity (rad/s, ground axes).
    #[must_use]
    pub fn angular_velocity(&self) -> Vector3<f64> {
        self.w
    }
    #[must_use]
    pub fn stats(&self) -> &Stats3d {
        &self.stats
    }
    /// The closed-form rest condition of this body.
    #[must_use]
    pub fn rest_condition(&self) -> &RestCondition {
        &self.rest
    }

    /// Tilt (rad) and its azimuth (degrees clockwise from north, [0, 360)) of the current
    /// pose: the angle between the body's initial up axis and the vertical, and the
    /// horizontal direction towards which that axis leans.
    #[must_use]
    pub fn tilt(&self) -> (f64, f64) {
        let u = self.q * Vector3::z();
        let horizontal = u.x.hypot(u.y);
        (
            horizontal.atan2(u.z),
            u.x.atan2(u.y).to_degrees().rem_euclid(360.0),
        )
    }

    /// Rotation about the vertical (rad, (−π, π], counter-clockwise seen from above): the
    /// twist of the swing–twist decomposition q = q_swing·q_twist(Z).
    #[must_use]
    pub fn twist_rad(&self) -> f64 {
        let q = self.q.quaternion();
        let t = 2.0 * q.k.atan2(q.w);
        if t > std::f64::consts::PI {
            t - 2.0 * std::f64::consts::PI
        } else if t <= -std::f64::consts::PI {
            t + 2.0 * std::f64::consts::PI
        } else {
            t
        }
    }

    /// Static friction μs and kinetic friction μk.
    #[must_use]
    pub fn friction(&self) -> (f64, f64) {
        (self.mu_s, self.mu_k)
    }

    /// Stands the body up again at rest on its resting facet, at time 0, with fresh
    /// statistics (an operator's reset; no allocation).
    pub fn reset(&mut self) {
        self.mode = Mode3d::Rest;
        self.time_s = 0.0;
        self.x = Vector3::new(0.0, 0.0, self.body.h_m());
        self.set_rotation(UnitQuaternion::identity());
        self.v = Vector3::zeros();
        self.w = Vector3::zeros();
        for p in &mut self.solver.impulse {
            *p = Vector3::zeros();
        }
        self.solver.contacts.clear();
        self.above_alpha = false;
        self.stats = Stats3d::default();
    }

    /// Sets the clock of a body at rest to `time_s` (s) and returns true; a body not at rest
    /// is left alone (false). For a caller that skipped intervals in which rest provably held
    /// (the engine's station-wide rest check): resting for them changes nothing but the time.
    pub fn stay_at_rest_until(&mut self, time_s: f64) -> bool {
        let at_rest = self.mode == Mode3d::Rest;
        if at_rest {
            self.time_s = time_s;
        }
        at_rest
    }

    /// Sets the pose's rotation and its matrix.
    fn set_rotation(&mut self, q: UnitQuaternion<f64>) {
        self.q = q;
        self.rot = *q.to_rotation_matrix().matrix();
    }

    /// Marks the body overturned (e.g. by an outside decision); terminal.
    pub fn set_overturned(&mut self) {
        self.mode = Mode3d::Overturned;
    }

    /// Advances over one input interval of `dt_s` seconds, the ground acceleration going
    /// linearly from `from` to `to`. Never allocates.
    ///
    /// Overturn (terminal) is declared after a sub-step when
    /// - the tilt reaches π/2, or
    /// - tilt/α(d) > 1 and a hull vertex outside the resting facet carries a contact impulse
    ///   (the rock has passed its balance point and landed on another part of its hull), or
    /// - the body is in flight with tilt/α(d) > 1 and the tilt increasing (spec §10).
    pub fn advance(
        &mut self,
        dt_s: f64,
        from: GroundAccel3d,
        to: GroundAccel3d,
    ) -> Result<(), Advance3dError> {
        if !(dt_s > 0.0 && dt_s.is_finite()) {
            return Err(Advance3dError::BadInterval(dt_s));
        }
        if !(from.is_finite() && to.is_finite()) {
            return Err(Advance3dError::NonFiniteInput);
        }
        let t0 = self.time_s;
        let mut w = 0.0;
        loop {
            match self.mode {
                Mode3d::Overturned => break,
                Mode3d::Rest => {
                    if self.rest.holds(to) && self.rest.holds(from.lerp(to, w)) {
                        break;
                    }
                    w = self.leave_rest(from, to, w);
                    self.mode = Mode3d::Moving;
                    let t = t0 + w * dt_s;
                    self.stats.first_motion_s.get_or_insert(t);
                    self.stats.last_motion_s = Some(t);
                }
                Mode3d::Moving => {
                    w = self.integrate(t0, dt_s, from, to, w);
                    if w >= 1.0 {
                        break;
                    }
                }
            }
        }
        self.time_s = t0 + dt_s;
        Ok(())
    }

    /// The first fraction of the interval at which rest fails, given that it holds at `w`
    /// (bisection: the rest set is convex, the input linear).
    fn leave_rest(&self, from: GroundAccel3d, to: GroundAccel3d, w: f64) -> f64 {
        if !self.rest.holds(from.lerp(to, w)) {
            return w;
        }
        let (mut lo, mut hi) = (w, 1.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if self.rest.holds(from.lerp(to, mid)) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi
    }

    /// Time-steps from the fraction `w0` of the interval to its end, or until the body comes
    /// to rest or overturns; returns the fraction reached.
    fn integrate(
        &mut self,
        t0: f64,
        dt_s: f64,
        from: GroundAccel3d,
        to: GroundAccel3d,
        w0: f64,
    ) -> f64 {
        let max_step = self.options.max_step_s;
        let mut w = w0;
        while w < 1.0 {
            let remaining = (1.0 - w) * dt_s;
            let mut h = remaining / (remaining / max_step).ceil().max(1.0);
            // End the step when a vertex lands (impact located at the step boundary).
            let ttc = self.time_to_contact();
            let split = ttc >= MIN_SPLIT * max_step && ttc < h;
            if split {
                h = ttc;
            }
            let wb = if !split && h >= remaining {
                1.0
            } else {
                (w + h / dt_s).min(1.0)
            };
            self.step(h, from.lerp(to, 0.5 * (w + wb)));
            self.time_s = t0 + wb * dt_s;
            w = wb;
            if self.mode == Mode3d::Overturned {
                return 1.0;
            }
            if self.can_rest(from.lerp(to, wb)) {
                self.snap_to_rest();
                return wb;
            }
        }
        1.0
    }

    /// The shortest time (s) in which a vertex above the ground would reach it at its current
    /// velocity (∞ if none approaches).
    fn time_to_contact(&self) -> f64 {
        let rot = self.rot;
        let mut best = f64::INFINITY;
        for rb in self.body.vertices() {
            let r = rot * rb;
            let gap = self.x.z + r.z;
            let un = self.v.z + self.w.x * r.y - self.w.y * r.x;
            if gap > 0.0 && un < 0.0 {
                best = best.min(gap / -un);
            }
        }
        best
    }

    fn can_rest(&self, a: GroundAccel3d) -> bool {
        let o = &self.options;
        if self.v.norm() + self.w.norm() * self.body.radius_m() > o.rest_speed_mps {
            return false;
        }
        let row = self.rot.row(2);
        let lifted = self.body.vertices()[..self.body.n_resting()]
            .iter()
            .any(|r| self.x.z + row.dot(&r.transpose()) > o.rest_gap_m);
        !lifted && self.rest.holds(a)
    }

    fn snap_to_rest(&mut self) {
        let q = self.q.quaternion();
        self.set_rotation(UnitQuaternion::new_normalize(nalgebra::Quaternion::new(
            q.w, 0.0, 0.0, q.k,
        )));
        self.x.z = self.body.h_m();
        self.v = Vector3::zeros();
        self.w = Vector3::zeros();
        for p in &mut self.solver.impulse {
            *p = Vector3::zeros();
        }
        self.solver.contacts.clear();
        self.above_alpha = false;
        self.mode = Mode3d::Rest;
        self.stats.n_rest_entries += 1;
    }

    /// Rotates the pose by `w`·`h` and carries the world angular momentum over the rotation
    /// (the gyroscopic term): returns the angular velocity in the new pose.
    fn drift(&mut self, h: f64, v: Vector3<f64>, w: Vector3<f64>) -> Vector3<f64> {
        let rot = self.rot;
        let l = rot * (self.body.inertia() * (rot.transpose() * w));
        self.x += v * h;
        self.set_rotation(UnitQuaternion::new_normalize(
            (UnitQuaternion::from_scaled_axis(w * h) * self.q).into_inner(),
        ));
        let rot = self.rot;
        rot * (self.body.inertia_inv() * (rot.transpose() * l))
    }

    /// Fills the solver with the contact candidates of the current pose: every vertex lower
    /// than `reach` (m), its speculative target −max(gap, 0)/`horizon` (m/s) and its μ (from
    /// its slip velocity `self.v + self.w × r`). Returns the world inverse inertia.
    fn collect_contacts(&mut self, reach: f64, horizon: f64) -> Matrix3<f64> {
        let o = self.options;
        let inv_mass = 1.0 / self.body.mass_kg();
        let rot = self.rot;
        let i_inv_world: Matrix3<f64> = rot * self.body.inertia_inv() * rot.transpose();
        self.solver.contacts.clear();
        for (i, rb) in self.body.vertices().iter().enumerate() {
            let r = rot * rb;
            let gap = self.x.z + r.z;
            if gap <= reach {
                let u = self.v + self.w.cross(&r);
                let mu = if u.x * u.x + u.y * u.y > o.slip_speed_mps * o.slip_speed_mps {
                    self.mu_k
                } else {
                    self.mu_s
                };
                let target = if horizon > 0.0 {
                    -gap.max(0.0) / horizon
                } else {
                    0.0
                };
                let c = ContactSolver::contact(i, r, target, mu, inv_mass, &i_inv_world);
                self.solver.contacts.push(c);
            } else {
                self.solver.impulse[i] = Vector3::zeros();
            }
        }
        i_inv_world
    }

    /// The plastic impact of the vertices touching the ground (gap ≤ `touch`) at the current
    /// pose, if one of them approaches: the contact problem without forces, targets 0.
    fn impact(&mut self, h: f64) {
        let touch = 1e-9 * self.body.radius_m();
        let rot = self.rot;
        let approaching = self.body.vertices().iter().any(|rb| {
            let r = rot * rb;
            let un = self.v.z + self.w.x * r.y - self.w.y * r.x;
            self.x.z + r.z <= touch && un < -self.options.slip_speed_mps
        });
        if !approaching {
            return;
        }
        let i_inv_world = self.collect_contacts(touch, 0.0);
        for c in &self.solver.contacts {
            self.solver.impulse[c.vertex] = Vector3::zeros();
        }
        let (mut v, mut w) = (self.v, self.w);
        let m = self.body.mass_kg();
        let o = self.options;
        let report = self.solver.solve(
            &mut v,
            &mut w,
            1.0 / m,
            &i_inv_world,
            o.solver_tolerance * m * o.gravity_mps2 * h,
            o.max_sweeps,
        );
        self.note_solve(report.sweeps, report.converged);
        // The impact's impulses are not a warm start for the smooth step's.
        for c in &self.solver.contacts {
            self.solver.impulse[c.vertex] = Vector3::zeros();
        }
        self.v = v;
        self.w = w;
    }

    fn note_solve(&mut self, sweeps: u32, converged: bool) {
        self.stats.max_sweeps = self.stats.max_sweeps.max(sweeps);
        if !converged {
            self.stats.n_unconverged += 1;
        }
    }

    /// One sub-step of `h` seconds under the ground acceleration `a` (module doc): the impact
    /// of vertices landing now, then Moreau's midpoint scheme (drift h/2, contact-constrained
    /// kick at the midpoint, drift h/2).
    fn step(&mut self, h: f64, a: GroundAccel3d) {
        let o = self.options;
        self.impact(h);
        let m = self.body.mass_kg();
        let half = 0.5 * h;
        let (v0, w0) = (self.v, self.w);
        self.w = self.drift(half, v0, w0);
        let force = Vector3::new(-a.east_mps2, -a.north_mps2, -(o.gravity_mps2 + a.up_mps2));
        let mut v = self.v + force * h;
        let mut w = self.w;
        let radius = self.body.radius_m();
        let reach = h * (v.norm() + w.norm() * radius) + 1e-9 * radius;
        let i_inv_world = self.collect_contacts(reach, half);
        let report = self.solver.solve(
            &mut v,
            &mut w,
            1.0 / m,
            &i_inv_world,
            o.solver_tolerance * m * o.gravity_mps2 * h,
            o.max_sweeps,
        );
        self.stats.n_steps += 1;
        self.note_solve(report.sweeps, report.converged);
        let on_other_facet =
            self.solver.contacts.iter().any(|c| {
                c.vertex >= self.body.n_resting() && self.solver.impulse[c.vertex].z > 0.0
            });
        self.w = self.drift(half, v, w);
        self.v = v;

        // Gap stabilisation by projection.
        let row = self.rot.row(2);
        let lowest = self
            .body
            .vertices()
            .iter()
            .map(|r| row.dot(&r.transpose()))
            .fold(f64::INFINITY, f64::min);
        let min_gap = self.x.z + lowest;
        if min_gap < 0.0 {
            self.x.z -= min_gap;
        }

        self.update_stats(report.normal_impulse, min_gap.max(0.0), on_other_facet);
    }

    fn update_stats(&mut self, normal_impulse: f64, min_gap: f64, on_other_facet: bool) {
        let t = self.time_s;
        let up: Vector3<f64> = self.rot.column(2).into();
        let horizontal = (up.x * up.x + up.y * up.y).sqrt();
        let tilt = horizontal.atan2(up.z);
        let s = &mut self.stats;
        let mut ratio = 0.0;
        if horizontal > 0.0 {
            let (dx, dy) = (up.x / horizontal, up.y / horizontal);
            let azimuth = || dx.atan2(dy).to_degrees().rem_euclid(360.0);
            ratio = tilt / self.body.alpha_towards(dx, dy);
            if tilt > s.max_tilt_rad {
                s.max_tilt_rad = tilt;
                s.max_tilt_azimuth_deg = azimuth();
            }
            if ratio > s.max_tilt_over_alpha {
                s.max_tilt_over_alpha = ratio;
                s.max_tilt_over_alpha_azimuth_deg = azimuth();
            }
        }
        let above = ratio > 1.0;
        if above {
            s.exceeded_alpha = true;
            if !self.above_alpha {
                s.last_alpha_upcrossing_s = Some(t);
            }
        }
        self.above_alpha = above;
        s.max_slide_m = s
            .max_slide_m
            .max((self.x.x * self.x.x + self.x.y * self.x.y).sqrt());
        let twist = {
            let q = self.q.quaternion();
            let t = 2.0 * q.k.atan2(q.w);
            // |t| modulo a full turn, in [0, π]
            let t = t.abs() % (2.0 * std::f64::consts::PI);
            t.min(2.0 * std::f64::consts::PI - t)
        };
        s.max_abs_twist_rad = s.max_abs_twist_rad.max(twist);
        let flying = normal_impulse <= 0.0 && min_gap > self.options.flight_gap_m;
        if flying && !s.flight {
            s.flight = true;
            s.first_flight_s = Some(t);
        }
        // Tilt increasing ⇔ the up axis's vertical component decreasing: (ω × u)_z < 0.
        let outward = self.w.cross(&up).z < 0.0;
        let fallen = tilt >= std::f64::consts::FRAC_PI_2
            || (above && on_other_facet)
            || (above && flying && outward);
        if fallen && self.options.stop_at_overturn {
            s.overturn_time_s = Some(s.last_alpha_upcrossing_s.unwrap_or(t));
            self.mode = Mode3d::Overturned;
        }
    }
}
