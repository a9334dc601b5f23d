//! The data the tests share: paths in the repository, THE loader of the bundled Rinaldi record
//! (in the forms the tests use), the engine tests' blocks and specs.

use std::path::{Path, PathBuf};

use rockwatch_core::azimuth::Azimuth;
use rockwatch_core::dynamics::BlockParams;
use rockwatch_core::engine::{PbrSpec, StationId};
use rockwatch_core::record::Record;

/// The repository's root directory.
#[must_use]
pub fn repo() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// The bundled records (AT2 files): `tests/data/records`.
#[must_use]
pub fn records_dir() -> PathBuf {
    repo().join("tests/data/records")
}

/// The Rinaldi record's horizontal component, along azimuth 228°.
pub const RINALDI_AT2: &str = "Rinaldi228.AT2";
/// The Rinaldi record's vertical component.
pub const RINALDI_UP_AT2: &str = "RinaldiUP.AT2";
/// The azimuth of the Rinaldi record's horizontal component (degrees from north): the axis of
/// the example catalogue's CI.RRS.00 blocks.
pub const RINALDI_AZIMUTH_DEG: f64 = 228.0;
/// The station the tests send the Rinaldi record as.
pub const RINALDI_STATION: &str = "CI.RRS.00";

/// The Rinaldi record's horizontal component (228°) alone.
#[must_use]
pub fn rinaldi_horizontal() -> Record {
    Record::read(&records_dir().join(RINALDI_AT2)).expect("the bundled Rinaldi228.AT2 reads")
}

/// The Rinaldi record: horizontal (228°) and vertical components.
#[must_use]
pub fn rinaldi() -> Record {
    let mut record = rinaldi_horizontal();
    record
        .attach_vertical(&records_dir().join(RINALDI_UP_AT2))
        .expect("the bundled RinaldiUP.AT2 is Rinaldi228.AT2's vertical");
    record
}

/// The azimuth of [`rinaldi`]'s horizontal component ([`RINALDI_AZIMUTH_DEG`]).
#[must_use]
pub fn rinaldi_azimuth() -> Azimuth {
    Azimuth::from_degrees(RINALDI_AZIMUTH_DEG).expect("228° is an azimuth")
}

/// [`RINALDI_STATION`], parsed.
#[must_use]
pub fn rinaldi_station() -> StationId {
    StationId::parse(RINALDI_STATION).expect("CI.RRS.00 is a station id")
}

/// The Rinaldi 228° record with its samples rounded to f32: packets carry f32 samples, so the
/// engine is compared against the simulator on the same rounded values.
#[must_use]
pub fn rinaldi_f32() -> Record {
    let mut r = rinaldi_horizontal();
    r.horizontal_mps2
        .iter_mut()
        .for_each(|a| *a = f64::from(*a as f32));
    r
}

/// Start time of the first packet of the engine tests (ns since 1970).
pub const T0_NS: i64 = 1_700_000_000_000_000_000;

/// Block `id` on `station`, rocking in the vertical plane of azimuth `azimuth_deg`.
#[must_use]
pub fn spec(id: &str, station: &str, azimuth_deg: f64, p: BlockParams) -> PbrSpec {
    PbrSpec {
        id: rockwatch_core::engine::PbrId::parse(id).unwrap(),
        station: StationId::parse(station).expect("a test station id"),
        azimuth: Azimuth::from_degrees(azimuth_deg).expect("a test azimuth"),
        nominal: p,
        members: vec![],
        more_directions: vec![],
        rock_3d: None,
        place: Default::default(),
    }
}

/// A 0.4 m × 2 m block (μs 0.8, μk 0.6): it topples under Rinaldi.
#[must_use]
pub fn slender() -> BlockParams {
    BlockParams::from_width_height(0.4, 2.0, 0.8, 0.6, None).expect("a valid block")
}

/// A 1.2 m × 2 m block (μs 0.8, μk 0.6): it does not topple under Rinaldi.
#[must_use]
pub fn stocky() -> BlockParams {
    BlockParams::from_width_height(1.2, 2.0, 0.8, 0.6, None).expect("a valid block")
}

/// A node configuration (TOML) with `catalogue` and loopback-only ROS 2.
pub fn write_node_config(dir: &Path, catalogue: &Path) -> PathBuf {
    let path = dir.join("node.toml");
    std::fs::write(
        &path,
        format!(
            "catalogue = \"{}\"\n[ros2]\ndiscovery_range = \"LOCALHOST\"\n",
            catalogue.display()
        ),
    )
    .expect("write the node configuration");
    path
}
