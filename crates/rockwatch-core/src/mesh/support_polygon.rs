//! The support polygon of a resting rock and the distance to its boundary along a horizontal
//! ray: the lever arm b(d) of the exact 2-D reduction (docs/meshes.md, "The pivot of a
//! direction").
//!
//! A rigid body standing on a convex support polygon P, its centre of mass at height h above P
//! and projecting vertically to c inside P, under a horizontal pseudo-force m·a along the unit
//! direction d (the inertial force of a ground acceleration −a·d), first lifts off about an
//! edge e of P (outward unit normal n_e, at distance dist_e from c) when the overturning
//! moment m·a·h·(d·n_e) reaches the restoring moment m·g·dist_e. The smallest such a over the
//! edges with d·n_e > 0 is a = g·r(d)/h, with
//!
//! r(d) = min over edges with d·n_e > 0 of dist_e / (d·n_e),
//!
//! which is the distance from c to the boundary of P along the ray c + t·d (t > 0): the ray
//! leaves P through the edge that minimises the ratio. The extreme vertex of P along d,
//! max_p (p − c)·d, is never smaller and equals r(d) only when that vertex lies on the ray.
//!
//! Coordinates are horizontal (east, north) in metres, relative to c.

/// A convex polygon around the origin (the centre of mass's projection): its vertices
/// counter-clockwise (east, north) in metres, with each edge's outward unit normal and distance
/// from the origin.
#[derive(Debug, Clone, PartialEq)]
pub struct SupportPolygon {
    vertices: Vec<(f64, f64)>,
    /// Per edge k (from vertex k to k + 1): outward unit normal and the origin's distance to the
    /// edge's line (m, > 0).
    edges: Vec<((f64, f64), f64)>,
}

/// Why a set of contact points gives no support polygon around the origin.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SupportPolygonError {
    /// Fewer than three points not on one line.
    #[error("the contact points span no area (fewer than three points off one line)")]
    Degenerate,
    /// The origin (centre of mass) is on or outside the hull of the points.
    #[error("the centre of mass does not project strictly inside the contact points' hull")]
    OriginOutside,
}

impl SupportPolygon {
    /// The convex hull of `points` (east, north; m, relative to the centre of mass), which must
    /// contain the origin strictly inside (by more than `margin_m`, m, from every edge).
    ///
    /// Andrew's monotone chain: O(n log n), collinear boundary points dropped.
    pub fn hull_of(
        points: impl IntoIterator<Item = (f64, f64)>,
        margin_m: f64,
    ) -> Result<SupportPolygon, SupportPolygonError> {
        let mut pts: Vec<(f64, f64)> = points.into_iter().collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        pts.dedup();
        if pts.len() < 3 {
            return Err(SupportPolygonError::Degenerate);
        }
        let turn = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
            (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
        };
        // Lower chain left to right, then upper chain right to left; each chain's last point
        // starts the other, so it is dropped.
        let mut hull: Vec<(f64, f64)> = Vec::with_capacity(pts.len() + 1);
        let mut chain = |points: &mut dyn Iterator<Item = (f64, f64)>| {
            let start = hull.len();
            for p in points {
                while hull.len() >= start + 2
                    && turn(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
                {
                    hull.pop();
                }
                hull.push(p);
            }
            hull.pop();
        };
        chain(&mut pts.iter().copied());
        chain(&mut pts.iter().rev().copied());
        if hull.len() < 3 {
            return Err(SupportPolygonError::Degenerate);
        }
        let n = hull.len();
        let mut edges = Vec::with_capacity(n);
        for k in 0..n {
            let (a, b) = (hull[k], hull[(k + 1) % n]);
            let (ex, ey) = (b.0 - a.0, b.1 - a.1);
            let len = ex.hypot(ey);
            // Counter-clockwise polygon: the outward normal is the edge turned clockwise.
            let normal = (ey / len, -ex / len);
            let dist = normal.0 * a.0 + normal.1 * a.1;
            // (a NaN distance fails too)
            if dist.is_nan() || dist <= margin_m {
                return Err(SupportPolygonError::OriginOutside);
            }
            edges.push((normal, dist));
        }
        Ok(SupportPolygon {
            vertices: hull,
            edges,
        })
    }

    /// The polygon's vertices, counter-clockwise (east, north; m, relative to the centre of
    /// mass).
    #[must_use]
    pub fn vertices(&self) -> &[(f64, f64)] {
        &self.vertices
    }

    /// r(d): the distance (m) from the origin to the boundary along the ray t·(dx, dy), t > 0,
    /// for a unit direction (dx, dy) (module doc), and the index of the edge the ray leaves
    /// through (from vertex k to k + 1): the pivot edge of a tip towards d.
    #[must_use]
    pub fn exit(&self, dx: f64, dy: f64) -> (f64, usize) {
        let mut best = (f64::INFINITY, 0);
        for (k, &((nx, ny), dist)) in self.edges.iter().enumerate() {
            let along = nx * dx + ny * dy;
            if along > 0.0 {
                let r = dist / along;
                if r < best.0 {
                    best = (r, k);
                }
            }
        }
        best
    }

    /// The distance from the origin to the boundary along the unit direction (dx, dy) (m).
    #[must_use]
    pub fn exit_distance(&self, dx: f64, dy: f64) -> f64 {
        self.exit(dx, dy).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> SupportPolygon {
        let pts = [
            (-1.0, -1.0),
            (1.0, -1.0),
            (1.0, 1.0),
            (-1.0, 1.0),
            (0.5, 1.0),
            (0.0, 0.3),
        ];
        SupportPolygon::hull_of(pts, 0.0).expect("square")
    }

    #[test]
    fn hull_drops_interior_and_collinear_points_counter_clockwise() {
        let p = square();
        assert_eq!(p.vertices().len(), 4);
        let v = p.vertices();
        let area2: f64 = (0..v.len())
            .map(|k| {
                let (a, b) = (v[k], v[(k + 1) % v.len()]);
                a.0 * b.1 - a.1 * b.0
            })
            .sum();
        assert!(
            (area2 - 8.0).abs() < 1e-15,
            "counter-clockwise area 4: {area2}"
        );
    }

    #[test]
    fn exit_distance_of_a_square_is_the_secant_to_its_sides() {
        let p = square();
        for k in 0..72 {
            let az = f64::from(k) * 5.0_f64.to_radians();
            let (dx, dy) = (az.sin(), az.cos());
            let want = 1.0 / dx.abs().max(dy.abs());
            let got = p.exit_distance(dx, dy);
            assert!((got - want).abs() < 1e-12, "az {k}·5°: {got} vs {want}");
        }
    }

    #[test]
    fn an_origin_on_or_outside_the_hull_is_refused() {
        let off = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)];
        assert_eq!(
            SupportPolygon::hull_of(off, 0.0),
            Err(SupportPolygonError::OriginOutside)
        );
        let line = [(-1.0, 0.0), (1.0, 0.0), (0.0, 0.0)];
        assert_eq!(
            SupportPolygon::hull_of(line, 0.0),
            Err(SupportPolygonError::Degenerate)
        );
    }
}
