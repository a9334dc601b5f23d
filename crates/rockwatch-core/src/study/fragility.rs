//! Lognormal fragility curves fitted by maximum likelihood (probit regression on ln IM).
//!
//! Model: `P(overturn | IM = im) = Φ(a + b·ln im) = Φ(ln(im/θ)/β)`, with median `θ = e^{−a/b}`
//! (units of the IM) and logarithmic standard deviation `β = 1/b`. The parameters maximise the
//! Bernoulli log-likelihood `Σ yᵢ ln Φ(ηᵢ) + (1 − yᵢ) ln Φ(−ηᵢ)` (Newton's method with step
//! halving; the probit log-likelihood is concave). Their covariance is the inverse of the
//! observed information (the negative Hessian at the optimum).
//!
//! Confidence band: pointwise, by the delta method on the linear predictor
//! `η(im) = a + b·ln im`: `Var η = V_aa + 2 ln(im) V_ab + ln(im)² V_bb`, and the band is
//! `Φ(η ± z·√Var η)` (z = 1.96 for 95 %), which stays inside [0, 1].

use super::special::{ln_normal_cdf, normal_cdf, normal_pdf};

/// z of a two-sided 95 % normal interval.
pub const Z_95: f64 = 1.959_963_984_540_054;

/// Why a fragility curve could not be fitted.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FragilityError {
    /// Fewer than 2 usable points (IM > 0 and finite).
    #[error("fewer than 2 cases with a positive, finite IM")]
    TooFewPoints,
    /// No case has the event (e.g. no block overturned).
    #[error("no case reached the damage state: the curve is not identifiable")]
    NoEvents,
    /// Every case has the event.
    #[error("every case reached the damage state: the curve is not identifiable")]
    AllEvents,
    /// The events are perfectly separated by an IM threshold: the MLE of β is 0.
    #[error("the IM separates the cases perfectly (beta -> 0): no finite maximum-likelihood fit")]
    Separated,
    /// Newton's method did not converge.
    #[error("maximum-likelihood iteration did not converge")]
    NotConverged,
}

/// A fitted lognormal fragility curve, small enough to be evaluated by the live node.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LognormalFragility {
    /// Stable name of the IM the curve is a function of (e.g. `"asi_1.0-2.5"`).
    pub im: String,
    /// Unit of the IM (SI, e.g. `"m/s"`).
    pub im_unit: String,
    /// Probit intercept a (dimensionless).
    pub a: f64,
    /// Probit slope b (per unit ln IM).
    pub b: f64,
    /// Covariance `[[V_aa, V_ab], [V_ab, V_bb]]` of (a, b) from the observed information.
    pub covariance: [[f64; 2]; 2],
    /// Median θ = e^{−a/b} (IM units): the IM at which P = 0.5 (NaN if b ≤ 0).
    pub median: f64,
    /// Logarithmic standard deviation β = 1/b (NaN if b ≤ 0).
    pub beta: f64,
    /// Number of cases fitted.
    pub n: usize,
    /// Number of those cases with the event (e.g. overturned).
    pub n_events: usize,
    /// Maximised log-likelihood (natural log).
    pub log_likelihood: f64,
}

impl LognormalFragility {
    /// Linear predictor η = a + b·ln(im) (−∞ for im ≤ 0).
    #[must_use]
    pub fn eta(&self, im: f64) -> f64 {
        if im > 0.0 {
            self.a + self.b * im.ln()
        } else {
            f64::NEG_INFINITY
        }
    }

    /// Probability of the event given the IM value `im` (IM units); 0 for im ≤ 0.
    #[must_use]
    pub fn probability(&self, im: f64) -> f64 {
        if im > 0.0 {
            normal_cdf(self.eta(im))
        } else {
            0.0
        }
    }

    /// Pointwise confidence band `(lower, upper)` of the probability at `im`, `z` standard
    /// errors of η either side (z = [`Z_95`] for 95 %). `(0, 0)` for im ≤ 0.
    #[must_use]
    pub fn band(&self, im: f64, z: f64) -> (f64, f64) {
        if im <= 0.0 {
            return (0.0, 0.0);
        }
        let x = im.ln();
        let c = &self.covariance;
        let var = (c[0][0] + 2.0 * x * c[0][1] + x * x * c[1][1]).max(0.0);
        let eta = self.eta(im);
        let half = z * var.sqrt();
        (normal_cdf(eta - half), normal_cdf(eta + half))
    }
}

/// Log-likelihood, gradient and negative Hessian of the probit model at (a, b), x centred.
fn probit_terms(x: &[f64], y: &[bool], a: f64, b: f64) -> (f64, [f64; 2], [[f64; 2]; 2]) {
    let mut ll = 0.0;
    let mut g = [0.0; 2];
    let mut info = [[0.0; 2]; 2];
    for (&xi, &yi) in x.iter().zip(y) {
        let eta = a + b * xi;
        // s = +η for an event, −η otherwise: the contribution is ln Φ(s).
        let s = if yi { eta } else { -eta };
        let ln_cdf = ln_normal_cdf(s);
        ll += ln_cdf;
        // Inverse Mills ratio λ(s) = φ(s)/Φ(s), computed in logs for the far tail.
        let lambda = (normal_pdf(s).ln() - ln_cdf).exp();
        let score = if yi { lambda } else { -lambda };
        let h = lambda * (s + lambda);
        g[0] += score;
        g[1] += score * xi;
        info[0][0] += h;
        info[0][1] += h * xi;
        info[1][1] += h * xi * xi;
    }
    info[1][0] = info[0][1];
    (ll, g, info)
}

fn invert_2x2(m: &[[f64; 2]; 2]) -> Option<[[f64; 2]; 2]> {
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    if !(det.is_finite() && det > 0.0) {
        return None;
    }
    Some([
        [m[1][1] / det, -m[0][1] / det],
        [-m[1][0] / det, m[0][0] / det],
    ])
}

/// Fits a lognormal fragility curve to `(im, event)` pairs by maximum likelihood (see the
/// module doc). Points with a non-positive or non-finite IM are ignored.
pub fn fit_lognormal(
    im_name: &str,
    im_unit: &str,
    im: &[f64],
    event: &[bool],
) -> Result<LognormalFragility, FragilityError> {
    let (x, y): (Vec<f64>, Vec<bool>) = im
        .iter()
        .zip(event)
        .filter(|(v, _)| v.is_finite() && **v > 0.0)
        .map(|(v, e)| (v.ln(), *e))
        .unzip();
    let n = x.len();
    if n < 2 {
        return Err(FragilityError::TooFewPoints);
    }
    let n_events = y.iter().filter(|&&e| e).count();
    if n_events == 0 {
        return Err(FragilityError::NoEvents);
    }
    if n_events == n {
        return Err(FragilityError::AllEvents);
    }
    // Centre and scale x for conditioning: η = ac + bc·(x − m)/s.
    let m = x.iter().sum::<f64>() / n as f64;
    let s = (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n as f64).sqrt();
    if s.is_nan() || s <= 0.0 {
        // A constant IM cannot explain the events.
        return Err(FragilityError::Separated);
    }
    let xc: Vec<f64> = x.iter().map(|v| (v - m) / s).collect();
    // (Quasi-)complete separation: the events lie on one side of an IM threshold (ties
    // included), where the likelihood keeps growing as β → 0.
    let range = |event: bool| {
        x.iter()
            .zip(&y)
            .filter(|(_, e)| **e == event)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (v, _)| {
                (lo.min(*v), hi.max(*v))
            })
    };
    let ((ev_lo, ev_hi), (non_lo, non_hi)) = (range(true), range(false));
    if ev_lo >= non_hi || ev_hi <= non_lo {
        return Err(FragilityError::Separated);
    }

    let p0 = n_events as f64 / n as f64;
    let mut theta = [crate::lhs::standard_normal_quantile(p0), 0.0];
    let (mut ll, mut g, mut info) = probit_terms(&xc, &y, theta[0], theta[1]);
    let mut converged = false;
    for _ in 0..200 {
        let inv = invert_2x2(&info).ok_or(FragilityError::NotConverged)?;
        let step = [
            inv[0][0] * g[0] + inv[0][1] * g[1],
            inv[1][0] * g[0] + inv[1][1] * g[1],
        ];
        let mut t = 1.0;
        let mut accepted = false;
        for _ in 0..60 {
            let cand = [theta[0] + t * step[0], theta[1] + t * step[1]];
            let (ll_c, g_c, info_c) = probit_terms(&xc, &y, cand[0], cand[1]);
            if ll_c.is_finite() && ll_c >= ll - 1e-12 * ll.abs() {
                theta = cand;
                ll = ll_c;
                g = g_c;
                info = info_c;
                accepted = true;
                break;
            }
            t *= 0.5;
        }
        if !accepted {
            return Err(FragilityError::NotConverged);
        }
        if theta[1].abs() > 1e6 {
            return Err(FragilityError::Separated);
        }
        if (step[0] * t).abs() < 1e-12 && (step[1] * t).abs() < 1e-12 {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(FragilityError::NotConverged);
    }
    let cov_c = invert_2x2(&info).ok_or(FragilityError::NotConverged)?;
    // Back to the original scale: b = bc/s, a = ac − bc·m/s, i.e. (a, b) = J·(ac, bc) with
    // J = [[1, −m/s], [0, 1/s]]; Cov = J Cov_c Jᵀ.
    let j = [[1.0, -m / s], [0.0, 1.0 / s]];
    let a = theta[0] + j[0][1] * theta[1];
    let b = theta[1] / s;
    let mut cov = [[0.0; 2]; 2];
    for (r, row) in cov.iter_mut().enumerate() {
        for (c, cell) in row.iter_mut().enumerate() {
            let mut acc = 0.0;
            for k in 0..2 {
                for l in 0..2 {
                    acc += j[r][k] * cov_c[k][l] * j[c][l];
                }
            }
            *cell = acc;
        }
    }
    let (median, beta) = if b > 0.0 {
        ((-a / b).exp(), 1.0 / b)
    } else {
        (f64::NAN, f64::NAN)
    };
    Ok(LognormalFragility {
        im: im_name.to_string(),
        im_unit: im_unit.to_string(),
        a,
        b,
        covariance: cov,
        median,
        beta,
        n,
        n_events,
        log_likelihood: ll,
    })
}
