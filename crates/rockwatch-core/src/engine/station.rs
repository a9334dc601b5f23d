//! One station's runtime: its stream sequencer, running intensity measures, and the blocks
//! bound to it, advanced sample by sample.

use super::config::{AlertConfig, Orientation, PbrSpec, StationConfig};
use std::collections::HashSet;

use super::health::{HealthChange, Liveness, StationHealth};
use super::output::{
    Alert, AlertKey, AlertLevel, JournalRecord, Notice, Output, OutputSink, PbrState, RaisedLevels,
    StationIntensity,
};
use super::rest_group::{GroundSample as Sample, RestGroup};
use super::stream::{Gap, Released, Sequencer, StreamConfig};
use crate::azimuth::Azimuth;
use crate::dynamics::{
    BlockEvent, BlockOptions, BlockParams, GroundAccel, Mode, RestLimit, RigidBlock,
};
use crate::ims::{RunningConfig, RunningIms};

/// Longest intensity window (s): a station that never goes quiet restarts its running IMs
/// after this long (bounding their memory, about 8 bytes per sample and component).
pub const MAX_INTENSITY_WINDOW_S: f64 = 3600.0;

/// Per-station counters of data problems (cumulative).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct StationCounters {
    pub packets: u64,
    pub samples: u64,
    /// Packets rejected by validation (NaN/Inf, bad lengths, absurd rates, …), including
    /// `implausible_packets`.
    pub rejected_packets: u64,
    /// Packets rejected because a sample, in m/s² after the station's gain, is beyond the
    /// physical bound `engine.plausibility.max_abs_accel_g`.
    pub implausible_packets: u64,
    pub rejected_samples: u64,
    /// Samples at or beyond 99.9 % of the sensor's full scale (used, but flagged).
    pub clipped_samples: u64,
    /// Intervals the block integrator could not complete (should stay 0).
    pub integration_errors: u64,
    /// Lift-offs of a nominal block (free flight, then put down again).
    pub flights: u64,
}

/// A block's response summary (the last line of `rockwatch monitor`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PbrSummary {
    pub pbr_id: String,
    pub station: String,
    pub max_theta_over_alpha: f64,
    pub max_slide_m: f64,
    pub overturned: bool,
    pub overturn_probability: f64,
    pub data_gap: bool,
    pub episodes: u32,
    /// Each direction's nominal response (one for a planar block; a rock from a mesh has
    /// one per azimuth, in catalogue order). The fields above are the largest over them.
    pub directions: Vec<DirectionSummary>,
}

/// One direction's nominal response in a [`PbrSummary`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DirectionSummary {
    /// Azimuth of the direction's +x axis, degrees clockwise from north.
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
    members: Vec<RigidBlock>,
}

impl Direction {
    fn new(axis: Azimuth, nominal: &BlockParams, members: &[BlockParams]) -> Self {
        let options = BlockOptions::default();
        Direction {
            axis,
            nominal: RigidBlock::new(*nominal, options),
            members: members
                .iter()
                .map(|p| RigidBlock::new(*p, options))
                .collect(),
        }
    }

    fn theta_over_alpha(&self) -> f64 {
        self.nominal
            .params()
            .theta_over_alpha(self.nominal.theta_rad())
    }
}

/// One catalogued block in the engine: a planar block (one direction) or a rock from a mesh
/// integrated in each of its directions. Its outputs follow the **governing** direction: the
/// first whose nominal block overturned, else the one with the largest |θ/α| (moving before
/// resting on a tie, then the first); a member counts as overturned when it has in any
/// direction.
#[derive(Debug, Clone)]
pub(crate) struct PbrRuntime {
    id: String,
    /// At least one.
    directions: Vec<Direction>,
    /// The governing direction (index into `directions`), updated after every step.
    governing: usize,
    members_overturned: usize,
    episode: u32,
    in_episode: bool,
    raised: RaisedLevels,
    data_gap: bool,
    last_state_ns: Option<i64>,
}

impl PbrRuntime {
    fn new(spec: &PbrSpec) -> Self {
        let mut directions = vec![Direction::new(spec.azimuth, &spec.nominal, &spec.members)];
        directions.extend(
            spec.more_directions
                .iter()
                .map(|d| Direction::new(d.azimuth, &d.nominal, &d.members)),
        );
        PbrRuntime {
            id: spec.id.clone(),
            directions,
            governing: 0,
            members_overturned: 0,
            episode: 0,
            in_episode: false,
            raised: RaisedLevels::default(),
            data_gap: false,
            last_state_ns: None,
        }
    }

    /// The governing direction (see the type's doc).
    fn gov(&self) -> &Direction {
        &self.directions[self.governing]
    }

    /// The governing direction's nominal block.
    fn nominal(&self) -> &RigidBlock {
        &self.directions[self.governing].nominal
    }

    /// Every block of the rock, nominal and members, in every direction.
    fn blocks(&self) -> impl Iterator<Item = &RigidBlock> {
        self.directions
            .iter()
            .flat_map(|d| std::iter::once(&d.nominal).chain(d.members.iter()))
    }

    fn blocks_mut(&mut self) -> impl Iterator<Item = &mut RigidBlock> {
        self.directions
            .iter_mut()
            .flat_map(|d| std::iter::once(&mut d.nominal).chain(d.members.iter_mut()))
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

    fn any_nominal_overturned(&self) -> bool {
        self.directions
            .iter()
            .any(|d| d.nominal.mode() == Mode::Overturned)
    }

    fn theta_over_alpha(&self) -> f64 {
        self.gov().theta_over_alpha().abs()
    }

    fn members_len(&self) -> usize {
        self.directions[0].members.len()
    }

    fn overturn_probability(&self) -> f64 {
        if self.members_len() == 0 {
            f64::from(u8::from(self.any_nominal_overturned()))
        } else {
            self.members_overturned as f64 / self.members_len() as f64
        }
    }

    /// The most demanding rest limit among every block of the rock (the componentwise
    /// minimum: every block's own limit is at least this one).
    fn rest_limit(&self) -> RestLimit {
        let mut blocks = self.blocks();
        let first = blocks.next().map_or(
            RestLimit {
                friction_limit: 0.0,
                gravity_mps2: 0.0,
            },
            RigidBlock::rest_limit,
        );
        blocks.fold(first, |acc, m| {
            let l = m.rest_limit();
            RestLimit {
                friction_limit: acc.friction_limit.min(l.friction_limit),
                gravity_mps2: acc.gravity_mps2.min(l.gravity_mps2),
            }
        })
    }

    /// The block may join its station's rest group (`rest_group`): every integrated block at
    /// rest at time `clock_s`, no episode open (nothing to end), no member fallen, and no
    /// alert that could be raised at rest (θ = 0 there and the overturn probability is 0, so
    /// only thresholds ≤ 0 could raise one; `EngineConfig::validate` rejects those, this
    /// guards a config set without validation).
    fn may_rest_in_group(&self, clock_s: f64, alerts: &AlertConfig) -> bool {
        let resting = |b: &RigidBlock| b.mode() == Mode::Rest && b.time_s() == clock_s;
        !self.in_episode
            && self.members_overturned == 0
            && alerts.imminent_theta_ratio > 0.0
            && alerts.imminent_probability > 0.0
            && self.directions.iter().all(|d| d.nominal.theta_rad() == 0.0)
            && self.blocks().all(resting)
    }

    /// The same block: id, and in every direction the axis, nominal body and ensemble members
    /// (a reload keeps its state).
    fn same_block(&self, other: &PbrRuntime) -> bool {
        self.id == other.id
            && self.directions.len() == other.directions.len()
            && self.directions.iter().zip(&other.directions).all(|(a, b)| {
                a.axis == b.axis
                    && a.nominal.params() == b.nominal.params()
                    && a.members.len() == b.members.len()
                    && a.members
                        .iter()
                        .zip(&b.members)
                        .all(|(x, y)| x.params() == y.params())
            })
    }

    pub(crate) fn id(&self) -> &str {
        &self.id
    }

    /// Episodes of this block before (a block new to a reload, back in the catalogue: its
    /// next episode comes after its journaled ones).
    pub(crate) fn continue_episodes_after(&mut self, episode: u32) {
        self.episode = self.episode.max(episode);
    }

    /// Leaves the rest group: the blocks' clocks are set to the group's.
    fn leave_rest_group(&mut self, clock_s: f64) {
        for b in self.blocks_mut() {
            b.stay_at_rest_until(clock_s);
        }
    }

    fn at_rest(&self) -> bool {
        self.blocks()
            .all(|b| matches!(b.mode(), Mode::Rest | Mode::Overturned))
    }

    fn state(&self, station: &str, data_time_ns: i64) -> PbrState {
        self.state_monitored(station, data_time_ns, false)
    }

    /// The block's state, flagged `not_monitored` as given (a stale station's blocks).
    fn state_monitored(&self, station: &str, data_time_ns: i64, not_monitored: bool) -> PbrState {
        let d = self.gov();
        PbrState {
            pbr_id: self.id.clone(),
            station: station.to_string(),
            mode: d.nominal.mode(),
            theta_rad: d.nominal.theta_rad(),
            theta_over_alpha: d.theta_over_alpha(),
            slide_m: d.nominal.slide_m(),
            overturned: d.nominal.mode() == Mode::Overturned,
            overturn_probability: self.overturn_probability(),
            data_gap: self.data_gap,
            data_time_ns,
            not_monitored,
            direction_deg: d.axis.degrees(),
        }
    }

    /// Advances the nominal block and the ensemble members over one sample interval of
    /// `dt_s` seconds, from the ground sample `prev` (at data time `t_prev_ns`) to `next`.
    /// Every direction is stepped under the ground motion projected on its azimuth; the
    /// step's first mode change is the earliest among the directions' nominal blocks.
    fn advance(&mut self, prev: Sample, next: Sample, dt_s: f64, t_prev_ns: i64) -> BlockStep {
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
            for m in &mut d.members {
                failed |= m.advance(dt_s, from, to, |_| {}).is_err();
                m.land_after_flight(to);
            }
        }
        // Member i is one rock: fallen when it has fallen in any direction.
        self.members_overturned = (0..self.members_len())
            .filter(|&i| {
                self.directions.iter().any(|d| {
                    d.members
                        .get(i)
                        .is_some_and(|m| m.mode() == Mode::Overturned)
                })
            })
            .count();
        self.update_governing();
        BlockStep {
            first_change_ns,
            failed,
            landed_after_flight,
        }
    }

    /// Raises each alert whose condition holds, once per episode (an alert journaled before
    /// a restart is not emitted again). The onset is dated at the step's first mode change
    /// (`first_change_ns`), the others at the sample.
    fn raise_alerts(
        &mut self,
        at: &SampleContext<'_>,
        first_change_ns: Option<i64>,
        ctx: &PacketContext<'_>,
        out: &mut dyn OutputSink,
    ) {
        let ratio = self.theta_over_alpha();
        let probability = self.overturn_probability();
        let mode = self.nominal().mode();
        let conditions = [
            (AlertLevel::MotionOnset, mode != Mode::Rest),
            (
                AlertLevel::OverturnImminent,
                ratio >= ctx.alerts.imminent_theta_ratio
                    || (self.members_len() > 0 && probability >= ctx.alerts.imminent_probability),
            ),
            (AlertLevel::Overturned, mode == Mode::Overturned),
        ];
        for (level, holds) in conditions {
            if holds && !self.raised.contains(level) {
                if !self.in_episode {
                    self.in_episode = true;
                    self.episode += 1;
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
                    station: at.station.to_string(),
                    level,
                    episode: self.episode,
                    mode,
                    theta_over_alpha: self.gov().theta_over_alpha(),
                    slide_m: self.nominal().slide_m(),
                    overturn_probability: probability,
                    pga_mps2: at.pga_mps2,
                    pgv_mps: at.pgv_mps,
                    data_time_ns,
                    arrival_ns: ctx.arrival_ns,
                    direction_deg: self.gov().axis.degrees(),
                }));
            }
        }
    }

    /// Episode end: back at rest on a quiet station (a fallen block stays fallen).
    fn end_episode_if_settled(&mut self, at: &SampleContext<'_>, out: &mut dyn OutputSink) {
        if self.in_episode && at.quiet_long && self.at_rest() && !self.any_nominal_overturned() {
            self.in_episode = false;
            self.raised = RaisedLevels::default();
            out.push(Output::EpisodeEnd {
                pbr_id: self.id.clone(),
                episode: self.episode,
            });
        }
    }

    /// The block's state, on a mode change (`mode_changed`) and at the state rate.
    fn emit_state_if_due(
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
    pub(crate) fn summary(&self, station: &str) -> PbrSummary {
        let (mut max_theta_over_alpha, mut max_slide_m) = (0.0f64, 0.0f64);
        for d in &self.directions {
            let stats = d.nominal.stats();
            max_theta_over_alpha = max_theta_over_alpha.max(stats.max_abs_theta_over_alpha);
            max_slide_m = max_slide_m.max(stats.max_abs_slide_m);
        }
        PbrSummary {
            pbr_id: self.id.clone(),
            station: station.to_string(),
            max_theta_over_alpha,
            max_slide_m,
            overturned: self.any_nominal_overturned(),
            directions: self
                .directions
                .iter()
                .map(|d| DirectionSummary {
                    direction_deg: d.axis.degrees(),
                    max_theta_over_alpha: d.nominal.stats().max_abs_theta_over_alpha,
                    max_slide_m: d.nominal.stats().max_abs_slide_m,
                    overturned: d.nominal.mode() == Mode::Overturned,
                })
                .collect(),
            overturn_probability: self.overturn_probability(),
            data_gap: self.data_gap,
            episodes: self.episode,
        }
    }
}

/// Everything the engine keeps for one station.
#[derive(Debug)]
pub(crate) struct StationRuntime {
    pub(crate) config: StationConfig,
    pub(crate) name: String,
    sequencer: Sequencer,
    /// Running intensity measures of the east and north components (the published values
    /// are the larger horizontal's; no vertical measure is published, so none is kept).
    ims: Option<[RunningIms; 2]>,
    last: Option<Sample>,
    pub(crate) pbrs: Vec<PbrRuntime>,
    /// The blocks at rest that share one rest check per sample.
    rest: RestGroup,
    quiet_since_ns: Option<i64>,
    last_intensity_ns: Option<i64>,
    pub(crate) counters: StationCounters,
    /// Whether the station still sends (`engine::health`).
    pub(crate) liveness: Liveness,
}

/// Context of one released packet, shared by its samples.
pub(crate) struct PacketContext<'a> {
    pub(crate) alerts: &'a AlertConfig,
    /// Alerts already in the journal (published before a restart): not emitted again.
    pub(crate) journaled: &'a HashSet<AlertKey>,
    pub(crate) state_interval_s: f64,
    pub(crate) arrival_ns: i64,
}

/// One sample of a station, as its blocks see it.
struct SampleContext<'a> {
    station: &'a str,
    /// Data time of the sample (ns).
    t_ns: i64,
    /// The station's running PGA and PGV, larger horizontal component (m/s², m/s).
    pga_mps2: f64,
    pgv_mps: f64,
    /// The station has been quiet for `quiet_s`.
    quiet_long: bool,
}

/// What one step of a block's integrators did.
#[derive(Debug, Clone, Copy, Default)]
struct BlockStep {
    /// Data time of the nominal block's first mode change during the step (ns).
    first_change_ns: Option<i64>,
    /// An integrator could not complete the step.
    failed: bool,
    /// The nominal block lifted off and was put down again.
    landed_after_flight: bool,
}

/// Hands `out` a notice about `station`.
fn notice(station: &str, kind: &'static str, message: String, out: &mut dyn OutputSink) {
    out.push(Output::Notice(Notice {
        station: station.to_string(),
        kind,
        message,
    }));
}

impl StationRuntime {
    pub(crate) fn new(config: StationConfig, pbrs: &[&PbrSpec], stream: StreamConfig) -> Self {
        let pbrs: Vec<PbrRuntime> = pbrs.iter().map(|s| PbrRuntime::new(s)).collect();
        StationRuntime {
            rest: RestGroup::new(pbrs.iter().map(PbrRuntime::rest_limit).collect()),
            name: config.id.to_string(),
            config,
            sequencer: Sequencer::new(stream),
            ims: None,
            last: None,
            pbrs,
            quiet_since_ns: None,
            last_intensity_ns: None,
            counters: StationCounters::default(),
            liveness: Liveness::default(),
        }
    }

    /// An accepted packet (validated, plausible) of `samples` samples at `rate_hz` starting at
    /// `start_ns` arrived at `arrival_ns`: if the station was stale, reports its recovery and
    /// the states of its blocks (monitored again).
    pub(crate) fn accepted(
        &mut self,
        arrival_ns: i64,
        start_ns: i64,
        samples: usize,
        rate_hz: f64,
        out: &mut dyn OutputSink,
    ) {
        let last_sample_ns =
            start_ns + ((samples.saturating_sub(1)) as f64 * 1e9 / rate_hz).round() as i64;
        if let Some(silent_ns) = self.liveness.accepted(arrival_ns, last_sample_ns, rate_hz) {
            self.report_health(true, silent_ns, out);
        }
    }

    /// At `now_ns` (health checks since `since_ns`): if the station goes stale now, reports
    /// it and the states of its blocks (not monitored).
    pub(crate) fn check_stale(
        &mut self,
        now_ns: i64,
        since_ns: i64,
        stale_after_ns: i64,
        out: &mut dyn OutputSink,
    ) {
        if let Some(silent_ns) = self.liveness.goes_stale(now_ns, since_ns, stale_after_ns) {
            self.report_health(false, silent_ns, out);
        }
    }

    /// One [`Output::Health`], then a state of each block flagged as `monitored` says.
    fn report_health(&self, monitored: bool, silent_ns: i64, out: &mut dyn OutputSink) {
        out.push(Output::Health(HealthChange {
            station: self.name.clone(),
            monitored,
            silent_ns,
            blocks: self.pbrs.len(),
        }));
        let data_time_ns = self.liveness.last_sample_ns.unwrap_or(0);
        for p in &self.pbrs {
            out.push(Output::State(p.state_monitored(
                &self.name,
                data_time_ns,
                !monitored,
            )));
        }
    }

    /// The station's health now.
    pub(crate) fn health(&self) -> StationHealth {
        let stream = self.sequencer.counters;
        let l = &self.liveness;
        StationHealth {
            station: self.name.clone(),
            monitored: !l.stale,
            blocks: self.pbrs.len(),
            last_arrival_ns: l.last_arrival_ns,
            last_sample_ns: l.last_sample_ns,
            sample_rate_hz: l.rate_hz,
            packets: self.counters.packets,
            samples: self.counters.samples,
            rejected_packets: self.counters.rejected_packets,
            rejected_samples: self.counters.rejected_samples,
            clipped_samples: self.counters.clipped_samples,
            gaps_bridged: stream.gaps_bridged,
            gaps_broken: stream.gaps_broken,
            missing_samples: stream.missing_samples,
            late_packets: stream.late_packets,
            duplicate_packets: stream.duplicate_packets,
            stale_events: l.stale_events,
        }
    }

    pub(crate) fn sequencer(&self) -> &Sequencer {
        &self.sequencer
    }

    /// Places a validated packet in the stream and processes whatever is ready.
    pub(crate) fn offer(
        &mut self,
        packet: super::packet::AccelPacket,
        ctx: &PacketContext<'_>,
        scratch: &mut Vec<Released>,
        out: &mut dyn OutputSink,
    ) {
        self.counters.packets += 1;
        scratch.clear();
        self.sequencer.offer(packet, scratch);
        for r in scratch.drain(..) {
            self.process_packet(&r, ctx, out);
        }
    }

    /// Releases and processes every packet held for reordering.
    pub(crate) fn flush(
        &mut self,
        ctx: &PacketContext<'_>,
        scratch: &mut Vec<Released>,
        out: &mut dyn OutputSink,
    ) {
        scratch.clear();
        self.sequencer.flush(scratch);
        for r in scratch.drain(..) {
            self.process_packet(&r, ctx, out);
        }
    }

    /// Restores the blocks' alerts and episodes from the journal `records`; the blocks in
    /// `fallen` ([`super::output::fallen_blocks`] of the same records) are restored fallen.
    pub(crate) fn restore(&mut self, records: &[JournalRecord], fallen: &HashSet<String>) {
        self.leave_rest_group();
        for pbr in &mut self.pbrs {
            let (mut last_episode, mut ended) = (0, 0);
            for record in records {
                match record {
                    JournalRecord::Alert(a) if a.pbr_id == pbr.id => {
                        last_episode = last_episode.max(a.episode);
                    }
                    JournalRecord::EpisodeEnd { pbr_id, episode } if *pbr_id == pbr.id => {
                        ended = ended.max(*episode);
                    }
                    JournalRecord::Reset { pbr_id } if *pbr_id == pbr.id => {
                        ended = last_episode;
                    }
                    _ => {}
                }
            }
            if fallen.contains(&pbr.id) {
                // Which direction fell is not journaled: the rock is fallen in every one.
                pbr.blocks_mut().for_each(RigidBlock::set_overturned);
                pbr.members_overturned = pbr.members_len();
                pbr.episode = last_episode;
                pbr.in_episode = true;
                pbr.raised = RaisedLevels::all();
            } else {
                // An open episode is re-entered under its own number, so that its journaled
                // alerts are recognised and not emitted twice.
                pbr.episode = if ended >= last_episode {
                    last_episode
                } else {
                    last_episode - 1
                };
            }
        }
    }

    /// The station's blocks, out of the rest group (their clocks set), for a reload.
    pub(crate) fn take_blocks(&mut self) -> Vec<PbrRuntime> {
        self.leave_rest_group();
        std::mem::take(&mut self.pbrs)
    }

    /// After a reload: this station, new from the new configuration, continues `old` (the
    /// same station before; its blocks already taken): the stream state, the running
    /// intensity measures, the quiet clock and the counters go on (the configuration is the
    /// new one; stream settings changed by the reload apply to stations new to it). Each of
    /// this station's blocks found in `previous` as the same block (id, axis, body, members)
    /// keeps its state — motion, episode, alerts raised; the others start at rest. Returns the
    /// ids of the blocks kept.
    pub(crate) fn continue_from(
        &mut self,
        old: Option<StationRuntime>,
        previous: &mut std::collections::HashMap<String, PbrRuntime>,
    ) -> Vec<String> {
        let mut kept = Vec::new();
        for pbr in &mut self.pbrs {
            if let Some(prev) = previous.remove(&pbr.id) {
                if prev.same_block(pbr) {
                    kept.push(pbr.id.clone());
                    *pbr = prev;
                } else {
                    // Same id, another body or station: the old state means nothing here,
                    // but episode numbers go on (an alert's identity includes its episode).
                    pbr.episode = prev.episode;
                    previous.insert(pbr.id.clone(), prev);
                }
            }
        }
        let limits = self.pbrs.iter().map(PbrRuntime::rest_limit).collect();
        if let Some(old) = old {
            self.rest = RestGroup::continuing(&old.rest, limits);
            self.sequencer = old.sequencer;
            self.ims = old.ims;
            self.last = old.last;
            self.quiet_since_ns = old.quiet_since_ns;
            self.last_intensity_ns = old.last_intensity_ns;
            self.counters = old.counters;
        } else {
            self.rest = RestGroup::new(limits);
        }
        kept
    }

    /// An operator reset: the block stands again at rest, its episode closed.
    pub(crate) fn reset_pbr(&mut self, id: &str) -> bool {
        if !self.pbrs.iter().any(|p| p.id == id) {
            return false;
        }
        self.leave_rest_group();
        let Some(pbr) = self.pbrs.iter_mut().find(|p| p.id == id) else {
            return false;
        };
        let options = BlockOptions::default();
        for b in pbr.blocks_mut() {
            *b = RigidBlock::new(*b.params(), options);
        }
        pbr.members_overturned = 0;
        pbr.governing = 0;
        pbr.in_episode = false;
        pbr.raised = RaisedLevels::default();
        true
    }

    /// Uses the shared rest check (`true`, the default) or steps every block (`false`, for
    /// comparison); the outputs are the same either way.
    pub(crate) fn set_shared_rest_check(&mut self, enabled: bool) {
        if !enabled {
            self.leave_rest_group();
        }
        self.rest.set_enabled(enabled);
    }

    /// Bytes held for this station's catalogued blocks: their runtimes (nominal block
    /// inline), ids, member lists and rest-group entries (allocator overhead excluded).
    pub(crate) fn block_bytes(&self) -> usize {
        self.pbrs.capacity() * std::mem::size_of::<PbrRuntime>()
            + self
                .pbrs
                .iter()
                .map(|p| {
                    p.id.capacity()
                        + p.directions.capacity() * std::mem::size_of::<Direction>()
                        + p.directions
                            .iter()
                            .map(|d| d.members.capacity() * std::mem::size_of::<RigidBlock>())
                            .sum::<usize>()
                })
                .sum::<usize>()
            + self.rest.heap_bytes()
    }

    pub(crate) fn parked_blocks(&self) -> usize {
        self.rest.parked_count()
    }

    /// Every block leaves the rest group (before blocks are changed directly).
    fn leave_rest_group(&mut self) {
        let pbrs = &mut self.pbrs;
        self.rest
            .release_all(|i, clock_s| pbrs[i].leave_rest_group(clock_s));
    }

    /// The ground input of every block jumps here: drop their integrators' stale state.
    fn input_discontinuity(&mut self) {
        self.last = None;
        for p in &mut self.pbrs {
            p.blocks_mut().for_each(RigidBlock::input_discontinuity);
        }
    }

    fn process_packet(&mut self, r: &Released, ctx: &PacketContext<'_>, out: &mut dyn OutputSink) {
        // The packet's own grid: held packets released by a rate change keep their rate.
        let dt_s = 1.0 / r.rate_hz;
        match r.gap {
            Gap::Start | Gap::RateChange | Gap::Rewind => {
                if r.gap == Gap::Rewind {
                    notice(
                        &self.name,
                        "grid_rewound",
                        "packets after a forward jump of the stream's time fell in the gap it left: the jump was an outlier, the grid is rewound to before it (blocks flagged data_gap, intensity window restarted)".into(),
                        out,
                    );
                    // Data time goes back: the rates measured from the jumped data restart.
                    self.quiet_since_ns = None;
                    self.last_intensity_ns = None;
                    for p in &mut self.pbrs {
                        p.data_gap = true;
                        p.last_state_ns = None;
                    }
                }
                if r.gap == Gap::RateChange {
                    notice(
                        &self.name,
                        "rate_change",
                        format!("sample rate changed to {} Hz: intensity window restarted, blocks resume", r.packet.sample_rate_hz),
                        out,
                    );
                }
                let config = RunningConfig::live_default();
                self.ims = match (
                    RunningIms::new(dt_s, &config),
                    RunningIms::new(dt_s, &config),
                ) {
                    (Ok(e), Ok(n)) => Some([e, n]),
                    _ => None,
                };
                self.input_discontinuity();
            }
            Gap::None => {}
            Gap::Bridge(n) => {
                if let (Some(prev), Some(next)) = (self.last, self.sample(&r.packet, r.skip)) {
                    notice(
                        &self.name,
                        "gap_bridged",
                        format!("{n} missing samples bridged by linear interpolation"),
                        out,
                    );
                    for j in 1..=n {
                        let w = j as f64 / (n + 1) as f64;
                        let s = Sample {
                            east: prev.east + (next.east - prev.east) * w,
                            north: prev.north + (next.north - prev.north) * w,
                            up: prev.up + (next.up - prev.up) * w,
                        };
                        let t = r.time_ns(j as i64 - n as i64 - 1);
                        self.feed(s, t, dt_s, ctx, out);
                    }
                }
            }
            Gap::Break(n) => {
                notice(
                    &self.name,
                    "gap",
                    format!("{n} missing samples ({:.3} s): blocks flagged data_gap, integration resumes from the last state", n as f64 * dt_s),
                    out,
                );
                self.input_discontinuity();
                for p in &mut self.pbrs {
                    p.data_gap = true;
                }
            }
        }
        for i in r.skip..r.packet.len() {
            if let Some(s) = self.sample(&r.packet, i) {
                let t = r.time_ns((i - r.skip) as i64);
                self.feed(s, t, dt_s, ctx, out);
            }
        }
        self.counters.samples += (r.packet.len() - r.skip) as u64;
    }

    /// The first sample of `p` beyond `max_abs_mps2` once converted to m/s² (the station's
    /// gain), as (component, index, value in m/s²).
    pub(crate) fn implausible(
        &self,
        p: &super::packet::AccelPacket,
        max_abs_mps2: f64,
    ) -> Option<(&'static str, usize, f64)> {
        let scale = self.config.gain_mps2_per_count.unwrap_or(1.0).abs();
        // One comparison per sample, in packet units (no division in the loop).
        let bound = max_abs_mps2 / scale;
        [("east", &p.east), ("north", &p.north), ("up", &p.up)]
            .into_iter()
            .find_map(|(component, values)| {
                values
                    .iter()
                    .position(|v| f64::from(v.abs()) > bound)
                    .map(|i| (component, i, f64::from(values[i]) * scale))
            })
    }

    /// Sample `i` of a packet in m/s², rotated to east/north; flags clipping.
    fn sample(&mut self, p: &super::packet::AccelPacket, i: usize) -> Option<Sample> {
        let raw = [
            f64::from(*p.east.get(i)?),
            f64::from(*p.north.get(i)?),
            p.up.get(i).map_or(0.0, |v| f64::from(*v)),
        ];
        if let Some(full) = self.config.full_scale {
            if raw.iter().any(|v| v.abs() >= 0.999 * full) {
                self.counters.clipped_samples += 1;
            }
        }
        let scale = self.config.gain_mps2_per_count.unwrap_or(1.0);
        let [c1, c2, up] = raw.map(|v| v * scale);
        let (east, north) = match self.config.orientation {
            Orientation::EastNorth => (c1, c2),
            Orientation::Azimuths { h1, h2 } => {
                let ((e1, n1), (e2, n2)) = (h1.to_east_north(c1), h2.to_east_north(c2));
                (e1 + e2, n1 + n2)
            }
        };
        Some(Sample { east, north, up })
    }

    /// Larger of the horizontal components' running PGA and PGV.
    fn horizontal_pga_pgv(&self) -> (f64, f64) {
        self.ims.as_ref().map_or((0.0, 0.0), |[e, n]| {
            (e.pga_mps2().max(n.pga_mps2()), e.pgv_mps().max(n.pgv_mps()))
        })
    }

    /// One new sample at data time `t_ns`: the station's intensities and quiet, then every
    /// block bound to it (step, alerts, episode, state), then the station's intensity output.
    fn feed(
        &mut self,
        s: Sample,
        t_ns: i64,
        dt_s: f64,
        ctx: &PacketContext<'_>,
        out: &mut dyn OutputSink,
    ) {
        self.push_intensities(s);
        let quiet_long = self.track_quiet(s, t_ns, ctx);
        let prev = self.last.replace(s);
        let (pga_mps2, pgv_mps) = self.horizontal_pga_pgv();
        let at = SampleContext {
            station: &self.name,
            t_ns,
            pga_mps2,
            pgv_mps,
            quiet_long,
        };
        let t_prev_ns = t_ns - (dt_s * 1e9).round() as i64;
        // Without a previous sample no block is stepped; otherwise the parked blocks stay
        // parked while the shared check holds, and those whose own check fails leave.
        if let Some(prev) = prev {
            if self.rest.any_parked() && !self.rest.holds(prev, s, dt_s) {
                let pbrs = &mut self.pbrs;
                self.rest.release_failing(prev, s, dt_s, |i, clock_s| {
                    pbrs[i].leave_rest_group(clock_s);
                });
            }
            self.rest.tick(dt_s);
        }
        let parked_states_due = self.rest.states_may_be_due(t_ns, ctx.state_interval_s);
        if self.rest.all_parked() && !parked_states_due {
            self.emit_intensity_if_due(t_ns, ctx, out);
            self.restart_intensity_window_if_settled(quiet_long, dt_s, ctx);
            return;
        }
        for (i, pbr) in self.pbrs.iter_mut().enumerate() {
            if self.rest.is_parked(i) {
                // Its step would be idle (rest_group): only its periodic state may be due.
                if parked_states_due {
                    pbr.emit_state_if_due(&at, false, ctx, out);
                }
                continue;
            }
            let step = prev.map_or_else(BlockStep::default, |prev| {
                pbr.advance(prev, s, dt_s, t_prev_ns)
            });
            if step.failed {
                self.counters.integration_errors += 1;
            }
            if step.landed_after_flight {
                self.counters.flights += 1;
                notice(
                    at.station,
                    "flight",
                    format!("block {} lost contact with the ground (g + a_up ≤ 0 or N → 0); put down flat at rest", pbr.id),
                    out,
                );
            }
            pbr.raise_alerts(&at, step.first_change_ns, ctx, out);
            pbr.end_episode_if_settled(&at, out);
            pbr.emit_state_if_due(&at, step.first_change_ns.is_some(), ctx, out);
            if self.rest.may_park(i, pbr.nominal().time_s())
                && pbr.may_rest_in_group(self.rest.clock_s(), ctx.alerts)
            {
                self.rest.park(i, pbr.last_state_ns, ctx.state_interval_s);
            }
        }
        if parked_states_due {
            let pbrs = &self.pbrs;
            self.rest
                .rebound_states(ctx.state_interval_s, |i| pbrs[i].last_state_ns);
        }
        self.emit_intensity_if_due(t_ns, ctx, out);
        self.restart_intensity_window_if_settled(quiet_long, dt_s, ctx);
    }

    /// Adds the sample's horizontal components to the running intensity measures.
    fn push_intensities(&mut self, s: Sample) {
        if let Some([e, n]) = &mut self.ims {
            e.push(s.east);
            n.push(s.north);
        }
    }

    /// Follows how long the station has been quiet (every component within
    /// `quiet_threshold_mps2`); true once that has lasted `quiet_s`.
    fn track_quiet(&mut self, s: Sample, t_ns: i64, ctx: &PacketContext<'_>) -> bool {
        let loud =
            s.east.abs().max(s.north.abs()).max(s.up.abs()) > ctx.alerts.quiet_threshold_mps2;
        if loud {
            self.quiet_since_ns = None;
        } else if self.quiet_since_ns.is_none() {
            self.quiet_since_ns = Some(t_ns);
        }
        self.quiet_since_ns
            .is_some_and(|since| (t_ns - since) as f64 * 1e-9 >= ctx.alerts.quiet_s)
    }

    /// Station intensities at the state rate.
    fn emit_intensity_if_due(
        &mut self,
        t_ns: i64,
        ctx: &PacketContext<'_>,
        out: &mut dyn OutputSink,
    ) {
        if self
            .last_intensity_ns
            .is_none_or(|last| (t_ns - last) as f64 * 1e-9 >= ctx.state_interval_s)
        {
            self.last_intensity_ns = Some(t_ns);
            out.push(Output::Intensity(self.intensity(t_ns)));
        }
    }

    /// The intensity window restarts once the station is quiet and no standing block is in
    /// an episode (a fallen block keeps its episode until reset, not the window), and in
    /// any case after MAX_INTENSITY_WINDOW_S, which bounds the running IMs' memory.
    fn restart_intensity_window_if_settled(
        &mut self,
        quiet_long: bool,
        dt_s: f64,
        ctx: &PacketContext<'_>,
    ) {
        let pbrs = &self.pbrs;
        let settled = || {
            pbrs.iter()
                .all(|p| !p.in_episode || p.any_nominal_overturned())
        };
        if let Some(ims) = &mut self.ims {
            let window_s = ims[0].npts() as f64 * dt_s;
            if (quiet_long && window_s > 2.0 * ctx.alerts.quiet_s && settled())
                || window_s > MAX_INTENSITY_WINDOW_S
            {
                ims.iter_mut().for_each(RunningIms::reset);
            }
        }
    }

    pub(crate) fn intensity(&self, t_ns: i64) -> StationIntensity {
        let stream = self.sequencer.counters;
        let (pga, pgv) = self.horizontal_pga_pgv();
        let mut out = StationIntensity {
            station: self.name.clone(),
            data_time_ns: t_ns,
            pga_mps2: pga,
            pgv_mps: pgv,
            pgd_m: 0.0,
            cav_mps: 0.0,
            arias_mps: 0.0,
            asi_mps: 0.0,
            d5_95_s: 0.0,
            sa_periods_s: Vec::new(),
            sa_mps2: Vec::new(),
            rejected_samples: self.counters.rejected_samples,
            gap_samples: stream.missing_samples,
            late_samples: stream.overlap_samples,
        };
        if let Some([e, n]) = &self.ims {
            // Each value is the larger horizontal component's.
            out.pgd_m = e.pgd_m().max(n.pgd_m());
            out.cav_mps = e.cav_mps().max(n.cav_mps());
            out.arias_mps = e.arias_mps().max(n.arias_mps());
            out.d5_95_s = e.d5_95_s().max(n.d5_95_s());
            out.asi_mps = e
                .intensities()
                .zip(n.intensities())
                .map(|(a, b)| a.asi_mps.max(b.asi_mps))
                .next()
                .unwrap_or(0.0);
            for (a, b) in e.spectral().zip(n.spectral()) {
                out.sa_periods_s.push(a.period_s);
                out.sa_mps2.push(a.sa_mps2.max(b.sa_mps2));
            }
        }
        out
    }
}
