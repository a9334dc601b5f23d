//! The node as a systemd service, against the real binary in a private network namespace:
//! - sd_notify: a datagram listener stands in for systemd's `$NOTIFY_SOCKET`; with
//!   `WATCHDOG_USEC=200000` the node sends `READY=1`, then `WATCHDOG=1` every ≈ 100 ms (half
//!   the period) from its event loop; when the loop is stalled (fault injection: it sleeps 2 s
//!   on a reload request) the pings stop while the process still runs, and resume after;
//!   `RELOADING=1`/`READY=1` frame the reload and `STOPPING=1` ends the run.
//! - SIGHUP reload: the node runs on a catalogue with one block, which overturns; the catalogue
//!   gets a second block and the configuration a new threshold, SIGHUP: the new block alerts
//!   (at the new threshold), the old one keeps its state (still fallen: the same record again
//!   raises nothing for it). A configuration out of range and a catalogue that does not parse
//!   are refused with a log line, the running one kept; a catalogue without the first block
//!   drops it. Each reload logs the settings it changed, old → new.
//! - JSON logs: the stop counters and a reload's changed settings are structured fields.

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::netns::{reexec_in_netns, run_in_netns, text};
use rockwatch_test_harness::process::NodeProcess;
use rockwatch_test_harness::rockwatch_bin;

use std::os::unix::net::UnixDatagram;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A datagram received on the notify socket, with its arrival time.
type Datagram = (Instant, String);

fn block(id: &str, station: &str) -> String {
    format!(
        "[[pbr]]\nid = \"{id}\"\nname = \"{id}\"\nlat = 34.28\nlon = -118.48\n\
         station = \"{station}\"\nazimuth_deg = 228.0\nwidth_m = 0.30\nheight_m = 1.50\n\
         mu_s = 0.70\nmu_k = 0.55\nsource = \"test: copy of rrs-slender-pillar\"\n\n"
    )
}

fn node_toml(dir: &Path, ratio: f64) {
    std::fs::write(
        dir.join("node.toml"),
        format!(
            "catalogue = \"catalogue.toml\"\n[engine.alerts]\nimminent_theta_ratio = {ratio}\n\
             [ros2]\ndiscovery_range = \"LOCALHOST\"\n"
        ),
    )
    .unwrap();
}

/// Replays the Rinaldi record as `station`, stamped `restamp` (`original`: 1970, `now`: ending
/// now — always after the `original` data, so a block that stood then sees new data).
fn replay(config: &Path, station: &str, restamp: &str) {
    let data = repo().join("tests/data/records");
    let out = Command::new(rockwatch_bin!())
        .args(["replay", "--config"])
        .arg(config)
        .arg("--record")
        .arg(data.join("Rinaldi228.AT2"))
        .arg("--vertical")
        .arg(data.join("RinaldiUP.AT2"))
        .args(["--azimuth", "228", "--station", station])
        .args([
            "--transport",
            "ros2",
            "--speed",
            "max",
            "--tail",
            "5",
            "--wait-s",
            "20",
            "--restamp",
            restamp,
        ])
        .output()
        .unwrap();
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "replay {station}: {stdout}\n{stderr}");
}

/// Waits (≤ 30 s) until `cond` holds of the node's stderr.
fn wait_for(node: &NodeProcess, what: &str, cond: impl Fn(&str) -> bool) -> String {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let err = node.stderr();
        if cond(&err) {
            return err;
        }
        assert!(Instant::now() < deadline, "no {what} in\n{err}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// (pbr, level, |θ/α|) of every journaled alert.
fn alerts(state: &Path) -> Vec<(String, String, f64)> {
    let out = Command::new(rockwatch_bin!())
        .args(["alerts", "--format", "json", "--state-dir"])
        .arg(state)
        .output()
        .unwrap();
    assert!(out.status.success());
    let records: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    records
        .iter()
        .filter(|r| r["type"] == "alert")
        .map(|a| {
            (
                a["pbr_id"].as_str().unwrap().to_string(),
                a["level"].as_str().unwrap().to_string(),
                a["theta_over_alpha"].as_f64().unwrap().abs(),
            )
        })
        .collect()
}

#[test]
fn sighup_reloads_catalogue_and_thresholds_keeping_the_blocks_state() {
    if !reexec_in_netns(
        "sighup_reloads_catalogue_and_thresholds_keeping_the_blocks_state",
        200,
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let catalogue = d.join("catalogue.toml");
    std::fs::write(&catalogue, block("pillar-one", "XB.ONE.00")).unwrap();
    node_toml(d, 0.8);
    let config = d.join("node.toml");
    let state = d.join("state");
    let mut node = rockwatch_bin!().start_node(&config, &state, d.join("node.err"));

    // 1. The first block overturns.
    replay(&config, "XB.ONE.00", "original");
    wait_for(&node, "pillar-one overturned", |_| {
        alerts(&state)
            .iter()
            .any(|(id, level, _)| id == "pillar-one" && level == "overturned")
    });

    // 2. A second block and a new threshold: SIGHUP.
    std::fs::write(
        &catalogue,
        block("pillar-one", "XB.ONE.00") + &block("pillar-two", "XB.TWO.00"),
    )
    .unwrap();
    node_toml(d, 0.5);
    let hup = |node: &NodeProcess| {
        let status = Command::new("kill")
            .args(["-HUP", &node.child.id().to_string()])
            .status()
            .unwrap();
        assert!(status.success());
    };
    hup(&node);
    let err = wait_for(&node, "the reload", |e| e.contains("rockwatch: reloaded:"));
    assert!(
        err.contains("reloaded: 1 settings changed; 1 blocks kept with their state, 1 new at rest (pillar-two), 0 changed and at rest again, 0 dropped"),
        "{err}"
    );
    // The setting that changed, old → new (issue 20 item 11).
    assert!(
        err.contains("rockwatch: reload: engine.alerts.imminent_theta_ratio 0.8 → 0.5\n"),
        "{err}"
    );

    // The old block kept its state (fallen): the same record again raises nothing for it.
    // The new block alerts, at the new threshold. (Stamped now: the same data again would
    // be dropped as already processed, and the replay fail.)
    replay(&config, "XB.ONE.00", "now");
    replay(&config, "XB.TWO.00", "now");
    wait_for(&node, "pillar-two overturned", |_| {
        alerts(&state)
            .iter()
            .any(|(id, level, _)| id == "pillar-two" && level == "overturned")
    });
    let journal = alerts(&state);
    let levels = |pbr: &str| -> Vec<&str> {
        journal
            .iter()
            .filter(|(id, _, _)| id == pbr)
            .map(|(_, l, _)| l.as_str())
            .collect()
    };
    assert_eq!(
        levels("pillar-one"),
        ["motion_onset", "overturn_imminent", "overturned"],
        "{journal:?}"
    );
    assert_eq!(
        levels("pillar-two"),
        ["motion_onset", "overturn_imminent", "overturned"],
        "{journal:?}"
    );
    let imminent = |pbr: &str| {
        journal
            .iter()
            .find(|(id, l, _)| id == pbr && l == "overturn_imminent")
            .unwrap()
            .2
    };
    assert!((0.8..0.9).contains(&imminent("pillar-one")), "{journal:?}");
    assert!((0.5..0.6).contains(&imminent("pillar-two")), "{journal:?}");

    // 3. Bad configurations are refused, the running one kept.
    node_toml(d, 1.5);
    hup(&node);
    let err = wait_for(&node, "a refused reload", |e| {
        e.matches("reload refused").count() == 1
    });
    assert!(
        err.contains("imminent_theta_ratio") && err.contains("out of range"),
        "{err}"
    );
    node_toml(d, 0.5);
    std::fs::write(&catalogue, "[[pbr]\nid = \n").unwrap();
    hup(&node);
    let err = wait_for(&node, "a second refused reload", |e| {
        e.matches("reload refused").count() == 2
    });
    assert!(err.contains("catalogue.toml"), "{err}");

    // 4. A block removed is dropped.
    std::fs::write(&catalogue, block("pillar-two", "XB.TWO.00")).unwrap();
    hup(&node);
    let err = wait_for(&node, "the second reload", |e| {
        e.matches("rockwatch: reloaded:").count() == 2
    });
    assert!(
        err.contains("reloaded: 0 settings changed; 1 blocks kept with their state, 0 new at rest, 0 changed and at rest again, 1 dropped (pillar-one)"),
        "{err}"
    );
    assert_eq!(err.matches("rockwatch: reload: ").count(), 1, "{err}");
    let status = node
        .signal_and_wait("TERM", Duration::from_secs(20))
        .unwrap();
    let err = node.stderr();
    assert!(status.success(), "{err}");
    assert!(err.contains(", 1 blocks, 1 overturned"), "{err}");
    // Four SIGHUPs, all taken by the signal thread: none reached a DDS thread (RustDDS would
    // have ended the participant on EINTR).
    assert!(!err.contains("transport dead"), "{err}");
}

/// Issue 20 item 11: with `--log-format json` the node's stop counters are fields of their
/// records, not only words of a message, and a reload logs each changed setting with the
/// fields `setting`, `old`, `new`.
#[test]
fn json_logs_carry_the_stop_counters_and_each_setting_a_reload_changed_as_fields() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("catalogue.toml"), block("pillar-one", "XB.ONE.00")).unwrap();
    node_toml(d, 0.8);
    let reloaded = std::fs::read_to_string(d.join("node.toml"))
        .unwrap()
        .replace("imminent_theta_ratio = 0.8", "imminent_theta_ratio = 0.5")
        .replace(
            "[engine.alerts]",
            "[engine]\nstale_after_s = 30.0\n[engine.alerts]",
        );
    std::fs::write(d.join("reloaded.toml"), reloaded).unwrap();
    let (bin, dd) = (rockwatch_bin!().display().to_string(), d.display());
    let rec = repo().join("tests/data/records");
    let rec = rec.display();
    let script = format!(
        "'{bin}' --log-format json node --config '{dd}/node.toml' 2> '{dd}/node.err' & NODE=$!
         '{bin}' replay --config '{dd}/node.toml' --record '{rec}/Rinaldi228.AT2' \
             --vertical '{rec}/RinaldiUP.AT2' --azimuth 228 --station XB.ONE.00 \
             --transport ros2 --speed max --tail 2 --wait-s 20 >/dev/null 2>&1
         cp '{dd}/reloaded.toml' '{dd}/node.toml'
         kill -HUP $NODE
         i=0; until grep -q 'reloaded:' '{dd}/node.err'; do i=$((i+1)); [ $i -lt 200 ] || break; sleep 0.1; done
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?"
    );
    let out = run_in_netns(&script, 90, &[]);
    let (stdout, stderr) = text(&out);
    let err = std::fs::read_to_string(d.join("node.err")).unwrap_or_default();
    let context = format!("--- stdout\n{stdout}\n--- stderr\n{stderr}\n--- node\n{err}");
    assert!(
        out.status.success() && stdout.contains("NODE_RC=0"),
        "{context}"
    );
    let records: Vec<serde_json::Value> = err
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}\n{context}")))
        .collect();
    let fields_of = |message_start: &str| -> Vec<&serde_json::Value> {
        records
            .iter()
            .map(|r| &r["fields"])
            .filter(|f| {
                f["message"]
                    .as_str()
                    .is_some_and(|m| m.starts_with(message_start))
            })
            .collect()
    };

    // The reload: one record per changed setting, and the count in the summary.
    let changes: Vec<(String, String, String)> = fields_of("reload: ")
        .iter()
        .map(|f| {
            let s = |k: &str| f[k].as_str().unwrap_or("?").to_string();
            (s("setting"), s("old"), s("new"))
        })
        .collect();
    let expected = |a: &str, b: &str, c: &str| (a.to_string(), b.to_string(), c.to_string());
    assert_eq!(
        changes,
        [
            expected("engine.alerts.imminent_theta_ratio", "0.8", "0.5"),
            expected("engine.stale_after_s", "60.0", "30.0"),
        ],
        "{context}"
    );
    let summary = fields_of("reloaded: ");
    assert_eq!(summary.len(), 1, "{context}");
    assert_eq!(summary[0]["settings_changed"], 2, "{context}");
    assert_eq!(summary[0]["blocks_kept"], 1, "{context}");

    // The stop counters as fields, equal to the words of the message.
    let stopped = fields_of("stopped: ");
    assert_eq!(stopped.len(), 1, "{context}");
    let packets = stopped[0]["ros2_packets"].as_u64().unwrap_or(0);
    assert!(packets > 100, "{context}");
    assert!(
        stopped[0]["message"]
            .as_str()
            .is_some_and(|m| m.starts_with(&format!("stopped: {packets} packets received"))),
        "{context}"
    );
    assert_eq!(
        (&stopped[0]["blocks"], &stopped[0]["overturned"]),
        (&serde_json::json!(1), &serde_json::json!(1)),
        "{context}"
    );
    assert_eq!(stopped[0]["ros2_undecodable"], 0, "{context}");
    let input = fields_of("engine input: ");
    assert_eq!(input.len(), 1, "{context}");
    assert_eq!(input[0]["packets"].as_u64(), Some(packets), "{context}");
    for key in ["rejected", "duplicate", "late", "unknown_station"] {
        assert_eq!(input[0][key], 0, "{key}\n{context}");
    }
}

#[test]
fn sd_notify_ready_then_watchdog_pings_from_the_event_loop_which_stop_while_it_stalls() {
    if !reexec_in_netns(
        "sd_notify_ready_then_watchdog_pings_from_the_event_loop_which_stop_while_it_stalls",
        120,
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("catalogue.toml"), block("pillar-one", "XB.ONE.00")).unwrap();
    node_toml(d, 0.8);
    let socket_path = d.join("notify.sock");
    let socket = UnixDatagram::bind(&socket_path).unwrap();
    socket
        .set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    let mut node = Command::new(rockwatch_bin!())
        .args(["node", "--config"])
        .arg(d.join("node.toml"))
        .env("NOTIFY_SOCKET", &socket_path)
        .env("WATCHDOG_USEC", "200000")
        .env(rockwatch::node::FAULT_STALL_ON_RELOAD_ENV, "2")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(d.join("node.err")).unwrap())
        .spawn()
        .unwrap();
    let start = Instant::now();
    // Every datagram with its arrival time, until `until` says stop or `limit` passes.
    let mut received: Vec<Datagram> = Vec::new();
    let receive =
        |received: &mut Vec<Datagram>, limit: Duration, until: &dyn Fn(&[Datagram]) -> bool| {
            let deadline = Instant::now() + limit;
            let mut buf = [0u8; 512];
            while Instant::now() < deadline && !until(received) {
                if let Ok(n) = socket.recv(&mut buf) {
                    received.push((
                        Instant::now(),
                        String::from_utf8_lossy(&buf[..n]).into_owned(),
                    ));
                }
            }
        };
    let has = |r: &[Datagram], what: &str| r.iter().any(|(_, m)| m.contains(what));
    receive(&mut received, Duration::from_secs(30), &|r| {
        has(r, "READY=1")
    });
    let err = std::fs::read_to_string(d.join("node.err")).unwrap_or_default();
    assert!(has(&received, "READY=1"), "no READY=1 within 30 s\n{err}");
    assert!(
        !has(&received, "WATCHDOG=1"),
        "a ping before READY: {received:?}"
    );
    let ready_at = received.len();
    // 2 s of pings.
    receive(&mut received, Duration::from_secs(2), &|_| false);
    let pings: Vec<Instant> = received[ready_at..]
        .iter()
        .filter(|(_, m)| m == "WATCHDOG=1")
        .map(|(t, _)| *t)
        .collect();
    assert!(
        pings.len() >= 5,
        "{} pings in 2 s: {received:?}",
        pings.len()
    );
    let mut gaps: Vec<f64> = pings
        .windows(2)
        .map(|w| (w[1] - w[0]).as_secs_f64())
        .collect();
    gaps.sort_by(f64::total_cmp);
    let median = gaps[gaps.len() / 2];
    // Half of WATCHDOG_USEC (100 ms), seen by an event loop that wakes every 50 ms at least.
    assert!(
        (0.09..0.3).contains(&median),
        "median ping interval {median} s: {gaps:?}"
    );

    // Stall the loop (SIGHUP with the fault): no ping while it sleeps, the process runs on.
    let before = received.len();
    let status = Command::new("kill")
        .args(["-HUP", &node.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    receive(&mut received, Duration::from_secs(10), &|r| {
        r[before..].iter().any(|(_, m)| m.starts_with("READY=1"))
    });
    let after: Vec<&Datagram> = received[before..].iter().collect();
    let reloading = after
        .iter()
        .position(|(_, m)| m.starts_with("RELOADING=1"))
        .unwrap_or_else(|| panic!("no RELOADING=1: {after:?}"));
    let ready = after
        .iter()
        .position(|(_, m)| m.starts_with("READY=1"))
        .unwrap_or_else(|| panic!("no READY=1 after the reload: {after:?}"));
    assert!(reloading < ready, "{after:?}");
    let stalled = (after[ready].0 - after[reloading].0).as_secs_f64();
    assert!(
        stalled >= 1.9,
        "the loop stalled only {stalled} s: {after:?}"
    );
    assert!(
        after[reloading..ready]
            .iter()
            .all(|(_, m)| m != "WATCHDOG=1"),
        "a ping while the event loop was stalled: {after:?}"
    );
    assert!(
        node.try_wait().unwrap().is_none(),
        "the node must still run"
    );
    // Pings resume.
    let resumed = received.len();
    receive(&mut received, Duration::from_secs(2), &|_| false);
    assert!(
        received[resumed..]
            .iter()
            .filter(|(_, m)| m == "WATCHDOG=1")
            .count()
            >= 5,
        "{:?}",
        &received[resumed..]
    );

    // Stop: STOPPING=1.
    let _ = Command::new("kill")
        .args(["-TERM", &node.id().to_string()])
        .status();
    let status = node.wait().unwrap();
    receive(&mut received, Duration::from_secs(2), &|r| {
        has(r, "STOPPING=1")
    });
    let err = std::fs::read_to_string(d.join("node.err")).unwrap_or_default();
    assert!(status.success(), "{err}");
    assert!(has(&received, "STOPPING=1"), "{received:?}");
    assert!(start.elapsed() < Duration::from_secs(100));
}
