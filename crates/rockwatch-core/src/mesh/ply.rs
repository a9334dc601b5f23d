//! PLY (Stanford polygon format), `ascii 1.0` or `binary_little_endian 1.0`: the `vertex`
//! element's `x`, `y`, `z` properties (any numeric type) and the `face` element's
//! `vertex_indices` (or `vertex_index`) list; other properties and elements are read past.
//! Polygons are fan-triangulated. `binary_big_endian` is refused with that reason.

use super::{MeshBuilder, MeshError, TriMesh};

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// Reads one little-endian value from `bytes` (at least `size()` long).
    fn read(self, b: &[u8]) -> f64 {
        match self {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            Scalar::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            Scalar::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::F64 => f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
        }
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar {
        name: String,
        kind: Scalar,
    },
    List {
        name: String,
        count: Scalar,
        item: Scalar,
    },
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

pub(super) fn parse(bytes: &[u8], source: &str) -> Result<TriMesh, MeshError> {
    let mut b = MeshBuilder::new(source);
    // Header: lines up to `end_header`.
    let mut pos = 0;
    let mut line = 0;
    let mut binary = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let end = bytes[pos..]
            .iter()
            .position(|&c| c == b'\n')
            .ok_or_else(|| b.syntax(None, "the PLY header has no `end_header`"))?;
        line += 1;
        let text = std::str::from_utf8(&bytes[pos..pos + end])
            .map_err(|_| b.syntax(Some(line), "the PLY header is not text"))?
            .trim_end_matches('\r');
        pos += end + 1;
        let words: Vec<&str> = text.split_whitespace().collect();
        if line == 1 {
            if text != "ply" {
                return Err(b.syntax(Some(1), "not a PLY file (the first line must be `ply`)"));
            }
            continue;
        }
        match words.as_slice() {
            ["format", "ascii", "1.0"] => binary = Some(false),
            ["format", "binary_little_endian", "1.0"] => binary = Some(true),
            ["format", other, ..] => {
                return Err(b.syntax(
                    Some(line),
                    format!(
                        "PLY format {other:?} is not supported (ascii or binary_little_endian 1.0)"
                    ),
                ))
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["element", name, count] => {
                let count: usize = count.parse().map_err(|_| {
                    b.syntax(
                        Some(line),
                        format!("element count {count:?} is not a number"),
                    )
                })?;
                let limit = if *name == "vertex" {
                    super::MAX_VERTICES
                } else {
                    super::MAX_FACES
                };
                if count > limit {
                    return Err(b.too_large(format!("{count} {name} elements, more than {limit}")));
                }
                elements.push(Element {
                    name: (*name).to_owned(),
                    count,
                    properties: Vec::new(),
                });
            }
            ["property", "list", count, item, name] => {
                let (Some(count), Some(item)) = (Scalar::parse(count), Scalar::parse(item)) else {
                    return Err(b.syntax(
                        Some(line),
                        format!("unknown list property types in {text:?}"),
                    ));
                };
                let element = elements
                    .last_mut()
                    .ok_or_else(|| b.syntax(Some(line), "property before any element"))?;
                element.properties.push(Property::List {
                    name: (*name).to_owned(),
                    count,
                    item,
                });
            }
            ["property", kind, name] => {
                let kind = Scalar::parse(kind).ok_or_else(|| {
                    b.syntax(Some(line), format!("unknown property type {kind:?}"))
                })?;
                let element = elements
                    .last_mut()
                    .ok_or_else(|| b.syntax(Some(line), "property before any element"))?;
                element.properties.push(Property::Scalar {
                    name: (*name).to_owned(),
                    kind,
                });
            }
            ["end_header"] => break,
            _ => return Err(b.syntax(Some(line), format!("unexpected PLY header line {text:?}"))),
        }
    }
    let binary = binary.ok_or_else(|| b.syntax(None, "the PLY header has no `format` line"))?;
    let Some(vertex) = elements.iter().find(|e| e.name == "vertex") else {
        return Err(b.syntax(None, "the PLY file has no `vertex` element"));
    };
    for axis in ["x", "y", "z"] {
        if !vertex
            .properties
            .iter()
            .any(|p| matches!(p, Property::Scalar { name, .. } if name == axis))
        {
            return Err(b.syntax(
                None,
                format!("the vertex element has no scalar property {axis:?}"),
            ));
        }
    }
    let faces_ok = elements.iter().any(|e| {
        e.name == "face"
            && e.properties.iter().any(|p| {
                matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index")
            })
    });
    if !faces_ok {
        return Err(b.syntax(
            None,
            "the PLY file has no `face` element with a `vertex_indices` list",
        ));
    }
    let mut values: Vec<f64> = Vec::new();
    let mut indices: Vec<usize> = Vec::new();
    let mut reader = Reader {
        bytes,
        pos,
        line,
        binary,
    };
    for element in &elements {
        for k in 0..element.count {
            reader.start_item();
            let at_line = reader.line;
            let mut p = [f64::NAN; 3];
            indices.clear();
            for property in &element.properties {
                match property {
                    Property::Scalar { name, kind } => {
                        let v = reader
                            .scalar(*kind)
                            .map_err(|m| item_error(&b, element, k, at_line, binary, &m))?;
                        if element.name == "vertex" {
                            match name.as_str() {
                                "x" => p[0] = v,
                                "y" => p[1] = v,
                                "z" => p[2] = v,
                                _ => {}
                            }
                        }
                    }
                    Property::List { name, count, item } => {
                        let n = reader
                            .scalar(*count)
                            .map_err(|m| item_error(&b, element, k, at_line, binary, &m))?;
                        if !((0.0..=1_000_000.0).contains(&n) && n.fract() == 0.0) {
                            return Err(item_error(
                                &b,
                                element,
                                k,
                                at_line,
                                binary,
                                &format!("list length {n} is not usable"),
                            ));
                        }
                        values.clear();
                        for _ in 0..n as usize {
                            values.push(
                                reader
                                    .scalar(*item)
                                    .map_err(|m| item_error(&b, element, k, at_line, binary, &m))?,
                            );
                        }
                        if element.name == "face"
                            && (name == "vertex_indices" || name == "vertex_index")
                        {
                            for &v in &values {
                                if !(v >= 0.0 && v.fract() == 0.0 && v < vertex.count as f64) {
                                    return Err(item_error(
                                        &b,
                                        element,
                                        k,
                                        at_line,
                                        binary,
                                        &format!(
                                        "vertex index {v} out of range (the file has {} vertices)",
                                        vertex.count
                                    ),
                                    ));
                                }
                                indices.push(v as usize);
                            }
                        }
                    }
                }
            }
            reader
                .end_item()
                .map_err(|m| item_error(&b, element, k, at_line, binary, &m))?;
            let location = (!binary).then_some(at_line);
            if element.name == "vertex" {
                b.vertex(p, location)?;
            } else if element.name == "face" {
                if b.vertex_count() < vertex.count {
                    return Err(
                        b.syntax(location, "the face element comes before the vertex element")
                    );
                }
                b.polygon(&indices, location).map_err(|e| {
                    if binary {
                        prefix(e, &format!("face {k} (0-based): "))
                    } else {
                        e
                    }
                })?;
            }
        }
    }
    b.finish()
}

fn prefix(e: MeshError, what: &str) -> MeshError {
    match e {
        MeshError::Syntax {
            source_name,
            location,
            message,
        } => MeshError::Syntax {
            source_name,
            location,
            message: format!("{what}{message}"),
        },
        other => other,
    }
}

fn item_error(
    b: &MeshBuilder,
    element: &Element,
    k: usize,
    line: usize,
    binary: bool,
    message: &str,
) -> MeshError {
    if binary {
        b.syntax(None, format!("{} {k} (0-based): {message}", element.name))
    } else {
        b.syntax(
            Some(line),
            format!("{} {k} (0-based): {message}", element.name),
        )
    }
}

/// Reads the body: binary values in sequence, or ASCII items one line each.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
    binary: bool,
}

impl Reader<'_> {
    /// ASCII: moves to the next non-empty line.
    fn start_item(&mut self) {
        if self.binary {
            return;
        }
        loop {
            let rest = &self.bytes[self.pos.min(self.bytes.len())..];
            let end = rest.iter().position(|&c| c == b'\n').unwrap_or(rest.len());
            if rest.is_empty() || !rest[..end].iter().all(u8::is_ascii_whitespace) {
                self.line += 1;
                return;
            }
            self.pos += end + 1;
            self.line += 1;
        }
    }

    fn end_item(&mut self) -> Result<(), String> {
        if self.binary {
            return Ok(());
        }
        let rest = &self.bytes[self.pos.min(self.bytes.len())..];
        let end = rest.iter().position(|&c| c == b'\n').unwrap_or(rest.len());
        if !rest[..end].iter().all(u8::is_ascii_whitespace) {
            return Err("more values on the line than the header declares".into());
        }
        self.pos += end + 1;
        Ok(())
    }

    fn scalar(&mut self, kind: Scalar) -> Result<f64, String> {
        if self.binary {
            let n = kind.size();
            if self.pos + n > self.bytes.len() {
                return Err("the binary body ends early (truncated file?)".into());
            }
            let v = kind.read(&self.bytes[self.pos..self.pos + n]);
            self.pos += n;
            return Ok(v);
        }
        // ASCII: the next word on the current line.
        let rest = &self.bytes[self.pos.min(self.bytes.len())..];
        let end = rest.iter().position(|&c| c == b'\n').unwrap_or(rest.len());
        let line = &rest[..end];
        let start = line
            .iter()
            .position(|c| !c.is_ascii_whitespace())
            .ok_or_else(|| "fewer values on the line than the header declares".to_string())?;
        let len = line[start..]
            .iter()
            .position(u8::is_ascii_whitespace)
            .unwrap_or(line.len() - start);
        let word =
            std::str::from_utf8(&line[start..start + len]).map_err(|_| "not text".to_string())?;
        self.pos += start + len;
        let v: f64 = word
            .parse()
            .map_err(|_| format!("{word:?} is not a number"))?;
        if matches!(kind, Scalar::F32 | Scalar::F64) || v.fract() == 0.0 {
            Ok(v)
        } else {
            Err(format!("{word:?} is not an integer"))
        }
    }
}
