//! Dormand–Prince 5(4) explicit Runge–Kutta integrator with adaptive step size and
//! dense output, generic over the state dimension `N`.
//!
//! Written here (rather than taken from a crate) because the block engine needs three things
//! together that the Rust ODE crates we looked at (ode_solvers, russell_ode, diffsol) do not
//! offer at once: a caller-driven *single step* API (so events are located and the mode switched
//! between steps), the continuous extension of every accepted step (for exact event location),
//! and no heap allocation per step. The coefficients and the continuous extension are those of
//! Hairer, Nørsett & Wanner, *Solving ODEs I*, §II.5–II.6 (the `DOPRI5` code).
//!
//! Architecture invariant: nothing in this module allocates; states are stack `SVector`s.

use nalgebra::SVector;

/// A first-order system `y' = f(t, y)`.
pub trait OdeSystem<const N: usize> {
    /// The derivative at time `t` and state `y`.
    fn derivative(&self, t: f64, y: &SVector<f64, N>) -> SVector<f64, N>;

    /// The derivative at the end `(t, y)` of a step that is then accepted or rejected (the
    /// last stage of [`Dopri5::step`], reused as the next step's first): the same value as
    /// [`OdeSystem::derivative`]; a system may keep what it computed there (e.g. for event
    /// functions evaluated at the step's end).
    #[inline]
    fn derivative_at_step_end(&self, t: f64, y: &SVector<f64, N>) -> SVector<f64, N> {
        self.derivative(t, y)
    }
}

/// Mixed error tolerance: a step is accepted when the RMS over components of
/// `err_i / (atol + rtol·max(|y0_i|, |y1_i|))` is at most 1.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Tolerance {
    /// Relative tolerance (dimensionless).
    pub rtol: f64,
    /// Absolute tolerance (in the units of each state component).
    pub atol: f64,
}

impl Default for Tolerance {
    fn default() -> Self {
        Tolerance {
            rtol: 1e-9,
            atol: 1e-12,
        }
    }
}

/// Why the integrator gave up.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum OdeError {
    /// The step size fell below the resolution of `t`: the problem is too stiff or singular.
    #[error("step size underflow at t = {t} (h = {h})")]
    StepSizeUnderflow { t: f64, h: f64 },
    /// The derivative was not finite.
    #[error("non-finite derivative at t = {t}")]
    NonFinite { t: f64 },
}

/// One accepted step `[t0, t0 + h]` with its continuous extension (4th-order accurate,
/// exact at both ends).
#[derive(Debug, Clone, Copy)]
pub struct DenseStep<const N: usize> {
    /// Start time of the step.
    pub t0: f64,
    /// Step length (> 0).
    pub h: f64,
    /// State at `t0 + h`.
    pub y1: SVector<f64, N>,
    coefficients: [SVector<f64, N>; 5],
}

impl<const N: usize> DenseStep<N> {
    /// End time of the step.
    #[must_use]
    pub fn t1(&self) -> f64 {
        self.t0 + self.h
    }

    /// The interpolated state at `t` (meant for `t0 ≤ t ≤ t0 + h`).
    #[must_use]
    pub fn eval(&self, t: f64) -> SVector<f64, N> {
        let s = (t - self.t0) / self.h;
        let s1 = 1.0 - s;
        let [r1, r2, r3, r4, r5] = &self.coefficients;
        r1 + (r2 + (r3 + (r4 + r5 * s1) * s) * s1) * s
    }
}

/// Dormand–Prince 5(4) stepper. Keeps the step-size suggestion and the FSAL derivative between
/// calls; call [`Dopri5::reset`] whenever the right-hand side changes discontinuously (a mode
/// switch or an impact), because the stored derivative is then stale.
#[derive(Debug, Clone, Copy)]
pub struct Dopri5<const N: usize> {
    /// Error tolerance.
    pub tolerance: Tolerance,
    h_next: f64,
    fsal: Option<SVector<f64, N>>,
    /// Number of accepted steps since creation.
    pub accepted_steps: u64,
    /// Number of rejected step attempts since creation.
    pub rejected_steps: u64,
}

// Butcher tableau of Dormand & Prince (1980).
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
// Error estimate coefficients: 5th-order minus 4th-order weights.
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
// Continuous extension (Hairer's DOPRI5 `contd5`).
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

impl<const N: usize> Dopri5<N> {
    /// A stepper with the given tolerance; the first step tries `initial_step`.
    #[must_use]
    pub fn new(tolerance: Tolerance, initial_step: f64) -> Self {
        Dopri5 {
            tolerance,
            h_next: initial_step,
            fsal: None,
            accepted_steps: 0,
            rejected_steps: 0,
        }
    }

    /// Forgets the stored derivative (call after any discontinuity of the right-hand side or
    /// of the state) and sets the next trial step to at most `initial_step`.
    /// The step size the next step will try first (s).
    #[must_use]
    pub fn next_step(&self) -> f64 {
        self.h_next
    }

    /// True when the stepper holds an FSAL derivative from its last step (none after
    /// [`Dopri5::new`] or [`Dopri5::reset`]).
    #[must_use]
    pub fn has_stored_derivative(&self) -> bool {
        self.fsal.is_some()
    }

    pub fn reset(&mut self, initial_step: f64) {
        self.fsal = None;
        self.h_next = self.h_next.min(initial_step);
    }

    /// Takes one accepted step from `(t, y)` towards `t_end` (never past it), shrinking the step
    /// until the error estimate passes.
    pub fn step<S: OdeSystem<N>>(
        &mut self,
        system: &S,
        t: f64,
        y: &SVector<f64, N>,
        t_end: f64,
    ) -> Result<DenseStep<N>, OdeError> {
        self.step_leading(system, t, y, t_end)
    }

    /// As [`Dopri5::step`] on a state of `N` components whose last `N − M` have a zero
    /// derivative, integrating only the first `M` (`system`, `y`): the others stay as they
    /// are and add exactly 0 to the error norm, which still averages over `N` components, so
    /// the steps, the values and the stored derivative are bit for bit those of
    /// [`Dopri5::step`] on the full state (with the last components of `y1` and of the dense
    /// output equal to the state's plus 0.0). A system with a constant part (a rocking
    /// block's slip) thus costs the arithmetic of its moving part only.
    pub fn step_leading<const M: usize, S: OdeSystem<M>>(
        &mut self,
        system: &S,
        t: f64,
        y: &SVector<f64, M>,
        t_end: f64,
    ) -> Result<DenseStep<M>, OdeError> {
        debug_assert!(M <= N);
        let k1 = match &self.fsal {
            Some(k) => SVector::<f64, M>::from_fn(|i, _| k[i]),
            None => system.derivative(t, y),
        };
        if !k1.iter().all(|v| v.is_finite()) {
            return Err(OdeError::NonFinite { t });
        }
        let remaining = t_end - t;
        let underflow = 4.0 * f64::EPSILON * t.abs().max(t_end.abs()).max(1e-300);
        if remaining > 0.0 && remaining <= underflow {
            // What is left of the interval is a rounding sliver (an event located within the
            // root tolerance of t_end leaves one): cross it with one Euler step, whose error,
            // O(remaining²) ≲ 10⁻³⁰, is below any tolerance, instead of failing on a step
            // smaller than t can resolve. The stored derivative is dropped (recomputed next).
            let ydiff = k1 * remaining;
            let y1 = y + ydiff;
            self.fsal = None;
            let zero = SVector::<f64, M>::zeros();
            return Ok(DenseStep {
                t0: t,
                h: remaining,
                y1,
                coefficients: [*y, ydiff, zero, zero, zero],
            });
        }
        let mut h = self.h_next.min(remaining);
        loop {
            // A step that would leave a sliver shorter than 1 % of h is stretched to t_end.
            if remaining - h < 0.01 * h {
                h = remaining;
            }
            if h <= underflow {
                return Err(OdeError::StepSizeUnderflow { t, h });
            }
            let k2 = system.derivative(t + C2 * h, &(y + k1 * (h * A21)));
            let k3 = system.derivative(t + C3 * h, &(y + (k1 * A31 + k2 * A32) * h));
            let k4 = system.derivative(t + C4 * h, &(y + (k1 * A41 + k2 * A42 + k3 * A43) * h));
            let k5 = system.derivative(
                t + C5 * h,
                &(y + (k1 * A51 + k2 * A52 + k3 * A53 + k4 * A54) * h),
            );
            let t1 = if h == remaining { t_end } else { t + h };
            let k6 = system.derivative(
                t1,
                &(y + (k1 * A61 + k2 * A62 + k3 * A63 + k4 * A64 + k5 * A65) * h),
            );
            let y1 = y + (k1 * A71 + k3 * A73 + k4 * A74 + k5 * A75 + k6 * A76) * h;
            let k7 = system.derivative_at_step_end(t1, &y1);
            let err_vec = (k1 * E1 + k3 * E3 + k4 * E4 + k5 * E5 + k6 * E6 + k7 * E7) * h;

            let tol = self.tolerance;
            let mut sum = 0.0;
            for i in 0..M {
                let scale = tol.atol + tol.rtol * y[i].abs().max(y1[i].abs());
                let e = err_vec[i] / scale;
                sum += e * e;
            }
            let err = (sum / N as f64).sqrt();
            if !err.is_finite() {
                // Non-finite stage: shrink hard and retry.
                self.rejected_steps += 1;
                h *= 0.1;
                continue;
            }
            if err <= 1.0 {
                let factor = if err == 0.0 {
                    5.0
                } else {
                    (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
                };
                self.h_next = h * factor;
                self.fsal = Some(SVector::<f64, N>::from_fn(
                    |i, _| {
                        if i < M {
                            k7[i]
                        } else {
                            0.0
                        }
                    },
                ));
                self.accepted_steps += 1;
                let ydiff = y1 - y;
                let bspl = k1 * h - ydiff;
                let coefficients = [
                    *y,
                    ydiff,
                    bspl,
                    ydiff - k7 * h - bspl,
                    (k1 * D1 + k3 * D3 + k4 * D4 + k5 * D5 + k6 * D6 + k7 * D7) * h,
                ];
                return Ok(DenseStep {
                    t0: t,
                    h: t1 - t,
                    y1,
                    coefficients,
                });
            }
            self.rejected_steps += 1;
            h *= (0.9 * err.powf(-0.2)).clamp(0.2, 1.0);
        }
    }
}

/// Locates a root of `g` in `[a, b]` where `g(a) > 0 ≥ g(b)` by the Illinois variant of
/// regula falsi, to an absolute time tolerance `t_tol`. Returns the bracket end on the
/// `g ≤ 0` side, so that the event has certainly happened at the returned time.
pub fn locate_root(
    mut g: impl FnMut(f64) -> f64,
    mut a: f64,
    mut ga: f64,
    mut b: f64,
    mut gb: f64,
    t_tol: f64,
) -> f64 {
    let mut side = 0i8;
    for _ in 0..200 {
        if b - a <= t_tol {
            break;
        }
        let mut c = (a * gb - b * ga) / (gb - ga);
        if !(c > a && c < b) {
            c = 0.5 * (a + b);
        }
        let gc = g(c);
        if gc > 0.0 {
            a = c;
            ga = gc;
            if side == 1 {
                gb *= 0.5;
            }
            side = 1;
        } else {
            b = c;
            gb = gc;
            if side == -1 {
                ga *= 0.5;
            }
            side = -1;
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    /// Harmonic oscillator y'' = −ω² y.
    struct Harmonic(f64);
    impl OdeSystem<2> for Harmonic {
        fn derivative(&self, _t: f64, y: &Vector2<f64>) -> Vector2<f64> {
            Vector2::new(y[1], -self.0 * self.0 * y[0])
        }
    }

    fn integrate(tol: Tolerance, t_end: f64) -> (Vector2<f64>, u64) {
        let sys = Harmonic(2.0);
        let mut stepper = Dopri5::new(tol, 1e-3);
        let (mut t, mut y) = (0.0, Vector2::new(1.0, 0.0));
        while t < t_end {
            let step = stepper.step(&sys, t, &y, t_end).unwrap();
            t = step.t1();
            y = step.y1;
        }
        (y, stepper.accepted_steps)
    }

    #[test]
    fn harmonic_oscillator_matches_cos_to_tolerance() {
        // Global error of a 5th-order method with rtol 1e-10 over ~3 periods stays well below 1e-8.
        let (y, _) = integrate(
            Tolerance {
                rtol: 1e-10,
                atol: 1e-12,
            },
            10.0,
        );
        assert!((y[0] - (20.0f64).cos()).abs() < 1e-8, "{}", y[0]);
        assert!((y[1] + 2.0 * (20.0f64).sin()).abs() < 2e-8, "{}", y[1]);
    }

    #[test]
    fn step_count_scales_as_fifth_root_of_tolerance() {
        // For a 5th-order pair, steps ∝ tol^(-1/5): tightening by 1e5 multiplies steps by ≈ 10.
        let (_, n_loose) = integrate(
            Tolerance {
                rtol: 1e-6,
                atol: 1e-9,
            },
            10.0,
        );
        let (_, n_tight) = integrate(
            Tolerance {
                rtol: 1e-11,
                atol: 1e-14,
            },
            10.0,
        );
        let ratio = n_tight as f64 / n_loose as f64;
        assert!((6.0..16.0).contains(&ratio), "ratio {ratio}");
    }

    #[test]
    fn dense_output_is_fourth_order_accurate_inside_a_step() {
        let sys = Harmonic(1.0);
        let mut stepper = Dopri5::new(
            Tolerance {
                rtol: 1.0,
                atol: 1.0,
            },
            0.1,
        );
        let step = stepper
            .step(&sys, 0.0, &Vector2::new(1.0, 0.0), 0.1)
            .unwrap();
        for i in 0..=10 {
            let t = 0.01 * i as f64;
            // Interpolation error O(h^5) with h = 0.1: ~1e-5 · small constant.
            assert!((step.eval(t)[0] - t.cos()).abs() < 1e-7, "t={t}");
        }
        assert_eq!(step.eval(0.0)[0], 1.0);
    }

    #[test]
    fn exact_for_quartic_polynomials() {
        // y' = 4t³ is integrated exactly by a 5th-order method.
        struct Quartic;
        impl OdeSystem<1> for Quartic {
            fn derivative(&self, t: f64, _y: &SVector<f64, 1>) -> SVector<f64, 1> {
                SVector::<f64, 1>::new(4.0 * t * t * t)
            }
        }
        let mut stepper = Dopri5::new(Tolerance::default(), 0.5);
        let step = stepper
            .step(&Quartic, 0.0, &SVector::<f64, 1>::new(0.0), 0.5)
            .unwrap();
        assert!((step.y1[0] - 0.0625).abs() < 1e-15);
    }

    #[test]
    fn root_is_located_to_tolerance() {
        let root = locate_root(|t| 1.0 - t * t, 0.0, 1.0, 2.0, -3.0, 1e-14);
        assert!((root - 1.0).abs() < 1e-13);
        assert!(1.0 - root * root <= 0.0);
    }
}
