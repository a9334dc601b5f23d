//! Block parameters: geometry, friction, impact restitution, validated at construction.

use crate::STANDARD_GRAVITY_MPS2;

/// Why a set of block parameters was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error("{name} must be a positive finite number, got {value}")]
    NotPositive { name: &'static str, value: f64 },
    #[error("{name} must be a finite number ≥ 0, got {value}")]
    Negative { name: &'static str, value: f64 },
    #[error("kinetic friction mu_k = {mu_k} exceeds static friction mu_s = {mu_s}")]
    KineticAboveStatic { mu_k: f64, mu_s: f64 },
    #[error(
        "kinetic friction mu_k = {0} ≥ 4/3: slide-rocking is ill-posed there (Painlevé paradox)"
    )]
    Painleve(f64),
    #[error("restitution must be in [0, 1], got {0}")]
    Restitution(f64),
    #[error("slenderness alpha must be in (0, π/2) rad, got {0}")]
    Alpha(f64),
}

/// A rectangular rigid block on a rigid base with Coulomb friction (spec §1).
///
/// Stores the primary parameters and the derived constants the dynamics use in every step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockParams {
    /// Base width B (m).
    pub width_m: f64,
    /// Height H (m).
    pub height_m: f64,
    /// Static friction coefficient μs (dimensionless, > 0).
    pub mu_s: f64,
    /// Kinetic friction coefficient μk (0 ≤ μk ≤ μs, μk < 4/3).
    pub mu_k: f64,
    /// Angular-velocity ratio e of a pure-rocking impact, replacing Housner's η when given.
    pub restitution: Option<f64>,
    /// Gravity g (m/s²).
    pub gravity_mps2: f64,
    /// Half-diagonal R = ½√(B² + H²) (m).
    pub half_diagonal_m: f64,
    /// Slenderness α = atan(B/H) (rad).
    pub alpha_rad: f64,
    pub sin_alpha: f64,
    pub cos_alpha: f64,
    pub tan_alpha: f64,
    /// Frequency parameter p = √(3g/(4R)) (rad/s).
    pub p_rad_per_s: f64,
    /// Impact ratio used in the angular-momentum balance (I1): `restitution` if given, else
    /// Housner's η = 1 − 1.5 sin²α.
    pub impact_ratio: f64,
}

impl BlockParams {
    /// Builds a block from base width B and height H (m), under standard gravity.
    pub fn from_width_height(
        width_m: f64,
        height_m: f64,
        mu_s: f64,
        mu_k: f64,
        restitution: Option<f64>,
    ) -> Result<Self, ParamError> {
        positive("width", width_m)?;
        positive("height", height_m)?;
        positive("mu_s", mu_s)?;
        if !(mu_k.is_finite() && mu_k >= 0.0) {
            return Err(ParamError::Negative {
                name: "mu_k",
                value: mu_k,
            });
        }
        if mu_k > mu_s {
            return Err(ParamError::KineticAboveStatic { mu_k, mu_s });
        }
        if mu_k >= 4.0 / 3.0 {
            return Err(ParamError::Painleve(mu_k));
        }
        if let Some(e) = restitution {
            if !(0.0..=1.0).contains(&e) {
                return Err(ParamError::Restitution(e));
            }
        }
        let g = STANDARD_GRAVITY_MPS2;
        let half_diagonal_m = 0.5 * width_m.hypot(height_m);
        let alpha_rad = width_m.atan2(height_m);
        let (sin_alpha, cos_alpha) = alpha_rad.sin_cos();
        Ok(BlockParams {
            width_m,
            height_m,
            mu_s,
            mu_k,
            restitution,
            gravity_mps2: g,
            half_diagonal_m,
            alpha_rad,
            sin_alpha,
            cos_alpha,
            tan_alpha: width_m / height_m,
            p_rad_per_s: (0.75 * g / half_diagonal_m).sqrt(),
            impact_ratio: restitution.unwrap_or(1.0 - 1.5 * sin_alpha * sin_alpha),
        })
    }

    /// Builds a block from half-diagonal R (m) and slenderness α (rad).
    pub fn from_r_alpha(
        half_diagonal_m: f64,
        alpha_rad: f64,
        mu_s: f64,
        mu_k: f64,
        restitution: Option<f64>,
    ) -> Result<Self, ParamError> {
        positive("R", half_diagonal_m)?;
        if !(alpha_rad > 0.0 && alpha_rad < std::f64::consts::FRAC_PI_2) {
            return Err(ParamError::Alpha(alpha_rad));
        }
        let (s, c) = alpha_rad.sin_cos();
        Self::from_width_height(
            2.0 * half_diagonal_m * s,
            2.0 * half_diagonal_m * c,
            mu_s,
            mu_k,
            restitution,
        )
    }

    /// Squared angular velocity of free rocking that reaches an excursion of `fraction·α`
    /// from θ = 0 (energy: θ̇² = 2p²[cos(α − θ) − cos α] evaluated at θ = fraction·α).
    #[must_use]
    pub fn theta_dot_sq_for_excursion(&self, fraction: f64) -> f64 {
        let a = self.alpha_rad;
        // cos(a − x) − cos a = 2 sin(x/2) sin(a − x/2), without cancellation.
        let x = fraction * a;
        2.0 * self.p_rad_per_s.powi(2) * 2.0 * (0.5 * x).sin() * (a - 0.5 * x).sin()
    }
}

fn positive(name: &'static str, value: f64) -> Result<(), ParamError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ParamError::NotPositive { name, value })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_constants_of_a_unit_block() {
        let p = BlockParams::from_width_height(0.4, 2.0, 0.7, 0.5, None).unwrap();
        assert!((p.alpha_rad - (0.2f64).atan()).abs() < 1e-15);
        assert!((p.half_diagonal_m - 0.5 * (4.16f64).sqrt()).abs() < 1e-15);
        let eta = 1.0 - 1.5 * p.sin_alpha.powi(2);
        assert_eq!(p.impact_ratio, eta);
    }

    #[test]
    fn r_alpha_round_trips() {
        let p = BlockParams::from_r_alpha(1.12, 0.6, 0.1, 0.1, None).unwrap();
        assert!((p.half_diagonal_m - 1.12).abs() < 1e-12);
        assert!((p.alpha_rad - 0.6).abs() < 1e-12);
    }

    #[test]
    fn invalid_parameters_are_named() {
        let bad = |b, h, ms, mk, e| BlockParams::from_width_height(b, h, ms, mk, e).unwrap_err();
        assert!(bad(0.0, 1.0, 0.5, 0.4, None).to_string().contains("width"));
        assert!(bad(1.0, f64::NAN, 0.5, 0.4, None)
            .to_string()
            .contains("height"));
        assert_eq!(
            bad(1.0, 1.0, 0.5, 0.6, None),
            ParamError::KineticAboveStatic {
                mu_k: 0.6,
                mu_s: 0.5
            }
        );
        assert_eq!(bad(1.0, 1.0, 1.5, 1.4, None), ParamError::Painleve(1.4));
        assert_eq!(
            bad(1.0, 1.0, 0.5, 0.4, Some(1.2)),
            ParamError::Restitution(1.2)
        );
        assert!(BlockParams::from_r_alpha(1.0, 1.6, 0.5, 0.4, None).is_err());
    }

    #[test]
    fn excursion_energy_matches_direct_formula() {
        let p = BlockParams::from_width_height(0.5, 2.0, 0.7, 0.5, None).unwrap();
        let a = p.alpha_rad;
        let direct = 2.0 * p.p_rad_per_s.powi(2) * ((a - 0.3 * a).cos() - a.cos());
        assert!((p.theta_dot_sq_for_excursion(0.3) - direct).abs() < 1e-14);
    }
}
