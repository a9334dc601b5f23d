//! The live node's runtime without transports: packets in, publications out, journal kept.

mod support;
use support::rinaldi_packets;

use std::path::PathBuf;
use std::time::Duration;

use rockwatch::catalogue::Catalogue;
use rockwatch::engine::{Engine, EngineConfig, Output, PbrSpec};
use rockwatch::journal::read_journal;
use rockwatch::node::{NodeOptions, NodeRuntime, Publication};

#[test]
fn runtime_publishes_the_engines_alerts_journaled_with_latencies() {
    let dir = tempfile::tempdir().unwrap();
    let options = NodeOptions {
        catalogue: Some(PathBuf::from("config/catalogue.toml")),
        state_dir: Some(dir.path().to_path_buf()),
        shards: 2,
        ..NodeOptions::default()
    };
    let mut node = NodeRuntime::start(&options).unwrap();
    let mut published = Vec::new();
    let mut publish = |p: Publication| published.push(p);
    for packet in rinaldi_packets() {
        node.submit(packet);
        node.poll(&mut publish).unwrap();
    }
    node.poll_wait(Duration::from_millis(10), &mut publish)
        .unwrap();
    let summaries = node.shutdown(&mut publish).unwrap();
    assert_eq!(
        summaries.len(),
        Catalogue::load("config/catalogue.toml").unwrap().len()
    );

    // The same alerts as the single-threaded engine on the same packets.
    let catalogue = Catalogue::load("config/catalogue.toml").unwrap();
    let specs: Vec<PbrSpec> = catalogue
        .pbrs()
        .iter()
        .map(|p| PbrSpec::from_catalogue(p).unwrap())
        .collect();
    let mut engine = Engine::new(EngineConfig::default(), vec![], &specs).unwrap();
    let mut out = Vec::new();
    for p in rinaldi_packets() {
        engine.process(p, 0, &mut out);
    }
    engine.flush(0, &mut out);
    let mut expected: Vec<_> = out
        .iter()
        .filter_map(|o| {
            if let Output::Alert(a) = o {
                Some(a.key())
            } else {
                None
            }
        })
        .collect();
    let mut got: Vec<_> = published
        .iter()
        .filter_map(|p| {
            if let Publication::Alert { alert, .. } = p {
                Some(alert.key())
            } else {
                None
            }
        })
        .collect();
    expected.sort();
    got.sort();
    assert!(!got.is_empty());
    assert_eq!(got, expected);
    for p in &published {
        if let Publication::Alert { latency_ns, .. } = p {
            assert!(
                *latency_ns >= 0 && *latency_ns < 5_000_000_000,
                "latency {latency_ns} ns"
            );
        }
    }
    assert!(published.iter().any(|p| matches!(p, Publication::State(_))));
    assert!(published
        .iter()
        .any(|p| matches!(p, Publication::Intensity(_))));
    let (records, _) = read_journal(dir.path()).unwrap();
    let journaled = records
        .iter()
        .filter(|r| matches!(r, rockwatch::engine::JournalRecord::Alert(_)))
        .count();
    assert_eq!(journaled, got.len());
}

/// Collects publications.
struct Collect(Vec<Publication>);
impl rockwatch::node::Publisher for Collect {
    fn publish(&mut self, p: &Publication) -> anyhow::Result<()> {
        self.0.push(p.clone());
        Ok(())
    }
}

#[test]
fn transport_threads_submit_while_the_pump_publishes() {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    let options = NodeOptions {
        catalogue: Some(PathBuf::from("config/catalogue.toml")),
        shards: 2,
        ..NodeOptions::default()
    };
    let mut node = NodeRuntime::start(&options).unwrap();
    let submitter = node.submitter().unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let producer = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            for p in rinaldi_packets() {
                submitter.submit(p);
            }
            std::thread::sleep(Duration::from_millis(300));
            stop.store(true, Ordering::Relaxed);
        })
    };
    let mut collect = Collect(Vec::new());
    node.pump(&mut [&mut collect], &stop).unwrap();
    producer.join().unwrap();
    node.shutdown(&mut |p| collect.0.push(p)).unwrap();
    let overturned = collect
        .0
        .iter()
        .filter(|p| matches!(p, Publication::Alert { alert, .. } if alert.level == rockwatch::engine::AlertLevel::Overturned))
        .count();
    assert_eq!(overturned, 1, "the slender pillar falls once");
}

#[test]
fn a_packet_held_for_missing_data_is_released_when_the_station_falls_silent() {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    let options = NodeOptions {
        catalogue: Some(PathBuf::from("config/catalogue.toml")),
        shards: 1,
        ..NodeOptions::default()
    };
    let mut node = NodeRuntime::start(&options).unwrap();
    let submitter = node.submitter().unwrap();
    let packets = rinaldi_packets();
    // Packet 0, then packet 12 (1.1 s lost), then silence: packet 12 waits in the reorder
    // window until the node's timer releases it. (States and intensities are published once
    // per second of data, so the held packet's must show a data time ≥ 1.2 s.)
    submitter.submit(packets[0].clone());
    submitter.submit(packets[12].clone());
    let held_start = packets[12].start_time_ns;
    let stop = Arc::new(AtomicBool::new(false));
    let timer = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            // One timeout (1 s) plus margin.
            std::thread::sleep(rockwatch::node::HELD_PACKET_TIMEOUT + Duration::from_millis(600));
            stop.store(true, Ordering::Relaxed);
        })
    };
    let mut collect = Collect(Vec::new());
    node.pump(&mut [&mut collect], &stop).unwrap();
    timer.join().unwrap();
    assert!(
        collect.0.iter().any(
            |p| matches!(p, Publication::Intensity(i) if i.data_time_ns >= held_start)
                || matches!(p, Publication::State(s) if s.data_time_ns >= held_start)
        ),
        "the held packet was never processed before shutdown"
    );
    node.shutdown(&mut |_| {}).unwrap();
}
