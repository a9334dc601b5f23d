//! `rockwatch demo`: the README's first command. With no arguments it starts the live node
//! in-process with the bundled example catalogue on DDS restricted to loopback, replays the
//! bundled Rinaldi Receiving Station record of the 1994 Northridge earthquake (228° + UP,
//! PEER NGA RSN1063) through ROS 2 as station CI.RRS.00, prints each alert as it arrives on
//! a real ROS 2 subscription to `/pbr/alerts`, then a table of every block.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context};
use rockwatch::log_text::{printable, PBR_ID_CHARS};
use rockwatch::node::{NodeOptions, ServeReport};
use rockwatch::node_config::NodeConfig;
use rockwatch::ports::{PacketSink, Publication, Publisher};
use rockwatch::replay::{now_shift_ns, replay, Restamp, Speed, Traces};
use rockwatch::ros2::{
    msg, network_plan, NetworkPlan, Ros2AlertListener, Ros2Config, Ros2PacketSink,
};
use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::dynamics::Mode;
use rockwatch_core::engine::{AccelPacket, AlertLevel, StationId};
use rockwatch_core::record::parse_at2_text;

const HORIZONTAL_AT2: &str = include_str!("../../../../tests/data/records/Rinaldi228.AT2");
const VERTICAL_AT2: &str = include_str!("../../../../tests/data/records/RinaldiUP.AT2");
const CATALOGUE_TOML: &str = include_str!("../../../../config/catalogue.toml");
const NODE_TOML: &str = include_str!("../../../../config/node.toml");
const STATION: &str = "CI.RRS.00";
const AZIMUTH_DEG: f64 = 228.0;

/// Run the built-in demonstration: the live node, over ROS 2 on loopback, watching the
/// bundled example blocks while a bundled near-fault record is replayed (no arguments
/// needed; nothing leaves the host).
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Replay speed (× real time; "max" = as fast as the node takes packets).
    #[arg(long, default_value = "10", value_name = "N|max")]
    speed: Speed,
    /// Seconds of quiet replayed after the record (blocks may fall after the shaking).
    #[arg(long, default_value_t = 10.0, value_name = "S")]
    tail: f64,
    /// Also serve the web dashboard on HOST:PORT (loopback only; 127.0.0.1:8080 when given
    /// without a value) and keep the node serving it after the replay until Ctrl-C.
    #[arg(
        long,
        value_name = "HOST:PORT",
        num_args = 0..=1,
        default_missing_value = "127.0.0.1:8080"
    )]
    web: Option<String>,
}

/// Records each alert's node latency (arrival of the triggering packet → publication).
struct LatencyRecorder(Arc<Mutex<BTreeMap<(String, AlertLevel), i64>>>);

impl Publisher for LatencyRecorder {
    fn publish(&mut self, publication: &Publication) -> anyhow::Result<()> {
        if let Publication::Alert {
            alert, latency_ns, ..
        } = publication
        {
            self.0
                .lock()
                .map_err(|_| anyhow!("latency table poisoned"))?
                .insert((alert.pbr_id.to_string(), alert.level), *latency_ns);
        }
        Ok(())
    }
}

/// A scratch directory removed on drop.
struct ScratchDir(PathBuf);

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn bundled_traces() -> anyhow::Result<Traces> {
    let h = Path::new("bundled:Rinaldi228.AT2");
    let v = Path::new("bundled:RinaldiUP.AT2");
    let mut record = parse_at2_text(HORIZONTAL_AT2, h)?.into_record(h);
    record.vertical_mps2 = Some(
        parse_at2_text(VERTICAL_AT2, v)?
            .into_record(v)
            .horizontal_mps2,
    );
    Ok(Traces::from_record(
        &record,
        Azimuth::from_degrees(AZIMUTH_DEG)?,
    ))
}

/// The demonstration to run: the bundled configuration, catalogue and record, ready.
struct DemoPlan {
    /// Where the bundled configuration and catalogue are written for the node to load.
    scratch: ScratchDir,
    /// The node's settings (loopback-only ROS 2, no iceoryx2 configuration file).
    options: NodeOptions,
    network: NetworkPlan,
    /// The record as packets of station [`STATION`], then the quiet tail.
    packets: Vec<AccelPacket>,
    /// Length of the record (s).
    record_s: f64,
    tail_s: f64,
    speed: Speed,
    /// `--web`: the dashboard's address, and the flag SIGINT/SIGTERM sets (the node then
    /// serves until it is set).
    web: Option<(String, Arc<AtomicBool>)>,
}

/// What the demonstration saw.
struct DemoOutcome {
    /// Alerts received on `/pbr/alerts`, in order.
    received: Vec<msg::PbrAlert>,
    /// Node latency of each alert published (ns), by block and level.
    latencies: BTreeMap<(String, AlertLevel), i64>,
    /// The node's closing report.
    report: ServeReport,
}

pub fn run(args: DemoArgs) -> anyhow::Result<()> {
    // With --web the demo waits for Ctrl-C: signals taken on one thread, before any other.
    let interrupted = match &args.web {
        Some(_) => Some(rockwatch::signals::stop_on_signals()?),
        None => None,
    };
    let mut plan = parse(args)?;
    if let Some(interrupted) = interrupted {
        plan.web = plan
            .options
            .config
            .web
            .listen
            .clone()
            .map(|l| (l, interrupted));
    }
    print_header(&plan);
    let outcome = execute(plan)?;
    print_blocks(&outcome);
    Ok(())
}

/// Writes the bundled configuration and catalogue where the node can load them, and cuts
/// the bundled record into packets.
fn parse(args: DemoArgs) -> anyhow::Result<DemoPlan> {
    let scratch = ScratchDir(std::env::temp_dir().join(format!(
        "rockwatch-demo-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    )));
    let dir = &scratch.0;
    std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
    std::fs::write(dir.join("catalogue.toml"), CATALOGUE_TOML)?;
    std::fs::write(dir.join("node.toml"), NODE_TOML)?;
    let mut config = NodeConfig::load(&dir.join("node.toml"))?;
    // Loopback only, whatever ROS_AUTOMATIC_DISCOVERY_RANGE says; ROS_DOMAIN_ID is honoured.
    config.ros2 = Ros2Config::loopback_only();
    // --ros-args -r __ns:=/x runs the demo's node, replay and listener in that namespace.
    super::apply_ros_naming(&mut config.ros2);
    // ROS 2 only: the bundled node.toml names an iceoryx2 config file beside it, which the
    // demo does not ship, and the default iceoryx2 services could clash with a real node's.
    config.iceoryx2.config_file = None;
    // --web: the dashboard, loopback only (the demo has no token).
    config.web.listen = args.web.clone();
    config.web.validate().map_err(|e| anyhow!("--web: {e}"))?;
    let network = network_plan(
        &config.ros2,
        std::env::var("ROS_DOMAIN_ID").ok().as_deref(),
        None,
    )?;
    let options = NodeOptions {
        config,
        ..NodeOptions::default()
    };

    let station = StationId::parse(STATION)?;
    let traces = bundled_traces()?;
    traces
        .check_packets(100, args.tail)
        .map_err(anyhow::Error::msg)?;
    Ok(DemoPlan {
        scratch,
        options,
        network,
        packets: traces.packets(&station, 100, args.tail),
        record_s: traces.len() as f64 / traces.rate_hz,
        tail_s: args.tail,
        speed: args.speed,
        web: None,
    })
}

fn print_header(plan: &DemoPlan) {
    outln!(
        "rockwatch demo: Northridge 1994, Rinaldi Receiving Sta (228° + UP, PEER NGA RSN1063) as {STATION}, {:.1} s + {} s quiet at {} over ROS 2 (DDS domain {}, loopback only)",
        plan.record_s,
        plan.tail_s,
        match plan.speed {
            Speed::Max => "max speed".to_string(),
            Speed::Times(f) => format!("{f}× real time"),
        },
        plan.network.domain_id
    );
    if let Some((listen, _)) = &plan.web {
        outln!("dashboard: http://{listen}/");
    }
}

/// Runs the node and the replay on threads of their own, and prints each alert as it
/// arrives on a ROS 2 subscription to `/pbr/alerts`, until the replay is over and the node
/// has been quiet a while.
fn execute(plan: DemoPlan) -> anyhow::Result<DemoOutcome> {
    let DemoPlan {
        scratch,
        options,
        network,
        packets,
        speed,
        web,
        ..
    } = plan;
    let naming = options.config.ros2.naming()?;
    let mut listener = Ros2AlertListener::open(&network, &naming)?;
    let stop = Arc::new(AtomicBool::new(false));
    let latencies = Arc::new(Mutex::new(BTreeMap::new()));
    let node = {
        let (stop, latencies, network) =
            (Arc::clone(&stop), Arc::clone(&latencies), network.clone());
        std::thread::Builder::new()
            .name("demo-node".into())
            .spawn(move || {
                let mut recorder = LatencyRecorder(latencies);
                rockwatch::node::serve(&options, &network, &stop, &mut [&mut recorder])
            })?
    };
    // UTC time (ns) given to the record's first sample once the replay starts, so that alert
    // lines can say how far into the record they were raised.
    let record_origin_ns = Arc::new(AtomicI64::new(i64::MIN));
    let replayer = {
        let (network, stop) = (network.clone(), Arc::clone(&stop));
        let record_origin_ns = Arc::clone(&record_origin_ns);
        let mut packets = packets;
        std::thread::Builder::new()
            .name("demo-replay".into())
            .spawn(move || -> anyhow::Result<()> {
                let mut sink = Ros2PacketSink::open(&network, &naming)?;
                if !sink.wait_for_subscriber(Duration::from_secs(30))? {
                    stop.store(true, Ordering::Relaxed);
                    anyhow::bail!("the node did not subscribe to /pbr/accel within 30 s");
                }
                let origin_ns = restamp_to_now(&mut packets, speed);
                record_origin_ns.store(origin_ns, Ordering::Relaxed);
                replay(&packets, &mut sink, speed, Restamp::Original, 1)?;
                if !sink.finish(Duration::from_secs(30))? {
                    anyhow::bail!("the node did not acknowledge every packet within 30 s");
                }
                Ok(())
            })?
    };

    // Alerts as they arrive, until the replay is over and the node has been quiet a while.
    let started = Instant::now();
    let mut received: Vec<msg::PbrAlert> = Vec::new();
    let mut quiet_since: Option<Instant> = None;
    outln!(
        "{:>9}  {:<23} {:<22} {:<10} {:>6} {:>8} {:>9}",
        "record t",
        "alert",
        "block",
        "mode",
        "θ/α",
        "slide",
        "PGA"
    );
    loop {
        for alert in listener.recv(Duration::from_millis(200))? {
            print_alert(&alert, record_origin_ns.load(Ordering::Relaxed));
            received.push(alert);
            quiet_since = None;
        }
        if replayer.is_finished() || node.is_finished() {
            let since = *quiet_since.get_or_insert_with(Instant::now);
            if since.elapsed() > Duration::from_millis(1500) || node.is_finished() {
                break;
            }
        }
        if started.elapsed() > Duration::from_secs(600) {
            break;
        }
    }
    if let Some((listen, interrupted)) = &web {
        outln!(
            "replay over: the node keeps serving the dashboard on http://{listen}/ until Ctrl-C"
        );
        while !interrupted.load(Ordering::Relaxed) && !node.is_finished() {
            for alert in listener.recv(Duration::from_millis(200))? {
                print_alert(&alert, record_origin_ns.load(Ordering::Relaxed));
                received.push(alert);
            }
        }
    }
    let replay_result = replayer
        .join()
        .map_err(|_| anyhow!("the replay thread panicked"))?;
    stop.store(true, Ordering::Relaxed);
    let report = node
        .join()
        .map_err(|_| anyhow!("the node thread panicked"))??;
    replay_result?;
    // Alerts published while shutting down.
    received.extend(listener.recv(Duration::from_millis(300))?);

    let latencies = latencies
        .lock()
        .map_err(|_| anyhow!("latency table poisoned"))?
        .clone();
    drop(scratch); // the node has stopped: its configuration can go
    Ok(DemoOutcome {
        received,
        latencies,
        report,
    })
}

/// Shifts the packets' time stamps to the wall clock as `replay` does for `--restamp now`
/// ([`now_shift_ns`]: in the past as they are sent, when faster than real time); returns the
/// UTC time (ns) of the record's first sample.
fn restamp_to_now(packets: &mut [AccelPacket], speed: Speed) -> i64 {
    let now_ns = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
    let shift_ns = now_shift_ns(packets, speed, 1, now_ns);
    for p in packets.iter_mut() {
        p.start_time_ns += shift_ns;
    }
    packets.first().map_or(now_ns, |p| p.start_time_ns)
}

/// One alert as a line under the header printed by [`execute`]: the data time of the alert
/// in seconds into the record (from `record_origin_ns`, the UTC time of the record's first
/// sample), then what the alert says.
fn print_alert(alert: &msg::PbrAlert, record_origin_ns: i64) {
    let record_t = if record_origin_ns == i64::MIN {
        "?".to_string()
    } else {
        format!(
            "{:.2} s",
            (alert.header.stamp.to_nanos() - record_origin_ns) as f64 * 1e-9
        )
    };
    outln!(
        "{:>9}  ALERT {:<17} {:<22} {:<10} {:>+6.2} {:>+6.3} m {:>4.2} m/s²",
        record_t,
        msg::level_name(alert.level),
        printable(&alert.pbr_id, PBR_ID_CHARS),
        msg::mode_of_code(alert.mode).map_or("?", Mode::as_str),
        alert.theta_over_alpha,
        alert.slide,
        alert.pga
    );
}

/// The table of every block, and what went over ROS 2.
fn print_blocks(outcome: &DemoOutcome) {
    let DemoOutcome {
        received,
        latencies,
        report,
    } = outcome;
    outln!();
    outln!(
        "{:<24} {:<10} {:>9} {:>10} {:>10} {:>8}  {:<25} {:>10}",
        "block",
        "station",
        "max |θ|/α",
        "max slide",
        "overturned",
        "P(over)",
        "alerts",
        "latency"
    );
    for s in &report.summaries {
        let mine: Vec<&msg::PbrAlert> = received
            .iter()
            .filter(|a| s.pbr_id == a.pbr_id.as_str())
            .collect();
        let levels: Vec<&str> = mine
            .iter()
            .filter_map(|a| {
                msg::level_of_code(a.level).map(|l| match l {
                    AlertLevel::MotionOnset => "onset",
                    AlertLevel::OverturnImminent => "imminent",
                    AlertLevel::Overturned => "overturned",
                })
            })
            .collect();
        let latency = AlertLevel::ALL
            .iter()
            .rev()
            .find_map(|l| latencies.get(&(s.pbr_id.to_string(), *l)))
            .map_or("-".to_string(), |ns| format!("{:.3} ms", *ns as f64 * 1e-6));
        outln!(
            "{:<24} {:<10} {:>9.3} {:>8.4} m {:>10} {:>8.2}  {:<25} {:>10}",
            s.pbr_id,
            s.station,
            s.max_theta_over_alpha,
            s.max_slide_m,
            if s.overturned { "YES" } else { "no" },
            s.overturn_probability,
            if levels.is_empty() {
                "-".to_string()
            } else {
                levels.join(",")
            },
            latency
        );
    }
    outln!();
    outln!("record t:   data time of the alert, seconds into the record (the replay runs at the speed given)");
    outln!("θ/α:        rocking angle over the block's slenderness α, signed (+ clockwise about the +x corner); |θ/α| = 1 puts the centre of mass above the pivot");
    outln!("max |θ|/α:  largest |θ|/α reached; a fallen block shows (π/2)/α, where the integration stops");
    outln!("P(over):    fraction of the block's uncertainty ensemble that overturned (0 or 1 for a block without ensemble)");
    outln!("latency:    arrival of the triggering packet at the node → publication of its most severe alert");
    let silent: Vec<&str> = report
        .summaries
        .iter()
        .filter(|s| s.station != STATION)
        .map(|s| s.station.as_str())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    if !silent.is_empty() {
        outln!(
            "no data:    {} (in the bundled catalogue; the demo replays {STATION} only)",
            silent.join(", ")
        );
    }
    outln!();
    outln!(
        "{} packets received by the node over ROS 2, {} alerts received on {}.",
        report.ros2_packets,
        received.len(),
        rockwatch::ros2::ALERTS_TOPIC
    );
    outln!(
        "Next: `rockwatch monitor --config config/node.toml --station {STATION} --record tests/data/records/Rinaldi228.AT2 --azimuth {AZIMUTH_DEG}` runs a record through the same engine offline (your own: --record FILE.AT2 with its station and azimuth, or --mseed FILE); `rockwatch node --config config/node.toml` runs the node live (README: `rockwatch node`)."
    );
}
