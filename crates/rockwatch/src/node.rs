//! The live node (shell).
//!
//! - [`NodeRuntime`]: the transport-independent runtime: the engine (inline on the caller's
//!   thread with one shard, else sharded over worker threads), the state directory, arrival
//!   time stamps, rate-limited logging. `rockwatch monitor` runs on it too (one inline shard,
//!   notices counted: [`NoticeLog::Counted`]), so the CLI and the node share one path from
//!   the engine to the outside.
//! - module `delivery`: the one path from the engine's outputs to the journal and the
//!   publishers (journal and sync, then publish; `Published` markers; the republication at
//!   start).
//! - [`serve`] / [`Reactor`] (module `serve`): the node itself, one event loop that takes the
//!   input of every transport (ROS 2, iceoryx2), runs the engine and publishes.
//!
//! Ordering guarantee: an alert is appended to the journal and synced before it is handed to
//! any publisher, so a published alert is never lost; once handed to the publishers, a
//! `Published` marker is journaled (unsynced). On restart the journal is restored into the
//! engine, so the engine never raises an alert twice; the node publishes again the journaled
//! alerts without a marker (to every publisher: at least once) and the last
//! [`HISTORY_ALERTS`](crate::journal::HISTORY_ALERTS) alerts on ROS 2 (the transient-local history of `/pbr/alerts`), see
//! docs/reliability.md.
//!
//! A failing state directory (a full disk) degrades, never stops, the node: an alert that
//! cannot be journaled is published at once flagged `journal_pending`, waits in a bounded
//! backlog ([`crate::journal::JournalWriter`]) and is journaled when the directory recovers
//! (retried every [`HELD_PACKET_TIMEOUT`] and before every later record); the fault is
//! logged, counted ([`NodeStats`]) and in the node's closing summary.

mod delivery;
mod serve;

use delivery::Emitter;

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::PathBuf;

use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;

pub use serve::{serve, serve_supervised, Probe, Reactor, ServeReport, Supervision};

use crate::ports::{Control, ControlSender, Publication, Publisher, Wake};

use crate::journal::{Journal, JournalWriter};
use crate::log_text::{printable, PBR_ID_CHARS};
use crate::logging::RateLimitedLog;
use crate::node_config::NodeConfig;
use crate::status::{NodeStatus, RockStatus, StatusBuilder};
use rockwatch_core::catalogue::Catalogue;
use rockwatch_core::engine::{
    fallen_blocks, journaled_history, AccelPacket, Alert, AlertLevel, Engine, HistoryEntry,
    JournalRecord, MalformedStation, Output, OutputSink, PbrId, PbrSpec, PbrSummary, ResetEvent,
    ShardedEngine, Source, SourceTally, StationHealth, StationId, Verdict,
};

/// Longest time a live packet waits in the engine's reorder window for missing data.
pub const HELD_PACKET_TIMEOUT: Duration = Duration::from_secs(1);

/// Fault injection for the crash-safety tests: with this variable set to N, the process
/// aborts right after the N-th alert has been journaled (and synced), before it is handed to
/// any publisher — the worst moment for a crash.
pub const FAULT_ABORT_AFTER_JOURNAL_ENV: &str = "ROCKWATCH_FAULT_ABORT_AFTER_JOURNAL";

/// Fault injection for tests: the event loop stalls this many seconds when it takes a
/// reload request (a stuck loop, as the systemd watchdog must notice).
pub const FAULT_STALL_ON_RELOAD_ENV: &str = "ROCKWATCH_FAULT_STALL_ON_RELOAD_S";

/// A configuration read again for a reload (SIGHUP): the engine's settings, the stations and
/// the catalogue's blocks (with a partition: the node's own stations and blocks, and the ids of
/// the blocks other partitions own, as [`NodeOptions::load_partitioned_blocks`] gives them).
#[derive(Debug, Clone)]
pub struct Reloaded {
    pub engine: rockwatch_core::engine::EngineConfig,
    pub stations: Vec<rockwatch_core::engine::StationConfig>,
    pub blocks: Vec<PbrSpec>,
    pub foreign_blocks: HashSet<String>,
}

/// What a reload ([`NodeRuntime::reload`]) did.
#[derive(Debug, Clone)]
pub struct ReloadOutcome {
    /// The blocks kept, added, replaced and dropped.
    pub blocks: rockwatch_core::engine::ReloadReport,
    /// The settings whose running value changed (engine and stations), old → new.
    pub changes: Vec<crate::node_config::SettingChange>,
}

/// Most engine shards (worker threads) a runtime starts.
pub const MAX_SHARDS: usize = 256;

/// What an operator reset of a block ([`NodeRuntime::operator_reset`]) did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResetOutcome {
    /// The block had overturned: the reset was journaled (and synced), then applied; the block
    /// stands again at rest, its episode closed, and a new episode can raise alerts.
    Reset,
    /// The block stands (it never overturned, or was reset already): nothing was journaled or
    /// changed. A block that is moving is not disturbed.
    NotOverturned,
    /// No block of the node's catalogue has this id: nothing was done.
    UnknownPbr,
}

impl ResetOutcome {
    /// Whether the request succeeded: the block is known and now stands (reset or already).
    #[must_use]
    pub fn success(self) -> bool {
        self != ResetOutcome::UnknownPbr
    }

    /// One line for people about block `pbr_id` (control characters escaped, length bounded).
    #[must_use]
    pub fn message(self, pbr_id: &str) -> String {
        let id = printable(pbr_id, PBR_ID_CHARS);
        match self {
            ResetOutcome::Reset => format!(
                "block {id} reset: it stands again at rest, and a new episode can raise alerts"
            ),
            ResetOutcome::NotOverturned => {
                format!("block {id} has not overturned: nothing to reset")
            }
            ResetOutcome::UnknownPbr => {
                format!("unknown block {id:?}: no such id in the node's catalogue")
            }
        }
    }
}

/// The blocks fallen according to the journal ([`fallen_blocks`]), each with the station and
/// episode of its last `overturned` alert.
fn fallen_with_their_fall(records: &[JournalRecord]) -> HashMap<PbrId, (StationId, u32)> {
    let fallen = fallen_blocks(records);
    let mut falls = HashMap::new();
    for record in records {
        if let JournalRecord::Alert(a) = record {
            if a.level == AlertLevel::Overturned && fallen.contains(&a.pbr_id) {
                falls.insert(a.pbr_id.clone(), (a.station.clone(), a.episode));
            }
        }
    }
    falls
}

/// Where the runtime's settings come from: the configuration file, overridden by flags.
#[derive(Debug, Clone)]
pub struct NodeOptions {
    pub config: NodeConfig,
    pub catalogue: Option<PathBuf>,
    pub state_dir: Option<PathBuf>,
    /// Engine shards (default 1; 0: one per core). One shard runs the engine inline on the
    /// node's event loop thread: a packet is processed, journaled and published without any
    /// thread hand-off (lowest latency). More shards spread stations over worker threads for
    /// throughput, at the cost of two hand-offs per packet (event loop → worker → event loop).
    pub shards: usize,
    /// How the engine's notices are reported (default: rate-limited, as the live node).
    pub notices: NoticeLog,
    /// Live input (default true): a packet whose last sample is stamped more than
    /// `engine.plausibility.max_ahead_s` ahead of the node's UTC clock at its arrival is
    /// rejected and counted ([`NodeStats::future_packets`]). Off for offline runs (monitor),
    /// whose data times are not related to the wall clock.
    pub reject_future: bool,
}

/// How the runtime reports the engine's notices (a station's data irregularities) on stderr.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NoticeLog {
    /// The live node: at most one line per (station, kind) every 10 s, with the count of the
    /// lines suppressed since; every alert is logged too (target `rockwatch::alert`).
    #[default]
    RateLimited,
    /// An offline run: every notice is counted per (station, kind)
    /// ([`Stopped::notice_counts`]), and the first `lines` of each (station, kind) are logged;
    /// alerts are not logged (the run prints them).
    Counted { lines: u64 },
}

impl Default for NodeOptions {
    fn default() -> Self {
        NodeOptions {
            config: NodeConfig::default(),
            catalogue: None,
            state_dir: None,
            shards: 1,
            notices: NoticeLog::default(),
            reject_future: true,
        }
    }
}

impl NodeOptions {
    /// The state directory in force: the flag's, else the configuration's (None: none).
    #[must_use]
    pub fn state_dir_path(&self) -> Option<PathBuf> {
        self.state_dir.clone().or(self.config.state_dir.clone())
    }

    /// The catalogue in force: the flag's, else the configuration's.
    pub fn catalogue_path(&self) -> anyhow::Result<PathBuf> {
        self.catalogue
            .clone()
            .or(self.config.catalogue.clone())
            .context("no catalogue: give --catalogue FILE or a --config that names one")
    }

    /// Loads the catalogue as the engine's blocks (with their ensemble members): those of the
    /// node's partition's stations (`partition` of the configuration; all without one).
    pub fn load_blocks(&self) -> anyhow::Result<Vec<PbrSpec>> {
        Ok(self.load_partitioned_blocks()?.0)
    }

    /// As [`NodeOptions::load_blocks`], with the ids of the catalogue's blocks that other
    /// partitions own (empty without a partition). Logs the partition's share.
    pub fn load_partitioned_blocks(&self) -> anyhow::Result<(Vec<PbrSpec>, HashSet<String>)> {
        let (_, owned, foreign) = self.load_catalogue()?;
        Ok((owned, foreign))
    }

    /// As [`NodeOptions::load_partitioned_blocks`], with the catalogue itself (its entries
    /// as written: positions, meshes).
    pub fn load_catalogue(&self) -> anyhow::Result<(Catalogue, Vec<PbrSpec>, HashSet<String>)> {
        let path = self.catalogue_path()?;
        let catalogue = Catalogue::load(&path)?;
        for pbr in catalogue.pbrs() {
            if let Some(cap) = pbr.mesh().and_then(|m| m.cap.as_ref()) {
                tracing::warn!(
                    "{}: pbr {}: {}: open scan closed by its lowest boundary loop ({} vertices, \
                     cap {:.4} m²): cap = true",
                    path.display(),
                    pbr.id(),
                    pbr.mesh()
                        .map_or_else(String::new, |m| m.path.display().to_string()),
                    cap.loop_vertices,
                    cap.area_m2
                );
            }
        }
        let specs = catalogue
            .pbrs()
            .iter()
            .map(PbrSpec::from_catalogue)
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        let Some((partition, map)) = self
            .config
            .partitioning()
            .map_err(|e| anyhow::anyhow!("configuration: {e}"))?
        else {
            return Ok((catalogue, specs, HashSet::new()));
        };
        let all = specs.len();
        let stations: HashSet<&str> = specs.iter().map(|s| s.station.as_str()).collect();
        let owned_stations = stations.iter().filter(|s| map.owns(partition, s)).count();
        let total_stations = stations.len();
        let (owned, foreign): (Vec<PbrSpec>, Vec<PbrSpec>) = specs
            .into_iter()
            .partition(|s| map.owns(partition, s.station.as_str()));
        tracing::info!(
            "partition {partition}: {owned_stations} of the catalogue's {total_stations} stations, {} of its {all} blocks",
            owned.len()
        );
        Ok((
            catalogue,
            owned,
            foreign.into_iter().map(|s| s.id.to_string()).collect(),
        ))
    }

    /// Opens the state directory in force (the flag's, else the configuration's), if any,
    /// returning the journal's writer and its records; repairs are reported on stderr. A
    /// directory whose file system is full (no space or no inode to open the journal) does
    /// not stop the node: its records are read, and the writer starts degraded
    /// ([`JournalWriter::degraded`]: alerts published flagged `journal pending`, kept in
    /// memory, written once the directory takes them), said on stderr.
    pub fn open_state(&self) -> anyhow::Result<Option<(JournalWriter, Vec<JournalRecord>)>> {
        let Some(dir) = self.state_dir_path() else {
            return Ok(None);
        };
        let (writer, records, report) = match Journal::open(&dir) {
            Ok((journal, records, report)) => (JournalWriter::new(journal), records, report),
            Err(e) if e.is_storage_full() => {
                let (records, report) = crate::journal::read_journal(&dir)?;
                tracing::error!(
                    "{e}: the state directory's file system is full: starting degraded — alerts \
                     are published (flagged journal pending) and kept in memory until it takes \
                     them; retried every second"
                );
                (JournalWriter::degraded(&dir, &e)?, records, report)
            }
            Err(e) => return Err(e.into()),
        };
        for line in report.warnings(&dir) {
            tracing::warn!("{line}");
        }
        Ok(Some((writer, records)))
    }
}

/// Counts of what the runtime did (for logs and tests).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NodeStats {
    pub packets: u64,
    pub alerts: u64,
    pub states: u64,
    pub intensities: u64,
    pub notices: u64,
    /// Failed writes to the state directory (each retry counts).
    pub journal_failures: u64,
    /// Alerts published before they could be journaled (flagged `journal_pending`).
    pub journal_pending_alerts: u64,
    /// Records (alerts, episode ends) waiting for the state directory now.
    pub journal_backlog: u64,
    /// Records lost because the backlog was full ([`crate::journal::MAX_BACKLOG`]).
    pub journal_dropped: u64,
    /// Packets rejected for a time stamp too far ahead of their arrival
    /// ([`NodeOptions::reject_future`]); not handed to the engine.
    pub future_packets: u64,
    /// Packets refused at their transport's edge for a station id that is not
    /// `NET.STA.LOC` ([`NodeRuntime::refuse_malformed`]); not handed to the engine.
    pub malformed_station_packets: u64,
}

/// What the engine made of its input, summed over every shard (the node's closing summary).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct InputTotals {
    /// Packets the engine examined.
    pub packets: u64,
    /// Packets rejected by validation: empty, mismatched component lengths, non-finite
    /// samples, sample rate or start time out of range, too many samples.
    pub rejected_packets: u64,
    /// Packets whose station id is not `NET.STA.LOC`, refused at their transport's edge
    /// ([`NodeStats::malformed_station_packets`]; not counted in `packets`).
    pub malformed_station_packets: u64,
    /// Packets from stations neither configured nor in the catalogue.
    pub unknown_station_packets: u64,
    /// Packets whose every sample had been processed already.
    pub duplicate_packets: u64,
    /// Packets that arrived after later data had been processed.
    pub late_packets: u64,
    /// Packets rejected because a sample is beyond the physical bound
    /// (`engine.plausibility.max_abs_accel_g`); counted in `rejected_packets` too.
    pub implausible_packets: u64,
    /// Packets stamped too far ahead of their arrival, rejected by the runtime before the
    /// engine ([`NodeStats::future_packets`]; not counted in `packets`).
    pub future_packets: u64,
    /// Forward jumps of a station's time grid undone by the packets that followed them.
    pub grid_rewinds: u64,
}

impl InputTotals {
    fn add(&mut self, engine: &Engine) {
        let c = engine.counters();
        self.packets += c.packets;
        self.unknown_station_packets += c.unknown_station_packets;
        for (_, station, stream) in engine.station_counters() {
            self.rejected_packets += station.rejected_packets;
            self.implausible_packets += station.implausible_packets;
            self.grid_rewinds += stream.grid_rewinds;
            self.duplicate_packets += stream.duplicate_packets;
            self.late_packets += stream.late_packets;
        }
    }
}

/// The status of each block of `specs` (id order): as in `known` if it was there (a reload
/// keeps the blocks it keeps), else standing (or fallen, if in `overturned`).
fn rock_statuses(
    specs: &[PbrSpec],
    overturned: &HashMap<PbrId, (StationId, u32)>,
    mut known: BTreeMap<String, RockStatus>,
) -> BTreeMap<String, RockStatus> {
    specs
        .iter()
        .map(|spec| {
            let station = spec.station.to_string();
            let rock = match known.remove(spec.id.as_str()) {
                Some(rock) if rock.station == station => rock,
                _ => RockStatus::new(
                    spec.id.to_string(),
                    station,
                    overturned.contains_key(&spec.id),
                )
                .at(spec.place.lat_deg, spec.place.lon_deg),
            };
            (spec.id.to_string(), rock)
        })
        .collect()
}

/// What the transports say about themselves, for [`NodeRuntime::status`].
#[derive(Debug, Clone, Copy, Default)]
pub struct TransportStatus {
    pub ros2_up: bool,
    pub ros2_rebuilds: u64,
    pub iceoryx2: bool,
}

/// The engine of a [`NodeRuntime`].
enum EngineMode {
    /// One shard: the engine runs on the caller's thread.
    Inline(Box<Engine>),
    /// Stations spread over worker threads.
    Sharded(ShardedEngine),
}

/// The running node minus its transports.
pub struct NodeRuntime {
    /// Always `Some` until `shutdown`.
    engine: Option<EngineMode>,
    /// Journal, stats, logs: where outputs go.
    emit: Emitter,
    pbr_ids: Vec<String>,
    /// Blocks of the catalogue that other partitions' nodes own (scale-out).
    foreign_pbr_ids: HashSet<String>,
    last_flush: Instant,
    /// [`NodeOptions::reject_future`]: the tolerance (ns), when on.
    max_ahead_ns: Option<i64>,
    /// The journal's alert history (until taken by [`NodeRuntime::take_journaled_history`]).
    journaled: Vec<HistoryEntry>,
    /// Judges the stations report after report.
    status: StatusBuilder,
    /// Time spent in the inline engine, and seconds of data it processed, since the last
    /// status (the real-time factor).
    busy_ns: u64,
    data_s: f64,
    /// What became of each sender's packets (the engine's, when sharded).
    tally: Arc<SourceTally>,
    /// The stations as configured now (at start, then by each reload), for the reload's
    /// account of what it changed.
    stations: Vec<rockwatch_core::engine::StationConfig>,
    /// `engine.alerts.imminent_theta_ratio` as configured (the sharded engine's; the inline
    /// engine's own value is read from it, ROS 2 parameter changes included).
    imminent_theta_ratio: f64,
}

impl NodeRuntime {
    /// Loads the catalogue, restores the state directory, and starts the engine (inline for
    /// one shard, else its workers).
    pub fn start(options: &NodeOptions) -> anyhow::Result<NodeRuntime> {
        Self::start_with_wake(options, Arc::new(|| {}))
    }

    /// As [`NodeRuntime::start`]; with several shards, each worker calls `wake` after queueing
    /// outputs (so an event loop can sleep until [`NodeRuntime::poll`] has work).
    pub fn start_with_wake(options: &NodeOptions, wake: Wake) -> anyhow::Result<NodeRuntime> {
        let (owned, foreign) = options.load_partitioned_blocks()?;
        let mut runtime = Self::start_with_blocks(options, owned, wake)?;
        runtime.foreign_pbr_ids = foreign;
        Ok(runtime)
    }

    /// As [`NodeRuntime::start_with_wake`], with the catalogue's blocks already loaded
    /// ([`NodeOptions::load_blocks`]).
    pub fn start_with_blocks(
        options: &NodeOptions,
        specs: Vec<PbrSpec>,
        wake: Wake,
    ) -> anyhow::Result<NodeRuntime> {
        let (journal, records) = match options.open_state()? {
            Some((journal, records)) => (Some(journal), records),
            None => (None, Vec::new()),
        };
        let overturned = fallen_with_their_fall(&records);
        let rocks = rock_statuses(&specs, &overturned, BTreeMap::new());
        if options.shards > MAX_SHARDS {
            anyhow::bail!(
                "--shards must be 0 (one per core) to {MAX_SHARDS}, got {}",
                options.shards
            );
        }
        let journaled = journaled_history(&records, crate::journal::HISTORY_ALERTS);
        let shards = if options.shards == 0 {
            std::thread::available_parallelism().map_or(1, usize::from)
        } else {
            options.shards
        };
        let config = &options.config;
        // A partitioned node configures only its own stations (the others never reach it).
        let stations = config
            .owned_stations()
            .map_err(|e| anyhow::anyhow!("configuration: {e}"))?;
        let (engine, tally) = if shards == 1 {
            let mut engine = Engine::new(config.engine, stations.clone(), &specs)?;
            engine.restore(&records);
            let tally = Arc::new(SourceTally::default());
            engine.set_source_tally(Arc::clone(&tally));
            (EngineMode::Inline(Box::new(engine)), tally)
        } else {
            let engine = ShardedEngine::start_with_wake(
                config.engine,
                &stations,
                &specs,
                &records,
                shards,
                wake,
            )?;
            let tally = engine.source_tally();
            (EngineMode::Sharded(engine), tally)
        };
        let mut runtime = NodeRuntime {
            engine: Some(engine),
            emit: Emitter {
                reports: None,
                marker_errors: 0,
                journal,
                epoch: Instant::now(),
                epoch_utc_ns: crate::journal::utc_now_ns(),
                log: RateLimitedLog::new(),
                notice_log: options.notices,
                notice_counts: BTreeMap::new(),
                abort_after_alert: std::env::var(FAULT_ABORT_AFTER_JOURNAL_ENV)
                    .ok()
                    .and_then(|v| v.parse().ok()),
                stats: NodeStats::default(),
                deferred: Vec::new(),
                overturned,
                resets: Vec::new(),
                last_alerts: HashMap::new(),
                health_reports: BTreeMap::new(),
                stale_after_s: config.engine.stale_after_s,
                rocks,
            },
            status: StatusBuilder::default(),
            busy_ns: 0,
            data_s: 0.0,
            tally,
            pbr_ids: specs.iter().map(|s| s.id.to_string()).collect(),
            stations,
            imminent_theta_ratio: config.engine.alerts.imminent_theta_ratio,
            foreign_pbr_ids: HashSet::new(),
            last_flush: Instant::now(),
            max_ahead_ns: options
                .reject_future
                .then_some((config.engine.plausibility.max_ahead_s * 1e9) as i64),
            journaled,
        };
        // Event reports go with a state directory; one that cannot take them (e.g. a full
        // disk) leaves the node without reports, never without monitoring.
        if let Some(dir) = options.state_dir_path() {
            let stations = runtime.traced_stations();
            match crate::reports::ReportFeed::start(&dir, &specs, &stations, &config.engine.alerts)
            {
                Ok(feed) => runtime.emit.reports = Some(feed),
                Err(e) => tracing::error!(
                    target: "rockwatch::reports",
                    "event reports disabled: {e}"
                ),
            }
        }
        Ok(runtime)
    }

    /// Feeds the traces (each station's recent data, each rock's episode) for the web
    /// dashboard: without a state directory they are not kept otherwise.
    pub fn enable_traces(&mut self) {
        if self.emit.reports.is_none() {
            let stations = self.traced_stations();
            self.emit.reports = Some(crate::reports::ReportFeed::traces_only(&stations));
        }
    }

    /// A copy of the traces for the web thread (None: not kept).
    pub fn traces_snapshot(
        &mut self,
        wanted: &crate::traces::WantedStations,
    ) -> Option<crate::traces::TracesSnapshot> {
        self.emit
            .reports
            .as_mut()
            .map(|r| r.traces.snapshot(wanted))
    }

    /// The event report writer's counts (None: no state directory, or it refused reports).
    #[must_use]
    pub fn report_counts(&self) -> Option<Arc<crate::reports::ReportCounts>> {
        self.emit
            .reports
            .as_ref()
            .map(crate::reports::ReportFeed::counts)
    }

    /// The node's stations now with their gains ((m/s²)/count): those of `[[station]]` (this
    /// node's partition) and those its rocks name without a `[[station]]` entry.
    #[must_use]
    pub fn traced_stations(&self) -> Vec<(String, Option<f64>)> {
        let mut stations: Vec<(String, Option<f64>)> = self
            .stations
            .iter()
            .map(|s| (s.id.as_str().to_string(), s.gain_mps2_per_count))
            .collect();
        for rock in self.emit.rocks.values() {
            if !stations.iter().any(|(id, _)| *id == rock.station) {
                stations.push((rock.station.clone(), None));
            }
        }
        stations
    }

    /// The journal's alert history at start ([`journaled_history`]: the last
    /// [`HISTORY_ALERTS`](crate::journal::HISTORY_ALERTS) alerts, each with whether it was published before, and the
    /// operator resets among them), in order; empty after the first call.
    pub fn take_journaled_history(&mut self) -> Vec<HistoryEntry> {
        std::mem::take(&mut self.journaled)
    }

    /// The operator resets journaled and applied since the last call, to publish with the
    /// alerts (`Publication::Reset`): a block's history ends in the truth.
    pub fn take_resets(&mut self) -> Vec<ResetEvent> {
        std::mem::take(&mut self.emit.resets)
    }

    /// Journals (unsynced) that `alert` has been handed to the publishers
    /// ([`Emitter::mark_published`]).
    pub fn mark_published(&mut self, alert: &Alert) {
        self.emit.mark_published(alert);
    }

    /// Engine shards: 1 when the engine runs inline.
    #[must_use]
    pub fn shards(&self) -> usize {
        match &self.engine {
            Some(EngineMode::Sharded(e)) => e.shards(),
            _ => 1,
        }
    }

    /// Monotonic wall time since start (ns): arrival and emission stamps.
    #[must_use]
    pub fn now_ns(&self) -> i64 {
        self.emit.now_ns()
    }

    /// Counts of what the runtime did so far.
    #[must_use]
    pub fn stats(&self) -> NodeStats {
        self.emit.stats
    }

    /// The instant [`NodeRuntime::now_ns`] counts from (to compare stamps with other clocks).
    #[must_use]
    pub fn epoch(&self) -> Instant {
        self.emit.epoch
    }

    /// Ids of the catalogued blocks.
    #[must_use]
    pub fn pbr_ids(&self) -> &[String] {
        &self.pbr_ids
    }

    /// Hands a packet to the engine, stamped with its arrival time. Inline, the packet is
    /// processed now: each alert is journaled (and synced) and published the moment the engine
    /// raises it, mid-packet, and the packet's states and intensities are published after it,
    /// all before this returns; sharded, it is queued for its station's worker (waiting if
    /// that queue is full) and the outputs come through [`NodeRuntime::poll`]. A state
    /// directory that fails does not stop it: the alert is published flagged
    /// `journal_pending` ([`Emitter::sink`]).
    pub fn submit(&mut self, packet: AccelPacket, publish: &mut impl FnMut(Publication)) {
        let arrival_ns = self.now_ns();
        self.submit_arrived(packet, arrival_ns, None, publish)
    }

    /// As [`NodeRuntime::submit`], for a packet taken from its transport at `arrival_ns`
    /// ([`NodeRuntime::now_ns`] then) and queued since, sent by `source` (what became of it is
    /// counted in [`NodeRuntime::source_tally`] once processed).
    pub fn submit_arrived(
        &mut self,
        packet: AccelPacket,
        arrival: i64,
        source: Option<Source>,
        publish: &mut impl FnMut(Publication),
    ) {
        if self.stamped_ahead(&packet, arrival) {
            if let Some(source) = source {
                self.tally.count(source, Verdict::Refused);
            }
            return;
        }
        self.emit.stats.packets += 1;
        if let Some(reports) = &mut self.emit.reports {
            reports.traces.push_packet(&packet);
        }
        match &mut self.engine {
            Some(EngineMode::Inline(engine)) => {
                // Each alert is journaled and published the moment the engine raises it; the
                // rest of the packet is processed after.
                let started = Instant::now();
                let rate = packet.sample_rate_hz;
                if rate.is_finite() && rate > 0.0 {
                    self.data_s += packet.len() as f64 / rate;
                }
                let mut sink = self.emit.sink(publish);
                engine.process_from(packet, source, arrival, &mut sink);
                sink.finish();
                self.busy_ns += started.elapsed().as_nanos() as u64;
            }
            Some(EngineMode::Sharded(engine)) => engine.submit_from(packet, arrival, source),
            None => {}
        }
    }

    /// What became of each sender's packets (processed and refused per [`Source`]): the
    /// transports report it to their senders.
    #[must_use]
    pub fn source_tally(&self) -> Arc<SourceTally> {
        Arc::clone(&self.tally)
    }

    /// Whether the engine monitors station `station` (configured, or bound to one of this
    /// node's blocks): a packet of any other station is taken but ignored.
    #[must_use]
    pub fn monitors(&self, station: &str) -> bool {
        match &self.engine {
            Some(EngineMode::Inline(engine)) => engine.monitors(station),
            Some(EngineMode::Sharded(engine)) => engine.monitors(station),
            None => false,
        }
    }

    /// Whether `packet`, arrived at `arrival` ([`NodeRuntime::now_ns`]), ends more than the
    /// tolerance ahead of the UTC clock then ([`NodeOptions::reject_future`]); such a packet
    /// is counted and logged (rate-limited), never handed to the engine, so it cannot move
    /// its station's time grid.
    fn stamped_ahead(&mut self, packet: &AccelPacket, arrival: i64) -> bool {
        let Some(max_ahead_ns) = self.max_ahead_ns else {
            return false;
        };
        let rate = packet.sample_rate_hz;
        let span_ns = if rate.is_finite() && rate > 0.0 {
            packet.len() as f64 * 1e9 / rate
        } else {
            0.0 // an invalid rate is the engine's to reject and report
        };
        let end_ns = packet.start_time_ns as f64 + span_ns;
        let ahead_s = (end_ns - (self.emit.epoch_utc_ns + arrival) as f64) * 1e-9;
        if ahead_s * 1e9 <= max_ahead_ns as f64 {
            return false;
        }
        self.emit.stats.future_packets += 1;
        self.emit.log.log(
            packet.station.as_str(),
            "future",
            &format!(
                "packet {} rejected: its data end {ahead_s:.3} s ahead of the node's clock \
                 (engine.plausibility.max_ahead_s = {} s; {} such packets in all)",
                packet.sequence,
                max_ahead_ns as f64 * 1e-9,
                self.emit.stats.future_packets
            ),
        );
        true
    }

    /// Refuses a packet whose station id, as a transport received it, is not `NET.STA.LOC`
    /// (`rockwatch_core::engine::station_at_edge`, the one check of every transport's edge):
    /// counted ([`NodeStats::malformed_station_packets`]), said as the engine's notices are
    /// (kind `rejected`, under the id as received: [`MalformedStation::notice`]), and
    /// counted as refused for its `source`, whichever transport it came by.
    pub fn refuse_malformed(&mut self, refused: &MalformedStation, source: Option<Source>) {
        self.emit.stats.malformed_station_packets += 1;
        if let Some(source) = source {
            self.tally.count(source, Verdict::Refused);
        }
        self.emit.notice(&refused.notice());
    }

    /// Applies a settings change, effective for the next packet.
    pub fn apply(&mut self, control: Control) {
        match (control, &mut self.engine) {
            (Control::Alerts(a), Some(EngineMode::Inline(e))) => e.set_alert_config(a),
            (Control::Alerts(a), Some(EngineMode::Sharded(e))) => e.set_alert_config(a),
            (Control::StateIntervalS(s), Some(EngineMode::Inline(e))) => {
                e.set_state_interval_s(s);
            }
            (Control::StateIntervalS(s), Some(EngineMode::Sharded(e))) => {
                e.set_state_interval_s(s);
            }
            (_, None) => {}
        }
    }

    /// Applies a reloaded configuration between packets ([`Engine::reload`]: blocks in both
    /// keep their state, new ones start at rest, removed ones are dropped; thresholds and
    /// stations as the files now say). On error (an invalid configuration, or several engine
    /// shards) nothing changes.
    pub fn reload(&mut self, reloaded: Reloaded) -> anyhow::Result<ReloadOutcome> {
        let Reloaded {
            engine: config,
            stations,
            blocks,
            foreign_blocks,
        } = reloaded;
        let (blocks_report, changes) = match &mut self.engine {
            Some(EngineMode::Inline(engine)) => {
                // The running values (ROS 2 parameter changes included) against the new ones.
                let changes = crate::node_config::setting_changes(
                    (engine.config(), &self.stations),
                    (&config, &stations),
                );
                (engine.reload(config, stations.clone(), &blocks)?, changes)
            }
            Some(EngineMode::Sharded(_)) => anyhow::bail!(
                "a reload needs one engine shard (--shards 1); restart the node to apply the new configuration"
            ),
            None => anyhow::bail!("the engine has stopped"),
        };
        self.stations = stations;
        self.imminent_theta_ratio = config.alerts.imminent_theta_ratio;
        let known = std::mem::take(&mut self.emit.rocks);
        self.emit.rocks = rock_statuses(&blocks, &self.emit.overturned, known);
        let traced = self.traced_stations();
        if let Some(reports) = &mut self.emit.reports {
            reports.reconfigure(&blocks, &traced, &config.alerts);
        }
        self.pbr_ids = blocks.into_iter().map(|s| s.id.to_string()).collect();
        self.foreign_pbr_ids = foreign_blocks;
        self.emit.stale_after_s = config.stale_after_s;
        if self.max_ahead_ns.is_some() {
            self.max_ahead_ns = Some((config.plausibility.max_ahead_s * 1e9) as i64);
        }
        Ok(ReloadOutcome {
            blocks: blocks_report,
            changes,
        })
    }

    /// Whether block `pbr_id` is in the catalogue but owned by another partition's node (which
    /// answers for it: this node stays silent on its resets).
    #[must_use]
    pub fn is_foreign(&self, pbr_id: &str) -> bool {
        self.foreign_pbr_ids.contains(pbr_id)
    }

    /// Whether block `pbr_id` has overturned and not been reset since (None: no such block).
    /// With several shards, an overturn counts once its alert has come back from the worker
    /// (through [`NodeRuntime::poll`]).
    #[must_use]
    pub fn overturned(&self, pbr_id: &str) -> Option<bool> {
        self.pbr_ids
            .iter()
            .any(|id| id == pbr_id)
            .then(|| self.emit.overturned.contains_key(pbr_id))
    }

    /// An operator's request to reset block `pbr_id`: an overturned block is reset
    /// ([`NodeRuntime::reset_pbr`]: journaled and synced, then applied, so a restart keeps
    /// it); a standing or moving block is left alone, an unknown id refused. Logs one line
    /// per reset naming the block (refusals rate-limited). An error means the state
    /// directory failed: nothing was applied.
    pub fn operator_reset(&mut self, pbr_id: &str) -> anyhow::Result<ResetOutcome> {
        let outcome = match self.overturned(pbr_id) {
            None => ResetOutcome::UnknownPbr,
            Some(false) => ResetOutcome::NotOverturned,
            Some(true) => {
                if let Err(e) = self.reset_pbr(pbr_id) {
                    self.emit
                        .log
                        .log(pbr_id, "reset_failed", &format!("not reset: {e:#}"));
                    return Err(e);
                }
                ResetOutcome::Reset
            }
        };
        match outcome {
            ResetOutcome::Reset => tracing::info!(
                "{}: reset by the operator: stands again at rest",
                printable(pbr_id, PBR_ID_CHARS)
            ),
            _ => self
                .emit
                .log
                .log(pbr_id, "reset_refused", &outcome.message(pbr_id)),
        }
        Ok(outcome)
    }

    /// Operator reset of a fallen block, unconditionally: journaled (and synced), then applied
    /// to the engine (see [`NodeRuntime::operator_reset`] for the checked request). An error
    /// means the state directory failed and nothing was applied.
    pub fn reset_pbr(&mut self, pbr_id: &str) -> anyhow::Result<()> {
        let id = PbrId::parse(pbr_id).with_context(|| format!("cannot reset {pbr_id:?}"))?;
        let time_ns = self.emit.epoch_utc_ns + self.emit.now_ns();
        if let Some(j) = &mut self.emit.journal {
            j.append_now(&JournalRecord::Reset {
                pbr_id: id.clone(),
                time_ns: Some(time_ns),
            })?;
        }
        if let Some((station, episode)) = self.emit.overturned.remove(pbr_id) {
            self.emit.resets.push(ResetEvent {
                pbr_id: id,
                station,
                episode,
                time_ns,
            });
        }
        if let Some(rock) = self.emit.rocks.get_mut(pbr_id) {
            *rock = RockStatus::new(rock.pbr_id.clone(), rock.station.clone(), false)
                .at(rock.lat_deg, rock.lon_deg);
        }
        match &mut self.engine {
            Some(EngineMode::Inline(e)) => {
                e.reset_pbr(pbr_id);
            }
            Some(EngineMode::Sharded(e)) => e.reset_pbr(pbr_id),
            None => {}
        }
        Ok(())
    }

    /// Writes the records waiting for a failing state directory now (also done every
    /// [`HELD_PACKET_TIMEOUT`] by [`NodeRuntime::flush_if_due`] and before every new record).
    pub fn retry_journal(&mut self) {
        self.emit.retry_journal();
    }

    /// Releases the packets held in the engine's reorder window if `HELD_PACKET_TIMEOUT` has
    /// passed since the last release. The engine's window counts packets (so replays are
    /// deterministic); live, a packet held for missing data must not wait forever if its
    /// station falls silent. Call it regularly (the event loop does, at least every 50 ms).
    pub fn flush_if_due(&mut self, publish: &mut impl FnMut(Publication)) {
        if self.last_flush.elapsed() < HELD_PACKET_TIMEOUT {
            return;
        }
        self.last_flush = Instant::now();
        self.emit.retry_journal();
        let now = self.now_ns();
        match &mut self.engine {
            Some(EngineMode::Inline(engine)) => {
                let mut sink = self.emit.sink(publish);
                engine.flush(now, &mut sink);
                sink.finish();
            }
            Some(EngineMode::Sharded(engine)) => engine.flush(now),
            None => {}
        }
    }

    /// Judges every station's health now ([`Engine::check_health`]): a station silent for
    /// `engine.stale_after_s` is reported (a log line, its blocks' states flagged
    /// `not_monitored`, published), and its recovery likewise. The event loop calls it on
    /// every tick; sharded, the workers answer through [`NodeRuntime::poll`].
    pub fn check_health(&mut self, publish: &mut impl FnMut(Publication)) {
        let now = self.now_ns();
        match &mut self.engine {
            Some(EngineMode::Inline(engine)) => {
                let mut sink = self.emit.sink(publish);
                engine.check_health(now, &mut sink);
                sink.finish();
            }
            Some(EngineMode::Sharded(engine)) => engine.check_health(now),
            None => {}
        }
    }

    /// The node's status now (stations, journal, engine margin; the transports' part from
    /// `transports`). The real-time factor covers the time since the previous call (inline
    /// engine only). Sharded, the stations are as the workers last reported them (asked
    /// again by this call).
    pub fn status(&mut self, transports: TransportStatus) -> NodeStatus {
        let now = self.now_ns();
        let healths: Vec<StationHealth> = match &self.engine {
            Some(EngineMode::Inline(engine)) => engine.health(),
            Some(EngineMode::Sharded(engine)) => {
                engine.report_health();
                self.emit.health_reports.values().cloned().collect()
            }
            None => Vec::new(),
        };
        let epoch_utc_ns = self.emit.epoch_utc_ns;
        let stations = healths
            .into_iter()
            .map(|h| {
                let last_alert = self.emit.last_alerts.get(h.station.as_str()).copied();
                let place = self
                    .stations
                    .iter()
                    .find(|s| s.id == h.station)
                    .map(|s| (s.lat, s.lon));
                let mut station = self.status.station(h, now, epoch_utc_ns, last_alert);
                if let Some((lat, lon)) = place {
                    (station.lat_deg, station.lon_deg) = (lat, lon);
                }
                station
            })
            .collect();
        let realtime_factor = (self.data_s > 0.0 && self.busy_ns > 0)
            .then(|| self.data_s / (self.busy_ns as f64 * 1e-9));
        (self.busy_ns, self.data_s) = (0, 0.0);
        let stats = self.emit.stats;
        let reports = self.emit.reports.as_ref().map(|r| r.counts());
        let reports = reports.as_deref();
        NodeStatus {
            stamp_ns: epoch_utc_ns + now,
            stations,
            rocks: self.emit.rocks.values().cloned().collect(),
            journal_configured: self.emit.journal.is_some(),
            journal_failures: stats.journal_failures,
            journal_backlog: stats.journal_backlog,
            journal_dropped: stats.journal_dropped,
            reports_written: reports.map_or(0, |c| c.written.load(Ordering::Relaxed)),
            reports_dropped: reports.map_or(0, |c| c.dropped.load(Ordering::Relaxed)),
            reports_failed: reports.map_or(0, |c| c.failed.load(Ordering::Relaxed)),
            ros2_up: transports.ros2_up,
            ros2_rebuilds: transports.ros2_rebuilds,
            iceoryx2: transports.iceoryx2,
            realtime_factor,
            shards: self.shards(),
            packets: stats.packets,
            alerts: stats.alerts,
            rosout_dropped: crate::logging::rosout_dropped(),
            imminent_theta_ratio: match &self.engine {
                Some(EngineMode::Inline(engine)) => engine.config().alerts.imminent_theta_ratio,
                _ => self.imminent_theta_ratio,
            },
        }
    }

    /// Journals and publishes `outputs` (drained), as [`Emitter::sink`].
    fn handle(&mut self, outputs: &mut Vec<Output>, publish: &mut impl FnMut(Publication)) {
        let mut sink = self.emit.sink(publish);
        for output in outputs.drain(..) {
            sink.push(output);
        }
        sink.finish();
    }

    /// Publishes everything the engine workers have produced so far, without waiting (inline,
    /// outputs are published by `submit` itself and this does nothing). Alerts are journaled
    /// first (one the state directory cannot take is published flagged `journal_pending`).
    pub fn poll(&mut self, publish: &mut impl FnMut(Publication)) {
        let mut outputs: Vec<Output> = match &self.engine {
            Some(EngineMode::Sharded(e)) => e.try_outputs().collect(),
            _ => return,
        };
        self.handle(&mut outputs, publish);
    }

    /// Waits up to `timeout` for outputs of the engine workers, then publishes them (returns
    /// at once inline).
    pub fn poll_wait(&mut self, timeout: Duration, publish: &mut impl FnMut(Publication)) {
        if let Some(EngineMode::Sharded(e)) = &self.engine {
            if let Some(mut first) = e.recv_outputs_timeout(timeout) {
                self.handle(&mut first, publish);
            }
        }
        self.poll(publish);
    }

    /// Stops intake: releases held packets, lets the workers finish, publishes what remains
    /// and returns every block's summary.
    pub fn shutdown(self, publish: &mut impl FnMut(Publication)) -> Vec<PbrSummary> {
        self.stop(publish).summaries()
    }

    /// As [`NodeRuntime::shutdown`], returning the stopped engines and what the runtime did.
    pub fn stop(mut self, publish: &mut impl FnMut(Publication)) -> Stopped {
        let now = self.now_ns();
        let engines = match self.engine.take() {
            None => Vec::new(),
            Some(EngineMode::Inline(mut engine)) => {
                let mut sink = self.emit.sink(publish);
                engine.flush(now, &mut sink);
                sink.finish();
                vec![*engine]
            }
            Some(EngineMode::Sharded(engine)) => {
                engine.flush(now);
                let (engines, mut rest) = engine.shutdown();
                self.handle(&mut rest, publish);
                engines
            }
        };
        // A last attempt for what waits; what still waits is in `stats.journal_backlog`.
        self.emit.retry_journal();
        // The reports queued are written before this returns.
        let reports = self
            .emit
            .reports
            .take()
            .map(crate::reports::ReportFeed::finish);
        Stopped {
            reports,
            engines,
            stats: self.emit.stats,
            notice_counts: self.emit.notice_counts,
        }
    }
}

/// What is left of a [`NodeRuntime`] once it has stopped ([`NodeRuntime::stop`]).
#[derive(Debug)]
pub struct Stopped {
    /// The engines, one per shard, every packet processed.
    pub engines: Vec<Engine>,
    /// Counts of what the runtime did.
    pub stats: NodeStats,
    /// Notices per (station, kind), with [`NoticeLog::Counted`] (else empty).
    pub notice_counts: BTreeMap<(String, &'static str), u64>,
    /// The event report writer's counts, its queue written (None: no reports).
    pub reports: Option<Arc<crate::reports::ReportCounts>>,
}

impl Stopped {
    /// Response summaries of every block, by shard, station, then catalogue order.
    #[must_use]
    pub fn summaries(&self) -> Vec<PbrSummary> {
        self.engines.iter().flat_map(Engine::summaries).collect()
    }

    /// What the engines made of their input, summed over the shards.
    #[must_use]
    pub fn input_totals(&self) -> InputTotals {
        let mut totals = InputTotals {
            future_packets: self.stats.future_packets,
            malformed_station_packets: self.stats.malformed_station_packets,
            ..InputTotals::default()
        };
        for e in &self.engines {
            totals.add(e);
        }
        totals
    }
}
