//! `rockwatch monitor`: the monitoring engine offline — a record cut into packets, then
//! `--tail` seconds of quiet, through the same engine as the live node, as fast as it can.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use rockwatch::catalogue::Catalogue;
use rockwatch::engine::{
    AccelPacket, Alert, Engine, EngineConfig, JournalRecord, Output, PbrSpec, StationId,
};
use rockwatch::journal::Journal;
use rockwatch::mseed::{format_time_ns, read_mseed, GapFill};
use rockwatch::node_config::NodeConfig;
use rockwatch::record::Record;

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

/// Three aligned components (m/s² or counts) with their timing.
struct Traces {
    start_ns: i64,
    rate_hz: f64,
    east: Vec<f64>,
    north: Vec<f64>,
    up: Option<Vec<f64>>,
}

fn traces_from_record(args: &MonitorArgs, path: &Path) -> anyhow::Result<Traces> {
    let mut record = Record::read(path)?;
    if let Some(v) = &args.vertical {
        record.attach_vertical(v)?;
    }
    if !args.azimuth.is_finite() {
        bail!(
            "--azimuth must be a finite number of degrees, got {}",
            args.azimuth
        );
    }
    let (s, c) = args.azimuth.to_radians().sin_cos();
    Ok(Traces {
        start_ns: 0,
        rate_hz: 1.0 / record.dt_s,
        east: record.horizontal_mps2.iter().map(|a| a * s).collect(),
        north: record.horizontal_mps2.iter().map(|a| a * c).collect(),
        up: record.vertical_mps2,
    })
}

fn traces_from_mseed(path: &Path, station: &StationId) -> anyhow::Result<Traces> {
    let file = read_mseed(path)?;
    let mine: Vec<_> = file
        .channels
        .iter()
        .filter(|c| format!("{}.{}.{}", c.net, c.sta, c.loc) == station.as_str())
        .collect();
    if mine.is_empty() {
        let ids: Vec<String> = file.channels.iter().map(|c| c.id()).collect();
        bail!(
            "{}: no channel of station {station} (channels: {})",
            path.display(),
            ids.join(", ")
        );
    }
    let pick = |codes: [char; 2]| mine.iter().find(|c| c.cha.ends_with(codes)).copied();
    let (east, north, up) = (pick(['E', '1']), pick(['N', '2']), pick(['Z', '3']));
    let Some(first) = east.or(north) else {
        bail!(
            "{}: station {station} has no horizontal channel (…E/…N or …1/…2)",
            path.display()
        );
    };
    let (start_ns, rate_hz) = (first.start_time_ns, first.sample_rate_hz);
    let samples = |c: Option<&rockwatch::mseed::Channel>| -> anyhow::Result<Option<Vec<f64>>> {
        let Some(c) = c else { return Ok(None) };
        if (c.sample_rate_hz - rate_hz).abs() > 1e-9 * rate_hz
            || (c.start_time_ns - start_ns).abs() as f64 > 0.5e9 / rate_hz
        {
            bail!(
                "{}: channel {} is not aligned with {} (rate or start time)",
                path.display(),
                c.id(),
                first.id()
            );
        }
        Ok(Some(c.contiguous_samples(GapFill::Linear)?))
    };
    let (e, n, u) = (samples(east)?, samples(north)?, samples(up)?);
    let len = [&e, &n, &u]
        .iter()
        .filter_map(|c| c.as_ref().map(Vec::len))
        .min()
        .unwrap_or(0);
    let cut = |v: Option<Vec<f64>>| {
        v.map(|mut v| {
            v.truncate(len);
            v
        })
    };
    Ok(Traces {
        start_ns,
        rate_hz,
        east: cut(e).unwrap_or_else(|| vec![0.0; len]),
        north: cut(n).unwrap_or_else(|| vec![0.0; len]),
        up: cut(u),
    })
}

/// Cuts traces (plus `tail_s` of zeros) into packets of `packet_ms`.
fn packets(station: &StationId, t: &Traces, packet_ms: u32, tail_s: f64) -> Vec<AccelPacket> {
    let per_packet = ((f64::from(packet_ms) * 1e-3 * t.rate_hz).round() as usize).max(1);
    let total = t.east.len() + (tail_s * t.rate_hz).round() as usize;
    let at = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(0.0) as f32;
    (0..total)
        .step_by(per_packet)
        .enumerate()
        .map(|(sequence, first)| {
            let range = first..(first + per_packet).min(total);
            AccelPacket {
                station: station.to_string(),
                start_time_ns: t.start_ns + (first as f64 * 1e9 / t.rate_hz).round() as i64,
                sample_rate_hz: t.rate_hz,
                sequence: sequence as u64,
                east: range.clone().map(|i| at(&t.east, i)).collect(),
                north: range.clone().map(|i| at(&t.north, i)).collect(),
                up: t
                    .up
                    .as_ref()
                    .map_or_else(Vec::new, |u| range.map(|i| at(u, i)).collect()),
            }
        })
        .collect()
}

fn alert_json(a: &Alert, t0_ns: i64) -> serde_json::Value {
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
    })
}

pub fn run(args: MonitorArgs) -> anyhow::Result<()> {
    let config = match &args.config {
        Some(path) => NodeConfig::load(path).map_err(anyhow::Error::msg)?,
        None => NodeConfig::default(),
    };
    let catalogue_path = args
        .catalogue
        .clone()
        .or(config.catalogue.clone())
        .context("no catalogue: give --catalogue FILE or a --config that names one")?;
    let catalogue = Catalogue::load(&catalogue_path)?;
    let specs = catalogue
        .pbrs()
        .iter()
        .map(PbrSpec::from_catalogue)
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| anyhow::anyhow!("{}: {e}", catalogue_path.display()))?;
    let station = StationId::parse(&args.station).map_err(|e| anyhow::anyhow!("--station: {e}"))?;
    if !specs.iter().any(|s| s.station == station) {
        bail!(
            "{}: no block is bound to station {station}",
            catalogue_path.display()
        );
    }
    if args.packet_ms == 0 {
        bail!("--packet-ms must be at least 1");
    }
    if !(args.tail.is_finite() && args.tail >= 0.0) {
        bail!("--tail must be a number of seconds ≥ 0, got {}", args.tail);
    }
    let traces = match (&args.record, &args.mseed) {
        (Some(path), _) => traces_from_record(&args, path)?,
        (None, Some(path)) => traces_from_mseed(path, &station)?,
        (None, None) => bail!("give --record FILE or --mseed FILE"),
    };
    let engine_config: EngineConfig = config.engine;
    let mut engine =
        Engine::new(engine_config, config.stations.clone(), &specs).map_err(anyhow::Error::msg)?;

    let state_dir = args.state_dir.clone().or(config.state_dir.clone());
    let mut journal = match &state_dir {
        Some(dir) => {
            let (journal, records, report) = Journal::open(dir)?;
            if !report.corrupt_lines.is_empty() || report.truncated_tail {
                eprintln!(
                    "rockwatch: warning: {}: journal repaired ({report:?})",
                    dir.display()
                );
            }
            engine.restore(&records);
            Some(journal)
        }
        None => None,
    };

    let jsonl = args.format == MonitorFormat::Jsonl;
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
                    // Journaled (and synced) before it is reported.
                    if let Some(j) = journal {
                        j.append(&JournalRecord::Alert(a.clone()))?;
                    }
                    alerts += 1;
                    if abort_after == Some(alerts) {
                        std::process::abort();
                    }
                    if jsonl {
                        println!("{}", alert_json(&a, traces.start_ns));
                    } else {
                        println!(
                            "t = {:>8.3} s  {:<18} {:<28} mode {:<10} θ/α {:>7.3}  slide {:>8.4} m  P(overturn) {:.2}  PGA {:.2} m/s²  PGV {:.3} m/s",
                            (a.data_time_ns - traces.start_ns) as f64 * 1e-9,
                            a.level.as_str(),
                            a.pbr_id,
                            a.mode.as_str(),
                            a.theta_over_alpha,
                            a.slide_m,
                            a.overturn_probability,
                            a.pga_mps2,
                            a.pgv_mps
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
    for packet in packets(&station, &traces, args.packet_ms, args.tail) {
        engine.process(packet, 0, &mut out);
        handle(&mut out, &mut journal)?;
    }
    engine.flush(0, &mut out);
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
        println!(
            "{}",
            serde_json::json!({
                "type": "summary", "pbrs": pbrs,
                "counters": {"engine": engine.counters(), "stations": counters},
            })
        );
    } else {
        println!("\n{alerts} alerts. Blocks:");
        println!(
            "{:<28} {:<11} {:>9} {:>11} {:>10} {:>13}",
            "pbr", "station", "max θ/α", "max slide", "overturned", "P(overturn)"
        );
        for s in &summaries {
            println!(
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
