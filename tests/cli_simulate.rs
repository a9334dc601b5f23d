//! `rockwatch simulate` block geometry given as B, H or as R, α.

use rockwatch_test_harness::process::Ran;
use rockwatch_test_harness::rockwatch_bin;
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
        let Ran {
            success: ok,
            stdout,
            stderr,
            ..
        } = rockwatch_bin!().run(&args).text();
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
        let Ran {
            success: ok,
            stderr,
            ..
        } = rockwatch_bin!().run(&args).text();
        assert!(
            !ok && stderr.contains("give the friction: --mu-s"),
            "{command}: {stderr}"
        );
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    }
    let Ran {
        success: ok,
        stderr,
        ..
    } = rockwatch_bin!()
        .run(&["simulate", "--record", record, "--mu-s", "0.9"])
        .text();
    assert!(!ok && stderr.contains("give the geometry"), "{stderr}");
    assert!(stderr.contains("--mesh"), "{stderr}");
}

/// The text elements of an SVG written by plotters: (x, y, text-anchor, font size, text).
fn svg_texts(svg: &str) -> Vec<(f64, f64, String, f64, String)> {
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
                attr(tag, "font-size")?.parse().ok()?,
                text,
            ))
        })
        .collect()
}

/// The advance widths of the bundled font (assets/fonts/DejaVuSans-subset.ttf, the font of
/// every plot), read from its TrueType tables here (cmap format 4, hhea, hmtx, head), not by
/// the plotting code: `width_em(text)` is the width of `text` in em.
struct FontWidths {
    font: Vec<u8>,
}

impl FontWidths {
    fn bundled() -> FontWidths {
        FontWidths {
            font: std::fs::read(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../assets/fonts/DejaVuSans-subset.ttf"
            ))
            .unwrap(),
        }
    }

    fn u16_at(&self, at: usize) -> usize {
        usize::from(u16::from_be_bytes([self.font[at], self.font[at + 1]]))
    }

    fn table(&self, tag: &[u8; 4]) -> usize {
        let tables = self.u16_at(4);
        (0..tables)
            .map(|i| 12 + 16 * i)
            .find(|&r| &self.font[r..r + 4] == tag)
            .map(|r| u32::from_be_bytes(self.font[r + 8..r + 12].try_into().unwrap()) as usize)
            .unwrap_or_else(|| panic!("no {tag:?} table"))
    }

    /// The glyph of `c` by the Windows Unicode BMP cmap (format 4).
    fn glyph(&self, c: char) -> usize {
        let cmap = self.table(b"cmap");
        let sub = (0..self.u16_at(cmap + 2))
            .map(|i| cmap + 4 + 8 * i)
            .find(|&r| self.u16_at(r) == 3 && self.u16_at(r + 2) == 1)
            .map(|r| {
                cmap + u32::from_be_bytes(self.font[r + 4..r + 8].try_into().unwrap()) as usize
            })
            .expect("a (3, 1) cmap");
        assert_eq!(self.u16_at(sub), 4, "cmap format");
        let segments = self.u16_at(sub + 6) / 2;
        let ends = sub + 14;
        let starts = ends + 2 * segments + 2;
        let deltas = starts + 2 * segments;
        let offsets = deltas + 2 * segments;
        let code = c as usize;
        for k in 0..segments {
            if code > self.u16_at(ends + 2 * k) {
                continue;
            }
            assert!(code >= self.u16_at(starts + 2 * k), "{c:?} not in the font");
            let delta = self.u16_at(deltas + 2 * k);
            let offset = self.u16_at(offsets + 2 * k);
            let glyph = if offset == 0 {
                code
            } else {
                let at = offsets + 2 * k + offset + 2 * (code - self.u16_at(starts + 2 * k));
                self.u16_at(at)
            };
            return (glyph + delta) % 65536;
        }
        panic!("{c:?} not in the font")
    }

    fn width_em(&self, text: &str) -> f64 {
        let units_per_em = self.u16_at(self.table(b"head") + 18) as f64;
        let metrics = self.u16_at(self.table(b"hhea") + 34);
        let hmtx = self.table(b"hmtx");
        text.chars()
            .map(|c| {
                let g = self.glyph(c).min(metrics - 1);
                self.u16_at(hmtx + 4 * g) as f64 / units_per_em
            })
            .sum()
    }
}

/// Issue 20 item 26: the title of `simulate --plot` was one line centred on the figure and cut
/// at both ends when the record's path is long. Every line of the title now lies within the
/// figure, and both ends of it (the record's scale and the block's friction) are there.
#[test]
fn a_long_title_is_wrapped_within_the_figure_not_cut() {
    let dir = tempfile::tempdir().unwrap();
    let long = dir.path().join(
        "Northridge-01_1994-01-17_Rinaldi_Receiving_Station_horizontal_component_228_from_north.AT2",
    );
    std::fs::copy(
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/records/Rinaldi228.AT2"
        ),
        &long,
    )
    .unwrap();
    let svg_path = dir.path().join("long.svg");
    let Ran {
        success: ok,
        stderr,
        ..
    } = rockwatch_bin!()
        .run(&[
            "simulate",
            "--record",
            long.to_str().unwrap(),
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
            svg_path.to_str().unwrap(),
        ])
        .text();
    assert!(ok, "{stderr}");
    let svg = std::fs::read_to_string(&svg_path).unwrap();
    let width: f64 = svg
        .split("width=\"")
        .nth(1)
        .and_then(|w| w.split('"').next())
        .and_then(|w| w.parse().ok())
        .unwrap();
    // The title: the centred lines above the panels (the first text elements, y < 60).
    let title: Vec<_> = svg_texts(&svg)
        .into_iter()
        .filter(|t| t.2 == "middle" && t.1 < 60.0 && (t.0 - width / 2.0).abs() < 1.0)
        .collect();
    assert!(!title.is_empty(), "no title");
    let font = FontWidths::bundled();
    // The font's own widths: "Rinaldi228.AT2" at 10 px is 75.67 px (fontTools' hmtx).
    assert!((font.width_em("Rinaldi228.AT2") * 10.0 - 75.67).abs() < 0.01);
    for (x, _, _, size, text) in &title {
        let half = 0.5 * font.width_em(text) * size;
        assert!(
            x - half >= 0.0 && x + half <= width,
            "title line {text:?} ({size} px) spans {} to {} of {width}",
            x - half,
            x + half
        );
    }
    let joined: Vec<&str> = title.iter().map(|t| t.4.as_str()).collect();
    let joined = joined.join(" ");
    assert!(
        joined.contains("× 0.5") && joined.ends_with("μk = 1"),
        "{joined}"
    );
    assert!(joined.contains("_from_north.AT2"), "{joined}");
}
