//! A minimal logger for the `log` facade, so that the lines of RustDDS and ros2-client (which
//! log through `log`) reach stderr: `rockwatch: LEVEL target: message`.
//!
//! Level: `ROCKWATCH_LOG` (`error`, `warn`, `info`, `debug`, `trace`, `off`) for every target;
//! unset, warnings of rockwatch itself and errors of the libraries (RustDDS's warnings are
//! chatty in normal operation; its errors, such as a failed event-loop poll, are not).

use std::sync::atomic::{AtomicUsize, Ordering};

use log::{Level, LevelFilter, Log, Metadata, Record};

/// Open [`MuteLibraries`] guards: while any is, the libraries' lines are not shown.
static MUTED: AtomicUsize = AtomicUsize::new(0);

/// While this guard lives, the libraries' log lines (not rockwatch's) are dropped: for the
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

/// Environment variable of the log level.
pub const LOG_ENV: &str = "ROCKWATCH_LOG";

struct StderrLogger {
    /// Level of every target when `ROCKWATCH_LOG` is set.
    all: Option<LevelFilter>,
}

impl StderrLogger {
    fn level_for(&self, target: &str) -> LevelFilter {
        let own = target.starts_with("rockwatch");
        if !own && MUTED.load(Ordering::Relaxed) > 0 {
            return LevelFilter::Off;
        }
        match self.all {
            Some(level) => level,
            None if own => LevelFilter::Warn,
            None => LevelFilter::Error,
        }
    }
}

impl Log for StderrLogger {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        metadata.level() <= self.level_for(metadata.target())
    }

    fn log(&self, record: &Record<'_>) {
        if self.enabled(record.metadata()) {
            let level = match record.level() {
                Level::Error => "error",
                Level::Warn => "warning",
                Level::Info => "info",
                Level::Debug => "debug",
                Level::Trace => "trace",
            };
            eprintln!("rockwatch: {level}: {}: {}", record.target(), record.args());
        }
    }

    fn flush(&self) {}
}

/// Installs the logger (once; later calls do nothing). An unknown `ROCKWATCH_LOG` value is
/// reported and the default levels are used.
pub fn init() {
    init_with_level(None);
}

/// As [`init`]; `level` (from `--ros-args --log-level`), when given, is the level of every
/// target, over `ROCKWATCH_LOG`.
pub fn init_with_level(level: Option<LevelFilter>) {
    let all = level.or_else(env_level);
    let max = all.unwrap_or(LevelFilter::Warn);
    if log::set_boxed_logger(Box::new(StderrLogger { all })).is_ok() {
        log::set_max_level(max);
    }
}

/// `ROCKWATCH_LOG`'s level, if set and valid.
fn env_level() -> Option<LevelFilter> {
    std::env::var(LOG_ENV).ok().and_then(|v| {
        let parsed = v.parse::<LevelFilter>().ok();
        if parsed.is_none() {
            eprintln!("rockwatch: warning: {LOG_ENV}={v:?} is not a log level (error, warn, info, debug, trace, off): using the defaults");
        }
        parsed
    })
}
