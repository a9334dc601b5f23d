//! `rockwatch replay --transport iceoryx2` → `rockwatch node` → an iceoryx2 subscriber, all
//! through the binary. The node runs in its own network namespace (its ROS 2 side opens DDS);
//! iceoryx2 uses shared memory, which the namespace does not separate.

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::node_output::count_before;
use rockwatch_test_harness::process::{stop_node, LoggedChild};
use rockwatch_test_harness::rockwatch_bin;

use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

use rockwatch::iox::{IoxAlertSubscriber, IoxConfig};

#[test]
fn replay_over_iceoryx2_reaches_the_node_and_its_alerts_come_back() {
    let dir = tempfile::tempdir().unwrap();
    let id = std::process::id();
    let (accel, alerts) = (
        format!("rockwatch-cli-{id}/accel"),
        format!("rockwatch-cli-{id}/alerts"),
    );
    let iox_file = repo().join("config/iceoryx2.toml");
    let config = dir.path().join("node.toml");
    std::fs::write(
        &config,
        format!(
            "catalogue = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n[iceoryx2]\nconfig_file = \"{}\"\naccel_service = \"{accel}\"\nalerts_service = \"{alerts}\"\n",
            repo().join("config/catalogue.toml").display(),
            iox_file.display()
        ),
    )
    .unwrap();
    let mut node = rockwatch_bin!().spawn_node_in_netns(&config);

    // Subscribe to the node's alerts (retry until the node has created the service).
    let sub_config = IoxConfig {
        config_file: Some(iox_file.clone()),
        accel_service: accel.clone(),
        alerts_service: alerts.clone(),
        ..IoxConfig::default()
    };
    let deadline = Instant::now() + Duration::from_secs(20);
    let subscriber = loop {
        match IoxAlertSubscriber::new(&sub_config) {
            Ok(s) => break s,
            Err(_) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(100)),
            Err(e) => {
                let _ = node.child.kill();
                panic!("alerts service never appeared: {e:#}");
            }
        }
    };
    let replay = rockwatch_bin!().replay_rinaldi_iox(&config);
    let mut received = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(15);
    while Instant::now() < deadline
        && !received
            .iter()
            .any(|a: &rockwatch::iox::PbrAlertIox| a.level == 3)
    {
        subscriber
            .wait(Duration::from_millis(200), &mut received)
            .unwrap();
    }
    // SIGTERM: the node stops cleanly.
    let (status, stderr) = stop_node(node);
    assert!(
        replay.status.success(),
        "replay: {}",
        String::from_utf8_lossy(&replay.stderr)
    );
    assert!(status.success(), "node exit {status:?}\n{stderr}");
    assert!(
        received
            .iter()
            .any(|a| a.pbr_id() == "rrs-slender-pillar" && a.level == 3),
        "no OVERTURNED over iceoryx2: {:?}\n{stderr}",
        received
            .iter()
            .map(|a| (a.pbr_id(), a.level))
            .collect::<Vec<_>>()
    );
    assert!(received
        .iter()
        .all(|a| a.pbr_id() != "rrs-stocky-boulder" || a.level == 1));
    assert!(
        stderr.contains("iceoryx2:") && stderr.contains("submitted"),
        "{stderr}"
    );
}

/// A node with iceoryx2 input on services of its own (`extra`: more TOML for its
/// configuration), and its configuration file.
fn iox_node(dir: &std::path::Path, tag: &str, extra: &str) -> (LoggedChild, PathBuf) {
    let id = std::process::id();
    let config = dir.join("node.toml");
    std::fs::write(
        &config,
        format!(
            "catalogue = \"{}\"\n{extra}\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n[iceoryx2]\nconfig_file = \"{}\"\naccel_service = \"rockwatch-{tag}-{id}/accel\"\nalerts_service = \"rockwatch-{tag}-{id}/alerts\"\n",
            repo().join("config/catalogue.toml").display(),
            repo().join("config/iceoryx2.toml").display()
        ),
    )
    .unwrap();
    let node = rockwatch_bin!().spawn_node_in_netns(&config);
    (node, config)
}

/// `rockwatch replay --transport iceoryx2` of the Rinaldi record with `args`, once the node's
/// input exists (the replay waits for a subscriber).
fn replay_iox(config: &std::path::Path, args: &[&str]) -> std::process::Output {
    let data = repo().join("tests/data/records");
    Command::new(rockwatch_bin!())
        .args(["replay", "--config"])
        .arg(config)
        .arg("--record")
        .arg(data.join("Rinaldi228.AT2"))
        .args([
            "--azimuth",
            "228",
            "--station",
            "CI.RRS.00",
            "--transport",
            "iceoryx2",
        ])
        .args(args)
        .output()
        .unwrap()
}

/// Issue 24 item 4: an iceoryx2 replay at full speed lost 57–100 % and exited 0. Paced by the
/// node's intake reports, every packet reaches the engine, and the replay says so only then.
#[test]
fn an_iceoryx2_replay_at_full_speed_is_processed_whole_before_it_exits_0() {
    let dir = tempfile::tempdir().unwrap();
    let (node, config) = iox_node(dir.path(), "max", "");
    let replay = replay_iox(
        &config,
        &["--speed", "max", "--loop", "20", "--wait-s", "60"],
    );
    let (status, stderr) = stop_node(node);
    let replay_err = String::from_utf8_lossy(&replay.stderr);
    assert!(replay.status.success(), "replay: {replay_err}\n{stderr}");
    assert!(status.success(), "node exit {status:?}\n{stderr}");
    let sent: u64 = String::from_utf8_lossy(&replay.stdout)
        .strip_prefix("replayed ")
        .and_then(|l| l.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{}", String::from_utf8_lossy(&replay.stdout)));
    // 20 laps of the record and its quiet tail: far more than the node's buffer (1024).
    assert!(sent.is_multiple_of(20) && sent >= 20 * 250, "{sent}");
    let submitted: u64 = stderr
        .lines()
        .find_map(|l| l.strip_prefix("rockwatch: iceoryx2: "))
        .and_then(|l| l.split(" packets received, ").nth(1))
        .and_then(|l| l.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no iceoryx2 summary in\n{stderr}"));
    assert_eq!(
        submitted, sent,
        "the replay exited 0 but the node did not get every packet\n{stderr}"
    );
}

/// Issue 24 item 4: a replay whose packets the node refused (here: beyond a plausibility bound
/// of 0.05 g, which the strong motion exceeds) exits 1 naming the node and the count.
#[test]
fn an_iceoryx2_replay_whose_packets_the_node_refuses_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let (node, config) = iox_node(
        dir.path(),
        "refuse",
        "[engine.plausibility]\nmax_abs_accel_g = 0.05",
    );
    let replay = replay_iox(&config, &["--speed", "max", "--wait-s", "30"]);
    let (status, stderr) = stop_node(node);
    let replay_err = String::from_utf8_lossy(&replay.stderr);
    assert!(status.success(), "node exit {status:?}\n{stderr}");
    assert_eq!(replay.status.code(), Some(1), "{replay_err}");
    assert!(
        replay_err.contains("rockwatch node (pid")
            && replay_err.contains("refused")
            && replay_err.contains("implausible"),
        "{replay_err}"
    );
    let refused: u64 = replay_err
        .split("refused ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{replay_err}"));
    assert!(refused > 0 && refused < 250, "{replay_err}");
    assert_eq!(
        count_before(&stderr, "rejected as invalid"),
        refused,
        "the node's count of implausible packets is what the replay was told\n{stderr}"
    );
}
