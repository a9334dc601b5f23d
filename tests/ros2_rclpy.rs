//! A real ROS 2 peer: rclpy with Fast DDS from PyPI (`ros-rclpy[fastrtps]`, pinned in .ci/run)
//! with `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, in a private network namespace, against a
//! node started as `rockwatch node --ros-args -r __ns:=/site_a --params-file P -p …` (the
//! ROS 2 YAML parameter file, with a `/**` section and a `/site_a/rockwatch` one). The peer
//! sees `rockwatch` in `/site_a` in the node graph; reads `alerts.imminent_theta_ratio`
//! through `/site_a/rockwatch/get_parameters` (the file's value); describes it through
//! `describe_parameters` (description, floating_point_range [0, 1], not read-only) and
//! `catalogue` (read-only); a value out of range (1.5, accepted before descriptors) and a
//! change of a read-only parameter are refused with their reason and change nothing; a valid
//! change (0.05) takes effect at once: of two identical slender blocks fed the same record,
//! the one fed before the change raises `overturn_imminent` at |θ|/α ≈ 0.5 (the file's
//! threshold), the one fed after it at |θ|/α ≈ 0.05; the change (only it) is announced on
//! `/parameter_events`, through the node's one writer of it, volatile as rcl's.
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
fn rclpy_peer_sees_rockwatch_in_its_namespace_and_its_parameters_have_descriptors_and_ranges() {
    if !rclpy_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let catalogue = dir.path().join("catalogue.toml");
    write_catalogue(&catalogue);
    write_node_config(dir.path(), &catalogue);
    // The ROS 2 parameter file: a wildcard section (another node's parameter in it is
    // skipped with a log line), then this node's own section, which wins.
    std::fs::write(
        dir.path().join("params.yaml"),
        concat!(
            "/**:\n",
            "  ros__parameters:\n",
            "    alerts:\n",
            "      imminent_theta_ratio: 0.3\n",
            "    other_nodes_param: 1\n",
            "/site_a/rockwatch:\n",
            "  ros__parameters:\n",
            "    alerts.imminent_theta_ratio: 0.5\n",
        ),
    )
    .unwrap();
    let d = dir.path().display();
    let bin = rockwatch().display().to_string();
    let py = repo().join("tests/data/ros2/rclpy_params.py");
    let py = py.display();
    let rec = repo().join("tests/data/records");
    let rec = rec.display();
    let replay = |station: &str| {
        format!(
            "'{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' \
             --azimuth 228 --station {station} --transport ros2 --speed max --tail 5 --wait-s 20 \
             --ros-args -r __ns:=/site_a >/dev/null"
        )
    };
    // Waits (≤ 20 s) until `id`'s overturned alert is journaled.
    let wait_overturned = |id: &str| {
        format!(
            "i=0; until grep -q '\"{id}\".*\"overturned\"' '{d}/state/journal.log' 2>/dev/null; do \
             i=$((i+1)); [ $i -lt 200 ] || {{ echo NO_OVERTURNED_{id}; break; }}; sleep 0.1; done"
        )
    };
    let peer = format!("python3 '{py}' --wait-s 30 --node /site_a/rockwatch");
    let script = format!(
        "trap \"cat '{d}/node.err' >&2\" EXIT
         {VETH_TX}
         '{bin}' node --config '{d}/node.toml' --state-dir '{d}/state' \
             --ros-args -r __ns:=/site_a --params-file '{d}/params.yaml' -p alerts.quiet_s:=20.0 \
             2> '{d}/node.err' & NODE=$!
         {peer} --get alerts.imminent_theta_ratio --get alerts.quiet_s \
             --describe alerts.imminent_theta_ratio --describe catalogue --get catalogue \
             --writers /parameter_events | sed 's/^/BEFORE /'
         {}
         {}
         {peer} --events --set alerts.imminent_theta_ratio=1.5 --get alerts.imminent_theta_ratio \
             --set catalogue=/elsewhere.toml --set alerts.imminent_theta_ratio=0.05 \
             --get alerts.imminent_theta_ratio | sed 's/^/AFTER /'
         {}
         {}
         sleep 1
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         {VETH_TX}
         '{bin}' alerts --state-dir '{d}/state' --format json | tr -d '\\n' | sed 's/^/JOURNAL /'; echo",
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
    assert!(
        stderr.contains("parameter other_nodes_param is not a parameter of rockwatch: ignored"),
        "{stderr}"
    );

    // The graph; the values of the file's node section and of -p; the descriptors.
    let before = json_lines(&stdout, "BEFORE ");
    assert_eq!(before.len(), 7, "{stdout}\n{stderr}");
    let graph = before[0]["graph"].as_array().unwrap();
    assert!(
        graph.contains(&serde_json::json!(["rockwatch", "/site_a"])),
        "{graph:?}"
    );
    assert_eq!(before[1]["get"], "alerts.imminent_theta_ratio");
    assert_eq!(before[1]["type"], 3, "PARAMETER_DOUBLE");
    assert_eq!(before[1]["value"], 0.5);
    assert_eq!(before[2]["value"], 20.0);
    let ratio = &before[3];
    assert_eq!(ratio["type"], 3, "{ratio}");
    assert!(
        ratio["description"].as_str().unwrap().contains("|θ|/α"),
        "{ratio}"
    );
    assert_eq!(
        ratio["floating_point_range"],
        serde_json::json!([[0.0, 1.0, 0.0]])
    );
    assert_eq!(ratio["additional_constraints"], "greater than 0");
    assert_eq!(ratio["read_only"], false);
    let catalogue_d = &before[4];
    assert_eq!(catalogue_d["type"], 4, "PARAMETER_STRING: {catalogue_d}");
    assert_eq!(catalogue_d["read_only"], true, "{catalogue_d}");
    assert_eq!(before[5]["value"], catalogue.display().to_string());
    // One /parameter_events writer, volatile, as rcl's (rmw_qos_profile_parameter_events);
    // ros2-client 0.12.1 gave the node two, transient local (crates/vendor/README.md). (A
    // writer's history depth is not announced in discovery: the peer sees 0.)
    assert_eq!(
        before[6]["of_node"],
        serde_json::json!([{"durability": "VOLATILE", "reliability": "RELIABLE", "depth": 0}]),
        "{}",
        before[6]
    );

    // Out of range and read-only refused with the reason, nothing changed; a valid change.
    let after = json_lines(&stdout, "AFTER ");
    assert_eq!(after.len(), 7, "{stdout}\n{stderr}");
    // The accepted change, and only it, announced on /parameter_events.
    assert_eq!(
        after[6]["event"],
        serde_json::json!({"node": "/site_a/rockwatch", "changed": [["alerts.imminent_theta_ratio", 0.05]]}),
        "{stdout}"
    );
    assert_eq!(after[1]["successful"], false, "{}", after[1]);
    assert!(
        after[1]["reason"]
            .as_str()
            .unwrap()
            .contains("1.5 is out of range [0, 1]"),
        "{}",
        after[1]
    );
    assert_eq!(after[2]["value"], 0.5);
    assert_eq!(after[3]["successful"], false, "{}", after[3]);
    assert!(
        after[3]["reason"].as_str().unwrap().contains("read-only"),
        "{}",
        after[3]
    );
    assert_eq!(after[4]["successful"], true, "{}", after[4]);
    assert_eq!(after[5]["value"], 0.05);

    // Effect: each block's overturn_imminent at its threshold in force (|θ|/α crosses the
    // threshold continuously, so the alert's |θ|/α is just above it).
    let journal = stdout
        .lines()
        .find_map(|l| l.strip_prefix("JOURNAL "))
        .unwrap_or_else(|| panic!("no journal\n{stdout}"));
    let records: Vec<serde_json::Value> = serde_json::from_str(journal).unwrap();
    let imminent = |id: &str| -> f64 {
        let found: Vec<f64> = records
            .iter()
            .filter(|r| {
                r["type"] == "alert" && r["pbr_id"] == id && r["level"] == "overturn_imminent"
            })
            .map(|a| a["theta_over_alpha"].as_f64().unwrap().abs())
            .collect();
        assert_eq!(found.len(), 1, "{id}: {journal}");
        found[0]
    };
    let (one, two) = (imminent("pillar-one"), imminent("pillar-two"));
    assert!((0.5..0.6).contains(&one), "pillar-one at |θ|/α = {one}");
    assert!((0.05..0.1).contains(&two), "pillar-two at |θ|/α = {two}");
}
