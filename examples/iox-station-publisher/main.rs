//! A station acquisition process feeding `rockwatch node` over iceoryx2 (zero copy, same host).
//!
//! It publishes an earthquake record on the publish-subscribe service `pbr/accel` as a live
//! station would: one iceoryx2 sample per packet, whose user header is an [`AccelHeader`] and
//! whose payload is a slice of [`AccelSample`]s, written in place in shared memory; after each
//! packet it notifies the event service of the same name, which wakes the node. The wire
//! contract (layouts, type names, service settings) is docs/iceoryx2.md; this file is the
//! reference client of it. See README.md beside this file for how to run it.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{anyhow, bail, Context};
use clap::Parser;
use iceoryx2::config::Config;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;
use rockwatch::iox::types::{AccelHeader, AccelSample, ACCEL_FLAG_HAS_UP, STATION_BYTES};
use rockwatch::iox::IoxConfig;
use rockwatch::replay::{Speed, Traces};
use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::engine::{AccelPacket, StationId};
use rockwatch_core::record::mseed::format_time_ns;
use rockwatch_core::record::Record;

/// How often the wait for a subscriber looks again (and notices SIGINT/SIGTERM).
const CYCLE: Duration = Duration::from_millis(10);

/// Publish an earthquake record to `rockwatch node` over iceoryx2, as a station acquisition
/// process on the same host would.
///
/// The record (by default the bundled Rinaldi record of the 1994 Northridge earthquake, the
/// one that throws over the example catalogue's slender pillar) is cut into packets of
/// --packet-ms, followed by --tail seconds of quiet. Each packet is one sample of the iceoryx2
/// service `pbr/accel`: user header `rockwatch::AccelHeader` (station, sample rate, UTC time of
/// the first sample, sequence number, sample count, flags), payload a slice of
/// `rockwatch::AccelSample` (east, north, up in m/s²); then the event service `pbr/accel` is
/// notified. Packets are stamped with the wall clock (the first sample is "now") and leave
/// when their last sample would have been recorded, scaled by --speed.
///
/// The process loads the SAME iceoryx2 configuration file as the node (--iceoryx2-config): a
/// process left to iceoryx2's own lookup may silently get other service limits, and then
/// cannot open the node's services. It waits for the node's subscription before the first
/// packet. SIGINT or SIGTERM stops it between two packets; it then prints what it sent and
/// exits 0.
#[derive(Debug, Parser)]
#[command(name = "iox-station-publisher", version)]
struct Args {
    /// iceoryx2 configuration file: the one the node loads (`[iceoryx2] config_file` of its
    /// node.toml). Default: this checkout's config/iceoryx2.toml.
    #[arg(
        long = "iceoryx2-config",
        value_name = "FILE",
        default_value_os_t = repo_path("config/iceoryx2.toml"),
        hide_default_value = true
    )]
    iceoryx2_config: PathBuf,
    /// iceoryx2 service to publish on: the node's `[iceoryx2] accel_service`.
    #[arg(long, value_name = "NAME", default_value_t = IoxConfig::default().accel_service)]
    service: String,
    /// Station SEED id `NET.STA.LOC` the packets are sent as. The node's catalogue attaches
    /// blocks to stations: CI.RRS.00 carries the example catalogue's Rinaldi blocks.
    #[arg(long, value_name = "ID", default_value = "CI.RRS.00")]
    station: String,
    /// Horizontal component to send: an AT2 file (PEER NGA format, in g) or a CSV file (t,ax
    /// in m/s²), as `rockwatch replay --record` takes. Default: the bundled Rinaldi record, component 228°, with its vertical
    /// (tests/data/records/Rinaldi228.AT2 and RinaldiUP.AT2).
    #[arg(long, value_name = "FILE")]
    record: Option<PathBuf>,
    /// Vertical component (same format, time step and length as the horizontal one). Without
    /// it the packets have no vertical channel (header flag HAS_UP clear). Default: the
    /// bundled RinaldiUP.AT2 when --record is not given.
    #[arg(long, value_name = "FILE")]
    vertical: Option<PathBuf>,
    /// Direction of the horizontal component, degrees clockwise from north: it is split into
    /// east = a·sin(az) and north = a·cos(az).
    #[arg(long, value_name = "DEG", default_value_t = 228.0)]
    azimuth: f64,
    /// Pace: 1 = real time, N = N × real time, max = as fast as possible (the node buffers
    /// 1024 packets per station; beyond that the oldest are overwritten and counted as gaps).
    #[arg(long, value_name = "1|N|max", default_value = "1")]
    speed: Speed,
    /// Packet length (ms of data).
    #[arg(long = "packet-ms", value_name = "MS", default_value_t = 100)]
    packet_ms: u32,
    /// Seconds of quiet (zero acceleration) sent after the record.
    #[arg(long, value_name = "S", default_value_t = 10.0)]
    tail: f64,
    /// Seconds to wait for a subscriber (the node) before the first packet; an error if none
    /// comes.
    #[arg(long = "wait-s", value_name = "S", default_value_t = 30.0)]
    wait_s: f64,
    /// Print only the closing summary, not one line per packet.
    #[arg(long)]
    quiet: bool,
}

/// A path inside this checkout (the defaults point at the bundled files); the package is
/// crates/rockwatch.
fn repo_path(relative: &str) -> PathBuf {
    let package = Path::new(env!("CARGO_MANIFEST_DIR"));
    package.ancestors().nth(2).unwrap_or(package).join(relative)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    // The libraries' errors (iceoryx2, RustDDS log through `log`) on stderr, as the node's.
    rockwatch::logging::init(&rockwatch::logging::LogOptions::default())?;
    let station = StationId::parse(&args.station).map_err(|e| {
        anyhow!(
            "--station {:?}: {e} (the node drops such packets)",
            args.station
        )
    })?;
    if !(args.wait_s.is_finite() && (0.0..=86_400.0).contains(&args.wait_s)) {
        return Err(anyhow!("--wait-s must be 0 to 86400 seconds, got {}", args.wait_s).into());
    }
    let packets = load_packets(&args, &station)?;
    let samples_per_packet = packets.iter().map(AccelPacket::len).max().unwrap_or(1);

    // One explicit configuration file for every process (docs/iceoryx2.md).
    let config = load_iceoryx2_config(&args.iceoryx2_config)?;
    let node = NodeBuilder::new()
        .config(&config)
        .create::<ipc::Service>()
        .map_err(|e| anyhow!("cannot create the iceoryx2 node: {e:?}"))?;

    // Open the service with the settings the node creates it with (IoxConfig's defaults), so
    // that whichever of the two starts first creates it and the other can open it.
    let node_side = IoxConfig::default();
    let service_name = ServiceName::new(&args.service).map_err(|e| {
        anyhow!(
            "--service {:?}: not an iceoryx2 service name: {e:?}",
            args.service
        )
    })?;
    let service = node
        .service_builder(&service_name)
        .publish_subscribe::<[AccelSample]>()
        .user_header::<AccelHeader>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(node_side.subscriber_buffer)
        .max_publishers(node_side.max_publishers)
        .open_or_create()
        .map_err(|e| {
            anyhow!(
                "iceoryx2 service {:?}: {e:?} (was it created with another configuration file?)",
                args.service
            )
        })?;
    // The slice is sized once for the longest packet: no reallocation while sending.
    let publisher = service
        .publisher_builder()
        .initial_max_slice_len(samples_per_packet)
        .backpressure_strategy(BackpressureStrategy::DiscardData)
        .create()
        .map_err(|e| anyhow!("cannot create the {} publisher: {e:?}", args.service))?;
    let notifier = node
        .service_builder(&service_name)
        .event()
        .open_or_create()
        .map_err(|e| anyhow!("iceoryx2 event service {:?}: {e:?}", args.service))?
        .notifier_builder()
        .create()
        .map_err(|e| anyhow!("cannot create the {} notifier: {e:?}", args.service))?;

    // Wait for the node: a sample sent before any subscriber exists is lost.
    eprintln!(
        "iox-station-publisher: waiting for a subscriber on {} ({})",
        args.service,
        args.iceoryx2_config.display()
    );
    let deadline = Instant::now() + Duration::from_secs_f64(args.wait_s);
    while service.dynamic_config().number_of_subscribers() == 0 {
        if Instant::now() >= deadline {
            return Err(anyhow!(
                "no subscriber on {} within {} s: is `rockwatch node` running with \
                 [iceoryx2] config_file = {} and accel_service = {:?}?",
                args.service,
                args.wait_s,
                args.iceoryx2_config.display(),
                args.service
            )
            .into());
        }
        if node.wait(CYCLE).is_err() {
            eprintln!("iox-station-publisher: interrupted before the first packet");
            return Ok(());
        }
    }
    publisher
        .update_connections()
        .map_err(|e| anyhow!("{}: cannot connect to the subscriber: {e:?}", args.service))?;

    // The first sample is stamped "now"; the record's own time starts at 0.
    let wall_start_ns = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .context("the system clock is before 1970")?
        .as_nanos() as i64;
    let started = Instant::now();
    let (mut sent, mut sent_samples, mut interrupted) = (0u64, 0u64, false);
    for packet in &packets {
        // Pace on an absolute schedule: a packet leaves when its last sample is recorded.
        if let Speed::Times(factor) = args.speed {
            let data_end_s =
                packet.start_time_ns as f64 * 1e-9 + packet.len() as f64 / packet.sample_rate_hz;
            let due = Duration::from_secs_f64(data_end_s / factor);
            let now = started.elapsed();
            if due > now && node.wait(due - now).is_err() {
                interrupted = true; // SIGINT or SIGTERM
                break;
            }
        }

        let header = AccelHeader {
            station: padded_station(&station),
            sample_rate_hz: packet.sample_rate_hz,
            start_time_ns: wall_start_ns + packet.start_time_ns,
            sequence: packet.sequence,
            sample_count: packet.len() as u64,
            flags: if packet.up.is_empty() {
                0
            } else {
                ACCEL_FLAG_HAS_UP
            },
            reserved: 0,
        };
        // Loan a slice of the packet's length in shared memory and write it in place.
        let mut sample = publisher
            .loan_slice_uninit(packet.len())
            .map_err(|e| anyhow!("{}: loan failed: {e:?}", args.service))?;
        *sample.user_header_mut() = header;
        let sample = sample.write_from_fn(|i| AccelSample {
            east: packet.east[i],
            north: packet.north[i],
            up: packet.up.get(i).copied().unwrap_or(0.0),
        });
        sample
            .send()
            .map_err(|e| anyhow!("{}: send failed: {e:?}", args.service))?;
        // The sample first, then the notification: the node takes the notifications, then
        // every sample waiting, so nothing sent before a notification is missed.
        notifier
            .notify()
            .map_err(|e| anyhow!("{}: notify failed: {e:?}", args.service))?;
        sent += 1;
        sent_samples += packet.len() as u64;
        if !args.quiet {
            println!(
                "sent #{:<4} {} {} {:>4} samples  peak horizontal {:6.3} m/s²",
                header.sequence,
                station,
                format_time_ns(header.start_time_ns),
                header.sample_count,
                peak_horizontal_mps2(packet)
            );
        }
    }
    let data_s = packets
        .iter()
        .take(sent as usize)
        .map(|p| p.len() as f64 / p.sample_rate_hz)
        .sum::<f64>();
    println!(
        "{} {sent} packets ({sent_samples} samples, {data_s:.2} s of data) as {station} on {} in {:.2} s",
        if interrupted {
            "interrupted after"
        } else {
            "sent"
        },
        args.service,
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Reads the iceoryx2 configuration; an error names the file (iceoryx2 gives only a code).
fn load_iceoryx2_config(path: &Path) -> anyhow::Result<Config> {
    std::fs::read_to_string(path).with_context(|| {
        format!(
            "{}: cannot read the iceoryx2 configuration (give the node's file with --iceoryx2-config)",
            path.display()
        )
    })?;
    let text = path
        .to_str()
        .with_context(|| format!("{}: path is not UTF-8", path.display()))?;
    let file = FilePath::new(text.as_bytes())
        .map_err(|e| anyhow!("{}: not a usable path: {e:?}", path.display()))?;
    Config::from_file(&file).map_err(|e| {
        anyhow!(
            "{}: not a valid iceoryx2 configuration: {e:?}",
            path.display()
        )
    })
}

/// The record the arguments name, as packets of `station` with times from 0 (ns).
fn load_packets(args: &Args, station: &StationId) -> anyhow::Result<Vec<AccelPacket>> {
    let (horizontal, vertical) = match &args.record {
        Some(path) => (path.clone(), args.vertical.clone()),
        None => (
            repo_path("tests/data/records/Rinaldi228.AT2"),
            Some(
                args.vertical
                    .clone()
                    .unwrap_or_else(|| repo_path("tests/data/records/RinaldiUP.AT2")),
            ),
        ),
    };
    let mut record = Record::read(&horizontal)?;
    if let Some(path) = &vertical {
        record.attach_vertical(path)?;
    }
    if !(args.tail.is_finite() && args.tail >= 0.0) {
        bail!("--tail must be a number of seconds ≥ 0, got {}", args.tail);
    }
    let azimuth = Azimuth::from_degrees(args.azimuth).map_err(|e| anyhow!("--azimuth: {e}"))?;
    let traces = Traces::from_record(&record, azimuth);
    let packets = traces.packets(station, args.packet_ms, args.tail);
    if packets.is_empty() {
        bail!("{}: the record has no samples", horizontal.display());
    }
    Ok(packets)
}

/// The station id as the header's NUL-padded ASCII field (a SEED id has at most 11 bytes).
fn padded_station(station: &StationId) -> [u8; STATION_BYTES] {
    let mut field = [0; STATION_BYTES];
    let id = station.as_str().as_bytes();
    field[..id.len()].copy_from_slice(id);
    field
}

/// Largest horizontal acceleration of a packet (m/s²), for the log line.
fn peak_horizontal_mps2(packet: &AccelPacket) -> f32 {
    packet
        .east
        .iter()
        .zip(&packet.north)
        .map(|(e, n)| e.hypot(*n))
        .fold(0.0, f32::max)
}
