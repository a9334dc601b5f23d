//! The impact map of spec §9.1, generalised to the planar body of docs/general-body.md §7:
//! the body, rotating about pivot σ_old, returns to θ = 0 and the opposite pivot O′
//! (σ_new = −σ_old) strikes the ground. Instantaneous impulse at O′, plastic in the normal
//! direction, Coulomb in the tangential direction; angular momentum about O′ is conserved
//! with the impact ratio q (the generalised Housner ratio by default). With
//! J = I_O,new/m = ρ² + R_new² and h the height of the centre of mass:
//!
//! J θ̇⁺ + h u̇⁺ = q J θ̇⁻ + h u̇⁻                                 (I1, divided by m)
//! P_x/m = (u̇⁺ − u̇⁻) + h (θ̇⁺ − θ̇⁻),  P_y/m = σ_new (b_new θ̇⁺ + b_old θ̇⁻)   (I2)
//!
//! For the rectangle J = 4R²/3, h = R cos α, b = R sin α: the spec's (I1), (I2).

use super::params::BlockParams;

/// How the new pivot behaved during the impact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ImpactKind {
    /// O′ sticks (u̇⁺ = 0); for a purely rocking block this is Housner's θ̇⁺ = η θ̇⁻.
    Stick,
    /// O′ slips with Coulomb impulse P_x = −μk s⁺ P_y.
    Slip,
    /// No single-corner solution (σ_new θ̇⁺ ≤ 0): the block lands flat, θ̇⁺ = 0.
    FlatLanding,
}

/// Post-impact velocities and impulses (per unit mass).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactOutcome {
    pub kind: ImpactKind,
    /// New pivot corner (±1); for a flat landing the block is flat and this is σ_new anyway.
    pub sigma_new: f64,
    /// θ̇⁺ (rad/s).
    pub theta_dot: f64,
    /// u̇⁺, slip velocity of the contact point after the impact (m/s).
    pub slip_dot: f64,
    /// Horizontal impulse per unit mass P_x/m (m/s).
    pub impulse_x_per_mass: f64,
    /// Vertical impulse per unit mass P_y/m (m/s), ≥ 0.
    pub impulse_y_per_mass: f64,
}

/// Applies the impact rule of spec §9.1 to a body arriving at θ = 0 on pivot `sigma_old`
/// with angular velocity `theta_dot_before` (σ_old θ̇⁻ < 0) and pivot slip velocity
/// `slip_dot_before` (m/s).
#[must_use]
pub fn impact(
    p: &BlockParams,
    sigma_old: f64,
    theta_dot_before: f64,
    slip_dot_before: f64,
) -> ImpactOutcome {
    let sigma_new = -sigma_old;
    let (old, new) = (p.side(sigma_old), p.side(sigma_new));
    // Written in the new pivot's R, sin α, cos α (h = R cos α, b_new = R sin α) and the ratio
    // k = b_old/b_new, so that for the rectangle (k = 1 exactly) every operation is the
    // spec's: (I1)/(mR²) reads κ θ̇⁺ + (cos α/R) u̇⁺ = κ q θ̇⁻ + (cos α/R) u̇⁻.
    let (r, sa, ca, kappa) = (
        new.half_diagonal_m,
        new.sin_alpha,
        new.cos_alpha,
        new.pivot_inertia_ratio,
    );
    let k = (old.half_diagonal_m * old.sin_alpha) / (r * sa);
    let q = p.impact_ratio(sigma_old);
    let (w0, v0) = (theta_dot_before, slip_dot_before);
    // Friction available at the impact: static if O′ arrives without tangential velocity.
    let mu = if v0 == 0.0 { p.mu_s } else { p.mu_k };
    let impulses = |w1: f64, v1: f64| {
        (
            (v1 - v0) + r * ca * (w1 - w0),
            sigma_new * r * sa * (w1 + k * w0),
        )
    };

    // Stick: u̇⁺ = 0; θ̇⁺ = q θ̇⁻ + (h/J) u̇⁻ with h/J = (1/κ) cos α / R.
    let mut w_stick = q * w0 + new.rocking_factor * ca / r * v0;
    if p.restitution.is_some() && !p.is_rectangle() {
        // A restitution on a body whose pivots differ is not a momentum balance: a body that
        // arrives slipping could leave with more kinetic energy than it had. Bound the
        // post-impact energy ½ I_new θ̇⁺² by the pre-impact energy (docs/general-body.md §7).
        let (h, b_old) = (r * ca, old.half_diagonal_m * old.sin_alpha);
        let vx = v0 + h * w0;
        let energy_before = vx * vx + (b_old * b_old + p.rho_m * p.rho_m) * w0 * w0;
        let w_max = (energy_before / new.pivot_inertia_m2()).sqrt();
        w_stick = w_stick.clamp(-w_max, w_max);
    }
    let (px_stick, py_stick) = impulses(w_stick, 0.0);
    if sigma_new * w_stick > 0.0 && px_stick.abs() <= mu * py_stick {
        return ImpactOutcome {
            kind: ImpactKind::Stick,
            sigma_new,
            theta_dot: w_stick,
            slip_dot: 0.0,
            impulse_x_per_mass: px_stick,
            impulse_y_per_mass: py_stick,
        };
    }

    // Slip: P_x = −μk s⁺ P_y. Try the direction opposite to the sticking impulse first.
    let first = if px_stick > 0.0 { -1.0 } else { 1.0 };
    for s_new in [first, -first] {
        // θ̇⁺ = θ̇⁻ (J q − h² + μk s⁺σ_new b_old h)/(J − h² − μk s⁺σ_new b_new h), ÷ R².
        let c = p.mu_k * s_new * sigma_new * sa * ca;
        let q = p.slip_impact_ratio(sigma_old);
        let w1 = w0 * (kappa * q - ca * ca + c * k) / (kappa - ca * ca - c);
        let v1 = v0 - r * ca * (w1 - w0) - p.mu_k * s_new * sigma_new * r * sa * (w1 + k * w0);
        let (px, py) = impulses(w1, v1);
        if sigma_new * w1 > 0.0 && v1 * s_new >= 0.0 && py >= 0.0 {
            return ImpactOutcome {
                kind: ImpactKind::Slip,
                sigma_new,
                theta_dot: w1,
                slip_dot: v1,
                impulse_x_per_mass: px,
                impulse_y_per_mass: py,
            };
        }
    }

    // Flat landing: the centroid's vertical velocity is stopped (θ̇⁺ = 0) and the horizontal
    // velocity of the base is reduced by a Coulomb impulse bounded by μ P_y.
    let py = -sigma_old * old.half_diagonal_m * old.sin_alpha * w0;
    let centroid_vx = v0 + old.half_diagonal_m * old.cos_alpha * w0;
    let v1 = if centroid_vx.abs() <= mu * py {
        0.0
    } else {
        centroid_vx - p.mu_k * centroid_vx.signum() * py
    };
    ImpactOutcome {
        kind: ImpactKind::FlatLanding,
        sigma_new,
        theta_dot: 0.0,
        slip_dot: v1,
        impulse_x_per_mass: v1 - centroid_vx,
        impulse_y_per_mass: py,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pure_rocking_impact_with_ample_friction_is_housner() {
        let p = BlockParams::from_width_height(0.4, 2.0, 0.8, 0.6, None).unwrap();
        let out = impact(&p, 1.0, -0.3, 0.0);
        let eta = 1.0 - 1.5 * p.plus.sin_alpha.powi(2);
        assert_eq!(out.kind, ImpactKind::Stick);
        assert!((out.theta_dot / -0.3 - eta).abs() < 1e-15);
        assert_eq!(out.slip_dot, 0.0);
    }

    #[test]
    fn frictionless_impact_ratio_matches_closed_form() {
        // Spec §9.1: μk = 0 → θ̇⁺/θ̇⁻ = (1 − 3 sin²α)/(1 + 3 sin²α).
        let p = BlockParams::from_width_height(0.4, 2.0, 1e-12, 0.0, None).unwrap();
        let out = impact(&p, -1.0, 0.5, 0.0);
        let s2 = p.plus.sin_alpha.powi(2);
        assert_eq!(out.kind, ImpactKind::Slip);
        assert!((out.theta_dot / 0.5 - (1.0 - 3.0 * s2) / (1.0 + 3.0 * s2)).abs() < 1e-12);
    }
}
