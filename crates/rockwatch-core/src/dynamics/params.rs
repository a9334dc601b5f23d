//! Body parameters: geometry, friction, impact restitution, validated at construction.
//!
//! The body is the general planar rigid body of docs/general-body.md: a flat base between two
//! pivots, the centre of mass at height `h` above the base and at horizontal distances `b₊`
//! from the +x pivot and `b₋` from the −x pivot, radius of gyration `ρ` about the centre of
//! mass. The rectangle of the spec (shared/spec/block-dynamics.md §1) is the case
//! b₊ = b₋ = B/2, h = H/2, ρ² = (B² + H²)/12.

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
        "kinetic friction mu_k = {mu_k} ≥ {bound:.6}: slide-rocking is ill-posed there \
         (Painlevé paradox; the bound is 2√(c(1+c)), c = ρ²/R², 4/3 for a rectangle)"
    )]
    Painleve { mu_k: f64, bound: f64 },
    #[error("restitution must be in [0, 1], got {0}")]
    Restitution(f64),
    #[error("slenderness alpha must be in (0, π/2) rad, got {0}")]
    Alpha(f64),
}

/// The constants of rotation about one pivot (σ = +1: the +x pivot, σ = −1: the −x pivot).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PivotSide {
    /// Horizontal distance b_σ from the centre of mass to this pivot (m).
    pub b_m: f64,
    /// Distance R_σ = √(b_σ² + h²) from this pivot to the centre of mass (m).
    pub half_diagonal_m: f64,
    /// Uplift angle α_σ = atan(b_σ/h) (rad): the rotation about this pivot that brings the
    /// centre of mass above it.
    pub alpha_rad: f64,
    pub sin_alpha: f64,
    pub cos_alpha: f64,
    /// tan α_σ = b_σ/h: static uplift threshold |ẍg|/g' of rocking on this pivot.
    pub tan_alpha: f64,
    /// c_σ = ρ²/R_σ² = I_c/(m R_σ²) (dimensionless); exactly 1/3 for a rectangle.
    pub inertia_ratio: f64,
    /// κ_σ = I_O,σ/(m R_σ²) = 1 + c_σ (dimensionless); exactly 4/3 for a rectangle.
    pub pivot_inertia_ratio: f64,
    /// 1/κ_σ = m R_σ²/I_O,σ (dimensionless), the factor of the rocking equation (R1):
    /// θ̈ = −(1/(κ_σ R_σ))[…]; exactly 3/4 for a rectangle.
    pub rocking_factor: f64,
    /// Frequency parameter p_σ = √(g m R_σ / I_O,σ) (rad/s).
    pub p_rad_per_s: f64,
}

impl PivotSide {
    /// I_O,σ/m = κ_σ R_σ² = ρ² + R_σ² (m²), moment of inertia about the pivot per unit mass.
    #[must_use]
    pub fn pivot_inertia_m2(&self) -> f64 {
        self.pivot_inertia_ratio * self.half_diagonal_m * self.half_diagonal_m
    }

    /// Squared angular velocity of free rocking about this pivot that reaches an excursion
    /// of `fraction·α_σ` from θ = 0 (energy: θ̇² = 2p_σ²[cos(α_σ − |θ|) − cos α_σ]).
    #[must_use]
    pub fn theta_dot_sq_for_excursion(&self, fraction: f64) -> f64 {
        let a = self.alpha_rad;
        // cos(a − x) − cos a = 2 sin(x/2) sin(a − x/2), without cancellation.
        let x = fraction * a;
        2.0 * self.p_rad_per_s.powi(2) * 2.0 * (0.5 * x).sin() * (a - 0.5 * x).sin()
    }
}

/// A planar rigid body with a flat base on a rigid ground with Coulomb friction.
///
/// Stores the primary parameters and the derived constants the dynamics use in every step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockParams {
    /// Horizontal distance b₊ from the centre of mass to the +x pivot (m).
    pub b_plus_m: f64,
    /// Horizontal distance b₋ from the centre of mass to the −x pivot (m).
    pub b_minus_m: f64,
    /// Height h of the centre of mass above the base (m).
    pub com_height_m: f64,
    /// Radius of gyration ρ about the centre of mass (m): I_c = m ρ².
    pub rho_m: f64,
    /// Static friction coefficient μs (dimensionless, > 0).
    pub mu_s: f64,
    /// Kinetic friction coefficient μk (0 ≤ μk ≤ μs, below the Painlevé bound).
    pub mu_k: f64,
    /// Restitution e of a pure-rocking impact, replacing the generalised Housner ratio when
    /// given: θ̇⁺ = e θ̇⁻ for a rectangle, kinetic-energy ratio e² for any body (see
    /// [`BlockParams::impact_ratio`]).
    pub restitution: Option<f64>,
    /// Gravity g (m/s²).
    pub gravity_mps2: f64,
    /// Rotation about the +x pivot (θ > 0).
    pub plus: PivotSide,
    /// Rotation about the −x pivot (θ < 0).
    pub minus: PivotSide,
    /// min(α₊, α₋) (rad): the smaller uplift angle; for the rectangle its slenderness α.
    pub alpha_rad: f64,
    /// Impact ratios θ̇⁺/θ̇⁻ of a sticking pure-rocking impact, `[+ → −, − → +]`
    /// (old pivot → new pivot). See [`BlockParams::impact_ratio`].
    pub impact_ratios: [f64; 2],
    /// The ratios q used in (I1) when the new pivot slips, `[+ → −, − → +]`: equal to
    /// `impact_ratios` except with a restitution on an asymmetric body, where they are capped
    /// so that a slipping impact cannot gain energy (see [`BlockParams::slip_impact_ratio`]).
    pub slip_impact_ratios: [f64; 2],
}

impl BlockParams {
    /// Builds a rectangular block from base width B and height H (m), under standard
    /// gravity: b₊ = b₋ = B/2, h = H/2, ρ² = (B² + H²)/12.
    pub fn from_width_height(
        width_m: f64,
        height_m: f64,
        mu_s: f64,
        mu_k: f64,
        restitution: Option<f64>,
    ) -> Result<Self, ParamError> {
        positive("width", width_m)?;
        positive("height", height_m)?;
        Self::from_body(
            0.5 * width_m,
            0.5 * width_m,
            0.5 * height_m,
            rectangle_rho(width_m, height_m),
            mu_s,
            mu_k,
            restitution,
        )
    }

    /// Builds a rectangular block from half-diagonal R (m) and slenderness α (rad).
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

    /// Builds a general planar body (docs/general-body.md) from b₊, b₋ (m, horizontal
    /// distances from the centre of mass to the +x and −x pivots), the height h of the centre
    /// of mass above the base (m) and the radius of gyration ρ about it (m), under standard
    /// gravity.
    pub fn from_body(
        b_plus_m: f64,
        b_minus_m: f64,
        com_height_m: f64,
        rho_m: f64,
        mu_s: f64,
        mu_k: f64,
        restitution: Option<f64>,
    ) -> Result<Self, ParamError> {
        positive("b_plus", b_plus_m)?;
        positive("b_minus", b_minus_m)?;
        positive("com_height", com_height_m)?;
        positive("rho", rho_m)?;
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
        if let Some(e) = restitution {
            if !(0.0..=1.0).contains(&e) {
                return Err(ParamError::Restitution(e));
            }
        }
        let g = STANDARD_GRAVITY_MPS2;
        let rho2 = rho_m * rho_m;
        // A body that is the rectangle to rounding (b₊ = b₋ and ρ² = R²/3 within a few ulps)
        // gets the rectangle's exact ratios (c = 1/3, κ = 4/3, 1/κ = 3/4, Housner's η), so
        // that it reproduces the rectangle's response bit for bit: rocking with impacts is
        // chaotic and would amplify a last-bit difference in the constants.
        let r2 = b_plus_m * b_plus_m + com_height_m * com_height_m;
        let rectangle = b_plus_m == b_minus_m && (3.0 * rho2 - r2).abs() <= 8.0 * f64::EPSILON * r2;
        let plus = pivot_side(b_plus_m, com_height_m, rho2, g, rectangle);
        let minus = pivot_side(b_minus_m, com_height_m, rho2, g, rectangle);
        // Slide-rock is well posed while ρ²/R² + sin²φ − μk sin φ cos φ > 0 for every φ:
        // min over φ of (c + sin²φ)/(sin φ cos φ) = 2√(c(1 + c)) (4/3 for c = 1/3).
        let bound = [plus, minus]
            .iter()
            .map(|s| 2.0 * (s.inertia_ratio * (1.0 + s.inertia_ratio)).sqrt())
            .fold(f64::INFINITY, f64::min);
        if mu_k >= bound {
            return Err(ParamError::Painleve { mu_k, bound });
        }
        let (impact_ratios, slip_impact_ratios) = if rectangle {
            // (ρ² + h² − b²)/(ρ² + R²) = 1 − 1.5 sin²α for ρ² = R²/3 (Housner).
            let eta = restitution.unwrap_or(1.0 - 1.5 * plus.sin_alpha * plus.sin_alpha);
            ([eta, eta], [eta, eta])
        } else {
            let to_minus = impact_ratio(&plus, &minus, rho2, com_height_m, restitution);
            let to_plus = impact_ratio(&minus, &plus, rho2, com_height_m, restitution);
            ([to_minus.0, to_plus.0], [to_minus.1, to_plus.1])
        };
        Ok(BlockParams {
            b_plus_m,
            b_minus_m,
            com_height_m,
            rho_m,
            mu_s,
            mu_k,
            restitution,
            gravity_mps2: g,
            plus,
            minus,
            alpha_rad: plus.alpha_rad.min(minus.alpha_rad),
            impact_ratios,
            slip_impact_ratios,
        })
    }

    /// The constants of the pivot σ (+1: the +x pivot, −1: the −x pivot).
    #[inline]
    #[must_use]
    pub fn side(&self, sigma: f64) -> &PivotSide {
        if sigma > 0.0 {
            &self.plus
        } else {
            &self.minus
        }
    }

    /// θ̇⁺/θ̇⁻ of a sticking impact of a purely rocking body that arrives on pivot
    /// `sigma_old` and continues on the other pivot: the generalised Housner ratio
    /// (ρ² + h² − b_old b_new)/(ρ² + R_new²) (angular momentum about the new pivot), or,
    /// with a `restitution` e, e·√(I_O,old/I_O,new) (kinetic energy ratio e²; exactly e for
    /// a rectangle). docs/general-body.md §7.
    #[inline]
    #[must_use]
    pub fn impact_ratio(&self, sigma_old: f64) -> f64 {
        self.impact_ratios[usize::from(sigma_old < 0.0)]
    }

    /// The ratio q of (I1) for an impact whose new pivot slips: [`BlockParams::impact_ratio`],
    /// except with a `restitution` e on a body whose pivots differ, where it is capped at
    /// (h² + e√((I_O,old − h²)(I_O,new − h²)))/I_O,new (per unit mass) so that a slipping
    /// impact cannot gain energy (docs/general-body.md §7).
    #[inline]
    #[must_use]
    pub fn slip_impact_ratio(&self, sigma_old: f64) -> f64 {
        self.slip_impact_ratios[usize::from(sigma_old < 0.0)]
    }

    /// Base width b₊ + b₋ (m).
    #[must_use]
    pub fn base_width_m(&self) -> f64 {
        self.b_plus_m + self.b_minus_m
    }

    /// True when the body is the rectangle B × H (b₊ = b₋ and ρ² = (B² + H²)/12 to a few
    /// ulps): its constants are then the rectangle's exact ratios.
    #[must_use]
    pub fn is_rectangle(&self) -> bool {
        self.plus.inertia_ratio == 1.0 / 3.0 && self.b_plus_m == self.b_minus_m
    }

    /// A one-line description of the geometry for titles and summaries:
    /// `B = … m, H = … m` for a rectangle, else `b+ = … m, b- = … m, h = … m, rho = … m`,
    /// followed by the uplift angles in degrees; the lengths (m) written by `number` and the
    /// angles (°) by `angle` (the shell rounds both to its text precision:
    /// `rockwatch::number_text`).
    #[must_use]
    pub fn geometry_label_with(
        &self,
        number: impl Fn(f64) -> String,
        angle: impl Fn(f64) -> String,
    ) -> String {
        let (ap, am) = (
            angle(self.plus.alpha_rad.to_degrees()),
            angle(self.minus.alpha_rad.to_degrees()),
        );
        if self.is_rectangle() {
            format!(
                "B = {} m, H = {} m, α = {ap}°",
                number(self.base_width_m()),
                number(2.0 * self.com_height_m)
            )
        } else {
            format!(
                "b+ = {} m, b- = {} m, h = {} m, rho = {} m, α+ = {ap}°, α- = {am}°",
                number(self.b_plus_m),
                number(self.b_minus_m),
                number(self.com_height_m),
                number(self.rho_m)
            )
        }
    }

    /// θ/α_σ on the side θ leans to (σ = sgn θ): 1 when the centre of mass is above the
    /// pivot; θ/α for a rectangle.
    #[inline]
    #[must_use]
    pub fn theta_over_alpha(&self, theta_rad: f64) -> f64 {
        theta_rad / self.side(theta_rad).alpha_rad
    }

    /// Squared angular velocity of free rocking that reaches an excursion of `fraction·α`
    /// about the weaker pivot (the smaller of the two per-side values; see
    /// [`PivotSide::theta_dot_sq_for_excursion`]).
    #[must_use]
    pub fn theta_dot_sq_for_excursion(&self, fraction: f64) -> f64 {
        self.plus
            .theta_dot_sq_for_excursion(fraction)
            .min(self.minus.theta_dot_sq_for_excursion(fraction))
    }
}

/// ρ = √((B² + H²)/12) (m), the radius of gyration of a B × H rectangle about its centroid.
#[must_use]
pub fn rectangle_rho(width_m: f64, height_m: f64) -> f64 {
    0.5 * width_m.hypot(height_m) / 3f64.sqrt()
}

fn pivot_side(b_m: f64, h_m: f64, rho2: f64, g: f64, rectangle: bool) -> PivotSide {
    let r = b_m.hypot(h_m);
    let alpha = b_m.atan2(h_m);
    let (sin_alpha, cos_alpha) = alpha.sin_cos();
    let (inertia_ratio, pivot_inertia_ratio, rocking_factor) = if rectangle {
        (1.0 / 3.0, 4.0 / 3.0, 0.75)
    } else {
        let c = rho2 / (r * r);
        (c, 1.0 + c, (r * r) / (rho2 + r * r))
    };
    PivotSide {
        b_m,
        half_diagonal_m: r,
        alpha_rad: alpha,
        sin_alpha,
        cos_alpha,
        tan_alpha: b_m / h_m,
        inertia_ratio,
        pivot_inertia_ratio,
        rocking_factor,
        // p² = g m R/I_O = g/(κ R).
        p_rad_per_s: (rocking_factor * g / r).sqrt(),
    }
}

/// θ̇⁺/θ̇⁻ of a sticking pure-rocking impact from pivot `old` to pivot `new`.
/// (stick, slip) ratios q of a pure-rocking impact from pivot `old` to pivot `new`.
fn impact_ratio(
    old: &PivotSide,
    new: &PivotSide,
    rho2: f64,
    h: f64,
    restitution: Option<f64>,
) -> (f64, f64) {
    let (j_old, j_new) = (old.pivot_inertia_m2(), new.pivot_inertia_m2());
    match restitution {
        // Energy ratio e² for a sticking pure-rocking impact. A slipping impact with the same
        // q could gain energy: with X = J_old − h², Y = J_new − h², a frictionless one has
        // the energy ratio (J_new q − h²)²/(XY), ≤ e² iff q ≤ (h² + e√(XY))/J_new
        // (docs/general-body.md §7); the slip branch uses q capped there. For a rectangle
        // (X = Y) the cap is ≥ e and never binds.
        Some(e) => {
            let stick = e * (j_old / j_new).sqrt();
            let cap = (h * h + e * ((j_old - h * h) * (j_new - h * h)).sqrt()) / j_new;
            (stick, stick.min(cap))
        }
        None => {
            let q = (rho2 + h * h - old.b_m * new.b_m) / (rho2 + new.half_diagonal_m.powi(2));
            (q, q)
        }
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
        for side in [p.plus, p.minus] {
            assert!((side.alpha_rad - (0.2f64).atan()).abs() < 1e-15);
            assert!((side.half_diagonal_m - 0.5 * (4.16f64).sqrt()).abs() < 1e-15);
            assert_eq!(side.rocking_factor, 0.75);
            assert_eq!(side.inertia_ratio, 1.0 / 3.0);
        }
        let eta = 1.0 - 1.5 * p.plus.sin_alpha.powi(2);
        assert!((p.impact_ratio(1.0) - eta).abs() < 1e-15);
        assert!((p.impact_ratio(-1.0) - eta).abs() < 1e-15);
        assert!(p.is_rectangle());
    }

    #[test]
    fn a_rectangle_given_as_a_body_is_the_rectangle_and_its_general_ratios_agree() {
        let (b, h) = (0.4, 2.0);
        let rect = BlockParams::from_width_height(b, h, 0.7, 0.5, None).unwrap();
        let body =
            BlockParams::from_body(0.2, 0.2, 1.0, rectangle_rho(b, h), 0.7, 0.5, None).unwrap();
        assert_eq!(rect, body);
        // The general formulas give the same ratios to rounding.
        let rho2 = rectangle_rho(b, h).powi(2);
        let r2 = rect.plus.half_diagonal_m.powi(2);
        assert!((rho2 / r2 - 1.0 / 3.0).abs() < 1e-15);
        let general_eta = (rho2 + 1.0 - 0.04) / (rho2 + r2);
        assert!((general_eta - rect.impact_ratio(1.0)).abs() < 1e-15);
        // A slightly different ρ is a general body.
        let other =
            BlockParams::from_body(0.2, 0.2, 1.0, 1.001 * rectangle_rho(b, h), 0.7, 0.5, None)
                .unwrap();
        assert!(!other.is_rectangle());
    }

    #[test]
    fn r_alpha_round_trips() {
        let p = BlockParams::from_r_alpha(1.12, 0.6, 0.1, 0.1, None).unwrap();
        assert!((p.plus.half_diagonal_m - 1.12).abs() < 1e-12);
        assert!((p.alpha_rad - 0.6).abs() < 1e-12);
    }

    #[test]
    fn asymmetric_body_has_its_own_sides_and_impact_ratios() {
        let p = BlockParams::from_body(0.2, 0.5, 1.0, 0.45, 0.8, 0.5, None).unwrap();
        assert!((p.plus.tan_alpha - 0.2).abs() < 1e-15);
        assert!((p.minus.tan_alpha - 0.5).abs() < 1e-15);
        assert_eq!(p.alpha_rad, p.plus.alpha_rad);
        assert!(!p.is_rectangle());
        // (ρ² + h² − b₊b₋)/(ρ² + R_new²).
        let rho2 = 0.45f64 * 0.45;
        for side in [p.plus, p.minus] {
            let r2 = side.half_diagonal_m.powi(2);
            assert!((side.inertia_ratio - rho2 / r2).abs() < 1e-15);
            assert!((side.rocking_factor - r2 / (rho2 + r2)).abs() < 1e-15);
        }
        let to_minus = (rho2 + 1.0 - 0.1) / (rho2 + 0.25 + 1.0);
        let to_plus = (rho2 + 1.0 - 0.1) / (rho2 + 0.04 + 1.0);
        assert!((p.impact_ratio(1.0) - to_minus).abs() < 1e-15);
        assert!((p.impact_ratio(-1.0) - to_plus).abs() < 1e-15);
        // Restitution e: kinetic-energy ratio e² whatever the pivots.
        let q = BlockParams::from_body(0.2, 0.5, 1.0, 0.45, 0.8, 0.5, Some(0.9)).unwrap();
        let e2 =
            q.impact_ratio(1.0).powi(2) * q.minus.pivot_inertia_m2() / q.plus.pivot_inertia_m2();
        assert!((e2 - 0.81).abs() < 1e-15);
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
        assert!(matches!(
            bad(1.0, 1.0, 1.5, 1.4, None),
            ParamError::Painleve { mu_k, bound } if mu_k == 1.4 && (bound - 4.0 / 3.0).abs() < 1e-12
        ));
        assert_eq!(
            bad(1.0, 1.0, 0.5, 0.4, Some(1.2)),
            ParamError::Restitution(1.2)
        );
        assert!(BlockParams::from_r_alpha(1.0, 1.6, 0.5, 0.4, None).is_err());
        let body = |bp, bm, h, rho| BlockParams::from_body(bp, bm, h, rho, 0.5, 0.4, None);
        assert!(body(-0.1, 0.2, 1.0, 0.3)
            .unwrap_err()
            .to_string()
            .contains("b_plus"));
        assert!(body(0.1, 0.2, 1.0, 0.0)
            .unwrap_err()
            .to_string()
            .contains("rho"));
    }

    #[test]
    fn excursion_energy_matches_direct_formula() {
        let p = BlockParams::from_width_height(0.5, 2.0, 0.7, 0.5, None).unwrap();
        let a = p.alpha_rad;
        let direct = 2.0 * p.plus.p_rad_per_s.powi(2) * ((a - 0.3 * a).cos() - a.cos());
        assert!((p.theta_dot_sq_for_excursion(0.3) - direct).abs() < 1e-14);
    }
}
