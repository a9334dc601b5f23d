//! The ensemble members of one toppling direction of a rock ([`DirectionMembers`]), stored by
//! what can still change: a member at rest is its primary parameters, its two rest limits and
//! a [`RestRecord`] on the direction's one clock; a fallen member is a tag; only a member in
//! motion is a full [`RigidBlock`]. Each member advances bit for bit as its own `RigidBlock`
//! would under [`RigidBlock::advance`] then [`RigidBlock::land_after_flight`] (the engine's
//! unbatched step), because:
//! - a member stored at rest stays at rest over an interval exactly when `RigidBlock::advance`
//!   would take its at-rest path (the same test, [`rest_holds_with`], on its own limits at
//!   both ends), and that path only adds the interval to the clock, which the direction does
//!   once for all of them with the same additions in the same order;
//! - when the direction's most demanding limit ([`RestLimit::holds`], the componentwise
//!   minimum over its members) holds at both ends, every member's own test holds too (each
//!   limit is at least the minimum, rounding is monotone: the argument of the station's rest
//!   group, `rest_group.rs`), so the members at rest are not visited at all;
//! - a member leaving rest is rebuilt ([`RigidBlock::from_rest_record`]) with parameters
//!   rebuilt by [`BlockParams::from_body`] from its primary ones (checked equal to the given
//!   parameters when stored), the direction's clock and its record, then advanced; it is
//!   stored at rest again when it is at rest on the direction's clock with a record;
//! - a fallen member's outcome never changes (overturned is terminal), so it is not visited.
//!
//! Only a member's [`RigidBlock::stats`] and step counts start again when it is rebuilt; the
//! engine reads neither of a member. The moving members' list is allocated once, for all K
//! members of the direction, when its first member moves (one allocation per direction in a
//! node's life, not a doubling series in the first seconds of strong shaking), and freed by a
//! reset (an operator's act, not the hot path).

use crate::dynamics::block::{rest_holds_with, rest_limits_of, RestRecord};
use crate::dynamics::{BlockOptions, BlockParams, GroundAccel, Mode, RestLimit, RigidBlock};

/// A member's primary parameters: the arguments of [`BlockParams::from_body`].
#[derive(Debug, Clone, Copy, PartialEq)]
struct Body {
    b_plus_m: f64,
    b_minus_m: f64,
    com_height_m: f64,
    rho_m: f64,
    mu_s: f64,
    mu_k: f64,
    restitution: Option<f64>,
}

impl Body {
    fn of(p: &BlockParams) -> Self {
        Body {
            b_plus_m: p.b_plus_m,
            b_minus_m: p.b_minus_m,
            com_height_m: p.com_height_m,
            rho_m: p.rho_m,
            mu_s: p.mu_s,
            mu_k: p.mu_k,
            restitution: p.restitution,
        }
    }

    fn build(self) -> Result<BlockParams, crate::dynamics::ParamError> {
        BlockParams::from_body(
            self.b_plus_m,
            self.b_minus_m,
            self.com_height_m,
            self.rho_m,
            self.mu_s,
            self.mu_k,
            self.restitution,
        )
    }

    /// The member's parameters (built once, and checked, when the member was stored).
    fn params(self) -> BlockParams {
        self.build()
            .expect("a stored member's primary parameters were built when it was stored")
    }
}

/// Where a member's state is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    /// At rest on the direction's clock.
    Rest(RestRecord),
    /// In [`DirectionMembers::moving`].
    Moving,
    /// Overturned (terminal).
    Fallen,
}

/// A member whose parameters are not [`BlockParams::from_body`] of its primary ones (a body
/// built field by field): it could not be rebuilt bit for bit, so it is refused.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("ensemble member {member}: its derived constants are not those of BlockParams::from_body of its primary parameters")]
pub struct MemberError {
    pub member: usize,
}

/// One member as it stands (tests, [`DirectionMembers::member`]).
#[cfg(test)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct MemberView {
    pub(super) mode: Mode,
    /// `[θ, θ̇, u, u̇]`; a fallen member's are not kept (zeros).
    pub(super) y: [f64; 4],
    /// The member's clock (s); a fallen member's is not kept (NaN).
    pub(super) time_s: f64,
}

/// The ensemble members of one direction (module doc); none (a rock without an ensemble)
/// costs one pointer.
#[derive(Debug, Clone)]
pub(super) struct DirectionMembers(Option<Box<Members>>);

/// At least one member (see [`DirectionMembers`]).
#[derive(Debug, Clone)]
struct Members {
    options: BlockOptions,
    bodies: Vec<Body>,
    /// Each member's rest limits, [`rest_limits_of`].
    limits: Vec<[f64; 2]>,
    states: Vec<State>,
    /// The members in motion (or whose clock left the direction's): member index, block.
    moving: Vec<(u32, RigidBlock)>,
    /// Clock of the members stored at rest (s).
    clock_s: f64,
    /// Members fallen.
    fallen: usize,
    /// The most demanding rest limit over every member (componentwise minimum).
    rest_limit: RestLimit,
}

impl DirectionMembers {
    /// Every member at rest at time 0 (as [`RigidBlock::new`] leaves it).
    pub(super) fn new(members: &[BlockParams], options: BlockOptions) -> Result<Self, MemberError> {
        Ok(DirectionMembers(if members.is_empty() {
            None
        } else {
            Some(Box::new(Members::new(members, options)?))
        }))
    }

    pub(super) fn len(&self) -> usize {
        self.0.as_ref().map_or(0, |m| m.len())
    }

    /// The most demanding rest limit over the members (none: no limit at all).
    pub(super) fn rest_limit(&self) -> Option<RestLimit> {
        self.0.as_ref().map(|m| m.rest_limit)
    }

    /// [`Members::advance`]; false without members.
    pub(super) fn advance(
        &mut self,
        dt_s: f64,
        from: GroundAccel,
        to: GroundAccel,
        fell: impl FnMut(usize),
    ) -> bool {
        self.0
            .as_mut()
            .is_some_and(|m| m.advance(dt_s, from, to, fell))
    }

    /// Every member at rest at `clock_s` (none fallen, none in motion).
    pub(super) fn all_resting_at(&self, clock_s: f64) -> bool {
        self.0.as_ref().is_none_or(|m| m.all_resting_at(clock_s))
    }

    /// Every member at rest or fallen.
    pub(super) fn settled(&self) -> bool {
        self.0.as_ref().is_none_or(|m| m.settled())
    }

    /// Members neither at rest nor fallen.
    pub(super) fn in_motion(&self) -> usize {
        self.0.as_ref().map_or(0, |m| m.in_motion())
    }

    /// [`RigidBlock::stay_at_rest_until`] on every member.
    pub(super) fn stay_at_rest_until(&mut self, clock_s: f64) {
        if let Some(m) = &mut self.0 {
            m.stay_at_rest_until(clock_s);
        }
    }

    /// [`RigidBlock::input_discontinuity`] on every member.
    pub(super) fn input_discontinuity(&mut self) {
        if let Some(m) = &mut self.0 {
            m.input_discontinuity();
        }
    }

    /// Every member fallen ([`RigidBlock::set_overturned`]).
    pub(super) fn set_all_fallen(&mut self) {
        if let Some(m) = &mut self.0 {
            m.set_all_fallen();
        }
    }

    /// Every member standing again at rest at time 0 ([`RigidBlock::new`]).
    pub(super) fn reset(&mut self) {
        if let Some(m) = &mut self.0 {
            m.reset();
        }
    }

    /// The same members (parameters in order).
    pub(super) fn same(&self, other: &DirectionMembers) -> bool {
        match (&self.0, &other.0) {
            (Some(a), Some(b)) => a.bodies == b.bodies,
            (None, None) => true,
            _ => false,
        }
    }

    /// Heap bytes held (allocator overhead excluded).
    pub(super) fn heap_bytes(&self) -> usize {
        self.0
            .as_ref()
            .map_or(0, |m| std::mem::size_of::<Members>() + m.heap_bytes())
    }
}

impl Members {
    fn new(members: &[BlockParams], options: BlockOptions) -> Result<Self, MemberError> {
        let mut bodies = Vec::with_capacity(members.len());
        let mut limits = Vec::with_capacity(members.len());
        let mut rest_limit = RestLimit {
            friction_limit: f64::INFINITY,
            gravity_mps2: f64::INFINITY,
        };
        for (member, p) in members.iter().enumerate() {
            let body = Body::of(p);
            if body.build().ok().as_ref() != Some(p) {
                return Err(MemberError { member });
            }
            let l = rest_limits_of(p);
            rest_limit.friction_limit = rest_limit.friction_limit.min(l[0].min(l[1]));
            rest_limit.gravity_mps2 = rest_limit.gravity_mps2.min(p.gravity_mps2);
            bodies.push(body);
            limits.push(l);
        }
        let states = vec![State::Rest(Self::fresh_record(options)); members.len()];
        Ok(Members {
            options,
            bodies,
            limits,
            states,
            moving: Vec::new(),
            clock_s: 0.0,
            fallen: 0,
            rest_limit,
        })
    }

    fn fresh_record(options: BlockOptions) -> RestRecord {
        RestRecord {
            slide_m: 0.0,
            next_step_s: options.initial_step_s,
        }
    }

    fn len(&self) -> usize {
        self.bodies.len()
    }

    /// Member `i`'s parameters.
    #[cfg(test)]
    fn params(&self, i: usize) -> BlockParams {
        self.bodies[i].params()
    }

    /// Advances every member over one interval of `dt_s` s, the ground going linearly from
    /// `from` to `to`, as [`RigidBlock::advance`] then [`RigidBlock::land_after_flight`] on
    /// each; `fell(i)` is called for each member that overturned in it. Returns true if some
    /// member's integration failed.
    fn advance(
        &mut self,
        dt_s: f64,
        from: GroundAccel,
        to: GroundAccel,
        mut fell: impl FnMut(usize),
    ) -> bool {
        let mut failed = false;
        let valid = dt_s.is_finite() && dt_s > 0.0 && from.is_finite() && to.is_finite();
        if valid {
            // The members at rest: none visited when the shared limit holds at both ends.
            let shared = self.rest_limit.holds(to) && self.rest_limit.holds(from);
            if !shared {
                let g = self.rest_limit_gravity();
                let members = self.states.len();
                for (i, state) in self.states.iter_mut().enumerate() {
                    let State::Rest(record) = *state else {
                        continue;
                    };
                    let l = self.limits[i];
                    if rest_holds_with(g, l, to) && rest_holds_with(g, l, from) {
                        continue;
                    }
                    let block = RigidBlock::from_rest_record(
                        self.bodies[i].params(),
                        self.options,
                        self.clock_s,
                        record,
                    );
                    *state = State::Moving;
                    if self.moving.capacity() == 0 {
                        // Room for every member at once: the only allocation of the list.
                        self.moving.reserve_exact(members);
                    }
                    self.moving.push((i as u32, block));
                }
            }
            self.clock_s += dt_s;
        } else {
            // `RigidBlock::advance` refuses the interval and leaves the block as it was.
            failed |= self.states.iter().any(|s| matches!(s, State::Rest(_)));
        }
        let mut k = 0;
        while k < self.moving.len() {
            let (i, block) = &mut self.moving[k];
            let i = *i as usize;
            failed |= block.advance(dt_s, from, to, |_| {}).is_err();
            block.land_after_flight(to);
            let settled = match block.mode() {
                Mode::Overturned => {
                    self.fallen += 1;
                    fell(i);
                    Some(State::Fallen)
                }
                Mode::Rest if block.time_s().to_bits() == self.clock_s.to_bits() => {
                    block.rest_record().map(State::Rest)
                }
                _ => None,
            };
            match settled {
                Some(state) => {
                    self.states[i] = state;
                    self.moving.swap_remove(k);
                }
                None => k += 1,
            }
        }
        failed
    }

    /// Gravity of the members' rest test: every stored member's own (`new` stores only bodies
    /// of `BlockParams::from_body`, all under standard gravity, so the minimum is it).
    fn rest_limit_gravity(&self) -> f64 {
        self.rest_limit.gravity_mps2
    }

    /// Every member at rest at `clock_s` (none fallen, none in motion).
    fn all_resting_at(&self, clock_s: f64) -> bool {
        self.moving
            .iter()
            .all(|(_, b)| b.mode() == Mode::Rest && b.time_s() == clock_s)
            && (self.moving.len() == self.len() || self.clock_s == clock_s)
            && self.fallen == 0
    }

    /// Every member at rest or fallen.
    fn settled(&self) -> bool {
        self.moving
            .iter()
            .all(|(_, b)| matches!(b.mode(), Mode::Rest | Mode::Overturned))
    }

    /// Members neither at rest nor fallen.
    fn in_motion(&self) -> usize {
        self.moving
            .iter()
            .filter(|(_, b)| !matches!(b.mode(), Mode::Rest | Mode::Overturned))
            .count()
    }

    /// [`RigidBlock::stay_at_rest_until`] on every member.
    fn stay_at_rest_until(&mut self, clock_s: f64) {
        self.clock_s = clock_s;
        for (_, b) in &mut self.moving {
            b.stay_at_rest_until(clock_s);
        }
    }

    /// [`RigidBlock::input_discontinuity`] on every member (a member at rest keeps the
    /// integrator's reset rule: its next trial step is at most the initial one).
    fn input_discontinuity(&mut self) {
        let initial = self.options.initial_step_s;
        for state in &mut self.states {
            if let State::Rest(record) = state {
                record.next_step_s = record.next_step_s.min(initial);
            }
        }
        for (_, b) in &mut self.moving {
            b.input_discontinuity();
        }
    }

    /// Every member fallen ([`RigidBlock::set_overturned`]).
    fn set_all_fallen(&mut self) {
        self.moving.clear();
        self.states.fill(State::Fallen);
        self.fallen = self.len();
    }

    /// Every member standing again at rest at time 0 ([`RigidBlock::new`]).
    fn reset(&mut self) {
        // Standing again: the room the moving members took is given back.
        self.moving = Vec::new();
        self.states
            .fill(State::Rest(Self::fresh_record(self.options)));
        self.clock_s = 0.0;
        self.fallen = 0;
    }

    /// Member `i` as it stands.
    #[cfg(test)]
    fn member(&self, i: usize) -> MemberView {
        match self.states[i] {
            State::Rest(r) => MemberView {
                mode: Mode::Rest,
                y: [0.0, 0.0, r.slide_m, 0.0],
                time_s: self.clock_s,
            },
            State::Fallen => MemberView {
                mode: Mode::Overturned,
                y: [0.0; 4],
                time_s: f64::NAN,
            },
            State::Moving => {
                let (_, b) = self
                    .moving
                    .iter()
                    .find(|(j, _)| *j as usize == i)
                    .expect("a member in motion is in the moving list");
                MemberView {
                    mode: b.mode(),
                    y: [
                        b.theta_rad(),
                        b.theta_dot(),
                        b.slide_m(),
                        b.slide_velocity_mps(),
                    ],
                    time_s: b.time_s(),
                }
            }
        }
    }

    /// Heap bytes held (allocator overhead excluded).
    fn heap_bytes(&self) -> usize {
        self.bodies.capacity() * std::mem::size_of::<Body>()
            + self.limits.capacity() * std::mem::size_of::<[f64; 2]>()
            + self.states.capacity() * std::mem::size_of::<State>()
            + self.moving.capacity() * std::mem::size_of::<(u32, RigidBlock)>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The engine's unbatched member step (before `DirectionMembers`): each member its own
    /// `RigidBlock`, advanced then put down after a flight.
    fn reference_step(
        blocks: &mut [RigidBlock],
        dt: f64,
        from: GroundAccel,
        to: GroundAccel,
    ) -> bool {
        let mut failed = false;
        for m in blocks {
            failed |= m.advance(dt, from, to, |_| {}).is_err();
            m.land_after_flight(to);
        }
        failed
    }

    /// Modes seen over a run (coverage of the comparisons).
    #[derive(Default)]
    struct Seen {
        modes: std::collections::HashSet<&'static str>,
        back_to_rest: usize,
        fallen: usize,
    }

    /// Runs the members and the reference over `ground` (interval `dt`), comparing every
    /// member bit for bit after every interval; an input discontinuity at `gap` if given.
    fn compare(
        params: &[BlockParams],
        ground: &[GroundAccel],
        dt: f64,
        gap: Option<usize>,
    ) -> Seen {
        let options = BlockOptions::default();
        let mut members = Members::new(params, options).expect("bodies from from_body");
        let mut reference: Vec<RigidBlock> = params
            .iter()
            .map(|p| RigidBlock::new(*p, options))
            .collect();
        let mut fallen = vec![false; params.len()];
        let mut seen = Seen::default();
        let mut was_moving = vec![false; params.len()];
        for (k, w) in ground.windows(2).enumerate() {
            if gap == Some(k) {
                members.input_discontinuity();
                reference
                    .iter_mut()
                    .for_each(RigidBlock::input_discontinuity);
            }
            let failed = members.advance(dt, w[0], w[1], |i| {
                assert!(!fallen[i], "member {i} reported fallen twice");
                fallen[i] = true;
            });
            assert_eq!(
                failed,
                reference_step(&mut reference, dt, w[0], w[1]),
                "step {k}"
            );
            for (i, r) in reference.iter().enumerate() {
                let m = members.member(i);
                assert_eq!(m.mode, r.mode(), "member {i} at step {k}");
                assert_eq!(
                    fallen[i],
                    r.mode() == Mode::Overturned,
                    "member {i} at step {k}"
                );
                seen.modes.insert(r.mode().as_str());
                if r.mode() == Mode::Overturned {
                    continue;
                }
                let y = [
                    r.theta_rad(),
                    r.theta_dot(),
                    r.slide_m(),
                    r.slide_velocity_mps(),
                ];
                assert_eq!(
                    m.y.map(f64::to_bits),
                    y.map(f64::to_bits),
                    "member {i} at step {k}"
                );
                assert_eq!(
                    m.time_s.to_bits(),
                    r.time_s().to_bits(),
                    "member {i} at step {k}"
                );
                if was_moving[i] && r.mode() == Mode::Rest {
                    seen.back_to_rest += 1;
                }
                was_moving[i] = r.mode() != Mode::Rest;
            }
            // Nothing fallen or at rest on the direction's clock is kept as a full block.
            for (i, b) in &members.moving {
                assert!(
                    b.mode() != Mode::Overturned,
                    "fallen member {i} still stepped"
                );
            }
        }
        seen.fallen = fallen.iter().filter(|f| **f).count();
        seen
    }

    fn ground(h: &[f64], v: Option<&[f64]>) -> Vec<GroundAccel> {
        h.iter()
            .enumerate()
            .map(|(i, &x)| GroundAccel {
                horizontal_mps2: x,
                vertical_mps2: v.map_or(0.0, |v| v[i]),
            })
            .collect()
    }

    fn record(name: &str) -> crate::record::Record {
        let dir = std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/records"
        ));
        crate::record::Record::read(&dir.join(name)).expect("bundled record")
    }

    /// A spread of bodies as an ensemble draws them: slender to stocky, sticky to slippery,
    /// one asymmetric, one with a restitution.
    fn ensemble(k: usize) -> Vec<BlockParams> {
        (0..k)
            .map(|m| {
                let u = m as f64 / (k - 1) as f64;
                let width = 0.3 + 0.9 * ((m * 37) % k) as f64 / k as f64;
                let height = 0.8 + 3.0 * u;
                let mu_s = 0.25 + 0.6 * ((m * 61) % k) as f64 / k as f64;
                match m % 9 {
                    4 => BlockParams::from_body(0.2, 0.35, 0.6, 0.4, mu_s, 0.8 * mu_s, None),
                    7 => BlockParams::from_width_height(width, height, mu_s, 0.8 * mu_s, Some(0.9)),
                    _ => BlockParams::from_width_height(width, height, mu_s, 0.8 * mu_s, None),
                }
                .expect("valid body")
            })
            .collect()
    }

    #[test]
    fn members_advance_as_their_own_blocks_on_the_rinaldi_record() {
        let h = record("Rinaldi228.AT2");
        let v = record("RinaldiUP.AT2");
        let n = h.horizontal_mps2.len().min(v.horizontal_mps2.len());
        // Quiet lead-in (rest), the record (motion, impacts, sliding, overturns, returns to
        // rest), its vertical scaled up so that some bodies lift off, then quiet again.
        let mut hx = vec![0.0; 50];
        let mut vx = vec![0.0; 50];
        hx.extend(&h.horizontal_mps2[..n]);
        vx.extend(v.horizontal_mps2[..n].iter().map(|x| 1.5 * x));
        hx.extend(std::iter::repeat_n(0.0, 400));
        vx.extend(std::iter::repeat_n(0.0, 400));
        let seen = compare(&ensemble(60), &ground(&hx, Some(&vx)), h.dt_s, Some(n / 2));
        for mode in ["rest", "rock", "slide", "slide-rock", "overturned"] {
            assert!(
                seen.modes.contains(mode),
                "no member in {mode}: {:?}",
                seen.modes
            );
        }
        assert!(seen.back_to_rest > 0, "no member came back to rest");
        assert!(
            seen.fallen > 0 && seen.fallen < 60,
            "{} fallen",
            seen.fallen
        );
    }

    #[test]
    fn fallen_and_resting_members_are_not_stepped() {
        let options = BlockOptions::default();
        // Slender and sticky (tan α < μs): they rock, never slide, and fall under a push.
        let params: Vec<BlockParams> = (0..10)
            .map(|m| {
                BlockParams::from_width_height(0.3 + 0.03 * m as f64, 2.0, 0.9, 0.7, None)
                    .expect("valid body")
            })
            .collect();
        let mut members = Members::new(&params, options).expect("bodies");
        let quiet = GroundAccel {
            horizontal_mps2: 0.01,
            vertical_mps2: 0.0,
        };
        members.advance(0.01, quiet, quiet, |_| panic!("nothing falls at rest"));
        assert!(
            members.moving.is_empty(),
            "members at rest on quiet ground are not stepped"
        );
        // A violent pulse: every member falls; then none is stepped any more.
        let hard = GroundAccel {
            horizontal_mps2: 30.0,
            vertical_mps2: 0.0,
        };
        let mut fell = 0;
        members.advance(0.01, hard, hard, |_| fell += 1);
        // The moving list: one allocation, room for every member.
        assert_eq!(members.moving.capacity(), params.len());
        for _ in 1..400 {
            members.advance(0.01, hard, hard, |_| fell += 1);
        }
        assert_eq!(fell, 10, "every member falls once");
        assert!(members.moving.is_empty(), "fallen members are not stepped");
        assert!(members.settled());
        members.reset();
        assert_eq!(members.moving.capacity(), 0, "a reset gives the room back");
        assert_eq!(members.member(3).mode, Mode::Rest);
        assert_eq!(members.params(3), params[3]);
    }

    #[test]
    fn a_member_built_field_by_field_is_refused() {
        let mut p = BlockParams::from_width_height(0.5, 1.5, 0.6, 0.5, None).expect("valid");
        p.gravity_mps2 = 9.7;
        let err = DirectionMembers::new(&[p], BlockOptions::default()).unwrap_err();
        assert!(DirectionMembers::new(&[], BlockOptions::default()).is_ok());
        assert_eq!(err, MemberError { member: 0 });
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn members_advance_as_their_own_blocks_on_random_records(
            amps in proptest::collection::vec(0.0f64..9.0, 3),
            freqs in proptest::collection::vec(0.3f64..6.0, 3),
            vertical in 0.0f64..12.0,
            quiet_at in 100usize..500,
            k in 3usize..24,
            gap in proptest::option::of(0usize..800),
        ) {
            let dt = 0.01;
            let n = 800;
            // Sines with a quiet stretch in the middle (rest → motion → rest → motion).
            let h: Vec<f64> = (0..n)
                .map(|i| {
                    let t = i as f64 * dt;
                    let on = if (quiet_at..quiet_at + 150).contains(&i) { 0.0 } else { 1.0 };
                    on * amps.iter().zip(&freqs).map(|(a, f)| a * (std::f64::consts::TAU * f * t).sin()).sum::<f64>()
                })
                .collect();
            let v: Vec<f64> = (0..n)
                .map(|i| vertical * (std::f64::consts::TAU * 2.3 * i as f64 * dt).sin())
                .collect();
            compare(&ensemble(k), &ground(&h, Some(&v)), dt, gap);
        }
    }
}
