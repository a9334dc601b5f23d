//! iceoryx2 with independent peers: the PyPI package `iceoryx2` (same version as the crate)
//! publishes the Rinaldi packets and subscribes to the alerts; a `kill -9`ed publisher process.
//! The node is `rockwatch::node::Reactor` (what `rockwatch node` runs); it also joins ROS 2, so
//! each test runs in a private network namespace (loopback only).
//! Without Python/iceoryx2 the tests are skipped locally and FAIL when CI=true.

mod shell_harness;
use rockwatch_test_harness::netns::reexec_in_netns;
use shell_harness::rinaldi_packets;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use rockwatch::iox::IoxConfig;
use rockwatch::node::{NodeOptions, Probe, Reactor};
use rockwatch::ros2::{network_plan, Ros2Config};
use rockwatch_core::engine::AccelPacket;

const ICEORYX2_VERSION: &str = "0.10.0";

fn test_config(tag: &str) -> IoxConfig {
    let id = std::process::id();
    IoxConfig {
        config_file: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/iceoryx2.toml"
        ))),
        accel_service: format!("rockwatch-peer/{id}/{tag}/accel"),
        alerts_service: format!("rockwatch-peer/{id}/{tag}/alerts"),
        ..IoxConfig::default()
    }
}

/// True when `python3` has iceoryx2 of the crate's version; panics under CI=true otherwise.
fn python_peer_available() -> bool {
    let ok = Command::new("python3")
        .args([
            "-c",
            &format!(
                "import importlib.metadata as m, iceoryx2; assert m.version('iceoryx2') == '{ICEORYX2_VERSION}'"
            ),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI=true but python3 with iceoryx2=={ICEORYX2_VERSION} is missing (see .ci/run)"
        );
        eprintln!("skipped: python3 with iceoryx2=={ICEORYX2_VERSION} not found");
    }
    ok
}

fn write_packets(path: &Path, packets: &[AccelPacket]) {
    let list: Vec<serde_json::Value> = packets
        .iter()
        .map(|p| {
            serde_json::json!({
                "station": p.station, "start_time_ns": p.start_time_ns,
                "sample_rate_hz": p.sample_rate_hz, "sequence": p.sequence,
                "east": p.east, "north": p.north, "up": p.up,
            })
        })
        .collect();
    std::fs::write(path, serde_json::to_string(&list).unwrap()).unwrap();
}

/// A child process killed on drop, with its stdout lines on a channel.
struct Peer {
    child: Child,
    lines: Receiver<String>,
}

impl Peer {
    fn spawn(script: &str, args: &[&str]) -> Peer {
        let mut child = Command::new("python3")
            .arg(format!(
                concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/iox/{}"),
                script
            ))
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Peer { child, lines }
    }

    /// Waits (bounded) for a line equal to `want`.
    fn expect_line(&self, want: &str, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) if line.trim() == want => return,
                Ok(_) => {}
                Err(e) => panic!("peer never printed {want:?}: {e}"),
            }
        }
    }

    /// Closes its stdin (a lingering publisher then exits).
    fn close_stdin(&mut self) {
        drop(self.child.stdin.take());
    }

    /// Waits (bounded) for the process to exit; true if it exited successfully.
    fn wait(&mut self, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status.success();
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        false
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts a Python alert subscriber and waits until it is subscribed.
fn python_subscriber(config: &IoxConfig, stop_file: &Path) -> Peer {
    let peer = Peer::spawn(
        "alert_subscriber.py",
        &[
            concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/iceoryx2.toml"),
            &config.alerts_service,
            stop_file.to_str().unwrap(),
            "90",
        ],
    );
    peer.expect_line("ready", Duration::from_secs(30));
    peer
}

/// Stops the subscriber and returns the alerts it printed, as (pbr_id, level, sequence).
fn alerts_of(mut peer: Peer, stop_file: &Path) -> Vec<(String, u64, u64)> {
    std::thread::sleep(Duration::from_millis(300));
    std::fs::write(stop_file, "").unwrap();
    assert!(peer.wait(Duration::from_secs(20)), "subscriber failed");
    let mut alerts = Vec::new();
    while let Ok(line) = peer.lines.recv_timeout(Duration::from_millis(200)) {
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        alerts.push((
            v["pbr_id"].as_str().unwrap().to_string(),
            v["level"].as_u64().unwrap(),
            v["sequence"].as_u64().unwrap(),
        ));
    }
    alerts
}

/// Runs the node on this thread while `drive` runs on another; returns the iceoryx2 input's
/// counters.
fn run_node(
    config: &IoxConfig,
    drive: impl FnOnce(&Probe) + Send,
) -> rockwatch::iox::IoxInputStats {
    let mut options = NodeOptions {
        catalogue: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))),
        ..NodeOptions::default()
    };
    options.config.iceoryx2 = config.clone();
    options.config.ros2 = Ros2Config::loopback_only();
    let plan = network_plan(&options.config.ros2, None, None).unwrap();
    let reactor = Reactor::start(&options, &plan).unwrap();
    let probe = reactor.probe();
    let stop = AtomicBool::new(false);
    let report = std::thread::scope(|s| {
        s.spawn(|| {
            let guard = StopOnDrop(&stop);
            drive(&probe);
            std::thread::sleep(Duration::from_millis(500));
            drop(guard);
        });
        reactor.run(&stop, &mut []).unwrap()
    });
    report.iox.unwrap()
}

/// Waits (bounded) until the node's iceoryx2 input has taken `n` packets.
fn wait_received(probe: &Probe, n: u64) {
    let deadline = Instant::now() + Duration::from_secs(30);
    while probe.iox().unwrap().received < n && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Sets the flag when dropped (also when the driver panics, so the node never hangs).
struct StopOnDrop<'a>(&'a AtomicBool);
impl Drop for StopOnDrop<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

#[test]
fn python_publisher_to_node_to_python_subscriber_overturns_the_slender_pillar() {
    if !python_peer_available()
        || !reexec_in_netns(
            "python_publisher_to_node_to_python_subscriber_overturns_the_slender_pillar",
            180,
        )
    {
        return;
    }
    let config = test_config("python");
    let dir = tempfile::tempdir().unwrap();
    let packets_file = dir.path().join("packets.json");
    let packets = rinaldi_packets(10.0);
    write_packets(&packets_file, &packets);
    let stop_file = dir.path().join("stop");
    let subscriber = python_subscriber(&config, &stop_file);

    let stats = run_node(&config, |probe| {
        let mut publisher = Peer::spawn(
            "accel_publisher.py",
            &[
                concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/iceoryx2.toml"),
                &config.accel_service,
                packets_file.to_str().unwrap(),
                "--linger",
            ],
        );
        publisher.expect_line(&format!("sent {}", packets.len()), Duration::from_secs(60));
        wait_received(probe, packets.len() as u64);
        publisher.close_stdin();
        assert!(publisher.wait(Duration::from_secs(10)));
    });
    let alerts = alerts_of(subscriber, &stop_file);

    assert_eq!(stats.submitted, packets.len() as u64, "{stats:?}");
    assert_eq!(stats.sequence_gaps, 0, "{stats:?}");
    assert!(
        alerts
            .iter()
            .any(|(id, level, _)| id == "rrs-slender-pillar" && *level == 3),
        "{alerts:?}"
    );
    assert!(
        !alerts
            .iter()
            .any(|(id, level, _)| id == "rrs-stocky-boulder" && *level >= 2),
        "{alerts:?}"
    );
}

#[test]
fn killed_publisher_leaves_the_node_serving_the_next_one() {
    if !python_peer_available()
        || !reexec_in_netns("killed_publisher_leaves_the_node_serving_the_next_one", 180)
    {
        return;
    }
    let config = test_config("kill");
    let dir = tempfile::tempdir().unwrap();
    let packets = rinaldi_packets(10.0);
    let split = 40;
    let (first, second) = (
        dir.path().join("first.json"),
        dir.path().join("second.json"),
    );
    write_packets(&first, &packets);
    write_packets(&second, &packets[split..]);
    let stop_file = dir.path().join("stop");
    let subscriber = python_subscriber(&config, &stop_file);

    let stats = run_node(&config, |probe| {
        let mut killed = Peer::spawn(
            "accel_publisher.py",
            &[
                concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/iceoryx2.toml"),
                &config.accel_service,
                first.to_str().unwrap(),
                "--pause-after",
                &split.to_string(),
            ],
        );
        killed.expect_line("paused", Duration::from_secs(60));
        killed.child.kill().unwrap(); // SIGKILL: no clean-up in the publisher
        killed.child.wait().unwrap();
        // The node notices the dead node (deadline / periodic check) and cleans it (a node
        // of a test running in parallel may get there first: any process may clean).
        let iox_config = config.load_iceoryx2_config().unwrap();
        let dead_nodes = || {
            let mut dead = 0;
            Node::<ipc::Service>::list(&iox_config, |state| {
                if matches!(state, NodeState::Dead(_)) {
                    dead += 1;
                }
                CallbackProgression::Continue
            })
            .unwrap();
            dead
        };
        let deadline = Instant::now() + Duration::from_secs(20);
        while dead_nodes() > 0 && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(50));
        }
        assert_eq!(dead_nodes(), 0, "{:?}", probe.iox());
        let mut next = Peer::spawn(
            "accel_publisher.py",
            &[
                concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/iceoryx2.toml"),
                &config.accel_service,
                second.to_str().unwrap(),
                "--linger",
            ],
        );
        next.expect_line(
            &format!("sent {}", packets.len() - split),
            Duration::from_secs(60),
        );
        wait_received(probe, packets.len() as u64);
        next.close_stdin();
        assert!(next.wait(Duration::from_secs(10)));
    });
    let alerts = alerts_of(subscriber, &stop_file);

    assert_eq!(stats.submitted, packets.len() as u64, "{stats:?}");
    assert!(
        alerts
            .iter()
            .any(|(id, level, _)| id == "rrs-slender-pillar" && *level == 3),
        "{alerts:?}"
    );
}
