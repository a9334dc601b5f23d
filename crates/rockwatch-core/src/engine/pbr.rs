//! One catalogued rock in the engine ([`PbrRuntime`]): its dynamics — planar blocks in each
//! toppling direction, or one 3-D rigid body ([`super::rigid_rock`]) — and what is shared by
//! both: episodes, alerts raised once per episode and level, states at the state rate, the
//! rest-group bookkeeping, reload, reset and restore.

use std::collections::HashSet;

use super::config::{AlertConfig, PbrSpec};
use super::members::{DirectionMembers, MemberError};
use super::output::{Alert, AlertKey, AlertLevel, Output, OutputSink, PbrState, RaisedLevels};
use super::rest_group::GroundSample as Sample;
use super::rigid_rock::RigidRock;
use crate::azimuth::Azimuth;
use crate::dynamics::{
    BlockEvent, BlockOptions, BlockParams, GroundAccel, Mode, RestLimit, RigidBlock,
};
use crate::pbr_id::PbrId;
use crate::rocking3d::report::PlanarView as Pose;
use crate::station_id::StationId;

/// A block's response summary (the last line of `rockwatch monitor`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PbrSummary {
    pub pbr_id: PbrId,
    pub station: StationId,
    pub max_theta_over_alpha: f64,
    pub max_slide_m: f64,
    pub overturned: bool,
    pub overturn_probability: f64,
    pub data_gap: bool,
    pub episodes: u32,
    /// Each direction's nominal response (one for a planar block; a rock from a mesh has
    /// one per azimuth, in catalogue order; a 3-D rock one, the azimuth of its largest
    /// tilt/α). The fields above are the largest over them.
    pub directions: Vec<DirectionSummary>,
}

/// One direction's nominal response in a [`PbrSummary`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DirectionSummary {
    /// Azimuth of the direction's +x axis, degrees clockwise from north (a 3-D rock: the
    /// azimuth towards which it leaned at its largest tilt/α).
    pub direction_deg: f64,
    pub max_theta_over_alpha: f64,
    pub max_slide_m: f64,
    pub overturned: bool,
}

/// One toppling direction of a catalogued rock: its blocks under the ground motion projected
/// on its azimuth.
#[derive(Debug, Clone)]
struct Direction {
    /// Direction of the blocks' +x axis.
    axis: Azimuth,
    nominal: RigidBlock,
    /// Its ensemble members, stored by what can still change (`members.rs`).
    members: DirectionMembers,
}

impl Direction {
    fn new(
        axis: Azimuth,
        nominal: &BlockParams,
        members: &[BlockParams],
    ) -> Result<Self, MemberError> {
        let options = BlockOptions::default();
        Ok(Direction {
            axis,
            nominal: RigidBlock::new(*nominal, options),
            members: DirectionMembers::new(members, options)?,
        })
    }

    fn theta_over_alpha(&self) -> f64 {
        self.nominal
            .params()
            .theta_over_alpha(self.nominal.theta_rad())
    }

    fn pose(&self) -> Pose {
        Pose {
            mode: self.nominal.mode(),
            theta_rad: self.nominal.theta_rad(),
            theta_over_alpha: self.theta_over_alpha(),
            slide_m: self.nominal.slide_m(),
            direction_deg: self.axis.degrees(),
        }
    }
}

/// Planar blocks in each toppling direction. The rock's outputs follow the **governing**
/// direction: the first whose nominal block overturned, else the one with the largest |θ/α|
/// (moving before resting on a tie, then the first); a member counts as overturned when it
/// has in any direction.
#[derive(Debug, Clone)]
struct Planar {
    /// At least one.
    directions: Vec<Direction>,
    /// The governing direction (index into `directions`), updated after every step.
    governing: usize,
    /// Member i has fallen in some direction (as many as each direction's members).
    fallen: Vec<bool>,
    /// How many of `fallen` are true (kept with it: not counted per sample).
    overturned: usize,
}

/// How a rock is integrated (a 3-D rock boxed: a planar one, by far the most common, stays
/// small).
#[derive(Debug, Clone)]
enum Dynamics {
    Planar(Planar),
    Rigid(Box<RigidRock>),
}

/// One catalogued rock in the engine (module doc).
#[derive(Debug, Clone)]
pub(crate) struct PbrRuntime {
    pub(super) id: PbrId,
    /// Name and position, copied into each alert (boxed: read only when an alert is raised).
    place: Box<super::RockPlace>,
    dynamics: Dynamics,
    pub(super) members_overturned: usize,
    pub(super) episode: u32,
    pub(super) in_episode: bool,
    pub(super) raised: RaisedLevels,
    pub(super) data_gap: bool,
    pub(super) last_state_ns: Option<i64>,
}

/// Context of one released packet, shared by its samples.
pub(crate) struct PacketContext<'a> {
    pub(crate) alerts: &'a AlertConfig,
    /// Alerts already in the journal (published before a restart): not emitted again.
    pub(crate) journaled: &'a HashSet<AlertKey>,
    pub(crate) state_interval_s: f64,
    pub(crate) arrival_ns: i64,
    /// Where the senders' packets dropped as already processed are counted.
    pub(crate) tally: Option<&'a super::SourceTally>,
}

/// One sample of a station, as its blocks see it.
pub(super) struct SampleContext<'a> {
    pub(super) station: &'a StationId,
    /// Data time of the sample (ns).
    pub(super) t_ns: i64,
    /// The station's running PGA and PGV, larger horizontal component (m/s², m/s).
    pub(super) pga_mps2: f64,
    pub(super) pgv_mps: f64,
    /// The station has been quiet for `quiet_s`.
    pub(super) quiet_long: bool,
}

/// What one step of a block's integrators did.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct BlockStep {
    /// Data time of the nominal block's first mode change during the step (ns).
    pub(super) first_change_ns: Option<i64>,
    /// An integrator could not complete the step.
    pub(super) failed: bool,
    /// The nominal block lifted off and was put down again.
    pub(super) landed_after_flight: bool,
}

impl Planar {
    fn gov(&self) -> &Direction {
        &self.directions[self.governing]
    }

    fn members_len(&self) -> usize {
        self.directions[0].members.len()
    }

    fn members_overturned(&self) -> usize {
        self.overturned
    }

    fn any_nominal_overturned(&self) -> bool {
        self.directions
            .iter()
            .any(|d| d.nominal.mode() == Mode::Overturned)
    }

    /// Chooses the governing direction (no allocation).
    fn update_governing(&mut self) {
        if self.directions.len() == 1 {
            return;
        }
        let key = |d: &Direction| {
            (
                d.nominal.mode() == Mode::Overturned,
                d.theta_over_alpha().abs(),
                d.nominal.mode() != Mode::Rest,
            )
        };
        let mut best = 0;
        for (i, d) in self.directions.iter().enumerate().skip(1) {
            let (a, b) = (key(d), key(&self.directions[best]));
            let better =
                (a.0 && !b.0) || (a.0 == b.0 && (a.1 > b.1 || (a.1 == b.1 && a.2 && !b.2)));
            if better {
                best = i;
            }
        }
        self.governing = best;
    }

    /// The most demanding rest limit among every block of the rock (the componentwise
    /// minimum: every block's own limit is at least this one).
    fn rest_limit(&self) -> RestLimit {
        let min = |a: RestLimit, b: RestLimit| RestLimit {
            friction_limit: a.friction_limit.min(b.friction_limit),
            gravity_mps2: a.gravity_mps2.min(b.gravity_mps2),
        };
        let gov = self.gov().nominal.rest_limit();
        self.directions.iter().fold(gov, |acc, d| {
            let acc = min(acc, d.nominal.rest_limit());
            d.members.rest_limit().map_or(acc, |m| min(acc, m))
        })
    }

    /// Every direction's nominal block and members over one sample interval (see
    /// [`PbrRuntime::advance`]); returns the step and the number of members fallen.
    fn advance(
        &mut self,
        prev: Sample,
        next: Sample,
        dt_s: f64,
        t_prev_ns: i64,
    ) -> (BlockStep, usize) {
        let mut first_change_ns: Option<i64> = None;
        let mut landed_after_flight = false;
        let mut failed = false;
        for d in &mut self.directions {
            let project = |x: Sample| GroundAccel {
                horizontal_mps2: d.axis.component(x.east, x.north),
                vertical_mps2: x.up,
            };
            let (from, to) = (project(prev), project(next));
            let t_before = d.nominal.time_s();
            let mut change_ns: Option<i64> = None;
            let result = d.nominal.advance(dt_s, from, to, |e| {
                if let BlockEvent::ModeChange { t_s, .. } = e {
                    change_ns.get_or_insert(t_prev_ns + ((t_s - t_before) * 1e9).round() as i64);
                }
            });
            if let Some(t) = change_ns {
                first_change_ns = Some(first_change_ns.map_or(t, |f: i64| f.min(t)));
            }
            failed |= result.is_err();
            // A lift-off is reported (state, notice); the block is put down again as soon
            // as the effective gravity is positive (flight is not modelled, spec §10).
            if d.nominal.mode() == Mode::Flight {
                landed_after_flight |= d.nominal.land_after_flight(to);
            }
            // Member i is one rock: fallen when it has fallen in any direction.
            let (fallen, overturned) = (&mut self.fallen, &mut self.overturned);
            failed |= d.members.advance(dt_s, from, to, |i| {
                if let Some(f) = fallen.get_mut(i) {
                    if !*f {
                        *f = true;
                        *overturned += 1;
                    }
                }
            });
        }
        let members_overturned = self.members_overturned();
        self.update_governing();
        let step = BlockStep {
            first_change_ns,
            failed,
            landed_after_flight,
        };
        (step, members_overturned)
    }

    fn same(&self, other: &Planar) -> bool {
        self.directions.len() == other.directions.len()
            && self.directions.iter().zip(&other.directions).all(|(a, b)| {
                a.axis == b.axis
                    && a.nominal.params() == b.nominal.params()
                    && a.members.same(&b.members)
            })
    }

    fn summaries(&self) -> Vec<DirectionSummary> {
        self.directions
            .iter()
            .map(|d| DirectionSummary {
                direction_deg: d.axis.degrees(),
                max_theta_over_alpha: d.nominal.stats().max_abs_theta_over_alpha,
                max_slide_m: d.nominal.stats().max_abs_slide_m,
                overturned: d.nominal.mode() == Mode::Overturned,
            })
            .collect()
    }

    fn heap_bytes(&self) -> usize {
        self.directions.capacity() * std::mem::size_of::<Direction>()
            + self
                .directions
                .iter()
                .map(|d| d.members.heap_bytes())
                .sum::<usize>()
            + self.fallen.capacity()
    }
}

impl PbrRuntime {
    pub(super) fn new(spec: &PbrSpec) -> Result<Self, super::ConfigError> {
        let dynamics = match &spec.rock_3d {
            Some(rock) => Dynamics::Rigid(Box::new(RigidRock::new(rock).map_err(|error| {
                super::ConfigError::Rock3d {
                    pbr: spec.id.to_string(),
                    error,
                }
            })?)),
            None => {
                let member_error = |azimuth: Azimuth| {
                    move |error| super::ConfigError::Member {
                        pbr: spec.id.to_string(),
                        direction_deg: azimuth.degrees(),
                        error,
                    }
                };
                let mut directions =
                    vec![Direction::new(spec.azimuth, &spec.nominal, &spec.members)
                        .map_err(member_error(spec.azimuth))?];
                for d in &spec.more_directions {
                    directions.push(
                        Direction::new(d.azimuth, &d.nominal, &d.members)
                            .map_err(member_error(d.azimuth))?,
                    );
                }
                Dynamics::Planar(Planar {
                    fallen: vec![false; directions[0].members.len()],
                    overturned: 0,
                    directions,
                    governing: 0,
                })
            }
        };
        Ok(PbrRuntime {
            id: spec.id.clone(),
            place: Box::new(spec.place.clone()),
            dynamics,
            members_overturned: 0,
            episode: 0,
            in_episode: false,
            raised: RaisedLevels::default(),
            data_gap: false,
            last_state_ns: None,
        })
    }

    /// The nominal rock as the outputs describe it (the governing direction of a planar rock).
    fn pose(&self) -> Pose {
        match &self.dynamics {
            Dynamics::Planar(p) => p.gov().pose(),
            Dynamics::Rigid(r) => r.pose(),
        }
    }

    /// The nominal rock's clock (s): the time its integration has reached.
    pub(super) fn time_s(&self) -> f64 {
        match &self.dynamics {
            Dynamics::Planar(p) => p.gov().nominal.time_s(),
            Dynamics::Rigid(r) => r.time_s(),
        }
    }

    pub(super) fn any_nominal_overturned(&self) -> bool {
        match &self.dynamics {
            Dynamics::Planar(p) => p.any_nominal_overturned(),
            Dynamics::Rigid(r) => r.nominal_overturned(),
        }
    }

    fn members_len(&self) -> usize {
        match &self.dynamics {
            Dynamics::Planar(p) => p.members_len(),
            Dynamics::Rigid(r) => r.members_len(),
        }
    }

    fn overturn_probability(&self) -> f64 {
        if self.members_len() == 0 {
            f64::from(u8::from(self.any_nominal_overturned()))
        } else {
            self.members_overturned as f64 / self.members_len() as f64
        }
    }

    /// The rock's limit in its station's rest group (the most demanding of its blocks').
    pub(super) fn rest_limit(&self) -> RestLimit {
        match &self.dynamics {
            Dynamics::Planar(p) => p.rest_limit(),
            Dynamics::Rigid(r) => r.rest_limit(),
        }
    }

    /// The block may join its station's rest group (`rest_group`): every integrated block at
    /// rest at time `clock_s`, no episode open (nothing to end), no member fallen, and no
    /// alert that could be raised at rest (θ = 0 there and the overturn probability is 0, so
    /// only thresholds ≤ 0 could raise one; `EngineConfig::validate` rejects those, this
    /// guards a config set without validation).
    pub(super) fn may_rest_in_group(&self, clock_s: f64, alerts: &AlertConfig) -> bool {
        let resting = |b: &RigidBlock| b.mode() == Mode::Rest && b.time_s() == clock_s;
        let all_resting = || match &self.dynamics {
            Dynamics::Planar(p) => p.directions.iter().all(|d| {
                d.nominal.theta_rad() == 0.0
                    && resting(&d.nominal)
                    && d.members.all_resting_at(clock_s)
            }),
            Dynamics::Rigid(r) => r.resting_at(clock_s),
        };
        !self.in_episode
            && self.members_overturned == 0
            && alerts.imminent_theta_ratio > 0.0
            && alerts.imminent_probability > 0.0
            && all_resting()
    }

    /// The same block: id, and in every direction the axis, nominal body and ensemble members
    /// (a 3-D rock: its body and every member's heading and friction); a reload keeps its
    /// state.
    pub(super) fn same_block(&self, other: &PbrRuntime) -> bool {
        self.id == other.id
            && match (&self.dynamics, &other.dynamics) {
                (Dynamics::Planar(a), Dynamics::Planar(b)) => a.same(b),
                (Dynamics::Rigid(a), Dynamics::Rigid(b)) => a.same(b),
                _ => false,
            }
    }

    pub(crate) fn id(&self) -> &PbrId {
        &self.id
    }

    /// Episodes of this block before (a block new to a reload, back in the catalogue: its
    /// next episode comes after its journaled ones).
    pub(crate) fn continue_episodes_after(&mut self, episode: u32) {
        self.episode = self.episode.max(episode);
    }

    /// Leaves the rest group: the blocks' clocks are set to the group's.
    pub(super) fn leave_rest_group(&mut self, clock_s: f64) {
        match &mut self.dynamics {
            Dynamics::Planar(p) => {
                for d in &mut p.directions {
                    d.nominal.stay_at_rest_until(clock_s);
                    d.members.stay_at_rest_until(clock_s);
                }
            }
            Dynamics::Rigid(r) => r.stay_at_rest_until(clock_s),
        }
    }

    /// The ground input jumps here: the planar integrators drop their stale state (a 3-D
    /// rock keeps none between intervals).
    pub(super) fn input_discontinuity(&mut self) {
        if let Dynamics::Planar(p) = &mut self.dynamics {
            for d in &mut p.directions {
                d.nominal.input_discontinuity();
                d.members.input_discontinuity();
            }
        }
    }

    /// Restored fallen after a restart: fallen in every direction (which one fell is not
    /// journaled), every member fallen, the episode open with every level raised.
    pub(super) fn restore_fallen(&mut self, episode: u32) {
        match &mut self.dynamics {
            Dynamics::Planar(p) => {
                for d in &mut p.directions {
                    d.nominal.set_overturned();
                    d.members.set_all_fallen();
                }
                p.fallen.fill(true);
                p.overturned = p.fallen.len();
            }
            Dynamics::Rigid(r) => r.set_fallen(),
        }
        self.members_overturned = self.members_len();
        self.episode = episode;
        self.in_episode = true;
        self.raised = RaisedLevels::all();
    }

    /// An operator reset: the rock stands again at rest, its episode closed.
    pub(super) fn reset(&mut self) {
        match &mut self.dynamics {
            Dynamics::Planar(p) => {
                let options = BlockOptions::default();
                for d in &mut p.directions {
                    d.nominal = RigidBlock::new(*d.nominal.params(), options);
                    d.members.reset();
                }
                p.fallen.fill(false);
                p.overturned = 0;
                p.governing = 0;
            }
            Dynamics::Rigid(r) => r.reset(),
        }
        self.members_overturned = 0;
        self.in_episode = false;
        self.raised = RaisedLevels::default();
    }

    /// Heap bytes of the rock's blocks (id, name and place, directions, members).
    pub(super) fn heap_bytes(&self) -> usize {
        // The id's text behind its two reference counts (shared with its outputs).
        2 * std::mem::size_of::<usize>()
            + self.id.as_str().len()
            + std::mem::size_of::<super::RockPlace>()
            + self.place.name.capacity()
            + match &self.dynamics {
                Dynamics::Planar(p) => p.heap_bytes(),
                Dynamics::Rigid(r) => std::mem::size_of::<RigidRock>() + r.heap_bytes(),
            }
    }

    /// Planar ensemble members (every direction) neither at rest nor fallen (a 3-D rock: 0).
    pub(super) fn members_in_motion(&self) -> usize {
        match &self.dynamics {
            Dynamics::Planar(p) => p.directions.iter().map(|d| d.members.in_motion()).sum(),
            Dynamics::Rigid(_) => 0,
        }
    }

    pub(super) fn at_rest(&self) -> bool {
        match &self.dynamics {
            Dynamics::Planar(p) => p.directions.iter().all(|d| {
                matches!(d.nominal.mode(), Mode::Rest | Mode::Overturned) && d.members.settled()
            }),
            Dynamics::Rigid(r) => r.settled(),
        }
    }

    pub(super) fn state(&self, station: &StationId, data_time_ns: i64) -> PbrState {
        self.state_monitored(station, data_time_ns, false)
    }

    /// The block's state, flagged `not_monitored` as given (a stale station's blocks).
    pub(super) fn state_monitored(
        &self,
        station: &StationId,
        data_time_ns: i64,
        not_monitored: bool,
    ) -> PbrState {
        let pose = self.pose();
        PbrState {
            pbr_id: self.id.clone(),
            station: station.clone(),
            mode: pose.mode,
            theta_rad: pose.theta_rad,
            theta_over_alpha: pose.theta_over_alpha,
            slide_m: pose.slide_m,
            overturned: pose.mode == Mode::Overturned,
            overturn_probability: self.overturn_probability(),
            data_gap: self.data_gap,
            data_time_ns,
            not_monitored,
            direction_deg: pose.direction_deg,
        }
    }

    /// Advances the nominal block and the ensemble members over one sample interval of
    /// `dt_s` seconds, from the ground sample `prev` (at data time `t_prev_ns`) to `next`.
    /// Planar: every direction is stepped under the ground motion projected on its azimuth;
    /// the step's first mode change is the earliest among the directions' nominal blocks.
    /// 3-D: every member under the three components turned to its heading; the step's mode
    /// change is the nominal rock's leaving rest (at its instant) or its coming to rest or
    /// overturning (at the step's end).
    pub(super) fn advance(
        &mut self,
        prev: Sample,
        next: Sample,
        dt_s: f64,
        t_prev_ns: i64,
    ) -> BlockStep {
        let (step, members_overturned) = match &mut self.dynamics {
            Dynamics::Planar(p) => p.advance(prev, next, dt_s, t_prev_ns),
            Dynamics::Rigid(r) => {
                let t_before = r.time_s();
                let s = r.advance(prev, next, dt_s);
                let at = |t_s: f64| t_prev_ns + ((t_s - t_before) * 1e9).round() as i64;
                let first_change_ns = s
                    .left_rest_s
                    .map(at)
                    .or_else(|| s.mode_changed.then(|| at(r.time_s())));
                let step = BlockStep {
                    first_change_ns,
                    failed: s.failed,
                    landed_after_flight: false,
                };
                (step, r.members_overturned())
            }
        };
        self.members_overturned = members_overturned;
        step
    }

    /// Raises each alert whose condition holds, once per episode (an alert journaled before
    /// a restart is not emitted again). The onset is dated at the step's first mode change
    /// (`first_change_ns`), the others at the sample.
    pub(super) fn raise_alerts(
        &mut self,
        at: &SampleContext<'_>,
        first_change_ns: Option<i64>,
        ctx: &PacketContext<'_>,
        out: &mut dyn OutputSink,
    ) {
        let pose = self.pose();
        let probability = self.overturn_probability();
        let conditions = [
            (AlertLevel::MotionOnset, pose.mode != Mode::Rest),
            (
                AlertLevel::OverturnImminent,
                pose.theta_over_alpha.abs() >= ctx.alerts.imminent_theta_ratio
                    || (self.members_len() > 0 && probability >= ctx.alerts.imminent_probability),
            ),
            (AlertLevel::Overturned, pose.mode == Mode::Overturned),
        ];
        for (level, holds) in conditions {
            if holds && !self.raised.contains(level) {
                if !self.in_episode {
                    self.in_episode = true;
                    // Journals bound the number restored (rockwatch::journal): never wraps.
                    self.episode = self.episode.saturating_add(1);
                }
                self.raised.insert(level);
                if ctx
                    .journaled
                    .contains(&(self.id.clone(), self.episode, level))
                {
                    continue; // published before a restart
                }
                let data_time_ns = if level == AlertLevel::MotionOnset {
                    first_change_ns.unwrap_or(at.t_ns)
                } else {
                    at.t_ns
                };
                out.push(Output::Alert(Alert {
                    pbr_id: self.id.clone(),
                    station: at.station.clone(),
                    level,
                    episode: self.episode,
                    mode: pose.mode,
                    theta_over_alpha: pose.theta_over_alpha,
                    slide_m: pose.slide_m,
                    overturn_probability: probability,
                    pga_mps2: at.pga_mps2,
                    pgv_mps: at.pgv_mps,
                    data_time_ns,
                    arrival_ns: ctx.arrival_ns,
                    direction_deg: pose.direction_deg,
                    pbr_name: self.place.name.clone(),
                    lat_deg: self.place.lat_deg,
                    lon_deg: self.place.lon_deg,
                }));
            }
        }
    }

    /// Episode end: back at rest on a quiet station (a fallen block stays fallen).
    pub(super) fn end_episode_if_settled(
        &mut self,
        at: &SampleContext<'_>,
        out: &mut dyn OutputSink,
    ) {
        if self.in_episode && at.quiet_long && self.at_rest() && !self.any_nominal_overturned() {
            self.in_episode = false;
            self.raised = RaisedLevels::default();
            out.push(Output::EpisodeEnd {
                pbr_id: self.id.clone(),
                episode: self.episode,
                data_time_ns: at.t_ns,
            });
        }
    }

    /// The block's state, on a mode change (`mode_changed`) and at the state rate.
    pub(super) fn emit_state_if_due(
        &mut self,
        at: &SampleContext<'_>,
        mode_changed: bool,
        ctx: &PacketContext<'_>,
        out: &mut dyn OutputSink,
    ) {
        let due = self
            .last_state_ns
            .is_none_or(|last| (at.t_ns - last) as f64 * 1e-9 >= ctx.state_interval_s);
        if mode_changed || due {
            self.last_state_ns = Some(at.t_ns);
            out.push(Output::State(self.state(at.station, at.t_ns)));
        }
    }

    /// The rock's summary: the largest responses over its directions.
    pub(crate) fn summary(&self, station: &StationId) -> PbrSummary {
        let directions = match &self.dynamics {
            Dynamics::Planar(p) => p.summaries(),
            Dynamics::Rigid(r) => {
                let (max_theta_over_alpha, direction_deg, max_slide_m) = r.extremes();
                vec![DirectionSummary {
                    direction_deg,
                    max_theta_over_alpha,
                    max_slide_m,
                    overturned: r.nominal_overturned(),
                }]
            }
        };
        let (mut max_theta_over_alpha, mut max_slide_m) = (0.0f64, 0.0f64);
        for d in &directions {
            max_theta_over_alpha = max_theta_over_alpha.max(d.max_theta_over_alpha);
            max_slide_m = max_slide_m.max(d.max_slide_m);
        }
        PbrSummary {
            pbr_id: self.id.clone(),
            station: station.clone(),
            max_theta_over_alpha,
            max_slide_m,
            overturned: self.any_nominal_overturned(),
            directions,
            overturn_probability: self.overturn_probability(),
            data_gap: self.data_gap,
            episodes: self.episode,
        }
    }
}
