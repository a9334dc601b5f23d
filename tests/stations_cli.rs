//! `rockwatch stations` through the binary, on real StationXML documents
//! (tests/data/stationxml, see its README).

use rockwatch_test_harness::rockwatch_bin;

const AND3: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/stationxml/ingv_IX.AND3_level-response.xml"
);
const MN: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/stationxml/ingv_MN_level-channel.xml"
);

fn json(args: &[&str]) -> serde_json::Value {
    let out = rockwatch_bin!().output(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn json_has_exactly_the_documented_keys_and_the_documents_values() {
    let v = json(&["stations", "--stationxml", AND3, "--format", "json"]);
    let channels = v["channels"].as_array().unwrap();
    assert_eq!(v.as_object().unwrap().len(), 1);
    assert_eq!(channels.len(), 6);
    let keys: Vec<&str> = channels[0]
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    let mut expected = vec![
        "id",
        "start",
        "end",
        "sample_rate_hz",
        "azimuth_deg",
        "dip_deg",
        "sensitivity",
        "sensitivity_frequency_hz",
        "input_units",
        "gain_mps2_per_count",
        "usable",
        "reason",
        "usable_with_differentiation",
    ];
    expected.sort_unstable();
    assert_eq!(keys, expected);
    // From the document's text: HNE loc 01, 125 sps, 949627 counts per M/S**2 at 0.1 Hz,
    // azimuth 90, dip 0, from 2013-12-17, open-ended.
    let hne = &channels[0];
    assert_eq!(hne["id"], "IX.AND3.01.HNE");
    assert_eq!(hne["start"], "2013-12-17T00:00:00.000000000Z");
    assert_eq!(hne["end"], serde_json::Value::Null);
    assert_eq!(
        (
            hne["sample_rate_hz"].as_f64(),
            hne["azimuth_deg"].as_f64(),
            hne["dip_deg"].as_f64()
        ),
        (Some(125.0), Some(90.0), Some(0.0))
    );
    assert_eq!(hne["sensitivity"], 949627.0);
    assert_eq!(hne["sensitivity_frequency_hz"], 0.1);
    assert_eq!(hne["input_units"], "M/S**2");
    // serde_json's default parser may be 1 ulp off the shortest round-trip text.
    let gain = hne["gain_mps2_per_count"].as_f64().unwrap();
    assert!((gain * 949627.0 - 1.0).abs() < 1e-15, "{gain}");
    assert_eq!(
        (hne["usable"].as_bool(), &hne["reason"]),
        (Some(true), &serde_json::Value::Null)
    );
    // The velocity sensor at loc 02 is listed, unusable, with the reason.
    let hhz = &channels[5];
    assert_eq!(hhz["id"], "IX.AND3.02.HHZ");
    assert_eq!(hhz["usable"], false);
    assert_eq!(hhz["gain_mps2_per_count"], serde_json::Value::Null);
    assert!(hhz["reason"]
        .as_str()
        .unwrap()
        .starts_with("velocity channel (M/S)"));
    // ... and usable once differentiation is asked for; the accelerometer either way.
    assert_eq!(hhz["usable_with_differentiation"], true);
    assert_eq!(hne["usable_with_differentiation"], true);
    let text = String::from_utf8(
        rockwatch_bin!()
            .output(&["stations", "--stationxml", AND3])
            .stdout,
    )
    .unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("IX.AND3.02.HHZ"))
        .unwrap();
    assert!(line.contains("with differentiation only"), "{line}");
}

#[test]
fn at_keeps_only_the_epochs_in_force() {
    let all = json(&["stations", "--stationxml", MN, "--format", "json"]);
    assert_eq!(all["channels"].as_array().unwrap().len(), 160);
    let v = json(&[
        "stations",
        "--stationxml",
        MN,
        "--at",
        "2009-06-01T00:00:00Z",
        "--format",
        "json",
    ]);
    let ids: Vec<&str> = v["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["id"].as_str().unwrap())
        .collect();
    // In 2009 AQU had the HL? accelerometers (first epoch, 534331/537500/537691), no HN?.
    assert!(
        ids.contains(&"MN.AQU..HLE") && !ids.iter().any(|i| i.ends_with("HNZ")),
        "{ids:?}"
    );
    let hle = v["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["id"] == "MN.AQU..HLE")
        .unwrap();
    assert_eq!(hle["sensitivity"], 534331.0);
    // Text output: one line per epoch and a count.
    let out = rockwatch_bin!().output(&["stations", "--stationxml", MN, "--at", "2009-06-01"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.trim_end()
            .ends_with(&format!("{} channel epochs", ids.len())),
        "{text}"
    );
}

#[test]
fn bad_input_is_a_one_line_error() {
    for (args, needle) in [
        (
            vec!["stations", "--stationxml", MN, "--at", "yesterday"],
            "--at \"yesterday\" is not an ISO 8601 time",
        ),
        (
            vec!["stations", "--stationxml", "/nonexistent.xml"],
            "/nonexistent.xml: cannot read",
        ),
        (
            vec![
                "stations",
                "--stationxml",
                concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml"),
            ],
            "not well-formed XML",
        ),
    ] {
        let out = rockwatch_bin!().output(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(
            stderr.starts_with("rockwatch: error: ") && stderr.contains(needle),
            "{stderr}"
        );
    }
}

/// Issue 20 item 6: 1-sample-per-second accelerometer channels (LN?) were listed usable. A
/// channel below 50 Hz is unusable, with the minimum and the reason; a 1 Hz velocity channel
/// is refused for its rate, not offered "with differentiation".
#[test]
fn channels_sampled_too_slowly_for_rocking_are_unusable_with_the_minimum() {
    const MIKB: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/stationxml/gmprocess_CI.MIKB_level-channel.xml"
    );
    let v = json(&["stations", "--stationxml", MIKB, MN, "--format", "json"]);
    let channels = v["channels"].as_array().unwrap();
    let find = |id: &str, rate: f64| {
        channels
            .iter()
            .find(|c| c["id"] == id && c["sample_rate_hz"].as_f64() == Some(rate))
            .unwrap_or_else(|| panic!("{id} at {rate} Hz"))
            .clone()
    };
    for (id, rate) in [("CI.MIKB..LNE", 1.0), ("CI.MIKB..BNE", 40.0)] {
        let c = find(id, rate);
        assert_eq!(c["usable"], false, "{c}");
        assert_eq!(c["usable_with_differentiation"], false, "{c}");
        let reason = c["reason"].as_str().unwrap();
        assert!(
            reason.starts_with(&format!(
                "sampling rate {rate} Hz is below the 50 Hz minimum: the ground acceleration \
                 that rocks or slides a block has peaks up to ≈ 25 Hz"
            )),
            "{reason}"
        );
    }
    // Accelerometers at 100 and 200 Hz stay usable.
    for rate in [100.0, 200.0] {
        assert_eq!(find("CI.MIKB..HNE", rate)["usable"], true);
    }
    // A 1 Hz velocity channel: its rate is the reason (differentiating would not mend it);
    // a 100 Hz one stays usable with differentiation.
    let lhe = find("MN.AQU..LHE", 1.0);
    assert_eq!(lhe["usable_with_differentiation"], false, "{lhe}");
    assert!(lhe["reason"]
        .as_str()
        .unwrap()
        .starts_with("sampling rate 1 Hz"));
    let hhe = find("MN.AQU..HHE", 100.0);
    assert_eq!(hhe["usable_with_differentiation"], true, "{hhe}");
    // The table says it on the channel's line.
    let out = rockwatch_bin!().output(&["stations", "--stationxml", MIKB]);
    let text = String::from_utf8(out.stdout).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("CI.MIKB..LNE"))
        .unwrap();
    assert!(
        line.contains("no: sampling rate 1 Hz is below the 50 Hz minimum"),
        "{line}"
    );
}
