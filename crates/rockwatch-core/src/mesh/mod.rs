//! Closed triangle meshes of rocks (photogrammetry, laser scans) and what the dynamics need
//! from them (docs/meshes.md).
//!
//! - [`TriMesh::read`]: OBJ, PLY (ASCII, binary little-endian) and STL (ASCII, binary), the
//!   format by extension (`obj.rs`, `ply.rs`, `stl.rs`). Coordinates are metres. Vertices with
//!   identical coordinates are merged (STL has no shared vertices; seams of other writers
//!   duplicate them), polygons are fan-triangulated.
//! - [`TriMesh::validate`]: the mesh must be a closed, consistently oriented 2-manifold
//!   surface (every undirected edge in exactly two faces, once in each direction) without
//!   degenerate (collinear) faces and with a non-zero volume. A consistently *inward*
//!   oriented mesh is accepted and turned outward (its signed volume tells).
//! - [`mass`]: volume, centre of mass and inertia tensor by the divergence theorem.
//! - [`hull`]: the 3-D convex hull (quickhull) and its planar facets.
//! - [`cap`]: closing an open scan by its lowest boundary loop (`--cap`).
//! - [`contact`]: the resting contact and the planar body of each azimuth.
//! - [`support_polygon`]: the support polygon and the lever arm b(d) of a direction.
//!
//! Work is bounded: files above [`MAX_FILE_BYTES`], meshes above [`MAX_VERTICES`] vertices or
//! [`MAX_FACES`] triangles are refused before they are processed.
//!
//! Errors never panic and name the file and, for text formats, the line
//! (`rock.obj:12: face refers to vertex 9, the file has 8`), for binary ones the face index.

pub mod cap;
pub mod contact;
pub mod hull;
pub mod mass;
mod obj;
mod ply;
mod stl;
pub mod support_polygon;

use std::collections::HashMap;
use std::path::Path;

/// Largest mesh file read (bytes): 1 GiB.
pub const MAX_FILE_BYTES: u64 = 1 << 30;
/// Most vertices a mesh may have (before merging duplicates).
pub const MAX_VERTICES: usize = 5_000_000;
/// Most triangles a mesh may have (after triangulating polygons).
pub const MAX_FACES: usize = 10_000_000;

/// A triangle mesh: vertex positions (m) and triangles (indices into `vertices`, counter-
/// clockwise seen from outside once validated).
#[derive(Debug, Clone, PartialEq)]
pub struct TriMesh {
    /// Name of the source, for messages (the file path).
    pub source: String,
    pub vertices: Vec<[f64; 3]>,
    pub faces: Vec<[usize; 3]>,
    /// Where each face was written: the 1-based line of a text format, 0 when unknown
    /// (binary formats: the face index names it).
    pub face_lines: Vec<usize>,
}

/// Why a mesh could not be read or used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// The file could not be read.
    #[error("{source_name}: cannot read the mesh: {message}")]
    Io {
        source_name: String,
        message: String,
    },
    /// The extension is not one of .obj, .ply, .stl.
    #[error("{source_name}: unknown mesh format: the file name must end in .obj, .ply or .stl")]
    UnknownFormat { source_name: String },
    /// The file is malformed (syntax, counts, indices).
    #[error("{source_name}{}: {message}", location.map(|l| format!(":{l}")).unwrap_or_default())]
    Syntax {
        source_name: String,
        /// 1-based line (text formats), when known.
        location: Option<usize>,
        message: String,
    },
    /// The mesh is too large to be processed.
    #[error("{source_name}: {message}")]
    TooLarge {
        source_name: String,
        message: String,
    },
    /// The surface is not closed or not consistently oriented.
    #[error("{source_name}{}: not a closed, consistently oriented surface: {message}", location.map(|l| format!(":{l}")).unwrap_or_default())]
    NotClosed {
        source_name: String,
        location: Option<usize>,
        message: String,
    },
    /// A face or the whole body is degenerate (collinear face, zero volume, flat point set).
    #[error("{source_name}{}: degenerate mesh: {message}", location.map(|l| format!(":{l}")).unwrap_or_default())]
    Degenerate {
        source_name: String,
        location: Option<usize>,
        message: String,
    },
    /// The body has no stable resting face, or a parameter is out of range.
    #[error("{source_name}: {message}")]
    Contact {
        source_name: String,
        message: String,
    },
}

/// Mesh file formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    Obj,
    Ply,
    Stl,
}

impl MeshFormat {
    /// The format of a file name by its extension (any case).
    #[must_use]
    pub fn from_path(path: &Path) -> Option<MeshFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(MeshFormat::Obj),
            "ply" => Some(MeshFormat::Ply),
            "stl" => Some(MeshFormat::Stl),
            _ => None,
        }
    }
}

/// Builds meshes while reading, enforcing the bounds; shared by the readers.
pub(crate) struct MeshBuilder {
    source: String,
    vertices: Vec<[f64; 3]>,
    faces: Vec<[usize; 3]>,
    face_lines: Vec<usize>,
}

impl MeshBuilder {
    pub(crate) fn new(source: &str) -> Self {
        MeshBuilder {
            source: source.to_owned(),
            vertices: Vec::new(),
            faces: Vec::new(),
            face_lines: Vec::new(),
        }
    }

    pub(crate) fn syntax(&self, line: Option<usize>, message: impl Into<String>) -> MeshError {
        MeshError::Syntax {
            source_name: self.source.clone(),
            location: line,
            message: message.into(),
        }
    }

    /// `bytes` as text; else a syntax error at the line of the first byte that is not UTF-8,
    /// `why` saying why the format must be text.
    pub(crate) fn text<'a>(&self, bytes: &'a [u8], why: &str) -> Result<&'a str, MeshError> {
        std::str::from_utf8(bytes).map_err(|e| {
            let line = bytes[..e.valid_up_to()]
                .iter()
                .filter(|&&c| c == b'\n')
                .count()
                + 1;
            self.syntax(Some(line), format!("not UTF-8 text ({why})"))
        })
    }

    pub(crate) fn too_large(&self, message: impl Into<String>) -> MeshError {
        MeshError::TooLarge {
            source_name: self.source.clone(),
            message: message.into(),
        }
    }

    pub(crate) fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// The three coordinates of a text vertex statement (OBJ `v`, ASCII STL `vertex`) from
    /// `words`, at `line`.
    pub(crate) fn coordinates<'w>(
        &self,
        words: &mut impl Iterator<Item = &'w str>,
        line: usize,
    ) -> Result<[f64; 3], MeshError> {
        let mut p = [0.0; 3];
        for (k, c) in p.iter_mut().enumerate() {
            let word = words.next().ok_or_else(|| {
                self.syntax(Some(line), format!("vertex needs 3 coordinates, got {k}"))
            })?;
            *c = word.parse().map_err(|_| {
                self.syntax(
                    Some(line),
                    format!("vertex coordinate {word:?} is not a number"),
                )
            })?;
        }
        Ok(p)
    }

    /// Adds a vertex; refuses non-finite coordinates and too many vertices.
    pub(crate) fn vertex(&mut self, p: [f64; 3], line: Option<usize>) -> Result<(), MeshError> {
        if !p.iter().all(|c| c.is_finite()) {
            return Err(self.syntax(line, format!("vertex {p:?} is not finite")));
        }
        if self.vertices.len() >= MAX_VERTICES {
            return Err(MeshError::TooLarge {
                source_name: self.source.clone(),
                message: format!("more than {MAX_VERTICES} vertices"),
            });
        }
        self.vertices.push(p);
        Ok(())
    }

    /// Adds a polygon (fan-triangulated) of vertex indices already checked in range.
    pub(crate) fn polygon(
        &mut self,
        indices: &[usize],
        line: Option<usize>,
    ) -> Result<(), MeshError> {
        if indices.len() < 3 {
            return Err(self.syntax(
                line,
                format!("a face needs at least 3 vertices, got {}", indices.len()),
            ));
        }
        if let Some(&bad) = indices.iter().find(|&&i| i >= self.vertices.len()) {
            return Err(self.syntax(
                line,
                format!(
                    "face refers to vertex {} (1-based), the mesh has {} vertices",
                    bad + 1,
                    self.vertices.len()
                ),
            ));
        }
        if self.faces.len() + indices.len() - 2 > MAX_FACES {
            return Err(MeshError::TooLarge {
                source_name: self.source.clone(),
                message: format!("more than {MAX_FACES} triangles"),
            });
        }
        for k in 1..indices.len() - 1 {
            self.faces.push([indices[0], indices[k], indices[k + 1]]);
            self.face_lines.push(line.unwrap_or(0));
        }
        Ok(())
    }

    pub(crate) fn finish(self) -> Result<TriMesh, MeshError> {
        if self.faces.is_empty() {
            return Err(self.syntax(None, "the mesh has no faces"));
        }
        Ok(TriMesh {
            source: self.source,
            vertices: self.vertices,
            faces: self.faces,
            face_lines: self.face_lines,
        })
    }
}

impl TriMesh {
    /// A vertical prism: the convex polygon `base` (x east, y north, m; counter-clockwise seen
    /// from above) extruded from z = 0 to z = `height_m` (z up), validated. The shapes of the
    /// tests, benchmarks and docs (boxes, triangular and pentagonal prisms) whose volume,
    /// centre of mass and pivots have closed forms.
    pub fn prism(base: &[(f64, f64)], height_m: f64) -> Result<TriMesh, MeshError> {
        let n = base.len();
        let mut vertices: Vec<[f64; 3]> = base.iter().map(|&(x, y)| [x, y, 0.0]).collect();
        vertices.extend(base.iter().map(|&(x, y)| [x, y, height_m]));
        let mut faces = Vec::with_capacity(4 * n);
        for k in 1..n.saturating_sub(1) {
            faces.push([0, k + 1, k]); // bottom, outward −z
            faces.push([n, n + k, n + k + 1]); // top, outward +z
        }
        for i in 0..n {
            let j = (i + 1) % n;
            faces.push([i, j, n + j]);
            faces.push([i, n + j, n + i]);
        }
        let mut mesh = TriMesh {
            source: format!("prism of {n} sides, {height_m} m"),
            face_lines: vec![0; faces.len()],
            vertices,
            faces,
        };
        mesh.validate()?;
        Ok(mesh)
    }

    /// A box `b` (x, east) × `d` (y, north) × `h` (z, up) m with its base's corner at the
    /// origin ([`TriMesh::prism`] of the rectangle).
    pub fn cuboid(b: f64, d: f64, h: f64) -> Result<TriMesh, MeshError> {
        TriMesh::prism(&[(0.0, 0.0), (b, 0.0), (b, d), (0.0, d)], h)
    }

    /// Reads a mesh file (format by extension), merges duplicate vertices and validates it
    /// ([`TriMesh::validate`]).
    pub fn read(path: impl AsRef<Path>) -> Result<TriMesh, MeshError> {
        Ok(TriMesh::read_with(path, None)?.0)
    }

    /// [`TriMesh::read`], first closing the lowest boundary loop along `cap_up` (a unit
    /// vector, mesh coordinates) when given ([`TriMesh::cap`]); says what was capped.
    pub fn read_with(
        path: impl AsRef<Path>,
        cap_up: Option<[f64; 3]>,
    ) -> Result<(TriMesh, Option<cap::Cap>), MeshError> {
        let path = path.as_ref();
        let source = path.display().to_string();
        let format = MeshFormat::from_path(path).ok_or_else(|| MeshError::UnknownFormat {
            source_name: source.clone(),
        })?;
        let io = |e: std::io::Error| MeshError::Io {
            source_name: source.clone(),
            message: e.to_string(),
        };
        let size = std::fs::metadata(path).map_err(io)?.len();
        if size > MAX_FILE_BYTES {
            return Err(MeshError::TooLarge {
                source_name: source,
                message: format!("{size} bytes, more than the {MAX_FILE_BYTES} read"),
            });
        }
        // The size read is bounded too: a device reads as size 0 and never ends.
        let bytes = crate::bounded_read::read_bounded(path, MAX_FILE_BYTES).map_err(io)?;
        TriMesh::parse_with(&bytes, format, &source, cap_up)
    }

    /// Parses the bytes of a mesh file of `format` (`source` names it in messages), merges
    /// duplicate vertices and validates the surface.
    pub fn parse(bytes: &[u8], format: MeshFormat, source: &str) -> Result<TriMesh, MeshError> {
        Ok(TriMesh::parse_with(bytes, format, source, None)?.0)
    }

    /// [`TriMesh::parse`], capping first as [`TriMesh::read_with`] does.
    pub fn parse_with(
        bytes: &[u8],
        format: MeshFormat,
        source: &str,
        cap_up: Option<[f64; 3]>,
    ) -> Result<(TriMesh, Option<cap::Cap>), MeshError> {
        let mut mesh = match format {
            MeshFormat::Obj => obj::parse(bytes, source)?,
            MeshFormat::Ply => ply::parse(bytes, source)?,
            MeshFormat::Stl => stl::parse(bytes, source)?,
        };
        mesh.merge_duplicate_vertices();
        let capped = match cap_up {
            Some(up) => mesh.cap(up)?,
            None => None,
        };
        mesh.validate()?;
        Ok((mesh, capped))
    }

    /// Merges vertices with bit-identical coordinates (−0 and +0 alike) and drops the vertices
    /// no face uses.
    pub fn merge_duplicate_vertices(&mut self) {
        let key = |p: &[f64; 3]| p.map(|c| (c + 0.0).to_bits());
        let mut index: HashMap<[u64; 3], usize> = HashMap::with_capacity(self.vertices.len());
        let mut used = vec![false; self.vertices.len()];
        for f in &self.faces {
            for &v in f {
                used[v] = true;
            }
        }
        let mut remap = vec![usize::MAX; self.vertices.len()];
        let mut merged: Vec<[f64; 3]> = Vec::with_capacity(self.vertices.len());
        for (i, p) in self.vertices.iter().enumerate() {
            if !used[i] {
                continue;
            }
            let next = merged.len();
            let j = *index.entry(key(p)).or_insert(next);
            if j == next {
                merged.push(*p);
            }
            remap[i] = j;
        }
        for f in &mut self.faces {
            *f = f.map(|v| remap[v]);
        }
        self.vertices = merged;
    }

    fn location(&self, face: usize) -> Option<usize> {
        self.face_lines.get(face).copied().filter(|&l| l > 0)
    }

    /// Names a face for messages: its line, or its 0-based index.
    fn face_name(&self, face: usize) -> String {
        match self.location(face) {
            Some(_) => format!("face {face}"),
            None => format!("face {face} (0-based)"),
        }
    }

    /// Checks that the mesh is a closed, consistently oriented surface without collinear
    /// faces and with a non-zero volume; turns an inward-oriented mesh outward.
    pub fn validate(&mut self) -> Result<(), MeshError> {
        let scale = self.bounding_diagonal();
        if scale.is_nan() || scale <= 0.0 {
            return Err(MeshError::Degenerate {
                source_name: self.source.clone(),
                location: None,
                message: "all vertices coincide".into(),
            });
        }
        // Collinear (zero-area) faces, including faces repeating a vertex.
        for (i, f) in self.faces.iter().enumerate() {
            let [a, b, c] = f.map(|v| self.vertices[v]);
            let n = cross(sub(b, a), sub(c, a));
            if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] || norm(n) <= 1e-12 * scale * scale {
                return Err(MeshError::Degenerate {
                    source_name: self.source.clone(),
                    location: self.location(i),
                    message: format!(
                        "{} has collinear or repeated vertices (zero area)",
                        self.face_name(i)
                    ),
                });
            }
        }
        // Every directed edge once, and its reverse once.
        let mut directed: HashMap<(usize, usize), usize> =
            HashMap::with_capacity(3 * self.faces.len());
        for (i, f) in self.faces.iter().enumerate() {
            for k in 0..3 {
                let e = (f[k], f[(k + 1) % 3]);
                if let Some(&other) = directed.get(&e) {
                    let (a, b) = (self.vertices[e.0], self.vertices[e.1]);
                    return Err(MeshError::NotClosed {
                        source_name: self.source.clone(),
                        location: self.location(i),
                        message: format!(
                            "the edge {a:?} → {b:?} is traversed in the same direction by {} and \
                             {}{}: inconsistent orientation or an edge shared by more than two faces",
                            self.face_name(other),
                            self.face_name(i),
                            self.location(other)
                                .map(|l| format!(" (line {l})"))
                                .unwrap_or_default()
                        ),
                    });
                }
                directed.insert(e, i);
            }
        }
        // The first face (in file order) with an edge whose reverse no face has.
        for (i, f) in self.faces.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if !directed.contains_key(&(b, a)) {
                    return Err(MeshError::NotClosed {
                        source_name: self.source.clone(),
                        location: self.location(i),
                        message: format!(
                            "the edge {:?} → {:?} of {} belongs to no other face (a hole or a \
                             boundary), or its neighbour runs it the same way (inconsistent \
                             orientation)",
                            self.vertices[a],
                            self.vertices[b],
                            self.face_name(i)
                        ),
                    });
                }
            }
        }
        let volume = mass::MassProperties::signed_volume(self);
        if volume.is_nan() || volume.abs() <= 1e-12 * scale.powi(3) {
            return Err(MeshError::Degenerate {
                source_name: self.source.clone(),
                location: None,
                message: format!("the enclosed volume is {volume:e} m³ (zero)"),
            });
        }
        if volume < 0.0 {
            for f in &mut self.faces {
                f.swap(1, 2);
            }
        }
        Ok(())
    }

    /// Length of the diagonal of the axis-aligned bounding box (m).
    #[must_use]
    pub fn bounding_diagonal(&self) -> f64 {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if self.vertices.is_empty() {
            return 0.0;
        }
        norm(sub(hi, lo))
    }
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(crate) fn scale3(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

pub(crate) fn normalize(a: [f64; 3]) -> [f64; 3] {
    scale3(a, 1.0 / norm(a))
}
