//! iceoryx2 end to end: latency from publishing a packet on `pbr/accel` to receiving the alert
//! it triggers on `pbr/alerts` (p50, p99, max over ≥ 1000 alerts), and sustained intake.
//!
//! Run: `cargo bench --bench iox_latency`. The node is `rockwatch::node::Reactor`, the very code
//! `rockwatch node` runs (one event loop: iceoryx2 input, engine inline with the default one
//! shard, journal-free here, iceoryx2 alert publisher, plus its ROS 2 side on a loopback-only
//! DDS plan), on this thread; the sender and the alert subscriber are threads of this process
//! talking to it through iceoryx2 shared memory exactly as separate processes would.
//!
//! Alerts: 400 stations, one slender block each (the catalogue's rrs-slender-pillar), all fed
//! the Rinaldi record; each block raises motion onset, overturn imminent and overturned
//! (1200 alerts). Packets are sent round-robin over the stations, one every `PACE`, so the
//! latency is the transport + engine path, not a queue. An alert's triggering packet is the
//! station's latest packet sent before the alert arrived.

mod common;
use common::{percentile, rinaldi, station, station_packets, write_catalogue, SendLog};

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use rockwatch::engine::{AccelPacket, StationId};
use rockwatch::iox::{IoxAlertSubscriber, IoxConfig, IoxPacketSink};
use rockwatch::node::{NodeOptions, Publication, Publisher, Reactor};
use rockwatch::replay::PacketSink;
use rockwatch::ros2::{network_plan, NetworkPlan, Ros2Config};

const ALERT_STATIONS: usize = 400;
const INTAKE_STATIONS: usize = 1000;
const PACKET_MS: u32 = 100;
const PACE: Duration = Duration::from_micros(250);

/// Records the node-internal part of the latency: arrival of the triggering packet at the
/// input → publication of the alert (after journaling, before the iceoryx2 publisher).
struct Internal(Vec<f64>);
impl Publisher for Internal {
    fn publish(&mut self, p: &Publication) -> anyhow::Result<()> {
        if let Publication::Alert { latency_ns, .. } = p {
            self.0.push(*latency_ns as f64 / 1e3);
        }
        Ok(())
    }
}

/// The node's options: the bench catalogue, iceoryx2 `iox`, ROS 2 on loopback only (a DDS
/// domain derived from the process id), default shards (1: engine inline).
fn node_options(catalogue: &Path, iox: &IoxConfig) -> (NodeOptions, NetworkPlan) {
    let mut options = NodeOptions {
        catalogue: Some(catalogue.to_path_buf()),
        ..NodeOptions::default()
    };
    options.config.iceoryx2 = iox.clone();
    options.config.ros2 = Ros2Config {
        domain_id: Some(100 + (std::process::id() % 100) as u16),
        ..Ros2Config::loopback_only()
    };
    let plan = network_plan(&options.config.ros2, None, None).unwrap();
    (options, plan)
}

fn main() {
    let dir = tempfile::tempdir().unwrap();
    let catalogue = dir.path().join("catalogue.toml");
    write_catalogue(&catalogue, INTAKE_STATIONS);
    let pid = std::process::id();
    let config = IoxConfig {
        config_file: Some(PathBuf::from("config/iceoryx2.toml")),
        accel_service: format!("rockwatch-bench/{pid}/accel"),
        alerts_service: format!("rockwatch-bench/{pid}/alerts"),
        alert_history: 1024,
        ..IoxConfig::default()
    };
    let traces = rinaldi();
    let template = traces.packets(&StationId::parse("XB.S0000.00").unwrap(), PACKET_MS, 2.0);
    let per_station = template.len();

    // ---- latency -------------------------------------------------------------------------
    let (options, plan) = node_options(&catalogue, &config);
    let reactor = Reactor::start(&options, &plan).unwrap();
    let log = Arc::new(SendLog::new(ALERT_STATIONS, per_station));
    let epoch = log.epoch;
    let subscriber_done = Arc::new(AtomicBool::new(false));
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let subscriber = {
        let (config, done) = (config.clone(), subscriber_done.clone());
        std::thread::spawn(move || {
            let sub = IoxAlertSubscriber::new(&config).unwrap();
            ready_tx.send(()).unwrap();
            let mut got = Vec::new();
            let mut stamped = Vec::new();
            while !done.load(Ordering::Relaxed) {
                let before = got.len();
                sub.wait(Duration::from_millis(20), &mut got).unwrap();
                let now = epoch.elapsed().as_nanos() as i64;
                stamped.extend(got[before..].iter().map(|a| (*a, now)));
            }
            stamped
        })
    };
    ready_rx.recv_timeout(Duration::from_secs(30)).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let sender = {
        let (config, log, stop) = (config.clone(), log.clone(), stop.clone());
        let packets = station_packets(&template, ALERT_STATIONS);
        std::thread::spawn(move || {
            let mut sink = IoxPacketSink::new(&config).unwrap();
            assert!(sink.wait_for_subscriber(Duration::from_secs(30)).unwrap());
            log.paced_send(&mut sink, &packets, PACE);
            std::thread::sleep(Duration::from_millis(500));
            stop.store(true, Ordering::Relaxed);
        })
    };
    let mut internal = Internal(Vec::new());
    let report = reactor.run(&stop, &mut [&mut internal]).unwrap();
    sender.join().unwrap();
    let input_stats = report.iox.unwrap();
    std::thread::sleep(Duration::from_millis(100));
    subscriber_done.store(true, Ordering::Relaxed);
    let alerts = subscriber.join().unwrap();

    let latencies_us = log.latencies_us(alerts.iter().map(|(a, t)| (a.station(), *t)));
    let mut internal = internal.0;
    internal.sort_by(f64::total_cmp);
    if !internal.is_empty() {
        println!(
            "  node-internal part (packet taken by the input → alert published): p50 {:.1} µs, p99 {:.1} µs",
            percentile(&internal, 50.0),
            percentile(&internal, 99.0)
        );
    }
    println!(
        "iceoryx2 alert latency (publish packet -> receive alert), {} alerts from {} packets \
         ({} stations, {} shard(s), one packet every {:?}): p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
        latencies_us.len(),
        input_stats.submitted,
        ALERT_STATIONS,
        options.shards,
        PACE,
        percentile(&latencies_us, 50.0),
        percentile(&latencies_us, 99.0),
        latencies_us.last().copied().unwrap_or(f64::NAN),
    );
    assert!(
        latencies_us.len() >= 1000,
        "only {} alerts",
        latencies_us.len()
    );

    // ---- sustained intake ----------------------------------------------------------------
    let intake_config = IoxConfig {
        accel_service: format!("rockwatch-bench/{pid}/intake"),
        ..config
    };
    let (options, plan) = node_options(&catalogue, &intake_config);
    let reactor = Reactor::start(&options, &plan).unwrap();
    let probe = reactor.probe();
    let received = move || probe.iox().map_or(0, |s| s.received);
    // 10 s of quiet 100 Hz data in 100 ms packets from every station.
    let quiet = |s: usize, j: usize| AccelPacket {
        station: station(s),
        start_time_ns: j as i64 * 100_000_000,
        sample_rate_hz: 100.0,
        sequence: j as u64,
        east: vec![0.001; 10],
        north: vec![-0.001; 10],
        up: vec![0.0; 10],
    };
    let rounds = 100;
    let total = (rounds * INTAKE_STATIONS) as u64;
    let stop = Arc::new(AtomicBool::new(false));
    let sender = {
        let (config, stop) = (intake_config.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut sink = IoxPacketSink::new(&config).unwrap();
            assert!(sink.wait_for_subscriber(Duration::from_secs(30)).unwrap());
            // Flow control from the node's counters (same process): at most BACKLOG packets in
            // flight, below the subscriber buffer, so nothing overflows and the rate is the
            // node's.
            const BACKLOG: u64 = 512;
            let start = Instant::now();
            let deadline = start + Duration::from_secs(300);
            let mut sent = 0u64;
            for j in 0..rounds {
                for s in 0..INTAKE_STATIONS {
                    while sent >= received() + BACKLOG && Instant::now() < deadline {
                        std::thread::sleep(Duration::from_micros(50));
                    }
                    sink.send(&quiet(s, j)).unwrap();
                    sent += 1;
                }
            }
            let sent_s = start.elapsed().as_secs_f64();
            while received() < total && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(1));
            }
            let intake_s = start.elapsed().as_secs_f64();
            stop.store(true, Ordering::Relaxed);
            (start, sent_s, intake_s)
        })
    };
    let report = reactor.run(&stop, &mut []).unwrap();
    let end = Instant::now();
    let (start, sent_s, intake_s) = sender.join().unwrap();
    let engine_s = end.duration_since(start).as_secs_f64();
    let stats = report.iox.unwrap();
    println!(
        "iceoryx2 intake: {total} packets ({INTAKE_STATIONS} stations x {rounds} packets of 10 \
         samples = {:.0} s of data): sent in {sent_s:.2} s, taken by the node in {intake_s:.2} s \
         ({:.0} packets/s, {} lost to overflow), node stopped (everything processed) after \
         {engine_s:.2} s ({:.0} packets/s = {:.1}x real time for {INTAKE_STATIONS} stations at \
         100 Hz; {} shard(s), the engine inline on the event loop)",
        rounds as f64 * 0.1,
        stats.received as f64 / intake_s,
        stats.sequence_gaps,
        total as f64 / engine_s,
        (rounds as f64 * 0.1) / engine_s,
        options.shards,
    );
}
