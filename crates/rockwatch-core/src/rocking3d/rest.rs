//! The closed-form rest test of a rock standing on its resting facet.
//!
//! In the ground frame the rock at rest feels, per unit mass, the effective gravity
//! g' = g + a_U downwards and the horizontal inertial force f = −(a_E, a_N). It stays at rest
//! iff
//! - g' > 0 (the ground pushes; otherwise it takes off);
//! - |f| ≤ μs·g' (the friction of the whole facet holds: it is a rigid body and the
//!   resultant friction force must equal m·f);
//! - for every edge e of the support polygon (outward unit normal n_e, distance dist_e from
//!   the centre of mass's projection) the overturning moment about the edge does not exceed
//!   the restoring one: (f·n_e)·h ≤ g'·dist_e (docs/meshes.md §1: this is the uplift
//!   threshold g·r(d)/h in every direction).
//!
//! The set of accelerations (a_E, a_N, a_U) at which rest holds is convex (an intersection of
//! half-spaces and a second-order cone). The input is linear within a sample interval, so
//! rest holds during the whole interval iff it holds at both ends: one test per input sample
//! decides, and leaving rest is located by bisection on that segment.

use super::body::RockBody;
use super::ground::GroundAccel3d;

/// The rest condition of a body (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct RestCondition {
    mu_s: f64,
    gravity_mps2: f64,
    h_m: f64,
    /// (n_east, n_north, dist) per support-polygon edge.
    edges: Vec<(f64, f64, f64)>,
    /// min(μs, min_e dist_e/h): |f| ≤ quick·g' is sufficient for every condition.
    quick: f64,
}

impl RestCondition {
    /// The rest condition of `body` with static friction `mu_s` under gravity `gravity_mps2`.
    #[must_use]
    pub fn new(body: &RockBody, mu_s: f64, gravity_mps2: f64) -> RestCondition {
        let h = body.h_m();
        let edges = body.edges().to_vec();
        let quick = edges.iter().map(|e| e.2 / h).fold(mu_s, f64::min).max(0.0);
        RestCondition {
            mu_s,
            gravity_mps2,
            h_m: h,
            edges,
            quick,
        }
    }

    /// k = min(μs, min_e dist_e/h) (dimensionless): a horizontal ground acceleration of
    /// magnitude at most k·(g + a_U), with g + a_U > 0, keeps the rock at rest whatever its
    /// direction (it neither slips nor lifts off about any edge).
    #[must_use]
    pub fn sufficient_ratio(&self) -> f64 {
        self.quick
    }

    /// Gravity g (m/s²) of the condition.
    #[must_use]
    pub fn gravity_mps2(&self) -> f64 {
        self.gravity_mps2
    }

    /// True when rest is consistent under the ground acceleration `a`.
    #[inline]
    #[must_use]
    pub fn holds(&self, a: GroundAccel3d) -> bool {
        let gp = self.gravity_mps2 + a.up_mps2;
        if gp.is_nan() || gp <= 0.0 {
            return false;
        }
        let (fx, fy) = (-a.east_mps2, -a.north_mps2);
        let f2 = fx * fx + fy * fy;
        let q = self.quick * gp;
        if f2 <= q * q {
            return true;
        }
        let s = self.mu_s * gp;
        if f2.is_nan() || f2 > s * s {
            return false;
        }
        self.edges
            .iter()
            .all(|&(nx, ny, dist)| (fx * nx + fy * ny) * self.h_m <= gp * dist)
    }

    /// The horizontal acceleration magnitude (m/s²) along the azimuth `azimuth_deg` at which
    /// a ground acceleration −a·d first breaks rest by lift-off (g·r(d)/h) or slip (μs·g),
    /// whichever is smaller, without vertical motion; d = (sin az, cos az) (east, north) is
    /// the direction of the inertial force (the rock tips towards d).
    #[must_use]
    pub fn threshold_towards(&self, azimuth_deg: f64) -> f64 {
        let (dx, dy) = {
            let (s, c) = azimuth_deg.to_radians().sin_cos();
            (s, c)
        };
        let g = self.gravity_mps2;
        let lift = self
            .edges
            .iter()
            .filter(|e| e.0 * dx + e.1 * dy > 0.0)
            .map(|&(nx, ny, dist)| g * dist / (self.h_m * (nx * dx + ny * dy)))
            .fold(f64::INFINITY, f64::min);
        lift.min(self.mu_s * g)
    }
}
