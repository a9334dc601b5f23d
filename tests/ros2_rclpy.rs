//! A real ROS 2 peer: rclpy with Fast DDS from PyPI (`ros-rclpy[fastrtps]`, pinned in .ci/run)
//! with `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, in a private network namespace. It sees
//! `/rockwatch` in the node graph, reads `alerts.imminent_theta_ratio` through
//! `/rockwatch/get_parameters`, changes it through `/rockwatch/set_parameters`, and the change
//! takes effect at once: of two identical slender blocks fed the same record, the one fed
//! before the change raises `overturn_imminent`, the one fed after it (ratio 1000, out of
//! reach: |θ|/α < π/2 / α ≈ 8 for this block even once fallen) does not, though both overturn.
//! An invalid value (−1) is refused with a reason and leaves the parameter unchanged.
//! Without rclpy the test is skipped locally and FAILS under CI=true.

mod ros2_util;
use ros2_util::*;

/// The PyPI package of the peer (rclpy 9.1.2 = ROS 2 Kilted, with rmw_fastrtps_cpp).
const RCLPY_VERSION: &str = "9.1.2";

fn rclpy_available() -> bool {
    let ok = std::process::Command::new("python3")
        .args([
            "-c",
            &format!(
                "import importlib.metadata as m, rclpy, rcl_interfaces.srv; \
                 assert m.version('ros-rclpy') == '{RCLPY_VERSION}'"
            ),
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    peer_available(
        ok,
        &format!("python3 with ros-rclpy[fastrtps]=={RCLPY_VERSION}"),
        "see .ci/run",
    )
}

/// Two copies of the catalogue's rrs-slender-pillar (no ensemble), on two stations.
fn write_catalogue(path: &std::path::Path) {
    let mut text = String::new();
    for (id, station) in [("pillar-one", "XB.ONE.00"), ("pillar-two", "XB.TWO.00")] {
        text += &format!(
            "[[pbr]]\nid = \"{id}\"\nname = \"{id}\"\nlat = 34.28\nlon = -118.48\n\
             station = \"{station}\"\nazimuth_deg = 228.0\nwidth_m = 0.30\nheight_m = 1.50\n\
             mu_s = 0.70\nmu_k = 0.55\nsource = \"test: copy of rrs-slender-pillar\"\n\n"
        );
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn rclpy_peer_sees_rockwatch_and_a_threshold_set_through_parameter_services_takes_effect() {
    if !rclpy_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let catalogue = dir.path().join("catalogue.toml");
    write_catalogue(&catalogue);
    write_node_config(dir.path(), &catalogue);
    let d = dir.path().display();
    let bin = rockwatch().display().to_string();
    let py = repo().join("tests/data/ros2/rclpy_params.py");
    let py = py.display();
    let rec = repo().join("tests/data/records");
    let rec = rec.display();
    let replay = |station: &str| {
        format!(
            "'{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' \
             --azimuth 228 --station {station} --transport ros2 --speed max --tail 5 --wait-s 20 >/dev/null"
        )
    };
    // Waits (≤ 20 s) until `id`'s overturned alert is journaled.
    let wait_overturned = |id: &str| {
        format!(
            "i=0; until grep -q '\"{id}\".*\"overturned\"' '{d}/state/journal.log' 2>/dev/null; do \
             i=$((i+1)); [ $i -lt 200 ] || {{ echo NO_OVERTURNED_{id}; break; }}; sleep 0.1; done"
        )
    };
    let script = format!(
        "{VETH_TX}
         '{bin}' node --config '{d}/node.toml' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         python3 '{py}' --wait-s 30 --get alerts.imminent_theta_ratio | sed 's/^/BEFORE /'
         {}
         {}
         python3 '{py}' --wait-s 30 --set alerts.imminent_theta_ratio=1000 \
             --get alerts.imminent_theta_ratio --set alerts.imminent_theta_ratio=-1 \
             --get alerts.imminent_theta_ratio | sed 's/^/AFTER /'
         {}
         {}
         sleep 1
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         {VETH_TX}
         '{bin}' alerts --state-dir '{d}/state' --format json | tr -d '\\n' | sed 's/^/JOURNAL /'; echo
         cat '{d}/node.err' >&2",
        replay("XB.ONE.00"),
        wait_overturned("pillar-one"),
        replay("XB.TWO.00"),
        wait_overturned("pillar-two"),
    );
    let out = run_in_netns(
        &script,
        150,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{stderr}");
    assert!(!stdout.contains("NO_OVERTURNED"), "{stdout}\n{stderr}");
    // Neither participant (RustDDS under the LOCALHOST plan, Fast DDS under
    // ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST) sent anything on the non-loopback interface.
    let veth: Vec<&str> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("VETH_TX="))
        .collect();
    assert_eq!(veth.len(), 2, "{stdout}");
    assert_eq!(veth[0], veth[1], "traffic on the veth\n{stdout}");

    // The graph, and the configured value (config/node.toml's default, 0.8) read back.
    let before = json_lines(&stdout, "BEFORE ");
    assert_eq!(before.len(), 2, "{stdout}\n{stderr}");
    let graph = before[0]["graph"].as_array().unwrap();
    assert!(
        graph.contains(&serde_json::json!(["rockwatch", "/"])),
        "{graph:?}"
    );
    assert_eq!(before[1]["get"], "alerts.imminent_theta_ratio");
    assert_eq!(before[1]["type"], 3, "PARAMETER_DOUBLE");
    assert_eq!(before[1]["value"], 0.8);

    // Set, read back, an invalid value refused, the value unchanged.
    let after = json_lines(&stdout, "AFTER ");
    assert_eq!(after.len(), 5, "{stdout}\n{stderr}");
    assert_eq!(after[1]["successful"], true, "{}", after[1]);
    assert_eq!(after[2]["value"], 1000.0);
    assert_eq!(after[3]["successful"], false, "{}", after[3]);
    assert!(
        after[3]["reason"].as_str().unwrap().contains("invalid"),
        "{}",
        after[3]
    );
    assert_eq!(after[4]["value"], 1000.0);

    // Effect: overturn_imminent for the block fed before the change only.
    let journal = stdout
        .lines()
        .find_map(|l| l.strip_prefix("JOURNAL "))
        .unwrap_or_else(|| panic!("no journal\n{stdout}"));
    let records: Vec<serde_json::Value> = serde_json::from_str(journal).unwrap();
    let levels = |id: &str| -> Vec<String> {
        records
            .iter()
            .filter(|r| r["type"] == "alert" && r["pbr_id"] == id)
            .map(|a| a["level"].as_str().unwrap().to_string())
            .collect()
    };
    assert_eq!(
        levels("pillar-one"),
        ["motion_onset", "overturn_imminent", "overturned"],
        "{journal}"
    );
    assert_eq!(
        levels("pillar-two"),
        ["motion_onset", "overturned"],
        "{journal}"
    );
}
