//! Issue 23 and issue 24 item 1: one bad record, or one odd sequence number, must not stall a
//! station. A hostile SeedLink server (`seedlink_server::hostile`, loopback) streams the K2
//! station's clean records with one fault put among them; `rockwatch acquire` → `rockwatch
//! node`, and the node's alerts and final station intensity must equal `rockwatch monitor` on
//! the clean data (`acquire_util::Rig`, the comparison of tests/acquire_e2e.rs) — every fault
//! alone, and with `acquire` SIGKILLed and restarted after the fault. The faults are
//! additions: every clean record is still sent, so nothing may be lost.
//!
//! - `OtherRate`: a copy of the next record claiming 200× its rate, just before it;
//! - `ResentFarAheadThenHang`: the last record sent again under a number 500 000 ahead, then
//!   the connection hangs (alone only: a duplicate);
//! - `NextFarAheadThenHang`, `NextFarAheadThenClose`: the next record sent first under a
//!   number 500 000 ahead, then the connection hangs or closes (the clean copy follows,
//!   numbered on, and the server resends the copy too on a resume before its number);
//! - `HugeValuesFarAhead`: a FLOAT32 record of 1e30 at the next record's time, numbered 500 000
//!   ahead;
//! - `FarFuture`: a copy of the next record stamped in the year 2100 (a GPS glitch);
//! - `SampleCount65535`, `YearZero`, `CorruptSteim`: a copy of the next record whose header
//!   claims 65535 samples, that starts in the year 0, or whose Steim frame's integration
//!   constant is wrong (undecodable: `malformed`);
//! - `NanSamples`: a FLOAT32 record of NaN at the next record's time (undecodable);
//! - `UnknownLocation`: a copy of the next record under location `99` (a stream no pattern
//!   selects and the inventory does not hold: `unselected`).
//!
//! Faults of the connection rather than of a record — `Garbage` (text in place of a packet),
//! `HugeLength` (a SeedLink 4 header claiming a 2^31-byte payload), `UnreadableSequence` (a
//! v3 header whose number is not hex, on every connection: the record's only copy),
//! `HangMidPacket`, `CloseMidPacket` (100 bytes of a packet, then silence or a close) — decide
//! only which records reach the assembler, so they run against the client and `acquire`'s
//! publisher in this process (no node; [`run_link`]): every record delivered, none twice,
//! nothing published twice across a restart, the fault's log line, its counter in
//! `acquire_prometheus` (the `/metrics` text) and in `acquire_summary` (the end-of-run line).
//!
//! Each test also checks acquire's log line naming the station and the fault, and (without a
//! restart, where acquire sees the fault and runs to its end) its end-of-run summary and the
//! fault's counter on acquire's `/metrics`. `OtherRate` alone also runs `acquire --to ros2`
//! with an independent ROS 2 peer (rclpy, [`DiagnosticsPeer`]) on `/diagnostics`: the refusal
//! is counted on the station's item (WARN in the report that sees it), the station recovers
//! (OK, every later record taken), and the link and publication items are there. The
//! client alone is tested below against the same server: a jump is never the resume point,
//! a resume by number that yields nothing falls back to time, refused records are never
//! delivered or saved. Tests run one at a time (each in its own network namespace), so the
//! scenarios do not compete for the 2 cores.

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::netns::reexec_in_netns;
use rockwatch_test_harness::peers::peer_available;

mod acquire_util;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

use rockwatch::acquire::{acquire_prometheus, acquire_summary, ClippingSection, PacketPublisher};
use rockwatch::ports::PacketSink;
use rockwatch::seedlink::{
    LinkCounters, ProtocolChoice, RecordSink, SeedLinkClient, SeedLinkConfig, Taken,
};
use rockwatch_core::assembly::{AssemblyConfig, AssemblyCounters};
use rockwatch_core::engine::AccelPacket;
use rockwatch_core::inventory::Inventory;
use rockwatch_core::record::mseed::{parse_mseed, Channel};
use rockwatch_core::utc::format_utc_ns;

use acquire_util::{latest_starts, Rig};
use rockwatch_test_harness::seedlink_server::hostile::{
    at_other_rate, in_year, with_corrupt_steim, with_location, with_nan, with_sample_count,
    with_values, Conn, Hostile,
};
use rockwatch_test_harness::seedlink_server::records_in_time_order;

/// At most [`AT_ONCE`] scenarios at a time (the outer test processes wait here for their
/// namespace's run). Each scenario is its own process in its own network namespace, with
/// iceoryx2 services named by that process's id, so scenarios do not meet; they mostly wait
/// (on the server's pace and acquire's timeouts), so two share the two cores of CI.
static RUNNING: (Mutex<usize>, Condvar) = (Mutex::new(0), Condvar::new());
const AT_ONCE: usize = 2;

/// A place among the [`AT_ONCE`] running scenarios, given back when dropped.
struct Slot;

impl Slot {
    fn take() -> Slot {
        let (count, freed) = &RUNNING;
        let mut running = count.lock().unwrap_or_else(|e| e.into_inner());
        while *running >= AT_ONCE {
            running = freed.wait(running).unwrap_or_else(|e| e.into_inner());
        }
        *running += 1;
        Slot
    }
}

impl Drop for Slot {
    fn drop(&mut self) {
        let (count, freed) = &RUNNING;
        *count.lock().unwrap_or_else(|e| e.into_inner()) -= 1;
        freed.notify_one();
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Fault {
    OtherRate,
    ResentFarAheadThenHang,
    NextFarAheadThenHang,
    NextFarAheadThenClose,
    HugeValuesFarAhead,
    FarFuture,
    SampleCount65535,
    YearZero,
    UnknownLocation,
    CorruptSteim,
    NanSamples,
    // Faults of the connection ([`run_link`]).
    Garbage,
    HugeLength,
    UnreadableSequence,
    HangMidPacket,
    CloseMidPacket,
}

impl Fault {
    /// A fault of the connection (run against the client and publisher, no node).
    fn of_the_link(self) -> bool {
        matches!(
            self,
            Fault::Garbage
                | Fault::HugeLength
                | Fault::UnreadableSequence
                | Fault::HangMidPacket
                | Fault::CloseMidPacket
        )
    }
}

/// Where the fault goes: before record 30 of the 104 (about 3 s into the data).
const AT: usize = 30;
/// "Far ahead" for a sequence number.
const FAR: u64 = 500_000;

/// The log line of an undecodable copy of record `AT` (packet 31).
const UNDECODABLE: &str =
    "station XX.STN..HN3: packet 31: record dropped, it cannot be decoded: record 1 at byte 0: ";

/// What acquire's log must say: a line naming the station and the fault (every part), and
/// (when acquire ran to its end with the fault in its run) its end-of-run summary.
fn expected_lines(fault: Fault) -> (&'static [&'static str], &'static str) {
    match fault {
        Fault::OtherRate => (
            &["station XX.STN.: XX.STN..HN3: 50000 Hz, but the station is assembled at 250 Hz"],
            "records refused (1 at another sampling rate",
        ),
        Fault::ResentFarAheadThenHang => {
            (&["timeout: no packet for 2 s"], "104 records delivered (")
        }
        Fault::NextFarAheadThenHang | Fault::NextFarAheadThenClose => (
            &["station XX_STN: sequence number"],
            "1 sequence numbers out of line",
        ),
        Fault::HugeValuesFarAhead => (
            &["station XX.STN.: XX.STN..HN3: impossible sample values"],
            "records refused (0 at another sampling rate, 1 with impossible values",
        ),
        Fault::FarFuture => (
            &["station XX.STN.: XX.STN..HN3: record starts"],
            "1 far ahead of their station's data",
        ),
        Fault::SampleCount65535 => (
            &[UNDECODABLE, "XX.STN..HN3: Steim-2: header says 65535 samples"],
            ", 1 malformed, ",
        ),
        Fault::YearZero => (
            &[UNDECODABLE, "invalid start time: year/day of year 0/"],
            ", 1 malformed, ",
        ),
        Fault::CorruptSteim => (
            &[UNDECODABLE, "XX.STN..HN3: Steim-2 integrity check failed"],
            ", 1 malformed, ",
        ),
        Fault::NanSamples => (
            &[UNDECODABLE, "XX.STN..HN3: sample 0 is NaN (not a finite number)"],
            ", 1 malformed, ",
        ),
        Fault::UnknownLocation => (
            &[
                "XX.STN.99.HN3: unselected: ",
                "stream not selected by any pattern; dropped",
            ],
            ", 1 unselected, ",
        ),
        Fault::Garbage => (
            &[
                "protocol error: not a SeedLink V3 packet: starts with \"<html><body>502 \"",
                "after station XX_STN's packet 30; counted: dropping the connection",
            ],
            ", 1 packets not framed as the protocol says, ",
        ),
        Fault::HugeLength => (
            &[
                "protocol error: v4 payload of 2147483648 bytes is more than the 1048576 accepted",
                "after station XX_STN's packet 30; counted: dropping the connection",
            ],
            ", 1 packets not framed as the protocol says, ",
        ),
        Fault::UnreadableSequence => (
            &["XX_STN: unreadable sequence: ", "station XX_STN: packet with the unreadable number \"zz!?00\": its record XX.STN..HN3 goes by its start time"],
            ", 1 unreadable sequence numbers (delivered by start time), ",
        ),
        Fault::HangMidPacket => (
            &["timeout: no packet for 2 s in the middle of a packet (100 bytes of it received, dropped; after station XX_STN's packet 30; counted)"],
            ", 1 packets cut off by the end of a connection, ",
        ),
        Fault::CloseMidPacket => (
            &["the server closed the connection in the middle of a packet (100 bytes of it received, dropped; after station XX_STN's packet 30; counted)"],
            ", 1 packets cut off by the end of a connection, ",
        ),
    }
}

/// The line of acquire's `/metrics` that counts the fault (`None`: the fault has no counter of
/// its own: a re-sent record is a duplicate like any other).
fn expected_metric(fault: Fault) -> Option<&'static str> {
    match fault {
        Fault::OtherRate => {
            Some("rockwatch_acquire_records_refused_total{reason=\"other_rate\"} 1\n")
        }
        Fault::HugeValuesFarAhead => {
            Some("rockwatch_acquire_records_refused_total{reason=\"impossible_values\"} 1\n")
        }
        Fault::FarFuture => {
            Some("rockwatch_acquire_records_refused_total{reason=\"far_ahead\"} 1\n")
        }
        Fault::NextFarAheadThenHang | Fault::NextFarAheadThenClose => {
            Some("rockwatch_acquire_link_sequence_outliers_total 1\n")
        }
        Fault::SampleCount65535 | Fault::YearZero | Fault::CorruptSteim | Fault::NanSamples => {
            Some("rockwatch_acquire_link_malformed_total 1\n")
        }
        Fault::UnknownLocation => Some("rockwatch_acquire_link_unselected_total 1\n"),
        Fault::Garbage | Fault::HugeLength => {
            Some("rockwatch_acquire_link_protocol_errors_total 1\n")
        }
        Fault::UnreadableSequence => Some("rockwatch_acquire_link_unreadable_sequences_total 1\n"),
        Fault::HangMidPacket | Fault::CloseMidPacket => {
            Some("rockwatch_acquire_link_partial_packets_total 1\n")
        }
        Fault::ResentFarAheadThenHang => None,
    }
}

/// `GET /metrics` of acquire (its `[metrics]` listen address in the Rig's configuration).
fn scrape() -> String {
    use std::io::{Read, Write};
    let Ok(mut s) = std::net::TcpStream::connect(acquire_util::ACQUIRE_METRICS) else {
        return String::new();
    };
    let _ = s.write_all(b"GET /metrics HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    let mut reply = String::new();
    let _ = s.read_to_string(&mut reply);
    reply
}

/// The independent ROS 2 peer of acquire's `/diagnostics`: tests/data/ros2/rclpy_status.py
/// `--diagnostics-only` (rclpy with Fast DDS and diagnostic_msgs, PyPI wheels; loopback in the
/// test's network namespace), printing every `DiagnosticArray` received as one JSON line.
struct DiagnosticsPeer {
    child: std::process::Child,
    out: PathBuf,
    err: PathBuf,
    _dir: tempfile::TempDir,
}

/// The prefix of acquire's items on `/diagnostics` (diagnostic_updater's `<program>: <item>`).
const ACQUIRE_ITEM: &str = "rockwatch acquire: ";

/// One DiagnosticArray of acquire as the peer decoded it: item name (without the prefix) →
/// `{level, name, message, hardware_id, values: {key: value}}`.
type Report = serde_json::Map<String, serde_json::Value>;

impl DiagnosticsPeer {
    /// Starts the peer; `None` (the check skipped) without rclpy and diagnostic_msgs, except
    /// under `CI=true` (a failure: .ci/run installs them).
    fn start() -> Option<DiagnosticsPeer> {
        let ok = Command::new("python3")
            .args(["-c", "import rclpy, diagnostic_msgs.msg"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if !peer_available(
            ok,
            "python3 with ros-rclpy[fastrtps] and ros-diagnostic-msgs",
            "see .ci/run",
        ) {
            return None;
        }
        let dir = tempfile::tempdir().unwrap();
        let (out, err) = (dir.path().join("peer.out"), dir.path().join("peer.err"));
        let child = Command::new("python3")
            .arg(repo().join("tests/data/ros2/rclpy_status.py"))
            .args(["--seconds", "200", "--diagnostics-only"])
            .stdout(std::fs::File::create(&out).unwrap())
            .stderr(std::fs::File::create(&err).unwrap())
            .spawn()
            .unwrap();
        Some(DiagnosticsPeer {
            child,
            out,
            err,
            _dir: dir,
        })
    }

    /// Acquire's reports received so far, in order (arrays without an acquire item, e.g. the
    /// node's, left out).
    fn reports(&self) -> Vec<Report> {
        std::fs::read_to_string(&self.out)
            .unwrap_or_default()
            .lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter_map(|m| {
                let items: Report = m["diagnostics"]
                    .as_array()?
                    .iter()
                    .filter_map(|s| {
                        let name = s["name"].as_str()?.strip_prefix(ACQUIRE_ITEM)?;
                        Some((name.to_string(), s.clone()))
                    })
                    .collect();
                (!items.is_empty()).then_some(items)
            })
            .collect()
    }

    /// Stops the peer (what it received is already written, a line per message); its stderr.
    fn stop(&mut self) -> String {
        let _ = self.child.kill();
        let _ = self.child.wait();
        std::fs::read_to_string(&self.err).unwrap_or_default()
    }
}

impl Drop for DiagnosticsPeer {
    fn drop(&mut self) {
        self.stop();
    }
}

/// What the peer must have seen of acquire's status, with one record at another rate among
/// `records` (all sent): the refusal counted once on the station's item, WARN in the report
/// that saw it; then the station OK again with the refusal still counted and its last record
/// the data's last; the link connected to `server`; the publication item counting it too.
fn check_diagnostics(peer: &mut DiagnosticsPeer, records: &[Vec<u8>], server: &str) {
    let reports = peer.reports();
    let peer_err = peer.stop();
    let context = format!(
        "\n--- acquire's items as the rclpy peer received them ({} reports)\n{}\n--- peer stderr\n{peer_err}",
        reports.len(),
        reports
            .iter()
            .map(|r| serde_json::Value::Object(r.clone()).to_string())
            .collect::<Vec<_>>()
            .join("\n")
    );
    let station = "station XX.STN.";
    let value =
        |item: &serde_json::Value, key: &str| item["values"][key].as_str().map(String::from);
    // The refused record is counted once, and never again.
    let counts: Vec<String> = reports
        .iter()
        .filter_map(|r| value(r.get(station)?, "records_refused_other_rate"))
        .collect();
    assert!(
        counts.iter().all(|c| c == "0" || c == "1") && counts.last().is_some_and(|c| c == "1"),
        "records_refused_other_rate of {station}: {counts:?}{context}"
    );
    let warned = reports
        .iter()
        .position(|r| {
            r.get(station).is_some_and(|s| {
                s["level"] == 1 && value(s, "records_refused_other_rate").as_deref() == Some("1")
            })
        })
        .unwrap_or_else(|| panic!("no WARN report of {station} counting the refusal{context}"));
    let warn = &reports[warned][station];
    assert_eq!(warn["hardware_id"], "XX.STN.", "{warn}");
    assert!(
        warn["message"]
            .as_str()
            .is_some_and(|m| m.contains("1 at another sampling rate")),
        "{warn}"
    );
    // Recovered: OK again, the refusal still counted, every record up to the data's last taken.
    let recovered = reports[warned..]
        .iter()
        .filter_map(|r| r.get(station))
        .find(|s| s["level"] == 0)
        .unwrap_or_else(|| panic!("{station} never OK again after the refusal{context}"));
    assert_eq!(
        value(recovered, "records_refused_other_rate").as_deref(),
        Some("1"),
        "{recovered}"
    );
    let last_start = acquire_util::latest_starts(records)
        .into_values()
        .max()
        .unwrap();
    let last = reports.last().unwrap();
    let final_station = &last[station];
    assert_eq!(
        (
            final_station["level"].clone(),
            value(final_station, "last_record_time")
        ),
        (0.into(), Some(format_utc_ns(i128::from(last_start)))),
        "{final_station}{context}"
    );
    // The link: OK while connected, WARN while reconnecting (the idle timeout of 2 s ends
    // connections that have nothing more to send).
    for link in reports.iter().filter_map(|r| r.get("link")) {
        assert_eq!(link["hardware_id"], server, "{link}");
        let state = value(link, "state").unwrap_or_default();
        assert!(
            (state == "connected" && link["level"] == 0)
                || (state == "reconnecting" && link["level"] == 1),
            "{link}{context}"
        );
    }
    assert!(
        reports[warned..]
            .iter()
            .any(|r| value(&r["link"], "state").as_deref() == Some("connected")),
        "{context}"
    );
    let publication = &last["publication"];
    println!(
        "acquire's /diagnostics, as the rclpy peer received them: {} reports; the refusal: {warn}; recovered: {recovered}; last: {}",
        reports.len(),
        serde_json::Value::Object(last.clone())
    );
    assert_eq!(
        value(publication, "records_refused_other_rate").as_deref(),
        Some("1"),
        "{publication}"
    );
    assert!(
        value(publication, "packets_published").is_some_and(|p| p != "0"),
        "{publication}"
    );
}

fn run(fault: Fault, restart: bool) {
    let server = Hostile::start();
    let mut rig = Rig::start(server.addr, "idle_timeout_s = 2.0");
    let records = records_in_time_order();
    // acquire's /diagnostics (issue 23), checked on one fault: acquire publishes over ROS 2
    // and starts before the ring holds anything, so the peer hears it before the fault comes.
    let mut peer = (fault == Fault::OtherRate && !restart)
        .then(DiagnosticsPeer::start)
        .flatten();
    let early = peer.as_ref().map(|peer| {
        let running = rig.acquire("ros2");
        rig.wait(
            "the rclpy peer never received acquire's /diagnostics",
            &|_| !peer.reports().is_empty(),
        );
        running
    });
    server.push(&records[..AT]);
    let far = server.next_seq() + FAR;
    match fault {
        Fault::OtherRate => server.push(&[at_other_rate(&records[AT], 200)]),
        Fault::ResentFarAheadThenHang => {
            server.push_with_seq(&records[AT - 1], far);
            server.plan(&[Conn::HangAfter(AT + 1)]);
        }
        Fault::NextFarAheadThenHang => {
            server.push_with_seq(&records[AT], far);
            server.plan(&[Conn::HangAfter(AT + 1)]);
        }
        Fault::NextFarAheadThenClose => {
            server.push_with_seq(&records[AT], far);
            server.plan(&[Conn::CloseAfter(AT + 1)]);
        }
        Fault::HugeValuesFarAhead => server.push_with_seq(&with_values(&records[AT], 1e30), far),
        Fault::FarFuture => server.push(&[in_year(&records[AT], 2100)]),
        Fault::SampleCount65535 => server.push(&[with_sample_count(&records[AT], 65535)]),
        Fault::YearZero => server.push(&[in_year(&records[AT], 0)]),
        Fault::UnknownLocation => server.push(&[with_location(&records[AT], "99")]),
        Fault::CorruptSteim => server.push(&[with_corrupt_steim(&records[AT])]),
        Fault::NanSamples => server.push(&[with_nan(&records[AT])]),
        link => unreachable!("{link:?} runs in run_link"),
    }
    let scenario = format!("{fault:?}{}", if restart { " + restart" } else { "" });
    let mut running;
    if restart {
        // The ring up to a little after the fault; once records past it are committed and the
        // fault is in acquire's log, SIGKILL; the rest of the data; acquire again. (The log is
        // written from a queue by a thread of its own: a line still queued when SIGKILL comes
        // is lost, so the commit alone does not mean the line was written.)
        server.push(&records[AT..AT + 12]);
        running = rig.acquire("iceoryx2");
        let want = latest_starts(&records[..AT + 9]);
        let (fault_lines, _) = expected_lines(fault);
        rig.wait("acquire did not commit past the fault and log it", &|rig| {
            let got = rig.committed();
            let logs = rig.acquire_logs();
            want.iter().all(|(k, t)| got.get(k).is_some_and(|g| g >= t))
                && fault_lines.iter().all(|line| logs.contains(line))
        });
        running.kill();
        server.push(&records[AT + 12..]);
        running = rig.acquire("iceoryx2");
    } else {
        server.push(&records[AT..]);
        running = early.unwrap_or_else(|| rig.acquire("iceoryx2"));
        // The fault is counted on acquire's /metrics while it runs.
        if let Some(metric) = expected_metric(fault) {
            rig.wait(
                &format!("acquire's /metrics never said {metric:?}"),
                &|_| scrape().contains(metric),
            );
        }
    }
    let logs = rig.finish(running, Duration::from_secs(60), &scenario);
    server.stop();
    let (lines, summary) = expected_lines(fault);
    for line in lines {
        assert!(
            logs.contains(line),
            "{scenario}: acquire's log must say {line:?}:\n{logs}"
        );
    }
    if !restart {
        assert!(
            logs.contains(summary),
            "{scenario}: acquire's summary must say {summary:?}:\n{logs}"
        );
    }
    if let Some(peer) = &mut peer {
        check_diagnostics(peer, &records, &server.addr.to_string());
    }
}

fn scenario(name: &str, fault: Fault, restart: bool) {
    let _slot = Slot::take();
    if reexec_in_netns(name, 240) {
        if fault.of_the_link() {
            run_link(fault, restart);
        } else {
            run(fault, restart);
        }
    }
}

#[test]
fn a_record_at_another_rate_costs_nothing_of_the_clean_data() {
    scenario(
        "a_record_at_another_rate_costs_nothing_of_the_clean_data",
        Fault::OtherRate,
        false,
    );
}

#[test]
fn a_record_at_another_rate_then_a_restart_of_acquire_costs_nothing() {
    scenario(
        "a_record_at_another_rate_then_a_restart_of_acquire_costs_nothing",
        Fault::OtherRate,
        true,
    );
}

#[test]
fn a_duplicate_numbered_far_ahead_then_a_hang_does_not_move_the_resume_point() {
    scenario(
        "a_duplicate_numbered_far_ahead_then_a_hang_does_not_move_the_resume_point",
        Fault::ResentFarAheadThenHang,
        false,
    );
}

#[test]
fn a_record_numbered_far_ahead_then_a_hang_is_one_odd_number_not_a_resume_point() {
    scenario(
        "a_record_numbered_far_ahead_then_a_hang_is_one_odd_number_not_a_resume_point",
        Fault::NextFarAheadThenHang,
        false,
    );
}

#[test]
fn a_record_numbered_far_ahead_then_a_hang_and_a_restart_of_acquire() {
    scenario(
        "a_record_numbered_far_ahead_then_a_hang_and_a_restart_of_acquire",
        Fault::NextFarAheadThenHang,
        true,
    );
}

#[test]
fn a_record_numbered_far_ahead_then_a_close_is_one_odd_number_not_a_resume_point() {
    scenario(
        "a_record_numbered_far_ahead_then_a_close_is_one_odd_number_not_a_resume_point",
        Fault::NextFarAheadThenClose,
        false,
    );
}

#[test]
fn a_record_numbered_far_ahead_then_a_close_and_a_restart_of_acquire() {
    scenario(
        "a_record_numbered_far_ahead_then_a_close_and_a_restart_of_acquire",
        Fault::NextFarAheadThenClose,
        true,
    );
}

#[test]
fn impossible_values_numbered_far_ahead_are_refused_and_not_a_server_restart() {
    scenario(
        "impossible_values_numbered_far_ahead_are_refused_and_not_a_server_restart",
        Fault::HugeValuesFarAhead,
        false,
    );
}

#[test]
fn impossible_values_numbered_far_ahead_then_a_restart_of_acquire() {
    scenario(
        "impossible_values_numbered_far_ahead_then_a_restart_of_acquire",
        Fault::HugeValuesFarAhead,
        true,
    );
}

#[test]
fn a_far_future_record_costs_nothing() {
    scenario("a_far_future_record_costs_nothing", Fault::FarFuture, false);
}

#[test]
fn a_far_future_record_is_never_a_resume_point_across_a_restart_of_acquire() {
    scenario(
        "a_far_future_record_is_never_a_resume_point_across_a_restart_of_acquire",
        Fault::FarFuture,
        true,
    );
}

// ---- The SeedLink client alone against the hostile server (loopback, no node) ----

/// A client of `server` for XX.STN..HN? (`protocol`, idle timeout 2 s, reconnecting after
/// 0.2 s).
fn client(server: &Hostile, state: &Path, protocol: ProtocolChoice) -> SeedLinkClient {
    let config = SeedLinkConfig {
        server: server.addr.to_string(),
        streams: vec!["XX.STN..HN?".into()],
        protocol,
        connect_timeout_s: 5.0,
        idle_timeout_s: 2.0,
        reconnect_initial_s: 0.2,
        reconnect_max_s: 0.5,
        station_refresh_s: 300.0,
        backfill_s: 300.0,
    };
    SeedLinkClient::new(config, Some(state)).unwrap()
}

/// The (stream, start) of every record.
fn keys(records: &[Vec<u8>]) -> BTreeSet<(String, i64)> {
    records
        .iter()
        .map(|r| {
            let c = parse_mseed(r, Path::new("r")).unwrap().channels.remove(0);
            (c.id(), c.start_time_ns)
        })
        .collect()
}

fn run_until(
    client: &mut SeedLinkClient,
    want: BTreeSet<(String, i64)>,
) -> (Vec<(String, i64)>, LinkCounters) {
    let stop = AtomicBool::new(false);
    let mut sink = Watch {
        inner: None,
        want,
        got: Vec::new(),
        stop: &stop,
        deadline: Instant::now() + Duration::from_secs(30),
    };
    client.run(&stop, &mut sink).unwrap();
    (sink.got, client.counters())
}

fn client_scenario(name: &str, body: fn()) {
    let _slot = Slot::take();
    if reexec_in_netns(name, 120) {
        body();
    }
}

#[test]
fn a_number_far_ahead_that_nothing_followed_is_never_the_resume_point() {
    client_scenario(
        "a_number_far_ahead_that_nothing_followed_is_never_the_resume_point",
        || {
            let server = Hostile::start();
            let records = records_in_time_order();
            server.push(&records[..10]);
            // The next record first under a number far ahead, then the connection closes;
            // the clean copy comes next, numbered on (11, 12, …).
            server.push_with_seq(&records[10], server.next_seq() + FAR);
            server.plan(&[Conn::CloseAfter(11)]);
            server.push(&records[10..]);
            let dir = tempfile::tempdir().unwrap();
            let mut c = client(&server, dir.path(), ProtocolChoice::V3);
            let (got, counters) = run_until(&mut c, keys(&records));
            let unique: BTreeSet<_> = got.iter().cloned().collect();
            assert_eq!(
                (unique.len(), got.len()),
                (104, 104),
                "every record once; commands {:?}; {counters:?}",
                server.commands()
            );
            // The second connection resumed from the last number in line, not the jump.
            assert!(
                server.commands().contains(&"DATA 00000A".to_string()),
                "{:?}",
                server.commands()
            );
            assert_eq!(counters.sequence_outliers, 1, "{counters:?}");
            assert_eq!(counters.server_resets, 0, "{counters:?}");
            // The resume point is the last real number (104 records numbered 1..=104).
            assert_eq!(c.state().stations["XX_STN"].sequence, 104);
        },
    );
}

#[test]
fn a_resume_by_number_that_yields_nothing_falls_back_to_time() {
    client_scenario(
        "a_resume_by_number_that_yields_nothing_falls_back_to_time",
        || {
            let server = Hostile::start();
            let records = records_in_time_order();
            server.push(&records);
            // A state saved with a number the server does not hold (as a jump saved by an
            // older acquire would be), the streams delivered up to record 20.
            let dir = tempfile::tempdir().unwrap();
            let latest = acquire_util::latest_starts(&records[..21]);
            let state = serde_json::json!({
                "server": server.addr.to_string(),
                "server_started": null,
                "stations": {"XX_STN": {"sequence": 600_000, "protocol": "V3"}},
                "streams": latest,
            });
            std::fs::write(
                dir.path().join(format!(
                    "seedlink-{}.json",
                    server.addr.to_string().replace(':', "_")
                )),
                state.to_string(),
            )
            .unwrap();
            let mut c = client(&server, dir.path(), ProtocolChoice::V3);
            let (got, counters) = run_until(&mut c, keys(&records[21..]));
            let unique: BTreeSet<_> = got.iter().cloned().collect();
            assert!(
                keys(&records[21..]).is_subset(&unique) && unique.len() == got.len(),
                "everything after the saved times, once; commands {:?}; {counters:?}",
                server.commands()
            );
            assert_eq!(counters.resume_fallbacks, 1, "{counters:?}");
            assert!(
                server.commands().iter().any(|c| c.starts_with("TIME ")),
                "{:?}",
                server.commands()
            );
        },
    );
}

/// acquire's record sink (`inner`) watched — or, without one, every record taken at once
/// (nothing held, so each is committed at once): the records taken (not refused), and `stop`
/// set once `want` are all among them or after `deadline`.
struct Watch<'a, 'p> {
    inner: Option<&'a mut PacketPublisher<'p>>,
    want: BTreeSet<(String, i64)>,
    got: Vec<(String, i64)>,
    stop: &'a AtomicBool,
    deadline: Instant,
}

impl RecordSink for Watch<'_, '_> {
    fn record(&mut self, r: &Channel) -> Taken {
        let t = self.inner.as_mut().map_or(Taken::Done, |p| p.record(r));
        if t != Taken::Refused {
            self.got.push((r.id(), r.start_time_ns));
        }
        if self.want.iter().all(|k| self.got.contains(k)) {
            self.stop.store(true, Ordering::Relaxed);
        }
        t
    }
    fn published_until_ns(&self, s: &str) -> Option<i64> {
        self.inner.as_ref()?.published_until_ns(s)
    }
    fn tick(&mut self, link: &LinkCounters) {
        if let Some(p) = self.inner.as_mut() {
            p.tick(link);
        }
        if Instant::now() > self.deadline {
            self.stop.store(true, Ordering::Relaxed);
        }
    }
    fn link(&mut self, up: bool) {
        if let Some(p) = self.inner.as_mut() {
            p.link(up);
        }
    }
}

/// Publishes nowhere (the assembler's decisions are what is tested).
struct Nowhere;

impl PacketSink for Nowhere {
    fn wait_for_subscriber(&mut self, _: Duration) -> anyhow::Result<bool> {
        Ok(true)
    }
    fn send(&mut self, _: &AccelPacket) -> anyhow::Result<()> {
        Ok(())
    }
}

#[test]
fn refused_records_are_never_delivered_nor_saved_and_their_clean_copies_go_through() {
    client_scenario(
        "refused_records_are_never_delivered_nor_saved_and_their_clean_copies_go_through",
        || {
            let server = Hostile::start();
            let records = records_in_time_order();
            server.push(&records[..30]);
            // Before the clean record 30: a copy at 200× the rate, one of 1e30, one in 2100.
            server.push(&[
                at_other_rate(&records[30], 200),
                with_values(&records[30], 1e30),
                in_year(&records[30], 2100),
            ]);
            server.push(&records[30..]);
            let dir = tempfile::tempdir().unwrap();
            // Until the client has delivered every clean record.
            let run = acquire_in_process(&server, dir.path(), ProtocolChoice::V3, keys(&records));
            let (counters, assembled) = (run.link, run.assembled);
            assert_eq!(
                (counters.delivered, counters.refused, counters.duplicates),
                (104, 3, 0),
                "{counters:?} {assembled:?}"
            );
            assert_eq!(
                (
                    assembled.other_rate_records,
                    assembled.implausible_records,
                    assembled.far_ahead_records
                ),
                (1, 1, 1),
                "{assembled:?}"
            );
            // No refused time is a resume point: every stream's latest is a clean record's.
            let latest = acquire_util::latest_starts(&records);
            for (stream, t) in &run.saved {
                assert!(latest[stream] >= *t, "{stream}: {t} saved");
            }
        },
    );
}

// ---- Faults of the connection: the client and acquire's publisher, in this process ----

/// What this process logged (the `tracing` lines of the client and the publisher, as
/// `acquire` writes them), captured from the first call on.
fn captured_log() -> String {
    static LOG: Mutex<Vec<u8>> = Mutex::new(Vec::new());
    struct Capture;
    impl std::io::Write for Capture {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
            LOG.lock()
                .unwrap_or_else(|e| e.into_inner())
                .extend_from_slice(bytes);
            Ok(bytes.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        let _ = tracing_subscriber::fmt()
            .with_ansi(false)
            .with_writer(|| Capture)
            .try_init();
    });
    String::from_utf8_lossy(&LOG.lock().unwrap_or_else(|e| e.into_inner())).into_owned()
}

/// What one run of "acquire" in this process did ([`acquire_in_process`]).
struct InProcessRun {
    /// The records taken (not refused), in order.
    got: Vec<(String, i64)>,
    link: LinkCounters,
    assembled: AssemblyCounters,
    /// `acquire_prometheus`: the `/metrics` text at the end.
    metrics: String,
    /// `acquire_summary`: the end-of-run line.
    summary: String,
    /// The records taken that the saved state counts as committed.
    committed: BTreeSet<(String, i64)>,
    /// The saved per-stream latest start times.
    saved: std::collections::BTreeMap<String, i64>,
}

/// One run of "acquire" in this process: a client on `state` and its publisher (to nowhere)
/// until `want` are taken (at most 30 s), then stopped as on SIGTERM.
fn acquire_in_process(
    server: &Hostile,
    state: &Path,
    protocol: ProtocolChoice,
    want: BTreeSet<(String, i64)>,
) -> InProcessRun {
    let xml = repo().join("tests/data/stationxml/obspy_XX.STN_k2.xml");
    let mut out = Nowhere;
    let mut publisher = PacketPublisher::new(
        Inventory::read(&xml).unwrap(),
        AssemblyConfig::default(),
        ClippingSection::default(),
        &mut out,
    );
    let mut c = client(server, state, protocol);
    let stop = AtomicBool::new(false);
    let mut watch = Watch {
        inner: Some(&mut publisher),
        want,
        got: Vec::new(),
        stop: &stop,
        deadline: Instant::now() + Duration::from_secs(30),
    };
    c.run(&stop, &mut watch).unwrap();
    let got = std::mem::take(&mut watch.got);
    let (published, assembled) = publisher.counters();
    assert_eq!(
        assembled.missing_component_samples, 0,
        "nothing zero-filled: {assembled:?}"
    );
    let link = c.counters();
    let saved = c.state().streams.clone();
    let committed = got
        .iter()
        .filter(|(stream, t)| saved.get(stream).is_some_and(|l| t <= l))
        .cloned()
        .collect();
    InProcessRun {
        metrics: acquire_prometheus(&link, &published, &assembled),
        summary: acquire_summary(&link, &published, &assembled),
        got,
        link,
        assembled,
        committed,
        saved,
    }
}

/// A fault of the connection after record `AT` (or, `UnreadableSequence`, record `AT`'s only
/// copy under an unreadable number), alone or with acquire stopped 10 records after the fault
/// and started again on its state: every record taken, none twice in one run, none taken
/// again that the first run had committed; the fault's log line, counter and summary.
fn run_link(fault: Fault, restart: bool) {
    let log_before = captured_log().len();
    let server = match fault {
        Fault::HugeLength => Hostile::start_v4(),
        _ => Hostile::start(),
    };
    let protocol = match fault {
        Fault::HugeLength => ProtocolChoice::V4,
        _ => ProtocolChoice::V3,
    };
    let records = records_in_time_order();
    server.push(&records[..AT]);
    let mut rest = AT;
    match fault {
        Fault::Garbage => server.plan(&[Conn::GarbageAfter(AT)]),
        Fault::HugeLength => server.plan(&[Conn::HugeLengthAfter(AT)]),
        Fault::HangMidPacket => server.plan(&[Conn::HangMidPacketAfter(AT)]),
        Fault::CloseMidPacket => server.plan(&[Conn::CloseMidPacketAfter(AT)]),
        Fault::UnreadableSequence => {
            server.push_with_number_text(&records[AT], b"zz!?00");
            rest = AT + 1;
        }
        other => unreachable!("{other:?} runs against the node"),
    }
    server.push(&records[rest..]);
    let all = keys(&records);
    let dir = tempfile::tempdir().unwrap();
    let first_want = if restart {
        keys(&records[..AT + 10])
    } else {
        all.clone()
    };
    let first = acquire_in_process(&server, dir.path(), protocol, first_want);
    let (mut got, link) = (first.got, first.link);
    let once: BTreeSet<_> = got.iter().cloned().collect();
    assert_eq!(once.len(), got.len(), "a record taken twice: {got:?}");
    if restart {
        let want: BTreeSet<_> = all.difference(&once).cloned().collect();
        let again = acquire_in_process(&server, dir.path(), protocol, want).got;
        let twice: Vec<_> = again
            .iter()
            .filter(|k| first.committed.contains(*k))
            .collect();
        assert!(
            twice.is_empty(),
            "taken again after the restart though committed before it: {twice:?}"
        );
        let again_once: BTreeSet<_> = again.iter().cloned().collect();
        assert_eq!(again_once.len(), again.len(), "{again:?}");
        got.extend(again);
    }
    let taken: BTreeSet<_> = got.into_iter().collect();
    let missing: Vec<_> = all.difference(&taken).collect();
    let log = captured_log()[log_before..].to_string();
    assert!(
        missing.is_empty(),
        "{fault:?}: records never taken: {missing:?}; commands {:?}; {link:?}\n{log}",
        server.commands()
    );
    let (lines, summary_part) = expected_lines(fault);
    for line in lines {
        assert!(
            log.contains(line),
            "{fault:?}: the log must say {line:?}:\n{log}"
        );
    }
    let metric = expected_metric(fault).unwrap();
    let (metrics, summary) = (first.metrics, first.summary);
    assert!(
        metrics.contains(metric),
        "{fault:?}: /metrics must say {metric:?}:\n{metrics}"
    );
    assert!(
        summary.contains(summary_part),
        "{fault:?}: the summary must say {summary_part:?}:\n{summary}"
    );
    println!(
        "{fault:?}{}: every record taken once; {summary}",
        if restart { " + restart" } else { "" }
    );
}

#[test]
fn a_record_claiming_65535_samples_is_dropped_as_malformed_and_costs_nothing() {
    scenario(
        "a_record_claiming_65535_samples_is_dropped_as_malformed_and_costs_nothing",
        Fault::SampleCount65535,
        false,
    );
}

#[test]
fn a_record_claiming_65535_samples_then_a_restart_of_acquire() {
    scenario(
        "a_record_claiming_65535_samples_then_a_restart_of_acquire",
        Fault::SampleCount65535,
        true,
    );
}

#[test]
fn a_record_of_the_year_0_is_dropped_as_malformed_and_costs_nothing() {
    scenario(
        "a_record_of_the_year_0_is_dropped_as_malformed_and_costs_nothing",
        Fault::YearZero,
        false,
    );
}

#[test]
fn a_record_of_the_year_0_then_a_restart_of_acquire() {
    scenario(
        "a_record_of_the_year_0_then_a_restart_of_acquire",
        Fault::YearZero,
        true,
    );
}

#[test]
fn a_record_of_an_unknown_location_is_unselected_and_costs_nothing() {
    scenario(
        "a_record_of_an_unknown_location_is_unselected_and_costs_nothing",
        Fault::UnknownLocation,
        false,
    );
}

#[test]
fn a_record_of_an_unknown_location_then_a_restart_of_acquire() {
    scenario(
        "a_record_of_an_unknown_location_then_a_restart_of_acquire",
        Fault::UnknownLocation,
        true,
    );
}

#[test]
fn a_corrupt_steim_frame_is_dropped_as_malformed_and_costs_nothing() {
    scenario(
        "a_corrupt_steim_frame_is_dropped_as_malformed_and_costs_nothing",
        Fault::CorruptSteim,
        false,
    );
}

#[test]
fn a_corrupt_steim_frame_then_a_restart_of_acquire() {
    scenario(
        "a_corrupt_steim_frame_then_a_restart_of_acquire",
        Fault::CorruptSteim,
        true,
    );
}

#[test]
fn a_record_of_nan_samples_is_dropped_as_malformed_and_costs_nothing() {
    scenario(
        "a_record_of_nan_samples_is_dropped_as_malformed_and_costs_nothing",
        Fault::NanSamples,
        false,
    );
}

#[test]
fn a_record_of_nan_samples_then_a_restart_of_acquire() {
    scenario(
        "a_record_of_nan_samples_then_a_restart_of_acquire",
        Fault::NanSamples,
        true,
    );
}

#[test]
fn garbage_in_place_of_a_packet_drops_the_connection_and_costs_nothing() {
    scenario(
        "garbage_in_place_of_a_packet_drops_the_connection_and_costs_nothing",
        Fault::Garbage,
        false,
    );
}

#[test]
fn garbage_in_place_of_a_packet_then_a_restart_of_acquire() {
    scenario(
        "garbage_in_place_of_a_packet_then_a_restart_of_acquire",
        Fault::Garbage,
        true,
    );
}

#[test]
fn a_v4_packet_claiming_2_31_bytes_drops_the_connection_and_costs_nothing() {
    scenario(
        "a_v4_packet_claiming_2_31_bytes_drops_the_connection_and_costs_nothing",
        Fault::HugeLength,
        false,
    );
}

#[test]
fn a_v4_packet_claiming_2_31_bytes_then_a_restart_of_acquire() {
    scenario(
        "a_v4_packet_claiming_2_31_bytes_then_a_restart_of_acquire",
        Fault::HugeLength,
        true,
    );
}

#[test]
fn a_packet_with_an_unreadable_sequence_number_is_delivered_by_time() {
    scenario(
        "a_packet_with_an_unreadable_sequence_number_is_delivered_by_time",
        Fault::UnreadableSequence,
        false,
    );
}

#[test]
fn a_packet_with_an_unreadable_sequence_number_then_a_restart_of_acquire() {
    scenario(
        "a_packet_with_an_unreadable_sequence_number_then_a_restart_of_acquire",
        Fault::UnreadableSequence,
        true,
    );
}

#[test]
fn a_connection_that_hangs_mid_packet_costs_nothing() {
    scenario(
        "a_connection_that_hangs_mid_packet_costs_nothing",
        Fault::HangMidPacket,
        false,
    );
}

#[test]
fn a_connection_that_hangs_mid_packet_then_a_restart_of_acquire() {
    scenario(
        "a_connection_that_hangs_mid_packet_then_a_restart_of_acquire",
        Fault::HangMidPacket,
        true,
    );
}

#[test]
fn a_connection_that_closes_mid_packet_costs_nothing() {
    scenario(
        "a_connection_that_closes_mid_packet_costs_nothing",
        Fault::CloseMidPacket,
        false,
    );
}

#[test]
fn a_connection_that_closes_mid_packet_then_a_restart_of_acquire() {
    scenario(
        "a_connection_that_closes_mid_packet_then_a_restart_of_acquire",
        Fault::CloseMidPacket,
        true,
    );
}
