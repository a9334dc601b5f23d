//! End to end: an independent SeedLink server (`seedlink-rs-server` 0.4.0, in this process,
//! loopback) → `rockwatch acquire` (SeedLink v3, StationXML calibration, iceoryx2 or ROS 2) →
//! `rockwatch node` → the node's alert journal and its `/pbr/ims` station intensities,
//! compared with `rockwatch monitor --mseed FILE --stationxml FILE --format jsonl` on the same
//! data (its alerts, and its summary's last station intensity).
//!
//! The final CAV and Arias intensity are sums over every sample: a lost or doubled sample
//! changes them (one 250 Hz sample of this record moves CAV by ~1e-4 relative, far beyond the
//! 1e-9 allowed); the alerts' PGV and times check the same before each alert. Scenarios:
//! - `acquire` SIGKILLed mid-stream and restarted (resume from its state directory);
//! - the SeedLink server restarted mid-stream with a fresh ring whose sequence numbers start
//!   again (acquire reconnects, sees the new start time, resumes by time, drops duplicates);
//! - `acquire --to ros2` (ROS 2 `/pbr/accel` instead of iceoryx2).
//!
//! Each test runs in its own network namespace (re-executed there: the node and this test's
//! `/pbr/ims` subscriber open DDS).
//!
//! Data: the K2 accelerograph counts of tests/data/mseed/k2_STNA_HN123_counts.mseed with the
//! ObsPy-written inventory tests/data/stationxml/obspy_XX.STN_k2.xml; blocks slender enough
//! for its ~0.05 m/s² to rock them, at several thresholds so alerts fall through the record.

mod ros2_util;
mod seedlink_server;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use rockwatch::iox::{IoxAlertSubscriber, IoxConfig};
use rockwatch::ros2::msg::{self, StationIntensity};
use rockwatch::ros2::{network_plan, output_qos, Ros2Config, Ros2Session};
use rockwatch_core::record::mseed::parse_mseed;
use ros2_util::{reexec_in_netns, repo, rockwatch};
use seedlink_server::{records_in_time_order, Server};

/// Blocks on XX.STN. rocking from |a| = g·B/H (0.01 to 0.06 m/s²): with this record their
/// alerts fall from 0 to about 10 s (3 overturn), before and after the interruption at ~5 s.
fn catalogue(dir: &Path) -> PathBuf {
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

/// The journal's alerts, without arrival times.
fn alerts(state: &Path) -> Vec<serde_json::Value> {
    let out = Command::new(rockwatch())
        .args(["alerts", "--format", "json", "--state-dir"])
        .arg(state)
        .output()
        .unwrap();
    if !out.status.success() {
        return Vec::new();
    }
    let all: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap_or_default();
    // The shared alert schema (README, "Alert JSON"): no arrival time, which differs by run.
    all.into_iter().filter(|r| r["type"] == "alert").collect()
}

/// The station intensity compared: time and the values (CAV, Arias cumulative).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Intensity {
    data_time_ns: i64,
    pga: f64,
    pgv: f64,
    cav: f64,
    arias: f64,
    gap_samples: u64,
}

/// `rockwatch monitor` on the same file and inventory: its alerts and last intensity.
fn reference(dir: &Path, catalogue: &Path, xml: &Path) -> (Vec<serde_json::Value>, Intensity) {
    let state = dir.join("monitor-state");
    let out = Command::new(rockwatch())
        .args(["monitor", "--catalogue"])
        .arg(catalogue)
        .arg("--mseed")
        .arg(repo().join("tests/data/mseed/k2_STNA_HN123_counts.mseed"))
        .arg("--stationxml")
        .arg(xml)
        .args([
            "--station",
            "XX.STN.",
            "--tail",
            "0",
            "--format",
            "jsonl",
            "--state-dir",
        ])
        .arg(&state)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let summary: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    let i = &summary["intensity"];
    assert_eq!(i["station"], "XX.STN.", "{summary}");
    let intensity = Intensity {
        data_time_ns: i["data_time_ns"].as_i64().unwrap(),
        pga: i["pga_mps2"].as_f64().unwrap(),
        pgv: i["pgv_mps"].as_f64().unwrap(),
        cav: i["cav_mps"].as_f64().unwrap(),
        arias: i["arias_mps"].as_f64().unwrap(),
        gap_samples: i["gap_samples"].as_u64().unwrap(),
    };
    let expected = alerts(&state);
    assert!(
        expected.len() >= 3,
        "the test needs alerts through the record: {expected:?}"
    );
    (expected, intensity)
}

/// A subscriber of the node's `/pbr/ims`, keeping XX.STN.'s latest intensity.
struct ImsListener {
    subscription: ros2_client::Subscription<StationIntensity>,
    latest: Option<Intensity>,
    received: usize,
    _session: Ros2Session,
}

impl ImsListener {
    fn open() -> ImsListener {
        let plan = network_plan(&Ros2Config::loopback_only(), None, None).unwrap();
        let mut session =
            Ros2Session::open_client(&plan, &"/".try_into().unwrap(), "e2e_ims_listener").unwrap();
        let subscription = session
            .subscription("/pbr/ims", msg::PACKAGE, "StationIntensity", output_qos())
            .unwrap();
        ImsListener {
            subscription,
            latest: None,
            received: 0,
            _session: session,
        }
    }

    /// Takes what has arrived.
    fn drain(&mut self) {
        while let Ok(Some((m, _))) = self.subscription.take() {
            if m.header.frame_id != "XX.STN." {
                continue;
            }
            self.received += 1;
            let t = m.header.stamp.to_nanos();
            if self.latest.is_none_or(|l| t >= l.data_time_ns) {
                self.latest = Some(Intensity {
                    data_time_ns: t,
                    pga: m.pga,
                    pgv: m.pgv,
                    cav: m.cav,
                    arias: m.arias,
                    gap_samples: m.gap_samples,
                });
            }
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scenario {
    /// iceoryx2; acquire SIGKILLed mid-stream and restarted.
    KillAcquire,
    /// iceoryx2; the server restarted mid-stream with a fresh ring.
    RestartServer,
    /// ROS 2 output, uninterrupted.
    Ros2,
}

/// A child process of the scenario with its stderr log: stopped (SIGTERM, SIGKILL after 15 s)
/// when dropped, so a failed assertion leaves nothing running; the end of its log (its closing
/// counters) is then printed.
struct Process {
    child: Child,
    name: &'static str,
    log: PathBuf,
}

impl Process {
    fn spawn(name: &'static str, command: &mut Command, log: &Path) -> Process {
        let child = command
            .stdout(std::process::Stdio::null())
            .stderr(std::fs::File::create(log).unwrap())
            .spawn()
            .unwrap();
        Process {
            child,
            name,
            log: log.to_path_buf(),
        }
    }

    /// SIGTERM, then SIGKILL if it has not exited within 15 s; waits for it.
    fn stop(&mut self) {
        if !matches!(self.child.try_wait(), Ok(None)) {
            return;
        }
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        let deadline = Instant::now() + Duration::from_secs(15);
        while matches!(self.child.try_wait(), Ok(None)) {
            if Instant::now() > deadline {
                eprintln!("{} did not stop within 15 s of SIGTERM: SIGKILL", self.name);
                let _ = self.child.kill();
                let _ = self.child.wait();
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Process {
    fn drop(&mut self) {
        let running = matches!(self.child.try_wait(), Ok(None));
        self.stop();
        if running && std::thread::panicking() {
            let log = std::fs::read_to_string(&self.log).unwrap_or_default();
            let lines: Vec<&str> = log.lines().collect();
            eprintln!(
                "{} stopped after the failure; the end of its log:\n{}",
                self.name,
                lines[lines.len().saturating_sub(8)..].join("\n")
            );
        }
    }
}

fn acquire(config: &Path, state: &Path, to: &str, log: &Path) -> Process {
    Process::spawn(
        "acquire",
        Command::new(rockwatch())
            .args(["acquire", "--to", to, "--config"])
            .arg(config)
            .arg("--state-dir")
            .arg(state),
        log,
    )
}

/// The latest record start per stream in `records`.
fn latest_starts(records: &[Vec<u8>]) -> BTreeMap<String, i64> {
    let mut out = BTreeMap::new();
    for r in records {
        let file = parse_mseed(r, Path::new("record")).unwrap();
        let c = &file.channels[0];
        let t = c.segments[0].start_time_ns;
        let e = out.entry(c.id()).or_insert(t);
        *e = (*e).max(t);
    }
    out
}

/// The acquire state's per-stream latest start times.
fn committed(state_file: &Path) -> BTreeMap<String, i64> {
    std::fs::read_to_string(state_file)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| v["streams"].as_object().cloned())
        .map(|m| {
            m.into_iter()
                .filter_map(|(k, v)| Some((k, v.as_i64()?)))
                .collect()
        })
        .unwrap_or_default()
}

/// Waits (bounded, taking /pbr/ims meanwhile) until `done`.
fn wait(what: &str, ims: &mut ImsListener, done: &dyn Fn() -> bool, logs: &dyn Fn(&str) -> String) {
    let deadline = Instant::now() + Duration::from_secs(60);
    while !done() {
        ims.drain();
        assert!(Instant::now() < deadline, "{what}{}", logs(""));
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn run(scenario: Scenario) {
    let dir = tempfile::tempdir().unwrap();
    let catalogue = catalogue(dir.path());
    let xml = repo().join("tests/data/stationxml/obspy_XX.STN_k2.xml");
    let (expected, expected_intensity) = reference(dir.path(), &catalogue, &xml);

    let mut server = Server::start("127.0.0.1:0");
    let addr = server.addr;
    let id = std::process::id();
    let (accel, alerts_service) = (
        format!("rockwatch-acq-{id}/accel"),
        format!("rockwatch-acq-{id}/alerts"),
    );
    let iox_file = repo().join("config/iceoryx2.toml");
    let iox_section = format!(
        "[iceoryx2]\nconfig_file = \"{}\"\naccel_service = \"{accel}\"\nalerts_service = \"{alerts_service}\"\n",
        iox_file.display()
    );
    let ros2_section = "[ros2]\ndiscovery_range = \"LOCALHOST\"\n";
    let node_state = dir.path().join("node-state");
    let node_config = dir.path().join("node.toml");
    std::fs::write(
        &node_config,
        format!(
            "catalogue = \"{}\"\nstate_dir = \"{}\"\n{ros2_section}{iox_section}",
            catalogue.display(),
            node_state.display()
        ),
    )
    .unwrap();
    let acquire_config = dir.path().join("acquire.toml");
    std::fs::write(
        &acquire_config,
        format!(
            "[seedlink]\nserver = \"{addr}\"\nstreams = [\"XX.STN..HN?\"]\nprotocol = 3\n\
             reconnect_initial_s = 0.2\nreconnect_max_s = 0.5\n\
             [inventory]\nstationxml = [\"{}\"]\n[assembly]\nmax_wait_s = 3.0\n{ros2_section}{iox_section}",
            xml.display()
        ),
    )
    .unwrap();

    let node_log = dir.path().join("node.log");
    let mut node = Process::spawn(
        "node",
        Command::new(rockwatch())
            .args(["node", "--config"])
            .arg(&node_config),
        &node_log,
    );
    let logs = |extra: &str| {
        let read = |p: &Path| std::fs::read_to_string(p).unwrap_or_default();
        format!(
            "{extra}\nfirst acquire:\n{}\nsecond acquire:\n{}\nnode:\n{}",
            read(&dir.path().join("acquire-1.log")),
            read(&dir.path().join("acquire-2.log")),
            read(&node_log)
        )
    };
    // The node is up once its alert service exists.
    let sub_config = IoxConfig {
        config_file: Some(iox_file.clone()),
        accel_service: accel.clone(),
        alerts_service: alerts_service.clone(),
        ..IoxConfig::default()
    };
    let deadline = Instant::now() + Duration::from_secs(30);
    while IoxAlertSubscriber::new(&sub_config).is_err() {
        assert!(
            Instant::now() < deadline,
            "the node's alert service never appeared{}",
            logs("")
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let mut ims = ImsListener::open();
    // /pbr/ims is volatile: let the subscription match the node's publisher first.
    let deadline = Instant::now() + Duration::from_secs(3);
    while Instant::now() < deadline {
        ims.drain();
        std::thread::sleep(Duration::from_millis(50));
    }

    let records = records_in_time_order();
    // 15 of 104 records (time order, ~3 records per second): about the first 5 s.
    let (third, half) = (10, 15);
    let acquire_state = dir.path().join("acquire-state");
    let state_file = acquire_state.join(format!(
        "seedlink-{}.json",
        addr.to_string().replace(':', "_")
    ));
    let log1 = dir.path().join("acquire-1.log");
    let log2 = dir.path().join("acquire-2.log");
    let to = if scenario == Scenario::Ros2 {
        "ros2"
    } else {
        "iceoryx2"
    };
    let running = match scenario {
        Scenario::KillAcquire => {
            server.push(&records[..half]);
            let mut first = acquire(&acquire_config, &acquire_state, to, &log1);
            // Mid-stream: once something is committed, SIGKILL.
            wait(
                "acquire committed nothing",
                &mut ims,
                &|| std::fs::read_to_string(&state_file).is_ok_and(|t| t.contains("\"sequence\"")),
                &logs,
            );
            first.child.kill().unwrap(); // SIGKILL
            let _ = first.child.wait();
            server.push(&records[half..]);
            acquire(&acquire_config, &acquire_state, to, &log2)
        }
        Scenario::RestartServer => {
            server.push(&records[..half]);
            let first = acquire(&acquire_config, &acquire_state, to, &log1);
            // Mid-stream: the first third published (the records after it may be held waiting
            // for their other components), then the server goes away.
            let want = latest_starts(&records[..third]);
            wait(
                "acquire did not publish the first server's records",
                &mut ims,
                &|| {
                    let got = committed(&state_file);
                    want.iter().all(|(k, t)| got.get(k).is_some_and(|g| g >= t))
                },
                &logs,
            );
            server.stop();
            // Down longer than max_wait_s (3 s): the components held waiting for the others
            // must not be given up for missing (zero-filled) while nothing can be fetched.
            // Then a new start time (INFO ID `started` has one-second resolution) and a fresh
            // ring numbered from 1 holding records acquire has had (third..half) and new ones.
            std::thread::sleep(Duration::from_millis(4500));
            server = Server::start(&addr.to_string());
            server.push(&records[third..]);
            first
        }
        Scenario::Ros2 => {
            server.push(&records);
            acquire(&acquire_config, &acquire_state, to, &log1)
        }
    };

    // Until the node's intensity reaches the end of the data and every alert is in.
    let deadline = Instant::now() + Duration::from_secs(90);
    let mut got = alerts(&node_state);
    loop {
        ims.drain();
        let at_end = ims
            .latest
            .is_some_and(|l| l.data_time_ns >= expected_intensity.data_time_ns);
        if at_end && got.len() >= expected.len() {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "{} of {} alerts, last intensity {:?} (want {expected_intensity:?}){}",
            got.len(),
            expected.len(),
            ims.latest,
            logs("")
        );
        std::thread::sleep(Duration::from_millis(200));
        got = alerts(&node_state);
    }
    // Time for anything doubled or late to show.
    let settle = Instant::now() + Duration::from_secs(2);
    while Instant::now() < settle {
        ims.drain();
        std::thread::sleep(Duration::from_millis(50));
    }
    got = alerts(&node_state);
    let mut running = running;
    running.stop();
    node.stop();
    server.stop();
    let context = logs(&format!("scenario {scenario:?}"));

    assert_eq!(
        got.len(),
        expected.len(),
        "{got:#?}\nvs\n{expected:#?}{context}"
    );
    for (a, b) in got.iter().zip(&expected) {
        for key in [
            "pbr_id",
            "station",
            "level",
            "episode",
            "mode",
            "data_time_ns",
        ] {
            assert_eq!(a[key], b[key], "{key}: {a} vs {b}{context}");
        }
        // The same f32 samples through the same engine: equal to round-off of the summation
        // order (none expected; 1e-9 relative allows it).
        for key in ["theta_over_alpha", "slide_m", "pga_mps2", "pgv_mps"] {
            let (x, y) = (a[key].as_f64().unwrap(), b[key].as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
                "{key}: {x} vs {y}{context}"
            );
        }
    }
    let last = ims.latest.unwrap();
    assert_eq!(
        last.data_time_ns, expected_intensity.data_time_ns,
        "{context}"
    );
    assert_eq!(
        (last.gap_samples, expected_intensity.gap_samples),
        (0, 0),
        "nothing may be missing{context}"
    );
    for (name, x, y) in [
        ("PGA", last.pga, expected_intensity.pga),
        ("PGV", last.pgv, expected_intensity.pgv),
        ("CAV", last.cav, expected_intensity.cav),
        ("Arias", last.arias, expected_intensity.arias),
    ] {
        assert!(
            (x - y).abs() <= 1e-9 * x.abs().max(y.abs()) && x > 0.0,
            "{name}: node {x} vs monitor {y}{context}"
        );
    }
    println!(
        "{scenario:?}: {} alerts and the final intensity ({:?}; {} /pbr/ims messages) equal{context}",
        got.len(),
        last,
        ims.received
    );
    let acquire_logs = std::fs::read_to_string(&log1).unwrap_or_default()
        + &std::fs::read_to_string(&log2).unwrap_or_default();
    assert!(acquire_logs.contains("packets published"), "{context}");
    if scenario == Scenario::RestartServer {
        assert!(
            acquire_logs.contains("the server restarted"),
            "the restart must be detected{context}"
        );
    }
}

#[test]
fn alerts_and_intensities_equal_monitor_across_a_sigkill_of_acquire() {
    if reexec_in_netns(
        "alerts_and_intensities_equal_monitor_across_a_sigkill_of_acquire",
        240,
    ) {
        run(Scenario::KillAcquire);
    }
}

#[test]
fn alerts_and_intensities_equal_monitor_across_a_restart_of_the_server() {
    if reexec_in_netns(
        "alerts_and_intensities_equal_monitor_across_a_restart_of_the_server",
        240,
    ) {
        run(Scenario::RestartServer);
    }
}

#[test]
fn alerts_and_intensities_equal_monitor_with_acquire_to_ros2() {
    if reexec_in_netns(
        "alerts_and_intensities_equal_monitor_with_acquire_to_ros2",
        240,
    ) {
        run(Scenario::Ros2);
    }
}
