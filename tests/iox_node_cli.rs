//! `rockwatch replay --transport iceoryx2` → `rockwatch node` → an iceoryx2 subscriber, all
//! through the binary. The node runs in its own network namespace (its ROS 2 side opens DDS);
//! iceoryx2 uses shared memory, which the namespace does not separate.

mod ros2_util;

use std::time::{Duration, Instant};

use rockwatch::iox::{IoxAlertSubscriber, IoxConfig};
use ros2_util::{replay_rinaldi_iox, repo, spawn_node_in_netns, stop_node};

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
    let mut node = spawn_node_in_netns(&config);

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
    let replay = replay_rinaldi_iox(&config);
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
