//! End-to-end tests of `rockwatch pulses`: files written, read back, and consistent with the
//! printed summary and the pulse model.

use rockwatch_core::record::Record;
use rockwatch_test_harness::rockwatch_bin;
use std::path::Path;

fn run_json(out: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["pulses", "--out", out.to_str().unwrap(), "--format", "json"];
    args.extend_from_slice(extra);
    let output = rockwatch_bin!().output(&args);
    assert!(
        output.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).expect("stdout is JSON")
}

fn files_in(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    files
}

/// Peak |v| of the trapezoidal integral of the record's acceleration (m/s).
fn peak_integrated_velocity(record: &Record) -> f64 {
    let a = &record.horizontal_mps2;
    let mut v = 0.0_f64;
    let mut peak = 0.0_f64;
    for pair in a.windows(2) {
        v += 0.5 * (pair[0] + pair[1]) * record.dt_s;
        peak = peak.max(v.abs());
    }
    peak
}

#[test]
fn pulses_writes_count_at2_files_that_read_back_and_match_the_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m7r10");
    let json = run_json(
        &out,
        &[
            "--mw", "7", "--r-km", "10", "--count", "12", "--seed", "1", "--dt", "0.005",
        ],
    );
    let pulses = json["pulses"].as_array().unwrap();
    assert_eq!(pulses.len(), 12);
    assert_eq!(files_in(&out).len(), 12);
    for (i, p) in pulses.iter().enumerate() {
        assert_eq!(p["id"].as_u64(), Some(i as u64 + 1));
        assert_eq!(p["mw"].as_f64(), Some(7.0));
        assert_eq!(p["r_km"].as_f64(), Some(10.0));
        let field = |name: &str| p[name].as_f64().unwrap_or_else(|| panic!("{name}"));
        let (tp, vp, gamma, nu) = (
            field("tp_s"),
            field("vp_mps"),
            field("gamma"),
            field("nu_rad"),
        );
        assert!(gamma > 1.0 && nu.abs() <= std::f64::consts::FRAC_PI_2);
        assert!((field("duration_s") - gamma * tp).abs() < 1e-9 * tp);
        assert!(
            field("a_mps") >= vp * (1.0 - 1e-12),
            "A is never below the peak"
        );

        let file = Path::new(p["file"].as_str().unwrap());
        assert!(file.starts_with(&out));
        let record = Record::read(file).unwrap();
        assert_eq!(record.dt_s, 0.005);
        // Samples 0..=N with N·dt the first grid time at or after the end of the pulse.
        let expected_len = (gamma * tp / 0.005 - 1e-9).ceil() as usize + 1;
        assert_eq!(record.len(), expected_len);
        // PGA: the file stores g to 10 digits.
        let pga = record
            .horizontal_mps2
            .iter()
            .fold(0.0_f64, |m, a| m.max(a.abs()));
        assert!((pga - field("pga_mps2")).abs() < 1e-8 * pga);
        // Integrating the file's acceleration recovers a velocity pulse whose peak is Vp:
        // trapezoid error ~ (2π·dt/Tp)²/12 < 1e-4 relative for Tp > 0.5 s, plus the peak
        // falling between samples ~ (2π·dt/Tp)²/8; 1e-3 bounds both.
        let peak_v = peak_integrated_velocity(&record);
        assert!(
            (peak_v - vp).abs() < 1e-3 * vp,
            "pulse {}: {peak_v} vs {vp}",
            i + 1
        );
        // Velocity returns to zero at the end of the pulse (a is the exact derivative).
        let residual_v: f64 = record
            .horizontal_mps2
            .windows(2)
            .map(|w| 0.5 * (w[0] + w[1]) * 0.005)
            .sum();
        assert!(
            residual_v.abs() < 1e-3 * vp,
            "residual velocity {residual_v}"
        );
    }
}

#[test]
fn pulses_csv_files_read_back_in_mps2() {
    let dir = tempfile::tempdir().unwrap();
    let json = run_json(
        dir.path(),
        &[
            "--mw",
            "6.5",
            "--r-km",
            "5",
            "--count",
            "3",
            "--dt",
            "0.01",
            "--file-format",
            "csv",
        ],
    );
    let files = files_in(dir.path());
    assert_eq!(files.len(), 3);
    for (p, file) in json["pulses"].as_array().unwrap().iter().zip(&files) {
        assert_eq!(p["file"].as_str().unwrap(), file.display().to_string());
        assert_eq!(file.extension().unwrap(), "csv");
        let record = Record::read(file).unwrap();
        let pga = record
            .horizontal_mps2
            .iter()
            .fold(0.0_f64, |m, a| m.max(a.abs()));
        // CSV round-trips exactly.
        assert_eq!(pga, p["pga_mps2"].as_f64().unwrap());
    }
}

#[test]
fn pulses_same_seed_same_files_different_seed_different() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, seed: &str| {
        let out = dir.path().join(name);
        run_json(
            &out,
            &["--mw", "8", "--r-km", "15", "--count", "4", "--seed", seed],
        );
        files_in(&out)
            .iter()
            .map(|f| std::fs::read(f).unwrap())
            .collect::<Vec<_>>()
    };
    let a = run("a", "42");
    assert_eq!(a, run("b", "42"));
    let c = run("c", "43");
    assert!(a.iter().zip(&c).all(|(x, y)| x != y));
}

#[test]
fn pulses_text_output_is_a_table() {
    let dir = tempfile::tempdir().unwrap();
    let output = rockwatch_bin!().output(&[
        "pulses",
        "--mw",
        "7",
        "--r-km",
        "10",
        "--count",
        "2",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(output.status.success());
    let text = String::from_utf8(output.stdout).unwrap();
    assert!(text.lines().next().unwrap().contains("Vp m/s"), "{text}");
    assert_eq!(text.lines().count(), 4, "header, 2 rows, footer: {text}");
}

#[test]
fn pulses_bad_arguments_fail_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    for (args, needle) in [
        (vec!["--mw", "-1", "--r-km", "10"], "moment magnitude"),
        (vec!["--mw", "7", "--r-km", "-3"], "distance"),
        (vec!["--mw", "7", "--r-km", "10", "--dt", "0"], "--dt"),
        (vec!["--mw", "7", "--r-km", "10", "--dt", "-0.01"], "--dt"),
        (
            vec!["--mw", "7", "--r-km", "10", "--pad-s", "-1"],
            "--pad-s",
        ),
        (vec!["--mw", "7", "--r-km", "10", "--count", "0"], "--count"),
    ] {
        let mut full = vec!["pulses", "--out", out];
        full.extend(args.iter());
        let output = rockwatch_bin!().output(&full);
        assert!(!output.status.success(), "{args:?} should fail");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
    }
}

#[test]
fn format_also_names_the_file_format_as_in_the_issue_signature() {
    // `rockwatch pulses ... --format csv` (the short form) writes CSV files and the text table.
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rockwatch"))
        .args([
            "pulses", "--mw", "7", "--r-km", "10", "--count", "3", "--seed", "1", "--dt", "0.01",
            "--format", "csv", "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names.len(), 3);
    assert!(names.iter().all(|n| n.ends_with(".csv")), "{names:?}");
    for n in &names {
        rockwatch_core::record::Record::read(&dir.path().join(n)).unwrap();
    }
}
