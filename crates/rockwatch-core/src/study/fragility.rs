//! Lognormal fragility curves fitted by maximum likelihood (probit regression on ln IM).
//!
//! Model: `P(overturn | IM = im) = Φ(a + b·ln im) = Φ(ln(im/θ)/β)`, with median `θ = e^{−a/b}`
//! (units of the IM) and logarithmic standard deviation `β = 1/b`. The parameters maximise the
//! Bernoulli log-likelihood `Σ yᵢ ln Φ(ηᵢ) + (1 − yᵢ) ln Φ(−ηᵢ)` by the project's one probit
//! fit ([`crate::fragility::fit::fit_lognormal_groups`], every case a group of one trial: the
//! binomial likelihood is then the Bernoulli one). Their covariance is the inverse of the
//! observed information (the negative Hessian at the optimum). Data that do not identify the
//! curve (no event, all events, perfect separation, a slope ≤ 0) are a [`FitError`].
//!
//! Confidence band: pointwise, by the delta method on the linear predictor
//! `η(im) = a + b·ln im`: `Var η = V_aa + 2 ln(im) V_ab + ln(im)² V_bb`, and the band is
//! `Φ(η ± z·√Var η)` (z = 1.96 for 95 %), which stays inside [0, 1].

use crate::fragility::fit::{fit_lognormal_groups, FitError};
use crate::ims::Im;
use crate::stats::normal_cdf;

/// z of a two-sided 95 % normal interval.
pub const Z_95: f64 = 1.959_963_984_540_054;

/// A fitted lognormal fragility curve, small enough to be evaluated by the live node.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LognormalFragility {
    /// The IM the curve is a function of, written as the study spells it (e.g.
    /// `"asi_1.0-2.5"`, [`Im::study_name`]).
    #[serde(with = "crate::ims::im::study_spelling")]
    pub im: Im,
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

/// Fits a lognormal fragility curve to `(im, event)` pairs by maximum likelihood (see the
/// module doc): the one probit fit of [`crate::fragility::fit`], every case a group of one
/// trial. `im` holds the values of IM `which` (its SI unit, [`Im::unit`]). Points with a
/// non-positive or non-finite IM are ignored.
pub fn fit_lognormal(
    which: Im,
    im: &[f64],
    event: &[bool],
) -> Result<LognormalFragility, FitError> {
    let (ln_im, events): (Vec<f64>, Vec<f64>) = im
        .iter()
        .zip(event)
        .filter(|(v, _)| v.is_finite() && **v > 0.0)
        .map(|(v, e)| (v.ln(), if *e { 1.0 } else { 0.0 }))
        .unzip();
    let trials = vec![1.0; ln_im.len()];
    let fit = fit_lognormal_groups(&ln_im, &trials, &events)?;
    let [a, b] = fit.coef;
    Ok(LognormalFragility {
        im: which,
        im_unit: which.unit().to_owned(),
        a,
        b,
        covariance: fit.covariance,
        median: fit.median,
        beta: fit.beta,
        n: ln_im.len(),
        n_events: events.iter().filter(|&&e| e > 0.0).count(),
        log_likelihood: fit.log_likelihood,
    })
}
