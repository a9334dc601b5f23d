//! `rockwatch monitor`: the monitoring engine offline — a record cut into packets, then
//! `--tail` seconds of quiet, through the live node's runtime (`NodeRuntime`, one inline
//! shard: engine, journal, then report), as fast as it can.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{bail, Context as _};
use rockwatch::alert_json::alert_value;
use rockwatch::log_text::{printable, STATION_CHARS};
use rockwatch::node::{NodeOptions, NodeRuntime, NoticeLog};
use rockwatch::node_config::NodeConfig;
use rockwatch::ports::Publication;
use rockwatch::replay::{ChannelChoice, MseedCalibration, Traces};

use super::mseed_flags::MseedInputFlags;
use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::engine::{
    Alert, EngineCounters, PbrSpec, PbrSummary, StationCounters, StationId, StationIntensity,
    StreamCounters,
};
use rockwatch_core::inventory::Inventory;
use rockwatch_core::record::Record;

/// Run the monitoring engine over a record: "which of my rocks should have toppled?".
///
/// The record is cut into packets of `--packet-ms`, followed by `--tail` seconds of zero
/// acceleration (a live stream goes on after the shaking, and blocks often fall after it),
/// and run through the same engine as the live node. Alerts are printed as they are raised;
/// a summary of every block follows.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["record", "mseed"])))]
pub struct MonitorArgs {
    /// Node configuration (TOML): catalogue, stations, thresholds, state directory.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// PBR catalogue (TOML or CSV); overrides the configuration's.
    #[arg(long, value_name = "FILE")]
    catalogue: Option<PathBuf>,
    /// One horizontal component (AT2 in g, or CSV t,ax[,ay] in m/s²) whose direction is
    /// --azimuth.
    #[arg(long, value_name = "FILE")]
    record: Option<PathBuf>,
    /// Vertical component for --record (AT2 or CSV, same dt and length).
    #[arg(long, value_name = "FILE", requires = "record")]
    vertical: Option<PathBuf>,
    /// Direction of --record's component, degrees clockwise from north (90 = east).
    #[arg(long, default_value_t = 90.0, value_name = "DEG", requires = "record")]
    azimuth: f64,
    #[command(flatten)]
    mseed_input: MseedInputFlags,
    /// Station the data belong to (NET.STA.LOC).
    #[arg(long, value_name = "ID")]
    station: String,
    /// Packet length (ms).
    #[arg(long = "packet-ms", default_value_t = 100, value_name = "MS")]
    packet_ms: u32,
    /// Seconds of quiet appended after the record.
    #[arg(long, default_value_t = 10.0, value_name = "S")]
    tail: f64,
    /// State directory of this rehearsal: alerts are journaled there (and restored from it on
    /// the next run). Only this flag gives one: the configuration's `state_dir` is the node's
    /// and never written. DIR must be new, empty or an earlier `monitor`'s (marked by a file
    /// `rehearsal`, which `rockwatch node` refuses); a directory a node holds or held is
    /// refused.
    #[arg(long = "state-dir", value_name = "DIR")]
    state_dir: Option<PathBuf>,
    /// Output: a readable log and table, or JSON lines (one per alert, a summary last; the
    /// summary's `intensity` is the station's last intensity output, as the node publishes it
    /// on /pbr/ims: data_time_ns, pga_mps2, pgv_mps, pgd_m, cav_mps, arias_mps, …).
    #[arg(long, value_enum, default_value_t = MonitorFormat::Text)]
    format: MonitorFormat,
}

/// Output format of `rockwatch monitor`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MonitorFormat {
    Text,
    Jsonl,
}

/// Notices of each (station, kind) logged in text output; the rest are counted at the end.
const NOTICE_LINES: u64 = 3;

/// A monitoring run, its flags checked.
struct MonitorPlan {
    /// The node's settings: configuration, catalogue, state directory, one engine shard.
    options: NodeOptions,
    /// The catalogue's blocks, at least one bound to `station`.
    blocks: Vec<PbrSpec>,
    station: StationId,
    input: MonitorInput,
    packet_ms: u32,
    /// Seconds of quiet appended after the record.
    tail_s: f64,
    format: MonitorFormat,
}

/// Where the acceleration comes from.
enum MonitorInput {
    /// One horizontal component in direction `azimuth`,
    /// and optionally its vertical.
    Record {
        path: PathBuf,
        vertical: Option<PathBuf>,
        azimuth: Azimuth,
    },
    /// A MiniSEED file with the station's channels, and the station's inventory (if given).
    Mseed {
        path: PathBuf,
        inventory: Option<Inventory>,
        choice: ChannelChoice,
    },
}

/// What a monitoring run leaves once its alerts have been reported.
struct MonitorOutcome {
    /// Alerts journaled and reported.
    alerts: u64,
    /// Blocks of the monitored station only: the others received no data.
    summaries: Vec<PbrSummary>,
    engine: EngineCounters,
    /// Per station: its own and its stream's counters.
    stations: Vec<(String, StationCounters, StreamCounters)>,
    /// Notices per (station, kind).
    notice_counts: BTreeMap<(String, &'static str), u64>,
    /// The monitored station's last intensity output (what the node publishes on /pbr/ims).
    intensity: Option<StationIntensity>,
}

/// An alert line of `--format jsonl`: the shared alert schema (`rockwatch::alert_json`) plus
/// `t_s` (s since the record's start `t0_ns`) and `latency_us` (arrival → publication).
fn alert_line(a: &Alert, t0_ns: i64, latency_ns: i64) -> serde_json::Value {
    let mut v = alert_value(a);
    if let Some(o) = v.as_object_mut() {
        o.insert(
            "t_s".into(),
            ((a.data_time_ns - t0_ns) as f64 * 1e-9).into(),
        );
        o.insert("latency_us".into(), (latency_ns as f64 * 1e-3).into());
    }
    v
}

pub fn run(args: MonitorArgs) -> anyhow::Result<()> {
    let plan = parse(args)?;
    let format = plan.format;
    let station = plan.station.clone();
    let outcome = execute(plan)?;
    print_summary(&outcome, format);
    usable(&outcome, &station)
}

/// An error unless the engine integrated at least one sample of `station`: a run whose every
/// packet was rejected (non-finite, beyond the physical bound, …) did not do its job.
fn usable(outcome: &MonitorOutcome, station: &StationId) -> anyhow::Result<()> {
    let Some((_, own, _)) = outcome
        .stations
        .iter()
        .find(|(id, _, _)| id == station.as_str())
    else {
        bail!("station {station}: no data reached the engine");
    };
    if own.samples == 0 {
        bail!(
            "station {station}: nothing usable: {} of {} packets rejected as invalid (see the \
             notices above), no sample integrated",
            own.rejected_packets,
            own.packets + own.rejected_packets
        );
    }
    Ok(())
}

/// Checks the flags and loads the configuration and the catalogue.
fn parse(args: MonitorArgs) -> anyhow::Result<MonitorPlan> {
    let mut config = match &args.config {
        Some(path) => NodeConfig::load(path)?,
        None => NodeConfig::default(),
    };
    if !config.notify.is_empty() {
        eprintln!("rockwatch: note: [[notify]] receivers are used by `rockwatch node` only");
    }
    // The configuration's state directory is the node's: a rehearsal's alerts there would be
    // published again by the next node and leave its rocks fallen (issue 20 item 1).
    if let (Some(dir), None) = (config.state_dir.take(), &args.state_dir) {
        eprintln!(
            "rockwatch: note: the configuration's state_dir ({}) is the node's: monitor does \
             not write it (--state-dir DIR journals this run in a directory of its own)",
            dir.display()
        );
    }
    if let Some(dir) = &args.state_dir {
        rockwatch::journal::claim_rehearsal_dir(dir)?;
    }
    let options = NodeOptions {
        config,
        catalogue: args.catalogue,
        state_dir: args.state_dir,
        shards: 1,
        reject_future: false,
        notices: NoticeLog::Counted {
            lines: match args.format {
                MonitorFormat::Text => NOTICE_LINES,
                MonitorFormat::Jsonl => 0,
            },
        },
    };
    let blocks = options.load_blocks()?;
    let station = StationId::parse(&args.station).map_err(|e| anyhow::anyhow!("--station: {e}"))?;
    if !blocks.iter().any(|s| s.station == station) {
        bail!(
            "{}: no block is bound to station {station}",
            options.catalogue_path()?.display()
        );
    }
    let input = match (args.record, args.mseed_input.mseed.clone()) {
        (Some(path), _) => MonitorInput::Record {
            path,
            vertical: args.vertical,
            azimuth: Azimuth::from_degrees(args.azimuth)?,
        },
        (None, Some(path)) => MonitorInput::Mseed {
            path,
            inventory: args.mseed_input.inventory()?,
            choice: args.mseed_input.choice(),
        },
        (None, None) => bail!("give --record FILE or --mseed FILE"),
    };
    Ok(MonitorPlan {
        options,
        blocks,
        station,
        input,
        packet_ms: args.packet_ms,
        tail_s: args.tail,
        format: args.format,
    })
}

/// Reads the input as the station's traces.
fn read_traces(
    input: &MonitorInput,
    config: &NodeConfig,
    station: &StationId,
) -> anyhow::Result<Traces> {
    Ok(match input {
        MonitorInput::Record {
            path,
            vertical,
            azimuth,
        } => {
            let mut record = Record::read(path)?;
            if let Some(v) = vertical {
                record.attach_vertical(v)?;
            }
            Traces::from_record(&record, *azimuth)
        }
        MonitorInput::Mseed {
            path,
            inventory,
            choice,
        } => {
            let calibration = MseedCalibration::for_station(inventory.as_ref(), config, station)
                .map_err(anyhow::Error::msg)?;
            Traces::from_mseed_with(path, station, calibration, choice)?
        }
    })
}

/// Runs the node's runtime (one inline shard) over the input's packets, then the tail, as
/// fast as it goes: each alert is journaled (and synced) and then reported ([`print_alert`])
/// the moment the engine raises it.
fn execute(plan: MonitorPlan) -> anyhow::Result<MonitorOutcome> {
    let MonitorPlan {
        options,
        blocks,
        station,
        input,
        packet_ms,
        tail_s,
        format,
    } = plan;
    let traces = read_traces(&input, &options.config, &station)?;
    traces
        .check_packets(packet_ms, tail_s)
        .map_err(anyhow::Error::msg)?;
    let mut runtime = NodeRuntime::start_with_blocks(&options, blocks, Arc::new(|| {}))?;
    let mut intensity = None;
    let mut report = |publication: Publication| match publication {
        Publication::Alert {
            alert, latency_ns, ..
        } => print_alert(format, &alert, traces.start_ns, latency_ns),
        Publication::Intensity(i) if i.station == station.as_str() => intensity = Some(i),
        _ => {}
    };
    for packet in traces.packets(&station, packet_ms, tail_s) {
        runtime.submit(packet, &mut report);
    }
    let stopped = runtime.stop(&mut report);
    let unjournaled = stopped.stats.journal_backlog + stopped.stats.journal_dropped;
    if unjournaled > 0 {
        bail!(
            "{unjournaled} records (alerts, episode ends) could not be journaled: the state \
             directory failed ({} failed writes)",
            stopped.stats.journal_failures
        );
    }
    if let Some(reports) = &stopped.reports {
        let lost = reports.dropped.load(std::sync::atomic::Ordering::Relaxed)
            + reports.failed.load(std::sync::atomic::Ordering::Relaxed);
        if lost > 0 {
            eprintln!("rockwatch: warning: {lost} event reports not written (see above)");
        }
    }
    let engine = stopped.engines.first().context("the engine did not run")?;
    Ok(MonitorOutcome {
        alerts: stopped.stats.alerts,
        summaries: engine
            .summaries()
            .into_iter()
            .filter(|s| s.station == station.as_str())
            .collect(),
        engine: engine.counters(),
        stations: engine
            .station_counters()
            .map(|(id, own, stream)| (id.to_string(), own, stream))
            .collect(),
        notice_counts: stopped.notice_counts,
        intensity,
    })
}

/// One alert, as it is raised; `t0_ns`: start of the record.
fn print_alert(format: MonitorFormat, a: &Alert, t0_ns: i64, latency_ns: i64) {
    match format {
        MonitorFormat::Jsonl => outln!("{}", alert_line(a, t0_ns, latency_ns)),
        MonitorFormat::Text => outln!(
            "t = {:>8.3} s  {:<18} {:<28} mode {:<10} θ/α {:>7.3}  slide {:>8.4} m  P(overturn) {:.2}  PGA {:.2} m/s²  PGV {:.3} m/s  latency {:.0} µs",
            (a.data_time_ns - t0_ns) as f64 * 1e-9,
            a.level.as_str(),
            a.pbr_id,
            a.mode.as_str(),
            a.theta_over_alpha,
            a.slide_m,
            a.overturn_probability,
            a.pga_mps2,
            a.pgv_mps,
            latency_ns as f64 * 1e-3
        ),
    }
}

/// The closing summary: every block of the station, and (text) the notice counts.
fn print_summary(outcome: &MonitorOutcome, format: MonitorFormat) {
    match format {
        MonitorFormat::Jsonl => {
            let pbrs: Vec<_> = outcome
                .summaries
                .iter()
                .map(|s| {
                    serde_json::json!({
                        "pbr_id": s.pbr_id, "station": s.station,
                        "max_theta_over_alpha": s.max_theta_over_alpha, "max_slide_m": s.max_slide_m,
                        "overturned": s.overturned, "overturn_probability": s.overturn_probability,
                        "data_gap": s.data_gap, "directions": s.directions,
                    })
                })
                .collect();
            let stations: BTreeMap<&str, serde_json::Value> = outcome
                .stations
                .iter()
                .map(|(id, own, stream)| {
                    (
                        id.as_str(),
                        serde_json::json!({"station": own, "stream": stream}),
                    )
                })
                .collect();
            outln!(
                "{}",
                serde_json::json!({
                    "type": "summary", "pbrs": pbrs,
                    "counters": {"engine": outcome.engine, "stations": stations},
                    "intensity": outcome.intensity,
                })
            );
        }
        MonitorFormat::Text => {
            outln!("\n{} alerts. Blocks:", outcome.alerts);
            outln!(
                "{:<28} {:<11} {:>9} {:>11} {:>10} {:>13}",
                "pbr",
                "station",
                "max θ/α",
                "max slide",
                "overturned",
                "P(overturn)"
            );
            for s in &outcome.summaries {
                outln!(
                    "{:<28} {:<11} {:>9.3} {:>9.4} m {:>10} {:>13.2}{}",
                    s.pbr_id,
                    s.station,
                    s.max_theta_over_alpha,
                    s.max_slide_m,
                    if s.overturned { "yes" } else { "no" },
                    s.overturn_probability,
                    if s.data_gap { "  (data gap)" } else { "" }
                );
            }
            for ((station, kind), count) in &outcome.notice_counts {
                if *count > NOTICE_LINES {
                    eprintln!(
                        "rockwatch: {}: {kind}: {count} in all",
                        printable(station, STATION_CHARS)
                    );
                }
            }
        }
    }
}
