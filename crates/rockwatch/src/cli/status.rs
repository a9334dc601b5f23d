//! `rockwatch status`: what stands now, for people and for a monitoring check. From a running
//! node's JSON API (`--node URL`: `GET /api/status`, `[web]`), or from a state directory
//! (`--state-dir DIR`: the journal, the node running or not). A table of every rock and every
//! station, or `--format json`; the exit code says whether all is well:
//! 0 every rock standing and every station live; 1 a rock fallen or a station stale;
//! 2 the status could not be read (node unreachable, refused, bad answer, no such directory,
//! usage error).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{bail, Context as _};
use rockwatch::journal::read_journal;
use rockwatch::log_text::printable;
use rockwatch::number_text::{json_number, short_number};
use rockwatch_core::catalogue::Catalogue;
use rockwatch_core::engine::{fallen_blocks, AlertLevel, JournalRecord};
use rockwatch_core::utc::format_utc_ns;
use serde_json::{json, Value};

use super::OutputFormat;

/// Exit code when a rock is fallen or a station stale.
pub const EXIT_ALARM: u8 = 1;
/// Exit code when the status could not be read.
pub const EXIT_ERROR: u8 = 2;

/// Longest answer read from the node (bytes): `/api/status` is about 300 B per rock, so
/// 256 MiB holds the 100 000-rock capacity case with room.
const MAX_ANSWER_BYTES: u64 = 256 << 20;

/// What stands now: every rock (state, direction, peak |θ|/α of its last episode,
/// P(overturn), its station's health) and every station, from a running node or a state
/// directory. Exit code 0: all standing and live; 1: a rock fallen or a station stale (a
/// monitoring check's alarm); 2: the status could not be read (node unreachable, HTTP error,
/// no such state directory, usage error).
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["node", "state_dir"])))]
pub struct StatusArgs {
    /// A running node's web API (`[web] listen`), e.g. http://127.0.0.1:8080: reads
    /// `/api/status`.
    #[arg(long, value_name = "URL")]
    node: Option<String>,
    /// The node's bearer token (`[web] token_file`), for a token-protected node.
    #[arg(long = "token-file", value_name = "FILE", requires = "node")]
    token_file: Option<PathBuf>,
    /// Seconds to wait for the node's answer.
    #[arg(long = "timeout-s", value_name = "S", default_value_t = 5.0)]
    timeout_s: f64,
    /// A state directory (of a node, or written by `monitor --state-dir`): the rocks of its
    /// journal, fallen or standing, with their last episode; stations have no health there.
    #[arg(long = "state-dir", value_name = "DIR")]
    state_dir: Option<PathBuf>,
    /// With --state-dir: list every rock of this catalogue (those without a record stand).
    #[arg(long, value_name = "FILE", requires = "state_dir")]
    catalogue: Option<PathBuf>,
    /// Output format: tables, or one JSON object (`rocks`, `stations`, `fallen`, `stale`,
    /// `exit_code`; SI units, angles in degrees as in the catalogue).
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
}

/// One rock's line.
#[derive(Debug, Clone, PartialEq, Default)]
struct RockRow {
    pbr_id: String,
    station: String,
    /// `standing`, `moving`, `fallen`, `not_monitored` (node); `standing`, `episode_open`,
    /// `fallen` (state directory).
    state: String,
    /// Direction of its last state or alert (degrees clockwise from north).
    direction_deg: Option<f64>,
    /// Largest |θ|/α of its current or last episode (from a state directory: of its alerts).
    peak_theta_over_alpha: Option<f64>,
    /// P(overturn) (ensemble fraction) of its last state or alert (a state directory: the
    /// largest of its last episode's alerts).
    overturn_probability: Option<f64>,
    /// Its last episode (state directory).
    episode: Option<u32>,
}

/// One station's line.
#[derive(Debug, Clone, PartialEq, Default)]
struct StationRow {
    id: String,
    /// `OK`, `WARN`, `ERROR`, `STALE`, `NO DATA YET`; `unknown` from a state directory.
    health: String,
    stale: bool,
    data_latency_s: Option<f64>,
    seconds_since_last_packet: Option<f64>,
    message: String,
}

/// What `status` reports.
#[derive(Debug, Clone, PartialEq, Default)]
struct Report {
    /// `node URL` or `state directory DIR`.
    source: String,
    /// UTC of the node's status (ns).
    stamp_ns: Option<i64>,
    rocks: Vec<RockRow>,
    stations: Vec<StationRow>,
}

impl Report {
    fn fallen(&self) -> Vec<&str> {
        self.rocks
            .iter()
            .filter(|r| r.state == "fallen")
            .map(|r| r.pbr_id.as_str())
            .collect()
    }

    fn stale(&self) -> Vec<&str> {
        self.stations
            .iter()
            .filter(|s| s.stale)
            .map(|s| s.id.as_str())
            .collect()
    }

    fn exit_code(&self) -> u8 {
        if self.fallen().is_empty() && self.stale().is_empty() {
            0
        } else {
            EXIT_ALARM
        }
    }

    /// The health of station `id`.
    fn health(&self, id: &str) -> &str {
        self.stations
            .iter()
            .find(|s| s.id == id)
            .map_or("unknown", |s| s.health.as_str())
    }

    fn json(&self) -> Value {
        let number = |x: Option<f64>| x.map_or(Value::Null, json_number);
        json!({
            "source": self.source,
            "stamp_ns": self.stamp_ns,
            "rocks": self.rocks.iter().map(|r| json!({
                "pbr_id": r.pbr_id,
                "station": r.station,
                "state": r.state,
                "direction_deg": number(r.direction_deg),
                "peak_theta_over_alpha": number(r.peak_theta_over_alpha),
                "overturn_probability": number(r.overturn_probability),
                "episode": r.episode,
                "station_health": self.health(&r.station),
            })).collect::<Vec<_>>(),
            "stations": self.stations.iter().map(|s| json!({
                "id": s.id,
                "health": s.health,
                "stale": s.stale,
                "data_latency_s": number(s.data_latency_s),
                "seconds_since_last_packet": number(s.seconds_since_last_packet),
                "message": s.message,
            })).collect::<Vec<_>>(),
            "fallen": self.fallen(),
            "stale": self.stale(),
            "exit_code": self.exit_code(),
        })
    }

    fn text(&self) -> String {
        let dash = |x: Option<f64>, unit: &str| x.map_or("-".into(), |v| short_number(v) + unit);
        let mut out = String::new();
        let at = self
            .stamp_ns
            .map(|t| format!(" at {}", format_utc_ns(i128::from(t))))
            .unwrap_or_default();
        out += &format!("status of {}{at}\n", self.source);
        out += &format!(
            "{:<24} {:<13} {:>9} {:>11} {:>11} {:<14} {}\n",
            "rock", "state", "direction", "peak |θ|/α", "P(overturn)", "station", "health"
        );
        for r in &self.rocks {
            out += &format!(
                "{:<24} {:<13} {:>9} {:>11} {:>11} {:<14} {}\n",
                printable(&r.pbr_id, 64),
                printable(&r.state, 16),
                dash(r.direction_deg, "°"),
                dash(r.peak_theta_over_alpha, ""),
                dash(r.overturn_probability, ""),
                printable(&r.station, 32),
                printable(self.health(&r.station), 16)
            );
        }
        out += &format!(
            "{:<14} {:<12} {:>10} {:>10}  {}\n",
            "station", "health", "latency", "silent", "message"
        );
        for s in &self.stations {
            out += &format!(
                "{:<14} {:<12} {:>10} {:>10}  {}\n",
                printable(&s.id, 32),
                printable(&s.health, 16),
                dash(s.data_latency_s, " s"),
                dash(s.seconds_since_last_packet, " s"),
                printable(&s.message, 200)
            );
        }
        // Ids come from the node's answer or a journal: printed escaped, as every cell.
        let ids = |ids: &[&str]| -> String {
            ids.iter()
                .map(|id| printable(id, 64))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let (fallen, stale) = (self.fallen(), self.stale());
        out += &if fallen.is_empty() && stale.is_empty() {
            format!(
                "OK: none of {} rocks fallen, none of {} stations stale\n",
                self.rocks.len(),
                self.stations.len()
            )
        } else {
            let mut parts = Vec::new();
            if !fallen.is_empty() {
                parts.push(format!("{} fallen ({})", fallen.len(), ids(&fallen)));
            }
            if !stale.is_empty() {
                parts.push(format!("{} stations stale ({})", stale.len(), ids(&stale)));
            }
            format!("ALARM: {}\n", parts.join("; "))
        };
        out
    }
}

/// Runs `status`: prints the report and returns its exit code (errors: one line, 2).
pub fn run(args: StatusArgs) -> ExitCode {
    match report(&args) {
        Ok(report) => {
            let text = match args.format {
                OutputFormat::Text => report.text(),
                OutputFormat::Json => format!("{}\n", report.json()),
            };
            outln!("{}", text.trim_end());
            ExitCode::from(report.exit_code())
        }
        Err(e) => {
            eprintln!("rockwatch: error: {e:#}");
            ExitCode::from(EXIT_ERROR)
        }
    }
}

fn report(args: &StatusArgs) -> anyhow::Result<Report> {
    match (&args.node, &args.state_dir) {
        (Some(url), _) => {
            let token = match &args.token_file {
                Some(file) => Some(rockwatch::web::config::load_token("--token-file", file)?),
                None => None,
            };
            if !(args.timeout_s.is_finite() && args.timeout_s > 0.0) {
                bail!("--timeout-s must be > 0, got {}", args.timeout_s);
            }
            let answer = fetch_status(url, token.as_deref(), args.timeout_s)?;
            from_api(url, &answer)
        }
        (None, Some(dir)) => from_state_dir(dir, args.catalogue.as_deref()),
        (None, None) => bail!("give --node URL or --state-dir DIR"),
    }
}

/// `GET <url>/api/status` (with the bearer token), its JSON.
fn fetch_status(url: &str, token: Option<&str>, timeout_s: f64) -> anyhow::Result<Value> {
    let base = url.trim_end_matches('/');
    if !(base.starts_with("http://") || base.starts_with("https://")) {
        bail!("--node {url:?}: give the node's web address, e.g. http://127.0.0.1:8080");
    }
    let endpoint = format!("{base}/api/status");
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .timeout_global(Some(
            Duration::try_from_secs_f64(timeout_s)
                .with_context(|| format!("--timeout-s {timeout_s}: not a duration"))?,
        ))
        .http_status_as_error(false)
        .user_agent(concat!("rockwatch/", env!("CARGO_PKG_VERSION")))
        .build()
        .into();
    let mut request = agent.get(&endpoint);
    if let Some(token) = token {
        request = request.header("Authorization", &format!("Bearer {token}"));
    }
    let mut response = request
        .call()
        .with_context(|| format!("{endpoint}: the node does not answer"))?;
    let status = response.status();
    let body = response
        .body_mut()
        .with_config()
        .limit(MAX_ANSWER_BYTES)
        .read_to_string()
        .with_context(|| format!("{endpoint}: cannot read the answer"))?;
    if !status.is_success() {
        let reason = serde_json::from_str::<Value>(&body)
            .ok()
            .and_then(|v| v["error"].as_str().map(|e| printable(e, 200)))
            .unwrap_or_else(|| printable(&body, 200));
        bail!("{endpoint}: HTTP {status}: {reason}");
    }
    serde_json::from_str(&body).with_context(|| format!("{endpoint}: the answer is not JSON"))
}

/// The report of a node's `/api/status` answer (fields: README, "Web dashboard").
fn from_api(url: &str, v: &Value) -> anyhow::Result<Report> {
    let (Some(rocks), Some(stations)) = (v["rocks"].as_array(), v["stations"].as_array()) else {
        bail!("{url}/api/status: no rocks and stations in the answer: is this a rockwatch node?");
    };
    let text = |x: &Value| x.as_str().unwrap_or_default().to_string();
    Ok(Report {
        source: format!("node {url}"),
        stamp_ns: v["stamp_ns"].as_i64(),
        rocks: rocks
            .iter()
            .map(|r| RockRow {
                pbr_id: text(&r["pbr_id"]),
                station: text(&r["station"]),
                state: text(&r["display"]),
                direction_deg: r["direction_deg"].as_f64(),
                peak_theta_over_alpha: r["peak_theta_over_alpha"].as_f64(),
                overturn_probability: r["overturn_probability"].as_f64(),
                episode: None,
            })
            .collect(),
        stations: stations
            .iter()
            .map(|s| StationRow {
                id: text(&s["id"]),
                health: text(&s["health"]),
                stale: s["stale"].as_bool().unwrap_or(false),
                data_latency_s: s["data_latency_s"].as_f64(),
                seconds_since_last_packet: s["seconds_since_last_packet"].as_f64(),
                message: text(&s["message"]),
            })
            .collect(),
    })
}

/// The report of a state directory's journal (and of `catalogue`'s rocks, standing unless
/// the journal says otherwise). Fallen: [`fallen_blocks`], the node's own reading. A rock's
/// last episode: the largest |θ|/α and P(overturn) of its alerts (a lower bound of the
/// peak: the journal keeps alerts, not states), the direction of the last; open until its
/// episode end. Stations: those of the rocks, health unknown (never stale).
fn from_state_dir(dir: &Path, catalogue: Option<&Path>) -> anyhow::Result<Report> {
    if !dir.is_dir() {
        bail!("--state-dir {}: no such directory", dir.display());
    }
    let (records, load) = read_journal(dir)?;
    for line in load.warnings(dir) {
        tracing::warn!("{line}");
    }
    let mut rocks: BTreeMap<String, RockRow> = BTreeMap::new();
    if let Some(path) = catalogue {
        for pbr in Catalogue::load(path)?.pbrs() {
            rocks.insert(
                pbr.id().to_string(),
                RockRow {
                    pbr_id: pbr.id().to_string(),
                    station: pbr.station().to_string(),
                    state: "standing".into(),
                    ..RockRow::default()
                },
            );
        }
    }
    for record in &records {
        match record {
            JournalRecord::Alert(a) => {
                let rock = rocks
                    .entry(a.pbr_id.to_string())
                    .or_insert_with(|| RockRow {
                        pbr_id: a.pbr_id.to_string(),
                        ..RockRow::default()
                    });
                rock.station = a.station.to_string();
                if rock.episode != Some(a.episode) {
                    rock.episode = Some(a.episode);
                    rock.peak_theta_over_alpha = None;
                    rock.overturn_probability = None;
                }
                let max = |old: Option<f64>, new: f64| {
                    Some(old.map_or(new, |o| o.max(new))).filter(|v| v.is_finite())
                };
                rock.peak_theta_over_alpha =
                    max(rock.peak_theta_over_alpha, a.theta_over_alpha.abs());
                rock.overturn_probability = max(rock.overturn_probability, a.overturn_probability);
                rock.direction_deg = Some(a.direction_deg).filter(|d| d.is_finite());
                rock.state = if a.level == AlertLevel::Overturned {
                    "fallen"
                } else {
                    "episode_open"
                }
                .into();
            }
            JournalRecord::EpisodeEnd {
                pbr_id, episode, ..
            } => {
                if let Some(rock) = rocks.get_mut(pbr_id.as_str()) {
                    if rock.episode == Some(*episode) && rock.state == "episode_open" {
                        rock.state = "standing".into();
                    }
                }
            }
            JournalRecord::Reset { pbr_id, .. } => {
                if let Some(rock) = rocks.get_mut(pbr_id.as_str()) {
                    rock.state = "standing".into();
                }
            }
            JournalRecord::Published { .. } => {}
        }
    }
    // The journal's own reading of who lies (the one policy), over the walk above.
    let fallen = fallen_blocks(&records);
    for rock in rocks.values_mut() {
        if fallen.contains(rock.pbr_id.as_str()) {
            rock.state = "fallen".into();
        } else if rock.state == "fallen" {
            rock.state = "standing".into();
        }
    }
    let mut stations: Vec<StationRow> = rocks
        .values()
        .map(|r| r.station.clone())
        .filter(|s| !s.is_empty())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .map(|id| StationRow {
            id,
            health: "unknown".into(),
            message: "a state directory keeps no station health".into(),
            ..StationRow::default()
        })
        .collect();
    stations.sort_by(|a, b| a.id.cmp(&b.id));
    Ok(Report {
        source: format!("state directory {}", dir.display()),
        stamp_ns: None,
        rocks: rocks.into_values().collect(),
        stations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_escapes_what_the_node_or_a_journal_says() {
        let r = Report {
            rocks: vec![RockRow {
                pbr_id: "a\u{1b}[2J".into(),
                station: "XX.A.00".into(),
                state: "fallen".into(),
                ..RockRow::default()
            }],
            stations: vec![StationRow {
                id: "XX.A.00".into(),
                health: "OK\u{1b}]0;x\u{7}".into(),
                ..StationRow::default()
            }],
            ..Report::default()
        };
        let text = r.text();
        assert!(
            !text.contains('\u{1b}') && !text.contains('\u{7}'),
            "{text:?}"
        );
        assert!(text.contains("ALARM: 1 fallen (a\\u{1b}[2J)"), "{text}");
    }

    #[test]
    fn the_exit_code_is_1_for_a_fallen_rock_or_a_stale_station_only() {
        let mut r = Report {
            rocks: vec![RockRow {
                pbr_id: "a".into(),
                station: "XX.A.00".into(),
                state: "moving".into(),
                ..RockRow::default()
            }],
            stations: vec![StationRow {
                id: "XX.A.00".into(),
                health: "WARN".into(),
                ..StationRow::default()
            }],
            ..Report::default()
        };
        assert_eq!(r.exit_code(), 0);
        assert!(
            r.text().contains("OK: none of 1 rocks fallen"),
            "{}",
            r.text()
        );
        r.stations[0].stale = true;
        assert_eq!(r.exit_code(), EXIT_ALARM);
        r.stations[0].stale = false;
        r.rocks[0].state = "fallen".into();
        assert_eq!(r.exit_code(), EXIT_ALARM);
        assert!(r.text().contains("ALARM: 1 fallen (a)"), "{}", r.text());
        assert_eq!(r.json()["fallen"], json!(["a"]));
        assert_eq!(r.json()["rocks"][0]["station_health"], "WARN");
    }
}
