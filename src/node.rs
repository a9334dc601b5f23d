//! The live node's transport-independent runtime (shell): the sharded engine, the state
//! directory, arrival time stamps, rate-limited logging. Transports (ROS 2, iceoryx2) are thin
//! adapters around it: they `submit` packets as they arrive and `poll` for publications.
//!
//! Ordering guarantee: an alert is appended to the journal and synced before `poll` hands it
//! to the transport, so a published alert is never lost; on restart the journal is restored
//! into the engine, so an alert is never published twice.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;

use crate::catalogue::Catalogue;
use crate::engine::{
    AccelPacket, Alert, AlertConfig, Engine, EngineHandle, JournalRecord, Output, PbrSpec,
    PbrState, PbrSummary, ShardedEngine, StationIntensity,
};
use crate::journal::Journal;
use crate::node_config::NodeConfig;

/// Longest time a live packet waits in the engine's reorder window for missing data.
pub const HELD_PACKET_TIMEOUT: Duration = Duration::from_secs(1);

/// What a transport publishes.
#[derive(Debug, Clone, PartialEq)]
pub enum Publication {
    /// An alert, already journaled; `latency_ns` = wall time now − arrival of the packet that
    /// triggered it.
    Alert {
        alert: Alert,
        latency_ns: i64,
    },
    State(PbrState),
    Intensity(StationIntensity),
}

/// A transport's output side: publishes what the runtime hands it (alerts already journaled).
pub trait Publisher {
    /// Publishes one item; an error is logged (rate-limited) and the node goes on.
    fn publish(&mut self, publication: &Publication) -> anyhow::Result<()>;
}

/// A transport's input side: a cloneable, thread-safe handle that stamps each packet with its
/// arrival time and hands it to the engine.
#[derive(Clone)]
pub struct Submitter {
    engine: EngineHandle,
    epoch: Instant,
}

impl Submitter {
    /// Hands a packet to the engine, stamped with its arrival time.
    pub fn submit(&self, packet: AccelPacket) {
        self.engine
            .submit(packet, self.epoch.elapsed().as_nanos() as i64);
    }

    /// New alert thresholds (e.g. from a ROS 2 parameter), effective for the next packet.
    pub fn set_alert_config(&self, alerts: AlertConfig) {
        self.engine.set_alert_config(alerts);
    }

    /// New state publication interval (s of data; e.g. from a ROS 2 parameter), effective
    /// for the next packet; ignored unless finite and > 0.
    pub fn set_state_interval_s(&self, state_interval_s: f64) {
        self.engine.set_state_interval_s(state_interval_s);
    }
}

/// Where the runtime's settings come from: the configuration file, overridden by flags.
#[derive(Debug, Clone, Default)]
pub struct NodeOptions {
    pub config: NodeConfig,
    pub catalogue: Option<PathBuf>,
    pub state_dir: Option<PathBuf>,
    /// Engine worker threads (0: one per core).
    pub shards: usize,
}

impl NodeOptions {
    /// The catalogue in force: the flag's, else the configuration's.
    pub fn catalogue_path(&self) -> anyhow::Result<PathBuf> {
        self.catalogue
            .clone()
            .or(self.config.catalogue.clone())
            .context("no catalogue: give --catalogue FILE or a --config that names one")
    }

    /// Loads the catalogue as the engine's blocks (with their ensemble members).
    pub fn load_blocks(&self) -> anyhow::Result<Vec<PbrSpec>> {
        let path = self.catalogue_path()?;
        Catalogue::load(&path)?
            .pbrs()
            .iter()
            .map(PbrSpec::from_catalogue)
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
    }

    /// Opens the state directory in force (the flag's, else the configuration's), if any,
    /// returning the journal and its records; repairs are reported on stderr.
    pub fn open_state(&self) -> anyhow::Result<Option<(Journal, Vec<JournalRecord>)>> {
        let Some(dir) = self.state_dir.clone().or(self.config.state_dir.clone()) else {
            return Ok(None);
        };
        let (journal, records, report) = Journal::open(&dir)?;
        if !report.corrupt_lines.is_empty() || report.truncated_tail {
            eprintln!(
                "rockwatch: warning: {}: journal repaired ({report:?})",
                dir.display()
            );
        }
        Ok(Some((journal, records)))
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
}

/// What the engine made of its input, summed over every shard (the node's closing summary).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct InputTotals {
    /// Packets the engine examined.
    pub packets: u64,
    /// Packets rejected by validation: empty, mismatched component lengths, non-finite
    /// samples, sample rate or start time out of range, too many samples.
    pub rejected_packets: u64,
    /// Packets whose station id is not `NET.STA.LOC`.
    pub malformed_station_packets: u64,
    /// Packets from stations neither configured nor in the catalogue.
    pub unknown_station_packets: u64,
    /// Packets whose every sample had been processed already.
    pub duplicate_packets: u64,
    /// Packets that arrived after later data had been processed.
    pub late_packets: u64,
}

impl InputTotals {
    fn add(&mut self, engine: &Engine) {
        let c = engine.counters();
        self.packets += c.packets;
        self.malformed_station_packets += c.malformed_station_packets;
        self.unknown_station_packets += c.unknown_station_packets;
        for (_, station, stream) in engine.station_counters() {
            self.rejected_packets += station.rejected_packets;
            self.duplicate_packets += stream.duplicate_packets;
            self.late_packets += stream.late_packets;
        }
    }
}

/// Logs at most one line per (station, kind) every `interval`, with the count suppressed.
#[derive(Debug)]
struct RateLimitedLog {
    interval: Duration,
    last: HashMap<(String, &'static str), (Instant, u64)>,
}

/// Distinct (station, kind) keys the log remembers; past this, new stations share one key,
/// so a flood of invented station ids cannot grow the map without bound.
const LOG_MAX_KEYS: usize = 4096;

/// `text` fit for one log line: control characters escaped, at most `max_chars` characters
/// (the rest replaced by a count), so a hostile station id cannot forge or flood log lines.
fn printable(text: &str, max_chars: usize) -> String {
    let mut out = String::new();
    for (n, c) in text.chars().enumerate() {
        if n == max_chars {
            out += &format!(
                "…(+{} bytes)",
                text.len() - text.char_indices().nth(n).map_or(0, |(i, _)| i)
            );
            break;
        }
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

impl RateLimitedLog {
    fn log(&mut self, station: &str, kind: &'static str, message: &str) {
        let now = Instant::now();
        let mut key = (printable(station, 48), kind);
        if self.last.len() >= LOG_MAX_KEYS && !self.last.contains_key(&key) {
            key.0 = "(other stations)".into();
        }
        let message = printable(message, 400);
        let station = key.0.clone();
        let entry = self.last.entry(key).or_insert((now - self.interval, 0));
        if now.duration_since(entry.0) >= self.interval {
            let suppressed = std::mem::take(&mut entry.1);
            let more = if suppressed > 0 {
                format!(" (+{suppressed} more since last report)")
            } else {
                String::new()
            };
            eprintln!("rockwatch: {station}: {kind}: {message}{more}");
            entry.0 = now;
        } else {
            entry.1 += 1;
        }
    }
}

/// The running node minus its transports.
pub struct NodeRuntime {
    /// Always `Some` until `shutdown`.
    engine: Option<ShardedEngine>,
    journal: Option<Journal>,
    epoch: Instant,
    log: RateLimitedLog,
    pub stats: NodeStats,
    pbr_ids: Vec<String>,
}

impl NodeRuntime {
    /// Loads the catalogue, restores the state directory, and starts the engine workers.
    pub fn start(options: &NodeOptions) -> anyhow::Result<NodeRuntime> {
        let specs = options.load_blocks()?;
        let (journal, records) = match options.open_state()? {
            Some((journal, records)) => (Some(journal), records),
            None => (None, Vec::new()),
        };
        let shards = if options.shards == 0 {
            std::thread::available_parallelism().map_or(1, usize::from)
        } else {
            options.shards
        };
        let engine = ShardedEngine::start(
            options.config.engine,
            &options.config.stations,
            &specs,
            &records,
            shards,
        )
        .map_err(anyhow::Error::msg)?;
        Ok(NodeRuntime {
            engine: Some(engine),
            journal,
            epoch: Instant::now(),
            log: RateLimitedLog {
                interval: Duration::from_secs(10),
                last: HashMap::new(),
            },
            stats: NodeStats::default(),
            pbr_ids: specs.into_iter().map(|s| s.id).collect(),
        })
    }

    /// Monotonic wall time since start (ns): arrival and emission stamps.
    #[must_use]
    pub fn now_ns(&self) -> i64 {
        self.epoch.elapsed().as_nanos() as i64
    }

    /// Ids of the catalogued blocks.
    #[must_use]
    pub fn pbr_ids(&self) -> &[String] {
        &self.pbr_ids
    }

    /// A handle for transport threads to submit packets.
    #[must_use]
    pub fn submitter(&self) -> Option<Submitter> {
        self.engine.as_ref().map(|e| Submitter {
            engine: e.handle(),
            epoch: self.epoch,
        })
    }

    /// Publishes the engine's outputs to every publisher as they come, until `stop` is set
    /// (checked every 50 ms). Blocks: run it on the thread that owns the publishers.
    pub fn pump(
        &mut self,
        publishers: &mut [&mut dyn Publisher],
        stop: &AtomicBool,
    ) -> anyhow::Result<()> {
        let mut errors = 0u64;
        let mut last_flush = Instant::now();
        while !stop.load(Ordering::Relaxed) {
            // The engine's reorder window counts packets (so replays are deterministic); live,
            // a packet held for missing data must not wait forever if its station falls
            // silent: release held packets (accepting the gap) every HELD_PACKET_TIMEOUT.
            if last_flush.elapsed() >= HELD_PACKET_TIMEOUT {
                last_flush = Instant::now();
                if let Some(engine) = &self.engine {
                    engine.flush(self.now_ns());
                }
            }
            let batch = self
                .engine
                .as_ref()
                .and_then(|e| e.recv_outputs_timeout(Duration::from_millis(50)));
            if let Some(batch) = batch {
                let mut failures = Vec::new();
                self.handle(batch, &mut |p| {
                    for publisher in publishers.iter_mut() {
                        if let Err(e) = publisher.publish(&p) {
                            failures.push(e.to_string());
                        }
                    }
                })?;
                for f in failures {
                    errors += 1;
                    self.log
                        .log("node", "publish_failed", &format!("{f} ({errors} in all)"));
                }
            }
        }
        Ok(())
    }

    /// Hands a packet to the engine, stamped with its arrival time.
    pub fn submit(&mut self, packet: AccelPacket) {
        self.stats.packets += 1;
        let arrival = self.now_ns();
        if let Some(engine) = &self.engine {
            engine.submit(packet, arrival);
        }
    }

    /// New alert thresholds, effective for the next packet.
    pub fn set_alert_config(&self, alerts: AlertConfig) {
        if let Some(engine) = &self.engine {
            engine.set_alert_config(alerts);
        }
    }

    /// Operator reset of a fallen block: journaled, then applied.
    pub fn reset_pbr(&mut self, pbr_id: &str) -> anyhow::Result<()> {
        if let Some(j) = &mut self.journal {
            j.append(&JournalRecord::Reset {
                pbr_id: pbr_id.to_string(),
            })?;
        }
        if let Some(engine) = &self.engine {
            engine.reset_pbr(pbr_id);
        }
        Ok(())
    }

    fn handle(
        &mut self,
        outputs: Vec<Output>,
        publish: &mut impl FnMut(Publication),
    ) -> anyhow::Result<()> {
        for output in outputs {
            match output {
                Output::Alert(alert) => {
                    if let Some(j) = &mut self.journal {
                        j.append(&JournalRecord::Alert(alert.clone()))?;
                    }
                    self.stats.alerts += 1;
                    let latency_ns = self.now_ns() - alert.arrival_ns;
                    publish(Publication::Alert { alert, latency_ns });
                }
                Output::EpisodeEnd { pbr_id, episode } => {
                    if let Some(j) = &mut self.journal {
                        j.append(&JournalRecord::EpisodeEnd { pbr_id, episode })?;
                    }
                }
                Output::State(s) => {
                    self.stats.states += 1;
                    publish(Publication::State(s));
                }
                Output::Intensity(i) => {
                    self.stats.intensities += 1;
                    publish(Publication::Intensity(i));
                }
                Output::Notice(n) => {
                    self.stats.notices += 1;
                    self.log.log(&n.station, n.kind, &n.message);
                }
            }
        }
        Ok(())
    }

    /// Publishes everything the engine has produced so far, without waiting. Alerts are
    /// journaled first; an error means the state directory failed (the alert was not
    /// published).
    pub fn poll(&mut self, publish: &mut impl FnMut(Publication)) -> anyhow::Result<()> {
        let outputs: Vec<Output> = self
            .engine
            .as_ref()
            .map_or_else(Vec::new, |e| e.try_outputs().collect());
        self.handle(outputs, publish)
    }

    /// Waits up to `timeout` for outputs, then publishes them (for transports without their
    /// own event loop).
    pub fn poll_wait(
        &mut self,
        timeout: Duration,
        publish: &mut impl FnMut(Publication),
    ) -> anyhow::Result<()> {
        if let Some(first) = self
            .engine
            .as_ref()
            .and_then(|e| e.recv_outputs_timeout(timeout))
        {
            self.handle(first, publish)?;
        }
        self.poll(publish)
    }

    /// Stops intake: releases held packets, lets the workers finish, publishes what remains
    /// and returns every block's summary.
    pub fn shutdown(
        self,
        publish: &mut impl FnMut(Publication),
    ) -> anyhow::Result<Vec<PbrSummary>> {
        Ok(self.shutdown_with_totals(publish)?.0)
    }

    /// As [`NodeRuntime::shutdown`], also returning what the engine made of its input.
    pub fn shutdown_with_totals(
        mut self,
        publish: &mut impl FnMut(Publication),
    ) -> anyhow::Result<(Vec<PbrSummary>, InputTotals)> {
        let now = self.now_ns();
        let Some(engine) = self.engine.take() else {
            return Ok((Vec::new(), InputTotals::default()));
        };
        engine.flush(now);
        let (engines, rest) = engine.shutdown();
        self.handle(rest, publish)?;
        let mut totals = InputTotals::default();
        for e in &engines {
            totals.add(e);
        }
        Ok((engines.iter().flat_map(Engine::summaries).collect(), totals))
    }
}

#[cfg(test)]
mod tests {
    use super::printable;

    #[test]
    fn printable_escapes_control_characters_and_bounds_the_length() {
        assert_eq!(printable("CI.RRS.00", 48), "CI.RRS.00");
        assert_eq!(
            printable("CI.RRS.00\0\nforged", 48),
            "CI.RRS.00\\u{0}\\nforged"
        );
        let long = "A".repeat(100_000);
        assert_eq!(
            printable(&long, 8),
            format!("AAAAAAAA…(+{} bytes)", 100_000 - 8)
        );
        // Multi-byte characters are counted as characters, never split.
        assert_eq!(printable("ééé", 2), "éé…(+2 bytes)");
    }
}
