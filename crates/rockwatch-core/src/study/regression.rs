//! Least-squares regressions of the study: simple OLS `y = b0 + b1·x` with R² and the
//! t-test of the slope, the log–log variant, multiple regression (vector IMs), and the
//! residual-on-(Mw, R) sufficiency test of Luco & Cornell (2007).
//!
//! Conventions (stated in docs/im-study.md):
//! * R² = 1 − SS_res/SS_tot, which for a simple regression equals the squared Pearson
//!   correlation; it is in [0, 1] (clamped against rounding).
//! * A constant regressor (all x equal) explains nothing: R² = 0, slope 0, slope p-value
//!   undefined (NaN). A constant response (SS_tot = 0) makes R² undefined: the fit is `None`.
//! * Fewer than 2 points: `None`. The slope's p-value needs n ≥ 3 (n − 2 degrees of
//!   freedom); with n = 2 it is NaN.
//! * p-values are two-sided, from the Student-t distribution with n − 2 (simple) or
//!   n − k − 1 (k regressors) degrees of freedom.

use crate::stats::student_t_two_sided_p;
use nalgebra::{DMatrix, DVector};

/// An ordinary least-squares fit `y = intercept + slope·x` (units: those of y and y/x).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LinearFit {
    /// Number of points used.
    pub n: usize,
    /// Slope b1 (units of y per unit of x).
    pub slope: f64,
    /// Intercept b0 (units of y).
    pub intercept: f64,
    /// Coefficient of determination, in [0, 1].
    pub r2: f64,
    /// Standard error of the slope (NaN when n < 3 or x is constant).
    pub slope_se: f64,
    /// Two-sided p-value of H0: slope = 0 (NaN when n < 3 or x is constant).
    pub slope_p: f64,
}

impl LinearFit {
    /// Fitted value at `x`.
    #[must_use]
    pub fn predict(&self, x: f64) -> f64 {
        self.intercept + self.slope * x
    }
}

/// Arithmetic mean (NaN for an empty slice).
fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// OLS of `y` on `x` (same length; extra elements of the longer slice are ignored).
/// Returns `None` with fewer than 2 points, a non-finite value, or a constant `y`.
#[must_use]
pub fn linear_fit(x: &[f64], y: &[f64]) -> Option<LinearFit> {
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    if n < 2 || x.iter().chain(y).any(|v| !v.is_finite()) {
        return None;
    }
    // Two-pass centred sums: exact for data with a large common offset.
    let (mx, my) = (mean(x), mean(y));
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (&xi, &yi) in x.iter().zip(y) {
        let (dx, dy) = (xi - mx, yi - my);
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    if syy <= 0.0 {
        return None;
    }
    if sxx <= 0.0 {
        return Some(LinearFit {
            n,
            slope: 0.0,
            intercept: my,
            r2: 0.0,
            slope_se: f64::NAN,
            slope_p: f64::NAN,
        });
    }
    let slope = sxy / sxx;
    let r2 = ((sxy / sxx) * (sxy / syy)).clamp(0.0, 1.0);
    let (slope_se, slope_p) = if n >= 3 {
        let ss_res = (syy - slope * sxy).max(0.0);
        let dof = (n - 2) as f64;
        let se = (ss_res / dof / sxx).sqrt();
        let p = if se > 0.0 {
            student_t_two_sided_p(slope / se, dof)
        } else {
            0.0
        };
        (se, p)
    } else {
        (f64::NAN, f64::NAN)
    };
    Some(LinearFit {
        n,
        slope,
        intercept: my - slope * mx,
        r2,
        slope_se,
        slope_p,
    })
}

/// Keeps the points with `x > 0` and `y ≥ y_floor` (with `y_floor > 0`) and returns
/// `(ln x, ln y)`: the sample of a log–log regression over the responding cases.
#[must_use]
pub fn log_log_sample(x: &[f64], y: &[f64], y_floor: f64) -> (Vec<f64>, Vec<f64>) {
    x.iter()
        .zip(y)
        .filter(|&(&xi, &yi)| xi > 0.0 && yi >= y_floor && yi > 0.0 && xi.is_finite())
        .map(|(&xi, &yi)| (xi.ln(), yi.ln()))
        .unzip()
}

/// OLS of `ln y` on `ln x` over the points with `x > 0` and `y ≥ y_floor`.
#[must_use]
pub fn log_log_fit(x: &[f64], y: &[f64], y_floor: f64) -> Option<LinearFit> {
    let (lx, ly) = log_log_sample(x, y, y_floor);
    linear_fit(&lx, &ly)
}

/// Residuals `y − fit(x)`.
#[must_use]
pub fn residuals(fit: &LinearFit, x: &[f64], y: &[f64]) -> Vec<f64> {
    x.iter()
        .zip(y)
        .map(|(&xi, &yi)| yi - fit.predict(xi))
        .collect()
}

/// A multiple OLS fit `y = b0 + b1·x1 + … + bk·xk`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MultipleFit {
    /// Number of points used.
    pub n: usize,
    /// `[b0, b1, …, bk]` (intercept first), in the units of y per unit of each regressor.
    pub coefficients: Vec<f64>,
    /// Coefficient of determination, in [0, 1].
    pub r2: f64,
    /// Adjusted R² = 1 − (1 − R²)(n − 1)/(n − k − 1) (NaN when n ≤ k + 1).
    pub adjusted_r2: f64,
}

/// OLS of `y` on the regressors `columns` (each the length of `y`), solved by SVD of the
/// centred, unit-norm-scaled design (rank-deficient designs, e.g. two collinear IMs, get the
/// minimum-norm solution and still a correct R²). `None` with fewer than k + 1 points, a
/// non-finite value, mismatched lengths or a constant `y`.
#[must_use]
pub fn multiple_fit(columns: &[&[f64]], y: &[f64]) -> Option<MultipleFit> {
    let n = y.len();
    let k = columns.len();
    if n < k + 1 || columns.iter().any(|c| c.len() != n) {
        return None;
    }
    if y.iter()
        .chain(columns.iter().flat_map(|c| c.iter()))
        .any(|v| !v.is_finite())
    {
        return None;
    }
    let my = mean(y);
    let yc = DVector::from_iterator(n, y.iter().map(|v| v - my));
    let ss_tot = yc.norm_squared();
    if ss_tot <= 0.0 {
        return None;
    }
    let means: Vec<f64> = columns.iter().map(|c| mean(c)).collect();
    let mut design = DMatrix::zeros(n, k);
    let mut scales = vec![1.0; k];
    for (j, c) in columns.iter().enumerate() {
        for (i, &v) in c.iter().enumerate() {
            design[(i, j)] = v - means[j];
        }
        let norm = design.column(j).norm();
        if norm > 0.0 {
            scales[j] = norm;
            design.column_mut(j).scale_mut(1.0 / norm);
        }
    }
    let svd = design.clone().svd(true, true);
    let beta_scaled = svd.solve(&yc, 1e-12).ok()?;
    let fitted = &design * &beta_scaled;
    let ss_res = (&yc - fitted).norm_squared();
    let r2 = (1.0 - ss_res / ss_tot).clamp(0.0, 1.0);
    let mut coefficients = Vec::with_capacity(k + 1);
    let slopes: Vec<f64> = (0..k).map(|j| beta_scaled[j] / scales[j]).collect();
    coefficients.push(my - slopes.iter().zip(&means).map(|(b, m)| b * m).sum::<f64>());
    coefficients.extend(slopes);
    let adjusted_r2 = if n > k + 1 {
        1.0 - (1.0 - r2) * (n - 1) as f64 / (n - k - 1) as f64
    } else {
        f64::NAN
    };
    Some(MultipleFit {
        n,
        coefficients,
        r2,
        adjusted_r2,
    })
}

/// Sufficiency test of Luco & Cornell (2007): regress the residuals of a DM–IM fit on a
/// scenario variable (Mw, or R in km) and return the two-sided p-value of that slope. A small
/// p-value (e.g. < 0.05) means the residuals still depend on the variable: the IM is not
/// sufficient with respect to it. NaN when the test is undefined (n < 3, constant variable).
#[must_use]
pub fn residual_dependence_p(residuals: &[f64], variable: &[f64]) -> f64 {
    linear_fit(variable, residuals).map_or(f64::NAN, |f| f.slope_p)
}
