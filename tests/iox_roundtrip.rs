//! iceoryx2 transport: wire layouts, and the Rust round trip IoxPacketSink → the node
//! (`rockwatch::node::Reactor`, the code `rockwatch node` runs: iceoryx2 input, engine,
//! alert publisher on one event loop) → a Rust subscriber, with the Rinaldi record. The node
//! also joins ROS 2, so those tests run in a private network namespace (loopback only).

mod shell_harness;
use rockwatch_test_harness::netns::reexec_in_netns;
use shell_harness::rinaldi_packets;

use std::mem::{align_of, offset_of, size_of};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use rockwatch::iox::types::{AccelHeader, AccelSample, IntakeIox, PbrAlertIox};
use rockwatch::iox::{IoxAlertSubscriber, IoxConfig, IoxPacketSink};
use rockwatch::node::{NodeOptions, Reactor};
use rockwatch::ports::PacketSink;
use rockwatch::ros2::{network_plan, NetworkPlan, Ros2Config};
use rockwatch_core::engine::AccelPacket;

/// Unique service names per test and process, so tests run in parallel.
fn test_config(tag: &str) -> IoxConfig {
    let id = std::process::id();
    IoxConfig {
        config_file: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/iceoryx2.toml"
        ))),
        accel_service: format!("rockwatch-test/{id}/{tag}/accel"),
        alerts_service: format!("rockwatch-test/{id}/{tag}/alerts"),
        ..IoxConfig::default()
    }
}

/// Node options for the example catalogue with the iceoryx2 transport `iox`, and the
/// loopback-only ROS 2 plan.
fn node_options(iox: &IoxConfig, shards: usize) -> (NodeOptions, NetworkPlan) {
    let mut options = NodeOptions {
        catalogue: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))),
        shards,
        ..NodeOptions::default()
    };
    options.config.iceoryx2 = iox.clone();
    options.config.ros2 = Ros2Config::loopback_only();
    let plan = network_plan(&options.config.ros2, None, None).unwrap();
    (options, plan)
}

#[test]
fn wire_layouts_match_the_documented_c_layouts() {
    // Offsets from docs/iceoryx2.md (C struct rules: every field at a multiple of its
    // alignment, no padding needed by construction).
    assert_eq!(
        (size_of::<AccelHeader>(), align_of::<AccelHeader>()),
        (56, 8)
    );
    assert_eq!(offset_of!(AccelHeader, station), 0);
    assert_eq!(offset_of!(AccelHeader, sample_rate_hz), 16);
    assert_eq!(offset_of!(AccelHeader, start_time_ns), 24);
    assert_eq!(offset_of!(AccelHeader, sequence), 32);
    assert_eq!(offset_of!(AccelHeader, sample_count), 40);
    assert_eq!(offset_of!(AccelHeader, flags), 48);
    assert_eq!(offset_of!(AccelHeader, reserved), 52);

    assert_eq!(
        (size_of::<AccelSample>(), align_of::<AccelSample>()),
        (12, 4)
    );
    assert_eq!(offset_of!(AccelSample, east), 0);
    assert_eq!(offset_of!(AccelSample, north), 4);
    assert_eq!(offset_of!(AccelSample, up), 8);

    assert_eq!(
        (size_of::<PbrAlertIox>(), align_of::<PbrAlertIox>()),
        (168, 8)
    );
    for (offset, expected) in [
        (offset_of!(PbrAlertIox, sequence), 0),
        (offset_of!(PbrAlertIox, data_time_ns), 8),
        (offset_of!(PbrAlertIox, latency_ns), 16),
        (offset_of!(PbrAlertIox, theta_over_alpha), 24),
        (offset_of!(PbrAlertIox, slide_m), 32),
        (offset_of!(PbrAlertIox, overturn_probability), 40),
        (offset_of!(PbrAlertIox, pga_mps2), 48),
        (offset_of!(PbrAlertIox, pgv_mps), 56),
        (offset_of!(PbrAlertIox, episode), 64),
        (offset_of!(PbrAlertIox, flags), 68),
        (offset_of!(PbrAlertIox, level), 72),
        (offset_of!(PbrAlertIox, mode), 73),
        (offset_of!(PbrAlertIox, reserved), 74),
        (offset_of!(PbrAlertIox, station), 80),
        (offset_of!(PbrAlertIox, pbr_id), 96),
    ] {
        assert_eq!(offset, expected);
    }

    assert_eq!((size_of::<IntakeIox>(), align_of::<IntakeIox>()), (200, 8));
    for (offset, expected) in [
        (offset_of!(IntakeIox, node_id), 0),
        (offset_of!(IntakeIox, reader), 16),
        (offset_of!(IntakeIox, writer), 32),
        (offset_of!(IntakeIox, taken), 48),
        (offset_of!(IntakeIox, ignored), 56),
        (offset_of!(IntakeIox, processed), 64),
        (offset_of!(IntakeIox, refused), 72),
        (offset_of!(IntakeIox, window), 80),
        (offset_of!(IntakeIox, node_len), 88),
        (offset_of!(IntakeIox, node), 96),
        (offset_of!(IntakeIox, dropped), 160),
        (offset_of!(IntakeIox, reserved), 168),
    ] {
        assert_eq!(offset, expected);
    }
}

#[test]
fn wire_type_names_are_the_documented_ones() {
    // SAFETY: `type_name` is an unsafe trait fn of iceoryx2 only because implementors promise
    // the layout; calling it just returns the static name.
    let names = unsafe {
        [
            <AccelHeader as ZeroCopySend>::type_name(),
            <AccelSample as ZeroCopySend>::type_name(),
            <PbrAlertIox as ZeroCopySend>::type_name(),
            <IntakeIox as ZeroCopySend>::type_name(),
        ]
    };
    assert_eq!(
        names,
        [
            "rockwatch::AccelHeader",
            "rockwatch::AccelSample",
            "rockwatch::PbrAlert",
            "rockwatch::IntakeReport"
        ]
    );
}

/// Receives alerts on `pbr/alerts` until `want` says stop or the deadline passes.
fn collect_alerts(
    config: &IoxConfig,
    ready: &std::sync::Barrier,
    done: &AtomicBool,
) -> Vec<PbrAlertIox> {
    let subscriber = IoxAlertSubscriber::new(config).unwrap();
    ready.wait();
    let mut got = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(60);
    while Instant::now() < deadline {
        subscriber
            .wait(Duration::from_millis(50), &mut got)
            .unwrap();
        if done.load(Ordering::Relaxed) {
            break;
        }
    }
    got
}

fn rinaldi_over_iceoryx2_overturns_the_slender_pillar(shards: usize) {
    let config = test_config(&format!("roundtrip{shards}"));
    let (options, plan) = node_options(&config, shards);
    let reactor = Reactor::start(&options, &plan).unwrap();

    // The alert subscriber exists before anything is published.
    let ready = Arc::new(std::sync::Barrier::new(2));
    let done = Arc::new(AtomicBool::new(false));
    let subscriber = {
        let (config, ready, done) = (config.clone(), ready.clone(), done.clone());
        std::thread::spawn(move || collect_alerts(&config, &ready, &done))
    };
    ready.wait();

    let packets = rinaldi_packets(10.0);
    let n = packets.len() as u64;
    // The node runs on this thread; the sender stops it once everything was sent (what the
    // engine still holds comes out at shutdown).
    let stop = Arc::new(AtomicBool::new(false));
    let sender = {
        let (config, stop) = (config.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut sink = IoxPacketSink::new(&config).unwrap();
            let connected = sink.wait_for_subscriber(Duration::from_secs(10));
            if matches!(connected, Ok(true)) {
                for p in &packets {
                    sink.send(p).unwrap();
                }
            }
            std::thread::sleep(Duration::from_millis(500));
            stop.store(true, Ordering::Relaxed);
            connected.unwrap()
        })
    };
    let report = reactor.run(&stop, &mut []).unwrap();
    assert!(sender.join().unwrap(), "the input never subscribed");
    let stats = report.iox.unwrap();
    std::thread::sleep(Duration::from_millis(200));
    done.store(true, Ordering::Relaxed);
    let alerts = subscriber.join().unwrap();

    assert_eq!(stats.received, n, "{stats:?}");
    assert_eq!(stats.submitted, n, "{stats:?}");
    assert_eq!(stats.sequence_gaps, 0, "{stats:?}");
    assert_eq!(report.input.packets, n, "{:?}", report.input);
    let overturned: Vec<_> = alerts
        .iter()
        .filter(|a| a.level == 3)
        .map(PbrAlertIox::pbr_id)
        .collect();
    assert!(
        overturned.contains(&"rrs-slender-pillar".to_string()),
        "{alerts:?}"
    );
    // The stocky boulder may slide (motion onset) but never comes near overturning.
    assert!(!alerts
        .iter()
        .any(|a| a.pbr_id() == "rrs-stocky-boulder" && a.level >= 2));
    // Alert sequence numbers are contiguous from 0: nothing lost.
    for (i, a) in alerts.iter().enumerate() {
        assert_eq!(a.sequence, i as u64);
        assert_eq!(a.station(), "CI.RRS.00");
    }
}

#[test]
fn rinaldi_over_iceoryx2_overturns_the_slender_pillar_with_the_inline_engine() {
    if reexec_in_netns(
        "rinaldi_over_iceoryx2_overturns_the_slender_pillar_with_the_inline_engine",
        120,
    ) {
        rinaldi_over_iceoryx2_overturns_the_slender_pillar(1);
    }
}

#[test]
fn rinaldi_over_iceoryx2_overturns_the_slender_pillar_with_two_engine_shards() {
    if reexec_in_netns(
        "rinaldi_over_iceoryx2_overturns_the_slender_pillar_with_two_engine_shards",
        120,
    ) {
        rinaldi_over_iceoryx2_overturns_the_slender_pillar(2);
    }
}

#[test]
fn malformed_input_over_the_wire_is_counted_and_never_crashes() {
    if !reexec_in_netns(
        "malformed_input_over_the_wire_is_counted_and_never_crashes",
        120,
    ) {
        return;
    }
    let config = test_config("malformed");
    let (options, plan) = node_options(&config, 1);
    let reactor = Reactor::start(&options, &plan).unwrap();
    let probe = reactor.probe();
    let stop = Arc::new(AtomicBool::new(false));
    let sender = {
        let (config, stop) = (config.clone(), stop.clone());
        std::thread::spawn(move || {
            send_hostile_packets(&config, &probe);
            stop.store(true, Ordering::Relaxed);
        })
    };
    let report = reactor.run(&stop, &mut []).unwrap();
    sender.join().unwrap();
    let stats = report.iox.unwrap();
    let total = 11; // 10 hostile + 1 good, sent below
    assert_eq!(stats.received, total, "{stats:?}");
    // Refused at the wire: what only iceoryx2 can get wrong.
    assert_eq!(stats.rejected_count_mismatch, 1, "{stats:?}");
    assert_eq!(stats.rejected_station, 2, "{stats:?}");
    assert_eq!(stats.rejected_structure, 3, "{stats:?}");
    // The rest is refused as on every transport (ROS 2 too, tests/ros2_malformed.rs): the
    // id that is text but not NET.STA.LOC by the node at the edge, the bad values (NaN,
    // absurd rate, empty) by the engine's one check, after the good packet's station is
    // found.
    assert_eq!(stats.submitted, 4, "{stats:?}");
    assert_eq!(
        report.input.malformed_station_packets, 1,
        "{:?}",
        report.input
    );
    assert_eq!(report.input.packets, 4, "{:?}", report.input);
    assert_eq!(report.input.rejected_packets, 3, "{:?}", report.input);
}

/// Sends 10 hostile packets and a good one, and waits (bounded) until the node took them.
fn send_hostile_packets(config: &IoxConfig, probe: &rockwatch::node::Probe) {
    let mut sink = IoxPacketSink::new(config).unwrap();
    assert!(sink.wait_for_subscriber(Duration::from_secs(10)).unwrap());

    let good = AccelPacket {
        station: rockwatch_core::engine::StationId::parse("CI.RRS.00").unwrap(),
        start_time_ns: 0,
        sample_rate_hz: 100.0,
        sequence: 0,
        east: vec![0.1; 10],
        north: vec![0.0; 10],
        up: vec![],
        unit: Default::default(),
    };
    let header = AccelHeader::from_packet(&good);
    let samples = vec![AccelSample::default(); 10];
    let with = |f: &dyn Fn(&mut AccelHeader)| {
        let mut h = header;
        f(&mut h);
        h
    };
    let mut station_after_nul = [0u8; 16];
    station_after_nul[..9].copy_from_slice(b"CI.RRS.00");
    station_after_nul[12] = b'X';
    let mut nan = samples.clone();
    nan[3].north = f32::NAN;
    let hostile: Vec<(AccelHeader, Vec<AccelSample>)> = vec![
        // Count mismatch (1).
        (with(&|h| h.sample_count = 11), samples.clone()),
        // Station: invalid UTF-8, garbage after the NUL (2), not a SEED id (1).
        (with(&|h| h.station = [0xFF; 16]), samples.clone()),
        (with(&|h| h.station = station_after_nul), samples.clone()),
        (
            with(&|h| h.station[..3].copy_from_slice(b"C-I")),
            samples.clone(),
        ),
        // Structure: unknown flag, reserved set, oversized (3).
        (with(&|h| h.flags = 0x80), samples.clone()),
        (with(&|h| h.reserved = 7), samples.clone()),
        (
            with(&|h| h.sample_count = 100_001),
            vec![AccelSample::default(); 100_001],
        ),
        // Values: NaN, absurd rate, empty (3).
        (header, nan),
        (with(&|h| h.sample_rate_hz = 1e9), samples.clone()),
        (with(&|h| h.sample_count = 0), vec![]),
    ];
    for (h, s) in &hostile {
        sink.send_raw(h, s).unwrap();
    }
    sink.send(&good).unwrap();
    let total = hostile.len() as u64 + 1;
    assert_eq!(total, 11);
    let deadline = Instant::now() + Duration::from_secs(20);
    while probe.iox().unwrap().received < total && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
}
