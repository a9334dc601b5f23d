//! The dashboard's JSON API and live stream, served from the web thread's shared state
//! ([`Shared`]): the last status the event loop handed over, the alert history and the
//! connected stream clients. See the README's "Web dashboard" section for every field.

use std::collections::VecDeque;
use std::convert::Infallible;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use axum::extract::{Path, Query, State};
use axum::http::{header, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Response};
use serde_json::{json, Value};
use tokio::sync::{mpsc, watch};

use crate::alert_json::RecordJson;
use crate::number_text::json_number;
use crate::ports::Publication;
use crate::status::{Level, NodeStatus};
use crate::traces::{
    EpisodeTrace, TracesSnapshot, WantedStations, BIN_NS, COMPONENTS, RETENTION_S,
};
use crate::wire_codes::mode_code;
use rockwatch_core::dynamics::Mode;
use rockwatch_core::engine::JournalRecord;

/// Alerts and resets kept for `/api/alerts` and a new page (the newest; older ones are
/// forgotten by the web side, never by the journal).
pub const HISTORY: usize = 1000;

/// Events queued for one stream client (`/api/events`); a client this far behind is dropped.
pub const CLIENT_QUEUE: usize = 64;

/// Most stream clients at once; one more is refused with 503.
pub const MAX_CLIENTS: usize = 64;

/// The web side's counters (on `/metrics` as `rockwatch_web_*`).
#[derive(Debug, Default)]
pub struct WebCounters {
    /// Alerts (and resets) the event loop could not hand over: the hand-off queue was full.
    pub handoff_dropped: AtomicU64,
    /// Alerts (and resets) handed over.
    pub handed_over: AtomicU64,
    /// Stream clients dropped because they fell [`CLIENT_QUEUE`] events behind.
    pub clients_dropped: AtomicU64,
    /// Stream clients refused: [`MAX_CLIENTS`] already connected.
    pub clients_refused: AtomicU64,
}

/// One item of the alert feed: its JSON text and the time it is filtered on.
#[derive(Debug)]
pub struct FeedItem {
    /// Data time of an alert, wall-clock time of a reset (ns since the Unix epoch).
    pub time_ns: i64,
    pub json: Arc<str>,
}

/// One event for a stream client: its SSE event name and JSON data.
type StreamEvent = (&'static str, Arc<str>);

/// What the web thread's handlers share.
pub struct Shared {
    pub status: watch::Receiver<Option<Arc<NodeStatus>>>,
    pub traces: watch::Receiver<Arc<TracesSnapshot>>,
    /// The stations whose rings a client asked for (the next snapshots hold them).
    pub wanted: Arc<WantedStations>,
    pub history: Mutex<VecDeque<Arc<FeedItem>>>,
    clients: Mutex<Vec<mpsc::Sender<StreamEvent>>>,
    pub counters: Arc<WebCounters>,
}

impl Shared {
    #[must_use]
    pub fn new(
        status: watch::Receiver<Option<Arc<NodeStatus>>>,
        traces: watch::Receiver<Arc<TracesSnapshot>>,
        wanted: Arc<WantedStations>,
        counters: Arc<WebCounters>,
    ) -> Shared {
        Shared {
            status,
            traces,
            wanted,
            history: Mutex::new(VecDeque::new()),
            clients: Mutex::new(Vec::new()),
            counters,
        }
    }

    /// Hands `event` to every stream client without waiting: a client whose queue is full is
    /// dropped (its stream ends) and counted; one that has gone is forgotten.
    fn broadcast(&self, name: &'static str, data: &Arc<str>) {
        let Ok(mut clients) = self.clients.lock() else {
            return;
        };
        clients.retain(|c| match c.try_send((name, Arc::clone(data))) {
            Ok(()) => true,
            Err(mpsc::error::TrySendError::Full(_)) => {
                self.counters
                    .clients_dropped
                    .fetch_add(1, Ordering::Relaxed);
                tracing::info!("web: a stream client fell {CLIENT_QUEUE} events behind: dropped");
                false
            }
            Err(mpsc::error::TrySendError::Closed(_)) => false,
        });
    }

    fn clients(&self) -> usize {
        self.clients.lock().map(|c| c.len()).unwrap_or(0)
    }

    /// Takes in one publication handed over by the event loop (alerts and resets; the rest
    /// is ignored): kept in the history and sent to the stream clients.
    pub fn take(&self, publication: &Publication) {
        let Some(item) = feed_item(publication) else {
            return;
        };
        let item = Arc::new(item);
        if let Ok(mut history) = self.history.lock() {
            if history.len() == HISTORY {
                history.pop_front();
            }
            history.push_back(Arc::clone(&item));
        }
        self.broadcast("alert", &item.json);
    }

    /// The status changed: sent to the stream clients.
    pub fn status_changed(&self) {
        let status = self.status.borrow().clone();
        if let Some(status) = status {
            let json: Arc<str> = status_json(&status).to_string().into();
            self.broadcast("status", &json);
        }
    }

    /// The node's Prometheus text with the web side's own series.
    #[must_use]
    pub fn prometheus(&self) -> String {
        let status = self.status.borrow().clone();
        let mut text = match status {
            Some(s) => s.prometheus(),
            None => "# no status yet\n".to_string(),
        };
        let c = &self.counters;
        let mut metric = |name: &str, help: &str, kind: &str, value: u64| {
            text.push_str(&format!(
                "# HELP rockwatch_web_{name} {help}\n# TYPE rockwatch_web_{name} {kind}\nrockwatch_web_{name} {value}\n"
            ));
        };
        metric(
            "handoff_dropped_total",
            "Alerts and resets the event loop could not hand to the web server (its queue was full).",
            "counter",
            c.handoff_dropped.load(Ordering::Relaxed),
        );
        metric(
            "handed_over_total",
            "Alerts and resets handed to the web server.",
            "counter",
            c.handed_over.load(Ordering::Relaxed),
        );
        metric(
            "clients_dropped_total",
            "Live-stream clients dropped for falling behind.",
            "counter",
            c.clients_dropped.load(Ordering::Relaxed),
        );
        metric(
            "clients_refused_total",
            "Live-stream clients refused (too many connected).",
            "counter",
            c.clients_refused.load(Ordering::Relaxed),
        );
        metric(
            "clients",
            "Live-stream clients connected.",
            "gauge",
            self.clients() as u64,
        );
        text
    }
}

/// The feed's item for an alert or a reset.
fn feed_item(publication: &Publication) -> Option<FeedItem> {
    let (time_ns, record) = match publication {
        Publication::Alert { alert, .. } => (
            alert.data_time_ns,
            RecordJson::from(&JournalRecord::Alert(alert.clone())),
        ),
        Publication::Reset(reset) => (
            reset.time_ns,
            RecordJson::from(&JournalRecord::Reset {
                pbr_id: reset.pbr_id.clone(),
                time_ns: Some(reset.time_ns),
            }),
        ),
        _ => return None,
    };
    let json = serde_json::to_string(&record).ok()?;
    Some(FeedItem {
        time_ns,
        json: json.into(),
    })
}

/// How the page shows a rock: `standing`, `moving` (rocking or sliding: see
/// `theta_over_alpha`), `imminent` (moving with |θ|/α at or above `imminent_theta_ratio`,
/// the threshold of the node's `overturn_imminent` alert, `engine.alerts.imminent_theta_ratio`),
/// `fallen`, `not_monitored` (its station is stale).
pub fn rock_display(
    mode: Mode,
    theta_over_alpha: f64,
    not_monitored: bool,
    imminent_theta_ratio: f64,
) -> &'static str {
    match mode {
        Mode::Overturned => "fallen",
        _ if not_monitored => "not_monitored",
        Mode::Rest => "standing",
        _ if theta_over_alpha.abs() >= imminent_theta_ratio => "imminent",
        _ => "moving",
    }
}

/// `/api/status`: the node's status as JSON (see the README for the fields and units).
#[must_use]
pub fn status_json(s: &NodeStatus) -> Value {
    let stations: Vec<Value> = s
        .stations
        .iter()
        .map(|st| {
            json!({
                "id": st.health.station,
                "health": st.level.as_str(),
                "stale": st.level == Level::Stale,
                "message": st.message,
                "data_latency_s": st.data_latency_s.map(json_number),
                "seconds_since_last_packet": st.silent_s.map(json_number),
                "last_sample_ns": st.health.last_sample_ns,
                "sample_rate_hz": json_number(st.health.sample_rate_hz),
                "packets": st.health.packets,
                "blocks": st.health.blocks,
                "monitored": st.health.monitored,
                "lat_deg": st.lat_deg.map(json_number),
                "lon_deg": st.lon_deg.map(json_number),
            })
        })
        .collect();
    let rocks: Vec<Value> = s
        .rocks
        .iter()
        .map(|r| {
            json!({
                "pbr_id": r.pbr_id,
                "station": r.station,
                "mode": r.mode,
                "mode_code": mode_code(r.mode),
                "display": rock_display(
                    r.mode,
                    r.theta_over_alpha,
                    r.not_monitored,
                    s.imminent_theta_ratio
                ),
                "theta_over_alpha": json_number(r.theta_over_alpha),
                "peak_theta_over_alpha": json_number(r.peak_theta_over_alpha),
                "direction_deg": json_number(r.direction_deg),
                "overturn_probability": json_number(r.overturn_probability),
                "not_monitored": r.not_monitored,
                "lat_deg": r.lat_deg.map(json_number),
                "lon_deg": r.lon_deg.map(json_number),
            })
        })
        .collect();
    json!({
        "stamp_ns": s.stamp_ns,
        "stations": stations,
        "rocks": rocks,
        "node": {
            "packets": s.packets,
            "alerts": s.alerts,
            "journal_configured": s.journal_configured,
            "journal_backlog": s.journal_backlog,
            "journal_lost": s.journal_dropped,
            "ros2_up": s.ros2_up,
            "iceoryx2": s.iceoryx2,
            "realtime_factor": s.realtime_factor.map(json_number),
            "imminent_theta_ratio": json_number(s.imminent_theta_ratio),
        },
    })
}

/// A JSON body with status 200.
fn json_text(text: String) -> Response {
    ([(header::CONTENT_TYPE, "application/json")], text).into_response()
}

fn error(status: StatusCode, message: String) -> Response {
    (
        status,
        [(header::CONTENT_TYPE, "application/json")],
        json!({ "error": message }).to_string(),
    )
        .into_response()
}

/// `GET /api/status`: 503 until the node's first status (one status period after start).
pub async fn get_status(State(shared): State<Arc<Shared>>) -> Response {
    let status = shared.status.borrow().clone();
    match status {
        Some(s) => json_text(status_json(&s).to_string()),
        None => error(
            StatusCode::SERVICE_UNAVAILABLE,
            "no status yet: the node publishes its first one status period after start".into(),
        ),
    }
}

/// `GET /api/rocks/{id}`: one rock's status and its alerts in the history; 404 for an id
/// the node does not monitor.
pub async fn get_rock(State(shared): State<Arc<Shared>>, Path(id): Path<String>) -> Response {
    let status = shared.status.borrow().clone();
    let Some(status) = status else {
        return error(StatusCode::SERVICE_UNAVAILABLE, "no status yet".into());
    };
    let Some(rock) = status_json(&status)["rocks"]
        .as_array()
        .and_then(|rocks| rocks.iter().find(|r| r["pbr_id"] == id.as_str()).cloned())
    else {
        return error(
            StatusCode::NOT_FOUND,
            format!("no rock {id:?} on this node: /api/status lists them"),
        );
    };
    let alerts: Vec<Value> = history(&shared, i64::MIN)
        .into_iter()
        .filter(|a| a["pbr_id"] == id.as_str())
        .collect();
    let traces = shared.traces.borrow().clone();
    let episode = traces.rocks.get(&id).map(|e| episode_json(e));
    json_text(
        json!({
            "rock": rock,
            "alerts": alerts,
            "episode": episode,
            "imminent_theta_ratio": json_number(status.imminent_theta_ratio),
        })
        .to_string(),
    )
}

/// A rock's episode trace: parallel arrays, oldest first, and its alert marks (see
/// [`crate::traces`] for the bounds).
fn episode_json(e: &EpisodeTrace) -> Value {
    let marks: Vec<Value> = e
        .marks
        .iter()
        .map(|m| {
            json!({
                "data_time_ns": m.data_time_ns,
                "level": m.level.as_str(),
                "theta_over_alpha": json_number(m.theta_over_alpha),
                "overturn_probability": json_number(m.overturn_probability),
            })
        })
        .collect();
    json!({
        "episode": e.episode,
        "ended": e.ended,
        "stride": e.stride,
        "data_time_ns": e.points.iter().map(|p| p.data_time_ns).collect::<Vec<_>>(),
        "theta_over_alpha": e.points.iter().map(|p| json_number(p.theta_over_alpha)).collect::<Vec<_>>(),
        "slide_m": e.points.iter().map(|p| json_number(p.slide_m)).collect::<Vec<_>>(),
        "mode": e.points.iter().map(|p| p.mode).collect::<Vec<_>>(),
        "alerts": marks,
    })
}

/// The query of `/api/stations/{id}/trace`.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TraceQuery {
    /// Data seconds up to the newest sample, in (0, [`RETENTION_S`]]; default 120.
    pub seconds: Option<f64>,
}

/// `GET /api/stations/{id}/trace?seconds=<s>`: the station's last `seconds` of its three
/// components as a min/max envelope of [`BIN_NS`] bins (see [`crate::traces`]) and its
/// running intensity measures; 404 for a station the node does not have, 400 for a
/// `seconds` out of (0, retention].
pub async fn get_station_trace(
    State(shared): State<Arc<Shared>>,
    Path(id): Path<String>,
    query: Result<Query<TraceQuery>, axum::extract::rejection::QueryRejection>,
) -> Response {
    let usage = format!("seconds=<s in (0, {RETENTION_S}]>");
    let seconds = match query {
        Ok(Query(q)) => q.seconds.unwrap_or(f64::from(RETENTION_S)),
        Err(e) => return error(StatusCode::BAD_REQUEST, format!("{e}: takes {usage}")),
    };
    if !(seconds > 0.0 && seconds <= f64::from(RETENTION_S)) {
        return error(
            StatusCode::BAD_REQUEST,
            format!("seconds = {seconds}: takes {usage} (the node keeps {RETENTION_S} s)"),
        );
    }
    let traces = match station_traces(&shared, &id).await {
        Ok(traces) => traces,
        Err(response) => return response,
    };
    let Some(view) = traces.stations.get(&id) else {
        return error(
            StatusCode::NOT_FOUND,
            format!("no station {id:?} on this node: /api/status lists them"),
        );
    };
    let (first, bins) = view.last(seconds);
    let series = |pick: &dyn Fn(&crate::traces::Bin, usize) -> f32| -> Vec<Vec<Value>> {
        (0..3)
            .map(|c| {
                bins.iter()
                    .map(|b| {
                        if b.min[c] <= b.max[c] {
                            json_number(f64::from(pick(b, c)))
                        } else {
                            Value::Null
                        }
                    })
                    .collect()
            })
            .collect()
    };
    let ims = traces
        .intensities
        .get(&id)
        .and_then(|i| serde_json::to_value(&**i).ok());
    json_text(
        json!({
            "station": id,
            "seconds": json_number(seconds),
            "bin_s": json_number(BIN_NS as f64 * 1e-9),
            "start_ns": first.map(|f| f * BIN_NS),
            "components": COMPONENTS,
            "unit": "m/s²",
            "min": series(&|b, c| b.min[c]),
            "max": series(&|b, c| b.max[c]),
            "samples": bins.iter().map(|b| b.samples).collect::<Vec<_>>(),
            "ims": ims,
        })
        .to_string(),
    )
}

/// Longest a trace request waits for the snapshot that holds its station's ring (a station
/// not asked for in the last [`crate::traces::WANTED_FOR`] comes with the next status).
const TRACE_WAIT: std::time::Duration = std::time::Duration::from_secs(5);

/// The traces snapshot holding station `id`'s ring: marks `id` wanted (a station of the
/// node's status only, so the wanted set stays bounded) and, when the current snapshot lacks
/// it, waits up to [`TRACE_WAIT`] for one that has it. Errors: 404 for a station the node does
/// not have, 503 when no snapshot came in time.
async fn station_traces(shared: &Shared, id: &str) -> Result<Arc<TracesSnapshot>, Response> {
    let mut traces = shared.traces.clone();
    let current = traces.borrow_and_update().clone();
    if current.stations.contains_key(id) {
        shared.wanted.mark(id);
        return Ok(current);
    }
    let known = match shared.status.borrow().as_ref() {
        Some(s) => s.stations.iter().any(|st| st.health.station == id),
        None => {
            return Err(retry_later(
                "the node has not made its first status yet: ask again".into(),
            ))
        }
    };
    if !known {
        return Err(error(
            StatusCode::NOT_FOUND,
            format!("no station {id:?} on this node: /api/status lists them"),
        ));
    }
    shared.wanted.mark(id);
    let arrived = tokio::time::timeout(TRACE_WAIT, async {
        loop {
            if traces.changed().await.is_err() {
                return None;
            }
            let next = traces.borrow_and_update().clone();
            if next.stations.contains_key(id) {
                return Some(next);
            }
        }
    })
    .await;
    match arrived {
        Ok(Some(next)) => Ok(next),
        _ => Err(retry_later(format!(
            "the trace of {id:?} comes with the node's next status ([status] \
             diagnostics_period_s): ask again"
        ))),
    }
}

/// 503 with `Retry-After: 1`.
fn retry_later(message: String) -> Response {
    (
        StatusCode::SERVICE_UNAVAILABLE,
        [
            (header::RETRY_AFTER, "1"),
            (header::CONTENT_TYPE, "application/json"),
        ],
        json!({ "error": message }).to_string(),
    )
        .into_response()
}

/// The query of `/api/alerts`.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AlertsQuery {
    /// Only items at or after this time (ns since the Unix epoch: an alert's data time, a
    /// reset's wall-clock time).
    pub since: Option<i64>,
}

fn history(shared: &Shared, since: i64) -> Vec<Value> {
    let Ok(history) = shared.history.lock() else {
        return Vec::new();
    };
    history
        .iter()
        .filter(|i| i.time_ns >= since)
        .filter_map(|i| serde_json::from_str(&i.json).ok())
        .collect()
}

/// `GET /api/alerts?since=<ns>`: the alerts and resets since the node started (the journal's
/// history first), oldest first, as `{"alerts": [...]}`.
pub async fn get_alerts(
    State(shared): State<Arc<Shared>>,
    query: Result<Query<AlertsQuery>, axum::extract::rejection::QueryRejection>,
) -> Response {
    let Query(query) = match query {
        Ok(q) => q,
        Err(e) => {
            return error(
                StatusCode::BAD_REQUEST,
                format!("{e}: /api/alerts takes since=<ns since the Unix epoch, an integer>"),
            )
        }
    };
    let alerts = history(&shared, query.since.unwrap_or(i64::MIN));
    json_text(json!({ "alerts": alerts }).to_string())
}

/// `GET /api/events`: Server-Sent Events, `status` (the `/api/status` object, now and every
/// status period) and `alert` (one item of `/api/alerts`, as it happens). A client that
/// falls [`CLIENT_QUEUE`] events behind is dropped.
pub async fn get_events(State(shared): State<Arc<Shared>>) -> Response {
    let (tx, rx) = mpsc::channel::<StreamEvent>(CLIENT_QUEUE);
    if let Some(status) = shared.status.borrow().clone() {
        let _ = tx.try_send(("status", status_json(&status).to_string().into()));
    }
    match shared.clients.lock() {
        Ok(mut clients) if clients.len() < MAX_CLIENTS => clients.push(tx),
        _ => {
            shared
                .counters
                .clients_refused
                .fetch_add(1, Ordering::Relaxed);
            return error(
                StatusCode::SERVICE_UNAVAILABLE,
                format!("too many live-stream clients ({MAX_CLIENTS})"),
            );
        }
    }
    let stream = futures::stream::unfold(rx, |mut rx| async move {
        let (name, data) = rx.recv().await?;
        Some((
            Ok::<Event, Infallible>(Event::default().event(name).data(&*data)),
            rx,
        ))
    });
    Sse::new(stream)
        .keep_alive(KeepAlive::default())
        .into_response()
}

/// `GET /metrics`: the Prometheus text.
pub async fn get_metrics(State(shared): State<Arc<Shared>>) -> Response {
    (
        [(header::CONTENT_TYPE, super::PROMETHEUS_CONTENT_TYPE)],
        shared.prometheus(),
    )
        .into_response()
}
