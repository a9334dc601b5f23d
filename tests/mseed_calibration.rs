//! MiniSEED counts calibrated with StationXML (`--stationxml` of `monitor` and `ims`,
//! `rockwatch::replay::Traces::from_mseed`): refused without a gain, equal to the
//! physical-unit files of tests/data/mseed with the inventories of tests/data/stationxml
//! (written by ObsPy, see generate/inventories.py), and calibrated + rotated like ObsPy's
//! `remove_sensitivity` + `rotate("->ZNE", inventory=…)` for tilted, non-orthogonal axes.

use rockwatch_test_harness::peers;
use rockwatch_test_harness::rockwatch_bin;

use std::path::{Path, PathBuf};
use std::process::Output;

use rockwatch::node_config::NodeConfig;
use rockwatch::replay::{MseedCalibration, Traces};
use rockwatch_core::engine::StationId;
use rockwatch_core::inventory::Inventory;

fn data(rel: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data")).join(rel)
}

/// A catalogue with one very slender block (B/H = 0.005) on XX.STN., so the K2 record's
/// ~0.05 m/s² rocks it: a wrong gain or axis would change its alerts and θ/α.
fn stn_catalogue(dir: &Path) -> PathBuf {
    let path = dir.join("catalogue.toml");
    std::fs::write(
        &path,
        "[[pbr]]\nid = \"stn-needle\"\nname = \"test needle\"\nlat = 50.47\nlon = 4.279\n\
         station = \"XX.STN.\"\nazimuth_deg = 90.0\nwidth_m = 0.05\nheight_m = 10.0\n\
         mu_s = 0.7\nmu_k = 0.55\nsource = \"test\"\n",
    )
    .unwrap();
    path
}

fn monitor(catalogue: &Path, mseed: &str, extra: &[&str]) -> Output {
    let (catalogue, mseed) = (catalogue.to_str().unwrap(), data(mseed));
    let mut args = vec![
        "monitor",
        "--catalogue",
        catalogue,
        "--mseed",
        mseed.to_str().unwrap(),
        "--station",
        "XX.STN.",
        "--format",
        "jsonl",
    ];
    args.extend(extra);
    rockwatch_bin!().output(&args)
}

/// JSON lines without the wall-clock field `latency_us`.
fn lines_without_latency(out: &Output) -> Vec<serde_json::Value> {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            v.as_object_mut().unwrap().remove("latency_us");
            v
        })
        .collect()
}

#[test]
fn integer_counts_without_a_gain_are_a_one_line_error_naming_the_channel() {
    let dir = tempfile::tempdir().unwrap();
    let out = monitor(
        &stn_catalogue(dir.path()),
        "mseed/k2_STNA_HN123_counts.mseed",
        &[],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with("rockwatch: error: ")
            && stderr.contains("channel XX.STN..HN1 holds integer counts and no gain is known"),
        "{stderr}"
    );
    // Nothing was reported (formerly: a false overturn with PGA 29766 m/s²).
    assert!(out.stdout.is_empty());
    let out = rockwatch_bin!().output(&[
        "ims",
        "--record",
        data("mseed/knet_AKT013_HNE_counts.mseed").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        (out.status.code(), stderr.lines().count()),
        (Some(1), 1),
        "{stderr}"
    );
    assert!(
        stderr.contains("BO.AKT01..HNE") && stderr.contains("--stationxml"),
        "{stderr}"
    );
}

#[test]
fn counts_with_stationxml_monitor_like_the_m_s2_file() {
    // k2_STNA_HN123_ms2_float32.mseed holds counts × ObsPy's calib; the inventory's
    // sensitivities are 1/calib and its axes put HN1 east, HN2 north, HN3 up (the order the
    // float file is read in). Packets carry f32, so the two runs see the same numbers up to
    // 1 ulp of f32 in a few samples: alerts and summaries agree to 1e-5 relative.
    let dir = tempfile::tempdir().unwrap();
    let catalogue = stn_catalogue(dir.path());
    let xml = data("stationxml/obspy_XX.STN_k2.xml");
    let ours = lines_without_latency(&monitor(
        &catalogue,
        "mseed/k2_STNA_HN123_counts.mseed",
        &["--stationxml", xml.to_str().unwrap()],
    ));
    let reference = lines_without_latency(&monitor(
        &catalogue,
        "mseed/k2_STNA_HN123_ms2_float32.mseed",
        &[],
    ));
    assert!(ours.iter().any(|l| l["type"] == "alert"), "{ours:?}");
    assert_eq!(ours.len(), reference.len());
    for (a, b) in ours.iter().zip(&reference) {
        assert_json_close(a, b, 1e-5);
    }
    // Gain or orientation in the configuration as well as --stationxml: refused.
    let config = dir.path().join("node.toml");
    std::fs::write(
        &config,
        "[[station]]\nid = \"XX.STN.\"\ngain_mps2_per_count = 1e-6\n",
    )
    .unwrap();
    let out = monitor(
        &catalogue,
        "mseed/k2_STNA_HN123_counts.mseed",
        &[
            "--stationxml",
            xml.to_str().unwrap(),
            "--config",
            config.to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("must not set gain_mps2_per_count"),
        "{stderr}"
    );
}

fn assert_json_close(a: &serde_json::Value, b: &serde_json::Value, rel: f64) {
    match (a, b) {
        (serde_json::Value::Number(x), serde_json::Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!((x - y).abs() <= rel * x.abs().max(y.abs()), "{x} vs {y}");
        }
        (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
            assert_eq!(x.keys().collect::<Vec<_>>(), y.keys().collect::<Vec<_>>());
            for (k, v) in x {
                assert_json_close(v, &y[k], rel);
            }
        }
        (serde_json::Value::Array(x), serde_json::Value::Array(y)) => {
            assert_eq!(x.len(), y.len());
            x.iter()
                .zip(y)
                .for_each(|(v, w)| assert_json_close(v, w, rel));
        }
        _ => assert_eq!(a, b),
    }
}

#[test]
fn ims_of_counts_with_stationxml_equal_those_of_the_m_s2_file() {
    let ims = |args: &[&str]| {
        let out = rockwatch_bin!().output(&[&["ims", "--format", "json"], args].concat());
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let counts = data("mseed/knet_AKT013_HNE_counts.mseed");
    let xml = data("stationxml/obspy_BO.AKT01_knet.xml");
    let ours = ims(&[
        "--record",
        counts.to_str().unwrap(),
        "--stationxml",
        xml.to_str().unwrap(),
    ]);
    let reference = ims(&[
        "--record",
        data("mseed/knet_AKT013_HNE_ms2.mseed").to_str().unwrap(),
    ]);
    // The gain goes through the XML as 1/calib and back (1 ulp), and FLOAT64 in the file:
    // 1e-12 relative.
    assert_json_close(&ours, &reference, 1e-12);
}

// ---------------------------------------------------------------------------------------
// ObsPy as the independent reference: `pip install obspy`
// ---------------------------------------------------------------------------------------

/// Writes a tilted, non-orthogonal inventory for XX.STN (one negative sensitivity) to
/// argv[1], then prints ObsPy's remove_sensitivity + rotate("->ZNE") of argv[2].
const OBSPY_ROTATE: &str = r#"
import json, sys
import obspy
from obspy.core.inventory import (Inventory, Network, Station, Channel, Response,
                                  InstrumentSensitivity, ResponseStage)
from obspy import UTCDateTime as T
AXES = [("HN1", 20.0, 3.0, 8.6e5), ("HN2", 112.0, -4.0, -8.5e5), ("HN3", 30.0, -84.0, 8.4e5)]
chans = [Channel(code=c, location_code="", latitude=50.47, longitude=4.279, elevation=144.0,
                 depth=0.0, azimuth=az, dip=dip, sample_rate=250.0, start_date=T("2002-01-01"),
                 response=Response(instrument_sensitivity=InstrumentSensitivity(
                     value=s, frequency=1.0, input_units="M/S**2", output_units="COUNTS"),
                     # remove_sensitivity looks at the first stage: one gain-only stage.
                     response_stages=[ResponseStage(1, s, 1.0, "M/S**2", "COUNTS")]))
         for c, az, dip, s in AXES]
inv = Inventory(networks=[Network("XX", stations=[Station("STN", 50.47, 4.279, 144.0,
                channels=chans)])], source="rockwatch test")
inv.write(sys.argv[1], format="STATIONXML", validate=True)
st = obspy.read(sys.argv[2])
st.remove_sensitivity(inv)
st.rotate("->ZNE", inventory=inv)
out = {tr.stats.channel[-1]: {"start_ns": tr.stats.starttime.ns, "data": tr.data.tolist()}
       for tr in st}
print(json.dumps(out))
"#;

#[test]
fn calibration_and_rotation_agree_with_obspy_to_1e_6() {
    let dir = tempfile::tempdir().unwrap();
    let xml = dir.path().join("tilted.xml");
    let counts = data("mseed/k2_STNA_HN123_counts.mseed");
    let Some(stdout) = peers::run_obspy(
        OBSPY_ROTATE,
        &[xml.to_str().unwrap(), counts.to_str().unwrap()],
    ) else {
        return;
    };
    let theirs: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
    let inventory = Inventory::read(&xml).unwrap();
    let station = StationId::parse("XX.STN.").unwrap();
    let calibration =
        MseedCalibration::for_station(Some(&inventory), &NodeConfig::default(), &station).unwrap();
    let ours = Traces::from_mseed(&counts, &station, calibration).unwrap();
    assert_eq!(Some(ours.start_ns), theirs["Z"]["start_ns"].as_i64());
    let up = ours.up.as_ref().unwrap();
    for (name, series) in [("E", &ours.east), ("N", &ours.north), ("Z", up)] {
        let reference: Vec<f64> = theirs[name]["data"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(series.len(), reference.len(), "{name}");
        let scale = reference.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        // The issue's bound: 1e-6 relative to the component's peak (both compute in f64 with
        // a 3×3 inverse, so the real difference is round-off, ~1e-15).
        let worst = series
            .iter()
            .zip(&reference)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        println!("{name}: worst |ours - ObsPy| {worst:.3e} m/s² of peak {scale:.3e} m/s²");
        assert!(
            worst <= 1e-6 * scale,
            "{name}: worst {worst} of peak {scale}"
        );
    }
}

#[test]
fn missing_or_wrong_inventory_entries_name_the_channel() {
    let station = StationId::parse("XX.STN.").unwrap();
    let counts = data("mseed/k2_STNA_HN123_counts.mseed");
    // The K-NET inventory has no XX.STN channel.
    let inventory = Inventory::read(&data("stationxml/obspy_BO.AKT01_knet.xml")).unwrap();
    let e =
        Traces::from_mseed(&counts, &station, MseedCalibration::Inventory(&inventory)).unwrap_err();
    assert!(
        e.to_string()
            .contains("channel XX.STN..HN1 is not in the inventory"),
        "{e}"
    );
}

/// A station with two sensors, velocity HH? (values 1, 2, 3) and acceleration HN? (values
/// 10, 20, 30), as floats in one file.
fn two_sensor_file(dir: &Path) -> PathBuf {
    use rockwatch_core::record::mseed::{write_mseed, ChannelData, Samples, WriteOptions};
    let n = 500;
    let values: Vec<Vec<f64>> = [1.0, 2.0, 3.0, 10.0, 20.0, 30.0]
        .iter()
        .map(|&v| vec![v; n])
        .collect();
    let ids = [
        "XX.TWO..HHE",
        "XX.TWO..HHN",
        "XX.TWO..HHZ",
        "XX.TWO..HNE",
        "XX.TWO..HNN",
        "XX.TWO..HNZ",
    ];
    let channels: Vec<ChannelData<'_>> = ids
        .iter()
        .zip(&values)
        .map(|(id, v)| ChannelData {
            id: (*id).to_string(),
            start_time_ns: 1_600_000_000_000_000_000,
            sample_rate_hz: 100.0,
            samples: Samples::Float(v),
        })
        .collect();
    let path = dir.join("two_sensors.mseed");
    write_mseed(&path, &channels, WriteOptions::default()).unwrap();
    path
}

#[test]
fn mseed_input_prefers_the_accelerometer_and_channels_chooses() {
    use rockwatch::replay::ChannelChoice;
    let dir = tempfile::tempdir().unwrap();
    let path = two_sensor_file(dir.path());
    let station = StationId::parse("XX.TWO.").unwrap();
    let as_stored = MseedCalibration::AsStored {
        counts_have_gain: false,
    };
    let pick = |channels: Option<&str>| {
        let choice = ChannelChoice {
            channels: channels.map(str::to_string),
            differentiate_velocity: false,
        };
        Traces::from_mseed_with(&path, &station, as_stored, &choice)
    };
    // Default: HN? (instrument code N, the accelerometer), not the first channels (HH?).
    let t = pick(None).unwrap();
    assert_eq!(
        (t.east[0], t.north[0], t.up.as_ref().unwrap()[0]),
        (10.0, 20.0, 30.0)
    );
    // --channels HH? takes the seismometer.
    let t = pick(Some("HH?")).unwrap();
    assert_eq!((t.east[0], t.north[0]), (1.0, 2.0));
    // A pattern matching both sensors, or none, is an error saying what to do.
    let e = pick(Some("H??")).unwrap_err().to_string();
    assert!(
        e.contains("several sensors") && e.contains("--channels"),
        "{e}"
    );
    let e = pick(Some("BN?")).unwrap_err().to_string();
    assert!(e.contains("matches no channel") && e.contains("HNZ"), "{e}");
    // Through the CLI: monitor --channels is accepted and reaches the same choice.
    let catalogue = dir.path().join("c.toml");
    std::fs::write(
        &catalogue,
        "[[pbr]]\nid = \"b\"\nname = \"b\"\nlat = 0.0\nlon = 0.0\nstation = \"XX.TWO.\"\n\
         azimuth_deg = 90.0\nwidth_m = 1.0\nheight_m = 2.0\nmu_s = 0.7\nmu_k = 0.55\nsource = \"t\"\n",
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec![
            "monitor",
            "--catalogue",
            catalogue.to_str().unwrap(),
            "--mseed",
            path.to_str().unwrap(),
            "--station",
            "XX.TWO.",
            "--tail",
            "0",
            "--format",
            "jsonl",
        ];
        args.extend_from_slice(extra);
        rockwatch_bin!().output(&args)
    };
    let summary = |o: &Output| -> serde_json::Value {
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        serde_json::from_str(text.lines().last().unwrap()).unwrap()
    };
    let hn = run(&[]);
    let hh = run(&["--channels", "HH?"]);
    assert!(hn.status.success() && hh.status.success());
    // Constant 10/20 m/s² vs 1/2 m/s²: the PGA (the peak of the horizontal vector, √(E² + N²))
    // says which was used.
    let pga = |o: &Output| summary(o)["intensity"]["pga_mps2"].as_f64().unwrap();
    assert!((pga(&hn) - 500f64.sqrt()).abs() < 1e-9, "{}", pga(&hn));
    assert!((pga(&hh) - 5f64.sqrt()).abs() < 1e-9, "{}", pga(&hh));
}

#[test]
fn velocity_channels_are_refused_or_differentiated_with_the_flag() {
    use rockwatch_core::record::mseed::{write_mseed, ChannelData, Samples, WriteOptions};
    // A 2 Hz ground velocity of 0.01 m/s east, counts at 1e6 counts per m/s (floats).
    let dir = tempfile::tempdir().unwrap();
    let (n, rate, f, v0, s) = (1000, 100.0, 2.0, 0.01, 1.0e6);
    let w = 2.0 * std::f64::consts::PI * f;
    let counts: Vec<f64> = (0..n)
        .map(|k| s * v0 * (w * k as f64 / rate).sin())
        .collect();
    let zeros = vec![0.0; n];
    let mseed = dir.path().join("vel.mseed");
    let channels: Vec<ChannelData<'_>> = [("HHE", &counts), ("HHN", &zeros)]
        .iter()
        .map(|(cha, v)| ChannelData {
            id: format!("XX.VEL..{cha}"),
            start_time_ns: 1_600_000_000_000_000_000,
            sample_rate_hz: rate,
            samples: Samples::Float(v),
        })
        .collect();
    write_mseed(&mseed, &channels, WriteOptions::default()).unwrap();
    let channel = |cha: &str, az: f64| {
        format!(
            "<Channel code=\"{cha}\" locationCode=\"\" startDate=\"2000-01-01T00:00:00\"><Latitude>0</Latitude><Longitude>0</Longitude><Elevation>0</Elevation><Depth>0</Depth><Azimuth>{az}</Azimuth><Dip>0</Dip><SampleRate>{rate}</SampleRate><Response><InstrumentSensitivity><Value>{s}</Value><Frequency>1</Frequency><InputUnits><Name>M/S</Name></InputUnits><OutputUnits><Name>COUNTS</Name></OutputUnits></InstrumentSensitivity></Response></Channel>"
        )
    };
    let xml = dir.path().join("vel.xml");
    std::fs::write(
        &xml,
        format!(
            "<?xml version=\"1.0\"?><FDSNStationXML xmlns=\"http://www.fdsn.org/xml/station/1\" schemaVersion=\"1.1\"><Source>test</Source><Created>2020-01-01T00:00:00</Created><Network code=\"XX\"><Station code=\"VEL\" startDate=\"2000-01-01T00:00:00\"><Latitude>0</Latitude><Longitude>0</Longitude><Elevation>0</Elevation>{}{}</Station></Network></FDSNStationXML>",
            channel("HHE", 90.0),
            channel("HHN", 0.0)
        ),
    )
    .unwrap();
    let ims = |extra: &[&str]| {
        let dir = dir.path();
        let e = dir.join("e.mseed");
        // ims takes one channel per file: HHE alone.
        write_mseed(&e, &channels[..1], WriteOptions::default()).unwrap();
        let mut args = vec![
            "ims",
            "--record",
            e.to_str().unwrap(),
            "--stationxml",
            xml.to_str().unwrap(),
            "--format",
            "json",
        ];
        args.extend_from_slice(extra);
        rockwatch_bin!().output(&args)
    };
    let refused = ims(&[]);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && err.contains("--differentiate-velocity"),
        "{err}"
    );
    let ok = ims(&["--differentiate-velocity"]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&ok.stdout).unwrap();
    // PGA = v0·ω (within the central difference's sinc(ωh) and the one-sided ends);
    // PGV of the differentiated record's integral ≈ v0.
    let pga = v["pga"].as_f64().unwrap();
    let exact = v0 * w;
    let sinc = (w / rate).sin() / (w / rate);
    assert!(
        (pga - exact).abs() <= exact * (1.0 - sinc) + exact * 1e-9 + exact * (w / rate) / 2.0,
        "{pga} vs {exact}"
    );
    // monitor: the same flag, east = the differentiated HHE.
    let catalogue = dir.path().join("c.toml");
    std::fs::write(
        &catalogue,
        "[[pbr]]\nid = \"b\"\nname = \"b\"\nlat = 0.0\nlon = 0.0\nstation = \"XX.VEL.\"\n\
         azimuth_deg = 90.0\nwidth_m = 1.0\nheight_m = 2.0\nmu_s = 0.7\nmu_k = 0.55\nsource = \"t\"\n",
    )
    .unwrap();
    let out = rockwatch_bin!().output(&[
        "monitor",
        "--catalogue",
        catalogue.to_str().unwrap(),
        "--mseed",
        mseed.to_str().unwrap(),
        "--stationxml",
        xml.to_str().unwrap(),
        "--differentiate-velocity",
        "--station",
        "XX.VEL.",
        "--tail",
        "0",
        "--format",
        "jsonl",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let summary: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    let monitor_pga = summary["intensity"]["pga_mps2"].as_f64().unwrap();
    // f32 packets.
    assert!(
        (monitor_pga - pga).abs() <= 1e-6 * pga,
        "{monitor_pga} vs {pga}"
    );
}

#[test]
fn replay_of_a_station_the_node_does_not_know_is_refused_before_sending() {
    // config/node.toml's catalogue binds blocks to CI.RRS.00 and others, not XX.STN.: the
    // node would count all the packets as unknown_station and ignore them.
    let node_toml = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/node.toml");
    let out = rockwatch_bin!().output(&[
        "replay",
        "--mseed",
        data("mseed/k2_STNA_HN123_counts.mseed").to_str().unwrap(),
        "--stationxml",
        data("stationxml/obspy_XX.STN_k2.xml").to_str().unwrap(),
        "--station",
        "XX.STN.",
        "--transport",
        "iceoryx2",
        "--config",
        node_toml,
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.starts_with("rockwatch: error: station XX.STN. is neither in the [[station]]")
            && err.contains("unknown station")
            && err.lines().count() == 1,
        "{err}"
    );
}
