//! Round trips of the record writers (`write_at2`, `write_csv`) through the readers.

use rockwatch_core::record::{
    read_at2, read_csv, write_at2, write_csv, Record, STANDARD_GRAVITY_MPS2,
};

fn sample_record(with_vertical: bool) -> Record {
    // Values spanning many magnitudes and both signs, including exact zero.
    let horizontal_mps2: Vec<f64> = (0..23)
        .map(|i| {
            let x = i as f64;
            (0.7 * x).sin() * 10f64.powi(i % 7 - 4) * if i % 3 == 0 { -1.0 } else { 1.0 }
        })
        .chain([0.0, -9.80665, 1e-30])
        .collect();
    let vertical_mps2 =
        with_vertical.then(|| horizontal_mps2.iter().map(|a| -0.5 * a + 1e-3).collect());
    Record {
        source: "test".into(),
        dt_s: 0.005,
        horizontal_mps2,
        vertical_mps2,
    }
}

#[test]
fn at2_round_trip_keeps_header_dt_and_values_to_ten_digits() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rt.AT2");
    let record = sample_record(false);
    let header = [
        "PEER NGA STRONG MOTION DATABASE RECORD",
        "synthetic test, 1 2 3",
        "ACCELERATION TIME SERIES IN UNITS OF G",
    ];
    write_at2(&path, &record, header).unwrap();

    let at2 = read_at2(&path).unwrap();
    assert_eq!(at2.header, header.map(String::from));
    assert_eq!(at2.dt_s, 0.005);
    assert_eq!(at2.values_g.len(), record.len());
    for (g, a) in at2.values_g.iter().zip(&record.horizontal_mps2) {
        // 10 significant digits: relative rounding ≤ 5e-10 (one more ulp for the division).
        let expected = a / STANDARD_GRAVITY_MPS2;
        assert!(
            (g - expected).abs() <= 6e-10 * expected.abs(),
            "{g} vs {expected}"
        );
    }

    let back = Record::read(&path).unwrap();
    assert_eq!(back.dt_s, record.dt_s);
    for (b, a) in back.horizontal_mps2.iter().zip(&record.horizontal_mps2) {
        assert!((b - a).abs() <= 1e-9 * a.abs(), "{b} vs {a}");
    }
}

#[test]
fn csv_round_trip_is_exact_with_and_without_vertical() {
    let dir = tempfile::tempdir().unwrap();
    for with_vertical in [false, true] {
        let path = dir.path().join(format!("rt_{with_vertical}.csv"));
        let record = sample_record(with_vertical);
        write_csv(&path, &record).unwrap();
        let back = read_csv(&path).unwrap();
        // Shortest round-trip formatting: the values are bit-identical.
        assert_eq!(back.horizontal_mps2, record.horizontal_mps2);
        assert_eq!(back.vertical_mps2, record.vertical_mps2);
        // dt is re-derived from the time column: (n-1)·dt / (n-1), exact to rounding.
        assert!((back.dt_s - record.dt_s).abs() < 1e-15);
        let first_line = std::fs::read_to_string(&path).unwrap();
        let header = first_line.lines().next().unwrap();
        assert_eq!(header, if with_vertical { "t,ax,ay" } else { "t,ax" });
    }
}

#[test]
fn writers_refuse_unwritable_records_with_the_file_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.AT2");
    let header = ["a", "b", "c"];

    let err = write_at2(&path, &sample_record(true), header).unwrap_err();
    assert!(
        err.to_string().contains("bad.AT2") && err.problem.contains("vertical"),
        "{err}"
    );

    let mut empty = sample_record(false);
    empty.horizontal_mps2.clear();
    assert!(write_at2(&path, &empty, header)
        .unwrap_err()
        .problem
        .contains("empty"));
    assert!(write_csv(&path, &empty).is_err());

    let mut nan = sample_record(false);
    nan.horizontal_mps2[4] = f64::NAN;
    assert!(write_csv(&path, &nan)
        .unwrap_err()
        .problem
        .contains("sample 4"));

    let mut zero_dt = sample_record(false);
    zero_dt.dt_s = 0.0;
    assert!(write_at2(&path, &zero_dt, header).is_err());

    let mut short_vertical = sample_record(true);
    if let Some(v) = short_vertical.vertical_mps2.as_mut() {
        v.pop();
    }
    assert!(write_csv(&path, &short_vertical).is_err());

    assert!(write_at2(&path, &sample_record(false), ["a\nb", "c", "d"]).is_err());

    let missing = dir.path().join("no/such/dir/x.csv");
    let err = write_csv(&missing, &sample_record(false)).unwrap_err();
    assert!(err.to_string().contains("x.csv"), "{err}");
}
