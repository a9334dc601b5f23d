//! The contact impulses of one time step: projected Gauss–Seidel on the exact Coulomb cone,
//! started from a direct solve when few contacts stick (below).
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
//!
//! # Direct start for a few contacts
//! Gauss–Seidel converges slowly when the contacts are strongly coupled: on a slender body
//! rocking about an edge its two vertices need 70 sweeps on average, up to hundreds. With at
//! most `DIRECT_CONTACTS` (4) contacts the solver first tries the exact solution in which every
//! contact of an active set sticks (u_i = (0, 0, −gap_i/Δt); a frictionless contact only
//! u_U,i = −gap_i/Δt, P_t,i = 0): a linear system in the active impulses, W_AA·P_A = b_A,
//! solved by Cholesky. The active set starts from the contacts that carried a normal impulse
//! in the last step (all of them if none did); a contact with P_U < 0 leaves it, an inactive
//! one that would penetrate joins it (principal pivoting, at most a few rounds). If the
//! solution lies in every friction cone it replaces the warm start; otherwise (a contact
//! slips) the warm start is kept as before. Either way the Gauss–Seidel sweeps follow with
//! the same stopping rule, so the result is a fixed point of the same iteration to the same
//! tolerance; an exact start merely ends them after one or two sweeps.
//!
//! W_AA is singular when contacts are dependent (two vertices of an edge cannot push against
//! each other along it): a ridge of 10⁻¹⁰ of its largest diagonal term picks the
//! smallest-norm impulses, which share such an internal component evenly.

use nalgebra::{Matrix3, Vector3};

/// Most contacts the direct start takes (three unknowns each): a box on an edge has two, on
/// its face four.
const DIRECT_CONTACTS: usize = 4;
const DIRECT_ROWS: usize = 3 * DIRECT_CONTACTS;
/// Ridge added to W_AA, relative to its largest diagonal term (module doc).
const RIDGE: f64 = 1e-10;
/// Most active-set changes of one direct start.
const MAX_PIVOTS: usize = 2 * DIRECT_CONTACTS + 2;

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
        // Warm start: apply last step's impulses of the active vertices (or the direct
        // solution); forget the others.
        self.direct_start(v, w, inv_mass, i_inv, impulse_tolerance);
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
                let pt = (px * px + py * py).sqrt();
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

    /// The direct start (module doc): if every contact of some active set can stick, with
    /// the others clear of the ground, within the friction cones, writes those impulses into
    /// the warm-start memory (the others 0) and returns true; otherwise leaves it alone.
    /// `v`, `w`: the free velocities (m/s, rad/s).
    fn direct_start(
        &mut self,
        v: &Vector3<f64>,
        w: &Vector3<f64>,
        inv_mass: f64,
        i_inv: &Matrix3<f64>,
        impulse_tolerance: f64,
    ) -> bool {
        let n = self.contacts.len();
        if n == 0 || n > DIRECT_CONTACTS {
            return false;
        }
        let warm = self.contacts.iter().any(|c| self.impulse[c.vertex].z > 0.0);
        let mut active = [false; DIRECT_CONTACTS];
        for (a, c) in active.iter_mut().zip(&self.contacts) {
            *a = !warm || self.impulse[c.vertex].z > 0.0;
        }
        let mut p = [Vector3::zeros(); DIRECT_CONTACTS];
        for _ in 0..MAX_PIVOTS {
            let n_active = active.iter().filter(|&&a| a).count();
            let solved = match n_active {
                1 => self.solve_sticking::<3>(&active, v, w, inv_mass, i_inv, &mut p),
                2 => self.solve_sticking::<6>(&active, v, w, inv_mass, i_inv, &mut p),
                3 => self.solve_sticking::<9>(&active, v, w, inv_mass, i_inv, &mut p),
                4 => self.solve_sticking::<DIRECT_ROWS>(&active, v, w, inv_mass, i_inv, &mut p),
                _ => false,
            };
            if !solved {
                return false;
            }
            // A contact pulling leaves the active set (the most negative first).
            let pulling = (0..n)
                .filter(|&k| active[k] && p[k].z < 0.0)
                .min_by(|&a, &b| p[a].z.total_cmp(&p[b].z));
            if let Some(k) = pulling {
                active[k] = false;
                continue;
            }
            // A contact that would pass its target joins it (the most violating first, by the
            // normal impulse that would stop it).
            let (mut v1, mut w1) = (*v, *w);
            for (c, pk) in self.contacts.iter().zip(&p) {
                v1 += pk * inv_mass;
                w1 += i_inv * c.r.cross(pk);
            }
            let mut worst = (impulse_tolerance, None);
            for (k, c) in self.contacts.iter().enumerate() {
                let un = v1.z + w1.x * c.r.y - w1.y * c.r.x;
                let need = (c.target - un) * c.inv_wn;
                if !active[k] && need > worst.0 {
                    worst = (need, Some(k));
                }
            }
            if let (_, Some(k)) = worst {
                active[k] = true;
                continue;
            }
            let in_cones = self.contacts.iter().zip(&p).all(|(c, pk)| {
                let limit = c.mu * pk.z + impulse_tolerance;
                pk.x * pk.x + pk.y * pk.y <= limit * limit
            });
            if !in_cones {
                return false;
            }
            for (c, pk) in self.contacts.iter().zip(&p) {
                self.impulse[c.vertex] = *pk;
            }
            return true;
        }
        false
    }

    /// The impulses `p` (N·s) with which every contact of `active` sticks (a frictionless one
    /// only stops falling faster than its target, P_t = 0) and the others carry none; false if
    /// the system could not be factorised. `v`, `w`: the free velocities. `M` = 3 × the
    /// number of active contacts.
    fn solve_sticking<const M: usize>(
        &self,
        active: &[bool; DIRECT_CONTACTS],
        v: &Vector3<f64>,
        w: &Vector3<f64>,
        inv_mass: f64,
        i_inv: &Matrix3<f64>,
        p: &mut [Vector3<f64>; DIRECT_CONTACTS],
    ) -> bool {
        // Unknowns: three per active contact (east, north, up), in contact order.
        let mut slot = [0usize; DIRECT_CONTACTS];
        let mut n_active = 0;
        for (k, s) in slot.iter_mut().enumerate().take(self.contacts.len()) {
            if active[k] {
                *s = 3 * n_active;
                n_active += 1;
            }
        }
        debug_assert_eq!(M, 3 * n_active);
        let mut a = [[0.0; M]; M];
        let mut b = [0.0; M];
        for (k, ck) in self.contacts.iter().enumerate() {
            if !active[k] {
                continue;
            }
            let i0 = slot[k];
            let u = v + w.cross(&ck.r);
            b[i0] = -u.x;
            b[i0 + 1] = -u.y;
            b[i0 + 2] = ck.target - u.z;
            // Delassus blocks W_kl = 𝟙/m − [r_k]×·I⁻¹·[r_l]× (l ≤ k; W_lk = W_klᵀ).
            let rk_i_inv = ck.r.cross_matrix() * i_inv;
            for (l, cl) in self.contacts.iter().enumerate().take(k + 1) {
                if !active[l] {
                    continue;
                }
                let j0 = slot[l];
                let wkl = Matrix3::identity() * inv_mass - rk_i_inv * cl.r.cross_matrix();
                for r in 0..3 {
                    for c in 0..3 {
                        a[i0 + r][j0 + c] = wkl[(r, c)];
                        a[j0 + c][i0 + r] = wkl[(r, c)];
                    }
                }
            }
        }
        let ridge = RIDGE * (0..M).map(|i| a[i][i]).fold(0.0, f64::max);
        for (i, row) in a.iter_mut().enumerate() {
            row[i] += ridge;
        }
        // A frictionless contact's tangential impulses are 0: their rows become P_t = 0.
        for (k, ck) in self.contacts.iter().enumerate() {
            if active[k] && ck.mu <= 0.0 {
                for t in slot[k]..slot[k] + 2 {
                    a[t] = [0.0; M];
                    for row in a.iter_mut() {
                        row[t] = 0.0;
                    }
                    a[t][t] = 1.0;
                    b[t] = 0.0;
                }
            }
        }
        if !cholesky_solve(&mut a, &mut b) {
            return false;
        }
        for (k, pk) in p.iter_mut().enumerate() {
            *pk = if k < self.contacts.len() && active[k] {
                Vector3::new(b[slot[k]], b[slot[k] + 1], b[slot[k] + 2])
            } else {
                Vector3::zeros()
            };
        }
        true
    }
}

/// Solves A·x = b in place for a symmetric positive definite `a` (Cholesky; `b` becomes x);
/// false if a pivot is not positive.
fn cholesky_solve<const M: usize>(a: &mut [[f64; M]; M], b: &mut [f64; M]) -> bool {
    for j in 0..M {
        let d = a[j][j] - (0..j).map(|k| a[j][k] * a[j][k]).sum::<f64>();
        // A NaN pivot fails too.
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let d = d.sqrt();
        a[j][j] = d;
        for i in j + 1..M {
            a[i][j] = (a[i][j] - (0..j).map(|k| a[i][k] * a[j][k]).sum::<f64>()) / d;
        }
    }
    for i in 0..M {
        b[i] = (b[i] - (0..i).map(|k| a[i][k] * b[k]).sum::<f64>()) / a[i][i];
    }
    for i in (0..M).rev() {
        b[i] = (b[i] - (i + 1..M).map(|k| a[k][i] * b[k]).sum::<f64>()) / a[i][i];
    }
    true
}
