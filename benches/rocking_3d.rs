//! Cost of the 3-D rigid-body rock (crates/rockwatch-core/src/rocking3d) per rock per input
//! sample at 100 Hz: (a) at rest under weak motion (the closed-form rest test), (b) rocking
//! (a 0.4 × 0.6 × 2.0 m box under a 1 Hz sine above its uplift threshold, released tilted: it
//! rocks with a growing amplitude and falls after about 2.2 s; only the samples that start
//! with the rock moving are timed and counted, so an overturned rock's free samples do not
//! dilute the figure). Prints the number of 3-D rocks one core runs at 2× real time while all
//! of them rock; and (c) in the engine, a quiet station's 3-D rocks (`model = "3d"`)
//! against as many planar blocks, per rock per sample (the rest group on). Run:
//! `cargo bench --bench rocking_3d` (compare benches/block_step.rs for the planar block).
//!
//! Instruction counts (noise-free on a shared machine): with `ROCKING_3D_SAMPLES=N` in the
//! environment the binary runs only the rocking case (b) for at most N samples from its
//! release (while it moves),
//! prints the rock's step and solver counters, and exits without Criterion, e.g.
//! `ROCKING_3D_SAMPLES=300 valgrind --tool=callgrind target/release/deps/rocking_3d-…`
//! (instructions per sample = the total of `advance` / N).

use criterion::{criterion_group, Criterion};
use nalgebra::{UnitQuaternion, Vector3};
use rockwatch_core::mesh::contact::{RockGeometry, UpAxis};
use rockwatch_core::mesh::TriMesh;
use rockwatch_core::rocking3d::{GroundAccel3d, Mode3d, Rock3d, Rock3dOptions, RockBody};
use std::hint::black_box;

const DT: f64 = 0.01; // 100 Hz

fn box_body() -> RockBody {
    // 0.4 × 0.6 × 2.0 m, centred on the origin.
    let (b, d, h) = (0.2, 0.3, 2.0);
    let mesh = TriMesh::prism(&[(-b, -d), (b, -d), (b, d), (-b, d)], h).expect("box");
    let geometry = RockGeometry::new(&mesh).expect("geometry");
    let rest = geometry.rest(UpAxis::PlusZ, 0.0).expect("rest");
    RockBody::from_mesh(&geometry, &rest, 2500.0).expect("body")
}

fn sine(amp: f64, f_hz: f64, n: usize) -> Vec<GroundAccel3d> {
    (0..=n)
        .map(|i| {
            let t = i as f64 * DT;
            GroundAccel3d::horizontal(amp * (2.0 * std::f64::consts::PI * f_hz * t).sin(), 90.0)
        })
        .collect()
}

/// The rocking case (b): a 1 Hz sine above the uplift threshold.
fn strong_sine() -> Vec<GroundAccel3d> {
    sine(2.3, 1.0, 1000)
}

/// The box of case (b) released at a tilt of 0.05 rad about its west edge.
fn released(body: &RockBody) -> Rock3d {
    let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -0.05);
    let x = Vector3::new(-0.2, 0.0, 0.0) - q * Vector3::new(-0.2, 0.0, -1.0);
    Rock3d::released(
        body.clone(),
        0.8,
        0.8,
        Rock3dOptions::default(),
        (x, q, Vector3::zeros(), Vector3::zeros()),
    )
    .unwrap()
}

fn bench(c: &mut Criterion) {
    let body = box_body();
    let weak = sine(0.5, 2.0, 1000);
    let strong = strong_sine();
    let mut group = c.benchmark_group("rocking_3d");
    group.bench_function("at rest, per sample", |bch| {
        let mut rock = Rock3d::new(body.clone(), 0.8, 0.8, Rock3dOptions::default()).unwrap();
        let mut i = 0;
        bch.iter(|| {
            let k = i % 1000;
            rock.advance(DT, weak[k], weak[k + 1]).unwrap();
            i += 1;
            black_box(rock.mode());
        });
    });
    let mut rocking_ns = 0.0;
    group.bench_function("rocking, per sample", |bch| {
        bch.iter_custom(|iters| {
            let mut total = std::time::Duration::ZERO;
            let mut done = 0u64;
            while done < iters {
                let mut rock = released(&body);
                let n = (iters - done).min(300);
                let start = std::time::Instant::now();
                let rocked = rock_while_moving(&mut rock, &strong, n as usize);
                total += start.elapsed();
                done += rocked as u64;
            }
            rocking_ns = total.as_nanos() as f64 / iters as f64;
            total
        });
    });
    group.finish();
    if rocking_ns > 0.0 {
        // One rock costs rocking_ns per 10 ms of data: at 2× real time a core has 5 ms.
        println!(
            "rocking: {:.1} µs per rock per 100 Hz sample → {:.0} rocks on one core at 2× real time",
            rocking_ns / 1e3,
            5e6 / rocking_ns
        );
    }
}

/// (c) A quiet station (0.01 m/s² noise on every component, 100 Hz, 1 s packets) with
/// `ROCKS` rocks: all 3-D (`model = "3d"`, the box above) or all planar (the box's planar
/// block), in the engine with its shared rest check; the cost per rock per sample.
fn bench_engine_at_rest(c: &mut Criterion) {
    use rockwatch_core::azimuth::Azimuth;
    use rockwatch_core::catalogue::RigidMember;
    use rockwatch_core::dynamics::BlockParams;
    use rockwatch_core::engine::{
        AccelPacket, Engine, EngineConfig, PbrSpec, Rock3dSpec, StationId,
    };
    const ROCKS: usize = 100;
    let station = StationId::parse("XX.Q.00").expect("station");
    let planar = BlockParams::from_width_height(0.4, 2.0, 0.8, 0.8, None).expect("block");
    let specs = |three_d: bool| -> Vec<PbrSpec> {
        (0..ROCKS)
            .map(|k| PbrSpec {
                id: rockwatch_core::engine::PbrId::parse(&format!("rock-{k}")).expect("valid id"),
                station: station.clone(),
                azimuth: Azimuth::from_degrees(3.6 * k as f64).expect("azimuth"),
                nominal: planar,
                members: vec![],
                more_directions: vec![],
                rock_3d: three_d.then(|| Rock3dSpec {
                    body: box_body(),
                    nominal: RigidMember {
                        heading_deg: 3.6 * k as f64,
                        mu_s: 0.8,
                        mu_k: 0.8,
                    },
                    members: vec![],
                }),
                place: Default::default(),
            })
            .collect()
    };
    let packet = |i: usize| {
        let noise = |phase: f32| -> Vec<f32> {
            (0..100)
                .map(|j| 0.01 * ((i * 100 + j) as f32 * phase).sin())
                .collect()
        };
        AccelPacket {
            station: rockwatch_core::engine::StationId::parse("XX.Q.00").unwrap(),
            start_time_ns: 1_700_000_000_000_000_000 + i as i64 * 1_000_000_000,
            sample_rate_hz: 100.0,
            sequence: i as u64,
            east: noise(0.7),
            north: noise(0.3),
            up: noise(0.9),
            unit: Default::default(),
        }
    };
    let mut group = c.benchmark_group("engine_at_rest");
    let mut per_rock_ns = [0.0; 2];
    for (slot, three_d) in [(0, false), (1, true)] {
        let config = EngineConfig {
            state_interval_s: 3600.0,
            ..EngineConfig::default()
        };
        let mut engine = Engine::new(config, vec![], &specs(three_d)).expect("engine");
        let mut out = Vec::new();
        let mut i = 0;
        for _ in 0..3 {
            engine.process(packet(i), 0, &mut out);
            i += 1;
        }
        assert_eq!(engine.parked_blocks(), ROCKS, "every rock parked");
        let name = if three_d {
            "3-D rocks"
        } else {
            "planar blocks"
        };
        group.bench_function(format!("{ROCKS} {name}, per 1 s packet"), |bch| {
            bch.iter_custom(|iters| {
                let packets: Vec<AccelPacket> =
                    (0..iters as usize).map(|k| packet(i + k)).collect();
                i += iters as usize;
                let start = std::time::Instant::now();
                for p in packets {
                    engine.process(p, 0, &mut out);
                }
                let elapsed = start.elapsed();
                out.clear();
                per_rock_ns[slot] =
                    elapsed.as_nanos() as f64 / (iters as f64 * 100.0 * ROCKS as f64);
                elapsed
            });
        });
    }
    group.finish();
    println!(
        "engine at rest (quiet station, shared rest check): planar {:.2} ns, 3-D {:.2} ns per rock per sample",
        per_rock_ns[0], per_rock_ns[1]
    );
}

/// Advances `rock` over at most `n` samples of `input` (from its first), stopping before a
/// sample that starts with the rock no longer moving; returns the samples advanced.
fn rock_while_moving(rock: &mut Rock3d, input: &[GroundAccel3d], n: usize) -> usize {
    for k in 0..n {
        if rock.mode() != Mode3d::Moving {
            return k;
        }
        rock.advance(DT, input[k], input[k + 1]).unwrap();
    }
    n
}

/// `ROCKING_3D_SAMPLES=N`: case (b) alone for at most N samples while the rock moves (for
/// callgrind; module doc).
fn rocking_samples_only(n: usize) {
    let strong = strong_sine();
    let mut rock = released(&box_body());
    let rocked = rock_while_moving(&mut rock, &strong, n);
    let s = rock.stats();
    println!(
        "{rocked} samples rocked: mode {:?}, steps {}, max sweeps {}, unconverged {}, max tilt/α {:.5}",
        rock.mode(),
        s.n_steps,
        s.max_sweeps,
        s.n_unconverged,
        s.max_tilt_over_alpha
    );
}

criterion_group!(benches, bench, bench_engine_at_rest);

fn main() {
    if let Some(n) = std::env::var("ROCKING_3D_SAMPLES")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        rocking_samples_only(n);
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
