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
mod thread_time;
use common::{percentile, rinaldi, station, station_packets, write_catalogue, SendLog};

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use rockwatch::iox::{
    IoxAlertPublisher, IoxAlertSubscriber, IoxConfig, IoxInput, IoxPacketSink, PbrAlertIox,
};
use rockwatch::node::{NodeOptions, Reactor};
use rockwatch::ports::PacketSink;
use rockwatch::ports::{Publication, Publisher};
use rockwatch::ros2::{network_plan, NetworkPlan, Ros2Config};
use rockwatch_core::dynamics::Mode;
use rockwatch_core::engine::{AccelPacket, Alert, AlertLevel, StationId};

const ALERT_STATIONS: usize = 400;
const INTAKE_STATIONS: usize = 1000;
const PACKET_MS: u32 = 100;
const PACE: Duration = Duration::from_micros(250);

/// Records the node-internal part of the latency (arrival of the triggering packet at the
/// input → the alert ready to publish, journaled: the alert's own `latency_ns`) and when the
/// node was ready to publish each alert (ns since the send log's epoch: the node's arrival
/// stamp plus `latency_ns`, moved to that epoch), keyed by (block, data time).
struct Internal {
    /// Node epoch − send log epoch (ns).
    node_offset_ns: i64,
    internal_us: Vec<f64>,
    published: Vec<(String, String, i64, i64)>,
}
impl Publisher for Internal {
    fn publish(&mut self, p: &Publication) -> anyhow::Result<()> {
        if let Publication::Alert {
            alert, latency_ns, ..
        } = p
        {
            self.internal_us.push(*latency_ns as f64 / 1e3);
            self.published.push((
                alert.station.to_string(),
                alert.pbr_id.to_string(),
                alert.data_time_ns,
                self.node_offset_ns + alert.arrival_ns + latency_ns,
            ));
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

/// A thread subscribed to the alerts of `config` (it says so on `ready`) that waits on the
/// alerts' event service, as a client would, until `done`: every alert with the time it was
/// received (ns since `epoch`).
fn alert_subscriber(
    config: &IoxConfig,
    epoch: Instant,
    done: Arc<AtomicBool>,
    ready: std::sync::mpsc::Sender<()>,
) -> std::thread::JoinHandle<Vec<(PbrAlertIox, i64)>> {
    let config = config.clone();
    std::thread::spawn(move || {
        let sub = IoxAlertSubscriber::new(&config).unwrap();
        ready.send(()).unwrap();
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
}

/// The transport alone, for comparison: the same sender, subscriber and pace, and an echo
/// thread built like the node's event loop (the iceoryx2 input on a mio Poll, the alert
/// publisher) that answers each packet with an alert at once — no engine, no ROS 2, no other
/// thread. Returns the sorted latencies (µs) publish packet → receive alert: two wake-ups.
fn transport_floor(config: &IoxConfig, packets: usize) -> Vec<f64> {
    let stop = Arc::new(AtomicBool::new(false));
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let echo = {
        let (config, stop, ready_tx) = (config.clone(), stop.clone(), ready_tx.clone());
        std::thread::spawn(move || {
            let mut input = IoxInput::open(&config, Default::default()).unwrap();
            let mut publisher = IoxAlertPublisher::new(&config).unwrap();
            let mut poll = mio::Poll::new().unwrap();
            poll.registry()
                .register(&mut input, mio::Token(0), mio::Interest::READABLE)
                .unwrap();
            let mut events = mio::Events::with_capacity(8);
            ready_tx.send(()).unwrap();
            while !stop.load(Ordering::Relaxed) {
                poll.poll(&mut events, Some(Duration::from_millis(50)))
                    .unwrap();
                input.drain(usize::MAX, &|_| true, &mut |received, _| {
                    let p: AccelPacket = received.expect("the bench sends valid station ids");
                    let alert = Alert {
                        pbr_id: rockwatch_core::engine::PbrId::parse("echo").unwrap(),
                        station: p.station,
                        level: AlertLevel::MotionOnset,
                        episode: 1,
                        mode: Mode::Rock,
                        theta_over_alpha: 0.0,
                        slide_m: 0.0,
                        overturn_probability: 0.0,
                        pga_mps2: 0.0,
                        pgv_mps: 0.0,
                        data_time_ns: p.start_time_ns,
                        arrival_ns: 0,
                        direction_deg: 0.0,
                        lat_deg: Default::default(),
                        lon_deg: Default::default(),
                        pbr_name: Default::default(),
                    };
                    publisher
                        .publish(&Publication::Alert {
                            alert,
                            latency_ns: 0,
                            journal_pending: false,
                        })
                        .expect("the echo alert is published");
                });
            }
        })
    };
    let epoch = Instant::now();
    let done = Arc::new(AtomicBool::new(false));
    let subscriber = alert_subscriber(config, epoch, done.clone(), ready_tx);
    ready_rx.recv_timeout(Duration::from_secs(30)).unwrap();
    ready_rx.recv_timeout(Duration::from_secs(30)).unwrap();
    let mut sink = IoxPacketSink::new(config).unwrap();
    assert!(sink.wait_for_subscriber(Duration::from_secs(30)).unwrap());
    let mut sent = vec![0i64; packets];
    let mut next = Instant::now();
    for (i, sent) in sent.iter_mut().enumerate() {
        std::thread::sleep(next.saturating_duration_since(Instant::now()));
        next += PACE;
        let packet = AccelPacket {
            station: rockwatch_core::engine::StationId::parse(&station(i % ALERT_STATIONS))
                .expect("valid id"),
            start_time_ns: i as i64,
            sample_rate_hz: 100.0,
            sequence: (i / ALERT_STATIONS) as u64,
            east: vec![0.0; 10],
            north: vec![0.0; 10],
            up: vec![0.0; 10],
            unit: Default::default(),
        };
        *sent = epoch.elapsed().as_nanos() as i64;
        sink.send(&packet).unwrap();
    }
    std::thread::sleep(Duration::from_millis(200));
    done.store(true, Ordering::Relaxed);
    stop.store(true, Ordering::Relaxed);
    echo.join().unwrap();
    let mut latencies: Vec<f64> = subscriber
        .join()
        .unwrap()
        .into_iter()
        .filter_map(|(a, t)| {
            Some((t - *sent.get(usize::try_from(a.data_time_ns).ok()?)?) as f64 / 1e3)
        })
        .collect();
    latencies.sort_by(f64::total_cmp);
    latencies
}

/// The calling thread's (involuntary context switches, ns waited on a run queue, ns run on a
/// CPU) so far, from `/proc/thread-self/status` and `/proc/thread-self/schedstat` (zeros if
/// unreadable).
fn thread_sched() -> (u64, u64, u64) {
    let status = std::fs::read_to_string("/proc/thread-self/status").unwrap_or_default();
    let involuntary = status
        .lines()
        .find_map(|l| l.strip_prefix("nonvoluntary_ctxt_switches:"))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(0);
    let (run, wait) = thread_time::run_and_wait_ns().unwrap_or((0, 0));
    (involuntary, wait, run)
}

/// The node's own part with nothing around it: the same catalogue and packets, handed one by
/// one to the node's runtime (`NodeRuntime::submit`: arrival stamp → engine → alert ready,
/// the code the event loop runs per packet) on this thread, no transport, no other thread of
/// ours running. The sorted `latency_ns` (µs) of every alert.
/// With `state_dir`, every alert is journaled and synced (fdatasync) before it is ready, as
/// in a node with a state directory.
fn node_part_alone(
    catalogue: &Path,
    packets: &[Vec<AccelPacket>],
    state_dir: Option<&Path>,
) -> Vec<f64> {
    let options = NodeOptions {
        catalogue: Some(catalogue.to_path_buf()),
        state_dir: state_dir.map(Path::to_path_buf),
        ..NodeOptions::default()
    };
    let mut runtime = rockwatch::node::NodeRuntime::start(&options).unwrap();
    let mut out = Vec::with_capacity(4096);
    for j in 0..packets[0].len() {
        for station in packets {
            runtime.submit(station[j].clone(), &mut |p| {
                if let Publication::Alert { latency_ns, .. } = p {
                    out.push(latency_ns as f64 / 1e3);
                }
            });
        }
    }
    out.sort_by(f64::total_cmp);
    out
}

fn main() {
    let dir = tempfile::tempdir().unwrap();
    let catalogue = dir.path().join("catalogue.toml");
    write_catalogue(&catalogue, INTAKE_STATIONS);
    let pid = std::process::id();
    let config = IoxConfig {
        config_file: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/iceoryx2.toml"
        ))),
        accel_service: format!("rockwatch-bench/{pid}/accel"),
        alerts_service: format!("rockwatch-bench/{pid}/alerts"),
        alert_history: 1024,
        ..IoxConfig::default()
    };
    let traces = rinaldi();
    let template = traces.packets(&StationId::parse("XB.S0000.00").unwrap(), PACKET_MS, 2.0);
    let per_station = template.len();

    // ---- transport floor -----------------------------------------------------------------
    let floor_config = IoxConfig {
        accel_service: format!("rockwatch-bench/{pid}/floor-accel"),
        alerts_service: format!("rockwatch-bench/{pid}/floor-alerts"),
        ..config.clone()
    };
    let floor = transport_floor(&floor_config, 20_000);
    println!(
        "  transport alone (same pace; an echo thread built like the event loop answers each \
         packet at once: two wake-ups, no engine, no ROS 2), {} round trips: p50 {:.1} µs, \
         p99 {:.1} µs, max {:.1} µs",
        floor.len(),
        percentile(&floor, 50.0),
        percentile(&floor, 99.0),
        floor.last().copied().unwrap_or(f64::NAN),
    );

    // ---- latency -------------------------------------------------------------------------
    let (options, plan) = node_options(&catalogue, &config);
    let reactor = Reactor::start(&options, &plan).unwrap();
    let log = Arc::new(SendLog::new(ALERT_STATIONS, per_station));
    let epoch = log.epoch;
    let subscriber_done = Arc::new(AtomicBool::new(false));
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let subscriber = alert_subscriber(&config, epoch, subscriber_done.clone(), ready_tx);
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
    let mut internal = Internal {
        node_offset_ns: reactor.epoch().duration_since(epoch).as_nanos() as i64
            - epoch.duration_since(reactor.epoch()).as_nanos() as i64,
        internal_us: Vec::with_capacity(4096),
        published: Vec::with_capacity(4096),
    };
    let sched_before = thread_sched();
    let run_start = Instant::now();
    let report = reactor.run(&stop, &mut [&mut internal]).unwrap();
    let run_s = run_start.elapsed().as_secs_f64();
    let sched_after = thread_sched();
    sender.join().unwrap();
    let input_stats = report.iox.unwrap();
    std::thread::sleep(Duration::from_millis(100));
    subscriber_done.store(true, Ordering::Relaxed);
    let alerts = subscriber.join().unwrap();

    let latencies_us = log.latencies_us(alerts.iter().map(|(a, t)| (a.station(), *t)));
    // Where the time goes: publish packet → the alert is ready (journaled) in the node
    // (iceoryx2 wake-up of the node, queueing, engine), and ready → the subscriber has it
    // (iceoryx2 publish + notify, wake-up of the subscriber).
    let to_node_us = log.latencies_us(
        internal
            .published
            .iter()
            .map(|(station, _, _, t)| (station, *t)),
    );
    let published: std::collections::HashMap<(String, i64), i64> = internal
        .published
        .iter()
        .map(|(_, pbr, data_ns, t)| ((pbr.clone(), *data_ns), *t))
        .collect();
    let mut to_subscriber_us: Vec<f64> = alerts
        .iter()
        .filter_map(|(a, t)| {
            let sent = published.get(&(a.pbr_id(), a.data_time_ns))?;
            Some((t - sent) as f64 / 1e3)
        })
        .collect();
    to_subscriber_us.sort_by(f64::total_cmp);
    let mut internal_us = internal.internal_us;
    internal_us.sort_by(f64::total_cmp);
    let p = |v: &[f64], q: f64| {
        if v.is_empty() {
            f64::NAN
        } else {
            percentile(v, q)
        }
    };
    println!(
        "  node-internal part (packet taken by the input → alert published): p50 {:.1} µs, p99 {:.1} µs",
        p(&internal_us, 50.0),
        p(&internal_us, 99.0)
    );
    println!(
        "iceoryx2 node's added part vs bare transport, same run: node (packet taken → alert \
         published) p99 {:.1} µs (target ≤ 25 µs), bare iceoryx2 round trip p99 {:.1} µs",
        p(&internal_us, 99.0),
        percentile(&floor, 99.0),
    );
    // Why the tail: the node's thread shares 2 vCPUs with the sender, the subscriber, its
    // DDS threads and the rest of the machine. Its scheduling over the run, and the same
    // node part measured with nothing else of ours running.
    let (involuntary, waited_ns, ran_ns) = (
        sched_after.0 - sched_before.0,
        sched_after.1 - sched_before.1,
        sched_after.2 - sched_before.2,
    );
    println!(
        "  node thread over the run ({run_s:.1} s): {involuntary} involuntary context switches \
         (preempted), {:.1} ms waiting for a CPU, {:.1} ms on a CPU; {} alerts",
        waited_ns as f64 / 1e6,
        ran_ns as f64 / 1e6,
        internal_us.len()
    );
    let alert_packets = station_packets(&template, ALERT_STATIONS);
    let alone = node_part_alone(&catalogue, &alert_packets, None);
    println!(
        "  node part alone (same packets and catalogue through NodeRuntime::submit on one \
         thread, no transport, no other thread): {} alerts, p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
        alone.len(),
        p(&alone, 50.0),
        p(&alone, 99.0),
        alone.last().copied().unwrap_or(f64::NAN)
    );
    let journal_dir = tempfile::tempdir().unwrap();
    let synced = node_part_alone(&catalogue, &alert_packets, Some(journal_dir.path()));
    println!(
        "  same with a state directory (each alert journaled and fdatasync'ed before it is \
         published; the runs above have none): p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
        p(&synced, 50.0),
        p(&synced, 99.0),
        synced.last().copied().unwrap_or(f64::NAN)
    );
    println!(
        "  packet published → alert ready in the node: p50 {:.1} µs, p99 {:.1} µs; \
         alert ready in the node → received: p50 {:.1} µs, p99 {:.1} µs",
        p(&to_node_us, 50.0),
        p(&to_node_us, 99.0),
        p(&to_subscriber_us, 50.0),
        p(&to_subscriber_us, 99.0),
    );
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
        station: rockwatch_core::engine::StationId::parse(&station(s)).expect("valid id"),
        start_time_ns: j as i64 * 100_000_000,
        sample_rate_hz: 100.0,
        sequence: j as u64,
        east: vec![0.001; 10],
        north: vec![-0.001; 10],
        up: vec![0.0; 10],
        unit: Default::default(),
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
