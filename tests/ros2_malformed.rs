//! Malformed and hostile input over the wire to a running `rockwatch node` (in its own network
//! namespace, loopback only): well-typed packets with bad contents (empty arrays, mismatched
//! lengths, NaN/Inf, absurd sample rates, unknown or malformed station ids, oversized
//! packets, counts for a station without a gain, an unknown unit) and raw bytes that do not decode as `pbr_msgs/AccelPacket`. The node survives,
//! counts each kind in its closing summary, and still raises OVERTURNED for the slender
//! pillar when the Rinaldi record is replayed afterwards.

mod shell_harness;
use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::reexec_in_netns;
use rockwatch_test_harness::node_output::count_before;
use rockwatch_test_harness::rockwatch_bin;
use shell_harness::rinaldi_packets;

use std::time::{Duration, Instant};

use rockwatch::ports::PacketSink;
use rockwatch::replay::{replay, Restamp, Speed};
use rockwatch::ros2::msg::{self, Header};
use rockwatch::ros2::{
    network_plan, replay_qos, Ros2AlertListener, Ros2Config, Ros2PacketSink, Ros2Session,
    ACCEL_TOPIC,
};

/// 2024-01-01T00:00:00Z (ns): a plausible start time for the hand-made packets.
const T0_NS: i64 = 1_704_067_200_000_000_000;

fn packet(
    station: &str,
    rate_hz: f64,
    east: Vec<f32>,
    north: Vec<f32>,
    up: Vec<f32>,
) -> msg::AccelPacket {
    msg::AccelPacket {
        header: Header::new(T0_NS, station),
        sample_rate: rate_hz,
        sequence: 7,
        east,
        north,
        up,
        unit: msg::UNIT_MPS2,
    }
}

/// Ends after the header: the decoder runs out of bytes at `sample_rate`.
#[derive(Debug, serde::Serialize)]
struct Truncated {
    header: Header,
}

/// A header whose frame_id (CDR string: u32 length incl. NUL, bytes) is not UTF-8.
#[derive(Debug, serde::Serialize)]
struct BadUtf8 {
    sec: i32,
    nanosec: u32,
    frame_id_len: u32,
    frame_id: [u8; 4],
    rest: [u64; 8],
}

/// A well-formed prefix whose `east` sequence claims 4 × 10⁹ floats that are not there.
#[derive(Debug, serde::Serialize)]
struct HugeLength {
    header: Header,
    sample_rate: f64,
    sequence: u64,
    unit: u8,
    east_len: u32,
    east: [f32; 4],
}

#[test]
fn node_survives_counts_and_rejects_hostile_input_then_still_raises_overturned() {
    if !reexec_in_netns(
        "node_survives_counts_and_rejects_hostile_input_then_still_raises_overturned",
        150,
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let mut node = rockwatch_bin!().start_node(
        &config,
        &dir.path().join("state"),
        dir.path().join("node.err"),
    );

    // Loopback only whatever the environment says (we are in a private namespace anyway).
    let plan = network_plan(&Ros2Config::loopback_only(), None, None).unwrap();
    let mut sink = Ros2PacketSink::open(&plan, "/").unwrap();
    assert!(
        sink.wait_for_subscriber(Duration::from_secs(30)).unwrap(),
        "the node never subscribed\n{}",
        node.stderr()
    );
    let mut listener = Ros2AlertListener::open(&plan, "/").unwrap();

    // Raw bytes on /pbr/accel under the AccelPacket type name, from another participant.
    let mut hostile = Ros2Session::open(
        &plan,
        &rockwatch::ros2::Naming::new("/", "hostile", Vec::new()).unwrap(),
        ros2_client::NodeOptions::new().enable_rosout(false),
    )
    .unwrap();
    let truncated = hostile
        .publisher::<Truncated>(ACCEL_TOPIC, "AccelPacket", replay_qos())
        .unwrap();
    let bad_utf8 = hostile
        .publisher::<BadUtf8>(ACCEL_TOPIC, "AccelPacket", replay_qos())
        .unwrap();
    let huge_length = hostile
        .publisher::<HugeLength>(ACCEL_TOPIC, "AccelPacket", replay_qos())
        .unwrap();
    // Each must match the node's subscription before publishing (volatile: nothing is kept).
    let deadline = Instant::now() + Duration::from_secs(20);
    while [
        truncated.get_subscription_count(hostile.node()),
        bad_utf8.get_subscription_count(hostile.node()),
        huge_length.get_subscription_count(hostile.node()),
    ]
    .contains(&0)
    {
        assert!(Instant::now() < deadline, "hostile writers never matched");
        std::thread::sleep(Duration::from_millis(20));
    }
    truncated
        .publish(Truncated {
            header: Header::new(T0_NS, "CI.RRS.00"),
        })
        .unwrap();
    bad_utf8
        .publish(BadUtf8 {
            sec: 1,
            nanosec: 0,
            frame_id_len: 4,
            frame_id: [0xff, 0xfe, 0xfd, 0x00],
            rest: [0; 8],
        })
        .unwrap();
    huge_length
        .publish(HugeLength {
            header: Header::new(T0_NS, "CI.RRS.00"),
            sample_rate: 100.0,
            sequence: 1,
            unit: msg::UNIT_MPS2,
            east_len: 4_000_000_000,
            east: [0.0; 4],
        })
        .unwrap();
    const UNDECODABLE: u64 = 3;

    // Well-typed packets with bad contents, for the catalogue's station CI.RRS.00.
    let ten = || vec![0.01_f32; 10];
    let mut nan = ten();
    nan[3] = f32::NAN;
    let mut inf = ten();
    inf[9] = f32::INFINITY;
    let invalid = vec![
        packet("CI.RRS.00", 100.0, vec![], vec![], vec![]), // empty
        packet("CI.RRS.00", 100.0, ten(), vec![0.0; 9], ten()), // north shorter
        packet("CI.RRS.00", 100.0, ten(), ten(), vec![0.0; 3]), // up neither empty nor 10
        packet("CI.RRS.00", 100.0, nan, ten(), ten()),
        packet("CI.RRS.00", 100.0, ten(), inf, vec![]),
        packet("CI.RRS.00", 0.0, ten(), ten(), ten()),
        packet("CI.RRS.00", -100.0, ten(), ten(), ten()),
        packet("CI.RRS.00", f64::NAN, ten(), ten(), ten()),
        packet("CI.RRS.00", f64::INFINITY, ten(), ten(), ten()),
        packet("CI.RRS.00", 1e12, ten(), ten(), ten()),
        packet("CI.RRS.00", 0.001, ten(), ten(), ten()),
        // Counts for a station without a gain, and an unknown unit (issue 20 item 15).
        msg::AccelPacket {
            unit: msg::UNIT_COUNTS,
            ..packet("CI.RRS.00", 100.0, ten(), ten(), ten())
        },
        msg::AccelPacket {
            unit: 9,
            ..packet("CI.RRS.00", 100.0, ten(), ten(), ten())
        },
        // One sample over the engine's limit (100 000): 1.2 MB, sent in DDS fragments.
        packet(
            "CI.RRS.00",
            100.0,
            vec![0.0; 100_001],
            vec![0.0; 100_001],
            vec![0.0; 100_001],
        ),
    ];
    let unknown = vec![
        packet("XX.NOPE.00", 100.0, ten(), ten(), ten()),
        packet("CI.SYX.00", 100.0, ten(), ten(), ten()),
    ];
    let malformed_id = vec![
        packet("", 100.0, ten(), ten(), ten()),
        packet("not a station", 100.0, ten(), ten(), ten()),
        packet(&"A".repeat(100_000), 100.0, ten(), ten(), ten()),
        packet("CI.RRS.00\u{0}", 100.0, ten(), ten(), ten()),
    ];
    let well_typed = (invalid.len() + unknown.len() + malformed_id.len()) as u64;
    for m in invalid.iter().chain(&unknown).chain(&malformed_id) {
        sink.send_msg(m.clone()).unwrap();
    }

    // Then a real earthquake: the node must still work.
    let packets = rinaldi_packets(5.0);
    let report = replay(&packets, &mut sink, Speed::Max, Restamp::Now, 1).unwrap();
    assert_eq!(report.packets as usize, packets.len());
    let deadline = Instant::now() + Duration::from_secs(40);
    let mut alerts = Vec::new();
    while !alerts.iter().any(|a: &msg::PbrAlert| {
        a.pbr_id == "rrs-slender-pillar" && a.level == msg::LEVEL_OVERTURNED
    }) {
        assert!(
            Instant::now() < deadline,
            "no OVERTURNED for the slender pillar after the hostile input; got {alerts:?}\n{}",
            node.stderr()
        );
        alerts.extend(listener.recv(Duration::from_millis(500)).unwrap());
    }
    // Let the last messages of the other writers arrive before stopping the node.
    std::thread::sleep(Duration::from_secs(1));
    let status = node.signal_and_wait("TERM", Duration::from_secs(20));
    let stderr = node.stderr();
    assert!(
        status.is_some_and(|s| s.success()),
        "node did not exit 0 on SIGTERM ({status:?})\n{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");

    // The closing summary counts every hostile message, each under its kind.
    let valid = packets.len() as u64;
    assert_eq!(
        count_before(&stderr, "undecodable"),
        UNDECODABLE,
        "raw bytes that are not an AccelPacket\n{stderr}"
    );
    assert_eq!(
        count_before(&stderr, "packets received over ROS 2"),
        well_typed + valid,
        "{stderr}"
    );
    assert_eq!(
        count_before(&stderr, "rejected as invalid"),
        invalid.len() as u64,
        "{stderr}"
    );
    assert_eq!(
        count_before(&stderr, "from unknown stations"),
        unknown.len() as u64,
        "{stderr}"
    );
    assert_eq!(
        count_before(&stderr, "with a malformed station id"),
        malformed_id.len() as u64,
        "{stderr}"
    );
    assert_eq!(count_before(&stderr, "duplicate"), 0, "{stderr}");
    assert!(stderr.contains("1 overturned"), "{stderr}");
    // Hostile station ids are neither echoed in full nor with their control characters (a
    // 100 kB id, a NUL): every log line stays short and printable.
    for line in stderr.lines() {
        assert!(line.len() < 1000, "log line of {} bytes", line.len());
        assert!(!line.contains('\0'), "raw NUL in the log: {line:?}");
    }
}
