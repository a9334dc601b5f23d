//! Issue 20 item 21: text output printed raw f64s (`median 12.09751932922565 m/s2`,
//! `b+ = 0.4458421458288538 m`). The text of `simulate`, `geometry`, `hazard` and `fragility`
//! has 4 significant digits (`rockwatch::number_text::short_number`), their JSON every digit.

use rockwatch_test_harness::rockwatch_bin;
use std::path::{Path, PathBuf};

use rockwatch::number_text::short_number;

fn repo(path: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../..")).join(path)
}

/// The decimal numbers of `text` (a fraction or an exponent; integers such as counts are not
/// rounded), each with its significant digits. A number glued to a word (`Rinaldi228.AT2`) is
/// part of a name, not a number.
fn decimals(text: &str) -> Vec<(String, usize)> {
    let chars: Vec<char> = text.chars().collect();
    let mut found = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let glued = i > 0 && (chars[i - 1].is_alphanumeric() || chars[i - 1] == '.');
        if !chars[i].is_ascii_digit() || glued {
            i += 1;
            continue;
        }
        let start = i;
        let digits = |i: &mut usize| {
            while *i < chars.len() && chars[*i].is_ascii_digit() {
                *i += 1;
            }
        };
        digits(&mut i);
        let mut decimal = false;
        if i + 1 < chars.len() && chars[i] == '.' && chars[i + 1].is_ascii_digit() {
            i += 1;
            digits(&mut i);
            decimal = true;
        }
        let mantissa_end = i;
        if i + 1 < chars.len() && chars[i] == 'e' {
            let mut j = i + 1;
            if j < chars.len() && chars[j] == '-' {
                j += 1;
            }
            if j < chars.len() && chars[j].is_ascii_digit() {
                i = j;
                digits(&mut i);
                decimal = true;
            }
        }
        let glued_after = i < chars.len() && (chars[i].is_alphabetic() || chars[i] == '_');
        if decimal && !glued_after {
            let mantissa: String = chars[start..mantissa_end]
                .iter()
                .filter(|c| c.is_ascii_digit())
                .collect();
            let significant = mantissa.trim_start_matches('0').len();
            found.push((chars[start..i].iter().collect(), significant));
        }
    }
    found
}

/// Every decimal number of the lines of `text` that `keep` selects has at most 4 significant
/// digits.
fn assert_short(command: &str, text: &str, keep: impl Fn(&str) -> bool) {
    let mut checked = 0;
    for line in text.lines().filter(|l| keep(l)) {
        for (number, significant) in decimals(line) {
            checked += 1;
            assert!(
                significant <= 4,
                "{command}: {number} has {significant} significant digits in {line:?}"
            );
        }
    }
    assert!(
        checked > 3,
        "{command}: only {checked} numbers checked in {text}"
    );
}

#[test]
fn the_scanner_finds_long_numbers_and_skips_names() {
    assert_eq!(
        decimals("b+ = 0.4458421458288538 m, Rinaldi228.AT2 at 228°, 1.235e-5, 2000 runs"),
        [
            ("0.4458421458288538".to_string(), 16),
            ("1.235e-5".to_string(), 4)
        ]
    );
}

#[test]
fn simulate_prints_four_significant_digits_and_json_keeps_them_all() {
    let wedge = repo("tests/data/meshes/leaning-wedge.obj");
    let record = repo("tests/data/records/Rinaldi228.AT2");
    let args = [
        "simulate",
        "--record",
        record.to_str().unwrap(),
        "--mesh",
        wedge.to_str().unwrap(),
        "--azimuth",
        "270",
        "--mu-s",
        "0.7",
        "--mu-k",
        "0.55",
    ];
    let text = rockwatch_bin!().run(&args).success_stdout();
    // The body of a mesh direction: b± are computed (0.2333… m), not typed.
    assert!(text.contains("b+ = 0.2333 m"), "{text}");
    // (The mode changes are an aligned table of times.)
    assert_short("simulate", &text, |l| !l.starts_with("  "));
    let json: serde_json::Value = serde_json::from_str(
        &rockwatch_bin!()
            .run(&[&args[..], &["--format", "json"]].concat())
            .success_stdout(),
    )
    .unwrap();
    let theta = json["max_abs_theta"].as_f64().unwrap();
    assert!(
        text.contains(&format!("max |θ|     {} rad", short_number(theta))),
        "{text}"
    );
    assert!(
        theta.to_string().len() > 8,
        "JSON keeps every digit: {theta}"
    );

    // The 3-D model's summary too.
    let text = rockwatch_bin!()
        .run(&[
            "simulate",
            "--record",
            record.to_str().unwrap(),
            "--mesh",
            wedge.to_str().unwrap(),
            "--model",
            "3d",
            "--azimuth",
            "228",
            "--mu-s",
            "0.8",
        ])
        .success_stdout();
    assert_short("simulate --model 3d", &text, |_| true);
}

#[test]
fn geometry_summary_lines_print_four_significant_digits() {
    let wedge = repo("tests/data/meshes/leaning-wedge.obj");
    let text = rockwatch_bin!()
        .run(&[
            "geometry",
            "--mesh",
            wedge.to_str().unwrap(),
            "--azimuths",
            "0:360:45",
        ])
        .success_stdout();
    // The summary lines; the direction and tolerance tables keep aligned fixed decimals.
    let summary = ["volume", "com ", "resting", "com height", "weakest"];
    assert_short("geometry", &text, |l| {
        summary.iter().any(|s| l.starts_with(s))
    });
    assert!(text.contains("com height  0.4667 m"), "{text}");
}

#[test]
fn hazard_prints_four_significant_digits_and_json_keeps_them_all() {
    let dir = tempfile::tempdir().unwrap();
    let fragility = dir.path().join("fragility.json");
    // The issue's median, as a fragility fit writes it.
    std::fs::write(
        &fragility,
        r#"{"ims": {"PGA": {"median": 12.09751932922565, "beta": 0.4458421458288538, "unit": "m/s2"}}}"#,
    )
    .unwrap();
    let curve = dir.path().join("pga.csv");
    std::fs::write(
        &curve,
        "pga_g,annual_rate\n0.05,2.3456789e-2\n0.1,7.654321e-3\n0.3,1.2345678e-3\n0.6,2.2222e-4\n\
         1.0,4.4444e-5\n2.0,3.3333e-6\n",
    )
    .unwrap();
    let args = [
        "hazard",
        "--fragility",
        fragility.to_str().unwrap(),
        "--im",
        "PGA",
        "--hazard-curve",
        curve.to_str().unwrap(),
        "--hazard-unit",
        "g",
        "--age-years",
        "12345",
    ];
    let text = rockwatch_bin!().run(&args).success_stdout();
    assert!(text.contains("median 12.1 m/s2, beta 0.4458"), "{text}");
    // The unit factor is exact (g = 9.80665 m/s² by definition) and printed whole.
    assert!(text.contains("× 9.80665 → m/s2"), "{text}");
    assert_short("hazard", &text.replace("× 9.80665", ""), |_| true);
    let json: serde_json::Value = serde_json::from_str(
        &rockwatch_bin!()
            .run(&[&args[..], &["--format", "json"]].concat())
            .success_stdout(),
    )
    .unwrap();
    assert_eq!(json["median"], 12.09751932922565);
    assert_eq!(json["beta"], 0.4458421458288538);
}

#[test]
fn fragility_prints_four_significant_digits() {
    let dir = tempfile::tempdir().unwrap();
    let records = format!(
        "{},{}",
        repo("tests/data/records/Rinaldi228.AT2").display(),
        repo("tests/data/records/RSN1084_NORTHR_SCS142.AT2").display()
    );
    let text = rockwatch_bin!()
        .run(&[
            "fragility",
            "--b-plus",
            "0.1234567",
            "--b-minus",
            "0.2345678",
            "--com-height",
            "0.7654321",
            "--rho",
            "0.4567891",
            "--mu-s",
            "0.7",
            "--records",
            &records,
            "--im",
            "PGA,PGV",
            "--scales",
            "0.25:4:10",
            "--bootstrap",
            "20",
            "--no-plots",
            "--out",
            dir.path().to_str().unwrap(),
        ])
        .success_stdout();
    assert!(text.contains("b+ = 0.1235 m"), "{text}");
    // (The time line is the run's; the paths are the user's.)
    assert_short("fragility", &text, |l| {
        !l.starts_with("wrote") && !l.starts_with("time")
    });
}
