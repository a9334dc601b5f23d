//! `rockwatch geometry` and `rockwatch simulate --mesh --azimuth` / `--trace` through the
//! binary: the JSON against a box's closed forms, one-line errors for bad meshes and flags,
//! a meshed block simulated like the same block given by its planar-body flags, and the trace
//! CSV against the record and the summary.

use rockwatch_test_harness::rockwatch_bin;
use std::path::{Path, PathBuf};

const RINALDI: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/records/Rinaldi228.AT2"
);
const RINALDI_UP: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/records/RinaldiUP.AT2"
);

fn ok_json(args: &[&str]) -> serde_json::Value {
    let out = rockwatch_bin!().output(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// A box a (east, x) × b (north, y) × c (up, z) standing on z = 0, centred on x = y = 0, as
/// an OBJ with quad faces (outward).
fn box_obj(dir: &Path, a: f64, b: f64, c: f64) -> PathBuf {
    let (x, y) = (a / 2.0, b / 2.0);
    let text = format!(
        "# box {a} x {b} x {c}\n\
         v {} {} 0\nv {x} {} 0\nv {x} {y} 0\nv {} {y} 0\n\
         v {} {} {c}\nv {x} {} {c}\nv {x} {y} {c}\nv {} {y} {c}\n\
         f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n",
        -x, -y, -y, -x, -x, -y, -y, -x
    );
    let path = dir.join("box.obj");
    std::fs::write(&path, text).unwrap();
    path
}

fn f(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap()
}

#[test]
fn geometry_json_of_a_box_matches_its_closed_forms() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, c) = (0.4, 0.3, 1.2);
    let mesh = box_obj(dir.path(), a, b, c);
    let json = ok_json(&[
        "geometry",
        "--mesh",
        mesh.to_str().unwrap(),
        "--azimuths",
        "0:360:45",
        "--format",
        "json",
    ]);
    assert!((f(&json["volume_m3"]) - a * b * c).abs() < 1e-14);
    let com: Vec<f64> = json["com_m"].as_array().unwrap().iter().map(f).collect();
    assert_eq!(com.len(), 3);
    assert!(com[0].abs() < 1e-14 && com[1].abs() < 1e-14 && (com[2] - c / 2.0).abs() < 1e-14);
    let dirs = json["directions"].as_array().unwrap();
    assert_eq!(dirs.len(), 8);
    for d in dirs {
        let az = f(&d["azimuth_deg"]).to_radians();
        // The ray from the centre leaves the base through the nearer side.
        let exit = (a / 2.0 / az.sin().abs()).min(b / 2.0 / az.cos().abs());
        let rho2 = (az.cos().powi(2) * (b * b + c * c) + az.sin().powi(2) * (a * a + c * c)) / 12.0;
        for key in ["b_plus_m", "b_minus_m"] {
            assert!((f(&d[key]) - exit).abs() < 1e-12, "{key} {d}");
        }
        assert!((f(&d["h_m"]) - c / 2.0).abs() < 1e-12);
        assert!((f(&d["rho_m"]) - rho2.sqrt()).abs() < 1e-12);
        let alpha = (exit / (c / 2.0)).atan().to_degrees();
        assert!((f(&d["alpha_plus_deg"]) - alpha).abs() < 1e-10);
        assert!((f(&d["alpha_minus_deg"]) - alpha).abs() < 1e-10);
    }
    // The weakest direction of 0:360:45 tips across the shorter half-width: b/2 = 0.15 m
    // north-south against a/2 = 0.2 m east-west, so towards 0° or 180°, α = atan(b/c).
    let weakest = &json["weakest"];
    let alpha_min = (b / 2.0 / (c / 2.0)).atan().to_degrees();
    assert!(
        (f(&weakest["alpha_deg"]) - alpha_min).abs() < 1e-10,
        "{weakest}"
    );
    assert!(
        [0.0, 180.0].contains(&f(&weakest["azimuth_deg"])),
        "{weakest}"
    );
    assert!(
        (f(&weakest["uplift_mps2"]) - 9.80665 * b / c).abs() < 1e-10,
        "{weakest}"
    );
    // The sensitivity rows: 0, 1, 2, 5 mm; a box's patch is its base at every tolerance.
    let rows = json["tolerance_sensitivity"].as_array().unwrap();
    let tolerances: Vec<f64> = rows.iter().map(|r| f(&r["tolerance_m"])).collect();
    assert_eq!(tolerances, [0.0, 0.001, 0.002, 0.005]);
    for r in rows {
        assert_eq!(r["contact_vertices"], 4, "{r}");
        assert!((f(&r["b_ratio_max"]) - 1.0).abs() < 1e-12, "{r}");
    }
    assert_eq!(
        json["contact_tolerance_m"], 0.0,
        "the default is the resting facet alone"
    );
    // Text output names the units.
    let out = rockwatch_bin!().output(&["geometry", "--mesh", mesh.to_str().unwrap()]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("volume") && text.contains("m³") && text.contains("rho(m)"));
    assert_eq!(
        text.lines()
            .filter(|l| l.trim_start().starts_with("345.00"))
            .count(),
        1
    );
}

#[test]
fn geometry_shows_how_the_pivots_move_with_the_contact_tolerance() {
    // A block 0.5 (x, east) × 0.4 (y) × 1.0 (z) whose east bottom edge is chamfered, rising
    // 3 mm over its last 40 mm: the resting facet ends 40 mm short of the east side; a
    // tolerance of 3 mm or more takes the chamfer's top into the patch.
    let (a, w, c, rise, run) = (0.5, 0.4, 1.0, 0.003, 0.04);
    let profile = [
        (-a / 2.0, 0.0),
        (a / 2.0 - run, 0.0),
        (a / 2.0, rise),
        (a / 2.0, c),
        (-a / 2.0, c),
    ];
    let mut text = String::new();
    for y in [-w / 2.0, w / 2.0] {
        for (x, z) in profile {
            text += &format!("v {x} {y} {z}\n");
        }
    }
    // Caps: the profile is counter-clockwise in (x, z), so the y = −w/2 cap keeps its order.
    text += "f 1 2 3 4 5\nf 10 9 8 7 6\n";
    for i in 0..5 {
        let j = (i + 1) % 5;
        text += &format!("f {} {} {} {}\n", i + 1, i + 6, j + 6, j + 1);
    }
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("chamfered.obj");
    std::fs::write(&mesh, text).unwrap();
    let json = ok_json(&[
        "geometry",
        "--mesh",
        mesh.to_str().unwrap(),
        "--format",
        "json",
    ]);
    // The profile's centroid (shoelace), independent of the library's tetrahedra.
    let (mut area, mut cx) = (0.0, 0.0);
    for k in 0..5 {
        let ((x0, z0), (x1, z1)) = (profile[k], profile[(k + 1) % 5]);
        let cross = x0 * z1 - x1 * z0;
        area += cross / 2.0;
        cx += (x0 + x1) * cross / 6.0;
    }
    let gx = cx / area;
    let grown = (a / 2.0 - gx) / (a / 2.0 - run - gx);
    let rows = json["tolerance_sensitivity"].as_array().unwrap();
    assert_eq!(rows.len(), 4);
    for (row, (vertices, ratio)) in rows.iter().zip([(4, 1.0), (4, 1.0), (4, 1.0), (6, grown)]) {
        assert_eq!(row["contact_vertices"], vertices, "{row}");
        assert!(
            (f(&row["b_ratio_max"]) - ratio).abs() < 1e-9,
            "{row} vs {ratio}"
        );
    }
    // The text says it too, and marks the tolerance in force.
    let out = rockwatch_bin!().output(&["geometry", "--mesh", mesh.to_str().unwrap()]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("contact tolerance sensitivity"), "{text}");
    let row_5mm = text
        .lines()
        .find(|l| l.trim_start().starts_with("5.0 "))
        .unwrap_or_else(|| panic!("no 5 mm row:\n{text}"));
    assert!(row_5mm.contains(&format!("{grown:.3}")), "{row_5mm}");
    let row_0 = text
        .lines()
        .find(|l| l.trim_start().starts_with("0.0 "))
        .unwrap();
    assert!(row_0.ends_with("(in force)"), "{row_0}");
}

#[test]
fn geometry_draws_the_alpha_rose_and_a_section() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, c) = (0.4, 0.3, 1.2);
    let mesh = box_obj(dir.path(), a, b, c);
    let rose = dir.path().join("rose.svg");
    let section = dir.path().join("section.png");
    let out = rockwatch_bin!().output(&[
        "geometry",
        "--mesh",
        mesh.to_str().unwrap(),
        "--polar-plot",
        rose.to_str().unwrap(),
        "--section-plot",
        section.to_str().unwrap(),
        "--section",
        "90",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The rose marks the weakest direction: across the 0.3 m side, α = atan(0.15/0.6).
    let svg = std::fs::read_to_string(&rose).unwrap();
    assert!(svg.starts_with("<svg"), "not an SVG");
    let alpha = (b / 2.0 / (c / 2.0)).atan().to_degrees();
    assert!(
        svg.contains(&format!("weakest {alpha:.2}"))
            || svg.contains(&format!("weakest {alpha:.3}")),
        "{alpha}"
    );
    let png = std::fs::read(&section).unwrap();
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    // Towards 90° (east) the section names b± = a/2 in its title (SVG text).
    let section_svg = dir.path().join("section.svg");
    let out = rockwatch_bin!().output(&[
        "geometry",
        "--mesh",
        mesh.to_str().unwrap(),
        "--section-plot",
        section_svg.to_str().unwrap(),
        "--section",
        "90",
    ]);
    assert!(out.status.success());
    let svg = std::fs::read_to_string(&section_svg).unwrap();
    assert!(
        svg.contains("towards 90°: b+ = 0.2 m, b− = 0.2 m, h = 0.6 m"),
        "{svg}"
    );
    // A plot name that says neither format is refused in one line.
    let bad = dir.path().join("rose.jpg");
    let out = rockwatch_bin!().output(&[
        "geometry",
        "--mesh",
        mesh.to_str().unwrap(),
        "--polar-plot",
        bad.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("must end in .svg or .png") && err.trim_end().lines().count() == 1,
        "{err}"
    );
}

#[test]
fn an_open_scan_is_refused_unless_capped_and_capping_says_so() {
    // The box of box_obj without its bottom face (`f 1 4 3 2`): a scan seen from above.
    let dir = tempfile::tempdir().unwrap();
    let (a, b, c) = (0.4, 0.3, 1.2);
    let closed = box_obj(dir.path(), a, b, c);
    let text = std::fs::read_to_string(&closed)
        .unwrap()
        .replace("f 1 4 3 2\n", "");
    let open = dir.path().join("open.obj");
    std::fs::write(&open, text).unwrap();
    let out = rockwatch_bin!().output(&["geometry", "--mesh", open.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("not a closed") && err.trim_end().lines().count() == 1,
        "{err}"
    );
    let capped = ok_json(&[
        "geometry",
        "--mesh",
        open.to_str().unwrap(),
        "--cap",
        "--format",
        "json",
    ]);
    let reference = ok_json(&[
        "geometry",
        "--mesh",
        closed.to_str().unwrap(),
        "--format",
        "json",
    ]);
    assert_eq!(capped["cap"]["loop_vertices"], 4, "{}", capped["cap"]);
    assert!((f(&capped["cap"]["area_m2"]) - a * b).abs() < 1e-12);
    assert!((f(&capped["volume_m3"]) - a * b * c).abs() < 1e-12);
    assert_eq!(capped["directions"], reference["directions"]);
    assert_eq!(reference["cap"], serde_json::Value::Null);
    // The text and stderr say it.
    let out = rockwatch_bin!().output(&["geometry", "--mesh", open.to_str().unwrap(), "--cap"]);
    assert!(out.status.success());
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stdout.contains("capped      open scan closed by its lowest boundary loop (4 vertices"),
        "{stdout}"
    );
    assert!(
        stderr.contains("warning") && stderr.contains("open scan closed"),
        "{stderr}"
    );
}

#[test]
fn bad_meshes_and_flags_fail_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let hole = dir.path().join("hole.obj");
    std::fs::write(
        &hole,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\n",
    )
    .unwrap();
    let mesh = box_obj(dir.path(), 1.0, 1.0, 1.0);
    let cases: [(Vec<&str>, &str); 5] = [
        (vec!["--mesh", hole.to_str().unwrap()], "hole.obj:"),
        (
            vec!["--mesh", "/nonexistent/rock.stl"],
            "cannot read the mesh",
        ),
        (vec!["--mesh", "rock.dxf"], "unknown mesh format"),
        (vec!["--mesh", mesh.to_str().unwrap(), "--up", "w"], "--up"),
        (
            vec!["--mesh", mesh.to_str().unwrap(), "--azimuths", "0:360:0"],
            "--azimuths",
        ),
    ];
    for (args, expected) in cases {
        let mut all = vec!["geometry"];
        all.extend(args.iter());
        let out = rockwatch_bin!().output(&all);
        assert_eq!(out.status.code(), Some(1), "{all:?}");
        let stderr = String::from_utf8(out.stderr).unwrap();
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(
            stderr.starts_with("rockwatch: error: ") && stderr.contains(expected),
            "{stderr}"
        );
    }
}

#[test]
fn simulate_mesh_azimuth_is_the_planar_body_of_that_direction() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, c) = (0.5, 0.3, 1.5);
    let mesh = box_obj(dir.path(), a, b, c);
    let common = [
        "simulate", "--record", RINALDI, "--mu-s", "1.5", "--mu-k", "1.0", "--scale", "0.6",
        "--format", "json",
    ];
    for (az, width) in [("90", a), ("0", b)] {
        let mut meshed = common.to_vec();
        meshed.extend(["--mesh", mesh.to_str().unwrap(), "--azimuth", az]);
        let mut rect = common.to_vec();
        let (w, h) = (width.to_string(), c.to_string());
        rect.extend(["--width", w.as_str(), "--height", h.as_str()]);
        let (m, r) = (ok_json(&meshed), ok_json(&rect));
        assert_eq!(m["status"], r["status"], "az {az}");
        assert!((f(&m["alpha"]) - f(&r["alpha"])).abs() < 1e-12);
        let (x, y) = (f(&m["max_abs_theta"]), f(&r["max_abs_theta"]));
        assert!((x - y).abs() <= 1e-9 * y.max(1e-3), "az {az}: {x} vs {y}");
    }
    let out = rockwatch_bin!().output(&[
        "simulate",
        "--record",
        RINALDI,
        "--mu-s",
        "1",
        "--mu-k",
        "0.8",
        "--mesh",
        mesh.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1), "--mesh without --azimuth");
}

#[test]
fn trace_csv_holds_the_record_and_the_response_per_step() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("trace.csv");
    let json = ok_json(&[
        "simulate",
        "--record",
        RINALDI,
        "--vertical",
        RINALDI_UP,
        "--width",
        "0.4",
        "--height",
        "2.0",
        "--mu-s",
        "1.5",
        "--mu-k",
        "1.0",
        "--scale",
        "0.3",
        "--t-extra",
        "2",
        "--format",
        "json",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(&trace).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("t_s,ground_h_mps2,ground_v_mps2,theta_rad,slide_m,mode")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // The record's own samples: AT2 values in g × 9.80665 × scale.
    let at2 = std::fs::read_to_string(RINALDI).unwrap();
    let values: Vec<f64> = at2
        .lines()
        .skip(4)
        .flat_map(|l| l.split_whitespace().map(|w| w.parse::<f64>().unwrap()))
        .collect();
    let dt = 0.01; // the file's DT
    let expected_rows = values.len() + (2.0 / dt) as usize;
    assert_eq!(json["status"], "ok");
    assert_eq!(rows.len(), expected_rows);
    let mut max_theta: f64 = 0.0;
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row.len(), 6);
        let t: f64 = row[0].parse().unwrap();
        assert!((t - i as f64 * dt).abs() < 1e-9, "row {i}: t {t}");
        let ah: f64 = row[1].parse().unwrap();
        let want = values.get(i).map_or(0.0, |g| g * 9.80665 * 0.3);
        assert!((ah - want).abs() <= 1e-12 * want.abs().max(1.0), "row {i}");
        max_theta = max_theta.max(row[3].parse::<f64>().unwrap().abs());
        assert!(
            [
                "rest",
                "slide",
                "rock",
                "slide-rock",
                "flight",
                "overturned"
            ]
            .contains(&row[5]),
            "{}",
            row[5]
        );
    }
    assert!(max_theta > 0.0, "the block rocks");
    assert!(max_theta <= f(&json["max_abs_theta"]) * (1.0 + 1e-12));
    let last_slide: f64 = rows.last().unwrap()[4].parse().unwrap();
    assert_eq!(last_slide, f(&json["residual_slide"]));
}

/// `monitor` over a catalogue with a rock from a mesh: its alerts name one of its directions,
/// and its summary lists every direction: under a one-component record, the direction along
/// the record and the opposite one respond alike (mirrored body, negated input), the
/// perpendicular one not at all.
#[test]
fn monitor_integrates_a_meshed_rock_in_each_direction_and_names_it() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("meshes")).unwrap();
    std::fs::copy(
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/meshes/leaning-wedge.obj"
        ),
        dir.path().join("meshes/wedge.obj"),
    )
    .unwrap();
    let catalogue = dir.path().join("cat.toml");
    std::fs::write(
        &catalogue,
        "[[pbr]]\nid = \"wedge\"\nname = \"wedge\"\nlat = 34.28\nlon = -118.48\n\
         station = \"CI.RRS.00\"\nmesh = \"meshes/wedge.obj\"\nazimuths = [228, 48, 138]\n\
         heading_deg = 0.0\nmu_s = 0.8\nmu_k = 0.6\nsource = \"test\"\n",
    )
    .unwrap();
    let out = rockwatch_bin!().output(&[
        "monitor",
        "--catalogue",
        catalogue.to_str().unwrap(),
        "--record",
        RINALDI,
        "--azimuth",
        "228",
        "--station",
        "CI.RRS.00",
        "--format",
        "jsonl",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let values: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let alerts: Vec<&serde_json::Value> = values.iter().filter(|v| v["type"] == "alert").collect();
    assert!(!alerts.is_empty(), "the wedge rocks under Rinaldi");
    for a in &alerts {
        let d = f(&a["direction_deg"]);
        assert!(d == 228.0 || d == 48.0, "{a}");
    }
    let summary = values.last().unwrap();
    let dirs = summary["pbrs"][0]["directions"].as_array().unwrap();
    let got: Vec<(f64, f64)> = dirs
        .iter()
        .map(|d| (f(&d["direction_deg"]), f(&d["max_theta_over_alpha"])))
        .collect();
    assert_eq!(
        got.iter().map(|g| g.0).collect::<Vec<_>>(),
        [228.0, 48.0, 138.0]
    );
    assert!(got[0].1 > 0.0);
    assert!((got[0].1 - got[1].1).abs() <= 1e-6 * got[0].1, "{got:?}");
    assert_eq!(got[2].1, 0.0, "perpendicular to the motion");
    assert_eq!(
        f(&summary["pbrs"][0]["max_theta_over_alpha"]),
        got[0].1.max(got[1].1)
    );
}

#[test]
fn simulate_model_3d_of_a_box_matches_the_planar_block_and_reports_its_pose() {
    // The 0.4 (east) × 0.6 (north) × 2.0 m box under Rinaldi228 × 0.3 with its component
    // towards the east: the 3-D rock rocks about its north-south edges like the planar block
    // (tests/rocking_3d.rs checks the physics; here the flags, the JSON and the text).
    let dir = tempfile::tempdir().unwrap();
    let mesh = box_obj(dir.path(), 0.4, 0.6, 2.0);
    let mesh = mesh.to_str().unwrap();
    let common = [
        "simulate",
        "--mesh",
        mesh,
        "--record",
        RINALDI,
        "--scale",
        "0.3",
        "--mu-s",
        "0.8",
        "--t-extra",
        "4",
        "--format",
        "json",
    ];
    let mut args3 = common.to_vec();
    args3.extend(["--model", "3d", "--azimuth", "90"]);
    let three = ok_json(&args3);
    assert_eq!(three["model"], "3d");
    assert_eq!(three["overturned"], false);
    let mut args2 = common.to_vec();
    args2.extend(["--azimuth", "90"]);
    let two = ok_json(&args2);
    let (p3, p2) = (
        f(&three["max_tilt_over_alpha"]),
        f(&two["max_abs_theta_over_alpha"]),
    );
    assert!((p3 - p2).abs() < 0.02 * p2, "3-D {p3} vs 2-D {p2}");
    // The top moved west or east (rocking about a north-south edge).
    let az = f(&three["max_tilt_azimuth_deg"]);
    assert!(
        (az - 90.0).abs() < 1.0 || (az - 270.0).abs() < 1.0,
        "azimuth {az}"
    );
    assert_eq!(three["final_rotation"].as_array().unwrap().len(), 4);
    // Text output, and a second horizontal component with the vertical one.
    let out = rockwatch_bin!().output(&[
        "simulate",
        "--mesh",
        mesh,
        "--model",
        "3d",
        "--record",
        RINALDI,
        "--azimuth",
        "90",
        "--record2",
        RINALDI,
        "--azimuth2",
        "0",
        "--vertical",
        RINALDI_UP,
        "--scale",
        "0.2",
        "--mu-s",
        "0.8",
        "--t-extra",
        "1",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("max tilt") && text.contains("twist") && text.contains("final pose"),
        "{text}"
    );
    // --model 3d needs a mesh.
    let out = rockwatch_bin!().output(&[
        "simulate", "--width", "0.4", "--height", "2", "--model", "3d", "--record", RINALDI,
        "--mu-s", "0.8",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--model 3d needs a mesh"));
}

#[test]
fn simulate_model_3d_writes_its_trace_and_plot() {
    // The 0.4 × 0.6 × 2.0 m box under Rinaldi228 × 1.2 towards 60°: the trace has one row per
    // input sample until the overturn, its ground columns are the record laid along 60°
    // (east = a·sin 60°, north = a·cos 60°, as read independently here), its tilt/α peaks at
    // the summary's (sampled at the input samples: at most the sub-step maximum), and the
    // last row is the overturn; the plot is a PNG.
    let dir = tempfile::tempdir().unwrap();
    let mesh = box_obj(dir.path(), 0.4, 0.6, 2.0);
    let (trace, plot) = (dir.path().join("t.csv"), dir.path().join("p.png"));
    let summary = ok_json(&[
        "simulate",
        "--mesh",
        mesh.to_str().unwrap(),
        "--model",
        "3d",
        "--record",
        RINALDI,
        "--azimuth",
        "60",
        "--scale",
        "1.2",
        "--mu-s",
        "0.8",
        "--format",
        "json",
        "--trace",
        trace.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
    ]);
    assert_eq!(summary["overturned"], true, "{summary}");
    let csv = std::fs::read_to_string(&trace).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,ground_e_mps2,ground_n_mps2,ground_u_mps2,tilt_rad,tilt_over_alpha,direction_deg,\
         slide_m,com_e_m,com_n_m,com_u_m,twist_rad,mode"
    );
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    // The record read independently: AT2, g, 5 values per line after the 4 header lines.
    let at2 = std::fs::read_to_string(RINALDI).unwrap();
    let g_values: Vec<f64> = at2
        .lines()
        .skip(4)
        .flat_map(|l| l.split_whitespace().map(|v| v.parse::<f64>().unwrap()))
        .collect();
    let (s, c) = 60f64.to_radians().sin_cos();
    for (i, row) in rows.iter().enumerate() {
        let a = 1.2 * 9.80665 * g_values.get(i).copied().unwrap_or(0.0);
        let (e, n): (f64, f64) = (row[1].parse().unwrap(), row[2].parse().unwrap());
        assert!(
            (e - a * s).abs() < 1e-9 && (n - a * c).abs() < 1e-9,
            "row {i}: {row:?}"
        );
        let t: f64 = row[0].parse().unwrap();
        assert!((t - 0.01 * i as f64).abs() < 1e-9, "row {i}: {row:?}");
    }
    let last = rows.last().unwrap();
    assert_eq!(last[12], "overturned");
    assert!(rows[..rows.len() - 1].iter().all(|r| r[12] != "overturned"));
    assert!(rows.iter().any(|r| r[12] == "rock"));
    let peak = rows[..rows.len() - 1]
        .iter()
        .map(|r| r[5].parse::<f64>().unwrap())
        .fold(0.0, f64::max);
    let summary_peak = f(&summary["max_tilt_over_alpha"]);
    assert!(
        peak <= summary_peak && peak > 0.9,
        "{peak} vs {summary_peak}"
    );
    let png = std::fs::read(&plot).unwrap();
    assert!(png.starts_with(b"\x89PNG"), "not a PNG");
    // --rtol is not a setting of the 3-D model.
    let out = rockwatch_bin!().output(&[
        "simulate",
        "--mesh",
        mesh.to_str().unwrap(),
        "--model",
        "3d",
        "--record",
        RINALDI,
        "--azimuth",
        "60",
        "--mu-s",
        "0.8",
        "--rtol",
        "1e-6",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--rtol is not a setting of --model 3d"));
}
