//! The process's log: `tracing` events of rockwatch, of ros2-client (which logs through
//! `tracing`) and the `log` records of RustDDS and iceoryx2 (bridged by `tracing-log`), as
//! human lines or one JSON object per line on stderr.
//!
//! - **Levels**: `--log-level FILTER`, else `RUST_LOG`, else `ROCKWATCH_LOG` (a single level
//!   for every target, the older variable), else the default [`DEFAULT_FILTER`]: rockwatch's
//!   own lines from `info` up, the libraries' errors only (RustDDS's warnings are chatty in
//!   normal operation). A filter is `tracing-subscriber`'s `EnvFilter` syntax: `debug`, or
//!   `rockwatch=debug,rustdds=warn`.
//! - **Formats** ([`LogFormat`]): `text` (the default), one line per record:
//!   `rockwatch: [error: |warning: |debug: |trace: ]message` (a library's line names its
//!   target: `rockwatch: error: rustdds::…: message`); `json`, for log shippers: one object
//!   per line, `{"timestamp": RFC 3339 UTC, "level", "target", "fields": {"message", …}}`.
//!   Text lines carry the message only; the structured fields (an alert's `pbr_id`,
//!   `latency_ms`, …) are in the JSON objects.
//! - **Muting** ([`MuteLibraries`]): while a guard lives, the libraries' records (not
//!   rockwatch's) are dropped: a DDS participant's teardown logs an error per endpoint.
//! - **Expected noise** ([`EXPECTED_NOISE`], [`expect`]): a library's warnings that a
//!   configuration makes expected (RustDDS's "No locators for RtpsReaderProxy" on a
//!   loopback-only DDS domain, set by the ROS 2 session) are written at debug; the first one
//!   that would have been written is replaced by one line of ours saying what it means.
//! - **Floods** ([`LibraryLog`]): a library's call site (target, file, line) writes at most
//!   [`LIBRARY_BURST`] records per [`LIBRARY_WINDOW`]; the next record it lets through is
//!   preceded by a line saying how many were dropped. A library stuck in a loop (RustDDS logs
//!   an error every 100 ms while it waits for a lock, or per packet it cannot encode) can
//!   neither fill a disk nor drown the node's own lines.
//! - **Never blocked by stderr** ([`init_queued`], for the long-running `node` and `acquire`):
//!   a record is formatted by the thread that logs and queued (bounded, [`LOG_QUEUE`]); the
//!   thread `rockwatch-log` writes the queue to stderr. If stderr does not keep up (a pipe
//!   nobody reads, a stuck log shipper), records are dropped and counted, and the next line
//!   written says how many: the engine and the DDS threads never wait for stderr (with a
//!   blocking stderr, a full 64 KiB pipe stalled every thread of the process that logs).
//!   [`flush`] before the process ends (a panic flushes, for at most 1 s, before its message).
//! - **`/rosout`** ([`enable_rosout`], [`take_rosout`]): rockwatch's own records at or above
//!   a level are also queued (bounded) for the node's event loop, which publishes them as
//!   `rcl_interfaces/msg/Log` on its own thread (no record is ever published from a DDS
//!   thread, so a library's record cannot deadlock RustDDS).
//!
//! Cost: a disabled level costs one cached check per call site; records are formatted only
//! when enabled. The node logs per alert and per event (a station going silent), never per
//! sample.

use std::collections::{HashMap, VecDeque};
use std::fmt;
use std::sync::atomic::{AtomicU64, AtomicU8, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use crate::log_text::{printable, MESSAGE_CHARS, STATION_CHARS};

use tracing::field::{Field, Visit};
use tracing::subscriber::Interest;
use tracing::{Event, Level, Metadata, Subscriber};
use tracing_subscriber::filter::EnvFilter;
use tracing_subscriber::fmt::format::Writer;
use tracing_subscriber::fmt::{FmtContext, FormatEvent, FormatFields};
use tracing_subscriber::layer::{Context, Layer, SubscriberExt};
use tracing_subscriber::registry::LookupSpan;

/// The older environment variable of the log level: one level for every target.
pub const LOG_ENV: &str = "ROCKWATCH_LOG";

/// The filter without `--log-level`, `RUST_LOG` or `ROCKWATCH_LOG`.
pub const DEFAULT_FILTER: &str = "error,rockwatch=info";

/// The default filter of `rockwatch demo`: [`DEFAULT_FILTER`] without the node's alert lines
/// (target `rockwatch::alert`), which the demo shows in its own table; their "data → arrival"
/// figure (the replay's clock, not a latency) interleaved with it (issue 20 item 9).
/// `--log-level rockwatch=info` brings them back.
pub const DEMO_FILTER: &str = "error,rockwatch=info,rockwatch::alert=off";

/// How records are written on stderr.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum LogFormat {
    /// Human lines: `rockwatch: [level: ]message`.
    #[default]
    Text,
    /// One JSON object per line (timestamp, level, target, fields), for log shippers.
    Json,
}

/// Where the levels and the format come from.
#[derive(Debug, Clone, Default)]
pub struct LogOptions {
    /// `--log-level`: an `EnvFilter` (a level, or `target=level,…`); wins over the variables.
    pub level: Option<String>,
    pub format: LogFormat,
}

/// Open [`MuteLibraries`] guards: while any is, the libraries' records are dropped.
static MUTED: AtomicUsize = AtomicUsize::new(0);

/// While this guard lives, the libraries' log records (not rockwatch's) are dropped: for the
/// teardown of a DDS participant, where RustDDS reports every endpoint it cannot remove from
/// an event loop that has ended (or every multicast group it leaves) at error level.
#[derive(Debug)]
pub struct MuteLibraries(());

impl MuteLibraries {
    #[must_use]
    pub fn new() -> MuteLibraries {
        MUTED.fetch_add(1, Ordering::Relaxed);
        MuteLibraries(())
    }
}

impl Default for MuteLibraries {
    fn default() -> Self {
        Self::new()
    }
}

impl Drop for MuteLibraries {
    fn drop(&mut self) {
        MUTED.fetch_sub(1, Ordering::Relaxed);
    }
}

/// Whether a target is rockwatch's own (the library, the binary, `rockwatch::…`).
fn own(target: &str) -> bool {
    target.starts_with("rockwatch")
}

/// The layer of [`MuteLibraries`]: the libraries' call sites are checked at every record
/// (`Interest::sometimes`), rockwatch's are never muted.
struct Mute;

impl<S: Subscriber> Layer<S> for Mute {
    fn register_callsite(&self, metadata: &'static Metadata<'static>) -> Interest {
        if own(metadata.target()) {
            Interest::always()
        } else {
            Interest::sometimes()
        }
    }

    fn enabled(&self, metadata: &Metadata<'_>, _: Context<'_, S>) -> bool {
        own(metadata.target()) || MUTED.load(Ordering::Relaxed) == 0
    }
}

/// The log could not be installed.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// `--log-level` is not a filter.
    #[error(
        "--log-level {level:?} is not a log filter ({error}): give a level (error, warn, info, \
         debug, trace, off) or target=level pairs, e.g. rockwatch=debug,rustdds=warn"
    )]
    BadLevel {
        level: String,
        error: tracing_subscriber::filter::ParseError,
    },
}

/// The filter in force: `--log-level`, else `RUST_LOG`, else `ROCKWATCH_LOG`, else
/// [`DEFAULT_FILTER`]. A bad `--log-level` is an error; a bad variable is reported (returned
/// as a warning) and the default used.
fn filter(options: &LogOptions) -> Result<(EnvFilter, Option<String>), LogError> {
    if let Some(level) = &options.level {
        return EnvFilter::builder()
            .parse(level)
            .map(|f| (f, None))
            .map_err(|error| LogError::BadLevel {
                level: level.clone(),
                error,
            });
    }
    for var in ["RUST_LOG", LOG_ENV] {
        let Ok(value) = std::env::var(var) else {
            continue;
        };
        return match EnvFilter::builder().parse(&value) {
            Ok(f) => Ok((f, None)),
            Err(e) => Ok((
                EnvFilter::new(DEFAULT_FILTER),
                Some(format!(
                    "{var}={value:?} is not a log filter ({e}): using the default ({DEFAULT_FILTER})"
                )),
            )),
        };
    }
    Ok((EnvFilter::new(DEFAULT_FILTER), None))
}

/// Installs the process's log (once; a second call does nothing): stderr in `options.format`,
/// the `log` records of the libraries bridged in. Errors: a `--log-level` that is not a
/// filter.
pub fn init(options: &LogOptions) -> Result<(), LogError> {
    init_with_writer(options, std::io::stderr)
}

/// Records waiting for the thread `rockwatch-log` at most ([`init_queued`]); beyond, records
/// are dropped and counted.
pub const LOG_QUEUE: usize = 8192;

/// Records queued for and written by `rockwatch-log`, and dropped (queue full).
static QUEUED: AtomicU64 = AtomicU64::new(0);
static WRITTEN: AtomicU64 = AtomicU64::new(0);
static DROPPED: AtomicU64 = AtomicU64::new(0);
static QUEUE: std::sync::OnceLock<std::sync::mpsc::SyncSender<Vec<u8>>> =
    std::sync::OnceLock::new();

/// As [`init`], with stderr written by the thread `rockwatch-log` from a bounded queue: no
/// thread that logs ever waits for stderr (see the module documentation). The thread blocks
/// the stop signals (they are the signal thread's, `crate::signals`).
pub fn init_queued(options: &LogOptions) -> Result<(), LogError> {
    let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<u8>>(LOG_QUEUE);
    let spawned = std::thread::Builder::new()
        .name("rockwatch-log".into())
        .spawn(move || {
            use std::io::Write as _;
            let mut signals = nix::sys::signal::SigSet::empty();
            for s in crate::signals::STOP_SIGNALS {
                signals.add(s);
            }
            let _ = signals.thread_block();
            let mut reported = 0;
            while let Ok(line) = rx.recv() {
                let mut stderr = std::io::stderr().lock();
                let dropped = DROPPED.load(Ordering::Relaxed);
                if dropped > reported {
                    let _ = writeln!(
                        stderr,
                        "rockwatch: warning: {} log records dropped: stderr did not keep up",
                        dropped - reported
                    );
                    reported = dropped;
                }
                let _ = stderr.write_all(&line);
                WRITTEN.fetch_add(1, Ordering::Release);
            }
        });
    match spawned {
        Ok(_) => {
            let _ = QUEUE.set(tx);
            // A panic's message is written in place: the records queued before it first.
            let report = std::panic::take_hook();
            std::panic::set_hook(Box::new(move |info| {
                flush(std::time::Duration::from_secs(1));
                report(info);
            }));
            init_with_writer(options, || QueuedLine(Vec::with_capacity(256)))
        }
        // No thread: stderr written in place.
        Err(_) => init(options),
    }
}

/// Waits (at most `timeout`) until every record queued for `rockwatch-log` is written.
pub fn flush(timeout: std::time::Duration) {
    let deadline = std::time::Instant::now() + timeout;
    while WRITTEN.load(Ordering::Acquire) < QUEUED.load(Ordering::Acquire)
        && std::time::Instant::now() < deadline
    {
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
}

/// One formatted record, queued for `rockwatch-log` when dropped.
struct QueuedLine(Vec<u8>);

impl std::io::Write for QueuedLine {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        self.0.extend_from_slice(bytes);
        Ok(bytes.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Drop for QueuedLine {
    fn drop(&mut self) {
        if self.0.is_empty() {
            return;
        }
        let line = std::mem::take(&mut self.0);
        let Some(queue) = QUEUE.get() else {
            use std::io::Write as _;
            let _ = std::io::stderr().write_all(&line);
            return;
        };
        // Counted before it is sent, so that `flush` never sees it written but not queued.
        QUEUED.fetch_add(1, Ordering::AcqRel);
        if queue.try_send(line).is_err() {
            QUEUED.fetch_sub(1, Ordering::AcqRel);
            DROPPED.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// As [`init`], writing to `writer` instead of stderr (tests).
pub fn init_with_writer<W>(options: &LogOptions, writer: W) -> Result<(), LogError>
where
    W: for<'w> tracing_subscriber::fmt::MakeWriter<'w> + Send + Sync + 'static,
{
    let (filter, warning) = filter(options)?;
    // The `log` records (RustDDS, iceoryx2) go through the same filter; `log`'s own
    // max level cuts the ones no directive can enable before any formatting.
    let max = match filter.max_level_hint() {
        Some(tracing::level_filters::LevelFilter::OFF) => log::LevelFilter::Off,
        Some(tracing::level_filters::LevelFilter::ERROR) => log::LevelFilter::Error,
        Some(tracing::level_filters::LevelFilter::WARN) => log::LevelFilter::Warn,
        Some(tracing::level_filters::LevelFilter::INFO) => log::LevelFilter::Info,
        Some(tracing::level_filters::LevelFilter::DEBUG) => log::LevelFilter::Debug,
        _ => log::LevelFilter::Trace,
    };
    let registry = tracing_subscriber::registry()
        .with(filter)
        .with(Mute)
        .with(RosoutLayer);
    // `set_global_default`, not `try_init`: with tracing-subscriber's `tracing-log` feature,
    // `try_init` installs its own `log` logger (a bare LogTracer), and then `LibraryLog` (the
    // flood limit, the expected noise) could not be installed.
    let installed = match options.format {
        LogFormat::Text => tracing::subscriber::set_global_default(
            registry.with(
                tracing_subscriber::fmt::layer()
                    .with_writer(writer)
                    .event_format(TextLine),
            ),
        ),
        LogFormat::Json => tracing::subscriber::set_global_default(
            registry.with(
                tracing_subscriber::fmt::layer()
                    .json()
                    .with_writer(writer)
                    .with_current_span(false)
                    .with_span_list(false),
            ),
        ),
    };
    if installed.is_ok() {
        // Fails only if a `log` logger is installed already (then theirs stays).
        if log::set_boxed_logger(Box::new(LibraryLog::default())).is_ok() {
            log::set_max_level(max);
        }
        if let Some(w) = warning {
            tracing::warn!(target: "rockwatch::logging", "{w}");
        }
    }
    Ok(())
}

/// Records a library call site may write per [`LIBRARY_WINDOW`] (see [`LibraryLog`]).
pub const LIBRARY_BURST: u32 = 10;

/// See [`LIBRARY_BURST`].
pub const LIBRARY_WINDOW: std::time::Duration = std::time::Duration::from_secs(10);

/// Call sites [`FloodLimit`] remembers; past this, new sites share one budget (bounded memory
/// whatever a library logs).
const LIBRARY_SITES: usize = 1024;

/// A call site of a library's `log` records.
type Site = (String, Option<&'static str>, Option<u32>);

/// Per call site, at most [`LIBRARY_BURST`] records per [`LIBRARY_WINDOW`].
#[derive(Debug, Default)]
struct FloodLimit {
    /// Per site: start of its window, records let through in it, records dropped since the
    /// last one let through.
    sites: HashMap<Site, (std::time::Instant, u32, u64)>,
}

impl FloodLimit {
    /// Whether a record of `site` at `now` may be written; `Some(n)`: yes, `n` records of the
    /// site were dropped before it.
    fn admit(&mut self, mut site: Site, now: std::time::Instant) -> Option<u64> {
        if self.sites.len() >= LIBRARY_SITES && !self.sites.contains_key(&site) {
            site = ("(other call sites)".into(), None, None);
        }
        let (start, passed, dropped) = self.sites.entry(site).or_insert((now, 0, 0));
        if now.duration_since(*start) >= LIBRARY_WINDOW {
            *start = now;
            *passed = 0;
        }
        if *passed < LIBRARY_BURST {
            *passed += 1;
            Some(std::mem::take(dropped))
        } else {
            *dropped += 1;
            None
        }
    }
}

/// The `log` logger of the process: the libraries' records (RustDDS, iceoryx2) go to
/// `tracing` as `tracing_log::LogTracer` sends them, each call site within [`FloodLimit`].
#[derive(Default)]
pub struct LibraryLog {
    bridge: tracing_log::LogTracer,
    limit: Mutex<FloodLimit>,
}

impl log::Log for LibraryLog {
    fn enabled(&self, metadata: &log::Metadata<'_>) -> bool {
        self.bridge.enabled(metadata)
    }

    fn log(&self, record: &log::Record<'_>) {
        if !self.bridge.enabled(record.metadata()) {
            return;
        }
        if let Some(noise) = expected_noise(record) {
            noise.explain_once(record);
            // The same record at debug: shown only where debug is asked for.
            let demoted = log::Record::builder()
                .args(*record.args())
                .level(log::Level::Debug)
                .target(record.target())
                .module_path_static(record.module_path_static())
                .file_static(record.file_static())
                .line(record.line())
                .build();
            if self.bridge.enabled(demoted.metadata()) {
                self.admit_and_log(&demoted);
            }
            return;
        }
        self.admit_and_log(record);
    }

    fn flush(&self) {}
}

impl LibraryLog {
    /// Writes `record` within its call site's [`FloodLimit`].
    fn admit_and_log(&self, record: &log::Record<'_>) {
        let site = (
            record.target().to_owned(),
            record.file_static(),
            record.line(),
        );
        // The lock is held for the count only, never while a record is written.
        let admitted = match self.limit.lock() {
            Ok(mut limit) => limit.admit(site, std::time::Instant::now()),
            Err(_) => Some(0),
        };
        match admitted {
            Some(0) => log::Log::log(&self.bridge, record),
            Some(dropped) => {
                tracing::warn!(
                    target: "rockwatch::logging",
                    "{dropped} more lines of {} ({}:{}) were dropped (at most {LIBRARY_BURST} per {} s per call site)",
                    record.target(),
                    record.file().unwrap_or("?"),
                    record.line().unwrap_or(0),
                    LIBRARY_WINDOW.as_secs()
                );
                log::Log::log(&self.bridge, record);
            }
            None => {}
        }
    }
}

/// A configuration in which some library records are expected ([`expect`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expectation {
    /// A DDS participant on loopback interfaces only (`ROS_AUTOMATIC_DISCOVERY_RANGE` =
    /// `LOCALHOST` or `OFF`, `[ros2] discovery_range`): set by `ros2::Ros2Session::open`.
    LoopbackOnlyDds = 0,
}

impl Expectation {
    /// The configuration in words, after "expected".
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Expectation::LoopbackOnlyDds => {
                "on a loopback-only DDS domain (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, \
                 [ros2] discovery_range = \"LOCALHOST\")"
            }
        }
    }
}

/// The [`Expectation`]s in force, one bit each.
static EXPECTED: AtomicU8 = AtomicU8::new(0);

/// From now on the process runs in `expectation`: the library records it makes expected
/// ([`EXPECTED_NOISE`]) are kept at debug, and explained once.
pub fn expect(expectation: Expectation) {
    EXPECTED.fetch_or(1 << expectation as u8, Ordering::Relaxed);
}

/// A library's record that is expected in a configuration: there it is written at debug
/// (seen with e.g. `RUST_LOG=rustdds=debug`), and the first one that would have been written
/// at its own level is replaced by one line of ours, at that level, saying what it means.
#[derive(Debug)]
pub struct ExpectedNoise {
    /// The configuration in which it is expected.
    pub when: Expectation,
    /// The record's target starts with this, and its message with `message`.
    pub target: &'static str,
    pub message: &'static str,
    /// What it means there (our line; the library's message is quoted before it).
    pub meaning: &'static str,
    /// Our line has been written.
    said: std::sync::atomic::AtomicBool,
}

impl ExpectedNoise {
    const fn new(
        when: Expectation,
        target: &'static str,
        message: &'static str,
        meaning: &'static str,
    ) -> ExpectedNoise {
        ExpectedNoise {
            when,
            target,
            message,
            meaning,
            said: std::sync::atomic::AtomicBool::new(false),
        }
    }

    /// Writes our line the first time (at `record`'s level, target `rockwatch::logging`).
    fn explain_once(&self, record: &log::Record<'_>) {
        if self.said.swap(true, Ordering::Relaxed) {
            return;
        }
        let (target, message, meaning) = (self.target, self.message, self.meaning);
        let line = format!(
            "library noise: \"{message} …\" ({target}) is expected {}: {meaning}. These \
             lines are kept at debug (RUST_LOG={}=debug shows them)",
            self.when.describe(),
            target.split("::").next().unwrap_or(target)
        );
        match record.level() {
            log::Level::Error => tracing::error!(target: "rockwatch::logging", "{line}"),
            log::Level::Warn => tracing::warn!(target: "rockwatch::logging", "{line}"),
            _ => tracing::info!(target: "rockwatch::logging", "{line}"),
        }
    }
}

/// The library records expected in a configuration (see [`ExpectedNoise`]). RustDDS 0.15 on a
/// loopback-only participant:
/// - `No locators for RtpsReaderProxy`: a peer on this host that advertises only loopback
///   addresses is sent to on 127.0.0.1 once one of its packets has shown that it is on this
///   host; until then each send to it finds no other address and says so;
/// - `No multicast joins succeeded`: the loopback interface takes no multicast; participants on
///   it find each other through the discovery ports on 127.0.0.1;
/// - `Message size = N` (`send_to_locator`, `try_send_to_locator`): a datagram above 1500
///   bytes, an Ethernet MTU; loopback's MTU is 65536.
pub static EXPECTED_NOISE: [ExpectedNoise; 4] = [
    ExpectedNoise::new(
        Expectation::LoopbackOnlyDds,
        "rustdds::rtps::writer",
        "send_message_to_readers: No locators for",
        "a peer on this host that advertises only loopback addresses is sent to on \
         127.0.0.1 once one of its packets has shown that it is on this host; until then \
         RustDDS finds no other address for it and says so at each send",
    ),
    ExpectedNoise::new(
        Expectation::LoopbackOnlyDds,
        "rustdds::network::udp_listener",
        "No multicast joins succeeded",
        "the loopback interface takes no multicast, and loopback-only participants find each \
         other through the DDS discovery ports on 127.0.0.1",
    ),
    ExpectedNoise::new(
        Expectation::LoopbackOnlyDds,
        "rustdds::network::udp_sender",
        "send_to_locator: Message size",
        "RustDDS notes datagrams above 1500 bytes (an Ethernet MTU); loopback's MTU is 65536",
    ),
    ExpectedNoise::new(
        Expectation::LoopbackOnlyDds,
        "rustdds::network::udp_sender",
        "try_send_to_locator: Message size",
        "RustDDS notes datagrams above 1500 bytes (an Ethernet MTU); loopback's MTU is 65536",
    ),
];

/// The entry of [`EXPECTED_NOISE`] `record` is, in the configuration in force, if any.
fn expected_noise(record: &log::Record<'_>) -> Option<&'static ExpectedNoise> {
    let expected = EXPECTED.load(Ordering::Relaxed);
    if expected == 0 {
        return None;
    }
    EXPECTED_NOISE.iter().find(|n| {
        expected & (1 << n.when as u8) != 0
            && record.target().starts_with(n.target)
            && record
                .args()
                .as_str()
                .map_or_else(|| record.args().to_string(), str::to_owned)
                .starts_with(n.message)
    })
}

/// The text format: `rockwatch: [level: ][target: ]message` (target for the libraries only).
struct TextLine;

impl<S, N> FormatEvent<S, N> for TextLine
where
    S: Subscriber + for<'a> LookupSpan<'a>,
    N: for<'a> FormatFields<'a> + 'static,
{
    fn format_event(
        &self,
        _ctx: &FmtContext<'_, S, N>,
        mut writer: Writer<'_>,
        event: &Event<'_>,
    ) -> fmt::Result {
        let meta = event.metadata();
        write!(writer, "rockwatch: ")?;
        match *meta.level() {
            Level::ERROR => write!(writer, "error: ")?,
            Level::WARN => write!(writer, "warning: ")?,
            Level::INFO => {}
            Level::DEBUG => write!(writer, "debug: ")?,
            Level::TRACE => write!(writer, "trace: ")?,
        }
        // A `log` record's target is in its `log.target` field.
        let mut message = MessageOf::default();
        event.record(&mut message);
        let target = message.log_target.as_deref().unwrap_or(meta.target());
        if !own(target) {
            write!(writer, "{target}: ")?;
        }
        writeln!(writer, "{}", message.text)
    }
}

/// The `message` field of a record (and a `log` record's target).
#[derive(Default)]
struct MessageOf {
    text: String,
    log_target: Option<String>,
}

impl Visit for MessageOf {
    fn record_str(&mut self, field: &Field, value: &str) {
        match field.name() {
            "message" => self.text.push_str(value),
            "log.target" => self.log_target = Some(value.to_string()),
            _ => {}
        }
    }

    fn record_debug(&mut self, field: &Field, value: &dyn fmt::Debug) {
        if field.name() == "message" {
            use fmt::Write as _;
            let _ = write!(self.text, "{value:?}");
        }
    }
}

/// One record for `/rosout` (`rcl_interfaces/msg/Log`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RosoutRecord {
    /// UTC, ns since the Unix epoch.
    pub stamp_ns: i64,
    /// `rcl_interfaces/msg/Log` level: 10 debug, 20 info, 30 warn, 40 error.
    pub level: u8,
    /// The record's target (`rockwatch::node`, …).
    pub target: String,
    pub message: String,
    pub file: String,
    pub line: u32,
}

/// Records queued for `/rosout` at most; beyond, records are dropped and counted
/// ([`rosout_dropped`]).
pub const ROSOUT_QUEUE: usize = 1000;

/// `/rosout` level: 0 off (the default), else the lowest `rcl_interfaces/msg/Log` level queued.
static ROSOUT_LEVEL: AtomicU8 = AtomicU8::new(0);
static ROSOUT_DROPPED: AtomicU64 = AtomicU64::new(0);
static ROSOUT: Mutex<VecDeque<RosoutRecord>> = Mutex::new(VecDeque::new());

/// The `rcl_interfaces/msg/Log` level of a tracing level.
#[must_use]
pub fn rosout_level(level: Level) -> u8 {
    match level {
        Level::ERROR => 40,
        Level::WARN => 30,
        Level::INFO => 20,
        Level::DEBUG | Level::TRACE => 10,
    }
}

/// From now on, rockwatch's records at or above `level` (that pass the filter) are queued
/// for `/rosout`; `None` turns it off.
pub fn enable_rosout(level: Option<Level>) {
    ROSOUT_LEVEL.store(level.map_or(0, rosout_level), Ordering::Relaxed);
}

/// Takes the records queued for `/rosout` (the node's event loop publishes them).
pub fn take_rosout(into: &mut Vec<RosoutRecord>) {
    if let Ok(mut queue) = ROSOUT.lock() {
        into.extend(queue.drain(..));
    }
}

/// Records dropped because the `/rosout` queue was full.
#[must_use]
pub fn rosout_dropped() -> u64 {
    ROSOUT_DROPPED.load(Ordering::Relaxed)
}

/// Queues rockwatch's records for `/rosout` (see [`enable_rosout`]).
struct RosoutLayer;

impl<S: Subscriber> Layer<S> for RosoutLayer {
    fn on_event(&self, event: &Event<'_>, _: Context<'_, S>) {
        let min = ROSOUT_LEVEL.load(Ordering::Relaxed);
        let meta = event.metadata();
        let level = rosout_level(*meta.level());
        if min == 0 || level < min || !own(meta.target()) {
            return;
        }
        let mut message = MessageOf::default();
        event.record(&mut message);
        let stamp_ns = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
        let record = RosoutRecord {
            stamp_ns,
            level,
            target: meta.target().to_string(),
            message: message.text,
            file: meta.file().unwrap_or("").to_string(),
            line: meta.line().unwrap_or(0),
        };
        if let Ok(mut queue) = ROSOUT.lock() {
            if queue.len() < ROSOUT_QUEUE {
                queue.push_back(record);
                return;
            }
        }
        ROSOUT_DROPPED.fetch_add(1, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_log_level_is_refused_with_the_flag_named() {
        let options = LogOptions {
            level: Some("rockwatch=loud".into()),
            format: LogFormat::Text,
        };
        let err = filter(&options).unwrap_err().to_string();
        assert!(err.contains("--log-level") && err.contains("loud"), "{err}");
        let ok = LogOptions {
            level: Some("rockwatch=debug,rustdds=warn".into()),
            format: LogFormat::Json,
        };
        assert!(filter(&ok).is_ok());
    }

    #[test]
    fn a_library_call_site_writes_at_most_its_burst_per_window_and_says_what_it_dropped() {
        let mut limit = FloodLimit::default();
        let site = || {
            (
                "rustdds::security".to_string(),
                Some("plugins.rs"),
                Some(1357),
            )
        };
        let other = ("rustdds::rtps".to_string(), Some("writer.rs"), Some(10));
        let t0 = std::time::Instant::now();
        for _ in 0..LIBRARY_BURST {
            assert_eq!(limit.admit(site(), t0), Some(0));
        }
        for _ in 0..25 {
            assert_eq!(limit.admit(site(), t0), None);
        }
        // Another site has its own budget.
        assert_eq!(limit.admit(other, t0), Some(0));
        // The next window: the first record says how many were dropped.
        let t1 = t0 + LIBRARY_WINDOW;
        assert_eq!(limit.admit(site(), t1), Some(25));
        assert_eq!(limit.admit(site(), t1), Some(0));
        // Bounded whatever the number of sites.
        for line in 0..(LIBRARY_SITES as u32 + 50) {
            limit.admit(("x".into(), None, Some(line)), t1);
        }
        assert!(limit.sites.len() <= LIBRARY_SITES + 1);
    }

    #[test]
    fn rosout_levels_are_those_of_rcl_interfaces_log() {
        // rcl_interfaces/msg/Log: DEBUG=10 INFO=20 WARN=30 ERROR=40 FATAL=50.
        assert_eq!(rosout_level(Level::DEBUG), 10);
        assert_eq!(rosout_level(Level::INFO), 20);
        assert_eq!(rosout_level(Level::WARN), 30);
        assert_eq!(rosout_level(Level::ERROR), 40);
    }
}

/// Logs at most one line per (station, kind) every `interval`, with the count suppressed, and
/// at most [`LOG_STATIONS_PER_KIND`] stations' lines of one kind per interval: beyond them a
/// kind's lines fold into one `(other stations)` line (2000 invented station ids used to give
/// 2000 lines at once, issue 24 item 8). The one rate-limited log of the shell (the node's
/// notices, `acquire`'s per-stream problems, the SeedLink client's).
#[derive(Debug)]
pub(crate) struct RateLimitedLog {
    interval: Duration,
    last: HashMap<(String, &'static str), (Instant, u64)>,
    /// Per kind: the start of its current interval and the stations' lines written in it.
    per_kind: HashMap<&'static str, (Instant, usize)>,
}

/// Distinct (station, kind) keys the log remembers; past this, new stations share one key,
/// so a flood of invented station ids cannot grow the map without bound.
const LOG_MAX_KEYS: usize = 4096;

/// Most stations with a line of one kind per interval (then `(other stations)`).
pub(crate) const LOG_STATIONS_PER_KIND: usize = 20;

/// The key of the lines folded together.
const OTHER_STATIONS: &str = "(other stations)";

impl RateLimitedLog {
    /// At most one line per (station, kind) every 10 s.
    pub(crate) fn new() -> RateLimitedLog {
        Self::with_interval(Duration::from_secs(10))
    }

    /// At most one line per (station, kind) every `interval`.
    pub(crate) fn with_interval(interval: Duration) -> RateLimitedLog {
        RateLimitedLog {
            interval,
            last: HashMap::new(),
            per_kind: HashMap::new(),
        }
    }

    /// Logs `message` unless a line of this (station, kind) was written within the interval,
    /// or its kind has had [`LOG_STATIONS_PER_KIND`] stations' lines in it (then it is
    /// counted, and the next line of its key says how many).
    pub(crate) fn log(&mut self, station: &str, kind: &'static str, message: &str) {
        self.write(station, kind, message);
    }

    /// [`RateLimitedLog::log`], returning whether a line was written.
    fn write(&mut self, station: &str, kind: &'static str, message: &str) -> bool {
        let now = Instant::now();
        let mut key = (printable(station, STATION_CHARS), kind);
        if self.last.len() >= LOG_MAX_KEYS && !self.last.contains_key(&key) {
            key.0 = OTHER_STATIONS.into();
        }
        let due = |last: &HashMap<(String, &'static str), (Instant, u64)>, key| {
            last.get(key)
                .is_none_or(|(at, _): &(Instant, u64)| now.duration_since(*at) >= self.interval)
        };
        if key.0 != OTHER_STATIONS && due(&self.last, &key) {
            let (start, lines) = self.per_kind.entry(kind).or_insert((now, 0));
            if now.duration_since(*start) >= self.interval {
                (*start, *lines) = (now, 0);
            }
            if *lines >= LOG_STATIONS_PER_KIND {
                key.0 = OTHER_STATIONS.into();
            } else {
                *lines += 1;
            }
        }
        let message = printable(message, MESSAGE_CHARS);
        let station = key.0.clone();
        let entry = self.last.entry(key).or_insert((now - self.interval, 0));
        if now.duration_since(entry.0) >= self.interval {
            let suppressed = std::mem::take(&mut entry.1);
            let more = if suppressed > 0 {
                format!(" (+{suppressed} more since last report)")
            } else {
                String::new()
            };
            tracing::warn!(target: "rockwatch::notice", station = %station, kind, "{station}: {kind}: {message}{more}");
            entry.0 = now;
            true
        } else {
            entry.1 += 1;
            false
        }
    }
}

#[cfg(test)]
mod rate_limited_log_tests {
    use super::*;

    #[test]
    fn thousands_of_stations_of_one_kind_give_a_bounded_number_of_lines() {
        // Issue 24 item 8: 2000 unknown station ids gave 2000 warning lines at once.
        let mut log = RateLimitedLog::with_interval(Duration::from_secs(3600));
        let written = (0..2000)
            .filter(|i| log.write(&format!("XX.S{i}.00"), "unknown_station", "not monitored"))
            .count();
        // 20 stations, then one line for the others.
        assert_eq!(written, LOG_STATIONS_PER_KIND + 1);
        // Another kind has its own budget; a station already logged stays quiet.
        assert!(log.write("XX.S0.00", "gap", "missing samples"));
        assert!(!log.write("XX.S0.00", "unknown_station", "not monitored"));
    }
}
