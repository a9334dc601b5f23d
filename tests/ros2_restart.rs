//! `kill -9` of the node mid-replay, then a restart on the same state directory and the record
//! replayed again from the start: the alert history (`rockwatch alerts --format json`) equals
//! that of an uninterrupted run — same (block, episode, level) set, no alert twice. In a
//! private network namespace, loopback only.

mod shell_harness;
use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::reexec_in_netns;
use rockwatch_test_harness::process::NodeProcess;
use rockwatch_test_harness::rockwatch_bin;
use shell_harness::rinaldi_packets;

use std::collections::BTreeSet;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use rockwatch::ports::PacketSink;
use rockwatch::replay::{replay, Restamp, Speed};
use rockwatch::ros2::{network_plan, NetworkPlan, Ros2Config, Ros2PacketSink};
use rockwatch_core::engine::AccelPacket;

/// A sink that fails once `stop` is set (ends a replay whose node was killed).
struct Stoppable {
    inner: Ros2PacketSink,
    stop: Arc<AtomicBool>,
}

impl PacketSink for Stoppable {
    fn wait_for_subscriber(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        self.inner.wait_for_subscriber(timeout)
    }
    fn send(&mut self, packet: &AccelPacket) -> anyhow::Result<()> {
        if self.stop.load(Ordering::Relaxed) {
            anyhow::bail!("stopped");
        }
        self.inner.send(packet)
    }
}

/// Alerts journaled before the kill.
const KILL_AFTER_ALERTS: usize = 3;

fn plan() -> NetworkPlan {
    network_plan(&Ros2Config::loopback_only(), None, None).unwrap()
}

fn journal_text(state: &Path) -> String {
    std::fs::read_to_string(state.join("journal.log")).unwrap_or_default()
}

/// Waits (bounded) until the journal shows the slender pillar overturned, then a little more
/// for the quiet tail, and stops the node with SIGTERM; returns its stderr.
fn finish(mut node: NodeProcess, state: &Path) -> String {
    let deadline = Instant::now() + Duration::from_secs(40);
    while !journal_text(state)
        .lines()
        .any(|l| l.contains("rrs-slender-pillar") && l.contains("\"overturned\""))
    {
        assert!(
            Instant::now() < deadline,
            "no overturned alert in the journal\n{}\n{}",
            journal_text(state),
            node.stderr()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    std::thread::sleep(Duration::from_secs(2));
    let status = node.signal_and_wait("TERM", Duration::from_secs(20));
    let stderr = node.stderr();
    assert!(status.is_some_and(|s| s.success()), "{status:?}\n{stderr}");
    stderr
}

fn sink_for_node(node: &NodeProcess) -> Ros2PacketSink {
    let mut sink = Ros2PacketSink::open(&plan(), "/").unwrap();
    assert!(
        sink.wait_for_subscriber(Duration::from_secs(30)).unwrap(),
        "the node never subscribed\n{}",
        node.stderr()
    );
    sink
}

#[test]
fn kill_9_mid_replay_and_restart_gives_the_alert_history_of_an_uninterrupted_run() {
    if !reexec_in_netns(
        "kill_9_mid_replay_and_restart_gives_the_alert_history_of_an_uninterrupted_run",
        170,
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let packets = rinaldi_packets(5.0);

    // Uninterrupted run.
    let state_a = dir.path().join("uninterrupted");
    let node = rockwatch_bin!().start_node(&config, &state_a, dir.path().join("a.err"));
    let mut sink = sink_for_node(&node);
    replay(&packets, &mut sink, Speed::Max, Restamp::Now, 1).unwrap();
    assert!(
        sink.finish(Duration::from_secs(30)).unwrap(),
        "not acknowledged"
    );
    let stderr_a = finish(node, &state_a);
    assert!(
        stderr_a.contains(&format!("stopped: {} packets received", packets.len())),
        "the uninterrupted node must have taken every packet\n{stderr_a}"
    );
    drop(sink);
    let uninterrupted = rockwatch_bin!().alert_history(&state_a);
    let expected: BTreeSet<_> = uninterrupted.iter().cloned().collect();
    assert_eq!(expected.len(), uninterrupted.len(), "{uninterrupted:?}");
    assert!(
        expected.contains(&("rrs-slender-pillar".into(), 1, "overturned".into())),
        "{uninterrupted:?}"
    );

    // Interrupted run: paced replay (5 × real time), kill -9 once KILL_AFTER_ALERTS alerts
    // are in the journal (of the 7 of a full run): alerts both before and after the kill.
    let state_b = dir.path().join("interrupted");
    let mut node = rockwatch_bin!().start_node(&config, &state_b, dir.path().join("b1.err"));
    let stop = Arc::new(AtomicBool::new(false));
    let replayer = {
        let mut sink = Stoppable {
            inner: sink_for_node(&node),
            stop: Arc::clone(&stop),
        };
        let packets = packets.clone();
        std::thread::spawn(move || {
            let _ = replay(&packets, &mut sink, Speed::Times(5.0), Restamp::Now, 1);
        })
    };
    let deadline = Instant::now() + Duration::from_secs(40);
    while journal_text(&state_b).lines().count() < KILL_AFTER_ALERTS {
        assert!(
            Instant::now() < deadline,
            "no alert before the kill\n{}",
            node.stderr()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let killed = node.signal_and_wait("KILL", Duration::from_secs(10));
    assert!(killed.is_some(), "kill -9 did not end the node");
    stop.store(true, Ordering::Relaxed);
    replayer.join().unwrap();
    let before_restart: BTreeSet<_> = rockwatch_bin!()
        .alert_history(&state_b)
        .into_iter()
        .collect();
    assert!(
        !before_restart.is_empty() && before_restart.len() < expected.len(),
        "the kill must land between the first and the last alert: {before_restart:?}"
    );
    assert!(before_restart.is_subset(&expected), "{before_restart:?}");

    // Restart on the same state directory; the record again from the start.
    let node = rockwatch_bin!().start_node(&config, &state_b, dir.path().join("b2.err"));
    let mut sink = sink_for_node(&node);
    replay(&packets, &mut sink, Speed::Max, Restamp::Now, 1).unwrap();
    assert!(
        sink.finish(Duration::from_secs(30)).unwrap(),
        "not acknowledged"
    );
    let stderr_b = finish(node, &state_b);
    let restarted = rockwatch_bin!().alert_history(&state_b);
    let got: BTreeSet<_> = restarted.iter().cloned().collect();
    assert_eq!(
        got.len(),
        restarted.len(),
        "an alert was journaled twice: {restarted:?}"
    );
    assert_eq!(
        got, expected,
        "history after kill -9 + restart differs from the uninterrupted run\n{stderr_b}"
    );
}
