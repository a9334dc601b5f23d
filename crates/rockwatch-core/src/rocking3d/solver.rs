//! The contact impulses of one time step: projected Gauss–Seidel on the exact Coulomb cone.
//!
//! Unknowns: the impulse P_i = (P_E, P_N, P_U) (N·s, ground frame) at each active contact
//! vertex i, at offset r_i from the centre of mass (world orientation). The post-step
//! velocities are v⁺ = v_free + Σ P_i/m, ω⁺ = ω_free + I_w⁻¹ Σ r_i × P_i, and the contact
//! velocity u_i = v⁺ + ω⁺ × r_i. Conditions (Moreau–Jean, restitution 0, speculative gap):
//!
//! - Signorini: P_U,i ≥ 0, u_U,i + gap_i/Δt ≥ 0, complementary (a vertex at height
//!   gap_i ≥ 0 may fall by at most its gap in this step, and lands without bounce);
//! - Coulomb: |P_t,i| ≤ μ_i·P_U,i; |P_t,i| < μ_i·P_U,i ⇒ u_t,i = 0; otherwise u_t,i = −λ·P_t,i,
//!   λ ≥ 0 (maximal dissipation: the friction impulse opposes the slip velocity).
//!
//! Projected Gauss–Seidel: each contact in turn solves its normal row against the current
//! velocities (P_U ← max(0, P_U − (u_U + gap/Δt)/W_UU)), then its tangential pair with a scalar
//! step 1/w_t (w_t the largest eigenvalue of the 2×2 tangential block of the Delassus operator
//! W_ii = 𝟙/m − [r_i]× I_w⁻¹ [r_i]×) followed by the Euclidean projection on the disc of radius
//! μ·P_U. A scalar step makes the fixed point satisfy maximal dissipation exactly (a matrix step
//! would tilt the slip direction). Sweeps stop when no impulse changes by more than
//! `tolerance`·m·g·Δt (an impulse error of that fraction of one step's weight), or after
//! `max_sweeps` (counted as not converged). Sweeps alternate their order (forward, backward) so
//! that no vertex is favoured. Impulses are warm-started from the previous step.

use nalgebra::{Matrix3, Vector3};

/// One active contact of a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Contact {
    /// Hull vertex index.
    pub vertex: usize,
    /// Offset from the centre of mass, world orientation (m).
    pub r: Vector3<f64>,
    /// Smallest allowed normal velocity (m/s): −gap/Δt.
    pub target: f64,
    /// Friction coefficient of this step (μs if the vertex was not slipping, else μk).
    pub mu: f64,
    /// 1/W_UU and 1/w_t (see the module doc).
    pub inv_wn: f64,
    pub inv_wt: f64,
}

/// The projected Gauss–Seidel solver and its warm-start memory (allocated once).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ContactSolver {
    pub contacts: Vec<Contact>,
    /// Impulse of each hull vertex in the last step (0 when it was not active).
    pub impulse: Vec<Vector3<f64>>,
}

/// Result of one solve.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct SolveReport {
    pub sweeps: u32,
    pub converged: bool,
    /// Total normal impulse (N·s).
    pub normal_impulse: f64,
}

impl ContactSolver {
    pub fn new(n_vertices: usize) -> ContactSolver {
        ContactSolver {
            contacts: Vec::with_capacity(n_vertices),
            impulse: vec![Vector3::zeros(); n_vertices],
        }
    }

    /// Prepares the Delassus diagonal terms of a contact at `r` (world offset).
    pub fn contact(
        vertex: usize,
        r: Vector3<f64>,
        target: f64,
        mu: f64,
        inv_mass: f64,
        i_inv: &Matrix3<f64>,
    ) -> Contact {
        let rx = r.cross_matrix();
        let w = Matrix3::identity() * inv_mass - rx * i_inv * rx;
        let (a, b, c) = (w[(0, 0)], w[(0, 1)], w[(1, 1)]);
        let wt = 0.5 * (a + c) + (0.25 * (a - c) * (a - c) + b * b).sqrt();
        Contact {
            vertex,
            r,
            target,
            mu,
            inv_wn: 1.0 / w[(2, 2)],
            inv_wt: 1.0 / wt,
        }
    }

    /// Solves for the impulses of `self.contacts`, updating `v` and `w` (the free velocities
    /// on entry, the post-step ones on exit) and the warm-start memory.
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &mut self,
        v: &mut Vector3<f64>,
        w: &mut Vector3<f64>,
        inv_mass: f64,
        i_inv: &Matrix3<f64>,
        impulse_tolerance: f64,
        max_sweeps: u32,
    ) -> SolveReport {
        // Warm start: apply last step's impulses of the active vertices; forget the others.
        for c in &self.contacts {
            let p = self.impulse[c.vertex];
            *v += p * inv_mass;
            *w += i_inv * c.r.cross(&p);
        }
        let mut report = SolveReport::default();
        for sweep in 1..=max_sweeps {
            let mut change: f64 = 0.0;
            // Alternate the order (symmetric Gauss–Seidel): no bias towards the first vertex.
            let n = self.contacts.len();
            for k in 0..n {
                let c = if sweep % 2 == 1 {
                    &self.contacts[k]
                } else {
                    &self.contacts[n - 1 - k]
                };
                let old = self.impulse[c.vertex];
                // Normal row.
                let un = v.z + w.x * c.r.y - w.y * c.r.x;
                let pn = (old.z - (un - c.target) * c.inv_wn).max(0.0);
                let dn = Vector3::new(0.0, 0.0, pn - old.z);
                *v += dn * inv_mass;
                *w += i_inv * c.r.cross(&dn);
                // Tangential pair.
                let u = *v + w.cross(&c.r);
                let mut px = old.x - u.x * c.inv_wt;
                let mut py = old.y - u.y * c.inv_wt;
                let limit = c.mu * pn;
                let pt = px.hypot(py);
                if pt > limit {
                    let s = if pt > 0.0 { limit / pt } else { 0.0 };
                    px *= s;
                    py *= s;
                }
                let dt = Vector3::new(px - old.x, py - old.y, 0.0);
                *v += dt * inv_mass;
                *w += i_inv * c.r.cross(&dt);
                let new = Vector3::new(px, py, pn);
                change = change.max((new - old).abs().max());
                self.impulse[c.vertex] = new;
            }
            report.sweeps = sweep;
            if change <= impulse_tolerance {
                report.converged = true;
                break;
            }
        }
        report.normal_impulse = self.contacts.iter().map(|c| self.impulse[c.vertex].z).sum();
        report
    }
}
