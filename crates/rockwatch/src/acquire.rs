//! `rockwatch acquire`, the station acquisition process: SeedLink records
//! ([`crate::seedlink::SeedLinkClient`]) → decoded by the project's MiniSEED reader →
//! calibrated, rotated and aligned with StationXML ([`rockwatch_core::assembly`]) →
//! [`AccelPacket`](rockwatch_core::engine::AccelPacket)s published to the node through a
//! [`PacketSink`] (iceoryx2 or ROS 2). Configuration: `config/acquire.toml` (every key).
//! Its counters: Prometheus text on `/metrics` ([`acquire_prometheus`]) and, over ROS 2, its
//! status on `/diagnostics` ([`PacketPublisher::publish_status`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rockwatch_core::assembly::{Assembler, AssemblyConfig, AssemblyCounters, RecordIssue};
use rockwatch_core::inventory::Inventory;
use rockwatch_core::record::mseed::{Channel, NS_PER_S};
use rockwatch_core::utc::format_utc_ns;

use crate::iox::IoxConfig;
use crate::log_text::{printable, STATION_CHARS};
use crate::logging::RateLimitedLog;
use crate::ports::PacketSink;
use crate::ros2::Ros2Config;
use crate::seedlink::{LinkCounters, RecordSink, SeedLinkConfig, Taken, LOG_INTERVAL};
use crate::status::{kv, Item, Level, StatusReport};

/// The acquisition configuration file.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AcquireConfig {
    pub seedlink: SeedLinkConfig,
    pub inventory: InventorySection,
    #[serde(default)]
    pub assembly: AssemblySection,
    #[serde(default)]
    pub clipping: ClippingSection,
    /// Where the SeedLink resume state is kept (overridden by `--state-dir`).
    #[serde(default)]
    pub state_dir: Option<PathBuf>,
    /// ROS 2 output (`--to ros2`): the node's `[ros2]` section.
    #[serde(default)]
    pub ros2: Ros2Config,
    /// iceoryx2 output (`--to iceoryx2`, the default): the node's `[iceoryx2]` section.
    #[serde(default)]
    pub iceoryx2: IoxConfig,
    /// ROS 2 output to a scaled-out service of this many partitioned nodes
    /// (docs/capacity.md): each station's packets go to its partition's topic
    /// `pbr/accel/p<i>of<N>` (relative, resolved in `[ros2] namespace`). None: `pbr/accel`.
    #[serde(default)]
    pub partitions: Option<u32>,
    /// Stations assigned to a partition explicitly, as in the nodes' configurations.
    #[serde(default)]
    pub partition_assign: BTreeMap<String, u32>,
    /// `[metrics] listen = "127.0.0.1:9465"`: acquire's counters as Prometheus text on
    /// `GET /metrics` ([`acquire_prometheus`]); none by default.
    #[serde(default)]
    pub metrics: crate::metrics::MetricsConfig,
}

/// Acquire's end-of-run summary (one log line): what the link received and dropped, what
/// was refused and why, what was assembled and published. Counters are totals of the run.
#[must_use]
pub fn acquire_summary(
    link: &LinkCounters,
    published: &PublishCounters,
    assembled: &AssemblyCounters,
) -> String {
    let refused = RefusedRecords::from(assembled);
    format!(
        "acquire: {} packets received, {} records delivered ({} duplicates dropped, {} malformed, {} unselected, {} packets not framed as the protocol says, {} packets cut off by the end of a connection, {} unreadable sequence numbers (delivered by start time), {} server resets, {} sequence numbers out of line, {} server restarts, {} resumes by number that yielded nothing (resumed by time), {} INFO STREAMS answers that could not be read, {} reconnections); {} records refused ({} at another sampling rate, {} with impossible values, {} far ahead of their station's data, {} other: not in the inventory, off the grid, another band; {} station grids restarted after an outage), {} clipped samples in {} records, {} overlap samples trimmed, {} missing-component samples zero-filled; {} packets published ({} send errors, {} losses of the node's subscription)",
        link.packets,
        link.delivered,
        link.duplicates,
        link.malformed,
        link.unselected,
        link.protocol_errors,
        link.partial_packets,
        link.unreadable_sequences,
        link.server_resets,
        link.sequence_outliers,
        link.server_restarts,
        link.resume_fallbacks,
        link.unreadable_info,
        link.disconnects,
        assembled.refused_records,
        refused.other_rate,
        refused.impossible_values,
        refused.far_ahead,
        refused.other,
        assembled.grid_restarts,
        published.clipped_samples,
        published.clipped_records,
        assembled.overlap_samples,
        assembled.missing_component_samples,
        published.packets_sent,
        published.send_errors,
        published.subscription_losses
    )
}

/// Acquire's counters in the Prometheus text exposition format (served on `/metrics`): the
/// link (`rockwatch_acquire_link_*`), the records refused by reason, the assembly and the
/// publication. Counters are totals since acquire started.
#[must_use]
pub fn acquire_prometheus(
    link: &LinkCounters,
    published: &PublishCounters,
    assembled: &AssemblyCounters,
) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let mut counter = |name: &str, help: &str, values: &[(&str, u64)]| {
        let _ = writeln!(out, "# HELP rockwatch_acquire_{name} {help}");
        let _ = writeln!(out, "# TYPE rockwatch_acquire_{name} counter");
        for (labels, v) in values {
            let _ = writeln!(out, "rockwatch_acquire_{name}{labels} {v}");
        }
    };
    let refused = RefusedRecords::from(assembled);
    counter(
        "link_connections_total",
        "SeedLink connections made.",
        &[("", link.connections)],
    );
    counter(
        "link_disconnects_total",
        "SeedLink connections lost or closed.",
        &[("", link.disconnects)],
    );
    counter(
        "link_packets_total",
        "SeedLink packets received.",
        &[("", link.packets)],
    );
    counter(
        "link_records_delivered_total",
        "Records delivered to the assembler.",
        &[("", link.delivered)],
    );
    counter(
        "link_duplicates_total",
        "Records dropped as already delivered.",
        &[("", link.duplicates)],
    );
    counter(
        "link_malformed_total",
        "Packets that could not be decoded.",
        &[("", link.malformed)],
    );
    counter(
        "link_unselected_total",
        "Records of streams no pattern selects (dropped).",
        &[("", link.unselected)],
    );
    counter(
        "link_protocol_errors_total",
        "Bytes that were not a SeedLink packet (the connection dropped and made again).",
        &[("", link.protocol_errors)],
    );
    counter(
        "link_partial_packets_total",
        "Connections that ended in the middle of a packet (the part dropped).",
        &[("", link.partial_packets)],
    );
    counter(
        "link_unreadable_sequences_total",
        "v3 packets whose sequence number could not be read (delivered by start time).",
        &[("", link.unreadable_sequences)],
    );
    counter(
        "link_server_resets_total",
        "New data numbered behind a confirmed number (the server restarted its numbering).",
        &[("", link.server_resets)],
    );
    counter(
        "link_missing_sequences_total",
        "Sequence numbers skipped by the server.",
        &[("", link.missing_sequences)],
    );
    counter(
        "link_sequence_outliers_total",
        "Sequence numbers out of line (one odd number, not a server restart).",
        &[("", link.sequence_outliers)],
    );
    counter(
        "link_server_restarts_total",
        "Connections on which the server had restarted.",
        &[("", link.server_restarts)],
    );
    counter(
        "link_resume_fallbacks_total",
        "Resumes by sequence number that yielded nothing and fell back to time.",
        &[("", link.resume_fallbacks)],
    );
    counter(
        "link_unreadable_info_total",
        "INFO STREAMS answers that could not be read (backfill not applied).",
        &[("", link.unreadable_info)],
    );
    counter(
        "records_refused_total",
        "Records refused (never used, never a resume point), by reason.",
        &[
            ("{reason=\"other_rate\"}", refused.other_rate),
            ("{reason=\"impossible_values\"}", refused.impossible_values),
            ("{reason=\"far_ahead\"}", refused.far_ahead),
            ("{reason=\"other\"}", refused.other),
        ],
    );
    counter(
        "clipped_samples_total",
        "Samples at or beyond their stream's full scale (used, flagged).",
        &[("", published.clipped_samples)],
    );
    counter(
        "overlap_samples_total",
        "Samples trimmed as overlapping data already assembled.",
        &[("", assembled.overlap_samples)],
    );
    counter(
        "missing_component_samples_total",
        "Samples of a missing component zero-filled.",
        &[("", assembled.missing_component_samples)],
    );
    counter(
        "packets_published_total",
        "Packets published to the node.",
        &[("", published.packets_sent)],
    );
    counter(
        "send_errors_total",
        "Packets the output transport refused.",
        &[("", published.send_errors)],
    );
    counter(
        "subscription_losses_total",
        "Times every subscriber of the packets (the node) went away.",
        &[("", published.subscription_losses)],
    );
    out
}

/// `[inventory]`.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InventorySection {
    /// StationXML files (relative to the configuration file).
    pub stationxml: Vec<PathBuf>,
    /// Velocity channels (input units M/S) are differentiated to acceleration in the core
    /// (`rockwatch_core::differentiate`); without it they are refused.
    #[serde(default)]
    pub differentiate_velocity: bool,
}

/// `[clipping]`: the digitizer's full scale in raw counts, for flagging clipped samples.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ClippingSection {
    /// Full scale (counts) of every stream not listed in `streams`: 8388607 = 2^23 − 1, the
    /// largest count of a 24-bit digitizer.
    pub full_scale_counts: f64,
    /// Per `NET.STA.LOC.CHA` (a stream) or `NET.STA.LOC` (every stream of a station): its
    /// full scale in counts.
    pub streams: BTreeMap<String, f64>,
}

impl Default for ClippingSection {
    fn default() -> Self {
        ClippingSection {
            full_scale_counts: DEFAULT_FULL_SCALE_COUNTS,
            streams: BTreeMap::new(),
        }
    }
}

/// 2^23 − 1: the largest count of a 24-bit digitizer.
pub const DEFAULT_FULL_SCALE_COUNTS: f64 = 8_388_607.0;

impl ClippingSection {
    /// The full scale of stream `id` (`NET.STA.LOC.CHA`): its own, its station's, or the
    /// default.
    #[must_use]
    pub fn full_scale(&self, id: &str) -> f64 {
        if let Some(&fs) = self.streams.get(id) {
            return fs;
        }
        let station = id.rsplit_once('.').map_or(id, |(s, _)| s);
        self.streams
            .get(station)
            .copied()
            .unwrap_or(self.full_scale_counts)
    }

    fn check(&self) -> Result<(), String> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if !ok(self.full_scale_counts) {
            return Err(format!(
                "[clipping] full_scale_counts must be > 0, got {}",
                self.full_scale_counts
            ));
        }
        for (id, &v) in &self.streams {
            let parts = id.split('.').count();
            if !(parts == 3 || parts == 4) || !ok(v) {
                return Err(format!(
                    "[clipping.streams] {id:?} = {v}: keys are NET.STA.LOC or NET.STA.LOC.CHA, values counts > 0"
                ));
            }
        }
        Ok(())
    }
}

/// `[assembly]`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AssemblySection {
    /// Seconds a span waits for a missing component before it is published without it.
    pub max_wait_s: f64,
    /// Most samples per published packet.
    pub max_packet_samples: usize,
    /// Most seconds of data held per component waiting for the others.
    pub max_buffer_s: f64,
}

impl Default for AssemblySection {
    fn default() -> Self {
        let d = AssemblyConfig::default();
        AssemblySection {
            max_wait_s: d.max_wait_ns as f64 / NS_PER_S as f64,
            max_packet_samples: d.max_packet_samples,
            max_buffer_s: d.max_buffer_s,
        }
    }
}

/// Why an acquisition configuration could not be loaded: `path: problem`.
#[derive(Debug, thiserror::Error)]
#[error("{}: {problem}", path.display())]
pub struct AcquireConfigError {
    /// The configuration file.
    pub path: PathBuf,
    pub problem: AcquireConfigProblem,
}

/// What is wrong with an acquisition configuration file.
#[derive(Debug, thiserror::Error)]
pub enum AcquireConfigProblem {
    /// It could not be read.
    #[error("{0}")]
    Read(#[from] std::io::Error),
    /// It is not valid TOML for this schema: `line N: message`.
    #[error("{0}")]
    Syntax(String),
    /// A `[seedlink]` value (server, streams, timing, backfill) is invalid.
    #[error("{0}")]
    SeedLink(crate::seedlink::SeedLinkConfigError),
    /// A `[clipping]` value is invalid.
    #[error("{0}")]
    Clipping(String),
    /// `partitions` or `[partition_assign]` is invalid.
    #[error("{0}")]
    Partition(crate::node_config::PartitionConfigError),
    /// `[inventory] stationxml` lists no file.
    #[error("inventory.stationxml is empty: list the StationXML files")]
    NoInventory,
    /// An `[assembly]` value is out of its range.
    #[error("{0}")]
    Assembly(String),
    /// A `[metrics]` value is invalid (e.g. a non-loopback listen without a token).
    #[error("{0}")]
    Metrics(crate::web::config::ListenerError),
}

impl AcquireConfig {
    /// Reads and checks `path`; relative paths are taken from the file's directory; errors
    /// name the file (and the line, for TOML syntax).
    pub fn load(path: &Path) -> Result<AcquireConfig, AcquireConfigError> {
        use AcquireConfigProblem as P;
        let fail = |problem: AcquireConfigProblem| AcquireConfigError {
            path: path.to_owned(),
            problem,
        };
        let text = rockwatch_core::bounded_read::read_to_string_bounded(
            path,
            rockwatch_core::bounded_read::MAX_CONFIG_FILE_BYTES,
        )
        .map_err(|e| fail(e.into()))?;
        let mut config: AcquireConfig = toml::from_str(&text).map_err(|e| {
            fail(P::Syntax(rockwatch_core::catalogue::toml_error_line(
                &text, &e,
            )))
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        for file in &mut config.inventory.stationxml {
            *file = base.join(&*file);
        }
        config.state_dir = config.state_dir.map(|d| base.join(d));
        config.iceoryx2.config_file = config.iceoryx2.config_file.map(|f| base.join(f));
        config
            .seedlink
            .patterns()
            .map_err(|e| fail(P::SeedLink(e)))?;
        config.clipping.check().map_err(|e| fail(P::Clipping(e)))?;
        config.metrics.resolve(base);
        config.metrics.token().map_err(|e| fail(P::Metrics(e)))?;
        config.partition_map().map_err(|e| fail(P::Partition(e)))?;
        if config.inventory.stationxml.is_empty() {
            return Err(fail(P::NoInventory));
        }
        let a = config.assembly;
        let ok = a.max_wait_s.is_finite()
            && (0.0..=3600.0).contains(&a.max_wait_s)
            && (1..=rockwatch_core::engine::packet::MAX_SAMPLES_PER_PACKET)
                .contains(&a.max_packet_samples)
            && a.max_buffer_s.is_finite()
            && (1.0..=86_400.0).contains(&a.max_buffer_s);
        if !ok {
            return Err(fail(P::Assembly(format!(
                "[assembly] out of range: max_wait_s 0–3600, max_packet_samples 1–100000, max_buffer_s 1–86400 (got {a:?})"
            ))));
        }
        Ok(config)
    }

    /// The partition map of the ROS 2 output (`partitions`, `[partition_assign]`), if any.
    pub fn partition_map(
        &self,
    ) -> Result<
        Option<rockwatch_core::partition::PartitionMap>,
        crate::node_config::PartitionConfigError,
    > {
        match self.partitions {
            Some(n) => crate::node_config::partition_map(n, &self.partition_assign).map(Some),
            None if self.partition_assign.is_empty() => Ok(None),
            None => Err(
                crate::node_config::PartitionConfigError::AssignWithoutCount {
                    needs: "partitions = N",
                },
            ),
        }
    }

    /// The assembler settings.
    #[must_use]
    pub fn assembly_config(&self) -> AssemblyConfig {
        AssemblyConfig {
            max_wait_ns: (self.assembly.max_wait_s * 1e9) as i64,
            max_packet_samples: self.assembly.max_packet_samples,
            max_buffer_s: self.assembly.max_buffer_s,
            differentiate_velocity: self.inventory.differentiate_velocity,
        }
    }
}

/// What the publisher did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct PublishCounters {
    pub packets_sent: u64,
    pub send_errors: u64,
    /// Times the node's subscription went away (every subscriber of the packets gone: they
    /// are published to nobody until it comes back).
    pub subscription_losses: u64,
    /// Raw samples at or beyond their stream's full scale (`[clipping]`): used, flagged here.
    pub clipped_samples: u64,
    /// Records holding at least one clipped sample.
    pub clipped_records: u64,
}

/// Records refused (never used, never a resume point), by reason.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RefusedRecords {
    /// Claiming another sampling rate than their station's (or their inventory epoch's).
    pub other_rate: u64,
    /// Impossible values: a sample not finite, or beyond ±100 g once calibrated.
    pub impossible_values: u64,
    /// Starting more than `max_buffer_s` after what their station holds (a far-future time).
    pub far_ahead: u64,
    /// Any other reason: not in the inventory, unusable, off the grid, another band, …
    pub other: u64,
}

impl RefusedRecords {
    /// Counts one refused record.
    fn count(&mut self, issue: &RecordIssue) {
        if issue.is_other_rate() {
            self.other_rate += 1;
        } else if matches!(issue, RecordIssue::Implausible { .. }) {
            self.impossible_values += 1;
        } else if matches!(issue, RecordIssue::FarAhead { .. }) {
            self.far_ahead += 1;
        } else {
            self.other += 1;
        }
    }

    #[must_use]
    pub fn total(&self) -> u64 {
        self.other_rate + self.impossible_values + self.far_ahead + self.other
    }

    /// The counts by reason since `before`.
    fn since(&self, before: &RefusedRecords) -> RefusedRecords {
        RefusedRecords {
            other_rate: self.other_rate.saturating_sub(before.other_rate),
            impossible_values: self
                .impossible_values
                .saturating_sub(before.impossible_values),
            far_ahead: self.far_ahead.saturating_sub(before.far_ahead),
            other: self.other.saturating_sub(before.other),
        }
    }

    /// `N at another sampling rate, N with impossible values, N far ahead, N other`.
    fn describe(&self) -> String {
        format!(
            "{} at another sampling rate, {} with impossible values, {} far ahead of the station's data, {} other",
            self.other_rate, self.impossible_values, self.far_ahead, self.other
        )
    }

    /// The `values` of a status item: `records_refused` and one entry per reason.
    fn values(&self, out: &mut Vec<(String, String)>) {
        out.extend([
            kv("records_refused", self.total()),
            kv("records_refused_other_rate", self.other_rate),
            kv("records_refused_impossible_values", self.impossible_values),
            kv("records_refused_far_ahead", self.far_ahead),
            kv("records_refused_other", self.other),
        ]);
    }
}

impl From<&AssemblyCounters> for RefusedRecords {
    /// The assembler's totals (`other`: the refusals of no counted reason).
    fn from(c: &AssemblyCounters) -> RefusedRecords {
        RefusedRecords {
            other_rate: c.other_rate_records,
            impossible_values: c.implausible_records,
            far_ahead: c.far_ahead_records,
            other: c
                .refused_records
                .saturating_sub(c.other_rate_records + c.implausible_records + c.far_ahead_records),
        }
    }
}

/// The prefix of acquire's item names on `/diagnostics` (diagnostic_updater's
/// `<program>: <item>`; the node's is `rockwatch`).
pub const DIAGNOSTICS_PREFIX: &str = "rockwatch acquire";

/// Most stations with an item of their own in acquire's status: a server that sends ever
/// new station names under a wildcard pattern cannot grow it without bound (the records of
/// the others are counted in the `publication` item).
pub const MAX_STATUS_STATIONS: usize = 4096;

/// How often acquire looks whether the node still subscribes to its packets.
const SUBSCRIPTION_CHECK: Duration = Duration::from_secs(1);

/// At most one line on the node's subscription (gone, back) per this interval; a change
/// within it is said when the interval has passed, if it still holds.
const SUBSCRIPTION_LOG_INTERVAL: Duration = Duration::from_secs(10);

/// Whether the node subscribes to acquire's packets, as last looked and as last said.
#[derive(Debug)]
struct Subscription {
    now: bool,
    said: bool,
    checked: Instant,
    said_at: Option<Instant>,
}

/// One station's figures in acquire's status (`station NET.STA.LOC`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct StationFigures {
    /// Records taken (placed by the assembler).
    records: u64,
    refused: RefusedRecords,
    /// `refused` at the previous report.
    reported: RefusedRecords,
    /// Start (UTC, ns) of the latest record taken.
    last_record_ns: Option<i64>,
    /// Raw samples at or beyond the stream's full scale, in records taken.
    clipped_samples: u64,
}

/// What the previous status report counted, to judge what happened since.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Reported {
    /// Malformed records, protocol errors and partial packets.
    malformed: u64,
    send_errors: u64,
    refused: u64,
}

/// The record sink of `acquire`: assembles records into packets and sends them.
pub struct PacketPublisher<'a> {
    assembler: Assembler,
    sink: &'a mut dyn PacketSink,
    /// The assembler's clock: time the SeedLink link was up (a component is not missing
    /// while nothing can be fetched).
    clock: Instant,
    /// Time the link was down before the current state, and since when it is down now.
    offline: Duration,
    offline_since: Option<Instant>,
    counters: PublishCounters,
    clipping: ClippingSection,
    /// Per stream and kind (`clipped`, `refused`): at most one line per [`LOG_INTERVAL`].
    log: RateLimitedLog,
    /// Per station (`NET.STA.LOC`, at most [`MAX_STATUS_STATIONS`]): the status figures.
    stations: BTreeMap<String, StationFigures>,
    /// Records of stations beyond [`MAX_STATUS_STATIONS`].
    records_not_itemised: u64,
    reported: Reported,
    subscription: Subscription,
}

impl<'a> PacketPublisher<'a> {
    #[must_use]
    pub fn new(
        inventory: Inventory,
        config: AssemblyConfig,
        clipping: ClippingSection,
        sink: &'a mut dyn PacketSink,
    ) -> Self {
        PacketPublisher {
            assembler: Assembler::new(inventory, config),
            sink,
            clock: Instant::now(),
            offline: Duration::ZERO,
            offline_since: Some(Instant::now()),
            counters: PublishCounters::default(),
            clipping,
            log: RateLimitedLog::with_interval(LOG_INTERVAL),
            stations: BTreeMap::new(),
            records_not_itemised: 0,
            reported: Reported::default(),
            // Acquire starts publishing once the node has subscribed.
            subscription: Subscription {
                now: true,
                said: true,
                checked: Instant::now(),
                said_at: None,
            },
        }
    }

    /// Looks (every [`SUBSCRIPTION_CHECK`]) whether the node still subscribes; a loss is
    /// counted, and each change said at info (at most one line per
    /// [`SUBSCRIPTION_LOG_INTERVAL`]; a change undone within it is counted, not said).
    fn watch_subscription(&mut self) {
        let s = &mut self.subscription;
        if s.checked.elapsed() < SUBSCRIPTION_CHECK {
            return;
        }
        s.checked = Instant::now();
        // A transport error is logged by `tick`; the subscription is then unknown.
        let Ok(now) = self.sink.wait_for_subscriber(Duration::ZERO) else {
            return;
        };
        if s.now && !now {
            self.counters.subscription_losses += 1;
        }
        s.now = now;
        if s.now == s.said
            || s.said_at
                .is_some_and(|t| t.elapsed() < SUBSCRIPTION_LOG_INTERVAL)
        {
            return;
        }
        (s.said, s.said_at) = (now, Some(Instant::now()));
        let losses = self.counters.subscription_losses;
        if now {
            tracing::info!(
                "acquire: the node subscribes again: publishing ({losses} losses of its subscription so far)"
            );
        } else {
            tracing::info!(
                "acquire: the node's subscription went away: packets are published to nobody until it comes back (a node restarting resumes from its own state; {losses} losses so far)"
            );
        }
    }

    #[must_use]
    pub fn counters(&self) -> (PublishCounters, AssemblyCounters) {
        (self.counters, self.assembler.counters())
    }

    /// The status figures of `station` (`None`: beyond [`MAX_STATUS_STATIONS`], counted).
    fn station_figures(&mut self, station: &str) -> Option<&mut StationFigures> {
        if !self.stations.contains_key(station) {
            if self.stations.len() >= MAX_STATUS_STATIONS {
                self.records_not_itemised += 1;
                return None;
            }
            self.stations
                .insert(station.to_string(), StationFigures::default());
        }
        self.stations.get_mut(station)
    }

    /// Acquire's status as `/diagnostics` items, judged on what changed since the previous
    /// call (call it once per report):
    /// - `link` (`hardware_id`: `server`): **WARN** while the link is down (reconnecting), or
    ///   if packets could not be decoded since the previous report; else **OK**;
    /// - `publication` (assembly and publication): **WARN** if records were refused or
    ///   packets could not be sent since the previous report; else **OK**;
    /// - `station NET.STA.LOC` (`hardware_id`: the station), in id order: **WARN** if records
    ///   of the station were refused since the previous report (the count by reason in the
    ///   message); else **OK**. Values: records taken and refused by reason, clipped samples,
    ///   `last_record_time` (UTC start of the latest record taken) and `published_until` (UTC
    ///   before which every sample is published).
    ///
    /// Counters are totals since acquire started; `stamp_ns` is the report's UTC time (ns).
    pub fn status_report(
        &mut self,
        link: &LinkCounters,
        server: &str,
        stamp_ns: i64,
    ) -> StatusReport {
        let mut items = Vec::with_capacity(2 + self.stations.len());
        // Packets that could not be decoded or framed (a connection dropped for it).
        let undecoded = link.malformed + link.protocol_errors + link.partial_packets;
        let malformed = undecoded.saturating_sub(self.reported.malformed);
        let (state, level, message) = match self.offline_since {
            Some(since) => (
                "reconnecting",
                Level::Warn,
                format!(
                    "link down for {:.0} s: reconnecting to {server} ({} connections lost so far)",
                    since.elapsed().as_secs_f64(),
                    link.disconnects
                ),
            ),
            None if malformed > 0 => (
                "connected",
                Level::Warn,
                format!("{malformed} packets could not be decoded or framed since the last report"),
            ),
            None => ("connected", Level::Ok, format!("connected to {server}")),
        };
        items.push(Item {
            name: "link".into(),
            hardware_id: server.to_string(),
            level,
            message,
            values: vec![
                kv("state", state),
                kv("server", server),
                kv("connections", link.connections),
                kv("reconnections", link.disconnects),
                kv("packets", link.packets),
                kv("records_delivered", link.delivered),
                kv("records_refused", link.refused),
                kv("duplicates", link.duplicates),
                kv("malformed", link.malformed),
                kv("unselected", link.unselected),
                kv("protocol_errors", link.protocol_errors),
                kv("partial_packets", link.partial_packets),
                kv("unreadable_sequences", link.unreadable_sequences),
                kv("missing_sequences", link.missing_sequences),
                kv("sequence_outliers", link.sequence_outliers),
                kv("server_resets", link.server_resets),
                kv("server_restarts", link.server_restarts),
                kv("resume_fallbacks", link.resume_fallbacks),
                kv("unreadable_info", link.unreadable_info),
            ],
        });
        let (published, assembled) = self.counters();
        let refused = RefusedRecords::from(&assembled);
        let new_refused = refused.total().saturating_sub(self.reported.refused);
        let send_errors = published
            .send_errors
            .saturating_sub(self.reported.send_errors);
        let (level, message) = if send_errors + new_refused > 0 {
            (
                Level::Warn,
                format!(
                    "since the last report: {new_refused} records refused, {send_errors} packets not published"
                ),
            )
        } else {
            (
                Level::Ok,
                format!("{} packets published", published.packets_sent),
            )
        };
        let mut values = vec![
            kv("records", assembled.records),
            kv("packets_assembled", assembled.packets),
            kv("samples_assembled", assembled.samples),
            kv("packets_published", published.packets_sent),
            kv("send_errors", published.send_errors),
            kv("clipped_samples", published.clipped_samples),
            kv("clipped_records", published.clipped_records),
            kv("overlap_samples", assembled.overlap_samples),
            kv(
                "missing_component_samples",
                assembled.missing_component_samples,
            ),
            kv("grid_restarts", assembled.grid_restarts),
            kv("stations", self.stations.len()),
            kv(
                "records_of_stations_not_itemised",
                self.records_not_itemised,
            ),
        ];
        refused.values(&mut values);
        items.push(Item {
            name: "publication".into(),
            hardware_id: "assembly and publication".into(),
            level,
            message,
            values,
        });
        for (station, figures) in &mut self.stations {
            let new = figures.refused.since(&figures.reported);
            figures.reported = figures.refused;
            let (level, message) = if new.total() > 0 {
                (
                    Level::Warn,
                    format!(
                        "{} records refused since the last report ({})",
                        new.total(),
                        new.describe()
                    ),
                )
            } else if figures.records == 0 {
                (Level::Ok, "no record taken yet".to_string())
            } else {
                (Level::Ok, "receiving records".to_string())
            };
            let time = |t: Option<i64>| t.map_or(String::new(), |t| format_utc_ns(i128::from(t)));
            let mut values = vec![
                kv("records", figures.records),
                kv("clipped_samples", figures.clipped_samples),
                kv("last_record_time", time(figures.last_record_ns)),
                kv(
                    "published_until",
                    time(self.assembler.emitted_until_ns(station)),
                ),
            ];
            figures.refused.values(&mut values);
            items.push(Item {
                name: format!("station {station}"),
                hardware_id: station.clone(),
                level,
                message,
                values,
            });
        }
        self.reported = Reported {
            malformed: link.malformed + link.protocol_errors + link.partial_packets,
            send_errors: published.send_errors,
            refused: refused.total(),
        };
        StatusReport {
            stamp_ns,
            prefix: DIAGNOSTICS_PREFIX,
            items,
        }
    }

    /// Hands the sink acquire's status ([`PacketPublisher::status_report`], stamped now):
    /// ROS 2 publishes it on `/diagnostics`. A failure is logged (at most once a minute).
    pub fn publish_status(&mut self, link: &LinkCounters, server: &str) {
        let stamp_ns = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
        let report = self.status_report(link, server, stamp_ns);
        if let Err(e) = self.sink.status(report) {
            self.log.log(
                "output",
                "status",
                &format!(
                    "acquire: cannot publish its status on /diagnostics: {e:#} (logged at most once a minute)"
                ),
            );
        }
    }

    /// Nanoseconds the link has been up since the publisher started.
    fn now_ns(&self) -> i64 {
        let down = self.offline
            + self
                .offline_since
                .map_or_else(Default::default, |t| t.elapsed());
        let up = self.clock.elapsed().saturating_sub(down);
        i64::try_from(up.as_nanos()).unwrap_or(i64::MAX)
    }
}

/// Sends packets, counting and logging (once per kind) failures.
fn send_all<'s>(
    sink: &'s mut dyn PacketSink,
    counters: &'s mut PublishCounters,
) -> impl FnMut(rockwatch_core::engine::AccelPacket) + 's {
    move |packet| match sink.send(&packet) {
        Ok(()) => counters.packets_sent += 1,
        Err(e) => {
            if counters.send_errors == 0 {
                tracing::warn!(
                    "acquire: cannot publish a packet of {}: {e:#} (further failures counted)",
                    printable(packet.station.as_str(), STATION_CHARS)
                );
            }
            counters.send_errors += 1;
        }
    }
}

impl RecordSink for PacketPublisher<'_> {
    fn record(&mut self, record: &Channel) -> Taken {
        let now = self.now_ns();
        let mut send = send_all(&mut *self.sink, &mut self.counters);
        let result = self.assembler.push(record, now, &mut send);
        drop(send);
        // The record's station and channel ids, formed once.
        let station = format!("{}.{}.{}", record.net, record.sta, record.loc);
        let channel = record.id();
        if let Err(issue) = result {
            if let Some(figures) = self.station_figures(&station) {
                figures.refused.count(&issue);
            }
            self.log.log(
                &channel,
                "refused",
                &format!(
                    "acquire: station {}: {issue} (record dropped; counted, logged at most once a minute)",
                    printable(&station, STATION_CHARS)
                ),
            );
            return Taken::Refused;
        }
        // Clipping is counted on records taken (impossible values were refused above).
        let full_scale = self.clipping.full_scale(&channel);
        let clipped = record
            .segments
            .iter()
            .flat_map(|s| &s.samples)
            .filter(|x| x.abs() >= full_scale)
            .count();
        let start = record.segments.first().map(|s| s.start_time_ns);
        if let Some(figures) = self.station_figures(&station) {
            figures.records += 1;
            figures.clipped_samples += clipped as u64;
            figures.last_record_ns = figures.last_record_ns.max(start);
        }
        if clipped > 0 {
            self.counters.clipped_samples += clipped as u64;
            self.counters.clipped_records += 1;
            self.log.log(
                &channel,
                "clipped",
                &format!(
                    "acquire: {clipped} samples at or beyond the full scale ±{full_scale} counts (used; the shaking was larger; counted, logged at most once a minute)"
                ),
            );
        }
        let end = record.segments.last().map_or(0, |s| {
            s.start_time_ns + (s.samples.len() as f64 * 1e9 / record.sample_rate_hz).round() as i64
        });
        if self
            .assembler
            .emitted_until_ns(&station)
            .is_none_or(|t| t < end)
        {
            Taken::Held
        } else {
            Taken::Done
        }
    }

    fn published_until_ns(&self, station: &str) -> Option<i64> {
        self.assembler.emitted_until_ns(station)
    }

    fn link(&mut self, up: bool) {
        match (up, self.offline_since) {
            (true, Some(since)) => {
                self.offline += since.elapsed();
                self.offline_since = None;
            }
            (false, None) => self.offline_since = Some(Instant::now()),
            _ => {}
        }
    }

    fn tick(&mut self, _link: &LinkCounters) {
        if let Err(e) = self.sink.tick() {
            self.log.log(
                "output",
                "transport",
                &format!("acquire: the output transport: {e:#} (logged at most once a minute)"),
            );
        }
        self.watch_subscription();
        let now = self.now_ns();
        let mut send = send_all(&mut *self.sink, &mut self.counters);
        self.assembler.tick(now, &mut send);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seedlink::RecordSink;
    use rockwatch_core::engine::AccelPacket;
    use rockwatch_core::record::mseed::read_mseed;

    /// Collects what is published.
    #[derive(Default)]
    struct Collect(Vec<AccelPacket>);

    impl PacketSink for Collect {
        fn wait_for_subscriber(&mut self, _: Duration) -> anyhow::Result<bool> {
            Ok(true)
        }
        fn send(&mut self, packet: &AccelPacket) -> anyhow::Result<()> {
            self.0.push(packet.clone());
            Ok(())
        }
    }

    /// Subscribed or not, as the test says.
    struct Toggled(std::rc::Rc<std::cell::Cell<bool>>);

    impl PacketSink for Toggled {
        fn wait_for_subscriber(&mut self, _: Duration) -> anyhow::Result<bool> {
            Ok(self.0.get())
        }
        fn send(&mut self, _: &AccelPacket) -> anyhow::Result<()> {
            Ok(())
        }
    }

    /// Issue 20 item 4: the node leaving and coming back is counted and said, at most one
    /// line per interval, and what is said catches up with what holds.
    #[test]
    fn the_node_leaving_and_coming_back_is_counted_and_said_at_a_bounded_rate() {
        let subscribed = std::rc::Rc::new(std::cell::Cell::new(true));
        let mut sink = Toggled(std::rc::Rc::clone(&subscribed));
        let (inventory, _) = k2();
        let mut publisher = PacketPublisher::new(
            inventory,
            AssemblyConfig::default(),
            ClippingSection {
                full_scale_counts: DEFAULT_FULL_SCALE_COUNTS,
                streams: BTreeMap::new(),
            },
            &mut sink,
        );
        let look = |publisher: &mut PacketPublisher<'_>, now: bool| {
            subscribed.set(now);
            publisher.subscription.checked -= SUBSCRIPTION_CHECK;
            publisher.tick(&LinkCounters::default());
            (
                publisher.counters.subscription_losses,
                publisher.subscription.said,
            )
        };
        assert_eq!(look(&mut publisher, true), (0, true));
        assert_eq!(
            look(&mut publisher, false),
            (1, false),
            "gone: counted, said"
        );
        assert_eq!(
            look(&mut publisher, true),
            (1, false),
            "back within the interval: not said yet"
        );
        assert_eq!(look(&mut publisher, false), (2, false));
        assert_eq!(look(&mut publisher, true), (2, false));
        // The interval passes: the state now is said.
        if let Some(at) = &mut publisher.subscription.said_at {
            *at -= SUBSCRIPTION_LOG_INTERVAL;
        }
        assert_eq!(look(&mut publisher, true), (2, true));
        assert!(acquire_summary(
            &LinkCounters::default(),
            &publisher.counters,
            &publisher.assembler.counters()
        )
        .contains("2 losses of the node's subscription"));
    }

    fn k2() -> (Inventory, Vec<Channel>) {
        let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data"));
        let inventory = Inventory::read(&root.join("stationxml/obspy_XX.STN_k2.xml")).unwrap();
        let file = read_mseed(&root.join("mseed/k2_STNA_HN123_counts.mseed")).unwrap();
        (inventory, file.channels)
    }

    #[test]
    fn clipped_unknown_and_uncalibrated_streams_are_counted_and_the_others_go_on() {
        let (mut inventory, channels) = k2();
        // An absurd gain on a second station's channel (1 count = 1e6 m/s²).
        let mut absurd = inventory.channels[0].clone();
        absurd.station = "ABS".into();
        if let Some(s) = &mut absurd.sensitivity {
            s.value = 1e-6;
        }
        inventory.channels.push(absurd);
        let mut sink = Collect::default();
        let clipping = ClippingSection {
            full_scale_counts: DEFAULT_FULL_SCALE_COUNTS,
            // HN2 of XX.STN. has a (made-up) 16-bit full scale; the rest the 24-bit default.
            streams: BTreeMap::from([("XX.STN..HN2".to_string(), 1000.0)]),
        };
        let mut publisher =
            PacketPublisher::new(inventory, AssemblyConfig::default(), clipping, &mut sink);
        publisher.link(true);
        let mut expected_clipped = 0;
        for original in &channels {
            let mut c = original.clone();
            if c.cha == "HN1" {
                // Two samples at and beyond the 24-bit full scale.
                c.segments[0].samples[10] = DEFAULT_FULL_SCALE_COUNTS;
                c.segments[0].samples[11] = -DEFAULT_FULL_SCALE_COUNTS - 1.0;
                expected_clipped += 2;
            }
            if c.cha == "HN2" {
                expected_clipped += c.segments[0]
                    .samples
                    .iter()
                    .filter(|x| x.abs() >= 1000.0)
                    .count();
            }
            publisher.record(&c);
            // Records of a channel missing from the inventory, an unknown station and the
            // absurd gain: refused, counted; XX.STN. goes on.
            for (sta, cha) in [("STN", "HNX"), ("UNK", "HN1"), ("ABS", c.cha.as_str())] {
                let mut other = original.clone();
                other.sta = sta.into();
                other.cha = cha.into();
                assert_eq!(publisher.record(&other), Taken::Refused);
            }
        }
        assert!(
            expected_clipped > 2,
            "the test needs HN2 samples beyond 1000 counts"
        );
        let (published, assembled) = publisher.counters();
        assert_eq!(published.clipped_samples, expected_clipped as u64);
        assert_eq!(published.clipped_records, 2);
        assert_eq!(assembled.refused_records, 9);
        drop(publisher);
        let samples: usize = sink.0.iter().map(AccelPacket::len).sum();
        assert_eq!(samples, 8250, "every XX.STN. sample published");
    }

    #[test]
    fn the_status_warns_of_a_refused_record_once_and_of_a_link_down() {
        let (inventory, channels) = k2();
        let mut sink = Collect::default();
        let mut publisher = PacketPublisher::new(
            inventory,
            AssemblyConfig::default(),
            ClippingSection::default(),
            &mut sink,
        );
        publisher.link(true);
        let link = LinkCounters::default();
        let find = |report: &StatusReport, name: &str| -> Item {
            let item = report.items.iter().find(|i| i.name == name);
            item.cloned()
                .unwrap_or_else(|| panic!("{name}: {report:?}"))
        };
        let value = |item: &Item, key: &str| -> String {
            let kv = item.values.iter().find(|(k, _)| k == key);
            kv.map(|(_, v)| v.clone())
                .unwrap_or_else(|| panic!("{key}: {item:?}"))
        };
        assert_eq!(publisher.record(&channels[0]), Taken::Held);
        // The next record of HN1 claiming 200× its rate: refused, counted by reason.
        let mut other_rate = channels[0].clone();
        other_rate.sample_rate_hz *= 200.0;
        assert_eq!(publisher.record(&other_rate), Taken::Refused);
        let report = publisher.status_report(&link, "host:18000", 7);
        assert_eq!((report.stamp_ns, report.prefix), (7, DIAGNOSTICS_PREFIX));
        let names: Vec<&str> = report.items.iter().map(|i| i.name.as_str()).collect();
        assert_eq!(names, ["link", "publication", "station XX.STN."]);
        let station = find(&report, "station XX.STN.");
        assert_eq!(
            (station.level, station.hardware_id.as_str()),
            (Level::Warn, "XX.STN.")
        );
        assert!(
            station
                .message
                .contains("(1 at another sampling rate, 0 with"),
            "{station:?}"
        );
        assert_eq!(value(&station, "records_refused_other_rate"), "1");
        assert_eq!(value(&station, "records"), "1");
        let start = format_utc_ns(i128::from(channels[0].segments[0].start_time_ns));
        assert_eq!(value(&station, "last_record_time"), start);
        assert_eq!(find(&report, "publication").level, Level::Warn);
        let link_item = find(&report, "link");
        assert_eq!(
            (link_item.level, value(&link_item, "state")),
            (Level::Ok, "connected".to_string())
        );
        // Nothing new: OK, the refusal still counted.
        let report = publisher.status_report(&link, "host:18000", 8);
        let station = find(&report, "station XX.STN.");
        assert_eq!(station.level, Level::Ok);
        assert_eq!(value(&station, "records_refused_other_rate"), "1");
        assert_eq!(find(&report, "publication").level, Level::Ok);
        // The link down: WARN, reconnecting, the connections lost counted.
        publisher.link(false);
        let down = LinkCounters {
            connections: 1,
            disconnects: 1,
            ..LinkCounters::default()
        };
        let link_item = find(&publisher.status_report(&down, "host:18000", 9), "link");
        assert_eq!(
            (
                link_item.level,
                value(&link_item, "state"),
                value(&link_item, "reconnections")
            ),
            (Level::Warn, "reconnecting".to_string(), "1".to_string())
        );
        assert_eq!(link_item.hardware_id, "host:18000");
    }

    #[test]
    fn prometheus_text_names_each_refusal_reason_and_the_link_counters() {
        let link = LinkCounters {
            sequence_outliers: 2,
            resume_fallbacks: 1,
            ..LinkCounters::default()
        };
        let published = PublishCounters {
            packets_sent: 7,
            ..PublishCounters::default()
        };
        let assembled = AssemblyCounters {
            refused_records: 6,
            other_rate_records: 1,
            implausible_records: 2,
            far_ahead_records: 1,
            ..AssemblyCounters::default()
        };
        let text = acquire_prometheus(&link, &published, &assembled);
        for line in [
            "rockwatch_acquire_records_refused_total{reason=\"other_rate\"} 1\n",
            "rockwatch_acquire_records_refused_total{reason=\"impossible_values\"} 2\n",
            "rockwatch_acquire_records_refused_total{reason=\"far_ahead\"} 1\n",
            "rockwatch_acquire_records_refused_total{reason=\"other\"} 2\n",
            "rockwatch_acquire_link_sequence_outliers_total 2\n",
            "rockwatch_acquire_link_resume_fallbacks_total 1\n",
            "rockwatch_acquire_packets_published_total 7\n",
            "# TYPE rockwatch_acquire_records_refused_total counter\n",
        ] {
            assert!(text.contains(line), "{line:?} missing from:\n{text}");
        }
        // Every sample line belongs to a declared metric.
        for l in text.lines().filter(|l| !l.starts_with('#')) {
            let name = l.split(['{', ' ']).next().unwrap_or("");
            assert!(text.contains(&format!("# TYPE {name} counter")), "{l}");
        }
    }

    #[test]
    fn full_scale_is_the_streams_the_stations_or_the_default() {
        let c = ClippingSection {
            full_scale_counts: 100.0,
            streams: BTreeMap::from([("XX.S..HN1".to_string(), 1.0), ("XX.S.".to_string(), 2.0)]),
        };
        assert_eq!(c.full_scale("XX.S..HN1"), 1.0);
        assert_eq!(c.full_scale("XX.S..HN2"), 2.0);
        assert_eq!(c.full_scale("XX.T..HN2"), 100.0);
        assert!(ClippingSection {
            streams: BTreeMap::from([("XX".to_string(), 1.0)]),
            ..ClippingSection::default()
        }
        .check()
        .is_err());
    }

    #[test]
    fn the_documented_configuration_loads_with_paths_relative_to_it() {
        let path = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/acquire.toml"
        ));
        let config = AcquireConfig::load(path).unwrap();
        assert_eq!(config.seedlink.server, "127.0.0.1:18000");
        assert_eq!(config.seedlink.streams, ["CI.RRS..HN?", "BK.*..HN?"]);
        assert!(config.inventory.stationxml[0].ends_with("config/inventory/ci.xml"));
        assert_eq!(config.assembly, AssemblySection::default());
        assert_eq!(config.assembly_config(), AssemblyConfig::default());
        assert!(config
            .iceoryx2
            .config_file
            .unwrap()
            .ends_with("config/iceoryx2.toml"));
    }

    #[test]
    fn velocity_differentiation_and_clipping_are_configured_by_their_keys() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.toml");
        std::fs::write(
            &path,
            "[seedlink]\nserver = \"h:1\"\nstreams = [\"XX.S..HH?\"]\n[inventory]\nstationxml = [\"x.xml\"]\ndifferentiate_velocity = true\n[clipping]\nfull_scale_counts = 32767.0\n[clipping.streams]\n\"XX.S..HHZ\" = 1000.0\n",
        )
        .unwrap();
        let config = AcquireConfig::load(&path).unwrap();
        assert!(config.assembly_config().differentiate_velocity);
        assert_eq!(config.clipping.full_scale("XX.S..HHZ"), 1000.0);
        assert_eq!(config.clipping.full_scale("XX.S..HHN"), 32767.0);
        // Off by default.
        let d = AcquireConfig::load(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/acquire.toml"
        )))
        .unwrap();
        assert!(!d.assembly_config().differentiate_velocity);
        assert_eq!(d.clipping, ClippingSection::default());
    }

    #[test]
    fn bad_values_are_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.toml");
        let base = "[seedlink]\nserver = \"h:1\"\nstreams = [\"XX.S..HN?\"]\n[inventory]\nstationxml = [\"x.xml\"]\n";
        for (extra, needle) in [
            ("[assembly]\nmax_wait_s = -1.0\n", "[assembly] out of range"),
            ("[partition_assign]\n\"XX.S.00\" = 1\n", "needs `partitions"),
            ("", ""),
        ] {
            std::fs::write(&path, format!("{base}{extra}")).unwrap();
            match AcquireConfig::load(&path) {
                Ok(_) => assert!(needle.is_empty()),
                Err(e) => {
                    let e = e.to_string();
                    assert!(
                        !needle.is_empty() && e.contains(needle) && e.contains("a.toml"),
                        "{e}"
                    );
                }
            }
        }
        std::fs::write(&path, base.replace("XX.S..HN?", "XX.S.HN?")).unwrap();
        let e = AcquireConfig::load(&path).unwrap_err();
        assert!(
            matches!(e.problem, AcquireConfigProblem::SeedLink(_))
                && e.to_string().contains("not NET.STA.LOC.CHA"),
            "{e}"
        );
        std::fs::write(
            &path,
            base.replace("[seedlink]", "[seedlink]\nprotocol = 5"),
        )
        .unwrap();
        assert!(AcquireConfig::load(&path)
            .unwrap_err()
            .to_string()
            .contains("protocol must be"));
        // backfill_s: 0 (off) is valid, a negative or absurd window is not.
        for (value, ok) in [("0", true), ("-1", false), ("1e9", false)] {
            std::fs::write(
                &path,
                base.replace("[seedlink]", &format!("[seedlink]\nbackfill_s = {value}")),
            )
            .unwrap();
            match AcquireConfig::load(&path) {
                Ok(_) => assert!(ok, "backfill_s = {value}"),
                Err(e) => assert!(!ok && e.to_string().contains("seedlink.backfill_s"), "{e}"),
            }
        }
    }
}
