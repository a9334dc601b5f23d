//! Property and end-to-end checks of the block engine (spec: block-dynamics.md §4–§10).
//!
//! * the equations of motion (R1)–(R3), (SR1)–(SR3), (S1) against an independent
//!   absolute-frame Newton–Euler linear solve at random states;
//! * the impact map (§9.1) against momentum balances computed here from the centroid
//!   velocities: angular momentum about the new corner, Coulomb cone, energy, Housner and
//!   frictionless limits;
//! * every developer record through `simulate` and through the CLI, including an exact
//!   Newmark sliding-block reference for the piecewise-linear record, and the CLI's handling of
//!   bad input.

use std::path::{Path, PathBuf};
use std::process::Command;

use proptest::prelude::*;
use rockwatch_core::dynamics::equations::{rocking, slide_rocking, sliding};
use rockwatch_core::dynamics::impact::impact;
use rockwatch_core::dynamics::{BlockParams, GroundAccel, ImpactKind, Mode};
use rockwatch_core::record::Record;
use rockwatch_core::simulate::{simulate, SimulationOptions, Status};
use rockwatch_test_harness::physics_reference::{self, accel_scale, newton_euler, Pivot, G_MPS2};

fn sign() -> impl Strategy<Value = f64> {
    prop_oneof![Just(1.0), Just(-1.0)]
}

// =============================================================================================
// 7. Equations of motion vs an absolute-frame Newton–Euler solve
// =============================================================================================

/// A random block state and input: B, H (m), σ, θ (on the σ side, up to 1.5 rad), θ̇ (rad/s),
/// ẍg, ÿg (m/s², |ÿg| < g so that g' > 0).
#[allow(clippy::type_complexity)]
fn state() -> impl Strategy<Value = (f64, f64, f64, f64, f64, GroundAccel)> {
    (
        0.05f64..4.0,
        0.05f64..6.0,
        sign(),
        0.0f64..1.5,
        -6.0f64..6.0,
        -2.0 * G_MPS2..2.0 * G_MPS2,
        -0.95 * G_MPS2..0.95 * G_MPS2,
    )
        .prop_map(|(b, h, sigma, tilt, theta_dot, ax, ay)| {
            (
                b,
                h,
                sigma,
                sigma * tilt,
                theta_dot,
                GroundAccel {
                    horizontal_mps2: ax,
                    vertical_mps2: ay,
                },
            )
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn rocking_equations_match_newton_euler_solve(
        (b, h, sigma, theta, theta_dot, ground) in state(),
    ) {
        let p = BlockParams::from_width_height(b, h, 1.0, 0.5, None).unwrap();
        let engine = rocking(&p, sigma, theta, theta_dot, ground);
        let reference =
            newton_euler(b, h, Pivot::Stuck, sigma, theta, theta_dot, ground, G_MPS2);
        let r = 0.5 * b.hypot(h);
        let tol = 1e-12 * accel_scale(r, theta_dot, ground);
        prop_assert!((engine.theta_ddot - reference.theta_ddot).abs() * r <= tol,
            "θ̈ {} vs {}", engine.theta_ddot, reference.theta_ddot);
        prop_assert!((engine.friction_per_mass - reference.friction_per_mass).abs() <= tol,
            "F/m {} vs {}", engine.friction_per_mass, reference.friction_per_mass);
        prop_assert!((engine.normal_per_mass - reference.normal_per_mass).abs() <= tol,
            "N/m {} vs {}", engine.normal_per_mass, reference.normal_per_mass);
        prop_assert!(reference.slip_ddot.abs() <= tol);
        prop_assert_eq!(engine.slip_ddot, 0.0);
    }

    #[test]
    fn slide_rocking_equations_match_newton_euler_solve(
        (b, h, sigma, theta, theta_dot, ground) in state(),
        s in sign(),
        mu_k in 0.0f64..1.0,
    ) {
        let p = BlockParams::from_width_height(b, h, 1.0, mu_k, None).unwrap();
        let engine = slide_rocking(&p, sigma, s, theta, theta_dot, ground);
        let reference = newton_euler(
            b, h, Pivot::Slipping { mu_k, s }, sigma, theta, theta_dot, ground, G_MPS2,
        );
        let r = 0.5 * b.hypot(h);
        // The slide-rock system's denominator 1/3 + sin²φ − μk σ s sin φ cos φ ≥ 1/3 − 1/2·μk
        // > 0 (μk < 1): at most a factor ~6 worse conditioned than rocking; same tolerance.
        let tol = 1e-12 * accel_scale(r, theta_dot, ground);
        prop_assert!((engine.theta_ddot - reference.theta_ddot).abs() * r <= tol,
            "θ̈ {} vs {}", engine.theta_ddot, reference.theta_ddot);
        prop_assert!((engine.slip_ddot - reference.slip_ddot).abs() <= tol,
            "ü {} vs {}", engine.slip_ddot, reference.slip_ddot);
        prop_assert!((engine.friction_per_mass - reference.friction_per_mass).abs() <= tol,
            "F/m {} vs {}", engine.friction_per_mass, reference.friction_per_mass);
        prop_assert!((engine.normal_per_mass - reference.normal_per_mass).abs() <= tol,
            "N/m {} vs {}", engine.normal_per_mass, reference.normal_per_mass);
    }

    #[test]
    fn flat_sliding_equation_is_newton_with_coulomb_friction(
        (b, h, _sigma, _theta, _theta_dot, ground) in state(),
        s in sign(),
        mu_k in 0.0f64..1.0,
    ) {
        // Flat block, both corners down: no rotation, N = m g', F = −μk s N, and the base
        // accelerates relative to the ground by F/m − ẍg (S1).
        let p = BlockParams::from_width_height(b, h, 1.0, mu_k, None).unwrap();
        let normal = G_MPS2 + ground.vertical_mps2;
        let expected = -mu_k * s * normal - ground.horizontal_mps2;
        prop_assert!((sliding(&p, s, ground) - expected).abs()
            <= 1e-13 * accel_scale(0.0, 0.0, ground));
    }
}

// =============================================================================================
// 8. Impact map
// =============================================================================================

/// Velocity state of a block at θ = 0 rotating about corner σ (pivot at (σB/2, −H/2) from the
/// centroid) with angular velocity θ̇ (clockwise) and pivot slip velocity u̇:
/// v_c = (u̇, 0) + θ̇ × (c − pivot) = (u̇ + θ̇ H/2, σ θ̇ B/2).
fn centroid_velocity(b: f64, h: f64, sigma: f64, theta_dot: f64, slip_dot: f64) -> [f64; 2] {
    [slip_dot + theta_dot * 0.5 * h, sigma * theta_dot * 0.5 * b]
}

/// Clockwise angular momentum per unit mass about the corner σ_new at (σ_new B/2, −H/2):
/// I_c θ̇ + (d × v)_cw with d = c − O′ = (−σ_new B/2, H/2).
fn angular_momentum_about(b: f64, h: f64, sigma_new: f64, theta_dot: f64, v: [f64; 2]) -> f64 {
    let inertia = (b * b + h * h) / 12.0;
    inertia * theta_dot + 0.5 * h * v[0] + sigma_new * 0.5 * b * v[1]
}

/// Kinetic energy per unit mass ½|v_c|² + ½ I_c θ̇².
fn kinetic_energy(b: f64, h: f64, theta_dot: f64, v: [f64; 2]) -> f64 {
    0.5 * (v[0] * v[0] + v[1] * v[1]) + 0.5 * (b * b + h * h) / 12.0 * theta_dot * theta_dot
}

/// Random blocks (α from ~1° to ~80°, squat blocks included so that flat landings occur),
/// friction μk ≤ μs, any impact ratio e ∈ [0, 1] or Housner's η, and a pre-impact state:
/// corner σ_old, returning angular velocity (σ_old θ̇⁻ < 0) and slip u̇⁻ (zero half the time).
#[allow(clippy::type_complexity)]
fn impact_case() -> impl Strategy<Value = (BlockParams, f64, f64, f64)> {
    (
        0.05f64..3.0,
        0.02f64..1.4,
        0.0f64..1.3,
        0.0f64..=1.0,
        prop::option::of(0.0f64..=1.0),
        sign(),
        1e-3f64..8.0,
        prop_oneof![Just(0.0), -4.0f64..4.0],
    )
        .prop_map(|(r, alpha, mu_s, mu_k_fraction, e, sigma_old, w, v)| {
            let mu_s = mu_s.max(1e-3);
            let params = BlockParams::from_width_height(
                2.0 * r * alpha.sin(),
                2.0 * r * alpha.cos(),
                mu_s,
                (mu_k_fraction * mu_s).min(1.3),
                e,
            )
            .unwrap();
            (params, sigma_old, -sigma_old * w, v)
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn impact_conserves_angular_momentum_about_new_corner_inside_coulomb_cone_without_energy_gain(
        (params, sigma_old, w0, v0) in impact_case(),
    ) {
        let (b, h) = (params.base_width_m(), 2.0 * params.com_height_m);
        let out = impact(&params, sigma_old, w0, v0);
        let sigma_new = -sigma_old;
        prop_assert_eq!(out.sigma_new, sigma_new);

        let v_before = centroid_velocity(b, h, sigma_old, w0, v0);
        let v_after = centroid_velocity(b, h, sigma_new, out.theta_dot, out.slip_dot);
        // Scales for rounding: velocities (m/s) and angular momenta (m²/s).
        let r = 0.5 * b.hypot(h);
        let v_scale = r * w0.abs() + v0.abs();
        let l_scale = r * v_scale;

        // Impulses = jump of the centroid momentum (independent of the engine's formulas).
        let px = v_after[0] - v_before[0];
        let py = v_after[1] - v_before[1];
        prop_assert!((out.impulse_x_per_mass - px).abs() <= 1e-12 * v_scale,
            "P_x {} vs {px}", out.impulse_x_per_mass);
        prop_assert!((out.impulse_y_per_mass - py).abs() <= 1e-12 * v_scale,
            "P_y {} vs {py}", out.impulse_y_per_mass);
        prop_assert!(py >= -1e-14 * v_scale, "P_y = {py} < 0");

        // Coulomb: μs bounds every impulse; μk bounds it when O′ arrives slipping; a slipping
        // impact sits on the cone with the friction impulse opposing the post-impact slip.
        let mu = if v0 == 0.0 { params.mu_s } else { params.mu_k };
        prop_assert!(px.abs() <= mu * py + 1e-12 * v_scale,
            "|P_x| = {} > μ P_y = {} ({:?})", px.abs(), mu * py, out.kind);
        if out.kind == ImpactKind::Slip {
            prop_assert!((px.abs() - params.mu_k * py).abs() <= 1e-12 * v_scale);
            prop_assert!(px * out.slip_dot <= 1e-12 * v_scale * v_scale);
        }

        match out.kind {
            ImpactKind::Stick | ImpactKind::Slip => {
                // The block rotates about O′ afterwards (the old corner lifts).
                prop_assert!(sigma_new * out.theta_dot > 0.0);
                if out.kind == ImpactKind::Stick {
                    prop_assert_eq!(out.slip_dot, 0.0);
                }
                // (I1): with Housner's η this is conservation of angular momentum about O′;
                // a restitution e replaces η I_O θ̇⁻ by e I_O θ̇⁻ (I_O = 4R²/3).
                let eta = 1.0 - 1.5 * (b / (2.0 * r)).powi(2);
                let e = params.restitution.unwrap_or(eta);
                let l_before = angular_momentum_about(b, h, sigma_new, w0, v_before);
                let l_after = angular_momentum_about(b, h, sigma_new, out.theta_dot, v_after);
                let expected = l_before + (e - eta) * (4.0 / 3.0) * r * r * w0;
                prop_assert!((l_after - expected).abs() <= 1e-12 * l_scale,
                    "L⁺ = {l_after}, expected {expected} ({:?})", out.kind);
            }
            ImpactKind::FlatLanding => {
                prop_assert_eq!(out.theta_dot, 0.0);
            }
        }

        // Kinetic energy T = ½(u̇² + 2Ru̇θ̇ cos α) + ½(4R²/3)θ̇² never increases.
        let t_before = kinetic_energy(b, h, w0, v_before);
        let t_after = kinetic_energy(b, h, out.theta_dot, v_after);
        prop_assert!(t_after <= t_before * (1.0 + 1e-12),
            "energy gain: {t_before} → {t_after} ({:?})", out.kind);
    }

    #[test]
    fn impact_map_is_mirror_symmetric(
        (params, sigma_old, w0, v0) in impact_case(),
    ) {
        // Reflecting x → −x swaps the corners and negates θ̇, u̇ and P_x.
        let a = impact(&params, sigma_old, w0, v0);
        let m = impact(&params, -sigma_old, -w0, -v0);
        prop_assert_eq!(a.kind, m.kind);
        prop_assert_eq!(a.theta_dot, -m.theta_dot);
        prop_assert_eq!(a.slip_dot, -m.slip_dot);
        prop_assert_eq!(a.impulse_x_per_mass, -m.impulse_x_per_mass);
        prop_assert_eq!(a.impulse_y_per_mass, m.impulse_y_per_mass);
    }

    #[test]
    fn rocking_impact_with_enough_friction_is_exactly_housner(
        r in 0.05f64..3.0,
        // η > 0 needs sin²α < 2/3 (α < 0.955); e = 0 would be a flat landing.
        alpha in 0.02f64..0.95,
        restitution in prop::option::of(0.01f64..=1.0),
        sigma_old in sign(),
        w in 1e-3f64..8.0,
        margin in 1e-6f64..1.0,
    ) {
        let (b, h) = (2.0 * r * alpha.sin(), 2.0 * r * alpha.cos());
        // sin α, cos α of the block as built (B = 2R sin α, H = 2R cos α).
        let (sa, ca) = (b / b.hypot(h), h / b.hypot(h));
        let e = restitution.unwrap_or(1.0 - 1.5 * sa * sa);
        prop_assume!(e > 0.0); // e ≤ 0 has no single-corner solution (flat landing)
        // Stick needs |P_x|/P_y = R cos α (1 − e)|θ̇⁻| / (R sin α (1 + e)|θ̇⁻|) ≤ μs.
        let needed = ca * (1.0 - e) / (sa * (1.0 + e));
        let params =
            BlockParams::from_width_height(b, h, needed * (1.0 + margin) + 1e-12, 0.0, restitution)
                .unwrap();
        let w0 = -sigma_old * w;
        let out = impact(&params, sigma_old, w0, 0.0);
        prop_assert_eq!(out.kind, ImpactKind::Stick);
        // Housner: θ̇⁺ = e θ̇⁻ exactly. Our η = 1 − 1.5 sin²α and the engine's differ only by
        // the rounding of sin α (a few ulps of 1.5 sin²α ≤ 1.5): 1e-14 |θ̇⁻|.
        prop_assert!((out.theta_dot - e * w0).abs() <= 1e-14 * w0.abs(),
            "θ̇⁺ = {}, e θ̇⁻ = {}", out.theta_dot, e * w0);
        prop_assert_eq!(out.slip_dot, 0.0);

        // Just below the required friction the corner cannot stick.
        let weak =
            BlockParams::from_width_height(b, h, needed * (1.0 - margin.min(0.5)), 0.0, restitution);
        if let Ok(weak) = weak {
            prop_assert_ne!(impact(&weak, sigma_old, w0, 0.0).kind, ImpactKind::Stick);
        }
    }

    #[test]
    fn frictionless_impact_ratio_and_horizontal_momentum_are_exact(
        r in 0.05f64..3.0,
        alpha in 0.02f64..0.6,
        sigma_old in sign(),
        w in 1e-3f64..8.0,
        v0 in prop_oneof![Just(0.0), -4.0f64..4.0],
    ) {
        // μk = 0 (μs only needs to be positive and tiny). sin²α < 1/3 for α < 0.6155, so a
        // single-corner solution exists.
        let (sa, ca) = alpha.sin_cos();
        let params =
            BlockParams::from_width_height(2.0 * r * sa, 2.0 * r * ca, 1e-12, 0.0, None).unwrap();
        let w0 = -sigma_old * w;
        let out = impact(&params, sigma_old, w0, v0);
        let (b, h) = (params.base_width_m(), 2.0 * params.com_height_m);
        let v_before = centroid_velocity(b, h, sigma_old, w0, v0);
        let v_after = centroid_velocity(b, h, -sigma_old, out.theta_dot, out.slip_dot);
        let v_scale = r * w + v0.abs();
        // No horizontal impulse: the centroid's horizontal velocity is conserved.
        prop_assert!((v_after[0] - v_before[0]).abs() <= 1e-12 * v_scale);
        if v0 == 0.0 {
            let s2 = sa * sa;
            let ratio = (1.0 - 3.0 * s2) / (1.0 + 3.0 * s2);
            prop_assert!((out.theta_dot / w0 - ratio).abs() <= 1e-13,
                "θ̇⁺/θ̇⁻ = {} vs {ratio}", out.theta_dot / w0);
        }
    }
}

// =============================================================================================
// 10. End to end: every developer record through `simulate` and the CLI
// =============================================================================================

fn records_dir() -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../..")).join("tests/data/records")
}

/// A slender block that rocks, slide-rocks (μk > tan α = 0.25) and may overturn.
const ROCKING_BLOCK: (f64, f64, f64, f64) = (0.4, 1.6, 0.6, 0.5);
/// A squat block (tan α = 2 > μs) that can only slide: Newmark's rigid sliding block.
const SLIDING_BLOCK: (f64, f64, f64, f64) = (2.0, 1.0, 0.2, 0.15);
const T_EXTRA_S: f64 = 5.0;

/// Exact solution of the rigid sliding block (μs ≥ μk, μs < tan α: never rocks, §6–§7) under
/// a piecewise-linear input, interval by interval: rest while |ẍg| ≤ μs g' (exit at the root
/// of a linear function), else ü = −ẍg − μk s g' with both ẍg and g' linear, so u̇ is a
/// quadratic in time whose first zero ends the slide (found on its monotone pieces by Brent);
/// at a stop the block rests if |ẍg| ≤ μs g', else slides on against ẍg.
/// Returns (max |u|, final u) in m.
fn newmark_piecewise_linear(ax: &[f64], ay: &[f64], dt: f64, mu_s: f64, mu_k: f64) -> (f64, f64) {
    let (mut u, mut v, mut max_u) = (0.0_f64, 0.0_f64, 0.0_f64);
    let mut slip: Option<f64> = None; // direction s while sliding
    for i in 0..ax.len() - 1 {
        let (a0, ka) = (ax[i], (ax[i + 1] - ax[i]) / dt);
        let (g0, kg) = (G_MPS2 + ay[i], (ay[i + 1] - ay[i]) / dt);
        let accel = |t: f64| a0 + ka * t;
        let g_eff = |t: f64| g0 + kg * t;
        let mut t = 0.0;
        while t < dt {
            match slip {
                None => {
                    // Rest margins μs g' ∓ ẍg, linear: exit at the first one to go negative.
                    let margin = |t: f64, side: f64| mu_s * g_eff(t) - side * accel(t);
                    let mut exit = f64::INFINITY;
                    for side in [1.0, -1.0] {
                        let (m0, m1) = (margin(t, side), margin(dt, side));
                        if m1 < 0.0 {
                            exit = exit.min(if m0 < 0.0 {
                                t
                            } else {
                                t + (dt - t) * m0 / (m0 - m1)
                            });
                        }
                    }
                    if exit > dt {
                        t = dt;
                    } else {
                        t = exit;
                        slip = Some(-accel(t).signum());
                    }
                }
                Some(s) => {
                    // u̇(τ) = v + c1 (τ − t) + c2 (τ − t)², from ü = −(ẍg + μk s g').
                    let (t0, u0, v0) = (t, u, v);
                    let c1 = -(accel(t0) + mu_k * s * g_eff(t0));
                    let c2 = -0.5 * (ka + mu_k * s * kg);
                    let vel = |x: f64| v0 + c1 * (x - t0) + c2 * (x - t0) * (x - t0);
                    let disp = |x: f64| {
                        let d = x - t0;
                        u0 + v0 * d + c1 * d * d / 2.0 + c2 * d * d * d / 3.0
                    };
                    // Monotone pieces of u̇ on (t0, dt]: split at the vertex of the parabola.
                    let mut cuts = vec![t0];
                    if c2 != 0.0 {
                        let vertex = t0 - c1 / (2.0 * c2);
                        if vertex > t0 && vertex < dt {
                            cuts.push(vertex);
                        }
                    }
                    cuts.push(dt);
                    let mut stop = None;
                    for piece in cuts.windows(2) {
                        let (x0, x1) = (piece[0], piece[1]);
                        // At the start of a slide u̇ = 0 exactly and grows in direction s.
                        let f0 = if x0 == t0 && v0 == 0.0 {
                            1.0
                        } else {
                            s * vel(x0)
                        };
                        let f1 = s * vel(x1);
                        if f0 > 0.0 && f1 <= 0.0 {
                            let lo = if x0 == t0 && v0 == 0.0 {
                                x0 + 1e-15 * dt
                            } else {
                                x0
                            };
                            stop = Some(if s * vel(lo) <= 0.0 {
                                lo
                            } else {
                                physics_reference::brent(|x| s * vel(x), lo, x1, 1e-16)
                            });
                            break;
                        }
                    }
                    match stop {
                        None => {
                            u = disp(dt);
                            v = vel(dt);
                            t = dt;
                        }
                        Some(t1) => {
                            u = disp(t1);
                            v = 0.0;
                            t = t1;
                            let a1 = accel(t1);
                            slip = if a1.abs() <= mu_s * g_eff(t1) {
                                None
                            } else {
                                Some(-a1.signum())
                            };
                        }
                    }
                    max_u = max_u.max(u.abs());
                }
            }
        }
    }
    (max_u, u)
}

/// The input `simulate` integrates: the record followed by zeros over `t_extra`.
fn padded(record: &Record, t_extra: f64) -> (Vec<f64>, Vec<f64>) {
    let n_extra = (t_extra / record.dt_s).ceil() as usize;
    let mut ax = record.horizontal_mps2.clone();
    ax.extend(std::iter::repeat_n(0.0, n_extra));
    let mut ay = record
        .vertical_mps2
        .clone()
        .unwrap_or_else(|| vec![0.0; record.len()]);
    ay.extend(std::iter::repeat_n(0.0, n_extra));
    (ax, ay)
}

fn block((b, h, mu_s, mu_k): (f64, f64, f64, f64)) -> BlockParams {
    BlockParams::from_width_height(b, h, mu_s, mu_k, None).unwrap()
}

/// Runs the CLI; returns (success, stdout, stderr).
fn cli(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rockwatch"))
        .args(args)
        .output()
        .expect("cannot run the rockwatch binary");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn block_args((b, h, mu_s, mu_k): (f64, f64, f64, f64)) -> Vec<String> {
    vec![
        "--width".into(),
        b.to_string(),
        "--height".into(),
        h.to_string(),
        "--mu-s".into(),
        mu_s.to_string(),
        "--mu-k".into(),
        mu_k.to_string(),
        "--t-extra".into(),
        T_EXTRA_S.to_string(),
    ]
}

/// Structural equality of two JSON values, numbers to 4 ulps: serde_json's default float
/// parser (without the `float_roundtrip` feature) may be off by one ulp.
fn assert_json_eq(a: &serde_json::Value, b: &serde_json::Value, at: &str) {
    use serde_json::Value;
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 4.0 * f64::EPSILON * x.abs().max(y.abs()),
                "{at}: CLI {x} vs library {y}"
            );
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}: lengths differ");
            for (i, (x, y)) in x.iter().zip(y).enumerate() {
                assert_json_eq(x, y, &format!("{at}[{i}]"));
            }
        }
        (Value::Object(x), Value::Object(y)) => {
            assert_eq!(
                x.keys().collect::<Vec<_>>(),
                y.keys().collect::<Vec<_>>(),
                "{at}: keys differ"
            );
            for (k, v) in x {
                assert_json_eq(v, &y[k], &format!("{at}.{k}"));
            }
        }
        _ => assert_eq!(a, b, "{at}"),
    }
}

/// `simulate` and `rockwatch simulate --format json` on one record (optionally with a
/// vertical component): no error, finite and consistent outputs, identical summaries, and the
/// sliding block equal to the exact Newmark solution.
fn end_to_end(file: &str, vertical: Option<&str>, scale: f64) {
    let path = records_dir().join(file);
    let mut record = Record::read(&path).unwrap();
    if let Some(v) = vertical {
        record.attach_vertical(&records_dir().join(v)).unwrap();
    }
    record.scale(scale);
    // Without --rtol the CLI uses the library's default tolerance: the same computation.
    let options = SimulationOptions {
        t_extra_s: T_EXTRA_S,
        ..SimulationOptions::default()
    };

    // Rocking block: sanity of the summary.
    let params = block(ROCKING_BLOCK);
    let sim = simulate(params, &record, &options).unwrap();
    let s = &sim.summary;
    println!(
        "{file}: {:?}, max |θ|/α = {:.4}, {} impacts, max |u| = {:.4} m, {} modes",
        s.status,
        s.max_abs_theta_over_alpha,
        s.n_impacts,
        s.max_abs_slide,
        s.modes.len()
    );
    for x in [
        s.alpha,
        s.max_abs_theta,
        s.max_abs_theta_over_alpha,
        s.max_abs_slide,
        s.residual_slide,
        s.duration,
    ] {
        assert!(x.is_finite(), "non-finite output in {s:?}");
    }
    assert_eq!(s.overturned, s.status == Status::Overturned);
    assert_eq!(s.overturn_time.is_some(), s.overturned);
    assert!((s.alpha - (0.4f64 / 1.6).atan()).abs() < 1e-15);
    assert!((s.max_abs_theta_over_alpha - s.max_abs_theta / s.alpha).abs() < 1e-12);
    assert!(s.max_abs_theta <= std::f64::consts::FRAC_PI_2 + 1e-9);
    assert!(s.n_impacts_significant <= s.n_impacts);
    let full = (record.len() - 1) as f64 * record.dt_s + T_EXTRA_S;
    assert!(s.duration <= full + record.dt_s && s.duration > 0.0);
    assert_eq!(s.modes.first(), Some(&(0.0, Mode::Rest)));
    assert!(
        s.modes
            .windows(2)
            .all(|w| w[0].0 <= w[1].0 && w[0].1 != w[1].1),
        "mode list must be in time order, without repeats"
    );
    if s.overturned {
        let t = s.overturn_time.unwrap();
        assert!(s.exceeded_alpha && t >= 0.0 && t <= s.duration);
        assert_eq!(s.modes.last().map(|m| m.1), Some(Mode::Overturned));
    } else {
        // Standing at the end: |θ| never exceeded α unless reported, and the residual slide
        // is bounded by the maximum.
        assert_eq!(s.exceeded_alpha, s.max_abs_theta > s.alpha);
        assert!(s.residual_slide.abs() <= s.max_abs_slide + 1e-12);
        if s.status == Status::Ok {
            assert!((s.duration - full).abs() <= record.dt_s);
        }
    }

    // The CLI prints the same summary as JSON.
    let mut args: Vec<String> = vec![
        "simulate".into(),
        "--record".into(),
        path.display().to_string(),
    ];
    if let Some(v) = vertical {
        args.push("--vertical".into());
        args.push(records_dir().join(v).display().to_string());
    }
    args.extend(block_args(ROCKING_BLOCK));
    args.extend(["--scale".into(), scale.to_string()]);
    args.extend(["--format".into(), "json".into()]);
    let (ok, stdout, stderr) = cli(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(ok, "CLI failed: {stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("CLI output is not JSON");
    for key in [
        "status",
        "overturned",
        "overturn_time",
        "exceeded_alpha",
        "alpha",
        "max_abs_theta",
        "max_abs_theta_over_alpha",
        "max_abs_slide",
        "residual_slide",
        "n_impacts",
        "modes",
    ] {
        assert!(json.get(key).is_some(), "key {key} missing from {stdout}");
    }
    assert_json_eq(&json, &serde_json::to_value(s).unwrap(), "");

    // Sliding block: exact piecewise-linear Newmark solution.
    let (b, h, mu_s, mu_k) = SLIDING_BLOCK;
    assert!(mu_s < b / h);
    let sim = simulate(block(SLIDING_BLOCK), &record, &options).unwrap();
    let s = &sim.summary;
    assert_eq!(s.status, Status::Ok);
    assert_eq!(
        s.max_abs_theta, 0.0,
        "a block with μs < tan α must not rock"
    );
    let (ax, ay) = padded(&record, T_EXTRA_S);
    let (max_u, residual) = newmark_piecewise_linear(&ax, &ay, record.dt_s, mu_s, mu_k);
    println!(
        "{file}: sliding max |u| = {} (exact {max_u}), residual {} (exact {residual})",
        s.max_abs_slide, s.residual_slide
    );
    // Sliding under linear input has a polynomial (cubic) solution that DOPRI5 reproduces to
    // rounding, and every stick/slip time is a located root (1e-13 s): only rounding
    // accumulated over ≤ 2·10⁴ intervals separates the two, far below 1e-9 (relative).
    assert!(max_u > 1e-3, "the record should make the block slide");
    assert!(
        (s.max_abs_slide - max_u).abs() <= 1e-9 * max_u,
        "max |u| {} vs exact {max_u}",
        s.max_abs_slide
    );
    assert!(
        (s.residual_slide - residual).abs() <= 1e-9 * max_u,
        "residual {} vs exact {residual}",
        s.residual_slide
    );
}

#[test]
fn end_to_end_imperial_valley_el_centro_6() {
    end_to_end("RSN181_IMPVALL.H_H-E06230.AT2", None, 1.0);
}

#[test]
fn end_to_end_northridge_sylmar_converter() {
    end_to_end("RSN1084_NORTHR_SCS142.AT2", None, 1.0);
}

#[test]
fn end_to_end_northridge_rinaldi_228() {
    end_to_end("Rinaldi228.AT2", None, 1.0);
}

#[test]
fn end_to_end_northridge_rinaldi_with_vertical_up() {
    end_to_end("Rinaldi228.AT2", Some("RinaldiUP.AT2"), 1.0);
}

#[test]
fn end_to_end_landers_lucerne() {
    end_to_end("RSN879_LANDERS_LCN345.AT2", None, 1.0);
}

#[test]
fn end_to_end_chichi_tcu029() {
    // PGA 0.20 g: scaled so that the blocks move.
    end_to_end("RSN1476_CHICHI_TCU029-N.AT2", None, 3.0);
}

#[test]
fn end_to_end_kern_county_taft() {
    // PGA 0.16 g: scaled so that the blocks move.
    end_to_end("RSN15_KERN_TAF021.AT2", None, 4.0);
}

#[test]
fn end_to_end_northridge_port_hueneme() {
    // PGA 0.10 g: scaled so that the blocks move.
    end_to_end("RSN1059_NORTHR_PTH090.AT2", None, 5.0);
}

// ---------------------------------------------------------------------------------------------
// CLI: bad input fails with exactly one stderr line naming the file or parameter
// ---------------------------------------------------------------------------------------------

/// Runs `rockwatch simulate` on `record` with a valid block (or `block` if given) and checks
/// exit ≠ 0, nothing on stdout, exactly one stderr line, containing `needle`.
fn expect_cli_error(record: &Path, block: Option<(f64, f64, f64, f64)>, needle: &str) {
    let mut args: Vec<String> = vec![
        "simulate".into(),
        "--record".into(),
        record.display().to_string(),
    ];
    args.extend(block_args(block.unwrap_or(ROCKING_BLOCK)));
    args.extend(["--format".into(), "json".into()]);
    let (ok, stdout, stderr) = cli(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(!ok, "bad input accepted: {stdout}");
    assert!(stdout.is_empty(), "stdout on error: {stdout}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "expected one stderr line, got {stderr:?}");
    assert!(
        lines[0].contains(needle),
        "{:?} does not name {needle:?}",
        lines[0]
    );
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

const AT2_HEADER: &str = "PEER NGA STRONG MOTION DATABASE RECORD\nTest, 1/1/2000, Nowhere, 0\n\
                          ACCELERATION TIME SERIES IN UNITS OF G\n";

#[test]
fn cli_rejects_missing_record_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    expect_cli_error(
        &dir.path().join("no_such_record.AT2"),
        None,
        "no_such_record.AT2",
    );
}

#[test]
fn cli_rejects_malformed_at2_header_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!("{AT2_HEADER}this is not an NPTS line\n  .1E-01  .2E-01\n");
    let path = write(dir.path(), "bad_header.AT2", &text);
    expect_cli_error(&path, None, "bad_header.AT2");
}

#[test]
fn cli_rejects_at2_with_fewer_values_than_npts_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!("{AT2_HEADER}NPTS=      8, DT=   .0100 SEC,\n  .1E-01  .2E-01  .3E-01\n");
    let path = write(dir.path(), "short.AT2", &text);
    expect_cli_error(&path, None, "short.AT2");
}

#[test]
fn cli_rejects_nan_sample_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!("{AT2_HEADER}NPTS=      3, DT=   .0100 SEC,\n  .1E-01  NaN  .3E-01\n");
    let path = write(dir.path(), "nan.AT2", &text);
    expect_cli_error(&path, None, "nan.AT2");
    let path = write(dir.path(), "nan.csv", "t,ax\n0,0.1\n0.01,nan\n0.02,0.3\n");
    expect_cli_error(&path, None, "nan.csv");
}

#[test]
fn cli_rejects_non_uniform_csv_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "jitter.csv",
        "t,ax\n0,0.1\n0.01,0.2\n0.025,0.3\n0.03,0.1\n",
    );
    expect_cli_error(&path, None, "jitter.csv");
}

#[test]
fn cli_rejects_kinetic_friction_above_static_naming_the_parameter() {
    let record = records_dir().join("Rinaldi228.AT2");
    expect_cli_error(&record, Some((0.4, 1.6, 0.5, 0.6)), "mu_k");
}

/// A one-cycle sine just above the uplift threshold, sampled at 10 kHz: the block lifts a
/// little and settles through impacts located within the root tolerance of a sample's end.
/// The integrator once refused the rounding sliver left of that sample ("step size underflow
/// at t = 0.0001, h = 1.4e-20"); sampled at 1 kHz the same motion ran. Both rates must now
/// agree on the response (the motion is the same sine).
#[test]
fn a_finely_sampled_pulse_does_not_underflow_at_a_sample_end() {
    let (b, h, mu) = (0.4, 2.0, 0.8);
    let params = BlockParams::from_width_height(b, h, mu, mu, None).unwrap();
    let response = |dt: f64| {
        let (amp, f) = (2.0, 0.5);
        let n = (1.0 / f / dt).round() as usize + 1;
        let ax: Vec<f64> = (0..n)
            .map(|i| amp * (2.0 * std::f64::consts::PI * f * i as f64 * dt).sin())
            .collect();
        let record = Record {
            source: "one-sine".into(),
            dt_s: dt,
            horizontal_mps2: ax,
            vertical_mps2: None,
        };
        let options = SimulationOptions {
            t_extra_s: 6.0,
            ..SimulationOptions::default()
        };
        simulate(params, &record, &options)
            .unwrap_or_else(|e| panic!("dt {dt}: {e}"))
            .summary
    };
    let fine = response(1e-4);
    let coarse = response(1e-3);
    assert_eq!(fine.status, Status::Ok);
    assert!(!fine.overturned);
    // Uplift threshold g·b/h = 1.96 m/s² < 2.0: it rocks, a little.
    assert!(fine.max_abs_theta_over_alpha > 0.0 && fine.max_abs_theta_over_alpha < 0.01);
    // Linear interpolation of the sine at 1 kHz vs 10 kHz: the peaks agree closely.
    let (x, y) = (
        fine.max_abs_theta_over_alpha,
        coarse.max_abs_theta_over_alpha,
    );
    assert!((x - y).abs() <= 0.05 * y, "{x} vs {y}");
}
