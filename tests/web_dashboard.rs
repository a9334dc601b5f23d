//! The node's web dashboard (`[web]`, issue 22 §1), from a real `rockwatch node` in a private
//! network namespace (loopback only; curl as the client):
//! - `/api/status` lists every rock of the catalogue and every station from the start;
//! - after the Rinaldi record (ROS 2 replay) the slender pillar's overturn is in
//!   `/api/alerts` and was streamed on `/api/events` (SSE), the pillar is `fallen`, and once
//!   `engine.stale_after_s` has passed without data both stations are STALE and the standing
//!   rocks `not_monitored`;
//! - a client that opens `/api/events` and never reads does not stop the node;
//! - `/metrics` serves the same text on `[web] listen` and `[metrics] listen` (one server);
//! - restarted on the same state directory, the node's `/api/alerts` holds the journal's
//!   history before any new data;
//! - a non-loopback `listen` without `token_file` is refused at start; with a token, a request
//!   without it (or with a wrong one) gets 401, with it 200.

use rockwatch_test_harness::fixtures::repo;
use rockwatch_test_harness::netns::{reexec_in_netns, run_in_netns, text};
use rockwatch_test_harness::node_output::{labelled_value, parse_prometheus};
use rockwatch_test_harness::peers::peer_available;
use rockwatch_test_harness::process::LoggedChild;
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

/// The samples of a PEER AT2 file (g), read here independently of the code under test:
/// four header lines, then the values.
fn at2_g(path: &std::path::Path) -> Vec<f64> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(4)
        .flat_map(|l| l.split_whitespace().map(|v| v.parse::<f64>().unwrap()))
        .collect()
}

/// The last `n` bytes of `text` (about: on a character boundary).
fn tail(text: &str, n: usize) -> &str {
    let mut start = text.len().saturating_sub(n);
    while !text.is_char_boundary(start) {
        start += 1;
    }
    &text[start..]
}

const WEB: &str = "http://127.0.0.1:8080";

/// The node's configuration of these tests. `stale_after_s = 5`: long enough that the page is
/// loaded (a browser's start on a loaded 2-core machine) before the stations turn stale.
fn node_config(dir: &std::path::Path, extra: &str) {
    std::fs::write(
        dir.join("node.toml"),
        format!(
            "catalogue = \"{}\"\nstate_dir = \"state\"\n[engine]\nstale_after_s = 5.0\n\
             [ros2]\ndiscovery_range = \"LOCALHOST\"\n[status]\ndiagnostics_period_s = 0.2\n{extra}",
            repo().join("config/catalogue.toml").display()
        ),
    )
    .unwrap();
}

fn json(dir: &std::path::Path, name: &str, context: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join(name)).unwrap_or_default();
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}: {text:?}\n{context}"))
}

/// The alerts of `/api/alerts` as (pbr_id, level).
fn alert_keys(alerts: &serde_json::Value) -> Vec<(String, String)> {
    alerts["alerts"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|a| {
                    (
                        a["pbr_id"].as_str().unwrap_or("").to_string(),
                        a["level"].as_str().unwrap_or("").to_string(),
                    )
                })
                .collect()
        })
        .unwrap_or_default()
}

fn rock<'a>(status: &'a serde_json::Value, id: &str) -> &'a serde_json::Value {
    status["rocks"]
        .as_array()
        .and_then(|r| r.iter().find(|r| r["pbr_id"] == id))
        .unwrap_or_else(|| panic!("no rock {id} in {status}"))
}

fn station<'a>(status: &'a serde_json::Value, id: &str) -> &'a serde_json::Value {
    status["stations"]
        .as_array()
        .and_then(|r| r.iter().find(|r| r["id"] == id))
        .unwrap_or_else(|| panic!("no station {id} in {status}"))
}

#[test]
fn the_dashboard_shows_rocks_alerts_and_stale_stations_and_survives_a_stalled_client() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    node_config(
        p,
        "[metrics]\nlisten = \"127.0.0.1:9464\"\n[web]\nlisten = \"127.0.0.1:8080\"\n",
    );
    let d = p.display().to_string();
    let bin = rockwatch_bin!().display().to_string();
    let rec = repo().join("tests/data/records");
    let rec = rec.display();
    let replay = format!(
        "'{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' \
         --azimuth 228 --station CI.RRS.00 --transport ros2 --speed max --tail 2 --wait-s 20 >/dev/null"
    );
    let get =
        |path: &str, file: &str| format!("curl -sf --max-time 5 '{WEB}{path}' > '{d}/{file}'");
    let code = |path: &str, file: &str| {
        format!("curl -s --max-time 5 -o /dev/null -w '%{{http_code}}' '{WEB}{path}' > '{d}/{file}' || true")
    };
    let wait_status = |file: &str| {
        format!(
            "i=0; until curl -sf --max-time 2 '{WEB}/api/status' > '{d}/{file}'; do i=$((i+1)); [ $i -lt 300 ] || break; sleep 0.1; done"
        )
    };
    let script = format!(
        "'{bin}' node --config '{d}/node.toml' 2> '{d}/node.err' & NODE=$!
         {wait_start}
         curl -sN --max-time 60 '{WEB}/api/events' > '{d}/events.txt' & SSE=$!
         bash -c 'exec 3<>/dev/tcp/127.0.0.1/8080; printf \"GET /api/events HTTP/1.1\\r\\nHost: x\\r\\n\\r\\n\" >&3; sleep 60' & STALLED=$!
         sleep 0.5
         {replay}
         sleep 1
         {live}
         {alerts}
         {none}
         {bad}
         {rock}
         {rock404}
         {trace}
         {trace_long}
         {trace404}
         {page}
         {web_metrics}
         curl -sf --max-time 5 http://127.0.0.1:9464/metrics > '{d}/metrics.txt'
         sleep 6
         {stale}
         kill $SSE $STALLED 2>/dev/null || true
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?
         '{bin}' node --config '{d}/node.toml' 2> '{d}/node2.err' & NODE=$!
         {wait_restart}
         {history}
         kill -TERM $NODE; wait $NODE; echo NODE2_RC=$?",
        wait_start = wait_status("start.json"),
        wait_restart = wait_status("restart.json"),
        live = get("/api/status", "live.json"),
        alerts = get("/api/alerts", "alerts.json"),
        none = get("/api/alerts?since=9223372036854775807", "none.json"),
        bad = code("/api/alerts?since=yesterday", "bad.txt"),
        rock = get("/api/rocks/rrs-slender-pillar", "rock.json"),
        rock404 = code("/api/rocks/no-such-rock", "rock404.txt"),
        trace = get("/api/stations/CI.RRS.00/trace?seconds=120", "trace.json"),
        trace_long = code("/api/stations/CI.RRS.00/trace?seconds=121", "trace_long.txt"),
        trace404 = code("/api/stations/XX.NONE.00/trace", "trace404.txt"),
        page = get("/", "page.html"),
        web_metrics = get("/metrics", "web_metrics.txt"),
        stale = get("/api/status", "stale.json"),
        history = get("/api/alerts", "history.json"),
    );
    let out = run_in_netns(
        &script,
        150,
        &[("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into())],
    );
    let read = |name: &str| std::fs::read_to_string(p.join(name)).unwrap_or_default();
    let (stdout, stderr) = text(&out);
    let context = format!(
        "--- stdout\n{stdout}\n--- stderr\n{stderr}\n--- node\n{}\n--- node (restarted)\n{}\n--- events\n{}",
        read("node.err"),
        read("node2.err"),
        tail(&read("events.txt"), 3000),
    );
    assert!(
        out.status.success() && stdout.contains("NODE_RC=0") && stdout.contains("NODE2_RC=0"),
        "{context}"
    );

    // From the start: every rock of the catalogue, standing; both stations.
    let start = json(p, "start.json", &context);
    for id in ROCKS {
        assert_eq!(rock(&start, id)["display"], "standing", "{id}\n{context}");
    }
    assert_eq!(start["rocks"].as_array().map(Vec::len), Some(ROCKS.len()));
    for id in ["CI.RRS.00", "CI.SYL.00"] {
        station(&start, id);
    }

    // After the record: the pillar fell, its alert is in the feed and was streamed.
    let live = json(p, "live.json", &context);
    let pillar = rock(&live, "rrs-slender-pillar");
    assert_eq!(pillar["display"], "fallen", "{context}");
    assert_eq!(pillar["mode"], "overturned", "{context}");
    assert!(pillar["peak_theta_over_alpha"].as_f64().unwrap_or(0.0) >= 1.0);
    assert_eq!(rock(&live, "rrs-stocky-boulder")["display"], "standing");
    let alerts = json(p, "alerts.json", &context);
    let keys = alert_keys(&alerts);
    let overturned = ("rrs-slender-pillar".to_string(), "overturned".to_string());
    assert!(keys.contains(&overturned), "{keys:?}\n{context}");
    let first = &alerts["alerts"][0];
    assert_eq!(first["type"], "alert");
    assert_eq!(first["station"], "CI.RRS.00");
    assert!(first["data_time_ns"].as_i64().is_some());
    assert_eq!(
        json(p, "none.json", &context)["alerts"]
            .as_array()
            .map(Vec::len),
        Some(0),
        "since filters by time\n{context}"
    );
    assert_eq!(read("bad.txt"), "400", "a bad since is a 400\n{context}");
    let rock_json = json(p, "rock.json", &context);
    assert_eq!(rock_json["rock"]["display"], "fallen");
    assert!(alert_keys(&rock_json).contains(&overturned), "{rock_json}");
    assert_eq!(read("rock404.txt"), "404", "{context}");
    // The pillar's episode: its θ/α trace reaches the overturn, with its three alert marks.
    let episode = &rock_json["episode"];
    let marks: Vec<&str> = episode["alerts"]
        .as_array()
        .map(|a| a.iter().filter_map(|m| m["level"].as_str()).collect())
        .unwrap_or_default();
    assert_eq!(
        marks,
        ["motion_onset", "overturn_imminent", "overturned"],
        "{rock_json}"
    );
    let peak = episode["theta_over_alpha"]
        .as_array()
        .map(|t| {
            t.iter()
                .filter_map(|v| v.as_f64())
                .fold(0.0, |m: f64, v| m.max(v.abs()))
        })
        .unwrap_or(0.0);
    assert!(peak >= 1.0 && episode["ended"] == true, "{rock_json}");
    assert_eq!(rock_json["imminent_theta_ratio"], 0.8);

    // CI.RRS.00's trace: the record's east component (its 228° component projected), as
    // read from the AT2 file here: the envelope's extremes are the record's, sample for
    // sample (f32), and its PGA the peak of the record.
    let trace = json(p, "trace.json", &context);
    let record = at2_g(&repo().join("tests/data/records/Rinaldi228.AT2"));
    let g = 9.80665;
    let east_peak = record
        .iter()
        .map(|a| (a * g * 228f64.to_radians().sin()).abs())
        .fold(0.0, f64::max);
    let values = |key: &str| -> Vec<f64> {
        trace[key][0]
            .as_array()
            .map(|v| v.iter().filter_map(|v| v.as_f64()).collect())
            .unwrap_or_default()
    };
    let envelope_peak = values("min")
        .into_iter()
        .chain(values("max"))
        .fold(0.0, |m: f64, v| m.max(v.abs()));
    assert!(
        (envelope_peak - east_peak).abs() <= 1e-5 * east_peak,
        "envelope {envelope_peak} vs the record's east peak {east_peak}\n{trace}"
    );
    assert_eq!(trace["bin_s"], 0.2);
    assert_eq!(trace["samples"].as_array().map(Vec::len), Some(600));
    // 100 Hz: 20 samples in a full bin.
    let counts: Vec<u64> = trace["samples"]
        .as_array()
        .map(|s| s.iter().filter_map(|v| v.as_u64()).collect())
        .unwrap_or_default();
    assert!(
        counts.iter().filter(|c| **c == 20).count() >= 95,
        "{counts:?}"
    );
    let pga = record.iter().fold(0.0, |m: f64, a| m.max(a.abs())) * g;
    let ims_pga = trace["ims"]["pga_mps2"].as_f64().unwrap_or(0.0);
    assert!(
        (ims_pga - pga).abs() <= 0.02 * pga,
        "running PGA {ims_pga} vs the record's {pga}\n{trace}"
    );
    assert_eq!(read("trace_long.txt"), "400", "{context}");
    assert_eq!(read("trace404.txt"), "404", "{context}");
    let events = read("events.txt");
    assert!(
        events.contains("event: status") && events.contains("event: alert"),
        "{context}"
    );
    let streamed = events
        .lines()
        .filter_map(|l| l.strip_prefix("data: "))
        .filter_map(|d| serde_json::from_str::<serde_json::Value>(d).ok())
        .any(|a| a["pbr_id"] == "rrs-slender-pillar" && a["level"] == "overturned");
    assert!(streamed, "the overturn was streamed\n{context}");

    // The page is served, self-contained.
    let page = read("page.html");
    assert!(page.contains("<title>rockwatch</title>") && page.contains("/api/events"));
    assert!(
        !page.contains("http://") && !page.contains("https://"),
        "no external asset"
    );

    // /metrics: the node's series and the web side's, on both listeners.
    for file in ["web_metrics.txt", "metrics.txt"] {
        let samples = parse_prometheus(&read(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert!(
            labelled_value(
                &samples,
                "rockwatch_rock_state",
                &[("pbr", "rrs-slender-pillar")]
            ) == Some(4.0),
            "{file}\n{context}"
        );
        assert!(
            samples.iter().any(|s| s.0 == "rockwatch_web_clients"),
            "{file}\n{context}"
        );
        assert_eq!(
            samples
                .iter()
                .find(|s| s.0 == "rockwatch_web_handoff_dropped_total")
                .map(|s| s.2),
            Some(0.0),
            "{file}"
        );
    }

    // The live node wrote the pillar's fall report (issue 22 §4) into its state directory,
    // from the same traces the dashboard shows: the station's envelope and the fall's alerts.
    let reports: Vec<std::path::PathBuf> = std::fs::read_dir(p.join("state/reports"))
        .unwrap_or_else(|e| panic!("state/reports: {e}\n{context}"))
        .map(|e| e.unwrap().path())
        .filter(|f| {
            f.to_str()
                .is_some_and(|n| n.ends_with("_rrs-slender-pillar.json"))
        })
        .collect();
    assert_eq!(reports.len(), 1, "{reports:?}\n{context}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&reports[0]).unwrap()).unwrap();
    assert_eq!(report["reason"], "overturned");
    let levels: Vec<&str> = report["alerts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["level"].as_str().unwrap())
        .collect();
    assert_eq!(levels, ["motion_onset", "overturn_imminent", "overturned"]);
    assert!(report["station"]["components"][0]["max_mps2"]
        .as_array()
        .is_some_and(|b| b.len() > 10));
    assert!(reports[0].with_extension("png").is_file());

    // No data for stale_after_s: both stations STALE, their standing rocks not monitored,
    // the fallen pillar still fallen.
    let stale = json(p, "stale.json", &context);
    for id in ["CI.RRS.00", "CI.SYL.00"] {
        assert_eq!(station(&stale, id)["health"], "STALE", "{id}\n{context}");
        assert_eq!(station(&stale, id)["stale"], true);
    }
    assert_eq!(
        rock(&stale, "rrs-stocky-boulder")["display"],
        "not_monitored",
        "{context}"
    );
    assert_eq!(rock(&stale, "rrs-slender-pillar")["display"], "fallen");

    // Restarted: the journal's history is on /api/alerts before any new data.
    let history = alert_keys(&json(p, "history.json", &context));
    assert!(history.contains(&overturned), "{history:?}\n{context}");
    assert!(
        history.len() >= keys.iter().filter(|(_, l)| !l.is_empty()).count(),
        "{history:?} vs {keys:?}"
    );
}

#[test]
fn a_non_loopback_dashboard_needs_a_token_and_checks_it_on_every_request() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let d = p.display().to_string();
    let bin = rockwatch_bin!().display().to_string();
    // Refused at start: no token for an address open to the network.
    std::fs::create_dir(p.join("open")).unwrap();
    node_config(&p.join("open"), "[web]\nlisten = \"0.0.0.0:8080\"\n");
    // With one (inside the test's own network namespace: nothing is reachable from outside).
    std::fs::write(p.join("web.token"), "0123456789abcdef-test-token\n").unwrap();
    node_config(
        p,
        "[web]\nlisten = \"0.0.0.0:8080\"\ntoken_file = \"web.token\"\n",
    );
    let auth = "-H 'Authorization: Bearer 0123456789abcdef-test-token'";
    let code = |args: &str, path: &str, file: &str| {
        format!("curl -s --max-time 5 {args} -o /dev/null -w '%{{http_code}}' '{WEB}{path}' > '{d}/{file}' || true")
    };
    let script = format!(
        "'{bin}' node --config '{d}/open/node.toml' 2> '{d}/open.err' && echo OPEN_RC=0 || echo OPEN_RC=$?
         '{bin}' node --config '{d}/node.toml' 2> '{d}/node.err' & NODE=$!
         i=0; until curl -sf --max-time 2 {auth} '{WEB}/api/status' >/dev/null; do i=$((i+1)); [ $i -lt 300 ] || break; sleep 0.1; done
         {none}
         {wrong}
         {status}
         {page}
         {metrics}
         {events}
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?",
        none = code("", "/api/status", "none.txt"),
        wrong = code(
            "-H 'Authorization: Bearer 0123456789abcdef-test-tokeN'",
            "/api/status",
            "wrong.txt"
        ),
        status = code(auth, "/api/status", "status.txt"),
        page = code(auth, "/", "page.txt"),
        metrics = code("", "/metrics", "metrics.txt"),
        events = code("--max-time 1", "/api/events", "events.txt"),
    );
    let out = run_in_netns(&script, 60, &[]);
    let read = |name: &str| std::fs::read_to_string(p.join(name)).unwrap_or_default();
    let (stdout, stderr) = text(&out);
    let context = format!(
        "--- stdout\n{stdout}\n--- stderr\n{stderr}\n--- refused node\n{}\n--- node\n{}",
        read("open.err"),
        read("node.err")
    );
    assert!(
        out.status.success() && stdout.contains("NODE_RC=0"),
        "{context}"
    );
    assert!(
        stdout.contains("OPEN_RC=") && !stdout.contains("OPEN_RC=0"),
        "{context}"
    );
    let refusal = read("open.err");
    assert!(
        refusal.contains("[web] listen = \"0.0.0.0:8080\" is not a loopback address")
            && refusal.contains("token_file"),
        "{context}"
    );
    assert_eq!(read("none.txt"), "401", "no token\n{context}");
    assert_eq!(read("wrong.txt"), "401", "a wrong token\n{context}");
    assert_eq!(read("status.txt"), "200", "{context}");
    assert_eq!(read("page.txt"), "200", "{context}");
    assert_eq!(read("metrics.txt"), "401", "/metrics too\n{context}");
    assert_eq!(read("events.txt"), "401", "the stream too\n{context}");
}

/// `rockwatch demo --web`: prints the dashboard's URL, keeps the node serving it after the
/// replay (the overturn on `/api/alerts`) until SIGINT, then exits 0; a non-loopback address
/// is refused (the demo has no token).
#[test]
fn demo_web_serves_the_dashboard_after_the_replay_until_interrupted() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().display().to_string();
    let bin = rockwatch_bin!().display().to_string();
    let script = format!(
        "'{bin}' demo --speed max --tail 1 --web 0.0.0.0:8080 > '{d}/open.out' 2>&1 && echo OPEN_RC=0 || echo OPEN_RC=$?
         '{bin}' demo --speed max --tail 1 --web > '{d}/demo.out' 2> '{d}/demo.err' & DEMO=$!
         i=0; until grep -q 'until Ctrl-C' '{d}/demo.out'; do i=$((i+1)); [ $i -lt 600 ] || break; sleep 0.1; done
         curl -sf --max-time 5 '{WEB}/api/alerts' > '{d}/alerts.json'
         curl -sf --max-time 5 -o /dev/null '{WEB}/' && echo PAGE_OK
         kill -INT $DEMO; wait $DEMO; echo DEMO_RC=$?"
    );
    let out = run_in_netns(&script, 120, &[]);
    let read = |name: &str| std::fs::read_to_string(dir.path().join(name)).unwrap_or_default();
    let (stdout, stderr) = text(&out);
    let context = format!(
        "--- stdout\n{stdout}\n--- stderr\n{stderr}\n--- demo\n{}\n{}\n--- refused\n{}",
        read("demo.out"),
        read("demo.err"),
        read("open.out")
    );
    assert!(
        out.status.success() && stdout.contains("DEMO_RC=0"),
        "{context}"
    );
    assert!(stdout.contains("PAGE_OK"), "{context}");
    let demo = read("demo.out");
    assert!(
        demo.contains("dashboard: http://127.0.0.1:8080/")
            && demo.contains(
                "the node keeps serving the dashboard on http://127.0.0.1:8080/ until Ctrl-C"
            ),
        "{context}"
    );
    let alerts = json(dir.path(), "alerts.json", &context);
    assert!(
        alert_keys(&alerts).contains(&("rrs-slender-pillar".to_string(), "overturned".to_string())),
        "{context}"
    );
    assert!(
        stdout.contains("OPEN_RC=") && !stdout.contains("OPEN_RC=0"),
        "{context}"
    );
    assert!(
        read("open.out").contains("not a loopback address"),
        "{context}"
    );
}

/// Decodes standard base64 (the WebDriver screenshot), padding and all.
fn base64_decode(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    };
    let (mut out, mut acc, mut bits) = (Vec::new(), 0u32, 0);
    for v in text.bytes().filter_map(value) {
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    out
}

/// A WebDriver session of chromedriver on `port` (W3C protocol, JSON over loopback HTTP).
struct Browser {
    base: String,
}

impl Browser {
    fn call(&self, method: &str, path: &str, body: Option<serde_json::Value>) -> serde_json::Value {
        let url = format!("{}{path}", self.base);
        let reply = match (method, body) {
            ("GET", _) => ureq::get(&url).call(),
            ("DELETE", _) => ureq::delete(&url).call(),
            (_, body) => ureq::post(&url)
                .header("Content-Type", "application/json")
                .send(body.unwrap_or(serde_json::json!({})).to_string()),
        };
        let text = reply
            .unwrap_or_else(|e| panic!("WebDriver {method} {path}: {e}"))
            .body_mut()
            .read_to_string()
            .unwrap_or_else(|e| panic!("WebDriver {method} {path}: {e}"));
        serde_json::from_str::<serde_json::Value>(&text).unwrap_or_default()["value"].take()
    }

    /// Runs `script` (a function body) in the page and returns its value.
    fn eval(&self, script: &str) -> serde_json::Value {
        self.call(
            "POST",
            "/execute/sync",
            Some(serde_json::json!({ "script": script, "args": [] })),
        )
    }

    /// Waits up to `timeout` for `script` to return true; the time it took.
    fn wait_for(&self, script: &str, timeout: std::time::Duration) -> Option<std::time::Duration> {
        let start = std::time::Instant::now();
        while start.elapsed() < timeout {
            if self.eval(script) == serde_json::json!(true) {
                return Some(start.elapsed());
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        None
    }

    fn screenshot(&self, path: &std::path::Path) {
        let png = self.call("GET", "/screenshot", None);
        std::fs::write(path, base64_decode(png.as_str().unwrap_or(""))).unwrap();
    }

    /// Starts chromedriver on port 9515 (loopback) and a headless Chromium session; fails
    /// if chromedriver does not answer within 60 s of `up`.
    fn start(up: std::time::Instant) -> (std::process::Child, Browser) {
        let driver = std::process::Command::new("chromedriver")
            .args(["--port=9515", "--allowed-ips=127.0.0.1"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("chromedriver");
        let driver_base = "http://127.0.0.1:9515";
        while ureq::get(&format!("{driver_base}/status")).call().is_err() {
            assert!(up.elapsed().as_secs() < 60, "chromedriver did not start");
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        let session = Browser {
            base: driver_base.into(),
        }
        .call(
            "POST",
            "/session",
            Some(serde_json::json!({"capabilities": {"alwaysMatch": {
                "browserName": "chrome",
                "goog:chromeOptions": {"args": [
                    "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                    "--window-size=1200,1500"
                ]}
            }}})),
        );
        let id = session["sessionId"]
            .as_str()
            .unwrap_or_else(|| panic!("no session: {session}"))
            .to_string();
        let browser = Browser {
            base: format!("{driver_base}/session/{id}"),
        };
        (driver, browser)
    }
}

/// Whether chromium and chromedriver are installed (else the browser tests say so and pass,
/// or fail under CI: `peer_available`).
fn have_browser() -> bool {
    let have = |bin: &str| {
        std::process::Command::new("sh")
            .args(["-c", &format!("command -v {bin}")])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    peer_available(
        have("chromium") && have("chromedriver"),
        "chromium and chromedriver",
        "apt-get install chromium chromium-driver",
    )
}

/// The page in a real browser (headless Chromium driven over WebDriver by chromedriver, both
/// Debian packages, installed by .ci/run), in the test's own network namespace: it loads and
/// shows every rock of the catalogue; the Rinaldi overturn appears in its alert feed within 2 s
/// of the replay's end (the stream, not a reload) and the pillar turns to its fallen colour;
/// once the stations have been silent for `engine.stale_after_s` they are shown STALE. A
/// screenshot of each state goes to `$CARGO_TARGET_TMPDIR/web_dashboard/`.
#[test]
fn the_page_in_headless_chromium_shows_rocks_the_alert_and_stale_stations() {
    if !have_browser() {
        return;
    }
    if !reexec_in_netns(
        "the_page_in_headless_chromium_shows_rocks_the_alert_and_stale_stations",
        150,
    ) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    // CI.RRS.00 placed (drawn on the map), CI.SYL.00 not (listed, not drawn).
    node_config(
        p,
        "[web]\nlisten = \"127.0.0.1:8080\"\n\
         [[station]]\nid = \"CI.RRS.00\"\nlat = 34.2811\nlon = -118.4787\n",
    );
    let shots = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("web_dashboard");
    std::fs::create_dir_all(&shots).unwrap();
    // The browser first: the page must load before the stations go stale (2 s after the
    // node's start), which a loaded machine's Chromium start-up alone can exceed.
    let up = std::time::Instant::now();
    let (mut driver, browser) = Browser::start(up);
    let node = LoggedChild::spawn(
        std::process::Command::new(rockwatch_bin!())
            .arg("node")
            .arg("--config")
            .arg(p.join("node.toml")),
    );
    while ureq::get(&format!("{WEB}/api/status")).call().is_err() {
        assert!(
            up.elapsed().as_secs() < 90,
            "no status\n{}",
            node.stderr_so_far()
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    let second = std::time::Duration::from_secs(1);
    browser.call("POST", "/url", Some(serde_json::json!({ "url": WEB })));

    // Every rock of the catalogue, standing.
    let listed = format!(
        "return {:?}.every(id => {{ const r = document.getElementById('rock-' + id); \
         return r !== null && r.dataset.display === 'standing'; }})",
        ROCKS
    );
    assert!(
        browser.wait_for(&listed, 10 * second).is_some(),
        "{}",
        browser.eval("return document.body.innerText")
    );
    // On the map too: every rock (all have catalogue coordinates), standing; the placed
    // station drawn, the other listed only.
    let mapped = format!(
        "return {:?}.every(id => {{ const c = document.getElementById('map-rock-' + id); \
         return c !== null && c.dataset.display === 'standing'; }}) && \
         document.getElementById('map-station-CI.RRS.00') !== null && \
         document.getElementById('map-station-CI.SYL.00') === null && \
         document.getElementById('station-CI.SYL.00') !== null",
        ROCKS
    );
    assert!(
        browser.wait_for(&mapped, 10 * second).is_some(),
        "{}",
        browser.eval("return document.getElementById('map').outerHTML")
    );
    browser.screenshot(&shots.join("1-loaded.png"));

    // The record: the overturn appears in the feed within 2 s of the replay's end.
    let rec = repo().join("tests/data/records");
    let replay = std::process::Command::new(rockwatch_bin!())
        .args(["replay", "--record"])
        .arg(rec.join("Rinaldi228.AT2"))
        .arg("--vertical")
        .arg(rec.join("RinaldiUP.AT2"))
        .args([
            "--azimuth",
            "228",
            "--station",
            "CI.RRS.00",
            "--transport",
            "ros2",
            "--speed",
            "max",
            "--tail",
            "2",
            "--wait-s",
            "20",
        ])
        .output()
        .unwrap();
    assert!(replay.status.success(), "{}", text(&replay).1);
    let alerted = "return [...document.querySelectorAll('#feed li.overturned')]\
                   .some(li => li.dataset.pbr === 'rrs-slender-pillar')";
    let took = browser.wait_for(alerted, 2 * second);
    browser.screenshot(&shots.join("2-alert.png"));
    assert!(
        took.is_some(),
        "the overturn not in the feed 2 s after the replay\n{}\n{}",
        browser.eval("return document.body.innerText"),
        node.stderr_so_far()
    );
    // The pillar in its fallen colour (the page's .fallen, #f08080).
    let fallen = "const r = document.getElementById('rock-rrs-slender-pillar'); \
                  return r.dataset.display === 'fallen' && \
                  getComputedStyle(r.cells[2]).backgroundColor === 'rgb(240, 128, 128)'";
    assert!(
        browser.wait_for(fallen, 2 * second).is_some(),
        "{}",
        browser.eval("return document.body.innerText")
    );
    // On the map: the pillar in its fallen colour (#d02020), the others not.
    let fallen_on_map = "const c = document.getElementById('map-rock-rrs-slender-pillar'); \
                         return c.dataset.display === 'fallen' && \
                         getComputedStyle(c).fill === 'rgb(208, 32, 32)' && \
                         getComputedStyle(document.getElementById('map-rock-rrs-stocky-boulder')).fill \
                         !== 'rgb(208, 32, 32)'";
    assert!(
        browser.wait_for(fallen_on_map, 2 * second).is_some(),
        "{}",
        browser.eval("return document.getElementById('map').outerHTML")
    );
    // CI.RRS.00's trace drawn (the station first in the list, shown by default): the
    // record's ≈ 22 s in 0.2 s bins, and ink on the canvas.
    let drawn = "const c = document.getElementById('trace'); \
                 if (c.dataset.station !== 'CI.RRS.00' || !(Number(c.dataset.bins) >= 100)) return false; \
                 const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; \
                 let ink = 0; for (let i = 0; i < d.length; i += 4) \
                 if (d[i + 3] > 0 && d[i + 2] > d[i] + 40) ink++; return ink > 500";
    assert!(
        browser.wait_for(drawn, 5 * second).is_some(),
        "trace: {}",
        browser.eval("return JSON.stringify(document.getElementById('trace').dataset)")
    );
    // The pillar's episode: its θ/α and slide traces, with the three alert marks.
    browser.eval(
        "const s = document.getElementById('episode-rock'); s.value = 'rrs-slender-pillar'; \
         s.dispatchEvent(new Event('change')); return true",
    );
    let episode = "const c = document.getElementById('episode'); \
                   return c.dataset.rock === 'rrs-slender-pillar' && Number(c.dataset.points) > 3 && \
                   document.getElementById('episode-note').textContent.includes('overturned')";
    assert!(
        browser.wait_for(episode, 5 * second).is_some(),
        "episode: {}",
        browser.eval("return document.getElementById('episode-note').textContent")
    );
    browser.screenshot(&shots.join("3-fallen.png"));

    // No data for stale_after_s (5 s): both stations STALE, in the stale colour (#bbb).
    let stale = "return ['CI.RRS.00', 'CI.SYL.00'].every(id => { \
                 const s = document.getElementById('station-' + id); \
                 return s !== null && s.dataset.health === 'STALE' && \
                 getComputedStyle(s.cells[1]).backgroundColor === 'rgb(187, 187, 187)'; })";
    assert!(
        browser.wait_for(stale, 10 * second).is_some(),
        "{}",
        browser.eval("return document.body.innerText")
    );
    // On the map: CI.RRS.00 grey (#999) and labelled STALE.
    let stale_on_map = "const t = document.getElementById('map-station-CI.RRS.00'); \
                        return t.dataset.health === 'STALE' && getComputedStyle(t).fill === 'rgb(153, 153, 153)' && \
                        document.getElementById('map').textContent.includes('CI.RRS.00 STALE')";
    assert!(
        browser.wait_for(stale_on_map, 2 * second).is_some(),
        "{}",
        browser.eval("return document.getElementById('map').outerHTML")
    );
    browser.screenshot(&shots.join("4-stale.png"));

    browser.call("DELETE", "", None);
    let _ = driver.kill();
    let _ = driver.wait();
    let (status, stderr) = node.stop(std::time::Duration::from_secs(10));
    assert!(status.success(), "{stderr}");
    eprintln!("screenshots in {}", shots.display());
}

/// A small valid PNG (16 × 16, RGB, one stored deflate block): a pale square with a darker
/// border, so that the screenshot shows the tile grid. Built here (CRC-32, Adler-32) to need no
/// image crate.
fn tile_png() -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = 0xffff_ffffu32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 == 1 {
                    0xedb8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        out.extend((data.len() as u32).to_be_bytes());
        let start = out.len();
        out.extend(kind);
        out.extend(data);
        let crc = crc32(&out[start..]);
        out.extend(crc.to_be_bytes());
    }
    const N: usize = 16;
    let mut raw = Vec::new();
    for y in 0..N {
        raw.push(0); // filter: none
        for x in 0..N {
            let edge = x == 0 || y == 0;
            raw.extend(if edge {
                [150, 160, 175]
            } else {
                [228, 234, 240]
            });
        }
    }
    let (mut a, mut b) = (1u32, 0u32);
    for &v in &raw {
        a = (a + u32::from(v)) % 65521;
        b = (b + a) % 65521;
    }
    let mut z = vec![0x78, 0x01, 0x01];
    z.extend((raw.len() as u16).to_le_bytes());
    z.extend((!(raw.len() as u16)).to_le_bytes());
    z.extend(&raw);
    z.extend(((b << 16) | a).to_be_bytes());
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend((N as u32).to_be_bytes());
    ihdr.extend((N as u32).to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]); // 8 bits, RGB, deflate, no filter, no interlace
    chunk(&mut png, b"IHDR", &ihdr);
    chunk(&mut png, b"IDAT", &z);
    chunk(&mut png, b"IEND", &[]);
    png
}

/// A tile server on loopback: answers any path with [`tile_png`], except tiles whose column
/// plus row is odd (404: a tile that fails), and records every path requested.
fn tile_server() -> (u16, std::sync::Arc<std::sync::Mutex<Vec<String>>>) {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let paths = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let recorded = std::sync::Arc::clone(&paths);
    let png = tile_png();
    // One thread per connection: a browser may open a connection it sends nothing on.
    std::thread::spawn(move || {
        for stream in listener.incoming().flatten() {
            let (recorded, png) = (std::sync::Arc::clone(&recorded), png.clone());
            std::thread::spawn(move || serve_tile(stream, &recorded, &png));
        }
    });
    (port, paths)
}

/// Answers one request of [`tile_server`].
fn serve_tile(stream: std::net::TcpStream, recorded: &std::sync::Mutex<Vec<String>>, png: &[u8]) {
    use std::io::{BufRead, Write};
    let mut reader = std::io::BufReader::new(stream);
    let mut request = String::new();
    if reader.read_line(&mut request).is_err() || request.is_empty() {
        return;
    }
    let mut line = String::new();
    while reader.read_line(&mut line).is_ok_and(|n| n > 2) {
        line.clear();
    }
    let path = request.split_whitespace().nth(1).unwrap_or("").to_string();
    let odd = path
        .trim_end_matches(".png")
        .rsplit('/')
        .take(2)
        .map(|v| v.parse::<u64>().unwrap_or(0))
        .sum::<u64>()
        % 2
        == 1;
    recorded.lock().unwrap().push(path);
    let mut stream = reader.into_inner();
    let _ = if odd {
        stream
            .write_all(b"HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n")
    } else {
        write!(
            stream,
            "HTTP/1.1 200 OK\r\nContent-Type: image/png\r\nContent-Length: {}\r\n\
             Connection: close\r\n\r\n",
            png.len()
        )
        .and_then(|()| stream.write_all(png))
    };
}

/// Web Mercator (EPSG:3857) world pixel coordinates at zoom `z` (256-px tiles, the slippy-map
/// formulas: x = (λ + 180°)/360° · 256 · 2^z, y = (1 − ln(tan φ + sec φ)/π)/2 · 256 · 2^z).
fn slippy_px(lat_deg: f64, lon_deg: f64, z: u8) -> (f64, f64) {
    let n = 256.0 * f64::from(1u32 << z);
    let phi = lat_deg.to_radians();
    (
        (lon_deg + 180.0) / 360.0 * n,
        (1.0 - (phi.tan() + 1.0 / phi.cos()).ln() / std::f64::consts::PI) / 2.0 * n,
    )
}

/// With `[web] tiles` (a tile server on loopback started by the test) the map draws the
/// slippy-map tiles of its view under the markers: the page requests exactly the tiles the
/// test computes from the slippy-map formulas for the catalogue's rocks and the placed
/// station (zoom: the largest ≤ 18 at which their extent fits the 640 × 360 map less 40 px
/// each side; centred on the extent, whole pixels); a rock's marker sits at its Web Mercator
/// position within its tile (±1.5 px); the tiles that fail (404) leave the markers drawn and
/// are counted under the map beside the attribution; the page's CSP allows images from the
/// tile server's origin only. Screenshot `5-tiles.png`.
#[test]
fn the_map_draws_slippy_map_tiles_under_the_markers_at_their_web_mercator_positions() {
    if !have_browser() {
        return;
    }
    if !reexec_in_netns(
        "the_map_draws_slippy_map_tiles_under_the_markers_at_their_web_mercator_positions",
        120,
    ) {
        return;
    }
    let (port, requested) = tile_server();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let station = (34.2811, -118.4787);
    node_config(
        p,
        &format!(
            "[web]\nlisten = \"127.0.0.1:8080\"\n\
             tiles = \"http://127.0.0.1:{port}/tiles/{{z}}/{{x}}/{{y}}.png\"\n\
             tiles_attribution = \"test tiles\"\n\
             [[station]]\nid = \"CI.RRS.00\"\nlat = {}\nlon = {}\n",
            station.0, station.1
        ),
    );
    // The points of the map, from the catalogue read here (every rock has lat/lon) and the
    // station placed above (CI.SYL.00 has no position).
    let catalogue: toml::Value =
        toml::from_str(&std::fs::read_to_string(repo().join("config/catalogue.toml")).unwrap())
            .unwrap();
    let rocks: Vec<(String, f64, f64)> = catalogue["pbr"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            let f = |k: &str| r[k].as_float().unwrap();
            (r["id"].as_str().unwrap().to_string(), f("lat"), f("lon"))
        })
        .collect();
    assert_eq!(rocks.len(), ROCKS.len());
    let points: Vec<(f64, f64)> = rocks.iter().map(|r| (r.1, r.2)).chain([station]).collect();
    // The view: the largest zoom at which the extent fits 560 × 280 px.
    let extent = |z: u8| {
        let px: Vec<(f64, f64)> = points.iter().map(|&(a, o)| slippy_px(a, o, z)).collect();
        let (x0, x1) = px
            .iter()
            .fold((f64::MAX, f64::MIN), |m, q| (m.0.min(q.0), m.1.max(q.0)));
        let (y0, y1) = px
            .iter()
            .fold((f64::MAX, f64::MIN), |m, q| (m.0.min(q.1), m.1.max(q.1)));
        (x0, x1, y0, y1)
    };
    let z = (0..=18u8)
        .rev()
        .find(|&z| {
            let (x0, x1, y0, y1) = extent(z);
            x1 - x0 <= 560.0 && y1 - y0 <= 280.0
        })
        .unwrap();
    let (x0, x1, y0, y1) = extent(z);
    let (ox, oy) = (
        ((x0 + x1) / 2.0 - 320.0).round() as i64,
        ((y0 + y1) / 2.0 - 180.0).round() as i64,
    );
    let mut expected = std::collections::BTreeSet::new();
    for ty in oy.div_euclid(256)..=(oy + 359).div_euclid(256) {
        for tx in ox.div_euclid(256)..=(ox + 639).div_euclid(256) {
            expected.insert(format!("/tiles/{z}/{tx}/{ty}.png"));
        }
    }
    let failing = expected
        .iter()
        .filter(|t| {
            let v: Vec<u64> = t
                .trim_end_matches(".png")
                .rsplit('/')
                .take(2)
                .map(|v| v.parse().unwrap())
                .collect();
            (v[0] + v[1]) % 2 == 1
        })
        .count();
    assert!(
        (2..=12).contains(&expected.len()) && failing >= 1,
        "zoom {z}: {expected:?}"
    );

    let node = LoggedChild::spawn(
        std::process::Command::new(rockwatch_bin!())
            .arg("node")
            .arg("--config")
            .arg(p.join("node.toml")),
    );
    let up = std::time::Instant::now();
    let page = loop {
        if let Ok(reply) = ureq::get(WEB).call() {
            break reply;
        }
        assert!(
            up.elapsed().as_secs() < 30,
            "no page\n{}",
            node.stderr_so_far()
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    };
    let csp = page
        .headers()
        .get("content-security-policy")
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_string();
    assert!(
        csp.ends_with(&format!("; img-src 'self' http://127.0.0.1:{port}")),
        "{csp}"
    );
    let (mut driver, browser) = Browser::start(up);
    let second = std::time::Duration::from_secs(1);
    browser.call("POST", "/url", Some(serde_json::json!({ "url": WEB })));
    // Every rock on the map (markers drawn whatever the tiles did), the failed tiles counted.
    let drawn = format!(
        "return {:?}.every(id => document.getElementById('map-rock-' + id) !== null) && \
         document.getElementById('map-attribution').dataset.failed === '{failing}'",
        ROCKS
    );
    let shown = browser.wait_for(&drawn, 10 * second);
    let got: std::collections::BTreeSet<String> =
        requested.lock().unwrap().iter().cloned().collect();
    assert!(
        shown.is_some(),
        "{}\nrequested {got:?}",
        browser.eval("return document.getElementById('map').outerHTML + document.getElementById('map-attribution').outerHTML")
    );
    // A moment for any request beyond the expected ones, then: exactly the view's tiles.
    std::thread::sleep(std::time::Duration::from_millis(500));
    let got: std::collections::BTreeSet<String> =
        requested.lock().unwrap().iter().cloned().collect();
    assert_eq!(got, expected, "zoom {z}, view origin {ox}, {oy}");
    let note = browser.eval("return document.getElementById('map-attribution').textContent");
    assert!(
        note.as_str()
            .is_some_and(|n| n.starts_with("map tiles: test tiles")),
        "{note}"
    );
    // Each rock's marker at its Web Mercator position within its tile (as rendered).
    for (id, lat, lon) in &rocks {
        let (x, y) = slippy_px(*lat, *lon, z);
        let (tx, ty) = ((x / 256.0).floor() as i64, (y / 256.0).floor() as i64);
        let at = browser.eval(&format!(
            "const c = document.getElementById('map-rock-{id}').getBoundingClientRect(); \
             const t = document.getElementById('map-tile-{z}-{tx}-{ty}').getBoundingClientRect(); \
             return [c.x + c.width / 2 - t.x, c.y + c.height / 2 - t.y]"
        ));
        let at: Vec<f64> = at
            .as_array()
            .unwrap_or_else(|| panic!("{id}: {at}"))
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let want = [x - tx as f64 * 256.0, y - ty as f64 * 256.0];
        assert!(
            (at[0] - want[0]).abs() <= 1.5 && (at[1] - want[1]).abs() <= 1.5,
            "{id}: at {at:?} in tile {z}/{tx}/{ty}, want {want:?}"
        );
    }
    let shots = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("web_dashboard");
    std::fs::create_dir_all(&shots).unwrap();
    browser.screenshot(&shots.join("5-tiles.png"));
    browser.call("DELETE", "", None);
    let _ = driver.kill();
    let _ = driver.wait();
    let (status, stderr) = node.stop(std::time::Duration::from_secs(10));
    assert!(status.success(), "{stderr}");
    eprintln!("screenshot in {}", shots.display());
}

/// `rockwatch status --node` against a running, token-protected node (issue 22 §2): exit 0
/// while every rock stands and no station is stale (its table lists both rocks); after the
/// Rinaldi record, exit 1 with the pillar fallen (direction 228°, P(overturn) 1, its
/// station's health as `/api/status` has it); once the pillar is reset and the station has
/// been silent for `engine.stale_after_s`, exit 1 again for the stale station alone. Without
/// the token (401), or with no node at the address: exit 2, with the reason.
#[test]
fn status_of_a_running_node_exits_0_then_1_for_a_fallen_rock_and_a_stale_station_and_2_on_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let d = p.display().to_string();
    let bin = rockwatch_bin!().display().to_string();
    let catalogue = p.join("catalogue.toml");
    let block = |id: &str, width_m: f64, height_m: f64, mu_s: f64, mu_k: f64| {
        format!(
            "[[pbr]]\nid = \"{id}\"\nname = \"{id}\"\nlat = 34.28\nlon = -118.48\n\
             station = \"CI.RRS.00\"\nazimuth_deg = 228.0\nwidth_m = {width_m:?}\n\
             height_m = {height_m:?}\nmu_s = {mu_s:?}\nmu_k = {mu_k:?}\nsource = \"test\"\n\n"
        )
    };
    std::fs::write(
        &catalogue,
        block("pillar", 0.30, 1.50, 0.70, 0.55) + &block("boulder", 2.0, 1.6, 0.9, 0.7),
    )
    .unwrap();
    std::fs::write(p.join("web.token"), "0123456789abcdef-test-token\n").unwrap();
    std::fs::write(
        p.join("node.toml"),
        format!(
            "catalogue = \"{}\"\nstate_dir = \"state\"\n[engine]\nstale_after_s = 10.0\n\
             [ros2]\ndiscovery_range = \"LOCALHOST\"\n[status]\ndiagnostics_period_s = 0.2\n\
             [web]\nlisten = \"127.0.0.1:8080\"\ntoken_file = \"web.token\"\n",
            catalogue.display()
        ),
    )
    .unwrap();
    let rec = repo().join("tests/data/records");
    let rec = rec.display();
    let status = |file: &str, extra: &str| {
        format!(
            "'{bin}' status --node {WEB} --token-file '{d}/web.token' --format json {extra} \
             > '{d}/{file}.json' 2> '{d}/{file}.err'; echo {file}=$?"
        )
    };
    let script = format!(
        "'{bin}' node --config '{d}/node.toml' 2> '{d}/node.err' & NODE=$!
         i=0; until curl -sf --max-time 2 -H 'Authorization: Bearer 0123456789abcdef-test-token' \
             '{WEB}/api/status' >/dev/null; do i=$((i+1)); [ $i -lt 300 ] || break; sleep 0.1; done
         {before}
         '{bin}' status --node {WEB} --token-file '{d}/web.token' > '{d}/table.txt'; echo TABLE=$?
         '{bin}' replay --record '{rec}/Rinaldi228.AT2' --vertical '{rec}/RinaldiUP.AT2' \
             --azimuth 228 --station CI.RRS.00 --transport ros2 --speed max --tail 5 --wait-s 20 >/dev/null
         sleep 1
         {fallen}
         '{bin}' reset --node --wait-s 20 --pbr pillar > /dev/null
         i=0; until curl -s -H 'Authorization: Bearer 0123456789abcdef-test-token' '{WEB}/api/status' \
             | grep -q '\"stale\":true'; do i=$((i+1)); [ $i -lt 300 ] || break; sleep 0.1; done
         {stale}
         '{bin}' status --node {WEB} 2> '{d}/no_token.err'; echo NO_TOKEN=$?
         '{bin}' status --node http://127.0.0.1:9 2> '{d}/nobody.err'; echo NOBODY=$?
         kill -TERM $NODE; wait $NODE; echo NODE_RC=$?",
        before = status("before", ""),
        fallen = status("fallen", ""),
        stale = status("stale", ""),
    );
    let out = run_in_netns(&script, 120, &[]);
    let read = |name: &str| std::fs::read_to_string(p.join(name)).unwrap_or_default();
    let (stdout, stderr) = text(&out);
    let context = format!(
        "--- stdout\n{stdout}\n--- stderr\n{stderr}\n--- node\n{}",
        tail(&read("node.err"), 4000)
    );
    assert!(
        out.status.success() && stdout.contains("NODE_RC=0"),
        "{context}"
    );
    let parsed = |name: &str| -> serde_json::Value {
        serde_json::from_str(&read(&format!("{name}.json")))
            .unwrap_or_else(|e| panic!("{name}: {e}: {}\n{context}", read(&format!("{name}.err"))))
    };
    let row = |v: &serde_json::Value, id: &str| -> serde_json::Value {
        v["rocks"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["pbr_id"] == id)
            .unwrap_or_else(|| panic!("no {id}: {v}"))
            .clone()
    };

    // Before any data: both rocks standing, no station stale.
    assert!(
        stdout.contains("before=0"),
        "{context}\n{}",
        read("before.json")
    );
    let before = parsed("before");
    assert_eq!(before["rocks"].as_array().unwrap().len(), 2, "{before}");
    assert_eq!(row(&before, "pillar")["state"], "standing");
    assert!(stdout.contains("TABLE=0"), "{context}");
    let table = read("table.txt");
    assert!(
        table.contains("pillar") && table.contains("boulder") && table.contains("CI.RRS.00"),
        "{table}"
    );
    assert!(table.contains("OK: none of 2 rocks fallen"), "{table}");

    // After the record: the pillar fallen.
    assert!(
        stdout.contains("fallen=1"),
        "{context}\n{}",
        read("fallen.json")
    );
    let fallen = parsed("fallen");
    assert_eq!(fallen["fallen"], serde_json::json!(["pillar"]), "{fallen}");
    assert_eq!(fallen["stale"], serde_json::json!([]), "{fallen}");
    let pillar = row(&fallen, "pillar");
    assert_eq!(pillar["state"], "fallen", "{pillar}");
    assert_eq!(pillar["direction_deg"], 228.0, "{pillar}");
    assert_eq!(pillar["overturn_probability"], 1.0, "{pillar}");
    assert!(
        pillar["peak_theta_over_alpha"].as_f64().unwrap() >= 1.0,
        "{pillar}"
    );
    let health = fallen["stations"][0]["health"]
        .as_str()
        .unwrap()
        .to_string();
    assert_eq!(pillar["station_health"], health.as_str(), "{fallen}");
    assert_ne!(health, "STALE", "{fallen}");

    // Reset, then silent: the station stale alone.
    assert!(
        stdout.contains("stale=1"),
        "{context}\n{}",
        read("stale.json")
    );
    let stale = parsed("stale");
    assert_eq!(stale["fallen"], serde_json::json!([]), "{stale}");
    assert_eq!(stale["stale"], serde_json::json!(["CI.RRS.00"]), "{stale}");
    assert_eq!(row(&stale, "pillar")["station_health"], "STALE", "{stale}");

    // Errors: 2 with the reason.
    assert!(stdout.contains("NO_TOKEN=2"), "{context}");
    assert!(
        read("no_token.err").contains("401"),
        "{}",
        read("no_token.err")
    );
    assert!(stdout.contains("NOBODY=2"), "{context}");
    assert!(
        read("nobody.err").contains("does not answer"),
        "{}",
        read("nobody.err")
    );
}

/// VmRSS of process `pid` (kB), from /proc/<pid>/status.
fn rss_kb(pid: u32) -> u64 {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .unwrap_or_default()
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or(0)
}

/// Clients that open `/api/events` and never read do not grow the node's memory: with 20 of
/// them connected while a node of 401 rocks streams its status (≈ 100 kB of JSON, 10 times a
/// second) and the Rinaldi record's alerts, the node's VmRSS stays within 24 MB of what it was
/// before they came (measured: +8.6 MB; the statuses streamed meanwhile, ≈ 22 MB, would stay in memory if a stalled client's queue were not bounded), each is dropped and counted
/// (`rockwatch_web_clients_dropped_total`), and the node goes on serving.
#[test]
fn stream_clients_that_never_read_are_dropped_and_do_not_grow_the_node() {
    if !reexec_in_netns(
        "stream_clients_that_never_read_are_dropped_and_do_not_grow_the_node",
        150,
    ) {
        return;
    }
    const STALLED: usize = 20;
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path();
    let mut catalogue = String::new();
    for i in 0..401 {
        // One slender pillar that the record throws over (the alerts), 400 stocky boulders.
        let (id, width, height) = match i {
            0 => ("rrs-slender-pillar".to_string(), 0.3, 1.5),
            _ => (format!("rrs-boulder-{i:04}"), 2.0, 1.6),
        };
        catalogue.push_str(&format!(
            "[[pbr]]\nid = \"{id}\"\nname = \"rock {i}\"\nlat = {}\nlon = -118.4765\n\
             station = \"CI.RRS.00\"\nazimuth_deg = 228.0\nwidth_m = {width}\nheight_m = {height}\n\
             mu_s = 0.7\nmu_k = 0.55\nsource = \"test\"\n\n",
            34.28 + i as f64 * 1e-5
        ));
    }
    std::fs::write(p.join("catalogue.toml"), catalogue).unwrap();
    std::fs::write(
        p.join("node.toml"),
        "catalogue = \"catalogue.toml\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n\
         [status]\ndiagnostics_period_s = 0.1\n[web]\nlisten = \"127.0.0.1:8080\"\n",
    )
    .unwrap();
    let node = LoggedChild::spawn(
        std::process::Command::new(rockwatch_bin!())
            .arg("node")
            .arg("--config")
            .arg(p.join("node.toml")),
    );
    let pid = node.child.id();
    let up = std::time::Instant::now();
    let status_len = loop {
        if let Ok(mut r) = ureq::get(&format!("{WEB}/api/status")).call() {
            break r.body_mut().read_to_string().unwrap_or_default().len();
        }
        assert!(
            up.elapsed().as_secs() < 60,
            "no status\n{}",
            node.stderr_so_far()
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    };
    assert!(status_len > 80_000, "a status of {status_len} bytes");
    std::thread::sleep(std::time::Duration::from_secs(1));
    let before = rss_kb(pid);
    let stalled: Vec<std::net::TcpStream> = (0..STALLED)
        .map(|_| {
            let mut s = std::net::TcpStream::connect("127.0.0.1:8080").unwrap();
            std::io::Write::write_all(&mut s, b"GET /api/events HTTP/1.1\r\nHost: x\r\n\r\n")
                .unwrap();
            s
        })
        .collect();
    let rec = repo().join("tests/data/records");
    let replay = std::process::Command::new(rockwatch_bin!())
        .args(["replay", "--record"])
        .arg(rec.join("Rinaldi228.AT2"))
        .args([
            "--azimuth",
            "228",
            "--station",
            "CI.RRS.00",
            "--transport",
            "ros2",
            "--speed",
            "1",
            "--wait-s",
            "20",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // 25 s: the record in real time (20 s) and more.
    let (mut peak, mut dropped) = (before, 0.0);
    let start = std::time::Instant::now();
    while start.elapsed().as_secs() < 25 {
        std::thread::sleep(std::time::Duration::from_millis(250));
        peak = peak.max(rss_kb(pid));
    }
    let mut replay = replay;
    let replayed = replay.wait().unwrap();
    if let Ok(mut r) = ureq::get(&format!("{WEB}/metrics")).call() {
        let text = r.body_mut().read_to_string().unwrap_or_default();
        let samples = parse_prometheus(&text).unwrap_or_default();
        dropped = samples
            .iter()
            .find(|s| s.0 == "rockwatch_web_clients_dropped_total")
            .map(|s| s.2)
            .unwrap_or(0.0);
    }
    let served = ureq::get(&format!("{WEB}/api/alerts"))
        .call()
        .ok()
        .and_then(|mut r| r.body_mut().read_to_string().ok())
        .unwrap_or_default();
    drop(stalled);
    let (status, stderr) = node.stop(std::time::Duration::from_secs(10));
    let grew_mb = (peak.saturating_sub(before)) as f64 / 1024.0;
    eprintln!(
        "status {status_len} B; VmRSS before {before} kB, peak {peak} kB (+{grew_mb:.1} MB); {dropped} stalled clients dropped"
    );
    assert!(status.success() && replayed.success(), "{stderr}");
    assert!(
        dropped >= STALLED as f64,
        "{dropped} of {STALLED} dropped\n{stderr}"
    );
    assert!(
        grew_mb < 24.0,
        "the node grew by {grew_mb:.1} MB with {STALLED} stalled clients"
    );
    assert!(
        served.contains("\"overturned\"") && served.contains("rrs-slender-pillar"),
        "the alerts were served meanwhile: {served}"
    );
}
