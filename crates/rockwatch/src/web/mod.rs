//! The node's web dashboard (`[web] listen`, issue 22 §1) and the one HTTP server of the
//! codebase (Prometheus `/metrics` too, `[metrics] listen`).
//!
//! - [`config`]: the `[web]` section (loopback by default; a non-loopback address needs a
//!   bearer token, `token_file`).
//! - [`server`]: axum on a tokio current-thread runtime in ONE dedicated thread
//!   (`rockwatch-web`); the node's mio event loop stays as it is.
//! - [`api`]: `/api/status`, `/api/alerts?since=<ns>`, `/api/rocks/{id}`, `/api/events`
//!   (Server-Sent Events), `/metrics`.
//! - [`page`]: `/`, one self-contained HTML page (no external assets; with `[web] tiles`, the
//!   map's background tiles come from the template's origin, fetched by the browser).
//! - [`tiles`]: the `[web] tiles` template and its checks.
//!
//! The event loop never waits for the web side: it hands each status snapshot over a
//! `tokio::sync::watch` (a store of the latest, never blocks) and each alert and reset
//! through a bounded queue with `try_send` ([`ALERT_QUEUE`]; a full queue drops the item and
//! counts it: `rockwatch_web_handoff_dropped_total`). The web thread keeps the history and
//! fans it out to the stream clients, each with a bounded queue; a client that falls behind
//! is dropped (`rockwatch_web_clients_dropped_total`), never the node.

pub mod api;
pub mod config;
pub mod page;
pub mod server;
pub mod tiles;

use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

use anyhow::Context;
use axum::routing::get;
use axum::Router;
use tokio::sync::{mpsc, watch};

use crate::ports::{Publication, Publisher};
use crate::status::NodeStatus;
use crate::traces::{TracesSnapshot, WantedStations};
pub use api::WebCounters;
pub use config::{MetricsConfig, WebConfig};
use server::{HttpThread, Listener};

/// Alerts and resets waiting to be taken by the web thread; beyond, they are dropped
/// (counted) rather than making the event loop wait.
pub const ALERT_QUEUE: usize = 1024;

/// The Content-Type of the Prometheus text exposition format.
pub const PROMETHEUS_CONTENT_TYPE: &str = "text/plain; version=0.0.4; charset=utf-8";

/// The node's web server: the dashboard on `[web] listen` and/or `/metrics` alone on
/// `[metrics] listen`, one thread.
pub struct WebServer {
    thread: HttpThread,
    status: watch::Sender<Option<Arc<NodeStatus>>>,
    traces: watch::Sender<Arc<TracesSnapshot>>,
    /// The stations whose rings the web side asked for (shared with the handlers).
    wanted: Arc<WantedStations>,
    feed: AlertFeed,
    /// `[web] listen`'s address, when configured.
    web_address: Option<std::net::SocketAddr>,
    metrics_address: Option<std::net::SocketAddr>,
}

impl WebServer {
    /// Starts the server if `web` or `metrics` asks for it (else None). Each listener requires
    /// its section's token when `token_file` is set.
    pub fn start(web: &WebConfig, metrics: &MetricsConfig) -> anyhow::Result<Option<WebServer>> {
        let metrics_listen = metrics.listen.as_deref();
        if web.listen.is_none() && metrics_listen.is_none() {
            return Ok(None);
        }
        let (status, status_rx) = watch::channel(None);
        let (traces, traces_rx) = watch::channel(Arc::new(TracesSnapshot::default()));
        let counters = Arc::new(WebCounters::default());
        let wanted = Arc::new(WantedStations::default());
        let shared = Arc::new(api::Shared::new(
            status_rx,
            traces_rx,
            Arc::clone(&wanted),
            Arc::clone(&counters),
        ));
        let (alerts, mut alerts_rx) = mpsc::channel::<Publication>(ALERT_QUEUE);
        let mut listeners = Vec::new();
        if let Some(listen) = &web.listen {
            let token = web.token()?;
            let page = page::Page::new(web.tiles()?.as_ref());
            let router = guarded(dashboard_router(Arc::clone(&shared), page), token);
            listeners.push(Listener::bind("[web] listen", listen, router)?);
        }
        if let Some(listen) = metrics_listen {
            let token = metrics.token()?;
            let router = guarded(metrics_router(Arc::clone(&shared)), token);
            listeners.push(Listener::bind("[metrics] listen", listen, router)?);
        }
        let fan_out = {
            let shared = Arc::clone(&shared);
            let mut status_rx = shared.status.clone();
            async move {
                loop {
                    tokio::select! {
                        p = alerts_rx.recv() => match p {
                            Some(p) => shared.take(&p),
                            None => return,
                        },
                        changed = status_rx.changed() => match changed {
                            Ok(()) => shared.status_changed(),
                            Err(_) => return,
                        },
                    }
                }
            }
        };
        let thread =
            HttpThread::start(listeners, fan_out).context("cannot start the web server")?;
        let mut addresses = thread.addresses().iter().copied();
        let web_address = web.listen.as_ref().and_then(|_| addresses.next());
        let metrics_address = metrics_listen.and_then(|_| addresses.next());
        if let Some(a) = web_address {
            tracing::info!("web: the dashboard on http://{a}/");
        }
        if let Some(a) = metrics_address {
            tracing::info!("metrics: Prometheus text on http://{a}/metrics");
        }
        Ok(Some(WebServer {
            thread,
            status,
            traces,
            wanted,
            feed: AlertFeed { alerts, counters },
            web_address,
            metrics_address,
        }))
    }

    /// The dashboard's address (the port, when `listen` asked for 0).
    #[must_use]
    pub fn web_address(&self) -> Option<std::net::SocketAddr> {
        self.web_address
    }

    /// `[metrics] listen`'s address.
    #[must_use]
    pub fn metrics_address(&self) -> Option<std::net::SocketAddr> {
        self.metrics_address
    }

    /// Hands the web side a new status (never waits: the latest replaces the previous).
    pub fn update_status(&self, status: NodeStatus) {
        self.status.send_replace(Some(Arc::new(status)));
    }

    /// Hands the web side the stations' and rocks' traces (never waits: the latest replaces
    /// the previous).
    pub fn update_traces(&self, traces: TracesSnapshot) {
        self.traces.send_replace(Arc::new(traces));
    }

    /// The stations whose rings the next snapshot should hold ([`crate::traces::Traces::snapshot`]).
    #[must_use]
    pub fn wanted_stations(&self) -> &WantedStations {
        &self.wanted
    }

    /// The publisher that hands alerts and resets to the web side (never waits).
    #[must_use]
    pub fn alert_feed(&self) -> AlertFeed {
        self.feed.clone()
    }

    /// Every address bound: `[web] listen`'s first when configured, then `[metrics] listen`'s.
    #[must_use]
    pub fn addresses(&self) -> &[std::net::SocketAddr] {
        self.thread.addresses()
    }
}

/// Hands alerts and resets to the web thread through a bounded queue, never waiting: a full
/// queue drops the item and counts it.
#[derive(Clone)]
pub struct AlertFeed {
    alerts: mpsc::Sender<Publication>,
    counters: Arc<WebCounters>,
}

impl Publisher for AlertFeed {
    fn publish(&mut self, publication: &Publication) -> anyhow::Result<()> {
        if !matches!(
            publication,
            Publication::Alert { .. } | Publication::Reset(_)
        ) {
            return Ok(());
        }
        match self.alerts.try_send(publication.clone()) {
            Ok(()) => {
                self.counters.handed_over.fetch_add(1, Ordering::Relaxed);
                Ok(())
            }
            Err(mpsc::error::TrySendError::Full(_)) => {
                self.counters
                    .handoff_dropped
                    .fetch_add(1, Ordering::Relaxed);
                anyhow::bail!("web: the hand-off queue is full ({ALERT_QUEUE}): an alert was not shown on the dashboard")
            }
            // The server has stopped: nothing to show it on.
            Err(mpsc::error::TrySendError::Closed(_)) => Ok(()),
        }
    }
}

/// Everything the dashboard serves.
fn dashboard_router(shared: Arc<api::Shared>, page: page::Page) -> Router {
    let page = Router::new()
        .route("/", get(page::index))
        .with_state(Arc::new(page));
    Router::new()
        .route("/api/status", get(api::get_status))
        .route("/api/alerts", get(api::get_alerts))
        .route("/api/rocks/{id}", get(api::get_rock))
        .route("/api/stations/{id}/trace", get(api::get_station_trace))
        .route("/api/events", get(api::get_events))
        .route("/metrics", get(api::get_metrics))
        .fallback(page::not_found)
        .with_state(shared)
        .merge(page)
}

/// `/metrics` alone (`[metrics] listen`).
fn metrics_router(shared: Arc<api::Shared>) -> Router {
    Router::new()
        .route("/metrics", get(api::get_metrics))
        .fallback(page::not_found)
        .with_state(shared)
}

/// `router` behind `token` (every request must carry it), when there is one.
fn guarded(router: Router, token: Option<String>) -> Router {
    match token {
        Some(token) => router.layer(axum::middleware::from_fn_with_state(
            Arc::<str>::from(token),
            server::require_token,
        )),
        None => router,
    }
}

/// A `/metrics` endpoint serving a text the caller replaces (`rockwatch acquire`'s
/// `[metrics] listen`), behind `token` when given: the same server implementation as the
/// dashboard's.
pub fn text_metrics_server(
    listen: &str,
    token: Option<String>,
) -> anyhow::Result<(HttpThread, Arc<Mutex<String>>)> {
    let text = Arc::new(Mutex::new("# no status yet\n".to_string()));
    let served = Arc::clone(&text);
    let router = Router::new()
        .route(
            "/metrics",
            get(move || {
                let text = served.lock().map(|t| t.clone()).unwrap_or_default();
                async move {
                    (
                        [(axum::http::header::CONTENT_TYPE, PROMETHEUS_CONTENT_TYPE)],
                        text,
                    )
                }
            }),
        )
        .fallback(page::not_found);
    let router = guarded(router, token);
    let thread = HttpThread::start(
        vec![Listener::bind("[metrics] listen", listen, router)?],
        async {},
    )?;
    Ok((thread, text))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::status::RockStatus;
    use std::io::{Read, Write};
    use std::net::TcpStream;
    use std::time::{Duration, Instant};

    /// A status of `rocks` rocks (about 200 bytes of JSON each).
    /// Rocks per status in the stalled-client test (about 35 kB of JSON: a debug build's web
    /// thread encodes one well within the test's 10 ms between statuses).
    const ROCKS_N: usize = 200;

    fn status(rocks: usize, stamp_ns: i64) -> NodeStatus {
        NodeStatus {
            stamp_ns,
            stations: Vec::new(),
            rocks: (0..rocks)
                .map(|i| RockStatus::new(format!("rock-{i:05}"), "XX.STA.00".into(), false))
                .collect(),
            journal_configured: false,
            journal_failures: 0,
            journal_backlog: 0,
            journal_dropped: 0,
            reports_written: 0,
            reports_dropped: 0,
            reports_failed: 0,
            ros2_up: true,
            ros2_rebuilds: 0,
            iceoryx2: false,
            realtime_factor: None,
            shards: 1,
            packets: 0,
            alerts: 0,
            rosout_dropped: 0,
            imminent_theta_ratio: 0.8,
        }
    }

    fn open_stream(address: std::net::SocketAddr) -> TcpStream {
        let mut s = TcpStream::connect(address).unwrap();
        s.write_all(b"GET /api/events HTTP/1.1\r\nHost: x\r\n\r\n")
            .unwrap();
        s
    }

    #[test]
    fn a_stream_client_that_never_reads_is_dropped_and_the_sender_never_waits() {
        let server = WebServer::start(
            &WebConfig {
                listen: Some("127.0.0.1:0".into()),
                ..WebConfig::default()
            },
            &MetricsConfig::default(),
        )
        .unwrap()
        .unwrap();
        let address = server.web_address().unwrap();
        let stalled = open_stream(address);
        // A client that keeps up: reads on its own thread.
        let mut reader = open_stream(address);
        let received = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let reading = {
            let received = Arc::clone(&received);
            std::thread::spawn(move || {
                let mut buf = vec![0u8; 1 << 16];
                while let Ok(n @ 1..) = reader.read(&mut buf) {
                    received.fetch_add(n, Ordering::Relaxed);
                }
            })
        };
        // About 35 kB per status event: the stalled client's socket buffers hold some, its
        // queue CLIENT_QUEUE more; then it is dropped.
        let mut slowest = Duration::ZERO;
        let deadline = Instant::now() + Duration::from_secs(60);
        let mut sent = 0;
        while server.feed.counters.clients_dropped.load(Ordering::Relaxed) == 0 {
            assert!(Instant::now() < deadline, "not dropped after {sent} events");
            let s = status(ROCKS_N, sent);
            let t = Instant::now();
            server.update_status(s);
            slowest = slowest.max(t.elapsed());
            sent += 1;
            std::thread::sleep(Duration::from_millis(10));
        }
        assert!(
            sent > api::CLIENT_QUEUE as i64,
            "dropped after {sent} events"
        );
        assert!(
            slowest < Duration::from_millis(50),
            "update_status took {slowest:?}"
        );
        // The reading client is served: what was queued for it arrives (polled, not read at
        // once: on a loaded machine its thread may not have run yet).
        let deadline = Instant::now() + Duration::from_secs(20);
        while received.load(Ordering::Relaxed) <= 200_000 && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        let received = received.load(Ordering::Relaxed);
        assert!(
            received > 200_000,
            "the reading client got {received} bytes"
        );
        drop(stalled);
        drop(server); // the thread ends (joined), streams and all
        reading.join().unwrap();
    }

    #[test]
    fn status_and_metrics_are_served_before_and_after_the_first_status() {
        let server = WebServer::start(
            &WebConfig {
                listen: Some("127.0.0.1:0".into()),
                ..WebConfig::default()
            },
            &MetricsConfig {
                listen: Some("127.0.0.1:0".into()),
                token_file: None,
            },
        )
        .unwrap()
        .unwrap();
        let (web, metrics) = (
            server.web_address().unwrap(),
            server.metrics_address().unwrap(),
        );
        let get = |address, path: &str| {
            let mut s = TcpStream::connect(address).unwrap();
            write!(
                s,
                "GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
            )
            .unwrap();
            let mut reply = String::new();
            s.read_to_string(&mut reply).unwrap();
            reply
        };
        assert!(get(web, "/api/status").starts_with("HTTP/1.1 503"));
        assert!(get(metrics, "/metrics").contains("# no status yet"));
        server.update_status(status(2, 7));
        let reply = get(web, "/api/status");
        assert!(reply.starts_with("HTTP/1.1 200"), "{reply}");
        assert!(
            reply.contains("\"pbr_id\":\"rock-00001\"")
                && reply.contains("\"display\":\"standing\"")
        );
        for address in [web, metrics] {
            let m = get(address, "/metrics");
            assert!(
                m.contains("rockwatch_rock_state{") && m.contains("rockwatch_web_clients 0"),
                "{m}"
            );
        }
        // The metrics listener serves /metrics only; the dashboard's paths are unknown there.
        assert!(get(metrics, "/api/status").starts_with("HTTP/1.1 404"));
        assert!(get(web, "/api/alerts?since=x").starts_with("HTTP/1.1 400"));
        assert!(get(web, "/api/alerts?until=1").starts_with("HTTP/1.1 400"));
        assert!(get(web, "/api/rocks/nope").starts_with("HTTP/1.1 404"));
        // A station's trace: the newest bins of its ring, as the snapshot holds them.
        let mut traces = crate::traces::Traces::new(&[("XX.STA.00".into(), None)]);
        traces.push_packet(&rockwatch_core::engine::AccelPacket {
            station: rockwatch_core::engine::StationId::parse("XX.STA.00").unwrap(),
            start_time_ns: 1_000_000_000_000,
            sample_rate_hz: 100.0,
            sequence: 0,
            east: (0..100).map(|i| i as f32 * 0.01).collect(),
            north: vec![0.0; 100],
            up: Vec::new(),
            unit: Default::default(),
        });
        // Not asked for: the snapshot holds no ring.
        server.update_traces(traces.snapshot(server.wanted_stations()));
        assert!(server.traces.borrow().stations.is_empty());
        server.wanted_stations().mark("XX.STA.00");
        server.update_traces(traces.snapshot(server.wanted_stations()));
        let reply = get(web, "/api/stations/XX.STA.00/trace?seconds=1");
        let body: serde_json::Value =
            serde_json::from_str(reply.split("\r\n\r\n").nth(1).unwrap_or("")).unwrap();
        assert_eq!(
            body["samples"],
            serde_json::json!([20, 20, 20, 20, 20]),
            "{body}"
        );
        assert_eq!(body["start_ns"], 1_000_000_000_000i64);
        assert_eq!(body["max"][0][4], f64::from(99.0f32 * 0.01));
        assert_eq!(body["min"][0][0], 0.0);
        assert_eq!(
            body["min"][2][0],
            serde_json::Value::Null,
            "no up component"
        );
        assert!(get(web, "/api/stations/XX.STA.00/trace?seconds=121").starts_with("HTTP/1.1 400"));
        assert!(get(web, "/api/stations/XX.STA.00/trace?seconds=0").starts_with("HTTP/1.1 400"));
        assert!(get(web, "/api/stations/XX.NO.00/trace").starts_with("HTTP/1.1 404"));
        assert!(get(web, "/").contains("<title>rockwatch</title>"));
    }
}
