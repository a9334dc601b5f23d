//! Alerts at least once, never silently twice, through the real node over ROS 2: the node is
//! made to abort right after journaling its 3rd alert and before publishing it
//! (`ROCKWATCH_FAULT_ABORT_AFTER_JOURNAL`, the worst moment for a crash). A live subscriber
//! never got that alert. Restarted on the same state directory, the node publishes it, and a
//! late subscriber gets the whole journaled history of `/pbr/alerts` (transient local); after
//! another restart the late subscriber gets the same history again, and no alert was
//! journaled twice. In a private network namespace, loopback only.

mod shell_harness;
use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::reexec_in_netns;
use rockwatch_test_harness::rockwatch_bin;
use shell_harness::{collect, rinaldi_packets};

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use rockwatch::journal::read_journal;
use rockwatch::node::FAULT_ABORT_AFTER_JOURNAL_ENV;
use rockwatch::ports::PacketSink;
use rockwatch::replay::{replay, Restamp, Speed};
use rockwatch::ros2::msg::PbrAlert;
use rockwatch::ros2::{network_plan, NetworkPlan, Ros2AlertListener, Ros2Config, Ros2PacketSink};
use rockwatch_core::engine::JournalRecord;

const ABORT_AFTER: usize = 3;

fn plan() -> NetworkPlan {
    network_plan(&Ros2Config::loopback_only(), None, None).unwrap()
}

fn start_node(config: &Path, state: &Path, err: &Path, fault: bool) -> Child {
    let mut cmd = Command::new(rockwatch_bin!());
    cmd.args(["node", "--config"])
        .arg(config)
        .arg("--state-dir")
        .arg(state)
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(err).unwrap());
    if fault {
        cmd.env(FAULT_ABORT_AFTER_JOURNAL_ENV, ABORT_AFTER.to_string());
    } else {
        cmd.env_remove(FAULT_ABORT_AFTER_JOURNAL_ENV);
    }
    cmd.spawn().unwrap()
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

/// A late subscriber's view: opened once the node runs, everything it gets.
fn late_history() -> Vec<PbrAlert> {
    let mut listener = Ros2AlertListener::open(&plan(), "/").unwrap();
    collect(&mut listener, Duration::from_secs(4))
}

/// The journal's alerts (as messages) and how many `Published` markers it holds.
fn journal(state: &Path) -> (Vec<PbrAlert>, usize) {
    let (records, _) = read_journal(state).unwrap();
    let alerts = records
        .iter()
        .filter_map(|r| match r {
            JournalRecord::Alert(a) => Some(PbrAlert::from(a)),
            _ => None,
        })
        .collect();
    let markers = records
        .iter()
        .filter(|r| matches!(r, JournalRecord::Published { .. }))
        .count();
    (alerts, markers)
}

#[test]
fn an_alert_journaled_but_not_published_before_a_crash_is_published_at_restart_with_the_history() {
    if !reexec_in_netns(
        "an_alert_journaled_but_not_published_before_a_crash_is_published_at_restart_with_the_history",
        170,
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let state = dir.path().join("state");
    let err = |n: &str| dir.path().join(n);

    // 1. The node aborts after journaling its 3rd alert; a live subscriber listens.
    let mut node = start_node(&config, &state, &err("1.err"), true);
    let mut live = Ros2AlertListener::open(&plan(), "/").unwrap();
    let mut sink = Ros2PacketSink::open(&plan(), "/").unwrap();
    sink.set_wait(Duration::from_secs(5));
    assert!(sink.wait_for_subscriber(Duration::from_secs(30)).unwrap());
    // The replay fails once the node has aborted (nothing more is taken).
    let _ = replay(
        &rinaldi_packets(5.0),
        &mut sink,
        Speed::Max,
        Restamp::Now,
        1,
    )
    .and_then(|_| sink.finish(Duration::from_secs(5)));
    let status = node.wait().unwrap();
    assert!(
        !status.success(),
        "the fault injection must abort the node: {status}"
    );
    let live_got = collect(&mut live, Duration::from_secs(2));
    drop((live, sink));
    let (journaled, _) = journal(&state);
    assert_eq!(journaled.len(), ABORT_AFTER, "{journaled:?}");
    let unpublished = &journaled[ABORT_AFTER - 1];
    assert!(
        !live_got.contains(unpublished),
        "the fault must land between journal and publication: {live_got:?}"
    );

    // 2. Restart: the unpublished alert is published, a late subscriber gets all of them.
    let node = start_node(&config, &state, &err("2.err"), false);
    std::thread::sleep(Duration::from_secs(1));
    let history = late_history();
    let stderr = stop(node, &err("2.err"));
    assert_eq!(
        history, journaled,
        "late subscriber after the crash\n{stderr}"
    );
    assert!(
        stderr.contains("had never been published"),
        "the republication is reported\n{stderr}"
    );
    let (after, markers) = journal(&state);
    assert_eq!(after, journaled, "no alert journaled twice");
    assert!(
        markers >= ABORT_AFTER,
        "every alert marked published: {markers}"
    );

    // 3. Another restart: the same history for a late subscriber; nothing new journaled.
    let node = start_node(&config, &state, &err("3.err"), false);
    std::thread::sleep(Duration::from_secs(1));
    let again = late_history();
    let stderr = stop(node, &err("3.err"));
    assert_eq!(again, history, "{stderr}");
    assert_eq!(journal(&state).0, journaled);
}
