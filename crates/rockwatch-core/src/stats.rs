//! Statistics shared by the study, the fragility fits, the hazard integral and the catalogue's
//! normal distributions: log-gamma, the regularized incomplete beta and gamma functions, and
//! from them the Student-t and standard normal distributions (Φ, φ, ln Φ), and the percentiles
//! of the project's intervals (type 7, and its weighted generalisation). One home for each.
//!
//! All are classic algorithms (Lanczos log-gamma; Lentz's continued fractions as in
//! Numerical Recipes, 3rd ed., §6.2 and §6.4), accurate to about 1e−14 relative in the
//! ranges the study uses (degrees of freedom 1 … 10⁶, |z| < 37).

use std::f64::consts::{LN_2, PI, SQRT_2};

/// Relative accuracy at which the continued fractions and series stop.
const EPS: f64 = 1e-16;
/// Smallest magnitude allowed in Lentz's algorithm (avoids division by zero).
const TINY: f64 = 1e-300;
/// Iteration cap of the continued fractions and series (convergence needs
/// O(√max(a, b)) terms; 10 000 covers parameters up to ~10⁷).
const MAX_ITER: usize = 10_000;

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, 9 terms; relative error < 2e−15).
/// Returns NaN for x ≤ 0 or NaN.
#[must_use]
#[allow(clippy::excessive_precision)]
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_93,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_13,
        -176.615_029_162_140_59,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_571_6e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x.is_nan() || x <= 0.0 {
        return f64::NAN;
    }
    if x < 0.5 {
        // Reflection: Γ(x)Γ(1 − x) = π / sin(πx).
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let z = x - 1.0;
    let mut sum = C[0];
    for (i, &c) in C.iter().enumerate().skip(1) {
        sum += c / (z + i as f64);
    }
    let t = z + G + 0.5;
    0.5 * (2.0 * PI).ln() + (z + 0.5) * t.ln() - t + sum.ln()
}

/// Continued fraction of the incomplete beta function (modified Lentz), NR Eq. 6.4.5.
fn beta_continued_fraction(a: f64, b: f64, x: f64) -> f64 {
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=MAX_ITER {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < EPS {
            break;
        }
    }
    h
}

/// The regularized incomplete beta function `I_x(a, b)` for `a, b > 0`, `0 ≤ x ≤ 1`.
/// Returns NaN outside that domain.
#[must_use]
pub fn regularized_incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    if !(a > 0.0 && b > 0.0 && (0.0..=1.0).contains(&x)) {
        return f64::NAN;
    }
    if x == 0.0 {
        return 0.0;
    }
    if x == 1.0 {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (-x).ln_1p();
    let front = ln_front.exp();
    // The continued fraction converges fast for x < (a + 1)/(a + b + 2); use the symmetry
    // I_x(a, b) = 1 − I_{1−x}(b, a) on the other side.
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_continued_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_continued_fraction(b, a, 1.0 - x) / b
    }
}

/// ln Q(a, x), the log of the regularized upper incomplete gamma function, for a > 0, x ≥ 0
/// (series for x < a + 1, continued fraction otherwise; NR §6.2).
fn ln_gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let ln_front = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^{−x} x^a / Γ(a) · Σ x^n / (a (a+1) … (a+n)).
        let mut ap = a;
        let mut term = 1.0 / a;
        let mut sum = term;
        for _ in 0..MAX_ITER {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * EPS {
                break;
            }
        }
        let p = (ln_front + sum.ln()).exp();
        (-p).ln_1p()
    } else {
        // Q(a, x) = e^{−x} x^a / Γ(a) · 1/(x + 1 − a − 1·(1 − a)/(x + 3 − a − …)).
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..=MAX_ITER {
            let i = i as f64;
            let an = -i * (i - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < EPS {
                break;
            }
        }
        ln_front + h.ln()
    }
}

/// ln Φ(z), the log of the standard normal CDF, accurate in both tails
/// (Φ(z) = ½·erfc(−z/√2) and erfc(y) = Q(½, y²) for y ≥ 0).
#[must_use]
pub fn ln_normal_cdf(z: f64) -> f64 {
    if z.is_nan() {
        return f64::NAN;
    }
    let y = -z / SQRT_2;
    if y >= 0.0 {
        // Lower tail: Φ(z) = ½ Q(½, y²).
        ln_gamma_q(0.5, y * y) - LN_2
    } else {
        // Upper half: Φ(z) = 1 − ½ Q(½, y²).
        let q = ln_gamma_q(0.5, y * y).exp();
        (-0.5 * q).ln_1p()
    }
}

/// Φ(z), the standard normal CDF, as ½·erfc(−z/√2) (erfc from `libm`, accurate to about one
/// ulp, also in the tails). Φ(−∞) = 0, Φ(∞) = 1. (For ln Φ far in the lower tail, where Φ
/// underflows, use [`ln_normal_cdf`].)
#[must_use]
pub fn normal_cdf(z: f64) -> f64 {
    0.5 * libm::erfc(-z / SQRT_2)
}

/// φ(z), the standard normal density.
#[must_use]
pub fn normal_pdf(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (2.0 * PI).sqrt()
}

/// The Student-t CDF P(T ≤ t) with `nu > 0` degrees of freedom (NaN for nu ≤ 0 or NaN t).
#[must_use]
pub fn student_t_cdf(t: f64, nu: f64) -> f64 {
    if nu.is_nan() || nu <= 0.0 || t.is_nan() {
        return f64::NAN;
    }
    if t.is_infinite() {
        return if t > 0.0 { 1.0 } else { 0.0 };
    }
    let tail = 0.5 * regularized_incomplete_beta(0.5 * nu, 0.5, nu / (nu + t * t));
    if t > 0.0 {
        1.0 - tail
    } else {
        tail
    }
}

/// Two-sided p-value `P(|T| ≥ |t|)` of a t statistic with `nu` degrees of freedom.
#[must_use]
pub fn student_t_two_sided_p(t: f64, nu: f64) -> f64 {
    if nu.is_nan() || nu <= 0.0 || t.is_nan() {
        return f64::NAN;
    }
    if t.is_infinite() {
        return 0.0;
    }
    regularized_incomplete_beta(0.5 * nu, 0.5, nu / (nu + t * t))
}

/// The probabilities of the project's two-sided 95 % percentile intervals (the fragility's
/// bootstrap intervals, the hazard's intervals on λ): the 2.5 and 97.5 % percentiles.
pub const INTERVAL_95: [f64; 2] = [0.025, 0.975];

/// The `q`-quantile (0 ≤ q ≤ 1) of values sorted in increasing order, by linear interpolation
/// between order statistics (Hyndman & Fan type 7, R's and NumPy's default): the value at
/// position (n − 1)·q, counting from 0. Panics on an empty slice.
#[must_use]
pub fn percentile_sorted(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// The `q`-quantile (0 ≤ q ≤ 1) of a discrete distribution given as `(value, weight)` pairs
/// (weights ≥ 0, not all 0; any order): the weighted generalisation of [`percentile_sorted`].
/// Sorted by value, point k (weight wₖ, cumulative weight Sₖ up to and including it, total W)
/// sits at the probability position pₖ = (Sₖ − wₖ/2 − w₁/2)/(W − w₁/2 − wₙ/2), so that the
/// first point is at 0 and the last at 1, and the quantile interpolates linearly between
/// positions. With equal weights pₖ = (k − 1)/(n − 1): exactly type 7. Zero-weight points are
/// left out. None without a point of positive weight.
#[must_use]
pub fn weighted_percentile(points: &[(f64, f64)], q: f64) -> Option<f64> {
    let mut v: Vec<(f64, f64)> = points.iter().copied().filter(|p| p.1 > 0.0).collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (first, last) = (v.first()?.1, v.last()?.1);
    if v.len() == 1 {
        return Some(v[0].0);
    }
    let total: f64 = v.iter().map(|p| p.1).sum();
    let span = total - 0.5 * first - 0.5 * last;
    let mut cumulative = 0.0;
    let mut previous: Option<(f64, f64)> = None;
    for &(x, w) in &v {
        cumulative += w;
        let position = (cumulative - 0.5 * w - 0.5 * first) / span;
        if position >= q {
            return Some(match previous {
                Some((p0, x0)) if position > p0 => x0 + (q - p0) / (position - p0) * (x - x0),
                _ => x,
            });
        }
        previous = Some((position, x));
    }
    v.last().map(|p| p.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_normal_cdf_matches_published_values() {
        // Φ(1) = 0.841344746068542948…, Φ(−1.959963984540054) = 0.025, Φ(−6) = 9.8658765e−10
        // (A&S table 26.1 / R pnorm); erfc is ~1 ulp, so 1e−15 relative is generous.
        assert!((normal_cdf(1.0) - 0.841_344_746_068_542_9).abs() < 1e-15);
        assert!((normal_cdf(-1.959_963_984_540_054) - 0.025).abs() < 1e-16);
        assert!((normal_cdf(-6.0) / 9.865_876_450_376_98e-10 - 1.0).abs() < 1e-12);
        assert_eq!(normal_cdf(f64::NEG_INFINITY), 0.0);
        assert_eq!(normal_cdf(f64::INFINITY), 1.0);
    }

    #[test]
    fn weighted_percentiles_are_type_7_with_equal_weights() {
        // Type 7 of 1..=5 (R: quantile(1:5, c(0.025, 0.3, 0.975)) = 1.1, 2.2, 4.9).
        let sorted = [1.0, 2.0, 3.0, 4.0, 5.0];
        let points: Vec<(f64, f64)> = [4.0, 2.0, 5.0, 1.0, 3.0].map(|x| (x, 0.7)).to_vec();
        for (q, expected) in [
            (0.025, 1.1),
            (0.3, 2.2),
            (0.975, 4.9),
            (0.0, 1.0),
            (1.0, 5.0),
        ] {
            assert!((percentile_sorted(&sorted, q) - expected).abs() < 1e-12);
            let w = weighted_percentile(&points, q).unwrap();
            assert!((w - expected).abs() < 1e-12, "{q}: {w}");
        }
        // Unequal weights: the first point at position 0, the last at 1, whatever their
        // weights; zero weights are left out.
        assert_eq!(
            weighted_percentile(&[(1.0, 1.0), (2.0, 2.0)], 0.5),
            Some(1.5)
        );
        assert_eq!(
            weighted_percentile(&[(7.0, 1.0), (2.0, 0.0)], 0.1),
            Some(7.0)
        );
        assert_eq!(weighted_percentile(&[(7.0, 0.0)], 0.1), None);
    }
}
