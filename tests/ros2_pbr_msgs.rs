//! The GENERATED `pbr_msgs` types on the wire: `msg/` built by the real ROS 2 toolchain (colcon,
//! rosidl; `launch-scripts/build-msgs.sh`, install in `$ROCKWATCH_PBR_MSGS_PREFIX` or
//! `target/pbr_msgs`) and used from rclpy (Fast DDS) with the environment of that install,
//! against `rockwatch node` (RustDDS, the structs of `src/ros2/msg.rs`), loopback only, in a
//! private network namespace. The rclpy peer publishes the Rinaldi record (228° + up, station
//! CI.RRS.00) as `pbr_msgs/AccelPacket`s on `/pbr/accel` and subscribes `/pbr/alerts`
//! (reliable, transient local). A slender block overturns and the peer decodes
//! `PbrAlert.OVERTURNED`; a stocky one does not; every alert it decodes equals, field by field,
//! the one the node journaled before publishing it. So both directions of the wire layout of the
//! generated types equal the Rust structs'. Without the build the test is skipped locally and
//! FAILS under CI=true.

mod shell_harness;
use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::{run_in_netns, text, VETH_TX};
use rockwatch_test_harness::node_output::json_lines;
use rockwatch_test_harness::peers::{pbr_msgs_install, source_pbr_msgs};
use rockwatch_test_harness::rockwatch_bin;
use shell_harness::rinaldi_packets;

use rockwatch::alert_json::{AlertJson, RecordJson};
use rockwatch::ros2::msg::{self as wire, level_code, mode_code};
use rockwatch_core::engine::AlertLevel;

const STATION: &str = "CI.RRS.00";
const SLENDER: &str = "slender-pillar";
const STOCKY: &str = "stocky-boulder";

/// The Rinaldi 228° component's PGA (m/s²), tests/data/records/im_expected.json.
const RINALDI_228_PGA_MPS2: f64 = 8.571_596_576_34;

/// Copies of the catalogue's rrs-slender-pillar (B/H = 0.2: overturns under Rinaldi) and
/// rrs-stocky-boulder (B/H = 1.25 > μs: never rocks), both on CI.RRS.00, azimuth 228°.
fn write_catalogue(path: &std::path::Path) {
    let block = |id: &str, width_m: f64, height_m: f64, mu_s: f64, mu_k: f64| {
        format!(
            "[[pbr]]\nid = \"{id}\"\nname = \"{id}\"\nlat = 34.28\nlon = -118.48\n\
             station = \"{STATION}\"\nazimuth_deg = 228.0\nwidth_m = {width_m:?}\n\
             height_m = {height_m:?}\nmu_s = {mu_s:?}\nmu_k = {mu_k:?}\n\
             source = \"test: copy of the example catalogue's block\"\n\n"
        )
    };
    let text = block(SLENDER, 0.30, 1.50, 0.70, 0.55) + &block(STOCKY, 2.00, 1.60, 0.90, 0.70);
    std::fs::write(path, text).unwrap();
}

/// The Rinaldi packets (5 s of quiet after the record) as JSON for the peer; samples as f64,
/// which holds every f32 exactly, so the peer's float32[] fields get the very same values.
fn write_packets(path: &std::path::Path) -> usize {
    let packets = rinaldi_packets(5.0);
    let wide = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<f64>>();
    let list: Vec<serde_json::Value> = packets
        .iter()
        .map(|p| {
            serde_json::json!({
                "station": p.station, "start_time_ns": p.start_time_ns,
                "sample_rate_hz": p.sample_rate_hz, "sequence": p.sequence,
                "east": wide(&p.east), "north": wide(&p.north), "up": wide(&p.up),
            })
        })
        .collect();
    std::fs::write(path, serde_json::to_string(&list).unwrap()).unwrap();
    packets.len()
}

/// `a` and `b` agree to 1e-12 relative: both went through a decimal JSON text (shortest
/// round-trip digits, from Python and from Rust) and a parse that may be off by an ulp; a wrong
/// wire layout gives unrelated values, not ulp differences.
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()) || a == b
}

#[test]
fn rclpy_peer_with_the_generated_types_gets_overturned_for_the_slender_block_only() {
    let Some(prefix) = pbr_msgs_install() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let catalogue = dir.path().join("catalogue.toml");
    write_catalogue(&catalogue);
    write_node_config(dir.path(), &catalogue);
    let n_packets = write_packets(&dir.path().join("packets.json"));
    let d = dir.path().display();
    let bin = rockwatch_bin!().display().to_string();
    let py = repo().join("tests/data/ros2/rclpy_pbr_msgs.py");
    let script = format!(
        "{VETH_TX}
         '{bin}' node --config '{d}/node.toml' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         PEER_RC=0
         ( {source}; exec python3 '{py}' '{d}/packets.json' --wait-s 60 --quiet-s 3 ) \
             > '{d}/peer.out' 2> '{d}/peer.err' || PEER_RC=$?
         echo PEER_RC=$PEER_RC
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         {VETH_TX}
         sed 's/^/PEER /' '{d}/peer.out'
         '{bin}' alerts --state-dir '{d}/state' --format json | tr -d '\\n' | sed 's/^/JOURNAL /'; echo
         cat '{d}/peer.err' '{d}/node.err' >&2",
        source = source_pbr_msgs(&prefix),
        py = py.display(),
    );
    let out = run_in_netns(
        &script,
        150,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let (stdout, stderr) = text(&out);
    let all = format!("{stdout}\n--- stderr\n{stderr}");
    assert!(out.status.success(), "{all}");
    assert!(stdout.contains("PEER_RC=0"), "{all}");
    assert!(stdout.contains("NODE_RC=0"), "{all}");
    // Neither participant sent anything on the non-loopback interface.
    let veth: Vec<&str> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("VETH_TX="))
        .collect();
    assert_eq!(veth.len(), 2, "{all}");
    assert_eq!(veth[0], veth[1], "traffic on the veth\n{all}");

    let peer = json_lines(&stdout, "PEER ");
    // The generated constants are the Rust ones.
    let constants = &peer[0]["constants"];
    for (name, code) in [
        ("MOTION_ONSET", wire::LEVEL_MOTION_ONSET),
        ("OVERTURN_IMMINENT", wire::LEVEL_OVERTURN_IMMINENT),
        ("OVERTURNED", wire::LEVEL_OVERTURNED),
    ] {
        assert_eq!(constants["PbrAlert"][name], code, "PbrAlert.{name}");
    }
    for (name, code) in [
        ("REST", wire::MODE_REST),
        ("SLIDE", wire::MODE_SLIDE),
        ("ROCK", wire::MODE_ROCK),
        ("SLIDE_ROCK", wire::MODE_SLIDE_ROCK),
        ("OVERTURNED", wire::MODE_OVERTURNED),
        ("FLIGHT", wire::MODE_FLIGHT),
    ] {
        assert_eq!(constants["PbrState"][name], code, "PbrState.{name}");
    }

    // Every AccelPacket reached the node (reliable, acknowledged) and decoded into a valid
    // packet of its station, in sequence (no duplicate, none late).
    assert!(
        stderr.contains(&format!(
            "{n_packets} packets received over ROS 2 (0 undecodable, 0 participant rebuilds, \
             0 redelivered and skipped)"
        )),
        "{all}"
    );
    assert!(
        stderr.contains(&format!(
            "engine input: {n_packets} packets, 0 rejected as invalid (0 beyond the physical \
             bound), 0 stamped too far ahead (not processed), 0 with a malformed station id, \
             0 from unknown stations, 0 duplicate, 0 late, 0 time-grid rewinds"
        )),
        "{all}"
    );
    let sent = peer
        .iter()
        .find(|v| v.get("sent").is_some())
        .unwrap_or_else(|| panic!("the peer published nothing\n{all}"));
    assert_eq!(sent["sent"], n_packets, "{all}");
    assert_eq!(sent["acked"], true, "{all}");
    let first_ns = sent["first_stamp_ns"].as_i64().unwrap();
    let end_ns = sent["end_stamp_ns"].as_i64().unwrap();

    let alerts: Vec<&serde_json::Value> = peer.iter().filter_map(|v| v.get("alert")).collect();
    let of = |id: &str| -> Vec<&serde_json::Value> {
        alerts
            .iter()
            .copied()
            .filter(|a| a["pbr_id"] == id)
            .collect()
    };

    // The slender block: OVERTURNED (the generated constant), with sane fields.
    let overturned: Vec<_> = of(SLENDER)
        .into_iter()
        .filter(|a| a["is_overturned"] == true)
        .collect();
    assert_eq!(overturned.len(), 1, "one OVERTURNED for {SLENDER}\n{all}");
    let a = overturned[0];
    assert_eq!(a["level"], wire::LEVEL_OVERTURNED, "{a}");
    assert_eq!(a["mode"], wire::MODE_OVERTURNED, "{a}");
    assert_eq!(a["station"], STATION, "{a}");
    // The rock's frame, as its PbrState (REP-105: map → pbr/<id> on /tf_static).
    assert_eq!(a["frame_id"], format!("pbr/{SLENDER}"), "{a}");
    // Fallen: |θ| ≥ α.
    assert!(a["theta_over_alpha"].as_f64().unwrap() >= 1.0, "{a}");
    // 0 < station PGA ≤ the record's PGA: each horizontal component is a projection of the
    // 228° trace (|sin|, |cos| ≤ 1); 1e-6 relative covers the f32 samples.
    let pga = a["pga"].as_f64().unwrap();
    assert!(
        pga > 0.0 && pga <= RINALDI_228_PGA_MPS2 * (1.0 + 1e-6),
        "{a}"
    );
    assert!(a["pgv"].as_f64().unwrap() > 0.0, "{a}");
    // The triggering sample lies within the packets sent.
    let stamp = a["stamp_ns"].as_i64().unwrap();
    assert!(
        first_ns <= stamp && stamp < end_ns,
        "{a}: {first_ns}..{end_ns}"
    );
    assert!(a["stamp_nanosec"].as_u64().unwrap() < 1_000_000_000, "{a}");
    assert!(!a["message"].as_str().unwrap().is_empty(), "{a}");
    // The first episode of a fresh node (the de-duplication key is (pbr_id, episode, level)).
    assert_eq!(a["episode"], 1, "{a}");

    // The stocky block never fell.
    for a in of(STOCKY) {
        assert_ne!(a["level"], wire::LEVEL_OVERTURNED, "{a}");
        assert_eq!(a["is_overturned"], false, "{a}");
    }

    // Field by field, the alerts decoded by the generated type are those the node journaled
    // (written before publishing), and no other.
    let journal = stdout
        .lines()
        .find_map(|l| l.strip_prefix("JOURNAL "))
        .unwrap_or_else(|| panic!("no journal\n{all}"));
    let journaled: Vec<AlertJson> = serde_json::from_str::<Vec<RecordJson>>(journal)
        .unwrap()
        .into_iter()
        .filter_map(|r| match r {
            RecordJson::Alert(a) => Some(a),
            _ => None,
        })
        .collect();
    assert!(
        journaled
            .iter()
            .any(|j| j.pbr_id == SLENDER && j.level == AlertLevel::Overturned),
        "{journal}"
    );
    assert_eq!(alerts.len(), journaled.len(), "{journal}\n{all}");
    for j in &journaled {
        let got: Vec<_> = alerts
            .iter()
            .filter(|a| a["pbr_id"] == j.pbr_id.as_str() && a["level"] == level_code(j.level))
            .collect();
        assert_eq!(got.len(), 1, "{j:?}\n{all}");
        let a = got[0];
        assert_eq!(a["station"], j.station.as_str(), "{a} vs {j:?}");
        assert_eq!(a["frame_id"], format!("pbr/{}", j.pbr_id), "{a} vs {j:?}");
        assert_eq!(a["mode"], mode_code(j.mode), "{a} vs {j:?}");
        assert_eq!(a["stamp_ns"], j.data_time_ns, "{a} vs {j:?}");
        for (field, want) in [
            ("theta_over_alpha", j.theta_over_alpha),
            ("slide", j.slide_m),
            ("overturn_probability", j.overturn_probability),
            ("pga", j.pga_mps2),
            ("pgv", j.pgv_mps),
            // After the string `message`: its alignment is checked too.
            ("direction_deg", j.direction_deg),
            // The rock's position (issue 20 item 10), after the string `pbr_name`.
            ("latitude_deg", j.lat_deg.unwrap_or(f64::NAN)),
            ("longitude_deg", j.lon_deg.unwrap_or(f64::NAN)),
        ] {
            let got = a[field].as_f64().unwrap();
            assert!(close(got, want), "{field}: {got} vs {want}: {a} vs {j:?}");
        }
        assert_eq!(a["pbr_name"], j.pbr_name.as_str(), "{a} vs {j:?}");
    }
    // The catalogue's name and position of the pillar (`write_catalogue`).
    let pillar = journaled.iter().find(|j| j.pbr_id == SLENDER).unwrap();
    assert_eq!(
        (pillar.pbr_name.as_str(), pillar.lat_deg, pillar.lon_deg),
        (SLENDER, Some(34.28), Some(-118.48))
    );
}
