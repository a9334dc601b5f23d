//! `rockwatch node`: the live node. The node itself is `rockwatch::node::serve` (one event
//! loop for every transport, see src/node/serve.rs); this file parses the flags, handles
//! SIGINT/SIGTERM and prints the closing summary.

use std::path::PathBuf;

use rockwatch::journal::read_journal;
use rockwatch::node::{serve_supervised, NodeOptions, NoticeLog, Reloaded, Supervision};
use rockwatch::node_config::NodeConfig;
use rockwatch::notify::{Notifier, STOP_GRACE};
use rockwatch::ros2::{network_plan_from_env, ParamValues};
use rockwatch::sd_notify::SystemdNotifier;
use rockwatch::signals::node_signals;

/// Run the live node: subscribes `/pbr/accel` (and configured Imu topics) over ROS 2, runs
/// the monitoring engine, publishes `/pbr/ims`, `/pbr/state` and `/pbr/alerts`.
///
/// The node is `<namespace>/rockwatch`, its topics and service relative (`pbr/alerts` is
/// `/site_a/pbr/alerts` in the namespace `/site_a`); DDS domain `ROS_DOMAIN_ID`;
/// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` keeps it on loopback. It takes `--ros-args` as
/// every ROS 2 node does (`-r from:=to`, `-r __ns:=/x`, `-r __node:=n`, `-p name:=value`,
/// `--params-file FILE`, `--log-level LEVEL`). Alert thresholds (`alerts.*`) and
/// `state_interval_s` are ROS 2 parameters with descriptors (ranges), settable at run time.
/// The service `pbr/reset` (`pbr_msgs/srv/ResetPbr`) resets a fallen block (`rockwatch reset
/// --node`). Alerts also go to the configuration's `[[notify]]` receivers (a command, or a
/// webhook), at least once, kept in the state directory until acknowledged. SIGINT or SIGTERM
/// (taken on one thread, never on DDS's): stop intake, publish what remains, flush the state
/// directory, give the receivers up to 5 s to deliver what is queued, exit 0. SIGHUP reloads
/// the configuration and the catalogue between packets: blocks in both keep their state, new
/// ones start at rest, removed ones are dropped; a bad new configuration is refused with a log
/// line and the running one kept. Under systemd (`Type=notify`) it reports READY, pings the
/// watchdog (`WatchdogSec=`) while its event loop runs, and RELOADING/STOPPING. A DDS
/// participant found dead (its RustDDS threads ended, e.g. after SIGSTOP/SIGCONT) is reported
/// and rebuilt, the engine's state kept; if it cannot be rebuilt within 30 s the node exits 1.
/// Logs (--log-level, --log-format text|json, RUST_LOG) log every alert and station health
/// change; `engine.stale_after_s` (60 s) without data makes a station stale (its blocks'
/// /pbr/state not_monitored). Status on /diagnostics, records on /rosout, optional Prometheus
/// text on `[metrics] listen`.
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

/// A path as a parameter's text (empty: none).
fn path_text(path: Option<&PathBuf>) -> String {
    path.map(|p| p.display().to_string()).unwrap_or_default()
}

/// A parameter's text as a path (empty: none).
fn text_path(text: &str) -> Option<PathBuf> {
    (!text.is_empty()).then(|| PathBuf::from(text))
}

/// The node's options from its files and flags: the configuration file, `--catalogue` and
/// `--state-dir`, then the `--ros-args` naming rules and parameters (files, then `-p`) over
/// them. At start and at every reload (SIGHUP), so a reload reads what a restart would.
fn resolve_options(args: &NodeArgs) -> anyhow::Result<NodeOptions> {
    let mut config = match &args.config {
        Some(path) => NodeConfig::load(path)?,
        None => NodeConfig::default(),
    };
    super::apply_ros_naming(&mut config.ros2);
    let naming = config.ros2.naming()?;
    let mut params = ParamValues {
        engine: config.engine,
        catalogue: path_text(args.catalogue.as_ref().or(config.catalogue.as_ref())),
        state_dir: path_text(args.state_dir.as_ref().or(config.state_dir.as_ref())),
        use_sim_time: false,
    };
    params.apply_overrides(&super::ros_args().parameters_for(&naming.node_fqn())?)?;
    config.engine = params.engine;
    config.ros2.use_sim_time = params.use_sim_time;
    Ok(NodeOptions {
        config,
        catalogue: text_path(&params.catalogue),
        state_dir: text_path(&params.state_dir),
        shards: args.shards,
        notices: NoticeLog::RateLimited,
        reject_future: true,
    })
}

pub fn run(args: NodeArgs) -> anyhow::Result<()> {
    // First, before any thread starts: the signals go to one thread, never to DDS's.
    let signals = node_signals()?;
    let stop = signals.stop;
    let systemd = SystemdNotifier::from_env()?;
    let options = resolve_options(&args)?;
    let naming = options.config.ros2.naming()?;
    let plan = network_plan_from_env(&options.config.ros2, rockwatch::ros2::NODE_ENCLAVE)?;
    tracing::info!(
        "node {} on DDS domain {} ({}; {})",
        naming.node_fqn(),
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
    let partition = options
        .config
        .partitioning()
        .map_err(|e| anyhow::anyhow!("configuration: {e}"))?
        .map(|(partition, _)| partition);
    if let Some(warning) = plan.exposure_warning(&naming, partition)? {
        tracing::warn!("{warning}");
    }
    if plan.security.is_some() {
        // What a keystore of launch-scripts/keystore.sh leaves closed (docs/reliability.md).
        tracing::info!(
            "DDS Security: only enclaves whose permissions grant it may call the parameter \
             services of {} or read /diagnostics and /rosout; launch-scripts/keystore.sh \
             grants none (set parameters at start: --ros-args -p / --params-file)",
            naming.node_fqn()
        );
    }
    let state_dir = options.state_dir_path();
    if let Some(dir) = &state_dir {
        // Refused here, before DDS and the notifications start, if another node holds it or
        // `rockwatch monitor` wrote it (a rehearsal's alerts are not the node's history).
        rockwatch::journal::refuse_rehearsal_dir(dir)?;
        rockwatch::journal::check_state_dir_free(dir)?;
    }
    let journal = match &state_dir {
        Some(dir) => read_journal(dir)?.0,
        None => Vec::new(),
    };
    let mut notifier = Notifier::start(&options.config.notify, state_dir.as_deref(), &journal)?;
    // SIGHUP: the files again; what a reload cannot change is said, not silently ignored.
    let mut reload = || -> anyhow::Result<Reloaded> {
        let new = resolve_options(&args)?;
        let (old, now) = (&options.config, &new.config);
        let mut ignored = Vec::new();
        if old.ros2 != now.ros2 {
            ignored.push("[ros2]");
        }
        if old.iceoryx2 != now.iceoryx2 {
            ignored.push("[iceoryx2]");
        }
        if old.notify != now.notify {
            ignored.push("[[notify]]");
        }
        if old.status != now.status {
            ignored.push("[status]");
        }
        if old.metrics != now.metrics {
            ignored.push("[metrics]");
        }
        if old.web != now.web {
            ignored.push("[web]");
        }
        if options.state_dir != new.state_dir || old.state_dir != now.state_dir {
            ignored.push("state_dir");
        }
        // The partition fixes the node's input topic: a reload cannot move it.
        if old.partition != now.partition || old.partition_assign != now.partition_assign {
            anyhow::bail!(
                "a change of partition or [partition_assign] needs a restart (the input topic and the service's other nodes depend on it)"
            );
        }
        if !ignored.is_empty() {
            tracing::warn!(
                "reload: changes to {} take effect at the next restart",
                ignored.join(", ")
            );
        }
        let (blocks, foreign_blocks) = new.load_partitioned_blocks()?;
        Ok(Reloaded {
            engine: now.engine,
            stations: now.owned_stations().map_err(anyhow::Error::msg)?,
            blocks,
            foreign_blocks,
        })
    };
    let supervision = Supervision {
        reload_requested: Some(&signals.reload),
        reload: Some(&mut reload),
        systemd,
    };
    let report = serve_supervised(&options, &plan, &stop, &mut [&mut notifier], supervision)?;
    for r in notifier.shutdown(STOP_GRACE) {
        tracing::info!(
            receiver = r.name.as_str(),
            delivered = r.delivered,
            failed_attempts = r.failed_attempts,
            queue_overflows = r.overflows,
            spool_errors = r.spool_errors,
            undelivered = r.pending,
            "notify {}: {} delivered, {} failed attempts, {} queue overflows, {} spool errors, {} undelivered (kept for the next start)",
            r.name, r.delivered, r.failed_attempts, r.overflows, r.spool_errors, r.pending
        );
    }
    let fallen = report.summaries.iter().filter(|s| s.overturned).count();
    // The stop counters: in the message for a reader, and as fields for a log shipper
    // (--log-format json).
    tracing::info!(
        ros2_packets = report.ros2_packets,
        ros2_undecodable = report.ros2_decode_errors,
        ros2_rebuilds = report.ros2_rebuilds,
        ros2_redelivered = report.ros2_redelivered,
        blocks = report.summaries.len(),
        overturned = fallen,
        "stopped: {} packets received over ROS 2 ({} undecodable, {} participant rebuilds, {} redelivered and skipped), {} blocks, {} overturned",
        report.ros2_packets,
        report.ros2_decode_errors,
        report.ros2_rebuilds,
        report.ros2_redelivered,
        report.summaries.len(),
        fallen
    );
    let input = report.input;
    tracing::info!(
        packets = input.packets,
        rejected = input.rejected_packets,
        implausible = input.implausible_packets,
        future = input.future_packets,
        malformed_station = input.malformed_station_packets,
        unknown_station = input.unknown_station_packets,
        duplicate = input.duplicate_packets,
        late = input.late_packets,
        grid_rewinds = input.grid_rewinds,
        "engine input: {} packets, {} rejected as invalid ({} beyond the physical bound), {} stamped too far ahead (not processed), {} with a malformed station id, {} from unknown stations, {} duplicate, {} late, {} time-grid rewinds",
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
        // Refused at the wire (the rest is refused as on every transport: `engine input`).
        let rejected = iox.rejected_count_mismatch + iox.rejected_station + iox.rejected_structure;
        tracing::info!(
            iox_received = iox.received,
            iox_submitted = iox.submitted,
            iox_rejected = rejected,
            iox_sequence_gaps = iox.sequence_gaps,
            iox_dead_publishers_cleaned = iox.dead_nodes_cleaned,
            "iceoryx2: {} packets received, {} submitted, {} rejected, {} sequence gaps, {} dead publishers cleaned",
            iox.received,
            iox.submitted,
            rejected,
            iox.sequence_gaps,
            iox.dead_nodes_cleaned
        );
    }
    let stats = report.stats;
    if stats.journal_failures > 0 {
        tracing::warn!(
            journal_failed_writes = stats.journal_failures,
            journal_pending_alerts = stats.journal_pending_alerts,
            journal_backlog = stats.journal_backlog,
            journal_lost = stats.journal_dropped,
            "state directory: {} failed writes, {} alerts published before they could be journaled, {} records still not journaled, {} lost (backlog full)",
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
