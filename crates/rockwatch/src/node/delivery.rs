//! Delivery: the one path from the engine's outputs to the outside, and the guarantees of the
//! node's alerts (docs/reliability.md).
//!
//! - [`Emitter`] and its [`EmitSink`]: each alert is journaled and synced, then published at
//!   once, in engine order (one the state directory cannot take goes out flagged
//!   `journal_pending` and waits in the journal's backlog); episode ends journaled; states and
//!   intensities published after the batch; notices and health changes logged; the node's
//!   counters. `rockwatch monitor` runs on it too.
//! - [`Outlet`]: the node's publishers (iceoryx2 at once, ROS 2 and the others batched per
//!   turn of the event loop); [`Outlet::settle`] journals a `Published` marker for every alert
//!   handed to ROS 2 ([`Emitter::mark_published`]).
//! - At start, [`republish_journaled`] publishes the journal's alert history again (the
//!   transient-local history of `/pbr/alerts`; an alert never marked published goes to every
//!   publisher), and [`publish_resets`] each operator reset as it is applied.

use std::collections::{BTreeMap, HashMap};
use std::time::Instant;

use super::{NodeRuntime, NodeStats, NoticeLog};
use crate::journal::{Appended, JournalWriter};
use crate::log_text::{printable, MESSAGE_CHARS, PBR_ID_CHARS, STATION_CHARS};
use crate::logging::RateLimitedLog;
use crate::ports::{Publication, Publisher};
use crate::ros2::{Ros2Publisher, ALERTS_TOPIC};
use crate::status::{AlertLatency, RockStatus};
use rockwatch_core::engine::{
    Alert, AlertLevel, HealthChange, HistoryEntry, JournalRecord, Notice, Output, OutputSink,
    PbrId, ResetEvent, StationHealth, StationId,
};

/// Where the runtime's outputs go: the journal, the publishers (through a callback), the
/// stats and the logs. The one path from the engine to the outside, the node's and
/// `rockwatch monitor`'s: journal (and sync), then publish.
pub(super) struct Emitter {
    pub(super) journal: Option<JournalWriter>,
    pub(super) epoch: Instant,
    /// UTC (ns since the Unix epoch) at `epoch`: arrival stamps in UTC.
    pub(super) epoch_utc_ns: i64,
    pub(super) log: RateLimitedLog,
    pub(super) notice_log: NoticeLog,
    /// Notices per (station, kind), with [`NoticeLog::Counted`] (else empty).
    pub(super) notice_counts: BTreeMap<(String, &'static str), u64>,
    /// [`FAULT_ABORT_AFTER_JOURNAL_ENV`]: abort after journaling this many alerts.
    pub(super) abort_after_alert: Option<u64>,
    pub(super) stats: NodeStats,
    /// States and intensities held back until the batch's alerts are out (reused).
    pub(super) deferred: Vec<Output>,
    /// Blocks overturned and not reset since, with the station and episode of their fall:
    /// restored from the journal, then every `overturned` alert the engine raises (inline or
    /// on a worker) until an operator reset.
    pub(super) overturned: HashMap<PbrId, (StationId, u32)>,
    /// Operator resets journaled and applied, to publish ([`NodeRuntime::take_resets`]).
    pub(super) resets: Vec<ResetEvent>,
    /// Each station's last alert and its latencies (for the status).
    pub(super) last_alerts: HashMap<String, AlertLatency>,
    /// The stations' health as the sharded engine's workers last reported it.
    pub(super) health_reports: BTreeMap<String, StationHealth>,
    /// `engine.stale_after_s`, for the log lines.
    pub(super) stale_after_s: f64,
    /// Each block of the node as its states and alerts last described it (for the status).
    pub(super) rocks: BTreeMap<String, RockStatus>,
    /// `Published` markers that could not be journaled.
    pub(super) marker_errors: u64,
    /// Event reports (with a state directory): the traces they need, fed here with each
    /// publication and by the runtime with each packet.
    pub(super) reports: Option<crate::reports::ReportFeed>,
}

impl Emitter {
    pub(super) fn now_ns(&self) -> i64 {
        self.epoch.elapsed().as_nanos() as i64
    }

    /// Journals `record` (after any backlog); false if it waits in the backlog or was lost.
    /// The first failure of a run of failures, and each recovery, is logged.
    fn journal(&mut self, record: JournalRecord) -> bool {
        let Some(writer) = &mut self.journal else {
            return true;
        };
        let was_failing = writer.backlog() > 0;
        let appended = writer.append(record);
        self.journal_changed(was_failing, 0);
        appended == Appended::Written
    }

    /// Writes the backlog of a failing state directory, if any, and opens a journal that
    /// could not be opened at start.
    pub(super) fn retry_journal(&mut self) {
        if let Some(writer) = self
            .journal
            .as_mut()
            .filter(|w| w.backlog() > 0 || !w.is_open())
        {
            let written = writer.retry();
            self.journal_changed(true, written);
        }
    }

    /// Updates the journal's counters and logs a change of health: failing (one line every
    /// 10 s while it lasts, with the count) or recovered.
    fn journal_changed(&mut self, was_failing: bool, written: usize) {
        let Some(writer) = &self.journal else {
            return;
        };
        let backlog = writer.backlog();
        self.stats.journal_failures = writer.failures;
        self.stats.journal_backlog = backlog as u64;
        self.stats.journal_dropped = writer.dropped;
        if let Some(error) = writer.last_error.clone() {
            let message = format!(
                "{error}: the node goes on; alerts are published flagged journal_pending and \
                 {backlog} records wait in memory ({} lost) to be journaled when it recovers \
                 ({} failed writes)",
                writer.dropped, writer.failures
            );
            self.log.log("state directory", "journal_failing", &message);
        } else if was_failing && backlog == 0 {
            tracing::info!(
                "state directory recovered: {written} waiting records journaled \
                 ({} failed writes)",
                writer.failures
            );
        }
    }

    /// Reports one of the engine's notices (or the runtime's own refusal of a malformed
    /// station id) as [`NoticeLog`] says.
    pub(super) fn notice(&mut self, notice: &Notice) {
        self.stats.notices += 1;
        match self.notice_log {
            NoticeLog::RateLimited => {
                self.log
                    .log(&notice.station, notice.kind.as_str(), &notice.message)
            }
            NoticeLog::Counted { lines } => {
                let count = self
                    .notice_counts
                    .entry((notice.station.clone(), notice.kind.as_str()))
                    .or_insert(0);
                *count += 1;
                if *count <= lines {
                    tracing::info!(
                        "{}: {}: {}",
                        printable(&notice.station, STATION_CHARS),
                        notice.kind.as_str(),
                        printable(&notice.message, MESSAGE_CHARS)
                    );
                }
            }
        }
    }

    /// Journals (unsynced) that `alert` has been handed to the publishers. A failure is
    /// logged (rate-limited) and counted: the alert will be published again at restart.
    pub(super) fn mark_published(&mut self, alert: &Alert) {
        let Some(journal) = &mut self.journal else {
            return;
        };
        let record = JournalRecord::Published {
            pbr_id: alert.pbr_id.clone(),
            episode: alert.episode,
            level: alert.level,
        };
        if !journal.append_unsynced(&record) {
            self.marker_errors += 1;
            let reason = journal
                .last_error
                .clone()
                .unwrap_or_else(|| "the state directory is failing".into());
            let message = format!(
                "cannot journal that an alert was published ({reason}; {} in all): it will be published again at restart",
                self.marker_errors
            );
            self.log
                .log(alert.pbr_id.as_str(), "journal_failed", &message);
        }
    }

    /// A sink for one batch of engine outputs (one packet, one flush, one worker batch):
    /// each alert is journaled (and synced), then published at once, in engine order; episode
    /// ends are journaled; notices logged; states and intensities are published by
    /// [`EmitSink::finish`], after the batch (they are not journaled, and an alert must not
    /// wait for them). An alert the state directory cannot take is published all the same,
    /// flagged `journal_pending` ([`Emitter::journal`]).
    pub(super) fn sink<'a, P: FnMut(Publication)>(
        &'a mut self,
        publish: &'a mut P,
    ) -> EmitSink<'a, P> {
        self.deferred.clear();
        EmitSink {
            emit: self,
            publish,
        }
    }
}

/// See [`Emitter::sink`].
pub(super) struct EmitSink<'a, P: FnMut(Publication)> {
    emit: &'a mut Emitter,
    publish: &'a mut P,
}

impl<P: FnMut(Publication)> EmitSink<'_, P> {
    /// Publishes the batch's states and intensities.
    pub(super) fn finish(self) {
        let EmitSink { emit, publish } = self;
        for output in emit.deferred.drain(..) {
            match output {
                Output::State(s) => {
                    emit.stats.states += 1;
                    if let Some(rock) = emit.rocks.get_mut(s.pbr_id.as_str()) {
                        rock.observe(s.mode, s.theta_over_alpha, Some(s.not_monitored));
                        rock.observe_direction(s.direction_deg, s.overturn_probability);
                    }
                    let publication = Publication::State(s);
                    if let Some(reports) = &mut emit.reports {
                        reports.observe(&publication);
                    }
                    publish(publication);
                }
                Output::Intensity(i) => {
                    emit.stats.intensities += 1;
                    let publication = Publication::Intensity(i);
                    if let Some(reports) = &mut emit.reports {
                        reports.observe(&publication);
                    }
                    publish(publication);
                }
                _ => {}
            }
        }
    }
}

impl<P: FnMut(Publication)> OutputSink for EmitSink<'_, P> {
    fn push(&mut self, output: Output) {
        if let Output::Alert(a) = &output {
            if a.level == AlertLevel::Overturned {
                self.emit
                    .overturned
                    .insert(a.pbr_id.clone(), (a.station.clone(), a.episode));
            }
            if let Some(rock) = self.emit.rocks.get_mut(a.pbr_id.as_str()) {
                rock.observe(a.mode, a.theta_over_alpha, None);
                rock.observe_direction(a.direction_deg, a.overturn_probability);
            }
        }
        // Without a state directory there is nothing to journal: no copy of the alert (an
        // allocation on the way from packet to alert).
        let record = match &output {
            _ if self.emit.journal.is_none() => None,
            Output::Alert(alert) => Some(JournalRecord::Alert(alert.clone())),
            Output::EpisodeEnd {
                pbr_id,
                episode,
                data_time_ns,
            } => Some(JournalRecord::EpisodeEnd {
                pbr_id: pbr_id.clone(),
                episode: *episode,
                data_time_ns: Some(*data_time_ns),
            }),
            _ => None,
        };
        let journaled = record.is_none_or(|r| self.emit.journal(r));
        match output {
            Output::Alert(alert) => {
                if !journaled {
                    self.emit.stats.journal_pending_alerts += 1;
                }
                if self.emit.abort_after_alert == Some(self.emit.stats.alerts + 1) {
                    std::process::abort(); // fault injection: journaled, not published
                }
                self.emit.stats.alerts += 1;
                let latency_ns = self.emit.now_ns() - alert.arrival_ns;
                let data_to_arrival_ns =
                    self.emit.epoch_utc_ns + alert.arrival_ns - alert.data_time_ns;
                let latency = AlertLatency {
                    data_time_ns: alert.data_time_ns,
                    data_to_arrival_s: data_to_arrival_ns as f64 * 1e-9,
                    arrival_to_published_s: latency_ns as f64 * 1e-9,
                };
                match self.emit.last_alerts.get_mut(alert.station.as_str()) {
                    Some(last) => *last = latency,
                    None => {
                        self.emit
                            .last_alerts
                            .insert(alert.station.to_string(), latency);
                    }
                }
                if self.emit.notice_log == NoticeLog::RateLimited {
                    log_alert(&alert, &latency, !journaled);
                }
                let publication = Publication::Alert {
                    alert,
                    latency_ns,
                    journal_pending: !journaled,
                };
                if let Some(reports) = &mut self.emit.reports {
                    reports.observe(&publication);
                }
                (self.publish)(publication);
            }
            Output::EpisodeEnd {
                pbr_id,
                episode,
                data_time_ns,
            } => {
                if let Some(reports) = &mut self.emit.reports {
                    reports.episode_end(pbr_id.as_str(), episode, data_time_ns);
                }
            }
            Output::State(_) | Output::Intensity(_) => self.emit.deferred.push(output),
            Output::Notice(n) => self.emit.notice(&n),
            Output::Health(change) => log_health(&change, self.emit.stale_after_s),
            Output::HealthReport(report) => {
                for h in report {
                    self.emit.health_reports.insert(h.station.to_string(), h);
                }
            }
        }
    }
}

/// Logs one alert as it is handed to the publishers (target `rockwatch::alert`, level warn):
/// its level, block, station, episode, data time (ISO 8601 UTC) and the two latencies —
/// `data_latency_ms`, from the triggering sample's data time to the arrival of its packet
/// (UTC clocks of the station and the node), and `latency_ms`, from that arrival to now
/// (the node's processing, journal sync included).
fn log_alert(alert: &Alert, latency: &AlertLatency, journal_pending: bool) {
    let data_time = rockwatch_core::utc::format_utc_ns(i128::from(alert.data_time_ns));
    let data_latency_ms = latency.data_to_arrival_s * 1e3;
    let latency_ms = latency.arrival_to_published_s * 1e3;
    let pbr_id = printable(alert.pbr_id.as_str(), PBR_ID_CHARS);
    let station = printable(alert.station.as_str(), STATION_CHARS);
    tracing::warn!(
        target: "rockwatch::alert",
        level = alert.level.as_str(),
        pbr_id = %pbr_id,
        station = %station,
        episode = alert.episode,
        data_time = %data_time,
        data_latency_ms,
        latency_ms,
        theta_over_alpha = alert.theta_over_alpha,
        overturn_probability = alert.overturn_probability,
        journal_pending,
        "ALERT {} {pbr_id} (station {station}, episode {}): data time {data_time}, |θ|/α {:.3}, \
         P(overturn) {:.2}; data → arrival {data_latency_ms:.1} ms, arrival → published \
         {latency_ms:.3} ms{}",
        alert.level.as_str(),
        alert.episode,
        alert.theta_over_alpha.abs(),
        alert.overturn_probability,
        if journal_pending { " (not journaled yet: the state directory is failing)" } else { "" }
    );
}

/// Logs a station going stale (warn) or recovering (info), target `rockwatch::health`.
fn log_health(change: &HealthChange, stale_after_s: f64) {
    let station = printable(change.station.as_str(), STATION_CHARS);
    let silent_s = change.silent_ns as f64 * 1e-9;
    if change.monitored {
        tracing::info!(
            target: "rockwatch::health",
            station = %station,
            monitored = true,
            silent_s,
            blocks = change.blocks,
            "{station}: data again after {silent_s:.1} s of silence: its {} blocks are monitored again",
            change.blocks
        );
    } else {
        tracing::warn!(
            target: "rockwatch::health",
            station = %station,
            monitored = false,
            silent_s,
            blocks = change.blocks,
            "{station}: stale: no data for {silent_s:.1} s (engine.stale_after_s = {stale_after_s} s): its {} blocks are NOT MONITORED",
            change.blocks
        );
    }
}

/// Every publisher of the node. The iceoryx2 alert publisher (`immediate`) publishes at once; the
/// others (ROS 2, extra) are handed the turn's publications together at its end
/// ([`Outlet::flush`]): each ROS 2 publication wakes RustDDS's event-loop thread, which would
/// otherwise compete for the CPU with the iceoryx2 subscriber being woken at that moment, and
/// one batch per turn wakes it once. A failed publication is logged (rate-limited) and the
/// node goes on.
pub(super) struct Outlet<'a> {
    /// Publishes each publication at once (the iceoryx2 alert publisher, when configured).
    pub(super) immediate: Option<&'a mut dyn Publisher>,
    /// The ROS 2 publishers (replaced when the participant is rebuilt), handed the turn's
    /// publications at its end as `later`.
    pub(super) ros2: Ros2Publisher,
    pub(super) later: Vec<&'a mut dyn Publisher>,
    /// Handed what `later` is handed and, at start, the journal's alert history too (the web
    /// dashboard's feed).
    pub(super) history: Option<&'a mut dyn Publisher>,
    /// Publications for `later` (reused: no allocation per turn).
    pub(super) queue: Vec<Publication>,
    /// Alerts handed to the ROS 2 publisher, to be marked published in the journal
    /// ([`Outlet::settle`]).
    pub(super) published: Vec<Alert>,
    pub(super) errors: u64,
    pub(super) log: RateLimitedLog,
}

/// Everything handed to the outlet has been journaled: whatever ends the event loop, an
/// error included, the queued publications still go out.
impl Drop for Outlet<'_> {
    fn drop(&mut self) {
        self.flush();
    }
}

impl Outlet<'_> {
    pub(super) fn publish(&mut self, publication: Publication) {
        if let Some(publisher) = &mut self.immediate {
            if let Err(e) = publisher.publish(&publication) {
                Self::failed(&mut self.errors, &mut self.log, &e);
            }
        }
        self.queue.push(publication);
    }

    /// Hands the queued publications to the other publishers.
    pub(super) fn flush(&mut self) {
        for publication in self.queue.drain(..) {
            match (self.ros2.publish(&publication), &publication) {
                (Err(e), _) => Self::failed(&mut self.errors, &mut self.log, &e),
                (Ok(()), Publication::Alert { alert, .. }) => self.published.push(alert.clone()),
                (Ok(()), _) => {}
            }
            for publisher in self.later.iter_mut().chain(self.history.iter_mut()) {
                if let Err(e) = publisher.publish(&publication) {
                    Self::failed(&mut self.errors, &mut self.log, &e);
                }
            }
        }
    }

    /// [`Outlet::flush`], then journals a `Published` marker for every alert handed to ROS 2
    /// (an alert without one is published again at restart).
    pub(super) fn settle(&mut self, runtime: &mut NodeRuntime) {
        self.flush();
        for alert in self.published.drain(..) {
            runtime.mark_published(&alert);
        }
    }

    pub(super) fn failed(errors: &mut u64, log: &mut RateLimitedLog, e: &anyhow::Error) {
        *errors += 1;
        log.log(
            "node",
            "publish_failed",
            &format!("{e:#} ({errors} in all)"),
        );
    }
}

/// Publishes the operator resets just journaled and applied on every output, with the alerts.
pub(super) fn publish_resets(runtime: &mut NodeRuntime, out: &mut Outlet<'_>) {
    for reset in runtime.take_resets() {
        out.publish(Publication::Reset(reset));
    }
    out.flush();
}

/// At start: publishes the journal's last alerts again on ROS 2, in order, with the operator
/// resets among them, rebuilding the transient-local history of `/pbr/alerts` that a late
/// subscriber gets (a reset block's history ends in its reset); an alert never published
/// before (journaled, then a crash) goes to every publisher, and is marked published.
/// Subscribers de-duplicate by (pbr_id, episode, level) — see docs/reliability.md.
pub(super) fn republish_journaled(runtime: &mut NodeRuntime, out: &mut Outlet<'_>) {
    let journaled = runtime.take_journaled_history();
    let (mut all, mut unpublished, mut resets) = (0, 0, 0);
    for entry in journaled {
        let (alert, published) = match entry {
            HistoryEntry::Alert(alert, published) => (alert, published),
            HistoryEntry::Reset(reset) => {
                resets += 1;
                let publication = Publication::Reset(reset);
                if let Err(e) = out.ros2.publish(&publication) {
                    Outlet::failed(&mut out.errors, &mut out.log, &e);
                }
                if let Some(Err(e)) = out.history.as_mut().map(|h| h.publish(&publication)) {
                    Outlet::failed(&mut out.errors, &mut out.log, &e);
                }
                continue;
            }
        };
        all += 1;
        // A journaled alert: not `journal_pending`.
        let publication = Publication::Alert {
            alert,
            latency_ns: 0,
            journal_pending: false,
        };
        if published {
            if let Err(e) = out.ros2.publish(&publication) {
                Outlet::failed(&mut out.errors, &mut out.log, &e);
            }
            if let Some(Err(e)) = out.history.as_mut().map(|h| h.publish(&publication)) {
                Outlet::failed(&mut out.errors, &mut out.log, &e);
            }
        } else {
            unpublished += 1;
            out.publish(publication);
            out.settle(runtime);
        }
    }
    if all > 0 {
        tracing::info!(
            "journal: {all} alerts published again on {ALERTS_TOPIC} (its history for late subscribers), with {resets} operator resets among them; {unpublished} of the alerts had never been published (a crash), now sent to every output"
        );
    }
}
