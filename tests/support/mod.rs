//! Fixtures shared by the integration tests.

use std::path::Path;

use rockwatch::replay::Traces;
use rockwatch_core::engine::{AccelPacket, StationId};
use rockwatch_core::record::Record;

/// The bundled Rinaldi record (228° + vertical) as station CI.RRS.00 would send it: 100 ms
/// packets, horizontal along azimuth 228° (the axis of the example catalogue's CI.RRS.00
/// blocks), followed by 10 s of quiet.
pub fn rinaldi_packets() -> Vec<AccelPacket> {
    let mut record = Record::read(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/records/Rinaldi228.AT2"
    )))
    .unwrap();
    record
        .attach_vertical(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/records/RinaldiUP.AT2"
        )))
        .unwrap();
    let station = StationId::parse("CI.RRS.00").unwrap();
    let azimuth = rockwatch_core::azimuth::Azimuth::from_degrees(228.0).unwrap();
    Traces::from_record(&record, azimuth).packets(&station, 100, 10.0)
}
