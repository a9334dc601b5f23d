//! The node and the replay survive stop/continue: `kill -STOP` then `kill -CONT` (0.5 s, 1 s,
//! 3 s) of `rockwatch node` and of `rockwatch replay`, mid-stream, interrupts RustDDS's
//! `epoll_wait` (EINTR, signal(7)) and RustDDS 0.15.1 ends the participant's threads. Each
//! process must say so, rebuild its participant (the node keeping the engine's state, the
//! replay sending again what the node had not taken), and the run must end as an
//! uninterrupted one: every packet counted, the same alerts. Also: SIGINT stops the node
//! cleanly (signals are taken on one thread). In a private network namespace, loopback only.

use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::{run_in_netns, text};
use rockwatch_test_harness::node_output::count_before;
use rockwatch_test_harness::rockwatch_bin;

use std::collections::BTreeSet;
use std::path::Path;

fn alert_history_set(state: &Path) -> BTreeSet<(String, u64, String)> {
    rockwatch_bin!().alert_history(state).into_iter().collect()
}

/// Runs a node on `dir`/state and a replay of the Rinaldi record at `speed`; meanwhile
/// `pauses` (shell: `$NODE` and `$REPLAY` are the pids). The node is stopped by
/// `stop_signal`. Returns (stdout, replay stderr, node stderr).
fn run(dir: &Path, speed: &str, pauses: &str, stop_signal: &str) -> (String, String, String) {
    let config = write_node_config(dir, &repo().join("config/catalogue.toml"));
    let (d, bin) = (dir.display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    let script = format!(
        "'{bin}' node --config '{c}' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         '{bin}' replay --config '{c}' --record '{r}' --azimuth 228 --station CI.RRS.00 \
             --transport ros2 --speed {speed} --tail 5 --restamp original --wait-s 30 \
             > '{d}/replay.out' 2> '{d}/replay.err' & REPLAY=$!
         {pauses}
         RC=0; wait $REPLAY || RC=$?; echo REPLAY_RC=$RC
         sleep 1; kill -{stop_signal} $NODE; wait $NODE; echo NODE_RC=$?",
        c = config.display(),
        r = rec.display()
    );
    let out = run_in_netns(&script, 150, &[]);
    let (stdout, _) = text(&out);
    let read = |f: &str| std::fs::read_to_string(dir.join(f)).unwrap_or_default();
    let (replay_out, replay_err, node_err) =
        (read("replay.out"), read("replay.err"), read("node.err"));
    assert!(
        stdout.contains("NODE_RC=0") && stdout.contains("REPLAY_RC=0"),
        "{stdout}\n--- replay\n{replay_err}\n--- node\n{node_err}"
    );
    (replay_out, replay_err, node_err)
}

fn replayed(stdout: &str) -> u64 {
    stdout
        .lines()
        .find_map(|l| l.strip_prefix("replayed "))
        .and_then(|l| l.split(' ').next()?.parse().ok())
        .unwrap_or_else(|| panic!("no replay summary\n{stdout}"))
}

/// Stops `who` for `s` seconds, 1 s from now (the process may have ended: no error).
fn pause(who: &str, s: f64) -> String {
    format!("sleep 1; kill -STOP ${who} || true; sleep {s}; kill -CONT ${who} || true; ")
}

#[test]
fn node_and_replay_paused_mid_stream_rebuild_their_participants_and_lose_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();

    let (out_a, _, err_a) = run(&a, "max", "", "TERM");
    let sent = replayed(&out_a);
    assert_eq!(
        count_before(&err_a, "packets received over ROS 2"),
        sent,
        "{err_a}"
    );
    let expected = alert_history_set(&a.join("state"));
    assert!(
        expected.contains(&("rrs-slender-pillar".into(), 1, "overturned".into())),
        "{expected:?}"
    );

    // 25 s of data at 1.5 × real time (≈ 17 s): node and replay each paused 0.5 s, 1 s and
    // 3 s, in turn; the node stopped by SIGINT (SIGHUP reloads it: tests/node_systemd.rs).
    let pauses: String = [0.5, 1.0, 3.0]
        .iter()
        .flat_map(|&s| [pause("NODE", s), pause("REPLAY", s)])
        .collect();
    let (out_b, err_replay, err_b) = run(&b, "1.5", &pauses, "INT");
    // Each pause ends the participant's threads (EINTR): said loudly, and rebuilt.
    assert!(
        err_b.contains("ROS 2 transport dead") && err_b.contains("has ended"),
        "the node's dead participant must be reported\n{err_b}"
    );
    assert!(
        err_replay.contains("ROS 2 transport dead") && err_replay.contains("participant rebuilt"),
        "the replay's dead participant must be reported and rebuilt\n{err_replay}"
    );
    let rebuilds = count_before(&err_b, "participant rebuilds");
    assert!((1..=6).contains(&rebuilds), "{rebuilds} rebuilds\n{err_b}");
    assert!(err_b.contains("rockwatch: SIGINT: stopping"), "{err_b}");
    // RustDDS's own error line is visible (the logger is installed).
    assert!(err_b.contains("Interrupted"), "{err_b}");
    assert_eq!(replayed(&out_b), sent, "{out_b}");
    // Every packet counted once by the node: a packet the replay sent again after its
    // rebuild may reach the engine twice (once per writer), and is then a duplicate.
    let received = count_before(&err_b, "packets received over ROS 2");
    for line in err_b.lines().chain(err_replay.lines()) {
        if line.contains("rebuilt") || line.contains("stopped:") || line.contains("engine input") {
            eprintln!("{line}");
        }
    }
    let duplicate = count_before(&err_b, "duplicate");
    assert_eq!(
        received - duplicate,
        sent,
        "packets lost or double counted after the pauses\n{err_b}"
    );
    assert_eq!(alert_history_set(&b.join("state")), expected, "{err_b}");
}

/// Issue 24 item 5: a replay paused ten times in quick succession rebuilt its participant,
/// which died again while it waited for the node and was never checked again. Every new
/// participant is watched, while it waits for the node too, and built again; the run ends
/// as an uninterrupted one (exit 0, every packet counted once).
#[test]
fn a_replay_paused_ten_times_in_a_row_rebuilds_as_often_as_needed_and_loses_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let pauses = "sleep 1; for i in 1 2 3 4 5 6 7 8 9 10; do \
                  kill -STOP $REPLAY || true; sleep 0.05; kill -CONT $REPLAY || true; sleep 0.1; \
                  done; ";
    let (out, err_replay, err_node) = run(dir.path(), "2", pauses, "TERM");
    for line in err_replay.lines() {
        if line.contains("rebuilt") || line.contains("died too") {
            eprintln!("{line}");
        }
    }
    assert!(
        err_replay.contains("participant rebuilt"),
        "the replay's dead participant must be rebuilt\n{err_replay}"
    );
    let sent = replayed(&out);
    let received = count_before(&err_node, "packets received over ROS 2");
    let duplicate = count_before(&err_node, "duplicate");
    assert_eq!(
        received - duplicate,
        sent,
        "packets lost or double counted after the pauses\n{err_node}\n{err_replay}"
    );
}
