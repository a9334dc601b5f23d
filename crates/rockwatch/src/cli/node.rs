//! `rockwatch node`: the live node. The node itself is `rockwatch::node::serve` (one event
//! loop for every transport, see src/node/serve.rs); this file parses the flags, handles
//! SIGINT/SIGTERM and prints the closing summary.

use std::path::PathBuf;

use rockwatch::journal::read_journal;
use rockwatch::node::{serve, NodeOptions, NoticeLog};
use rockwatch::node_config::NodeConfig;
use rockwatch::notify::{Notifier, STOP_GRACE};
use rockwatch::ros2::network_plan_from_env;
use rockwatch::signals::stop_on_signals;

/// Run the live node: subscribes `/pbr/accel` (and configured Imu topics) over ROS 2, runs
/// the monitoring engine, publishes `/pbr/ims`, `/pbr/state` and `/pbr/alerts`.
///
/// The node is `<namespace>/rockwatch`; DDS domain `ROS_DOMAIN_ID`;
/// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` keeps it on loopback. Alert thresholds
/// (`alerts.*`) and `state_interval_s` are ROS 2 parameters, settable at run time. The
/// service `/pbr/reset` (`pbr_msgs/srv/ResetPbr`) resets a fallen block (`rockwatch reset
/// --node`). Alerts also go to the configuration's `[[notify]]` receivers (a command, or a
/// webhook), at least once, kept in the state directory until acknowledged. SIGINT, SIGTERM
/// or SIGHUP (taken on one thread, never on DDS's): stop intake, publish what remains, flush
/// the state directory, give the receivers up to 5 s to deliver what is queued, exit 0. A DDS
/// participant found dead (its RustDDS threads ended, e.g. after SIGSTOP/SIGCONT) is reported
/// and rebuilt, the engine's state kept; if it cannot be rebuilt within 30 s the node exits 1.
/// ROCKWATCH_LOG sets the log level of the libraries (default: their errors).
#[derive(Debug, clap::Args)]
pub struct NodeArgs {
    /// Node configuration (TOML, e.g. config/node.toml): catalogue, stations, thresholds,
    /// state directory, the [ros2] section.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// PBR catalogue (TOML or CSV); overrides the configuration's.
    #[arg(long, value_name = "FILE")]
    catalogue: Option<PathBuf>,
    /// State directory (alert journal); overrides the configuration's.
    #[arg(long = "state-dir", value_name = "DIR")]
    state_dir: Option<PathBuf>,
    /// Engine shards. 1 (the default) runs the engine on the node's event loop thread: no
    /// thread hand-off between a packet's arrival and its alert (lowest latency; one core
    /// keeps 1000 stations at 100 Hz in real time with a wide margin). N > 1 spreads stations
    /// over N worker threads for more throughput, adding two hand-offs (latency) per packet.
    /// 0: one per core. At most 256.
    #[arg(long, default_value_t = 1, value_name = "N")]
    shards: usize,
}

pub fn run(args: NodeArgs) -> anyhow::Result<()> {
    // First, before any thread starts: the stop signals go to one thread, never to DDS's.
    let stop = stop_on_signals()?;
    let config = match &args.config {
        Some(path) => NodeConfig::load(path)?,
        None => NodeConfig::default(),
    };
    let plan = network_plan_from_env(&config.ros2, rockwatch::ros2::NODE_ENCLAVE)?;
    let options = NodeOptions {
        config,
        catalogue: args.catalogue,
        state_dir: args.state_dir,
        shards: args.shards,
        notices: NoticeLog::RateLimited,
        reject_future: true,
    };
    eprintln!(
        "rockwatch: node {}/{} on DDS domain {} ({}; {})",
        options.config.ros2.namespace.trim_end_matches('/'),
        rockwatch::ros2::NODE_NAME,
        plan.domain_id,
        match &plan.only_networks {
            Some(n) => format!(
                "interfaces {}",
                n.iter()
                    .map(ToString::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            None => "all interfaces".into(),
        },
        match &plan.security {
            Some(s) => format!(
                "DDS Security enclave {} from {}",
                s.enclave,
                s.dir.display()
            ),
            None => "DDS Security off".into(),
        }
    );
    if let Some(warning) = plan.exposure_warning() {
        eprintln!("{warning}");
    }
    let state_dir = options
        .state_dir
        .clone()
        .or(options.config.state_dir.clone());
    let journal = match &state_dir {
        Some(dir) => read_journal(dir)?.0,
        None => Vec::new(),
    };
    let mut notifier = Notifier::start(&options.config.notify, state_dir.as_deref(), &journal)?;
    let report = serve(&options, &plan, &stop, &mut [&mut notifier])?;
    for r in notifier.shutdown(STOP_GRACE) {
        eprintln!(
            "rockwatch: notify {}: {} delivered, {} failed attempts, {} queue overflows, {} spool errors, {} undelivered (kept for the next start)",
            r.name, r.delivered, r.failed_attempts, r.overflows, r.spool_errors, r.pending
        );
    }
    let fallen = report.summaries.iter().filter(|s| s.overturned).count();
    eprintln!(
        "rockwatch: stopped: {} packets received over ROS 2 ({} undecodable, {} participant rebuilds, {} redelivered and skipped), {} blocks, {} overturned",
        report.ros2_packets,
        report.ros2_decode_errors,
        report.ros2_rebuilds,
        report.ros2_redelivered,
        report.summaries.len(),
        fallen
    );
    let input = report.input;
    eprintln!(
        "rockwatch: engine input: {} packets, {} rejected as invalid ({} beyond the physical bound), {} stamped too far ahead (not processed), {} with a malformed station id, {} from unknown stations, {} duplicate, {} late, {} time-grid rewinds",
        input.packets,
        input.rejected_packets,
        input.implausible_packets,
        input.future_packets,
        input.malformed_station_packets,
        input.unknown_station_packets,
        input.duplicate_packets,
        input.late_packets,
        input.grid_rewinds
    );
    if let Some(iox) = report.iox {
        eprintln!(
            "rockwatch: iceoryx2: {} packets received, {} submitted, {} rejected, {} sequence gaps, {} dead publishers cleaned",
            iox.received,
            iox.submitted,
            iox.rejected_count_mismatch + iox.rejected_station + iox.rejected_structure + iox.rejected_values,
            iox.sequence_gaps,
            iox.dead_nodes_cleaned
        );
    }
    let stats = report.stats;
    if stats.journal_failures > 0 {
        eprintln!(
            "rockwatch: state directory: {} failed writes, {} alerts published before they could be journaled, {} records still not journaled, {} lost (backlog full)",
            stats.journal_failures,
            stats.journal_pending_alerts,
            stats.journal_backlog,
            stats.journal_dropped
        );
    }
    if stats.journal_backlog + stats.journal_dropped > 0 {
        anyhow::bail!(
            "{} records (alerts, episode ends) could not be journaled: the state directory is still failing",
            stats.journal_backlog + stats.journal_dropped
        );
    }
    Ok(())
}
