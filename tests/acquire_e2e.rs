//! End to end: an independent SeedLink server (`seedlink-rs-server` 0.4.0, in this process,
//! loopback) → `rockwatch acquire` (SeedLink v3, StationXML calibration, iceoryx2) →
//! `rockwatch node` (in its own network namespace: its ROS 2 side opens DDS) → the node's
//! alert journal, compared with `rockwatch monitor --mseed FILE --stationxml FILE` on the same
//! data. `acquire` is SIGKILLed mid-stream and restarted: the alerts must still be the same
//! (a lost or doubled sample before an alert changes its PGV, an integral, and its time).
//!
//! Data: the K2 accelerograph counts of tests/data/mseed/k2_STNA_HN123_counts.mseed with the
//! ObsPy-written inventory tests/data/stationxml/obspy_XX.STN_k2.xml; blocks slender enough
//! for its ~0.05 m/s² to rock them, at several thresholds so alerts fall through the record.

mod ros2_util;
mod seedlink_server;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use rockwatch::iox::{IoxAlertSubscriber, IoxConfig};
use ros2_util::{repo, rockwatch};
use seedlink_server::{records_in_time_order, Server};

/// Blocks on XX.STN. rocking from |a| = g·B/H (0.01 to 0.06 m/s²): with this record their
/// alerts fall from 0 to about 10 s (3 overturn), before and after the SIGKILL at ~5 s.
fn catalogue(dir: &Path) -> PathBuf {
    let mut text = String::new();
    for (i, width) in [0.01, 0.015, 0.02, 0.04, 0.05, 0.06].iter().enumerate() {
        text += &format!(
            "[[pbr]]\nid = \"needle-{i}\"\nname = \"test needle\"\nlat = 50.47\nlon = 4.279\n\
             station = \"XX.STN.\"\nazimuth_deg = {}\nwidth_m = {width}\nheight_m = 10.0\n\
             mu_s = 0.7\nmu_k = 0.55\nsource = \"test\"\n\n",
            30.0 * i as f64
        );
    }
    let path = dir.join("catalogue.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The journal's alerts, without arrival times.
fn alerts(state: &Path) -> Vec<serde_json::Value> {
    let out = Command::new(rockwatch())
        .args(["alerts", "--format", "json", "--state-dir"])
        .arg(state)
        .output()
        .unwrap();
    if !out.status.success() {
        return Vec::new();
    }
    let all: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap_or_default();
    // The shared alert schema (README, "Alert JSON"): no arrival time, which differs by run.
    all.into_iter().filter(|r| r["type"] == "alert").collect()
}

fn acquire(config: &Path, state: &Path) -> Child {
    Command::new(rockwatch())
        .args(["acquire", "--config"])
        .arg(config)
        .arg("--state-dir")
        .arg(state)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn stderr_of(mut child: Child) -> String {
    use std::io::Read;
    let mut text = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut text)
        .unwrap();
    text
}

#[test]
fn seedlink_to_acquire_to_node_alerts_equal_monitor_across_a_sigkill_of_acquire() {
    let dir = tempfile::tempdir().unwrap();
    let catalogue = catalogue(dir.path());
    let xml = repo().join("tests/data/stationxml/obspy_XX.STN_k2.xml");

    // Reference: monitor on the same file and inventory (no quiet tail: the node gets none).
    let reference_state = dir.path().join("monitor-state");
    let out = Command::new(rockwatch())
        .args(["monitor", "--catalogue"])
        .arg(&catalogue)
        .arg("--mseed")
        .arg(repo().join("tests/data/mseed/k2_STNA_HN123_counts.mseed"))
        .arg("--stationxml")
        .arg(&xml)
        .args([
            "--station",
            "XX.STN.",
            "--tail",
            "0",
            "--format",
            "jsonl",
            "--state-dir",
        ])
        .arg(&reference_state)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let expected = alerts(&reference_state);
    assert!(
        expected.len() >= 3,
        "the test needs alerts through the record: {expected:?}"
    );

    let server = Server::start("127.0.0.1:0");
    let id = std::process::id();
    let (accel, alerts_service) = (
        format!("rockwatch-acq-{id}/accel"),
        format!("rockwatch-acq-{id}/alerts"),
    );
    let iox_file = repo().join("config/iceoryx2.toml");
    let iox_section = format!(
        "[iceoryx2]\nconfig_file = \"{}\"\naccel_service = \"{accel}\"\nalerts_service = \"{alerts_service}\"\n",
        iox_file.display()
    );
    let node_state = dir.path().join("node-state");
    let node_config = dir.path().join("node.toml");
    std::fs::write(
        &node_config,
        format!(
            "catalogue = \"{}\"\nstate_dir = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n{iox_section}",
            catalogue.display(),
            node_state.display()
        ),
    )
    .unwrap();
    let acquire_config = dir.path().join("acquire.toml");
    std::fs::write(
        &acquire_config,
        format!(
            "[seedlink]\nserver = \"{}\"\nstreams = [\"XX.STN..HN?\"]\nprotocol = 3\nreconnect_initial_s = 0.2\n\
             [inventory]\nstationxml = [\"{}\"]\n[assembly]\nmax_wait_s = 1.0\n{iox_section}",
            server.addr,
            xml.display()
        ),
    )
    .unwrap();

    let mut node = Command::new("unshare")
        .args([
            "-n",
            "sh",
            "-c",
            "ip link set lo up && exec \"$0\" node --config \"$1\"",
        ])
        .arg(rockwatch())
        .arg(&node_config)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The node is up once its alert service exists.
    let sub_config = IoxConfig {
        config_file: Some(iox_file.clone()),
        accel_service: accel.clone(),
        alerts_service: alerts_service.clone(),
        ..IoxConfig::default()
    };
    let deadline = Instant::now() + Duration::from_secs(20);
    while IoxAlertSubscriber::new(&sub_config).is_err() {
        if Instant::now() > deadline {
            let _ = node.kill();
            panic!(
                "the node's alert service never appeared: {}",
                stderr_of(node)
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    }

    let records = records_in_time_order();
    // 15 of 104 records (time order, ~3 records per second): about the first 5 s.
    let half = 15;
    let acquire_state = dir.path().join("acquire-state");
    server.push(&records[..half]);
    let mut first = acquire(&acquire_config, &acquire_state);
    // Mid-stream: once something is committed, SIGKILL.
    let state_file = acquire_state.join(format!(
        "seedlink-{}.json",
        server.addr.to_string().replace(':', "_")
    ));
    let deadline = Instant::now() + Duration::from_secs(20);
    while !std::fs::read_to_string(&state_file).is_ok_and(|t| t.contains("\"sequence\"")) {
        assert!(Instant::now() < deadline, "acquire committed nothing");
        std::thread::sleep(Duration::from_millis(20));
    }
    first.kill().unwrap(); // SIGKILL
    let first_stderr = stderr_of(first);
    server.push(&records[half..]);
    let second = acquire(&acquire_config, &acquire_state);

    let deadline = Instant::now() + Duration::from_secs(40);
    let mut got = alerts(&node_state);
    while got.len() < expected.len() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(200));
        got = alerts(&node_state);
    }
    // Time for anything doubled or late to show.
    std::thread::sleep(Duration::from_secs(2));
    got = alerts(&node_state);
    let _ = Command::new("kill")
        .args(["-TERM", &second.id().to_string()])
        .status();
    let second_stderr = stderr_of(second);
    let _ = Command::new("kill")
        .args(["-TERM", &node.id().to_string()])
        .status();
    let _ = node.wait();
    let node_stderr = stderr_of(node);
    server.stop();

    let context = format!(
        "\nfirst acquire:\n{first_stderr}\nsecond acquire:\n{second_stderr}\nnode:\n{node_stderr}"
    );
    assert_eq!(
        got.len(),
        expected.len(),
        "{got:#?}\nvs\n{expected:#?}{context}"
    );
    for (a, b) in got.iter().zip(&expected) {
        for key in [
            "pbr_id",
            "station",
            "level",
            "episode",
            "mode",
            "data_time_ns",
        ] {
            assert_eq!(a[key], b[key], "{key}: {a} vs {b}{context}");
        }
        // The same f32 samples through the same engine: equal to round-off of the summation
        // order (none expected; 1e-9 relative allows it).
        for key in ["theta_over_alpha", "slide_m", "pga_mps2", "pgv_mps"] {
            let (x, y) = (a[key].as_f64().unwrap(), b[key].as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
                "{key}: {x} vs {y}{context}"
            );
        }
    }
    println!("{} alerts equal{context}", got.len());
    assert!(second_stderr.contains("packets published"), "{context}");
}
