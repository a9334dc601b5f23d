//! STL, binary (80-byte header, u32 triangle count, 50 bytes per triangle: normal, three
//! vertices as f32 little-endian, u16 attribute) or ASCII (`solid … facet normal … outer loop
//! vertex x y z ×3 endloop endfacet … endsolid`). A file whose length is exactly
//! 84 + 50 × count is binary (binary headers may start with `solid` too); otherwise a file
//! starting with `solid` is ASCII. Stored normals are ignored (the vertex order is used).
//! STL repeats vertices per triangle; the caller merges identical ones.

use super::{MeshBuilder, MeshError, TriMesh};

pub(super) fn parse(bytes: &[u8], source: &str) -> Result<TriMesh, MeshError> {
    let b = MeshBuilder::new(source);
    if bytes.len() >= 84 {
        let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        if 84 + 50 * count == bytes.len() as u64 {
            return parse_binary(b, bytes, count as usize);
        }
    }
    let head = &bytes[..bytes.len().min(5)];
    if head.eq_ignore_ascii_case(b"solid") {
        return parse_ascii(b, bytes);
    }
    if bytes.len() >= 84 {
        let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        return Err(b.syntax(
            None,
            format!(
                "binary STL of {} bytes, but its header announces {count} triangles \
                 ({} bytes): truncated or not an STL file",
                bytes.len(),
                84 + 50 * count
            ),
        ));
    }
    Err(b.syntax(
        None,
        "not an STL file (shorter than a binary header and not ASCII `solid`)",
    ))
}

fn parse_binary(mut b: MeshBuilder, bytes: &[u8], count: usize) -> Result<TriMesh, MeshError> {
    if count > super::MAX_FACES {
        return Err(b.too_large(format!("{count} triangles, more than {}", super::MAX_FACES)));
    }
    for t in 0..count {
        let record = &bytes[84 + 50 * t..84 + 50 * (t + 1)];
        let f = |k: usize| {
            let o = 12 + 4 * k;
            f64::from(f32::from_le_bytes([
                record[o],
                record[o + 1],
                record[o + 2],
                record[o + 3],
            ]))
        };
        let first = b.vertex_count();
        for v in 0..3 {
            b.vertex([f(3 * v), f(3 * v + 1), f(3 * v + 2)], None)
                .map_err(|e| with_triangle(e, t))?;
        }
        b.polygon(&[first, first + 1, first + 2], None)?;
    }
    b.finish()
}

fn with_triangle(e: MeshError, t: usize) -> MeshError {
    match e {
        MeshError::Syntax {
            source_name,
            message,
            ..
        } => MeshError::Syntax {
            source_name,
            location: None,
            message: format!("triangle {t} (0-based): {message}"),
        },
        other => other,
    }
}

fn parse_ascii(mut b: MeshBuilder, bytes: &[u8]) -> Result<TriMesh, MeshError> {
    let text = b.text(bytes, "ASCII STL")?;
    // States: outside a facet, inside (counting vertices of its loop).
    let mut in_facet: Option<(usize, Vec<usize>)> = None;
    let mut solid_open = false;
    let mut ended = false;
    for (number, raw) in text.lines().enumerate() {
        let line = number + 1;
        let mut words = raw.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword.to_ascii_lowercase().as_str() {
            "solid" if !solid_open => solid_open = true,
            "facet" if solid_open && in_facet.is_none() => in_facet = Some((line, Vec::new())),
            "outer" | "endloop" if in_facet.is_some() => {}
            "vertex" => {
                let Some((_, ref mut loop_vertices)) = in_facet else {
                    return Err(b.syntax(Some(line), "`vertex` outside a facet"));
                };
                let p = b.coordinates(&mut words, line)?;
                loop_vertices.push(b.vertex_count());
                b.vertex(p, Some(line))?;
            }
            "endfacet" => {
                let Some((start, loop_vertices)) = in_facet.take() else {
                    return Err(b.syntax(Some(line), "`endfacet` without `facet`"));
                };
                if loop_vertices.len() != 3 {
                    return Err(b.syntax(
                        Some(start),
                        format!(
                            "facet has {} vertices, STL facets have 3",
                            loop_vertices.len()
                        ),
                    ));
                }
                b.polygon(&loop_vertices, Some(start))?;
            }
            "endsolid" if solid_open && in_facet.is_none() => {
                ended = true;
                break;
            }
            other => {
                return Err(b.syntax(
                    Some(line),
                    format!("unexpected {other:?} in an ASCII STL file"),
                ))
            }
        }
    }
    if !ended {
        return Err(b.syntax(None, "ASCII STL ends without `endsolid` (truncated?)"));
    }
    b.finish()
}
