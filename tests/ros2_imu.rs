//! `sensor_msgs/msg/Imu` input over the wire: an independent peer, Eclipse Cyclone DDS's Python
//! binding (tests/data/ros2/cyclone_imu.py, the Imu type declared there field by field from
//! the ROS 2 definition), publishes `sensor_msgs::msg::dds_::Imu_` on DDS topic `rt/imu/data`
//! to a `rockwatch node` whose configuration maps `/imu/data` to station XB.IMU.00
//! (`[[ros2.imu]]`), each test in its own network namespace, loopback only.
//!
//! Frame convention (src/ros2/mod.rs `imu_packet`, config/node.toml): the Imu is mounted level
//! with x east, y north, z up (ENU, REP 103) and reports the specific force like any
//! accelerometer (REP 145: z reads +g at rest), so the node takes east = x, north = y,
//! up = z − g (`remove_gravity = true`). The peer therefore publishes the Rinaldi record's
//! horizontal component, recorded along azimuth 228°, as x = a_h sin 228°, y = a_h cos 228°,
//! and z = a_v + g, one message per sample at the record's 100 Hz.
//!
//! Expectations come from the record and the block geometry, never from a previous run:
//! * the stocky block (B/H = 1.25 > μs = 0.9 ≥ μk) cannot rock: friction caps the horizontal
//!   force at μ (g + a_v) m < tan α (g + a_v) m, the least force that lifts a corner, as long
//!   as g + a_v > 0 (checked on the record). So no overturn, whatever the record; it slides
//!   from the first instant |a_x| = μs (g + a_v);
//! * the slender block (B/H = 0.2 < μs) starts rocking at the first instant
//!   |a_x| = tan α (g + a_v) (closed form, on the linearly interpolated input the engine
//!   integrates) and overturns: `rockwatch_core::simulate` of the same block on the same samples
//!   says so and when;
//! * a copy of the slender block turned 90° (azimuth 318°) gets a_x = 0 from this motion and
//!   must stay at rest: a sign error on one Imu axis, or a yaw offset, would throw it over.
//!   (An x↔y swap is nearly invisible for a motion along 228°, 3° off the diagonal; the unit
//!   test in src/ros2/mod.rs pins the exact mapping.)
//!
//! Without python3 + cyclonedds the tests are skipped locally and FAIL under CI=true.

use rockwatch_test_harness::fixtures::rinaldi;
use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::{reexec_in_netns, text};
use rockwatch_test_harness::node_output::count_before;
use rockwatch_test_harness::peers::{have_cyclonedds, peer_available};
use rockwatch_test_harness::rockwatch_bin;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use rockwatch_core::dynamics::{BlockParams, Mode};
use rockwatch_core::record::Record;
use rockwatch_core::simulate::{simulate, SimulationOptions};
use rockwatch_core::STANDARD_GRAVITY_MPS2 as G;

const STATION: &str = "XB.IMU.00";
/// ROS 2 topic of the Imu (DDS topic `rt/imu/data`).
const TOPIC: &str = "/imu/data";
const DDS_TOPIC: &str = "rt/imu/data";
/// Azimuth of the record's horizontal component (Rinaldi228.AT2), clockwise from north.
const RECORD_AZIMUTH_DEG: f64 = 228.0;

/// A catalogue block (the geometry and friction of config/catalogue.toml's CI.RRS.00 pair).
struct Block {
    id: &'static str,
    azimuth_deg: f64,
    width_m: f64,
    height_m: f64,
    mu_s: f64,
    mu_k: f64,
}

/// rrs-slender-pillar.
const SLENDER: Block = Block {
    id: "imu-slender-pillar",
    azimuth_deg: 228.0,
    width_m: 0.30,
    height_m: 1.50,
    mu_s: 0.70,
    mu_k: 0.55,
};
/// rrs-stocky-boulder.
const STOCKY: Block = Block {
    id: "imu-stocky-boulder",
    azimuth_deg: 228.0,
    width_m: 2.00,
    height_m: 1.60,
    mu_s: 0.90,
    mu_k: 0.70,
};
/// rrs-slender-pillar turned 90°: across the motion.
const CROSSWISE: Block = Block {
    id: "imu-crosswise-pillar",
    azimuth_deg: 318.0,
    ..SLENDER
};

impl Block {
    fn params(&self) -> BlockParams {
        BlockParams::from_width_height(self.width_m, self.height_m, self.mu_s, self.mu_k, None)
            .unwrap()
    }
}

fn have_peer() -> bool {
    peer_available(
        have_cyclonedds(),
        "python3 with cyclonedds==11.0.1",
        "pip install cyclonedds==11.0.1, as .ci/run does",
    )
}

/// A catalogue of `blocks` on [`STATION`] and a node configuration mapping [`TOPIC`] to it.
/// `qos`: the `[[ros2.imu]] qos` key's value, or None for the default (sensor data).
fn write_config(dir: &Path, blocks: &[&Block], rate_hz: f64, qos: Option<&str>) -> PathBuf {
    let catalogue = dir.join("catalogue.toml");
    let mut text = String::new();
    for b in blocks {
        text += &format!(
            "[[pbr]]\nid = \"{}\"\nname = \"{}\"\nlat = 34.28\nlon = -118.48\n\
             station = \"{STATION}\"\nazimuth_deg = {:.1}\nwidth_m = {}\nheight_m = {}\n\
             mu_s = {}\nmu_k = {}\nsource = \"test: copy of a config/catalogue.toml block\"\n\n",
            b.id, b.id, b.azimuth_deg, b.width_m, b.height_m, b.mu_s, b.mu_k
        );
    }
    std::fs::write(&catalogue, text).unwrap();
    let config = write_node_config(dir, &catalogue);
    let mut text = std::fs::read_to_string(&config).unwrap();
    text += &format!(
        "[[ros2.imu]]\ntopic = \"{TOPIC}\"\nstation = \"{STATION}\"\nsample_rate_hz = {rate_hz:?}\n\
         remove_gravity = true\n"
    );
    if let Some(qos) = qos {
        text += &format!("qos = \"{qos}\"\n");
    }
    std::fs::write(&config, text).unwrap();
    config
}

/// Runs the Cyclone Imu peer with `args` (bounded by `timeout_s`); its JSON lines.
fn run_peer(args: &[&str], timeout_s: u32) -> Vec<serde_json::Value> {
    let out = Command::new("timeout")
        .args(["-k", "5", &timeout_s.to_string(), "python3"])
        .arg(repo().join("tests/data/ros2/cyclone_imu.py"))
        .args(["--topic", DDS_TOPIC])
        .args(args)
        .output()
        .unwrap();
    let (stdout, stderr) = text(&out);
    assert!(
        out.status.success(),
        "Imu peer failed ({})\n{stdout}\n{stderr}",
        out.status
    );
    let lines: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    assert!(
        lines.iter().any(|l| l["acked"] == true),
        "the node did not acknowledge every message\n{stdout}\n{stderr}"
    );
    lines
}

/// The first value of `key` among the peer's lines.
fn field(lines: &[serde_json::Value], key: &str) -> serde_json::Value {
    lines
        .iter()
        .find_map(|l| l.get(key).cloned())
        .unwrap_or_else(|| panic!("no {key:?} in {lines:?}"))
}

/// The journal's alerts (`rockwatch alerts --format json`).
fn journal_alerts(state_dir: &Path) -> Vec<serde_json::Value> {
    let out = Command::new(rockwatch_bin!())
        .args(["alerts", "--format", "json", "--state-dir"])
        .arg(state_dir)
        .output()
        .unwrap();
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let records: Vec<serde_json::Value> = serde_json::from_str(&stdout).unwrap();
    records
        .iter()
        .filter(|r| r["type"] == "alert")
        .cloned()
        .collect()
}

/// The ground motion as the node receives it: the record's components along azimuth
/// [`RECORD_AZIMUTH_DEG`] split into east and north, each rounded to f32 as the node stores
/// samples, and the vertical after the gravity the peer added is removed.
struct Received {
    dt_s: f64,
    east: Vec<f32>,
    north: Vec<f32>,
    up: Vec<f32>,
}

fn received() -> Received {
    let record = rinaldi();
    let (sin, cos) = RECORD_AZIMUTH_DEG.to_radians().sin_cos();
    let vertical = record.vertical_mps2.as_ref().unwrap();
    Received {
        dt_s: record.dt_s,
        east: record
            .horizontal_mps2
            .iter()
            .map(|h| (h * sin) as f32)
            .collect(),
        north: record
            .horizontal_mps2
            .iter()
            .map(|h| (h * cos) as f32)
            .collect(),
        up: vertical.iter().map(|v| ((v + G) - G) as f32).collect(),
    }
}

impl Received {
    /// A block's input: horizontal acceleration along its +x axis, and the vertical (m/s²).
    fn along(&self, b: &Block) -> (Vec<f64>, Vec<f64>) {
        let (sin, cos) = b.azimuth_deg.to_radians().sin_cos();
        let ax = self
            .east
            .iter()
            .zip(&self.north)
            .map(|(&e, &n)| f64::from(e) * sin + f64::from(n) * cos)
            .collect();
        (ax, self.up.iter().map(|&v| f64::from(v)).collect())
    }

    fn record(&self, b: &Block) -> Record {
        let (ax, av) = self.along(b);
        Record {
            source: format!("Rinaldi 228 + UP along {}°", b.azimuth_deg),
            dt_s: self.dt_s,
            horizontal_mps2: ax,
            vertical_mps2: Some(av),
        }
    }
}

/// The first time (s after the first sample) at which |a_x| = k (g + a_v), both linear between
/// samples (how the engine interpolates its input), coming from below.
fn first_crossing(ax: &[f64], av: &[f64], dt_s: f64, k: f64) -> Option<f64> {
    (1..ax.len()).find_map(|i| {
        let below = |j: usize| ax[j].abs() < k * (G + av[j]);
        if below(i - 1) && !below(i) {
            // On the crossing side a_x has the sign of ax[i]; s a_x − k (g + a_v) is linear.
            let s = ax[i].signum();
            let f0 = s * ax[i - 1] - k * (G + av[i - 1]);
            let f1 = s * ax[i] - k * (G + av[i]);
            Some(((i - 1) as f64 + f0 / (f0 - f1)) * dt_s)
        } else {
            None
        }
    })
}

/// Seconds after `t0_ns` of an alert's data time.
fn data_time_s(alert: &serde_json::Value, t0_ns: i64) -> f64 {
    (alert["data_time_ns"].as_i64().unwrap() - t0_ns) as f64 * 1e-9
}

#[test]
fn imu_record_from_cyclone_overturns_the_slender_block_and_not_the_stocky_one() {
    if !have_peer()
        || !reexec_in_netns(
            "imu_record_from_cyclone_overturns_the_slender_block_and_not_the_stocky_one",
            150,
        )
    {
        return;
    }
    let motion = received();
    let rate_hz = 1.0 / motion.dt_s;
    let n = motion.east.len() as u64;

    // Expectations, from the record and the geometry.
    let (slender_ax, av) = motion.along(&SLENDER);
    assert!(
        av.iter().all(|v| G + v > 0.0),
        "the record lifts blocks off (a_v < -g): the friction argument needs contact"
    );
    let stocky = STOCKY.params();
    assert!(stocky.mu_k <= stocky.mu_s && stocky.mu_s < stocky.plus.tan_alpha);
    let slender = SLENDER.params();
    assert!(
        slender.plus.tan_alpha < slender.mu_s,
        "the slender block rocks first"
    );
    let rock_onset_s = first_crossing(&slender_ax, &av, motion.dt_s, slender.plus.tan_alpha)
        .expect("the record exceeds the slender block's rocking threshold");
    let (stocky_ax, _) = motion.along(&STOCKY);
    let slide_onset_s = first_crossing(&stocky_ax, &av, motion.dt_s, stocky.mu_s)
        .expect("the record exceeds the stocky block's sliding threshold");
    let sim = simulate(
        slender,
        &motion.record(&SLENDER),
        &SimulationOptions {
            t_extra_s: 0.0,
            ..SimulationOptions::default()
        },
    )
    .unwrap()
    .summary;
    assert!(
        sim.overturned,
        "the offline simulation of the slender block"
    );
    let fall_s = sim
        .modes
        .iter()
        .find(|(_, m)| *m == Mode::Overturned)
        .map(|(t, _)| *t)
        .unwrap();

    // The node, then the peer publishing the record at its sample rate.
    let dir = tempfile::tempdir().unwrap();
    // Reliable on both sides (the peer is reliable): every sample must arrive, exactly.
    let config = write_config(
        dir.path(),
        &[&SLENDER, &STOCKY, &CROSSWISE],
        rate_hz,
        Some("reliable"),
    );
    let state = dir.path().join("state");
    let mut node = rockwatch_bin!().start_node(&config, &state, dir.path().join("node.err"));
    let rec = repo().join("tests/data/records");
    let (at2, up) = (rec.join("Rinaldi228.AT2"), rec.join("RinaldiUP.AT2"));
    let peer = run_peer(
        &[
            "record",
            "--at2",
            at2.to_str().unwrap(),
            "--vertical",
            up.to_str().unwrap(),
            "--azimuth",
            &RECORD_AZIMUTH_DEG.to_string(),
            "--gravity",
            "add",
        ],
        90,
    );
    assert_eq!(field(&peer, "sent"), n, "{peer:?}");
    assert_eq!(field(&peer, "rate_hz"), rate_hz, "{peer:?}");
    let t0_ns = field(&peer, "first_stamp_ns").as_i64().unwrap();
    // Acknowledged by the node's reader; leave its intake a moment to hand them on.
    std::thread::sleep(Duration::from_secs(1));
    let status = node.signal_and_wait("TERM", Duration::from_secs(20));
    let stderr = node.stderr();
    assert!(
        status.is_some_and(|s| s.success()),
        "node did not exit 0 on SIGTERM ({status:?})\n{stderr}"
    );

    // One packet per Imu message, all decoded, all valid, in order, on the sample grid.
    assert_eq!(
        count_before(&stderr, "packets received over ROS 2"),
        n,
        "{stderr}"
    );
    assert_eq!(count_before(&stderr, "undecodable"), 0, "{stderr}");
    assert_eq!(
        count_before(&stderr, " packets, "),
        n,
        "engine input\n{stderr}"
    );
    for label in [
        "rejected as invalid",
        "from unknown stations",
        "with a malformed station id",
        "duplicate",
        "late",
    ] {
        assert_eq!(count_before(&stderr, label), 0, "{label}\n{stderr}");
    }
    assert!(stderr.contains("3 blocks, 1 overturned"), "{stderr}");

    let alerts = journal_alerts(&state);
    let of = |id: &str| -> Vec<&serde_json::Value> {
        alerts.iter().filter(|a| a["pbr_id"] == id).collect()
    };
    for a in &alerts {
        assert_eq!(a["station"], STATION, "{a}");
    }
    // The slender block: rocks at the closed-form onset, falls when the simulation says.
    let slender_alerts = of(SLENDER.id);
    let onset = slender_alerts
        .iter()
        .find(|a| a["level"] == "motion_onset")
        .unwrap_or_else(|| panic!("no motion_onset for the slender block: {alerts:?}"));
    assert_eq!(onset["mode"], "rock", "{onset}");
    // 1 µs: the onset is the root of a linear function (no integration); the inputs differ
    // from the test's only by f32 rounding (relative 6e-8, ≪ 1 µs at this slope) and the
    // data time is whole nanoseconds. Gravity left in z (or removed twice) would move the
    // onset by whole samples.
    let t = data_time_s(onset, t0_ns);
    assert!(
        (t - rock_onset_s).abs() < 1e-6,
        "rocking onset at {t} s, closed form {rock_onset_s} s"
    );
    let fell = slender_alerts
        .iter()
        .find(|a| a["level"] == "overturned")
        .unwrap_or_else(|| panic!("no overturned alert for the slender block: {alerts:?}"));
    // The engine reports a fall at the end of the sample interval in which it happened.
    let t = data_time_s(fell, t0_ns);
    assert!(
        t >= fall_s - 1e-6 && t <= fall_s + motion.dt_s + 1e-6,
        "overturned at {t} s, simulated fall at {fall_s} s"
    );
    // The stocky block slides (at the closed-form instant) but never rocks.
    let stocky_alerts = of(STOCKY.id);
    for a in &stocky_alerts {
        assert_eq!(
            a["level"], "motion_onset",
            "stocky block beyond sliding: {a}"
        );
        assert_eq!(a["mode"], "slide", "{a}");
    }
    let slid = stocky_alerts
        .first()
        .unwrap_or_else(|| panic!("the stocky block never slid: {alerts:?}"));
    let t = data_time_s(slid, t0_ns);
    assert!(
        (t - slide_onset_s).abs() < 1e-6,
        "sliding onset at {t} s, closed form {slide_onset_s} s"
    );
    // Across the motion: nothing moves it.
    assert!(of(CROSSWISE.id).is_empty(), "{alerts:?}");
}

#[test]
fn imu_messages_with_a_wrong_layout_are_counted_undecodable_and_the_node_carries_on() {
    if !have_peer()
        || !reexec_in_netns(
            "imu_messages_with_a_wrong_layout_are_counted_undecodable_and_the_node_carries_on",
            90,
        )
    {
        return;
    }
    const GOOD: u64 = 50;
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), &[&SLENDER], 100.0, Some("reliable"));
    let mut node = rockwatch_bin!().start_node(
        &config,
        &dir.path().join("state"),
        dir.path().join("node.err"),
    );
    // A truncated struct, a non-UTF-8 frame_id, a frame_id claiming 4 GiB (all under the
    // Imu type name), one Imu with a NaN acceleration, then GOOD Imu messages at rest.
    let peer = run_peer(
        &["hostile", "--good", &GOOD.to_string(), "--rate", "100"],
        60,
    );
    let wrong_layout = field(&peer, "wrong_layout").as_u64().unwrap();
    assert_eq!(wrong_layout, 3, "{peer:?}");
    assert_eq!(field(&peer, "sent"), GOOD, "{peer:?}");
    std::thread::sleep(Duration::from_secs(1));
    assert!(
        node.child.try_wait().unwrap().is_none(),
        "the node died\n{}",
        node.stderr()
    );
    let status = node.signal_and_wait("TERM", Duration::from_secs(20));
    let stderr = node.stderr();
    assert!(
        status.is_some_and(|s| s.success()),
        "node did not exit 0 on SIGTERM ({status:?})\n{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(
        count_before(&stderr, "undecodable"),
        wrong_layout,
        "{stderr}"
    );
    assert!(
        stderr.contains(&format!("ROS 2 {TOPIC}: undecodable message")),
        "the topic is named\n{stderr}"
    );
    // The NaN message decodes (one packet) and the engine rejects it.
    assert_eq!(
        count_before(&stderr, "packets received over ROS 2"),
        GOOD + 1,
        "{stderr}"
    );
    assert_eq!(count_before(&stderr, "rejected as invalid"), 1, "{stderr}");
    assert_eq!(
        count_before(&stderr, " packets, "),
        GOOD + 1,
        "engine input\n{stderr}"
    );
}

#[test]
fn a_best_effort_imu_driver_is_matched_by_the_default_qos() {
    if !have_peer()
        || !reexec_in_netns(
            "a_best_effort_imu_driver_is_matched_by_the_default_qos",
            120,
        )
    {
        return;
    }
    // A reliable reader never matches a best-effort writer: with a reliable default the peer
    // would see no reader and exit 2 (no reader matched), failing this test.
    const COUNT: u64 = 200;
    let dir = tempfile::tempdir().unwrap();
    let config = write_config(dir.path(), &[&SLENDER], 100.0, None);
    let mut node = rockwatch_bin!().start_node(
        &config,
        &dir.path().join("state"),
        dir.path().join("node.err"),
    );
    let peer = run_peer(
        &["at-rest", "--count", &COUNT.to_string(), "--rate", "100"],
        60,
    );
    assert_eq!(field(&peer, "sent"), COUNT, "{peer:?}");
    std::thread::sleep(Duration::from_secs(1));
    let status = node.signal_and_wait("TERM", Duration::from_secs(20));
    let stderr = node.stderr();
    assert!(status.is_some_and(|s| s.success()), "{status:?}\n{stderr}");
    // Best effort may lose samples (none expected on loopback; the first ones may go while
    // the node's reader is still discovering the writer): most must arrive, all decodable.
    let got = count_before(&stderr, "packets received over ROS 2");
    assert!(
        (COUNT * 3 / 4..=COUNT).contains(&got),
        "{got} of {COUNT}\n{stderr}"
    );
    assert_eq!(count_before(&stderr, "undecodable"), 0, "{stderr}");
    assert_eq!(count_before(&stderr, "rejected as invalid"), 0, "{stderr}");
}
