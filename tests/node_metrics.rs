//! The node's Prometheus endpoint, scraped from a real `rockwatch node` in a private network
//! namespace (issue 20 item 5):
//! - before any data every station is NO DATA YET (4), not OK (0), while
//!   `engine.stale_after_s` (60 s) has not passed (/diagnostics: tests/ros2_diagnostics.rs);
//! - every rock of the catalogue has its series from the start: state (the `PbrState` wire
//!   code), |θ|/α now and its peak, and whether it is monitored;
//! - after the Rinaldi record on CI.RRS.00 the slender pillar is overturned (state 4, a peak
//!   |θ|/α ≥ 1), the stocky boulder stands (state 0), CI.RRS.00 is no longer NO DATA YET
//!   while CI.SYL.00, never heard from, still is;
//! - the same record sent again is counted per station as duplicate and late packets.

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::netns::{run_in_netns, text};
use rockwatch_test_harness::node_output::{
    labelled_value, parse_prometheus, station_value, Sample,
};
use rockwatch_test_harness::rockwatch_bin;

const ROCKS: [&str; 7] = [
    "rrs-slender-pillar",
    "rrs-stocky-boulder",
    "rrs-sliding-slab",
    "rrs-pinnacle-ensemble",
    "syl-slender-tombstone",
    "syl-stocky-block",
    "syl-slide-rock-column",
];

#[test]
fn metrics_report_rocks_duplicates_and_stations_with_no_data_yet() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().display().to_string();
    std::fs::write(
        dir.path().join("node.toml"),
        format!(
            "catalogue = \"{}\"\n[engine]\nstale_after_s = 60.0\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n\
             [status]\ndiagnostics_period_s = 0.2\n[metrics]\nlisten = \"127.0.0.1:9464\"\n",
            repo().join("config/catalogue.toml").display()
        ),
    )
    .unwrap();
    let bin = rockwatch_bin!().display().to_string();
    let rec = repo().join("tests/data/records");
    let rec = rec.display();
    let replay = format!(
        "'{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' \
         --azimuth 228 --station CI.RRS.00 --transport ros2 --speed max --tail 2 --wait-s 20 >/dev/null"
    );
    let scrape = "curl -sf --max-time 5 http://127.0.0.1:9464/metrics";
    let script = format!(
        "'{bin}' node --config '{d}/node.toml' 2> '{d}/node.err' & NODE=$!
         i=0; until {scrape} | grep -q rockwatch_station_status; do i=$((i+1)); [ $i -lt 300 ] || break; sleep 0.1; done
         {scrape} > '{d}/start.txt'
         {replay}
         sleep 1
         {scrape} > '{d}/live.txt'
         {replay} || echo SECOND_REPLAY_RC=$?
         sleep 1
         {scrape} > '{d}/again.txt'
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?"
    );
    let out = run_in_netns(
        &script,
        120,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let read = |name: &str| std::fs::read_to_string(dir.path().join(name)).unwrap_or_default();
    let (stdout, stderr) = text(&out);
    let context = format!(
        "--- stdout\n{stdout}\n--- stderr\n{stderr}\n--- node\n{}\n--- metrics at start\n{}\n--- after the record\n{}\n--- after it again\n{}",
        read("node.err"),
        read("start.txt"),
        read("live.txt"),
        read("again.txt")
    );
    assert!(
        out.status.success() && stdout.contains("NODE_RC=0"),
        "{context}"
    );
    let parse =
        |name: &str| parse_prometheus(&read(name)).unwrap_or_else(|e| panic!("{e}\n{context}"));
    let (start, live, again) = (parse("start.txt"), parse("live.txt"), parse("again.txt"));
    let rock = |samples: &[Sample], name: &str, pbr: &str| {
        labelled_value(samples, &format!("rockwatch_rock_{name}"), &[("pbr", pbr)])
            .unwrap_or_else(|| panic!("no rockwatch_rock_{name} of {pbr}\n{context}"))
    };

    // Before any data: NO DATA YET (4), not OK (0), well before stale_after_s.
    for station in ["CI.RRS.00", "CI.SYL.00"] {
        assert_eq!(
            station_value(&start, "rockwatch_station_status", station),
            Some(4.0),
            "{station}\n{context}"
        );
    }
    for pbr in ROCKS {
        assert_eq!(rock(&start, "state", pbr), 0.0, "{pbr} at rest\n{context}");
        assert_eq!(rock(&start, "theta_over_alpha", pbr), 0.0);
        assert_eq!(rock(&start, "peak_theta_over_alpha", pbr), 0.0);
        assert_eq!(rock(&start, "not_monitored", pbr), 0.0);
    }
    assert_eq!(
        labelled_value(
            &start,
            "rockwatch_rock_state",
            &[("pbr", "rrs-slender-pillar"), ("station", "CI.RRS.00")]
        ),
        Some(0.0),
        "each rock is labelled with its station\n{context}"
    );

    // After the record: the pillar fell, the boulder stands, RRS has data, SYL still none.
    assert_eq!(rock(&live, "state", "rrs-slender-pillar"), 4.0, "{context}");
    assert!(
        rock(&live, "peak_theta_over_alpha", "rrs-slender-pillar") >= 1.0,
        "{context}"
    );
    assert_eq!(rock(&live, "state", "rrs-stocky-boulder"), 0.0, "{context}");
    assert!(rock(&live, "peak_theta_over_alpha", "rrs-stocky-boulder") < 1.0);
    assert_eq!(rock(&live, "not_monitored", "rrs-slender-pillar"), 0.0);
    assert_ne!(
        station_value(&live, "rockwatch_station_status", "CI.RRS.00"),
        Some(4.0),
        "{context}"
    );
    assert_eq!(
        station_value(&live, "rockwatch_station_status", "CI.SYL.00"),
        Some(4.0),
        "{context}"
    );
    assert_eq!(
        station_value(
            &live,
            "rockwatch_station_duplicate_packets_total",
            "CI.RRS.00"
        ),
        Some(0.0),
        "{context}"
    );

    // The same record again: every packet was processed already.
    let packets = station_value(&live, "rockwatch_station_packets_total", "CI.RRS.00")
        .unwrap_or_else(|| panic!("{context}"));
    let duplicates = station_value(
        &again,
        "rockwatch_station_duplicate_packets_total",
        "CI.RRS.00",
    )
    .unwrap_or_else(|| panic!("{context}"));
    let late = station_value(&again, "rockwatch_station_late_packets_total", "CI.RRS.00")
        .unwrap_or_else(|| panic!("{context}"));
    assert!(
        duplicates >= packets * 0.9 && late > 0.0,
        "{packets} packets, then {duplicates} duplicates, {late} late\n{context}"
    );
    assert_eq!(
        station_value(&again, "rockwatch_station_late_packets_total", "CI.SYL.00"),
        Some(0.0)
    );
}
