//! End to end: an independent SeedLink server (`seedlink-rs-server` 0.4.0, in this process,
//! loopback) → `rockwatch acquire` (SeedLink v3, StationXML calibration, iceoryx2 or ROS 2) →
//! `rockwatch node` → the node's alert journal and its `/pbr/ims` station intensities,
//! compared with `rockwatch monitor --mseed FILE --stationxml FILE --format jsonl` on the same
//! data (its alerts, and its summary's last station intensity).
//!
//! The final CAV and Arias intensity are sums over every sample: a lost or doubled sample
//! changes them (one 250 Hz sample of this record moves CAV by ~1e-4 relative, far beyond the
//! 1e-9 allowed); the alerts' PGV and times check the same before each alert. Scenarios:
//! - `acquire` SIGKILLed mid-stream and restarted (resume from its state directory);
//! - the SeedLink server restarted mid-stream with a fresh ring whose sequence numbers start
//!   again (acquire reconnects, sees the new start time, resumes by time, drops duplicates);
//! - `acquire --to ros2` (ROS 2 `/pbr/accel` instead of iceoryx2);
//! - issue 20 item 12a: the records arriving channel by channel (a backfill, a scanned
//!   archive) on a server that, like ringserver, starts a plain `DATA` at its next record
//!   (`seedlink_server::hostile`'s ringserver model: no ringserver can be installed here):
//!   a fresh `acquire` backfills from the ring (`INFO STREAMS`, `TIME`), is SIGKILLed before
//!   anything could be published, and the restarted one resumes from the first record the
//!   killed one received — nothing lost, nothing zero-filled.
//!
//! Each test runs in its own network namespace (re-executed there: the node and this test's
//! `/pbr/ims` subscriber open DDS).
//!
//! Data: the K2 accelerograph counts of tests/data/mseed/k2_STNA_HN123_counts.mseed with the
//! ObsPy-written inventory tests/data/stationxml/obspy_XX.STN_k2.xml; blocks slender enough
//! for its ~0.05 m/s² to rock them, at several thresholds so alerts fall through the record.

use rockwatch_test_harness::netns::reexec_in_netns;

mod acquire_util;

use std::time::Duration;

use acquire_util::{latest_starts, Rig};
use rockwatch_core::record::mseed::record_stream_id;
use rockwatch_test_harness::seedlink_server::hostile::Hostile;
use rockwatch_test_harness::seedlink_server::{records_in_time_order, Server};

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scenario {
    /// iceoryx2; acquire SIGKILLed mid-stream and restarted.
    KillAcquire,
    /// iceoryx2; the server restarted mid-stream with a fresh ring.
    RestartServer,
    /// ROS 2 output, uninterrupted.
    Ros2,
}

fn run(scenario: Scenario) {
    let mut server = Server::start("127.0.0.1:0");
    let addr = server.addr;
    let mut rig = Rig::start(addr, "");
    let records = records_in_time_order();
    // 15 of 104 records (time order, ~3 records per second): about the first 5 s.
    let (third, half) = (10, 15);
    let to = if scenario == Scenario::Ros2 {
        "ros2"
    } else {
        "iceoryx2"
    };
    let running = match scenario {
        Scenario::KillAcquire => {
            server.push(&records[..half]);
            let first = rig.acquire(to);
            // Mid-stream: once something is committed, SIGKILL.
            rig.wait("acquire committed nothing", &|rig| {
                std::fs::read_to_string(rig.state_file()).is_ok_and(|t| t.contains("\"sequence\""))
            });
            first.kill();
            server.push(&records[half..]);
            rig.acquire(to)
        }
        Scenario::RestartServer => {
            server.push(&records[..half]);
            let first = rig.acquire(to);
            // Mid-stream: the first third published (the records after it may be held waiting
            // for their other components), then the server goes away.
            let want = latest_starts(&records[..third]);
            rig.wait(
                "acquire did not publish the first server's records",
                &|rig| {
                    let got = rig.committed();
                    want.iter().all(|(k, t)| got.get(k).is_some_and(|g| g >= t))
                },
            );
            server.stop();
            // Down longer than max_wait_s (3 s): the components held waiting for the others
            // must not be given up for missing (zero-filled) while nothing can be fetched.
            // Then a new start time (INFO ID `started` has one-second resolution) and a fresh
            // ring numbered from 1 holding records acquire has had (third..half) and new ones.
            std::thread::sleep(Duration::from_millis(4500));
            server = Server::start(&addr.to_string());
            server.push(&records[third..]);
            first
        }
        Scenario::Ros2 => {
            server.push(&records);
            rig.acquire(to)
        }
    };
    let acquire_logs = rig.finish(running, Duration::from_secs(90), &format!("{scenario:?}"));
    server.stop();
    if scenario == Scenario::RestartServer {
        assert!(
            acquire_logs.contains("the server restarted"),
            "the restart must be detected\n{acquire_logs}"
        );
        // Issue 20 item 4: acquire says where it is — the reconnection, and each stream's
        // resume point after it.
        assert!(
            acquire_logs.contains("connected (connection 2), SeedLink 3"),
            "{acquire_logs}"
        );
    }
    // Issue 20 item 4: connecting, the protocol, each stream and where it resumes.
    assert!(
        acquire_logs.contains("connecting")
            && acquire_logs.contains("connected (connection 1), SeedLink 3")
            && acquire_logs.contains("requesting 1 stream(s): XX.STN..HN? from the next record"),
        "{acquire_logs}"
    );
    if scenario == Scenario::KillAcquire {
        // The restarted acquire resumes each station after the last record it published.
        assert!(
            acquire_logs.contains("XX.STN..HN? after sequence number "),
            "{acquire_logs}"
        );
    }
}

/// Issue 20 item 12a: the K2 file's records channel by channel (HN1's ~35 s, then HN2's, then
/// HN3's) in a ringserver-like ring. The first `acquire` starts with no state and gets HN1 —
/// from the ring by backfill (`backfill`: HN1 is in the ring before it starts; ringserver's
/// plain `DATA` would send none of it), or live (`backfill_s = 0`, HN1 pushed once it is
/// connected) — and is SIGKILLed before anything can be published (HN2 and HN3 missing;
/// `max_wait_s` is 3 s). The restarted `acquire` resumes from the first record the killed
/// one received, then HN2 and HN3 arrive: the node's alerts and final intensity equal
/// `monitor`'s, nothing zero-filled. Before the fix the restarted `acquire` of the live case
/// started at the server's next record, lost HN1 and zero-filled it; the backfill case
/// received nothing at all.
fn run_channel_by_channel(backfill: bool) {
    let server = Hostile::start_like_ringserver();
    let mut rig = Rig::start(server.addr, if backfill { "" } else { "backfill_s = 0" });
    let mut records = records_in_time_order();
    records.sort_by_key(|r| record_stream_id(r).unwrap_or_default());
    let hn1 = records
        .iter()
        .take_while(|r| record_stream_id(r).is_some_and(|id| id.ends_with("HN1")))
        .count();
    assert!(hn1 > 10 && hn1 < records.len(), "{hn1} HN1 records");
    // Waits until the `n`-th acquire has made its request (the server starts a plain
    // `DATA` there), so that records pushed after it arrive live.
    let requested = |rig: &mut Rig, n: usize| {
        rig.wait("acquire did not request the station", &|rig| {
            rig.acquire_logs().matches("requesting 1 stream(s)").count() >= n
        });
        std::thread::sleep(Duration::from_millis(300));
    };
    let first = if backfill {
        server.push(&records[..hn1]);
        rig.acquire("iceoryx2")
    } else {
        let first = rig.acquire("iceoryx2");
        requested(&mut rig, 1);
        server.push(&records[..hn1]);
        first
    };
    rig.wait("the server sent acquire none of HN1", &|_| {
        server.sent() >= hn1
    });
    // Time to save the state of the batch (saved after every batch), far below max_wait_s.
    std::thread::sleep(Duration::from_millis(500));
    first.kill();
    assert!(
        rig.committed().is_empty(),
        "nothing can have been published with HN2 and HN3 missing{}",
        rig.logs("")
    );
    // HN2 and HN3 arrive after the restart, as the rest of a backfill does.
    let running = rig.acquire("iceoryx2");
    requested(&mut rig, 2);
    server.push(&records[hn1..]);
    let scenario = if backfill {
        "ChannelByChannelBackfill"
    } else {
        "ChannelByChannelLive"
    };
    let logs = rig.finish(running, Duration::from_secs(90), scenario);
    // The restarted acquire resumed from the first record received (by time: nothing was
    // committed), not from the server's next record, and zero-filled nothing.
    assert!(
        logs.contains("requesting 1 stream(s): XX.STN..HN? from 2002-07-22T04:46:49"),
        "{logs}"
    );
    assert!(
        logs.contains(" 0 missing-component samples zero-filled"),
        "{logs}"
    );
    if backfill {
        // The fresh acquire backfilled from the ring's newest data.
        assert!(
            logs.contains("station XX_STN has no resume point: backfilling 300 s before the newest data the server holds of its streams"),
            "{logs}"
        );
    }
    server.stop();
}

#[test]
fn alerts_and_intensities_equal_monitor_with_records_channel_by_channel_backfilled_and_a_sigkill() {
    if reexec_in_netns(
        "alerts_and_intensities_equal_monitor_with_records_channel_by_channel_backfilled_and_a_sigkill",
        240,
    ) {
        run_channel_by_channel(true);
    }
}

#[test]
fn alerts_and_intensities_equal_monitor_with_records_channel_by_channel_live_and_a_sigkill() {
    if reexec_in_netns(
        "alerts_and_intensities_equal_monitor_with_records_channel_by_channel_live_and_a_sigkill",
        240,
    ) {
        run_channel_by_channel(false);
    }
}

#[test]
fn alerts_and_intensities_equal_monitor_across_a_sigkill_of_acquire() {
    if reexec_in_netns(
        "alerts_and_intensities_equal_monitor_across_a_sigkill_of_acquire",
        240,
    ) {
        run(Scenario::KillAcquire);
    }
}

#[test]
fn alerts_and_intensities_equal_monitor_across_a_restart_of_the_server() {
    if reexec_in_netns(
        "alerts_and_intensities_equal_monitor_across_a_restart_of_the_server",
        240,
    ) {
        run(Scenario::RestartServer);
    }
}

#[test]
fn alerts_and_intensities_equal_monitor_with_acquire_to_ros2() {
    if reexec_in_netns(
        "alerts_and_intensities_equal_monitor_with_acquire_to_ros2",
        240,
    ) {
        run(Scenario::Ros2);
    }
}
