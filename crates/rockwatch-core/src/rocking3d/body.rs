//! The rigid body of a mesh rock: mass, inertia tensor and contact vertices in the body frame
//! (the ground frame of the resting pose, see the module doc of [`super`]).

use nalgebra::{Matrix3, Vector3};

use crate::mesh::contact::{RestingContact, RockGeometry};
use crate::mesh::support_polygon::SupportPolygon;

/// The density given to a rock whose density is not known (kg/m³, a granite's 2500–2700):
/// the dynamics do not depend on it (every force is proportional to the mass), only the
/// reported mass and impulses do.
pub const NOMINAL_DENSITY_KG_M3: f64 = 2500.0;

/// Why a body could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BodyError {
    #[error("density must be a finite number > 0 kg/m³, got {0}")]
    Density(f64),
    #[error("the inertia tensor is not positive definite")]
    Inertia,
    #[error("the resting facet gives no support polygon around the centre of mass: {0}")]
    Support(String),
    #[error("the hull has fewer than four vertices")]
    Hull,
}

/// A convex rigid body resting on a facet of its hull.
///
/// Units: kg, m, kg·m². Frame: body (east, north, up of the resting pose, origin at the centre
/// of mass). The dynamics do not depend on the density (every force is proportional to the
/// mass); it only scales the reported mass and impulses.
#[derive(Debug, Clone, PartialEq)]
pub struct RockBody {
    mass_kg: f64,
    inertia: Matrix3<f64>,
    inertia_inv: Matrix3<f64>,
    /// Hull vertices relative to the centre of mass (m): the resting facet's first
    /// (`n_resting`, their height set to exactly −h), then the others, each group in
    /// increasing mesh order.
    vertices: Vec<Vector3<f64>>,
    n_resting: usize,
    h_m: f64,
    /// Support polygon of the resting facet (east, north relative to the centre of mass).
    polygon: SupportPolygon,
    /// Per polygon edge: outward unit normal (east, north) and the centre of mass's
    /// horizontal distance to the edge's line (m, > 0).
    edges: Vec<(f64, f64, f64)>,
    /// Largest distance of a hull vertex from the centre of mass (m).
    radius_m: f64,
}

impl RockBody {
    /// The body of `geometry` resting as `rest` describes (its frame and resting facet; the
    /// contact tolerance is not used: the resting facet is the support), of uniform density
    /// `density_kg_m3`.
    pub fn from_mesh(
        geometry: &RockGeometry,
        rest: &RestingContact,
        density_kg_m3: f64,
    ) -> Result<RockBody, BodyError> {
        if !(density_kg_m3.is_finite() && density_kg_m3 > 0.0) {
            return Err(BodyError::Density(density_kg_m3));
        }
        let mp = geometry.mass();
        // Rows east, north, up: mesh vectors → body (resting ground) frame.
        let r0 = Matrix3::from_rows(&[
            Vector3::from(rest.east).transpose(),
            Vector3::from(rest.north).transpose(),
            Vector3::from(rest.up).transpose(),
        ]);
        let i_mesh = Matrix3::from_fn(|i, j| mp.inertia_com[i][j]);
        let inertia = r0 * i_mesh * r0.transpose() * density_kg_m3;
        let inertia = 0.5 * (inertia + inertia.transpose());
        let inertia_inv = inertia.try_inverse().ok_or(BodyError::Inertia)?;
        if !(inertia[(0, 0)] > 0.0 && inertia[(1, 1)] > 0.0 && inertia[(2, 2)] > 0.0) {
            return Err(BodyError::Inertia);
        }
        let c = Vector3::from(mp.com_m);
        let h = rest.h_m;
        let hull = geometry.hull_vertices();
        if hull.len() < 4 {
            return Err(BodyError::Hull);
        }
        let local: Vec<Vector3<f64>> = hull.iter().map(|p| r0 * (Vector3::from(*p) - c)).collect();
        let radius_m = local.iter().map(|r| r.norm()).fold(0.0, f64::max);
        // The hull's coplanarity tolerance (hull.rs) is 10⁻⁹ of the mesh size.
        let margin = 1e-9 * geometry_scale(&local);
        let (mut resting, mut others): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) =
            local.into_iter().partition(|r| (r.z + h).abs() <= margin);
        for r in &mut resting {
            r.z = -h;
        }
        let polygon = SupportPolygon::hull_of(resting.iter().map(|r| (r.x, r.y)), 0.0)
            .map_err(|e| BodyError::Support(e.to_string()))?;
        let v = polygon.vertices();
        let edges = (0..v.len())
            .map(|k| {
                let (a, b) = (v[k], v[(k + 1) % v.len()]);
                let (ex, ey) = (b.0 - a.0, b.1 - a.1);
                let len = ex.hypot(ey);
                let (nx, ny) = (ey / len, -ex / len);
                (nx, ny, nx * a.0 + ny * a.1)
            })
            .collect();
        let n_resting = resting.len();
        resting.append(&mut others);
        Ok(RockBody {
            mass_kg: mp.volume_m3 * density_kg_m3,
            inertia,
            inertia_inv,
            vertices: resting,
            n_resting,
            h_m: h,
            polygon,
            edges,
            radius_m,
        })
    }

    /// Mass (kg).
    #[must_use]
    pub fn mass_kg(&self) -> f64 {
        self.mass_kg
    }

    /// Inertia tensor about the centre of mass, body frame (kg·m²).
    #[must_use]
    pub fn inertia(&self) -> &Matrix3<f64> {
        &self.inertia
    }

    /// Its inverse (1/(kg·m²)).
    #[must_use]
    pub fn inertia_inv(&self) -> &Matrix3<f64> {
        &self.inertia_inv
    }

    /// Hull vertices relative to the centre of mass, body frame (m); the first
    /// [`RockBody::n_resting`] are the resting facet's.
    #[must_use]
    pub fn vertices(&self) -> &[Vector3<f64>] {
        &self.vertices
    }

    /// Number of vertices of the resting facet.
    #[must_use]
    pub fn n_resting(&self) -> usize {
        self.n_resting
    }

    /// Height of the centre of mass above the resting facet (m).
    #[must_use]
    pub fn h_m(&self) -> f64 {
        self.h_m
    }

    /// The resting facet's support polygon (east, north relative to the centre of mass, m).
    #[must_use]
    pub fn polygon(&self) -> &SupportPolygon {
        &self.polygon
    }

    /// Support polygon edges: (outward normal east, north; distance from the centre of mass's
    /// projection, m).
    #[must_use]
    pub fn edges(&self) -> &[(f64, f64, f64)] {
        &self.edges
    }

    /// Largest distance of a hull vertex from the centre of mass (m).
    #[must_use]
    pub fn radius_m(&self) -> f64 {
        self.radius_m
    }

    /// The uplift angle α(d) = atan(r(d)/h) (rad) of the horizontal unit direction
    /// (east, north) = (`dx`, `dy`): the tilt towards d at which the centre of mass is above
    /// the support polygon's edge the ray crosses (docs/meshes.md §1).
    #[must_use]
    pub fn alpha_towards(&self, dx: f64, dy: f64) -> f64 {
        (self.polygon.exit_distance(dx, dy) / self.h_m).atan()
    }

    /// The weakest direction: the azimuth (degrees clockwise from the mesh's north axis,
    /// [0, 360)) of the support polygon's nearest edge normal, and its uplift angle
    /// α = atan(dist/h) (rad), the smallest over all directions.
    #[must_use]
    pub fn weakest_direction(&self) -> (f64, f64) {
        let nearest = self
            .edges
            .iter()
            .copied()
            .fold(None, |best: Option<(f64, f64, f64)>, e| match best {
                Some(b) if b.2 <= e.2 => Some(b),
                _ => Some(e),
            });
        nearest.map_or((0.0, 0.0), |(nx, ny, dist)| {
            (
                nx.atan2(ny).to_degrees().rem_euclid(360.0),
                (dist / self.h_m).atan(),
            )
        })
    }
}

fn geometry_scale(points: &[Vector3<f64>]) -> f64 {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    (hi - lo).norm()
}
