//! A station's resting blocks share one rest check per sample.
//!
//! Most blocks of a live network are at rest most of the time. A catalogued block (its
//! nominal block and every ensemble member) that is at rest, outside an episode, with no
//! alert that could be raised at rest, is **parked** in its station's [`RestGroup`]: while the
//! group's one check per sample holds, a parked block is not stepped at all, and costs one
//! byte read per sample (nothing when the whole station is parked). The check is recomputed
//! from the remaining blocks' limits when it fails (those whose own limit fails leave the
//! group and are stepped as before) and whenever a block joins.
//!
//! # The shared check never keeps at rest a block that would have left rest
//!
//! Each block i's stepper ([`RigidBlock::advance`](crate::dynamics::RigidBlock::advance))
//! takes, for an interval from ground sample `from` to `to` (both finite), its at-rest path
//! (which only adds the interval's length to its time) iff it is at rest and its
//! [`RestLimit::holds`] at both ends, i.e. for x ∈ {from, to}, in floating point (fl = round
//! to nearest; Rust does not contract `a·b + c` into a fused multiply-add):
//!
//! ```text
//!   h_i = fl(fl(e·s_i) + fl(n·c_i))      (Azimuth::component; s_i, c_i = sin, cos of the azimuth)
//!   g'_i = fl(g_i + up),  L_i = fl(k_i·g'_i)      (k_i = min(μs, tan α) of block i)
//!   rest_i(x)  ⇔  g'_i > 0  ∧  |h_i| ≤ L_i
//! ```
//!
//! The group keeps k = min k_i ≥ 0 and g = min g_i over its blocks and checks, for both ends,
//!
//! ```text
//!   H = fl(|e| + |n|) finite,  up finite,  G = fl(g + up) > 0,  H ≤ fl(k·G).
//! ```
//!
//! Claim: if the group's check holds, rest_i holds for every block i of the group, for every
//! azimuth. Proof. Rounding to nearest is monotone (x ≤ y ⇒ fl(x) ≤ fl(y)) and exact on
//! representable values. (1) |s_i|, |c_i| ≤ 1 (sine and cosine never exceed 1 in magnitude),
//! so |e·s_i| ≤ |e|, which is representable, hence |fl(e·s_i)| ≤ |e|; likewise
//! |fl(n·c_i)| ≤ |n|; then |h_i| = |fl(fl(e·s_i) + fl(n·c_i))| ≤ fl(|fl(e·s_i)| + |fl(n·c_i)|)
//! ≤ fl(|e| + |n|) = H. (2) g_i ≥ g ⇒ g_i + up ≥ g + up ⇒ g'_i ≥ G > 0. (3) k_i ≥ k ≥ 0 and
//! g'_i ≥ G > 0 ⇒ k_i·g'_i ≥ k·G ⇒ L_i ≥ fl(k·G) ≥ H ≥ |h_i|. So rest_i holds at both ends:
//! block i would have taken its at-rest path, whose only effect is `time += dt`. Finite e,
//! n, up make its input finite (|h_i| ≤ H < ∞), so it would not have failed either. ∎
//!
//! The group's clock receives the same additions `clock += dt`, in the same order, as each
//! parked block's time would have; a block joins only when its time equals the clock, and
//! leaves with its time set to the clock, so its state on leaving is bit for bit what
//! stepping it would have left. A parked block's per-sample bookkeeping is provably idle
//! (no mode change, no alert — θ = 0 and no member fallen while at rest, and the alert
//! thresholds are positive —, no episode to end); only its periodic state is due, and the
//! group keeps a lower bound of the next due time so that the exact per-block check runs
//! only from then on. Hence the engine's outputs, in content and order, are those of
//! stepping every block (`tests/engine.rs` checks this bit for bit).
//!
//! Memory: per catalogued block, one flag and one [`RestLimit`] (17 bytes plus padding).

use crate::dynamics::RestLimit;

/// One ground sample as the group sees it: east, north, up (m/s²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct GroundSample {
    pub(crate) east: f64,
    pub(crate) north: f64,
    pub(crate) up: f64,
}

/// State intervals above this (s) are not bounded (always checked exactly).
const MAX_BOUNDED_STATE_INTERVAL_S: f64 = 1e6;

/// The parked blocks of one station and their shared rest check.
#[derive(Debug, Clone)]
pub(crate) struct RestGroup {
    /// The shared check is used (on by default; off steps every block, for comparison).
    enabled: bool,
    /// Data time (s) every parked block would have: receives the same `+= dt` as they would.
    clock_s: f64,
    /// Per catalogued block (station order): parked or not.
    parked: Vec<bool>,
    /// Per catalogued block: the most demanding rest limit among its nominal and members.
    limits: Vec<RestLimit>,
    n_parked: usize,
    /// The group's limit: componentwise minimum over the parked blocks.
    group_limit: RestLimit,
    /// No parked block's state is due before this data time (ns).
    states_due_from_ns: i64,
    /// State interval (s) `states_due_from_ns` was computed with.
    bound_interval_s: f64,
}

/// The limit no block is below (the identity of the componentwise minimum).
const NO_LIMIT: RestLimit = RestLimit {
    friction_limit: f64::INFINITY,
    gravity_mps2: f64::INFINITY,
};

impl RestGroup {
    /// A group for blocks with these limits (one per catalogued block, in station order),
    /// none parked, clock at 0 (the blocks' time at creation).
    pub(crate) fn new(limits: Vec<RestLimit>) -> Self {
        RestGroup {
            enabled: true,
            clock_s: 0.0,
            parked: vec![false; limits.len()],
            limits,
            n_parked: 0,
            group_limit: NO_LIMIT,
            states_due_from_ns: i64::MAX,
            bound_interval_s: f64::NAN,
        }
    }

    /// A group for `limits` continuing `old`'s clock and switch (none parked): after the
    /// station's blocks changed (a reload), blocks kept from `old` may park again.
    pub(crate) fn continuing(old: &RestGroup, limits: Vec<RestLimit>) -> Self {
        RestGroup {
            enabled: old.enabled,
            clock_s: old.clock_s,
            ..RestGroup::new(limits)
        }
    }

    pub(crate) fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// The clock of the parked blocks (s).
    pub(crate) fn clock_s(&self) -> f64 {
        self.clock_s
    }

    /// An input interval of `dt_s` seconds was stepped (every unparked block advanced by it).
    pub(crate) fn tick(&mut self, dt_s: f64) {
        self.clock_s += dt_s;
    }

    #[inline]
    pub(crate) fn is_parked(&self, i: usize) -> bool {
        self.parked[i]
    }

    /// Every catalogued block of the station is parked.
    #[inline]
    pub(crate) fn all_parked(&self) -> bool {
        self.n_parked == self.parked.len()
    }

    /// Bytes of its per-block arrays (one flag and one limit per catalogued block).
    pub(crate) fn heap_bytes(&self) -> usize {
        self.parked.capacity() + self.limits.capacity() * std::mem::size_of::<RestLimit>()
    }

    pub(crate) fn parked_count(&self) -> usize {
        self.n_parked
    }

    pub(crate) fn any_parked(&self) -> bool {
        self.n_parked > 0
    }

    /// Whether block `i` may join: the group is on, the caller has established that the block
    /// is at rest with idle bookkeeping, and its time equals the clock.
    pub(crate) fn may_park(&self, i: usize, time_s: f64) -> bool {
        let l = self.limits[i];
        // Non-negative finite limits only (the proof's k ≥ 0; NaN fails every comparison).
        self.enabled
            && time_s == self.clock_s
            && l.friction_limit >= 0.0
            && l.friction_limit.is_finite()
            && l.gravity_mps2.is_finite()
    }

    /// Parks block `i`, whose last state was published at `last_state_ns`.
    pub(crate) fn park(&mut self, i: usize, last_state_ns: Option<i64>, state_interval_s: f64) {
        if self.parked[i] {
            return;
        }
        self.parked[i] = true;
        self.n_parked += 1;
        let l = self.limits[i];
        self.group_limit = RestLimit {
            friction_limit: self.group_limit.friction_limit.min(l.friction_limit),
            gravity_mps2: self.group_limit.gravity_mps2.min(l.gravity_mps2),
        };
        if state_interval_s != self.bound_interval_s {
            self.states_due_from_ns = i64::MIN;
        } else {
            self.states_due_from_ns = self
                .states_due_from_ns
                .min(not_due_before(last_state_ns, state_interval_s));
        }
    }

    /// The shared check over the interval `from` → `to` of `dt_s` seconds: true when every
    /// parked block would stay at rest (module doc).
    #[inline]
    pub(crate) fn holds(&self, from: GroundSample, to: GroundSample, dt_s: f64) -> bool {
        dt_s.is_finite() && dt_s > 0.0 && limit_holds(self.group_limit, from, to)
    }

    /// After the shared check failed: the blocks whose own limit fails at `from` or `to`
    /// leave the group (their clock set through `unpark`), the others stay and the group's
    /// limit is recomputed from them.
    pub(crate) fn release_failing(
        &mut self,
        from: GroundSample,
        to: GroundSample,
        dt_s: f64,
        mut unpark: impl FnMut(usize, f64),
    ) {
        let interval_ok = dt_s.is_finite() && dt_s > 0.0;
        let mut group = NO_LIMIT;
        for i in 0..self.parked.len() {
            if !self.parked[i] {
                continue;
            }
            let l = self.limits[i];
            if interval_ok && limit_holds(l, from, to) {
                group = RestLimit {
                    friction_limit: group.friction_limit.min(l.friction_limit),
                    gravity_mps2: group.gravity_mps2.min(l.gravity_mps2),
                };
            } else {
                self.parked[i] = false;
                self.n_parked -= 1;
                unpark(i, self.clock_s);
            }
        }
        self.group_limit = group;
    }

    /// Every block leaves the group (before an operation that changes blocks directly).
    pub(crate) fn release_all(&mut self, mut unpark: impl FnMut(usize, f64)) {
        for i in 0..self.parked.len() {
            if self.parked[i] {
                self.parked[i] = false;
                unpark(i, self.clock_s);
            }
        }
        self.n_parked = 0;
        self.group_limit = NO_LIMIT;
    }

    /// Whether a parked block's state may be due at data time `t_ns` (if false, none is).
    #[inline]
    pub(crate) fn states_may_be_due(&self, t_ns: i64, state_interval_s: f64) -> bool {
        self.n_parked > 0
            && (t_ns >= self.states_due_from_ns || state_interval_s != self.bound_interval_s)
    }

    /// Recomputes the due bound from the parked blocks' last state times, after their exact
    /// checks ran.
    pub(crate) fn rebound_states(
        &mut self,
        state_interval_s: f64,
        last_state_ns: impl Fn(usize) -> Option<i64>,
    ) {
        self.bound_interval_s = state_interval_s;
        self.states_due_from_ns = (0..self.parked.len())
            .filter(|&i| self.parked[i])
            .map(|i| not_due_before(last_state_ns(i), state_interval_s))
            .min()
            .unwrap_or(i64::MAX);
    }
}

/// The group check of the module doc for one limit, at both ends of an interval.
#[inline]
fn limit_holds(limit: RestLimit, from: GroundSample, to: GroundSample) -> bool {
    let ends_hold = |x: GroundSample| {
        let h_bound = x.east.abs() + x.north.abs();
        let gp = limit.gravity_mps2 + x.up;
        h_bound.is_finite() && x.up.is_finite() && gp > 0.0 && h_bound <= limit.friction_limit * gp
    };
    ends_hold(from) && ends_hold(to)
}

/// A data time (ns) before which a block whose state was last published at `last_ns` is
/// surely not due, for the station's exact test `(t − last)·1e-9 ≥ interval`.
///
/// With K = ⌊interval·1e9·(1 − 1e-6)⌋ and d = t − last < K (an integer, so d ≤ K − 1 and
/// |d| < 2^53 is exact in f64): fl(d·fl(1e-9)) ≤ interval·(1 − 1e-6)·(1 + 2^-52) < interval,
/// so the test fails. Intervals above 1e6 s, and a block never published, get no bound.
fn not_due_before(last_ns: Option<i64>, interval_s: f64) -> i64 {
    match last_ns {
        Some(last) if interval_s > 0.0 && interval_s <= MAX_BOUNDED_STATE_INTERVAL_S => {
            let k = (interval_s * 1e9 * (1.0 - 1e-6)) as i64;
            last.saturating_add(k)
        }
        _ => i64::MIN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::azimuth::Azimuth;
    use crate::dynamics::{BlockOptions, BlockParams, GroundAccel, RigidBlock};

    fn sample(east: f64, north: f64, up: f64) -> GroundSample {
        GroundSample { east, north, up }
    }

    /// Randomised check of the module doc's claim against the blocks' own test, including
    /// inputs right at the thresholds (where rounding decides).
    #[test]
    fn the_group_check_implies_every_blocks_own_rest_check() {
        let mut rng = crate::lhs::rng_from_seed(13);
        let mut uniform = |a: f64, b: f64| a + (b - a) * crate::lhs::uniform_open01(&mut rng);
        let limits: Vec<RestLimit> = (0..8)
            .map(|i| {
                let p = BlockParams::from_width_height(
                    0.5 + 0.2 * i as f64,
                    2.0,
                    0.3 + 0.1 * i as f64,
                    0.2,
                    None,
                )
                .unwrap();
                RigidBlock::new(p, BlockOptions::default()).rest_limit()
            })
            .collect();
        let mut group = RestGroup::new(limits.clone());
        for i in 0..limits.len() {
            group.park(i, None, 1.0);
        }
        let mut held = 0;
        for _ in 0..200_000 {
            let az = Azimuth::from_degrees(uniform(0.0, 360.0)).unwrap();
            // Horizontal magnitude near the smallest threshold (≈ 0.25 g here).
            let k = group.group_limit.friction_limit;
            let up = uniform(-3.0, 3.0);
            let mag = k * (9.80665 + up) * uniform(0.9, 1.0000001);
            let dir = uniform(0.0, std::f64::consts::TAU);
            let x = sample(mag * dir.sin(), mag * dir.cos(), up);
            if group.holds(x, x, 0.01) {
                held += 1;
                for l in &limits {
                    let g = GroundAccel {
                        horizontal_mps2: az.component(x.east, x.north),
                        vertical_mps2: x.up,
                    };
                    assert!(l.holds(g), "{x:?} at {az:?} breaks {l:?}");
                }
            }
        }
        assert!(
            held > 10_000,
            "the test must exercise the group check ({held})"
        );
    }

    #[test]
    fn non_finite_or_lifting_input_fails_the_check() {
        let l = RestLimit {
            friction_limit: 0.3,
            gravity_mps2: 9.80665,
        };
        let mut group = RestGroup::new(vec![l]);
        group.park(0, None, 1.0);
        let quiet = sample(0.01, 0.01, 0.0);
        assert!(group.holds(quiet, quiet, 0.01));
        for bad in [
            sample(f64::NAN, 0.0, 0.0),
            sample(f64::INFINITY, 0.0, 0.0),
            sample(0.0, 0.0, f64::INFINITY),
            sample(0.0, 0.0, -9.80665),
        ] {
            assert!(!group.holds(quiet, bad, 0.01), "{bad:?}");
            assert!(!group.holds(bad, quiet, 0.01), "{bad:?}");
        }
        assert!(!group.holds(quiet, quiet, 0.0));
    }

    #[test]
    fn a_failing_check_releases_only_the_blocks_whose_own_limit_fails() {
        let weak = RestLimit {
            friction_limit: 0.1,
            gravity_mps2: 9.80665,
        };
        let strong = RestLimit {
            friction_limit: 0.5,
            ..weak
        };
        let mut group = RestGroup::new(vec![weak, strong]);
        group.park(0, None, 1.0);
        group.park(1, None, 1.0);
        group.tick(0.01);
        let shake = sample(0.2 * 9.80665, 0.0, 0.0);
        assert!(!group.holds(shake, shake, 0.01));
        let mut released = vec![];
        group.release_failing(shake, shake, 0.01, |i, t| released.push((i, t)));
        assert_eq!(released, vec![(0, 0.01)]);
        assert!(group.is_parked(1) && !group.is_parked(0));
        assert!(
            group.holds(shake, shake, 0.01),
            "the strong block's limit alone"
        );
    }

    #[test]
    fn the_state_bound_never_skips_a_due_state() {
        // Exhaustive near the bound: for t below it the exact test must fail.
        for interval in [0.01, 0.1, 0.3, 1.0, 2.5, 3600.0, 1e6] {
            let last = 1_700_000_000_000_000_000i64;
            let bound = not_due_before(Some(last), interval);
            for t in (bound - 1000)..bound {
                assert!(((t - last) as f64 * 1e-9) < interval, "{interval} {t}");
            }
            // And it is not uselessly early.
            assert!((last + (interval * 1e9) as i64 - bound) as f64 <= interval * 1e9 * 2e-6);
        }
        assert_eq!(not_due_before(None, 1.0), i64::MIN);
        assert_eq!(not_due_before(Some(0), 1e7), i64::MIN);
    }
}
