//! The node survives stop/continue: `kill -STOP` then `kill -CONT` of `rockwatch node` (0.5 s,
//! 1 s, 3 s) interrupts RustDDS's `epoll_wait` (EINTR, signal(7)) and RustDDS 0.15.1 ends the
//! participant's threads; the node must say so, rebuild its participant keeping the engine's
//! state, and then take a replay as if nothing had happened: every packet counted, the alerts
//! of an uninterrupted run. Also: SIGHUP stops the node cleanly (signals are taken on one
//! thread). In a private network namespace, loopback only.

mod ros2_util;
use ros2_util::*;

use std::collections::BTreeSet;
use std::path::Path;

/// (pbr, episode, level) of every alert journaled in `state`.
fn alert_set(state: &Path) -> BTreeSet<(String, u64, String)> {
    let out = std::process::Command::new(rockwatch())
        .args(["alerts", "--format", "json", "--state-dir"])
        .arg(state)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let records: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    records
        .iter()
        .filter_map(|r| r.get("Alert"))
        .map(|a| {
            (
                a["pbr_id"].as_str().unwrap().to_string(),
                a["episode"].as_u64().unwrap(),
                a["level"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

/// Runs a node on `state`, pauses it (stop, `pause_s`, continue) for each of `pauses_s`,
/// then replays the Rinaldi record at full speed; returns (stdout, node stderr).
fn run(dir: &Path, state: &Path, pauses_s: &[f64], stop_signal: &str) -> (String, String) {
    let config = write_node_config(dir, &repo().join("config/catalogue.toml"));
    let (d, bin) = (dir.display(), rockwatch().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    let pauses: String = pauses_s
        .iter()
        .map(|s| format!("sleep 1; kill -STOP $NODE; sleep {s}; kill -CONT $NODE; "))
        .collect();
    let script = format!(
        "'{bin}' node --config '{c}' --state-dir '{s}' 2> '{d}/node.err' & NODE=$!
         sleep 2; {pauses} sleep 2
         '{bin}' replay --config '{c}' --record '{r}' --azimuth 228 --station CI.RRS.00 \
             --transport ros2 --speed max --tail 5 --restamp original --wait-s 30 | sed 's/^/REPLAY /'
         sleep 1; kill -{stop_signal} $NODE; wait $NODE; echo NODE_RC=$?",
        c = config.display(),
        s = state.display(),
        r = rec.display()
    );
    let out = run_in_netns(&script, 150, &[]);
    let (stdout, _) = text(&out);
    let stderr = std::fs::read_to_string(dir.join("node.err")).unwrap_or_default();
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{stderr}");
    (stdout, stderr)
}

fn replayed(stdout: &str) -> u64 {
    stdout
        .lines()
        .find_map(|l| l.strip_prefix("REPLAY replayed "))
        .and_then(|l| l.split(' ').next()?.parse().ok())
        .unwrap_or_else(|| panic!("no replay summary\n{stdout}"))
}

#[test]
fn a_node_paused_and_continued_rebuilds_its_participant_and_loses_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();

    let (out_a, err_a) = run(&a, &a.join("state"), &[], "TERM");
    let sent = replayed(&out_a);
    assert_eq!(
        count_before(&err_a, "packets received over ROS 2"),
        sent,
        "{err_a}"
    );
    let expected = alert_set(&a.join("state"));
    assert!(
        expected.contains(&("rrs-slender-pillar".into(), 1, "overturned".into())),
        "{expected:?}"
    );

    // Paused three times (0.5 s, 1 s, 3 s), stopped by SIGHUP.
    let (out_b, err_b) = run(&b, &b.join("state"), &[0.5, 1.0, 3.0], "HUP");
    // Each pause ends the participant's threads (EINTR): said loudly, and rebuilt.
    assert!(
        err_b.contains("ROS 2 transport dead") && err_b.contains("has ended"),
        "the dead participant must be reported\n{err_b}"
    );
    let rebuilds = count_before(&err_b, "participant rebuilds");
    assert!((1..=6).contains(&rebuilds), "{rebuilds} rebuilds\n{err_b}");
    assert!(err_b.contains("rockwatch: SIGHUP: stopping"), "{err_b}");
    // RustDDS's own error line is visible (the logger is installed).
    assert!(err_b.contains("Interrupted"), "{err_b}");
    assert_eq!(replayed(&out_b), sent, "{out_b}");
    assert_eq!(
        count_before(&err_b, "packets received over ROS 2"),
        sent,
        "packets lost after the pauses\n{err_b}"
    );
    assert_eq!(alert_set(&b.join("state")), expected, "{err_b}");
}
