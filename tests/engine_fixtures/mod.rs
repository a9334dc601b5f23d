//! Fixtures shared by the engine's tests (`tests/engine.rs`, `tests/engine_reload.rs`): the
//! Rinaldi record rounded as packets carry it, the two test blocks, and a block spec.

#![allow(dead_code)] // each test crate uses a different subset

use std::path::Path;

use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::dynamics::BlockParams;
use rockwatch_core::engine::{PbrSpec, StationId};
use rockwatch_core::record::Record;

/// Start time of the first packet (ns since 1970).
pub const T0_NS: i64 = 1_700_000_000_000_000_000;

/// The Rinaldi 228° record with its samples rounded to f32: packets carry f32 samples, so the
/// engine is compared against the simulator on the same rounded values.
pub fn rinaldi_f32() -> Record {
    let mut r = Record::read(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/records/Rinaldi228.AT2"
    )))
    .unwrap();
    r.horizontal_mps2
        .iter_mut()
        .for_each(|a| *a = f64::from(*a as f32));
    r
}

/// Block `id` on `station`, rocking in the vertical plane of azimuth `azimuth_deg`.
pub fn spec(id: &str, station: &str, azimuth_deg: f64, p: BlockParams) -> PbrSpec {
    PbrSpec {
        id: rockwatch_core::engine::PbrId::parse(id).unwrap(),
        station: StationId::parse(station).unwrap(),
        azimuth: Azimuth::from_degrees(azimuth_deg).unwrap(),
        nominal: p,
        members: vec![],
        more_directions: vec![],
        rock_3d: None,
        place: Default::default(),
    }
}

/// A 0.4 m × 2 m block (μs 0.8, μk 0.6): it topples under Rinaldi.
pub fn slender() -> BlockParams {
    BlockParams::from_width_height(0.4, 2.0, 0.8, 0.6, None).unwrap()
}

/// A 1.2 m × 2 m block (μs 0.8, μk 0.6): it does not topple under Rinaldi.
pub fn stocky() -> BlockParams {
    BlockParams::from_width_height(1.2, 2.0, 0.8, 0.6, None).unwrap()
}
