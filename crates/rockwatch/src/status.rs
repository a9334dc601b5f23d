//! The node's status as an operator sees it: per station (health, latencies, data problems)
//! and for the node (journal, transports, engine real-time margin), with one OK / WARN /
//! ERROR / STALE judgement per item. Built by the node's event loop about once a second
//! ([`StatusBuilder`]); published on `/diagnostics` (`ros2::diagnostics`) and, optionally, as
//! Prometheus text (`metrics`). Transport-free: it knows the engine's types only. A
//! [`StatusReport`] is what a program publishes on `/diagnostics`: the node's items, or
//! `rockwatch acquire`'s (`acquire::PacketPublisher::status_report`).
//!
//! The judgement (one policy, used by both outputs):
//! - a station: **STALE** while no data arrive for `engine.stale_after_s`; **ERROR** if packets
//!   were rejected (invalid or implausible) since the last report; **NO DATA YET** while no
//!   packet of it has been accepted since the node started (and `engine.stale_after_s` has not
//!   passed: then it is STALE); **WARN** if samples were
//!   clipped, a gap broke the stream, samples were missing or samples were dropped as already
//!   processed (duplicate, late, overlapping data) since the last report, or its
//!   last packet arrived more than [`LATENCY_WARN_S`] after its last sample; else **OK**;
//! - the journal: **ERROR** while records wait for a failing state directory or were lost;
//!   else OK (WARN when there is no state directory: alerts are not journaled);
//! - the transports: **ERROR** while the ROS 2 participant is dead; else OK;
//! - the engine: **ERROR** below real time (data seconds processed per second of processing
//!   under 1), **WARN** under [`MARGIN_WARN`]; OK otherwise or when idle.

use std::collections::HashMap;
use std::fmt::Write as _;

use rockwatch_core::dynamics::Mode;
use rockwatch_core::engine::StationHealth;
use rockwatch_core::utc::format_utc_ns;

use crate::wire_codes::mode_code;

/// A station whose last packet arrived this long after its last sample (s) is WARN.
pub const LATENCY_WARN_S: f64 = 10.0;

/// Real-time factor under which the engine is WARN (it keeps up, but with little margin).
pub const MARGIN_WARN: f64 = 2.0;

/// The judgement of an item. Its discriminant is its code on `/metrics`
/// (`rockwatch_station_status`): the `diagnostic_msgs/DiagnosticStatus` levels (OK=0, WARN=1,
/// ERROR=2, STALE=3), and 4 for a station never heard from ([`Level::NoDataYet`]), which
/// `/diagnostics` can only carry as STALE ([`Level::diagnostic_level`]) with its own message
/// and `health` value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    Ok = 0,
    Warn = 1,
    Error = 2,
    Stale = 3,
    /// No packet accepted since the node started, and `engine.stale_after_s` not yet passed:
    /// nothing is known of the station (it is not OK, and not yet stale).
    NoDataYet = 4,
}

impl Level {
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Level::Ok => "OK",
            Level::Warn => "WARN",
            Level::Error => "ERROR",
            Level::Stale => "STALE",
            Level::NoDataYet => "NO DATA YET",
        }
    }

    /// The `diagnostic_msgs/DiagnosticStatus` level byte (OK=0, WARN=1, ERROR=2, STALE=3): a
    /// station with no data yet is STALE there (diagnostic_msgs' level for an item without
    /// data); its message and `health` value say which.
    #[must_use]
    pub fn diagnostic_level(self) -> u8 {
        match self {
            Level::NoDataYet => Level::Stale as u8,
            other => other as u8,
        }
    }

    /// The code of `rockwatch_station_status` on `/metrics` (0 OK, 1 WARN, 2 ERROR, 3 STALE,
    /// 4 NO DATA YET).
    #[must_use]
    pub fn metrics_code(self) -> u8 {
        self as u8
    }
}

/// The last alert of a station, its two latencies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlertLatency {
    /// UTC data time of the triggering sample (ns).
    pub data_time_ns: i64,
    /// Triggering sample → arrival of its packet (s; the station's and the node's clocks).
    pub data_to_arrival_s: f64,
    /// Arrival → handed to the publishers (s; the node's processing, journal sync included).
    pub arrival_to_published_s: f64,
}

/// One station's status.
#[derive(Debug, Clone, PartialEq)]
pub struct StationStatus {
    pub health: StationHealth,
    pub level: Level,
    pub message: String,
    /// Last packet: its last sample → its arrival (s), if any packet arrived.
    pub data_latency_s: Option<f64>,
    /// Since the last accepted packet (s), if any.
    pub silent_s: Option<f64>,
    pub last_alert: Option<AlertLatency>,
    /// Its WGS84 position (degrees north, east) from its `[[station]]` `lat`/`lon`, when
    /// configured (the dashboard's map; a station without one is listed, not drawn).
    pub lat_deg: Option<f64>,
    pub lon_deg: Option<f64>,
}

/// One rock (catalogue block) as the engine's states and alerts last described it: the
/// per-rock series of `/metrics`.
#[derive(Debug, Clone, PartialEq)]
pub struct RockStatus {
    pub pbr_id: String,
    /// Its station (`NET.STA.LOC`).
    pub station: String,
    /// Its mode (on `/metrics` as its `pbr_msgs/PbrState` wire code, [`crate::wire_codes`]).
    pub mode: Mode,
    /// |θ/α| of its last state or alert (dimensionless; 1 is the static overturning angle).
    pub theta_over_alpha: f64,
    /// The largest |θ/α| of its current motion, or of its last one while it is at rest
    /// (dimensionless; 0 if it has not moved since the node started). Taken from the states
    /// (every mode change and every `engine.state_interval_s` while it moves) and alerts.
    pub peak_theta_over_alpha: f64,
    /// Its station is stale: the rock is not monitored.
    pub not_monitored: bool,
    /// The direction of its last state or alert (degrees clockwise from north; NaN before
    /// any).
    pub direction_deg: f64,
    /// P(overturn) of its last state or alert (the ensemble's fraction overturned, 0..1;
    /// NaN before any).
    pub overturn_probability: f64,
    /// Its WGS84 position (degrees north, east) from the catalogue (`lat`, `lon`); None for
    /// a block made in code.
    pub lat_deg: Option<f64>,
    pub lon_deg: Option<f64>,
}

impl RockStatus {
    /// A rock standing at rest (or fallen, `overturned`), before any state of this run.
    #[must_use]
    pub fn new(pbr_id: String, station: String, overturned: bool) -> RockStatus {
        RockStatus {
            pbr_id,
            station,
            mode: if overturned {
                Mode::Overturned
            } else {
                Mode::Rest
            },
            theta_over_alpha: 0.0,
            peak_theta_over_alpha: 0.0,
            not_monitored: false,
            direction_deg: f64::NAN,
            overturn_probability: f64::NAN,
            lat_deg: None,
            lon_deg: None,
        }
    }

    /// Takes in the direction (degrees) and P(overturn) of one state or alert (non-finite
    /// values are ignored).
    pub fn observe_direction(&mut self, direction_deg: f64, overturn_probability: f64) {
        if direction_deg.is_finite() {
            self.direction_deg = direction_deg;
        }
        if overturn_probability.is_finite() {
            self.overturn_probability = overturn_probability;
        }
    }

    /// The same rock at `lat_deg`, `lon_deg` (WGS84 degrees).
    #[must_use]
    pub fn at(mut self, lat_deg: Option<f64>, lon_deg: Option<f64>) -> RockStatus {
        (self.lat_deg, self.lon_deg) = (lat_deg, lon_deg);
        self
    }

    /// Takes in one state or alert: its `mode` and signed `theta_over_alpha` (a motion that
    /// starts from rest starts a new peak); `not_monitored` from a state (an alert: None).
    pub fn observe(&mut self, mode: Mode, theta_over_alpha: f64, not_monitored: Option<bool>) {
        let magnitude = theta_over_alpha.abs();
        if self.mode == Mode::Rest && mode != Mode::Rest {
            self.peak_theta_over_alpha = 0.0;
        }
        if magnitude.is_finite() {
            self.theta_over_alpha = magnitude;
            self.peak_theta_over_alpha = self.peak_theta_over_alpha.max(magnitude);
        }
        self.mode = mode;
        if let Some(flag) = not_monitored {
            self.not_monitored = flag;
        }
    }
}

/// The node's status at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeStatus {
    /// UTC (ns) of the report.
    pub stamp_ns: i64,
    pub stations: Vec<StationStatus>,
    /// The node's rocks, in id order.
    pub rocks: Vec<RockStatus>,
    /// A state directory is configured.
    pub journal_configured: bool,
    pub journal_failures: u64,
    pub journal_backlog: u64,
    pub journal_dropped: u64,
    /// Event reports written, dropped (the writer's queue full) and failed (not written,
    /// logged) since the start (`crate::reports`; 0 without a state directory).
    pub reports_written: u64,
    pub reports_dropped: u64,
    pub reports_failed: u64,
    pub ros2_up: bool,
    pub ros2_rebuilds: u64,
    pub iceoryx2: bool,
    /// Data seconds processed per second of processing over the last period (None: idle, or
    /// not measured: the engine runs on worker threads).
    pub realtime_factor: Option<f64>,
    /// Engine shards (1: inline on the event loop, where the real-time factor is measured).
    pub shards: usize,
    pub packets: u64,
    pub alerts: u64,
    pub rosout_dropped: u64,
    /// `engine.alerts.imminent_theta_ratio`: a moving rock at or above this |θ|/α is shown
    /// "overturn imminent" (the ratio of the node's `overturn_imminent` alert).
    pub imminent_theta_ratio: f64,
}

/// The figures of one item of a status (the node's journal, transports, engine, a station;
/// acquire's link, publication, a station).
#[derive(Debug, Clone, PartialEq)]
pub struct Item {
    /// `journal`, `transports`, `engine`, or `station NET.STA.LOC`; acquire's `link`,
    /// `publication`, `station NET.STA.LOC`.
    pub name: String,
    pub hardware_id: String,
    pub level: Level,
    pub message: String,
    pub values: Vec<(String, String)>,
}

/// One status report of a program as diagnostic_updater publishes it: its items, each named
/// `<prefix>: <item name>` on `/diagnostics` (`ros2::diagnostics::DiagnosticArray`).
#[derive(Debug, Clone, PartialEq)]
pub struct StatusReport {
    /// UTC (ns) of the report.
    pub stamp_ns: i64,
    /// The program: `rockwatch` (the node), `rockwatch acquire`.
    pub prefix: &'static str,
    pub items: Vec<Item>,
}

impl NodeStatus {
    /// Every item, the node's three first, then the stations in id order.
    #[must_use]
    pub fn items(&self) -> Vec<Item> {
        let mut items = Vec::with_capacity(3 + self.stations.len());
        let (level, message) = if !self.journal_configured {
            (
                Level::Warn,
                "no state directory: alerts are not journaled".to_string(),
            )
        } else if self.journal_backlog + self.journal_dropped > 0 {
            (
                Level::Error,
                format!(
                    "state directory failing: {} records waiting, {} lost",
                    self.journal_backlog, self.journal_dropped
                ),
            )
        } else {
            (Level::Ok, "healthy".to_string())
        };
        items.push(Item {
            name: "journal".into(),
            hardware_id: "state directory".into(),
            level,
            message,
            values: vec![
                kv("configured", self.journal_configured),
                kv("failed_writes", self.journal_failures),
                kv("backlog_records", self.journal_backlog),
                kv("lost_records", self.journal_dropped),
            ],
        });
        items.push(Item {
            name: "transports".into(),
            hardware_id: "ros2, iceoryx2".into(),
            level: if self.ros2_up {
                Level::Ok
            } else {
                Level::Error
            },
            message: match (self.ros2_up, self.iceoryx2) {
                (true, true) => "ROS 2 and iceoryx2 up".into(),
                (true, false) => "ROS 2 up (iceoryx2 not configured)".into(),
                (false, _) => "ROS 2 participant dead: rebuilding".into(),
            },
            values: vec![
                kv("ros2_up", self.ros2_up),
                kv("ros2_rebuilds", self.ros2_rebuilds),
                kv("iceoryx2", self.iceoryx2),
                kv("rosout_dropped", self.rosout_dropped),
            ],
        });
        let (level, message) = match self.realtime_factor {
            None if self.shards > 1 => (
                Level::Ok,
                format!(
                    "real-time factor not measured ({} engine worker threads)",
                    self.shards
                ),
            ),
            None => (Level::Ok, "idle (no data in the last period)".to_string()),
            Some(f) if f < 1.0 => (Level::Error, format!("behind real time: {f:.2}×")),
            Some(f) if f < MARGIN_WARN => {
                (Level::Warn, format!("little margin: {f:.2}× real time"))
            }
            Some(f) => (Level::Ok, format!("{f:.0}× real time")),
        };
        items.push(Item {
            name: "engine".into(),
            hardware_id: "engine".into(),
            level,
            message,
            values: vec![
                kv(
                    "realtime_factor",
                    self.realtime_factor
                        .map_or("".to_string(), |f| format!("{f:.3}")),
                ),
                kv("packets", self.packets),
                kv("alerts", self.alerts),
                kv("stations", self.stations.len()),
                kv(
                    "stations_stale",
                    self.stations
                        .iter()
                        .filter(|s| s.level == Level::Stale)
                        .count(),
                ),
                kv(
                    "stations_no_data_yet",
                    self.stations
                        .iter()
                        .filter(|s| s.level == Level::NoDataYet)
                        .count(),
                ),
            ],
        });
        for s in &self.stations {
            let h = &s.health;
            let opt = |v: Option<f64>, digits: usize| {
                v.map_or(String::new(), |x| format!("{x:.digits$}"))
            };
            let mut values = vec![
                kv("health", s.level.as_str()),
                kv("data_latency_s", opt(s.data_latency_s, 3)),
                kv("seconds_since_last_packet", opt(s.silent_s, 3)),
                kv(
                    "last_data_time",
                    h.last_sample_ns
                        .map_or(String::new(), |t| format_utc_ns(i128::from(t))),
                ),
                kv("sample_rate_hz", h.sample_rate_hz),
                kv("packets", h.packets),
                kv("rejected_packets", h.rejected_packets),
                kv("rejected_samples", h.rejected_samples),
                kv("clipped_samples", h.clipped_samples),
                kv("gaps_bridged", h.gaps_bridged),
                kv("gaps_broken", h.gaps_broken),
                kv("missing_samples", h.missing_samples),
                kv("late_packets", h.late_packets),
                kv("duplicate_packets", h.duplicate_packets),
                kv("dropped_samples", h.dropped_samples),
                kv("blocks", h.blocks),
                kv("monitored", h.monitored),
                kv("stale_events", h.stale_events),
            ];
            if let Some(a) = s.last_alert {
                values.push(kv(
                    "last_alert_data_time",
                    format_utc_ns(i128::from(a.data_time_ns)),
                ));
                values.push(kv(
                    "last_alert_data_to_arrival_s",
                    format!("{:.3}", a.data_to_arrival_s),
                ));
                values.push(kv(
                    "last_alert_arrival_to_published_s",
                    format!("{:.6}", a.arrival_to_published_s),
                ));
            }
            items.push(Item {
                name: format!("station {}", h.station),
                hardware_id: h.station.to_string(),
                level: s.level,
                message: s.message.clone(),
                values,
            });
        }
        items
    }

    /// The same figures in the Prometheus text exposition format (version 0.0.4).
    #[must_use]
    pub fn prometheus(&self) -> String {
        let mut out = String::new();
        let mut metric = |name: &str, help: &str, kind: &str, samples: &[(String, f64)]| {
            let _ = writeln!(out, "# HELP rockwatch_{name} {help}");
            let _ = writeln!(out, "# TYPE rockwatch_{name} {kind}");
            for (labels, value) in samples {
                let _ = writeln!(out, "rockwatch_{name}{labels} {value}");
            }
        };
        let node = |v: f64| vec![(String::new(), v)];
        let b = |v: bool| f64::from(u8::from(v));
        metric("up", "1 while the node runs", "gauge", &node(1.0));
        metric(
            "packets_total",
            "Packets handed to the engine",
            "counter",
            &node(self.packets as f64),
        );
        metric(
            "alerts_total",
            "Alerts raised",
            "counter",
            &node(self.alerts as f64),
        );
        metric(
            "journal_failed_writes_total",
            "Failed writes to the state directory",
            "counter",
            &node(self.journal_failures as f64),
        );
        metric(
            "journal_backlog_records",
            "Records waiting for a failing state directory",
            "gauge",
            &node(self.journal_backlog as f64),
        );
        metric(
            "reports_written_total",
            "Event reports written (reports/ in the state directory)",
            "counter",
            &node(self.reports_written as f64),
        );
        metric(
            "reports_dropped_total",
            "Event reports dropped: the report writer was behind",
            "counter",
            &node(self.reports_dropped as f64),
        );
        metric(
            "reports_failed_total",
            "Event reports that could not be written (logged)",
            "counter",
            &node(self.reports_failed as f64),
        );
        metric(
            "ros2_up",
            "1 while the ROS 2 participant runs",
            "gauge",
            &node(b(self.ros2_up)),
        );
        metric(
            "ros2_rebuilds_total",
            "ROS 2 participants rebuilt",
            "counter",
            &node(self.ros2_rebuilds as f64),
        );
        if let Some(f) = self.realtime_factor {
            metric(
                "engine_realtime_factor",
                "Data seconds processed per second of processing (last period)",
                "gauge",
                &node(f),
            );
        }
        let per = |f: &dyn Fn(&StationStatus) -> Option<f64>| -> Vec<(String, f64)> {
            self.stations
                .iter()
                .filter_map(|s| {
                    f(s).map(|v| {
                        (
                            format!("{{station=\"{}\"}}", label(s.health.station.as_str())),
                            v,
                        )
                    })
                })
                .collect()
        };
        metric(
            "station_status",
            "0 OK, 1 WARN, 2 ERROR, 3 STALE, 4 NO DATA YET (no packet since the start)",
            "gauge",
            &per(&|s| Some(f64::from(s.level.metrics_code()))),
        );
        metric(
            "station_monitored",
            "1 unless the station is stale",
            "gauge",
            &per(&|s| Some(b(s.health.monitored))),
        );
        metric(
            "station_data_latency_seconds",
            "Last packet: its last sample to its arrival",
            "gauge",
            &per(&|s| s.data_latency_s),
        );
        metric(
            "station_seconds_since_last_packet",
            "Since the last accepted packet",
            "gauge",
            &per(&|s| s.silent_s),
        );
        metric(
            "station_sample_rate_hz",
            "Sample rate of the last packet",
            "gauge",
            &per(&|s| Some(s.health.sample_rate_hz)),
        );
        metric(
            "station_packets_total",
            "Accepted packets",
            "counter",
            &per(&|s| Some(s.health.packets as f64)),
        );
        metric(
            "station_rejected_packets_total",
            "Rejected packets (invalid or implausible)",
            "counter",
            &per(&|s| Some(s.health.rejected_packets as f64)),
        );
        metric(
            "station_rejected_samples_total",
            "Samples of rejected packets",
            "counter",
            &per(&|s| Some(s.health.rejected_samples as f64)),
        );
        metric(
            "station_clipped_samples_total",
            "Samples at or beyond 99.9 % of full scale",
            "counter",
            &per(&|s| Some(s.health.clipped_samples as f64)),
        );
        metric(
            "station_gaps_broken_total",
            "Gaps too long to bridge",
            "counter",
            &per(&|s| Some(s.health.gaps_broken as f64)),
        );
        metric(
            "station_missing_samples_total",
            "Samples missing in gaps",
            "counter",
            &per(&|s| Some(s.health.missing_samples as f64)),
        );
        metric(
            "station_late_packets_total",
            "Packets that arrived after later data had been processed (dropped wholly or partly)",
            "counter",
            &per(&|s| Some(s.health.late_packets as f64)),
        );
        metric(
            "station_duplicate_packets_total",
            "Packets whose every sample had been processed already (dropped)",
            "counter",
            &per(&|s| Some(s.health.duplicate_packets as f64)),
        );
        metric(
            "station_dropped_samples_total",
            "Samples dropped because the station had that data, or later data, already (duplicate, late or overlapping packets)",
            "counter",
            &per(&|s| Some(s.health.dropped_samples as f64)),
        );
        metric(
            "station_stale_events_total",
            "Times the station went stale",
            "counter",
            &per(&|s| Some(s.health.stale_events as f64)),
        );
        metric(
            "station_last_alert_data_to_arrival_seconds",
            "Last alert: triggering sample to arrival",
            "gauge",
            &per(&|s| s.last_alert.map(|a| a.data_to_arrival_s)),
        );
        metric(
            "station_last_alert_arrival_to_published_seconds",
            "Last alert: arrival to published",
            "gauge",
            &per(&|s| s.last_alert.map(|a| a.arrival_to_published_s)),
        );
        let rock = |f: &dyn Fn(&RockStatus) -> f64| -> Vec<(String, f64)> {
            self.rocks
                .iter()
                .map(|r| {
                    (
                        format!(
                            "{{pbr=\"{}\",station=\"{}\"}}",
                            label(&r.pbr_id),
                            label(&r.station)
                        ),
                        f(r),
                    )
                })
                .collect()
        };
        metric(
            "rock_state",
            "Mode, as pbr_msgs/PbrState: 0 rest, 1 slide, 2 rock, 3 slide-rock, 4 overturned, 5 flight",
            "gauge",
            &rock(&|r| f64::from(mode_code(r.mode))),
        );
        metric(
            "rock_theta_over_alpha",
            "|theta|/alpha of the last state (1 = static overturning angle)",
            "gauge",
            &rock(&|r| r.theta_over_alpha),
        );
        metric(
            "rock_peak_theta_over_alpha",
            "Largest |theta|/alpha of the current motion, or of the last one while at rest",
            "gauge",
            &rock(&|r| r.peak_theta_over_alpha),
        );
        metric(
            "rock_not_monitored",
            "1 while the rock's station is stale (the rock is not monitored)",
            "gauge",
            &rock(&|r| b(r.not_monitored)),
        );
        out
    }
}

/// One `values` entry of an [`Item`].
pub(crate) fn kv(key: &str, value: impl ToString) -> (String, String) {
    (key.to_string(), value.to_string())
}

/// A Prometheus label value: `\`, `"` and line feeds escaped.
fn label(text: &str) -> String {
    text.replace('\\', "\\\\")
        .replace('"', "\\\"")
        .replace('\n', "\\n")
}

/// Judges stations report after report (the counters' increase since the previous report).
#[derive(Debug, Default)]
pub struct StatusBuilder {
    /// Per station: rejected packets, clipped samples, broken gaps, missing samples at the
    /// previous report.
    previous: HashMap<String, [u64; 5]>,
}

impl StatusBuilder {
    /// One station's status from its `health`, at `now_ns` on the arrival clock, with
    /// `epoch_utc_ns` the UTC time of that clock's zero.
    pub fn station(
        &mut self,
        health: StationHealth,
        now_ns: i64,
        epoch_utc_ns: i64,
        last_alert: Option<AlertLatency>,
    ) -> StationStatus {
        let counts = [
            health.rejected_packets,
            health.clipped_samples,
            health.gaps_broken,
            health.missing_samples,
            health.dropped_samples,
        ];
        let before = self
            .previous
            .insert(health.station.to_string(), counts)
            .unwrap_or([0; 5]);
        let new = |i: usize| counts[i].saturating_sub(before[i]);
        let data_latency_s = match (health.last_arrival_ns, health.last_sample_ns) {
            (Some(a), Some(t)) => Some((epoch_utc_ns + a - t) as f64 * 1e-9),
            _ => None,
        };
        let silent_s = health.last_arrival_ns.map(|a| (now_ns - a) as f64 * 1e-9);
        let (level, message) = if !health.monitored {
            (
                Level::Stale,
                match silent_s {
                    Some(s) => format!(
                        "no data for {s:.0} s: its {} blocks are not monitored",
                        health.blocks
                    ),
                    None => format!(
                        "no data yet: its {} blocks are not monitored",
                        health.blocks
                    ),
                },
            )
        } else if new(0) > 0 {
            (
                Level::Error,
                format!("{} packets rejected since the last report", new(0)),
            )
        } else if new(1) + new(2) + new(3) + new(4) > 0 {
            (
                Level::Warn,
                format!(
                    "since the last report: {} clipped samples, {} broken gaps, {} missing samples, {} samples dropped as already processed (duplicate, late or overlapping data)",
                    new(1),
                    new(2),
                    new(3),
                    new(4)
                ),
            )
        } else if health.last_arrival_ns.is_none() {
            (
                Level::NoDataYet,
                format!(
                    "no data yet: no packet since the node started; its {} blocks wait for \
                     their first data (stale after engine.stale_after_s)",
                    health.blocks
                ),
            )
        } else if data_latency_s.is_some_and(|l| l > LATENCY_WARN_S) {
            (
                Level::Warn,
                format!(
                    "data arrive late: {:.1} s after their last sample",
                    data_latency_s.unwrap_or(0.0)
                ),
            )
        } else {
            (Level::Ok, "receiving data".into())
        };
        StationStatus {
            health,
            level,
            message,
            data_latency_s,
            silent_s,
            last_alert,
            lat_deg: None,
            lon_deg: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn health(station: &str) -> StationHealth {
        StationHealth {
            station: rockwatch_core::engine::StationId::parse(station).unwrap(),
            monitored: true,
            blocks: 2,
            last_arrival_ns: Some(5_000_000_000),
            last_sample_ns: Some(1_000_000_000_000 + 4_000_000_000),
            sample_rate_hz: 100.0,
            packets: 10,
            samples: 1000,
            rejected_packets: 0,
            rejected_samples: 0,
            clipped_samples: 0,
            gaps_bridged: 0,
            gaps_broken: 0,
            missing_samples: 0,
            late_packets: 0,
            duplicate_packets: 0,
            dropped_samples: 0,
            stale_events: 0,
        }
    }

    #[test]
    fn stations_are_judged_on_what_changed_since_the_last_report() {
        let mut b = StatusBuilder::default();
        let epoch_utc = 1_000_000_000_000; // the arrival clock's zero, UTC
        let s = b.station(health("XX.A.00"), 6_000_000_000, epoch_utc, None);
        assert_eq!(s.level, Level::Ok);
        // Arrival 5 s after the clock's zero, last sample 4 s after it: 1 s of latency.
        assert!((s.data_latency_s.unwrap() - 1.0).abs() < 1e-9);
        assert!((s.silent_s.unwrap() - 1.0).abs() < 1e-9);
        let mut h = health("XX.A.00");
        h.rejected_packets = 3;
        assert_eq!(
            b.station(h.clone(), 6_000_000_000, epoch_utc, None).level,
            Level::Error
        );
        // The same count again: nothing new.
        assert_eq!(
            b.station(h.clone(), 7_000_000_000, epoch_utc, None).level,
            Level::Ok
        );
        h.clipped_samples = 1;
        assert_eq!(
            b.station(h.clone(), 8_000_000_000, epoch_utc, None).level,
            Level::Warn
        );
        // Issue 20 item 3: data dropped as already processed make the station WARN too.
        assert_eq!(
            b.station(h.clone(), 8_500_000_000, epoch_utc, None).level,
            Level::Ok
        );
        h.dropped_samples = 201;
        let dropped = b.station(h.clone(), 9_000_000_000, epoch_utc, None);
        assert_eq!(dropped.level, Level::Warn);
        assert!(
            dropped
                .message
                .contains("201 samples dropped as already processed"),
            "{}",
            dropped.message
        );
        h.monitored = false;
        let stale = b.station(h, 90_000_000_000, epoch_utc, None);
        assert_eq!(stale.level, Level::Stale);
        assert!(stale.message.contains("not monitored"), "{}", stale.message);
    }

    #[test]
    fn a_station_never_heard_from_has_no_data_yet_until_it_is_stale() {
        let mut b = StatusBuilder::default();
        let mut h = health("XX.A.00");
        (h.last_arrival_ns, h.last_sample_ns, h.packets) = (None, None, 0);
        let s = b.station(h.clone(), 6_000_000_000, 0, None);
        assert_eq!(s.level, Level::NoDataYet);
        assert_eq!(s.level.diagnostic_level(), Level::Stale as u8);
        assert_eq!(s.level.metrics_code(), 4);
        assert!(s.message.starts_with("no data yet"), "{}", s.message);
        h.monitored = false;
        assert_eq!(b.station(h, 90_000_000_000, 0, None).level, Level::Stale);
    }

    #[test]
    fn a_rock_keeps_the_peak_of_its_last_motion_until_it_moves_again() {
        let mut r = RockStatus::new("r".into(), "XX.A.00".into(), false);
        r.observe(Mode::Rock, -0.4, None);
        r.observe(Mode::Rock, 0.2, Some(false));
        r.observe(Mode::Rest, 0.0, Some(false));
        assert_eq!((r.theta_over_alpha, r.peak_theta_over_alpha), (0.0, 0.4));
        r.observe(Mode::Rest, 0.0, Some(true));
        assert!(r.not_monitored);
        r.observe(Mode::Slide, 0.1, None);
        assert_eq!((r.mode, r.peak_theta_over_alpha), (Mode::Slide, 0.1));
    }

    #[test]
    fn prometheus_text_has_help_type_and_labelled_samples() {
        let mut b = StatusBuilder::default();
        // A station id is a checked `StationId` (it cannot hold a quote); a rock's station
        // text in its status can, and is escaped below.
        let station = b.station(health("XX.Q.00"), 6_000_000_000, 1_000_000_000_000, None);
        let status = NodeStatus {
            stamp_ns: 0,
            stations: vec![station],
            rocks: vec![RockStatus::new("r\\1".into(), "XX.\"Q\".00".into(), false)],
            journal_configured: true,
            journal_failures: 0,
            journal_backlog: 0,
            journal_dropped: 0,
            reports_written: 0,
            reports_dropped: 0,
            reports_failed: 0,
            ros2_up: true,
            ros2_rebuilds: 0,
            iceoryx2: false,
            realtime_factor: Some(12.5),
            shards: 1,
            packets: 10,
            alerts: 0,
            rosout_dropped: 0,
            imminent_theta_ratio: 0.8,
        };
        let text = status.prometheus();
        assert!(text.contains("# TYPE rockwatch_station_packets_total counter\n"));
        assert!(
            text.contains("rockwatch_station_packets_total{station=\"XX.Q.00\"} 10\n"),
            "{text}"
        );
        assert!(text.contains("rockwatch_engine_realtime_factor 12.5\n"));
        assert!(
            text.contains("rockwatch_rock_state{pbr=\"r\\\\1\",station=\"XX.\\\"Q\\\".00\"} 0\n"),
            "{text}"
        );
        let items = status.items();
        assert_eq!(items.len(), 4);
        assert_eq!(items[3].hardware_id, "XX.Q.00");
    }
}

/// The `[status]` section of the node configuration.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StatusConfig {
    /// How often the status goes to `/diagnostics` (and the metrics endpoint), s.
    pub diagnostics_period_s: f64,
    /// rockwatch's log records at or above this level also go to `/rosout`: `debug`, `info`,
    /// `warn`, `error` or `off` (they must pass the log filter too).
    pub rosout_level: String,
}

impl Default for StatusConfig {
    fn default() -> Self {
        StatusConfig {
            diagnostics_period_s: 1.0,
            rosout_level: "info".into(),
        }
    }
}

/// Why the `[status]` section is refused (the message names the key).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StatusConfigError {
    #[error("status.diagnostics_period_s = {0} is out of range [0.1, 3600] s")]
    DiagnosticsPeriod(f64),
    #[error("status.rosout_level = {0:?}: expected debug, info, warn, error or off")]
    RosoutLevel(String),
}

impl StatusConfig {
    /// Checks the values.
    pub fn validate(&self) -> Result<(), StatusConfigError> {
        if !(self.diagnostics_period_s >= 0.1 && self.diagnostics_period_s <= 3600.0) {
            return Err(StatusConfigError::DiagnosticsPeriod(
                self.diagnostics_period_s,
            ));
        }
        self.rosout().map(|_| ())
    }

    /// The `/rosout` level (None: off).
    pub fn rosout(&self) -> Result<Option<tracing::Level>, StatusConfigError> {
        match self.rosout_level.as_str() {
            "off" => Ok(None),
            "debug" => Ok(Some(tracing::Level::DEBUG)),
            "info" => Ok(Some(tracing::Level::INFO)),
            "warn" => Ok(Some(tracing::Level::WARN)),
            "error" => Ok(Some(tracing::Level::ERROR)),
            other => Err(StatusConfigError::RosoutLevel(other.to_owned())),
        }
    }
}
