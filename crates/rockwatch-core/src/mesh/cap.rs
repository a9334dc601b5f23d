//! Closing an open scan (`--cap`, catalogue `cap = true`): a boulder scanned from above has no
//! base, so its mesh has a boundary loop where the scan meets the ground. [`TriMesh::cap`]
//! closes the **lowest** boundary loop (smallest mean height along the up axis) with a fan of
//! triangles from the loop's centroid, oriented like the surface around it (each boundary edge
//! a → b gets the triangle b → a → centroid, so every edge is then run once each way). The cap
//! is planar when the loop is; otherwise its triangles follow the loop. It adds one vertex, the
//! centroid, at the loop's mean height: nothing below the loop, so the support the rock rests on
//! (the convex hull's facet, docs/meshes.md) is never widened by the cap.
//!
//! Only one loop is closed: a mesh with other holes is still refused by [`TriMesh::validate`].

use std::collections::{BTreeMap, HashSet};

use super::{dot, MeshError, TriMesh};

/// What [`TriMesh::cap`] did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Cap {
    /// Vertices of the closed loop.
    pub loop_vertices: usize,
    /// Boundary loops the mesh had (the others are left open, and refused by validation).
    pub loops: usize,
    /// Mean height of the loop along the up axis (m, mesh coordinates).
    pub mean_height_m: f64,
    /// Largest distance of a loop vertex from the loop's mean plane normal to up (m): 0 for a
    /// planar, level loop.
    pub height_spread_m: f64,
    /// Area of the cap (m², sum of the fan's triangles).
    pub area_m2: f64,
}

impl TriMesh {
    /// Closes the lowest boundary loop along `up` (a unit vector, mesh coordinates) by a fan
    /// from its centroid (module doc). `Ok(None)` when the mesh has no boundary. Call before
    /// [`TriMesh::validate`].
    pub fn cap(&mut self, up: [f64; 3]) -> Result<Option<Cap>, MeshError> {
        let fail = |message: String| MeshError::NotClosed {
            source_name: self.source.clone(),
            location: None,
            message,
        };
        let directed: HashSet<(usize, usize)> = self
            .faces
            .iter()
            .flat_map(|f| (0..3).map(move |k| (f[k], f[(k + 1) % 3])))
            .collect();
        // Boundary edges a → b (no face runs b → a), keyed by a: BTreeMap for a deterministic
        // order of the loops.
        let mut next: BTreeMap<usize, usize> = BTreeMap::new();
        for f in &self.faces {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                if !directed.contains(&(b, a)) && next.insert(a, b).is_some() {
                    return Err(fail(format!(
                        "cannot cap: the boundary passes twice through the vertex {:?} (not a \
                         simple loop)",
                        self.vertices[a]
                    )));
                }
            }
        }
        if next.is_empty() {
            return Ok(None);
        }
        let mut loops: Vec<Vec<usize>> = Vec::new();
        let mut seen: HashSet<usize> = HashSet::new();
        for &start in next.keys() {
            if seen.contains(&start) {
                continue;
            }
            let mut ring = vec![start];
            seen.insert(start);
            let mut v = start;
            loop {
                let Some(&w) = next.get(&v) else {
                    return Err(fail(format!(
                        "cannot cap: the boundary ends at the vertex {:?} (an open chain, not a \
                         loop)",
                        self.vertices[v]
                    )));
                };
                if w == start {
                    break;
                }
                if !seen.insert(w) {
                    return Err(fail(format!(
                        "cannot cap: the boundary runs into itself at the vertex {:?}",
                        self.vertices[w]
                    )));
                }
                ring.push(w);
                v = w;
            }
            loops.push(ring);
        }
        let height = |ring: &[usize]| {
            ring.iter().map(|&v| dot(self.vertices[v], up)).sum::<f64>() / ring.len() as f64
        };
        let Some(lowest) = loops.iter().min_by(|a, b| height(a).total_cmp(&height(b))) else {
            return Ok(None);
        };
        if lowest.len() < 3 {
            return Err(fail(format!(
                "cannot cap: the lowest boundary loop has {} vertices",
                lowest.len()
            )));
        }
        let n = lowest.len() as f64;
        let mut centroid = [0.0; 3];
        for &v in lowest {
            centroid = super::add(centroid, super::scale3(self.vertices[v], 1.0 / n));
        }
        let mean = height(lowest);
        let spread = lowest
            .iter()
            .map(|&v| (dot(self.vertices[v], up) - mean).abs())
            .fold(0.0, f64::max);
        let c = self.vertices.len();
        self.vertices.push(centroid);
        let mut area = 0.0;
        for k in 0..lowest.len() {
            let (a, b) = (lowest[k], lowest[(k + 1) % lowest.len()]);
            self.faces.push([b, a, c]);
            self.face_lines.push(0);
            let (pa, pb) = (self.vertices[a], self.vertices[b]);
            let u = super::sub(pa, pb);
            let w = super::sub(centroid, pb);
            area += 0.5 * super::norm(super::cross(u, w));
        }
        Ok(Some(Cap {
            loop_vertices: lowest.len(),
            loops: loops.len(),
            mean_height_m: mean,
            height_spread_m: spread,
            area_m2: area,
        }))
    }
}
