//! Nothing lost on the input: a replay over ROS 2 ends with exit 0 only once the node has
//! taken every packet it sent (the node's `/pbr/intake` reports), else it exits non-zero
//! naming how many were not processed. Flat out (`--speed max --loop 40`), paced at
//! ≈ 10 000 packets/s, and with the node paused mid-stream. In a private network namespace.

use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::{run_in_netns, text};
use rockwatch_test_harness::node_output::count_before;
use rockwatch_test_harness::rockwatch_bin;

/// Runs a node and one replay with `replay_args` (`pause`: stop the node for 1 s, 1 s into
/// the replay); returns (replay exit code, packets the replay sent (from its summary, or
/// from its error line), packets the replay says the node took, replay stderr, node stderr).
fn replay_to_node(replay_args: &str, pause: bool) -> (i32, u64, u64, String, String) {
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let (d, bin) = (dir.path().display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    let pause = if pause {
        "sleep 1; kill -STOP $NODE; sleep 1; kill -CONT $NODE;"
    } else {
        ""
    };
    let script = format!(
        "'{bin}' node --config '{c}' 2> '{d}/node.err' & NODE=$!
         '{bin}' replay --config '{c}' --record '{r}' --azimuth 228 --station CI.RRS.00 \
             --transport ros2 --restamp original --tail 5 {replay_args} > '{d}/replay.out' 2> '{d}/replay.err' & REPLAY=$!
         {pause}
         RC=0; wait $REPLAY || RC=$?; echo REPLAY_RC=$RC
         sleep 1; kill -TERM $NODE; wait $NODE; echo NODE_RC=$?",
        c = config.display(),
        r = rec.display()
    );
    let out = run_in_netns(&script, 240, &[]);
    let (stdout, _) = text(&out);
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap_or_default();
    let (replay_out, replay_err, node_err) =
        (read("replay.out"), read("replay.err"), read("node.err"));
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{node_err}");
    let rc: i32 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("REPLAY_RC="))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{stdout}"));
    let number_after = |text: &str, label: &str| -> Option<u64> {
        let at = text.find(label)? + label.len();
        text[at..]
            .split(|c: char| !c.is_ascii_digit())
            .find(|s| !s.is_empty())?
            .parse()
            .ok()
    };
    let (sent, taken) = if rc == 0 {
        let sent = number_after(&replay_out, "replayed ").unwrap_or_else(|| panic!("{replay_out}"));
        (sent, sent)
    } else {
        let sent = number_after(&replay_err, "sent ").unwrap_or_else(|| panic!("{replay_err}"));
        let taken = number_after(&replay_err, " took ").unwrap_or_else(|| panic!("{replay_err}"));
        (sent, taken)
    };
    (rc, sent, taken, replay_err, node_err)
}

#[test]
fn a_replay_at_max_speed_looped_40_times_is_processed_whole() {
    let (rc, sent, taken, replay_err, node_err) =
        replay_to_node("--speed max --loop 40 --wait-s 60", false);
    assert_eq!(rc, 0, "{replay_err}\n{node_err}");
    assert_eq!(sent, 40 * 250, "{replay_err}");
    assert_eq!(taken, sent);
    assert_eq!(
        count_before(&node_err, "packets received over ROS 2"),
        sent,
        "the replay exited 0 but the node did not get everything\n{node_err}"
    );
}

#[test]
fn a_replay_paced_at_10k_packets_per_second_is_processed_whole() {
    // 10 ms packets at 100 Hz are one sample each: 100 × real time is 10 000 packets/s.
    let (rc, sent, _, replay_err, node_err) =
        replay_to_node("--packet-ms 10 --speed 100 --loop 10 --wait-s 60", false);
    assert_eq!(rc, 0, "{replay_err}\n{node_err}");
    assert!(sent > 20_000, "{sent}");
    assert_eq!(
        count_before(&node_err, "packets received over ROS 2"),
        sent,
        "{node_err}"
    );
}

#[test]
fn a_replay_whose_node_paused_mid_stream_is_whole_or_names_the_shortfall() {
    // 5 × real time (50 packets/s, ≈ 50 s): the node is stopped for 1 s, 1 s in; its
    // participant dies and is rebuilt. Whatever the new reader gets, the replay may not
    // report success unless the node took everything, and otherwise names the shortfall.
    let (rc, sent, taken, replay_err, node_err) =
        replay_to_node("--speed 5 --loop 1 --wait-s 5", true);
    let received = count_before(&node_err, "packets received over ROS 2");
    eprintln!("paused node: replay exit {rc}, sent {sent}, taken {taken}, received {received}");
    assert!(node_err.contains("ROS 2 participant rebuilt"), "{node_err}");
    if rc == 0 {
        assert_eq!(received, sent, "{node_err}");
    } else {
        assert_eq!(rc, 1, "{replay_err}");
        assert!(
            replay_err.contains(&format!("{} not processed", sent - taken)) && taken < sent,
            "{replay_err}"
        );
        assert_eq!(
            received, taken,
            "the replay's count of what the node took\n{node_err}"
        );
    }
}

/// A replay not given the node's configuration cannot check its station against the node's
/// catalogue: the node reports on `/pbr/intake` how many packets it ignored (a station it
/// does not monitor), and the replay exits 1 naming them; the same replay of a station the
/// node monitors exits 0.
#[test]
fn a_replay_of_a_station_the_node_does_not_monitor_exits_1_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let (d, bin) = (dir.path().display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    let replay = |station: &str, out: &str| {
        format!(
            "RC=0; ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST '{bin}' replay --record '{r}' --azimuth 228 \
                 --station {station} --transport ros2 --speed max --tail 0 --wait-s 30 \
                 > '{d}/{out}.out' 2> '{d}/{out}.err' || RC=$?; echo {out}_RC=$RC",
            r = rec.display()
        )
    };
    let script = format!(
        "'{bin}' node --config '{c}' 2> '{d}/node.err' & NODE=$!
         {unknown}
         {known}
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?",
        c = config.display(),
        unknown = replay("XX.UNK.00", "unknown"),
        known = replay("CI.RRS.00", "known"),
    );
    let out = run_in_netns(&script, 240, &[]);
    let (stdout, _) = text(&out);
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap_or_default();
    let node_err = read("node.err");
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{node_err}");
    let unknown_err = read("unknown.err");
    assert!(
        stdout.contains("unknown_RC=1"),
        "{stdout}\n{unknown_err}\n{node_err}"
    );
    let line = unknown_err
        .lines()
        .find(|l| l.starts_with("rockwatch: error: the node ignored"))
        .unwrap_or_else(|| panic!("{unknown_err}"));
    assert!(
        line.contains("the node ignored 200 of the 200 packets sent") && line.contains("XX.UNK.00"),
        "{line}"
    );
    assert_eq!(
        count_before(&node_err, "from unknown stations"),
        200,
        "{node_err}"
    );
    assert!(
        stdout.contains("known_RC=0"),
        "{stdout}\n{}\n{node_err}",
        read("known.err")
    );
}

/// A node whose stderr nobody reads (a one-page pipe, full at once under `--log-level debug`)
/// still takes every packet and raises its alerts: its records are queued for the log thread
/// (dropped and counted beyond `LOG_QUEUE`), never waited for (with a blocking stderr every
/// thread that logs stalled, DDS's included).
#[test]
fn a_node_whose_stderr_nobody_reads_keeps_monitoring() {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("state");
    let config = dir.path().join("node.toml");
    std::fs::write(
        &config,
        format!(
            "catalogue = \"{}\"\nstate_dir = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n",
            repo().join("config/catalogue.toml").display(),
            state.display()
        ),
    )
    .unwrap();
    let d = dir.path().display();
    let script = format!(
        "python3 '{py}' '{bin}' '{c}' '{rec}' '{d}/node.err' '{d}/replay.err'",
        py = repo().join("tests/data/ros2/blocked_stderr.py").display(),
        bin = rockwatch_bin!().display(),
        c = config.display(),
        rec = repo().join("tests/data/records/Rinaldi228.AT2").display(),
    );
    let out = run_in_netns(&script, 180, &[]);
    let (stdout, stderr) = text(&out);
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap_or_default();
    let node_err = read("node.err");
    assert!(
        stdout.contains("REPLAY_RC=0"),
        "{stdout}\n{stderr}\n{}\n{node_err}",
        read("replay.err")
    );
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{node_err}");
    // It wrote several times what the pipe holds: with a blocking stderr it would have
    // stalled at the first 4 KiB, before the replay's first packet.
    assert!(node_err.len() > 3 * 4096, "{}: {node_err}", node_err.len());
    let alerts = rockwatch_bin!().alert_history(&state);
    assert!(
        alerts.contains(&(
            "rrs-slender-pillar".to_string(),
            1,
            "overturned".to_string()
        )),
        "{alerts:?}"
    );
}

/// Issue 24 item 4: with two nodes subscribed, a replay exited 0 while one of them lost 23 %.
/// Each node reports on its own (its id and name); the replay is paced by the one furthest
/// behind and exits 1 naming the node that did not process everything — here one stopped
/// (SIGTERM) mid-replay — and not the one that did.
#[test]
fn a_replay_to_two_nodes_fails_naming_the_one_that_went_away() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    let catalogue = repo().join("config/catalogue.toml");
    let (ca, cb) = (
        write_node_config(&a, &catalogue),
        write_node_config(&b, &catalogue),
    );
    let (d, bin) = (dir.path().display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    let script = format!(
        "'{bin}' node --config '{ca}' 2> '{d}/a.err' & A=$!; echo A=$A
         '{bin}' node --config '{cb}' 2> '{d}/b.err' & B=$!; echo B=$B
         sleep 1
         '{bin}' replay --config '{ca}' --record '{r}' --azimuth 228 --station CI.RRS.00 \
             --transport ros2 --speed 5 --wait-s 8 > '{d}/replay.out' 2> '{d}/replay.err' & REPLAY=$!
         sleep 3; kill -TERM $B; wait $B; echo B_RC=$?
         RC=0; wait $REPLAY || RC=$?; echo REPLAY_RC=$RC
         kill -TERM $A; wait $A; echo A_RC=$?",
        ca = ca.display(),
        cb = cb.display(),
        r = rec.display()
    );
    let out = run_in_netns(&script, 240, &[]);
    let (stdout, _) = text(&out);
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap_or_default();
    let replay_err = read("replay.err");
    assert!(
        stdout.contains("A_RC=0") && stdout.contains("B_RC=0"),
        "{stdout}\n{}\n{}",
        read("a.err"),
        read("b.err")
    );
    assert!(stdout.contains("REPLAY_RC=1"), "{stdout}\n{replay_err}");
    let pid = |name: &str| -> String {
        stdout
            .lines()
            .find_map(|l| l.strip_prefix(&format!("{name}=")))
            .unwrap_or_else(|| panic!("{stdout}"))
            .to_string()
    };
    let (pid_a, pid_b) = (pid("A"), pid("B"));
    assert!(
        replay_err.contains(&format!("(pid {pid_b}) took"))
            && replay_err.contains("not processed (it went away)"),
        "the node that went away is named\n{replay_err}"
    );
    assert!(
        !replay_err.contains(&format!("(pid {pid_a})")),
        "the node that kept up is not\n{replay_err}"
    );
}

/// Issue 24 item 4: a replay whose every strong-motion packet the node refused (beyond a
/// plausibility bound of 0.05 g) exited 0. It exits 1, naming the node and how many it refused
/// — the node's own count.
#[test]
fn a_replay_whose_packets_the_node_refuses_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.toml");
    std::fs::write(
        &config,
        format!(
            "catalogue = \"{}\"\n[engine.plausibility]\nmax_abs_accel_g = 0.05\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n",
            repo().join("config/catalogue.toml").display()
        ),
    )
    .unwrap();
    let (d, bin) = (dir.path().display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    let script = format!(
        "'{bin}' node --config '{c}' 2> '{d}/node.err' & NODE=$!
         RC=0; '{bin}' replay --config '{c}' --record '{r}' --azimuth 228 --station CI.RRS.00 \
             --transport ros2 --speed max --wait-s 30 > '{d}/replay.out' 2> '{d}/replay.err' || RC=$?
         echo REPLAY_RC=$RC
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?",
        c = config.display(),
        r = rec.display()
    );
    let out = run_in_netns(&script, 240, &[]);
    let (stdout, _) = text(&out);
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap_or_default();
    let (replay_err, node_err) = (read("replay.err"), read("node.err"));
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{node_err}");
    assert!(stdout.contains("REPLAY_RC=1"), "{stdout}\n{replay_err}");
    let refused: u64 = replay_err
        .split("refused ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{replay_err}"));
    assert!(
        replay_err.contains("/rockwatch (pid") && replay_err.contains("implausible"),
        "{replay_err}"
    );
    assert_eq!(
        count_before(&node_err, "rejected as invalid"),
        refused,
        "{node_err}"
    );
}

/// Issue 24 item 8: a replay's resident memory does not grow with its length. RustDDS keeps a
/// reliable writer's acknowledged samples until its cache cleaning, every 6 s, so a replay flat
/// out holds up to about 6 s of what it sent; after that its resident size stays flat however
/// long it runs (here `--loop 1000`, sampled every 2 s for 26 s).
#[test]
fn a_long_replay_flat_out_stays_within_a_fixed_memory() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let (d, bin) = (dir.path().display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    let script = format!(
        "'{bin}' node --config '{c}' 2> '{d}/node.err' & NODE=$!
         '{bin}' replay --config '{c}' --record '{r}' --azimuth 228 --station CI.RRS.00 \
             --transport ros2 --speed max --loop 1000 --restamp original --wait-s 60 \
             > '{d}/replay.out' 2> '{d}/replay.err' & REPLAY=$!
         for i in $(seq 1 13); do sleep 2; \
             echo RSS $((i * 2)) $(awk '/VmRSS/ {{print $2}}' /proc/$REPLAY/status); done
         kill -TERM $REPLAY; wait $REPLAY
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?",
        c = config.display(),
        r = rec.display()
    );
    let out = run_in_netns(&script, 240, &[]);
    let (stdout, _) = text(&out);
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap_or_default();
    let samples: Vec<(u64, u64)> = stdout
        .lines()
        .filter_map(|l| {
            let mut words = l.strip_prefix("RSS ")?.split(' ');
            Some((words.next()?.parse().ok()?, words.next()?.parse().ok()?))
        })
        .collect();
    assert_eq!(
        samples.len(),
        13,
        "the replay ended early or its memory was not read\n{stdout}\n{}",
        read("replay.err")
    );
    // After two cache cleanings (12 s) the peak so far is the bound; the rest may not exceed it
    // by more than allocator slack.
    let peak = |from: u64, to: u64| {
        samples
            .iter()
            .filter(|(t, _)| (from..=to).contains(t))
            .map(|(_, kb)| *kb)
            .max()
            .unwrap_or(0)
    };
    let (early, late) = (peak(2, 14), peak(16, 26));
    eprintln!(
        "replay resident: peak {early} kB up to 14 s, {late} kB from 16 to 26 s: {samples:?}"
    );
    assert!(
        late <= early + early / 5 + 8 * 1024,
        "the replay's memory grows with its length: {samples:?}"
    );
}

/// Issue 24 item 5: a node paused during a flat-out replay ended it with `WouldBlock` and a raw
/// packet dump. The replay keeps within the node's window, so it waits on the node's reports,
/// and when they stand still for `--wait-s` it exits 1 with one line naming the node and what
/// it did not process.
#[test]
fn a_replay_whose_node_is_paused_longer_than_its_wait_fails_with_one_clean_line() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let (d, bin) = (dir.path().display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    let script = format!(
        "'{bin}' node --config '{c}' 2> '{d}/node.err' & NODE=$!
         '{bin}' replay --config '{c}' --record '{r}' --azimuth 228 --station CI.RRS.00 \
             --transport ros2 --speed max --loop 200 --restamp original --wait-s 2 \
             > '{d}/replay.out' 2> '{d}/replay.err' & REPLAY=$!
         sleep 1; kill -STOP $NODE; sleep 6; kill -CONT $NODE
         RC=0; wait $REPLAY || RC=$?; echo REPLAY_RC=$RC
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?",
        c = config.display(),
        r = rec.display()
    );
    let out = run_in_netns(&script, 240, &[]);
    let (stdout, _) = text(&out);
    let replay_err = std::fs::read_to_string(dir.path().join("replay.err")).unwrap_or_default();
    assert!(stdout.contains("REPLAY_RC=1"), "{stdout}\n{replay_err}");
    let errors: Vec<&str> = replay_err
        .lines()
        .filter(|l| l.starts_with("rockwatch: error:"))
        .collect();
    assert_eq!(errors.len(), 1, "{replay_err}");
    assert!(
        errors[0].contains("/rockwatch (pid") && errors[0].contains("not processed ("),
        "{replay_err}"
    );
    assert!(
        !replay_err.contains("WouldBlock") && !replay_err.contains("AccelPacket {"),
        "no raw error or packet dump\n{replay_err}"
    );
}

/// Issue 20 item 3: a replay of data the station already has (here the same record twice; in
/// the field, a replay onto a live station) lost every packet as duplicate or late, with no
/// word and exit 0. The second replay exits 1 saying how many of its packets the node dropped
/// as already processed — every one — and the node's log names the station and the span.
#[test]
fn a_replay_of_data_the_station_has_already_exits_1_naming_the_drops() {
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let (d, bin) = (dir.path().display(), rockwatch_bin!().display().to_string());
    let rec = repo().join("tests/data/records/Rinaldi228.AT2");
    let replay = |n: u8| {
        format!(
            "RC=0; '{bin}' replay --config '{c}' --record '{r}' --azimuth 228 --station CI.RRS.00 \
                 --transport ros2 --restamp original --speed max --wait-s 30 \
                 > '{d}/replay{n}.out' 2> '{d}/replay{n}.err' || RC=$?; echo REPLAY{n}_RC=$RC",
            c = config.display(),
            r = rec.display()
        )
    };
    let script = format!(
        "'{bin}' node --config '{c}' 2> '{d}/node.err' & NODE=$!
         {first}
         {second}
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?",
        c = config.display(),
        first = replay(1),
        second = replay(2),
    );
    let out = run_in_netns(&script, 240, &[]);
    let (stdout, _) = text(&out);
    let read = |f: &str| std::fs::read_to_string(dir.path().join(f)).unwrap_or_default();
    let (first_err, second_err, node_err) =
        (read("replay1.err"), read("replay2.err"), read("node.err"));
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{node_err}");
    assert!(stdout.contains("REPLAY1_RC=0"), "{stdout}\n{first_err}");
    assert!(
        stdout.contains("REPLAY2_RC=1"),
        "{stdout}\n{}\n{second_err}\n{node_err}",
        read("replay2.out")
    );
    let sent: u64 = read("replay1.out")
        .split("replayed ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{}", read("replay1.out")));
    assert!(
        second_err.contains(&format!(
            "dropped the samples (all or some) of {sent} as already processed of the {sent} packets sent"
        )) && second_err.contains("/rockwatch (pid"),
        "{second_err}"
    );
    assert!(
        node_err.contains("CI.RRS.00: dropped:") && node_err.contains("from 1970-01-01T"),
        "the node's log names the station and the span\n{node_err}"
    );
}
