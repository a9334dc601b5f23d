//! SeedLink acquisition: a reconnecting client ([`SeedLinkClient`]) around one connection
//! ([`connection::Connection`]) with its resume state in the state directory
//! ([`state::StateFile`]). The protocol logic that needs no socket (packets, selections,
//! sequence numbers, duplicates) is `rockwatch_core::seedlink`. See docs/seedlink.md.
//!
//! Guarantees: the client reconnects with exponential backoff after EOF, a timeout (no packet
//! for `idle_timeout_s`) or an I/O error; resumes each station after its last sequence number
//! (saved atomically after every batch of packets); drops duplicates by (stream, record start
//! time), so a packet sent again after a reconnect or a restart of `acquire` is delivered
//! once; and recognises a restarted server whose numbers start again (new data behind the
//! last number) instead of dropping its packets as duplicates.

pub mod connection;
pub mod state;

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use rockwatch_core::record::mseed::{parse_mseed, record_stream_id, Channel};
use rockwatch_core::seedlink::frame::Frame;
use rockwatch_core::seedlink::info::{expand, StreamSpan};
use rockwatch_core::seedlink::select::StreamPattern;
use rockwatch_core::seedlink::sequence::{judge, DeliveredStarts, StationSequence, Verdict};
use rockwatch_core::seedlink::Protocol;

use crate::log_text::{printable, STATION_CHARS};
use crate::logging::RateLimitedLog;

/// Shortest time between two log lines of one stream and kind of problem.
pub const LOG_INTERVAL: Duration = Duration::from_secs(60);
use connection::{Connection, Resume};
pub use state::StateFileError;
use state::{ResumeState, StateFile, StationResume};

/// Streams requested in one log line: each pattern and where it resumes (the first
/// [`STREAMS_NAMED`], then how many more).
fn resume_points(patterns: &[StreamPattern], resume: &dyn Fn(&StreamPattern) -> Resume) -> String {
    let named: Vec<String> = patterns
        .iter()
        .take(STREAMS_NAMED)
        .map(|p| {
            let from = match resume(p) {
                Resume::Next => "from the next record".to_string(),
                Resume::After(seq) => format!("after sequence number {seq}"),
                Resume::Since(t_ns) => format!(
                    "from {}",
                    rockwatch_core::utc::format_utc_ns(i128::from(t_ns))
                ),
            };
            format!(
                "{}.{}.{}.{} {from}",
                p.network, p.station, p.location, p.channel
            )
        })
        .collect();
    let more = patterns.len().saturating_sub(named.len());
    format!(
        "{} stream(s): {}{}",
        patterns.len(),
        named.join(", "),
        if more > 0 {
            format!(" and {more} more")
        } else {
            String::new()
        }
    )
}

/// Streams named in the line of what a connection requests.
const STREAMS_NAMED: usize = 20;

/// Which protocol to speak.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ProtocolChoice {
    /// v4 when the server offers it, else v3.
    #[default]
    Auto,
    V3,
    V4,
}

impl<'de> serde::Deserialize<'de> for ProtocolChoice {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(serde::Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Text(String),
            Number(i64),
        }
        match Raw::deserialize(d)? {
            Raw::Text(t) if t == "auto" => Ok(ProtocolChoice::Auto),
            Raw::Text(t) if t == "3" => Ok(ProtocolChoice::V3),
            Raw::Text(t) if t == "4" => Ok(ProtocolChoice::V4),
            Raw::Number(3) => Ok(ProtocolChoice::V3),
            Raw::Number(4) => Ok(ProtocolChoice::V4),
            _ => Err(serde::de::Error::custom(
                "protocol must be \"auto\", 3 or 4",
            )),
        }
    }
}

/// The `[seedlink]` section of the acquisition configuration.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeedLinkConfig {
    /// `HOST:PORT` of the SeedLink server.
    pub server: String,
    /// `NET.STA.LOC.CHA` patterns (`?`, `*` wildcards).
    pub streams: Vec<String>,
    /// `"auto"` (v4 when offered, else v3), 3 or 4.
    #[serde(default)]
    pub protocol: ProtocolChoice,
    /// Seconds allowed for connecting and for each response during negotiation.
    #[serde(default = "default_connect_timeout_s")]
    pub connect_timeout_s: f64,
    /// Seconds without any packet after which the connection is dropped and made again.
    #[serde(default = "default_idle_timeout_s")]
    pub idle_timeout_s: f64,
    /// First wait before reconnecting (s); doubled after each failure up to
    /// `reconnect_max_s`, back to this after a connection that delivered data.
    #[serde(default = "default_reconnect_initial_s")]
    pub reconnect_initial_s: f64,
    #[serde(default = "default_reconnect_max_s")]
    pub reconnect_max_s: f64,
    /// With wildcard stations (`BK.*..HN?`): seconds between two looks at the server's
    /// station list (`INFO STATIONS`, on a second short connection) for new matching
    /// stations; one appearing makes the client reconnect to request it.
    #[serde(default = "default_station_refresh_s")]
    pub station_refresh_s: f64,
    /// Seconds of data, before the newest the server holds of a stream, that a station with
    /// no resume point (a first start, or a station never heard of) is requested from: the
    /// client asks `INFO STREAMS` for each stream's `end_time` and sends `TIME` (v4 `DATA ALL
    /// start`) from the earliest `end_time − backfill_s` of the station's selected streams.
    /// Measured from the ring's data, not the wall clock (a backfill or a scanned archive is
    /// old data). 0: off, such a station starts from the server's next record (`DATA`).
    #[serde(default = "default_backfill_s")]
    pub backfill_s: f64,
}

fn default_connect_timeout_s() -> f64 {
    10.0
}
fn default_idle_timeout_s() -> f64 {
    120.0
}
fn default_reconnect_initial_s() -> f64 {
    1.0
}
fn default_reconnect_max_s() -> f64 {
    30.0
}
fn default_station_refresh_s() -> f64 {
    300.0
}
/// Five minutes: longer than the records of one component take to arrive ahead of the
/// others when a backfill or an archive comes channel by channel, and than a restart of
/// `acquire` usually takes, while bounded (a fresh start replays at most this much of the
/// ring's data per station, which the node takes as data like any other).
fn default_backfill_s() -> f64 {
    300.0
}

/// Longest `backfill_s` accepted (s): 30 days, beyond any ring's depth.
const MAX_BACKFILL_S: f64 = 30.0 * 86_400.0;

/// A `[seedlink]` setting that is invalid: which and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SeedLinkConfigError(pub String);

impl From<String> for SeedLinkConfigError {
    fn from(reason: String) -> Self {
        SeedLinkConfigError(reason)
    }
}

impl From<&str> for SeedLinkConfigError {
    fn from(reason: &str) -> Self {
        SeedLinkConfigError(reason.to_owned())
    }
}

impl SeedLinkConfig {
    /// The stream patterns, checked; and the durations in range.
    pub fn patterns(&self) -> Result<Vec<StreamPattern>, SeedLinkConfigError> {
        if self.streams.is_empty() {
            return Err(SeedLinkConfigError::from(
                "seedlink.streams is empty: list NET.STA.LOC.CHA patterns",
            ));
        }
        for (key, v, max) in [
            ("connect_timeout_s", self.connect_timeout_s, 3600.0),
            ("idle_timeout_s", self.idle_timeout_s, 86_400.0),
            ("reconnect_initial_s", self.reconnect_initial_s, 3600.0),
            ("reconnect_max_s", self.reconnect_max_s, 86_400.0),
            ("station_refresh_s", self.station_refresh_s, 86_400.0),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                return Err(SeedLinkConfigError::from(format!(
                    "seedlink.{key} = {v} is out of range (0, {max}] s"
                )));
            }
        }
        if !(self.backfill_s.is_finite() && (0.0..=MAX_BACKFILL_S).contains(&self.backfill_s)) {
            return Err(SeedLinkConfigError::from(format!(
                "seedlink.backfill_s = {} is out of range [0, {MAX_BACKFILL_S}] s",
                self.backfill_s
            )));
        }
        self.streams
            .iter()
            .map(|s| {
                StreamPattern::parse(s)
                    .map_err(|e| SeedLinkConfigError(format!("seedlink.streams: {e}")))
            })
            .collect()
    }
}

/// Why a connection ended.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LinkError {
    #[error("{0}")]
    Io(String),
    #[error("the server closed the connection")]
    Eof,
    #[error("timeout: {0}")]
    Timeout(String),
    #[error("refused: {0}")]
    Refused(String),
    #[error("protocol error: {0}")]
    Protocol(String),
    /// The selection changed (new stations match a wildcard pattern).
    #[error("{0}")]
    Resubscribe(String),
}

/// What the client did (monotonic counters).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct LinkCounters {
    pub connections: u64,
    pub disconnects: u64,
    pub packets: u64,
    pub delivered: u64,
    pub duplicates: u64,
    /// Sequence numbers skipped (gaps in the server's ring, or other stations' packets on a
    /// server with one sequence for all).
    pub missing_sequences: u64,
    pub server_resets: u64,
    /// Connections on which the server's start time had changed (a restart): the stations
    /// resumed by time, not by sequence number.
    pub server_restarts: u64,
    pub reordered: u64,
    /// Records the sink refused (another rate, impossible values, far ahead, unknown, …):
    /// never marked delivered, never a resume point (time or number).
    pub refused: u64,
    /// Sequence numbers found out of line (a jump followed by new data numbered on from
    /// before it): one odd number, not a server restart.
    pub sequence_outliers: u64,
    /// Stations whose resume by sequence number yielded nothing for `idle_timeout_s`: their
    /// number was dropped and they resumed by time.
    pub resume_fallbacks: u64,
    /// Packets that are not MiniSEED data (INFO, JSON, …).
    pub other_packets: u64,
    /// Records that could not be decoded.
    pub malformed: u64,
    /// Records of streams no pattern selects.
    pub unselected: u64,
    /// Bytes where a packet should start that are not one of the protocol (garbage, a v4
    /// payload length beyond the bound): the connection is dropped and made again, resuming
    /// after the last confirmed number.
    pub protocol_errors: u64,
    /// Connections that ended (closed, or silent for `idle_timeout_s`) in the middle of a
    /// packet: the part received is dropped; the packet comes again after reconnecting.
    pub partial_packets: u64,
    /// v3 data packets whose sequence number could not be read (not six hex digits): the
    /// packet's length is fixed, so its record is delivered by (stream, start time) like any
    /// other, and is never a resume point.
    pub unreadable_sequences: u64,
    /// `INFO STREAMS` answers that could not be read (not the XML or JSON of the protocol):
    /// the stations they were asked for start from the server's next record.
    pub unreadable_info: u64,
}

/// What the sink did with a record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Taken {
    /// Refused (the sink logged and counted why): the record is not delivered — its start
    /// time is not remembered (a clean copy is still taken), its number and time are never
    /// saved as a resume point.
    Refused,
    /// Taken, nothing of it held.
    Done,
    /// Taken, some of its samples held to publish later.
    Held,
}

/// Where the client's records go.
///
/// Resume state is saved only for what the sink has finished with: a record is *committed*
/// when [`RecordSink::record`] returns [`Taken::Done`] (nothing held), or once
/// [`RecordSink::published_until_ns`] of its station passes the record's end. A station's
/// saved sequence number never passes a record that is not committed, so a record held when
/// `acquire` is killed is fetched again on restart.
///
/// Every method is required (no defaults): a sink wrapping another must forward each one, and
/// the compiler says so (a wrapper that silently dropped `link` left the assembler's clock
/// stopped, so a component missing after a restart was waited for forever).
pub trait RecordSink {
    /// A new record of a selected stream (decoded: one channel, one record).
    fn record(&mut self, record: &Channel) -> Taken;
    /// Time before which every sample of station `NET.STA.LOC` has been published (ns);
    /// `None` if the sink holds nothing of it.
    fn published_until_ns(&self, station: &str) -> Option<i64>;
    /// Called about every 100 ms while connected (bounded waits, housekeeping) and while
    /// waiting to reconnect (the link down: see [`RecordSink::link`]), with the link's
    /// counters so far (for a sink that reports them, e.g. acquire's /metrics and
    /// /diagnostics). Not during a connection attempt (at most `connect_timeout_s` per step).
    fn tick(&mut self, link: &LinkCounters);
    /// The link came up (`true`: streams requested, data may flow) or went down. A sink that
    /// waits for data (a missing component) should not count the time the link is down:
    /// the data is not missing, it has not been fetched yet.
    fn link(&mut self, up: bool);
}

/// A sink that takes every record at once (nothing held).
pub struct EachRecord<F: FnMut(&Channel)>(pub F);

impl<F: FnMut(&Channel)> RecordSink for EachRecord<F> {
    fn record(&mut self, record: &Channel) -> Taken {
        (self.0)(record);
        Taken::Done
    }

    fn published_until_ns(&self, _station: &str) -> Option<i64> {
        None
    }

    fn tick(&mut self, _link: &LinkCounters) {}

    fn link(&mut self, _up: bool) {}
}

/// A delivered record not yet committed.
#[derive(Debug, Clone)]
struct Pending {
    /// `NET_STA` of the sequence number.
    station_key: String,
    /// `NET.STA.LOC` of the sink.
    station: String,
    stream: String,
    /// The station's resume point once this record is committed (its confirmed number),
    /// if the record moves it.
    resume: Option<u64>,
    protocol: Protocol,
    start_ns: i64,
    /// End of the record (ns), when the sink holds some of it; `None`: nothing held.
    held_until_ns: Option<i64>,
}

/// Most characters of server-supplied text (replies, errors) in a log line.
const SERVER_TEXT_CHARS: usize = 300;

/// How often the state file is synced to disk (it is renamed into place after every batch).
const DURABLE_EVERY: Duration = Duration::from_secs(1);
/// Longest wait for packets before checking the stop flag.
const TICK: Duration = Duration::from_millis(100);

/// Where the saved state resumes the station of `p` on a connection speaking `protocol`:
/// after its committed sequence number; else by time from the earliest of its streams'
/// latest committed records and first records received (their records may arrive
/// interleaved in time or channel by channel; duplicates are dropped); a station that
/// appeared while the client ran from the oldest data the server holds; else
/// [`Resume::Next`] (nothing saved: the caller may backfill).
fn saved_resume(
    state: &ResumeState,
    late: &BTreeSet<String>,
    protocol: Protocol,
    p: &StreamPattern,
) -> Resume {
    let by_sequence = p
        .exact_station()
        .and_then(|key| state.stations.get(&key).copied())
        .filter(|s| s.protocol == protocol);
    if let Some(s) = by_sequence {
        return Resume::After(s.sequence);
    }
    let prefix = format!("{}.{}.", p.network, p.station);
    let since = state
        .streams
        .iter()
        .chain(&state.received)
        .filter(|(id, _)| id.starts_with(&prefix))
        .map(|(_, &t)| t)
        .min();
    match (since, p.exact_station()) {
        (Some(t), _) => Resume::Since(t),
        // Appeared while we ran: all the server holds of it.
        (None, Some(key)) if late.contains(&key) => Resume::Since(0),
        (None, _) => Resume::Next,
    }
}

/// A SeedLink client that keeps going: connection, requests, packets, reconnections.
pub struct SeedLinkClient {
    config: SeedLinkConfig,
    patterns: Vec<StreamPattern>,
    state: ResumeState,
    state_file: Option<StateFile>,
    delivered: HashMap<String, DeliveredStarts>,
    /// Delivered records, in order, whose samples the sink still holds.
    pending: std::collections::VecDeque<Pending>,
    counters: LinkCounters,
    /// Problems per (stream, kind): at most one line a minute each, then counted.
    log: RateLimitedLog,
    /// `NET_STA` of stations that appeared on the server while the client ran: with nothing
    /// saved, they start from the oldest data the server holds for them (nothing is lost
    /// between their appearance and the next look at the station list).
    late_stations: BTreeSet<String>,
    /// `NET_STA` → the numbers received this run (protocol `sequences_protocol`), judged
    /// against; started from the saved resume point.
    sequences: HashMap<String, StationSequence>,
    sequences_protocol: Option<Protocol>,
    /// `NET_STA` of the stations of which a record arrived on the current connection.
    heard: BTreeSet<String>,
    /// The last data packet of the current connection (`station NET_STA's packet N`), to
    /// place a connection's failure in the stream.
    last_packet: Option<String>,
    /// What was already said once (a server without `INFO STREAMS`, a station it does not
    /// list): said at the first connection it applies to, not at every reconnection.
    told: BTreeSet<String>,
}

/// Why a SeedLink client could not start.
#[derive(Debug, thiserror::Error)]
pub enum SeedLinkClientError {
    /// `streams` holds a pattern that is not `NET.STA.LOC.CHA`.
    #[error("{0}")]
    Streams(SeedLinkConfigError),
    /// The resume state could not be read.
    #[error(transparent)]
    State(#[from] StateFileError),
}

impl SeedLinkClient {
    /// A client for `config`, resuming from `state_dir`'s state for the server if given.
    pub fn new(
        config: SeedLinkConfig,
        state_dir: Option<&Path>,
    ) -> Result<SeedLinkClient, SeedLinkClientError> {
        let patterns = config.patterns().map_err(SeedLinkClientError::Streams)?;
        let state_file = state_dir.map(|d| StateFile::in_dir(d, &config.server));
        let state = match &state_file {
            Some(f) => f.load(&config.server)?,
            None => ResumeState {
                server: config.server.clone(),
                ..ResumeState::default()
            },
        };
        Ok(SeedLinkClient {
            config,
            patterns,
            state,
            state_file,
            delivered: HashMap::new(),
            pending: std::collections::VecDeque::new(),
            counters: LinkCounters::default(),
            log: RateLimitedLog::with_interval(LOG_INTERVAL),
            late_stations: BTreeSet::new(),
            sequences: HashMap::new(),
            sequences_protocol: None,
            heard: BTreeSet::new(),
            last_packet: None,
            told: BTreeSet::new(),
        })
    }

    #[must_use]
    pub fn counters(&self) -> LinkCounters {
        self.counters
    }

    /// The resume state as it stands.
    #[must_use]
    pub fn state(&self) -> &ResumeState {
        &self.state
    }

    /// Runs until `stop` is set: connects, requests, passes every new record of a selected
    /// stream to `sink`, reconnects after failures. The state (what the sink has committed)
    /// is saved after every batch and durably on return.
    pub fn run(
        &mut self,
        stop: &AtomicBool,
        sink: &mut dyn RecordSink,
    ) -> Result<(), StateFileError> {
        let initial = Duration::from_secs_f64(self.config.reconnect_initial_s);
        let max = Duration::from_secs_f64(self.config.reconnect_max_s);
        let mut backoff = initial;
        while !stop.load(Ordering::Relaxed) {
            let delivered_before = self.counters.delivered;
            let result = self.session(stop, sink);
            sink.link(false);
            let _ = self.commit(sink);
            self.save(true)?;
            match result {
                Ok(()) => break,
                Err(e) => {
                    self.counters.disconnects += 1;
                    if self.counters.delivered > delivered_before {
                        backoff = initial;
                    }
                    tracing::warn!(
                        "seedlink {}: {}; reconnecting in {:.1} s",
                        self.config.server,
                        printable(&e.to_string(), SERVER_TEXT_CHARS),
                        backoff.as_secs_f64()
                    );
                    let until = Instant::now() + backoff;
                    while Instant::now() < until && !stop.load(Ordering::Relaxed) {
                        std::thread::sleep(
                            TICK.min(until.saturating_duration_since(Instant::now())),
                        );
                        // The sink reports the link down meanwhile.
                        sink.tick(&self.counters);
                    }
                    backoff = (backoff * 2).min(max);
                }
            }
        }
        let _ = self.commit(sink);
        self.save(true)
    }

    /// Moves what the sink has finished with from `pending` into the resume state; true if
    /// anything moved.
    fn commit(&mut self, sink: &dyn RecordSink) -> bool {
        let mut moved = false;
        while let Some(p) = self.pending.front() {
            if let Some(end) = p.held_until_ns {
                if sink.published_until_ns(&p.station).is_none_or(|t| t < end) {
                    break;
                }
            }
            if let Some(p) = self.pending.pop_front() {
                self.commit_one(&p);
                moved = true;
            }
        }
        moved
    }

    fn commit_one(&mut self, p: &Pending) {
        let latest = self
            .state
            .streams
            .entry(p.stream.clone())
            .or_insert(p.start_ns);
        *latest = (*latest).max(p.start_ns);
        // Committed: the stream resumes after its latest record from now on.
        self.state.received.remove(&p.stream);
        if let Some(sequence) = p.resume {
            self.state.stations.insert(
                p.station_key.clone(),
                StationResume {
                    sequence,
                    protocol: p.protocol,
                },
            );
        }
    }

    /// One connection, until `stop` (`Ok`) or a failure.
    fn session(&mut self, stop: &AtomicBool, sink: &mut dyn RecordSink) -> Result<(), LinkError> {
        let timeout = Duration::from_secs_f64(self.config.connect_timeout_s);
        if self.counters.connections == 0 {
            tracing::info!("seedlink {}: connecting", self.config.server);
        }
        let mut conn = Connection::open(&self.config.server, self.config.protocol, timeout)?;
        self.counters.connections += 1;
        let protocol = conn.protocol;
        tracing::info!(
            "seedlink {}: connected (connection {}), SeedLink {}{}",
            self.config.server,
            self.counters.connections,
            match protocol {
                Protocol::V3 => "3",
                Protocol::V4 => "4.0",
            },
            conn.server_started
                .as_deref()
                .map_or(String::new(), |t| format!(
                    ", server started {}",
                    printable(t, SERVER_TEXT_CHARS)
                ))
        );
        let restarted = match (&self.state.server_started, &conn.server_started) {
            (Some(before), Some(now)) => before != now,
            _ => false,
        };
        if restarted {
            self.counters.server_restarts += 1;
            tracing::info!(
                "seedlink {}: the server restarted (started {:?}, was {:?}): resuming by time",
                self.config.server,
                conn.server_started.as_deref().unwrap_or(""),
                self.state.server_started.as_deref().unwrap_or("")
            );
            // The old numbers mean nothing now.
            self.state.stations.clear();
            self.sequences.clear();
        }
        if self.sequences_protocol != Some(protocol) {
            self.sequences.clear();
            self.sequences_protocol = Some(protocol);
        }
        if conn.server_started.is_some() {
            self.state.server_started.clone_from(&conn.server_started);
        }
        let patterns = self.concrete_patterns(&mut conn, timeout)?;
        let saved = |p: &StreamPattern| saved_resume(&self.state, &self.late_stations, protocol, p);
        let fresh: Vec<StreamPattern> = patterns
            .iter()
            .filter(|p| p.exact_station().is_some() && saved(p) == Resume::Next)
            .cloned()
            .collect();
        let backfill = self.backfill_starts(&mut conn, &fresh, timeout)?;
        let state = &self.state;
        let late = &self.late_stations;
        let resume = |p: &StreamPattern| match saved_resume(state, late, protocol, p) {
            Resume::Next => p
                .exact_station()
                .and_then(|key| backfill.get(&key).copied())
                .map_or(Resume::Next, Resume::Since),
            other => other,
        };
        let by_sequence: BTreeMap<String, u64> = patterns
            .iter()
            .filter_map(|p| {
                let key = p.exact_station()?;
                match resume(p) {
                    Resume::After(seq) => Some((key, seq)),
                    _ => None,
                }
            })
            .collect();
        tracing::info!(
            "seedlink {}: requesting {}",
            self.config.server,
            resume_points(&patterns, &resume)
        );
        let refused = conn.request(&patterns, &resume, timeout)?;
        sink.link(true);
        for refused in refused {
            tracing::warn!(
                "seedlink {}: station refused: {}",
                self.config.server,
                printable(&refused, SERVER_TEXT_CHARS)
            );
        }
        let idle = Duration::from_secs_f64(self.config.idle_timeout_s);
        let refresh = Duration::from_secs_f64(self.config.station_refresh_s);
        let wildcards = self.patterns.iter().any(|p| p.exact_station().is_none());
        let mut last_refresh = Instant::now();
        let mut last_packet = Instant::now();
        let mut last_durable = Instant::now();
        let connected = Instant::now();
        self.heard.clear();
        self.last_packet = None;
        let mut resumes_checked = by_sequence.is_empty();
        loop {
            if stop.load(Ordering::Relaxed) {
                conn.close();
                return Ok(());
            }
            if wildcards && last_refresh.elapsed() >= refresh {
                last_refresh = Instant::now();
                if let Some(new) = self.new_stations(&patterns, timeout) {
                    conn.close();
                    return Err(LinkError::Resubscribe(format!(
                        "new stations match the streams ({new}): reconnecting to request them"
                    )));
                }
            }
            let before = self.counters.packets;
            let got = conn
                .poll_frames(TICK, &mut |frame| self.on_frame(protocol, frame, sink))
                .map_err(|e| self.connection_fault(e, conn.pending_bytes()))?;
            sink.tick(&self.counters);
            if !resumes_checked && connected.elapsed() > idle {
                resumes_checked = true;
                if let Some(e) = self.fall_back_to_time(&by_sequence) {
                    conn.close();
                    return Err(e);
                }
            }
            if got {
                last_packet = Instant::now();
            } else if last_packet.elapsed() > idle {
                let timeout =
                    LinkError::Timeout(format!("no packet for {} s", self.config.idle_timeout_s));
                return Err(self.connection_fault(timeout, conn.pending_bytes()));
            }
            let committed = self.commit(sink);
            if self.counters.packets > before || committed {
                let durable = last_durable.elapsed() >= DURABLE_EVERY;
                self.save(durable)
                    .map_err(|e| LinkError::Io(e.to_string()))?;
                if durable {
                    last_durable = Instant::now();
                }
            }
        }
    }

    /// Where each station of `fresh` (concrete patterns with no resume point) starts:
    /// `backfill_s` before the newest data of its selected streams in the server's ring
    /// (`INFO STREAMS` `end_time`), as `NET_STA` → ns since the epoch. Stations it cannot
    /// place start from the server's next record, said once: `backfill_s = 0`, a server
    /// refusing `INFO STREAMS`, a station with no stream (or no `end_time`) in the answer;
    /// an answer that cannot be read is logged naming the server and counted
    /// (`unreadable_info`). Only the connection's own failures are errors.
    fn backfill_starts(
        &mut self,
        conn: &mut Connection,
        fresh: &[StreamPattern],
        timeout: Duration,
    ) -> Result<BTreeMap<String, i64>, LinkError> {
        let mut starts = BTreeMap::new();
        if fresh.is_empty() || self.config.backfill_s == 0.0 {
            return Ok(starts);
        }
        let spans: Vec<StreamSpan> = match conn.query_streams(timeout)? {
            Some(Ok(spans)) => spans,
            Some(Err(e)) => {
                self.counters.unreadable_info += 1;
                self.log_once(
                    "unreadable INFO STREAMS",
                    "INFO STREAMS".into(),
                    &format!(
                        "{}: stations without a resume point start from the server's next record",
                        printable(&e.to_string(), SERVER_TEXT_CHARS)
                    ),
                );
                return Ok(starts);
            }
            None => {
                self.tell_once(
                    "INFO STREAMS",
                    &format!(
                        "seedlink {}: the server refuses INFO STREAMS: stations without a resume point start from its next record (backfill_s = {} s not applied)",
                        self.config.server, self.config.backfill_s
                    ),
                );
                return Ok(starts);
            }
        };
        let backfill_ns = (self.config.backfill_s * 1e9).round() as i64;
        for p in fresh {
            let Some(key) = p.exact_station() else {
                continue;
            };
            let newest = spans
                .iter()
                .filter(|s| p.matches(&s.network, &s.station, &s.location, &s.channel))
                .filter_map(|s| s.end_ns)
                .min();
            let Some(end) = newest else {
                self.tell_once(
                    &format!("no span {key}"),
                    &format!(
                        "seedlink {}: station {}: no selected stream with an end time in the server's INFO STREAMS answer: it starts from the server's next record (backfill_s not applied)",
                        self.config.server,
                        printable(&key, STATION_CHARS)
                    ),
                );
                continue;
            };
            let from = end.saturating_sub(backfill_ns);
            let earlier = starts.get(&key).copied().unwrap_or(from);
            starts.insert(key.clone(), earlier.min(from));
            tracing::info!(
                "seedlink {}: station {} has no resume point: backfilling {} s before the newest data the server holds of its streams ({}), from {}",
                self.config.server,
                printable(&key, STATION_CHARS),
                self.config.backfill_s,
                rockwatch_core::utc::format_utc_ns(i128::from(end)),
                rockwatch_core::utc::format_utc_ns(i128::from(earlier.min(from)))
            );
        }
        Ok(starts)
    }

    /// Logs `line` at info level the first time `key` comes up in this run.
    fn tell_once(&mut self, key: &str, line: &str) {
        if self.told.insert(key.to_string()) {
            tracing::info!("{line}");
        }
    }

    /// A connection's failure, counted and told in full: bytes that are not a packet
    /// (`protocol_errors`), or an end — closed, or silent — in the middle of a packet
    /// (`partial_packets`; `partial` bytes of it had arrived). Both name the last packet
    /// received before (its station and number), which is where the stream resumes.
    fn connection_fault(&mut self, error: LinkError, partial: usize) -> LinkError {
        let after = match &self.last_packet {
            Some(p) => format!("after {p}"),
            None => "before any data packet of this connection".to_string(),
        };
        match error {
            LinkError::Protocol(problem) => {
                self.counters.protocol_errors += 1;
                LinkError::Protocol(format!(
                    "{problem} ({after}; counted: dropping the connection)"
                ))
            }
            LinkError::Eof if partial > 0 => {
                self.counters.partial_packets += 1;
                LinkError::Io(format!(
                    "the server closed the connection in the middle of a packet ({partial} bytes of it received, dropped; {after}; counted)"
                ))
            }
            LinkError::Timeout(problem) if partial > 0 => {
                self.counters.partial_packets += 1;
                LinkError::Timeout(format!(
                    "{problem} in the middle of a packet ({partial} bytes of it received, dropped; {after}; counted)"
                ))
            }
            other => other,
        }
    }

    /// Stations resumed by sequence number (`by_sequence`) of which nothing arrived within
    /// `idle_timeout_s`: the number is one the server does not hold (a far-ahead number saved
    /// before, a renumbered ring). Their number is dropped, so the next connection resumes
    /// them by time (duplicates dropped); logged per station, counted. Returns the error that
    /// ends the connection when there are any.
    fn fall_back_to_time(&mut self, by_sequence: &BTreeMap<String, u64>) -> Option<LinkError> {
        let silent: Vec<(&String, &u64)> = by_sequence
            .iter()
            .filter(|(key, _)| !self.heard.contains(*key))
            .collect();
        if silent.is_empty() {
            return None;
        }
        for (key, seq) in &silent {
            self.counters.resume_fallbacks += 1;
            self.state.stations.remove(*key);
            self.sequences.remove(*key);
            tracing::warn!(
                "seedlink {}: station {}: nothing after sequence number {seq} for {} s: resuming it by time from its latest record (counted)",
                self.config.server,
                printable(key, STATION_CHARS),
                self.config.idle_timeout_s
            );
        }
        let names: Vec<&str> = silent.iter().map(|(k, _)| k.as_str()).collect();
        Some(LinkError::Resubscribe(format!(
            "resuming {} by time",
            printable(&names.join(", "), SERVER_TEXT_CHARS)
        )))
    }

    /// The configured patterns with wildcard stations expanded over the server's station
    /// list (`INFO STATIONS`), so every station is requested on its own and resumes from its
    /// own sequence number. A server that refuses INFO STATIONS gets the wildcard patterns
    /// (those stations then start from what the server sends next; logged once).
    fn concrete_patterns(
        &mut self,
        conn: &mut Connection,
        timeout: Duration,
    ) -> Result<Vec<StreamPattern>, LinkError> {
        if self.patterns.iter().all(|p| p.exact_station().is_some()) {
            return Ok(self.patterns.clone());
        }
        let Some(stations) = conn.query_stations(timeout)? else {
            self.log_once(
                "info",
                "INFO STATIONS".into(),
                "the server refuses INFO STATIONS: wildcard stations are requested as patterns and cannot resume by sequence number",
            );
            return Ok(self.patterns.clone());
        };
        let expanded = expand(&self.patterns, &stations);
        let unmatched: Vec<String> = self
            .patterns
            .iter()
            .filter(|p| {
                p.exact_station().is_none()
                    && !stations.iter().any(|(n, s)| p.matches_station(n, s))
            })
            .map(|p| format!("{}.{}", p.network, p.station))
            .collect();
        for key in unmatched {
            self.log_once(
                "no station",
                key,
                "no station of the server matches this pattern (yet)",
            );
        }
        if expanded.is_empty() {
            return Err(LinkError::Refused(
                "no station of the server matches the streams".into(),
            ));
        }
        Ok(expanded)
    }

    /// Stations matching a wildcard pattern that `current` does not request, from a second
    /// short connection; `None` when there are none or the server cannot say (logged).
    fn new_stations(&mut self, current: &[StreamPattern], timeout: Duration) -> Option<String> {
        let result = Connection::open(&self.config.server, self.config.protocol, timeout).and_then(
            |mut c| {
                let stations = c.query_stations(timeout);
                c.close();
                stations
            },
        );
        let stations = match result {
            Ok(Some(s)) => s,
            Ok(None) => return None,
            Err(e) => {
                tracing::warn!(
                    "seedlink {}: cannot look for new stations: {}",
                    self.config.server,
                    printable(&e.to_string(), SERVER_TEXT_CHARS)
                );
                return None;
            }
        };
        let new: Vec<String> = expand(&self.patterns, &stations)
            .into_iter()
            .filter(|p| !current.contains(p))
            .map(|p| {
                if let Some(key) = p.exact_station() {
                    self.late_stations.insert(key);
                }
                format!("{}.{}", p.network, p.station)
            })
            .collect();
        (!new.is_empty()).then(|| printable(&new.join(", "), SERVER_TEXT_CHARS))
    }

    /// Judges and delivers one packet.
    fn on_frame(&mut self, protocol: Protocol, frame: Frame<'_>, sink: &mut dyn RecordSink) {
        self.counters.packets += 1;
        if !frame.is_miniseed_data() {
            self.counters.other_packets += 1;
            return;
        }
        // `None`: a v3 number that cannot be read (the record goes by its start time only).
        let sequence = frame.sequence;
        let label = match (sequence, frame.unreadable_sequence) {
            (Some(n), _) => n.to_string(),
            (None, text) => format!(
                "with the unreadable number {:?}",
                printable(&String::from_utf8_lossy(text.unwrap_or_default()), 16)
            ),
        };
        let source = format!("seedlink {} packet {label}", self.config.server);
        let file = match parse_mseed(frame.payload, Path::new(&source)) {
            Ok(f) => f,
            Err(e) => {
                // Named by the stream its header gives, if any (the v3 packet does not say).
                let stream = record_stream_id(frame.payload)
                    .or_else(|| (!frame.station.is_empty()).then(|| frame.station.to_string()))
                    .unwrap_or_else(|| "(unknown stream)".into());
                self.counters.malformed += 1;
                self.last_packet = Some(format!(
                    "station {}'s packet {label}",
                    printable(&stream, STATION_CHARS)
                ));
                let message = format!(
                    "station {}: packet {label}: record dropped, it cannot be decoded: {}",
                    printable(&stream, STATION_CHARS),
                    e.problem
                );
                self.log_once("malformed", stream, &message);
                return;
            }
        };
        if sequence.is_none() {
            self.counters.unreadable_sequences += 1;
        }
        for channel in &file.channels {
            let id = channel.id();
            if !self
                .patterns
                .iter()
                .any(|p| p.matches(&channel.net, &channel.sta, &channel.loc, &channel.cha))
            {
                self.counters.unselected += 1;
                self.log_once(
                    "unselected",
                    id,
                    "stream not selected by any pattern; dropped",
                );
                continue;
            }
            let Some(start_ns) = channel.segments.first().map(|s| s.start_time_ns) else {
                continue;
            };
            let key = format!("{}_{}", channel.net, channel.sta);
            if !self.heard.contains(&key) {
                self.heard.insert(key.clone());
            }
            self.last_packet = Some(format!(
                "station {}'s packet {label}",
                printable(&key, STATION_CHARS)
            ));
            if sequence.is_none() {
                self.log_once(
                    "unreadable sequence",
                    key.clone(),
                    &format!(
                        "station {}: packet {label}: its record {id} goes by its start time (a duplicate if delivered before), never a resume point",
                        printable(&key, STATION_CHARS)
                    ),
                );
            }
            let saved = self
                .state
                .stations
                .get(&key)
                .filter(|s| s.protocol == protocol)
                .map(|s| s.sequence);
            let station = *self
                .sequences
                .entry(key.clone())
                .or_insert_with(|| StationSequence::resumed(saved));
            let latest = self.state.streams.get(&id).copied();
            let delivered = self
                .delivered
                .entry(id.clone())
                .or_insert_with(|| DeliveredStarts::from_latest(latest));
            let verdict = match sequence {
                Some(seq) => judge(protocol, &station, seq, delivered, start_ns),
                None if delivered.contains(start_ns) => Verdict::Duplicate,
                None => Verdict::Deliver { missing: 0 },
            };
            if verdict == Verdict::Duplicate {
                self.counters.duplicates += 1;
                continue;
            }
            let taken = sink.record(channel);
            if taken == Taken::Refused {
                // Not delivered: its start time is not remembered (a clean copy is still
                // taken), and neither its number nor its time becomes a resume point.
                self.counters.refused += 1;
                continue;
            }
            delivered.insert(start_ns);
            self.counters.delivered += 1;
            if !self.state.streams.contains_key(&id) {
                // Nothing of the stream committed yet: its resume point is this record (or
                // an earlier one received), saved with the next batch, so an `acquire`
                // killed before publishing it fetches it again.
                let first = self.state.received.entry(id.clone()).or_insert(start_ns);
                *first = (*first).min(start_ns);
            }
            let tracker = self.sequences.entry(key.clone()).or_default();
            let (undone, resume) = match sequence {
                Some(seq) => (
                    tracker.accept(protocol, seq, verdict),
                    tracker.resume_point(),
                ),
                // Unnumbered: the numbering is not touched, nor the resume point.
                None => (0, None),
            };
            match verdict {
                Verdict::Duplicate => {}
                Verdict::Deliver { missing } => self.counters.missing_sequences += missing,
                Verdict::DeliverAfterReset => {
                    self.counters.server_resets += 1;
                    // Rate-limited per station (it was logged per packet when a server kept
                    // renumbering, issue 24 item 8); every one is counted.
                    let line = format!(
                        "seedlink {}: station {}: sequence {label} after {} with new data: the server restarted its numbering (counted; logged at most once a minute)",
                        self.config.server,
                        printable(&key, STATION_CHARS),
                        station.last().unwrap_or(0)
                    );
                    self.log.log(&key, "server reset", &line);
                }
                Verdict::DeliverAfterOutlier { odd } => {
                    self.counters.sequence_outliers += 1;
                    self.counters.missing_sequences =
                        self.counters.missing_sequences.saturating_sub(undone);
                    let line = format!(
                        "seedlink {}: station {}: sequence number {odd} was out of line (new data numbered {label} follows {}): one odd number, not a server restart; never a resume point (counted; logged at most once a minute)",
                        self.config.server,
                        printable(&key, STATION_CHARS),
                        station.resume_point().unwrap_or(0)
                    );
                    self.log.log(&key, "sequence outlier", &line);
                }
                Verdict::DeliverReordered => self.counters.reordered += 1,
            }
            let samples: usize = channel.segments.iter().map(|s| s.samples.len()).sum();
            let held = taken == Taken::Held;
            let pending = Pending {
                station_key: key,
                station: format!("{}.{}.{}", channel.net, channel.sta, channel.loc),
                stream: id,
                resume: verdict.advances_sequence().then_some(resume).flatten(),
                protocol,
                start_ns,
                held_until_ns: held.then(|| {
                    start_ns
                        + (samples as f64 * 1e9 / channel.sample_rate_hz.max(1e-9)).round() as i64
                }),
            };
            if held || !self.pending.is_empty() {
                // Held, or behind a held record: committed in order.
                self.pending.push_back(pending);
            } else {
                self.commit_one(&pending);
            }
        }
    }

    fn save(&self, durable: bool) -> Result<(), StateFileError> {
        match &self.state_file {
            Some(file) => file.save(&self.state, durable),
            None => Ok(()),
        }
    }

    fn log_once(&mut self, kind: &'static str, key: String, message: &str) {
        let line = format!(
            "seedlink {}: {message} (counted; logged at most once a minute)",
            self.config.server
        );
        self.log.log(&key, kind, &line);
    }
}
