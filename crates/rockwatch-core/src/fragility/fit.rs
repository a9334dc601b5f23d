//! Maximum-likelihood probit fits of grouped binomial data: the lognormal fragility of one IM
//! and the two-IM fragility surface (docs/fragility.md §2–§4).
//!
//! Data are groups `g` with covariates `x_g` (natural logs of IMs), `n_g` trials and `k_g`
//! events (weights may be non-integer: a bootstrap replicate multiplies a record's counts by
//! the number of times it was drawn). The model is `P_g = Φ(c · [1, x_g])` and the
//! log-likelihood `Σ k_g ln Φ(η_g) + (n_g − k_g) ln Φ(−η_g)`: Baker's (2015) binomial
//! likelihood over stripes when the groups are stripes, the Bernoulli likelihood over runs
//! when every group is one run (the two differ by a constant, the binomial coefficients).
//! The probit log-likelihood is concave; it is maximised by Newton's method with step halving
//! on centred and scaled covariates. Perfect separation (the MLE at infinity, β → 0) is
//! detected and reported, never returned as a number.

// Small dense linear algebra (P ≤ 3) reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

use crate::lhs::standard_normal_quantile;
use crate::stats::{ln_normal_cdf, normal_pdf};

/// Why a fit has no finite maximum-likelihood estimate.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FitError {
    /// Fewer than 2 groups with a finite covariate and a positive number of trials.
    #[error("fewer than 2 usable groups")]
    TooFewGroups,
    /// No run reached the damage state.
    #[error("no run overturned: the fragility is not identifiable")]
    NoEvents,
    /// Every run reached the damage state.
    #[error("every run overturned: the fragility is not identifiable")]
    AllEvents,
    /// The covariates separate the events from the non-events perfectly (β → 0).
    #[error("the IM separates overturned from standing runs perfectly (beta -> 0): no finite maximum-likelihood fit")]
    Separated,
    /// The fitted probability decreases with the IM (slope ≤ 0).
    #[error("the fitted probability of overturning does not increase with the IM (slope <= 0)")]
    NotIncreasing,
    /// Newton's method did not converge.
    #[error("maximum-likelihood iteration did not converge")]
    NotConverged,
}

/// A fitted probit model `P = Φ(c₀ + c₁ x₁ + … )` with `P − 1` covariates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbitFit<const P: usize> {
    /// Coefficients (intercept first).
    pub coef: [f64; P],
    /// Covariance of the coefficients: inverse observed information at the optimum.
    pub covariance: [[f64; P]; P],
    /// Maximised log-likelihood (without the binomial coefficients).
    pub log_likelihood: f64,
    /// Total trials and events fitted.
    pub trials: f64,
    pub events: f64,
}

/// Log-likelihood, gradient and information (negative Hessian) at `c`; `z` rows are
/// `[1, x₁, …]` in the working (standardised) coordinates.
fn terms<const P: usize>(
    z: &[[f64; P]],
    n: &[f64],
    k: &[f64],
    c: &[f64; P],
) -> (f64, [f64; P], [[f64; P]; P]) {
    let mut ll = 0.0;
    let mut g = [0.0; P];
    let mut info = [[0.0; P]; P];
    for ((row, &ng), &kg) in z.iter().zip(n).zip(k) {
        let eta: f64 = row.iter().zip(c).map(|(a, b)| a * b).sum();
        // Events contribute ln Φ(η), non-events ln Φ(−η).
        let mut score = 0.0;
        let mut h = 0.0;
        for (s, w) in [(eta, kg), (-eta, ng - kg)] {
            if w <= 0.0 {
                continue;
            }
            let ln_cdf = ln_normal_cdf(s);
            ll += w * ln_cdf;
            // Inverse Mills ratio φ(s)/Φ(s), in logs for the far tail.
            let lambda = (normal_pdf(s).ln() - ln_cdf).exp();
            score += w * if s == eta { lambda } else { -lambda };
            h += w * lambda * (s + lambda);
        }
        for i in 0..P {
            g[i] += score * row[i];
            for j in 0..P {
                info[i][j] += h * row[i] * row[j];
            }
        }
    }
    (ll, g, info)
}

/// Solves `m x = b` for a symmetric positive-definite `m` (Cholesky); None if not SPD.
fn solve_spd<const P: usize>(m: &[[f64; P]; P], b: &[f64; P]) -> Option<[f64; P]> {
    let mut l = [[0.0; P]; P];
    for i in 0..P {
        for j in 0..=i {
            let mut s = m[i][j];
            for q in 0..j {
                s -= l[i][q] * l[j][q];
            }
            if i == j {
                if !(s.is_finite() && s > 0.0) {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    let mut y = [0.0; P];
    for i in 0..P {
        let mut s = b[i];
        for q in 0..i {
            s -= l[i][q] * y[q];
        }
        y[i] = s / l[i][i];
    }
    let mut x = [0.0; P];
    for i in (0..P).rev() {
        let mut s = y[i];
        for q in i + 1..P {
            s -= l[q][i] * x[q];
        }
        x[i] = s / l[i][i];
    }
    Some(x)
}

fn invert_spd<const P: usize>(m: &[[f64; P]; P]) -> Option<[[f64; P]; P]> {
    let mut inv = [[0.0; P]; P];
    for j in 0..P {
        let mut e = [0.0; P];
        e[j] = 1.0;
        let col = solve_spd(m, &e)?;
        for i in 0..P {
            inv[i][j] = col[i];
        }
    }
    Some(inv)
}

/// Why Newton's method stopped without a finite optimum, from where it stopped: a slope
/// steeper than 5 standardised units (β below a fifth of the covariate's spread) means it
/// was climbing towards a separating hyperplane ([`FitError::Separated`]); otherwise
/// [`FitError::NotConverged`]. Only consulted on failure: a converged fit may be steeper.
fn failure<const P: usize>(c: &[f64; P]) -> FitError {
    if c[1..].iter().any(|v| v.abs() > 5.0) {
        FitError::Separated
    } else {
        FitError::NotConverged
    }
}

/// Fits `P(event) = Φ(c₀ + Σ cᵢ xᵢ)` to groups `(x, trials, events)` by maximum likelihood.
/// `x[g]` holds the `P − 1` covariates of group g; groups with a non-finite covariate or no
/// trials are ignored. Events must lie in `[0, trials]`.
pub fn fit_probit<const P: usize>(
    x: &[[f64; P]],
    trials: &[f64],
    events: &[f64],
) -> Result<ProbitFit<P>, FitError> {
    // x rows are given as [_, x₁, …]: column 0 is ignored and set to 1 (intercept).
    let rows: Vec<([f64; P], f64, f64)> = x
        .iter()
        .zip(trials)
        .zip(events)
        .filter(|((r, &n), _)| n > 0.0 && r[1..].iter().all(|v| v.is_finite()))
        .map(|((r, &n), &k)| (*r, n, k.clamp(0.0, n)))
        .collect();
    if rows.len() < 2 {
        return Err(FitError::TooFewGroups);
    }
    let total_n: f64 = rows.iter().map(|r| r.1).sum();
    let total_k: f64 = rows.iter().map(|r| r.2).sum();
    if total_k <= 0.0 {
        return Err(FitError::NoEvents);
    }
    if total_k >= total_n {
        return Err(FitError::AllEvents);
    }
    // Standardise each covariate (trial-weighted mean and sd) for conditioning.
    let mut mean = [0.0; P];
    let mut sd = [1.0; P];
    for i in 1..P {
        mean[i] = rows.iter().map(|r| r.1 * r.0[i]).sum::<f64>() / total_n;
        let var = rows
            .iter()
            .map(|r| r.1 * (r.0[i] - mean[i]).powi(2))
            .sum::<f64>()
            / total_n;
        if var.is_nan() || var <= 0.0 {
            return Err(FitError::Separated);
        }
        sd[i] = var.sqrt();
    }
    let z: Vec<[f64; P]> = rows
        .iter()
        .map(|r| {
            let mut row = [1.0; P];
            for i in 1..P {
                row[i] = (r.0[i] - mean[i]) / sd[i];
            }
            row
        })
        .collect();
    let n: Vec<f64> = rows.iter().map(|r| r.1).collect();
    let k: Vec<f64> = rows.iter().map(|r| r.2).collect();

    let mut c = [0.0; P];
    c[0] = standard_normal_quantile(total_k / total_n);
    let (mut ll, mut g, mut info) = terms(&z, &n, &k, &c);
    let mut converged = false;
    for _ in 0..300 {
        let Some(step) = solve_spd(&info, &g) else {
            // A singular information matrix: every group but a few is predicted with
            // probability 0 or 1, the hallmark of (quasi-)separation when slopes are steep.
            return Err(failure(&c));
        };
        let mut t = 1.0;
        let mut accepted = false;
        for _ in 0..60 {
            let mut cand = c;
            for i in 0..P {
                cand[i] += t * step[i];
            }
            let (ll_c, g_c, info_c) = terms(&z, &n, &k, &cand);
            if ll_c.is_finite() && ll_c >= ll - 1e-12 * ll.abs() {
                c = cand;
                ll = ll_c;
                g = g_c;
                info = info_c;
                accepted = true;
                break;
            }
            t *= 0.5;
        }
        if !accepted {
            // No ascent left in floating point: at a finite optimum the step would have been
            // tiny; a steep standardised slope means the climb was towards separation.
            return Err(failure(&c));
        }
        // In standardised units a slope of 50 is a step over 1/50 of a standard deviation of
        // the covariate: the likelihood is climbing towards a separating hyperplane.
        if c[1..].iter().any(|v| v.abs() > 50.0) || c[0].abs() > 1e3 {
            return Err(FitError::Separated);
        }
        if step.iter().all(|s| (s * t).abs() < 1e-11) {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(failure(&c));
    }
    let cov_z = invert_spd(&info).ok_or(FitError::NotConverged)?;
    // Back to the original covariates: c_orig = J c with c₀ = c₀z − Σ cᵢz mᵢ/sᵢ, cᵢ = cᵢz/sᵢ.
    let mut j = [[0.0; P]; P];
    j[0][0] = 1.0;
    for i in 1..P {
        j[0][i] = -mean[i] / sd[i];
        j[i][i] = 1.0 / sd[i];
    }
    let mut coef = [0.0; P];
    for r in 0..P {
        coef[r] = (0..P).map(|q| j[r][q] * c[q]).sum();
    }
    let mut covariance = [[0.0; P]; P];
    for r in 0..P {
        for s in 0..P {
            let mut acc = 0.0;
            for a in 0..P {
                for b in 0..P {
                    acc += j[r][a] * cov_z[a][b] * j[s][b];
                }
            }
            covariance[r][s] = acc;
        }
    }
    Ok(ProbitFit {
        coef,
        covariance,
        log_likelihood: ll,
        trials: total_n,
        events: total_k,
    })
}

/// A lognormal fragility `P(overturn | im) = Φ(ln(im/θ)/β) = Φ(a + b ln im)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LognormalFit {
    /// Median θ = e^{−a/b} (units of the IM).
    pub median: f64,
    /// Logarithmic standard deviation β = 1/b.
    pub beta: f64,
    /// Maximised log-likelihood.
    pub log_likelihood: f64,
    /// The probit coefficients [a, b] (b per unit ln IM) and their covariance (inverse observed
    /// information).
    pub coef: [f64; 2],
    pub covariance: [[f64; 2]; 2],
}

/// Fits a lognormal fragility to groups `(ln im, trials, events)`. Besides the probit fit's
/// errors, a perfectly separated 1-D data set (every group with an event at or above every
/// group with a non-event) is reported as [`FitError::Separated`] before iterating.
pub fn fit_lognormal_groups(
    ln_im: &[f64],
    trials: &[f64],
    events: &[f64],
) -> Result<LognormalFit, FitError> {
    // Separation in one dimension: the events' lowest IM is at or above the non-events'
    // highest IM (ties included: the likelihood then still grows as β → 0).
    let (mut ev_lo, mut non_hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut ev_hi, mut non_lo) = (f64::NEG_INFINITY, f64::INFINITY);
    for ((&x, &n), &k) in ln_im.iter().zip(trials).zip(events) {
        if !(x.is_finite() && n > 0.0) {
            continue;
        }
        if k > 0.0 {
            ev_lo = ev_lo.min(x);
            ev_hi = ev_hi.max(x);
        }
        if k < n {
            non_hi = non_hi.max(x);
            non_lo = non_lo.min(x);
        }
    }
    // A mixed group alone (k and n − k at one IM, pure groups elsewhere) is separated too:
    // a step at that IM through P = k/n beats every finite β.
    if ev_lo.is_finite() && non_hi.is_finite() && (ev_lo >= non_hi || ev_hi <= non_lo) {
        return Err(FitError::Separated);
    }
    let x: Vec<[f64; 2]> = ln_im.iter().map(|&v| [1.0, v]).collect();
    let fit = fit_probit::<2>(&x, trials, events)?;
    let [a, b] = fit.coef;
    if b.is_nan() || b <= 0.0 {
        return Err(FitError::NotIncreasing);
    }
    Ok(LognormalFit {
        median: (-a / b).exp(),
        beta: 1.0 / b,
        log_likelihood: fit.log_likelihood,
        coef: fit.coef,
        covariance: fit.covariance,
    })
}

/// The two-IM fragility surface `P = Φ(c₀ + c₁ ln im₁ + c₂ ln im₂)`, also written
/// `Φ((ln im₁ − ln θ₁(im₂))/β₁)` with `β₁ = 1/c₁` and the median of im₁ a power law of im₂,
/// `θ₁(im₂) = exp(−c₀/c₁)·im₂^(−c₂/c₁)` (the form of Purvance et al. 2008 for PGA and PGV/PGA).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceFit {
    /// `[c₀, c₁, c₂]`.
    pub coef: [f64; 3],
    /// Covariance of the coefficients.
    pub covariance: [[f64; 3]; 3],
    pub log_likelihood: f64,
}

impl SurfaceFit {
    /// P(overturn) at `(im1, im2)` (0 when either is ≤ 0).
    #[must_use]
    pub fn probability(&self, im1: f64, im2: f64) -> f64 {
        if !(im1 > 0.0 && im2 > 0.0) {
            return 0.0;
        }
        let [c0, c1, c2] = self.coef;
        crate::stats::normal_cdf(c0 + c1 * im1.ln() + c2 * im2.ln())
    }

    /// β₁ = 1/c₁, the dispersion in ln im₁ at fixed im₂ (NaN if c₁ ≤ 0).
    #[must_use]
    pub fn beta1(&self) -> f64 {
        if self.coef[1] > 0.0 {
            1.0 / self.coef[1]
        } else {
            f64::NAN
        }
    }

    /// θ₁(im₂): the median of im₁ at a given im₂ (NaN if c₁ ≤ 0).
    #[must_use]
    pub fn median1_at(&self, im2: f64) -> f64 {
        let [c0, c1, c2] = self.coef;
        if c1 > 0.0 && im2 > 0.0 {
            (-(c0 + c2 * im2.ln()) / c1).exp()
        } else {
            f64::NAN
        }
    }
}

/// Fits the two-IM surface to groups `([ln im₁, ln im₂], trials, events)`.
pub fn fit_surface(
    ln_ims: &[[f64; 2]],
    trials: &[f64],
    events: &[f64],
) -> Result<SurfaceFit, FitError> {
    let x: Vec<[f64; 3]> = ln_ims.iter().map(|v| [1.0, v[0], v[1]]).collect();
    let fit = fit_probit::<3>(&x, trials, events)?;
    Ok(SurfaceFit {
        coef: fit.coef,
        covariance: fit.covariance,
        log_likelihood: fit.log_likelihood,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spd_solve_matches_a_known_system() {
        let m = [[4.0, 2.0, 0.6], [2.0, 5.0, 1.0], [0.6, 1.0, 3.0]];
        let x = [1.0, -2.0, 0.5];
        let b: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| m[i][j] * x[j]).sum());
        let got = solve_spd(&m, &b).unwrap();
        for i in 0..3 {
            assert!((got[i] - x[i]).abs() < 1e-12);
        }
        assert!(solve_spd(&[[1.0, 2.0], [2.0, 1.0]], &[1.0, 1.0]).is_none());
    }

    #[test]
    fn a_separated_surface_is_reported() {
        // Events exactly where x1 + x2 > 0, one mixed group on the line: no finite MLE.
        let (mut x, mut n, mut k) = (Vec::new(), Vec::new(), Vec::new());
        for a in -3..=3 {
            for b in -3..=3 {
                x.push([f64::from(a) * 0.3, f64::from(b) * 0.2]);
                n.push(2.0);
                k.push(match (a + b).cmp(&0) {
                    std::cmp::Ordering::Greater => 2.0,
                    std::cmp::Ordering::Less => 0.0,
                    std::cmp::Ordering::Equal => 1.0,
                });
            }
        }
        assert_eq!(fit_surface(&x, &n, &k), Err(FitError::Separated));
    }

    #[test]
    fn separated_stripes_are_reported() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let n = [10.0; 4];
        assert_eq!(
            fit_lognormal_groups(&x, &n, &[0.0, 0.0, 10.0, 10.0]),
            Err(FitError::Separated)
        );
        // A single mixed stripe between pure ones is still separated (a step through 0.5).
        assert_eq!(
            fit_lognormal_groups(&x, &n, &[0.0, 5.0, 10.0, 10.0]),
            Err(FitError::Separated)
        );
        // Overlap (events below non-events): a finite fit exists.
        assert!(fit_lognormal_groups(&x, &n, &[0.0, 3.0, 7.0, 10.0]).is_ok());
        assert_eq!(
            fit_lognormal_groups(&x, &n, &[0.0; 4]),
            Err(FitError::NoEvents)
        );
    }
}
