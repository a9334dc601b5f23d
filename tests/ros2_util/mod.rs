//! Shared by the ROS 2 tests: every DDS test runs its processes in a fresh network namespace
//! (`unshare -n`, loopback up, plus a veth pair with an address and a multicast route, so a
//! participant that ignored the loopback restriction would send on it), bounded in time.

#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

/// The rockwatch binary under test.
pub fn rockwatch() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_rockwatch"))
}

pub fn repo() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// Shell prelude creating the namespace's interfaces.
pub const NETNS_SETUP: &str = "ip link set lo up && \
    ip link add rwv0 type veth peer name rwv1 && \
    echo 1 > /proc/sys/net/ipv6/conf/rwv0/disable_ipv6 && echo 1 > /proc/sys/net/ipv6/conf/rwv1/disable_ipv6 && \
    ip addr add 10.213.0.1/24 dev rwv0 && ip link set rwv1 up && ip link set rwv0 up && \
    ip route add 224.0.0.0/4 dev rwv0";

/// Shell snippet printing `VETH_TX=<packets sent on rwv0>` (/proc/net/dev is per namespace;
/// /sys would show the host's).
pub const VETH_TX: &str =
    "echo VETH_TX=$(sed 's/:/ /' /proc/net/dev | awk '$1 == \"rwv0\" {print $11}')";

/// Runs `script` (sh, `set -e`) in a new network namespace with `timeout_s` as a hard bound;
/// whatever it leaves running is killed when it ends.
pub fn run_in_netns(script: &str, timeout_s: u32, envs: &[(&str, String)]) -> Output {
    let mut cmd = Command::new("timeout");
    cmd.arg("-k")
        .arg("5")
        .arg(timeout_s.to_string())
        .arg("unshare")
        .arg("-n")
        .arg("sh")
        .arg("-c")
        // The script in a subshell, then whatever it left running is killed: an orphan (a
        // node started with `&` before a failing command ended the script under `set -e`)
        // would keep the output's pipes open, and `output()` would wait for ever.
        .arg(format!(
            "set -e; {NETNS_SETUP}; rc=0; (\n{script}\n) || rc=$?; {KILL_LEFTOVERS}; exit $rc"
        ))
        .env_remove("ROS_DOMAIN_ID")
        .env_remove("ROS_AUTOMATIC_DISCOVERY_RANGE");
    // DDS Security only where a test asks for it (tests/ros2_security.rs sets these itself).
    for var in [
        "ROS_SECURITY_ENABLE",
        "ROS_SECURITY_KEYSTORE",
        "ROS_SECURITY_ENCLAVE_OVERRIDE",
        "ROS_SECURITY_STRATEGY",
    ] {
        cmd.env_remove(var);
    }
    for (k, v) in envs {
        cmd.env(k, v);
    }
    cmd.output()
        .expect("run timeout/unshare (util-linux, coreutils)")
}

pub fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Shell snippet killing (SIGKILL) every process of the current network namespace except
/// the shell itself, each named on stderr (`left running by the test: PID CMDLINE`). Only for
/// the private namespace of [`run_in_netns`]: there, every such process is the test's.
pub const KILL_LEFTOVERS: &str = "me=$(readlink /proc/$$/ns/net); \
    for p in /proc/[0-9]*; do pid=${p#/proc/}; [ \"$pid\" = \"$$\" ] && continue; \
    [ \"$(readlink $p/ns/net 2>/dev/null)\" = \"$me\" ] || continue; \
    echo \"left running by the test: $pid $(tr '\\0' ' ' < $p/cmdline 2>/dev/null)\" >&2; \
    kill -KILL $pid 2>/dev/null || true; done";

/// Set in a test re-executed inside its network namespace.
pub const IN_NETNS: &str = "ROCKWATCH_TEST_IN_NETNS";

/// Runs the test `name` of the current test binary again, alone, in a fresh network
/// namespace (see [`run_in_netns`]) with `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, bounded by
/// `timeout_s`. Returns true inside the namespace (run the body there); in the caller, asserts
/// that the re-executed test passed and returns false.
pub fn reexec_in_netns(name: &str, timeout_s: u32) -> bool {
    if std::env::var_os(IN_NETNS).is_some() {
        return true;
    }
    let exe = std::env::current_exe().expect("test executable path");
    // Whatever the test started and left running (a child of a failed test) is killed and
    // named by run_in_netns when the test ends.
    let out = run_in_netns(
        &format!(
            "'{}' --exact '{name}' --nocapture --test-threads=1",
            exe.display()
        ),
        timeout_s,
        &[
            (IN_NETNS, "1".into()),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into()),
        ],
    );
    let (stdout, stderr) = text(&out);
    // timeout(1): 124 after its SIGTERM, 137 after the SIGKILL 5 s later.
    let how = match out.status.code() {
        Some(124 | 137) => format!("did not finish within {timeout_s} s: killed by timeout"),
        _ => format!("failed ({})", out.status),
    };
    assert!(
        out.status.success() && stdout.contains("1 passed"),
        "{name} in its network namespace {how}\n--- stdout\n{stdout}\n--- stderr\n{stderr}"
    );
    false
}

/// A `rockwatch node` child process, killed (SIGKILL) if still running when dropped.
pub struct NodeProcess {
    pub child: std::process::Child,
    pub stderr_path: PathBuf,
}

impl NodeProcess {
    /// Starts `rockwatch node --config CONFIG --state-dir STATE`, stderr to `stderr_path`.
    pub fn start(
        config: &std::path::Path,
        state_dir: &std::path::Path,
        stderr_path: PathBuf,
    ) -> Self {
        let stderr = std::fs::File::create(&stderr_path).unwrap();
        let child = Command::new(rockwatch())
            .arg("node")
            .arg("--config")
            .arg(config)
            .arg("--state-dir")
            .arg(state_dir)
            .stdout(std::process::Stdio::null())
            .stderr(stderr)
            .spawn()
            .expect("start rockwatch node");
        NodeProcess { child, stderr_path }
    }

    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr_path).unwrap_or_default()
    }

    /// Sends `signal` (e.g. "TERM", "KILL") and waits up to `timeout` for the exit.
    pub fn signal_and_wait(
        &mut self,
        signal: &str,
        timeout: std::time::Duration,
    ) -> Option<std::process::ExitStatus> {
        let pid = self.child.id().to_string();
        let _ = Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(&pid)
            .status();
        let deadline = std::time::Instant::now() + timeout;
        loop {
            if let Ok(Some(status)) = self.child.try_wait() {
                return Some(status);
            }
            if std::time::Instant::now() >= deadline {
                return None;
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }
}

impl Drop for NodeProcess {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// A node configuration (TOML) with `catalogue` and loopback-only ROS 2.
pub fn write_node_config(dir: &std::path::Path, catalogue: &std::path::Path) -> PathBuf {
    let path = dir.join("node.toml");
    std::fs::write(
        &path,
        format!(
            "catalogue = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n",
            catalogue.display()
        ),
    )
    .unwrap();
    path
}

/// The Rinaldi record (228° + up) as 100 ms packets of station CI.RRS.00 with `tail_s` of quiet.
pub fn rinaldi_packets(tail_s: f64) -> Vec<rockwatch_core::engine::AccelPacket> {
    let rec = repo().join("tests/data/records");
    let mut record = rockwatch_core::record::Record::read(&rec.join("Rinaldi228.AT2")).unwrap();
    record.attach_vertical(&rec.join("RinaldiUP.AT2")).unwrap();
    let station = rockwatch_core::engine::StationId::parse("CI.RRS.00").unwrap();
    let azimuth = rockwatch_core::azimuth::Azimuth::from_degrees(228.0).unwrap();
    rockwatch::replay::Traces::from_record(&record, azimuth).packets(&station, 100, tail_s)
}

/// True if `python3` can import Cyclone DDS's Python binding (`cyclonedds`, pinned in .ci/run).
pub fn have_cyclonedds() -> bool {
    Command::new("python3")
        .args(["-c", "import cyclonedds.domain"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Whether an optional peer of a test is `available`: true if so. If not, the test is skipped
/// locally (prints `skipped: <what> not found`, returns false) but FAILS under `CI=true`, where
/// .ci/run installs it (`how` says how).
pub fn peer_available(available: bool, what: &str, how: &str) -> bool {
    if !available {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI=true but {what} is missing ({how})"
        );
        eprintln!("skipped: {what} not found ({how})");
    }
    available
}

/// The number `label` is preceded by in the node's closing summary (`rockwatch: stopped:` or
/// `rockwatch: engine input:`) line that contains it.
pub fn count_before(stderr: &str, label: &str) -> u64 {
    let line = stderr
        .lines()
        .filter(|l| {
            l.starts_with("rockwatch: stopped:") || l.starts_with("rockwatch: engine input:")
        })
        .find(|l| l.contains(label))
        .unwrap_or_else(|| panic!("no summary with {label:?} in\n{stderr}"));
    let before = &line[..line.find(label).unwrap()];
    before
        .split(|c: char| !c.is_ascii_digit())
        .rfind(|s| !s.is_empty())
        .unwrap_or_else(|| panic!("no count before {label:?}: {line}"))
        .parse()
        .unwrap()
}

/// The JSON objects of the lines of `stdout` that start with `prefix`.
pub fn json_lines(stdout: &str, prefix: &str) -> Vec<serde_json::Value> {
    stdout
        .lines()
        .filter_map(|l| l.strip_prefix(prefix))
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// The environment variable naming the colcon install base (merged layout) of `msg/`, the
/// ROS 2 package `pbr_msgs` built by `launch-scripts/build-msgs.sh` (.ci/run sets it).
pub const PBR_MSGS_PREFIX_ENV: &str = "ROCKWATCH_PBR_MSGS_PREFIX";

/// The colcon install of `pbr_msgs` whose generated Python types (the messages and the service
/// `ResetPbr`: an install built before the service counts as none) import (with rclpy) once
/// its `local_setup.sh` is sourced: `$ROCKWATCH_PBR_MSGS_PREFIX`, else `target/pbr_msgs` (the
/// script's default). None (test skipped) if there is none, except under `CI=true` (panics).
pub fn pbr_msgs_install() -> Option<PathBuf> {
    let prefix = std::env::var_os(PBR_MSGS_PREFIX_ENV)
        .map_or_else(|| repo().join("target/pbr_msgs"), PathBuf::from);
    let ok = prefix.join("local_setup.sh").is_file()
        && Command::new("sh")
            .arg("-c")
            .arg(format!(
                "{}; exec python3 -c 'import rclpy; from pbr_msgs.msg import PbrAlert, AccelPacket; from pbr_msgs.srv import ResetPbr'",
                source_pbr_msgs(&prefix)
            ))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
    let what = format!(
        "the colcon build of msg/ with importable Python types in {}",
        prefix.display()
    );
    peer_available(
        ok,
        &what,
        &format!("run launch-scripts/build-msgs.sh, or set {PBR_MSGS_PREFIX_ENV}"),
    )
    .then_some(prefix)
}

/// Shell (sh) commands setting up the environment of the colcon install at `prefix` as its
/// own setup file does (AMENT_PREFIX_PATH, CMAKE_PREFIX_PATH, PYTHONPATH, LD_LIBRARY_PATH),
/// wherever the install lies (COLCON_CURRENT_PREFIX). The setup file is not `set -e` clean.
pub fn source_pbr_msgs(prefix: &std::path::Path) -> String {
    format!(
        "set +e; COLCON_CURRENT_PREFIX='{p}'; . '{p}/local_setup.sh'; unset COLCON_CURRENT_PREFIX; set -e",
        p = prefix.display()
    )
}

/// A child process whose stderr a thread reads as it comes. A pipe nobody reads fills at
/// 64 KiB, and then every thread of the child that logs blocks in `write`: the whole process
/// stalls (a DDS participant's event loop included), which looks like a failure of the
/// process under test.
pub struct LoggedChild {
    pub child: std::process::Child,
    /// What the child has written on stderr so far.
    text: std::sync::Arc<std::sync::Mutex<String>>,
    reader: Option<std::thread::JoinHandle<()>>,
}

impl LoggedChild {
    /// Spawns `cmd` with its stderr piped to the reading thread.
    pub fn spawn(cmd: &mut Command) -> LoggedChild {
        let mut child = cmd.stderr(std::process::Stdio::piped()).spawn().unwrap();
        let pipe = child.stderr.take().expect("piped");
        let text = std::sync::Arc::new(std::sync::Mutex::new(String::new()));
        let theirs = std::sync::Arc::clone(&text);
        let reader = Some(std::thread::spawn(move || {
            use std::io::BufRead;
            for line in std::io::BufReader::new(pipe).lines().map_while(Result::ok) {
                let mut text = theirs
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
                text.push_str(&line);
                text.push('\n');
            }
        }));
        LoggedChild {
            child,
            text,
            reader,
        }
    }

    /// What the child has written on stderr so far.
    pub fn stderr_so_far(&self) -> String {
        self.text
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone()
    }

    /// SIGTERM, then up to `grace` for the process to end (SIGKILL after): its exit status
    /// and everything it wrote on stderr.
    pub fn stop(mut self, grace: std::time::Duration) -> (std::process::ExitStatus, String) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        let deadline = std::time::Instant::now() + grace;
        while self.child.try_wait().unwrap().is_none() && std::time::Instant::now() < deadline {
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        let _ = self.child.kill();
        let status = self.child.wait().unwrap();
        if let Some(reader) = self.reader.take() {
            let _ = reader.join();
        }
        (status, self.stderr_so_far())
    }
}

/// `rockwatch node --config CONFIG` in its own network namespace (loopback up: its ROS 2 side
/// opens DDS; iceoryx2 uses shared memory, which the namespace does not separate).
pub fn spawn_node_in_netns(config: &std::path::Path) -> LoggedChild {
    LoggedChild::spawn(
        Command::new("unshare")
            .args([
                "-n",
                "sh",
                "-c",
                "ip link set lo up && exec \"$0\" node --config \"$1\"",
            ])
            .arg(rockwatch())
            .arg(config),
    )
}

/// `rockwatch replay --transport iceoryx2` of the bundled Rinaldi record (228° + vertical) as
/// station CI.RRS.00, at 20× with 5 s of quiet after it, to the node of `config`.
pub fn replay_rinaldi_iox(config: &std::path::Path) -> Output {
    let data = repo().join("tests/data/records");
    Command::new(rockwatch())
        .args(["replay", "--config"])
        .arg(config)
        .arg("--record")
        .arg(data.join("Rinaldi228.AT2"))
        .arg("--vertical")
        .arg(data.join("RinaldiUP.AT2"))
        .args([
            "--azimuth",
            "228",
            "--station",
            "CI.RRS.00",
            "--transport",
            "iceoryx2",
            "--speed",
            "20",
            "--tail",
            "5",
        ])
        .output()
        .unwrap()
}

/// SIGTERM to a node of [`spawn_node_in_netns`]; its exit status and stderr.
pub fn stop_node(node: LoggedChild) -> (std::process::ExitStatus, String) {
    node.stop(std::time::Duration::from_secs(60))
}

/// Every alert a listener receives until none has come for `quiet`.
pub fn collect(
    listener: &mut rockwatch::ros2::Ros2AlertListener,
    quiet: std::time::Duration,
) -> Vec<rockwatch::ros2::msg::PbrAlert> {
    let mut got = Vec::new();
    let mut last = std::time::Instant::now();
    while last.elapsed() < quiet {
        let batch = listener
            .recv(std::time::Duration::from_millis(100))
            .unwrap();
        if !batch.is_empty() {
            got.extend(batch);
            last = std::time::Instant::now();
        }
    }
    got
}

/// The alert records journaled in the state directory `state`, in journal order, as the
/// shared alert JSON (`rockwatch alerts --format json`).
pub fn journaled_alerts(state: &std::path::Path) -> Vec<serde_json::Value> {
    let out = Command::new(rockwatch())
        .args(["alerts", "--format", "json", "--state-dir"])
        .arg(state)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let records: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    records
        .into_iter()
        .filter(|r| r["type"] == "alert")
        .collect()
}

/// (pbr, episode, level) of every alert journaled in the state directory `state`, in journal
/// order.
pub fn alert_history(state: &std::path::Path) -> Vec<(String, u64, String)> {
    journaled_alerts(state)
        .iter()
        .map(|a| {
            (
                a["pbr_id"].as_str().unwrap().to_string(),
                a["episode"].as_u64().unwrap(),
                a["level"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

/// One metric sample of the Prometheus text format: name, labels, value.
pub type Sample = (String, std::collections::BTreeMap<String, String>, f64);

/// Parses the Prometheus text exposition format (0.0.4): `# HELP`/`# TYPE` lines, then
/// `name{label="value",…} number` samples; a sample's family must have been typed first.
pub fn parse_prometheus(text: &str) -> Result<Vec<Sample>, String> {
    let mut typed = std::collections::BTreeSet::new();
    let mut samples = Vec::new();
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("# TYPE ") {
            let (name, kind) = rest.split_once(' ').ok_or(line)?;
            if !["counter", "gauge"].contains(&kind) {
                return Err(format!("unknown type: {line}"));
            }
            typed.insert(name.to_string());
            continue;
        }
        if line.starts_with("# HELP ") || line.is_empty() {
            continue;
        }
        let (head, value) = line.rsplit_once(' ').ok_or(line)?;
        let value: f64 = value.parse().map_err(|_| format!("bad value: {line}"))?;
        let (name, labels) = match head.split_once('{') {
            None => (head.to_string(), std::collections::BTreeMap::new()),
            Some((name, rest)) => {
                let body = rest.strip_suffix('}').ok_or(line)?;
                let mut labels = std::collections::BTreeMap::new();
                for pair in body.split("\",").filter(|p| !p.is_empty()) {
                    let (k, v) = pair.split_once("=\"").ok_or(line)?;
                    labels.insert(k.to_string(), v.trim_end_matches('"').to_string());
                }
                (name.to_string(), labels)
            }
        };
        if !typed.contains(&name) {
            return Err(format!("sample before its # TYPE: {line}"));
        }
        samples.push((name, labels, value));
    }
    Ok(samples)
}

pub fn station_value(samples: &[Sample], name: &str, station: &str) -> Option<f64> {
    samples
        .iter()
        .find(|(n, l, _)| n == name && l.get("station").map(String::as_str) == Some(station))
        .map(|s| s.2)
}

/// The value of the sample `name` whose labels include every pair of `labels`, if any.
pub fn labelled_value(samples: &[Sample], name: &str, labels: &[(&str, &str)]) -> Option<f64> {
    samples
        .iter()
        .find(|(n, l, _)| {
            n == name
                && labels
                    .iter()
                    .all(|(k, v)| l.get(*k).map(String::as_str) == Some(*v))
        })
        .map(|s| s.2)
}
