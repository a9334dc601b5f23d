//! `rockwatch replay`: feeds a recorded earthquake or a synthetic pulse to a running node as
//! a live station would, through ROS 2 (or iceoryx2).

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context};
use rockwatch::iox::IoxPacketSink;
use rockwatch::node_config::NodeConfig;
use rockwatch::ports::PacketSink;
use rockwatch::replay::{replay, MseedCalibration, Restamp, Speed, Traces};
use rockwatch::ros2::{network_plan_from_env, Ros2PacketSink};
use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::engine::StationId;
use rockwatch_core::pulse::{sample_pulses, PulseScenario};
use rockwatch_core::record::Record;

use super::mseed_flags::MseedInputFlags;

/// Transport of the replay.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Transport {
    /// ROS 2 (DDS): publishes pbr_msgs/AccelPacket on /pbr/accel.
    Ros2,
    /// iceoryx2 (zero-copy, same host): the `pbr/accel` service.
    Iceoryx2,
}

/// Time stamps of the replayed packets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RestampArg {
    /// Stamped to the wall clock (UTC): at --speed 1 or slower the first sample is "now" and
    /// later ones follow at the data rate; faster, the stream ends "now" (a live node rejects
    /// data stamped ahead of its clock).
    Now,
    /// As in the record (AT2/CSV records start at the Unix epoch).
    Original,
}

/// Replay a record (or a synthetic near-fault pulse) to a running node, as live packets.
///
/// Packets of `--packet-ms` are paced by a monotonic clock at `--speed` (no drift), followed
/// by `--tail` seconds of zero acceleration. The replay waits (up to --wait-s) for the node's
/// subscription before the first packet, then prints what it sent.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["record", "mseed", "synthetic"])))]
pub struct ReplayArgs {
    /// One horizontal component (AT2 in g, or CSV t,ax[,ay] in m/s²) whose direction is
    /// --azimuth.
    #[arg(long, value_name = "FILE")]
    record: Option<PathBuf>,
    /// Vertical component for --record (AT2 or CSV, same dt and length).
    #[arg(long, value_name = "FILE", requires = "record")]
    vertical: Option<PathBuf>,
    #[command(flatten)]
    mseed_input: MseedInputFlags,
    /// A synthetic Mavroeidis–Papageorgiou pulse drawn for --mw and --r-km with --seed.
    #[arg(long, requires_all = ["mw", "r_km"])]
    synthetic: bool,
    /// Moment magnitude of the synthetic pulse's scenario.
    #[arg(long, value_name = "MW")]
    mw: Option<f64>,
    /// Distance to the rupture (km) of the synthetic pulse's scenario.
    #[arg(long = "r-km", value_name = "KM")]
    r_km: Option<f64>,
    /// Seed of the synthetic pulse draw.
    #[arg(long, default_value_t = 1, value_name = "S")]
    seed: u64,
    /// Station the packets are sent as (NET.STA.LOC).
    #[arg(long, value_name = "ID")]
    station: String,
    /// Direction of --record's (or the pulse's) component, degrees clockwise from north.
    #[arg(long, default_value_t = 90.0, value_name = "DEG")]
    azimuth: f64,
    /// Multiply every sample by this factor.
    #[arg(long, default_value_t = 1.0, value_name = "X")]
    scale: f64,
    /// Transport.
    #[arg(long, value_enum)]
    transport: Transport,
    /// Pace: 1 = real time, N = N × real time, max = as fast as the node takes them.
    #[arg(long, default_value = "1", value_name = "1|N|max")]
    speed: Speed,
    /// Packet length (ms).
    #[arg(long = "packet-ms", default_value_t = 100, value_name = "MS")]
    packet_ms: u32,
    /// Seconds of quiet (zero acceleration) sent after the record.
    #[arg(long, default_value_t = 10.0, value_name = "S")]
    tail: f64,
    /// Time stamps: now (live) or original.
    #[arg(long, value_enum, default_value_t = RestampArg::Now)]
    restamp: RestampArg,
    /// Send the record this many times as one continuous stream.
    #[arg(long = "loop", default_value_t = 1, value_name = "N")]
    loops: u32,
    /// Node configuration whose [ros2] section (namespace, domain, interfaces) or [iceoryx2]
    /// section (config file, service names) to use. With `partition = "i/N"` (a node of a
    /// scaled-out service), the packets go over ROS 2 to the station's partition's topic
    /// `/pbr/accel/p<j>of<N>` (the hash or `[partition_assign]`), whatever i.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Seconds to wait for the node's subscription before the first packet, and (ROS 2) for
    /// the node's /pbr/intake reports to move: a replay ends only once the node reports every
    /// packet taken, else it exits 1 naming how many were not processed.
    #[arg(long = "wait-s", default_value_t = 30.0, value_name = "S")]
    wait_s: f64,
}

/// The traces the arguments describe, scaled.
fn traces(args: &ReplayArgs, config: &NodeConfig, station: &StationId) -> anyhow::Result<Traces> {
    let mut traces = if let Some(path) = &args.record {
        let mut record = Record::read(path)?;
        if let Some(v) = &args.vertical {
            record.attach_vertical(v)?;
        }
        Traces::from_record(&record, Azimuth::from_degrees(args.azimuth)?)
    } else if let Some(path) = &args.mseed_input.mseed {
        let inventory = args.mseed_input.inventory()?;
        let calibration = MseedCalibration::for_station(inventory.as_ref(), config, station)
            .map_err(anyhow::Error::msg)?;
        Traces::from_mseed_with(path, station, calibration, &args.mseed_input.choice())?
    } else {
        let (Some(mw), Some(r_km)) = (args.mw, args.r_km) else {
            bail!("--synthetic needs --mw and --r-km");
        };
        let scenario = PulseScenario::new(mw, r_km)?;
        let pulse = sample_pulses(&scenario, 1, args.seed)?
            .first()
            .map(|p| p.pulse)
            .context("no pulse drawn")?;
        let record = pulse.to_record_padded(0.01, 2.0)?;
        outln!(
            "synthetic pulse: Mw {mw}, R {r_km} km, seed {}: Tp {:.2} s, Vp {:.3} m/s",
            args.seed,
            pulse.period_s(),
            pulse.peak_velocity_mps()
        );
        Traces::from_record(&record, Azimuth::from_degrees(args.azimuth)?)
    };
    if !(args.scale.is_finite()) {
        bail!("--scale must be finite, got {}", args.scale);
    }
    if args.scale != 1.0 {
        let s = args.scale;
        traces.east.iter_mut().for_each(|a| *a *= s);
        traces.north.iter_mut().for_each(|a| *a *= s);
        if let Some(up) = &mut traces.up {
            up.iter_mut().for_each(|a| *a *= s);
        }
    }
    Ok(traces)
}

/// Replays `args` through `sink` and prints what was sent.
pub fn replay_through(
    args: &ReplayArgs,
    config: &NodeConfig,
    sink: &mut dyn PacketSink,
) -> anyhow::Result<()> {
    let station = StationId::parse(&args.station)?;
    let traces = traces(args, config, &station)?;
    traces
        .check_packets(args.packet_ms, args.tail)
        .map_err(anyhow::Error::msg)?;
    let packets = traces.packets(&station, args.packet_ms, args.tail);
    if !(args.wait_s.is_finite() && args.wait_s >= 0.0) {
        bail!("--wait-s must be ≥ 0, got {}", args.wait_s);
    }
    if !sink.wait_for_subscriber(Duration::from_secs_f64(args.wait_s))? {
        bail!(
            "no node subscribed to the packets within {} s (is `rockwatch node` running on the same domain and network?)",
            args.wait_s
        );
    }
    let restamp = match args.restamp {
        RestampArg::Now => Restamp::Now,
        RestampArg::Original => Restamp::Original,
    };
    let report = replay(&packets, sink, args.speed, restamp, args.loops)?;
    if !sink.finish(Duration::from_secs_f64(args.wait_s))? {
        bail!(
            "sent {} packets, but the node did not acknowledge them all within {} s (is it overloaded or gone?)",
            report.packets,
            args.wait_s
        );
    }
    outln!(
        "replayed {} packets ({} samples, {:.2} s of data at {} Hz) as {} in {:.2} s wall, max lag {:.3} s",
        report.packets,
        report.samples,
        report.data_s,
        traces.rate_hz,
        station,
        report.wall_s,
        report.max_lag_s
    );
    Ok(())
}

/// With the node's configuration (`--config`) naming a catalogue, a station the node does not
/// know — neither in its `[[station]]` nor bound to a block of its catalogue — is refused
/// before anything is sent: the node would ignore every packet (`unknown_station`). Without
/// a catalogue nothing can be checked here.
fn check_station_known(args: &ReplayArgs, config: &NodeConfig) -> anyhow::Result<()> {
    let (Some(config_path), Some(catalogue)) = (&args.config, &config.catalogue) else {
        return Ok(());
    };
    let station = StationId::parse(&args.station)?;
    if config.stations.iter().any(|s| s.id == station) {
        return Ok(());
    }
    let pbrs = rockwatch_core::catalogue::Catalogue::load(catalogue)?;
    if pbrs.pbrs_for_station(station.as_str()).next().is_some() {
        return Ok(());
    }
    bail!(
        "station {station} is neither in the [[station]] of {} nor bound to a block of its catalogue {}: the node would ignore every packet (unknown station); give a station of its blocks with --station (or, if the node runs with another --catalogue, that catalogue's)",
        config_path.display(),
        catalogue.display()
    )
}

pub fn run(args: ReplayArgs) -> anyhow::Result<()> {
    // Refused before any transport is opened.
    rockwatch::replay::check_packet_flags(args.packet_ms, args.tail).map_err(anyhow::Error::msg)?;
    let mut config = match &args.config {
        Some(path) => NodeConfig::load(path)?,
        None => NodeConfig::default(),
    };
    super::apply_ros_naming(&mut config.ros2);
    check_station_known(&args, &config)?;
    match args.transport {
        Transport::Ros2 => {
            let plan = network_plan_from_env(&config.ros2, rockwatch::ros2::STATION_ENCLAVE)?;
            // A partitioned service's configuration: each station to its partition's topic.
            let map = config
                .partitioning()
                .map_err(anyhow::Error::msg)?
                .map(|(_, map)| map);
            let mut sink = Ros2PacketSink::open_partitioned(&plan, config.ros2.naming()?, map)?;
            if args.wait_s.is_finite() && args.wait_s >= 0.0 {
                sink.set_wait(Duration::from_secs_f64(args.wait_s));
            }
            replay_through(&args, &config, &mut sink)
        }
        Transport::Iceoryx2 => {
            if config.iceoryx2.config_file.is_none() {
                bail!(
                    "--transport iceoryx2 needs the iceoryx2 config file every process loads: \
                     give --config with an [iceoryx2] config_file (e.g. config/node.toml)"
                );
            }
            // An invalid --wait-s is refused by replay_through, before anything is sent.
            let wait = if args.wait_s.is_finite() && args.wait_s >= 0.0 {
                Duration::from_secs_f64(args.wait_s)
            } else {
                rockwatch::ros2::DEFAULT_INTAKE_WAIT
            };
            let mut sink = IoxPacketSink::confirmed(&config.iceoryx2, wait)?;
            replay_through(&args, &config, &mut sink)
        }
    }
}
