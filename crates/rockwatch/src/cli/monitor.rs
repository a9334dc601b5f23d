//! `rockwatch monitor`: the monitoring engine offline — a record cut into packets, then
//! `--tail` seconds of quiet, through the same engine as the live node, as fast as it can.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::bail;
use rockwatch::journal::Journal;
use rockwatch::node::NodeOptions;
use rockwatch::node_config::NodeConfig;
use rockwatch::replay::Traces;
use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::engine::{Alert, Engine, EngineConfig, JournalRecord, Output, StationId};
use rockwatch_core::record::mseed::format_time_ns;
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
    /// MiniSEED file with the station's channels (E/N/Z or 1/2/3; integer data need the
    /// station's gain in the configuration). Gaps inside the file are filled linearly.
    #[arg(long, value_name = "FILE")]
    mseed: Option<PathBuf>,
    /// Station the data belong to (NET.STA.LOC).
    #[arg(long, value_name = "ID")]
    station: String,
    /// Packet length (ms).
    #[arg(long = "packet-ms", default_value_t = 100, value_name = "MS")]
    packet_ms: u32,
    /// Seconds of quiet appended after the record.
    #[arg(long, default_value_t = 10.0, value_name = "S")]
    tail: f64,
    /// State directory: alerts are journaled there (and restored from it on the next run).
    #[arg(long = "state-dir", value_name = "DIR")]
    state_dir: Option<PathBuf>,
    /// Output: a readable log and table, or JSON lines (one per alert, a summary last).
    #[arg(long, value_enum, default_value_t = MonitorFormat::Text)]
    format: MonitorFormat,
}

/// Output format of `rockwatch monitor`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MonitorFormat {
    Text,
    Jsonl,
}

fn alert_json(a: &Alert, t0_ns: i64, latency_ns: i64) -> serde_json::Value {
    serde_json::json!({
        "type": "alert",
        "pbr_id": a.pbr_id,
        "station": a.station,
        "level": a.level.as_str(),
        "episode": a.episode,
        "mode": a.mode.as_str(),
        "theta_over_alpha": a.theta_over_alpha,
        "slide_m": a.slide_m,
        "overturn_probability": a.overturn_probability,
        "pga_mps2": a.pga_mps2,
        "pgv_mps": a.pgv_mps,
        "data_time": format_time_ns(a.data_time_ns),
        "data_time_ns": a.data_time_ns,
        "t_s": (a.data_time_ns - t0_ns) as f64 * 1e-9,
        "latency_us": latency_ns as f64 * 1e-3,
    })
}

pub fn run(args: MonitorArgs) -> anyhow::Result<()> {
    let config = match &args.config {
        Some(path) => NodeConfig::load(path).map_err(anyhow::Error::msg)?,
        None => NodeConfig::default(),
    };
    let options = NodeOptions {
        config,
        catalogue: args.catalogue.clone(),
        state_dir: args.state_dir.clone(),
        shards: 1,
    };
    let specs = options.load_blocks()?;
    let station = StationId::parse(&args.station).map_err(|e| anyhow::anyhow!("--station: {e}"))?;
    if !specs.iter().any(|s| s.station == station) {
        bail!(
            "{}: no block is bound to station {station}",
            options.catalogue_path()?.display()
        );
    }
    if args.packet_ms == 0 {
        bail!("--packet-ms must be at least 1");
    }
    if !(args.tail.is_finite() && (0.0..=rockwatch::replay::MAX_TAIL_S).contains(&args.tail)) {
        bail!("--tail must be 0 to 86400 s, got {}", args.tail);
    }
    let traces = match (&args.record, &args.mseed) {
        (Some(path), _) => {
            let mut record = Record::read(path)?;
            if let Some(v) = &args.vertical {
                record.attach_vertical(v)?;
            }
            Traces::from_record(&record, Azimuth::from_degrees(args.azimuth)?)
        }
        (None, Some(path)) => Traces::from_mseed(path, &station)?,
        (None, None) => bail!("give --record FILE or --mseed FILE"),
    };
    let engine_config: EngineConfig = options.config.engine;
    let mut engine = Engine::new(engine_config, options.config.stations.clone(), &specs)?;

    let mut journal = match options.open_state()? {
        Some((journal, records)) => {
            engine.restore(&records);
            Some(journal)
        }
        None => None,
    };

    let jsonl = args.format == MonitorFormat::Jsonl;
    let epoch = std::time::Instant::now();
    // Fault injection for the crash-safety tests: abort right after the N-th journal append,
    // before the alert is reported (the worst moment for a crash).
    let abort_after: Option<usize> = std::env::var("ROCKWATCH_FAULT_ABORT_AFTER_JOURNAL")
        .ok()
        .and_then(|v| v.parse().ok());
    let mut notices: BTreeMap<(String, &'static str), u64> = BTreeMap::new();
    let mut alerts = 0usize;
    let mut out = Vec::new();
    let mut handle = |out: &mut Vec<Output>, journal: &mut Option<Journal>| -> anyhow::Result<()> {
        for o in out.drain(..) {
            match o {
                Output::Alert(a) => {
                    // Processing latency: now (before journaling) minus the packet's arrival.
                    let latency_ns = epoch.elapsed().as_nanos() as i64 - a.arrival_ns;
                    // Journaled (and synced) before it is reported.
                    if let Some(j) = journal {
                        j.append(&JournalRecord::Alert(a.clone()))?;
                    }
                    alerts += 1;
                    if abort_after == Some(alerts) {
                        std::process::abort();
                    }
                    if jsonl {
                        outln!("{}", alert_json(&a, traces.start_ns, latency_ns));
                    } else {
                        outln!(
                            "t = {:>8.3} s  {:<18} {:<28} mode {:<10} θ/α {:>7.3}  slide {:>8.4} m  P(overturn) {:.2}  PGA {:.2} m/s²  PGV {:.3} m/s  latency {:.0} µs",
                            (a.data_time_ns - traces.start_ns) as f64 * 1e-9,
                            a.level.as_str(),
                            a.pbr_id,
                            a.mode.as_str(),
                            a.theta_over_alpha,
                            a.slide_m,
                            a.overturn_probability,
                            a.pga_mps2,
                            a.pgv_mps,
                            latency_ns as f64 * 1e-3
                        );
                    }
                }
                Output::EpisodeEnd { pbr_id, episode } => {
                    if let Some(j) = journal {
                        j.append(&JournalRecord::EpisodeEnd { pbr_id, episode })?;
                    }
                }
                Output::Notice(n) => {
                    let count = notices.entry((n.station.clone(), n.kind)).or_insert(0);
                    *count += 1;
                    if *count <= 3 && !jsonl {
                        eprintln!("rockwatch: {}: {}: {}", n.station, n.kind, n.message);
                    }
                }
                Output::State(_) | Output::Intensity(_) => {}
            }
        }
        Ok(())
    };
    for packet in traces.packets(&station, args.packet_ms, args.tail) {
        engine.process(packet, epoch.elapsed().as_nanos() as i64, &mut out);
        handle(&mut out, &mut journal)?;
    }
    engine.flush(epoch.elapsed().as_nanos() as i64, &mut out);
    handle(&mut out, &mut journal)?;

    // Blocks of the monitored station only: the others received no data.
    let summaries: Vec<_> = engine
        .summaries()
        .into_iter()
        .filter(|s| s.station == station.as_str())
        .collect();
    let counters: BTreeMap<String, serde_json::Value> = engine
        .station_counters()
        .map(|(id, own, stream)| {
            (
                id.to_string(),
                serde_json::json!({"station": own, "stream": stream}),
            )
        })
        .collect();
    if jsonl {
        let pbrs: Vec<_> = summaries
            .iter()
            .map(|s| {
                serde_json::json!({
                    "pbr_id": s.pbr_id, "station": s.station,
                    "max_theta_over_alpha": s.max_theta_over_alpha, "max_slide_m": s.max_slide_m,
                    "overturned": s.overturned, "overturn_probability": s.overturn_probability,
                    "data_gap": s.data_gap,
                })
            })
            .collect();
        outln!(
            "{}",
            serde_json::json!({
                "type": "summary", "pbrs": pbrs,
                "counters": {"engine": engine.counters(), "stations": counters},
            })
        );
    } else {
        outln!("\n{alerts} alerts. Blocks:");
        outln!(
            "{:<28} {:<11} {:>9} {:>11} {:>10} {:>13}",
            "pbr",
            "station",
            "max θ/α",
            "max slide",
            "overturned",
            "P(overturn)"
        );
        for s in &summaries {
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
        for ((station, kind), count) in &notices {
            if *count > 3 {
                eprintln!("rockwatch: {station}: {kind}: {count} in all");
            }
        }
    }
    Ok(())
}
