//! Monitoring-engine throughput: the real-time factor for N three-component stations at
//! 100 Hz in 100 ms packets with M blocks, split into blocks at rest and in motion, and the
//! per-packet processing latency. Run: `cargo bench --bench engine` (prints the figures).
//!
//! Cases (ten seconds of data each, ensemble size 1, so every block is one integrated block):
//! - **existing**: 1000 stations with 10 blocks each (10 000 blocks). 100 "shaking" stations
//!   see a 0.3 g, 1.5 Hz horizontal sine (their 1000 blocks rock), the other 900 weak noise of
//!   0.005 g (their blocks stay at rest). Also run on the sharded engine.
//! - **capacity**: 5000 stations with 20 blocks each (100 000 blocks, azimuths 18° apart),
//!   500 shaking (10 000 blocks rocking), one core; prints the resident size and the resident
//!   bytes per block.
//! - **at rest**: 1000 quiet stations with 20 blocks each against the same stations with no
//!   block: the difference is the amortised cost of a block at rest per sample, with the
//!   station's shared rest check and without it (every block takes its own rest check).
//! - **region**: 2000 stations, 1000 rocks (one on every other station), each with a
//!   100-member ensemble in 24 toppling directions 15° apart: 2 400 000 member blocks. The
//!   rocks of the first 10 % of the stations see the 0.3 g shaking, the others weak noise;
//!   run on the sharded engine with 2 workers; prints the member blocks in motion at the
//!   end (M), the block state per member block and the process's resident size.
//!   `REGION_ROCKS=100` runs it at a tenth of the scale (stations and shaking scale along).
//!
//! Moving blocks' cost per sample: `cargo bench --bench block_step` (b, c).

mod thread_time;

use std::time::Instant;

use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::catalogue::DirectionBlocks;
use rockwatch_core::dynamics::{
    BlockEvent, BlockOptions, BlockParams, GroundAccel, Mode, RigidBlock,
};
use rockwatch_core::engine::{
    AccelPacket, Engine, EngineConfig, Output, PbrId, PbrSpec, ShardedEngine, StationConfig,
    StationId,
};

const RATE_HZ: f64 = 100.0;
const PACKET: usize = 10; // 100 ms
const SECONDS: usize = 10;
const ROUNDS: usize = SECONDS * 10;

/// One benchmark load.
#[derive(Clone, Copy)]
struct Case {
    stations: usize,
    /// The first `shaking` stations see 0.3 g; the others 0.005 g.
    shaking: usize,
    blocks_per_station: usize,
}

impl Case {
    fn blocks(self) -> usize {
        self.stations * self.blocks_per_station
    }
}

fn station(i: usize) -> String {
    format!("XX.S{i:04}.00")
}

fn pbrs(case: Case) -> Vec<PbrSpec> {
    let n = case.blocks_per_station;
    (0..case.stations)
        .flat_map(|s| {
            (0..n).map(move |b| {
                // Large, moderately slender blocks: α ≈ 0.16–0.25 rad, R ≈ 2–3 m; they rock
                // under 0.3 g without falling within 10 s. Azimuths spread over 360°.
                let k = (b % 10) as f64;
                let width = 0.8 + 0.05 * k;
                let height = 4.0 + 0.1 * k;
                PbrSpec {
                    id: PbrId::parse(&format!("{}-{b}", station(s))).expect("valid id"),
                    station: StationId::parse(&station(s)).expect("valid id"),
                    azimuth: Azimuth::from_degrees(360.0 * b as f64 / n as f64)
                        .expect("finite azimuth"),
                    nominal: BlockParams::from_width_height(width, height, 0.9, 0.7, None)
                        .expect("valid block"),
                    members: vec![],
                    more_directions: vec![],
                    rock_3d: None,
                    place: Default::default(),
                }
            })
        })
        .collect()
}

/// All packets of round `r` (100 ms) for every station, in station order.
fn round(case: Case, r: usize) -> Vec<AccelPacket> {
    (0..case.stations)
        .map(|s| {
            let amp = if s < case.shaking { 0.3 } else { 0.005 } * 9.80665;
            let phase = s as f64 * 0.37;
            let sample = |i: usize, f: f64| {
                let t = (r * PACKET + i) as f64 / RATE_HZ;
                (amp * (2.0 * std::f64::consts::PI * f * t + phase).sin()) as f32
            };
            AccelPacket {
                station: StationId::parse(&station(s)).expect("valid id"),
                start_time_ns: (r * PACKET) as i64 * 10_000_000,
                sample_rate_hz: RATE_HZ,
                sequence: r as u64,
                east: (0..PACKET).map(|i| sample(i, 1.5)).collect(),
                north: (0..PACKET).map(|i| sample(i, 1.1)).collect(),
                up: (0..PACKET).map(|i| 0.3 * sample(i, 2.3)).collect(),
                unit: Default::default(),
            }
        })
        .collect()
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

/// Resident set size of this process (bytes), from /proc/self/status (0 if unavailable).
fn resident_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmRSS:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

/// CPU time of this process so far (s; every thread, ended ones included), from
/// /proc/self/stat (utime + stime at 100 ticks per second; 0 if unavailable).
fn process_cpu_s() -> f64 {
    let text = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // The fields after the command name (which may hold spaces) start at the state (field 3).
    let after = text.rsplit_once(')').map_or("", |(_, rest)| rest);
    let fields: Vec<f64> = after
        .split_whitespace()
        .map(|f| f.parse::<f64>().unwrap_or(0.0))
        .collect();
    (fields.get(11).copied().unwrap_or(0.0) + fields.get(12).copied().unwrap_or(0.0)) / 100.0
}

/// This thread's time on a CPU and waiting for one (run queue), in s (zeros if unavailable).
fn thread_cpu_and_wait_s() -> (f64, f64) {
    thread_time::run_and_wait_ns().map_or((0.0, 0.0), |(run, wait)| {
        (run as f64 * 1e-9, wait as f64 * 1e-9)
    })
}

/// What one timed run measured.
struct Run {
    /// Seconds spent inside `Engine::process` (wall).
    engine_s: f64,
    /// CPU seconds of this thread over the `process` calls (and their timing), and seconds it
    /// waited for a CPU meanwhile.
    cpu_s: f64,
    waited_s: f64,
    latencies_us: Vec<f64>,
    in_motion: usize,
    overturned: usize,
}

impl Run {
    /// Engine time and real-time factor, wall and CPU.
    fn timing(&self) -> String {
        format!(
            "engine time {:.3} s → real-time factor {:.2}× (CPU time {:.3} s → {:.2}× on a core of its own; {:.3} s waiting for a CPU)",
            self.engine_s,
            SECONDS as f64 / self.engine_s,
            self.cpu_s,
            SECONDS as f64 / self.cpu_s,
            self.waited_s
        )
    }

    /// Percentiles of the per-packet processing time.
    fn latency(&self) -> String {
        let l = &self.latencies_us;
        format!(
            "per-packet latency: p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
            percentile(l, 0.5),
            percentile(l, 0.99),
            l.last().copied().unwrap_or(0.0)
        )
    }
}

/// Feeds the case's ten seconds to `engine` round by round (input generated outside the
/// timed calls) and times each `process` call.
fn timed_run(case: Case, engine: &mut Engine) -> Run {
    let mut out = Vec::new();
    let mut latencies_us = Vec::with_capacity(case.stations * ROUNDS);
    let mut modes = std::collections::HashMap::new();
    let (mut engine_s, mut cpu_s, mut waited_s) = (0.0, 0.0, 0.0);
    for r in 0..ROUNDS {
        let packets = round(case, r);
        let (cpu0, wait0) = thread_cpu_and_wait_s();
        for p in packets {
            let t = Instant::now();
            engine.process(p, 0, &mut out);
            let dt = t.elapsed().as_secs_f64();
            engine_s += dt;
            latencies_us.push(dt * 1e6);
        }
        let (cpu1, wait1) = thread_cpu_and_wait_s();
        cpu_s += cpu1 - cpu0;
        waited_s += wait1 - wait0;
        for o in out.drain(..) {
            if let Output::State(s) = o {
                modes.insert(s.pbr_id, s.mode);
            }
        }
    }
    latencies_us.sort_by(f64::total_cmp);
    Run {
        engine_s,
        cpu_s,
        waited_s,
        latencies_us,
        in_motion: modes.values().filter(|m| **m != Mode::Rest).count(),
        overturned: engine.summaries().iter().filter(|s| s.overturned).count(),
    }
}

fn existing_case() {
    let case = Case {
        stations: 1000,
        shaking: 100,
        blocks_per_station: 10,
    };
    let specs = pbrs(case);
    let mut engine = Engine::new(EngineConfig::default(), vec![], &specs).expect("engine");
    let run = timed_run(case, &mut engine);
    println!(
        "engine, 1 core: {} stations × 3 components at {RATE_HZ} Hz, {} blocks ({} in motion at the end, {} overturned), {SECONDS} s of data",
        case.stations,
        case.blocks(),
        run.in_motion,
        run.overturned
    );
    println!("  {}", run.timing());
    println!(
        "  {} (shaking-station packets carry 10 moving blocks)",
        run.latency()
    );

    // All cores: the sharded engine (the producer feeding it runs on one of the cores too).
    let rounds: Vec<Vec<AccelPacket>> = (0..ROUNDS).map(|r| round(case, r)).collect();
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
            SECONDS as f64 / wall
        );
    }
}

fn capacity_case() {
    let case = Case {
        stations: 5000,
        shaking: 500,
        blocks_per_station: 20,
    };
    let specs = pbrs(case);
    let mut engine = Engine::new(EngineConfig::default(), vec![], &specs).expect("engine");
    drop(specs);
    let resident_before = resident_bytes();
    let run = timed_run(case, &mut engine);
    let resident_after = resident_bytes();
    println!(
        "capacity: {} stations × 3 components at {RATE_HZ} Hz, {} blocks ({} in motion at the end, {} overturned), {SECONDS} s of data, 1 core: {}",
        case.stations,
        case.blocks(),
        run.in_motion,
        run.overturned,
        run.timing()
    );
    println!("  {}", run.latency());
    println!(
        "  resident size: process {:.0} MiB after the run (+{:.0} MiB during it: the stations' running intensity windows, the benchmark's records); blocks {:.1} MiB = {:.0} B per block (Engine::block_bytes; an ensemble member in motion is one RigidBlock, {} B, one at rest 104 B: docs/capacity.md)",
        resident_after as f64 / 1048576.0,
        resident_after.saturating_sub(resident_before) as f64 / 1048576.0,
        engine.block_bytes() as f64 / 1048576.0,
        engine.block_bytes() as f64 / case.blocks() as f64,
        std::mem::size_of::<RigidBlock>()
    );
}

fn at_rest_case() {
    let quiet = |blocks_per_station| Case {
        stations: 1000,
        shaking: 0,
        blocks_per_station,
    };
    let time = |case: Case, shared: bool| {
        let configs = (0..case.stations)
            .map(|s| StationConfig::default_for(StationId::parse(&station(s)).expect("id")))
            .collect();
        let mut engine =
            Engine::new(EngineConfig::default(), configs, &pbrs(case)).expect("engine");
        engine.set_shared_rest_check(shared);
        timed_run(case, &mut engine).cpu_s
    };
    let bare = time(quiet(0), true);
    let samples = (1000 * ROUNDS * PACKET) as f64;
    for shared in [true, false] {
        let with = time(quiet(20), shared);
        println!(
            "  at rest ({}): {:.2} ns per block per sample amortised (1000 quiet stations, 20 blocks each vs none: {:.3} s vs {:.3} s of CPU)",
            if shared {
                "station's shared rest check"
            } else {
                "each block's own rest check"
            },
            (with - bare) / (samples * 20.0) * 1e9,
            with,
            bare
        );
    }
}

/// Toppling directions of a region rock, 15° apart.
const REGION_DIRECTIONS: usize = 24;
/// Ensemble members of a region rock's direction.
const REGION_MEMBERS: usize = 100;

/// Block `m` (None: the nominal one) of rock `r` in direction `d` of the region case. The
/// nominal rock: α ≈ 0.16–0.25 rad as in the other cases; its width seen from direction d
/// varies by ±15 % (an elongated rock); members ±10 % in height and ±8 % in width, μs
/// 0.6–0.9 (a Latin-hypercube-like stratification of member m).
fn region_block(r: usize, d: usize, m: Option<usize>) -> BlockParams {
    let k = (r % 10) as f64;
    let az = (d as f64 * 15.0).to_radians();
    let mut width = (0.8 + 0.05 * k) * (1.0 + 0.15 * (2.0 * az).cos());
    let mut height = 4.0 + 0.1 * k;
    let mut mu_s = 0.75;
    if let Some(m) = m {
        let u = |stride: usize| {
            ((m * stride) % REGION_MEMBERS) as f64 / (REGION_MEMBERS - 1) as f64 - 0.5
        };
        height *= 1.0 + 0.2 * u(1);
        width *= 1.0 + 0.16 * u(37);
        mu_s += 0.3 * u(61);
    }
    BlockParams::from_width_height(width, height, mu_s, 0.8 * mu_s, None).expect("valid block")
}

/// Rocks of the region case: rock `r` on station `2r` (see the module doc).
fn region_specs(rocks: usize) -> Vec<PbrSpec> {
    (0..rocks)
        .map(|r| {
            let directions: Vec<DirectionBlocks> = (0..REGION_DIRECTIONS)
                .map(|d| DirectionBlocks {
                    azimuth: Azimuth::from_degrees(d as f64 * 15.0).expect("finite azimuth"),
                    nominal: region_block(r, d, None),
                    members: (0..REGION_MEMBERS)
                        .map(|m| region_block(r, d, Some(m)))
                        .collect(),
                })
                .collect();
            let mut directions = directions.into_iter();
            let first = directions.next().expect("24 directions");
            PbrSpec {
                id: PbrId::parse(&format!("rock-{r:04}")).expect("valid id"),
                station: StationId::parse(&station(2 * r)).expect("valid id"),
                azimuth: first.azimuth,
                nominal: first.nominal,
                members: first.members,
                more_directions: directions.collect(),
                rock_3d: None,
                place: Default::default(),
            }
        })
        .collect()
}

fn region_case() {
    let rocks: usize = std::env::var("REGION_ROCKS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1000);
    let case = Case {
        stations: 2 * rocks,
        shaking: 2 * rocks / 10,
        blocks_per_station: 0,
    };
    let members = rocks * 100 * 24;
    let workers = 2;
    let rounds: Vec<Vec<AccelPacket>> = (0..ROUNDS).map(|r| round(case, r)).collect();
    let specs = region_specs(rocks);
    let pool =
        ShardedEngine::start(EngineConfig::default(), &[], &specs, &[], workers).expect("pool");
    drop(specs);
    let cpu0 = process_cpu_s();
    let start = Instant::now();
    for packets in rounds {
        for p in packets {
            pool.submit(p, 0);
        }
        for _ in pool.try_outputs() {}
    }
    let (engines, _) = pool.shutdown();
    let wall = start.elapsed().as_secs_f64();
    let cpu = process_cpu_s() - cpu0;
    let in_motion: usize = engines.iter().map(Engine::members_in_motion).sum();
    let block_bytes: usize = engines.iter().map(Engine::block_bytes).sum();
    let per_worker: Vec<String> = engines
        .iter()
        .map(|e| e.members_in_motion().to_string())
        .collect();
    println!(
        "region: {} stations × 3 components at {RATE_HZ} Hz, {members} blocks ({rocks} rocks × 100 members × 24 directions, {in_motion} in motion at the end), {workers} workers: real-time factor {:.2}, block state {:.0} bytes per block, resident {:.0} MiB",
        case.stations,
        SECONDS as f64 / wall,
        block_bytes as f64 / members as f64,
        resident_bytes() as f64 / 1048576.0
    );
    println!(
        "  {SECONDS} s of data in {wall:.2} s wall, {cpu:.1} s of CPU ({:.2} cores of work per second of data; the machine's other load shares the 2 cores); members in motion at the end per worker: {}",
        cpu / SECONDS as f64,
        per_worker.join(", ")
    );
}

/// The cost of a moving member alone: the 100 members of rock 0 in 4 of its directions as
/// bare `RigidBlock`s under the region case's shaking (station 0's 0.3 g record projected on
/// each direction, f32 samples as in the packets), 10 s at 100 Hz on this thread. Prints the
/// thread's CPU time per member-sample in motion (a member not at rest at the sample's start;
/// one that fell counts on, at almost no cost), the integrator's steps per such sample and a
/// hash of every event and final state (equal hashes: the same results bit for bit).
fn member_step_case() {
    use std::hash::Hasher;
    let amp = 0.3 * 9.80665;
    let sample = |i: usize, f: f64| {
        let t = i as f64 / RATE_HZ;
        f64::from((amp * (2.0 * std::f64::consts::PI * f * t).sin()) as f32)
    };
    let n = SECONDS * RATE_HZ as usize;
    let mut hash = std::collections::hash_map::DefaultHasher::new();
    let (mut cpu_s, mut moving_samples, mut steps, mut rejected) = (0.0, 0u64, 0u64, 0u64);
    for d in [0, 5, 11, 17] {
        let az = (d as f64 * 15.0).to_radians();
        let input: Vec<GroundAccel> = (0..=n)
            .map(|i| GroundAccel {
                horizontal_mps2: sample(i, 1.5) * az.sin() + sample(i, 1.1) * az.cos(),
                vertical_mps2: 0.3 * sample(i, 2.3),
            })
            .collect();
        for m in 0..REGION_MEMBERS {
            let mut block = RigidBlock::new(region_block(0, d, Some(m)), BlockOptions::default());
            let (cpu0, _) = thread_cpu_and_wait_s();
            for w in input.windows(2) {
                if block.mode() != Mode::Rest {
                    moving_samples += 1;
                }
                block
                    .advance(1.0 / RATE_HZ, w[0], w[1], |e| hash_event(&mut hash, &e))
                    .expect("valid input");
            }
            cpu_s += thread_cpu_and_wait_s().0 - cpu0;
            let (a, r) = block.step_counts();
            steps += a;
            rejected += r;
            for v in [block.theta_rad(), block.theta_dot(), block.slide_m()] {
                hash.write_u64(v.to_bits());
            }
        }
    }
    let per = moving_samples.max(1) as f64;
    println!(
        "member step: 400 region members (rock 0, 4 directions), {SECONDS} s of its 0.3 g shaking: {moving_samples} member-samples in motion, {:.0} ns of CPU per member-sample in motion (hashing the events included), {:.3} accepted + {:.3} rejected steps per such sample, results hash {:016x}",
        cpu_s / per * 1e9,
        steps as f64 / per,
        rejected as f64 / per,
        hash.finish()
    );
}

/// Feeds an event's kind and its numbers, bit for bit, to `hash`.
fn hash_event(hash: &mut impl std::hash::Hasher, event: &BlockEvent) {
    let numbers: &[f64] = &match *event {
        BlockEvent::ModeChange { t_s, from, to } => [t_s, from as u8 as f64, to as u8 as f64, 0.0],
        BlockEvent::Impact {
            t_s,
            theta_dot_before,
            theta_dot_after,
            slip_dot_after,
            ..
        } => [t_s, theta_dot_before, theta_dot_after, slip_dot_after],
        BlockEvent::Peak { t_s, theta_rad } => [t_s, theta_rad, 1.0, 0.0],
        BlockEvent::AlphaCrossing { t_s, upward } => [t_s, f64::from(u8::from(upward)), 2.0, 0.0],
    };
    for v in numbers {
        hash.write_u64(v.to_bits());
    }
}

fn main() {
    // `cargo bench --bench engine -- capacity` runs only the cases whose name contains an
    // argument (flags such as `--bench` are ignored).
    let filters: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let cases: [(&str, fn()); 5] = [
        ("existing", existing_case),
        ("capacity", capacity_case),
        ("at_rest", at_rest_case),
        ("region", region_case),
        ("member_step", member_step_case),
    ];
    for (name, case) in cases {
        if filters.is_empty() || filters.iter().any(|f| name.contains(f.as_str())) {
            case();
        }
    }
}
