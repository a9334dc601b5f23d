//! `rockwatch node`: the live node. Transports are thin adapters around
//! `rockwatch::node::NodeRuntime`: each one starts with a `Submitter` (input side) and gives
//! back a `Publisher` (output side); `serve` wires them. Adding a transport = starting it in
//! `serve` and pushing its publisher.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::Context;
use rockwatch::engine::PbrSummary;
use rockwatch::iox::{IoxAlertPublisher, IoxInput};
use rockwatch::node::{InputTotals, NodeOptions, NodeRuntime, Publication, Publisher};
use rockwatch::node_config::NodeConfig;
use rockwatch::ros2::{network_plan_from_env, NetworkPlan, Ros2Node};

/// Run the live node: subscribes `/pbr/accel` (and configured Imu topics) over ROS 2, runs
/// the monitoring engine, publishes `/pbr/ims`, `/pbr/state` and `/pbr/alerts`.
///
/// The node is `<namespace>/rockwatch`; DDS domain `ROS_DOMAIN_ID`;
/// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` keeps it on loopback. Alert thresholds
/// (`alerts.*`) and `state_interval_s` are ROS 2 parameters, settable at run time. SIGINT or
/// SIGTERM: stop intake, publish what remains, flush the state directory, exit 0.
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
    /// Engine worker threads (0: one per core).
    #[arg(long, default_value_t = 0, value_name = "N")]
    shards: usize,
}

/// What `serve` hands back at the end.
pub struct ServeReport {
    pub summaries: Vec<PbrSummary>,
    pub ros2_packets: u64,
    pub ros2_decode_errors: u64,
    /// What the engine made of the input of every transport.
    pub input: InputTotals,
    /// iceoryx2 intake, when that transport ran.
    pub iox: Option<rockwatch::iox::IoxInputStats>,
}

/// Runs the node until `stop` is set: starts the runtime and the transports, pumps the
/// engine's outputs to every publisher (`extra` ones too), then shuts down in order
/// (intake stopped, engine flushed, remaining outputs published, journal synced).
pub fn serve(
    options: &NodeOptions,
    plan: &NetworkPlan,
    stop: &AtomicBool,
    extra: &mut [&mut dyn Publisher],
) -> anyhow::Result<ServeReport> {
    let mut runtime = NodeRuntime::start(options)?;
    let submitter = runtime
        .submitter()
        .context("the engine stopped before the transports started")?;
    let config = &options.config;

    // ROS 2 transport.
    let (mut ros2, mut ros2_publisher) =
        Ros2Node::start(&config.ros2, plan, &config.engine, submitter.clone())?;
    // iceoryx2 transport, when the configuration names its iceoryx2 config file (every
    // process of a deployment must load the same one explicitly).
    let iox_stop = Arc::new(AtomicBool::new(false));
    let mut iox = match &config.iceoryx2.config_file {
        Some(_) => {
            let mut iox_config = config.iceoryx2.clone();
            iox_config.handle_signals = false; // this process handles SIGINT/SIGTERM itself
            let input = IoxInput::spawn(&iox_config, submitter.clone(), Arc::clone(&iox_stop))?;
            let publisher = IoxAlertPublisher::new(&iox_config)?;
            Some((input, publisher))
        }
        None => None,
    };

    let mut publishers: Vec<&mut dyn Publisher> = vec![&mut ros2_publisher];
    if let Some((_, publisher)) = &mut iox {
        publishers.push(publisher);
    }
    for p in extra.iter_mut() {
        publishers.push(&mut **p);
    }
    runtime.pump(&mut publishers, stop)?;

    ros2.stop_intake();
    iox_stop.store(true, Ordering::Relaxed);
    let (iox_input, mut iox_publisher) = match iox {
        Some((input, publisher)) => (Some(input), Some(publisher)),
        None => (None, None),
    };
    let mut publishers: Vec<&mut dyn Publisher> = vec![&mut ros2_publisher];
    if let Some(publisher) = &mut iox_publisher {
        publishers.push(publisher);
    }
    for p in extra.iter_mut() {
        publishers.push(&mut **p);
    }
    let iox_stats = match iox_input {
        Some(input) => Some(input.join()?),
        None => None,
    };
    let (summaries, input) = runtime.shutdown_with_totals(&mut |p: Publication| {
        for publisher in publishers.iter_mut() {
            if let Err(e) = publisher.publish(&p) {
                eprintln!("rockwatch: at shutdown: {e:#}");
            }
        }
    })?;
    Ok(ServeReport {
        summaries,
        input,
        ros2_packets: ros2.counters.packets.load(Ordering::Relaxed),
        ros2_decode_errors: ros2.counters.decode_errors.load(Ordering::Relaxed),
        iox: iox_stats,
    })
}

/// Sets the returned flag on SIGINT or SIGTERM.
pub fn stop_on_signals() -> anyhow::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .with_context(|| format!("cannot handle signal {signal}"))?;
    }
    Ok(stop)
}

pub fn run(args: NodeArgs) -> anyhow::Result<()> {
    let config = match &args.config {
        Some(path) => NodeConfig::load(path).map_err(anyhow::Error::msg)?,
        None => NodeConfig::default(),
    };
    let plan = network_plan_from_env(&config.ros2).map_err(anyhow::Error::msg)?;
    let options = NodeOptions {
        config,
        catalogue: args.catalogue,
        state_dir: args.state_dir,
        shards: args.shards,
    };
    let stop = stop_on_signals()?;
    eprintln!(
        "rockwatch: node {}/{} on DDS domain {} ({})",
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
        }
    );
    let report = serve(&options, &plan, &stop, &mut [])?;
    let fallen = report.summaries.iter().filter(|s| s.overturned).count();
    eprintln!(
        "rockwatch: stopped: {} packets received over ROS 2 ({} undecodable), {} blocks, {} overturned",
        report.ros2_packets,
        report.ros2_decode_errors,
        report.summaries.len(),
        fallen
    );
    let input = report.input;
    eprintln!(
        "rockwatch: engine input: {} packets, {} rejected as invalid, {} with a malformed station id, {} from unknown stations, {} duplicate, {} late",
        input.packets,
        input.rejected_packets,
        input.malformed_station_packets,
        input.unknown_station_packets,
        input.duplicate_packets,
        input.late_packets
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
    Ok(())
}
