//! The node's logs and status, end to end through the binary, in a private network namespace:
//! `rockwatch node --log-format json` with `engine.stale_after_s = 3`, a Prometheus endpoint,
//! and an independent ROS 2 peer (rclpy with Fast DDS and the message definitions of
//! diagnostic_msgs, rcl_interfaces and the colcon build of msg/: tests/data/ros2/rclpy_status.py)
//! on /diagnostics, /rosout and /pbr/state.
//!
//! The Rinaldi record is replayed on CI.RRS.00, the node is left without data for 6 s, then a
//! second replay follows. Checked:
//! - every stderr line of the node is one JSON object with timestamp, level, target, fields;
//!   every journaled alert is logged once (level, pbr id, station, data time, both latencies);
//! - CI.RRS.00 goes stale (a log line; STALE on /diagnostics; a /pbr/state of each of its four
//!   blocks with not_monitored = true) and recovers (a log line; states with not_monitored =
//!   false); before its first packet it is NO DATA YET (health value; STALE is the nearest
//!   diagnostic_msgs level), not OK; CI.SYL.00, which never sent, is STALE with "no data yet"
//!   once stale_after_s has passed;
//! - /diagnostics carries the node's items (journal, transports, engine) and per station the
//!   data latency, sample rate and counters, decoded by the peer's own type support;
//! - /rosout carries the alert records (level WARN = 30) under the node's logger name;
//! - the metrics endpoint, scraped over loopback, parses as the Prometheus text format with
//!   the same figures.
//!
//! Without rclpy, diagnostic_msgs or the pbr_msgs build the test is skipped locally and FAILS
//! under CI=true.

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::netns::{run_in_netns, text};
use rockwatch_test_harness::node_output::{parse_prometheus, station_value};
use rockwatch_test_harness::peers::{pbr_msgs_install, peer_available, source_pbr_msgs};
use rockwatch_test_harness::rockwatch_bin;

use std::collections::BTreeSet;

const RRS_BLOCKS: [&str; 4] = [
    "rrs-slender-pillar",
    "rrs-stocky-boulder",
    "rrs-sliding-slab",
    "rrs-pinnacle-ensemble",
];

fn peer_ready() -> Option<std::path::PathBuf> {
    let ok = std::process::Command::new("python3")
        .args([
            "-c",
            "import rclpy, diagnostic_msgs.msg, rcl_interfaces.msg",
        ])
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
    pbr_msgs_install()
}

#[test]
fn node_logs_json_reports_station_health_on_diagnostics_rosout_state_and_metrics() {
    let Some(prefix) = peer_ready() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().display().to_string();
    std::fs::write(
        dir.path().join("node.toml"),
        format!(
            "catalogue = \"{}\"\n[engine]\nstale_after_s = 3.0\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n\
             [status]\ndiagnostics_period_s = 0.5\nrosout_level = \"info\"\n\
             [metrics]\nlisten = \"127.0.0.1:9464\"\n",
            repo().join("config/catalogue.toml").display()
        ),
    )
    .unwrap();
    let bin = rockwatch_bin!().display().to_string();
    let py = repo().join("tests/data/ros2/rclpy_status.py");
    let rec = repo().join("tests/data/records");
    let rec = rec.display();
    let replay = format!(
        "'{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' \
         --azimuth 228 --station CI.RRS.00 --transport ros2 --speed max --tail 2 --wait-s 20 >/dev/null"
    );
    let scrape = "python3 -c \"import urllib.request as u; print(u.urlopen('http://127.0.0.1:9464/metrics', timeout=5).read().decode(), end='')\"";
    let script = format!(
        "{source}
         '{bin}' --log-format json node --config '{d}/node.toml' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         python3 '{py}' --seconds 60 > '{d}/peer.out' 2> '{d}/peer.err' & PEER=$!
         i=0; until grep -q ready '{d}/peer.out'; do i=$((i+1)); [ $i -lt 300 ] || break; sleep 0.1; done
         sleep 2
         {replay}
         sleep 1
         {scrape} > '{d}/metrics_live.txt'
         sleep 6
         {scrape} > '{d}/metrics_stale.txt'
         {replay}
         sleep 2
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         sleep 1; kill -TERM $PEER; wait $PEER || true
         '{bin}' alerts --state-dir '{d}/state' --format json > '{d}/alerts.json'",
        source = source_pbr_msgs(&prefix),
        py = py.display(),
    );
    let out = run_in_netns(
        &script,
        150,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let read = |name: &str| std::fs::read_to_string(dir.path().join(name)).unwrap_or_default();
    let (stdout, stderr) = text(&out);
    let (node_err, peer_out) = (read("node.err"), read("peer.out"));
    let context = format!(
        "--- script stdout\n{stdout}\n--- script stderr\n{stderr}\n--- node stderr\n{node_err}\n--- peer (diagnostics of CI.RRS.00 and every state)\n{}\n{}",
        peer_out
            .lines()
            .filter(|l| l.contains("\"state\"") || l.contains("rosout"))
            .chain(peer_out.lines().filter(|l| l.contains("diagnostics")).flat_map(|l| {
                l.split("}, {").filter(|s| s.contains("CI.RRS.00")).take(1)
            }))
            .collect::<Vec<_>>()
            .join("\n"),
        read("peer.err")
    );
    assert!(
        out.status.success() && stdout.contains("NODE_RC=0"),
        "{context}"
    );

    // 1. Every line of the node's stderr is one JSON object: timestamp, level, target, fields.
    let logs: Vec<serde_json::Value> = node_err
        .lines()
        .map(|l| {
            serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON ({e}): {l}\n{context}"))
        })
        .collect();
    for l in &logs {
        assert!(
            l["timestamp"].is_string()
                && l["level"].is_string()
                && l["target"].is_string()
                && l["fields"]["message"].is_string(),
            "{l}"
        );
    }
    // Every journaled alert is logged once, with its figures.
    let journal: Vec<serde_json::Value> = serde_json::from_str(&read("alerts.json")).unwrap();
    let journaled: BTreeSet<(String, String, u64)> = journal
        .iter()
        .filter(|r| r["type"] == "alert")
        .map(|r| {
            (
                r["pbr_id"].as_str().unwrap().to_string(),
                r["level"].as_str().unwrap().to_string(),
                r["episode"].as_u64().unwrap(),
            )
        })
        .collect();
    let logged: Vec<&serde_json::Value> = logs
        .iter()
        .filter(|l| l["target"] == "rockwatch::alert")
        .collect();
    assert!(!journaled.is_empty(), "no alert journaled\n{context}");
    let logged_keys: BTreeSet<(String, String, u64)> = logged
        .iter()
        .map(|l| {
            let f = &l["fields"];
            assert_eq!(l["level"], "WARN", "{l}");
            assert_eq!(f["station"], "CI.RRS.00", "{l}");
            assert!(f["data_time"].as_str().unwrap().ends_with('Z'), "{l}");
            let data_latency_ms = f["data_latency_ms"].as_f64().unwrap();
            let latency_ms = f["latency_ms"].as_f64().unwrap();
            // Restamped to end now: the data reach the node within seconds; the node's own
            // part (journal sync included) is well under a second.
            assert!((-1000.0..30_000.0).contains(&data_latency_ms), "{l}");
            assert!((0.0..1000.0).contains(&latency_ms), "{l}");
            (
                f["pbr_id"].as_str().unwrap().to_string(),
                f["level"].as_str().unwrap().to_string(),
                f["episode"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        logged.len(),
        logged_keys.len(),
        "an alert logged twice\n{context}"
    );
    assert_eq!(logged_keys, journaled, "{context}");
    // Station health in the log: RRS stale then recovered, SYL (never sent) stale.
    let health: Vec<(String, bool)> = logs
        .iter()
        .filter(|l| l["target"] == "rockwatch::health")
        .map(|l| {
            (
                l["fields"]["station"].as_str().unwrap().to_string(),
                l["fields"]["monitored"].as_bool().unwrap(),
            )
        })
        .collect();
    let rrs: Vec<bool> = health
        .iter()
        .filter(|(s, _)| s == "CI.RRS.00")
        .map(|h| h.1)
        .collect();
    // Stale (maybe already before the first replay, with data from none), recovered by a
    // replay, stale in the silence between the replays, recovered by the second: alternating.
    assert!(
        rrs.len() >= 2
            && rrs.iter().enumerate().all(|(i, &m)| m == (i % 2 == 1))
            && rrs.len().is_multiple_of(2),
        "CI.RRS.00 monitored: {rrs:?}\n{context}"
    );
    // The silence between the replays: stale after the first alert.
    let first_alert = logs
        .iter()
        .position(|l| l["target"] == "rockwatch::alert")
        .unwrap();
    assert!(
        logs[first_alert..]
            .iter()
            .any(|l| l["target"] == "rockwatch::health"
                && l["fields"]["station"] == "CI.RRS.00"
                && l["fields"]["monitored"] == false),
        "{context}"
    );
    assert!(
        health.contains(&("CI.SYL.00".into(), false)),
        "CI.SYL.00 never sent: stale\n{context}"
    );

    // 2. The peer's view.
    let peer: Vec<serde_json::Value> = peer_out
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect();
    // /pbr/state: each RRS block flagged not monitored, then monitored again, in that order.
    for block in RRS_BLOCKS {
        let flags: Vec<bool> = peer
            .iter()
            .filter(|m| m["state"]["pbr_id"] == block)
            .map(|m| m["state"]["not_monitored"].as_bool().unwrap())
            .collect();
        let first_stale = flags.iter().position(|&f| f);
        assert!(
            first_stale.is_some_and(|i| flags[i..].contains(&false)),
            "{block}: no not_monitored state, or no recovery after it: {flags:?}\n{context}"
        );
    }
    // /diagnostics.
    let arrays: Vec<&serde_json::Value> = peer
        .iter()
        .filter(|m| m["diagnostics"].is_array())
        .collect();
    assert!(
        arrays.len() >= 10,
        "{} DiagnosticArrays\n{context}",
        arrays.len()
    );
    let find = |a: &serde_json::Value, name: &str| -> Option<serde_json::Value> {
        a["diagnostics"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["name"] == name)
            .cloned()
    };
    let rrs_name = "rockwatch: station CI.RRS.00";
    let rrs_levels: Vec<(u64, String)> = arrays
        .iter()
        .filter_map(|a| find(a, rrs_name))
        .map(|s| {
            (
                s["level"].as_u64().unwrap(),
                s["values"]["health"].as_str().unwrap_or("").to_string(),
            )
        })
        .collect();
    // No data yet before the replay (STALE = 3 on /diagnostics, health "NO DATA YET", not
    // OK), then receiving data (OK), then STALE while silent.
    assert_eq!(
        rrs_levels.first().map(|(l, h)| (*l, h.as_str())),
        Some((3, "NO DATA YET")),
        "CI.RRS.00 levels {rrs_levels:?}\n{context}"
    );
    // (A STALE before the first OK is right too: a station silent for stale_after_s from the
    // node's start is stale; on a loaded machine the replay may start that late.)
    let ok_at = rrs_levels.iter().position(|(l, h)| *l == 0 && h == "OK");
    assert!(
        ok_at.is_some_and(|i| rrs_levels[i..].iter().any(|(l, h)| *l == 3 && h == "STALE")),
        "CI.RRS.00 levels {rrs_levels:?}\n{context}"
    );
    let live = arrays
        .iter()
        .filter_map(|a| find(a, rrs_name))
        .find(|s| s["level"] == 0 && s["values"]["packets"] != "0")
        .unwrap_or_else(|| panic!("no OK report with data\n{context}"));
    assert_eq!(live["hardware_id"], "CI.RRS.00");
    let v = &live["values"];
    assert_eq!(v["sample_rate_hz"], "100", "{live}");
    let latency: f64 = v["data_latency_s"].as_str().unwrap().parse().unwrap();
    assert!((-1.0..30.0).contains(&latency), "{live}");
    assert!(
        v["last_data_time"].as_str().unwrap().ends_with('Z'),
        "{live}"
    );
    for key in [
        "rejected_packets",
        "rejected_samples",
        "clipped_samples",
        "gaps_broken",
        "missing_samples",
    ] {
        assert_eq!(v[key], "0", "{key}: {live}");
    }
    let stale = arrays
        .iter()
        .filter_map(|a| find(a, rrs_name))
        .find(|s| s["level"] == 3 && s["values"]["health"] == "STALE")
        .unwrap();
    assert!(
        stale["message"].as_str().unwrap().contains("not monitored"),
        "{stale}"
    );
    let last = arrays.last().unwrap();
    let syl = find(last, "rockwatch: station CI.SYL.00").unwrap();
    assert!(
        syl["level"] == 3
            && syl["values"]["health"] == "STALE"
            && syl["message"].as_str().unwrap().contains("no data yet"),
        "{syl}"
    );
    for item in ["journal", "transports", "engine"] {
        let s = find(last, &format!("rockwatch: {item}"))
            .unwrap_or_else(|| panic!("{item}\n{context}"));
        assert_eq!(s["level"], 0, "{s}");
    }
    // An alert's latencies appear once the station has raised one.
    assert!(
        find(last, rrs_name).unwrap()["values"]["last_alert_arrival_to_published_s"].is_string(),
        "{context}"
    );
    // /rosout: the alerts at WARN (30) under the node's logger name.
    let rosout_alerts = peer
        .iter()
        .filter(|m| {
            m["rosout"]["msg"]
                .as_str()
                .is_some_and(|t| t.starts_with("ALERT "))
        })
        .collect::<Vec<_>>();
    assert!(!rosout_alerts.is_empty(), "no alert on /rosout\n{context}");
    for m in &rosout_alerts {
        assert_eq!(m["rosout"]["level"], 30, "{m}");
        assert_eq!(m["rosout"]["name"], "rockwatch", "{m}");
        assert_eq!(m["rosout"]["function"], "rockwatch::alert", "{m}");
    }

    // 3. The metrics endpoint, as a scraper reads it.
    let context = format!(
        "{context}\n--- metrics (live)\n{}",
        read("metrics_live.txt")
    );
    let live =
        parse_prometheus(&read("metrics_live.txt")).unwrap_or_else(|e| panic!("{e}\n{context}"));
    let stale =
        parse_prometheus(&read("metrics_stale.txt")).unwrap_or_else(|e| panic!("{e}\n{context}"));
    assert!(
        station_value(&live, "rockwatch_station_packets_total", "CI.RRS.00")
            .is_some_and(|p| p > 0.0)
    );
    assert_eq!(
        station_value(&live, "rockwatch_station_status", "CI.RRS.00"),
        Some(0.0),
        "{context}"
    );
    assert_eq!(
        station_value(&live, "rockwatch_station_sample_rate_hz", "CI.RRS.00"),
        Some(100.0)
    );
    assert_eq!(
        station_value(&stale, "rockwatch_station_status", "CI.RRS.00"),
        Some(3.0)
    );
    assert_eq!(
        station_value(&stale, "rockwatch_station_monitored", "CI.RRS.00"),
        Some(0.0)
    );
    assert_eq!(
        station_value(&stale, "rockwatch_station_stale_events_total", "CI.RRS.00"),
        Some(rrs.iter().filter(|&&m| !m).count() as f64),
        "as many as the stale lines logged (the second replay ends the last)"
    );
    assert!(stale
        .iter()
        .any(|(n, _, v)| n == "rockwatch_alerts_total" && *v >= 1.0));
}

#[test]
fn the_prometheus_parser_of_this_test_rejects_what_is_not_the_format() {
    assert!(parse_prometheus("# TYPE a counter\na 1\n").is_ok());
    assert!(parse_prometheus("a 1\n").is_err(), "untyped sample");
    assert!(parse_prometheus("# TYPE a counter\na one\n").is_err());
    assert!(parse_prometheus("# TYPE a histogramm\n").is_err());
    let s = parse_prometheus("# TYPE a gauge\na{station=\"X.Y.00\",k=\"v\"} 2.5\n").unwrap();
    assert_eq!(s[0].1["station"], "X.Y.00");
    assert_eq!(s[0].1["k"], "v");
}
