//! The general planar body (docs/general-body.md): a flat base between two pivots at b₊ and b₋
//! from the centre of mass, which sits at height h, with radius of gyration ρ. Verified as the
//! rectangle was (tests/physics_closed_forms.rs, tests/physics_properties.rs):
//!
//! 1. exact reduction to the rectangle on the bundled records (reference responses of the
//!    rectangle engine before the generalisation, tests/data/rectangle_engine_reference.json);
//! 2. static uplift thresholds a = g'·tan α± per side;
//! 3. energy conservation with restitution 1 and the generalised Housner decay of the peaks;
//! 4. the impact map: angular momentum about the impact point, impulses from the momentum
//!    jump, Coulomb cone, no energy gain, mirror symmetry;
//! 5. the equations of motion against an absolute-frame Newton–Euler solve, and a rocking
//!    trajectory against that formulation integrated by a classical Runge–Kutta;
//! 6. mirror symmetry of whole responses on a bundled record, and the CLI's general-body form.

use rockwatch_test_harness::fixtures::rinaldi;
use std::path::{Path, PathBuf};
use std::process::Command;

use proptest::prelude::*;
use rockwatch_core::dynamics::equations::{rocking, slide_rocking};
use rockwatch_core::dynamics::impact::impact;
use rockwatch_core::dynamics::{
    BlockEvent, BlockOptions, BlockParams, GroundAccel, ImpactKind, Mode, RigidBlock,
};
use rockwatch_core::record::Record;
use rockwatch_core::simulate::{simulate, SimulationOptions};
use rockwatch_test_harness::physics_reference::{
    accel_scale, newton_euler_body, Body, Pivot, G_MPS2,
};

fn data(path: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data")).join(path)
}

/// The asymmetric body used by several tests: tan α₊ = 0.2, tan α₋ = 0.5.
fn asymmetric(mu_s: f64, mu_k: f64, restitution: Option<f64>) -> BlockParams {
    BlockParams::from_body(0.2, 0.5, 1.0, 0.4, mu_s, mu_k, restitution).unwrap()
}

fn body_of(p: &BlockParams) -> Body {
    Body {
        b_plus_m: p.b_plus_m,
        b_minus_m: p.b_minus_m,
        com_height_m: p.com_height_m,
        centroidal_inertia_m2: p.rho_m * p.rho_m,
    }
}

// =============================================================================================
// 1. Exact reduction to the rectangle
// =============================================================================================

/// Compares every value of `reference` with the same key of `actual`: numbers to `tol`
/// (absolute), everything else exactly.
fn assert_matches(reference: &serde_json::Value, actual: &serde_json::Value, at: &str, tol: f64) {
    use serde_json::Value;
    match (reference, actual) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= tol,
                "{at}: reference {x}, general body {y}"
            );
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}: lengths differ");
            for (i, (x, y)) in x.iter().zip(y).enumerate() {
                assert_matches(x, y, &format!("{at}[{i}]"), tol);
            }
        }
        (Value::Object(x), Value::Object(y)) => {
            for (k, v) in x {
                let other = y.get(k).unwrap_or_else(|| panic!("{at}.{k} missing"));
                assert_matches(v, other, &format!("{at}.{k}"), tol);
            }
        }
        _ => assert_eq!(reference, actual, "{at}"),
    }
}

#[test]
fn rectangle_given_as_a_general_body_reproduces_the_rectangle_engine_on_the_bundled_records() {
    let text = std::fs::read_to_string(data("rectangle_engine_reference.json")).unwrap();
    let reference: serde_json::Value = serde_json::from_str(&text).unwrap();
    let cases = reference["cases"].as_array().unwrap();
    assert!(cases.len() >= 50);
    let options = SimulationOptions {
        t_extra_s: 5.0,
        ..SimulationOptions::default()
    };
    let (mut overturned, mut impacts) = (0, 0);
    for case in cases {
        let f = |k: &str| case[k].as_f64().unwrap();
        let mut record =
            Record::read(&data("records").join(case["record"].as_str().unwrap())).unwrap();
        if let Some(v) = case["vertical"].as_str() {
            record.attach_vertical(&data("records").join(v)).unwrap();
        }
        record.scale(f("scale"));
        let (b, h) = (f("width_m"), f("height_m"));
        // The body's own parameters, computed here: b± = B/2, h = H/2, ρ² = (B² + H²)/12.
        let rho = ((b * b + h * h) / 12.0).sqrt();
        let body =
            BlockParams::from_body(0.5 * b, 0.5 * b, 0.5 * h, rho, f("mu_s"), f("mu_k"), None)
                .unwrap();
        let sim = simulate(body, &record, &options).unwrap();
        let actual = serde_json::to_value(&sim.summary).unwrap();
        let at = format!(
            "{} B={b} H={h} μs={} μk={} ×{}",
            case["record"], case["mu_s"], case["mu_k"], case["scale"]
        );
        // ≤ 1e-12 on every output (the bound); the engine in fact reproduces the
        // reference bit for bit, because a rectangle-shaped body gets the rectangle's exact
        // ratios (docs/general-body.md §9).
        assert_matches(&case["summary"], &actual, &at, 1e-12);
        overturned += usize::from(sim.summary.overturned);
        impacts += sim.summary.n_impacts;
    }
    // The reference exercises overturning and impacts, so the comparison means something.
    assert!(
        overturned >= 5 && impacts >= 100,
        "{overturned} overturned, {impacts} impacts"
    );
}

// =============================================================================================
// 2. Static uplift thresholds, per side
// =============================================================================================

/// Drives a body at rest with a slow linear ramp of ẍg (and a constant ÿg) and returns the
/// time and pivot of the first rest → rock change.
fn uplift(params: BlockParams, slope_mps3: f64, vertical_mps2: f64) -> (f64, f64) {
    let mut block = RigidBlock::new(params, BlockOptions::default());
    let dt = 0.01;
    let mut first = None;
    for k in 0..2000 {
        let at = |i: usize| GroundAccel {
            horizontal_mps2: slope_mps3 * i as f64 * dt,
            vertical_mps2,
        };
        block
            .advance(dt, at(k), at(k + 1), |e| {
                if let BlockEvent::ModeChange { t_s, from, to } = e {
                    if first.is_none() {
                        assert_eq!((from, to), (Mode::Rest, Mode::Rock));
                        first = Some(t_s);
                    }
                }
            })
            .unwrap();
        if let Some(t) = first {
            return (t, block.theta_rad().signum());
        }
    }
    panic!("no uplift");
}

#[test]
fn uplift_starts_at_g_tan_alpha_of_each_side() {
    // μs above both tan α: rocking, not sliding, starts. ÿg shifts g to g' = g + ÿg.
    let params = asymmetric(0.9, 0.6, None);
    for vertical in [0.0, 0.3 * G_MPS2, -0.2 * G_MPS2] {
        let gp = G_MPS2 + vertical;
        for (slope, sigma, tan_alpha) in [(-0.5, 1.0, 0.2), (0.5, -1.0, 0.5)] {
            let (t, pivot) = uplift(params, slope, vertical);
            // The ground pushed towards −x tips the body onto its +x pivot, and vice versa.
            assert_eq!(pivot, sigma);
            // Threshold crossing of a linear input: the exit time is the root of a linear
            // function (exact to rounding); 1e-9 s × 0.5 m/s³ leaves room for the 1e-9 s
            // right limit at which the new mode is selected.
            let a = slope * t;
            assert!(
                (a.abs() - gp * tan_alpha).abs() <= 1e-9,
                "σ = {sigma}, g' = {gp}: uplift at |ẍg| = {}, expected {}",
                a.abs(),
                gp * tan_alpha
            );
        }
    }
}

// =============================================================================================
// 3. Energy
// =============================================================================================

/// Height of the centre of mass above the base at rotation θ (m): R_σ cos(α_σ − |θ|), from the
/// geometry (pivot at (σb_σ, −h) from the centre of mass).
fn com_height(b_plus: f64, b_minus: f64, h: f64, theta: f64) -> f64 {
    let b = if theta > 0.0 { b_plus } else { b_minus };
    let (r, alpha) = (b.hypot(h), b.atan2(h));
    r * (alpha - theta.abs()).cos()
}

/// Free rocking from `theta0`; returns the θ of every peak event and the impact kinds.
fn free_rocking(params: BlockParams, theta0: f64, seconds: f64) -> (Vec<f64>, Vec<ImpactKind>) {
    let mut block = RigidBlock::released(params, BlockOptions::default(), theta0, 0.0);
    let (mut peaks, mut kinds) = (vec![theta0], Vec::new());
    let zero = GroundAccel::default();
    for _ in 0..(seconds / 0.01) as usize {
        block
            .advance(0.01, zero, zero, |e| match e {
                BlockEvent::Peak { theta_rad, .. } => peaks.push(theta_rad),
                BlockEvent::Impact { kind, landed, .. } if !landed => kinds.push(kind),
                _ => {}
            })
            .unwrap();
    }
    (peaks, kinds)
}

#[test]
fn free_rocking_with_restitution_one_conserves_energy_across_pivot_changes() {
    // e = 1: each sticking impact keeps the kinetic energy (θ̇⁺ = √(I_old/I_new) θ̇⁻), so every
    // peak, on either pivot, lifts the centre of mass to the same height.
    let params = asymmetric(0.9, 0.6, Some(1.0));
    let theta0 = 0.6 * params.plus.alpha_rad;
    let (peaks, kinds) = free_rocking(params, theta0, 8.0);
    assert!(peaks.len() >= 10, "{} peaks", peaks.len());
    assert!(peaks.iter().any(|&t| t < 0.0) && peaks.iter().any(|&t| t > 0.0));
    assert!(kinds.iter().all(|&k| k == ImpactKind::Stick), "{kinds:?}");
    let y0 = com_height(0.2, 0.5, 1.0, theta0);
    let lift0 = y0 - 1.0;
    for (i, &theta) in peaks.iter().enumerate() {
        let y = com_height(0.2, 0.5, 1.0, theta);
        // Integrator rtol 1e-9 over ~10 half-cycles: the lift (≈ 1 mm) is kept to 1e-6 of
        // itself; an energy error of a single ulp-level constant would not show, a wrong
        // inertia or lever arm (≥ 1e-3) would.
        assert!(
            (y - y0).abs() <= 1e-6 * lift0,
            "peak {i}: θ = {theta}, lift {} vs {lift0}",
            y - 1.0
        );
    }
}

#[test]
fn free_rocking_peaks_follow_the_generalised_housner_decay() {
    // Angular momentum about the new pivot: θ̇⁺ = q θ̇⁻, q = (ρ² + h² − b_old b_new)/I_new;
    // with the energy on each side, lift_new = q² (I_new/I_old) lift_old where
    // lift = R cos(α − |θ|) − h and I = ρ² + R² (all per unit mass).
    let params = asymmetric(0.9, 0.6, None);
    let (b_plus, b_minus, h, rho2) = (0.2, 0.5, 1.0, 0.16);
    let theta0 = 0.8 * params.plus.alpha_rad;
    let (peaks, kinds) = free_rocking(params, theta0, 3.0);
    assert!(kinds.iter().all(|&k| k == ImpactKind::Stick));
    assert!(peaks.len() >= 4, "{peaks:?}");
    for pair in peaks.windows(2).take(6) {
        let (old, new) = (pair[0], pair[1]);
        assert!(old * new < 0.0, "peaks alternate sides: {pair:?}");
        let (b_old, b_new) = if old > 0.0 {
            (b_plus, b_minus)
        } else {
            (b_minus, b_plus)
        };
        let i_old = rho2 + b_old * b_old + h * h;
        let i_new = rho2 + b_new * b_new + h * h;
        let q = (rho2 + h * h - b_old * b_new) / i_new;
        let lift_old = com_height(b_plus, b_minus, h, old) - h;
        let lift_new = com_height(b_plus, b_minus, h, new) - h;
        let expected = q * q * i_new / i_old * lift_old;
        assert!(
            (lift_new - expected).abs() <= 1e-6 * lift_old,
            "{pair:?}: lift {lift_new} vs {expected}"
        );
    }
}

// =============================================================================================
// 4. Impact map
// =============================================================================================

/// Centroid velocity at θ = 0 of a body rotating with θ̇ (clockwise) about pivot σ (at
/// (σb_σ, −h) from the centre of mass) slipping with u̇: (u̇ + h θ̇, σ b_σ θ̇).
fn centroid_velocity(body: &Body, sigma: f64, theta_dot: f64, slip_dot: f64) -> [f64; 2] {
    let b = if sigma > 0.0 {
        body.b_plus_m
    } else {
        body.b_minus_m
    };
    [
        slip_dot + theta_dot * body.com_height_m,
        sigma * b * theta_dot,
    ]
}

/// Clockwise angular momentum per unit mass about the pivot σ_new:
/// I_c θ̇ + (d × v)_cw with d = c − O′ = (−σ_new b_new, h).
fn angular_momentum_about(body: &Body, sigma_new: f64, theta_dot: f64, v: [f64; 2]) -> f64 {
    let b = if sigma_new > 0.0 {
        body.b_plus_m
    } else {
        body.b_minus_m
    };
    body.centroidal_inertia_m2 * theta_dot + body.com_height_m * v[0] + sigma_new * b * v[1]
}

fn kinetic_energy(body: &Body, theta_dot: f64, v: [f64; 2]) -> f64 {
    0.5 * (v[0] * v[0] + v[1] * v[1]) + 0.5 * body.centroidal_inertia_m2 * theta_dot * theta_dot
}

fn sign() -> impl Strategy<Value = f64> {
    prop_oneof![Just(1.0), Just(-1.0)]
}

/// Random bodies (b± from 2 cm to 1.5 m, h from 5 cm to 3 m, ρ from 0.3 to 1.2 times the
/// rectangle's), friction below the body's Painlevé bound, restitution or the default, and a
/// pre-impact state.
#[allow(clippy::type_complexity)]
fn impact_case() -> impl Strategy<Value = (BlockParams, f64, f64, f64)> {
    (
        (0.02f64..1.5, 0.02f64..1.5, 0.05f64..3.0, 0.3f64..1.2),
        0.0f64..1.3,
        0.0f64..=1.0,
        prop::option::of(0.0f64..=1.0),
        sign(),
        1e-3f64..8.0,
        prop_oneof![Just(0.0), -4.0f64..4.0],
    )
        .prop_filter_map(
            "friction above the Painlevé bound",
            |((bp, bm, h, rho_factor), mu_s, mu_k_fraction, e, sigma_old, w, v)| {
                let rho = rho_factor * ((bp + bm).powi(2) + 4.0 * h * h).sqrt() / 12f64.sqrt();
                let mu_s = mu_s.max(1e-3);
                let params =
                    BlockParams::from_body(bp, bm, h, rho, mu_s, mu_k_fraction * mu_s, e).ok()?;
                Some((params, sigma_old, -sigma_old * w, v))
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    #[test]
    fn impact_conserves_angular_momentum_about_the_new_pivot_within_the_coulomb_cone(
        (params, sigma_old, w0, v0) in impact_case(),
    ) {
        let body = body_of(&params);
        let out = impact(&params, sigma_old, w0, v0);
        let sigma_new = -sigma_old;
        let v_before = centroid_velocity(&body, sigma_old, w0, v0);
        let v_after = centroid_velocity(&body, sigma_new, out.theta_dot, out.slip_dot);
        let r = params.plus.half_diagonal_m.max(params.minus.half_diagonal_m);
        let v_scale = r * w0.abs() + v0.abs();
        let l_scale = r * v_scale;

        // Impulses are the jump of the centroid momentum.
        let (px, py) = (v_after[0] - v_before[0], v_after[1] - v_before[1]);
        prop_assert!((out.impulse_x_per_mass - px).abs() <= 1e-12 * v_scale);
        prop_assert!((out.impulse_y_per_mass - py).abs() <= 1e-12 * v_scale);
        prop_assert!(py >= -1e-14 * v_scale, "P_y = {py} < 0");
        let mu = if v0 == 0.0 { params.mu_s } else { params.mu_k };
        prop_assert!(px.abs() <= mu * py + 1e-12 * v_scale, "{:?}", out.kind);
        if out.kind == ImpactKind::Slip {
            prop_assert!((px.abs() - params.mu_k * py).abs() <= 1e-12 * v_scale);
            prop_assert!(px * out.slip_dot <= 1e-12 * v_scale * v_scale);
        }
        if out.kind != ImpactKind::FlatLanding {
            prop_assert!(sigma_new * out.theta_dot > 0.0);
            let l_before = angular_momentum_about(&body, sigma_new, w0, v_before);
            let l_after = angular_momentum_about(&body, sigma_new, out.theta_dot, v_after);
            match params.restitution {
                // Housner's rule generalised: angular momentum about O′ is conserved.
                None => prop_assert!((l_after - l_before).abs() <= 1e-12 * l_scale,
                    "L⁺ = {l_after}, L⁻ = {l_before} ({:?})", out.kind),
                // A restitution e on a pure-rocking sticking impact: energy ratio e².
                Some(e) => if out.kind == ImpactKind::Stick && v0 == 0.0 {
                    let ratio = kinetic_energy(&body, out.theta_dot, v_after)
                        / kinetic_energy(&body, w0, v_before);
                    prop_assert!((ratio - e * e).abs() <= 1e-12, "{ratio} vs {}", e * e);
                },
            }
        } else {
            prop_assert_eq!(out.theta_dot, 0.0);
        }
        let t_before = kinetic_energy(&body, w0, v_before);
        let t_after = kinetic_energy(&body, out.theta_dot, v_after);
        prop_assert!(t_after <= t_before * (1.0 + 1e-12),
            "energy gain {t_before} → {t_after} ({:?})", out.kind);
    }

    #[test]
    fn impact_of_the_mirrored_body_is_the_mirror_image(
        (params, sigma_old, w0, v0) in impact_case(),
    ) {
        // Reflecting x → −x swaps b₊ and b₋ and negates θ̇, u̇ and P_x.
        let mirrored = BlockParams::from_body(
            params.b_minus_m, params.b_plus_m, params.com_height_m, params.rho_m,
            params.mu_s, params.mu_k, params.restitution,
        ).unwrap();
        let a = impact(&params, sigma_old, w0, v0);
        let m = impact(&mirrored, -sigma_old, -w0, -v0);
        prop_assert_eq!(a.kind, m.kind);
        prop_assert_eq!(a.theta_dot, -m.theta_dot);
        prop_assert_eq!(a.slip_dot, -m.slip_dot);
        prop_assert_eq!(a.impulse_x_per_mass, -m.impulse_x_per_mass);
        prop_assert_eq!(a.impulse_y_per_mass, m.impulse_y_per_mass);
    }
}

// =============================================================================================
// 5. Equations of motion vs the absolute-frame Newton–Euler formulation
// =============================================================================================

#[allow(clippy::type_complexity)]
fn state() -> impl Strategy<Value = (BlockParams, f64, f64, f64, GroundAccel, f64, f64)> {
    (
        (0.05f64..2.0, 0.05f64..2.0, 0.05f64..3.0, 0.3f64..1.2),
        sign(),
        0.0f64..1.5,
        -6.0f64..6.0,
        -2.0 * G_MPS2..2.0 * G_MPS2,
        -0.95 * G_MPS2..0.95 * G_MPS2,
        sign(),
        0.0f64..1.0,
    )
        .prop_filter_map(
            "friction above the Painlevé bound",
            |((bp, bm, h, f), sigma, tilt, w, ax, ay, s, mu_k)| {
                let rho = f * ((bp + bm).powi(2) + 4.0 * h * h).sqrt() / 12f64.sqrt();
                let p = BlockParams::from_body(bp, bm, h, rho, 1.3, mu_k, None).ok()?;
                let ground = GroundAccel {
                    horizontal_mps2: ax,
                    vertical_mps2: ay,
                };
                Some((p, sigma, sigma * tilt, w, ground, s, mu_k))
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn rocking_and_slide_rocking_equations_match_newton_euler(
        (params, sigma, theta, theta_dot, ground, s, mu_k) in state(),
    ) {
        let body = body_of(&params);
        let r = params.side(sigma).half_diagonal_m;
        // 1e-11 (vs 1e-12 for rectangles) leaves room for the slide-rock denominator
        // c + sin²φ − μk sin φ cos φ, which can approach 0 near the Painlevé bound.
        let tol = 1e-11 * accel_scale(r, theta_dot, ground);
        let engine = rocking(&params, sigma, theta, theta_dot, ground);
        let reference =
            newton_euler_body(&body, Pivot::Stuck, sigma, theta, theta_dot, ground, G_MPS2);
        prop_assert!((engine.theta_ddot - reference.theta_ddot).abs() * r <= tol);
        prop_assert!((engine.friction_per_mass - reference.friction_per_mass).abs() <= tol);
        prop_assert!((engine.normal_per_mass - reference.normal_per_mass).abs() <= tol);

        let engine = slide_rocking(&params, sigma, s, theta, theta_dot, ground);
        let reference = newton_euler_body(
            &body, Pivot::Slipping { mu_k, s }, sigma, theta, theta_dot, ground, G_MPS2,
        );
        // Relative to the conditioning of the slide-rock solve.
        let c = params.side(sigma).inertia_ratio;
        let tol = tol / (c * 3.0).min(1.0);
        prop_assert!((engine.theta_ddot - reference.theta_ddot).abs() * r <= tol,
            "θ̈ {} vs {}", engine.theta_ddot, reference.theta_ddot);
        prop_assert!((engine.slip_ddot - reference.slip_ddot).abs() <= tol);
        prop_assert!((engine.friction_per_mass - reference.friction_per_mass).abs() <= tol);
        prop_assert!((engine.normal_per_mass - reference.normal_per_mass).abs() <= tol);
    }
}

/// A smooth ground motion: 0.12 g at 1.3 Hz plus 0.05 g vertical at 2.1 Hz (m/s²).
fn smooth_ground(t: f64) -> GroundAccel {
    let tau = std::f64::consts::TAU;
    GroundAccel {
        horizontal_mps2: 0.12 * G_MPS2 * (tau * 1.3 * t).sin(),
        vertical_mps2: 0.05 * G_MPS2 * (tau * 2.1 * t).sin(),
    }
}

#[test]
fn rocking_trajectory_matches_newton_euler_integrated_by_runge_kutta() {
    // Released on each pivot of the asymmetric body with ample friction, under a smooth
    // two-component input sampled at 100 Hz (the engine sees it linearly interpolated; so
    // does the reference). Compared until the first impact.
    let params = asymmetric(1.2, 0.5, None);
    let body = body_of(&params);
    let dt = 0.01;
    let ground_at = |t: f64| {
        let k = (t / dt).floor();
        let w = t / dt - k;
        smooth_ground(k * dt).lerp(smooth_ground((k + 1.0) * dt), w)
    };
    for (theta0, theta_dot0) in [(0.5 * params.plus.alpha_rad, 0.0), (-0.3, 0.2)] {
        let mut block = RigidBlock::released(params, BlockOptions::default(), theta0, theta_dot0);
        let sigma = theta0.signum();
        // Reference: θ̈ from the 6×6 Newton–Euler solve, classical RK4 with h = 1e-4 s
        // (global error O(h⁴) ≈ 1e-12 rad here, far below the comparison tolerance).
        let accel = |t: f64, th: f64, w: f64| {
            newton_euler_body(&body, Pivot::Stuck, sigma, th, w, ground_at(t), G_MPS2).theta_ddot
        };
        let (mut th, mut w, mut t) = (theta0, theta_dot0, 0.0);
        let h = 1e-4;
        let mut compared = 0;
        for k in 0..400 {
            let mut impacted = false;
            block
                .advance(
                    dt,
                    smooth_ground(k as f64 * dt),
                    smooth_ground((k + 1) as f64 * dt),
                    |e| {
                        impacted |=
                            matches!(e, BlockEvent::Impact { .. } | BlockEvent::ModeChange { .. });
                    },
                )
                .unwrap();
            if impacted {
                break;
            }
            for _ in 0..100 {
                let (k1t, k1w) = (w, accel(t, th, w));
                let (k2t, k2w) = (
                    w + 0.5 * h * k1w,
                    accel(t + 0.5 * h, th + 0.5 * h * k1t, w + 0.5 * h * k1w),
                );
                let (k3t, k3w) = (
                    w + 0.5 * h * k2w,
                    accel(t + 0.5 * h, th + 0.5 * h * k2t, w + 0.5 * h * k2w),
                );
                let (k4t, k4w) = (w + h * k3w, accel(t + h, th + h * k3t, w + h * k3w));
                th += h / 6.0 * (k1t + 2.0 * k2t + 2.0 * k3t + k4t);
                w += h / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
                t += h;
            }
            // Engine rtol 1e-9 / atol 1e-12 (DOPRI5) vs RK4: 1e-8 rad over ≤ 4 s.
            assert!(
                (block.theta_rad() - th).abs() <= 1e-8,
                "t = {t:.2} s: engine θ = {}, Newton–Euler θ = {th}",
                block.theta_rad()
            );
            assert!((block.theta_dot() - w).abs() <= 1e-7);
            compared += 1;
        }
        assert!(
            compared >= 20,
            "only {compared} intervals before the first impact"
        );
    }
}

// =============================================================================================
// 6. Whole responses: mirror symmetry on a bundled record, asymmetry, and the CLI
// =============================================================================================

#[test]
fn mirrored_body_under_mirrored_record_gives_the_mirrored_response() {
    let mut record = rinaldi();
    let options = SimulationOptions {
        t_extra_s: 5.0,
        ..SimulationOptions::default()
    };
    let params = BlockParams::from_body(0.15, 0.3, 0.9, 0.35, 0.7, 0.5, None).unwrap();
    let mirrored = BlockParams::from_body(0.3, 0.15, 0.9, 0.35, 0.7, 0.5, None).unwrap();
    let a = simulate(params, &record, &options).unwrap();
    record.horizontal_mps2.iter_mut().for_each(|x| *x = -*x);
    let m = simulate(mirrored, &record, &options).unwrap();
    // Every operation of the engine is mirror-symmetric (sign flips are exact): identical.
    let (a, m) = (&a.summary, &m.summary);
    assert_eq!(a.status, m.status);
    assert_eq!(a.modes, m.modes);
    assert_eq!(a.max_abs_theta, m.max_abs_theta);
    assert_eq!(a.max_abs_theta_over_alpha, m.max_abs_theta_over_alpha);
    assert_eq!(a.residual_slide, -m.residual_slide);
    assert_eq!(a.n_impacts, m.n_impacts);
    assert!(a.n_impacts > 0, "the record must make the body rock");
}

#[test]
fn the_weak_side_governs_the_overturning_scale() {
    // The body leans on its +x pivot (b₊ = 0.1 m, b₋ = 0.4 m): a one-sided pulse pushing it
    // onto the weak side (ẍg < 0) needs a smaller amplitude than one onto the strong side.
    let params = BlockParams::from_body(0.1, 0.4, 1.0, 0.45, 0.9, 0.6, None).unwrap();
    let falls = |amp: f64| {
        let mut block = RigidBlock::new(params, BlockOptions::default());
        let pulse = |t: f64| {
            GroundAccel::horizontal(if t < 0.5 {
                amp * (std::f64::consts::PI * t / 0.5).sin()
            } else {
                0.0
            })
        };
        for k in 0..500 {
            let (t0, t1) = (k as f64 * 0.01, (k + 1) as f64 * 0.01);
            block.advance(0.01, pulse(t0), pulse(t1), |_| {}).unwrap();
        }
        block.mode() == Mode::Overturned
    };
    let threshold = |sign: f64| {
        let (mut lo, mut hi) = (0.0, 3.0 * G_MPS2);
        for _ in 0..30 {
            let mid = 0.5 * (lo + hi);
            if falls(sign * mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    };
    let (weak, strong) = (threshold(-1.0), threshold(1.0));
    assert!(
        weak > 0.1 * G_MPS2 && weak < strong,
        "weak {weak}, strong {strong}"
    );
}

#[test]
fn cli_general_body_prints_the_library_summary() {
    let record = data("records/RSN1084_NORTHR_SCS142.AT2");
    let out = Command::new(env!("CARGO_BIN_EXE_rockwatch"))
        .args(["simulate", "--record"])
        .arg(&record)
        .args([
            "--b-plus",
            "0.15",
            "--b-minus",
            "0.3",
            "--com-height",
            "0.9",
            "--rho",
            "0.35",
            "--mu-s",
            "0.7",
            "--mu-k",
            "0.5",
            "--t-extra",
            "5",
            "--format",
            "json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cli: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let params = BlockParams::from_body(0.15, 0.3, 0.9, 0.35, 0.7, 0.5, None).unwrap();
    let sim = simulate(
        params,
        &Record::read(&record).unwrap(),
        &SimulationOptions {
            t_extra_s: 5.0,
            ..SimulationOptions::default()
        },
    )
    .unwrap();
    // serde_json's float parser may be off by one ulp.
    assert_matches(
        &serde_json::to_value(&sim.summary).unwrap(),
        &cli,
        "",
        1e-15 * 100.0,
    );
    assert_eq!(cli["alpha_plus"].as_f64().unwrap(), params.plus.alpha_rad);

    // An incomplete general body is refused with a one-line reason.
    let out = Command::new(env!("CARGO_BIN_EXE_rockwatch"))
        .args(["simulate", "--record"])
        .arg(&record)
        .args(["--b-plus", "0.15", "--mu-s", "0.7", "--mu-k", "0.5"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--b-minus") || err.contains("b-minus"),
        "{err}"
    );
}
