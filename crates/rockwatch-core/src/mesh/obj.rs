//! Wavefront OBJ: `v x y z [w]` vertices and `f i j k …` faces (indices 1-based, negative
//! ones relative to the end, each `v`, `v/vt`, `v//vn` or `v/vt/vn`); polygons are
//! fan-triangulated. Texture, normal, grouping and material statements are ignored; free-form
//! geometry, lines and points are refused (a rock is a surface).

use super::{MeshBuilder, MeshError, TriMesh};

/// Statements that carry nothing the geometry needs.
const IGNORED: [&str; 9] = ["vt", "vn", "vp", "o", "g", "s", "usemtl", "mtllib", "#"];

pub(super) fn parse(bytes: &[u8], source: &str) -> Result<TriMesh, MeshError> {
    let mut b = MeshBuilder::new(source);
    let text = b.text(bytes, "an OBJ file is text")?;
    let mut indices: Vec<usize> = Vec::new();
    let mut pending = String::new();
    for (number, raw) in text.lines().enumerate() {
        let line = number + 1;
        // A trailing backslash continues the statement on the next line.
        if let Some(stripped) = raw.strip_suffix('\\') {
            pending.push_str(stripped);
            pending.push(' ');
            continue;
        }
        let joined;
        let statement = if pending.is_empty() {
            raw
        } else {
            pending.push_str(raw);
            joined = std::mem::take(&mut pending);
            joined.as_str()
        };
        let statement = statement.split('#').next().unwrap_or("");
        let mut words = statement.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            "v" => {
                let mut p = b.coordinates(&mut words, line)?;
                if let Some(w) = words.next() {
                    let w: f64 = w.parse().map_err(|_| {
                        b.syntax(Some(line), format!("vertex weight {w:?} is not a number"))
                    })?;
                    if !(w.is_finite() && w != 0.0) {
                        return Err(
                            b.syntax(Some(line), format!("vertex weight {w} is not usable"))
                        );
                    }
                    p = p.map(|c| c / w);
                }
                b.vertex(p, Some(line))?;
            }
            "f" => {
                indices.clear();
                let n = b.vertex_count() as i64;
                for word in words {
                    let first = word.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| {
                        b.syntax(Some(line), format!("face index {word:?} is not an integer"))
                    })?;
                    let index = if i > 0 {
                        i - 1
                    } else if i < 0 {
                        n + i
                    } else {
                        return Err(b.syntax(Some(line), "face index 0 (OBJ indices start at 1)"));
                    };
                    if !(0..n).contains(&index) {
                        return Err(b.syntax(
                            Some(line),
                            format!("face index {i} refers to no vertex (the file has {n} so far)"),
                        ));
                    }
                    indices.push(index as usize);
                }
                b.polygon(&indices, Some(line))?;
            }
            k if IGNORED.contains(&k) || k.starts_with('#') => {}
            other => {
                return Err(b.syntax(
                    Some(line),
                    format!(
                        "unsupported OBJ statement {other:?} (a rock mesh needs v and f; vt, vn, \
                         o, g, s, usemtl, mtllib are ignored)"
                    ),
                ))
            }
        }
    }
    b.finish()
}
