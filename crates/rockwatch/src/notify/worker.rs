//! A receiver's thread: takes alerts from its bounded queue (or, after an overflow or at
//! start, from its spool), delivers them one at a time in order, retries a failed delivery
//! with exponential backoff, and acknowledges each delivered alert in the spool.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use super::deliver::Target;
use super::spool::Spool;
use crate::alert_json::{AlertJson, RecordJson};
use crate::log_text::{printable, PBR_ID_CHARS};
use rockwatch_core::engine::AlertLevel;

/// Longest a worker waits on its queue before looking at its stop and overflow flags.
const WORKER_TICK: Duration = Duration::from_millis(50);

/// Counters of one receiver (read from any thread).
#[derive(Debug, Default)]
pub(crate) struct Counters {
    pub delivered: AtomicU64,
    pub failed_attempts: AtomicU64,
    pub overflows: AtomicU64,
    pub spool_errors: AtomicU64,
}

/// What the node's thread and a receiver's thread share.
#[derive(Debug)]
pub(crate) struct Shared {
    /// The receiver for logs.
    pub name: String,
    pub spool: Mutex<Spool>,
    /// Alerts were spooled but not queued (the queue was full): reload from the spool.
    pub behind: AtomicBool,
    pub counters: Counters,
    /// Set at shutdown: deliver what is queued until `deadline`, give up at the first failure.
    pub stopping: AtomicBool,
    pub deadline: Mutex<Option<Instant>>,
    /// `<state_dir>/reports`: an `overturned` alert's payload names its event report there.
    pub reports_dir: Option<std::path::PathBuf>,
}

impl Shared {
    pub(crate) fn new(name: String, spool: Spool) -> Shared {
        Shared {
            name,
            spool: Mutex::new(spool),
            behind: AtomicBool::new(false),
            counters: Counters::default(),
            stopping: AtomicBool::new(false),
            deadline: Mutex::new(None),
            reports_dir: None,
        }
    }

    /// The spool (a panicked holder leaves it usable: every change is one whole record).
    pub(crate) fn spool(&self) -> MutexGuard<'_, Spool> {
        self.spool.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn past_deadline(&self) -> bool {
        self.stopping.load(Ordering::Relaxed)
            && self
                .deadline
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .is_none_or(|d| Instant::now() >= d)
    }
}

/// Retry timing of one receiver.
pub(crate) struct Backoff {
    pub initial: Duration,
    pub max: Duration,
}

/// The receiver's thread: runs until its queue is closed and empty, or the stop deadline.
pub(crate) fn run(
    target: &Target,
    timeout: Duration,
    backoff: &Backoff,
    shared: &Shared,
    queue: &Receiver<AlertJson>,
) {
    let mut backlog: VecDeque<AlertJson> = shared.spool().pending().into();
    let mut wait = backoff.initial;
    let mut failures = 0u64;
    loop {
        if shared.past_deadline() {
            return;
        }
        if backlog.is_empty() {
            if shared.behind.swap(false, Ordering::Relaxed) {
                // The spool holds everything not delivered, in order: start again from it.
                while queue.try_recv().is_ok() {}
                backlog = shared.spool().pending().into();
                continue;
            }
            match queue.recv_timeout(WORKER_TICK) {
                Ok(alert) => backlog.push_back(alert),
                Err(RecvTimeoutError::Timeout) => continue,
                Err(RecvTimeoutError::Disconnected) => {
                    if shared.behind.load(Ordering::Relaxed) {
                        continue;
                    }
                    return;
                }
            }
        }
        let Some(alert) = backlog.front() else {
            continue;
        };
        let key = alert.key();
        if shared.spool().is_acked(&key) {
            backlog.pop_front(); // queued twice around an overflow: delivered already
            continue;
        }
        let body = payload(alert, shared.reports_dir.as_deref());
        let what = format!(
            "alert {} {} episode {}",
            printable(key.0.as_str(), PBR_ID_CHARS),
            key.2.as_str(),
            key.1
        );
        match target.deliver(&body, timeout) {
            Ok(()) => {
                if let Err(e) = shared.spool().ack(&key) {
                    shared.counters.spool_errors.fetch_add(1, Ordering::Relaxed);
                    tracing::warn!(
                        "notify {}: cannot record the delivery of {what} in the spool (it may be delivered again): {e}",
                        shared.name
                    );
                }
                shared.counters.delivered.fetch_add(1, Ordering::Relaxed);
                if failures > 0 {
                    tracing::info!(
                        "notify {}: {what} delivered after {} failed attempts",
                        shared.name,
                        failures
                    );
                }
                failures = 0;
                wait = backoff.initial;
                backlog.pop_front();
            }
            Err(e) => {
                failures += 1;
                shared
                    .counters
                    .failed_attempts
                    .fetch_add(1, Ordering::Relaxed);
                let stopping = shared.stopping.load(Ordering::Relaxed);
                tracing::warn!(
                    "notify {}: {what} not delivered (attempt {failures}): {}; {}",
                    shared.name,
                    printable(&e, 300),
                    if stopping {
                        "kept in the spool for the next start".to_string()
                    } else {
                        format!("retry in {:.1} s", wait.as_secs_f64())
                    }
                );
                if stopping {
                    return;
                }
                let until = Instant::now() + wait;
                while Instant::now() < until && !shared.stopping.load(Ordering::Relaxed) {
                    std::thread::sleep(
                        WORKER_TICK.min(until.saturating_duration_since(Instant::now())),
                    );
                }
                wait = (wait * 2).min(backoff.max);
            }
        }
    }
}

/// A receiver's payload: the alert in the shared schema; an `overturned` alert with a state
/// directory also has `"report"`, the path of the PNG its event report is written to
/// (`crate::reports`; written by its own thread, it may appear a moment after the alert).
pub(crate) fn payload(
    alert: &crate::alert_json::AlertJson,
    reports_dir: Option<&std::path::Path>,
) -> Vec<u8> {
    let mut value = serde_json::to_value(RecordJson::Alert(alert.clone())).unwrap_or_default();
    if let (Some(dir), AlertLevel::Overturned, Some(object)) =
        (reports_dir, alert.level, value.as_object_mut())
    {
        let png = dir.join(format!(
            "{}.png",
            crate::reports::report_stem(alert.data_time_ns, alert.pbr_id.as_str())
        ));
        object.insert("report".into(), png.display().to_string().into());
    }
    serde_json::to_vec(&value).unwrap_or_default()
}
