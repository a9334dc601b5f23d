//! DDS Security (SROS2) end to end, each run in its own network namespace: a keystore made by
//! `launch-scripts/keystore.sh` (openssl), `rockwatch node` / `replay` / `reset --node` on
//! their enclaves through the SROS2 variables, and an independent unauthenticated peer
//! (Eclipse Cyclone DDS from PyPI, no security) acting as the attacker of issue 11 finding 6.
//!
//! Without security the attacker overturns blocks with forged packets and resets them (the
//! finding, reproduced); with `ROS_SECURITY_STRATEGY=Enforce` it matches none of the node's
//! endpoints: its packets, reset requests and alert subscription go nowhere, while a replay
//! with the station identity is processed in full. An operator identity can reset; a station
//! identity cannot.

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::netns::{reexec_in_netns, run_in_netns, text};
use rockwatch_test_harness::node_output::count_before;
use rockwatch_test_harness::peers::{have_cyclonedds, peer_available};
use rockwatch_test_harness::process::LoggedChild;
use rockwatch_test_harness::rockwatch_bin;
use rockwatch_test_harness::seedlink_server;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn keystore(dir: &Path) -> String {
    let ks = dir.join("keystore");
    let out = Command::new("bash")
        .arg(repo().join("launch-scripts/keystore.sh"))
        .arg(&ks)
        .output()
        .expect("bash");
    assert!(
        out.status.success(),
        "keystore.sh: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    ks.display().to_string()
}

fn node_toml(dir: &Path, discovery_range: &str) {
    std::fs::write(
        dir.join("node.toml"),
        format!(
            "catalogue = \"{}\"\n[ros2]\ndiscovery_range = \"{discovery_range}\"\n",
            repo().join("config/catalogue.toml").display()
        ),
    )
    .unwrap();
}

/// The journal's (pbr_id, level code) of alerts and the ids of resets.
fn journal(state: &Path) -> (Vec<(String, u64)>, Vec<String>) {
    use rockwatch_core::engine::{AlertLevel, JournalRecord};
    let (records, _) = rockwatch::journal::read_journal(state).unwrap();
    let mut alerts = Vec::new();
    let mut resets = Vec::new();
    for r in records {
        match r {
            JournalRecord::Alert(a) => alerts.push((
                a.pbr_id.to_string(),
                match a.level {
                    AlertLevel::MotionOnset => 1,
                    AlertLevel::OverturnImminent => 2,
                    AlertLevel::Overturned => 3,
                },
            )),
            JournalRecord::Reset { pbr_id, .. } => resets.push(pbr_id.to_string()),
            _ => {}
        }
    }
    (alerts, resets)
}

fn json_lines(stdout: &str, prefix: &str) -> Vec<serde_json::Value> {
    stdout
        .lines()
        .filter_map(|l| l.strip_prefix(prefix))
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

struct Paths {
    bin: String,
    py: String,
    alerts_py: String,
    msg: String,
    rec: String,
}

fn paths() -> Paths {
    Paths {
        bin: rockwatch_bin!().display().to_string(),
        py: repo()
            .join("tests/data/ros2/cyclone_forge.py")
            .display()
            .to_string(),
        alerts_py: repo()
            .join("tests/data/ros2/cyclone_alerts.py")
            .display()
            .to_string(),
        msg: repo().join("msg/pbr_msgs").display().to_string(),
        rec: repo().join("tests/data/records").display().to_string(),
    }
}

const SECURE: &str = "ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce";

/// The executable of example `ros2-alert-subscriber` (a reader of `/pbr/alerts`, enclave
/// `/rockwatch/reader`), built with the cargo that runs the tests into this test's target
/// directory (as tests/examples.rs does).
fn alert_subscriber() -> String {
    let exe = std::env::current_exe().unwrap();
    let profile_dir = exe.parent().and_then(Path::parent).unwrap();
    let profile = match profile_dir.file_name().and_then(|n| n.to_str()) {
        Some("debug") => "dev".to_owned(),
        Some(other) => other.to_owned(),
        None => panic!("no profile directory in {}", exe.display()),
    };
    let out = Command::new(env!("CARGO"))
        .args([
            "build",
            "--message-format=json-render-diagnostics",
            "--manifest-path",
        ])
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml"))
        .arg("--target-dir")
        .arg(profile_dir.parent().unwrap())
        .args(["--profile", &profile, "--example", "ros2-alert-subscriber"])
        .stderr(Stdio::inherit())
        .output()
        .unwrap();
    assert!(out.status.success(), "cargo build --example failed");
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|m| m["reason"] == "compiler-artifact")
        .find_map(|m| m["executable"].as_str().map(str::to_owned))
        .expect("the example's executable")
}

#[test]
fn without_security_an_unauthenticated_peer_forges_packets_and_resets_blocks() {
    if !peer_available(
        have_cyclonedds(),
        "cyclonedds",
        "python3 -m pip install cyclonedds==11.0.1 (see .ci/run)",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // SUBNET: every interface (the namespace's veth too), as a default ROS 2 node.
    node_toml(dir.path(), "SUBNET");
    let d = dir.path().display();
    let Paths { bin, py, msg, .. } = paths();
    let script = format!(
        "'{bin}' node --config '{d}/node.toml' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         python3 '{py}' '{msg}' --accel CI.RRS.00 50 --seconds 10 | sed 's/^/FORGE /'
         sleep 1
         python3 '{py}' '{msg}' --reset rrs-slender-pillar --seconds 10 | sed 's/^/RESET /'
         kill -TERM $NODE; wait $NODE && echo NODE_RC=0 || echo NODE_RC=$?
         cat '{d}/node.err' >&2"
    );
    let out = run_in_netns(&script, 90, &[]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{stderr}");
    // The node says at start that it is open to every host that reaches it.
    assert!(
        stderr.contains("warning: DDS Security is off and the node listens beyond localhost"),
        "{stderr}"
    );
    let (alerts, resets) = journal(&dir.path().join("state"));
    assert!(
        alerts.contains(&("rrs-slender-pillar".into(), 3)),
        "the forged packets did not overturn the pillar: {alerts:?}\n{stdout}\n{stderr}"
    );
    assert_eq!(resets, vec!["rrs-slender-pillar".to_owned()], "{stdout}");
    let replies = json_lines(&stdout, "RESET ");
    assert!(
        replies.iter().any(|r| r["reply"]["success"] == true),
        "{stdout}"
    );
}

/// Issue 20 item 17: a node in a namespace, with a remapped input, warns of the names it
/// really uses (it used to name `/pbr/accel` whatever its namespace).
#[test]
fn the_security_warning_names_the_resolved_topics_of_a_node_in_a_namespace() {
    let dir = tempfile::tempdir().unwrap();
    node_toml(dir.path(), "SUBNET");
    let d = dir.path().display();
    let bin = rockwatch_bin!().display().to_string();
    let script = format!(
        "'{bin}' node --config '{d}/node.toml' --ros-args -r __ns:=/site_a \
             -r pbr/alerts:=/all_sites/alerts 2> '{d}/node.err' & NODE=$!
         i=0; until grep -q 'DDS Security is off' '{d}/node.err'; do i=$((i+1)); [ $i -lt 100 ] || break; sleep 0.1; done
         kill -TERM $NODE; wait $NODE && echo NODE_RC=0 || echo NODE_RC=$?
         cat '{d}/node.err' >&2"
    );
    let out = run_in_netns(&script, 60, &[]);
    let (stdout, stderr) = text(&out);
    assert!(
        out.status.success() && stdout.contains("NODE_RC=0"),
        "{stdout}\n{stderr}"
    );
    let warning = stderr
        .lines()
        .find(|l| l.contains("DDS Security is off"))
        .unwrap_or_else(|| panic!("no security warning\n{stderr}"));
    assert!(
        warning.contains("publish /site_a/pbr/accel packets")
            && warning.contains("(/site_a/pbr/reset)")
            && warning.contains("(/all_sites/alerts)")
            && !warning.contains(" /pbr/accel"),
        "{warning}"
    );
}

#[test]
fn with_security_enforced_an_unauthenticated_peer_is_kept_out_and_a_station_is_served() {
    if !peer_available(
        have_cyclonedds(),
        "cyclonedds",
        "python3 -m pip install cyclonedds==11.0.1 (see .ci/run)",
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let ks = keystore(dir.path());
    node_toml(dir.path(), "SUBNET");
    let d = dir.path().display();
    let Paths {
        bin,
        py,
        alerts_py,
        msg,
        rec,
    } = paths();
    let reader = alert_subscriber();
    let script = format!(
        "export ROS_SECURITY_KEYSTORE='{ks}'
         {SECURE} '{bin}' node --config '{d}/node.toml' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         python3 '{alerts_py}' '{msg}/msg' --seconds 30 > '{d}/sub.out' 2> '{d}/sub.err' & SUB=$!
         python3 '{py}' '{msg}' --accel CI.RRS.00 50 --seconds 6 | sed 's/^/FORGE /'
         {SECURE} '{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' \
             --azimuth 228 --station CI.RRS.00 --transport ros2 --speed max --tail 10 --wait-s 20 \
             2> '{d}/replay.err' && echo REPLAY_RC=0 || echo REPLAY_RC=$?
         python3 '{py}' '{msg}' --reset rrs-slender-pillar --seconds 6 | sed 's/^/RESET /'
         python3 '{alerts_py}' '{msg}/msg' --seconds 4 | sed 's/^/LATE /'
         {SECURE} '{reader}' --json --count 1 --timeout 20 > '{d}/reader.out' 2> '{d}/reader.err' \
             && echo READER_RC=0 || echo READER_RC=$?
         sed 's/^/READER /' '{d}/reader.out'
         {SECURE} ROS_SECURITY_ENCLAVE_OVERRIDE=/rockwatch/station '{reader}' --json --count 1 \
             --timeout 5 2> '{d}/notreader.err' | sed 's/^/NOTREADER /'
         kill -TERM $NODE; wait $NODE && echo NODE_RC=0 || echo NODE_RC=$?
         kill $SUB 2>/dev/null || true; wait $SUB || true
         sed 's/^/EARLY /' '{d}/sub.out'
         cat '{d}/node.err' '{d}/replay.err' '{d}/sub.err' '{d}/reader.err' >&2
         sed 's/^/NOTREADER_ERR /' '{d}/notreader.err'"
    );
    let out = run_in_netns(&script, 150, &[]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{stderr}");
    assert!(
        stderr.contains("DDS Security enclave /rockwatch/node"),
        "{stderr}"
    );
    assert!(!stderr.contains("DDS Security is off"), "{stderr}");
    // The attacker matched none of the node's readers, for packets or resets.
    for prefix in ["FORGE ", "RESET "] {
        let lines = json_lines(&stdout, prefix);
        assert_eq!(
            lines.first().map(|l| l["matched_readers"].clone()),
            Some(serde_json::json!(0)),
            "{prefix}{lines:?}\n{stdout}\n{stderr}"
        );
    }
    assert!(
        json_lines(&stdout, "RESET ")
            .iter()
            .all(|l| l.get("reply").is_none()),
        "{stdout}"
    );
    // The station's replay was processed in full and the node took only its packets.
    assert!(stdout.contains("REPLAY_RC=0"), "{stdout}\n{stderr}");
    assert!(
        stderr.contains("rockwatch: stopped: 300 packets received over ROS 2"),
        "{stderr}"
    );
    let (alerts, resets) = journal(&dir.path().join("state"));
    assert!(
        alerts.contains(&("rrs-slender-pillar".into(), 3)),
        "{alerts:?}\n{stderr}"
    );
    assert!(resets.is_empty(), "the attacker reset a block: {resets:?}");
    // A subscriber with the reader identity reads the history; with the station identity
    // (no subscribe grant for rt/pbr/alerts) it cannot even subscribe.
    assert!(stdout.contains("READER_RC=0"), "{stdout}\n{stderr}");
    let read = json_lines(&stdout, "READER ");
    assert_eq!(read.len(), 1, "{stdout}");
    assert_eq!(read[0]["station"], "CI.RRS.00", "{read:?}");
    assert!(
        read[0]["pbr_id"]
            .as_str()
            .is_some_and(|p| p.starts_with("rrs-")),
        "{read:?}"
    );
    assert!(json_lines(&stdout, "NOTREADER ").is_empty(), "{stdout}");
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with("NOTREADER_ERR ") && l.contains("not allowed by security")),
        "{stdout}"
    );
    // Neither an early nor a late unauthenticated subscriber read an alert.
    for prefix in ["EARLY ", "LATE "] {
        let got: Vec<_> = json_lines(&stdout, prefix)
            .into_iter()
            .filter(|v| v.get("pbr_id").is_some())
            .collect();
        assert!(got.is_empty(), "{prefix}read alerts: {got:?}");
        assert!(
            json_lines(&stdout, prefix)
                .iter()
                .any(|v| v["ready"] == true),
            "{prefix}subscriber did not run\n{stdout}\n{stderr}"
        );
    }
}

#[test]
fn an_operator_identity_resets_a_block_and_a_station_identity_cannot() {
    let dir = tempfile::tempdir().unwrap();
    let ks = keystore(dir.path());
    node_toml(dir.path(), "LOCALHOST");
    let d = dir.path().display();
    let Paths { bin, rec, .. } = paths();
    let script = format!(
        "export ROS_SECURITY_KEYSTORE='{ks}'
         {SECURE} '{bin}' node --config '{d}/node.toml' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         {SECURE} '{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' \
             --azimuth 228 --station CI.RRS.00 --transport ros2 --speed max --tail 10 --wait-s 20 \
             2> '{d}/replay.err' && echo REPLAY_RC=0 || echo REPLAY_RC=$?
         {SECURE} ROS_SECURITY_ENCLAVE_OVERRIDE=/rockwatch/station '{bin}' reset --node \
             --pbr rrs-slender-pillar --wait-s 4 > '{d}/station.out' 2> '{d}/station.err' && echo STATION_RC=0 || echo STATION_RC=$?
         {SECURE} '{bin}' reset --node --pbr rrs-slender-pillar --wait-s 10 \
             > '{d}/operator.out' 2> '{d}/operator.err' && echo OPERATOR_RC=0 || echo OPERATOR_RC=$?
         kill -TERM $NODE; wait $NODE && echo NODE_RC=0 || echo NODE_RC=$?
         for f in node replay station operator; do sed \"s/^/$f: /\" '{d}'/$f.err >&2; done
         sed 's/^/OPERATOR /' '{d}/operator.out'"
    );
    let out = run_in_netns(
        &script,
        120,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("REPLAY_RC=0"), "{stdout}\n{stderr}");
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{stderr}");
    // The station identity may not even create the request writer: exit 1, one line.
    assert!(stdout.contains("STATION_RC=1"), "{stdout}\n{stderr}");
    let station_err: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("station: rockwatch: error: ") && !l.contains("rustdds"))
        .collect();
    assert!(
        station_err
            .iter()
            .any(|l| l.contains("not allowed by security")),
        "{stderr}"
    );
    assert!(stdout.contains("OPERATOR_RC=0"), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("OPERATOR block rrs-slender-pillar reset"),
        "{stdout}\n{stderr}"
    );
    let (alerts, resets) = journal(&dir.path().join("state"));
    assert!(
        alerts.contains(&("rrs-slender-pillar".into(), 3)),
        "{alerts:?}"
    );
    assert_eq!(resets, vec!["rrs-slender-pillar".to_owned()]);
}

#[test]
fn security_that_cannot_be_set_up_is_refused_under_enforce_and_said_under_permissive() {
    let dir = tempfile::tempdir().unwrap();
    let ks = keystore(dir.path());
    node_toml(dir.path(), "LOCALHOST");
    let d = dir.path().display();
    let bin = rockwatch_bin!().display().to_string();
    // An enclave the keystore does not have; a keystore that does not exist.
    let script = format!(
        "export ROS_SECURITY_KEYSTORE='{ks}' ROS_SECURITY_ENABLE=true
         ROS_SECURITY_STRATEGY=Enforce ROS_SECURITY_ENCLAVE_OVERRIDE=/rockwatch/nobody \
             '{bin}' node --config '{d}/node.toml' --state-dir '{d}/s1' 2> '{d}/e1' && echo RC1=0 || echo RC1=$?
         ROS_SECURITY_STRATEGY=Enforce ROS_SECURITY_KEYSTORE='{d}/none' \
             '{bin}' reset --node --pbr x --wait-s 0.2 2> '{d}/e2' && echo RC2=0 || echo RC2=$?
         ROS_SECURITY_STRATEGY=Permissive ROS_SECURITY_KEYSTORE='{d}/none' \
             '{bin}' reset --node --pbr x --wait-s 0.2 2> '{d}/e3' && echo RC3=0 || echo RC3=$?
         ROS_SECURITY_STRATEGY=enforce '{bin}' reset --node --pbr x --wait-s 0.2 2> '{d}/e4' && echo RC4=0 || echo RC4=$?
         ROS_SECURITY_STRATEGY=Enforce '{bin}' reset --node --pbr x --wait-s 0.2 \
             --ros-args --enclave /rockwatch/elsewhere 2> '{d}/e5' && echo RC5=0 || echo RC5=$?
         ROS_SECURITY_STRATEGY=Enforce ROS_SECURITY_ENCLAVE_OVERRIDE=/rockwatch/nobody '{bin}' reset \
             --node --pbr x --wait-s 0.2 --ros-args --enclave /rockwatch/elsewhere 2> '{d}/e6' && echo RC6=0 || echo RC6=$?
         for f in e1 e2 e3 e4 e5 e6; do sed \"s/^/$f: /\" '{d}'/$f; done"
    );
    let out = run_in_netns(
        &script,
        60,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let lines = |p: &str| -> Vec<String> {
        stdout
            .lines()
            .filter_map(|l| l.strip_prefix(p))
            .map(str::to_owned)
            .collect()
    };
    assert!(stdout.contains("RC1=1"), "{stdout}");
    assert_eq!(lines("e1: ").len(), 1, "{stdout}");
    assert!(
        lines("e1: ")[0].contains("enclave /rockwatch/nobody")
            && lines("e1: ")[0].contains("Enforce"),
        "{stdout}"
    );
    // Nothing was opened: the state directory was not created.
    assert!(!dir.path().join("s1").exists());
    assert!(stdout.contains("RC2=1"), "{stdout}");
    assert!(
        lines("e2: ")[0].contains("enclave /rockwatch/operator"),
        "{stdout}"
    );
    // Permissive runs without security, and says so.
    assert!(stdout.contains("RC3=1"), "{stdout}"); // no node to answer
    assert!(
        lines("e3: ")
            .iter()
            .any(|l| l.contains("running WITHOUT security")),
        "{stdout}"
    );
    assert!(
        lines("e3: ")
            .iter()
            .any(|l| l.contains("no node offered /pbr/reset")),
        "{stdout}"
    );
    // Issue 20 item 13: --ros-args --enclave picks the enclave, as in rcl; the override
    // variable still wins.
    assert!(stdout.contains("RC5=1"), "{stdout}");
    assert!(
        lines("e5: ")[0].contains("enclave /rockwatch/elsewhere"),
        "{stdout}"
    );
    assert!(stdout.contains("RC6=1"), "{stdout}");
    assert!(
        lines("e6: ")[0].contains("enclave /rockwatch/nobody"),
        "{stdout}"
    );
    assert!(stdout.contains("RC4=1"), "{stdout}");
    assert!(
        lines("e4: ")[0].contains("ROS_SECURITY_STRATEGY must be Enforce or Permissive"),
        "{stdout}"
    );
}

/// Issue 11, finding 1: "a transport that cannot be brought back makes the node exit
/// non-zero". A real cause: the node's enclave is gone (its keystore moved away) when its
/// participant dies (SIGSTOP/SIGCONT ends RustDDS's threads): every rebuild fails to validate
/// the identity, and after `REBUILD_GIVE_UP` (30 s) the node exits 1 naming the fault.
#[test]
fn a_participant_that_cannot_be_rebuilt_ends_the_node_with_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let ks = keystore(dir.path());
    node_toml(dir.path(), "LOCALHOST");
    let d = dir.path().display();
    let bin = rockwatch_bin!().display().to_string();
    let script = format!(
        "export ROS_SECURITY_KEYSTORE='{ks}'
         {SECURE} '{bin}' node --config '{d}/node.toml' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         sleep 2
         mv '{ks}/enclaves/rockwatch/node' '{d}/node-enclave-moved'
         for s in 1 1 1; do kill -STOP $NODE; sleep $s; kill -CONT $NODE; sleep 1; \
             grep -q 'transport dead' '{d}/node.err' && break; done
         wait $NODE && echo NODE_RC=0 || echo NODE_RC=$?
         cat '{d}/node.err' >&2"
    );
    let out = run_in_netns(
        &script,
        90,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("NODE_RC=1"), "{stdout}\n{stderr}");
    assert!(stderr.contains("ROS 2 transport dead"), "{stderr}");
    assert!(
        stderr.contains("cannot rebuild the ROS 2 participant"),
        "{stderr}"
    );
    let last = stderr
        .lines()
        .rfind(|l| l.starts_with("rockwatch: error: ") && !l.contains("rustdds"))
        .unwrap_or_default();
    assert!(
        last.contains("could not be rebuilt for 30 s") && last.contains("/rockwatch/node"),
        "{last}\n{stderr}"
    );
}

/// A six-needle catalogue on the K2 station XX.STN (as tests/acquire_e2e.rs).
fn needles(dir: &Path) -> std::path::PathBuf {
    let mut text = String::new();
    for (i, width) in [0.01, 0.015, 0.02, 0.04, 0.05, 0.06].iter().enumerate() {
        text += &format!(
            "[[pbr]]\nid = \"needle-{i}\"\nname = \"test needle\"\nlat = 50.47\nlon = 4.279\n\
             station = \"XX.STN.\"\nazimuth_deg = {}\nwidth_m = {width}\nheight_m = 10.0\n\
             mu_s = 0.7\nmu_k = 0.55\nsource = \"test\"\n\n",
            30.0 * i as f64
        );
    }
    let path = dir.join("catalogue.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// (pbr_id, level, episode) of the journal's alerts.
fn alert_keys(state: &Path) -> Vec<(String, u64, u32)> {
    use rockwatch_core::engine::JournalRecord;
    let Ok((records, _)) = rockwatch::journal::read_journal(state) else {
        return Vec::new();
    };
    records
        .into_iter()
        .filter_map(|r| match r {
            JournalRecord::Alert(a) => Some((a.pbr_id.to_string(), a.level as u64, a.episode)),
            _ => None,
        })
        .collect()
}

fn secured(cmd: &mut Command, keystore: &str) -> LoggedChild {
    LoggedChild::spawn(
        cmd.env("ROS_SECURITY_KEYSTORE", keystore)
            .env("ROS_SECURITY_ENABLE", "true")
            .env("ROS_SECURITY_STRATEGY", "Enforce"),
    )
}

fn stop(child: LoggedChild) -> String {
    child.stop(Duration::from_secs(10)).1
}

/// SeedLink (an independent server, seedlink-rs-server) → `rockwatch acquire --to ros2` with
/// the station identity → a secured node: the node's alerts equal `monitor`'s on the same
/// records, so every packet of the secured acquisition was taken.
#[test]
fn an_acquire_with_the_station_identity_is_served() {
    if !reexec_in_netns("an_acquire_with_the_station_identity_is_served", 150) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let ks = keystore(dir.path());
    let catalogue = needles(dir.path());
    let xml = repo().join("tests/data/stationxml/obspy_XX.STN_k2.xml");
    let reference = dir.path().join("monitor-state");
    let out = Command::new(rockwatch_bin!())
        .args(["monitor", "--catalogue"])
        .arg(&catalogue)
        .arg("--mseed")
        .arg(repo().join("tests/data/mseed/k2_STNA_HN123_counts.mseed"))
        .arg("--stationxml")
        .arg(&xml)
        .args([
            "--station",
            "XX.STN.",
            "--tail",
            "0",
            "--format",
            "jsonl",
            "--state-dir",
        ])
        .arg(&reference)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let expected = alert_keys(&reference);
    assert!(expected.len() >= 3, "{expected:?}");

    let server = seedlink_server::Server::start("127.0.0.1:0");
    server.push(&seedlink_server::records_in_time_order());
    let node_state = dir.path().join("node-state");
    let node_config = dir.path().join("node.toml");
    std::fs::write(
        &node_config,
        format!(
            "catalogue = \"{}\"\nstate_dir = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n",
            catalogue.display(),
            node_state.display()
        ),
    )
    .unwrap();
    let acquire_config = dir.path().join("acquire.toml");
    std::fs::write(
        &acquire_config,
        format!(
            "[seedlink]\nserver = \"{}\"\nstreams = [\"XX.STN..HN?\"]\nprotocol = 3\n\
             [inventory]\nstationxml = [\"{}\"]\n[assembly]\nmax_wait_s = 1.0\n\
             [ros2]\ndiscovery_range = \"LOCALHOST\"\n",
            server.addr,
            xml.display()
        ),
    )
    .unwrap();
    let node = secured(
        Command::new(rockwatch_bin!())
            .args(["node", "--config"])
            .arg(&node_config),
        &ks,
    );
    let acquire = secured(
        Command::new(rockwatch_bin!())
            .args(["acquire", "--to", "ros2", "--config"])
            .arg(&acquire_config)
            .arg("--state-dir")
            .arg(dir.path().join("acquire-state")),
        &ks,
    );
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut got = alert_keys(&node_state);
    while got.len() < expected.len() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(200));
        got = alert_keys(&node_state);
    }
    std::thread::sleep(Duration::from_secs(1)); // anything doubled would show
    let acquire_err = stop(acquire);
    let node_err = stop(node);
    server.stop();
    let got = alert_keys(&node_state);
    assert_eq!(
        got, expected,
        "\nacquire:\n{acquire_err}\nnode:\n{node_err}"
    );
    assert!(
        node_err.contains("DDS Security enclave /rockwatch/node"),
        "{node_err}"
    );
    // The station enclave may publish acquire's status (/diagnostics).
    assert!(
        !acquire_err.contains("cannot publish its status"),
        "{acquire_err}"
    );
}

/// The pbr names are granted under the node's namespace (`keystore.sh --namespace`): a node
/// in `/site_a` with such a keystore is served (the operator resets through
/// `/site_a/pbr/reset`); a node in `/site_b`, which the keystore does not cover, may not create
/// its endpoints and exits 1 at start.
#[test]
fn the_keystore_grants_the_pbr_names_under_the_nodes_namespace() {
    let dir = tempfile::tempdir().unwrap();
    let ks = dir.path().join("keystore");
    let out = Command::new("bash")
        .arg(repo().join("launch-scripts/keystore.sh"))
        .args(["--namespace", "/site_a"])
        .arg(&ks)
        .output()
        .expect("bash");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ks = ks.display();
    let d = dir.path().display();
    for site in ["site_a", "site_b"] {
        std::fs::write(
            dir.path().join(format!("{site}.toml")),
            format!(
                "catalogue = \"{}\"\n[ros2]\nnamespace = \"/{site}\"\ndiscovery_range = \"LOCALHOST\"\n",
                repo().join("config/catalogue.toml").display()
            ),
        )
        .unwrap();
    }
    let bin = rockwatch_bin!().display().to_string();
    let script = format!(
        "export ROS_SECURITY_KEYSTORE='{ks}'
         {SECURE} '{bin}' node --config '{d}/site_b.toml' --state-dir '{d}/b' 2> '{d}/b.err' \
             && echo B_RC=0 || echo B_RC=$?
         {SECURE} '{bin}' node --config '{d}/site_a.toml' --state-dir '{d}/a' 2> '{d}/a.err' & NODE=$!
         {SECURE} '{bin}' reset --node --config '{d}/site_a.toml' --pbr rrs-slender-pillar \
             --wait-s 10 > '{d}/reset.out' 2> '{d}/reset.err' && echo RESET_RC=0 || echo RESET_RC=$?
         kill -TERM $NODE; wait $NODE && echo NODE_RC=0 || echo NODE_RC=$?
         for f in a b reset; do sed \"s/^/$f: /\" '{d}'/$f.err >&2; done
         sed 's/^/RESET /' '{d}/reset.out'"
    );
    let out = run_in_netns(
        &script,
        90,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("B_RC=1"), "{stdout}\n{stderr}");
    assert!(
        stderr
            .lines()
            .any(|l| l.starts_with("b: rockwatch: error: ")
                && !l.contains("rustdds")
                && l.contains("not allowed by security")
                && l.contains("site_b/pbr/")),
        "{stderr}"
    );
    assert!(stdout.contains("NODE_RC=0"), "{stdout}\n{stderr}");
    assert!(stdout.contains("RESET_RC=0"), "{stdout}\n{stderr}");
    // Served through /site_a/pbr/reset: the node answered (the pillar has not fallen).
    assert!(
        stdout.contains("RESET block rrs-slender-pillar has not overturned"),
        "{stdout}\n{stderr}"
    );
}

/// A secured service of two partitioned nodes: a replay with the station identity to a
/// station of the SECOND partition (`[partition_assign]`) is paced and acknowledged by that
/// partition's node. The replay reads the nodes' reports on one `/pbr/intake` subscription:
/// with one per partition in one secured participant, only the first heard the nodes
/// (RustDDS 0.15.1's key exchange remembers the remote writer, not the local reader).
#[test]
fn a_secured_replay_to_the_second_of_two_partitions_is_acknowledged() {
    let dir = tempfile::tempdir().unwrap();
    let ks = keystore(dir.path());
    let d = dir.path().display();
    let Paths { bin, rec, .. } = paths();
    for i in 0..2 {
        std::fs::write(
            dir.path().join(format!("node{i}.toml")),
            format!(
                "catalogue = \"{}\"\nstate_dir = \"{d}/state{i}\"\npartition = \"{i}/2\"\n\
                 [partition_assign]\n\"CI.RRS.00\" = 1\n\"CI.SYL.00\" = 0\n\
                 [ros2]\ndiscovery_range = \"LOCALHOST\"\n",
                repo().join("config/catalogue.toml").display()
            ),
        )
        .unwrap();
    }
    let script = format!(
        "export ROS_SECURITY_KEYSTORE='{ks}'
         {SECURE} '{bin}' node --config '{d}/node0.toml' 2> '{d}/node0.err' & N0=$!
         {SECURE} '{bin}' node --config '{d}/node1.toml' 2> '{d}/node1.err' & N1=$!
         {SECURE} ROS_SECURITY_ENCLAVE_OVERRIDE=/rockwatch/station '{bin}' replay \
             --config '{d}/node0.toml' --record '{rec}/Rinaldi228.AT2' --azimuth 228 \
             --station CI.RRS.00 --transport ros2 --speed max --tail 10 --wait-s 20 \
             > '{d}/replay.out' 2> '{d}/replay.err' && echo REPLAY_RC=0 || echo REPLAY_RC=$?
         kill -TERM $N0 $N1; wait $N0 && echo N0_RC=0 || echo N0_RC=$?
         wait $N1 && echo N1_RC=0 || echo N1_RC=$?
         cat '{d}/replay.out'
         cat '{d}/replay.err' '{d}/node0.err' '{d}/node1.err' >&2"
    );
    let out = run_in_netns(&script, 150, &[]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("REPLAY_RC=0"), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("N0_RC=0") && stdout.contains("N1_RC=0"),
        "{stdout}\n{stderr}"
    );
    let node = |i: usize| std::fs::read_to_string(dir.path().join(format!("node{i}.err"))).unwrap();
    assert!(
        node(1).contains("DDS Security enclave /rockwatch/node"),
        "{}",
        node(1)
    );
    // Partition 1 took every packet (the record and 10 s of quiet), partition 0 none.
    assert_eq!(
        count_before(&node(1), "packets received over ROS 2"),
        300,
        "{}",
        node(1)
    );
    assert_eq!(
        count_before(&node(0), "packets received over ROS 2"),
        0,
        "{}",
        node(0)
    );
    let (alerts, _) = journal(&dir.path().join("state1"));
    assert!(
        alerts.contains(&("rrs-slender-pillar".into(), 3)),
        "{alerts:?}\n{}",
        node(1)
    );
}
