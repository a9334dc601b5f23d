//! The 3-D convex hull of a point set (quickhull, Barber, Dobkin & Huhdanpaa 1996) and its
//! planar facets.
//!
//! Robustness: a point counts as outside a face only when it is more than `eps` = 10⁻⁹ × the
//! bounding-box diagonal above the face's plane, so points on a face (the coplanar vertices of
//! a box side or a cylinder's cap) never create slivers; they end up in the facet of that
//! plane. Coplanar hull triangles are then merged into [`Facet`]s (plane within `eps`), each
//! with its convex polygon. Work: O(n log n) expected, bounded by the mesh bounds of
//! [`super::MAX_VERTICES`]; an iteration cap turns a numerical failure into an error.

use std::collections::HashMap;

use super::{cross, dot, norm, scale3, sub};

/// A planar facet of the hull: its outward unit normal, plane offset (n·x = offset for points
/// x of the plane) and the indices of the hull vertices on it, in counter-clockwise order seen
/// from outside (the convex polygon).
#[derive(Debug, Clone, PartialEq)]
pub struct Facet {
    pub normal: [f64; 3],
    pub offset: f64,
    pub polygon: Vec<usize>,
}

/// Why a hull could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HullError {
    #[error("the points are {0}: they span no volume")]
    Flat(&'static str),
    #[error("the hull construction did not converge (numerically degenerate point set)")]
    NotConverged,
}

#[derive(Debug, Clone)]
struct Face {
    v: [usize; 3],
    /// neighbour across edge k (v[k] → v[k+1])
    n: [usize; 3],
    normal: [f64; 3],
    offset: f64,
    outside: Vec<usize>,
    alive: bool,
}

/// The convex hull's facets of `points`. Facets are merged from hull triangles whose planes
/// agree within `eps` (see the module doc).
pub fn convex_hull(points: &[[f64; 3]]) -> Result<Vec<Facet>, HullError> {
    let triangles = hull_triangles(points)?;
    Ok(merge_facets(points, &triangles))
}

fn diagonal(points: &[[f64; 3]]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    norm(sub(hi, lo))
}

fn plane(points: &[[f64; 3]], v: [usize; 3]) -> ([f64; 3], f64) {
    let [a, b, c] = v.map(|i| points[i]);
    let n = cross(sub(b, a), sub(c, a));
    let len = norm(n);
    let n = scale3(n, 1.0 / len);
    (n, dot(n, a))
}

/// Hull triangles (outward, counter-clockwise) as vertex index triples.
fn hull_triangles(points: &[[f64; 3]]) -> Result<Vec<[usize; 3]>, HullError> {
    if points.len() < 4 {
        return Err(HullError::Flat("fewer than four"));
    }
    let scale = diagonal(points);
    if scale.is_nan() || scale <= 0.0 || !scale.is_finite() {
        return Err(HullError::Flat("all at one place"));
    }
    let eps = 1e-9 * scale;
    // Initial simplex: the two extreme points farthest apart among the axis extremes, the
    // point farthest from their line, the point farthest from that plane.
    let mut extremes = [0usize; 6];
    for (i, p) in points.iter().enumerate() {
        for k in 0..3 {
            if p[k] < points[extremes[2 * k]][k] {
                extremes[2 * k] = i;
            }
            if p[k] > points[extremes[2 * k + 1]][k] {
                extremes[2 * k + 1] = i;
            }
        }
    }
    let (mut i0, mut i1, mut best) = (0, 0, -1.0);
    for &a in &extremes {
        for &b in &extremes {
            let d = norm(sub(points[a], points[b]));
            if d > best {
                (i0, i1, best) = (a, b, d);
            }
        }
    }
    let axis = sub(points[i1], points[i0]);
    let (mut i2, mut best) = (0, -1.0);
    for (i, p) in points.iter().enumerate() {
        let d = norm(cross(axis, sub(*p, points[i0])));
        if d > best {
            (i2, best) = (i, d);
        }
    }
    if best <= eps * norm(axis) {
        return Err(HullError::Flat("collinear"));
    }
    let n = cross(axis, sub(points[i2], points[i0]));
    let n = scale3(n, 1.0 / norm(n));
    let (mut i3, mut best) = (0, 0.0f64);
    for (i, p) in points.iter().enumerate() {
        let d = dot(n, sub(*p, points[i0]));
        if d.abs() > best.abs() {
            (i3, best) = (i, d);
        }
    }
    if best.abs() <= eps {
        return Err(HullError::Flat("coplanar"));
    }
    // Orient the simplex outward: the apex i3 must be below each face.
    let (a, b, c, d) = if best > 0.0 {
        (i0, i2, i1, i3)
    } else {
        (i0, i1, i2, i3)
    };
    let mut faces: Vec<Face> = Vec::new();
    let simplex = [[a, b, c], [a, d, b], [b, d, c], [c, d, a]];
    for v in simplex {
        let (normal, offset) = plane(points, v);
        faces.push(Face {
            v,
            n: [usize::MAX; 3],
            normal,
            offset,
            outside: Vec::new(),
            alive: true,
        });
    }
    link_all(&mut faces);
    // Assign every point to the first face it is outside of.
    for (i, p) in points.iter().enumerate() {
        if [a, b, c, d].contains(&i) {
            continue;
        }
        for f in faces.iter_mut() {
            if dot(f.normal, *p) - f.offset > eps {
                f.outside.push(i);
                break;
            }
        }
    }
    let max_iterations = 4 * points.len() + 16;
    let mut iterations = 0;
    let mut visible: Vec<usize> = Vec::new();
    let mut stack: Vec<usize> = Vec::new();
    let mut mark: Vec<u32> = Vec::new();
    let mut stamp = 0u32;
    let mut pending: Vec<usize> = (0..faces.len()).collect();
    while let Some(fi) = pending.pop() {
        if !faces[fi].alive || faces[fi].outside.is_empty() {
            continue;
        }
        iterations += 1;
        if iterations > max_iterations {
            return Err(HullError::NotConverged);
        }
        // The farthest outside point of the face.
        let f = &faces[fi];
        let eye = *f
            .outside
            .iter()
            .max_by(|&&x, &&y| {
                let dx = dot(f.normal, points[x]) - f.offset;
                let dy = dot(f.normal, points[y]) - f.offset;
                dx.total_cmp(&dy)
            })
            .ok_or(HullError::NotConverged)?;
        let p = points[eye];
        // Visible faces: flood fill from fi over faces the eye is above.
        stamp += 1;
        mark.resize(faces.len(), 0);
        visible.clear();
        stack.clear();
        stack.push(fi);
        mark[fi] = stamp;
        while let Some(g) = stack.pop() {
            visible.push(g);
            for &h in &faces[g].n {
                if mark[h] != stamp
                    && faces[h].alive
                    && dot(faces[h].normal, p) - faces[h].offset > eps
                {
                    mark[h] = stamp;
                    stack.push(h);
                }
            }
        }
        // Horizon: directed edges of visible faces whose neighbour is not visible.
        let mut horizon: HashMap<usize, (usize, usize)> = HashMap::new(); // from → (to, neighbour)
        for &g in &visible {
            for k in 0..3 {
                let h = faces[g].n[k];
                if mark[h] != stamp {
                    let (from, to) = (faces[g].v[k], faces[g].v[(k + 1) % 3]);
                    if horizon.insert(from, (to, h)).is_some() {
                        return Err(HullError::NotConverged);
                    }
                }
            }
        }
        // Chain the horizon into one cycle.
        let start = *horizon.keys().min().ok_or(HullError::NotConverged)?;
        let mut cycle: Vec<(usize, usize, usize)> = Vec::with_capacity(horizon.len());
        let mut at = start;
        loop {
            let &(to, h) = horizon.get(&at).ok_or(HullError::NotConverged)?;
            cycle.push((at, to, h));
            at = to;
            if at == start {
                break;
            }
            if cycle.len() > horizon.len() {
                return Err(HullError::NotConverged);
            }
        }
        if cycle.len() != horizon.len() {
            return Err(HullError::NotConverged);
        }
        // Orphaned outside points.
        let mut orphans: Vec<usize> = Vec::new();
        for &g in &visible {
            faces[g].alive = false;
            orphans.append(&mut faces[g].outside);
        }
        // New faces (from, to, eye), linked around the cone and to the horizon.
        let first_new = faces.len();
        let m = cycle.len();
        for (k, &(from, to, h)) in cycle.iter().enumerate() {
            let v = [from, to, eye];
            let (normal, offset) = plane(points, v);
            if !normal.iter().all(|c| c.is_finite()) {
                return Err(HullError::NotConverged);
            }
            let next = first_new + (k + 1) % m;
            let prev = first_new + (k + m - 1) % m;
            faces.push(Face {
                v,
                n: [h, next, prev],
                normal,
                offset,
                outside: Vec::new(),
                alive: true,
            });
            // The horizon face now borders the new face across (to, from).
            let hf = &mut faces[h];
            for kk in 0..3 {
                if hf.v[kk] == to && hf.v[(kk + 1) % 3] == from {
                    hf.n[kk] = first_new + k;
                }
            }
        }
        for q in orphans {
            if q == eye {
                continue;
            }
            if let Some(g) = faces[first_new..]
                .iter_mut()
                .find(|g| dot(g.normal, points[q]) - g.offset > eps)
            {
                g.outside.push(q);
            }
        }
        pending.extend(first_new..faces.len());
    }
    Ok(faces.iter().filter(|f| f.alive).map(|f| f.v).collect())
}

/// Sets the neighbours of a closed set of faces from their shared edges.
fn link_all(faces: &mut [Face]) {
    let mut edges: HashMap<(usize, usize), usize> = HashMap::new();
    for (i, f) in faces.iter().enumerate() {
        for k in 0..3 {
            edges.insert((f.v[k], f.v[(k + 1) % 3]), i);
        }
    }
    for f in faces.iter_mut() {
        for k in 0..3 {
            if let Some(&g) = edges.get(&(f.v[(k + 1) % 3], f.v[k])) {
                f.n[k] = g;
            }
        }
    }
}

/// Groups hull triangles into planar facets: adjacent triangles whose vertices all lie within
/// `eps` of each other's planes belong to one facet.
fn merge_facets(points: &[[f64; 3]], triangles: &[[usize; 3]]) -> Vec<Facet> {
    let eps = 1e-9 * diagonal(points);
    let planes: Vec<([f64; 3], f64)> = triangles.iter().map(|&t| plane(points, t)).collect();
    let mut edges: HashMap<(usize, usize), usize> = HashMap::new();
    for (i, t) in triangles.iter().enumerate() {
        for k in 0..3 {
            edges.insert((t[k], t[(k + 1) % 3]), i);
        }
    }
    let coplanar = |i: usize, j: usize| {
        let (n, o) = planes[i];
        dot(n, planes[j].0) > 0.0
            && triangles[j]
                .iter()
                .all(|&v| (dot(n, points[v]) - o).abs() <= eps)
    };
    let mut group = vec![usize::MAX; triangles.len()];
    let mut facets = Vec::new();
    for seed in 0..triangles.len() {
        if group[seed] != usize::MAX {
            continue;
        }
        let id = facets.len();
        group[seed] = id;
        let mut members = vec![seed];
        let mut k = 0;
        while k < members.len() {
            let t = triangles[members[k]];
            for e in 0..3 {
                if let Some(&j) = edges.get(&(t[(e + 1) % 3], t[e])) {
                    if group[j] == usize::MAX && coplanar(seed, j) {
                        group[j] = id;
                        members.push(j);
                    }
                }
            }
            k += 1;
        }
        // The facet's plane: area-weighted normal of its triangles.
        let mut n = [0.0; 3];
        for &m in &members {
            let [a, b, c] = triangles[m].map(|v| points[v]);
            n = super::add(n, cross(sub(b, a), sub(c, a)));
        }
        let n = scale3(n, 1.0 / norm(n));
        let mut vertices: Vec<usize> = members.iter().flat_map(|&m| triangles[m]).collect();
        vertices.sort_unstable();
        vertices.dedup();
        let offset =
            vertices.iter().map(|&v| dot(n, points[v])).sum::<f64>() / vertices.len() as f64;
        let polygon = convex_polygon(points, &vertices, n);
        facets.push(Facet {
            normal: n,
            offset,
            polygon,
        });
    }
    facets
}

/// The convex polygon (counter-clockwise seen from the side `n` points to) of coplanar
/// points: Andrew's monotone chain in the plane's own 2-D frame.
fn convex_polygon(points: &[[f64; 3]], vertices: &[usize], n: [f64; 3]) -> Vec<usize> {
    let (e1, e2) = plane_frame(n);
    let mut pts: Vec<(f64, f64, usize)> = vertices
        .iter()
        .map(|&v| (dot(e1, points[v]), dot(e2, points[v]), v))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let turn = |o: (f64, f64, usize), a: (f64, f64, usize), b: (f64, f64, usize)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64, usize)> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &(f64, f64, usize)>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && turn(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull.into_iter().map(|p| p.2).collect()
}

/// Two unit vectors e1, e2 with (e1, e2, n) right-handed and orthonormal.
pub(crate) fn plane_frame(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let helper = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let e1 = cross(helper, n);
    let e1 = scale3(e1, 1.0 / norm(e1));
    let e2 = cross(n, e1);
    (e1, e2)
}
