//! The examples of examples/, run end to end against the real node (`rockwatch node`):
//!
//! - `iox-station-publisher` feeds the node the bundled Rinaldi record over iceoryx2, and the
//!   node journals exactly the alerts the engine raises for that record;
//! - `ros2-alert-subscriber` receives those alerts over ROS 2 from a node fed by
//!   `rockwatch replay`, live and (transient local) late, on the node's DDS domain only, and
//!   ends on `--count` and on SIGINT with exit 0.
//!
//! The examples are built by this test (`cargo build --example`, a no-op when they are
//! fresh) into the same target directory and profile as the test itself.

use rockwatch_test_harness::fixtures::{repo, write_node_config};
use rockwatch_test_harness::netns::{run_in_netns, text, VETH_TX};
use rockwatch_test_harness::node_output::json_lines;
use rockwatch_test_harness::process::NodeProcess;
use rockwatch_test_harness::rockwatch_bin;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use rockwatch::journal::read_journal;
use rockwatch_core::engine::JournalRecord;

/// The examples this file runs.
const EXAMPLES: [&str; 2] = ["iox-station-publisher", "ros2-alert-subscriber"];

/// The alerts (block, level) the engine raises for the Rinaldi record (228° + up) on the
/// example catalogue's CI.RRS.00 blocks, as `rockwatch monitor --config config/node.toml
/// --record tests/data/records/Rinaldi228.AT2 --vertical tests/data/records/RinaldiUP.AT2
/// --azimuth 228 --station CI.RRS.00` prints them: the slender pillar goes through every
/// level, the pinnacle ensemble comes close (imminent, not over), the slab and the boulder
/// only start moving.
const RINALDI_ALERTS: [(&str, &str); 7] = [
    ("rrs-slender-pillar", "motion_onset"),
    ("rrs-slender-pillar", "overturn_imminent"),
    ("rrs-slender-pillar", "overturned"),
    ("rrs-pinnacle-ensemble", "motion_onset"),
    ("rrs-pinnacle-ensemble", "overturn_imminent"),
    ("rrs-sliding-slab", "motion_onset"),
    ("rrs-stocky-boulder", "motion_onset"),
];

fn rinaldi_alerts() -> BTreeSet<(String, String)> {
    RINALDI_ALERTS
        .iter()
        .map(|(id, level)| (id.to_string(), level.to_string()))
        .collect()
}

/// The path of example `name`'s executable, built once per test process with the cargo that
/// runs the tests, into this test's target directory and profile (cargo's JSON messages name
/// the executable).
fn example(name: &str) -> PathBuf {
    static BUILT: OnceLock<Vec<(String, PathBuf)>> = OnceLock::new();
    let built = BUILT.get_or_init(|| {
        // This test runs as <target>/<profile dir>/deps/examples-<hash>.
        let exe = std::env::current_exe().expect("test executable path");
        let profile_dir = exe
            .parent()
            .and_then(Path::parent)
            .expect("<target>/<profile>/deps/");
        let target_dir = profile_dir.parent().expect("<target>/<profile>");
        let profile = match profile_dir.file_name().and_then(|n| n.to_str()) {
            Some("debug") => "dev",
            Some(other) => other,
            None => panic!("no profile directory in {}", exe.display()),
        };
        let mut cargo = Command::new(env!("CARGO"));
        cargo
            .args(["build", "--message-format=json-render-diagnostics"])
            .arg("--manifest-path")
            .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml"))
            .arg("--target-dir")
            .arg(target_dir)
            .args(["--profile", profile]);
        for name in EXAMPLES {
            cargo.args(["--example", name]);
        }
        let out = cargo.stderr(Stdio::inherit()).output().expect("run cargo");
        assert!(out.status.success(), "cargo build --example failed");
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter(|m| m["reason"] == "compiler-artifact")
            .filter_map(|m| {
                let name = m["target"]["name"].as_str()?.to_string();
                let exe = m["executable"].as_str()?;
                Some((name, PathBuf::from(exe)))
            })
            .collect()
    });
    built
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, exe)| exe.clone())
        .unwrap_or_else(|| panic!("cargo built no executable for example {name}: {built:?}"))
}

/// The (block, level) of every alert journaled in `state_dir`.
fn journaled_alerts(state_dir: &Path) -> BTreeSet<(String, String)> {
    let Ok((records, _)) = read_journal(state_dir) else {
        return BTreeSet::new();
    };
    records
        .iter()
        .filter_map(|r| match r {
            JournalRecord::Alert(a) => Some((a.pbr_id.to_string(), a.level.as_str().to_string())),
            _ => None,
        })
        .collect()
}

#[test]
fn iox_station_publisher_feeds_the_node_which_journals_the_rinaldi_alerts() {
    let publisher = example("iox-station-publisher");
    let dir = tempfile::tempdir().unwrap();
    let state_dir = dir.path().join("state");
    // Service names of this test process only (tests of other processes run alongside).
    let accel = format!("rockwatch-example-{}/accel", std::process::id());
    let alerts = format!("rockwatch-example-{}/alerts", std::process::id());
    let iox_file = repo().join("config/iceoryx2.toml");
    let config = dir.path().join("node.toml");
    std::fs::write(
        &config,
        format!(
            "catalogue = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n\
             [iceoryx2]\nconfig_file = \"{}\"\naccel_service = \"{accel}\"\nalerts_service = \"{alerts}\"\n",
            repo().join("config/catalogue.toml").display(),
            iox_file.display()
        ),
    )
    .unwrap();
    // The node's ROS 2 side opens DDS: it runs in a network namespace of its own. iceoryx2
    // goes through shared memory, which the namespace does not separate.
    let stderr_path = dir.path().join("node.err");
    let child = Command::new("unshare")
        .args([
            "-n",
            "sh",
            "-c",
            "ip link set lo up && exec \"$0\" node --config \"$1\" --state-dir \"$2\"",
        ])
        .arg(rockwatch_bin!())
        .arg(&config)
        .arg(&state_dir)
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&stderr_path).unwrap())
        .spawn()
        .expect("unshare (util-linux)");
    let mut node = NodeProcess { child, stderr_path };

    // The station: 20 × real time, 5 s of quiet after the record; it waits for the node.
    let out = Command::new("timeout")
        .args(["-k", "5", "120"])
        .arg(&publisher)
        .arg("--iceoryx2-config")
        .arg(&iox_file)
        .args(["--service", &accel, "--speed", "20", "--tail", "5"])
        .output()
        .unwrap();
    let (stdout, stderr) = text(&out);
    assert!(
        out.status.success(),
        "publisher: {}\n{stdout}\n{stderr}\n--- node\n{}",
        out.status,
        node.stderr()
    );
    let summary = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("sent "))
        .find(|l| l.contains(" packets ("))
        .unwrap_or_else(|| panic!("no summary line\n{stdout}"));
    let sent: u64 = summary.split(' ').next().unwrap().parse().unwrap();
    // 19.9 s of record + 5 s of quiet in 100 ms packets, one line per packet.
    assert!(sent > 240, "{summary}");
    assert_eq!(
        stdout.lines().filter(|l| l.starts_with("sent #")).count() as u64,
        sent,
        "{stdout}"
    );

    // Every alert of the record reaches the journal (written before it is published).
    let deadline = Instant::now() + Duration::from_secs(60);
    while journaled_alerts(&state_dir) != rinaldi_alerts() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(100));
    }
    // The node takes the quiet tail after the last alert: let it finish before stopping it
    // (it stops intake on SIGTERM). At 20 × real time it keeps pace with the station.
    std::thread::sleep(Duration::from_secs(3));
    let status = node.signal_and_wait("TERM", Duration::from_secs(20));
    let node_stderr = node.stderr();
    assert!(
        status.is_some_and(|s| s.success()),
        "node exit {status:?}\n{node_stderr}"
    );
    assert_eq!(
        journaled_alerts(&state_dir),
        rinaldi_alerts(),
        "alerts journaled by the node fed by the example\n{node_stderr}"
    );
    // Every packet arrived and passed the node's wire checks (layout, type names, header
    // fields): nothing rejected, no sequence gap.
    assert!(
        node_stderr.contains(&format!(
            "iceoryx2: {sent} packets received, {sent} submitted, 0 rejected, 0 sequence gaps"
        )),
        "sent {sent}\n{node_stderr}"
    );
}

#[test]
fn iox_station_publisher_waiting_for_its_node_ends_cleanly_on_sigint() {
    let publisher = example("iox-station-publisher");
    let service = format!("rockwatch-example-{}/nobody", std::process::id());
    let mut child = Command::new(&publisher)
        .args(["--service", &service, "--wait-s", "60"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Once it says it waits, it sits in node.wait() (iceoryx2's signal handling).
    let stderr = child.stderr.take().unwrap();
    let waiting = std::thread::spawn(move || {
        use std::io::{BufRead, BufReader};
        let mut lines = Vec::new();
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            lines.push(line);
        }
        lines
    });
    std::thread::sleep(Duration::from_secs(2));
    let started = Instant::now();
    let _ = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
    let out = child.wait_with_output().unwrap();
    let stderr = waiting.join().unwrap().join("\n");
    assert!(
        started.elapsed() < Duration::from_secs(5),
        "took {:?} to stop",
        started.elapsed()
    );
    assert!(out.status.success(), "{}\n{stderr}", out.status);
    assert!(
        stderr.contains("waiting for a subscriber") && stderr.contains("interrupted"),
        "{stderr}"
    );
}

#[test]
fn ros2_alert_subscriber_prints_the_alerts_of_a_replay_live_late_and_on_its_domain_only() {
    let subscriber = example("ros2-alert-subscriber");
    let dir = tempfile::tempdir().unwrap();
    let config = write_node_config(dir.path(), &repo().join("config/catalogue.toml"));
    let (d, bin, sub) = (
        dir.path().display(),
        rockwatch_bin!().display().to_string(),
        subscriber.display(),
    );
    let records = repo().join("tests/data/records");
    // Everything on DDS domain 7 (ROS_DOMAIN_ID, set below), loopback only
    // (ROS_AUTOMATIC_DISCOVERY_RANGE for the examples, discovery_range for node and replay):
    // 1. a live subscriber stops after the 7 alerts of the replay (--count);
    // 2. a late one gets them all from the topic's history (transient local) and stops on
    //    SIGINT;
    // 3. a subscriber on domain 8 gets nothing (--count 1 --timeout: exit 1).
    // VETH_TX before and after: nothing may leave on the non-loopback interface.
    let script = format!(
        "{VETH_TX}
         export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
         '{bin}' node --config '{c}' --state-dir '{d}/state' 2> '{d}/node.err' & NODE=$!
         '{sub}' --count 7 --timeout 120 > '{d}/live.out' 2> '{d}/live.err' & LIVE=$!
         '{bin}' replay --config '{c}' --record '{r}/Rinaldi228.AT2' --vertical '{r}/RinaldiUP.AT2' \
             --azimuth 228 --station CI.RRS.00 --transport ros2 --speed 20 --tail 5 --wait-s 60 > /dev/null
         RC=0; wait $LIVE || RC=$?; echo LIVE_RC=$RC
         '{sub}' --json > '{d}/late.out' 2> '{d}/late.err' & LATE=$!
         for i in $(seq 300); do [ \"$(wc -l < '{d}/late.out')\" -ge 7 ] && break; sleep 0.1; done
         kill -INT $LATE; RC=0; wait $LATE || RC=$?; echo LATE_RC=$RC
         RC=0; ROS_DOMAIN_ID=8 '{sub}' --count 1 --timeout 3 > '{d}/other.out' 2> '{d}/other.err' || RC=$?
         echo OTHER_RC=$RC
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         {VETH_TX}",
        c = config.display(),
        r = records.display(),
    );
    let out = run_in_netns(&script, 240, &[("ROS_DOMAIN_ID", "7".into())]);
    let (stdout, stderr) = text(&out);
    let read = |name: &str| std::fs::read_to_string(dir.path().join(name)).unwrap_or_default();
    let context = format!(
        "{stdout}\n{stderr}\n--- live.err\n{}\n--- late.err\n{}\n--- other.err\n{}\n--- node.err\n{}",
        read("live.err"),
        read("late.err"),
        read("other.err"),
        read("node.err")
    );
    assert!(out.status.success(), "{}\n{context}", out.status);
    for rc in ["LIVE_RC=0", "LATE_RC=0", "OTHER_RC=1", "NODE_RC=0"] {
        assert!(stdout.contains(rc), "expected {rc}\n{context}");
    }
    let veth: Vec<&str> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("VETH_TX="))
        .collect();
    assert!(
        veth.len() == 2 && veth[0] == veth[1],
        "the examples must stay on loopback: {veth:?}\n{context}"
    );

    // Live, as text: one line per alert, level then block.
    let live = read("live.out");
    let live_alerts: BTreeSet<(String, String)> = live
        .lines()
        .map(|l| {
            let fields: Vec<&str> = l.split_whitespace().collect();
            (fields[2].to_string(), fields[1].to_string())
        })
        .collect();
    assert_eq!(live.lines().count(), 7, "{live}\n{context}");
    assert_eq!(live_alerts, rinaldi_alerts(), "{live}");
    assert!(
        live.lines().all(|l| l.contains(" CI.RRS.00 mode ")),
        "{live}"
    );
    assert!(read("live.err").contains("7 alerts received (count reached)"));

    // Late, as JSON: the history, then SIGINT.
    let late = json_lines(&read("late.out"), "");
    let late_alerts: BTreeSet<(String, String)> = late
        .iter()
        .map(|a| {
            (
                a["pbr_id"].as_str().unwrap().to_string(),
                a["level"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(late.len(), 7, "{late:?}");
    assert_eq!(late_alerts, rinaldi_alerts());
    let overturned = late
        .iter()
        .find(|a| a["level"] == "overturned")
        .expect("the overturn");
    assert_eq!(overturned["pbr_id"], "rrs-slender-pillar");
    assert_eq!(overturned["level_code"], 3);
    assert_eq!(overturned["mode"], "overturned");
    assert!(overturned["theta_over_alpha"].as_f64().unwrap() > 1.0);
    assert!(read("late.err").contains("7 alerts received (stopped by a signal)"));

    // Another domain: nothing, and the error says where it looked.
    assert_eq!(read("other.out"), "");
    assert!(
        read("other.err").contains("received 0 of 1 alerts")
            && read("other.err").contains("domain 8"),
        "{context}"
    );
}
