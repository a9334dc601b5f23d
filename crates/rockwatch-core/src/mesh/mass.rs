//! Volume, centre of mass and inertia tensor of a closed, outward-oriented triangle mesh of
//! uniform density, by the divergence theorem: the body is the signed sum of the tetrahedra
//! (o, a, b, c) spanned by a reference point o and each face (a, b, c).
//!
//! For one tetrahedron with edge vectors a, b, c from o, the signed volume is
//! V = a·(b × c)/6, its centroid o + (a + b + c)/4, and its second moment about o is
//! ∫ x xᵀ dV = V/20 · (a aᵀ + b bᵀ + c cᵀ + s sᵀ), s = a + b + c (Tonon 2004, eq. for the
//! covariance of a tetrahedron with one vertex at the origin). The reference point o is the
//! centre of the bounding box, which keeps the cancellation between tetrahedra small.
//!
//! Inertia is given for unit density (kg/m³ = 1, so mass = volume in m³): the tensor of
//! a rock of density ρ_rock is ρ_rock times it, and radii of gyration √(I/m) do not depend on
//! the density at all.

use super::{add, cross, dot, scale3, sub, TriMesh};

/// Mass properties of a closed mesh, unit density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    /// Enclosed volume (m³) = mass at unit density.
    pub volume_m3: f64,
    /// Centre of mass (m, mesh coordinates).
    pub com_m: [f64; 3],
    /// Inertia tensor about the centre of mass, mesh axes, unit density (kg·m² per kg/m³,
    /// i.e. m⁵): I = ∫ (|r|² 𝟙 − r rᵀ) dV with r measured from the centre of mass.
    pub inertia_com: [[f64; 3]; 3],
}

impl MassProperties {
    /// The signed volume (m³): positive for an outward-oriented closed mesh.
    #[must_use]
    pub fn signed_volume(mesh: &TriMesh) -> f64 {
        let o = reference_point(mesh);
        mesh.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|v| sub(mesh.vertices[v], o));
                dot(a, cross(b, c)) / 6.0
            })
            .sum()
    }

    /// The mass properties of a validated (closed, outward-oriented) mesh.
    #[must_use]
    pub fn of(mesh: &TriMesh) -> MassProperties {
        let o = reference_point(mesh);
        let mut volume = 0.0;
        let mut first = [0.0; 3];
        let mut second = [[0.0; 3]; 3];
        for f in &mesh.faces {
            let [a, b, c] = f.map(|v| sub(mesh.vertices[v], o));
            let v = dot(a, cross(b, c)) / 6.0;
            let s = add(add(a, b), c);
            volume += v;
            first = add(first, scale3(s, v / 4.0));
            for i in 0..3 {
                for j in 0..3 {
                    second[i][j] +=
                        v / 20.0 * (a[i] * a[j] + b[i] * b[j] + c[i] * c[j] + s[i] * s[j]);
                }
            }
        }
        let centroid = scale3(first, 1.0 / volume);
        // Second moment about the centre of mass: C_c = C_o − V c cᵀ (parallel axes).
        let mut c = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] = second[i][j] - volume * centroid[i] * centroid[j];
            }
        }
        let trace = c[0][0] + c[1][1] + c[2][2];
        let mut inertia = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                inertia[i][j] = if i == j { trace } else { 0.0 } - c[i][j];
            }
        }
        MassProperties {
            volume_m3: volume,
            com_m: add(o, centroid),
            inertia_com: inertia,
        }
    }

    /// Moment of inertia about the axis through the centre of mass along the unit vector `u`
    /// (unit density, m⁵): uᵀ I u.
    #[must_use]
    pub fn moment_about(&self, u: [f64; 3]) -> f64 {
        let i = &self.inertia_com;
        let iu = [dot(i[0], u), dot(i[1], u), dot(i[2], u)];
        dot(u, iu)
    }
}

fn reference_point(mesh: &TriMesh) -> [f64; 3] {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &mesh.vertices {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if mesh.vertices.is_empty() {
        return [0.0; 3];
    }
    scale3(add(lo, hi), 0.5)
}
