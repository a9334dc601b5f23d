//! Architecture invariant: `RigidBlock::advance` never allocates, in any mode.
//! `allocation_counter` installs a counting global allocator for this test binary.

use rockwatch_core::dynamics::{
    BlockEvent, BlockOptions, BlockParams, GroundAccel, Mode, RigidBlock,
};

/// A two-cycle 1 Hz sine of `amp_g` g, then 8 s of quiet, at 100 Hz.
fn input(amp_g: f64) -> Vec<GroundAccel> {
    (0..=1000)
        .map(|i| {
            let t = i as f64 * 0.01;
            let a = if t < 2.0 {
                amp_g * 9.80665 * (2.0 * std::f64::consts::PI * 0.5 * t).sin()
            } else {
                0.0
            };
            GroundAccel::horizontal(a)
        })
        .collect()
}

#[test]
fn advance_does_not_allocate_in_any_mode() {
    // Three blocks that together visit every mode but flight: a slender one that rocks,
    // slide-rocks and overturns; a squat one on low friction that slides; and one whose
    // friction lies just above tan α, which slide-rocks (as in benches/block_step.rs).
    let cases = [
        (
            BlockParams::from_width_height(0.4, 2.0, 0.5, 0.45, None).unwrap(),
            0.6,
        ),
        (
            BlockParams::from_width_height(1.5, 1.5, 0.2, 0.15, None).unwrap(),
            0.4,
        ),
        (
            BlockParams::from_width_height(0.6, 2.0, 0.32, 0.31, None).unwrap(),
            0.4,
        ),
        // A general body (docs/general-body.md): asymmetric pivots, its own inertia.
        (
            BlockParams::from_body(0.12, 0.3, 0.9, 0.35, 0.5, 0.45, None).unwrap(),
            0.6,
        ),
    ];
    let mut visited = [false; 6];
    let mut blocks: Vec<(RigidBlock, Vec<GroundAccel>)> = cases
        .iter()
        .map(|(p, amp)| (RigidBlock::new(*p, BlockOptions::default()), input(*amp)))
        .collect();
    let info = allocation_counter::measure(|| {
        for (block, input) in &mut blocks {
            for w in input.windows(2) {
                block
                    .advance(0.01, w[0], w[1], |e| {
                        if let BlockEvent::ModeChange { to, .. } = e {
                            visited[to as usize] = true;
                        }
                    })
                    .unwrap();
            }
        }
    });
    // The counter itself works (else this test could not fail).
    let probe = allocation_counter::measure(|| {
        std::hint::black_box(vec![1u8; 8]);
    });
    assert!(probe.count_total > 0);
    assert_eq!(
        info.count_total, 0,
        "advance allocated {} times",
        info.count_total
    );
    for mode in [
        Mode::Slide,
        Mode::Rock,
        Mode::SlideRock,
        Mode::Overturned,
        Mode::Rest,
    ] {
        assert!(visited[mode as usize], "the test must exercise {mode}");
    }
}

/// Architecture invariant: a quiet station whose blocks share the rest check (and, for
/// comparison, one whose blocks each take their own) processes packets without allocating
/// once nothing is due for output (the state interval is set to its maximum here; states and
/// intensities, when due, are outputs and allocate by design).
#[test]
fn a_quiet_station_with_resting_blocks_does_not_allocate() {
    use rockwatch_core::azimuth::Azimuth;
    use rockwatch_core::catalogue::{DirectionBlocks, RigidMember};
    use rockwatch_core::engine::{
        AccelPacket, Engine, EngineConfig, PbrSpec, Rock3dSpec, StationId,
    };
    let station = StationId::parse("XX.Q.00").unwrap();
    let pbrs: Vec<PbrSpec> = (0..20)
        .map(|k| PbrSpec {
            id: rockwatch_core::engine::PbrId::parse(&format!("q-{k}")).unwrap(),
            station: station.clone(),
            azimuth: Azimuth::from_degrees(18.0 * k as f64).unwrap(),
            nominal: BlockParams::from_width_height(0.5 + 0.05 * k as f64, 2.0, 0.7, 0.5, None)
                .unwrap(),
            members: if k % 4 == 0 {
                vec![BlockParams::from_width_height(0.6, 2.0, 0.7, 0.5, None).unwrap(); 3]
            } else {
                vec![]
            },
            // Rocks from meshes: every fourth also topples in two more directions (general
            // bodies), with as many members as its first direction.
            more_directions: if k % 4 == 0 {
                (1..3)
                    .map(|j| {
                        let body =
                            BlockParams::from_body(0.2, 0.35, 0.9, 0.6, 0.7, 0.5, None).unwrap();
                        DirectionBlocks {
                            azimuth: Azimuth::from_degrees(18.0 * k as f64 + 60.0 * j as f64)
                                .unwrap(),
                            nominal: body,
                            members: vec![body; 3],
                        }
                    })
                    .collect()
            } else {
                vec![]
            },
            // Every fifth is a mesh rock integrated in 3-D, with two members.
            rock_3d: (k % 5 == 2).then(|| Rock3dSpec {
                body: box_body(),
                nominal: RigidMember {
                    heading_deg: 7.0 * k as f64,
                    mu_s: 0.7,
                    mu_k: 0.5,
                },
                members: vec![
                    RigidMember {
                        heading_deg: 3.0,
                        mu_s: 0.6,
                        mu_k: 0.6,
                    };
                    2
                ],
            }),
            place: Default::default(),
        })
        .collect();
    let packet = |i: usize| AccelPacket {
        station: rockwatch_core::engine::StationId::parse("XX.Q.00").unwrap(),
        start_time_ns: i as i64 * 100_000_000,
        sample_rate_hz: 100.0,
        sequence: i as u64,
        east: (0..10)
            .map(|j| 0.01 * ((i * 10 + j) as f32 * 0.7).sin())
            .collect(),
        north: (0..10)
            .map(|j| 0.01 * ((i * 10 + j) as f32 * 0.3).cos())
            .collect(),
        up: (0..10)
            .map(|j| 0.005 * ((i * 10 + j) as f32 * 0.9).sin())
            .collect(),
        unit: Default::default(),
    };
    for shared in [true, false] {
        let config = EngineConfig {
            state_interval_s: 3600.0,
            ..EngineConfig::default()
        };
        let mut engine = Engine::new(config, vec![], &pbrs).unwrap();
        engine.set_shared_rest_check(shared);
        let mut out = Vec::with_capacity(1024);
        for i in 0..20 {
            engine.process(packet(i), 0, &mut out);
        }
        out.clear();
        let packets: Vec<AccelPacket> = (20..120).map(packet).collect();
        let info = allocation_counter::measure(|| {
            for p in packets {
                engine.process(p, 0, &mut out);
            }
        });
        assert!(out.is_empty(), "nothing is due: {out:?}");
        assert_eq!(
            engine.parked_blocks(),
            if shared { pbrs.len() } else { 0 },
            "shared check {shared}"
        );
        // Freeing the moved-in packets is allowed (they were allocated by the caller).
        assert_eq!(
            info.count_total, 0,
            "shared check {shared}: {} allocations",
            info.count_total
        );
    }
}

/// The fragility analysis's run (`simulate::simulate_outcome`, issue 14 §3): a scaled record
/// through `advance` with early exits, without allocating, whether the block rests, rocks
/// back or overturns.
#[test]
fn a_fragility_run_does_not_allocate() {
    use rockwatch_core::record::Record;
    use rockwatch_core::simulate::{simulate_outcome, Status};
    let record = Record {
        source: "sine".into(),
        dt_s: 0.01,
        horizontal_mps2: input(1.0).iter().map(|g| g.horizontal_mps2).collect(),
        vertical_mps2: None,
    };
    let params = BlockParams::from_width_height(0.4, 2.0, 0.5, 0.45, None).unwrap();
    let mut statuses = Vec::with_capacity(3);
    let info = allocation_counter::measure(|| {
        for scale in [0.01, 0.21, 0.6] {
            let o = simulate_outcome(params, &record, scale, scale, 10.0, BlockOptions::default())
                .unwrap();
            statuses.push((o.status, o.max_abs_theta_over_alpha));
        }
    });
    assert_eq!(info.count_total, 0, "allocated {} times", info.count_total);
    assert_eq!(statuses[0].0, Status::Ok);
    assert_eq!(statuses[0].1, 0.0, "at rest");
    assert_eq!(statuses[2].0, Status::Overturned);
    assert!(
        statuses.iter().any(|s| s.0 == Status::Ok && s.1 > 0.0),
        "{statuses:?}"
    );
}

/// Architecture invariant: `Rock3d::advance` (3-D rocking, docs/rocking-3d.md) never
/// allocates, at rest, moving, coming back to rest and overturning.
#[test]
fn a_3d_rock_advances_without_allocating_in_any_mode() {
    use rockwatch_core::rocking3d::{GroundAccel3d, Mode3d, Rock3d, Rock3dOptions};
    let body = box_body();
    // One-cycle 1 Hz sines along a diagonal at 200 Hz, 4 s of quiet after: 1.05 of the planar
    // overturning amplitude along a face normal (the diagonal is 1.25 times stronger) rocks
    // and settles, 1.6 overturns.
    let pulse = |amplitude: f64| -> Vec<GroundAccel3d> {
        (0..1000)
            .map(|i| {
                let t = i as f64 * 0.005;
                let a = if t < 1.0 {
                    amplitude * (2.0 * std::f64::consts::PI * t).sin()
                } else {
                    0.0
                };
                GroundAccel3d {
                    east_mps2: 0.8 * a,
                    north_mps2: 0.6 * a,
                    up_mps2: 0.1 * a,
                }
            })
            .collect()
    };
    let mut cases: Vec<(Rock3d, Vec<GroundAccel3d>)> = [1.05, 1.6]
        .iter()
        .map(|&k| {
            let rock = Rock3d::new(body.clone(), 0.8, 0.7, Rock3dOptions::default()).unwrap();
            (rock, pulse(k * 2.481))
        })
        .collect();
    let mut seen = Vec::with_capacity(16);
    let info = allocation_counter::measure(|| {
        for (rock, input) in &mut cases {
            for w in input.windows(2) {
                rock.advance(0.005, w[0], w[1]).unwrap();
                seen.push(rock.mode());
                if seen.len() == seen.capacity() {
                    seen.dedup();
                }
            }
        }
    });
    assert_eq!(info.count_total, 0, "allocated {} times", info.count_total);
    seen.dedup();
    for mode in [Mode3d::Rest, Mode3d::Moving, Mode3d::Overturned] {
        assert!(seen.contains(&mode), "the test must exercise {mode:?}");
    }
    assert_eq!(cases[0].0.mode(), Mode3d::Rest, "the 1.05× rock settles");
    assert!(cases[0].0.stats().n_rest_entries > 0);
}

/// The rigid body of a 0.4 × 0.6 × 2.0 m box standing on its base.
fn box_body() -> rockwatch_core::rocking3d::RockBody {
    use rockwatch_core::mesh::contact::{RockGeometry, UpAxis};
    use rockwatch_core::mesh::TriMesh;
    use rockwatch_core::rocking3d::RockBody;
    let geometry = RockGeometry::new(&TriMesh::cuboid(0.4, 0.6, 2.0).unwrap()).unwrap();
    let rest = geometry.rest(UpAxis::PlusZ, 0.0).unwrap();
    RockBody::from_mesh(&geometry, &rest, 2500.0).unwrap()
}
