//! Tests of the intensity-measure study: special functions against closed forms and tables,
//! regressions against hand-computed values and a naive independent implementation, the
//! fragility fit against known parameters, and small end-to-end studies through the library
//! and the CLI (files, ranges, reproducibility).

use rockwatch_test_harness::rockwatch_bin;
use std::f64::consts::PI;
use std::path::Path;

use rockwatch::study::report;
use rockwatch_core::fragility::fit::FitError;
use rockwatch_core::ims::{Im, STUDY_IMS, STUDY_IM_COUNT};
use rockwatch_core::lhs::{rng_from_seed, uniform_open01};
use rockwatch_core::pulse::PulseParameters;
use rockwatch_core::stats::{
    ln_gamma, ln_normal_cdf, normal_cdf, regularized_incomplete_beta, student_t_cdf,
    student_t_two_sided_p,
};
use rockwatch_core::study::fragility::{fit_lognormal, Z_95};
use rockwatch_core::study::regression::{
    linear_fit, log_log_fit, multiple_fit, residual_dependence_p,
};
use rockwatch_core::study::{
    analyse, analyse_block, run_study, BlockResponse, DemandMeasure, PulseCase, ResponseStatus,
    StudyBlock, StudyConfig, StudyData,
};

// ---------------------------------------------------------------- special functions

#[test]
fn ln_gamma_matches_factorials_and_sqrt_pi() {
    // Γ(n) = (n − 1)!, Γ(½) = √π. Lanczos (g = 7) is accurate to ~1e−15 relative.
    let mut factorial = 1.0_f64;
    for n in 1..=20 {
        if n > 1 {
            factorial *= (n - 1) as f64;
        }
        let expected = factorial.ln();
        assert!(
            (ln_gamma(n as f64) - expected).abs() <= 1e-13 * expected.abs().max(1.0),
            "n = {n}"
        );
    }
    assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-14);
    assert!(ln_gamma(0.0).is_nan() && ln_gamma(-1.0).is_nan());
}

#[test]
fn incomplete_beta_matches_closed_forms() {
    // I_x(a, 1) = x^a, I_x(1, b) = 1 − (1 − x)^b, I_x(2, 2) = 3x² − 2x³ (exact identities).
    for &x in &[1e-6, 0.01, 0.2, 0.5, 0.77, 0.999] {
        for &a in &[0.5, 1.0, 2.5, 7.0, 40.0] {
            let got = regularized_incomplete_beta(a, 1.0, x);
            assert!((got - x.powf(a)).abs() < 1e-13, "a = {a}, x = {x}: {got}");
            let got = regularized_incomplete_beta(1.0, a, x);
            let expected = 1.0 - (1.0 - x).powf(a);
            assert!((got - expected).abs() < 1e-13, "b = {a}, x = {x}: {got}");
        }
        let got = regularized_incomplete_beta(2.0, 2.0, x);
        assert!((got - (3.0 * x * x - 2.0 * x * x * x)).abs() < 1e-14);
    }
    assert_eq!(regularized_incomplete_beta(3.0, 4.0, 0.0), 0.0);
    assert_eq!(regularized_incomplete_beta(3.0, 4.0, 1.0), 1.0);
    assert!(regularized_incomplete_beta(-1.0, 4.0, 0.5).is_nan());
}

#[test]
fn student_t_cdf_matches_closed_forms_for_one_two_and_three_dof() {
    // ν = 1 (Cauchy): F = ½ + atan(t)/π. ν = 2: F = ½ + t/(2√(2 + t²)).
    // ν = 3: F = ½ + [t/√3/(1 + t²/3) + atan(t/√3)]/π.
    for &t in &[-50.0, -3.0, -1.0, -0.1, 0.0, 0.4, 1.0, 2.5, 10.0, 300.0] {
        let cauchy = 0.5 + f64::atan(t) / PI;
        assert!((student_t_cdf(t, 1.0) - cauchy).abs() < 1e-14, "t = {t}");
        let two = 0.5 + t / (2.0 * (2.0 + t * t).sqrt());
        assert!((student_t_cdf(t, 2.0) - two).abs() < 1e-14, "t = {t}");
        let u = t / 3f64.sqrt();
        let three = 0.5 + (u / (1.0 + u * u) + u.atan()) / PI;
        assert!((student_t_cdf(t, 3.0) - three).abs() < 1e-14, "t = {t}");
    }
}

#[test]
fn student_t_quantiles_from_tables_give_their_probabilities() {
    // Critical values (Abramowitz & Stegun Table 26.10 / any t table, 9+ digits):
    // t(0.975; 10) = 2.228138852, t(0.995; 30) = 2.749995654, t(0.95; 120) = 1.657650899.
    let cases = [
        (2.228_138_852, 10.0, 0.975),
        (2.749_995_654, 30.0, 0.995),
        (1.657_650_899, 120.0, 0.95),
    ];
    for (t, nu, p) in cases {
        // 1e−9: the tabulated quantiles have 10 significant digits.
        assert!((student_t_cdf(t, nu) - p).abs() < 1e-9, "nu = {nu}");
        assert!((student_t_two_sided_p(t, nu) - 2.0 * (1.0 - p)).abs() < 2e-9);
    }
    // Large ν tends to the normal: P(|Z| > 1.96) = 0.0499958 (ν = 1e6 differs by ~1e−7).
    assert!((student_t_two_sided_p(1.959_963_984_540_054, 1e6) - 0.05).abs() < 1e-6);
}

#[test]
fn normal_cdf_matches_published_values_in_both_tails() {
    // Φ(−1) = 0.15865525393145705, Φ(1.96) = 0.9750021048517795 (erfc tables);
    // Φ(−30) = 4.906713927148187e−198 (asymptotic series, 16 digits).
    assert!((normal_cdf(-1.0) - 0.158_655_253_931_457_05).abs() < 1e-15);
    assert!((normal_cdf(1.96) - 0.975_002_104_851_779_5).abs() < 1e-15);
    let ln_phi = ln_normal_cdf(-30.0);
    assert!((ln_phi - 4.906_713_927_148_187e-198_f64.ln()).abs() < 1e-12);
    assert!((normal_cdf(0.0) - 0.5).abs() < 1e-16);
}

// ---------------------------------------------------------------- regressions

#[test]
fn linear_fit_of_five_points_matches_hand_computation() {
    // x̄ = 3, ȳ = 4, Sxx = 10, Sxy = 6, Syy = 6: slope 0.6, intercept 2.2, R² = 36/60 = 0.6,
    // SS_res = 6 − 0.6·6 = 2.4, se = √(2.4/3/10) = √0.08, t = 0.6/√0.08 = 2.1213203…
    let x = [1.0, 2.0, 3.0, 4.0, 5.0];
    let y = [2.0, 4.0, 5.0, 4.0, 5.0];
    let fit = linear_fit(&x, &y).unwrap();
    assert_eq!(fit.n, 5);
    assert!((fit.slope - 0.6).abs() < 1e-15);
    assert!((fit.intercept - 2.2).abs() < 1e-14);
    assert!((fit.r2 - 0.6).abs() < 1e-15);
    assert!((fit.slope_se - 0.08f64.sqrt()).abs() < 1e-15);
    // Two-sided p with 3 dof from the closed-form ν = 3 CDF.
    let t = 0.6 / 0.08f64.sqrt();
    let u = t / 3f64.sqrt();
    let p = 2.0 * (1.0 - (0.5 + (u / (1.0 + u * u) + u.atan()) / PI));
    assert!((fit.slope_p - p).abs() < 1e-13, "{} vs {p}", fit.slope_p);
    assert!((p - 0.124_0).abs() < 1e-3); // sanity: ≈ 0.124
}

#[test]
fn dm_itself_scores_one_and_a_constant_im_scores_zero() {
    let dm = [0.0, 0.01, 0.3, 0.02, 0.15, 0.0, 0.07];
    assert_eq!(linear_fit(&dm, &dm).unwrap().r2, 1.0);
    let scaled: Vec<f64> = dm.iter().map(|v| 3.0 * v + 1.0).collect();
    assert!((linear_fit(&scaled, &dm).unwrap().r2 - 1.0).abs() < 1e-15);
    let constant = [4.2; 7];
    let fit = linear_fit(&constant, &dm).unwrap();
    assert_eq!(fit.r2, 0.0);
    assert_eq!(fit.slope, 0.0);
    // A constant DM leaves R² undefined; fewer than 2 points too.
    assert!(linear_fit(&dm, &[1.0; 7]).is_none());
    assert!(linear_fit(&[1.0], &[2.0]).is_none());
}

#[test]
fn r2_is_in_unit_interval_and_equals_squared_correlation() {
    // Independent naive computation: Pearson r from raw sums.
    let mut rng = rng_from_seed(7);
    for _ in 0..50 {
        let n = 3 + (uniform_open01(&mut rng) * 30.0) as usize;
        let x: Vec<f64> = (0..n).map(|_| uniform_open01(&mut rng) * 10.0).collect();
        let y: Vec<f64> = x
            .iter()
            .map(|v| 0.3 * v + 2.0 * uniform_open01(&mut rng))
            .collect();
        let fit = linear_fit(&x, &y).unwrap();
        assert!((0.0..=1.0).contains(&fit.r2));
        let nf = n as f64;
        let (sx, sy) = (x.iter().sum::<f64>(), y.iter().sum::<f64>());
        let sxy: f64 = x.iter().zip(&y).map(|(a, b)| a * b).sum();
        let sxx: f64 = x.iter().map(|a| a * a).sum();
        let syy: f64 = y.iter().map(|b| b * b).sum();
        let r = (nf * sxy - sx * sy) / ((nf * sxx - sx * sx) * (nf * syy - sy * sy)).sqrt();
        // 1e−10: the raw-sum formula loses a few digits to cancellation.
        assert!((fit.r2 - r * r).abs() < 1e-10);
    }
}

#[test]
fn log_log_fit_recovers_a_power_law_and_skips_non_responding_cases() {
    // y = 0.2·x^1.5 exactly, plus points below the floor and x = 0 that must be ignored.
    let mut x: Vec<f64> = (1..=20).map(|k| k as f64 * 0.1).collect();
    let mut y: Vec<f64> = x.iter().map(|v| 0.2 * v.powf(1.5)).collect();
    x.extend([0.5, 0.0, 3.0]);
    y.extend([0.0, 0.3, 1e-9]);
    let fit = log_log_fit(&x, &y, 1e-6).unwrap();
    assert_eq!(fit.n, 20);
    assert!((fit.slope - 1.5).abs() < 1e-12);
    assert!((fit.intercept - 0.2f64.ln()).abs() < 1e-12);
    assert!((fit.r2 - 1.0).abs() < 1e-12);
}

/// Solves the 3×3 system `m·b = r` by Cramer's rule (independent of the SVD solver).
fn cramer3(m: [[f64; 3]; 3], r: [f64; 3]) -> [f64; 3] {
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det(m);
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let mut mk = m;
        for i in 0..3 {
            mk[i][k] = r[i];
        }
        *o = det(mk) / d;
    }
    out
}

#[test]
fn multiple_fit_matches_normal_equations_and_exact_planes() {
    let mut rng = rng_from_seed(11);
    let n = 40;
    let x1: Vec<f64> = (0..n).map(|_| uniform_open01(&mut rng) * 4.0).collect();
    let x2: Vec<f64> = (0..n)
        .map(|_| uniform_open01(&mut rng) * 2.0 - 1.0)
        .collect();
    // Exact plane: R² = 1 and the coefficients come back.
    let exact: Vec<f64> = x1
        .iter()
        .zip(&x2)
        .map(|(a, b)| 1.0 + 2.0 * a - 3.0 * b)
        .collect();
    let fit = multiple_fit(&[&x1, &x2], &exact).unwrap();
    for (got, want) in fit.coefficients.iter().zip([1.0, 2.0, -3.0]) {
        assert!((got - want).abs() < 1e-12);
    }
    assert!((fit.r2 - 1.0).abs() < 1e-12);
    // Noisy data: coefficients and R² equal the normal-equation solution.
    let y: Vec<f64> = exact
        .iter()
        .map(|v| v + 2.0 * (uniform_open01(&mut rng) - 0.5))
        .collect();
    let cols = [vec![1.0; n], x1.clone(), x2.clone()];
    let mut m = [[0.0; 3]; 3];
    let mut r = [0.0; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..n).map(|k| cols[i][k] * cols[j][k]).sum();
        }
        r[i] = (0..n).map(|k| cols[i][k] * y[k]).sum();
    }
    let b = cramer3(m, r);
    let fit = multiple_fit(&[&x1, &x2], &y).unwrap();
    for (got, want) in fit.coefficients.iter().zip(b) {
        assert!((got - want).abs() < 1e-10, "{got} vs {want}");
    }
    let ybar = y.iter().sum::<f64>() / n as f64;
    let ss_tot: f64 = y.iter().map(|v| (v - ybar).powi(2)).sum();
    let ss_res: f64 = (0..n)
        .map(|k| (y[k] - b[0] - b[1] * x1[k] - b[2] * x2[k]).powi(2))
        .sum();
    assert!((fit.r2 - (1.0 - ss_res / ss_tot)).abs() < 1e-12);
    let adj = 1.0 - (1.0 - fit.r2) * (n - 1) as f64 / (n - 3) as f64;
    assert!((fit.adjusted_r2 - adj).abs() < 1e-15);
    // Two identical regressors (rank 1): still the R² of the single regressor.
    let twice = multiple_fit(&[&x1, &x1], &y).unwrap();
    assert!((twice.r2 - linear_fit(&x1, &y).unwrap().r2).abs() < 1e-10);
}

#[test]
fn residual_dependence_detects_a_trend_in_magnitude() {
    // Residuals growing with Mw are flagged (p ≈ 0); residuals alternating in sign with no
    // trend in Mw are not (slope exactly 0 by symmetry: p = 1).
    let mw = [6.5, 6.5, 7.0, 7.0, 7.5, 7.5, 8.0, 8.0];
    let trend: Vec<f64> = mw
        .iter()
        .enumerate()
        .map(|(k, m)| m - 7.25 + 0.01 * (k % 2) as f64)
        .collect();
    assert!(residual_dependence_p(&trend, &mw) < 1e-6);
    let none = [0.1, -0.1, 0.1, -0.1, 0.1, -0.1, 0.1, -0.1];
    assert!((residual_dependence_p(&none, &mw) - 1.0).abs() < 1e-12);
}

// ---------------------------------------------------------------- fragility

/// Synthetic overturning data from a known lognormal curve (θ in IM units, β).
fn synthetic_fragility(theta: f64, beta: f64, n: usize, seed: u64) -> (Vec<f64>, Vec<bool>) {
    let mut rng = rng_from_seed(seed);
    let mut im = Vec::with_capacity(n);
    let mut event = Vec::with_capacity(n);
    for _ in 0..n {
        // IM log-uniform over θ·[e^−3β, e^3β].
        let x = theta * (beta * (6.0 * uniform_open01(&mut rng) - 3.0)).exp();
        let p = normal_cdf((x / theta).ln() / beta);
        im.push(x);
        event.push(uniform_open01(&mut rng) < p);
    }
    (im, event)
}

#[test]
fn fragility_fit_recovers_known_median_and_beta() {
    let (theta, beta) = (0.8, 0.35);
    let (im, event) = synthetic_fragility(theta, beta, 20_000, 3);
    let fit = fit_lognormal(STUDY_IMS[21], &im, &event).unwrap();
    // Standard errors from the observed information; the estimates must lie within 4 of
    // them (a 4σ band: a false failure has probability ~6e−5), and they must be small.
    let se_b = fit.covariance[1][1].sqrt();
    let b_true = 1.0 / beta;
    assert!(
        (fit.b - b_true).abs() < 4.0 * se_b,
        "b = {} ± {se_b}",
        fit.b
    );
    assert!(se_b < 0.05 * b_true);
    assert!(
        (fit.median / theta - 1.0).abs() < 0.02,
        "median {}",
        fit.median
    );
    assert!((fit.beta / beta - 1.0).abs() < 0.05, "beta {}", fit.beta);
    assert_eq!(fit.n, 20_000);
    // The curve is 0.5 at the median, and the band brackets the curve.
    assert!((fit.probability(fit.median) - 0.5).abs() < 1e-12);
    for x in [0.3, 0.8, 1.5] {
        let (lo, hi) = fit.band(x, Z_95);
        let p = fit.probability(x);
        assert!(lo < p && p < hi && hi - lo < 0.05, "x = {x}: {lo} {p} {hi}");
    }
}

#[test]
fn fragility_fit_standard_errors_match_the_spread_of_repeated_fits() {
    // Independent check of the observed-information covariance: the spread of b over 40
    // independent data sets matches its predicted standard error within 35 % (the sampling
    // error of an SD from 40 values is ~11 %; 35 % is a 3σ bound).
    let mut bs = Vec::new();
    let mut predicted = 0.0;
    for seed in 0..40 {
        let (im, event) = synthetic_fragility(2.0, 0.5, 400, 100 + seed);
        let fit = fit_lognormal(Im::Pga, &im, &event).unwrap();
        predicted += fit.covariance[1][1].sqrt() / 40.0;
        bs.push(fit.b);
    }
    let mean = bs.iter().sum::<f64>() / bs.len() as f64;
    let sd = (bs.iter().map(|b| (b - mean).powi(2)).sum::<f64>() / (bs.len() - 1) as f64).sqrt();
    assert!(
        (sd / predicted - 1.0).abs() < 0.35,
        "sd {sd} predicted {predicted}"
    );
}

#[test]
fn fragility_fit_reports_unidentifiable_data() {
    let im = [0.1, 0.2, 0.3, 0.4];
    assert_eq!(
        fit_lognormal(Im::Pga, &im, &[false; 4]),
        Err(FitError::NoEvents)
    );
    assert_eq!(
        fit_lognormal(Im::Pga, &im, &[true; 4]),
        Err(FitError::AllEvents)
    );
    assert_eq!(
        fit_lognormal(Im::Pga, &im, &[false, false, true, true]),
        Err(FitError::Separated)
    );
    assert_eq!(
        fit_lognormal(Im::Pga, &[0.0, -1.0, 0.5], &[true, false, true]),
        Err(FitError::TooFewGroups)
    );
}

// ---------------------------------------------------------------- block specs

#[test]
fn block_spec_parses_and_rejects_bad_input() {
    let b = StudyBlock::parse_spec("sr:r=1.5,alpha-deg=10,mu-s=0.2,mu-k=0.19").unwrap();
    assert_eq!(b.name, "sr");
    assert!((b.params.plus.half_diagonal_m - 1.5).abs() < 1e-12);
    assert!((b.params.alpha_rad - 10f64.to_radians()).abs() < 1e-12);
    // μs = 0.2 > tan 10° = 0.176: the block rocks before it slides, so the DM is θ.
    assert_eq!(b.dm, DemandMeasure::Theta);
    let s = StudyBlock::parse_spec("wide:width=2,height=1,mu-s=0.3").unwrap();
    assert_eq!(s.dm, DemandMeasure::Slide);
    assert_eq!(s.params.mu_k, 0.3);
    for bad in [
        "noname",
        ":r=1,alpha=0.2,mu-s=1",
        "x:r=1,mu-s=1",
        "x:r=1,alpha=0.2",
        "x:r=1,alpha=0.2,mu-s=abc",
        "x:r=1,alpha=0.2,mu-s=1,color=red",
        "x:r=1,alpha=0.2,mu-s=0.5,mu-k=0.9",
        "x:r=1,alpha=0.2,mu-s=1,dm=tilt",
    ] {
        assert!(StudyBlock::parse_spec(bad).is_err(), "{bad}");
    }
}

// ---------------------------------------------------------------- studies

fn small_config(pulses_per_pair: usize) -> StudyConfig {
    let mut config = StudyConfig::seed_default().unwrap();
    config.magnitudes = vec![6.5, 7.0];
    config.distances_km = vec![5.0, 10.0];
    config.pulses_per_pair = pulses_per_pair;
    config
        .blocks
        .push(StudyBlock::parse_spec("slender:r=0.6,alpha-deg=8,mu-s=1.0,mu-k=0.8").unwrap());
    config
}

#[test]
fn seed_blocks_have_the_papers_parameters() {
    let config = StudyConfig::seed_default().unwrap();
    assert_eq!(config.pairs().len(), 15);
    assert_eq!(config.pulses_per_pair, 250);
    let s = &config.blocks[0];
    assert_eq!((s.name.as_str(), s.dm), ("sliding", DemandMeasure::Slide));
    assert!((s.params.alpha_rad.to_degrees() - 45.0).abs() < 1e-12);
    assert_eq!((s.params.mu_s, s.params.mu_k), (0.1, 0.1));
    assert!((s.params.plus.half_diagonal_m - 1.12).abs() < 1e-12);
    let r = &config.blocks[1];
    assert_eq!((r.name.as_str(), r.dm), ("rocking", DemandMeasure::Theta));
    assert!((r.params.alpha_rad.to_degrees() - 11.31).abs() < 1e-12);
    assert_eq!((r.params.mu_s, r.params.mu_k), (1.5, 1.0));
    assert!((r.params.plus.half_diagonal_m - 3.29).abs() < 1e-12);
}

#[test]
fn small_study_is_identical_on_one_and_two_threads() {
    let config = small_config(3);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let data = run_study(&config, &|| {}).unwrap();
            let analysis = analyse(&config, &data);
            (
                report::results_csv(&config, &data, &analysis),
                report::efficiency_csv(&data, &analysis),
            )
        })
    };
    let one = run(1);
    let two = run(2);
    assert!(one == two, "results differ between 1 and 2 threads");
}

#[test]
fn small_study_counts_progress_and_scores_every_im() {
    let config = small_config(3);
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let data = run_study(&config, &|| {
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    })
    .unwrap();
    assert_eq!(calls.into_inner(), 12);
    assert_eq!(data.cases.len(), 12);
    assert_eq!(data.responses.len(), 12);
    let ids: Vec<usize> = data.cases.iter().map(|c| c.id).collect();
    assert_eq!(ids, (1..=12).collect::<Vec<_>>());
    let analysis = analyse(&config, &data);
    for block in &analysis.blocks {
        assert_eq!(block.ranking.len(), STUDY_IM_COUNT);
        assert_eq!(block.counts.used() + block.counts.excluded(), 12);
        for s in &block.ranking {
            let r2 = s.r2();
            assert!(
                r2.is_nan() || (0.0..=1.0).contains(&r2),
                "{}: {r2}",
                s.name()
            );
        }
    }
}

/// A synthetic study (no simulation): DM values and IMs chosen by hand.
fn synthetic_data(dm: &[f64]) -> (StudyConfig, StudyData) {
    let mut config = StudyConfig::seed_default().unwrap();
    config.magnitudes = vec![6.5, 7.0];
    config.distances_km = vec![10.0];
    config.pulses_per_pair = dm.len() / 2;
    config.blocks.truncate(1);
    let pairs = config.pairs();
    let cases = dm
        .iter()
        .enumerate()
        .map(|(i, &d)| {
            let mut ims = [0.0; STUDY_IM_COUNT];
            for (j, v) in ims.iter_mut().enumerate() {
                // Some arbitrary positive IM unrelated to DM.
                *v = 1.0 + ((i * 7 + j * 3) % 5) as f64;
            }
            ims[11] = d; // "cav" := the DM itself
            ims[0] = 2.5; // "pha" := a constant
            PulseCase {
                id: i + 1,
                pair_index: i % 2,
                mw: pairs[i % 2].mw,
                r_km: 10.0,
                parameters: PulseParameters {
                    tp_s: 1.0,
                    vp_mps: 0.5,
                    gamma: 2.0,
                    nu_rad: 0.0,
                },
                amplitude_mps: 0.5,
                duration_s: 2.0,
                ims,
            }
        })
        .collect();
    let responses = dm
        .iter()
        .map(|&d| {
            vec![BlockResponse {
                status: ResponseStatus::Ok,
                max_abs_slide_m: d,
                max_abs_theta_rad: 0.0,
                exceeded_alpha: false,
                modes: Vec::new(),
                error: None,
            }]
        })
        .collect();
    (
        config,
        StudyData {
            pairs,
            cases,
            responses,
        },
    )
}

#[test]
fn analysis_ranks_the_dm_itself_first_with_r2_one_and_a_constant_im_at_zero() {
    let dm = [0.0, 0.002, 0.05, 0.3, 0.01, 0.0, 0.12, 0.4, 0.07, 0.2];
    let (config, data) = synthetic_data(&dm);
    let block = analyse_block(&config, &data, 0);
    assert_eq!(block.ranking[0].name(), "cav");
    assert!((block.ranking[0].r2() - 1.0).abs() < 1e-12);
    assert!((block.ranking[0].r2_log() - 1.0).abs() < 1e-12);
    let pha = block.ranking.iter().find(|s| s.name() == "pha").unwrap();
    assert_eq!(pha.r2(), 0.0);
    assert_eq!(block.counts.used(), 10);
    assert_eq!(block.counts.responding, 8); // DM ≥ 1 mm
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

const SMALL: [&str; 8] = [
    "--pulses-per-pair",
    "3",
    "--mw",
    "6.5,7",
    "--r-km",
    "5,10",
    "--block",
    "slender:r=0.6,alpha-deg=8,mu-s=1.0,mu-k=0.8",
];

#[test]
fn cli_study_writes_parseable_files_and_json_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let mut args = vec!["study", "--out", out, "--format", "json"];
    args.extend_from_slice(&SMALL);
    let output = rockwatch_bin!().output(&args);
    assert!(
        output.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).expect("stdout is JSON");
    let names = files_in(dir.path());
    for f in [
        "efficiency.csv",
        "efficiency.md",
        "fragility.csv",
        "fragility.json",
        "fragility_fits.csv",
        "results.csv",
        "scatter_rocking.png",
        "scatter_rocking.svg",
        "scatter_sliding.png",
        "scatter_slender.svg",
        "sufficiency.csv",
        "summary.json",
        "vector.csv",
    ] {
        assert!(names.iter().any(|n| n == f), "{f} missing from {names:?}");
    }
    // The JSON on stdout is summary.json.
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(json, file);
    for name in ["sliding", "rocking", "slender"] {
        let block = &json["blocks"][name];
        let n = block["n"].as_u64().unwrap();
        let excluded = block["excluded"].as_u64().unwrap();
        assert_eq!(n + excluded, 12, "{name}");
        let ranking = block["ranking"].as_array().unwrap();
        assert_eq!(ranking.len(), STUDY_IM_COUNT);
        let mut previous = f64::INFINITY;
        for entry in ranking {
            assert!(STUDY_IMS
                .iter()
                .any(|im| im.study_name() == entry["im"].as_str().unwrap()));
            if let Some(r2) = entry["r2"].as_f64() {
                assert!((0.0..=1.0).contains(&r2));
                assert!(r2 <= previous, "ranking not sorted");
                previous = r2;
            }
            let by_pair = entry["r2_by_pair"].as_object().unwrap();
            assert_eq!(by_pair.len(), 4);
            assert!(by_pair.contains_key("M6.5-R10"));
            for v in by_pair.values() {
                assert!(v.is_null() || (0.0..=1.0).contains(&v.as_f64().unwrap()));
            }
            for key in ["sufficiency_p_mw", "sufficiency_p_r"] {
                let p = &entry[key];
                assert!(p.is_null() || (0.0..=1.0).contains(&p.as_f64().unwrap()));
            }
        }
    }
    // CSVs: a header and rows of the header's width.
    let results = std::fs::read_to_string(dir.path().join("results.csv")).unwrap();
    let lines: Vec<&str> = results.lines().collect();
    assert_eq!(lines.len(), 1 + 12 * 3);
    let width = lines[0].split(',').count();
    assert_eq!(width, 19 + STUDY_IM_COUNT);
    assert!(lines.iter().all(|l| l.split(',').count() == width));
    for line in &lines[1..] {
        let cols: Vec<&str> = line.split(',').collect();
        let slide: f64 = cols[15].parse().unwrap();
        assert!(slide >= 0.0);
        for v in &cols[19..] {
            assert!(v.parse::<f64>().unwrap().is_finite());
        }
    }
    let efficiency = std::fs::read_to_string(dir.path().join("efficiency.csv")).unwrap();
    assert_eq!(efficiency.lines().count(), 1 + 3 * STUDY_IM_COUNT);
    assert!(efficiency.lines().next().unwrap().contains("r2_M7-R5"));
    let sufficiency = std::fs::read_to_string(dir.path().join("sufficiency.csv")).unwrap();
    assert_eq!(sufficiency.lines().count(), 1 + 3 * STUDY_IM_COUNT);
    let md = std::fs::read_to_string(dir.path().join("efficiency.md")).unwrap();
    assert!(md.contains("| Intensity measure | M6.5 R10 | M7 R10 | Overall R² |"));
    let png = std::fs::read(dir.path().join("scatter_sliding.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    // Issue 14 §5: the zero-response runs are drawn apart, in a strip under each of the five
    // log–log panels, labelled with their number (the summary's count).
    for name in ["sliding", "rocking"] {
        let svg = std::fs::read_to_string(dir.path().join(format!("scatter_{name}.svg"))).unwrap();
        let none = json["blocks"][name]["counts"]["no_response"]
            .as_u64()
            .unwrap();
        let label = format!("no response ({none})");
        assert_eq!(svg.matches(&label).count(), 5, "{name}: {label}");
    }
    let fragility: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("fragility.json")).unwrap())
            .unwrap();
    assert!(fragility["blocks"]
        .as_object()
        .unwrap()
        .contains_key("slender"));
}

#[test]
fn cli_study_is_bit_for_bit_reproducible_for_a_seed() {
    let run = |dir: &Path, seed: &str, threads: &str| {
        let out = dir.to_str().unwrap();
        let mut args = vec![
            "study",
            "--out",
            out,
            "--no-plots",
            "--seed",
            seed,
            "--threads",
            threads,
        ];
        args.extend_from_slice(&SMALL);
        let output = rockwatch_bin!().output(&args);
        assert!(output.status.success());
        (
            std::fs::read(dir.join("results.csv")).unwrap(),
            std::fs::read(dir.join("summary.json")).unwrap(),
        )
    };
    let (a, b, c) = (
        tempfile::tempdir().unwrap(),
        tempfile::tempdir().unwrap(),
        tempfile::tempdir().unwrap(),
    );
    let first = run(a.path(), "42", "1");
    let second = run(b.path(), "42", "2");
    assert!(first == second, "same seed, different bytes");
    let other = run(c.path(), "43", "2");
    assert!(first.0 != other.0, "a different seed gives the same pulses");
}

#[test]
fn cli_study_rejects_bad_options_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    for (extra, needle) in [
        (vec!["--block", "x:r=1,mu-s=1"], "alpha"),
        (vec!["--pulses-per-pair", "0"], "pulses per pair"),
        (vec!["--mw", "11"], "mw"),
        (vec!["--no-default-blocks"], "no blocks"),
        (vec!["--fragility-im", "nope"], "nope"),
    ] {
        let mut args = vec!["study", "--out", out, "--no-plots"];
        args.extend(extra.iter());
        let output = rockwatch_bin!().output(&args);
        assert!(!output.status.success(), "{extra:?} accepted");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(needle), "{extra:?}: {stderr}");
    }
}
