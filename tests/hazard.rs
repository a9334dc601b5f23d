//! `rockwatch_core::hazard` and `rockwatch hazard`: the annual overturning rate
//! λ = ∫ P(overturn | im) |dλ_H(im)| against
//! - the closed form for a lognormal fragility and a power-law hazard curve,
//!   λ = k0 θ^(−k) exp(k²β²/2) (Cornell, Jalayer, Hamburger & Foutch 2002, eq. 11);
//! - a direct numerical integration of a curved (non-power-law) hazard curve, written here
//!   independently (midpoint sum of P·Δλ on a fine grid of the analytic curve);
//!
//! - issue 20 item 22: λ of every bootstrap replicate against the same closed form, λ's part
//!   between two levels against its closed form, E_T[exp(−λT)] of a truncated normal age
//!   against a direct quadrature written here, and fractile curves (tests/data/hazard, see its
//!   PROVENANCE.md) against the closed form and in order;
//!
//! and the unit handling and error messages.

use std::path::{Path, PathBuf};
use std::process::Command;

use rockwatch_core::hazard::{
    fractile_weights, overturn_rate, parse_openquake_csv, parse_two_column_csv, rate_density,
    rate_interval, rate_samples, CurveKind, ExposureAge, HazardCurve, ImUnit, Lognormal,
    SiteSelection,
};

const G: f64 = 9.80665;

/// Φ(z) = ½ + ∫₀^z φ by Simpson's rule on 2000 panels (error < 1e-14 for |z| ≤ 8; 0 or 1
/// beyond, where Φ differs from them by < 1e-15), independent of the library's Φ.
fn phi(z: f64) -> f64 {
    if z.abs() > 8.0 {
        return if z > 0.0 { 1.0 } else { 0.0 };
    }
    let n = 2000;
    let h = z / n as f64;
    let f = |x: f64| (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let mut s = f(0.0) + f(z);
    for i in 1..n {
        s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(i as f64 * h);
    }
    0.5 + s * h / 3.0
}

fn log_levels(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| (lo.ln() + (hi / lo).ln() * i as f64 / (n - 1) as f64).exp())
        .collect()
}

#[test]
fn power_law_hazard_and_lognormal_fragility_match_cornell_closed_form() {
    for (k0, k, theta, beta) in [
        (1e-4, 2.5, 0.4, 0.35),
        (3e-3, 1.5, 0.15, 0.6),
        (1e-5, 3.2, 1.2, 0.2),
    ] {
        let levels = log_levels(0.005, 20.0, 30);
        let rates: Vec<f64> = levels.iter().map(|x: &f64| k0 * x.powf(-k)).collect();
        let curve = HazardCurve::new(None, ImUnit::MetrePerSecond, levels, rates).unwrap();
        let rate = overturn_rate(&curve, &Lognormal::new(theta, beta).unwrap());
        let exact = k0 * theta.powf(-k) * (0.5 * k * k * beta * beta).exp();
        // A power law is reproduced exactly by the log-log interpolation; 20-point Gauss on
        // 16 panels per segment integrates the smooth integrand to ~1e-14; 1e-10 leaves room
        // for the tails cut at 40 β.
        assert!(
            ((rate.annual_rate - exact) / exact).abs() < 1e-10,
            "k0 {k0} k {k} θ {theta} β {beta}: {} vs {exact}",
            rate.annual_rate
        );
        assert!(rate.extrapolated_fraction < 1e-3);
        assert!((rate.return_period_years() - 1.0 / exact).abs() < 1e-9 / exact);
        assert!((rate.survival(1e4) - (-exact * 1e4).exp()).abs() < 1e-12);
    }
}

/// A curved hazard curve: λ_H(x) = a exp(−c (ln(x/x0))² − d ln(x/x0)), steepening with x
/// like real curves (decreasing for x > x0 e^(−d/2c) ≈ 3e-7).
fn curved(x: f64) -> f64 {
    let u = (x / 0.05).ln();
    2e-2 * (-0.05 * u * u - 1.2 * u).exp()
}

#[test]
fn curved_hazard_matches_direct_numerical_integration() {
    let fragility = Lognormal::new(0.35, 0.4).unwrap();
    // 60 tabulated levels (OpenQuake files have 20–50) from 1e-3 to 10.
    let levels = log_levels(1e-3, 10.0, 60);
    let rates: Vec<f64> = levels.iter().map(|&x| curved(x)).collect();
    let curve = HazardCurve::new(None, ImUnit::MetrePerSecond, levels, rates).unwrap();
    let engine = overturn_rate(&curve, &fragility).annual_rate;
    // Direct: Σ P(x_mid)(λ(x_i) − λ(x_{i+1})) on 2·10⁵ log-spaced points of the analytic
    // curve from 1e-4 to 1e4 (beyond, P·|dλ| is negligible: P(1e-4) ~ 1e-50, λ(1e4) ~ 1e-11).
    let n = 200_000;
    let grid = log_levels(1e-4, 1e4, n);
    let mut direct = 0.0;
    for w in grid.windows(2) {
        let mid = (w[0] * w[1]).sqrt();
        direct += phi((mid / 0.35).ln() / 0.4) * (curved(w[0]) - curved(w[1]));
    }
    // The engine interpolates the 60 levels log-linearly (a curvature error of
    // ~(Δ ln x)²·c/8 ≈ 3e-4 in ln λ per segment): agreement to 1e-3.
    assert!(
        ((engine - direct) / direct).abs() < 1e-3,
        "engine {engine} vs direct {direct}"
    );
}

fn openquake_text(imt: &str, time: f64, levels_oq: &[f64], rate: impl Fn(f64) -> f64) -> String {
    let mut text = format!(
        "#,,,,\"generated_by='OpenQuake engine 3.16.0', start_date='2024-01-01T00:00:00', \
         checksum=123, kind='mean', investigation_time={time}, imt='{imt}'\"\nlon,lat,depth"
    );
    for x in levels_oq {
        text.push_str(&format!(",poe-{x}"));
    }
    text.push_str("\n-118.48000,34.28000,0.00000E+00");
    for &x in levels_oq {
        let poe = -(-rate(x) * time).exp_m1();
        text.push_str(&format!(",{poe:.17e}"));
    }
    text.push('\n');
    text
}

#[test]
fn openquake_pgv_in_cm_per_s_is_converted_to_the_fragility_in_m_per_s() {
    // Power law in m/s: λ = k0 v^(−k); OpenQuake tabulates PGV in cm/s and PoE in 50 years.
    let (k0, k, theta, beta) = (2e-6, 2.2, 0.5, 0.3);
    let levels_cm: Vec<f64> = log_levels(0.5, 500.0, 25);
    let text = openquake_text("PGV", 50.0, &levels_cm, |x_cm| k0 * (x_cm / 100.0).powf(-k));
    let curve = parse_openquake_csv(&text, "oq.csv", SiteSelection::Row(0), None).unwrap();
    assert_eq!(curve.unit, ImUnit::CentimetrePerSecond);
    assert_eq!(curve.investigation_time_years, Some(50.0));
    let site = curve.site.unwrap();
    assert_eq!(
        (site.row, site.rows, site.lon, site.lat, site.distance_km),
        (0, 1, -118.48, 34.28, None)
    );
    let si = curve.converted_to(ImUnit::MetrePerSecond).unwrap();
    let rate = overturn_rate(&si, &Lognormal::new(theta, beta).unwrap()).annual_rate;
    let exact = k0 * theta.powf(-k) * (0.5 * k * k * beta * beta).exp();
    // PoE written with 17 digits and inverted by −ln(1 − PoE)/T: 1e-10.
    assert!(((rate - exact) / exact).abs() < 1e-10, "{rate} vs {exact}");
    // Without the conversion (cm/s read as m/s) the answer would be wrong by far.
    let wrong = overturn_rate(&curve, &Lognormal::new(theta, beta).unwrap()).annual_rate;
    assert!((wrong / exact).abs() > 10.0);
    // An acceleration curve cannot feed a velocity fragility.
    assert!(ImUnit::G.factor_to(ImUnit::MetrePerSecond).is_err());

    // The investigation time: from --investigation-time when the file lacks it; a
    // disagreement is refused.
    let bare = text.replace("investigation_time=50, ", "");
    assert!(
        parse_openquake_csv(&bare, "oq.csv", SiteSelection::Row(0), None)
            .unwrap_err()
            .to_string()
            .contains("investigation_time")
    );
    assert_eq!(
        parse_openquake_csv(&bare, "oq.csv", SiteSelection::Row(0), Some(50.0)).unwrap(),
        curve
    );
    assert!(
        parse_openquake_csv(&text, "oq.csv", SiteSelection::Row(0), Some(30.0))
            .unwrap_err()
            .to_string()
            .contains("disagrees")
    );
    assert!(
        parse_openquake_csv(&text, "oq.csv", SiteSelection::Row(1), None)
            .unwrap_err()
            .to_string()
            .contains("site 1 requested, the file has 1 site rows")
    );
}

#[test]
fn malformed_curves_are_refused_with_a_reason() {
    let two = |t: &str| {
        parse_two_column_csv(t, "h.csv", ImUnit::G)
            .unwrap_err()
            .to_string()
    };
    assert!(two("level,rate\n0.1,1e-2\n0.2,2e-2\n").contains("must not increase"));
    assert!(two("0.1,1e-2\n0.1,1e-3\n").contains("levels must increase"));
    assert!(two("0.1,1e-2\n0.2,x\n").contains("h.csv:2: \"x\" is not a number"));
    assert!(two("0.1,1e-2,3\n").contains("expected 2 cells"));
    assert!(two("0.1,1e-2\n").contains("at least two levels"));
    let ok = parse_two_column_csv(
        "# curve\nlevel_g,annual_rate\n0.1,1e-2\n0.2,1e-3\n",
        "h.csv",
        ImUnit::G,
    )
    .unwrap();
    assert_eq!(ok.levels, vec![0.1, 0.2]);
    let oq = |t: &str| {
        parse_openquake_csv(t, "oq.csv", SiteSelection::Row(0), None)
            .unwrap_err()
            .to_string()
    };
    assert!(oq("lon,lat,depth,poe-0.1\n").contains("comment line"));
    assert!(
        oq("#,investigation_time=50, imt='PGA'\nlon,lat,poe-0.1,poe-0.2\n1,2,0.1,0.01\n")
            .contains("lon,lat,depth")
    );
    assert!(oq(
        "#,investigation_time=50, imt='PGA'\nlon,lat,depth,poe-0.1,poe-0.2\n1,2,0,1.0,0.1\n"
    )
    .contains("probability in [0, 1)"));
}

// ---------------------------------------------------------------------------------------------
// CLI

fn cli(args: &[&str]) -> (bool, String, String) {
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

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rockwatch-hazard-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

#[test]
fn cli_prints_rate_return_period_and_survival_as_json() {
    let dir = temp_dir("json");
    let (k0, k, theta, beta) = (1e-3, 2.0, 0.6 * G, 0.4);
    // Fragility of PGA in m/s² (the §3 schema); hazard in g from OpenQuake.
    let fragility = write(
        &dir,
        "fragility.json",
        &format!(r#"{{"ims": {{"PGA": {{"median": {theta}, "beta": {beta}, "unit": "m/s2"}}}}}}"#),
    );
    let levels_g = log_levels(0.005, 5.0, 30);
    let curve = write(
        &dir,
        "hazard_curve-mean-PGA_1.csv",
        &openquake_text("PGA", 50.0, &levels_g, |g| k0 * (g * G).powf(-k)),
    );
    let (ok, stdout, stderr) = cli(&[
        "hazard",
        "--fragility",
        &fragility,
        "--im",
        "pga",
        "--hazard-curve",
        &curve,
        "--age-years",
        "10000,50000",
        "--format",
        "json",
    ]);
    assert!(ok, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let exact = k0 * theta.powf(-k) * (0.5 * k * k * beta * beta).exp();
    let lambda = json["annual_overturn_rate"].as_f64().unwrap();
    assert!(
        ((lambda - exact) / exact).abs() < 1e-9,
        "{lambda} vs {exact}"
    );
    assert!((json["return_period_years"].as_f64().unwrap() * exact - 1.0).abs() < 1e-9);
    for t in [10000.0, 50000.0] {
        let p = json["survival"][format!("{t}")].as_f64().unwrap();
        assert!((p - (-exact * t).exp()).abs() < 1e-9, "{t}: {p}");
    }
    assert_eq!(json["hazard_to_fragility_factor"].as_f64().unwrap(), G);

    // Text output names the numbers with their units.
    let (ok, text, _) = cli(&[
        "hazard",
        "--fragility",
        &fragility,
        "--im",
        "PGA",
        "--hazard-curve",
        &curve,
        "--age-years",
        "10000",
    ]);
    assert!(ok);
    assert!(
        text.contains("overturns per year") && text.contains("after 10000 years"),
        "{text}"
    );
    assert!(text.contains("× 9.80665 → m/s2"), "{text}");
}

#[test]
fn cli_reads_a_study_fragility_and_a_two_column_curve_and_refuses_mismatches() {
    let dir = temp_dir("study");
    // The schema written by `rockwatch study` (crates/rockwatch/src/study/report.rs).
    let study = write(
        &dir,
        "fragility.json",
        r#"{"blocks": {"rocking": {"im": "phv", "im_unit": "m/s", "a": 2.5, "b": 2.5,
            "covariance": [[0.1, 0.0], [0.0, 0.1]], "median": 0.3678794411714424, "beta": 0.4,
            "n": 100, "n_events": 40, "log_likelihood": -50.0}, "sliding": null}}"#,
    );
    let curve = write(
        &dir,
        "pgv.csv",
        "pgv_cm_s,annual_rate\n1,1e-1\n10,1e-2\n100,1e-4\n300,1e-6\n",
    );
    let base = |extra: &[&str]| {
        let mut args = vec![
            "hazard",
            "--fragility",
            &study,
            "--im",
            "PGV",
            "--hazard-curve",
            &curve,
            "--age-years",
            "20000",
            "--format",
            "json",
        ];
        args.extend_from_slice(extra);
        cli(&args)
    };
    let (ok, stdout, stderr) = base(&["--block", "rocking", "--hazard-unit", "cm/s"]);
    assert!(ok, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(json["hazard_to_fragility_factor"].as_f64().unwrap(), 0.01);
    let lambda = json["annual_overturn_rate"].as_f64().unwrap();
    assert!(lambda > 1e-5 && lambda < 1e-2, "{lambda}");

    let error = |extra: &[&str]| {
        let (ok, _, stderr) = base(extra);
        assert!(!ok);
        assert!(
            stderr.starts_with("rockwatch: error: ") && stderr.lines().count() <= 2,
            "{stderr}"
        );
        stderr
    };
    assert!(error(&["--hazard-unit", "cm/s"]).contains("choose one with --block"));
    assert!(error(&["--block", "sliding", "--hazard-unit", "cm/s"]).contains("no fragility curve"));
    assert!(error(&["--block", "rocking"]).contains("needs --hazard-unit"));
    assert!(error(&["--block", "rocking", "--hazard-unit", "g"]).contains("unit mismatch"));
    let (ok, _, stderr) = cli(&[
        "hazard",
        "--fragility",
        &study,
        "--im",
        "PGA",
        "--block",
        "rocking",
        "--hazard-curve",
        &curve,
        "--hazard-unit",
        "g",
        "--age-years",
        "1",
    ]);
    assert!(
        !ok && stderr.contains("is a function of \"phv\", not \"PGA\""),
        "{stderr}"
    );
}

/// Issue 20 item 23: `--lon --lat` take the OpenQuake file's nearest site, and say which and
/// how far (text and JSON); `--site N` still takes row N; both at once, or either with a
/// two-column curve (one site), are refused.
#[test]
fn cli_takes_the_nearest_site_to_lon_lat_and_says_its_distance() {
    let dir = temp_dir("nearest");
    let (k, theta, beta) = (2.0, 0.6 * G, 0.4);
    let fragility = write(
        &dir,
        "fragility.json",
        &format!(r#"{{"ims": {{"PGA": {{"median": {theta}, "beta": {beta}, "unit": "m/s2"}}}}}}"#),
    );
    // Three sites, each its own power law k0 im^(−k): the answer says which row was used.
    let sites = [
        (-118.0, 34.0, 1e-4),
        (-117.0, 34.0, 2e-4),
        (-116.0, 35.0, 4e-4),
    ];
    let levels_g = log_levels(0.005, 5.0, 30);
    let one_site = openquake_text("PGA", 1.0, &levels_g, |g| sites[0].2 * (g * G).powf(-k));
    let mut text: String = one_site.lines().take(2).map(|l| format!("{l}\n")).collect();
    for (lon, lat, k0) in sites {
        text.push_str(&format!("{lon},{lat},0"));
        for &x in &levels_g {
            let poe = -(-k0 * (x * G).powf(-k)).exp_m1();
            text.push_str(&format!(",{poe:.17e}"));
        }
        text.push('\n');
    }
    let curve = write(&dir, "hazard_curve-mean-PGA_3.csv", &text);
    let lambda = |k0: f64| k0 * theta.powf(-k) * (0.5 * k * k * beta * beta).exp();
    let base = [
        "hazard",
        "--fragility",
        &fragility,
        "--im",
        "PGA",
        "--hazard-curve",
        &curve,
        "--age-years",
        "10000",
    ];
    let run = |extra: &[&str]| cli(&[&base[..], extra].concat());

    // 0.1° north of site 2 (row 2): 0.1° of a meridian on the 6371.0088 km sphere.
    let (ok, stdout, stderr) = run(&["--lon", "-116", "--lat", "35.1", "--format", "json"]);
    assert!(ok, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let rate = json["annual_overturn_rate"].as_f64().unwrap();
    assert!(
        ((rate - lambda(4e-4)) / lambda(4e-4)).abs() < 1e-9,
        "{json}"
    );
    let site = &json["site"];
    assert_eq!(
        (site["row"].as_u64(), site["rows"].as_u64()),
        (Some(2), Some(3)),
        "{json}"
    );
    assert_eq!(
        (site["lon"].as_f64(), site["lat"].as_f64()),
        (Some(-116.0), Some(35.0))
    );
    assert_eq!(
        (
            site["requested_lon"].as_f64(),
            site["requested_lat"].as_f64()
        ),
        (Some(-116.0), Some(35.1))
    );
    let meridian_km = 6371.0088 * 0.1_f64.to_radians();
    let d = site["distance_km"].as_f64().unwrap();
    assert!((d - meridian_km).abs() < 1e-6, "{d} vs {meridian_km}");

    // The text says the site and the distance; between sites 0 and 1, nearer to 1 (0.4° of
    // longitude at 34° N: 6371.0088 km · 0.4° · cos 34° = 36.87 km).
    let (ok, stdout, stderr) = run(&["--lon", "-117.4", "--lat", "34"]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("site 1 of 3 at -117, 34, the nearest to -117.4, 34 (36.87 km)"),
        "{stdout}"
    );

    // --site N: that row, no distance.
    let (ok, stdout, stderr) = run(&["--site", "1", "--format", "json"]);
    assert!(ok, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(json["site"]["row"], 1);
    assert!(json["site"]["distance_km"].is_null(), "{json}");
    let rate = json["annual_overturn_rate"].as_f64().unwrap();
    assert!(((rate - lambda(2e-4)) / lambda(2e-4)).abs() < 1e-9);

    // Refused: --site with --lon/--lat, --lon without --lat, a position off the globe, and a
    // site choice for a two-column curve.
    let (ok, _, stderr) = run(&["--site", "1", "--lon", "-117", "--lat", "34"]);
    assert!(!ok && stderr.contains("cannot be used with"), "{stderr}");
    let (ok, _, stderr) = run(&["--lon", "-117"]);
    assert!(!ok && stderr.contains("--lat"), "{stderr}");
    let (ok, _, stderr) = run(&["--lon", "-117", "--lat", "95"]);
    assert!(!ok && stderr.contains("latitude in [-90, 90]"), "{stderr}");
    let two = write(&dir, "two.csv", "0.01,1e-2\n0.1,1e-4\n1,1e-6\n");
    let (ok, _, stderr) = cli(&[
        "hazard",
        "--fragility",
        &fragility,
        "--im",
        "PGA",
        "--hazard-curve",
        &two,
        "--hazard-unit",
        "g",
        "--age-years",
        "10000",
        "--lon",
        "-117",
        "--lat",
        "34",
    ]);
    assert!(!ok && stderr.contains("two-column"), "{stderr}");
}

/// Issue 20 item 20: `--units g` shows an acceleration fragility's median and the conversion
/// in g in the text; the JSON keeps the fragility's SI median and unit.
#[test]
fn units_g_shows_accelerations_in_g_in_text_and_keeps_si_in_json() {
    let dir = temp_dir("units");
    let theta = 4.2;
    let fragility = write(
        &dir,
        "fragility.json",
        &format!(r#"{{"ims": {{"PGA": {{"median": {theta}, "beta": 0.4, "unit": "m/s2"}}}}}}"#),
    );
    let levels_g = log_levels(0.005, 5.0, 30);
    let curve = write(
        &dir,
        "hazard_curve-mean-PGA_1.csv",
        &openquake_text("PGA", 50.0, &levels_g, |g| 1e-3 * (g * G).powf(-2.0)),
    );
    let run = |extra: &[&str]| {
        let mut args = vec![
            "hazard",
            "--fragility",
            &fragility,
            "--im",
            "PGA",
            "--hazard-curve",
            &curve,
            "--age-years",
            "10000",
        ];
        args.extend_from_slice(extra);
        let (ok, stdout, stderr) = cli(&args);
        assert!(ok, "{stderr}");
        stdout
    };
    let text = run(&["--units", "g"]);
    // 4.2 m/s² = 0.42828 g: four significant digits.
    assert!(text.contains("median 0.4283 g"), "{text}");
    assert!(text.contains("× 1 → g"), "{text}");
    let text = run(&[]);
    assert!(text.contains("median 4.2 m/s2"), "{text}");
    let json: serde_json::Value =
        serde_json::from_str(&run(&["--units", "g", "--format", "json"])).unwrap();
    assert_eq!(json["median"].as_f64(), Some(theta));
    assert_eq!(json["unit"], "m/s2");
}

/// Issue 20 item 25: the fragility's horizontal-component definition (fragility.json) against
/// the hazard's (--hazard-definition; OpenQuake's CSV does not carry it): said in the output,
/// a warning when they differ or when the fragility is one component and the hazard's unsaid.
#[test]
fn a_fragility_in_another_component_definition_than_the_hazard_is_warned_about() {
    let dir = temp_dir("definition");
    let levels_g = log_levels(0.005, 5.0, 30);
    let curve = write(
        &dir,
        "hazard_curve-mean-PGA_1.csv",
        &openquake_text("PGA", 50.0, &levels_g, |g| 1e-3 * (g * G).powf(-2.0)),
    );
    let run = |definition: &str, extra: &[&str]| {
        let fragility = write(
            &dir,
            &format!("fragility-{definition}.json"),
            &format!(
                r#"{{"ims": {{"PGA": {{"median": 4.0, "beta": 0.4, "unit": "m/s2", "horizontal_definition": "{definition}"}}}}}}"#
            ),
        );
        let mut args = vec![
            "hazard",
            "--fragility",
            &fragility,
            "--im",
            "PGA",
            "--hazard-curve",
            &curve,
            "--age-years",
            "10000",
        ];
        args.extend_from_slice(extra);
        let (ok, stdout, stderr) = cli(&args);
        assert!(ok, "{stderr}");
        (stdout, stderr)
    };
    let (text, stderr) = run("RotD50", &["--hazard-definition", "rotd50"]);
    assert!(
        text.contains("component   fragility RotD50, hazard RotD50"),
        "{text}"
    );
    assert!(!stderr.contains("warning"), "{stderr}");
    let (_, stderr) = run("GM", &["--hazard-definition", "rotd50"]);
    assert!(
        stderr.contains("warning: the fragility's PGA is GM and the hazard curve's RotD50"),
        "{stderr}"
    );
    let (text, stderr) = run("component", &[]);
    assert!(
        text.contains("fragility component, hazard not said"),
        "{text}"
    );
    assert!(
        stderr.contains("one horizontal component as recorded"),
        "{stderr}"
    );
    let (json, _) = run("RotD50", &["--hazard-definition", "gm", "--format", "json"]);
    let json: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(json["fragility_horizontal_definition"], "RotD50");
    assert_eq!(json["hazard_horizontal_definition"], "GM");
}

// ---------------------------------------------------------------------------------------------
// Issue 20 item 22: uncertainty of λ (fragility bootstrap, hazard fractiles) and of the age.

/// Cornell's closed form λ = k0 θ^(−k) exp(k²β²/2) of a power-law hazard k0 x^(−k) and a
/// lognormal fragility (θ, β).
fn cornell(k0: f64, k: f64, theta: f64, beta: f64) -> f64 {
    k0 * theta.powf(-k) * (0.5 * k * k * beta * beta).exp()
}

/// Type-7 percentile of `values` (R's default), written here: the value at position (n − 1) q
/// of the sorted values, interpolated linearly.
fn type7(values: &[f64], q: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let h = (v.len() - 1) as f64 * q;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    v[lo] + (h - lo as f64) * (v[hi] - v[lo])
}

fn power_law_curve(k0: f64, k: f64) -> HazardCurve {
    let levels = log_levels(0.005, 20.0, 30);
    let rates: Vec<f64> = levels.iter().map(|x: &f64| k0 * x.powf(-k)).collect();
    HazardCurve::new(None, ImUnit::MetrePerSecond, levels, rates).unwrap()
}

#[test]
fn each_bootstrap_replicate_matches_cornell_and_the_interval_is_their_type_7_percentiles() {
    let (k0, k) = (2e-4, 2.2);
    let curve = power_law_curve(k0, k);
    let replicates: Vec<Lognormal> = [
        (0.40, 0.30),
        (0.35, 0.42),
        (0.52, 0.25),
        (0.44, 0.38),
        (0.38, 0.33),
        (0.47, 0.45),
        (0.41, 0.29),
    ]
    .iter()
    .map(|&(m, b)| Lognormal::new(m, b).unwrap())
    .collect();
    let samples = rate_samples(&[(&curve, 1.0)], &replicates);
    assert_eq!(samples.len(), replicates.len());
    let exact: Vec<f64> = replicates
        .iter()
        .map(|r| cornell(k0, k, r.median, r.beta))
        .collect();
    for (s, (r, e)) in samples.iter().zip(replicates.iter().zip(&exact)) {
        assert_eq!(s.curve, 0);
        assert!((s.weight - 1.0 / 7.0).abs() < 1e-15);
        assert!(
            ((s.annual_rate - e) / e).abs() < 1e-10,
            "replicate {r:?}: {} vs {e}",
            s.annual_rate
        );
    }
    // Equal weights: the 2.5 and 97.5 % percentiles of type 7, as the fragility's own
    // bootstrap intervals.
    let [lo, hi] = rate_interval(&samples).unwrap();
    for (got, q) in [(lo, 0.025), (hi, 0.975)] {
        let want = type7(&exact, q);
        assert!(((got - want) / want).abs() < 1e-10, "{q}: {got} vs {want}");
    }
    assert!(rate_interval(&[]).is_none());
}

#[test]
fn fractile_weights_are_the_probabilities_between_midpoints() {
    let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-15);
    assert!(close(
        &fractile_weights(&[0.16, 0.5, 0.84]).unwrap(),
        &[0.33, 0.34, 0.33]
    ));
    assert!(close(
        &fractile_weights(&[0.05, 0.5, 0.95]).unwrap(),
        &[0.275, 0.45, 0.275]
    ));
    assert!(close(&fractile_weights(&[0.1, 0.9]).unwrap(), &[0.5, 0.5]));
    assert!(fractile_weights(&[0.5, 0.16]).is_err());
    assert!(fractile_weights(&[0.0, 0.5]).is_err());
}

/// The part of λ between IM levels a and b for a power-law hazard k0 x^(−k) and a lognormal
/// fragility, by parts: P(a) λ_H(a) − P(b) λ_H(b) + k0 θ^(−k) e^(k²β²/2) [Φ(z_b + kβ) −
/// Φ(z_a + kβ)], z = ln(x/θ)/β.
#[test]
fn contribution_by_level_matches_its_closed_form_and_adds_up_to_lambda() {
    let (k0, k, theta, beta) = (1e-4, 2.5, 0.4, 0.35);
    let curve = power_law_curve(k0, k);
    let fragility = Lognormal::new(theta, beta).unwrap();
    let rate = overturn_rate(&curve, &fragility);
    let total = cornell(k0, k, theta, beta);
    assert_eq!(rate.by_level.len(), curve.levels.len() + 1);
    assert_eq!(rate.by_level[0].lower, 0.0);
    assert_eq!(rate.by_level.last().unwrap().upper, f64::INFINITY);
    let sum: f64 = rate.by_level.iter().map(|c| c.annual_rate).sum();
    assert!(((sum - rate.annual_rate) / total).abs() < 1e-12);
    let p = |x: f64| phi((x / theta).ln() / beta);
    let h = |x: f64| k0 * x.powf(-k);
    for c in &rate.by_level[1..rate.by_level.len() - 1] {
        let (a, b) = (c.lower, c.upper);
        let za = (a / theta).ln() / beta;
        let zb = (b / theta).ln() / beta;
        let exact = p(a) * h(a) - p(b) * h(b) + total * (phi(zb + k * beta) - phi(za + k * beta));
        assert!(
            (c.annual_rate - exact).abs() < 1e-9 * total,
            "{a}..{b}: {} vs {exact}",
            c.annual_rate
        );
    }
    // The density at the median: P = 1/2, k λ_H(θ).
    let d = rate_density(&curve, &fragility, theta);
    assert!((d - 0.5 * k * h(theta)).abs() < 1e-12 * d);
}

/// E[exp(−λT)] for T normal (μ, σ) truncated at 0, by Simpson's rule on [0, μ + 12σ] with
/// 20 000 panels, over the truncated normal's normalisation, both written here.
fn survival_by_quadrature(lambda: f64, mu: f64, sigma: f64) -> f64 {
    let n = 20_000;
    let top = mu + 12.0 * sigma;
    let h = top / n as f64;
    let density = |t: f64| (-0.5 * ((t - mu) / sigma).powi(2)).exp();
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..=n {
        let t = i as f64 * h;
        let w = if i == 0 || i == n {
            1.0
        } else if i % 2 == 1 {
            4.0
        } else {
            2.0
        };
        num += w * density(t) * (-lambda * t).exp();
        den += w * density(t);
    }
    num / den
}

#[test]
fn survival_over_a_normal_age_matches_its_closed_form_and_quadrature() {
    for (lambda, mu, sigma) in [
        (1e-4, 10_000.0, 2_000.0),
        (1e-4, 10_000.0, 8_000.0), // truncation matters: μ/σ = 1.25
        (5e-4, 3_000.0, 6_000.0),  // mostly truncated
        (2e-3, 15_000.0, 4_000.0), // λσ = 8: exp(λ²σ²/2) alone is e³²
        (1e-5, 0.0, 5_000.0),      // half-normal
    ] {
        let age = ExposureAge::new(mu, sigma).unwrap();
        let got = age.survival(lambda);
        let quadrature = survival_by_quadrature(lambda, mu, sigma);
        assert!(
            ((got - quadrature) / quadrature).abs() < 1e-8,
            "λ {lambda} μ {mu} σ {sigma}: {got} vs {quadrature}"
        );
        // Jensen: averaging over the age raises the survival above exp(−λ E[T]) for the
        // untruncated normal; here against the closed form without truncation when μ ≫ σ.
        if mu > 4.0 * sigma {
            let untruncated = (-lambda * mu + 0.5 * (lambda * sigma).powi(2)).exp();
            assert!(((got - untruncated) / untruncated).abs() < 1e-4);
        }
    }
    // σ → 0: exp(−λT).
    for sigma in [0.0, 1e-6, 1e-2] {
        let got = ExposureAge::new(12_000.0, sigma).unwrap().survival(8e-5);
        assert!(
            (got - (-8e-5_f64 * 12_000.0).exp()).abs() < 1e-9,
            "{sigma}: {got}"
        );
    }
    assert_eq!(ExposureAge::new(5.0, 1.0).unwrap().survival(0.0), 1.0);
    assert!(ExposureAge::new(-1.0, 1.0).is_err());
    assert!(ExposureAge::new(1.0, -1.0).is_err());
    assert!(ExposureAge::new(1.0, f64::NAN).is_err());
}

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/hazard");

/// The fixtures' power laws (tests/data/hazard/PROVENANCE.md): (file, kind, k0), x in g.
const FRACTILE_FILES: [(&str, &str, f64); 4] = [
    ("quantile_curve-0.16-PGA_42.csv", "quantile-0.16", 0.5e-5),
    ("quantile_curve-0.5-PGA_42.csv", "quantile-0.5", 0.8e-5),
    ("hazard_curve-mean-PGA_42.csv", "mean", 1.0e-5),
    ("quantile_curve-0.84-PGA_42.csv", "quantile-0.84", 2.0e-5),
];

#[test]
fn openquake_fractile_curves_are_read_with_their_kind_and_order_lambda() {
    let fragility = Lognormal::new(0.5, 0.4).unwrap();
    let mut lambdas = Vec::new();
    for (file, kind, k0) in FRACTILE_FILES {
        let text = std::fs::read_to_string(format!("{DATA}/{file}")).unwrap();
        let curve = parse_openquake_csv(&text, file, SiteSelection::Row(0), None).unwrap();
        assert_eq!(
            curve.kind.as_ref().map(ToString::to_string).as_deref(),
            Some(kind)
        );
        assert_eq!(curve.unit, ImUnit::G);
        let lambda = overturn_rate(&curve, &fragility).annual_rate;
        let exact = cornell(k0, 2.5, 0.5, 0.4);
        // Levels written with 6 digits (a power law still, exactly interpolated), PoE with
        // 17: 1e-8.
        assert!(
            ((lambda - exact) / exact).abs() < 1e-8,
            "{file}: {lambda} vs {exact}"
        );
        lambdas.push(lambda);
    }
    // q16 ≤ q50 ≤ mean ≤ q84 (the order of the files above).
    assert!(lambdas.windows(2).all(|w| w[0] <= w[1]), "{lambdas:?}");
    assert_eq!(CurveKind::parse("quantile-0.16"), CurveKind::Quantile(0.16));
    assert_eq!(CurveKind::parse("mean"), CurveKind::Mean);
    assert_eq!(
        CurveKind::parse("rlz-003"),
        CurveKind::Other("rlz-003".into())
    );
    assert_eq!(
        CurveKind::parse("quantile-1.5"),
        CurveKind::Other("quantile-1.5".into())
    );
}

/// The fixture fragility's replicates (tests/data/hazard/fragility_pga_bootstrap.json), g.
const REPLICATES_G: [(f64, f64); 9] = [
    (0.42, 0.35),
    (0.45, 0.42),
    (0.47, 0.38),
    (0.49, 0.45),
    (0.5, 0.4),
    (0.52, 0.36),
    (0.55, 0.44),
    (0.58, 0.39),
    (0.6, 0.47),
];

fn fixture_run(extra: &[&str]) -> (bool, String, String) {
    let fragility = format!("{DATA}/fragility_pga_bootstrap.json");
    let files: Vec<String> = FRACTILE_FILES
        .iter()
        .map(|f| format!("{DATA}/{}", f.0))
        .collect();
    let mut args = vec![
        "hazard",
        "--fragility",
        &fragility,
        "--im",
        "PGA",
        "--hazard-curve",
    ];
    args.extend(files.iter().map(String::as_str));
    args.extend_from_slice(extra);
    cli(&args)
}

#[test]
fn cli_combines_fractile_curves_and_bootstrap_replicates_into_intervals() {
    let dir = temp_dir("fractiles");
    let plots = dir.join("plots");
    let (ok, stdout, stderr) = fixture_run(&[
        "--age-years",
        "10000,20000",
        "--age-sigma-years",
        "2000,4000",
        "--hazard-definition",
        "rotd50",
        "--plots",
        plots.to_str().unwrap(),
        "--format",
        "json",
    ]);
    assert!(ok, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    let pair = |v: &serde_json::Value| [f(&v[0]), f(&v[1])];
    // λ from the mean curve and the fitted fragility (0.5 g, β 0.4).
    let mean = cornell(1e-5, 2.5, 0.5, 0.4);
    let lambda = f(&json["annual_overturn_rate"]);
    assert!(((lambda - mean) / mean).abs() < 1e-8, "{lambda} vs {mean}");
    // Each curve: its kind, quantile, weight and λ against the closed form.
    let curves = json["hazard_curves"].as_array().unwrap();
    assert_eq!(curves.len(), 4);
    let weights = [Some(0.33), Some(0.34), None, Some(0.33)];
    for ((c, (_, kind, k0)), w) in curves.iter().zip(FRACTILE_FILES).zip(weights) {
        assert_eq!(c["kind"], kind);
        assert_eq!(c["central"], kind == "mean");
        let exact = cornell(k0, 2.5, 0.5, 0.4);
        let got = f(&c["annual_overturn_rate"]);
        assert!(
            ((got - exact) / exact).abs() < 1e-8,
            "{kind}: {got} vs {exact}"
        );
        match w {
            Some(w) => assert!((f(&c["weight"]) - w).abs() < 1e-12, "{c}"),
            None => assert!(c["weight"].is_null()),
        }
        // Each curve's interval over the 9 replicates: type 7 of the closed forms.
        let per_replicate: Vec<f64> = REPLICATES_G
            .iter()
            .map(|&(m, b)| cornell(k0, 2.5, m, b))
            .collect();
        let [lo, hi] = pair(&c["annual_overturn_rate_interval"]);
        assert!(
            ((lo - type7(&per_replicate, 0.025)) / lo).abs() < 1e-8,
            "{kind}"
        );
        assert!(
            ((hi - type7(&per_replicate, 0.975)) / hi).abs() < 1e-8,
            "{kind}"
        );
    }
    // The hazard alone: the 3 fractiles with weights 0.33, 0.34, 0.33 sit at the positions
    // 0, 1/2, 1 of the weighted percentile (docs/hazard.md), so the 2.5 % percentile is
    // λ16 + 0.05 (λ50 − λ16) and the 97.5 % one λ50 + 0.95 (λ84 − λ50).
    let l = |k0: f64| cornell(k0, 2.5, 0.5, 0.4);
    let (l16, l50, l84) = (l(0.5e-5), l(0.8e-5), l(2e-5));
    let [lo, hi] = pair(&json["interval"]["hazard_only"]);
    assert!(
        ((lo - (l16 + 0.05 * (l50 - l16))) / lo).abs() < 1e-8,
        "{lo}"
    );
    assert!(
        ((hi - (l50 + 0.95 * (l84 - l50))) / hi).abs() < 1e-8,
        "{hi}"
    );
    // The combined interval: within the product distribution's range, around λ, wider than
    // each source's spread alone at the low end.
    let product: Vec<f64> = [0.5e-5, 0.8e-5, 2e-5]
        .iter()
        .flat_map(|&k0| {
            REPLICATES_G
                .iter()
                .map(move |&(m, b)| cornell(k0, 2.5, m, b))
        })
        .collect();
    let [lo, hi] = pair(&json["annual_overturn_rate_interval"]);
    let min = product.iter().copied().fold(f64::INFINITY, f64::min);
    let max = product.iter().copied().fold(0.0, f64::max);
    assert!(
        min <= lo && lo < lambda && lambda < hi && hi <= max,
        "{lo} {hi}"
    );
    assert!(lo < f(&json["interval"]["hazard_only"][0]));
    assert_eq!(json["interval"]["samples"], 27);
    assert_eq!(json["interval"]["fragility_bootstrap_replicates"], 9);
    assert_eq!(
        json["interval"]["hazard_fractiles"],
        serde_json::json!([0.16, 0.5, 0.84])
    );
    let [rp_lo, rp_hi] = pair(&json["return_period_interval_years"]);
    assert!((rp_lo * hi - 1.0).abs() < 1e-12 && (rp_hi * lo - 1.0).abs() < 1e-12);
    // Survival: E_T[exp(−λT)] by quadrature at λ and at the interval's ends.
    for (entry, (mu, sigma)) in json["survival_by_age"]
        .as_array()
        .unwrap()
        .iter()
        .zip([(10_000.0, 2_000.0), (20_000.0, 4_000.0)])
    {
        assert_eq!(
            (f(&entry["age_years"]), f(&entry["age_sigma_years"])),
            (mu, sigma)
        );
        let p = f(&entry["survival"]);
        let q = survival_by_quadrature(mean, mu, sigma);
        assert!(((p - q) / q).abs() < 1e-6, "{p} vs {q}");
        assert_eq!(f(&json["survival"][format!("{mu}")]), p);
        let [s_lo, s_hi] = pair(&entry["survival_interval"]);
        let q_lo = survival_by_quadrature(hi, mu, sigma);
        let q_hi = survival_by_quadrature(lo, mu, sigma);
        assert!(((s_lo - q_lo) / q_lo).abs() < 1e-6 && ((s_hi - q_hi) / q_hi).abs() < 1e-6);
        assert!(s_lo < p && p < s_hi);
    }
    // The contribution by level adds up to λ.
    let parts: f64 = json["contribution_by_level"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| f(&c["annual_overturn_rate"]))
        .sum();
    assert!(((parts - lambda) / lambda).abs() < 1e-12);
    // The plots: three figures, SVG and PNG, with their content.
    let written: Vec<&str> = json["plots"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap())
        .collect();
    assert_eq!(written.len(), 6, "{written:?}");
    for (stem, words) in [
        ("hazard_curves", ["quantile-0.84", "bootstrap band"]),
        ("hazard_deaggregation", ["dλ/d(ln PGA)", "quantile-0.16"]),
        ("hazard_survival", ["T ± σ", "95 % interval of λ"]),
    ] {
        let svg = std::fs::read_to_string(plots.join(format!("{stem}.svg"))).unwrap();
        assert!(svg.len() > 10_000, "{stem}.svg: {} bytes", svg.len());
        for w in words {
            assert!(svg.contains(w), "{stem}.svg lacks {w:?}");
        }
        let png = std::fs::read(plots.join(format!("{stem}.png"))).unwrap();
        assert!(
            png.starts_with(b"\x89PNG") && png.len() > 20_000,
            "{stem}.png"
        );
    }

    // The text: significant digits, the interval and its sources, each curve's λ.
    let (ok, text, stderr) = fixture_run(&[
        "--age-years",
        "10000",
        "--age-sigma-years",
        "2000",
        "--hazard-definition",
        "rotd50",
    ]);
    assert!(ok, "{stderr}");
    assert!(
        text.contains("λ           9.327e-5 overturns per year (95 %: "),
        "{text}"
    );
    assert!(
        text.contains(
            "over 9 fragility bootstrap replicates × 3 hazard fractiles (0.16, 0.5, 0.84; \
             weights 0.33, 0.34, 0.33)"
        ),
        "{text}"
    );
    assert!(
        text.contains("by curve    quantile-0.16 4.663e-5, quantile-0.5 7.461e-5, mean 9.327e-5"),
        "{text}"
    );
    assert!(text.contains("after 10000 ± 2000 years (95 %: "), "{text}");
    assert!(text.contains("(mean; 30 levels 0.05 to 5 g"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn cli_refuses_inconsistent_fractile_sets_and_age_sigmas() {
    let dir = temp_dir("fractile-errors");
    let error = |args: &[&str]| {
        let (ok, _, stderr) = cli(args);
        assert!(!ok);
        assert!(stderr.starts_with("rockwatch: error: "), "{stderr}");
        stderr
    };
    let fragility = format!("{DATA}/fragility_pga_bootstrap.json");
    let file = |name: &str| format!("{DATA}/{name}");
    let (mean, q16, q84) = (
        file("hazard_curve-mean-PGA_42.csv"),
        file("quantile_curve-0.16-PGA_42.csv"),
        file("quantile_curve-0.84-PGA_42.csv"),
    );
    let base = [
        "hazard",
        "--fragility",
        &fragility,
        "--im",
        "PGA",
        "--age-years",
        "1000",
    ];
    let with = |curves: &[&str], extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = base.iter().map(|s| s.to_string()).collect();
        v.push("--hazard-curve".into());
        v.extend(curves.iter().map(|s| s.to_string()));
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let run = |v: Vec<String>| error(&v.iter().map(String::as_str).collect::<Vec<_>>());
    // Only one quantile besides the mean: no interval can be formed from it.
    assert!(run(with(&[&mean, &q16], &[])).contains("at least two quantile curves"));
    // Two quantiles, neither the mean nor the median: which gives λ?
    assert!(run(with(&[&q16, &q84], &[])).contains("the mean"));
    assert!(run(with(&[&mean, &mean, &q16, &q84], &[])).contains("a second mean"));
    // A two-column curve has no kind.
    let two = write(&dir, "two.csv", "0.01,1e-2\n0.1,1e-4\n1,1e-6\n");
    assert!(run(with(&[&mean, &two], &["--hazard-unit", "g"])).contains("kind"));
    // Another site.
    let other = std::fs::read_to_string(&q84)
        .unwrap()
        .replace("-118.48000,34.28000", "-117.00000,34.28000");
    let other = write(&dir, "q84-elsewhere.csv", &other);
    assert!(run(with(&[&mean, &q16, &other], &[])).contains("one site"));
    // σ: one, or one per age; finite, ≥ 0.
    assert!(run(with(&[&mean], &["--age-sigma-years", "1,2"])).contains("one per age"));
    assert!(run(with(&[&mean], &["--age-sigma-years", "-5"])).contains("≥ 0"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A fragility.json without `bootstrap.median_beta` (written before issue 20 item 22, or
/// with --bootstrap 0) and one curve: λ as before, no interval.
#[test]
fn without_replicates_or_fractiles_there_is_no_interval() {
    let dir = temp_dir("no-interval");
    let fragility = write(
        &dir,
        "fragility.json",
        r#"{"ims": {"PGA": {"median": 4.903325, "beta": 0.4, "unit": "m/s2",
            "bootstrap": {"replicates": 0, "failed": 0}}}}"#,
    );
    let (ok, stdout, stderr) = cli(&[
        "hazard",
        "--fragility",
        &fragility,
        "--im",
        "PGA",
        "--hazard-curve",
        &format!("{DATA}/hazard_curve-mean-PGA_42.csv"),
        "--age-years",
        "10000",
        "--format",
        "json",
    ]);
    assert!(ok, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert!(json["annual_overturn_rate_interval"].is_null());
    assert!(json["survival_by_age"][0]["survival_interval"].is_null());
    assert_eq!(json["interval"]["samples"], 0);
    let exact = cornell(1e-5, 2.5, 0.5, 0.4);
    let p = json["survival"]["10000"].as_f64().unwrap();
    assert!((p - (-exact * 1e4).exp()).abs() < 1e-9);
    // A replicate that is not [median > 0, beta > 0] is refused, naming it.
    let bad = write(
        &dir,
        "bad.json",
        r#"{"ims": {"PGA": {"median": 4.9, "beta": 0.4, "unit": "m/s2",
            "bootstrap": {"median_beta": [[4.0, 0.3], [4.0, -1]]}}}}"#,
    );
    let (ok, _, stderr) = cli(&[
        "hazard",
        "--fragility",
        &bad,
        "--im",
        "PGA",
        "--hazard-curve",
        &format!("{DATA}/hazard_curve-mean-PGA_42.csv"),
        "--age-years",
        "10000",
    ]);
    assert!(!ok && stderr.contains("median_beta[1]"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
