//! StationXML inventories (`rockwatch_core::inventory`) on real web-service documents
//! (tests/data/stationxml, see its README) and on documents written by ObsPy, compared with
//! ObsPy's own reading of the same files (an independent parser), plus hand-checked values
//! from the documents' text.

use rockwatch_test_harness::peers;

use std::path::{Path, PathBuf};

use rockwatch_core::inventory::{Inventory, LookupError, Unusable};
use rockwatch_core::utc::parse_utc_ns;

fn data(name: &str) -> PathBuf {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/stationxml"
    ))
    .join(name)
}

const REAL_DOCUMENTS: [&str; 8] = [
    "ingv_MN_level-channel.xml",
    "ingv_IX.AND3_level-response.xml",
    "ingv_IT.CMA_level-response.xml",
    "gmprocess_CI.MIKB_level-channel.xml",
    "gmprocess_CI.GR2_level-response.xml",
    "obspy_IRIS_single_channel_with_response.xml",
    "obspy_stationxml_IU.ANTO.30.LDO.xml",
    "obspy_no_default_namespace.xml",
];

fn t(iso: &str) -> i128 {
    parse_utc_ns(iso).unwrap()
}

fn read(name: &str) -> Inventory {
    Inventory::read(&data(name)).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn every_real_document_parses_with_the_expected_number_of_epochs() {
    // Counts of <Channel> elements, from the README (151 + 9 for MN; 48 for MIKB; …).
    let expected = [160, 6, 3, 48, 6, 1, 1, 0];
    for (name, n) in REAL_DOCUMENTS.iter().zip(expected) {
        assert_eq!(read(name).channels.len(), n, "{name}");
    }
}

#[test]
fn accelerometer_epochs_are_chosen_by_time_and_give_the_inverse_sensitivity() {
    let mn = read("ingv_MN_level-channel.xml");
    // HNZ from 2019-03-01, open-ended, 427693 counts per M/S**2 at 0.2 Hz.
    let hnz = mn.epoch_at("MN.AQU..HNZ", t("2020-01-01")).unwrap();
    let s = hnz.sensitivity.as_ref().unwrap();
    assert_eq!(
        (s.value, s.frequency_hz, s.input_units.as_str()),
        (427693.0, Some(0.2), "M/S**2")
    );
    assert_eq!(hnz.end_ns, None);
    assert_eq!(
        (hnz.azimuth_deg, hnz.dip_deg, hnz.sample_rate_hz),
        (Some(0.0), Some(-90.0), Some(100.0))
    );
    let cal = mn
        .calibration_at("MN.AQU..HNZ", t("2020-01-01"), 100.0)
        .unwrap();
    assert_eq!(cal.gain_mps2_per_count, 1.0 / 427693.0);
    // HLE: first epoch 534331, second (from the boundary instant on, half-open) 530244.
    let first = mn.epoch_at("MN.AQU..HLE", t("2009-06-01")).unwrap();
    assert_eq!(first.sensitivity.as_ref().unwrap().value, 534331.0);
    let second = mn
        .epoch_at("MN.AQU..HLE", t("2011-04-13T00:00:00"))
        .unwrap();
    assert_eq!(second.sensitivity.as_ref().unwrap().value, 530244.0);
    // The 2017-12-31 … 2019-03-01 gap: no epoch; a code never seen: unknown.
    let e = mn
        .calibration_at("MN.AQU..HLE", t("2018-06-01"), 100.0)
        .unwrap_err();
    assert!(matches!(e, LookupError::NoEpoch { .. }), "{e}");
    let e = mn
        .calibration_at("MN.AQU..HNX", t("2020-01-01"), 100.0)
        .unwrap_err();
    assert_eq!(e.to_string(), "channel MN.AQU..HNX is not in the inventory");
    // A record at another rate than the inventory's is refused.
    let e = mn
        .calibration_at("MN.AQU..HNZ", t("2020-01-01"), 200.0)
        .unwrap_err();
    assert!(matches!(e, LookupError::RateMismatch { .. }), "{e}");
}

#[test]
fn velocity_and_non_seismic_channels_are_unusable_with_a_reason() {
    let mn = read("ingv_MN_level-channel.xml");
    let e = mn
        .calibration_at("MN.AQU..BHZ", t("2020-01-01"), 20.0)
        .unwrap_err();
    match &e {
        LookupError::Unusable { reason, .. } => {
            assert!(matches!(reason, Unusable::Velocity { .. }), "{e}")
        }
        other => panic!("{other}"),
    }
    assert!(e.to_string().contains("velocity channel (M/S)"), "{e}");
    let anto = read("obspy_stationxml_IU.ANTO.30.LDO.xml");
    assert_eq!(
        anto.channels[0].calibration().unwrap_err(),
        Unusable::NoSensitivity
    );
    let iris = read("obspy_IRIS_single_channel_with_response.xml");
    // Two <Type> elements do not matter; the channel is a velocity one.
    assert!(matches!(
        iris.channels[0].calibration(),
        Err(Unusable::Velocity { .. })
    ));
}

#[test]
fn quirks_of_real_services_are_handled() {
    // nm/s**2 input units: 0.000106955 counts per nm/s² is 1e-9/0.000106955 m/s² per count;
    // COUNTS<!-- HARDWIRED--> as output units; endDate 2599 beyond i64 nanoseconds.
    let cma = read("ingv_IT.CMA_level-response.xml");
    let hgz = cma.epoch_at("IT.CMA..HGZ", t("2020-01-01")).unwrap();
    assert_eq!(
        hgz.sensitivity.as_ref().unwrap().output_units.as_deref(),
        Some("COUNTS")
    );
    assert_eq!(hgz.gain_mps2_per_count().unwrap(), 1e-9 / 0.000106955);
    assert_eq!(hgz.end_ns, Some(t("2599-12-31T23:59:59.999")));
    // ISO-8859-1, SampleRate "2E02", lowercase units, 0–2 <Type> per epoch.
    let mikb = read("gmprocess_CI.MIKB_level-channel.xml");
    let hnz = mikb
        .calibration_at("CI.MIKB..HNZ", t("2020-06-01"), 200.0)
        .unwrap();
    assert!(
        (hnz.gain_mps2_per_count * 213551.0 - 1.0).abs() < 1e-3,
        "{hnz:?}"
    );
    // Co-located borehole accelerometer (loc 01) and broadband (loc "") at CI.GR2.
    let gr2 = read("gmprocess_CI.GR2_level-response.xml");
    assert!(gr2
        .calibration_at("CI.GR2.01.HNE", t("2019-01-01"), 100.0)
        .is_ok());
    assert!(gr2
        .calibration_at("CI.GR2..BHE", t("2019-01-01"), 40.0)
        .is_err());
    // Latin-1 + CRLF document: the station is read.
    let anto = read("obspy_stationxml_IU.ANTO.30.LDO.xml");
    assert_eq!(anto.channels[0].id(), "IU.ANTO.30.LDO");
}

#[test]
fn documents_that_are_not_stationxml_are_refused_naming_the_document() {
    let e = Inventory::parse("x.xml", b"<a/>").unwrap_err();
    assert!(
        e.to_string().starts_with("x.xml: not FDSN StationXML"),
        "{e}"
    );
    let e = Inventory::parse("y.xml", b"<FDSNStationXML").unwrap_err();
    assert!(
        e.to_string().starts_with("y.xml: not well-formed XML"),
        "{e}"
    );
    let e = Inventory::parse(
        "z.xml",
        b"<FDSNStationXML xmlns='http://www.fdsn.org/xml/station/2'/>",
    )
    .unwrap_err();
    assert!(e.to_string().contains("not FDSN StationXML"), "{e}");
    let e = Inventory::read(Path::new("/nonexistent.xml")).unwrap_err();
    assert!(
        e.to_string().starts_with("/nonexistent.xml: cannot read"),
        "{e}"
    );
}

// ---------------------------------------------------------------------------------------
// ObsPy as the independent reader (and writer): `pip install obspy`
// ---------------------------------------------------------------------------------------

/// `write OUT`: writes an inventory with known channels (validate=True), then dumps it;
/// `dump FILE…`: dumps the channel epochs ObsPy reads.
const OBSPY_SCRIPT: &str = r#"
import json, sys
import obspy
from obspy.core.inventory import (Inventory, Network, Station, Channel, Response,
                                  InstrumentSensitivity)
from obspy import UTCDateTime as T

def channel(code, loc, az, dip, rate, sens, units, start, end=None, freq=1.0):
    resp = Response(instrument_sensitivity=InstrumentSensitivity(
        value=sens, frequency=freq, input_units=units, output_units="COUNTS"))
    return Channel(code=code, location_code=loc, latitude=34.0, longitude=-118.0,
                   elevation=100.0, depth=0.0, azimuth=az, dip=dip, sample_rate=rate,
                   start_date=T(start), end_date=None if end is None else T(end),
                   response=resp, types=["CONTINUOUS", "GEOPHYSICAL"])

def dump(paths):
    out = []
    for path in paths:
        for net in obspy.read_inventory(path):
            for sta in net:
                for ch in sta:
                    s = ch.response.instrument_sensitivity if ch.response else None
                    out.append({
                        "id": "%s.%s.%s.%s" % (net.code, sta.code, ch.location_code, ch.code),
                        "start_ns": ch.start_date.ns if ch.start_date else None,
                        "end_ns": ch.end_date.ns if ch.end_date else None,
                        "rate": ch.sample_rate, "az": ch.azimuth, "dip": ch.dip,
                        "sens": None if s is None or s.value is None else s.value,
                        "freq": None if s is None else s.frequency,
                        "units": None if s is None else s.input_units,
                    })
    print(json.dumps(out))

if sys.argv[1] == "write":
    chans = [
        channel("HNE", "00", 90.0, 0.0, 100.0, 4.0e5, "M/S**2", "2020-01-01"),
        channel("HNN", "00", 0.0, 0.0, 100.0, -4.1e5, "m/s**2", "2020-01-01"),
        channel("HNZ", "00", 0.0, -90.0, 100.0, 4.2e5, "M/S2", "2020-01-01"),
        channel("HN1", "10", 12.5, 1.5, 200.0, 2.0e5, "M/S**2", "2019-01-01", "2021-06-01T12:00:00.5"),
        channel("HN1", "10", 17.0, 0.0, 200.0, 2.5e5, "M/S**2", "2021-06-01T12:00:00.5"),
        channel("HHZ", "20", 0.0, -90.0, 100.0, 6.2e8, "M/S", "2020-01-01"),
        channel("HGZ", "30", 0.0, -90.0, 100.0, 1.0e-4, "nm/s**2", "2020-01-01"),
    ]
    inv = Inventory(networks=[Network("XX", stations=[Station("RW", 34.0, -118.0, 100.0,
                    channels=chans)])], source="rockwatch test")
    inv.write(sys.argv[2], format="STATIONXML", validate=True)
    dump([sys.argv[2]])
else:
    dump(sys.argv[2:])
"#;

fn obspy(args: &[&str]) -> Option<Vec<serde_json::Value>> {
    peers::run_obspy(OBSPY_SCRIPT, args).map(|out| serde_json::from_slice(&out).unwrap())
}

/// Our epochs equal ObsPy's, field by field (numbers exactly: both parse the same decimal
/// text to the nearest f64).
fn assert_same_as_obspy(ours: &Inventory, theirs: &[serde_json::Value]) {
    assert_eq!(ours.channels.len(), theirs.len());
    for (c, o) in ours.channels.iter().zip(theirs) {
        let id = c.id();
        assert_eq!(id, o["id"], "{id}");
        let ns = |v: &serde_json::Value| v.as_i64().map(i128::from);
        assert_eq!(
            c.start_ns.filter(|&s| s <= i128::from(i64::MAX)),
            ns(&o["start_ns"]),
            "{id}"
        );
        // ObsPy's ns for dates past 2262 are Python ints beyond i64: compare those as f64.
        match (c.end_ns, o["end_ns"].as_f64()) {
            (Some(ours), Some(theirs)) => assert!((ours as f64 - theirs).abs() <= 1e3, "{id}"),
            (ours, theirs) => assert_eq!(ours.is_some(), theirs.is_some(), "{id}"),
        }
        assert_eq!(c.sample_rate_hz, o["rate"].as_f64(), "{id}");
        assert_eq!(c.azimuth_deg, o["az"].as_f64(), "{id}");
        assert_eq!(c.dip_deg, o["dip"].as_f64(), "{id}");
        let s = c.sensitivity.as_ref();
        assert_eq!(s.map(|s| s.value), o["sens"].as_f64(), "{id}");
        if let Some(s) = s {
            assert_eq!(s.frequency_hz, o["freq"].as_f64(), "{id}");
            assert_eq!(Some(s.input_units.as_str()), o["units"].as_str(), "{id}");
        }
    }
}

#[test]
fn real_documents_read_the_same_as_obspy_reads_them() {
    for name in REAL_DOCUMENTS {
        let path = data(name);
        let Some(theirs) = obspy(&["dump", path.to_str().unwrap()]) else {
            return;
        };
        assert_same_as_obspy(&read(name), &theirs);
    }
}

#[test]
fn documents_written_by_obspy_read_back_with_their_values_and_usability() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("obspy.xml");
    let Some(theirs) = obspy(&["write", path.to_str().unwrap()]) else {
        return;
    };
    let inv = Inventory::read(&path).unwrap();
    assert_same_as_obspy(&inv, &theirs);
    // Negative sensitivity: reversed polarity, a negative gain.
    let hnn = inv
        .calibration_at("XX.RW.00.HNN", t("2020-02-01"), 100.0)
        .unwrap();
    assert_eq!(hnn.gain_mps2_per_count, -1.0 / 4.1e5);
    // Two epochs of HN1: the boundary (half-open) belongs to the second.
    let before = inv
        .calibration_at("XX.RW.10.HN1", t("2021-06-01T12:00:00.499"), 200.0)
        .unwrap();
    let after = inv
        .calibration_at("XX.RW.10.HN1", t("2021-06-01T12:00:00.5"), 200.0)
        .unwrap();
    assert_eq!(
        (before.axis.dip_deg(), after.axis.azimuth().degrees()),
        (1.5, 17.0)
    );
    assert!(inv
        .calibration_at("XX.RW.20.HHZ", t("2021-01-01"), 100.0)
        .is_err());
    let hgz = inv
        .calibration_at("XX.RW.30.HGZ", t("2021-01-01"), 100.0)
        .unwrap();
    assert_eq!(hgz.gain_mps2_per_count, 1e-9 / 1e-4);
}
