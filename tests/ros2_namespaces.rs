//! Two sites side by side in one network namespace (one DDS domain, loopback only): two
//! `rockwatch node` processes started with `--ros-args -r __ns:=/site_a` and `/site_b` (the
//! same catalogue and station ids). Each resolves its relative names in its namespace, so:
//! - `rockwatch replay --ros-args -r __ns:=/site_a` reaches site A's node only (its journal
//!   fills, site B's stays empty), and the alerts are on `/site_a/pbr/alerts` only (listeners
//!   in `/site_a`, `/site_b` and `/` tell);
//! - a replay in the root namespace with remaps (`-r pbr/accel:=/site_b/pbr/accel -r
//!   pbr/intake:=/site_b/pbr/intake`) reaches site B's node only;
//! - `rockwatch reset --node --ros-args -r __ns:=/site_a` resets site A's fallen block through
//!   `/site_a/pbr/reset` (site B's node answers nothing: its journal gets no reset).
//!
//! Also: `--ros-args` errors end the node at once with one line naming the problem (an unknown
//! argument; a parameter out of its descriptor's range).

mod shell_harness;
use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::{reexec_in_netns, text};
use rockwatch_test_harness::rockwatch_bin;
use shell_harness::collect;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use rockwatch::ros2::{network_plan, NetworkPlan, Ros2AlertListener, Ros2Config};

fn plan() -> NetworkPlan {
    network_plan(&Ros2Config::loopback_only(), None, None).unwrap()
}

fn start_node(config: &Path, state: &Path, err: &Path, ros_args: &[&str]) -> Child {
    Command::new(rockwatch_bin!())
        .args(["node", "--config"])
        .arg(config)
        .arg("--state-dir")
        .arg(state)
        .arg("--ros-args")
        .args(ros_args)
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(err).unwrap())
        .spawn()
        .unwrap()
}

/// `rockwatch replay` of the Rinaldi record as CI.RRS.00 at max speed, with `ros_args`.
fn replay(config: &Path, ros_args: &[&str]) -> std::process::Output {
    let data = repo().join("tests/data/records");
    Command::new(rockwatch_bin!())
        .args(["replay", "--config"])
        .arg(config)
        .arg("--record")
        .arg(data.join("Rinaldi228.AT2"))
        .arg("--vertical")
        .arg(data.join("RinaldiUP.AT2"))
        .args([
            "--azimuth",
            "228",
            "--station",
            "CI.RRS.00",
            "--transport",
            "ros2",
            "--speed",
            "max",
            "--tail",
            "5",
            "--wait-s",
            "20",
            "--ros-args",
        ])
        .args(ros_args)
        .output()
        .unwrap()
}

/// Waits (≤ 20 s) until `state`'s journal holds an `overturned` alert of `pbr`.
fn wait_overturned(state: &Path, pbr: &str) -> bool {
    let deadline = Instant::now() + Duration::from_secs(20);
    while Instant::now() < deadline {
        if rockwatch_bin!()
            .alert_history(state)
            .iter()
            .any(|(id, _, level)| id == pbr && level == "overturned")
        {
            return true;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    false
}

fn stop(mut node: Child, err: &Path) -> String {
    let _ = Command::new("kill")
        .arg("-TERM")
        .arg(node.id().to_string())
        .status();
    let status = node.wait().unwrap();
    let stderr = std::fs::read_to_string(err).unwrap_or_default();
    assert!(status.success(), "{status}\n{stderr}");
    stderr
}

#[test]
fn two_sites_in_two_namespaces_stay_apart() {
    if !reexec_in_netns("two_sites_in_two_namespaces_stay_apart", 200) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let (state_a, state_b) = (dir.path().join("a"), dir.path().join("b"));
    let (err_a, err_b) = (dir.path().join("a.err"), dir.path().join("b.err"));
    let node_a = start_node(&config, &state_a, &err_a, &["-r", "__ns:=/site_a"]);
    let node_b = start_node(&config, &state_b, &err_b, &["-r", "__ns:=/site_b", "--"]);
    let mut listen_a = Ros2AlertListener::open(&plan(), "/site_a").unwrap();
    let mut listen_b = Ros2AlertListener::open(&plan(), "/site_b").unwrap();
    let mut listen_root = Ros2AlertListener::open(&plan(), "/").unwrap();

    // 1. A replay in /site_a: site A's node only.
    let out = replay(&config, &["-r", "__ns:=/site_a"]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(wait_overturned(&state_a, "rrs-slender-pillar"), "{stderr}");
    let got_a = collect(&mut listen_a, Duration::from_secs(3));
    let got_b = collect(&mut listen_b, Duration::from_millis(500));
    let got_root = collect(&mut listen_root, Duration::from_millis(500));
    assert!(
        got_a
            .iter()
            .any(|a| a.pbr_id == "rrs-slender-pillar" && a.level == 3),
        "{got_a:?}"
    );
    assert!(got_b.is_empty(), "site B heard site A's alerts: {got_b:?}");
    assert!(got_root.is_empty(), "/pbr/alerts carried: {got_root:?}");
    assert!(
        rockwatch_bin!().alert_history(&state_b).is_empty(),
        "site B's node took site A's packets"
    );
    let journal_a = rockwatch_bin!().alert_history(&state_a);

    // 2. A root-namespace replay remapped onto site B's topics: site B's node only.
    let out = replay(
        &config,
        &[
            "-r",
            "pbr/accel:=/site_b/pbr/accel",
            "-r",
            "pbr/intake:=/site_b/pbr/intake",
        ],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(wait_overturned(&state_b, "rrs-slender-pillar"), "{stderr}");
    let got_b = collect(&mut listen_b, Duration::from_secs(3));
    assert!(
        got_b
            .iter()
            .any(|a| a.pbr_id == "rrs-slender-pillar" && a.level == 3),
        "{got_b:?}"
    );
    assert!(collect(&mut listen_a, Duration::from_millis(500)).is_empty());
    assert_eq!(
        rockwatch_bin!().alert_history(&state_a),
        journal_a,
        "site A took site B's packets"
    );

    // 3. The reset service in /site_a: site A's block stands again, site B's stays fallen.
    let reset = Command::new(rockwatch_bin!())
        .args(["reset", "--node", "--pbr", "rrs-slender-pillar", "--config"])
        .arg(&config)
        .args(["--wait-s", "20", "--ros-args", "-r", "__ns:=/site_a"])
        .output()
        .unwrap();
    let (stdout, stderr) = text(&reset);
    assert!(reset.status.success(), "{stdout}\n{stderr}");
    // A reset client in the root namespace finds no service (no /pbr/reset).
    let lost = Command::new(rockwatch_bin!())
        .args(["reset", "--node", "--pbr", "rrs-slender-pillar", "--config"])
        .arg(&config)
        .args(["--wait-s", "3"])
        .output()
        .unwrap();
    let (_, lost_err) = text(&lost);
    assert!(!lost.status.success(), "{lost_err}");
    assert!(
        lost_err.contains("no node offered /pbr/reset"),
        "{lost_err}"
    );

    drop((listen_a, listen_b, listen_root));
    let err_a_text = stop(node_a, &err_a);
    let err_b_text = stop(node_b, &err_b);
    assert!(
        err_a_text.contains("node /site_a/rockwatch"),
        "{err_a_text}"
    );
    assert!(
        err_b_text.contains("node /site_b/rockwatch"),
        "{err_b_text}"
    );
    let resets = |state: &Path| {
        rockwatch::journal::read_journal(state)
            .unwrap()
            .0
            .iter()
            .filter(|r| matches!(r, rockwatch_core::engine::JournalRecord::Reset { .. }))
            .count()
    };
    assert_eq!(resets(&state_a), 1);
    assert_eq!(resets(&state_b), 0);
}

#[test]
fn ros_args_errors_stop_the_node_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    for (args, expected) in [
        (
            vec!["--frobnicate", "-r", "a:=b"],
            "unknown ROS arguments: '--frobnicate'",
        ),
        (
            vec!["-p", "alerts.imminent_theta_ratio:=1.5"],
            "-p alerts.imminent_theta_ratio:=1.5: invalid value for alerts.imminent_theta_ratio: 1.5 is out of range [0, 1]",
        ),
        (vec!["-p", "alerts.typo:=1.0"], "parameter alerts.typo is not declared"),
        (vec!["-r", "__ns:=/bad-ns"], "not allowed"),
        (vec!["--log-level", "other_node:=debug"], "no logger \"other_node\""),
    ] {
        // No DDS is opened: the arguments are refused first (no network namespace needed).
        let out = Command::new("timeout")
            .arg("20")
            .arg(rockwatch_bin!())
            .args(["node", "--config"])
            .arg(&config)
            .arg("--ros-args")
            .args(&args)
            .output()
            .unwrap();
        let (_, stderr) = text(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "{args:?}: {stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
    }
    // --ros-args on a command that does not join the ROS 2 graph.
    let out = Command::new(rockwatch_bin!())
        .args(["alerts", "--ros-args", "-r", "__ns:=/x"])
        .output()
        .unwrap();
    let (_, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("--ros-args is taken by the ROS 2 commands only"),
        "{stderr}"
    );
}
