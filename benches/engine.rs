//! Monitoring-engine throughput: the real-time factor for N three-component stations at
//! 100 Hz in 100 ms packets with M blocks, split into blocks at rest and in motion, and the
//! per-packet processing latency. Run: `cargo bench --bench engine` (prints the figures).
//!
//! Load: 1000 stations with 10 blocks each (10 000 blocks). 100 "shaking" stations see a
//! 0.3 g, 1.5 Hz horizontal sine (their 1000 blocks rock), the other 900 weak noise of
//! 0.005 g (their blocks stay at rest). Ensemble size 1. Ten seconds of data.

use std::time::Instant;

use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::dynamics::BlockParams;
use rockwatch_core::engine::{
    AccelPacket, Engine, EngineConfig, Output, PbrSpec, ShardedEngine, StationId,
};

const STATIONS: usize = 1000;
const SHAKING: usize = 100;
const BLOCKS_PER_STATION: usize = 10;
const RATE_HZ: f64 = 100.0;
const PACKET: usize = 10; // 100 ms
const SECONDS: usize = 10;

fn station(i: usize) -> String {
    format!("XX.S{i:04}.00")
}

fn pbrs() -> Vec<PbrSpec> {
    (0..STATIONS)
        .flat_map(|s| {
            (0..BLOCKS_PER_STATION).map(move |b| {
                // Large, moderately slender blocks: α ≈ 0.16–0.25 rad, R ≈ 2–3 m; they rock
                // under 0.3 g without falling within 10 s.
                let width = 0.8 + 0.05 * b as f64;
                let height = 4.0 + 0.1 * b as f64;
                PbrSpec {
                    id: format!("{}-{b}", station(s)),
                    station: StationId::parse(&station(s)).expect("valid id"),
                    azimuth: Azimuth::from_degrees(36.0 * b as f64).expect("finite azimuth"),
                    nominal: BlockParams::from_width_height(width, height, 0.9, 0.7, None)
                        .expect("valid block"),
                    members: vec![],
                }
            })
        })
        .collect()
}

/// All packets of one round (100 ms) for every station, in station order.
fn round(r: usize) -> Vec<AccelPacket> {
    (0..STATIONS)
        .map(|s| {
            let amp = if s < SHAKING { 0.3 } else { 0.005 } * 9.80665;
            let phase = s as f64 * 0.37;
            let sample = |i: usize, f: f64| {
                let t = (r * PACKET + i) as f64 / RATE_HZ;
                (amp * (2.0 * std::f64::consts::PI * f * t + phase).sin()) as f32
            };
            AccelPacket {
                station: station(s),
                start_time_ns: (r * PACKET) as i64 * 10_000_000,
                sample_rate_hz: RATE_HZ,
                sequence: r as u64,
                east: (0..PACKET).map(|i| sample(i, 1.5)).collect(),
                north: (0..PACKET).map(|i| sample(i, 1.1)).collect(),
                up: (0..PACKET).map(|i| 0.3 * sample(i, 2.3)).collect(),
            }
        })
        .collect()
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    let specs = pbrs();
    let rounds: Vec<Vec<AccelPacket>> = (0..SECONDS * 10).map(round).collect();
    let data_s = SECONDS as f64;

    // One core: a single engine, each packet timed.
    let mut engine = Engine::new(EngineConfig::default(), vec![], &specs).expect("engine");
    let mut out = Vec::new();
    let mut latencies_us = Vec::with_capacity(STATIONS * SECONDS * 10);
    let mut moving = std::collections::HashMap::new();
    let input = rounds.clone();
    let start = Instant::now();
    for packets in input {
        for p in packets {
            let t = Instant::now();
            engine.process(p, 0, &mut out);
            latencies_us.push(t.elapsed().as_secs_f64() * 1e6);
            for o in out.drain(..) {
                if let Output::State(s) = o {
                    moving.insert(s.pbr_id, s.mode);
                }
            }
        }
    }
    let wall = start.elapsed().as_secs_f64();
    latencies_us.sort_by(f64::total_cmp);
    let in_motion = moving
        .values()
        .filter(|m| !matches!(m, rockwatch_core::dynamics::Mode::Rest))
        .count();
    let overturned = engine.summaries().iter().filter(|s| s.overturned).count();
    println!(
        "engine, 1 core: {STATIONS} stations × 3 components at {RATE_HZ} Hz, {} blocks ({in_motion} in motion at the end, {overturned} overturned), {SECONDS} s of data",
        specs.len()
    );
    println!(
        "  wall {wall:.3} s → real-time factor {:.2}×",
        data_s / wall
    );
    println!(
        "  per-packet latency: p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs (shaking-station packets carry 10 moving blocks)",
        percentile(&latencies_us, 0.5),
        percentile(&latencies_us, 0.99),
        latencies_us.last().copied().unwrap_or(0.0)
    );

    // All cores: the sharded engine (the producer feeding it runs on one of the cores too).
    for shards in [1, 2] {
        let pool =
            ShardedEngine::start(EngineConfig::default(), &[], &specs, &[], shards).expect("pool");
        let input = rounds.clone();
        let start = Instant::now();
        for packets in input {
            for p in packets {
                pool.submit(p, 0);
            }
            for _ in pool.try_outputs() {}
        }
        let (_, _) = pool.shutdown();
        let wall = start.elapsed().as_secs_f64();
        println!(
            "  sharded, {shards} worker(s): wall {wall:.3} s → real-time factor {:.2}×",
            data_s / wall
        );
    }
}
