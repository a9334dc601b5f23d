//! Acquisition throughput and added latency: MiniSEED records as a SeedLink server sends them
//! (512-byte Steim-2, interleaved in time over all streams) → decode (the project's reader) →
//! calibrate, rotate and align (`rockwatch_core::assembly` through `acquire`'s
//! `PacketPublisher`) → publish, for 1000 stations × 3 channels at 100 Hz. Publishing goes to
//! a counting sink (the pipeline alone) and, when it can be opened, to a real iceoryx2
//! `pbr/accel` publisher. Run: `cargo bench --bench acquire` (prints the figures).
//!
//! Figures: the real-time factor on one core (data seconds per wall second; the target is ≥ 5)
//! and the per-record processing time (record received → its packets published), p50/p99/max
//! (target p99 ≤ 1 ms). The wait for a station's other components is data arrival, not
//! processing, and is not counted.

use std::path::Path;
use std::time::{Duration, Instant};

use rockwatch::acquire::{ClippingSection, PacketPublisher};
use rockwatch::iox::{IoxConfig, IoxPacketSink};
use rockwatch::ports::PacketSink;
use rockwatch::seedlink::RecordSink;
use rockwatch_core::assembly::AssemblyConfig;
use rockwatch_core::engine::AccelPacket;
use rockwatch_core::inventory::{ChannelEpoch, Inventory, Sensitivity};
use rockwatch_core::record::mseed::{
    encode_mseed, parse_mseed, ChannelData, RecordLength, Samples, WriteOptions,
};

const STATIONS: usize = 1000;
const RATE_HZ: f64 = 100.0;
const SECONDS: usize = 20;
const CHANNELS: [(&str, f64, f64); 3] =
    [("HN1", 30.0, 0.0), ("HN2", 120.0, 0.0), ("HNZ", 0.0, -90.0)];
const T0_NS: i64 = 1_700_000_000_000_000_000;

fn station(i: usize) -> (String, String) {
    ("XX".into(), format!("S{i:03}"))
}

fn inventory() -> Inventory {
    let mut channels = Vec::new();
    for s in 0..STATIONS {
        let (net, sta) = station(s);
        for (cha, az, dip) in CHANNELS {
            channels.push(ChannelEpoch {
                source: "bench".into(),
                network: net.clone(),
                station: sta.clone(),
                location: "00".into(),
                channel: cha.into(),
                start_ns: Some(0),
                end_ns: None,
                sample_rate_hz: Some(RATE_HZ),
                azimuth_deg: Some(az),
                dip_deg: Some(dip),
                sensitivity: Some(Sensitivity {
                    value: 427_000.0,
                    frequency_hz: Some(1.0),
                    input_units: "M/S**2".into(),
                    output_units: Some("COUNTS".into()),
                }),
            });
        }
    }
    Inventory { channels }
}

/// Every stream's 512-byte records, ordered by start time as a server would send them.
fn records() -> Vec<Vec<u8>> {
    let n = SECONDS * RATE_HZ as usize;
    let mut all: Vec<(i64, Vec<u8>)> = Vec::new();
    for s in 0..STATIONS {
        let (net, sta) = station(s);
        for (c, (cha, _, _)) in CHANNELS.iter().enumerate() {
            let counts: Vec<i32> = (0..n)
                .map(|i| {
                    let t = i as f64 / RATE_HZ;
                    (2000.0
                        * (2.0 * std::f64::consts::PI * (1.0 + 0.1 * c as f64) * t + s as f64)
                            .sin()) as i32
                        + ((i * 7919 + s * 31 + c) % 41) as i32
                        - 20
                })
                .collect();
            let data = ChannelData {
                id: format!("{net}.{sta}.00.{cha}"),
                start_time_ns: T0_NS,
                sample_rate_hz: RATE_HZ,
                samples: Samples::Counts(&counts),
            };
            let options = WriteOptions {
                record_length: RecordLength::B512,
                ..WriteOptions::default()
            };
            let bytes = encode_mseed(&[data], options, Path::new("bench")).expect("encodes");
            for r in bytes.chunks(512) {
                let start = parse_mseed(r, Path::new("bench"))
                    .expect("decodes")
                    .channels[0]
                    .start_time_ns;
                all.push((start, r.to_vec()));
            }
        }
    }
    all.sort_by_key(|(t, _)| *t);
    all.into_iter().map(|(_, r)| r).collect()
}

/// Counts packets and samples.
#[derive(Default)]
struct Counting {
    packets: u64,
    samples: u64,
}

impl PacketSink for Counting {
    fn wait_for_subscriber(&mut self, _: Duration) -> anyhow::Result<bool> {
        Ok(true)
    }
    fn send(&mut self, packet: &AccelPacket) -> anyhow::Result<()> {
        self.packets += 1;
        self.samples += packet.len() as u64;
        std::hint::black_box(packet);
        Ok(())
    }
}

/// Runs every record through decode + publisher; returns (wall time, per-record times).
fn run(records: &[Vec<u8>], sink: &mut dyn PacketSink) -> (Duration, Vec<Duration>) {
    let mut publisher = PacketPublisher::new(
        inventory(),
        AssemblyConfig::default(),
        ClippingSection::default(),
        sink,
    );
    let mut per_record = Vec::with_capacity(records.len());
    let start = Instant::now();
    for r in records {
        let t = Instant::now();
        let file = parse_mseed(r, Path::new("seedlink")).expect("decodes");
        for channel in &file.channels {
            publisher.record(channel);
        }
        per_record.push(t.elapsed());
    }
    let wall = start.elapsed();
    let (published, assembled) = publisher.counters();
    assert_eq!(assembled.refused_records, 0);
    assert!(published.packets_sent > 0 || assembled.packets > 0);
    (wall, per_record)
}

fn report(label: &str, records: usize, wall: Duration, mut per_record: Vec<Duration>) {
    per_record.sort_unstable();
    let q = |f: f64| per_record[((per_record.len() - 1) as f64 * f) as usize];
    let data_s = SECONDS as f64;
    println!(
        "acquire [{label}]: {STATIONS} stations × 3 channels × {RATE_HZ} Hz, {SECONDS} s of data, {records} records in {:.3} s: {:.1}× real time on one core; per record (decode → packets published) p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
        wall.as_secs_f64(),
        data_s / wall.as_secs_f64(),
        q(0.5).as_secs_f64() * 1e6,
        q(0.99).as_secs_f64() * 1e6,
        per_record.last().map_or(0.0, |d| d.as_secs_f64() * 1e6),
    );
}

fn main() {
    let records = records();
    // Warm-up, then the measured run.
    let _ = run(&records[..records.len() / 10], &mut Counting::default());
    let mut counting = Counting::default();
    let (wall, per_record) = run(&records, &mut counting);
    report("counting sink", records.len(), wall, per_record);
    println!(
        "acquire [counting sink]: {} packets, {} samples per component published",
        counting.packets, counting.samples
    );
    let iox = IoxConfig {
        config_file: Some(
            Path::new(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../config/iceoryx2.toml"
            ))
            .into(),
        ),
        accel_service: format!("rockwatch-bench-acquire-{}/accel", std::process::id()),
        alerts_service: format!("rockwatch-bench-acquire-{}/alerts", std::process::id()),
        ..IoxConfig::default()
    };
    match IoxPacketSink::new(&iox) {
        Ok(mut sink) => {
            let (wall, per_record) = run(&records, &mut sink);
            report("iceoryx2 publisher", records.len(), wall, per_record);
        }
        Err(e) => println!("acquire [iceoryx2 publisher]: skipped, cannot open the service: {e:#}"),
    }
}
