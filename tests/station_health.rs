//! Station health in the engine (`engine::health`): a station silent for `stale_after_s` on
//! the caller's clock goes stale exactly once (one `Output::Health`, then a state of each of
//! its blocks flagged `not_monitored`), recovers on its next accepted packet (likewise, flag
//! cleared), a station never heard from counts from the first check, rejected packets do not
//! count as data, and the decisions depend only on the stamps passed in (two engines fed the
//! same calls give the same outputs), sharded or not.

use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::dynamics::BlockParams;
use rockwatch_core::engine::{
    AccelPacket, Engine, EngineConfig, HealthChange, Output, PbrSpec, ShardedEngine, StationId,
};

const T0_NS: i64 = 1_700_000_000_000_000_000;
const S: i64 = 1_000_000_000;

fn spec(id: &str, station: &str) -> PbrSpec {
    PbrSpec {
        id: rockwatch_core::engine::PbrId::parse(id).unwrap(),
        station: StationId::parse(station).unwrap(),
        azimuth: Azimuth::from_degrees(0.0).unwrap(),
        nominal: BlockParams::from_width_height(0.4, 2.0, 0.8, 0.6, None).unwrap(),
        members: vec![],
        more_directions: vec![],
        rock_3d: None,
        place: Default::default(),
    }
}

/// One second of quiet data (100 Hz) of `station`, packet `k`.
fn packet(station: &str, k: i64) -> AccelPacket {
    AccelPacket {
        station: rockwatch_core::engine::StationId::parse(station).unwrap(),
        start_time_ns: T0_NS + k * S,
        sample_rate_hz: 100.0,
        sequence: k as u64,
        east: vec![0.0; 100],
        north: vec![0.0; 100],
        up: vec![],
        unit: Default::default(),
    }
}

fn engine() -> Engine {
    let config = EngineConfig {
        stale_after_s: 10.0,
        ..EngineConfig::default()
    };
    let specs = [
        spec("a1", "XX.A.00"),
        spec("a2", "XX.A.00"),
        spec("b1", "XX.B.00"),
    ];
    Engine::new(config, vec![], &specs).unwrap()
}

fn changes(out: &[Output]) -> Vec<HealthChange> {
    out.iter()
        .filter_map(|o| match o {
            Output::Health(h) => Some(h.clone()),
            _ => None,
        })
        .collect()
}

#[test]
fn a_silent_station_goes_stale_once_and_recovers_on_its_next_packet() {
    let mut e = engine();
    let mut out = Vec::new();
    e.check_health(0, &mut out); // the health clock starts: B never sent
    for k in 0..5 {
        e.process(packet("XX.A.00", k), k * S, &mut out);
    }
    assert!(out.iter().all(|o| match o {
        Output::State(s) => !s.not_monitored,
        o => !matches!(o, Output::Health(_)),
    }));
    // A's last packet arrived at 4 s; the limit is 10 s: not stale at 14 s, stale after. (B,
    // never heard from, counts from the first check at 0 s: stale at 14 s already.)
    out.clear();
    e.check_health(14 * S, &mut out);
    let c = changes(&out);
    assert!(
        c.len() == 1 && c[0].station == "XX.B.00" && !c[0].monitored,
        "{out:?}"
    );
    out.clear();
    e.check_health(14 * S + 1, &mut out);
    let c = changes(&out);
    assert_eq!(c.len(), 1, "{out:?}");
    assert_eq!(
        c[0],
        HealthChange {
            station: rockwatch_core::engine::StationId::parse("XX.A.00").unwrap(),
            monitored: false,
            silent_ns: 10 * S + 1,
            blocks: 2,
        }
    );
    // Each of A's blocks: one state, flagged, stamped with the data time of A's last sample.
    let states: Vec<_> = out
        .iter()
        .filter_map(|o| match o {
            Output::State(s) => Some(s.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(
        states
            .iter()
            .map(|s| (s.pbr_id.as_str(), s.not_monitored))
            .collect::<Vec<_>>(),
        [("a1", true), ("a2", true)]
    );
    assert!(states
        .iter()
        .all(|s| s.data_time_ns == T0_NS + 4 * S + 99 * S / 100));
    assert!(!e.health()[0].monitored && e.health()[0].stale_events == 1);
    // Stale stays stale without further reports.
    out.clear();
    e.check_health(100 * S, &mut out);
    assert!(changes(&out).is_empty());
    // The next packet: recovery first, then the packet's own outputs.
    out.clear();
    e.process(packet("XX.A.00", 5), 120 * S, &mut out);
    let c = changes(&out);
    assert_eq!(c.len(), 1);
    assert!(c[0].monitored && c[0].silent_ns == 116 * S && c[0].blocks == 2);
    assert!(matches!(out[0], Output::Health(_)));
    assert_eq!(
        out[1..3]
            .iter()
            .map(|o| match o {
                Output::State(s) => (s.pbr_id.as_str(), s.not_monitored),
                o => panic!("{o:?}"),
            })
            .collect::<Vec<_>>(),
        [("a1", false), ("a2", false)]
    );
    let h = &e.health()[0];
    assert!(h.monitored && h.last_arrival_ns == Some(120 * S) && h.sample_rate_hz == 100.0);
    assert_eq!(h.last_sample_ns, Some(T0_NS + 5 * S + 99 * S / 100));
}

#[test]
fn a_station_never_heard_from_is_stale_after_the_limit_from_the_first_check() {
    let mut e = engine();
    let mut out = Vec::new();
    e.check_health(3 * S, &mut out);
    e.check_health(13 * S, &mut out);
    assert!(changes(&out).is_empty(), "exactly the limit: not yet");
    e.check_health(13 * S + 1, &mut out);
    let c = changes(&out);
    assert_eq!(c.len(), 2, "A and B, never heard from: {c:?}");
    assert!(c.iter().all(|h| !h.monitored && h.silent_ns == 10 * S + 1));
    let b = e
        .health()
        .into_iter()
        .find(|h| h.station == "XX.B.00")
        .unwrap();
    assert!(!b.monitored && b.last_arrival_ns.is_none() && b.packets == 0);
    // B's block: data time 0 (no data ever), flagged.
    assert!(out.iter().any(|o| matches!(o, Output::State(s)
        if s.pbr_id == "b1" && s.not_monitored && s.data_time_ns == 0)));
}

#[test]
fn rejected_packets_are_not_data() {
    let mut e = engine();
    let mut out = Vec::new();
    e.check_health(0, &mut out);
    e.process(packet("XX.A.00", 0), 0, &mut out);
    // NaN samples: rejected, counted; they do not keep the station alive.
    let mut bad = packet("XX.A.00", 1);
    bad.east[3] = f32::NAN;
    e.process(bad, 9 * S, &mut out);
    out.clear();
    e.check_health(10 * S + 1, &mut out);
    assert!(changes(&out)
        .iter()
        .any(|h| h.station == "XX.A.00" && !h.monitored));
    let h = &e.health()[0];
    assert_eq!((h.packets, h.rejected_packets), (1, 1));
    assert_eq!(h.last_arrival_ns, Some(0));
}

#[test]
fn health_decisions_depend_only_on_the_stamps_passed_in_inline_or_sharded() {
    let run = |e: &mut Engine| {
        let mut out = Vec::new();
        e.check_health(0, &mut out);
        for k in 0..3 {
            e.process(packet("XX.A.00", k), k * S, &mut out);
            e.process(packet("XX.B.00", k), k * S, &mut out);
        }
        e.check_health(12 * S + 1, &mut out);
        e.process(packet("XX.B.00", 3), 20 * S, &mut out);
        out
    };
    let (first, second) = (run(&mut engine()), run(&mut engine()));
    assert_eq!(first, second);
    assert_eq!(changes(&first).len(), 3); // A, B stale; B recovered
                                          // Sharded: the same health changes per station, through the workers' outputs.
    let config = EngineConfig {
        stale_after_s: 10.0,
        ..EngineConfig::default()
    };
    let specs = [
        spec("a1", "XX.A.00"),
        spec("a2", "XX.A.00"),
        spec("b1", "XX.B.00"),
    ];
    let sharded = ShardedEngine::start(config, &[], &specs, &[], 2).unwrap();
    sharded.check_health(0);
    for k in 0..3 {
        sharded.submit(packet("XX.A.00", k), k * S);
        sharded.submit(packet("XX.B.00", k), k * S);
    }
    sharded.check_health(12 * S + 1);
    sharded.submit(packet("XX.B.00", 3), 20 * S);
    sharded.report_health();
    let (_, rest) = sharded.shutdown();
    let mut got = changes(&rest);
    let mut want = changes(&first);
    got.sort_by(|a, b| (&a.station, a.monitored).cmp(&(&b.station, b.monitored)));
    want.sort_by(|a, b| (&a.station, a.monitored).cmp(&(&b.station, b.monitored)));
    assert_eq!(got, want);
    let reports: usize = rest
        .iter()
        .filter_map(|o| match o {
            Output::HealthReport(r) => Some(r.len()),
            _ => None,
        })
        .sum();
    assert_eq!(reports, 2, "one report per station, from its shard");
}

#[test]
fn stale_after_s_is_validated() {
    for bad in [0.0, -1.0, f64::NAN, 1e6] {
        let config = EngineConfig {
            stale_after_s: bad,
            ..EngineConfig::default()
        };
        let e = config.validate().unwrap_err().to_string();
        assert!(e.contains("engine.stale_after_s"), "{e}");
    }
}
