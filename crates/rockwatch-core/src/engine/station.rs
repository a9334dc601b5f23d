//! One station's runtime: its stream sequencer, running intensity measures, and the blocks
//! bound to it, advanced sample by sample.

use super::config::{AlertConfig, Orientation, PbrSpec, StationConfig};
use std::collections::HashSet;

use super::output::{
    Alert, AlertKey, AlertLevel, JournalRecord, Notice, Output, OutputSink, PbrState, RaisedLevels,
    StationIntensity,
};
use super::stream::{Gap, Released, Sequencer, StreamConfig};
use crate::azimuth::Azimuth;
use crate::dynamics::{BlockEvent, BlockOptions, GroundAccel, Mode, RigidBlock};
use crate::ims::{RunningConfig, RunningIms};

/// Longest intensity window (s): a station that never goes quiet restarts its running IMs
/// after this long (bounding their memory, about 8 bytes per sample and component).
pub const MAX_INTENSITY_WINDOW_S: f64 = 3600.0;

/// Per-station counters of data problems (cumulative).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct StationCounters {
    pub packets: u64,
    pub samples: u64,
    /// Packets rejected by validation (NaN/Inf, bad lengths, absurd rates, …).
    pub rejected_packets: u64,
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
}

/// One catalogued block in the engine.
#[derive(Debug, Clone)]
pub(crate) struct PbrRuntime {
    id: String,
    /// Direction of the block's +x axis.
    axis: Azimuth,
    nominal: RigidBlock,
    members: Vec<RigidBlock>,
    members_overturned: usize,
    episode: u32,
    in_episode: bool,
    raised: RaisedLevels,
    data_gap: bool,
    last_state_ns: Option<i64>,
}

impl PbrRuntime {
    fn new(spec: &PbrSpec) -> Self {
        let options = BlockOptions::default();
        PbrRuntime {
            id: spec.id.clone(),
            axis: spec.azimuth,
            nominal: RigidBlock::new(spec.nominal, options),
            members: spec
                .members
                .iter()
                .map(|p| RigidBlock::new(*p, options))
                .collect(),
            members_overturned: 0,
            episode: 0,
            in_episode: false,
            raised: RaisedLevels::default(),
            data_gap: false,
            last_state_ns: None,
        }
    }

    fn theta_over_alpha(&self) -> f64 {
        self.nominal.theta_rad().abs() / self.nominal.params().alpha_rad
    }

    fn overturn_probability(&self) -> f64 {
        if self.members.is_empty() {
            f64::from(u8::from(self.nominal.mode() == Mode::Overturned))
        } else {
            self.members_overturned as f64 / self.members.len() as f64
        }
    }

    fn at_rest(&self) -> bool {
        let still = |b: &RigidBlock| matches!(b.mode(), Mode::Rest | Mode::Overturned);
        still(&self.nominal) && self.members.iter().all(still)
    }

    fn state(&self, station: &str, data_time_ns: i64) -> PbrState {
        PbrState {
            pbr_id: self.id.clone(),
            station: station.to_string(),
            mode: self.nominal.mode(),
            theta_rad: self.nominal.theta_rad(),
            theta_over_alpha: self.nominal.theta_rad() / self.nominal.params().alpha_rad,
            slide_m: self.nominal.slide_m(),
            overturned: self.nominal.mode() == Mode::Overturned,
            overturn_probability: self.overturn_probability(),
            data_gap: self.data_gap,
            data_time_ns,
        }
    }

    pub(crate) fn summary(&self, station: &str) -> PbrSummary {
        let stats = self.nominal.stats();
        PbrSummary {
            pbr_id: self.id.clone(),
            station: station.to_string(),
            max_theta_over_alpha: stats.max_abs_theta_rad / self.nominal.params().alpha_rad,
            max_slide_m: stats.max_abs_slide_m,
            overturned: self.nominal.mode() == Mode::Overturned,
            overturn_probability: self.overturn_probability(),
            data_gap: self.data_gap,
            episodes: self.episode,
        }
    }
}

/// Ground acceleration of one sample at a station, rotated to east/north/up, in m/s².
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    east: f64,
    north: f64,
    up: f64,
}

/// Everything the engine keeps for one station.
#[derive(Debug)]
pub(crate) struct StationRuntime {
    pub(crate) config: StationConfig,
    pub(crate) name: String,
    sequencer: Sequencer,
    ims: Option<[RunningIms; 3]>,
    has_up: bool,
    last: Option<Sample>,
    pub(crate) pbrs: Vec<PbrRuntime>,
    quiet_since_ns: Option<i64>,
    last_intensity_ns: Option<i64>,
    pub(crate) counters: StationCounters,
}

/// Context of one released packet, shared by its samples.
pub(crate) struct PacketContext<'a> {
    pub(crate) alerts: &'a AlertConfig,
    /// Alerts already in the journal (published before a restart): not emitted again.
    pub(crate) journaled: &'a HashSet<AlertKey>,
    pub(crate) state_interval_s: f64,
    pub(crate) arrival_ns: i64,
}

impl StationRuntime {
    pub(crate) fn new(config: StationConfig, pbrs: &[&PbrSpec], stream: StreamConfig) -> Self {
        StationRuntime {
            name: config.id.to_string(),
            config,
            sequencer: Sequencer::new(stream),
            ims: None,
            has_up: false,
            last: None,
            pbrs: pbrs.iter().map(|s| PbrRuntime::new(s)).collect(),
            quiet_since_ns: None,
            last_intensity_ns: None,
            counters: StationCounters::default(),
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

    /// Restores a block's alerts, episodes and fallen state from the journal.
    pub(crate) fn restore(&mut self, records: &[JournalRecord]) {
        for pbr in &mut self.pbrs {
            let (mut last_episode, mut ended, mut overturned) = (0, 0, false);
            for record in records {
                match record {
                    JournalRecord::Alert(a) if a.pbr_id == pbr.id => {
                        last_episode = last_episode.max(a.episode);
                        overturned |= a.level == AlertLevel::Overturned;
                    }
                    JournalRecord::EpisodeEnd { pbr_id, episode } if *pbr_id == pbr.id => {
                        ended = ended.max(*episode);
                    }
                    JournalRecord::Reset { pbr_id } if *pbr_id == pbr.id => {
                        overturned = false;
                        ended = last_episode;
                    }
                    _ => {}
                }
            }
            if overturned {
                pbr.nominal.set_overturned();
                pbr.members.iter_mut().for_each(RigidBlock::set_overturned);
                pbr.members_overturned = pbr.members.len();
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

    /// An operator reset: the block stands again at rest, its episode closed.
    pub(crate) fn reset_pbr(&mut self, id: &str) -> bool {
        let Some(pbr) = self.pbrs.iter_mut().find(|p| p.id == id) else {
            return false;
        };
        let options = BlockOptions::default();
        pbr.nominal = RigidBlock::new(*pbr.nominal.params(), options);
        for m in &mut pbr.members {
            *m = RigidBlock::new(*m.params(), options);
        }
        pbr.members_overturned = 0;
        pbr.in_episode = false;
        pbr.raised = RaisedLevels::default();
        true
    }

    fn notice(&self, kind: &'static str, message: String, out: &mut dyn OutputSink) {
        out.push(Output::Notice(Notice {
            station: self.name.clone(),
            kind,
            message,
        }));
    }

    /// The ground input of every block jumps here: drop their integrators' stale state.
    fn input_discontinuity(&mut self) {
        self.last = None;
        for p in &mut self.pbrs {
            p.nominal.input_discontinuity();
            p.members
                .iter_mut()
                .for_each(RigidBlock::input_discontinuity);
        }
    }

    fn process_packet(&mut self, r: &Released, ctx: &PacketContext<'_>, out: &mut dyn OutputSink) {
        // The packet's own grid: held packets released by a rate change keep their rate.
        let dt_s = 1.0 / r.rate_hz;
        match r.gap {
            Gap::Start | Gap::RateChange => {
                if r.gap == Gap::RateChange {
                    self.notice(
                        "rate_change",
                        format!("sample rate changed to {} Hz: intensity window restarted, blocks resume", r.packet.sample_rate_hz),
                        out,
                    );
                }
                let config = RunningConfig::live_default();
                self.ims = match (
                    RunningIms::new(dt_s, &config),
                    RunningIms::new(dt_s, &config),
                    RunningIms::new(dt_s, &config),
                ) {
                    (Ok(e), Ok(n), Ok(u)) => Some([e, n, u]),
                    _ => None,
                };
                self.input_discontinuity();
            }
            Gap::None => {}
            Gap::Bridge(n) => {
                if let (Some(prev), Some(next)) = (self.last, self.sample(&r.packet, r.skip)) {
                    self.notice(
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
                self.notice(
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
        if !r.packet.up.is_empty() {
            self.has_up = true;
        }
        for i in r.skip..r.packet.len() {
            if let Some(s) = self.sample(&r.packet, i) {
                let t = r.time_ns((i - r.skip) as i64);
                self.feed(s, t, dt_s, ctx, out);
            }
        }
        self.counters.samples += (r.packet.len() - r.skip) as u64;
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
        self.ims.as_ref().map_or((0.0, 0.0), |[e, n, _]| {
            (e.pga_mps2().max(n.pga_mps2()), e.pgv_mps().max(n.pgv_mps()))
        })
    }

    /// One new sample at data time `t_ns`.
    fn feed(
        &mut self,
        s: Sample,
        t_ns: i64,
        dt_s: f64,
        ctx: &PacketContext<'_>,
        out: &mut dyn OutputSink,
    ) {
        if let Some([e, n, u]) = &mut self.ims {
            e.push(s.east);
            n.push(s.north);
            if self.has_up {
                u.push(s.up);
            }
        }
        let loud =
            s.east.abs().max(s.north.abs()).max(s.up.abs()) > ctx.alerts.quiet_threshold_mps2;
        if loud {
            self.quiet_since_ns = None;
        } else if self.quiet_since_ns.is_none() {
            self.quiet_since_ns = Some(t_ns);
        }
        let quiet_long = self
            .quiet_since_ns
            .is_some_and(|since| (t_ns - since) as f64 * 1e-9 >= ctx.alerts.quiet_s);

        let prev = self.last;
        self.last = Some(s);
        let (pga, pgv) = self.horizontal_pga_pgv();
        let t_prev_ns = t_ns - (dt_s * 1e9).round() as i64;
        for index in 0..self.pbrs.len() {
            let pbr = &mut self.pbrs[index];
            let project = |x: Sample| GroundAccel {
                horizontal_mps2: pbr.axis.component(x.east, x.north),
                vertical_mps2: x.up,
            };
            let mut first_change_ns: Option<i64> = None;
            let mut failed = false;
            let mut landed_after_flight = false;
            if let Some(prev) = prev {
                let (from, to) = (project(prev), project(s));
                let t_before = pbr.nominal.time_s();
                let result = pbr.nominal.advance(dt_s, from, to, |e| {
                    if let BlockEvent::ModeChange { t_s, .. } = e {
                        first_change_ns
                            .get_or_insert(t_prev_ns + ((t_s - t_before) * 1e9).round() as i64);
                    }
                });
                failed |= result.is_err();
                // A lift-off is reported (state, notice); the block is put down again as soon
                // as the effective gravity is positive (flight is not modelled, spec §10).
                if pbr.nominal.mode() == Mode::Flight {
                    landed_after_flight = pbr.nominal.land_after_flight(to);
                }
                let mut overturned = 0;
                for m in &mut pbr.members {
                    failed |= m.advance(dt_s, from, to, |_| {}).is_err();
                    m.land_after_flight(to);
                    overturned += usize::from(m.mode() == Mode::Overturned);
                }
                pbr.members_overturned = overturned;
            }
            if failed {
                self.counters.integration_errors += 1;
            }
            if landed_after_flight {
                self.counters.flights += 1;
                let id = self.pbrs[index].id.clone();
                self.notice(
                    "flight",
                    format!("block {id} lost contact with the ground (g + a_up ≤ 0 or N → 0); put down flat at rest"),
                    out,
                );
            }
            let pbr = &mut self.pbrs[index];
            let mode_changed = first_change_ns.is_some();
            // Alerts, each once per episode.
            let ratio = pbr.theta_over_alpha();
            let probability = pbr.overturn_probability();
            let mode = pbr.nominal.mode();
            let conditions = [
                (AlertLevel::MotionOnset, mode != Mode::Rest),
                (
                    AlertLevel::OverturnImminent,
                    ratio >= ctx.alerts.imminent_theta_ratio
                        || (!pbr.members.is_empty()
                            && probability >= ctx.alerts.imminent_probability),
                ),
                (AlertLevel::Overturned, mode == Mode::Overturned),
            ];
            for (level, holds) in conditions {
                if holds && !pbr.raised.contains(level) {
                    if !pbr.in_episode {
                        pbr.in_episode = true;
                        pbr.episode += 1;
                    }
                    pbr.raised.insert(level);
                    if ctx
                        .journaled
                        .contains(&(pbr.id.clone(), pbr.episode, level))
                    {
                        continue; // published before a restart
                    }
                    let data_time_ns = if level == AlertLevel::MotionOnset {
                        first_change_ns.unwrap_or(t_ns)
                    } else {
                        t_ns
                    };
                    out.push(Output::Alert(Alert {
                        pbr_id: pbr.id.clone(),
                        station: self.name.clone(),
                        level,
                        episode: pbr.episode,
                        mode,
                        theta_over_alpha: pbr.nominal.theta_rad() / pbr.nominal.params().alpha_rad,
                        slide_m: pbr.nominal.slide_m(),
                        overturn_probability: probability,
                        pga_mps2: pga,
                        pgv_mps: pgv,
                        data_time_ns,
                        arrival_ns: ctx.arrival_ns,
                    }));
                }
            }
            // Episode end: back at rest on a quiet station (a fallen block stays fallen).
            if pbr.in_episode && quiet_long && pbr.at_rest() && mode != Mode::Overturned {
                pbr.in_episode = false;
                pbr.raised = RaisedLevels::default();
                out.push(Output::EpisodeEnd {
                    pbr_id: pbr.id.clone(),
                    episode: pbr.episode,
                });
            }
            // States: on mode change and at the state rate.
            let due = pbr
                .last_state_ns
                .is_none_or(|last| (t_ns - last) as f64 * 1e-9 >= ctx.state_interval_s);
            if mode_changed || due {
                pbr.last_state_ns = Some(t_ns);
                out.push(Output::State(pbr.state(&self.name, t_ns)));
            }
        }
        // Station intensities at the state rate; the window restarts when all is quiet.
        if self
            .last_intensity_ns
            .is_none_or(|last| (t_ns - last) as f64 * 1e-9 >= ctx.state_interval_s)
        {
            self.last_intensity_ns = Some(t_ns);
            out.push(Output::Intensity(self.intensity(t_ns)));
        }
        // The intensity window restarts once the station is quiet and no standing block is in
        // an episode (a fallen block keeps its episode until reset, not the window), and in
        // any case after MAX_INTENSITY_WINDOW_S, which bounds the running IMs' memory.
        let settled = self
            .pbrs
            .iter()
            .all(|p| !p.in_episode || p.nominal.mode() == Mode::Overturned);
        if let Some(ims) = &mut self.ims {
            let window_s = ims[0].npts() as f64 * dt_s;
            if (quiet_long && settled && window_s > 2.0 * ctx.alerts.quiet_s)
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
        if let Some([e, n, _]) = &self.ims {
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
