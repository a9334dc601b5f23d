//! `rockwatch alerts` and `rockwatch reset`: the alert history of a state directory, and
//! the operator reset of a fallen block (in a state directory, or live through a running
//! node's ROS 2 service `/pbr/reset`).

use std::collections::HashSet;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context as _};
use rockwatch::alert_json::RecordJson;
use rockwatch::journal::{read_journal, Journal};
use rockwatch::log_text::printable;
use rockwatch::node_config::NodeConfig;
use rockwatch::ros2::{network_plan_from_env, Ros2ResetClient, RESET_SERVICE};
use rockwatch_core::engine::{Alert, AlertLevel, JournalRecord};
use rockwatch_core::record::mseed::format_time_ns;
use rockwatch_core::utc::parse_utc_ns;

use super::OutputFormat;

/// List the alert history kept in a state directory (alerts, episode ends, resets).
#[derive(Debug, clap::Args)]
pub struct AlertsArgs {
    /// State directory written by `rockwatch monitor` or the node.
    #[arg(long = "state-dir", value_name = "DIR")]
    state_dir: PathBuf,
    /// Only the records at or after this time (ISO 8601, e.g. 2024-05-01T12:00:00Z; no zone =
    /// UTC): alerts and episode ends by their data time, resets by the time they were made.
    /// Records journaled before rockwatch kept their time have none and are left out (counted
    /// on stderr).
    #[arg(long, value_name = "ISO_TIME")]
    since: Option<String>,
    /// Only the records of this block (its catalogue `id`); repeat for several.
    #[arg(long, value_name = "ID")]
    pbr: Vec<String>,
    /// Only the alerts at this level or a more severe one (motion_onset < overturn_imminent <
    /// overturned); episode ends and resets are kept.
    #[arg(long, value_name = "LEVEL", value_parser = parse_level)]
    level: Option<AlertLevel>,
    /// Output format: a table (times in ISO 8601 UTC), or one JSON array of records in the
    /// shared schema: `{"type": "alert", "pbr_id", "level", "episode", "data_time", …}`,
    /// `{"type": "episode_end", "pbr_id", "episode", "data_time", "data_time_ns"}`,
    /// `{"type": "reset", "pbr_id", "time", "time_ns"}`, `{"type": "published", "pbr_id",
    /// "episode", "level"}` (see README, "Alert JSON").
    #[arg(long, value_enum, default_value_t = OutputFormat::Text)]
    format: OutputFormat,
}

/// An alert level by its name.
fn parse_level(text: &str) -> Result<AlertLevel, String> {
    AlertLevel::ALL
        .into_iter()
        .find(|l| l.as_str() == text)
        .ok_or_else(|| {
            format!("{text:?} is not a level: motion_onset, overturn_imminent or overturned")
        })
}

/// Which journal records `alerts` lists.
struct RecordFilter {
    /// Records before this time (ns since the Unix epoch) are left out.
    since_ns: Option<i64>,
    /// Only these blocks (all when empty).
    pbrs: Vec<String>,
    /// Only alerts at this level or above.
    level: Option<AlertLevel>,
}

impl RecordFilter {
    fn from_args(args: &AlertsArgs) -> anyhow::Result<RecordFilter> {
        let since_ns = match &args.since {
            Some(text) => Some(
                parse_utc_ns(text)
                    .and_then(|t| i64::try_from(t).ok())
                    .with_context(|| format!("--since {text:?} is not an ISO 8601 time"))?,
            ),
            None => None,
        };
        Ok(RecordFilter {
            since_ns,
            pbrs: args.pbr.clone(),
            level: args.level,
        })
    }

    /// Whether a record of block `pbr_id` at `time_ns` (None: not known) passes the block and
    /// time filters.
    fn passes(&self, pbr_id: &str, time_ns: Option<i64>) -> bool {
        (self.pbrs.is_empty() || self.pbrs.iter().any(|p| p == pbr_id))
            && match (self.since_ns, time_ns) {
                (None, _) => true,
                (Some(since), Some(t)) => t >= since,
                (Some(_), None) => false,
            }
    }

    /// The records kept, in order, and how many were left out for having no time (with
    /// `--since`). A `published` marker is kept with its alert.
    fn apply<'a>(&self, records: &'a [JournalRecord]) -> (Vec<&'a JournalRecord>, usize) {
        let kept_alert = |a: &Alert| {
            self.passes(a.pbr_id.as_str(), Some(a.data_time_ns))
                && self.level.is_none_or(|l| a.level >= l)
        };
        let alerts: HashSet<(&str, u32, AlertLevel)> = records
            .iter()
            .filter_map(|r| match r {
                JournalRecord::Alert(a) if kept_alert(a) => {
                    Some((a.pbr_id.as_str(), a.episode, a.level))
                }
                _ => None,
            })
            .collect();
        let mut timeless = 0;
        let kept = records
            .iter()
            .filter(|r| match r {
                JournalRecord::Alert(a) => kept_alert(a),
                JournalRecord::Published {
                    pbr_id,
                    episode,
                    level,
                } => alerts.contains(&(pbr_id.as_str(), *episode, *level)),
                JournalRecord::EpisodeEnd {
                    pbr_id,
                    data_time_ns: time_ns,
                    ..
                }
                | JournalRecord::Reset { pbr_id, time_ns } => {
                    let kept = self.passes(pbr_id.as_str(), *time_ns);
                    if !kept && time_ns.is_none() && self.passes(pbr_id.as_str(), Some(i64::MAX)) {
                        timeless += 1;
                    }
                    kept
                }
            })
            .collect();
        (kept, timeless)
    }
}

/// Reset a fallen block: it stands again at rest and a new episode can raise alerts.
///
/// A block that overturned stays overturned (no further alerts) until an operator resets it.
/// Give exactly one of:
///
/// --node: reset it on the running node, now. Calls the node's ROS 2 service /pbr/reset
/// (pbr_msgs/srv/ResetPbr) from a participant of its own, on the DDS domain and interfaces
/// that ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE and --config's [ros2] section give (as
/// for `rockwatch replay`), waits up to --wait-s for the service and then for the response,
/// and prints the node's message. The node writes the reset to its state directory before
/// applying it, so a restart keeps it. A block that has not overturned is left alone (the
/// request succeeds: nothing to reset); an id not in the node's catalogue fails. Exits 1 with
/// a one-line reason when the node refuses, or no node answers in time.
///
/// --state-dir: append a reset record to a state directory's journal, for a node that is
/// not running (it applies the reset when it next starts). Do not use it on the state
/// directory of a running node: that node would not see the reset until it restarts.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("target").required(true).args(["state_dir", "node"])))]
pub struct ResetArgs {
    /// Id of the block to reset (its `id` in the catalogue).
    #[arg(long, value_name = "ID")]
    pbr: String,
    /// Reset offline: the state directory written by `rockwatch monitor` or a stopped node.
    #[arg(long = "state-dir", value_name = "DIR")]
    state_dir: Option<PathBuf>,
    /// Reset live: call the running node's ROS 2 service /pbr/reset.
    #[arg(long)]
    node: bool,
    /// With --node: node configuration whose [ros2] section (domain, discovery range,
    /// interfaces) to use.
    #[arg(long, value_name = "FILE", conflicts_with = "state_dir")]
    config: Option<PathBuf>,
    /// With --node: seconds to wait for the node's service, and then for its response.
    #[arg(
        long = "wait-s",
        default_value_t = 30.0,
        value_name = "S",
        conflicts_with = "state_dir"
    )]
    wait_s: f64,
}

pub fn run_alerts(args: AlertsArgs) -> anyhow::Result<()> {
    if !args.state_dir.is_dir() {
        bail!("{}: not a directory", args.state_dir.display());
    }
    let filter = RecordFilter::from_args(&args)?;
    let (records, report) = read_journal(&args.state_dir)?;
    if report.repaired() {
        eprintln!(
            "rockwatch: warning: {}: journal read with repairs: {report}",
            args.state_dir.display()
        );
    }
    let (records, timeless) = filter.apply(&records);
    if timeless > 0 {
        eprintln!(
            "rockwatch: note: {timeless} episode ends or resets journaled before rockwatch kept \
             their time are left out by --since"
        );
    }
    match args.format {
        OutputFormat::Json => {
            let records: Vec<RecordJson> = records.into_iter().map(RecordJson::from).collect();
            outln!("{}", serde_json::to_string_pretty(&records)?);
        }
        OutputFormat::Text => print_table(&records),
    }
    Ok(())
}

/// The records as a table; times in ISO 8601 UTC: an alert's and an episode end's data time,
/// a reset's wall-clock time (`-`: journaled before rockwatch kept it).
fn print_table(records: &[&JournalRecord]) {
    let time = |t: Option<i64>| t.map_or_else(|| "-".to_string(), format_time_ns);
    outln!(
        "{:<24} {:<12} {:>7} {:<18} {:<11} {:>8}  time (UTC)",
        "pbr",
        "station",
        "episode",
        "level",
        "mode",
        "θ/α",
    );
    for r in records {
        match r {
            JournalRecord::Alert(a) => outln!(
                "{:<24} {:<12} {:>7} {:<18} {:<11} {:>8.3}  {}",
                a.pbr_id,
                a.station,
                a.episode,
                a.level.as_str(),
                a.mode.as_str(),
                a.theta_over_alpha,
                format_time_ns(a.data_time_ns)
            ),
            JournalRecord::EpisodeEnd {
                pbr_id,
                episode,
                data_time_ns,
            } => outln!(
                "{pbr_id:<24} {:<12} {episode:>7} {:<18} {:<11} {:>8}  {}",
                "",
                "episode ended",
                "",
                "",
                time(*data_time_ns)
            ),
            JournalRecord::Reset { pbr_id, time_ns } => outln!(
                "{pbr_id:<24} {:<12} {:>7} {:<18} {:<11} {:>8}  {}",
                "",
                "",
                "reset by operator",
                "",
                "",
                time(*time_ns)
            ),
            // Bookkeeping of the node (see docs/reliability.md): in the JSON only.
            JournalRecord::Published { .. } => {}
        }
    }
}

pub fn run_reset(args: ResetArgs) -> anyhow::Result<()> {
    match &args.state_dir {
        Some(dir) => reset_offline(dir, &args.pbr),
        None => reset_live(&args),
    }
}

/// `--state-dir`: a reset record appended to the journal.
fn reset_offline(state_dir: &std::path::Path, pbr: &str) -> anyhow::Result<()> {
    if !state_dir.is_dir() {
        bail!("{}: not a directory", state_dir.display());
    }
    let (mut journal, records, _) = Journal::open(state_dir)?;
    let known = records
        .iter()
        .any(|r| matches!(r, JournalRecord::Alert(a) if a.pbr_id == pbr));
    if !known {
        bail!(
            "{}: no alert recorded for block {pbr:?}; nothing to reset",
            state_dir.display()
        );
    }
    journal.append(&JournalRecord::Reset {
        pbr_id: rockwatch_core::engine::PbrId::parse(pbr)?,
        time_ns: Some(rockwatch::journal::utc_now_ns()),
    })?;
    outln!("block {pbr} reset in {}", state_dir.display());
    Ok(())
}

/// `--node`: the running node's `/pbr/reset` service.
fn reset_live(args: &ResetArgs) -> anyhow::Result<()> {
    if !(args.wait_s.is_finite() && args.wait_s >= 0.0) {
        bail!("--wait-s must be ≥ 0, got {}", args.wait_s);
    }
    let wait = Duration::from_secs_f64(args.wait_s);
    let mut config = match &args.config {
        Some(path) => NodeConfig::load(path)?,
        None => NodeConfig::default(),
    };
    super::apply_ros_naming(&mut config.ros2);
    let plan = network_plan_from_env(&config.ros2, rockwatch::ros2::OPERATOR_ENCLAVE)?;
    let naming = config.ros2.naming()?;
    let mut client =
        Ros2ResetClient::open(&plan, &naming).context("cannot join the ROS 2 graph")?;
    if !client.wait_for_service(wait) {
        bail!(
            "no node offered {} within {} s (is `rockwatch node` running on the same domain and \
             network, in this namespace? give it with --ros-args -r __ns:=/NS or [ros2] namespace)",
            naming
                .for_node("rockwatch_reset")
                .resolve(RESET_SERVICE)
                .unwrap_or_else(|_| RESET_SERVICE.to_string()),
            args.wait_s
        );
    }
    let response = client.reset(&args.pbr, wait)?;
    // A peer's text, on one line (control characters escaped); its length is not bounded.
    let message = printable(response.message.trim_end(), usize::MAX);
    if !response.success {
        bail!("the node refused: {message}");
    }
    outln!("{message}");
    Ok(())
}
