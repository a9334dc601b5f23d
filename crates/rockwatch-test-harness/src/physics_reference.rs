//! Independent numerical references for the physics tests (spec: shared/spec/block-dynamics.md).
//!
//! Nothing here calls the engine's equations: the quadrature, the root finder and the
//! absolute-frame Newton–Euler solve are written from scratch so that the tests compare the
//! engine against a second, differently formulated computation. The only engine items used
//! are the driver API (`RigidBlock::advance`) and the input/event types.

use nalgebra::{SMatrix, SVector};
use rockwatch_core::dynamics::{BlockEvent, GroundAccel, RigidBlock};

/// Standard gravity (m/s²), the gravity every `BlockParams` constructor uses.
pub const G_MPS2: f64 = 9.80665;

// ---------------------------------------------------------------------------------------------
// Quadrature
// ---------------------------------------------------------------------------------------------

/// Nodes and weights of the `n`-point Gauss–Legendre rule on [−1, 1], by Newton's method on
/// the three-term recurrence of the Legendre polynomials (nodes to machine precision).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n {
        // Tricomi's initial guess for the i-th largest root.
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut derivative = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let k = k as f64;
                let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            // p1 = P_n(x), p0 = P_{n−1}(x); P_n'(x) = n (x P_n − P_{n−1}) / (x² − 1).
            derivative = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / derivative;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        nodes[i] = x;
        weights[i] = 2.0 / ((1.0 - x * x) * derivative * derivative);
    }
    (nodes, weights)
}

/// Composite Gauss–Legendre (20 points per panel) of `f` over [a, b] with `panels` panels.
pub fn gauss_legendre_composite(f: &impl Fn(f64) -> f64, a: f64, b: f64, panels: usize) -> f64 {
    let (nodes, weights) = gauss_legendre(20);
    let h = (b - a) / panels as f64;
    let mut sum = 0.0;
    for k in 0..panels {
        let mid = a + (k as f64 + 0.5) * h;
        for (x, w) in nodes.iter().zip(&weights) {
            sum += w * f(mid + 0.5 * h * x);
        }
    }
    0.5 * h * sum
}

/// ∫ₐᵇ f for a smooth integrand: composite Gauss–Legendre, doubling the number of panels until
/// two successive values agree to 1e-14 (relative). Panics if that never happens, so a test
/// cannot pass on an unconverged reference.
pub fn integrate(f: impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let mut panels = 2;
    let mut previous = gauss_legendre_composite(&f, a, b, panels);
    while panels < 4096 {
        panels *= 2;
        let value = gauss_legendre_composite(&f, a, b, panels);
        if (value - previous).abs() <= 1e-14 * value.abs().max(1e-300) {
            return value;
        }
        previous = value;
    }
    panic!("quadrature did not converge on [{a}, {b}]: last value {previous}");
}

// ---------------------------------------------------------------------------------------------
// Root finding
// ---------------------------------------------------------------------------------------------

/// Brent's method (inverse quadratic interpolation, secant and bisection; Brent 1973,
/// "Algorithms for minimization without derivatives", ch. 4) for a root of `f` in [a, b],
/// where f(a) and f(b) have opposite signs; absolute tolerance `x_tol`.
pub fn brent(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, x_tol: f64) -> f64 {
    let (mut a, mut b) = (a, b);
    let (mut fa, mut fb) = (f(a), f(b));
    assert!(
        fa * fb <= 0.0,
        "brent: root not bracketed: f({a}) = {fa}, f({b}) = {fb}"
    );
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    let (mut c, mut fc) = (a, fa);
    let mut d = b - a;
    let mut e = d;
    for _ in 0..300 {
        if fb * fc > 0.0 {
            c = a;
            fc = fa;
            d = b - a;
            e = d;
        }
        if fc.abs() < fb.abs() {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        let tol = 2.0 * f64::EPSILON * b.abs() + 0.5 * x_tol;
        let m = 0.5 * (c - b);
        if m.abs() <= tol || fb == 0.0 {
            return b;
        }
        if e.abs() >= tol && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q);
            if a == c {
                p = 2.0 * m * s;
                q = 1.0 - s;
            } else {
                let qa = fa / fc;
                let r = fb / fc;
                p = s * (2.0 * m * qa * (qa - r) - (b - a) * (r - 1.0));
                q = (qa - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if p > 0.0 {
                q = -q;
            }
            p = p.abs();
            if 2.0 * p < (3.0 * m * q - (tol * q).abs()).min((e * q).abs()) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = d;
            }
        } else {
            d = m;
            e = d;
        }
        a = b;
        fa = fb;
        b += if d.abs() > tol { d } else { tol.copysign(m) };
        fb = f(b);
    }
    panic!("brent did not converge");
}

/// The first root of `f` in (a, b]: scans with step `scan_s` from just after `a` (f(a) itself
/// is not looked at: it is often an exact zero, e.g. a velocity at the start of a slide) for
/// the first sign change, then refines with [`brent`]. `None` if there is no sign change.
pub fn first_root(f: impl Fn(f64) -> f64, a: f64, b: f64, scan_s: f64, x_tol: f64) -> Option<f64> {
    let mut t0 = a + 1e-6 * scan_s;
    let mut f0 = f(t0);
    while t0 < b {
        let t1 = (t0 + scan_s).min(b);
        let f1 = f(t1);
        if f0 * f1 <= 0.0 {
            return Some(brent(&f, t0, t1, x_tol));
        }
        t0 = t1;
        f0 = f1;
    }
    None
}

// ---------------------------------------------------------------------------------------------
// Absolute-frame Newton–Euler solve (a formulation independent of the spec's eqs. R1–SR3)
// ---------------------------------------------------------------------------------------------

/// Accelerations and contact forces of a block on one corner, per unit mass.
#[derive(Debug, Clone, Copy)]
pub struct NewtonEuler {
    /// θ̈ (rad/s², clockwise +).
    pub theta_ddot: f64,
    /// Horizontal acceleration of the pivot corner relative to the ground (m/s²).
    pub slip_ddot: f64,
    /// F/m (m/s²), horizontal contact force at the pivot.
    pub friction_per_mass: f64,
    /// N/m (m/s²), vertical contact force at the pivot.
    pub normal_per_mass: f64,
}

/// How the pivot corner is constrained horizontally.
#[derive(Debug, Clone, Copy)]
pub enum Pivot {
    /// No slip: the corner's horizontal acceleration relative to the ground is zero.
    Stuck,
    /// Slipping in direction `s` (±1) with Coulomb friction F = −μk s N.
    Slipping { mu_k: f64, s: f64 },
}

/// Solves the planar Newton–Euler equations of a B×H block (unit mass) in the ground frame
/// with the centroid accelerations, θ̈, F, N and the corner's horizontal acceleration ü as
/// unknowns (a 6×6 linear system, LU with partial pivoting):
///
/// * body frame: centroid at the origin, pivot corner at ρ = (σB/2, −H/2); ground-frame
///   offset of the corner d = Q(θ)ρ with Q the *clockwise* rotation by θ, so that
///   the corner's acceleration is r̈_c + θ̈ Q'(θ)ρ − θ̇² Q(θ)ρ;
/// * translation: ẍ_c + ẍg = F, ÿ_c + ÿg = N − g (absolute = relative + ground);
/// * rotation: I_c θ̈ = clockwise moment of (F, N) applied at d = −(d_x N − d_y F),
///   I_c = (B² + H²)/12;
/// * contact: corner vertical acceleration 0, horizontal acceleration ü;
/// * pivot law: ü = 0 (stuck) or F + μk s N = 0 (slipping).
#[allow(clippy::too_many_arguments)]
pub fn newton_euler(
    width_m: f64,
    height_m: f64,
    pivot: Pivot,
    sigma: f64,
    theta: f64,
    theta_dot: f64,
    ground: GroundAccel,
    gravity_mps2: f64,
) -> NewtonEuler {
    let body = Body {
        b_plus_m: 0.5 * width_m,
        b_minus_m: 0.5 * width_m,
        com_height_m: 0.5 * height_m,
        centroidal_inertia_m2: (width_m * width_m + height_m * height_m) / 12.0,
    };
    newton_euler_body(&body, pivot, sigma, theta, theta_dot, ground, gravity_mps2)
}

/// A planar body with a flat base (docs/general-body.md), per unit mass: pivots at
/// (+b₊, −h) and (−b₋, −h) from the centre of mass, centroidal inertia I_c/m.
#[derive(Debug, Clone, Copy)]
pub struct Body {
    pub b_plus_m: f64,
    pub b_minus_m: f64,
    pub com_height_m: f64,
    /// I_c/m = ρ² (m²).
    pub centroidal_inertia_m2: f64,
}

/// [`newton_euler`] for a general [`Body`]: the pivot σ sits at ρ = (σ b_σ, −h) from the
/// centre of mass in the body frame; everything else is the same 6×6 solve.
#[allow(clippy::too_many_arguments)]
pub fn newton_euler_body(
    body: &Body,
    pivot: Pivot,
    sigma: f64,
    theta: f64,
    theta_dot: f64,
    ground: GroundAccel,
    gravity_mps2: f64,
) -> NewtonEuler {
    let b = if sigma > 0.0 {
        body.b_plus_m
    } else {
        body.b_minus_m
    };
    let rho = [sigma * b, -body.com_height_m];
    let (s, c) = theta.sin_cos();
    // Clockwise rotation Q = [[c, s], [−s, c]] and its derivative dQ/dθ = [[−s, c], [−c, −s]].
    let d = [c * rho[0] + s * rho[1], -s * rho[0] + c * rho[1]];
    let dd = [-s * rho[0] + c * rho[1], -c * rho[0] - s * rho[1]];
    let inertia = body.centroidal_inertia_m2;
    let w2 = theta_dot * theta_dot;
    // Unknowns z = [ẍ_c, ÿ_c, θ̈, F, N, ü] (relative centroid accelerations, per unit mass).
    #[rustfmt::skip]
    let mut a = SMatrix::<f64, 6, 6>::from_row_slice(&[
        1.0, 0.0, 0.0,     -1.0,  0.0,  0.0,
        0.0, 1.0, 0.0,      0.0, -1.0,  0.0,
        0.0, 0.0, inertia, -d[1],  d[0], 0.0,
        1.0, 0.0, dd[0],    0.0,  0.0, -1.0,
        0.0, 1.0, dd[1],    0.0,  0.0,  0.0,
        0.0, 0.0, 0.0,      0.0,  0.0,  0.0,
    ]);
    match pivot {
        Pivot::Stuck => a[(5, 5)] = 1.0,
        Pivot::Slipping { mu_k, s } => {
            a[(5, 3)] = 1.0;
            a[(5, 4)] = mu_k * s;
        }
    }
    let b = SVector::<f64, 6>::from_row_slice(&[
        -ground.horizontal_mps2,
        -ground.vertical_mps2 - gravity_mps2,
        0.0,
        w2 * d[0],
        w2 * d[1],
        0.0,
    ]);
    let z = a.lu().solve(&b).expect("Newton–Euler system is singular");
    NewtonEuler {
        theta_ddot: z[2],
        slip_ddot: z[5],
        friction_per_mass: z[3],
        normal_per_mass: z[4],
    }
}

/// Acceleration scale of a state (m/s²): the sum of the magnitudes of the terms that enter
/// the forces. A 6×6 LU solve with O(1) condition number (the rows are scaled to unit mass
/// and lengths of order R) is accurate to ~1e-15 of this scale; 1e-12 leaves a wide margin.
pub fn accel_scale(r_m: f64, theta_dot: f64, ground: GroundAccel) -> f64 {
    G_MPS2 + ground.horizontal_mps2.abs() + ground.vertical_mps2.abs() + r_m * theta_dot.powi(2)
}

// ---------------------------------------------------------------------------------------------
// Driving the engine with a piecewise-linear input
// ---------------------------------------------------------------------------------------------

/// Feeds `block` the piecewise-linear ground acceleration through `knots` (t (s), accel),
/// starting at the block's current time (which must equal the first knot's time), each
/// segment split into intervals of at most `max_interval_s`. Returns every event, in order.
pub fn drive(
    block: &mut RigidBlock,
    knots: &[(f64, GroundAccel)],
    max_interval_s: f64,
) -> Vec<BlockEvent> {
    let mut events = Vec::new();
    for pair in knots.windows(2) {
        let ((t0, a0), (t1, a1)) = (pair[0], pair[1]);
        let n = ((t1 - t0) / max_interval_s).ceil().max(1.0) as usize;
        let dt = (t1 - t0) / n as f64;
        for k in 0..n {
            let from = a0.lerp(a1, k as f64 / n as f64);
            let to = a0.lerp(a1, (k + 1) as f64 / n as f64);
            block
                .advance(dt, from, to, |e| events.push(e))
                .unwrap_or_else(|e| panic!("advance failed at t = {}: {e}", block.time_s()));
        }
    }
    events
}

/// Horizontal-only ground acceleration (m/s²).
pub fn horizontal(a_mps2: f64) -> GroundAccel {
    GroundAccel::horizontal(a_mps2)
}

/// Knots of a near-rectangular horizontal pulse: 0 → `a` over `ramp_s`, held until `t_d`,
/// back to 0 over `ramp_s`, then 0 until `t_end`.
pub fn rectangular_pulse(
    a_mps2: f64,
    t_d: f64,
    ramp_s: f64,
    t_end: f64,
) -> Vec<(f64, GroundAccel)> {
    vec![
        (0.0, horizontal(0.0)),
        (ramp_s, horizontal(a_mps2)),
        (t_d, horizontal(a_mps2)),
        (t_d + ramp_s, horizontal(0.0)),
        (t_end, horizontal(0.0)),
    ]
}
