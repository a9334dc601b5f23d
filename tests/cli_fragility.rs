//! `rockwatch fragility` end to end on the bundled records: the fragility.json schema that
//! `rockwatch hazard` reads (the chain checked against Cornell's closed form with the fitted
//! median and β), runs.csv and plots, results independent of the thread count, the catalogue
//! ensemble, and one-line errors for bad input.

use std::path::PathBuf;
use std::process::Command;

const RECORDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/records");

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
    let dir =
        std::env::temp_dir().join(format!("rockwatch-fragility-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn vertical_pair() -> String {
    format!("Rinaldi228.AT2={RECORDS}/RinaldiUP.AT2")
}

/// The slender block of the README over the bundled records (the vertical paired by name).
fn run_block(out: &str, threads: &str, extra: &[&str]) -> (bool, String, String) {
    let pair = vertical_pair();
    let mut args = vec![
        "fragility",
        "--width",
        "0.4",
        "--height",
        "1.6",
        "--mu-s",
        "0.7",
        "--records",
        RECORDS,
        "--vertical-records",
        &pair,
        "--im",
        "PGV,PGA,PGV/PGA,SA(1.0)",
        "--stripes",
        "PGV:0.1:2.0:10",
        "--bootstrap",
        "60",
        "--threads",
        threads,
        "--out",
        out,
    ];
    args.extend_from_slice(extra);
    cli(&args)
}

#[test]
fn fragility_json_feeds_rockwatch_hazard() {
    let dir = temp_dir("chain");
    let out = dir.join("out");
    let (ok, stdout, stderr) = run_block(out.to_str().unwrap(), "0", &["--format", "json"]);
    assert!(ok, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("fragility.json")).unwrap())
            .unwrap();
    assert_eq!(json, file);
    // The schema of issue 14 §3, per IM.
    let pgv = &json["ims"]["PGV"];
    let (median, beta) = (
        pgv["median"].as_f64().unwrap(),
        pgv["beta"].as_f64().unwrap(),
    );
    assert!(median > 0.0 && beta > 0.0);
    for key in ["median", "beta"] {
        let ci = pgv["ci95"][key].as_array().unwrap();
        assert_eq!(ci.len(), 2);
        assert!(ci[0].as_f64().unwrap() <= ci[1].as_f64().unwrap());
    }
    assert_eq!(pgv["unit"], "m/s");
    assert_eq!(json["ims"]["SA(1.0)"]["unit"], "m/s2");
    // 7 horizontal records (RinaldiUP is Rinaldi228's vertical) × 10 stripes × 2 incidences.
    assert_eq!(json["runs"]["total"], 140);
    let usable = json["runs"]["usable"].as_u64().unwrap();
    assert_eq!(pgv["n_runs"].as_u64().unwrap(), usable);
    let overturned = pgv["n_overturned"].as_u64().unwrap();
    assert!(overturned > 0 && overturned < usable);
    assert!(json["not_fitted"]["PGV/PGA"].is_string());
    // Ranked by β.
    let ranking = json["ranking"].as_array().unwrap();
    let betas: Vec<f64> = ranking
        .iter()
        .map(|r| r["beta"].as_f64().unwrap())
        .collect();
    assert!(betas.windows(2).all(|w| w[0] <= w[1]), "{betas:?}");
    // The surface PGA × PGV/PGA on its grid.
    let surface = &json["surface"];
    assert_eq!(surface["ims"], serde_json::json!(["PGA", "PGV/PGA"]));
    let p = surface["grid"]["p"].as_array().unwrap();
    assert_eq!(p.len(), 41);
    // Every run in runs.csv (header + 140 rows), the plots written.
    let csv = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    assert_eq!(csv.lines().count(), 141);
    assert!(csv.lines().next().unwrap().contains("PGV (m/s)"));
    for f in [
        "fragility_PGV.svg",
        "fragility_PGV.png",
        "fragility_SA_1p0.png",
        "surface_PGA_PGV_PGA.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }

    // rockwatch hazard reads fragility.json as it is. With a power-law hazard curve
    // λ_H(x) = k0 x^−k (x in cm/s) the rate has the closed form k0 θ^−k exp(k²β²/2)
    // (Cornell et al. 2002), θ in cm/s: the chain is right if the hazard step used this
    // median, this β and the m/s → cm/s conversion.
    let (k0, k) = (1e-4_f64, 2.5_f64);
    let mut curve = String::from("pgv_cm_s,annual_rate\n");
    for i in 0..40 {
        let x = (0.5_f64.ln() + (2000.0_f64.ln() - 0.5_f64.ln()) * i as f64 / 39.0).exp();
        curve.push_str(&format!("{x},{}\n", k0 * x.powf(-k)));
    }
    let curve_path = dir.join("pgv.csv");
    std::fs::write(&curve_path, curve).unwrap();
    let (ok, stdout, stderr) = cli(&[
        "hazard",
        "--fragility",
        out.join("fragility.json").to_str().unwrap(),
        "--im",
        "PGV",
        "--hazard-curve",
        curve_path.to_str().unwrap(),
        "--hazard-unit",
        "cm/s",
        "--age-years",
        "10000",
        "--format",
        "json",
    ]);
    assert!(ok, "{stderr}");
    let h: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let lambda = h["annual_overturn_rate"].as_f64().unwrap();
    let exact = k0 * (median * 100.0).powf(-k) * (0.5 * k * k * beta * beta).exp();
    assert!(
        ((lambda - exact) / exact).abs() < 1e-6,
        "{lambda} vs {exact}"
    );
    // Issue 20 item 22: fragility.json stores the replicates' (median, β), one per replicate
    // that had a fit, and hazard's interval on λ is the 2.5–97.5 % percentiles (type 7, as
    // the fragility's ci95) of their closed-form λ.
    let boot = &pgv["bootstrap"];
    let pairs = boot["median_beta"].as_array().unwrap();
    assert_eq!(
        pairs.len() as u64,
        boot["replicates"].as_u64().unwrap() - boot["failed"].as_u64().unwrap()
    );
    let mut replicate_lambdas: Vec<f64> = pairs
        .iter()
        .map(|p| {
            let (m, b) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
            k0 * (m * 100.0).powf(-k) * (0.5 * k * k * b * b).exp()
        })
        .collect();
    replicate_lambdas.sort_by(f64::total_cmp);
    let type7 = |q: f64| {
        let h = (replicate_lambdas.len() - 1) as f64 * q;
        let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
        replicate_lambdas[lo] + (h - lo as f64) * (replicate_lambdas[hi] - replicate_lambdas[lo])
    };
    let interval = &h["annual_overturn_rate_interval"];
    for (i, q) in [(0, 0.025), (1, 0.975)] {
        let got = interval[i].as_f64().unwrap();
        assert!(
            ((got - type7(q)) / got).abs() < 1e-6,
            "{q}: {got} vs {}",
            type7(q)
        );
    }
    assert_eq!(h["interval"]["fragility_bootstrap_replicates"], pairs.len());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let dir = temp_dir("threads");
    let (a, b) = (dir.join("one"), dir.join("two"));
    let (ok, _, stderr) = run_block(a.to_str().unwrap(), "1", &["--no-plots"]);
    assert!(ok, "{stderr}");
    let (ok, _, stderr) = run_block(b.to_str().unwrap(), "2", &["--no-plots"]);
    assert!(ok, "{stderr}");
    for f in ["fragility.json", "runs.csv"] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f} differs between 1 and 2 threads"
        );
    }
    // And another seed gives other bootstrap intervals (the seed is used).
    let c = dir.join("seed");
    let (ok, _, stderr) = run_block(c.to_str().unwrap(), "2", &["--no-plots", "--seed", "7"]);
    assert!(ok, "{stderr}");
    let ci = |d: &PathBuf| {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.join("fragility.json")).unwrap())
                .unwrap();
        v["ims"]["PGV"]["ci95"].clone()
    };
    assert_ne!(ci(&a), ci(&c));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn catalogue_ensemble_members_multiply_the_runs() {
    let dir = temp_dir("ensemble");
    let catalogue = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/catalogue.toml");
    let records = format!("{RECORDS}/Rinaldi228.AT2,{RECORDS}/RSN1084_NORTHR_SCS142.AT2");
    let out = dir.join("out");
    let (ok, stdout, stderr) = cli(&[
        "fragility",
        "--pbr",
        "rrs-pinnacle-ensemble",
        "--catalogue",
        catalogue,
        "--ensemble",
        "3",
        "--records",
        &records,
        "--im",
        "PGA",
        "--scales",
        "0.25:4:6",
        "--azimuths",
        "0:360:90",
        "--bootstrap",
        "0",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
        "--format",
        "json",
    ]);
    // 2 records × 6 factors × 3 members × 4 incidences; the fit may or may not exist with
    // two records, the runs must.
    let json: serde_json::Value = serde_json::from_str(&stdout).unwrap_or_default();
    assert!(ok || stderr.contains("no IM could be fitted"), "{stderr}");
    let text = std::fs::read_to_string(out.join("fragility.json")).unwrap();
    let file: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(file["runs"]["total"], 144, "{json}");
    assert_eq!(file["members"], 3);
    assert_eq!(file["rock"]["ensemble"], 3);
    assert_eq!(
        file["incidences_deg"],
        serde_json::json!([0.0, 90.0, 180.0, 270.0])
    );
    // At 90° and 270° a single component has no projection on the rock's x axis: those runs
    // stand still.
    let csv = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    for line in csv.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        if cols[5] == "90" || cols[5] == "270" {
            assert_eq!(cols[6], "standing", "{line}");
            assert_eq!(cols[8], "0", "{line}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_gets_a_one_line_error() {
    let dir = temp_dir("errors");
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    let rec = format!("{RECORDS}/Rinaldi228.AT2");
    let base = |extra: &[&str]| {
        let mut args = vec![
            "fragility",
            "--width",
            "0.4",
            "--height",
            "1.6",
            "--mu-s",
            "0.7",
            "--records",
            &rec,
            "--out",
            out,
            "--no-plots",
        ];
        args.extend_from_slice(extra);
        let (ok, _, stderr) = cli(&args);
        assert!(!ok);
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        stderr
    };
    assert!(base(&["--im", "PGV/PGA", "--stripes", "PGV/PGA:0.1:1:5"])
        .contains("does not change when a record is scaled"));
    assert!(base(&["--im", "PGX", "--scales", "1:2:3"]).contains("unknown IM"));
    assert!(base(&["--im", "PGA", "--stripes", "PGV:0.1:1:5"]).contains("not among --im"));
    assert!(base(&["--im", "PGA", "--stripes", "PGA:1:0.1:5"]).contains("LO ≤ HI"));
    assert!(base(&["--im", "PGA", "--stripes", "PGA:0.1g:200g:5"]).contains("beyond ±100 g"));
    assert!(
        base(&["--im", "PGA", "--scales", "1:2:3", "--ensemble", "4"])
            .contains("--ensemble needs a catalogue entry")
    );
    assert!(base(&[
        "--im",
        "PGA",
        "--scales",
        "1:2:3",
        "--vertical-records",
        "a.AT2,b.AT2"
    ])
    .contains("2 files for 1 records"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn csv_and_at2_records_mix_and_give_the_same_ims() {
    // The same accelerogram as an AT2 (g) and as a CSV `t,ax` (m/s²): same scaled IMs and the
    // same outcome in every run.
    let dir = temp_dir("csv");
    let at2 = format!("{RECORDS}/Rinaldi228.AT2");
    let rec = rockwatch_core::record::Record::read(std::path::Path::new(&at2)).unwrap();
    let mut csv = String::from("t,ax\n");
    for (i, a) in rec.horizontal_mps2.iter().enumerate() {
        csv.push_str(&format!("{},{a:e}\n", i as f64 * rec.dt_s));
    }
    let csv_path = dir.join("rinaldi.csv");
    std::fs::write(&csv_path, csv).unwrap();
    let out = dir.join("out");
    let records = format!("{},{at2}", csv_path.display());
    let (_, _, stderr) = cli(&[
        "fragility",
        "--width",
        "0.4",
        "--height",
        "1.6",
        "--mu-s",
        "0.7",
        "--records",
        &records,
        "--im",
        "PGA,SA(1.0)",
        "--scales",
        "0.5:3:5",
        "--bootstrap",
        "0",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    let runs = std::fs::read_to_string(out.join("runs.csv")).unwrap_or_else(|_| panic!("{stderr}"));
    let rows: Vec<Vec<String>> = runs
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    assert_eq!(rows.len(), 2 * 5 * 2);
    let (from_csv, from_at2) = rows.split_at(10);
    for (c, a) in from_csv.iter().zip(from_at2) {
        assert_eq!(c[0], "rinaldi.csv");
        assert_eq!(a[0], "Rinaldi228.AT2");
        assert_eq!(c[6], a[6], "status {c:?} vs {a:?}");
        for col in [10, 11] {
            let (x, y): (f64, f64) = (c[col].parse().unwrap(), a[col].parse().unwrap());
            assert!((x - y).abs() <= 1e-9 * y, "{x} vs {y}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A box mesh 0.4 m (east) × 0.3 m (north) × 1.2 m (up), centred on the origin: `dir/box.obj`.
fn write_box_obj(dir: &std::path::Path) {
    std::fs::write(
        dir.join("box.obj"),
        "v -0.2 -0.15 0\nv 0.2 -0.15 0\nv 0.2 0.15 0\nv -0.2 0.15 0\n\
         v -0.2 -0.15 1.2\nv 0.2 -0.15 1.2\nv 0.2 0.15 1.2\nv -0.2 0.15 1.2\n\
         f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
    )
    .unwrap();
}

/// `runs.csv` rows as (record, scale, incidence, status, max |θ|/α).
fn runs(path: &std::path::Path) -> Vec<(String, f64, f64, String, f64)> {
    let csv = std::fs::read_to_string(path).unwrap();
    csv.lines()
        .skip(1)
        .map(|line| {
            let c: Vec<&str> = line.split(',').collect();
            (
                c[0].to_string(),
                c[3].parse().unwrap(),
                c[5].parse().unwrap(),
                c[6].to_string(),
                c[8].parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn a_meshed_catalogue_rock_is_analysed_in_each_of_its_directions() {
    // A box mesh 0.4 m (east) × 0.3 m (north) × 1.2 m (up), toppling north (0°) or east (90°).
    // A single-component record laid along incidence 0° moves only the north direction, whose
    // planar body is the 0.3 × 1.2 m rectangle; along 90° only the east one (0.4 × 1.2 m).
    // So every run must match the rectangle run with the flags, an independent path (no mesh).
    let dir = temp_dir("mesh");
    write_box_obj(&dir);
    let catalogue = dir.join("cat.toml");
    std::fs::write(
        &catalogue,
        "[[pbr]]\nid = \"box\"\nname = \"Box\"\nlat = 34.28\nlon = -118.48\n\
         station = \"CI.RRS.00\"\nmesh = \"box.obj\"\nazimuths = [0, 90]\n\
         mu_s = 0.8\nmu_k = 0.6\nsource = \"test\"\n",
    )
    .unwrap();
    let records = format!("{RECORDS}/Rinaldi228.AT2,{RECORDS}/RSN1084_NORTHR_SCS142.AT2");
    let common = [
        "--records",
        records.as_str(),
        "--im",
        "PGA",
        "--scales",
        "0.25:4:8",
        "--bootstrap",
        "0",
        "--no-plots",
        "--format",
        "json",
    ];
    let run = |name: &str, rock: &[&str], incidences: &str| {
        let out = dir.join(name);
        let mut args = vec!["fragility"];
        args.extend_from_slice(rock);
        args.extend_from_slice(&common);
        args.extend_from_slice(&["--azimuths", incidences, "--out", out.to_str().unwrap()]);
        let (ok, _, stderr) = cli(&args);
        assert!(ok || stderr.contains("no IM could be fitted"), "{stderr}");
        runs(&out.join("runs.csv"))
    };
    let mesh = run(
        "mesh",
        &["--pbr", "box", "--catalogue", catalogue.to_str().unwrap()],
        "0,90",
    );
    let north = run(
        "north",
        &[
            "--width", "0.3", "--height", "1.2", "--mu-s", "0.8", "--mu-k", "0.6",
        ],
        "0",
    );
    let east = run(
        "east",
        &[
            "--width", "0.4", "--height", "1.2", "--mu-s", "0.8", "--mu-k", "0.6",
        ],
        "0",
    );
    // The same mesh given directly (--mesh, --directions) is the same rock.
    let mesh_flag = run(
        "mesh-flag",
        &[
            "--mesh",
            dir.join("box.obj").to_str().unwrap(),
            "--directions",
            "0,90",
            "--mu-s",
            "0.8",
            "--mu-k",
            "0.6",
        ],
        "0,90",
    );
    assert_eq!(mesh_flag, mesh);
    assert_eq!(mesh.len(), 2 * 8 * 2);
    assert!(mesh.iter().any(|r| r.3 == "overturned"), "{mesh:?}");
    assert!(mesh.iter().any(|r| r.3 != "overturned"), "{mesh:?}");
    for r in &mesh {
        let planar = if r.2 == 0.0 { &north } else { &east };
        let p = planar
            .iter()
            .find(|p| p.0 == r.0 && p.1 == r.1)
            .unwrap_or_else(|| panic!("no planar run for {r:?}"));
        assert_eq!(r.3, p.3, "mesh {r:?} vs planar {p:?}");
        // The mesh's planar body equals the rectangle's to rounding (1e-12 relative, see
        // tests/mesh_geometry.rs); the responses agree to far better than this tolerance.
        assert!(
            (r.4 - p.4).abs() <= 1e-6 * p.4.max(1e-3),
            "mesh {r:?} vs planar {p:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_meshed_rock_sees_records_from_all_azimuths_whatever_its_first_direction() {
    // The leaning wedge of tests/data/meshes in four directions, listed from 0° or from 90°:
    // the same rock. Its incidences are azimuths from the mesh's north (default every 30°),
    // not angles from the first direction, so both lists give the same runs and fit.
    let dir = temp_dir("mesh-frame");
    let mesh = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/meshes/leaning-wedge.obj"
    );
    let record = format!("{RECORDS}/Rinaldi228.AT2");
    let run = |name: &str, directions: &str| {
        let out = dir.join(name);
        let (ok, _, stderr) = cli(&[
            "fragility",
            "--mesh",
            mesh,
            "--directions",
            directions,
            "--mu-s",
            "0.8",
            "--records",
            &record,
            "--im",
            "PGA",
            "--scales",
            "0.3:1.5:3",
            "--bootstrap",
            "0",
            "--no-plots",
            "--format",
            "json",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(ok || stderr.contains("no IM could be fitted"), "{stderr}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("fragility.json")).unwrap())
                .unwrap();
        let mut rows = runs(&out.join("runs.csv"));
        rows.sort_by(|a, b| a.partial_cmp(b).unwrap());
        (json, rows)
    };
    let (from_0, rows_0) = run("from-0", "0:360:90");
    let (from_90, rows_90) = run("from-90", "90:450:90");
    // 3 scales × 12 incidences (0:360:30) of one record.
    assert_eq!(rows_0.len(), 3 * 12, "{rows_0:?}");
    assert_eq!(rows_0, rows_90);
    assert!(rows_0.iter().any(|r| r.3 == "overturned"), "{rows_0:?}");
    assert!(rows_0.iter().any(|r| r.3 != "overturned"), "{rows_0:?}");
    assert_eq!(from_0["ims"], from_90["ims"]);
    // fragility.json names the exact rock: the mesh's SHA-256 (as sha256sum computes it), the
    // model and each direction's planar body.
    let sum = Command::new("sha256sum").arg(mesh).output().unwrap();
    let sum = String::from_utf8(sum.stdout).unwrap();
    let rock = &from_0["rock"];
    assert_eq!(
        rock["mesh_sha256"],
        sum.split_whitespace().next().unwrap(),
        "{rock}"
    );
    assert_eq!(rock["model"], "2d");
    let dirs = rock["directions"].as_array().unwrap();
    let azimuths: Vec<f64> = dirs
        .iter()
        .map(|d| d["azimuth_deg"].as_f64().unwrap())
        .collect();
    assert_eq!(azimuths, [0.0, 90.0, 180.0, 270.0]);
    // East (90°): the wedge's base runs 0.6 m east of x = 0 and its centre of mass is at
    // x = (0 + 0.6 + 0.1)/3, h = 1.4/3: b+ = 0.6 − 0.7/3 (tests/mesh_geometry.rs derives it).
    let east = &dirs[1];
    assert!(
        (east["b_plus_m"].as_f64().unwrap() - (0.6 - 0.7 / 3.0)).abs() < 1e-12,
        "{east}"
    );
    assert!(
        (east["com_height_m"].as_f64().unwrap() - 1.4 / 3.0).abs() < 1e-12,
        "{east}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_mesh_rock_in_3d_gets_the_planar_status_along_a_face_normal_from_the_flags_and_the_catalogue() {
    // The 0.4 (east) × 0.3 (north) × 1.2 m box of the test above as one 3-D rigid body
    // (`--model 3d`): records along incidence 0° (north) rock it over its 0.3 m side, as the
    // planar 0.3 × 1.2 m rectangle does (an independent formulation), so each run has the
    // rectangle's status; the standing peaks agree within 2 % where it rocks. The same body
    // from a catalogue entry with model = "3d" and heading 90° (its mesh north points east)
    // sees incidence 90° exactly as the flags' rock sees 0°.
    let dir = temp_dir("mesh-3d");
    write_box_obj(&dir);
    let catalogue = dir.join("cat.toml");
    std::fs::write(
        &catalogue,
        "[[pbr]]\nid = \"box\"\nname = \"Box\"\nlat = 34.28\nlon = -118.48\n\
         station = \"CI.RRS.00\"\nmesh = \"box.obj\"\nmodel = \"3d\"\nheading_deg = 90.0\n\
         mu_s = 0.8\nmu_k = 0.8\nsource = \"test\"\n",
    )
    .unwrap();
    let record = format!("{RECORDS}/Rinaldi228.AT2");
    let run = |name: &str, rock: &[&str], incidences: &str| {
        let out = dir.join(name);
        let mut args = vec!["fragility"];
        args.extend_from_slice(rock);
        args.extend_from_slice(&[
            "--records",
            &record,
            "--im",
            "PGA",
            "--scales",
            "0.2:1.6:4",
            "--bootstrap",
            "0",
            "--no-plots",
            "--format",
            "json",
            "--azimuths",
            incidences,
            "--out",
            out.to_str().unwrap(),
        ]);
        let (ok, _, stderr) = cli(&args);
        assert!(ok || stderr.contains("no IM could be fitted"), "{stderr}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("fragility.json")).unwrap())
                .unwrap();
        (json, runs(&out.join("runs.csv")))
    };
    let mesh = dir.join("box.obj");
    let (json, three) = run(
        "flags",
        &[
            "--mesh",
            mesh.to_str().unwrap(),
            "--model",
            "3d",
            "--mu-s",
            "0.8",
        ],
        "0",
    );
    let (_, planar) = run(
        "planar",
        &["--width", "0.3", "--height", "1.2", "--mu-s", "0.8"],
        "0",
    );
    assert_eq!(three.len(), 4);
    assert!(three.iter().any(|r| r.3 == "overturned"), "{three:?}");
    assert!(three.iter().any(|r| r.3 == "standing"), "{three:?}");
    for (t, p) in three.iter().zip(&planar) {
        assert_eq!(
            (&t.0, t.1, &t.3),
            (&p.0, p.1, &p.3),
            "3-D {t:?} vs planar {p:?}"
        );
        if t.3 == "standing" && p.4 > 0.05 {
            assert!((t.4 - p.4).abs() < 0.02 * p.4, "3-D {t:?} vs planar {p:?}");
        }
    }
    let rock = &json["rock"];
    assert_eq!(rock["model"], "3d", "{rock}");
    assert!((rock["body"]["com_height_m"].as_f64().unwrap() - 0.6).abs() < 1e-12);
    let (json, from_catalogue) = run(
        "catalogue",
        &["--pbr", "box", "--catalogue", catalogue.to_str().unwrap()],
        "90",
    );
    assert_eq!(json["rock"]["model"], "3d");
    let strip = |rows: &[(String, f64, f64, String, f64)]| -> Vec<(String, f64, String, f64)> {
        rows.iter()
            .map(|r| (r.0.clone(), r.1, r.3.clone(), r.4))
            .collect()
    };
    assert_eq!(strip(&from_catalogue), strip(&three));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 20 item 28: a mesh rock's `fragility --pbr` printed its first direction's b± as if
/// the rock were one planar block. The label says what the rock is: its directions (one planar
/// body each) and its weakest side, whatever direction is listed first; the same for `--mesh`.
#[test]
fn a_meshed_rock_is_labelled_by_its_directions_and_weakest_side_not_its_first_body() {
    // The box of `write_box_obj`: towards north (0°) the 0.3 × 1.2 m rectangle, α = atan(0.25)
    // = 14.04°; towards east (90°) 0.4 × 1.2 m, α = 18.43°. Listed east first.
    let dir = temp_dir("mesh-label");
    write_box_obj(&dir);
    let catalogue = dir.join("cat.toml");
    std::fs::write(
        &catalogue,
        "[[pbr]]\nid = \"box\"\nname = \"Box\"\nlat = 34.28\nlon = -118.48\n\
         station = \"CI.RRS.00\"\nmesh = \"box.obj\"\nazimuths = [90, 0]\n\
         mu_s = 0.8\nmu_k = 0.6\nsource = \"test\"\n",
    )
    .unwrap();
    let record = format!("{RECORDS}/Rinaldi228.AT2");
    let rock_line = |rock: &[&str], out: &str| -> String {
        let out = dir.join(out);
        let mut args = vec!["fragility"];
        args.extend_from_slice(rock);
        args.extend_from_slice(&[
            "--records",
            &record,
            "--im",
            "PGA",
            "--scales",
            "0.25:4:4",
            "--bootstrap",
            "0",
            "--no-plots",
            "--out",
            out.to_str().unwrap(),
        ]);
        let (_, stdout, stderr) = cli(&args);
        stdout
            .lines()
            .find(|l| l.starts_with("rock "))
            .unwrap_or_else(|| panic!("no rock line: {stdout}{stderr}"))
            .to_string()
    };
    let weakest = "2 directions (a planar body each, docs/meshes.md), weakest towards 0°: \
                   α = 14.04°, uplift at 2.452 m/s²";
    let line = rock_line(
        &["--pbr", "box", "--catalogue", catalogue.to_str().unwrap()],
        "pbr",
    );
    assert!(line.contains(weakest), "{line}");
    assert!(line.contains("box.obj"), "{line}");
    // Not the first direction's body (east: b± = 0.2 m, α = 18.43°) as if it were the rock.
    assert!(!line.contains("18.43") && !line.contains("b+ ="), "{line}");
    let line = rock_line(
        &[
            "--mesh",
            dir.join("box.obj").to_str().unwrap(),
            "--directions",
            "90,0",
            "--mu-s",
            "0.8",
        ],
        "flag",
    );
    assert!(line.contains(weakest), "{line}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 20 item 19: `--records DIR` took a vertical record (AT2 header "UP") as a horizontal
/// component. A vertical is recognised by its header and paired with the horizontal record of
/// the same event and station (said on stderr), never used as a horizontal; one with no
/// horizontal of its own is refused, naming it.
#[test]
fn a_vertical_record_among_the_records_is_paired_never_taken_as_horizontal() {
    let dir = temp_dir("vertical");
    let records = dir.join("records");
    std::fs::create_dir_all(&records).unwrap();
    for f in [
        "Rinaldi228.AT2",
        "RinaldiUP.AT2",
        "RSN1084_NORTHR_SCS142.AT2",
    ] {
        std::fs::copy(format!("{RECORDS}/{f}"), records.join(f)).unwrap();
    }
    let run = |out: &str| {
        cli(&[
            "fragility",
            "--width",
            "0.4",
            "--height",
            "1.6",
            "--mu-s",
            "0.7",
            "--records",
            records.to_str().unwrap(),
            "--im",
            "PGA",
            "--scales",
            "0.5:2:3",
            "--azimuths",
            "0",
            "--bootstrap",
            "0",
            "--no-plots",
            "--out",
            dir.join(out).to_str().unwrap(),
        ])
    };
    let (_, _, stderr) = run("paired");
    assert!(
        stderr.contains("RinaldiUP.AT2 is the vertical component of Rinaldi228.AT2"),
        "{stderr}"
    );
    let text = std::fs::read_to_string(dir.join("paired/fragility.json")).unwrap();
    let file: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(
        file["records"],
        serde_json::json!(["RSN1084_NORTHR_SCS142.AT2", "Rinaldi228.AT2"]),
        "the vertical is not a record of its own"
    );

    // Without its horizontal record, the vertical is refused.
    std::fs::remove_file(records.join("Rinaldi228.AT2")).unwrap();
    let (ok, _, stderr) = run("alone");
    assert!(!ok);
    assert!(
        stderr.contains("RinaldiUP.AT2: a vertical component")
            && stderr.contains("no horizontal record of the same event and station"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 20 item 24: runs that lose ground contact (free flight) were left out of the fits
/// with a stderr warning only, biasing the median upwards at the strongest stripes. The fit
/// still leaves them out (their outcome is unknown), and fragility.json and the text say how
/// many there were and bound the bias: each IM's median if every flight run had overturned.
#[test]
fn flight_runs_are_counted_and_the_bias_of_leaving_them_out_is_bounded() {
    let dir = temp_dir("flight");
    let out = dir.join("out");
    let records = format!(
        "{RECORDS}/Rinaldi228.AT2,{RECORDS}/RSN879_LANDERS_LCN345.AT2,{RECORDS}/RSN1084_NORTHR_SCS142.AT2"
    );
    let pair = vertical_pair();
    let (ok, stdout, stderr) = cli(&[
        "fragility",
        "--width",
        "0.4",
        "--height",
        "1.6",
        "--mu-s",
        "0.7",
        "--records",
        &records,
        "--vertical-records",
        &pair,
        "--im",
        "PGA",
        "--stripes",
        "PGA:2:60:8",
        "--azimuths",
        "0",
        "--bootstrap",
        "0",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    let text = std::fs::read_to_string(out.join("fragility.json")).unwrap();
    let file: serde_json::Value = serde_json::from_str(&text).unwrap();
    let flights = file["runs"]["flight"].as_u64().unwrap();
    assert!(flights > 0, "the strongest stripes lift the block: {text}");
    assert_eq!(file["flight_runs"]["count"].as_u64(), Some(flights));
    let median = file["ims"]["PGA"]["median"].as_f64().unwrap();
    let bound = file["ims"]["PGA"]["median_if_flight_overturned"]
        .as_f64()
        .unwrap();
    // More overturns at the strongest shaking can only lower the median.
    assert!(bound <= median, "{bound} vs {median}");
    assert!(
        stdout.contains(&format!(
            "flight      PGA: median {} with the {flights} flight runs left out",
            rockwatch::number_text::short_number(median)
        )),
        "{stdout}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The text elements of an SVG written by plotters: (x, y, text-anchor, text).
fn svg_texts(svg: &str) -> Vec<(f64, f64, String, String)> {
    let attr = |tag: &str, name: &str| -> Option<String> {
        let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
        Some(tag[start..].split('"').next()?.to_string())
    };
    svg.split("<text ")
        .skip(1)
        .filter_map(|part| {
            let (tag, rest) = part.split_once('>')?;
            let tag = &format!(" {tag}");
            let text = rest.split("</text>").next()?.trim().to_string();
            Some((
                attr(tag, "x")?.parse().ok()?,
                attr(tag, "y")?.parse().ok()?,
                attr(tag, "text-anchor").unwrap_or_default(),
                text,
            ))
        })
        .collect()
}

/// Issue 20 items 20 and 26: with `--units g` the table and the plots show accelerations in g
/// (fragility.json stays in m/s2); the surface plot has a colour bar, more than two labels on
/// its PGV/PGA axis, its legend off the chart (under it) and the rock in its title.
#[test]
fn units_g_and_the_surface_plot_colour_bar_ticks_legend_and_title() {
    let dir = temp_dir("units-plots");
    let out = dir.join("out");
    let (ok, text, stderr) = run_block(out.to_str().unwrap(), "0", &["--units", "g"]);
    assert!(ok, "{stderr}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("fragility.json")).unwrap())
            .unwrap();
    // JSON in SI whatever --units; the table's PGA and SA(1.0) rows in g, PGV in m/s.
    assert_eq!(json["ims"]["PGA"]["unit"], "m/s2");
    for (im, divisor, unit) in [
        ("PGA", 9.80665, "g"),
        ("SA(1.0)", 9.80665, "g"),
        ("PGV", 1.0, "m/s"),
    ] {
        let median = json["ims"][im]["median"].as_f64().unwrap();
        let row = text
            .lines()
            .find(|l| l.split_whitespace().next() == Some(im))
            .unwrap_or_else(|| panic!("no {im} row in {text}"));
        let cells: Vec<&str> = row.split_whitespace().collect();
        let shown: f64 = cells[1].parse().unwrap();
        assert!(
            ((shown - median / divisor) / (median / divisor)).abs() < 1e-3,
            "{row}: {median} / {divisor}"
        );
        assert_eq!(cells.last(), Some(&unit), "{row}");
    }

    // The surface's coefficients are for SI values, and the table in g says so.
    assert!(
        text.contains("(the surface's IMs in SI units: PGA in m/s2, PGV/PGA in s)"),
        "{text}"
    );
    let svg = std::fs::read_to_string(out.join("surface_PGA_PGV_PGA.svg")).unwrap();
    let texts = svg_texts(&svg);
    let find = |s: &str| texts.iter().find(|t| t.3 == s);
    // The title names the rock, not "rock:".
    let title: String = texts
        .iter()
        .filter(|t| t.1 < 50.0 && t.2 == "middle")
        .map(|t| t.3.as_str())
        .collect::<Vec<_>>()
        .join(" ");
    assert!(
        title.starts_with("B = 0.4 m, H = 1.6 m") && !title.contains("rock:"),
        "{title}"
    );
    // The axes in the units asked for.
    let x_desc = find("PGA (g)").expect("PGA axis in g");
    find("PGV/PGA (s)").expect("PGV/PGA axis");
    // A colour bar: its label, its six ticks 0.0 … 1.0 in one column, and its shades.
    find("P(overturn)").expect("colour bar label");
    let ticks: Vec<_> = ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]
        .iter()
        .map(|s| find(s).unwrap_or_else(|| panic!("colour bar tick {s}")))
        .collect();
    assert!(ticks.iter().all(|t| t.0 == ticks[0].0));
    assert!(ticks.windows(2).all(|w| w[1].1 < w[0].1), "ticks rise");
    let bar_shades: std::collections::BTreeSet<&str> = svg
        .split("<rect ")
        .skip(1)
        .filter(|r| r.contains("width=\"20\""))
        .filter_map(|r| r.split("fill=\"").nth(1)?.split('"').next())
        .collect();
    assert!(bar_shades.len() >= 50, "{} shades", bar_shades.len());
    // More than two labels on the PGV/PGA axis (right-aligned, left of the chart).
    let y_labels = texts.iter().filter(|t| t.2 == "end" && t.0 < 100.0).count();
    assert!(y_labels > 2, "{y_labels} labels on the PGV/PGA axis");
    // The legend under the chart (below the x axis's description), not over its corner.
    for entry in ["P = 0.1", "P = 0.5", "P = 0.9"] {
        let e = find(entry).unwrap_or_else(|| panic!("legend {entry}"));
        assert!(e.1 > x_desc.1, "{entry} at y = {} over the chart", e.1);
    }
    let curve = std::fs::read_to_string(out.join("fragility_PGA.svg")).unwrap();
    let curve_texts = svg_texts(&curve);
    assert!(curve_texts.iter().any(|t| t.3 == "PGA (g)"));
    assert!(curve_texts
        .iter()
        .any(|t| t.3.contains("median") && t.3.contains(" g,")));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Writes an AT2 file of `values_mps2` (written in g) whose header names `station` and
/// `component`.
fn write_at2(path: &std::path::Path, station: &str, component: &str, dt: f64, values_mps2: &[f64]) {
    let mut text = format!(
        "PEER NGA STRONG MOTION DATABASE RECORD\nSynthetic, 1/1/2000, {station}, {component}\n\
         ACCELERATION TIME SERIES IN UNITS OF G\nNPTS= {}, DT= {dt} SEC\n",
        values_mps2.len()
    );
    for chunk in values_mps2.chunks(5) {
        let line: Vec<String> = chunk.iter().map(|a| format!("{:e}", a / 9.80665)).collect();
        text.push_str(&line.join(" "));
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

/// Issue 20 item 25: `--horizontal-im rotd50` pairs the two horizontal AT2 components of one
/// station into one record: the stripes scale each pair so that its RotD50 PGA — computed here
/// by rotating the components at 1° steps and taking the median of the 180 peaks — equals the
/// stripe; the rock sees the pair's vector (the strong second component at incidence 90°,
/// which one component along 0° would never give it); fragility.json and the text say RotD50.
#[test]
fn rotd50_from_pairs_scales_each_pair_to_its_rotd50_and_shakes_the_rock_with_both() {
    let dir = temp_dir("rotd50");
    let records = dir.join("records");
    std::fs::create_dir_all(&records).unwrap();
    let dt = 0.01;
    let n = 1000;
    let env = |t: f64| (std::f64::consts::PI * t / 10.0).sin().powi(2);
    let mut pairs = Vec::new();
    for (k, (ax, ay, f)) in [(0.3, 1.0, 0.8), (0.5, 0.9, 1.1)].into_iter().enumerate() {
        let x: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 * dt;
                ax * env(t) * (2.0 * std::f64::consts::PI * 1.3 * f * t).sin()
            })
            .collect();
        let y: Vec<f64> = (0..n)
            .map(|i| {
                let t = i as f64 * dt;
                ay * env(t) * (2.0 * std::f64::consts::PI * f * t + 0.5).sin()
            })
            .collect();
        let station = format!("Station {k}");
        write_at2(
            &records.join(format!("S{k}_000.AT2")),
            &station,
            "000",
            dt,
            &x,
        );
        write_at2(
            &records.join(format!("S{k}_090.AT2")),
            &station,
            "090",
            dt,
            &y,
        );
        pairs.push((x, y));
    }
    // RotD50 of each pair, independently of the crate: the components as the AT2 reader gives
    // them back (g × 9.80665), rotated at 1° steps, the median of the 180 peaks.
    let rotd50 = |x: &[f64], y: &[f64]| {
        let back = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .map(|a| format!("{:e}", a / 9.80665).parse::<f64>().unwrap() * 9.80665)
                .collect()
        };
        let (x, y) = (back(x), back(y));
        let mut peaks: Vec<f64> = (0..180)
            .map(|deg| {
                let th = f64::from(deg).to_radians();
                x.iter()
                    .zip(&y)
                    .map(|(a, b)| (a * th.cos() + b * th.sin()).abs())
                    .fold(0.0, f64::max)
            })
            .collect();
        peaks.sort_by(f64::total_cmp);
        0.5 * (peaks[89] + peaks[90])
    };
    let expected: Vec<f64> = pairs.iter().map(|(x, y)| rotd50(x, y)).collect();
    let out = dir.join("out");
    let (ok, text, stderr) = cli(&[
        "fragility",
        "--width",
        "0.4",
        "--height",
        "1.6",
        "--mu-s",
        "0.7",
        "--records",
        records.to_str().unwrap(),
        "--horizontal-im",
        "rotd50",
        "--im",
        "PGA,PGV",
        "--stripes",
        "PGA:1:12:6",
        "--azimuths",
        "0,90",
        "--bootstrap",
        "0",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    assert!(text.contains("component   RotD50 of each pair"), "{text}");
    assert!(
        stderr.contains("are the horizontal components of"),
        "{stderr}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("fragility.json")).unwrap())
            .unwrap();
    assert_eq!(json["horizontal_definition"]["definition"], "RotD50");
    assert_eq!(json["records"][0], "S0_000.AT2+S0_090.AT2");
    for im in ["PGA", "PGV"] {
        if json["ims"][im].is_object() {
            assert_eq!(json["ims"][im]["horizontal_definition"], "RotD50", "{im}");
        }
    }
    let levels: Vec<f64> = json["intensity"]["stripes"]["levels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let csv = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    // 2 pairs × 6 stripes × 2 incidences.
    assert_eq!(csv.lines().count(), 1 + 24);
    let (mut overturned_at_0, mut overturned_at_90) = (0, 0);
    for line in csv.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let record = usize::from(!cells[0].starts_with("S0_"));
        let level: usize = cells[2].parse().unwrap();
        let scale: f64 = cells[3].parse().unwrap();
        let rotd50_scaled = scale * expected[record];
        assert!(
            ((rotd50_scaled - levels[level]) / levels[level]).abs() < 1e-9,
            "{line}: RotD50 × scale = {rotd50_scaled}, stripe {}",
            levels[level]
        );
        if cells[6] == "overturned" {
            match cells[5] {
                "0" => overturned_at_0 += 1,
                _ => overturned_at_90 += 1,
            }
        }
    }
    // The second component is the stronger: along 90° the rock falls more often (and does
    // fall: one component along 0° would leave it still at 90°).
    assert!(
        overturned_at_90 > overturned_at_0,
        "{overturned_at_90} at 90° vs {overturned_at_0} at 0°"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 20 item 25: pairs that cannot be one record are refused in one line: two components
/// that are not orthogonal, a station with one horizontal component, a CSV record (no header
/// to pair it by).
#[test]
fn records_that_do_not_make_orthogonal_pairs_are_refused() {
    let dir = temp_dir("bad-pairs");
    let a: Vec<f64> = (0..200).map(|i| (f64::from(i) * 0.1).sin()).collect();
    // (case, its files and their components, the error's words)
    type Case<'a> = (&'a str, &'a [(&'a str, &'a str)], &'a str);
    let cases: [Case; 3] = [
        (
            "oblique",
            &[("S_000.AT2", "000"), ("S_045.AT2", "045")],
            "must be orthogonal",
        ),
        (
            "lone",
            &[
                ("S_000.AT2", "000"),
                ("S_090.AT2", "090"),
                ("T_000.AT2", "000"),
            ],
            "needs exactly two horizontal components",
        ),
        ("csv", &[("S.csv", "")], "only AT2 records are paired"),
    ];
    for (name, files, message) in cases {
        let records = dir.join(name);
        std::fs::create_dir_all(&records).unwrap();
        for (file, component) in files {
            let path = records.join(file);
            if file.ends_with(".csv") {
                let text: String = a
                    .iter()
                    .enumerate()
                    .map(|(i, v)| format!("{},{v}\n", i as f64 * 0.01))
                    .collect();
                std::fs::write(&path, format!("t,ax\n{text}")).unwrap();
            } else {
                let station = &file[..1];
                write_at2(&path, &format!("Station {station}"), component, 0.01, &a);
            }
        }
        let (ok, _, stderr) = cli(&[
            "fragility",
            "--width",
            "0.4",
            "--height",
            "1.6",
            "--mu-s",
            "0.7",
            "--records",
            records.to_str().unwrap(),
            "--horizontal-im",
            "rotd50",
            "--im",
            "PGA",
            "--stripes",
            "PGA:1:2:2",
            "--out",
            dir.join("out").to_str().unwrap(),
        ]);
        assert!(!ok, "{name}");
        let errors: Vec<&str> = stderr
            .lines()
            .filter(|l| l.starts_with("rockwatch: error"))
            .collect();
        assert_eq!(errors.len(), 1, "{name}: {stderr}");
        assert!(errors[0].contains(message), "{name}: {stderr}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
