//! The monitoring engine: the transport-free core of the live node. It takes acceleration
//! packets from many stations, keeps running intensity measures per station, advances every
//! catalogued block bound to each station sample by sample, and emits states and alerts.
//!
//! - [`packet`]: packets and their validation;
//! - [`stream`]: per-station sequencing (gaps, overlaps, duplicates, reordering, rate changes);
//! - [`config`]: stations, thresholds, blocks;
//! - [`output`]: alerts, states, intensities, notices;
//! - [`sensor_frame`]: an accelerometer's specific force as ground acceleration (ENU, gravity);
//! - `station`: one station's runtime (sample-by-sample processing);
//! - [`health`]: whether each station still sends (stale / recovered) and its figures;
//! - [`sharded`]: stations spread over worker threads.
//!
//! Architecture invariant: deterministic — the same packets in the same order give the same
//! outputs. The engine reads no clock: the caller passes each packet's arrival time, which is
//! copied into alerts so that the shell can compute the processing latency on emission.
//!
//! Bad data never stops the engine. A packet that fails validation is rejected whole
//! (counted, with a notice naming the station); a packet for a station that is neither
//! configured nor named by the catalogue is counted and ignored. Gaps up to
//! `stream.max_bridge_s` are bridged by linear interpolation; longer gaps set the data-gap
//! flag of the station's blocks, and integration resumes at the first sample after the gap from
//! the blocks' last state (the motion during the gap is unknown; the flag says so).

pub mod config;
pub mod health;
mod members;
pub mod output;
pub mod packet;
mod pbr;
mod rest_group;
mod rigid_rock;
pub mod sensor_frame;
pub mod sharded;
pub mod source;
mod station;
pub mod stream;

use std::collections::{BTreeMap, HashMap, HashSet};
use std::sync::Arc;

pub use crate::pbr_id::PbrId;
pub use config::{
    AlertConfig, ConfigError, EngineConfig, Orientation, PbrSpec, PlausibilityConfig, Rock3dSpec,
    Rock3dSpecError, RockPlace, StationConfig,
};
pub use health::{HealthChange, StationHealth};
pub use members::MemberError;
pub use output::{
    compact_journal, fallen_blocks, journaled_alerts, journaled_history, Alert, AlertKey,
    AlertLevel, HistoryEntry, JournalRecord, Notice, NoticeKind, Output, OutputSink, PbrState,
    ResetEvent, StationIntensity,
};
pub use packet::{
    station_at_edge, AccelPacket, MalformedStation, PacketError, SampleUnit, StationId,
};
pub use pbr::{DirectionSummary, PbrSummary};
pub use sharded::{EngineHandle, ShardedEngine};
pub use source::{Source, SourceCounts, SourceTally, Verdict, MAX_SOURCES};
pub use station::StationCounters;
pub use stream::{Dropped, StreamConfig, StreamCounters};

use pbr::PacketContext;
use station::StationRuntime;

/// Engine-wide counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct EngineCounters {
    pub packets: u64,
    /// Packets from stations neither configured nor in the catalogue.
    pub unknown_station_packets: u64,
}

/// Why an engine cannot be built or started.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error("station {station} is configured twice")]
    DuplicateStation { station: StationId },
    /// A worker thread of a [`ShardedEngine`] could not be spawned.
    #[error("cannot start engine worker: {0}")]
    Worker(std::io::Error),
}

/// What [`Engine::reload`] did with the blocks (ids, catalogue order within each station).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReloadReport {
    /// In both catalogues, the same block on the same station: state kept.
    pub kept: Vec<PbrId>,
    /// New ids: at rest.
    pub added: Vec<PbrId>,
    /// Ids in both whose body, axis, members or station changed: at rest again.
    pub replaced: Vec<PbrId>,
    /// Gone from the catalogue: dropped.
    pub dropped: Vec<PbrId>,
}

/// The monitoring engine.
#[derive(Debug)]
pub struct Engine {
    config: EngineConfig,
    stations: BTreeMap<StationId, StationRuntime>,
    counters: EngineCounters,
    journaled: HashSet<AlertKey>,
    scratch: Vec<stream::Released>,
    /// `now_ns` of the first [`Engine::check_health`]: a station never heard from is stale
    /// `stale_after_s` after it.
    health_since_ns: Option<i64>,
    /// Where [`Engine::process_from`] counts what it made of each source's packets.
    tally: Option<Arc<SourceTally>>,
}

impl Engine {
    /// Builds an engine for `stations` and the blocks `pbrs`. A station named by a block but not
    /// configured gets the defaults (east/north/up in m/s², no clipping level).
    pub fn new(
        config: EngineConfig,
        stations: Vec<StationConfig>,
        pbrs: &[PbrSpec],
    ) -> Result<Engine, EngineError> {
        let mut configs: BTreeMap<StationId, StationConfig> = BTreeMap::new();
        for s in stations {
            s.validate()?;
            if configs.insert(s.id.clone(), s.clone()).is_some() {
                return Err(EngineError::DuplicateStation { station: s.id });
            }
        }
        for p in pbrs {
            configs
                .entry(p.station.clone())
                .or_insert_with(|| StationConfig::default_for(p.station.clone()));
        }
        config.validate()?;
        // Each station's blocks in catalogue order (one pass: linear in the catalogue).
        let mut bound: BTreeMap<&StationId, Vec<&PbrSpec>> = BTreeMap::new();
        for p in pbrs {
            bound.entry(&p.station).or_default().push(p);
        }
        let stations = configs
            .into_iter()
            .map(|(id, c)| {
                let mine = bound.remove(&id).unwrap_or_default();
                Ok((id, StationRuntime::new(c, &mine, config.stream)?))
            })
            .collect::<Result<BTreeMap<StationId, StationRuntime>, ConfigError>>()?;
        Ok(Engine {
            config,
            stations,
            counters: EngineCounters::default(),
            journaled: HashSet::new(),
            scratch: Vec::new(),
            health_since_ns: None,
            tally: None,
        })
    }

    /// Replaces the configuration, the stations and the blocks (a reload of the node's files)
    /// without losing state: a block present before and after, the same block on the same
    /// station, keeps its motion, episode and raised alerts; a new block starts at rest; a
    /// block gone is dropped; a station present before and after keeps its stream and running
    /// measures. Everything is checked first (as [`Engine::new`] does): on error nothing
    /// changes. Call it between packets.
    pub fn reload(
        &mut self,
        config: EngineConfig,
        stations: Vec<StationConfig>,
        pbrs: &[PbrSpec],
    ) -> Result<ReloadReport, EngineError> {
        let mut fresh = Engine::new(config, stations, pbrs)?;
        let old_ids: Vec<PbrId> = self
            .stations
            .values()
            .flat_map(|s| s.pbrs.iter().map(|p| p.id().clone()))
            .collect();
        let mut previous: HashMap<PbrId, pbr::PbrRuntime> = self
            .stations
            .values_mut()
            .flat_map(StationRuntime::take_blocks)
            .map(|p| (p.id().clone(), p))
            .collect();
        let mut report = ReloadReport::default();
        for (id, station) in &mut fresh.stations {
            let kept = station.continue_from(self.stations.remove(id), &mut previous);
            for pbr in &mut station.pbrs {
                let pid = pbr.id().clone();
                if kept.contains(&pid) {
                    report.kept.push(pid);
                } else if old_ids.contains(&pid) {
                    report.replaced.push(pid);
                } else {
                    // Its journaled alerts (a block back in the catalogue) are not reused.
                    let last = self
                        .journaled
                        .iter()
                        .filter(|(id, _, _)| *id == pid)
                        .map(|(_, episode, _)| *episode)
                        .max()
                        .unwrap_or(0);
                    pbr.continue_episodes_after(last);
                    report.added.push(pid);
                }
            }
        }
        report.dropped = old_ids
            .into_iter()
            .filter(|o| !pbrs.iter().any(|p| &p.id == o))
            .collect();
        fresh.counters = self.counters;
        fresh.journaled = std::mem::take(&mut self.journaled);
        fresh.tally = self.tally.take();
        *self = fresh;
        Ok(report)
    }

    /// Whether the engine monitors station `station` (`NET.STA.LOC`): configured, or bound to
    /// a block. A packet of any other station is ignored ([`Engine::process`] counts it and
    /// says so in a notice).
    #[must_use]
    pub fn monitors(&self, station: &str) -> bool {
        self.stations.contains_key(station)
    }

    /// The stations the engine monitors (see [`Engine::monitors`]).
    pub fn monitored_stations(&self) -> impl Iterator<Item = &str> {
        self.stations.keys().map(StationId::as_str)
    }

    /// The configuration in force.
    #[must_use]
    pub fn config(&self) -> &EngineConfig {
        &self.config
    }

    /// Changes the alert thresholds (e.g. from a ROS 2 parameter); effective immediately.
    pub fn set_alert_config(&mut self, alerts: AlertConfig) {
        self.config.alerts = alerts;
    }

    /// New state publication interval (s of data), effective for the next packet; a value
    /// that is not finite and > 0 is ignored (returns false).
    pub fn set_state_interval_s(&mut self, state_interval_s: f64) -> bool {
        let ok = state_interval_s.is_finite() && state_interval_s > 0.0;
        if ok {
            self.config.state_interval_s = state_interval_s;
        }
        ok
    }

    /// Counts what [`Engine::process_from`] makes of each source's packets in `tally` from
    /// now on.
    pub fn set_source_tally(&mut self, tally: Arc<SourceTally>) {
        self.tally = Some(tally);
    }

    /// Processes one packet that arrived at wall time `arrival_ns`; hands each output to `out`
    /// as soon as it is produced (pass a `&mut Vec<Output>` to collect them). Returns what
    /// became of the packet.
    pub fn process(
        &mut self,
        packet: AccelPacket,
        arrival_ns: i64,
        out: &mut dyn OutputSink,
    ) -> Verdict {
        self.process_from(packet, None, arrival_ns, out)
    }

    /// [`Engine::process`] of a packet from `source`: with a tally set
    /// ([`Engine::set_source_tally`]), the verdict is counted for the source, and so are its
    /// packets whose samples are dropped as already processed (now, or later when a held
    /// packet is released or dropped) — the drop is counted before the packet's verdict.
    pub fn process_from(
        &mut self,
        packet: AccelPacket,
        source: Option<Source>,
        arrival_ns: i64,
        out: &mut dyn OutputSink,
    ) -> Verdict {
        let verdict = self.judge(packet, source, arrival_ns, out);
        if let (Some(tally), Some(source)) = (&self.tally, source) {
            tally.count(source, verdict);
        }
        verdict
    }

    fn judge(
        &mut self,
        packet: AccelPacket,
        source: Option<Source>,
        arrival_ns: i64,
        out: &mut dyn OutputSink,
    ) -> Verdict {
        self.counters.packets += 1;
        let station = self.stations.get_mut(&packet.station);
        let Some(station) = station else {
            self.counters.unknown_station_packets += 1;
            out.push(Output::Notice(Notice {
                station: packet.station.to_string(),
                kind: NoticeKind::UnknownStation,
                message:
                    "packet from a station that is neither configured nor in the catalogue: ignored"
                        .into(),
            }));
            return Verdict::Ignored;
        };
        if let Some(problem) = station.unit_problem(packet.unit) {
            station.counters.unit_mismatches += 1;
            return station.refuse(&packet, NoticeKind::Rejected, &problem, out);
        }
        if let Err(error) = packet.validate_samples() {
            return station.refuse(&packet, NoticeKind::Rejected, &error.to_string(), out);
        }
        let max_abs_mps2 = self.config.plausibility.max_abs_accel_mps2();
        if let Some((component, index, value)) = station.implausible(&packet, max_abs_mps2) {
            station.counters.implausible_packets += 1;
            let why = format!(
                "{component}[{index}] = {value:.6e} m/s² is beyond the physical bound of {} g (engine.plausibility.max_abs_accel_g)",
                self.config.plausibility.max_abs_accel_g
            );
            return station.refuse(&packet, NoticeKind::Implausible, &why, out);
        }
        station.accepted(
            arrival_ns,
            packet.start_time_ns,
            packet.len(),
            packet.sample_rate_hz,
            out,
        );
        let ctx = PacketContext {
            alerts: &self.config.alerts,
            journaled: &self.journaled,
            state_interval_s: self.config.state_interval_s,
            arrival_ns,
            tally: self.tally.as_deref(),
        };
        station.offer(packet, source, &ctx, &mut self.scratch, out);
        Verdict::Accepted
    }

    /// Judges every station's health at `now_ns` (the clock of the arrival stamps passed to
    /// [`Engine::process`]): a station silent for more than `stale_after_s` goes stale, which
    /// is reported ([`Output::Health`], then a state of each of its blocks flagged
    /// `not_monitored`); its next accepted packet reports the recovery. A station never heard
    /// from counts from the first call. Call it regularly (the node does on every tick of its
    /// event loop); it allocates only to report a change.
    pub fn check_health(&mut self, now_ns: i64, out: &mut dyn OutputSink) {
        let since_ns = *self.health_since_ns.get_or_insert(now_ns);
        let stale_after_ns = (self.config.stale_after_s * 1e9) as i64;
        for station in self.stations.values_mut() {
            station.check_stale(now_ns, since_ns, stale_after_ns, out);
        }
    }

    /// Every station's health now, by station id.
    #[must_use]
    pub fn health(&self) -> Vec<StationHealth> {
        self.stations.values().map(|s| s.health()).collect()
    }

    /// Pushes [`Engine::health`] as one [`Output::HealthReport`] (how a sharded engine's
    /// workers answer).
    pub fn report_health(&self, out: &mut dyn OutputSink) {
        out.push(Output::HealthReport(self.health()));
    }

    /// Restores alerts, episodes and fallen blocks from the journal of a previous run. Alerts
    /// already journaled are never emitted again.
    pub fn restore(&mut self, records: &[JournalRecord]) {
        for record in records {
            if let JournalRecord::Alert(a) = record {
                self.journaled.insert(a.key());
            }
        }
        let fallen = fallen_blocks(records);
        for station in self.stations.values_mut() {
            station.restore(records, &fallen);
        }
    }

    /// An operator reset of block `pbr_id` (it stands again); false if no such block.
    /// Uses each station's shared rest check (`true`, the default: a station's resting
    /// blocks share one check per sample, see `engine/rest_group.rs`) or steps every block
    /// (`false`). The outputs are bit for bit the same either way; `false` exists to show it
    /// (`tests/engine.rs`) and to measure the gain (`cargo bench --bench engine`).
    pub fn set_shared_rest_check(&mut self, enabled: bool) {
        for station in self.stations.values_mut() {
            station.set_shared_rest_check(enabled);
        }
    }

    /// Catalogued blocks currently parked in their station's rest group (at rest, sharing
    /// the station's one rest check per sample).
    #[must_use]
    pub fn parked_blocks(&self) -> usize {
        self.stations.values().map(|s| s.parked_blocks()).sum()
    }

    /// Bytes held for the catalogued blocks: each block's runtime with its nominal
    /// `RigidBlock` inline, its id, its ensemble members (at rest or fallen: primary
    /// parameters, rest limits and state, 104 B; in motion: also a `RigidBlock`, in a list
    /// that grows to the largest number in motion at once, `members.rs`) and its rest-group
    /// entry; allocator overhead excluded.
    #[must_use]
    pub fn block_bytes(&self) -> usize {
        self.stations.values().map(|s| s.block_bytes()).sum()
    }

    /// Ensemble members (of every rock, in every direction) neither at rest nor fallen: the
    /// blocks whose integration costs a step per sample (capacity figures, docs/capacity.md).
    #[must_use]
    pub fn members_in_motion(&self) -> usize {
        self.stations
            .values()
            .flat_map(|s| s.pbrs.iter())
            .map(pbr::PbrRuntime::members_in_motion)
            .sum()
    }

    pub fn reset_pbr(&mut self, pbr_id: &str) -> bool {
        self.stations.values_mut().any(|s| s.reset_pbr(pbr_id))
    }

    /// Releases every packet held for reordering (call when streams go quiet, and at the end
    /// of an offline run).
    pub fn flush(&mut self, arrival_ns: i64, out: &mut dyn OutputSink) {
        let ctx = PacketContext {
            alerts: &self.config.alerts,
            journaled: &self.journaled,
            state_interval_s: self.config.state_interval_s,
            arrival_ns,
            tally: self.tally.as_deref(),
        };
        for station in self.stations.values_mut() {
            station.flush(&ctx, &mut self.scratch, out);
        }
    }

    /// Engine-wide counters.
    #[must_use]
    pub fn counters(&self) -> EngineCounters {
        self.counters
    }

    /// Per-station counters: (station, own counters, stream counters).
    pub fn station_counters(
        &self,
    ) -> impl Iterator<Item = (&StationId, StationCounters, StreamCounters)> {
        self.stations
            .iter()
            .map(|(id, s)| (id, s.counters, s.sequencer().counters))
    }

    /// Response summaries of every block, by station then catalogue order.
    #[must_use]
    pub fn summaries(&self) -> Vec<PbrSummary> {
        self.stations
            .values()
            .flat_map(|s| s.pbrs.iter().map(|p| p.summary(&s.name)))
            .collect()
    }
}
