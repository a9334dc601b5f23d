//! The end-to-end rig of the acquisition tests (`acquire_e2e`, `acquire_faults`): a node and
//! its `/pbr/ims` listener, `rockwatch acquire` processes against a SeedLink server on
//! loopback, and the comparison of the node's alerts and final station intensity with
//! `rockwatch monitor --mseed FILE --stationxml FILE --format jsonl` on the same clean data.
//!
//! The final CAV and Arias intensity are sums over every sample: a lost or doubled sample
//! changes them (one 250 Hz sample of this record moves CAV by ~1e-4 relative, far beyond the
//! 1e-9 allowed); the alerts' PGV and times check the same before each alert.
//!
//! Data: the K2 accelerograph counts of tests/data/mseed/k2_STNA_HN123_counts.mseed with the
//! ObsPy-written inventory tests/data/stationxml/obspy_XX.STN_k2.xml; blocks slender enough
//! for its ~0.05 m/s² to rock them, at several thresholds so alerts fall through the record.
//! Callers run inside a network namespace (`rockwatch_test_harness::netns::reexec_in_netns`):
//! the node and the `/pbr/ims` subscriber open DDS.

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use rockwatch::iox::{IoxAlertSubscriber, IoxConfig};
use rockwatch::ros2::msg::{self, StationIntensity};
use rockwatch::ros2::{network_plan, output_qos, Ros2Config, Ros2Session};
use rockwatch_core::record::mseed::parse_mseed;

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::rockwatch_bin;

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
    let out = Command::new(rockwatch_bin!())
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
pub struct Intensity {
    pub data_time_ns: i64,
    pub pga: f64,
    pub pgv: f64,
    pub cav: f64,
    pub arias: f64,
    pub gap_samples: u64,
}

/// `rockwatch monitor` on the same file and inventory: its alerts and last intensity.
fn reference(dir: &Path, catalogue: &Path, xml: &Path) -> (Vec<serde_json::Value>, Intensity) {
    let state = dir.join("monitor-state");
    let out = Command::new(rockwatch_bin!())
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

/// A child process of the scenario with its stderr log: stopped (SIGTERM, SIGKILL after 15 s)
/// when dropped, so a failed assertion leaves nothing running; the end of its log (its closing
/// counters) is then printed.
pub struct Process {
    pub child: Child,
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
    pub fn stop(&mut self) {
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

    /// SIGKILL, and wait.
    pub fn kill(mut self) {
        self.child.kill().unwrap();
        let _ = self.child.wait();
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

/// The latest record start per stream in `records`.
/// Where every Rig's acquire serves `/metrics` (each test runs in its own network namespace,
/// and one acquire runs at a time).
pub const ACQUIRE_METRICS: &str = "127.0.0.1:9465";

pub fn latest_starts(records: &[Vec<u8>]) -> BTreeMap<String, i64> {
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

/// A node, its `/pbr/ims` listener, the reference from `monitor`, and the acquire processes
/// of one scenario (each in the scenario's temporary directory, logs `acquire-N.log`).
pub struct Rig {
    dir: tempfile::TempDir,
    expected: Vec<serde_json::Value>,
    expected_intensity: Intensity,
    node: Process,
    node_state: PathBuf,
    ims: ImsListener,
    acquire_config: PathBuf,
    acquire_state: PathBuf,
    server: SocketAddr,
    acquires: usize,
}

impl Rig {
    /// Computes the reference, writes the configurations (acquire: SeedLink v3 from
    /// `server`, reconnecting after 0.2–0.5 s, `max_wait_s = 3`, plus `extra_seedlink` keys
    /// of `[seedlink]`), starts the node and waits for its services.
    pub fn start(server: SocketAddr, extra_seedlink: &str) -> Rig {
        let dir = tempfile::tempdir().unwrap();
        let catalogue = catalogue(dir.path());
        let xml = repo().join("tests/data/stationxml/obspy_XX.STN_k2.xml");
        let (expected, expected_intensity) = reference(dir.path(), &catalogue, &xml);
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
                "[seedlink]\nserver = \"{server}\"\nstreams = [\"XX.STN..HN?\"]\nprotocol = 3\n\
                 reconnect_initial_s = 0.2\nreconnect_max_s = 0.5\n{extra_seedlink}\n\
                 [inventory]\nstationxml = [\"{}\"]\n[assembly]\nmax_wait_s = 3.0\n\
                 [metrics]\nlisten = \"{ACQUIRE_METRICS}\"\n{ros2_section}{iox_section}",
                xml.display()
            ),
        )
        .unwrap();
        let node_log = dir.path().join("node.log");
        let node = Process::spawn(
            "node",
            Command::new(rockwatch_bin!())
                .args(["node", "--config"])
                .arg(&node_config),
            &node_log,
        );
        let acquire_state = dir.path().join("acquire-state");
        let mut rig = Rig {
            dir,
            expected,
            expected_intensity,
            node,
            node_state,
            // Opened below, once the node is up.
            ims: ImsListener::open(),
            acquire_config,
            acquire_state,
            server,
            acquires: 0,
        };
        // The node is up once its alert service exists.
        let sub_config = IoxConfig {
            config_file: Some(iox_file),
            accel_service: accel,
            alerts_service,
            ..IoxConfig::default()
        };
        let deadline = Instant::now() + Duration::from_secs(30);
        while IoxAlertSubscriber::new(&sub_config).is_err() {
            assert!(
                Instant::now() < deadline,
                "the node's alert service never appeared{}",
                rig.logs("")
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        // /pbr/ims is volatile: let the subscription match the node's publisher first.
        let deadline = Instant::now() + Duration::from_secs(3);
        while Instant::now() < deadline {
            rig.ims.drain();
            std::thread::sleep(Duration::from_millis(50));
        }
        rig
    }

    /// Starts the next `rockwatch acquire --to TO` (log `acquire-N.log`, N from 1).
    pub fn acquire(&mut self, to: &str) -> Process {
        self.acquires += 1;
        let log = self
            .dir
            .path()
            .join(format!("acquire-{}.log", self.acquires));
        Process::spawn(
            "acquire",
            Command::new(rockwatch_bin!())
                .args(["acquire", "--to", to, "--config"])
                .arg(&self.acquire_config)
                .arg("--state-dir")
                .arg(&self.acquire_state),
            &log,
        )
    }

    /// The acquire state file of the server.
    pub fn state_file(&self) -> PathBuf {
        self.acquire_state.join(format!(
            "seedlink-{}.json",
            self.server.to_string().replace(':', "_")
        ))
    }

    /// The acquire state's per-stream latest start times.
    pub fn committed(&self) -> BTreeMap<String, i64> {
        std::fs::read_to_string(self.state_file())
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

    /// Waits (at most 60 s, taking /pbr/ims meanwhile) until `done`.
    pub fn wait(&mut self, what: &str, done: &dyn Fn(&Rig) -> bool) {
        let deadline = Instant::now() + Duration::from_secs(60);
        while !done(self) {
            self.ims.drain();
            assert!(Instant::now() < deadline, "{what}{}", self.logs(""));
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// The acquire logs so far, concatenated.
    pub fn acquire_logs(&self) -> String {
        (1..=self.acquires)
            .map(|i| {
                std::fs::read_to_string(self.dir.path().join(format!("acquire-{i}.log")))
                    .unwrap_or_default()
            })
            .collect()
    }

    /// Every log, for a failure message.
    pub fn logs(&self, extra: &str) -> String {
        let mut text = format!("{extra}\n");
        for i in 1..=self.acquires {
            text += &format!(
                "acquire {i}:\n{}\n",
                std::fs::read_to_string(self.dir.path().join(format!("acquire-{i}.log")))
                    .unwrap_or_default()
            );
        }
        text += &format!(
            "node:\n{}",
            std::fs::read_to_string(self.dir.path().join("node.log")).unwrap_or_default()
        );
        text
    }

    /// Waits until the node's intensity reaches the end of the data and every alert is in
    /// (at most `within`), then stops `running` and the node and asserts that the alerts and
    /// the final intensity equal `monitor`'s. Returns the acquire logs (after the stop: they
    /// end with the end-of-run summary).
    pub fn finish(mut self, mut running: Process, within: Duration, scenario: &str) -> String {
        let deadline = Instant::now() + within;
        let mut got = alerts(&self.node_state);
        loop {
            self.ims.drain();
            let at_end = self
                .ims
                .latest
                .is_some_and(|l| l.data_time_ns >= self.expected_intensity.data_time_ns);
            if at_end && got.len() >= self.expected.len() {
                break;
            }
            if Instant::now() >= deadline {
                running.stop();
                panic!(
                    "{scenario}: {} of {} alerts, last intensity {:?} (want {:?}){}",
                    got.len(),
                    self.expected.len(),
                    self.ims.latest,
                    self.expected_intensity,
                    self.logs("")
                );
            }
            std::thread::sleep(Duration::from_millis(200));
            got = alerts(&self.node_state);
        }
        // Time for anything doubled or late to show.
        let settle = Instant::now() + Duration::from_secs(2);
        while Instant::now() < settle {
            self.ims.drain();
            std::thread::sleep(Duration::from_millis(50));
        }
        got = alerts(&self.node_state);
        running.stop();
        self.node.stop();
        let context = self.logs(&format!("scenario {scenario}"));
        let expected = &self.expected;
        assert_eq!(
            got.len(),
            expected.len(),
            "{got:#?}\nvs\n{expected:#?}{context}"
        );
        for (a, b) in got.iter().zip(expected) {
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
            // The same f32 samples through the same engine: equal to round-off of the
            // summation order (none expected; 1e-9 relative allows it).
            for key in ["theta_over_alpha", "slide_m", "pga_mps2", "pgv_mps"] {
                let (x, y) = (a[key].as_f64().unwrap(), b[key].as_f64().unwrap());
                assert!(
                    (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
                    "{key}: {x} vs {y}{context}"
                );
            }
        }
        let last = self.ims.latest.unwrap();
        let want = self.expected_intensity;
        assert_eq!(last.data_time_ns, want.data_time_ns, "{context}");
        assert_eq!(
            (last.gap_samples, want.gap_samples),
            (0, 0),
            "nothing may be missing{context}"
        );
        for (name, x, y) in [
            ("PGA", last.pga, want.pga),
            ("PGV", last.pgv, want.pgv),
            ("CAV", last.cav, want.cav),
            ("Arias", last.arias, want.arias),
        ] {
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(y.abs()) && x > 0.0,
                "{name}: node {x} vs monitor {y}{context}"
            );
        }
        println!(
            "{scenario}: {} alerts and the final intensity ({:?}; {} /pbr/ims messages) equal{context}",
            got.len(),
            last,
            self.ims.received
        );
        let logs = self.acquire_logs();
        assert!(logs.contains("packets published"), "{context}");
        logs
    }
}
