//! One station's runtime: its stream sequencer, running intensity measures, and the blocks
//! bound to it, advanced sample by sample.

use std::collections::HashSet;

use super::config::{ConfigError, Orientation, PbrSpec, StationConfig};
use super::health::{HealthChange, Liveness, StationHealth};
use super::output::{JournalRecord, Notice, NoticeKind, Output, OutputSink, StationIntensity};

use super::pbr::{BlockStep, PacketContext, PbrRuntime, SampleContext};
use super::rest_group::{GroundSample as Sample, RestGroup};
use super::stream::{Gap, Released, Sequencer, StreamConfig};
use crate::ims::{RunningConfig, RunningIms};
use crate::pbr_id::PbrId;
use crate::station_id::StationId;

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
    /// Packets rejected because their unit (counts, m/s²) is not the one the station's
    /// configuration expects (counts with a gain, m/s² without), included in
    /// `rejected_packets`.
    pub unit_mismatches: u64,
    pub rejected_samples: u64,
    /// Samples at or beyond 99.9 % of the sensor's full scale (used, but flagged).
    pub clipped_samples: u64,
    /// Intervals the block integrator could not complete (should stay 0).
    pub integration_errors: u64,
    /// Lift-offs of a nominal block (free flight, then put down again).
    pub flights: u64,
}

/// Everything the engine keeps for one station.
#[derive(Debug)]
pub(crate) struct StationRuntime {
    pub(crate) config: StationConfig,
    pub(crate) name: StationId,
    sequencer: Sequencer,
    /// Running intensity measures of the east and north components (the published values
    /// are the larger horizontal's, but PGA; no vertical measure is published, so none is
    /// kept).
    ims: Option<[RunningIms; 2]>,
    /// The published PGA (m/s²): the peak of the horizontal vector, max |(a_E, a_N)| over the
    /// intensity window — independent of the sensor's orientation, and equal to RotD100 of
    /// PGA (the peak over every rotation of the largest component).
    peak_horizontal_mps2: f64,
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

/// Hands `out` a notice about `station`.
fn notice(station: &StationId, kind: NoticeKind, message: String, out: &mut dyn OutputSink) {
    out.push(Output::Notice(Notice {
        station: station.to_string(),
        kind,
        message,
    }));
}

impl StationRuntime {
    pub(crate) fn new(
        config: StationConfig,
        pbrs: &[&PbrSpec],
        stream: StreamConfig,
    ) -> Result<Self, ConfigError> {
        // Exactly as many as bound (collecting through `Result` would not size the vector).
        let mut runtimes = Vec::with_capacity(pbrs.len());
        for spec in pbrs {
            runtimes.push(PbrRuntime::new(spec)?);
        }
        let pbrs = runtimes;
        Ok(StationRuntime {
            rest: RestGroup::new(pbrs.iter().map(PbrRuntime::rest_limit).collect()),
            name: config.id.clone(),
            config,
            sequencer: Sequencer::new(stream),
            ims: None,
            peak_horizontal_mps2: 0.0,
            last: None,
            pbrs,
            quiet_since_ns: None,
            last_intensity_ns: None,
            counters: StationCounters::default(),
            liveness: Liveness::default(),
        })
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
            dropped_samples: stream.overlap_samples,
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
        source: Option<super::Source>,
        ctx: &PacketContext<'_>,
        scratch: &mut Vec<Released>,
        out: &mut dyn OutputSink,
    ) {
        self.counters.packets += 1;
        scratch.clear();
        self.sequencer.offer(packet, source, scratch);
        self.report_dropped(ctx, out);
        for r in scratch.drain(..) {
            self.process_packet(&r, ctx, out);
        }
    }

    /// What the sequencer's last call dropped (data already processed: duplicates, late or
    /// overlapping packets, packets held beyond an undone jump): one notice naming the span,
    /// and each packet counted for its sender.
    fn report_dropped(&self, ctx: &PacketContext<'_>, out: &mut dyn OutputSink) {
        let dropped = self.sequencer.dropped();
        let (Some(start_ns), Some(end_ns)) = (
            dropped.iter().map(|d| d.start_ns).min(),
            dropped.iter().map(|d| d.end_ns).max(),
        ) else {
            return;
        };
        if let Some(tally) = ctx.tally {
            for source in dropped.iter().filter_map(|d| d.source) {
                tally.count_dropped(source);
            }
        }
        let samples: u64 = dropped.iter().map(|d| d.samples).sum();
        notice(
            &self.name,
            NoticeKind::Dropped,
            format!(
                "{samples} samples of {} packet(s) from {} to {} dropped: the station had this data, or later data, processed already (duplicate, late or overlapping packets; {} samples dropped so far)",
                dropped.len(),
                crate::utc::format_utc_ns(i128::from(start_ns)),
                crate::utc::format_utc_ns(i128::from(end_ns)),
                self.sequencer.counters.overlap_samples
            ),
            out,
        );
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
        self.report_dropped(ctx, out);
        for r in scratch.drain(..) {
            self.process_packet(&r, ctx, out);
        }
    }

    /// Restores the blocks' alerts and episodes from the journal `records`; the blocks in
    /// `fallen` ([`super::output::fallen_blocks`] of the same records) are restored fallen.
    pub(crate) fn restore(&mut self, records: &[JournalRecord], fallen: &HashSet<PbrId>) {
        self.leave_rest_group();
        for pbr in &mut self.pbrs {
            let (mut last_episode, mut ended) = (0, 0);
            for record in records {
                match record {
                    JournalRecord::Alert(a) if a.pbr_id == pbr.id => {
                        last_episode = last_episode.max(a.episode);
                    }
                    JournalRecord::EpisodeEnd {
                        pbr_id, episode, ..
                    } if *pbr_id == pbr.id => {
                        ended = ended.max(*episode);
                    }
                    JournalRecord::Reset { pbr_id, .. } if *pbr_id == pbr.id => {
                        ended = last_episode;
                    }
                    _ => {}
                }
            }
            if fallen.contains(&pbr.id) {
                pbr.restore_fallen(last_episode);
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
        previous: &mut std::collections::HashMap<PbrId, PbrRuntime>,
    ) -> Vec<PbrId> {
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
            self.peak_horizontal_mps2 = old.peak_horizontal_mps2;
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
        pbr.reset();
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
            + self.pbrs.iter().map(PbrRuntime::heap_bytes).sum::<usize>()
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
            p.input_discontinuity();
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
                        NoticeKind::GridRewound,
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
                        NoticeKind::RateChange,
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
                self.peak_horizontal_mps2 = 0.0;
                self.input_discontinuity();
            }
            Gap::None => {}
            Gap::Bridge(n) => {
                if let (Some(prev), Some(next)) = (self.last, self.sample(&r.packet, r.skip)) {
                    notice(
                        &self.name,
                        NoticeKind::GapBridged,
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
                    NoticeKind::Gap,
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
    /// Refuses `packet` whole: counted (rejected packets and samples) and said in a `kind`
    /// notice, `packet N rejected: {why}`.
    pub(crate) fn refuse(
        &mut self,
        packet: &super::packet::AccelPacket,
        kind: NoticeKind,
        why: &str,
        out: &mut dyn OutputSink,
    ) -> super::Verdict {
        self.counters.rejected_packets += 1;
        self.counters.rejected_samples += packet.len() as u64;
        notice(
            &self.name,
            kind,
            format!("packet {} rejected: {why}", packet.sequence),
            out,
        );
        super::Verdict::Refused
    }

    /// Why a packet whose samples are in `unit` cannot be taken by this station, if it
    /// cannot: the station's configuration says whether its packets are counts (a gain) or
    /// m/s² (none).
    pub(crate) fn unit_problem(&self, unit: super::SampleUnit) -> Option<String> {
        use super::SampleUnit;
        match (unit, self.config.gain_mps2_per_count) {
            (SampleUnit::Counts, None) => Some(
                "its samples are counts, but the station has no gain_mps2_per_count in the node's [[station]]: they cannot be converted to m/s²"
                    .into(),
            ),
            (SampleUnit::MetresPerSecondSquared, Some(gain)) => Some(format!(
                "its samples are m/s², but the node's [[station]] gives the station a gain for counts ({gain} m/s² per count): calibrated data would be scaled again"
            )),
            (SampleUnit::Unknown(code), _) => Some(format!(
                "unknown sample unit code {code} (0 m/s², 1 counts)"
            )),
            _ => None,
        }
    }

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

    /// The running PGA, the peak of the horizontal vector (orientation-independent), and the
    /// running PGV, the larger horizontal component's.
    fn horizontal_pga_pgv(&self) -> (f64, f64) {
        self.ims.as_ref().map_or((0.0, 0.0), |[e, n]| {
            (self.peak_horizontal_mps2, e.pgv_mps().max(n.pgv_mps()))
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
                    NoticeKind::Flight,
                    format!("block {} lost contact with the ground (g + a_up ≤ 0 or N → 0); put down flat at rest", pbr.id),
                    out,
                );
            }
            pbr.raise_alerts(&at, step.first_change_ns, ctx, out);
            pbr.end_episode_if_settled(&at, out);
            pbr.emit_state_if_due(&at, step.first_change_ns.is_some(), ctx, out);
            if self.rest.may_park(i, pbr.time_s())
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
            self.peak_horizontal_mps2 = self.peak_horizontal_mps2.max(s.east.hypot(s.north));
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
                self.peak_horizontal_mps2 = 0.0;
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
