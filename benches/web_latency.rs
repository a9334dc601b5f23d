//! The web dashboard's cost to the node (issue 22 §1): the node-added latency (a packet taken
//! by the input → its alert ready to publish, the alert's own `latency_ns`, as
//! benches/iox_latency.rs measures it) and the end-to-end latency (publish packet on iceoryx2
//! → receive the alert on iceoryx2), without the dashboard, with it and no browser, and with
//! 20 browsers connected.
//!
//! The machine's other load swings a run's p99 by an order of magnitude, so one run per case
//! cannot show "unchanged": the three cases run in [`ROUNDS`] rounds, interleaved (each round
//! runs all three, in an order rotated by one each round), so load affects them alike; per
//! case the p50 and p99 printed are the medians over the rounds. Beside them, the event loop
//! thread's CPU time per packet (its `/proc/thread-self/schedstat` run time over the run,
//! divided by the packets sent): the node's own work, insensitive to the other processes
//! (which take wall time, not its CPU time). The verdict compares the cases with
//! [`MEDIAN_TOLERANCE_US`] and [`CPU_TOLERANCE`].
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
mod thread_time;
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
/// Rounds of the three cases (about 40 s each on the 2-vCPU benchmark machine).
const ROUNDS: usize = 5;
/// The verdict's bound on the node-added p50's increase with 20 browsers over no dashboard
/// (µs; the ring fill of each packet costs ≈ 1 µs).
const MEDIAN_TOLERANCE_US: f64 = 3.0;
/// The verdict's bound on the loop's CPU time per packet with 20 browsers over no dashboard
/// (relative).
const CPU_TOLERANCE: f64 = 0.25;

/// This thread's CPU time so far (ns), None if unreadable.
fn thread_cpu_ns() -> Option<u64> {
    thread_time::run_and_wait_ns().map(|(run, _)| run)
}

/// One run's figures.
struct Run {
    /// Node-added latencies (µs), sorted.
    node: Vec<f64>,
    /// End-to-end latencies (µs), sorted.
    end_to_end: Vec<f64>,
    /// Bytes the browsers got.
    bytes: u64,
    /// The event loop thread's CPU time per packet sent (µs).
    cpu_per_packet_us: f64,
}

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

/// One run of a case: `web` None without the dashboard, else with it and that many browsers.
fn run(catalogue: &Path, name: &str, web: Option<usize>) -> Run {
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
    let packets_sent = STATIONS * template.len();
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
    // The loop runs on this thread: its CPU time over the run.
    let cpu_before = thread_cpu_ns();
    reactor.run(&stop, &mut [&mut internal]).unwrap();
    let cpu_ns = thread_cpu_ns()
        .zip(cpu_before)
        .map(|(b, a)| b.saturating_sub(a));
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
    Run {
        node,
        end_to_end,
        bytes: bytes.load(Ordering::Relaxed),
        cpu_per_packet_us: cpu_ns.map_or(f64::NAN, |ns| ns as f64 / 1e3 / packets_sent as f64),
    }
}

/// The median of `values` (NaN if empty).
fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| !x.is_nan()).collect();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        percentile(&v, 50.0)
    }
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
    let cases = [
        ("off", None, "no dashboard".to_string()),
        ("idle", Some(0), "dashboard, no browser".to_string()),
        (
            "busy",
            Some(BROWSERS),
            format!("dashboard, {BROWSERS} browsers"),
        ),
    ];
    // Per case, per round: (node-added p50, p99, end-to-end p50, p99, CPU µs per packet).
    let mut figures: Vec<Vec<[f64; 5]>> = vec![Vec::new(); cases.len()];
    for round in 0..ROUNDS {
        for k in 0..cases.len() {
            let c = (round + k) % cases.len();
            let (name, web, label) = &cases[c];
            let r = run(&catalogue, &format!("{name}{round}"), *web);
            println!(
                "  round {}, {label}: {} alerts; node-added (packet taken → alert ready) p50 {:.1} µs, \
                 p99 {:.1} µs; end to end (publish packet → alert received, iceoryx2) p50 {:.1} µs, \
                 p99 {:.1} µs; event loop CPU {:.2} µs/packet; browsers got {:.1} MB",
                round + 1,
                r.node.len(),
                p(&r.node, 50.0),
                p(&r.node, 99.0),
                p(&r.end_to_end, 50.0),
                p(&r.end_to_end, 99.0),
                r.cpu_per_packet_us,
                r.bytes as f64 / 1e6,
            );
            assert!(r.node.len() >= 500, "only {} alerts", r.node.len());
            figures[c].push([
                p(&r.node, 50.0),
                p(&r.node, 99.0),
                p(&r.end_to_end, 50.0),
                p(&r.end_to_end, 99.0),
                r.cpu_per_packet_us,
            ]);
        }
    }
    let medians: Vec<[f64; 5]> = figures
        .iter()
        .map(|rounds| {
            std::array::from_fn(|i| median(&rounds.iter().map(|f| f[i]).collect::<Vec<_>>()))
        })
        .collect();
    println!(
        "web dashboard's cost to the node, medians over {ROUNDS} interleaved rounds ({STATIONS} \
         stations, one packet every {PACE:?}, status every 0.2 s):"
    );
    for ((_, _, label), m) in cases.iter().zip(&medians) {
        println!(
            "  {label}: node-added p50 {:.1} µs, p99 {:.1} µs; end to end p50 {:.1} µs, p99 {:.1} µs; \
             event loop CPU {:.2} µs/packet",
            m[0], m[1], m[2], m[3], m[4]
        );
    }
    let (off, busy) = (&medians[0], &medians[2]);
    let median_ok = busy[0] - off[0] <= MEDIAN_TOLERANCE_US;
    let cpu_ok = busy[4].is_nan() || busy[4] <= off[4] * (1.0 + CPU_TOLERANCE);
    println!(
        "verdict: node-added latency with {BROWSERS} browsers {} (p50 {:+.1} µs over no dashboard, \
         bound {MEDIAN_TOLERANCE_US} µs; event loop CPU per packet {:+.0} %, bound {:.0} %; p99 \
         {:.1} vs {:.1} µs, medians over rounds)",
        if median_ok && cpu_ok {
            "UNCHANGED"
        } else {
            "CHANGED"
        },
        busy[0] - off[0],
        (busy[4] / off[4] - 1.0) * 100.0,
        CPU_TOLERANCE * 100.0,
        busy[1],
        off[1],
    );
}
