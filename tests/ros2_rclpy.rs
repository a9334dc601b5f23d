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

use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::{run_in_netns, text, VETH_TX};
use rockwatch_test_harness::node_output::json_lines;
use rockwatch_test_harness::peers::{have_cyclonedds, peer_available};
use rockwatch_test_harness::rockwatch_bin;

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
    let bin = rockwatch_bin!().display().to_string();
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

/// `visualization_msgs` from PyPI for the markers peer (pinned in .ci/run).
fn visualization_msgs_available() -> bool {
    let ok = std::process::Command::new("python3")
        .args(["-c", "import visualization_msgs.msg, rclpy"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    peer_available(
        ok,
        "python3 with ros-rclpy[fastrtps] and ros-visualization-msgs==5.5.1",
        "see .ci/run",
    )
}

/// WGS84 meridian radius of curvature at `lat_deg` (m): a(1−e²)/(1−e² sin²φ)^{3/2}.
fn meridian_radius_m(lat_deg: f64) -> f64 {
    let (a, f) = (6_378_137.0, 1.0 / 298.257_223_563);
    let e2 = f * (2.0 - f);
    let s2 = lat_deg.to_radians().sin().powi(2);
    a * (1.0 - e2) / (1.0 - e2 * s2).powf(1.5)
}

/// `v` rotated by `angle` (rad) about the unit `axis` (Rodrigues).
fn rotate(v: [f64; 3], axis: [f64; 3], angle: f64) -> [f64; 3] {
    let (s, c) = angle.sin_cos();
    let cross = [
        axis[1] * v[2] - axis[2] * v[1],
        axis[2] * v[0] - axis[0] * v[2],
        axis[0] * v[1] - axis[1] * v[0],
    ];
    let dot = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2];
    std::array::from_fn(|k| v[k] * c + cross[k] * s + axis[k] * dot * (1.0 - c))
}

fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The 3-D view (issue 22 §3) seen by independent peers: rclpy + Fast DDS with
/// `visualization_msgs` from PyPI on `/site_a/pbr/markers` (the relative name in the node's
/// namespace), Cyclone DDS with `tf2_msgs/TFMessage` declared from its definition on
/// `/tf_static`, and the node's `PbrState`s. A node in `/site_a` started with
/// `-p use_sim_time:=true` (before it was declared, the node refused to start), map origin at
/// the pillar; the Rinaldi record overturns the slender pillar; the stocky boulder 0.001° north
/// only slips. Checked: the static frames map → pbr/<id> at their ENU positions (the boulder at the
/// meridian arc north, closed form); every PbrState in its rock's frame; a subscriber joining
/// after the event (transient local) gets the whole picture: the pillar red, posed by its last
/// state's θ about the axis across its direction through its pivot (computed here with
/// Rodrigues' formula), the boulder green, upright, slid by its last state's slide along its
/// direction, their labels, the station's cylinder;
/// and the live subscriber got a few arrays (at most 5 a second), not one per state.
#[test]
fn rclpy_and_cyclone_peers_see_the_rocks_markers_posed_by_their_state_and_their_frames() {
    if !visualization_msgs_available() || !have_cyclonedds() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (lat, lon) = (34.28, -118.48);
    let catalogue = dir.path().join("catalogue.toml");
    let block = |id: &str, lat: f64, width_m: f64, height_m: f64, mu_s: f64, mu_k: f64| {
        format!(
            "[[pbr]]\nid = \"{id}\"\nname = \"{id}\"\nlat = {lat:?}\nlon = {lon:?}\n\
             station = \"CI.RRS.00\"\nazimuth_deg = 228.0\nwidth_m = {width_m:?}\n\
             height_m = {height_m:?}\nmu_s = {mu_s:?}\nmu_k = {mu_k:?}\nsource = \"test\"\n\n"
        )
    };
    std::fs::write(
        &catalogue,
        block("pillar", lat, 0.30, 1.50, 0.70, 0.55)
            + &block("boulder", lat + 0.001, 2.0, 1.6, 0.9, 0.7),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("node.toml"),
        format!(
            "catalogue = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n\
             map_origin = [{lat:?}, {lon:?}, 120.0]\n\
             [[station]]\nid = \"CI.RRS.00\"\nlat = {lat:?}\nlon = {:?}\n",
            catalogue.display(),
            lon + 0.001
        ),
    )
    .unwrap();
    let d = dir.path().display();
    let bin = rockwatch_bin!().display().to_string();
    let markers_py = repo().join("tests/data/ros2/rclpy_markers.py");
    let markers_py = markers_py.display();
    let frames_py = repo().join("tests/data/ros2/cyclone_frames.py");
    let frames_py = frames_py.display();
    let msg = repo().join("msg/pbr_msgs/msg");
    let msg = msg.display();
    let rec = repo().join("tests/data/records");
    let rec = rec.display();
    let script = format!(
        "trap \"cat '{d}/node.err' '{d}/frames.err' '{d}/live.err' '{d}/late.err' >&2\" EXIT
         '{bin}' node --config '{d}/node.toml' --state-dir '{d}/state' \
             --ros-args -r __ns:=/site_a -p use_sim_time:=true 2> '{d}/node.err' & NODE=$!
         python3 '{frames_py}' '{msg}' /site_a/pbr/state --seconds 60 > '{d}/frames.out' 2> '{d}/frames.err' & FRAMES=$!
         python3 '{markers_py}' /site_a/pbr/markers --seconds 60 --until-fallen pillar \
             > '{d}/live.out' 2> '{d}/live.err' & LIVE=$!
         sleep 4
         START=$(date +%s.%N)
         '{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' \
             --azimuth 228 --station CI.RRS.00 --transport ros2 --speed max --tail 5 --wait-s 20 \
             --ros-args -r __ns:=/site_a > /dev/null
         wait $LIVE
         echo LIVE_S=$START $(date +%s.%N)
         sleep 1
         python3 '{markers_py}' /site_a/pbr/markers --seconds 5 \
             > '{d}/late.out' 2> '{d}/late.err'
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         kill $FRAMES 2>/dev/null; wait $FRAMES
         sed 's/^/FRAMES /' '{d}/frames.out'; sed 's/^/LIVE /' '{d}/live.out'
         sed 's/^/LATE /' '{d}/late.out'"
    );
    let out = run_in_netns(
        &script,
        150,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{stderr}");
    assert!(stderr.contains("use_sim_time = true: accepted"), "{stderr}");

    // /tf_static: map → pbr/boulder, pbr/pillar, identity rotations; the pillar at the
    // origin, the boulder 0.001° north: the meridian arc at the origin's height (chord within
    // 1 mm at 111 m), below the tangent plane by d²/2R (≈ 1 mm).
    let frames = json_lines(&stdout, "FRAMES ");
    let tf: Vec<&serde_json::Value> = frames.iter().filter_map(|v| v.get("tf")).collect();
    assert!(!tf.is_empty(), "no /tf_static\n{stdout}\n{stderr}");
    let transforms = tf[tf.len() - 1].as_array().unwrap();
    assert_eq!(transforms.len(), 2, "{transforms:?}");
    let frame = |child: &str| {
        transforms
            .iter()
            .find(|t| t["child"] == child)
            .unwrap_or_else(|| panic!("no {child}: {transforms:?}"))
    };
    for t in transforms {
        assert_eq!(t["parent"], "map", "{t}");
        assert_eq!(floats(&t["rotation"]), [0.0, 0.0, 0.0, 1.0], "{t}");
    }
    let pillar_enu = floats(&frame("pbr/pillar")["translation"]);
    assert!(pillar_enu.iter().all(|v| v.abs() < 1e-6), "{pillar_enu:?}");
    let boulder_enu = floats(&frame("pbr/boulder")["translation"]);
    // At the origin's height (120 m): the arc's radius is M + h.
    let north = (meridian_radius_m(lat + 0.0005) + 120.0) * 0.001_f64.to_radians();
    assert!(boulder_enu[0].abs() < 1e-6, "{boulder_enu:?}");
    assert!(
        (boulder_enu[1] - north).abs() < 1e-3,
        "{boulder_enu:?} vs {north}"
    );
    assert!((-0.01..0.0).contains(&boulder_enu[2]), "{boulder_enu:?}");

    // Every state in its rock's frame; the station in its own field.
    let states: Vec<&serde_json::Value> = frames.iter().filter_map(|v| v.get("state")).collect();
    assert!(states.len() > 5, "{stdout}");
    for s in &states {
        assert_eq!(
            s["frame_id"].as_str().unwrap(),
            format!("pbr/{}", s["pbr_id"].as_str().unwrap()),
            "{s}"
        );
        assert_eq!(s["station"], "CI.RRS.00", "{s}");
    }
    let last = states
        .iter()
        .rev()
        .find(|s| s["pbr_id"] == "pillar")
        .unwrap();
    assert_eq!(
        last["mode"], 4,
        "the pillar's last state: OVERTURNED: {last}"
    );
    let (theta, slide, az) = (
        last["theta"].as_f64().unwrap(),
        last["slide"].as_f64().unwrap(),
        last["direction_deg"].as_f64().unwrap(),
    );

    // The late subscriber's last array (transient local, keep last 1: the whole picture). It
    // listens 5 s rather than stopping at the first array with the pillar fallen: RustDDS may
    // still deliver a sample the live subscriber left unacknowledged (the fall) before the
    // newest (the station's health colour, a status period later).
    let late = json_lines(&stdout, "LATE ");
    assert!(!late.is_empty(), "no late markers\n{stdout}\n{stderr}");
    let markers = late[late.len() - 1]["markers"].as_array().unwrap().clone();
    assert_eq!(markers[0]["action"], 3, "DELETEALL first: {}", markers[0]);
    let find = |ns: &str, text: Option<&str>, id: Option<i64>| -> serde_json::Value {
        markers
            .iter()
            .find(|m| {
                m["ns"] == ns
                    && text.is_none_or(|t| m["text"] == t)
                    && id.is_none_or(|i| m["id"] == i)
            })
            .unwrap_or_else(|| panic!("no {ns} {text:?} {id:?}: {markers:?}"))
            .clone()
    };
    let pillar_id = find("pbr_label", Some("pillar"), None)["id"]
        .as_i64()
        .unwrap();
    let boulder_id = find("pbr_label", Some("boulder"), None)["id"]
        .as_i64()
        .unwrap();
    let pillar = find("pbr", None, Some(pillar_id));
    let boulder = find("pbr", None, Some(boulder_id));
    for m in [&pillar, &boulder] {
        assert_eq!(m["frame_id"], "map", "{m}");
        assert_eq!(m["type"], 11, "TRIANGLE_LIST: {m}");
        assert_eq!(m["points"], 36, "a box, 12 triangles: {m}");
        assert_eq!(m["action"], 0, "{m}");
    }
    // Colours: the pillar fallen (red), the boulder standing (green).
    let color = |m: &serde_json::Value| floats(&m["color"]);
    assert!(
        color(&pillar)[0] > 0.8 && color(&pillar)[1] < 0.2,
        "{pillar}"
    );
    assert!(
        color(&boulder)[1] > 0.6 && color(&boulder)[0] < 0.3,
        "{boulder}"
    );
    // The pillar's box: 0.3 m wide, 1.5 m high (its points at rest, in the marker's pose).
    let bbox = &pillar["bbox"];
    assert!((bbox[1][2].as_f64().unwrap() - 1.5).abs() < 1e-9, "{bbox}");
    // Its pose from its last state: rotation θ about z × d, d = (sin az, cos az, 0), through
    // the pivot σ·0.15 m along d, slid by `slide` along d.
    let d = [az.to_radians().sin(), az.to_radians().cos(), 0.0];
    let axis = [-d[1], d[0], 0.0];
    let (s, c) = (theta / 2.0).sin_cos();
    let want_q = [axis[0] * s, axis[1] * s, 0.0, c];
    let q = floats(&pillar["orientation"]);
    for k in 0..4 {
        assert!(
            (q[k] - want_q[k]).abs() < 1e-9,
            "{q:?} vs {want_q:?} (θ {theta}, az {az})"
        );
    }
    assert!(theta.abs() > 1.0, "the pillar lies tilted: θ {theta}");
    let pivot = d.map(|x| x * 0.15 * theta.signum());
    let turned = rotate(pivot, axis, theta);
    let want_p: [f64; 3] = std::array::from_fn(|k| slide * d[k] + pivot[k] - turned[k]);
    let p = floats(&pillar["position"]);
    for k in 0..3 {
        assert!((p[k] - want_p[k]).abs() < 1e-6, "{p:?} vs {want_p:?}");
    }
    // The boulder upright (at rest, θ = 0) at its frame's place, moved by its last state's
    // slide along its direction (the record makes it slip a few cm).
    let boulder_last = states
        .iter()
        .rev()
        .find(|s| s["pbr_id"] == "boulder")
        .unwrap();
    assert_eq!(boulder_last["mode"], 0, "at rest: {boulder_last}");
    assert_eq!(floats(&boulder["orientation"]), [0.0, 0.0, 0.0, 1.0]);
    let slid = boulder_last["slide"].as_f64().unwrap();
    let bp = floats(&boulder["position"]);
    for k in 0..3 {
        let want = boulder_enu[k] + slid * d[k];
        assert!(
            (bp[k] - want).abs() < 1e-9,
            "{bp:?} vs {boulder_enu:?} + {slid} d"
        );
    }
    // The station: a cylinder 0.001° east of the pillar, labelled with its id.
    let station = find("station", None, Some(0));
    assert_eq!(station["type"], 3, "{station}");
    assert!(floats(&station["position"])[0] > 90.0, "{station}");
    assert_eq!(find("station_label", None, Some(0))["text"], "CI.RRS.00");

    // Live: the start picture and the fall, at most one array per 200 ms, far fewer than the
    // states.
    let live = json_lines(&stdout, "LIVE ");
    let live_s: f64 = stdout
        .lines()
        .find_map(|l| l.strip_prefix("LIVE_S="))
        .and_then(|v| {
            let (from, to) = v.trim().split_once(' ')?;
            Some(to.parse::<f64>().ok()? - from.parse::<f64>().ok()?)
        })
        .unwrap_or_else(|| panic!("{stdout}"));
    println!(
        "3-D view: {} marker arrays in {live_s:.1} s for {} states; pillar θ {theta:.3} rad",
        live.len(),
        states.len()
    );
    assert!(live.len() >= 2, "{stdout}");
    // The station's cylinder coloured by its health, as on the dashboard: grey (#999: NO DATA
    // YET, as STALE) in the start picture, before any packet; not grey in the late picture,
    // fed well within engine.stale_after_s (60 s) and after a status period (1 s).
    let grey = |m: &serde_json::Value| {
        floats(&m["color"])
            .iter()
            .zip([0.6, 0.6, 0.6, 1.0])
            .all(|(c, g)| (c - g).abs() < 1e-3)
    };
    let first_station = live[0]["markers"]
        .as_array()
        .and_then(|a| a.iter().find(|m| m["ns"] == "station"))
        .unwrap_or_else(|| panic!("no station in the start picture: {}", live[0]));
    assert!(grey(first_station), "{first_station}");
    assert!(!grey(&station), "{station}");
    assert!(
        (live.len() as f64) <= 2.0 + (live_s + 4.0) * 5.0,
        "{} arrays in {live_s} s",
        live.len()
    );
    assert!(
        live.len() < states.len(),
        "{} arrays for {} states",
        live.len(),
        states.len()
    );
}
