//! `[[notify]]` alert routing: the node's runtime over the bundled Rinaldi record publishing to
//! a `Notifier`, against a real HTTP server on loopback (a small one here, on
//! `std::net::TcpListener`) that is down for a while, and `exec` commands; then the same
//! through the binary (`rockwatch node` fed by `rockwatch replay --transport iceoryx2`).

mod shell_harness;
use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::process::stop_node;
use rockwatch_test_harness::rockwatch_bin;
use shell_harness::rinaldi_packets;

use std::collections::BTreeSet;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rockwatch::alert_json::{AlertJson, RecordJson};
use rockwatch::journal::read_journal;
use rockwatch::node::{NodeOptions, NodeRuntime};
use rockwatch::notify::{Notifier, NotifyConfig, NotifyKind};
use rockwatch::ports::Publisher;
use rockwatch_core::engine::{AlertLevel, JournalRecord};

type Key = (String, u32, AlertLevel);

fn catalogue() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../config/catalogue.toml"
    ))
}

/// The node's runtime (one inline shard, journal in `state`) over the Rinaldi packets, each
/// publication handed to `notifier` (if any); returns the journal's records.
fn run_rinaldi(state: &Path, mut notifier: Option<&mut Notifier>) -> Vec<JournalRecord> {
    let options = NodeOptions {
        catalogue: Some(catalogue()),
        state_dir: Some(state.to_path_buf()),
        ..NodeOptions::default()
    };
    let mut runtime = NodeRuntime::start(&options).unwrap();
    let mut publish = |p: rockwatch::ports::Publication| {
        if let Some(n) = notifier.as_deref_mut() {
            n.publish(&p).unwrap();
        }
    };
    for packet in rinaldi_packets(10.0) {
        runtime.submit(packet, &mut publish);
    }
    runtime.stop(&mut publish);
    read_journal(state).unwrap().0
}

fn alerts(records: &[JournalRecord]) -> Vec<AlertJson> {
    records
        .iter()
        .filter_map(|r| match r {
            JournalRecord::Alert(a) => Some(AlertJson::from(a)),
            _ => None,
        })
        .collect()
}

fn keys(alerts: &[AlertJson]) -> BTreeSet<Key> {
    alerts
        .iter()
        .map(|a| (a.pbr_id.to_string(), a.episode, a.level))
        .collect()
}

fn webhook(url: &str) -> NotifyConfig {
    NotifyConfig {
        kind: NotifyKind::Webhook,
        url: Some(url.into()),
        command: Vec::new(),
        timeout_s: 2.0,
        levels: None,
        pbrs: None,
        // Short retries so that the test does not wait long once the server is up.
        retry_initial_s: 0.05,
        retry_max_s: 0.2,
        queue: 1024,
    }
}

fn exec(command: &[&str]) -> NotifyConfig {
    NotifyConfig {
        kind: NotifyKind::Exec,
        url: None,
        command: command.iter().map(ToString::to_string).collect(),
        ..webhook("")
    }
}

/// `sh -c 'cat >> OUT'`: appends each alert (one JSON line) to `out`.
fn append_to(out: &Path) -> NotifyConfig {
    exec(&["sh", "-c", "cat >> \"$0\"", out.to_str().unwrap()])
}

/// The alerts a receiver got, parsed as the shared schema (one JSON document per line).
fn received_lines(out: &Path) -> Vec<AlertJson> {
    std::fs::read_to_string(out)
        .unwrap_or_default()
        .lines()
        .map(|l| match serde_json::from_str::<RecordJson>(l).unwrap() {
            RecordJson::Alert(a) => a,
            other => panic!("not an alert: {other:?}"),
        })
        .collect()
}

/// Waits (≤ `limit`) until `done` holds; false if it never did.
fn wait_until(limit: Duration, mut done: impl FnMut() -> bool) -> bool {
    let deadline = Instant::now() + limit;
    while Instant::now() < deadline {
        if done() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    done()
}

/// A port on loopback that nothing listens on (yet).
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A minimal HTTP/1.1 server on 127.0.0.1:`port`: answers every request 200 and keeps the
/// bodies of the POSTs to `/alerts`. Stops when dropped.
struct HttpServer {
    bodies: Arc<Mutex<Vec<serde_json::Value>>>,
    stop: Arc<AtomicBool>,
    port: u16,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl HttpServer {
    fn start(port: u16) -> HttpServer {
        let listener = TcpListener::bind(("127.0.0.1", port)).unwrap();
        let bodies = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (bodies, stop) = (Arc::clone(&bodies), Arc::clone(&stop));
            std::thread::spawn(move || {
                for stream in listener.incoming() {
                    if stop.load(Ordering::Relaxed) {
                        return;
                    }
                    if let Ok(stream) = stream {
                        if let Some(body) = Self::serve(stream) {
                            bodies.lock().unwrap().push(body);
                        }
                    }
                }
            })
        };
        HttpServer {
            bodies,
            stop,
            port,
            thread: Some(thread),
        }
    }

    /// Reads one request; answers 200; returns the body of a POST /alerts.
    fn serve(stream: TcpStream) -> Option<serde_json::Value> {
        stream.set_read_timeout(Some(Duration::from_secs(5))).ok()?;
        let mut reader = BufReader::new(stream);
        let mut request_line = String::new();
        reader.read_line(&mut request_line).ok()?;
        let mut length = 0;
        let mut json = false;
        loop {
            let mut line = String::new();
            reader.read_line(&mut line).ok()?;
            let line = line.trim_end();
            if line.is_empty() {
                break;
            }
            let (name, value) = line.split_once(':')?;
            match name.to_ascii_lowercase().as_str() {
                "content-length" => length = value.trim().parse().ok()?,
                "content-type" => json = value.trim() == "application/json",
                _ => {}
            }
        }
        let mut body = vec![0; length];
        reader.read_exact(&mut body).ok()?;
        let _ = reader
            .get_mut()
            .write_all(b"HTTP/1.1 200 OK\r\nContent-Length: 0\r\nConnection: close\r\n\r\n");
        (request_line.starts_with("POST /alerts ") && json)
            .then(|| serde_json::from_slice(&body).ok())
            .flatten()
    }

    fn bodies(&self) -> Vec<serde_json::Value> {
        self.bodies.lock().unwrap().clone()
    }

    /// The alerts received, parsed as the shared schema.
    fn alerts(&self) -> Vec<AlertJson> {
        self.bodies()
            .into_iter()
            .map(|b| match serde_json::from_value::<RecordJson>(b).unwrap() {
                RecordJson::Alert(a) => a,
                other => panic!("not an alert: {other:?}"),
            })
            .collect()
    }
}

impl Drop for HttpServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        let _ = TcpStream::connect(("127.0.0.1", self.port)); // wakes accept
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[test]
fn a_webhook_down_for_a_while_then_up_gets_every_alert() {
    let state = tempfile::tempdir().unwrap();
    let port = free_port();
    let mut config = webhook(&format!("http://127.0.0.1:{port}/alerts"));
    config.queue = 1; // the alerts of the burst overflow it: they wait in the spool only
    let mut notifier = Notifier::start(&[config], Some(state.path()), &[]).unwrap();
    let journaled = alerts(&run_rinaldi(state.path(), Some(&mut notifier)));
    assert!(journaled.len() >= 3, "{journaled:?}");
    // Down: connections refused, retried.
    std::thread::sleep(Duration::from_millis(500));
    let down = notifier.stats().remove(0);
    assert!(down.failed_attempts >= 2, "{down:?}");
    assert!(down.overflows >= 1, "{down:?}");
    assert_eq!(down.delivered, 0, "{down:?}");
    assert_eq!(down.pending, journaled.len() as u64, "{down:?}");
    // Up: everything arrives, as the journal has it.
    let server = HttpServer::start(port);
    assert!(
        wait_until(Duration::from_secs(20), || keys(&server.alerts())
            == keys(&journaled)),
        "received {:?}, journaled {:?}",
        keys(&server.alerts()),
        keys(&journaled)
    );
    for a in &journaled {
        assert!(
            server.alerts().contains(a),
            "{a:?} not received as journaled"
        );
    }
    for body in server.bodies() {
        assert_eq!(body["type"], "alert");
        assert!(body["data_time"].as_str().unwrap().ends_with('Z'), "{body}");
    }
    let stats = notifier.shutdown(Duration::from_secs(2)).remove(0);
    assert_eq!(stats.pending, 0, "{stats:?}");
    assert!(stats.delivered >= journaled.len() as u64, "{stats:?}");
}

#[test]
fn alerts_undelivered_when_the_node_stops_arrive_after_its_restart() {
    let state = tempfile::tempdir().unwrap();
    let port = free_port();
    let configs = [webhook(&format!("http://127.0.0.1:{port}/alerts"))];
    let mut notifier = Notifier::start(&configs, Some(state.path()), &[]).unwrap();
    let records = run_rinaldi(state.path(), Some(&mut notifier));
    let journaled = alerts(&records);
    let stopped = notifier.shutdown(Duration::from_millis(300)).remove(0);
    assert_eq!(stopped.pending, journaled.len() as u64, "{stopped:?}");
    assert_eq!(stopped.delivered, 0);
    let spools: Vec<_> = std::fs::read_dir(state.path().join("notify"))
        .unwrap()
        .collect();
    assert_eq!(spools.len(), 1, "{spools:?}");

    // The receiver comes up; the node restarts (its journal restored: the record replayed
    // again raises nothing new) and delivers what the spool kept.
    let server = HttpServer::start(port);
    let records = read_journal(state.path()).unwrap().0;
    let mut notifier = Notifier::start(&configs, Some(state.path()), &records).unwrap();
    assert_eq!(
        alerts(&run_rinaldi(state.path(), Some(&mut notifier))),
        journaled
    );
    assert!(
        wait_until(Duration::from_secs(20), || server.alerts().len()
            >= journaled.len()),
        "{:?}",
        server.alerts()
    );
    let stats = notifier.shutdown(Duration::from_secs(2)).remove(0);
    assert_eq!(stats.pending, 0, "{stats:?}");
    // Each exactly once here (at least once in general), in the journal's order.
    assert_eq!(server.alerts(), journaled);

    // A third start has nothing left to deliver.
    let notifier = Notifier::start(&configs, Some(state.path()), &records).unwrap();
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(notifier.shutdown(Duration::from_secs(1))[0].pending, 0);
    assert_eq!(server.alerts().len(), journaled.len());
}

#[test]
fn an_alert_journaled_but_never_spooled_is_delivered_from_the_journal_at_start() {
    let state = tempfile::tempdir().unwrap();
    let out = state.path().join("received.jsonl");
    let late = state.path().join("late.jsonl");
    // The receiver's spool exists (the node ran with it) …
    Notifier::start(&[append_to(&out)], Some(state.path()), &[])
        .unwrap()
        .shutdown(Duration::ZERO);
    // … then the node journaled alerts but died before spooling them.
    let records = run_rinaldi(state.path(), None);
    let journaled = alerts(&records);
    // At the next start they are delivered; a receiver new at this start gets no history.
    let notifier = Notifier::start(
        &[append_to(&out), append_to(&late)],
        Some(state.path()),
        &records,
    )
    .unwrap();
    assert!(
        wait_until(Duration::from_secs(20), || received_lines(&out).len()
            == journaled.len()),
        "{:?}",
        received_lines(&out)
    );
    let stats = notifier.shutdown(Duration::from_secs(2));
    assert_eq!(received_lines(&out), journaled);
    assert!(!late.exists(), "a new receiver was sent the history");
    assert_eq!((stats[1].delivered, stats[1].pending), (0, 0));
}

#[test]
fn a_hanging_exec_receiver_is_killed_at_its_timeout_and_retried_without_delaying_others() {
    let state = tempfile::tempdir().unwrap();
    let (mark, slow_out, fast_out) = (
        state.path().join("hung-once"),
        state.path().join("slow.jsonl"),
        state.path().join("fast.jsonl"),
    );
    // First run: hangs (30 s); every later run: takes the alert.
    let mut hanging = exec(&[
        "sh",
        "-c",
        "if [ -e \"$0\" ]; then cat >> \"$1\"; else touch \"$0\"; exec sleep 30; fi",
        mark.to_str().unwrap(),
        slow_out.to_str().unwrap(),
    ]);
    // 8 s: long enough that the other receiver finishes within it even on a loaded machine
    // (the assertion below that the hanging one has not been retried yet depends on it).
    hanging.timeout_s = 8.0;
    let mut notifier =
        Notifier::start(&[hanging, append_to(&fast_out)], Some(state.path()), &[]).unwrap();
    let started = Instant::now();
    let journaled = alerts(&run_rinaldi(state.path(), Some(&mut notifier)));
    // The other receiver gets everything while the first one hangs (its timeout is 8 s).
    assert!(
        wait_until(Duration::from_secs(20), || received_lines(&fast_out).len()
            == journaled.len()),
        "{:?}",
        received_lines(&fast_out)
    );
    assert_eq!(received_lines(&fast_out), journaled);
    assert!(
        mark.exists() && !slow_out.exists(),
        "the hanging receiver finished before its timeout"
    );
    // The hanging attempt is killed at 8 s and retried; then everything arrives, in order.
    assert!(
        wait_until(Duration::from_secs(20), || received_lines(&slow_out).len()
            == journaled.len()),
        "{:?}",
        received_lines(&slow_out)
    );
    // Killed no earlier than its timeout, and long before the command's own 30 s.
    let took = started.elapsed();
    assert!(
        took >= Duration::from_secs(8) && took < Duration::from_secs(28),
        "{took:?}"
    );
    let stats = notifier.shutdown(Duration::from_secs(2));
    assert_eq!(received_lines(&slow_out), journaled);
    assert_eq!(stats[0].failed_attempts, 1, "{stats:?}");
    assert_eq!(stats[1].failed_attempts, 0, "{stats:?}");
}

#[test]
fn levels_and_blocks_filter_what_a_receiver_gets() {
    let state = tempfile::tempdir().unwrap();
    let (fell, pillar) = (
        state.path().join("overturned.jsonl"),
        state.path().join("pillar.jsonl"),
    );
    let mut only_overturned = append_to(&fell);
    only_overturned.levels = Some(vec![AlertLevel::Overturned]);
    let mut only_pillar = append_to(&pillar);
    only_pillar.pbrs = Some(vec!["rrs-slender-pillar".into()]);
    let mut notifier =
        Notifier::start(&[only_overturned, only_pillar], Some(state.path()), &[]).unwrap();
    let journaled = alerts(&run_rinaldi(state.path(), Some(&mut notifier)));
    let expect = |keep: &dyn Fn(&AlertJson) -> bool| -> Vec<AlertJson> {
        journaled.iter().filter(|a| keep(a)).cloned().collect()
    };
    let want_fell = expect(&|a| a.level == AlertLevel::Overturned);
    let want_pillar = expect(&|a| a.pbr_id == "rrs-slender-pillar");
    // The record has alerts on both sides of each filter.
    assert!(!want_fell.is_empty() && want_fell.len() < journaled.len());
    assert!(!want_pillar.is_empty() && want_pillar.len() < journaled.len());
    assert!(wait_until(Duration::from_secs(20), || {
        received_lines(&fell).len() == want_fell.len()
            && received_lines(&pillar).len() == want_pillar.len()
    }));
    notifier.shutdown(Duration::from_secs(2));
    assert_eq!(received_lines(&fell), want_fell);
    assert_eq!(received_lines(&pillar), want_pillar);
    // An `overturned` alert's payload names its event report (issue 22 §4), written by the
    // runtime (stopped: its reports are written); the other levels name none.
    for line in std::fs::read_to_string(&pillar).unwrap().lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        match v["level"].as_str().unwrap() {
            "overturned" => {
                let png = Path::new(v["report"].as_str().unwrap());
                assert_eq!(png.parent().unwrap(), state.path().join("reports"));
                assert!(png.is_file(), "{}", png.display());
                let json: serde_json::Value =
                    serde_json::from_slice(&std::fs::read(png.with_extension("json")).unwrap())
                        .unwrap();
                assert_eq!(
                    (&json["pbr_id"], &json["data_time_ns"], &json["reason"]),
                    (&v["pbr_id"], &v["data_time_ns"], &"overturned".into())
                );
            }
            _ => assert!(v.get("report").is_none(), "{line}"),
        }
    }
}

/// Through the binary: `rockwatch node` (in its own network namespace: its ROS 2 side opens
/// DDS) with an `exec` receiver, fed by `rockwatch replay --transport iceoryx2`; every alert
/// of the node's journal reaches the receiver, in the shared schema.
#[test]
fn rockwatch_node_delivers_its_alerts_to_an_exec_receiver() {
    let dir = tempfile::tempdir().unwrap();
    let id = std::process::id();
    let (accel, alerts_service) = (
        format!("rockwatch-notify-{id}/accel"),
        format!("rockwatch-notify-{id}/alerts"),
    );
    let out = dir.path().join("received.jsonl");
    let state = dir.path().join("state");
    let config = dir.path().join("node.toml");
    std::fs::write(
        &config,
        format!(
            "catalogue = \"{}\"\nstate_dir = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n\
             [iceoryx2]\nconfig_file = \"{}\"\naccel_service = \"{accel}\"\nalerts_service = \"{alerts_service}\"\n\
             [[notify]]\nkind = \"exec\"\ncommand = [\"sh\", \"-c\", \"cat >> \\\"$0\\\"\", \"{}\"]\n",
            catalogue().display(),
            state.display(),
            repo().join("config/iceoryx2.toml").display(),
            out.display()
        ),
    )
    .unwrap();
    let node = rockwatch_bin!().spawn_node_in_netns(&config);
    let replay = rockwatch_bin!().replay_rinaldi_iox(&config);
    let journal_alerts = || alerts(&read_journal(&state).unwrap().0);
    let delivered = wait_until(Duration::from_secs(20), || {
        let j = journal_alerts();
        !j.is_empty() && received_lines(&out).len() >= j.len()
    });
    let (status, stderr) = stop_node(node);
    assert!(
        replay.status.success(),
        "replay: {}",
        String::from_utf8_lossy(&replay.stderr)
    );
    assert!(status.success(), "node exit {status:?}\n{stderr}");
    assert!(delivered, "{:?}\n{stderr}", received_lines(&out));
    let journaled = journal_alerts();
    assert!(
        journaled
            .iter()
            .any(|a| a.pbr_id == "rrs-slender-pillar" && a.level == AlertLevel::Overturned),
        "{journaled:?}"
    );
    assert_eq!(received_lines(&out), journaled, "{stderr}");
    assert!(
        stderr.contains("notify exec sh:") && stderr.contains("0 undelivered"),
        "{stderr}"
    );
}
