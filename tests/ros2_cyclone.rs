//! replay → `rockwatch node` → an independent Cyclone DDS subscriber (Python `cyclonedds`,
//! PbrAlert type parsed from msg/pbr_msgs/msg/), in a private network namespace. Also: a subscriber that
//! joins after the alerts gets them (transient local), and SIGTERM ends the node with 0.

use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::{run_in_netns, text};
use rockwatch_test_harness::node_output::json_lines;
use rockwatch_test_harness::peers::have_cyclonedds;
use rockwatch_test_harness::rockwatch_bin;

/// The JSON alerts a subscriber printed (lines after `PREFIX`).
fn alerts(stdout: &str, prefix: &str) -> Vec<serde_json::Value> {
    stdout
        .lines()
        .filter_map(|l| l.strip_prefix(prefix))
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v.get("pbr_id").is_some())
        .collect()
}

#[test]
fn cyclone_dds_subscriber_receives_the_slender_pillar_overturned_and_a_late_one_too() {
    assert!(
        have_cyclonedds(),
        "python3 -m pip install cyclonedds==11.0.1 (see .ci/run)"
    );
    let dir = tempfile::tempdir().unwrap();
    write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let d = dir.path().display();
    let bin = rockwatch_bin!().display().to_string();
    let py = repo().join("tests/data/ros2/cyclone_alerts.py");
    let py = py.display();
    let msg = repo().join("msg/pbr_msgs/msg");
    let msg = msg.display();
    let rec = repo().join("tests/data/records");
    let rec = rec.display();
    let script = format!(
        "'{bin}' node --config '{d}/node.toml' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         python3 '{py}' '{msg}' --seconds 25 > '{d}/early.out' 2> '{d}/early.err' & SUB=$!
         '{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' --azimuth 228 \
             --station CI.RRS.00 --transport ros2 --speed max --tail 10 --wait-s 20
         sleep 2
         python3 '{py}' '{msg}' --seconds 4 > '{d}/late.out' 2> '{d}/late.err'
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         kill $SUB 2>/dev/null || true; wait $SUB || true
         sed 's/^/EARLY /' '{d}/early.out'; sed 's/^/LATE /' '{d}/late.out'
         cat '{d}/early.err' '{d}/late.err' '{d}/node.err' >&2"
    );
    let out = run_in_netns(
        &script,
        120,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("NODE_RC=0"),
        "SIGTERM must exit 0\n{stdout}\n{stderr}"
    );
    assert!(stdout.contains("replayed "), "{stdout}\n{stderr}");
    for (who, prefix) in [("early", "EARLY "), ("late", "LATE ")] {
        let got = alerts(&stdout, prefix);
        // Level 3 = PbrAlert.OVERTURNED (msg/pbr_msgs/msg/PbrAlert.msg).
        assert!(
            got.iter()
                .any(|a| a["pbr_id"] == "rrs-slender-pillar" && a["level"] == 3),
            "{who} subscriber: no OVERTURNED for the slender pillar\n{stdout}\n{stderr}"
        );
        for a in got.iter().filter(|a| a["pbr_id"] == "rrs-stocky-boulder") {
            assert_eq!(
                a["level"], 1,
                "{who}: stocky boulder beyond motion onset: {a}"
            );
        }
        for a in &got {
            // The rock's frame, as its PbrState; the station is in `station`.
            assert_eq!(
                a["frame_id"],
                format!("pbr/{}", a["pbr_id"].as_str().unwrap_or("")),
                "{a}"
            );
            assert_eq!(a["station"], "CI.RRS.00", "{a}");
            // A fresh node: every block in its first episode (PbrAlert.episode).
            assert_eq!(a["episode"], 1, "{a}");
        }
    }
}

/// rmw_cyclonedds's service mapping (its 16-byte request/reply header) and the enhanced one
/// (Fast DDS, Connext, ros2-client) answered by the same servers of one node: a Cyclone DDS
/// client on rmw_cyclonedds's wire (tests/data/ros2/cyclone_service.py) lists and reads the
/// node's parameters and resets the slender pillar the Rinaldi record overturned; between its
/// calls `rockwatch reset` (enhanced) is answered too. Before the servers read both mappings,
/// the Cyclone client got no reply (exit 2).
#[test]
fn an_rmw_cyclonedds_client_is_answered_by_the_reset_and_parameter_services() {
    assert!(
        have_cyclonedds(),
        "python3 -m pip install cyclonedds==11.0.1 (see .ci/run)"
    );
    let dir = tempfile::tempdir().unwrap();
    write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let d = dir.path().display();
    let bin = rockwatch_bin!().display().to_string();
    let py = repo().join("tests/data/ros2/cyclone_service.py");
    let py = py.display();
    let srv = repo().join("msg/pbr_msgs/srv");
    let srv = srv.display();
    let rec = repo().join("tests/data/records");
    let rec = rec.display();
    let peer = format!("python3 '{py}' '{srv}' --wait-s 20");
    let script = format!(
        "'{bin}' node --config '{d}/node.toml' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         {peer} --list --get alerts.imminent_theta_ratio --get catalogue | sed 's/^/CYCLONE /'
         '{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' --azimuth 228 \
             --station CI.RRS.00 --transport ros2 --speed max --tail 10 --wait-s 20 > /dev/null
         '{bin}' reset --node --wait-s 20 --pbr no-such-rock; echo ENHANCED_RC=$?
         {peer} --reset rrs-slender-pillar --reset no-such-rock | sed 's/^/CYCLONE /'
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         '{bin}' alerts --state-dir '{d}/state' --format json | tr -d '\\n' | sed 's/^/JOURNAL /'; echo
         cat '{d}/node.err' >&2"
    );
    let out = run_in_netns(
        &script,
        150,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{stderr}");
    let got = json_lines(&stdout, "CYCLONE ");
    assert_eq!(got.len(), 5, "{stdout}\n{stderr}");
    let names = got[0]["list"].as_array().unwrap();
    for name in ["alerts.imminent_theta_ratio", "catalogue"] {
        assert!(names.contains(&serde_json::json!(name)), "{names:?}");
    }
    // PARAMETER_DOUBLE 3 with the default threshold; PARAMETER_STRING 4 with the path.
    assert_eq!(got[1]["type"], 3, "{}", got[1]);
    assert_eq!(got[1]["double"], 0.8, "{}", got[1]);
    assert_eq!(got[2]["type"], 4, "{}", got[2]);
    assert_eq!(
        got[2]["string"],
        repo().join("config/catalogue.toml").display().to_string()
    );
    // The enhanced client between the two Cyclone sessions: answered (an unknown id: exit 1).
    assert!(stdout.contains("ENHANCED_RC=1"), "{stdout}\n{stderr}");
    assert!(stderr.contains("no-such-rock"), "{stderr}");
    assert_eq!(got[3]["reset"], "rrs-slender-pillar");
    assert_eq!(got[3]["success"], true, "{}", got[3]);
    assert_eq!(got[4]["success"], false, "{}", got[4]);
    assert!(
        got[4]["message"]
            .as_str()
            .unwrap()
            .contains("unknown block"),
        "{}",
        got[4]
    );
    // The pillar had overturned, and the Cyclone client's reset is journaled.
    let journal = stdout
        .lines()
        .find_map(|l| l.strip_prefix("JOURNAL "))
        .unwrap_or_else(|| panic!("no journal\n{stdout}"));
    let records: Vec<serde_json::Value> = serde_json::from_str(journal).unwrap();
    let pillar = |ty: &str| {
        records
            .iter()
            .filter(|r| r["type"] == ty && r["pbr_id"] == "rrs-slender-pillar")
            .count()
    };
    assert!(
        records.iter().any(|r| r["type"] == "alert"
            && r["pbr_id"] == "rrs-slender-pillar"
            && r["level"] == "overturned"),
        "{journal}"
    );
    assert_eq!(pillar("reset"), 1, "{journal}");
}
