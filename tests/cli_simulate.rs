//! `rockwatch simulate` block geometry given as B, H or as R, α.

use std::process::Command;

fn simulate_json(block: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "simulate",
        "--record",
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/records/Rinaldi228.AT2"
        ),
        "--mu-s",
        "1.5",
        "--mu-k",
        "1.0",
        "--format",
        "json",
    ];
    args.extend_from_slice(block);
    let out = Command::new(env!("CARGO_BIN_EXE_rockwatch"))
        .args(&args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn half_diagonal_and_alpha_describe_the_same_block_as_width_and_height() {
    // R = ½√(B² + H²), α = atan(B/H): B = 2R sin α, H = 2R cos α.
    let (r, alpha_deg) = (3.29_f64, 11.31_f64);
    let (b, h) = (
        2.0 * r * alpha_deg.to_radians().sin(),
        2.0 * r * alpha_deg.to_radians().cos(),
    );
    let a = simulate_json(&["--half-diagonal", "3.29", "--alpha", "11.31"]);
    let w = simulate_json(&["--width", &b.to_string(), "--height", &h.to_string()]);
    assert!((a["alpha"].as_f64().unwrap() - alpha_deg.to_radians()).abs() < 1e-12);
    assert_eq!(a["status"], w["status"]);
    let (x, y) = (
        a["max_abs_theta"].as_f64().unwrap(),
        w["max_abs_theta"].as_f64().unwrap(),
    );
    assert!((x - y).abs() <= 1e-9 * y.abs().max(1.0), "{x} vs {y}");
}

#[test]
fn geometry_must_be_complete() {
    for block in [
        &["--width", "1.0"][..],
        &["--half-diagonal", "2.0"][..],
        &["--width", "1", "--height", "2", "--alpha", "10"][..],
    ] {
        let mut args = vec![
            "simulate",
            "--record",
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../tests/data/records/Rinaldi228.AT2"
            ),
            "--mu-s",
            "1.5",
            "--mu-k",
            "1.0",
        ];
        args.extend_from_slice(block);
        let out = Command::new(env!("CARGO_BIN_EXE_rockwatch"))
            .args(&args)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{block:?}");
    }
}

#[test]
fn plot_is_png_for_png_svg_for_svg_and_other_names_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let plot = |name: &str| {
        let path = dir.path().join(name);
        let out = Command::new(env!("CARGO_BIN_EXE_rockwatch"))
            .args([
                "simulate",
                "--record",
                concat!(
                    env!("CARGO_MANIFEST_DIR"),
                    "/../../tests/data/records/Rinaldi228.AT2"
                ),
                "--vertical",
                concat!(
                    env!("CARGO_MANIFEST_DIR"),
                    "/../../tests/data/records/RinaldiUP.AT2"
                ),
                "--width",
                "0.5806125494392025",
                "--height",
                "2.5",
                "--mu-s",
                "1.5",
                "--mu-k",
                "1.0",
                "--scale",
                "0.5",
                "--plot",
            ])
            .arg(&path)
            .output()
            .unwrap();
        (out, std::fs::read(&path).unwrap_or_default())
    };
    let (out, png) = plot("rinaldi.PNG");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    let (out, svg) = plot("rinaldi.svg");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let svg = String::from_utf8(svg).unwrap();
    assert!(svg.starts_with("<svg"), "not an SVG");
    // Rounded numbers, the scale, the vertical series and the ±1 lines of θ/α.
    assert!(
        svg.contains("B = 0.5806 m") && !svg.contains("0.5806125"),
        "title not rounded"
    );
    assert!(svg.contains("× 0.5"), "scale factor missing from the title");
    assert!(
        svg.contains("\nvertical\n") && svg.contains("\nhorizontal\n"),
        "legend"
    );
    let (out, jpg) = plot("rinaldi.jpg");
    assert!(!out.status.success() && jpg.is_empty());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains(".svg or .png"), "{stderr}");
}

/// Runs `rockwatch ARGS` and returns (success, stdout, stderr).
fn rockwatch(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rockwatch"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn simulate_and_fragility_share_one_rock_plan_mu_k_defaulting_to_mu_s() {
    let record = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/records/Rinaldi228.AT2"
    );
    let block = ["--width", "0.6", "--height", "2.5", "--format", "json"];
    let run = |friction: &[&str]| -> serde_json::Value {
        let mut args = vec!["simulate", "--record", record];
        args.extend_from_slice(friction);
        args.extend_from_slice(&block);
        let (ok, stdout, stderr) = rockwatch(&args);
        assert!(ok, "{friction:?}: {stderr}");
        serde_json::from_str(&stdout).unwrap()
    };
    // simulate once required --mu-k while fragility defaulted it to --mu-s.
    let implicit = run(&["--mu-s", "0.9"]);
    let explicit = run(&["--mu-s", "0.9", "--mu-k", "0.9"]);
    assert_eq!(implicit, explicit);
    assert_ne!(implicit, run(&["--mu-s", "0.9", "--mu-k", "0.3"]));
    // Without friction or geometry, both commands say what to give, in one line.
    let out = tempfile::tempdir().unwrap();
    let out = out.path().to_str().unwrap();
    for command in ["simulate", "fragility"] {
        let mut args = vec![command, "--width", "0.6", "--height", "2.5"];
        if command == "simulate" {
            args.extend(["--record", record]);
        } else {
            args.extend([
                "--records",
                record,
                "--im",
                "PGA",
                "--scales",
                "0.5:1:2",
                "--out",
                out,
            ]);
        }
        let (ok, _, stderr) = rockwatch(&args);
        assert!(
            !ok && stderr.contains("give the friction: --mu-s"),
            "{command}: {stderr}"
        );
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    }
    let (ok, _, stderr) = rockwatch(&["simulate", "--record", record, "--mu-s", "0.9"]);
    assert!(!ok && stderr.contains("give the geometry"), "{stderr}");
    assert!(stderr.contains("--mesh"), "{stderr}");
}
