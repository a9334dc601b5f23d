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

mod ros2_util;
use ros2_util::*;

const ROCKS: [&str; 7] = [
    "rrs-slender-pillar",
    "rrs-stocky-boulder",
    "rrs-sliding-slab",
    "rrs-pinnacle-ensemble",
    "syl-slender-tombstone",
    "syl-stocky-block",
    "syl-slide-rock-column",
];

/// The last `n` bytes of `text` (about: on a character boundary).
fn tail(text: &str, n: usize) -> &str {
    let mut start = text.len().saturating_sub(n);
    while !text.is_char_boundary(start) {
        start += 1;
    }
    &text[start..]
}

const WEB: &str = "http://127.0.0.1:8080";

fn node_config(dir: &std::path::Path, extra: &str) {
    std::fs::write(
        dir.join("node.toml"),
        format!(
            "catalogue = \"{}\"\nstate_dir = \"state\"\n[engine]\nstale_after_s = 2.0\n\
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
    let bin = rockwatch().display().to_string();
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
         {page}
         {web_metrics}
         curl -sf --max-time 5 http://127.0.0.1:9464/metrics > '{d}/metrics.txt'
         sleep 3
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
    let bin = rockwatch().display().to_string();
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
