//! The web dashboard's cost to the node (issue 22 §1): the node-added latency (a packet taken
//! by the input → its alert ready to publish, the alert's own `latency_ns`, as
//! benches/iox_latency.rs measures it) and the end-to-end latency (publish packet on iceoryx2
//! → receive the alert on iceoryx2), without the dashboard, with it and no browser, and with
//! 20 browsers connected.
//!
//! Run: `cargo bench --bench web_latency`. The node is `rockwatch::node::Reactor` (what
//! `rockwatch node` runs) with the iceoryx2 input and alert publisher, ROS 2 on a loopback-only
//! DDS plan, status every 0.2 s (each status and trace snapshot goes to the web side). A
//! "browser" is a thread that does what the page does: reads `/api/events` as it streams and,
//! at a status event at most once a second, fetches `/api/stations/{id}/trace?seconds=120` and
//! `/api/rocks/{id}`. The browsers are threads of this process: on the benchmark machine they
//! compete for the same cores as the node (2 vCPUs here), which real browsers on other
//! machines do not.
//! 200 stations, one slender block each, all fed the Rinaldi record (600 alerts per run), one
//! packet every 250 µs.

mod common;
use common::{percentile, rinaldi, station_packets, write_catalogue, SendLog};

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use rockwatch::iox::{IoxAlertSubscriber, IoxConfig, IoxPacketSink, PbrAlertIox};
use rockwatch::node::{NodeOptions, Reactor};
use rockwatch::ports::{PacketSink, Publication, Publisher};
use rockwatch::ros2::{network_plan, Ros2Config};
use rockwatch_core::engine::StationId;

const STATIONS: usize = 200;
const PACKET_MS: u32 = 100;
const PACE: Duration = Duration::from_micros(250);
const BROWSERS: usize = 20;

/// The alerts' node-added latency (µs).
struct Internal(Vec<f64>);
impl Publisher for Internal {
    fn publish(&mut self, p: &Publication) -> anyhow::Result<()> {
        if let Publication::Alert { latency_ns, .. } = p {
            self.0.push(*latency_ns as f64 / 1e3);
        }
        Ok(())
    }
}

/// One HTTP/1.1 GET on a new connection; the body's length (0 on any failure).
fn fetch(port: u16, path: &str) -> usize {
    let Ok(mut s) = TcpStream::connect(("127.0.0.1", port)) else {
        return 0;
    };
    let _ = write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
    );
    let mut body = Vec::new();
    let _ = s.read_to_end(&mut body);
    body.len()
}

/// A browser: streams `/api/events`; at each status, fetches a trace and a rock as the page
/// does. Counts the bytes it got.
fn browser(port: u16, stop: Arc<AtomicBool>, bytes: Arc<AtomicU64>) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let Ok(mut s) = TcpStream::connect(("127.0.0.1", port)) else {
            return;
        };
        let _ = s.set_read_timeout(Some(Duration::from_millis(200)));
        let _ = s.write_all(b"GET /api/events HTTP/1.1\r\nHost: x\r\n\r\n");
        let mut lines = BufReader::new(s);
        let mut line = String::new();
        let mut last = std::time::Instant::now() - Duration::from_secs(1);
        while !stop.load(Ordering::Relaxed) {
            line.clear();
            match lines.read_line(&mut line) {
                Ok(0) => return,
                Ok(n) => {
                    bytes.fetch_add(n as u64, Ordering::Relaxed);
                    if line.starts_with("event: status") && last.elapsed() >= Duration::from_secs(1)
                    {
                        last = std::time::Instant::now();
                        let got = fetch(port, "/api/stations/XB.S0000.00/trace?seconds=120")
                            + fetch(port, "/api/rocks/b0000");
                        bytes.fetch_add(got as u64, Ordering::Relaxed);
                    }
                }
                Err(_) => continue, // the read timeout: look at `stop`
            }
        }
    })
}

/// One run: (node-added µs sorted, end-to-end µs sorted, bytes the browsers got).
fn run(catalogue: &Path, name: &str, web: Option<usize>) -> (Vec<f64>, Vec<f64>, u64) {
    let pid = std::process::id();
    let config = IoxConfig {
        config_file: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/iceoryx2.toml"
        ))),
        accel_service: format!("rockwatch-bench/{pid}/{name}/accel"),
        alerts_service: format!("rockwatch-bench/{pid}/{name}/alerts"),
        alert_history: 1024,
        ..IoxConfig::default()
    };
    let mut options = NodeOptions {
        catalogue: Some(catalogue.to_path_buf()),
        ..NodeOptions::default()
    };
    options.config.iceoryx2 = config.clone();
    options.config.ros2 = Ros2Config {
        domain_id: Some(100 + (pid % 100) as u16),
        ..Ros2Config::loopback_only()
    };
    options.config.status.diagnostics_period_s = 0.2;
    let port = web.map(|_| {
        // A free loopback port.
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    });
    options.config.web.listen = port.map(|p| format!("127.0.0.1:{p}"));
    let plan = network_plan(&options.config.ros2, None, None).unwrap();
    let reactor = Reactor::start(&options, &plan).unwrap();

    let stop_browsers = Arc::new(AtomicBool::new(false));
    let bytes = Arc::new(AtomicU64::new(0));
    let browsers: Vec<_> = match (port, web) {
        (Some(port), Some(n)) => (0..n)
            .map(|_| browser(port, stop_browsers.clone(), bytes.clone()))
            .collect(),
        _ => Vec::new(),
    };

    let template = rinaldi().packets(&StationId::parse("XB.S0000.00").unwrap(), PACKET_MS, 2.0);
    let log = Arc::new(SendLog::new(STATIONS, template.len()));
    let epoch = log.epoch;
    let done = Arc::new(AtomicBool::new(false));
    let subscriber = {
        let (config, done) = (config.clone(), done.clone());
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let handle = std::thread::spawn(move || {
            let sub = IoxAlertSubscriber::new(&config).unwrap();
            ready_tx.send(()).unwrap();
            let mut got: Vec<PbrAlertIox> = Vec::new();
            let mut stamped = Vec::new();
            while !done.load(Ordering::Relaxed) {
                let before = got.len();
                sub.wait(Duration::from_millis(20), &mut got).unwrap();
                let now = epoch.elapsed().as_nanos() as i64;
                stamped.extend(got[before..].iter().map(|a| (a.station(), now)));
            }
            stamped
        });
        ready_rx.recv_timeout(Duration::from_secs(30)).unwrap();
        handle
    };
    let stop = Arc::new(AtomicBool::new(false));
    let sender = {
        let (config, log, stop) = (config.clone(), log.clone(), stop.clone());
        let packets = station_packets(&template, STATIONS);
        std::thread::spawn(move || {
            let mut sink = IoxPacketSink::new(&config).unwrap();
            assert!(sink.wait_for_subscriber(Duration::from_secs(30)).unwrap());
            // Let the browsers connect and the first statuses stream.
            std::thread::sleep(Duration::from_secs(1));
            log.paced_send(&mut sink, &packets, PACE);
            std::thread::sleep(Duration::from_millis(500));
            stop.store(true, Ordering::Relaxed);
        })
    };
    let mut internal = Internal(Vec::with_capacity(4096));
    reactor.run(&stop, &mut [&mut internal]).unwrap();
    sender.join().unwrap();
    std::thread::sleep(Duration::from_millis(100));
    done.store(true, Ordering::Relaxed);
    let alerts = subscriber.join().unwrap();
    stop_browsers.store(true, Ordering::Relaxed);
    for b in browsers {
        let _ = b.join();
    }
    let end_to_end = log.latencies_us(alerts.iter().map(|(s, t)| (s.as_str(), *t)));
    let mut node = internal.0;
    node.sort_by(f64::total_cmp);
    (node, end_to_end, bytes.load(Ordering::Relaxed))
}

fn main() {
    let dir = tempfile::tempdir().unwrap();
    let catalogue = dir.path().join("catalogue.toml");
    write_catalogue(&catalogue, STATIONS);
    let p = |v: &[f64], q: f64| {
        if v.is_empty() {
            f64::NAN
        } else {
            percentile(v, q)
        }
    };
    let mut figures = Vec::new();
    for (name, web, label) in [
        ("off", None, "no dashboard".to_string()),
        ("idle", Some(0), "dashboard, no browser".to_string()),
        (
            "busy",
            Some(BROWSERS),
            format!("dashboard, {BROWSERS} browsers"),
        ),
    ] {
        let (node, end_to_end, bytes) = run(&catalogue, name, web);
        println!(
            "  {label}: {} alerts; node-added (packet taken → alert ready) p50 {:.1} µs, p99 {:.1} µs; \
             end to end (publish packet → alert received, iceoryx2) p50 {:.1} µs, p99 {:.1} µs; \
             browsers got {:.1} MB",
            node.len(),
            p(&node, 50.0),
            p(&node, 99.0),
            p(&end_to_end, 50.0),
            p(&end_to_end, 99.0),
            bytes as f64 / 1e6,
        );
        assert!(node.len() >= 500, "only {} alerts", node.len());
        figures.push((p(&node, 50.0), p(&node, 99.0)));
    }
    println!(
        "web dashboard's cost to the node: node-added latency p50/p99 {:.1}/{:.1} µs without it, \
         {:.1}/{:.1} µs with it idle, {:.1}/{:.1} µs with {BROWSERS} browsers connected \
         ({STATIONS} stations, one packet every {PACE:?}, status every 0.2 s)",
        figures[0].0, figures[0].1, figures[1].0, figures[1].1, figures[2].0, figures[2].1,
    );
}
