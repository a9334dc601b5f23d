//! The live node's runtime without transports: packets in, publications out, journal kept.

mod shell_harness;
use shell_harness::rinaldi_packets;

use std::path::PathBuf;
use std::time::Duration;

use rockwatch::journal::read_journal;
use rockwatch::node::{NodeOptions, NodeRuntime, ResetOutcome};
use rockwatch::ports::Publication;
use rockwatch_core::catalogue::Catalogue;
use rockwatch_core::engine::{Engine, EngineConfig, Output, PbrSpec};

/// Alert keys of the single-threaded engine on the Rinaldi packets (the reference).
fn reference_alert_keys() -> Vec<rockwatch_core::engine::AlertKey> {
    let catalogue = Catalogue::load(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../config/catalogue.toml"
    ))
    .unwrap();
    let specs: Vec<PbrSpec> = catalogue
        .pbrs()
        .iter()
        .map(|p| PbrSpec::from_catalogue(p).unwrap())
        .collect();
    let mut engine = Engine::new(EngineConfig::default(), vec![], &specs).unwrap();
    let mut out = Vec::new();
    for p in rinaldi_packets(10.0) {
        engine.process(p, 0, &mut out);
    }
    engine.flush(0, &mut out);
    let mut expected: Vec<_> = out
        .iter()
        .filter_map(|o| {
            if let Output::Alert(a) = o {
                Some(a.key())
            } else {
                None
            }
        })
        .collect();
    expected.sort();
    expected
}

/// Feeds the Rinaldi packets through a runtime with `shards` shards; checks the published
/// alerts against the plain engine, their latencies, and the journal.
fn runtime_publishes_the_engines_alerts(shards: usize) {
    let dir = tempfile::tempdir().unwrap();
    let options = NodeOptions {
        catalogue: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))),
        state_dir: Some(dir.path().to_path_buf()),
        shards,
        ..NodeOptions::default()
    };
    let mut node = NodeRuntime::start(&options).unwrap();
    assert_eq!(node.shards(), shards);
    let mut published = Vec::new();
    let mut publish = |p: Publication| published.push(p);
    for packet in rinaldi_packets(10.0) {
        node.submit(packet, &mut publish);
        node.poll(&mut publish);
    }
    node.poll_wait(Duration::from_millis(10), &mut publish);
    let summaries = node.shutdown(&mut publish);
    assert_eq!(
        summaries.len(),
        Catalogue::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))
        .unwrap()
        .len()
    );

    // The same alerts as the single-threaded engine on the same packets.
    let expected = reference_alert_keys();
    let mut got: Vec<_> = published
        .iter()
        .filter_map(|p| {
            if let Publication::Alert { alert, .. } = p {
                Some(alert.key())
            } else {
                None
            }
        })
        .collect();
    got.sort();
    assert!(!got.is_empty());
    assert_eq!(got, expected);
    for p in &published {
        if let Publication::Alert { latency_ns, .. } = p {
            assert!(
                *latency_ns >= 0 && *latency_ns < 5_000_000_000,
                "latency {latency_ns} ns"
            );
        }
    }
    assert!(published.iter().any(|p| matches!(p, Publication::State(_))));
    assert!(published
        .iter()
        .any(|p| matches!(p, Publication::Intensity(_))));
    let (records, _) = read_journal(dir.path()).unwrap();
    let journaled = records
        .iter()
        .filter(|r| matches!(r, rockwatch_core::engine::JournalRecord::Alert(_)))
        .count();
    assert_eq!(journaled, got.len());
}

#[test]
fn inline_runtime_publishes_the_engines_alerts_journaled_with_latencies() {
    runtime_publishes_the_engines_alerts(1);
}

#[test]
fn sharded_runtime_publishes_the_engines_alerts_journaled_with_latencies() {
    runtime_publishes_the_engines_alerts(2);
}

#[test]
fn inline_runtime_publishes_an_alert_during_submit_after_journaling_it() {
    let dir = tempfile::tempdir().unwrap();
    let options = NodeOptions {
        catalogue: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))),
        state_dir: Some(dir.path().to_path_buf()),
        ..NodeOptions::default()
    };
    assert_eq!(options.shards, 1, "one shard (inline) is the default");
    let mut node = NodeRuntime::start(&options).unwrap();
    let mut alerts = 0;
    for packet in rinaldi_packets(10.0) {
        let mut during = Vec::new();
        node.submit(packet, &mut |p| {
            if let Publication::Alert { alert, .. } = &p {
                // At publication the alert is already in the journal on disk.
                let (records, _) = read_journal(dir.path()).unwrap();
                assert!(records.iter().any(|r| matches!(
                    r,
                    rockwatch_core::engine::JournalRecord::Alert(a) if a.key() == alert.key()
                )));
            }
            during.push(p);
        });
        // Inline: nothing is left for poll; everything came out during submit.
        node.poll(&mut |p| panic!("published after submit returned: {p:?}"));
        alerts += during
            .iter()
            .filter(|p| matches!(p, Publication::Alert { .. }))
            .count();
    }
    node.shutdown(&mut |_| {});
    assert_eq!(alerts, reference_alert_keys().len());
}

#[test]
fn a_restarted_inline_runtime_never_publishes_a_journaled_alert_again() {
    let dir = tempfile::tempdir().unwrap();
    let options = NodeOptions {
        catalogue: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))),
        state_dir: Some(dir.path().to_path_buf()),
        ..NodeOptions::default()
    };
    let packets = rinaldi_packets(10.0);
    let count_alerts = |node: &mut NodeRuntime, packets: &[rockwatch_core::engine::AccelPacket]| {
        let mut n = 0;
        for p in packets {
            node.submit(p.clone(), &mut |p| {
                n += usize::from(matches!(p, Publication::Alert { .. }));
            });
        }
        n
    };
    let mut first = NodeRuntime::start(&options).unwrap();
    let before = count_alerts(&mut first, &packets);
    first.shutdown(&mut |_| {});
    assert_eq!(before, reference_alert_keys().len());
    // Same record again on the same state directory: everything is journaled already.
    let mut second = NodeRuntime::start(&options).unwrap();
    assert_eq!(count_alerts(&mut second, &packets), 0);
    second.shutdown(&mut |_| {});
}

#[test]
fn a_packet_held_for_missing_data_is_released_when_the_station_falls_silent() {
    for shards in [1, 2] {
        let options = NodeOptions {
            catalogue: Some(PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../config/catalogue.toml"
            ))),
            shards,
            ..NodeOptions::default()
        };
        // Loaded before the start: the node's held-packet timer runs from its start.
        let packets = rinaldi_packets(10.0);
        let mut node = NodeRuntime::start(&options).unwrap();
        // Packet 0, then packet 12 (1.1 s lost), then silence: packet 12 waits in the reorder
        // window until the node's timer releases it. (States and intensities are published
        // once per second of data, so the held packet's must show a data time ≥ 1.2 s.)
        let held_start = packets[12].start_time_ns;
        let mut collect = Vec::new();
        node.submit(packets[0].clone(), &mut |p| collect.push(p));
        node.submit(packets[12].clone(), &mut |p| collect.push(p));
        let shows_held = |c: &[Publication]| {
            c.iter().any(|p| {
                matches!(p, Publication::Intensity(i) if i.data_time_ns >= held_start)
                    || matches!(p, Publication::State(s) if s.data_time_ns >= held_start)
            })
        };
        // Not yet due: still held.
        node.flush_if_due(&mut |p| collect.push(p));
        node.poll_wait(Duration::from_millis(100), &mut |p| collect.push(p));
        assert!(
            !shows_held(&collect),
            "released before its time ({shards} shards)"
        );
        std::thread::sleep(rockwatch::node::HELD_PACKET_TIMEOUT);
        node.flush_if_due(&mut |p| collect.push(p));
        // Sharded: the release comes back from the worker (bounded wait).
        for _ in 0..50 {
            if shows_held(&collect) {
                break;
            }
            node.poll_wait(Duration::from_millis(20), &mut |p| collect.push(p));
        }
        assert!(
            shows_held(&collect),
            "the held packet was not released by the timer ({shards} shards)"
        );
        node.shutdown(&mut |_| {});
    }
}

/// The Rinaldi packets again, as the same station's stream continuing `after_s` seconds after
/// the end of the first pass (later times, later sequence numbers).
fn rinaldi_again(after_s: f64) -> Vec<rockwatch_core::engine::AccelPacket> {
    let first = rinaldi_packets(10.0);
    let last = first.last().unwrap();
    let end_ns = last.start_time_ns + (last.len() as f64 * 1e9 / last.sample_rate_hz) as i64;
    let shift_ns = end_ns - first[0].start_time_ns + (after_s * 1e9) as i64;
    let n = first.len() as u64;
    first
        .into_iter()
        .map(|mut p| {
            p.start_time_ns += shift_ns;
            p.sequence += n;
            p
        })
        .collect()
}

/// Feeds `packets` and waits (bounded) for the sharded workers' outputs; returns the alerts'
/// (block, episode, level).
fn feed(
    node: &mut NodeRuntime,
    packets: &[rockwatch_core::engine::AccelPacket],
) -> Vec<(String, u32, String)> {
    let mut alerts = Vec::new();
    let mut publish = |p: Publication| {
        if let Publication::Alert { alert, .. } = p {
            alerts.push((
                alert.pbr_id.to_string(),
                alert.episode,
                alert.level.as_str().to_string(),
            ));
        }
    };
    for p in packets {
        node.submit(p.clone(), &mut publish);
    }
    // The quiet tail ends the episodes of the blocks that stand; sharded, the outputs come
    // back from the workers: wait until nothing more comes for 1 s (a loaded CI machine may
    // stall a worker for a while).
    loop {
        let before = node.stats().alerts + node.stats().states;
        node.poll_wait(Duration::from_secs(1), &mut publish);
        if node.stats().alerts + node.stats().states == before {
            break;
        }
    }
    alerts
}

const SLENDER: &str = "rrs-slender-pillar";

fn operator_reset_stands_the_block_again(shards: usize) {
    let dir = tempfile::tempdir().unwrap();
    let options = NodeOptions {
        catalogue: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))),
        state_dir: Some(dir.path().to_path_buf()),
        shards,
        ..NodeOptions::default()
    };
    let resets_in_journal = || {
        read_journal(dir.path())
            .unwrap()
            .0
            .iter()
            .filter(|r| matches!(r, rockwatch_core::engine::JournalRecord::Reset { pbr_id, .. } if pbr_id == SLENDER))
            .count()
    };
    let mut node = NodeRuntime::start(&options).unwrap();
    // Unknown ids and standing blocks: nothing done, nothing journaled.
    assert_eq!(node.overturned("no-such-block"), None);
    assert_eq!(
        node.operator_reset("no-such-block").unwrap(),
        ResetOutcome::UnknownPbr
    );
    assert_eq!(node.overturned(SLENDER), Some(false));
    assert_eq!(
        node.operator_reset(SLENDER).unwrap(),
        ResetOutcome::NotOverturned
    );
    assert_eq!(resets_in_journal(), 0);

    // First pass: the slender block overturns in episode 1 (as the plain engine says).
    let first = feed(&mut node, &rinaldi_packets(10.0));
    let expected: Vec<_> = reference_alert_keys()
        .into_iter()
        .filter(|k| k.0 == SLENDER)
        .collect();
    assert!(expected
        .iter()
        .any(|k| k.1 == 1 && k.2 == rockwatch_core::engine::AlertLevel::Overturned));
    let slender_levels = |alerts: &[(String, u32, String)], episode: u32| {
        let mut v: Vec<String> = alerts
            .iter()
            .filter(|a| a.0 == SLENDER && a.1 == episode)
            .map(|a| a.2.clone())
            .collect();
        v.sort();
        v
    };
    let mut reference_levels: Vec<String> =
        expected.iter().map(|k| k.2.as_str().to_string()).collect();
    reference_levels.sort();
    assert_eq!(slender_levels(&first, 1), reference_levels, "{first:?}");
    assert_eq!(node.overturned(SLENDER), Some(true));

    // A fallen block stays fallen: the record again raises nothing for it.
    let again = feed(&mut node, &rinaldi_again(30.0));
    assert!(!again.iter().any(|a| a.0 == SLENDER), "{again:?}");

    // The reset: journaled, and the block stands again.
    assert_eq!(node.operator_reset(SLENDER).unwrap(), ResetOutcome::Reset);
    assert_eq!(resets_in_journal(), 1);
    assert_eq!(node.overturned(SLENDER), Some(false));
    assert_eq!(
        node.operator_reset(SLENDER).unwrap(),
        ResetOutcome::NotOverturned
    );
    assert_eq!(
        resets_in_journal(),
        1,
        "a standing block's reset is not journaled"
    );

    // From rest under the same motion the block does what it did the first time, as episode 2.
    let third = feed(&mut node, &rinaldi_again(90.0));
    assert_eq!(slender_levels(&third, 2), reference_levels, "{third:?}");
    assert_eq!(node.overturned(SLENDER), Some(true));
    assert_eq!(node.operator_reset(SLENDER).unwrap(), ResetOutcome::Reset);
    node.shutdown(&mut |_| {});

    // A restart keeps the reset: the journal's last word on the block is a reset.
    let node = NodeRuntime::start(&options).unwrap();
    assert_eq!(node.overturned(SLENDER), Some(false));
    assert_eq!(resets_in_journal(), 2);
}

#[test]
fn operator_reset_of_a_fallen_block_is_journaled_and_a_new_episode_can_overturn_it_inline() {
    operator_reset_stands_the_block_again(1);
}

#[test]
fn operator_reset_of_a_fallen_block_is_journaled_and_a_new_episode_can_overturn_it_sharded() {
    operator_reset_stands_the_block_again(2);
}

/// Issue 11, finding 6 (live): a packet stamped more than `engine.plausibility.max_ahead_s`
/// ahead of its arrival is rejected and counted before the engine, so it cannot move its
/// station's time grid; packets stamped now (or in the past) are processed.
#[test]
fn packets_stamped_ahead_of_their_arrival_are_rejected_and_counted() {
    let options = NodeOptions {
        catalogue: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))),
        ..NodeOptions::default()
    };
    assert!(options.reject_future);
    let mut node = NodeRuntime::start(&options).unwrap();
    let now_ns = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_nanos() as i64;
    let mut packets = rinaldi_packets(10.0);
    packets.truncate(3);
    // 10 samples of 100 ms each: the packet's data end 0.1 s after its start.
    let stamp = |p: &mut rockwatch_core::engine::AccelPacket, start: i64| p.start_time_ns = start;
    stamp(&mut packets[0], now_ns - 1_000_000_000); // ended 0.9 s ago: fine
    stamp(&mut packets[1], now_ns + 4_000_000_000); // ends 4.1 s ahead: within 5 s
    stamp(&mut packets[2], now_ns + 300_000_000_000_000_000); // 9.5 years ahead
    let mut publish = |_: Publication| {};
    for p in packets {
        node.submit(p, &mut publish);
    }
    let stopped = node.stop(&mut publish);
    assert_eq!(stopped.stats.future_packets, 1);
    assert_eq!(stopped.stats.packets, 2);
    let totals = stopped.input_totals();
    assert_eq!((totals.future_packets, totals.packets), (1, 2));

    // Offline runs (monitor) have no arrival clock: nothing is rejected for its stamp.
    let offline = NodeOptions {
        reject_future: false,
        ..options
    };
    let mut node = NodeRuntime::start(&offline).unwrap();
    let mut p = rinaldi_packets(10.0).remove(0);
    p.start_time_ns = now_ns + 300_000_000_000_000_000;
    node.submit(p, &mut publish);
    assert_eq!(node.stats().future_packets, 0);
}

/// Issue 19 §1: a station id is parsed once, at each transport's edge, by one function
/// (`engine::station_at_edge`), and the samples are checked once, by the engine. The same
/// packet with a malformed id, as iceoryx2 and as ROS 2 carry it, is refused the same by
/// both conversions, and the node counts and says both refusals the same; the same valid
/// packet over both is the same packet (so the engine judges its values the same).
#[test]
fn a_malformed_station_id_is_refused_the_same_over_iceoryx2_and_ros2() {
    use rockwatch::iox::{packet_from_wire, AccelHeader, AccelSample, WireError};
    use rockwatch::node::NoticeLog;
    use rockwatch::ros2::msg;
    use rockwatch_core::engine::AccelPacket;

    let good = rinaldi_packets(10.0).remove(0);
    let samples: Vec<AccelSample> = (0..good.len())
        .map(|i| AccelSample {
            east: good.east[i],
            north: good.north[i],
            up: good.up[i],
        })
        .collect();
    let over_iox = |header: &AccelHeader| packet_from_wire(header, &samples);
    let over_ros2 = |m: &msg::AccelPacket| AccelPacket::try_from(m);
    assert_eq!(
        over_iox(&AccelHeader::from_packet(&good)).unwrap(),
        over_ros2(&msg::AccelPacket::from(&good)).unwrap()
    );
    assert_eq!(over_ros2(&msg::AccelPacket::from(&good)).unwrap(), good);

    let malformed = "C-I.RRS.00";
    let mut header = AccelHeader::from_packet(&good);
    header.station = [0; 16];
    header.station[..malformed.len()].copy_from_slice(malformed.as_bytes());
    let refused_iox = match over_iox(&header) {
        Err(WireError::MalformedStation(refused)) => refused,
        other => panic!("iceoryx2 took {malformed:?} as {other:?}"),
    };
    let mut m = msg::AccelPacket::from(&good);
    m.header.frame_id = malformed.into();
    let refused_ros2 = over_ros2(&m).unwrap_err();
    assert_eq!(refused_iox, refused_ros2);
    assert_eq!(refused_iox.received, malformed);

    let options = NodeOptions {
        catalogue: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))),
        notices: NoticeLog::Counted { lines: 0 },
        ..NodeOptions::default()
    };
    let mut node = NodeRuntime::start(&options).unwrap();
    node.refuse_malformed(&refused_iox, None);
    node.refuse_malformed(&refused_ros2, None);
    let stopped = node.stop(&mut |_: Publication| {});
    let totals = stopped.input_totals();
    assert_eq!((totals.malformed_station_packets, totals.packets), (2, 0));
    assert_eq!(
        stopped.notice_counts,
        std::collections::BTreeMap::from([((malformed.to_string(), "rejected"), 2)])
    );
}

/// Set in the full-disk test re-executed in its own mount namespace.
const IN_MOUNT_NS: &str = "ROCKWATCH_TEST_IN_MOUNT_NS";

/// Runs the test `name` again in a private mount namespace (`unshare -m`: it may mount a
/// tmpfs; root, as in CI) and asserts it passed there; returns true when already inside it
/// (the caller then does the work).
fn reexec_in_mount_ns(name: &str) -> bool {
    if std::env::var_os(IN_MOUNT_NS).is_some() {
        return true;
    }
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new("timeout")
        .args([
            "-k",
            "5",
            "120",
            "unshare",
            "-m",
            "--propagation",
            "private",
        ])
        .arg(exe)
        .args(["--exact", name, "--nocapture", "--test-threads=1"])
        .env(IN_MOUNT_NS, "1")
        .output()
        .expect("runs timeout and unshare (coreutils, util-linux)");
    assert!(
        out.status.success() && String::from_utf8_lossy(&out.stdout).contains("1 passed"),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    false
}

/// Issue 11, finding 5: the node exited 1 at the first alert it could not journal. On a real
/// full file system (a 64 KiB tmpfs, mounted in a private mount namespace: needs root, as in
/// CI), the runtime now publishes every alert flagged `journal_pending`, counts the failures,
/// and journals everything, in order and without a torn line, once space returns.
#[test]
fn a_full_disk_degrades_the_node_and_the_journal_catches_up_when_space_returns() {
    if !reexec_in_mount_ns(
        "a_full_disk_degrades_the_node_and_the_journal_catches_up_when_space_returns",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mounted = std::process::Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
        .arg(dir.path())
        .status()
        .unwrap();
    assert!(mounted.success(), "mount tmpfs (root needed)");
    let state = dir.path().join("state");
    let options = NodeOptions {
        catalogue: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))),
        state_dir: Some(state.clone()),
        reject_future: false,
        ..NodeOptions::default()
    };
    let mut node = NodeRuntime::start(&options).unwrap();
    // Fill the file system: every page taken, the journal (empty) cannot grow.
    let filler = dir.path().join("filler");
    {
        use std::io::Write;
        let mut f = std::fs::File::create(&filler).unwrap();
        while f.write_all(&[0u8; 4096]).is_ok() {}
        while f.write_all(&[0u8; 1]).is_ok() {}
    }
    let mut alerts = Vec::new();
    let mut publish = |p: Publication| {
        if let Publication::Alert {
            alert,
            journal_pending,
            ..
        } = p
        {
            alerts.push((alert.key(), journal_pending));
        }
    };
    for packet in rinaldi_packets(10.0) {
        node.submit(packet, &mut publish);
    }
    let stats = node.stats();
    let mut keys: Vec<_> = alerts.iter().map(|(k, _)| k.clone()).collect();
    keys.sort();
    assert_eq!(keys, reference_alert_keys(), "every alert published");
    assert!(alerts.iter().all(|(_, pending)| *pending), "{alerts:?}");
    assert_eq!(stats.journal_pending_alerts as usize, alerts.len());
    assert!(stats.journal_failures >= alerts.len() as u64);
    assert!(stats.journal_backlog >= alerts.len() as u64);
    assert_eq!(read_journal(&state).unwrap().0.len(), 0);
    // Still full: a retry fails and keeps everything.
    node.retry_journal();
    assert_eq!(node.stats().journal_backlog, stats.journal_backlog);
    // Space returns.
    std::fs::remove_file(&filler).unwrap();
    node.retry_journal();
    assert_eq!(node.stats().journal_backlog, 0);
    let stopped = node.stop(&mut |_| {});
    assert_eq!(stopped.stats.journal_backlog, 0);
    let (records, report) = read_journal(&state).unwrap();
    assert!(
        report.corrupt_lines.is_empty() && !report.truncated_tail,
        "{report:?}"
    );
    let mut journaled: Vec<_> = records
        .iter()
        .filter_map(|r| match r {
            rockwatch_core::engine::JournalRecord::Alert(a) => Some(a.key()),
            _ => None,
        })
        .collect();
    // In the order they were raised (published).
    assert_eq!(
        journaled,
        alerts.iter().map(|(k, _)| k.clone()).collect::<Vec<_>>()
    );
    journaled.sort();
    assert_eq!(journaled, reference_alert_keys());
    let _ = std::process::Command::new("umount")
        .arg(dir.path())
        .status();
}

/// Issue 24 item 2: on a full disk a node with `[[notify]]` could not restart ("cannot open
/// its spool: …spool.tmp: No space left on device") and with no free inode no node started
/// ("journal.log: No space left on device"). Now it starts degraded: alerts published flagged
/// `journal_pending`, kept in memory, journaled once the directory has room; the spool is
/// appended to uncompacted. On a tmpfs with 8 inodes, in a private mount namespace (root).
#[test]
fn a_node_starts_on_a_full_disk_degraded_and_journals_once_there_is_room() {
    const NAME: &str = "a_node_starts_on_a_full_disk_degraded_and_journals_once_there_is_room";
    if !reexec_in_mount_ns(NAME) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let mounted = std::process::Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=256k,nr_inodes=16", "tmpfs"])
        .arg(dir.path())
        .status()
        .unwrap();
    assert!(mounted.success(), "mount tmpfs (root needed)");
    let state = dir.path().join("state");
    // A receiver with its spool (it exists: a restart must compact it into a new file).
    let notify: Vec<rockwatch::notify::NotifyConfig> =
        toml::from_str::<std::collections::BTreeMap<String, Vec<_>>>(
            "notify = [{ kind = \"exec\", command = [\"true\"] }]",
        )
        .unwrap()
        .remove("notify")
        .unwrap();
    rockwatch::notify::Notifier::start(&notify, Some(&state), &[])
        .unwrap()
        .shutdown(Duration::from_secs(5));
    // No inode left, and no byte: every new file fails, every write too.
    let mut fillers = Vec::new();
    for i in 0.. {
        let path = dir.path().join(format!("filler-{i}"));
        match std::fs::File::create(&path) {
            Ok(mut f) => {
                use std::io::Write;
                while f.write_all(&[0u8; 4096]).is_ok() {}
                while f.write_all(&[0u8; 1]).is_ok() {}
                fillers.push(path);
            }
            Err(_) => break,
        }
    }
    assert!(std::fs::File::create(dir.path().join("one-more")).is_err());
    // The receiver restarts: its spool is used as it is.
    rockwatch::notify::Notifier::start(&notify, Some(&state), &[])
        .expect("notify starts on a full disk")
        .shutdown(Duration::from_secs(5));
    // The node starts with no journal file (none can be created): degraded, not refused.
    let options = NodeOptions {
        catalogue: Some(PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/catalogue.toml"
        ))),
        state_dir: Some(state.clone()),
        reject_future: false,
        ..NodeOptions::default()
    };
    let mut node = NodeRuntime::start(&options).expect("the node starts on a full disk");
    // A second node is still refused (the directory's lock needs no inode).
    assert!(NodeRuntime::start(&options).is_err());
    let mut alerts = Vec::new();
    let mut publish = |p: Publication| {
        if let Publication::Alert {
            alert,
            journal_pending,
            ..
        } = p
        {
            alerts.push((alert.key(), journal_pending));
        }
    };
    for packet in rinaldi_packets(10.0) {
        node.submit(packet, &mut publish);
    }
    let mut keys: Vec<_> = alerts.iter().map(|(k, _)| k.clone()).collect();
    keys.sort();
    assert_eq!(keys, reference_alert_keys(), "every alert published");
    assert!(alerts.iter().all(|(_, pending)| *pending), "{alerts:?}");
    assert!(!state.join(rockwatch::journal::JOURNAL_FILE).exists());
    // Room again: the journal is created and takes every alert, in order.
    for f in &fillers {
        std::fs::remove_file(f).unwrap();
    }
    std::thread::sleep(Duration::from_millis(1100)); // the reopening is tried once a second
    node.retry_journal();
    assert_eq!(node.stats().journal_backlog, 0);
    node.stop(&mut |_| {});
    let (records, report) = read_journal(&state).unwrap();
    assert!(report.corrupt_lines.is_empty() && !report.truncated_tail);
    let mut journaled: Vec<_> = records
        .iter()
        .filter_map(|r| match r {
            rockwatch_core::engine::JournalRecord::Alert(a) => Some(a.key()),
            _ => None,
        })
        .collect();
    journaled.sort();
    assert_eq!(journaled, reference_alert_keys());
}
