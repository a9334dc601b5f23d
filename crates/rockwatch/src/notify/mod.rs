//! Alert routing (`[[notify]]` in the node configuration): every alert, in the shared JSON
//! schema (`crate::alert_json`), to each receiver whose filters take it — a command run with
//! the alert on stdin (`exec`), or an HTTP POST (`webhook`).
//!
//! [`Notifier`] is a [`Publisher`] among the node's: the engine path is untouched. Guarantees:
//!
//! - **At least once, across restarts.** An alert is appended to the receiver's spool in the
//!   state directory (`<state_dir>/notify/<kind>-<crc32 of the target>.spool`, synced) before
//!   it is handed to the receiver's thread; it stays pending there until the receiver
//!   acknowledges it (exit status 0, HTTP 2xx) and is delivered after a restart otherwise.
//!   At start, an alert of the node's journal that a receiver's spool does not hold (the node
//!   died between journaling and spooling it) is added to that spool; a new receiver (no spool
//!   yet) starts from the journal as it is (it is not sent the history). Receivers
//!   de-duplicate on (`pbr_id`, `episode`, `level`).
//! - **Isolation.** Each receiver has its own thread and a bounded queue (`queue`): a slow or
//!   dead receiver delays neither the engine nor the other receivers. When the queue is full
//!   the alert waits in the spool only (counted as an overflow, logged) and the thread takes it
//!   from there. Delivery per receiver is in order; a failed delivery is retried after
//!   `retry_initial_s`, doubled at each failure up to `retry_max_s`; an `exec` command running
//!   longer than `timeout_s` is killed (its child processes are not) and retried.
//! - **Stop.** [`Notifier::shutdown`] gives the receivers a grace period to deliver what is
//!   queued; what is left stays in the spool. Without a state directory the spool is in
//!   memory only, and undelivered alerts are lost at the stop (a warning says so at start).

mod config;
mod deliver;
mod spool;
mod worker;

use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{sync_channel, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use rockwatch_core::engine::JournalRecord;

pub use config::{
    NotifyConfig, NotifyConfigError, NotifyKind, MAX_QUEUE, MAX_RETRY_S, MAX_TIMEOUT_S,
};
pub use spool::{Spool, SpoolReport};

use crate::alert_json::AlertJson;
use crate::ports::{Publication, Publisher};
use worker::{Backoff, Shared};

/// Directory of the spools inside the state directory.
pub const SPOOL_DIR: &str = "notify";

/// How long `rockwatch node` lets its receivers deliver what is queued when it stops.
pub const STOP_GRACE: Duration = Duration::from_secs(5);

/// One receiver: its filters, its thread and what it shares with it.
struct Receiver {
    config: NotifyConfig,
    shared: Arc<Shared>,
    /// None once shut down (closing the queue).
    queue: Option<SyncSender<AlertJson>>,
    thread: Option<JoinHandle<()>>,
}

/// What a receiver did (for the node's closing summary and tests).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReceiverStats {
    /// `webhook URL` or `exec PROGRAM`.
    pub name: String,
    /// Alerts acknowledged.
    pub delivered: u64,
    /// Delivery attempts that failed (each retried later).
    pub failed_attempts: u64,
    /// Alerts not queued because the queue was full (delivered from the spool).
    pub overflows: u64,
    /// Spool writes that failed (the alert was still queued in memory).
    pub spool_errors: u64,
    /// Alerts not acknowledged yet (kept in the spool).
    pub pending: u64,
}

/// The `[[notify]]` receivers, as a publisher of the node.
pub struct Notifier {
    receivers: Vec<Receiver>,
}

impl Notifier {
    /// Opens each receiver's spool (in `state_dir`, else in memory), reconciles it with the
    /// node's `journal` (see the module documentation) and starts its thread, which first
    /// delivers what the spool holds. Errors name the spool file.
    pub fn start(
        configs: &[NotifyConfig],
        state_dir: Option<&Path>,
        journal: &[JournalRecord],
    ) -> anyhow::Result<Notifier> {
        if !configs.is_empty() && state_dir.is_none() {
            tracing::warn!(
                "[[notify]] without a state directory: alerts not delivered \
                 when the node stops are lost (set state_dir or --state-dir)"
            );
        }
        let mut receivers = Vec::with_capacity(configs.len());
        for config in configs {
            let name = config.name();
            let spool = match state_dir {
                Some(dir) => {
                    let path = dir.join(SPOOL_DIR).join(config.spool_file_name());
                    let (mut spool, report) = Spool::open(&path)
                        .with_context(|| format!("notify {name}: cannot open its spool"))?;
                    if let Some(why) = &report.degraded {
                        tracing::error!(
                            "notify {name}: {}: the state directory's file system is full: {why}",
                            path.display()
                        );
                    }
                    if !report.corrupt_lines.is_empty() {
                        tracing::warn!(
                            "{}: skipped corrupt spool lines {:?}",
                            path.display(),
                            report.corrupt_lines
                        );
                    }
                    reconcile(&mut spool, config, journal, report.created)
                        .with_context(|| format!("notify {name}: {}", path.display()))?;
                    let pending = spool.pending().len();
                    if pending > 0 {
                        tracing::info!(
                            "notify {name}: {pending} undelivered alerts from {}",
                            path.display()
                        );
                    }
                    spool
                }
                None => Spool::in_memory(),
            };
            let mut shared = Shared::new(name.clone(), spool);
            shared.reports_dir = state_dir.map(|d| d.join(crate::reports::DIR));
            let shared = Arc::new(shared);
            let (tx, rx) = sync_channel(config.queue);
            let target = deliver::Target::new(config);
            let timeout = Duration::from_secs_f64(config.timeout_s);
            let backoff = Backoff {
                initial: Duration::from_secs_f64(config.retry_initial_s),
                max: Duration::from_secs_f64(config.retry_max_s),
            };
            let thread = {
                let shared = Arc::clone(&shared);
                std::thread::Builder::new()
                    .name("rockwatch-notify".into())
                    .spawn(move || worker::run(&target, timeout, &backoff, &shared, &rx))
                    .with_context(|| format!("notify {name}: cannot start its thread"))?
            };
            receivers.push(Receiver {
                config: config.clone(),
                shared,
                queue: Some(tx),
                thread: Some(thread),
            });
        }
        Ok(Notifier { receivers })
    }

    /// What each receiver did so far, in configuration order.
    #[must_use]
    pub fn stats(&self) -> Vec<ReceiverStats> {
        self.receivers
            .iter()
            .map(|r| {
                let c = &r.shared.counters;
                ReceiverStats {
                    name: r.shared.name.clone(),
                    delivered: c.delivered.load(Ordering::Relaxed),
                    failed_attempts: c.failed_attempts.load(Ordering::Relaxed),
                    overflows: c.overflows.load(Ordering::Relaxed),
                    spool_errors: c.spool_errors.load(Ordering::Relaxed),
                    pending: r.shared.spool().pending().len() as u64,
                }
            })
            .collect()
    }

    /// Closes the queues and waits up to `grace` for the receivers to deliver what they hold
    /// (a receiver whose delivery fails stops at once); what is left stays in the spools.
    /// Returns the final stats. A receiver still busy at the deadline is left to finish its
    /// attempt on its own (its thread is detached).
    pub fn shutdown(mut self, grace: Duration) -> Vec<ReceiverStats> {
        let deadline = Instant::now() + grace;
        for r in &mut self.receivers {
            *r.shared
                .deadline
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(deadline);
            r.shared.stopping.store(true, Ordering::Relaxed);
            r.queue = None;
        }
        loop {
            let busy = self
                .receivers
                .iter()
                .any(|r| r.thread.as_ref().is_some_and(|t| !t.is_finished()));
            if !busy || Instant::now() >= deadline {
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        for r in &mut self.receivers {
            if r.thread.as_ref().is_some_and(JoinHandle::is_finished) {
                if let Some(t) = r.thread.take() {
                    let _ = t.join();
                }
            }
        }
        self.stats()
    }
}

/// Adds to `spool` the alerts of `journal` that `config` takes and the spool does not hold;
/// for a new spool, marks them delivered instead (a new receiver starts from now).
fn reconcile(
    spool: &mut Spool,
    config: &NotifyConfig,
    journal: &[JournalRecord],
    created: bool,
) -> std::io::Result<()> {
    for record in journal {
        if let JournalRecord::Alert(alert) = record {
            if !config.accepts(alert) || spool.contains(&alert.key()) {
                continue;
            }
            if created {
                spool.ack(&alert.key())?;
            } else {
                spool.add(&AlertJson::from(alert))?;
            }
        }
    }
    Ok(())
}

/// Stops the receivers' threads without waiting (`shutdown` waits).
impl Drop for Notifier {
    fn drop(&mut self) {
        for r in &mut self.receivers {
            r.shared.stopping.store(true, Ordering::Relaxed);
            r.queue = None;
        }
    }
}

impl Publisher for Notifier {
    /// Spools each alert (synced) for every receiver whose filters take it, then queues it
    /// for the receiver's thread without waiting. Fails (after trying every receiver) if a
    /// spool could not be written; the alert was queued in memory all the same.
    fn publish(&mut self, publication: &Publication) -> anyhow::Result<()> {
        let Publication::Alert { alert, .. } = publication else {
            return Ok(());
        };
        let json = AlertJson::from(alert);
        let mut errors = Vec::new();
        for r in &mut self.receivers {
            if !r.config.accepts(alert) {
                continue;
            }
            match r.shared.spool().add(&json) {
                Ok(true) => {}
                Ok(false) => continue, // spooled already
                Err(e) => {
                    r.shared
                        .counters
                        .spool_errors
                        .fetch_add(1, Ordering::Relaxed);
                    errors.push(format!("notify {}: spool: {e}", r.shared.name));
                }
            }
            let Some(queue) = &r.queue else { continue };
            match queue.try_send(json.clone()) {
                Ok(()) => {}
                Err(TrySendError::Full(_)) => {
                    r.shared.behind.store(true, Ordering::Relaxed);
                    let n = r.shared.counters.overflows.fetch_add(1, Ordering::Relaxed) + 1;
                    if n.is_power_of_two() {
                        tracing::warn!(
                            "notify {}: queue full ({} alerts): alert kept in the spool, delivered from there ({n} overflows so far)",
                            r.shared.name, r.config.queue
                        );
                    }
                }
                Err(TrySendError::Disconnected(_)) => errors.push(format!(
                    "notify {}: its thread has stopped; the alert waits in the spool for the next start",
                    r.shared.name
                )),
            }
        }
        if errors.is_empty() {
            Ok(())
        } else {
            anyhow::bail!("{}", errors.join("; "))
        }
    }
}
