//! `rockwatch replay --transport ros2` delivers every packet: at `--speed max` the whole record
//! leaves in milliseconds, and the replay must not exit before the node has it (DDS discovery
//! is two-sided, and the node's DDS reader drops the unread samples of a writer that has left).
use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::{run_in_netns, text};
use rockwatch_test_harness::node_output::count_before;
use rockwatch_test_harness::rockwatch_bin;

use std::path::PathBuf;

/// A node configured with the stations `XX.R0.00`, `XX.R1.00`, … (`stations` of them), and
/// the catalogue, `extra` appended to its `[ros2]` table. Each replay of a test sends its own
/// station: the same data twice to one station would be dropped as already processed (and
/// the replay fail, as `tests/ros2_intake.rs` checks).
fn node_config_with_stations(dir: &std::path::Path, stations: u64, extra: &str) -> PathBuf {
    let config = dir.join("node.toml");
    let mut text = format!(
        "catalogue = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n{extra}",
        repo().join("config/catalogue.toml").display()
    );
    for i in 0..stations {
        text.push_str(&format!("[[station]]\nid = \"XX.R{i}.00\"\n"));
    }
    std::fs::write(&config, text).unwrap();
    config
}

#[test]
fn replays_at_max_speed_deliver_every_packet_to_the_node() {
    const REPLAYS: u64 = 6;
    let dir = tempfile::tempdir().unwrap();
    let config = node_config_with_stations(dir.path(), REPLAYS, "");
    let (d, bin) = (dir.path().display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    // Each replay is a new process (a new DDS participant and writer), sent flat out.
    let replay = format!(
        "'{bin}' replay --config '{}' --record '{}' --azimuth 228 --station XX.R$i.00 \
         --transport ros2 --speed max --tail 5 --restamp original --wait-s 30 | sed 's/^/REPLAY /'",
        config.display(),
        rec.display()
    );
    let script = format!(
        "'{bin}' node --config '{}' 2> '{d}/node.err' & NODE=$!
         for i in $(seq 0 {}); do {replay}; done
         sleep 1
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         cat '{d}/node.err' >&2",
        config.display(),
        REPLAYS - 1
    );
    let out = run_in_netns(&script, 180, &[]);
    let (stdout, stderr) = text(&out);
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{stderr}");
    let sent: Vec<u64> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("REPLAY replayed "))
        .map(|l| l.split(' ').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(sent.len() as u64, REPLAYS, "{stdout}\n{stderr}");
    assert!(sent.iter().all(|&n| n == sent[0] && n > 200), "{sent:?}");
    assert_eq!(
        count_before(&stderr, "packets received over ROS 2"),
        sent.iter().sum::<u64>(),
        "packets lost between the replay and the node\n{stdout}\n{stderr}"
    );
}

#[test]
fn a_replay_whose_node_stops_midway_exits_non_zero() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let (d, bin) = (dir.path().display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    // 25 s of data at 5× real time: the node is stopped (SIGTERM) about 1 s in.
    let script = format!(
        "'{bin}' node --config '{c}' 2> '{d}/node.err' & NODE=$!
         '{bin}' replay --config '{c}' --record '{r}' --station CI.RRS.00 --transport ros2 \
             --speed 5 --wait-s 10 > '{d}/replay.out' 2> '{d}/replay.err' & REPLAY=$!
         sleep 2; kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         RC=0; wait $REPLAY || RC=$?; echo REPLAY_RC=$RC
         cat '{d}/replay.err' >&2",
        c = config.display(),
        r = rec.display()
    );
    let out = run_in_netns(&script, 120, &[]);
    let (stdout, stderr) = text(&out);
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("REPLAY_RC=1"),
        "the replay must fail when its node goes away\n{stdout}\n{stderr}"
    );
    // One line naming the node, what it processed and why not the rest.
    assert!(
        stderr.contains("not every node processed them")
            && stderr.contains("/rockwatch (pid")
            && stderr.contains("not processed (it went away)"),
        "one line saying why\n{stderr}"
    );
}

/// Issue 24 item 5: 4–12 concurrent replays overflowed the node's one input reader (keep last
/// `input_depth`, shared by every writer): up to 2293 packets lost per run. Each node grants
/// each writer a share of its reader (its window in the intake reports), so ten replays flat
/// out at once, in 10 ms packets, to a node whose reader keeps only 100 (each replay alone
/// used to keep 256 in flight), all exit 0 and the node counts every packet.
#[test]
fn ten_concurrent_replays_flat_out_lose_nothing() {
    const REPLAYS: u64 = 10;
    let dir = tempfile::tempdir().unwrap();
    let config = node_config_with_stations(dir.path(), REPLAYS, "input_depth = 100\n");
    let (d, bin) = (dir.path().display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    let replay = |i: u64| {
        format!(
            "( RC=0; '{bin}' replay --config '{}' --record '{}' --azimuth 228 --station XX.R{i}.00 \
             --transport ros2 --speed max --packet-ms 10 --tail 0 --restamp original --wait-s 60 \
             > '{d}/r{i}.out' 2> '{d}/r{i}.err' || RC=$?; echo R{i}_RC=$RC ) & PIDS=\"$PIDS $!\"",
            config.display(),
            rec.display()
        )
    };
    let replays: String = (0..REPLAYS).map(replay).collect::<Vec<_>>().join("\n");
    let script = format!(
        "'{bin}' node --config '{}' 2> '{d}/node.err' & NODE=$!
         sleep 1
         PIDS=
         {replays}
         wait $PIDS
         sleep 1
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?",
        config.display()
    );
    let out = run_in_netns(&script, 300, &[]);
    let (stdout, _) = text(&out);
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap_or_default();
    let node_err = read("node.err");
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{node_err}");
    let mut sent = 0;
    for i in 0..REPLAYS {
        let (out, err) = (read(&format!("r{i}.out")), read(&format!("r{i}.err")));
        assert!(
            stdout.contains(&format!("R{i}_RC=0")),
            "replay {i}\n{stdout}\n{err}\n{node_err}"
        );
        sent += out
            .strip_prefix("replayed ")
            .and_then(|l| l.split(' ').next()?.parse::<u64>().ok())
            .unwrap_or_else(|| panic!("{out}"));
    }
    assert!(sent >= REPLAYS * 1900, "{sent}");
    assert_eq!(
        count_before(&node_err, "packets received over ROS 2"),
        sent,
        "packets lost between the replays and the node\n{node_err}"
    );
}
