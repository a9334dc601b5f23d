//! The equations of motion of spec §4–§6, generalised to the planar body of
//! docs/general-body.md, as pure functions of the state and the ground acceleration. No
//! modes, no events: just accelerations and contact forces.
//!
//! Conventions (spec §1): θ > 0 is clockwise, rotation about the right (+x) pivot; `sigma`
//! (σ) is the pivot (+1 right, −1 left) and `s` the slip direction of the pivot (sgn u̇);
//! both are passed as ±1.0. Each pivot has its own R_σ and α_σ; φ = α_σ − σθ. Forces are
//! reported per unit mass (m/s²): `F` horizontal and `N` vertical contact force on the body
//! at the pivot.

use super::params::BlockParams;

/// Ground acceleration at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GroundAccel {
    /// Horizontal ground acceleration ẍg (m/s², + to the right, along the block's +x axis).
    pub horizontal_mps2: f64,
    /// Vertical ground acceleration ÿg (m/s², + up).
    pub vertical_mps2: f64,
}

impl GroundAccel {
    /// A horizontal-only ground acceleration.
    #[must_use]
    pub fn horizontal(horizontal_mps2: f64) -> Self {
        GroundAccel {
            horizontal_mps2,
            vertical_mps2: 0.0,
        }
    }

    /// Linear interpolation `self + (other − self)·w`.
    #[must_use]
    pub fn lerp(self, other: GroundAccel, w: f64) -> GroundAccel {
        GroundAccel {
            horizontal_mps2: self.horizontal_mps2
                + (other.horizontal_mps2 - self.horizontal_mps2) * w,
            vertical_mps2: self.vertical_mps2 + (other.vertical_mps2 - self.vertical_mps2) * w,
        }
    }

    /// True when both components are finite.
    #[must_use]
    pub fn is_finite(self) -> bool {
        self.horizontal_mps2.is_finite() && self.vertical_mps2.is_finite()
    }
}

/// Accelerations and contact forces of a block on one corner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PivotDynamics {
    /// θ̈ (rad/s²).
    pub theta_ddot: f64,
    /// ü, slip acceleration of the pivot relative to the ground (m/s²); 0 while rocking.
    pub slip_ddot: f64,
    /// Horizontal contact force per unit mass F/m (m/s²).
    pub friction_per_mass: f64,
    /// Vertical contact force per unit mass N/m (m/s²).
    pub normal_per_mass: f64,
}

/// Effective gravity g' = g + ÿg (m/s²).
#[inline]
#[must_use]
pub fn effective_gravity(p: &BlockParams, ground: GroundAccel) -> f64 {
    p.gravity_mps2 + ground.vertical_mps2
}

/// Pure rocking about pivot `sigma` (no slip): equations (R1)–(R3) with
/// θ̈ = −(m R_σ/I_O,σ)[σ g' sin φ + ẍg cos φ] (docs/general-body.md §3).
#[inline]
#[must_use]
pub fn rocking(
    p: &BlockParams,
    sigma: f64,
    theta: f64,
    theta_dot: f64,
    ground: GroundAccel,
) -> PivotDynamics {
    let side = p.side(sigma);
    let r = side.half_diagonal_m;
    let gp = effective_gravity(p, ground);
    let (sin_phi, cos_phi) = (side.alpha_rad - sigma * theta).sin_cos();
    let theta_ddot =
        -(side.rocking_factor / r) * (sigma * gp * sin_phi + ground.horizontal_mps2 * cos_phi);
    let w2 = theta_dot * theta_dot;
    PivotDynamics {
        theta_ddot,
        slip_ddot: 0.0,
        friction_per_mass: ground.horizontal_mps2
            + r * cos_phi * theta_ddot
            + sigma * r * sin_phi * w2,
        normal_per_mass: gp + sigma * r * sin_phi * theta_ddot - r * cos_phi * w2,
    }
}

/// Slide-rocking about pivot `sigma` with the pivot slipping in direction `s`:
/// equations (SR1)–(SR3), Coulomb friction F = −μk s N, with 1/3 generalised to
/// c_σ = ρ²/R_σ² (docs/general-body.md §4).
#[inline]
#[must_use]
pub fn slide_rocking(
    p: &BlockParams,
    sigma: f64,
    s: f64,
    theta: f64,
    theta_dot: f64,
    ground: GroundAccel,
) -> PivotDynamics {
    let side = p.side(sigma);
    let r = side.half_diagonal_m;
    let gp = effective_gravity(p, ground);
    let (sin_phi, cos_phi) = (side.alpha_rad - sigma * theta).sin_cos();
    let w2 = theta_dot * theta_dot;
    let k = sigma * sin_phi - p.mu_k * s * cos_phi;
    let theta_ddot =
        -k * (gp - r * cos_phi * w2) / (r * (side.inertia_ratio + sigma * k * sin_phi));
    let normal_per_mass = gp + sigma * r * sin_phi * theta_ddot - r * cos_phi * w2;
    let friction_per_mass = -p.mu_k * s * normal_per_mass;
    PivotDynamics {
        theta_ddot,
        slip_ddot: -ground.horizontal_mps2 - r * cos_phi * theta_ddot - sigma * r * sin_phi * w2
            + friction_per_mass,
        friction_per_mass,
        normal_per_mass,
    }
}

/// Flat sliding in direction `s` (θ = 0, both corners down): equation (S1),
/// ü = −ẍg − μk s g' (m/s²).
#[inline]
#[must_use]
pub fn sliding(p: &BlockParams, s: f64, ground: GroundAccel) -> f64 {
    -ground.horizontal_mps2 - p.mu_k * s * effective_gravity(p, ground)
}

/// The friction coefficient needed for pure rocking on pivot `sigma` to start from rest
/// under a step of horizontal acceleration of magnitude `a` (m/s²) pushing the body onto
/// that pivot (ẍg = −σa), spec §7 (Shenton 1996) generalised (docs/general-body.md §6):
/// μ_crit(a) = [a(ρ² + b_σ²) + g b_σ h] / [g(ρ² + h²) + a b_σ h]; for the rectangle
/// (ρ² = (b² + h²)/3) [a(4b² + h²) + 3gbh] / [g(b² + 4h²) + 3abh].
#[must_use]
pub fn critical_friction_for_step(p: &BlockParams, sigma: f64, a_mps2: f64) -> f64 {
    let (b, h, g) = (p.side(sigma).b_m, p.com_height_m, p.gravity_mps2);
    let rho2 = p.rho_m * p.rho_m;
    (a_mps2 * (rho2 + b * b) + g * b * h) / (g * (rho2 + h * h) + a_mps2 * b * h)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block() -> BlockParams {
        BlockParams::from_width_height(0.6, 2.0, 0.8, 0.6, None).unwrap()
    }

    #[test]
    fn rocking_at_rest_threshold_has_zero_angular_acceleration_and_static_reactions() {
        // Spec §7: at |ẍg| = g' tan α, θ̈ = 0, F = m ẍg, N = m g'.
        let p = block();
        let g = GroundAccel {
            horizontal_mps2: -p.gravity_mps2 * p.plus.tan_alpha,
            vertical_mps2: 0.0,
        };
        let d = rocking(&p, 1.0, 0.0, 0.0, g);
        assert!(d.theta_ddot.abs() < 1e-14);
        assert!((d.friction_per_mass - g.horizontal_mps2).abs() < 1e-14);
        assert!((d.normal_per_mass - p.gravity_mps2).abs() < 1e-14);
    }

    #[test]
    fn slide_rock_without_friction_keeps_horizontal_momentum_of_centroid() {
        // μk = 0: no horizontal force, so the centroid's absolute horizontal acceleration
        // ẍg + ü + R cos φ θ̈ + σ R sin φ θ̇² vanishes.
        let p = BlockParams::from_width_height(0.6, 2.0, 0.8, 0.0, None).unwrap();
        let g = GroundAccel {
            horizontal_mps2: 1.3,
            vertical_mps2: -0.7,
        };
        let (theta, w) = (0.05, -0.4);
        let d = slide_rocking(&p, 1.0, -1.0, theta, w, g);
        let (sin_phi, cos_phi) = (p.plus.alpha_rad - theta).sin_cos();
        let r = p.plus.half_diagonal_m;
        let ax = g.horizontal_mps2 + d.slip_ddot + r * cos_phi * d.theta_ddot + r * sin_phi * w * w;
        assert!(ax.abs() < 1e-13, "{ax}");
    }

    #[test]
    fn critical_friction_equals_slenderness_at_rocking_threshold() {
        // Spec §7: μ_crit(g b/h) = b/h.
        let p = block();
        let a = p.gravity_mps2 * p.plus.tan_alpha;
        assert!((critical_friction_for_step(&p, 1.0, a) - p.plus.tan_alpha).abs() < 1e-15);
        // And per side for an asymmetric body: μ_crit(g tan α_σ) = tan α_σ.
        let q = BlockParams::from_body(0.2, 0.45, 1.1, 0.5, 0.8, 0.6, None).unwrap();
        for sigma in [1.0, -1.0] {
            let t = q.side(sigma).tan_alpha;
            let mu = critical_friction_for_step(&q, sigma, q.gravity_mps2 * t);
            assert!((mu - t).abs() < 1e-15, "{sigma}: {mu} vs {t}");
        }
    }
}
