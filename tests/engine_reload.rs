//! `Engine::reload` (the node's SIGHUP) against two independent references:
//! - a reload of the same configuration mid-record is invisible: every output, bit for bit,
//!   equals that of an engine never reloaded (every block's state, every station's stream and
//!   running measures carried over);
//! - a block added mid-record starts at rest at the instant of the station's last sample and
//!   then follows `simulate` (the offline driver) on the rest of the record exactly;
//! - a changed block starts at rest, a removed one is dropped, and a bad configuration changes
//!   nothing.

use rockwatch_test_harness::fixtures::{rinaldi_f32, slender, spec, stocky, T0_NS};

use rockwatch_core::engine::{AccelPacket, Engine, EngineConfig, Output, PbrSpec, ReloadReport};
use rockwatch_core::record::Record;
use rockwatch_core::simulate::{simulate, SimulationOptions};

/// Samples per packet.
const LEN: usize = 100;

/// The record as packets of `LEN` samples for `station` (east = the record, north = half of it).
fn packets(station: &str, record: &Record) -> Vec<AccelPacket> {
    let east = &record.horizontal_mps2;
    east.chunks(LEN)
        .enumerate()
        .map(|(i, e)| AccelPacket {
            station: rockwatch_core::engine::StationId::parse(station).unwrap(),
            start_time_ns: T0_NS + (i * LEN) as i64 * (record.dt_s * 1e9).round() as i64,
            sample_rate_hz: 1.0 / record.dt_s,
            sequence: i as u64,
            east: e.iter().map(|&v| v as f32).collect(),
            north: e.iter().map(|&v| (0.5 * v) as f32).collect(),
            up: vec![],
            unit: Default::default(),
        })
        .collect()
}

/// Both stations' packets, interleaved.
fn both(record: &Record) -> Vec<AccelPacket> {
    let a = packets("CI.RRS.00", record);
    let b = packets("CI.SYL.00", record);
    a.into_iter().zip(b).flat_map(|(x, y)| [x, y]).collect()
}

fn blocks() -> Vec<PbrSpec> {
    vec![
        spec("rrs-slender", "CI.RRS.00", 228.0, slender()),
        spec("rrs-stocky", "CI.RRS.00", 10.0, stocky()),
        spec("syl-slender", "CI.SYL.00", 90.0, slender()),
    ]
}

#[test]
fn a_reload_of_the_same_configuration_mid_record_changes_no_output() {
    let record = rinaldi_f32();
    let packets = both(&record);
    let mut reference = Engine::new(EngineConfig::default(), vec![], &blocks()).unwrap();
    let mut expected = Vec::new();
    for p in packets.clone() {
        reference.process(p, 0, &mut expected);
    }
    reference.flush(0, &mut expected);

    // Reload at several points: before the shaking, in it (blocks rocking), at its end.
    for at in [3, packets.len() / 3, packets.len() / 2, packets.len() - 2] {
        let mut engine = Engine::new(EngineConfig::default(), vec![], &blocks()).unwrap();
        let mut got: Vec<Output> = Vec::new();
        for (i, p) in packets.clone().into_iter().enumerate() {
            if i == at {
                let report = engine
                    .reload(EngineConfig::default(), vec![], &blocks())
                    .unwrap();
                assert_eq!(
                    report,
                    ReloadReport {
                        kept: ["rrs-slender", "rrs-stocky", "syl-slender"]
                            .map(|id| rockwatch_core::engine::PbrId::parse(id).unwrap())
                            .to_vec(),
                        ..ReloadReport::default()
                    }
                );
            }
            engine.process(p, 0, &mut got);
        }
        engine.flush(0, &mut got);
        assert_eq!(
            format!("{got:?}"),
            format!("{expected:?}"),
            "reload at {at}"
        );
        assert_eq!(
            format!("{:?}", engine.summaries()),
            format!("{:?}", reference.summaries())
        );
        assert_eq!(engine.counters(), reference.counters());
    }
}

#[test]
fn a_block_added_mid_record_starts_at_rest_and_follows_simulate_on_the_rest_of_it() {
    let record = rinaldi_f32();
    let packets = packets("CI.RRS.00", &record);
    let options = SimulationOptions {
        t_extra_s: 0.0,
        ..SimulationOptions::default()
    };
    let before = vec![spec("stocky", "CI.RRS.00", 90.0, stocky())];
    let mut after = before.clone();
    after.push(spec("new", "CI.RRS.00", 90.0, slender()));
    for k in [1, 3, 5, 12] {
        let mut engine = Engine::new(EngineConfig::default(), vec![], &before).unwrap();
        let mut out = Vec::new();
        for (i, p) in packets.clone().into_iter().enumerate() {
            if i == k {
                let report = engine
                    .reload(EngineConfig::default(), vec![], &after)
                    .unwrap();
                assert_eq!(report.kept, ["stocky"]);
                assert_eq!(report.added, ["new"]);
            }
            engine.process(p, 0, &mut out);
        }
        engine.flush(0, &mut out);
        // The new block starts at rest at the station's last sample before the reload
        // (index k·LEN − 1): the offline driver on the record from there.
        let tail = Record {
            source: "tail".into(),
            dt_s: record.dt_s,
            horizontal_mps2: record.horizontal_mps2[k * LEN - 1..].to_vec(),
            vertical_mps2: None,
        };
        let expected = simulate(slender(), &tail, &options).unwrap().summary;
        let got = engine
            .summaries()
            .into_iter()
            .find(|s| s.pbr_id == "new")
            .unwrap();
        if k == 1 {
            // Added before the strong motion: the comparison covers rocking, not rest only.
            assert!(expected.max_abs_theta_over_alpha > 0.1, "{expected:?}");
        }
        assert_eq!(got.overturned, expected.overturned, "k {k}");
        assert_eq!(
            got.max_theta_over_alpha, expected.max_abs_theta_over_alpha,
            "k {k}"
        );
        assert_eq!(got.max_slide_m, expected.max_abs_slide, "k {k}");
        // The kept block is the block of an engine never reloaded.
        let mut reference = Engine::new(EngineConfig::default(), vec![], &before).unwrap();
        let mut ignored = Vec::new();
        for p in packets.clone() {
            reference.process(p, 0, &mut ignored);
        }
        reference.flush(0, &mut ignored);
        assert_eq!(
            format!(
                "{:?}",
                engine.summaries().iter().find(|s| s.pbr_id == "stocky")
            ),
            format!("{:?}", reference.summaries().first())
        );
    }
}

#[test]
fn changed_blocks_restart_removed_ones_go_and_a_bad_configuration_changes_nothing() {
    let record = rinaldi_f32();
    let packets = both(&record);
    let mut engine = Engine::new(EngineConfig::default(), vec![], &blocks()).unwrap();
    let mut out = Vec::new();
    for p in packets.iter().take(packets.len() / 2).cloned() {
        engine.process(p, 0, &mut out);
    }
    let before = format!("{:?}", engine.summaries());
    // Invalid: refused, nothing changed.
    let mut bad = EngineConfig::default();
    bad.alerts.imminent_theta_ratio = 1.5;
    assert!(engine.reload(bad, vec![], &blocks()).is_err());
    assert_eq!(format!("{:?}", engine.summaries()), before);
    // rrs-stocky gets another body, syl-slender is removed.
    let changed = vec![
        spec("rrs-slender", "CI.RRS.00", 228.0, slender()),
        spec("rrs-stocky", "CI.RRS.00", 10.0, slender()),
    ];
    let report = engine
        .reload(EngineConfig::default(), vec![], &changed)
        .unwrap();
    assert_eq!(report.kept, ["rrs-slender"]);
    assert_eq!(report.replaced, ["rrs-stocky"]);
    assert_eq!(report.dropped, ["syl-slender"]);
    assert!(report.added.is_empty());
    let summaries = engine.summaries();
    assert_eq!(summaries.len(), 2);
    let stocky = summaries.iter().find(|s| s.pbr_id == "rrs-stocky").unwrap();
    assert_eq!(
        stocky.max_theta_over_alpha, 0.0,
        "at rest again: {stocky:?}"
    );
}
