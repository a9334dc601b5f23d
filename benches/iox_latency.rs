//! iceoryx2 end to end: latency from publishing a packet on `pbr/accel` to receiving the alert
//! it triggers on `pbr/alerts` (p50, p99, max over ≥ 1000 alerts), and sustained intake.
//!
//! Run: `cargo bench --bench iox_latency`. Everything runs in this process on separate
//! threads (sender, iceoryx2 input, engine shards, pump + alert publisher, alert subscriber),
//! talking through iceoryx2 shared memory exactly as separate processes would.
//!
//! Alerts: 400 stations, one slender block each (the catalogue's rrs-slender-pillar), all fed
//! the Rinaldi record; each block raises motion onset, overturn imminent and overturned
//! (1200 alerts). Packets are sent round-robin over the stations, one every `PACE`, so the
//! latency is the transport + engine path, not a queue. An alert's triggering packet is the
//! station's latest packet sent before the alert arrived.

mod common;
use common::{percentile, rinaldi, station, station_packets, write_catalogue, SendLog};

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use rockwatch::engine::{AccelPacket, StationId};
use rockwatch::iox::{IoxAlertPublisher, IoxAlertSubscriber, IoxConfig, IoxInput, IoxPacketSink};
use rockwatch::node::{NodeOptions, NodeRuntime};
use rockwatch::replay::PacketSink;

const ALERT_STATIONS: usize = 400;
const INTAKE_STATIONS: usize = 1000;
const PACKET_MS: u32 = 100;
const PACE: Duration = Duration::from_micros(250);

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
        handle_signals: false,
        ..IoxConfig::default()
    };
    let traces = rinaldi();
    let template = traces.packets(&StationId::parse("XB.S0000.00").unwrap(), PACKET_MS, 2.0);
    let per_station = template.len();

    // ---- latency -------------------------------------------------------------------------
    let mut runtime = NodeRuntime::start(&NodeOptions {
        catalogue: Some(catalogue.clone()),
        shards: 2,
        ..NodeOptions::default()
    })
    .unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let input = IoxInput::spawn(&config, runtime.submitter().unwrap(), stop.clone()).unwrap();
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
    let pump_stop = Arc::new(AtomicBool::new(false));
    let sender = {
        let (config, log, pump_stop) = (config.clone(), log.clone(), pump_stop.clone());
        let packets = station_packets(&template, ALERT_STATIONS);
        std::thread::spawn(move || {
            let mut sink = IoxPacketSink::new(&config).unwrap();
            assert!(sink.wait_for_subscriber(Duration::from_secs(30)).unwrap());
            log.paced_send(&mut sink, &packets, PACE);
            std::thread::sleep(Duration::from_millis(500));
            pump_stop.store(true, Ordering::Relaxed);
        })
    };
    // Wraps the alert publisher to record the node-internal part of the latency: arrival of
    // the triggering packet at the input → publication of the alert.
    struct Timed {
        inner: IoxAlertPublisher,
        internal_us: Vec<f64>,
    }
    impl rockwatch::node::Publisher for Timed {
        fn publish(&mut self, p: &rockwatch::node::Publication) -> anyhow::Result<()> {
            if let rockwatch::node::Publication::Alert { latency_ns, .. } = p {
                self.internal_us.push(*latency_ns as f64 / 1e3);
            }
            self.inner.publish(p)
        }
    }
    let mut publisher = Timed {
        inner: IoxAlertPublisher::new(&config).unwrap(),
        internal_us: Vec::new(),
    };
    runtime.pump(&mut [&mut publisher], &pump_stop).unwrap();
    sender.join().unwrap();
    let input_stats = input.join().unwrap();
    runtime.shutdown(&mut |_| {}).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    subscriber_done.store(true, Ordering::Relaxed);
    let alerts = subscriber.join().unwrap();

    let latencies_us = log.latencies_us(alerts.iter().map(|(a, t)| (a.station(), *t)));
    let mut internal = publisher.internal_us.clone();
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
         ({} stations, 2 shards, one packet every {:?}): p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
        latencies_us.len(),
        input_stats.submitted,
        ALERT_STATIONS,
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
    let runtime = NodeRuntime::start(&NodeOptions {
        catalogue: Some(catalogue),
        shards: 0,
        ..NodeOptions::default()
    })
    .unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let input = IoxInput::spawn(&intake_config, runtime.submitter().unwrap(), stop).unwrap();
    let mut sink = IoxPacketSink::new(&intake_config).unwrap();
    assert!(sink.wait_for_subscriber(Duration::from_secs(30)).unwrap());
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
    // Flow control from the input's counters (same process): at most BACKLOG packets in
    // flight, below the subscriber buffer, so nothing overflows and the rate is the input's.
    const BACKLOG: u64 = 512;
    let start = Instant::now();
    let deadline = start + Duration::from_secs(300);
    let mut sent = 0u64;
    for j in 0..rounds {
        for s in 0..INTAKE_STATIONS {
            while sent >= input.stats().received + BACKLOG && Instant::now() < deadline {
                std::thread::sleep(Duration::from_micros(50));
            }
            sink.send(&quiet(s, j)).unwrap();
            sent += 1;
        }
    }
    let sent_s = start.elapsed().as_secs_f64();
    while input.stats().received < total && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(1));
    }
    let intake_s = start.elapsed().as_secs_f64();
    let stats = input.join().unwrap();
    runtime.shutdown(&mut |_| {}).unwrap();
    let engine_s = start.elapsed().as_secs_f64();
    println!(
        "iceoryx2 intake: {total} packets ({INTAKE_STATIONS} stations x {rounds} packets of 10 \
         samples = {:.0} s of data): sent in {sent_s:.2} s, taken by the input in {intake_s:.2} s \
         ({:.0} packets/s, {} lost to overflow), processed by the engine in {engine_s:.2} s \
         ({:.0} packets/s = {:.1}x real time for {INTAKE_STATIONS} stations at 100 Hz)",
        rounds as f64 * 0.1,
        stats.received as f64 / intake_s,
        stats.sequence_gaps,
        total as f64 / engine_s,
        (rounds as f64 * 0.1) / engine_s,
    );
}
