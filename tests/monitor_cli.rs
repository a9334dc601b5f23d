//! `rockwatch monitor`, `alerts`, `reset` and `status --state-dir` end to end through the binary.

use rockwatch_test_harness::rockwatch_bin;
use std::path::Path;
use std::process::Output;

fn monitor_rinaldi(state_dir: Option<&Path>, env: &[(&str, &str)]) -> Output {
    let mut args = vec![
        "monitor",
        "--config",
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/node.toml"),
        "--record",
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/records/Rinaldi228.AT2"
        ),
        "--vertical",
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/records/RinaldiUP.AT2"
        ),
        "--azimuth",
        "228",
        "--station",
        "CI.RRS.00",
        "--format",
        "jsonl",
    ];
    let dir;
    if let Some(d) = state_dir {
        dir = d.to_str().unwrap().to_string();
        args.extend(["--state-dir", &dir]);
    }
    rockwatch_bin!().run(&args).envs(env).output()
}

fn lines(out: &Output) -> Vec<serde_json::Value> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn alert_ids(values: &[serde_json::Value]) -> Vec<String> {
    values
        .iter()
        .filter(|v| v["type"] == "alert")
        .map(|v| format!("{} {} {}", v["pbr_id"], v["episode"], v["level"]))
        .collect()
}

#[test]
fn jsonl_reports_alerts_then_a_summary_that_matches_the_catalogue_claims() {
    let out = monitor_rinaldi(None, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let values = lines(&out);
    let summary = values.last().unwrap();
    assert_eq!(summary["type"], "summary");
    let pbr = |id: &str| {
        summary["pbrs"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["pbr_id"] == id)
            .unwrap()
            .clone()
    };
    // config/catalogue.toml documents: the slender pillar falls, the stocky boulder does not
    // rock, the slab slides tens of cm without rocking.
    assert_eq!(pbr("rrs-slender-pillar")["overturned"], true);
    assert_eq!(pbr("rrs-stocky-boulder")["max_theta_over_alpha"], 0.0);
    assert!(pbr("rrs-sliding-slab")["max_slide_m"].as_f64().unwrap() > 0.1);
    let levels: Vec<_> = values
        .iter()
        .filter(|v| v["type"] == "alert" && v["pbr_id"] == "rrs-slender-pillar")
        .map(|v| v["level"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(levels, ["motion_onset", "overturn_imminent", "overturned"]);
    for key in [
        "pbr_id",
        "station",
        "level",
        "mode",
        "theta_over_alpha",
        "slide_m",
        "overturn_probability",
        "pga_mps2",
        "pgv_mps",
        "data_time",
    ] {
        assert!(values[0].get(key).is_some(), "alert lacks {key}");
    }
}

#[test]
fn state_dir_keeps_history_and_a_second_run_adds_no_duplicates() {
    let dir = tempfile::tempdir().unwrap();
    let first = monitor_rinaldi(Some(dir.path()), &[]);
    assert!(first.status.success());
    let first_alerts = alert_ids(&lines(&first));
    assert!(!first_alerts.is_empty());
    let second = monitor_rinaldi(Some(dir.path()), &[]);
    assert!(second.status.success());
    assert!(
        alert_ids(&lines(&second)).is_empty(),
        "replaying the same record re-alerted"
    );
    let history = rockwatch_bin!().output(&[
        "alerts",
        "--state-dir",
        dir.path().to_str().unwrap(),
        "--format",
        "json",
    ]);
    assert!(history.status.success());
    let records: Vec<serde_json::Value> = serde_json::from_slice(&history.stdout).unwrap();
    assert_eq!(
        records.iter().filter(|r| r["type"] == "alert").count(),
        first_alerts.len()
    );
}

#[test]
fn crash_between_journal_and_report_loses_and_duplicates_nothing() {
    let uninterrupted = alert_ids(&lines(&monitor_rinaldi(None, &[])));
    for crash_at in ["1", "3"] {
        let dir = tempfile::tempdir().unwrap();
        let crashed = monitor_rinaldi(
            Some(dir.path()),
            &[("ROCKWATCH_FAULT_ABORT_AFTER_JOURNAL", crash_at)],
        );
        assert!(!crashed.status.success(), "fault injection must abort");
        let restarted = monitor_rinaldi(Some(dir.path()), &[]);
        assert!(restarted.status.success());
        // The history in the state directory equals the uninterrupted run's alerts.
        let history = rockwatch_bin!().output(&[
            "alerts",
            "--state-dir",
            dir.path().to_str().unwrap(),
            "--format",
            "json",
        ]);
        let records: Vec<serde_json::Value> = serde_json::from_slice(&history.stdout).unwrap();
        let mut journaled: Vec<String> = records
            .iter()
            .filter(|r| r["type"] == "alert")
            .map(|a| format!("{} {} {}", a["pbr_id"], a["episode"], a["level"]))
            .collect();
        journaled.sort();
        let mut expected = uninterrupted.clone();
        expected.sort();
        assert_eq!(journaled, expected, "crash after alert {crash_at}");
    }
}

#[test]
fn reset_lets_a_fallen_block_fall_again_in_a_new_episode() {
    let dir = tempfile::tempdir().unwrap();
    assert!(monitor_rinaldi(Some(dir.path()), &[]).status.success());
    let d = dir.path().to_str().unwrap();
    let reset =
        rockwatch_bin!().output(&["reset", "--state-dir", d, "--pbr", "rrs-slender-pillar"]);
    assert!(
        reset.status.success(),
        "{}",
        String::from_utf8_lossy(&reset.stderr)
    );
    let again = lines(&monitor_rinaldi(Some(dir.path()), &[]));
    let pillar: Vec<_> = again
        .iter()
        .filter(|v| v["type"] == "alert" && v["pbr_id"] == "rrs-slender-pillar")
        .map(|v| {
            (
                v["episode"].as_u64().unwrap(),
                v["level"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(pillar.last(), Some(&(2, "overturned".to_string())));
    let unknown = rockwatch_bin!().output(&["reset", "--state-dir", d, "--pbr", "no-such-rock"]);
    assert!(!unknown.status.success());
}

/// `monitor --format jsonl`, `alerts --format json` and `alerts` (text) speak one schema:
/// the same alert objects (monitor adds only `t_s` and `latency_us`), the other records tagged
/// by `type`, and the data time as ISO 8601 UTC.
#[test]
fn alerts_and_monitor_share_one_alert_schema_with_iso_times() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let monitored = lines(&monitor_rinaldi(Some(dir.path()), &[]));
    let mut printed: Vec<serde_json::Value> = monitored
        .into_iter()
        .filter(|v| v["type"] == "alert")
        .collect();
    assert!(!printed.is_empty());
    for v in &mut printed {
        let o = v.as_object_mut().unwrap();
        assert!(o.remove("t_s").is_some() && o.remove("latency_us").is_some());
    }
    assert!(rockwatch_bin!()
        .output(&["reset", "--state-dir", d, "--pbr", "rrs-slender-pillar"])
        .status
        .success());
    let json = rockwatch_bin!().output(&["alerts", "--state-dir", d, "--format", "json"]);
    assert!(json.status.success());
    let records: Vec<serde_json::Value> = serde_json::from_slice(&json.stdout).unwrap();
    let journaled: Vec<_> = records
        .iter()
        .filter(|r| r["type"] == "alert")
        .cloned()
        .collect();
    assert_eq!(journaled, printed);
    for a in &journaled {
        let keys: Vec<&str> = a.as_object().unwrap().keys().map(String::as_str).collect();
        for key in [
            "type",
            "pbr_id",
            "level",
            "episode",
            "data_time",
            "data_time_ns",
            "station",
            "mode",
            "theta_over_alpha",
            "slide_m",
            "overturn_probability",
            "pga_mps2",
            "pgv_mps",
        ] {
            assert!(keys.contains(&key), "{key} missing in {a}");
        }
        // ISO 8601 UTC with ns: YYYY-MM-DDTHH:MM:SS.fffffffffZ.
        let t = a["data_time"].as_str().unwrap();
        assert!(
            t.len() == 30 && &t[10..11] == "T" && t.ends_with('Z'),
            "{t}"
        );
    }
    let reset = records.last().unwrap();
    assert_eq!(
        (&reset["type"], &reset["pbr_id"]),
        (
            &serde_json::json!("reset"),
            &serde_json::json!("rrs-slender-pillar")
        )
    );
    assert!(records
        .iter()
        .all(|r| ["alert", "episode_end", "reset"].contains(&r["type"].as_str().unwrap())));
    // Text: the same ISO times, no raw nanoseconds.
    let text = rockwatch_bin!().output(&["alerts", "--state-dir", d]);
    assert!(text.status.success());
    let text = String::from_utf8(text.stdout).unwrap();
    assert!(
        text.lines().next().unwrap().contains("time (UTC)"),
        "{text}"
    );
    for a in &journaled {
        assert!(text.contains(a["data_time"].as_str().unwrap()), "{text}");
        let ns = a["data_time_ns"].to_string();
        assert!(ns.len() < 10 || !text.contains(&ns), "{text}");
    }
}

#[test]
fn bad_invocations_fail_with_one_line() {
    let cases: [&[&str]; 4] = [
        &[
            "monitor",
            "--catalogue",
            concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/catalogue.toml"),
            "--record",
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../tests/data/records/Rinaldi228.AT2"
            ),
            "--station",
            "XX.NONE.00",
        ],
        &[
            "monitor",
            "--catalogue",
            "missing.toml",
            "--record",
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../tests/data/records/Rinaldi228.AT2"
            ),
            "--station",
            "CI.RRS.00",
        ],
        &[
            "monitor",
            "--catalogue",
            concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/catalogue.toml"),
            "--record",
            "nope.AT2",
            "--station",
            "CI.RRS.00",
        ],
        &[
            "monitor",
            "--record",
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../tests/data/records/Rinaldi228.AT2"
            ),
            "--station",
            "CI.RRS.00",
        ],
    ];
    for args in cases {
        let out = rockwatch_bin!().output(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert_eq!(stderr.lines().count(), 1, "{args:?}: {stderr}");
    }
}

#[test]
fn mseed_in_counts_with_station_gain_matches_the_file_in_mps2() {
    // K-NET AKT013 (E-W) as MiniSEED, once in counts and once in m/s² (tests/data/mseed/README.md:
    // gain 2.384185791015625e-06 (m/s²)/count). Its PGA is only 0.044 m/s², so the block is an
    // extremely slender one (tan α = 0.002) that rocks under it.
    let dir = tempfile::tempdir().unwrap();
    let catalogue = dir.path().join("cat.toml");
    std::fs::write(
        &catalogue,
        "[[pbr]]\nid = \"needle\"\nname = \"needle\"\nlat = 39.6\nlon = 140.3\nstation = \"BO.AKT01.\"\n\
         azimuth_deg = 90.0\nwidth_m = 0.01\nheight_m = 5.0\nmu_s = 0.8\nmu_k = 0.6\nsource = \"test\"\n",
    )
    .unwrap();
    let config = dir.path().join("node.toml");
    std::fs::write(
        &config,
        "catalogue = \"cat.toml\"\n[[station]]\nid = \"BO.AKT01.\"\ngain_mps2_per_count = 2.384185791015625e-06\n",
    )
    .unwrap();
    let summary = |args: &[&str]| {
        let out = rockwatch_bin!().output(args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        lines(&out).last().unwrap()["pbrs"][0].clone()
    };
    let counts = summary(&[
        "monitor",
        "--config",
        config.to_str().unwrap(),
        "--mseed",
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/mseed/knet_AKT013_HNE_counts.mseed"
        ),
        "--station",
        "BO.AKT01.",
        "--format",
        "jsonl",
    ]);
    let mps2 = summary(&[
        "monitor",
        "--catalogue",
        catalogue.to_str().unwrap(),
        "--mseed",
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/mseed/knet_AKT013_HNE_ms2.mseed"
        ),
        "--station",
        "BO.AKT01.",
        "--format",
        "jsonl",
    ]);
    let (a, b) = (
        counts["max_theta_over_alpha"].as_f64().unwrap(),
        mps2["max_theta_over_alpha"].as_f64().unwrap(),
    );
    assert!(a > 0.01, "the block must rock: {counts}");
    // Packets carry f32: the two paths round differently (counts exact, m/s² to 2^-24).
    assert!((a - b).abs() <= 1e-4 * a.max(b), "{a} vs {b}");
}

/// Issue 11 ("the journal rotates/compacts so it does not grow forever"), with the fault
/// injection of the crash tests: a state directory whose journal has passed its bound
/// (`journal::COMPACT_AT_BYTES`) is compacted when `monitor` opens it; the process is aborted
/// half-way through the temporary file, before the rename and before the directory sync. After
/// each crash the journal is the old one or the compacted one, never a mix; the next run
/// compacts it and raises exactly the alerts of a run without the old history, and the old
/// history's fallen block stays fallen.
#[test]
fn a_crash_during_journal_compaction_loses_nothing() {
    use rockwatch::journal::{
        read_journal, Journal, COMPACT_AT_BYTES, COMPACT_TMP, HISTORY_ALERTS, REHEARSAL_MARKER,
    };
    use rockwatch_core::dynamics::Mode;
    use rockwatch_core::engine::{
        compact_journal, fallen_blocks, Alert, AlertLevel, JournalRecord,
    };
    let uninterrupted = alert_ids(&lines(&monitor_rinaldi(None, &[])));
    let alert = |episode: u32, level| {
        JournalRecord::Alert(Alert {
            pbr_id: rockwatch_core::engine::PbrId::parse("old-rock").unwrap(),
            station: rockwatch_core::engine::StationId::parse("CI.OLD.00").unwrap(),
            level,
            episode,
            mode: Mode::Rock,
            theta_over_alpha: 1.0,
            slide_m: 0.0,
            overturn_probability: 1.0,
            pga_mps2: 3.0,
            pgv_mps: 0.5,
            data_time_ns: i64::from(episode) * 1_000_000_000,
            arrival_ns: 0,
            direction_deg: 0.0,
            lat_deg: Default::default(),
            lon_deg: Default::default(),
            pbr_name: Default::default(),
        })
    };
    // Years of a block that kept falling and being reset; fallen in its last episode.
    // (A rehearsal's directory, as `monitor` marks it: monitor never writes a node's.)
    let history = |dir: &Path| -> Vec<JournalRecord> {
        std::fs::write(dir.join(REHEARSAL_MARKER), "").unwrap();
        let (mut j, _, _) = Journal::open(dir).unwrap();
        let mut episode = 0;
        while j.len_bytes() <= COMPACT_AT_BYTES {
            episode += 1;
            for level in [AlertLevel::MotionOnset, AlertLevel::Overturned] {
                j.append_unsynced(&alert(episode, level)).unwrap();
                j.append_unsynced(&JournalRecord::Published {
                    pbr_id: rockwatch_core::engine::PbrId::parse("old-rock").unwrap(),
                    episode,
                    level,
                })
                .unwrap();
            }
            j.append_unsynced(&JournalRecord::Reset {
                pbr_id: rockwatch_core::engine::PbrId::parse("old-rock").unwrap(),
                time_ns: None,
            })
            .unwrap();
        }
        j.append(&alert(episode + 1, AlertLevel::Overturned))
            .unwrap();
        read_journal(dir).unwrap().0
    };
    for stage in ["mid-temporary", "before-rename", "before-dir-sync"] {
        let dir = tempfile::tempdir().unwrap();
        let old = history(dir.path());
        let crashed = monitor_rinaldi(
            Some(dir.path()),
            &[("ROCKWATCH_FAULT_ABORT_IN_COMPACTION", stage)],
        );
        assert!(!crashed.status.success(), "{stage}: the fault must abort");
        let (after, report) = read_journal(dir.path()).unwrap();
        assert!(
            report.corrupt_lines.is_empty() && !report.truncated_tail,
            "{stage}"
        );
        if stage == "before-dir-sync" {
            assert_eq!(after, compact_journal(&old, HISTORY_ALERTS), "{stage}");
        } else {
            assert_eq!(after, old, "{stage}: the old journal, whole");
            assert!(dir.path().join(COMPACT_TMP).exists(), "{stage}");
        }
        let restarted = monitor_rinaldi(Some(dir.path()), &[]);
        assert!(
            restarted.status.success(),
            "{stage}: {}",
            String::from_utf8_lossy(&restarted.stderr)
        );
        assert!(!dir.path().join(COMPACT_TMP).exists(), "{stage}");
        let size = std::fs::metadata(dir.path().join("journal.log"))
            .unwrap()
            .len();
        assert!(size < COMPACT_AT_BYTES / 8, "{stage}: {size} bytes");
        let (records, _) = read_journal(dir.path()).unwrap();
        assert!(fallen_blocks(&records).contains("old-rock"), "{stage}");
        let mut got: Vec<String> = records
            .iter()
            .filter_map(|r| match r {
                JournalRecord::Alert(a) if a.pbr_id != "old-rock" => Some(format!(
                    "\"{}\" {} \"{}\"",
                    a.pbr_id,
                    a.episode,
                    a.level.as_str()
                )),
                _ => None,
            })
            .collect();
        got.sort();
        let mut expected = uninterrupted.clone();
        expected.sort();
        assert_eq!(got, expected, "{stage}");
    }
}

#[test]
fn a_device_given_as_a_file_is_refused_not_read_until_memory_runs_out() {
    // Issue 24 item 8: `--mseed /dev/urandom` read until memory ran out. Input files are read
    // up to a bound (rockwatch_core::bounded_read), here a never-ending device.
    let catalogue = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/catalogue.toml");
    let out = rockwatch_bin!().output(&[
        "monitor",
        "--catalogue",
        catalogue,
        "--station",
        "CI.RRS.00",
        "--mseed",
        "/dev/zero",
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("/dev/zero") && stderr.contains("the most read of such a file"),
        "{stderr}"
    );
    // A configuration too.
    let out = rockwatch_bin!().output(&[
        "monitor",
        "--config",
        "/dev/zero",
        "--station",
        "CI.RRS.00",
        "--mseed",
        "/dev/null",
    ]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("the most read of such a file"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Issue 20 item 1: `monitor --config node.toml` wrote its alerts into the configuration's
/// `state_dir`, which the next node published again as its own (starting with a rock fallen).
/// The configuration's state directory is the node's: monitor never writes it; `--state-dir`
/// gives a rehearsal a directory of its own, and one a node holds or held is refused.
#[test]
fn monitor_never_writes_a_nodes_state_directory() {
    let dir = tempfile::tempdir().unwrap();
    let node_state = dir.path().join("node-state");
    let config = dir.path().join("node.toml");
    std::fs::write(
        &config,
        format!(
            "catalogue = {:?}\nstate_dir = \"node-state\"\n",
            concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/catalogue.toml")
        ),
    )
    .unwrap();
    let monitor = |extra: &[&str]| {
        let mut args = vec![
            "monitor",
            "--config",
            config.to_str().unwrap(),
            "--record",
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../tests/data/records/Rinaldi228.AT2"
            ),
            "--azimuth",
            "228",
            "--station",
            "CI.RRS.00",
            "--format",
            "jsonl",
        ];
        args.extend(extra);
        rockwatch_bin!().output(&args)
    };
    // The configuration's state_dir: untouched, and the user is told why.
    let out = monitor(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!alert_ids(&lines(&out)).is_empty());
    assert!(
        !node_state.exists(),
        "monitor wrote the node's state directory"
    );
    assert!(
        stderr.contains("is the node's: monitor does not write it"),
        "{stderr}"
    );

    // A directory that holds a node's journal (what a node leaves: journal and lock file):
    // refused, and left as it was.
    let (journal, _, _) = rockwatch::journal::Journal::open(&node_state).unwrap();
    drop(journal);
    let listing = |d: &Path| {
        let mut names: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        names
    };
    let before = listing(&node_state);
    let journal_len = || {
        std::fs::metadata(node_state.join(rockwatch::journal::JOURNAL_FILE))
            .unwrap()
            .len()
    };
    let out = monitor(&["--state-dir", node_state.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("holds or held a node's state"), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert_eq!(listing(&node_state), before);
    assert_eq!(journal_len(), 0);
    // Held by a running process: said as such.
    let (held, _, _) = rockwatch::journal::Journal::open(&node_state).unwrap();
    let out = monitor(&["--state-dir", node_state.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("in use by another rockwatch process"),
        "{stderr}"
    );
    drop(held);
    assert_eq!(journal_len(), 0);

    // A directory of its own: journaled, marked as a rehearsal, and usable again by monitor.
    let rehearsal = dir.path().join("rehearsal-state");
    let first = monitor(&["--state-dir", rehearsal.to_str().unwrap()]);
    assert!(first.status.success());
    assert!(!alert_ids(&lines(&first)).is_empty());
    assert!(rehearsal
        .join(rockwatch::journal::REHEARSAL_MARKER)
        .is_file());
    let second = monitor(&["--state-dir", rehearsal.to_str().unwrap()]);
    assert!(
        second.status.success(),
        "{}",
        String::from_utf8_lossy(&second.stderr)
    );
    assert!(
        alert_ids(&lines(&second)).is_empty(),
        "restored, not re-alerted"
    );
}

/// Issue 20 item 2: only the first problem of a catalogue was reported per run. The CLI lists
/// every one (here three in two entries) under one error line, and exits 1.
#[test]
fn a_catalogue_with_several_problems_lists_them_all_in_one_run() {
    let dir = tempfile::tempdir().unwrap();
    let catalogue = dir.path().join("catalogue.toml");
    let entry = |id: &str, lat: &str, extra: &str| {
        format!(
            "[[pbr]]\nid = \"{id}\"\nname = \"N\"\nlat = {lat}\nlon = -118.48\n\
             station = \"CI.RRS.00\"\nazimuth_deg = 228\nwidth_m = 0.3\nheight_m = 1.5\n\
             mu_s = 0.7\nmu_k = 0.5\n{extra}\n"
        )
    };
    std::fs::write(
        &catalogue,
        entry("a", "34.28", "") + &entry("b", "134.28", "source = \"x\"\nseed = -1"),
    )
    .unwrap();
    let out = rockwatch_bin!().output(&[
        "monitor",
        "--catalogue",
        catalogue.to_str().unwrap(),
        "--record",
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/records/Rinaldi228.AT2"
        ),
        "--station",
        "CI.RRS.00",
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr.lines().collect();
    let path = catalogue.display();
    assert_eq!(
        lines,
        [
            format!("rockwatch: error: {path}: 3 problems in the catalogue:"),
            format!(
                "  {path}:1: pbr[0] (id \"a\"): missing field `source` (required: where the \
                 numbers come from, e.g. a survey, a paper, or \"illustrative\" for made-up \
                 values)"
            ),
            format!("  {path}:13: pbr[1] (id \"b\"): lat = 134.28 must be in [-90, 90] degrees"),
            format!(
                "  {path}:13: pbr[1] (id \"b\"): seed = -1 must be an integer from 0 to \
                 18446744073709551615"
            ),
        ],
        "{stderr}"
    );
}

/// The README's table of journal records: `type` → its keys.
fn documented_record_keys() -> std::collections::BTreeMap<String, Vec<String>> {
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../README.md")).unwrap();
    readme
        .lines()
        .filter(|l| l.starts_with("| `") && l.split('|').count() == 5)
        .filter_map(|l| {
            let cells: Vec<&str> = l.split('|').map(str::trim).collect();
            let kind = cells[1].trim_matches('`');
            ["alert", "episode_end", "reset", "published"]
                .contains(&kind)
                .then(|| {
                    let mut keys: Vec<String> = cells[2]
                        .split(", ")
                        .map(|k| k.trim_matches('`').to_owned())
                        .collect();
                    keys.push("type".into());
                    keys.sort();
                    (kind.to_owned(), keys)
                })
        })
        .collect()
}

/// Issue 20 item 7: reset rows had no time, there were no filters, and the `published`
/// records `alerts --format json` shows were not in the documented schema.
#[test]
fn alerts_filter_by_time_block_and_level_and_every_record_has_its_documented_keys() {
    use rockwatch::journal::Journal;
    use rockwatch_core::engine::{AlertLevel, JournalRecord};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    // 60 s of quiet: the blocks that did not fall end their episode.
    let mut args: Vec<String> = [
        "monitor",
        "--config",
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/node.toml"),
        "--record",
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/records/Rinaldi228.AT2"
        ),
        "--azimuth",
        "228",
        "--station",
        "CI.RRS.00",
        "--tail",
        "60",
        "--state-dir",
    ]
    .map(String::from)
    .to_vec();
    args.push(d.to_owned());
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    assert!(rockwatch_bin!().output(&args).status.success());
    let before_ns = rockwatch::journal::utc_now_ns();
    let reset =
        rockwatch_bin!().output(&["reset", "--state-dir", d, "--pbr", "rrs-slender-pillar"]);
    assert!(reset.status.success());
    let after_ns = rockwatch::journal::utc_now_ns();
    // A node's publication marker, and a reset journaled before resets had a time.
    {
        let (mut j, _, _) = Journal::open(dir.path()).unwrap();
        j.append(&JournalRecord::Published {
            pbr_id: rockwatch_core::engine::PbrId::parse("rrs-slender-pillar").unwrap(),
            episode: 1,
            level: AlertLevel::Overturned,
        })
        .unwrap();
        j.append(&JournalRecord::Reset {
            pbr_id: rockwatch_core::engine::PbrId::parse("rrs-sliding-slab").unwrap(),
            time_ns: None,
        })
        .unwrap();
    }
    let json = |extra: &[&str]| -> (Vec<serde_json::Value>, String) {
        let mut args = vec!["alerts", "--state-dir", d, "--format", "json"];
        args.extend(extra);
        let out = rockwatch_bin!().output(&args);
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{stderr}");
        (serde_json::from_slice(&out.stdout).unwrap(), stderr)
    };
    let (all, _) = json(&[]);
    let kinds = |records: &[serde_json::Value]| -> Vec<String> {
        records
            .iter()
            .map(|r| r["type"].as_str().unwrap().to_owned())
            .collect()
    };
    // Every record has exactly the keys the README documents for its type (the timeless
    // reset excepted: it has no time).
    let documented = documented_record_keys();
    assert_eq!(documented.len(), 4, "{documented:?}");
    for kind in ["alert", "episode_end", "reset", "published"] {
        assert!(
            kinds(&all).contains(&kind.to_owned()),
            "no {kind} in {all:?}"
        );
    }
    for r in &all {
        let mut keys: Vec<String> = r.as_object().unwrap().keys().cloned().collect();
        keys.sort();
        let expected = &documented[r["type"].as_str().unwrap()];
        if r["type"] == "reset" && r.get("time").is_none() {
            assert_eq!(r["pbr_id"], "rrs-sliding-slab");
            continue;
        }
        assert_eq!(&keys, expected, "{r}");
    }
    // The reset's time: when the command ran, in ISO and ns.
    let reset = all
        .iter()
        .find(|r| r["type"] == "reset" && r["pbr_id"] == "rrs-slender-pillar")
        .unwrap();
    let t = reset["time_ns"].as_i64().unwrap();
    assert!((before_ns..=after_ns).contains(&t), "{reset}");
    assert!(reset["time"].as_str().unwrap().ends_with('Z'));
    // The text shows it on the reset row; the timeless one shows `-`.
    let text = String::from_utf8(
        rockwatch_bin!()
            .output(&["alerts", "--state-dir", d])
            .stdout,
    )
    .unwrap();
    let row = |pbr: &str| {
        text.lines()
            .find(|l| l.starts_with(pbr) && l.contains("reset by operator"))
            .unwrap_or_else(|| panic!("{text}"))
            .to_owned()
    };
    assert!(
        row("rrs-slender-pillar").ends_with(reset["time"].as_str().unwrap()),
        "{text}"
    );
    assert!(row("rrs-sliding-slab").ends_with(" -"), "{text}");
    let ends = all.iter().filter(|r| r["type"] == "episode_end");
    for end in ends {
        assert!(text.contains(end["data_time"].as_str().unwrap()), "{text}");
    }

    // --pbr: that block's records only.
    let (pillar, _) = json(&["--pbr", "rrs-slender-pillar"]);
    assert!(!pillar.is_empty());
    assert!(pillar.iter().all(|r| r["pbr_id"] == "rrs-slender-pillar"));
    assert_eq!(
        pillar.len(),
        all.iter()
            .filter(|r| r["pbr_id"] == "rrs-slender-pillar")
            .count()
    );
    // --level: alerts at that level or above (and the marker of the one kept), the other
    // records kept.
    let (overturned, _) = json(&["--level", "overturn_imminent"]);
    let levels: Vec<&str> = overturned
        .iter()
        .filter(|r| r["type"] == "alert")
        .map(|r| r["level"].as_str().unwrap())
        .collect();
    assert!(levels.contains(&"overturned") && levels.contains(&"overturn_imminent"));
    assert!(!levels.contains(&"motion_onset"), "{levels:?}");
    assert_eq!(
        kinds(&overturned)
            .iter()
            .filter(|k| *k == "published")
            .count(),
        1
    );
    assert_eq!(
        kinds(&overturned)
            .iter()
            .filter(|k| *k == "episode_end")
            .count(),
        kinds(&all).iter().filter(|k| *k == "episode_end").count()
    );
    let (onset, _) = json(&["--level", "overturned", "--pbr", "rrs-sliding-slab"]);
    assert!(onset.iter().all(|r| r["type"] != "alert"), "{onset:?}");
    // --since the pillar's overturn: the later alerts, the episode ends (later) and the
    // timed reset; the timeless reset is left out and counted.
    let overturn = all
        .iter()
        .find(|r| r["type"] == "alert" && r["level"] == "overturned")
        .unwrap();
    let (since, stderr) = json(&["--since", overturn["data_time"].as_str().unwrap()]);
    let since_alerts: Vec<&serde_json::Value> =
        since.iter().filter(|r| r["type"] == "alert").collect();
    assert_eq!(since_alerts.len(), 1, "{since:?}");
    assert_eq!(since_alerts[0], overturn);
    assert!(since.iter().any(|r| r["type"] == "episode_end"));
    assert!(since.iter().any(|r| r == reset));
    assert!(!since
        .iter()
        .any(|r| r["pbr_id"] == "rrs-sliding-slab" && r["type"] == "reset"));
    assert!(
        stderr.contains("1 episode ends or resets journaled before"),
        "{stderr}"
    );
    // A time that is not one: one line, exit 1.
    let bad = rockwatch_bin!().output(&["alerts", "--state-dir", d, "--since", "yesterday"]);
    assert!(!bad.status.success());
    assert_eq!(String::from_utf8_lossy(&bad.stderr).lines().count(), 1);
}

/// `status --state-dir` on a rehearsal's journal (issue 22 §2): the Rinaldi record overturns
/// the slender pillar: exit 1, the pillar `fallen` with its episode's direction, peak |θ|/α
/// (≥ 1: it passed α) and P(overturn) 1; after `reset` the same directory gives exit 0, and
/// with `--catalogue` every rock of the catalogue is listed (those without records standing).
/// A directory that does not exist is an error: exit 2, not a silent "all is well".
#[test]
fn status_of_a_state_dir_exits_1_while_a_rock_lies_and_0_after_its_reset() {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("state");
    assert!(monitor_rinaldi(Some(&state), &[]).status.success());
    let s = state.to_str().unwrap();
    let status = |extra: &[&str]| {
        let mut args = vec!["status", "--state-dir", s, "--format", "json"];
        args.extend(extra);
        let out = rockwatch_bin!().output(&args);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout)
            .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stderr)));
        (out.status.code(), v)
    };
    let (code, v) = status(&[]);
    assert_eq!(code, Some(1), "{v}");
    assert_eq!(
        v["fallen"],
        serde_json::json!(["rrs-slender-pillar"]),
        "{v}"
    );
    assert_eq!(v["exit_code"], 1);
    let pillar = v["rocks"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["pbr_id"] == "rrs-slender-pillar")
        .unwrap();
    assert_eq!(pillar["state"], "fallen", "{pillar}");
    assert_eq!(pillar["direction_deg"], 228.0, "{pillar}");
    assert_eq!(pillar["overturn_probability"], 1.0, "{pillar}");
    assert!(
        pillar["peak_theta_over_alpha"].as_f64().unwrap() >= 1.0,
        "{pillar}"
    );
    assert_eq!(pillar["station_health"], "unknown", "{pillar}");
    // The text table says why.
    let text = rockwatch_bin!().output(&["status", "--state-dir", s]);
    assert_eq!(text.status.code(), Some(1));
    let table = String::from_utf8_lossy(&text.stdout);
    assert!(
        table.contains("ALARM: 1 fallen (rrs-slender-pillar)"),
        "{table}"
    );

    let reset =
        rockwatch_bin!().output(&["reset", "--state-dir", s, "--pbr", "rrs-slender-pillar"]);
    assert!(reset.status.success());
    let catalogue = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/catalogue.toml");
    let (code, v) = status(&["--catalogue", catalogue]);
    assert_eq!(code, Some(0), "{v}");
    assert_eq!(v["fallen"], serde_json::json!([]));
    let rocks = v["rocks"].as_array().unwrap();
    assert_eq!(rocks.len(), 7, "every rock of the catalogue: {v}");
    let tombstone = rocks
        .iter()
        .find(|r| r["pbr_id"] == "syl-slender-tombstone")
        .unwrap();
    assert_eq!(tombstone["state"], "standing", "{tombstone}");
    assert!(tombstone["peak_theta_over_alpha"].is_null(), "{tombstone}");

    let missing = dir.path().join("nowhere");
    let out = rockwatch_bin!().output(&["status", "--state-dir", missing.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no such directory"));
    // A usage error is 2 as well (1 is the alarm).
    assert_eq!(rockwatch_bin!().output(&["status"]).status.code(), Some(2));
}

/// The samples of an AT2 file (in g), read here independently of the crate's reader.
fn at2_samples(path: &str) -> (f64, Vec<f64>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.nth(3).unwrap();
    let dt: f64 = header
        .split("DT=")
        .nth(1)
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .trim_end_matches(',')
        .parse()
        .unwrap();
    let values = lines
        .flat_map(|l| l.split_whitespace())
        .map(|v| v.parse::<f64>().unwrap())
        .collect();
    (dt, values)
}

/// Issue 22 §4: the pillar's fall writes an event report (JSON and PNG) into the rehearsal's
/// state directory; its station envelope keeps the record's peaks (computed here from the AT2
/// files: a·g·sin 228° east, a·g·cos 228° north, the vertical), its alerts are the run's, in
/// order; `rockwatch report` draws it again from the JSON, unchanged.
#[test]
fn a_fall_writes_an_event_report_that_rockwatch_report_draws_again() {
    let dir = tempfile::tempdir().unwrap();
    let out = monitor_rinaldi(Some(dir.path()), &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let alerts: Vec<serde_json::Value> = lines(&out)
        .into_iter()
        .filter(|v| v["type"] == "alert" && v["pbr_id"] == "rrs-slender-pillar")
        .collect();
    assert_eq!(alerts.last().unwrap()["level"], "overturned");
    let reports = dir.path().join("reports");
    let names: Vec<String> = std::fs::read_dir(&reports)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with("_rrs-slender-pillar.json"))
        .collect();
    assert_eq!(names.len(), 1, "{names:?}");
    let json_path = reports.join(&names[0]);
    let bytes = std::fs::read(&json_path).unwrap();
    let report: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
    assert_eq!(report["reason"], "overturned");
    assert_eq!(report["episode"], alerts[0]["episode"]);
    assert_eq!(
        report["data_time_ns"],
        alerts.last().unwrap()["data_time_ns"]
    );
    assert_eq!(report["rock"]["azimuth_deg"], 228.0);
    assert_eq!(report["thresholds"]["imminent_theta_ratio"], 0.8);
    assert!(report["intensity"]["pga_mps2"].as_f64().unwrap() > 1.0);
    // The alerts: the run's, in order.
    let marks = report["alerts"].as_array().unwrap();
    let got: Vec<(&serde_json::Value, &serde_json::Value)> = marks
        .iter()
        .map(|m| (&m["level"], &m["data_time_ns"]))
        .collect();
    let want: Vec<(&serde_json::Value, &serde_json::Value)> = alerts
        .iter()
        .map(|a| (&a["level"], &a["data_time_ns"]))
        .collect();
    assert_eq!(got, want);
    assert!(marks
        .windows(2)
        .all(|w| w[0]["data_time_ns"].as_i64() < w[1]["data_time_ns"].as_i64()));
    // The station's envelope: its peaks are the record's over the same span (f32 precision).
    let station = &report["station"];
    let start_ns = station["start_ns"].as_i64().unwrap();
    let bin_s = station["bin_s"].as_f64().unwrap();
    let records = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/records/");
    let (dt, horizontal) = at2_samples(&format!("{records}Rinaldi228.AT2"));
    let (_, vertical) = at2_samples(&format!("{records}RinaldiUP.AT2"));
    let g = 9.80665;
    let azimuth = 228f64.to_radians();
    let component = |c: usize, a: f64, v: f64| match c {
        0 => a * g * azimuth.sin(),
        1 => a * g * azimuth.cos(),
        _ => v * g,
    };
    for (c, name) in ["E", "N", "Z"].iter().enumerate() {
        let env = &station["components"][c];
        assert_eq!(env["component"], *name);
        let bins = env["max_mps2"].as_array().unwrap().len();
        let end_s = (start_ns as f64 * 1e-9) + bins as f64 * bin_s;
        assert!(
            end_s * 1e9 >= report["data_time_ns"].as_f64().unwrap(),
            "the envelope reaches the fall"
        );
        let peak_report = env["min_mps2"]
            .as_array()
            .unwrap()
            .iter()
            .chain(env["max_mps2"].as_array().unwrap())
            .filter_map(serde_json::Value::as_f64)
            .fold(0.0, |m: f64, v| m.max(v.abs()));
        let peak_record = horizontal
            .iter()
            .zip(&vertical)
            .enumerate()
            .filter(|(i, _)| (*i as f64 * dt) < end_s - 1e-9)
            .map(|(_, (a, v))| component(c, *a, *v).abs())
            .fold(0.0, f64::max);
        assert!(
            (peak_report - peak_record).abs() <= 1e-5 * peak_record,
            "{name}: report {peak_report} vs record {peak_record}"
        );
    }
    // The PNG: a PNG of the report's size.
    let png = std::fs::read(json_path.with_extension("png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&png[12..16], b"IHDR");
    let size = |o: usize| u32::from_be_bytes(png[o..o + 4].try_into().unwrap());
    assert_eq!((size(16), size(20)), (1100, 1000));
    // Drawn again: the PNG rewritten, the JSON unchanged and printed as the file holds it.
    std::fs::remove_file(json_path.with_extension("png")).unwrap();
    let state_dir = dir.path().to_str().unwrap();
    let again = rockwatch_bin!().output(&[
        "report",
        "--state-dir",
        state_dir,
        "--pbr",
        "rrs-slender-pillar",
        "--episode",
        "1",
        "--format",
        "json",
    ]);
    assert!(
        again.status.success(),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert_eq!(again.stdout, bytes);
    assert_eq!(std::fs::read(&json_path).unwrap(), bytes);
    assert_eq!(
        &std::fs::read(json_path.with_extension("png")).unwrap()[..8],
        b"\x89PNG\r\n\x1a\n"
    );
    // With a minute of quiet after the record, the rocks that moved and stand again end their
    // episodes: each gets its report (the fallen pillar only its fall's).
    let longer = tempfile::tempdir().unwrap();
    let rec = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/records/");
    let out = rockwatch_bin!().output(&[
        "monitor",
        "--config",
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/node.toml"),
        "--record",
        &format!("{rec}Rinaldi228.AT2"),
        "--vertical",
        &format!("{rec}RinaldiUP.AT2"),
        "--azimuth",
        "228",
        "--station",
        "CI.RRS.00",
        "--tail",
        "60",
        "--state-dir",
        longer.path().to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let history = rockwatch_bin!().output(&[
        "alerts",
        "--state-dir",
        longer.path().to_str().unwrap(),
        "--format",
        "json",
    ]);
    let ends: Vec<serde_json::Value> =
        serde_json::from_slice::<Vec<serde_json::Value>>(&history.stdout)
            .unwrap()
            .into_iter()
            .filter(|r| r["type"] == "episode_end")
            .collect();
    assert!(!ends.is_empty());
    for end in &ends {
        let pbr = end["pbr_id"].as_str().unwrap();
        let shown = rockwatch_bin!().output(&[
            "report",
            "--state-dir",
            longer.path().to_str().unwrap(),
            "--pbr",
            pbr,
            "--format",
            "json",
        ]);
        assert!(shown.status.success(), "{pbr}");
        let r: serde_json::Value = serde_json::from_slice(&shown.stdout).unwrap();
        assert_eq!(
            (&r["reason"], &r["episode"], &r["data_time_ns"]),
            (&"episode_end".into(), &end["episode"], &end["data_time_ns"]),
            "{pbr}"
        );
    }
    // No report of another episode, nor of a rock that did not move.
    for args in [
        ["--pbr", "rrs-slender-pillar", "--episode", "2"],
        ["--pbr", "no-such-rock", "--format", "text"],
    ] {
        let out = rockwatch_bin!()
            .output(&[&["report", "--state-dir", state_dir][..], &args[..]].concat());
        assert!(!out.status.success());
        assert!(String::from_utf8_lossy(&out.stderr).contains("no report of rock"));
    }
}
