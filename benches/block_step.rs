//! ns per block per input sample at 100 Hz for (a) a block at rest under weak motion,
//! (b) a rocking block, (c) a slide-rocking block, (d) a rocking general (asymmetric) body.
//! Run: `cargo bench --bench block_step`.
//! Criterion reports the time of one `advance` call (one input sample) and the throughput.
//! Before the timings it prints, for each moving case, how much the live engine's tolerance
//! (rtol 1e-9, atol 1e-12) moves the peaks against a 100× tighter reference (target ≤ 1e-6
//! relative): the speed is that of an integration whose peaks are right to that bound.

mod thread_time;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rockwatch_core::dynamics::{BlockOptions, BlockParams, GroundAccel, Mode, RigidBlock};
use std::hint::black_box;

const DT: f64 = 0.01; // 100 Hz
const N: usize = 1000; // samples per measured batch (10 s)

/// A sine ground acceleration (m/s²) of `amp_g` g at `f_hz`, sampled at 100 Hz.
fn sine(amp_g: f64, f_hz: f64, n: usize) -> Vec<GroundAccel> {
    (0..=n)
        .map(|i| {
            let t = i as f64 * DT;
            GroundAccel::horizontal(amp_g * 9.80665 * (2.0 * std::f64::consts::PI * f_hz * t).sin())
        })
        .collect()
}

fn run(block: &mut RigidBlock, input: &[GroundAccel]) {
    for w in input.windows(2) {
        block
            .advance(DT, w[0], w[1], |e| {
                black_box(e);
            })
            .expect("benchmark input is valid");
    }
}

/// Peak |θ|/α and peak |u| of `block` under `input` at the live tolerance and at a 100×
/// tighter one; prints their relative differences and returns the larger.
fn tolerance_effect(name: &str, block: &RigidBlock, input: &[GroundAccel]) -> f64 {
    let peaks = |options: BlockOptions| {
        let mut b = RigidBlock::new(*block.params(), options);
        // The same initial state as `block` (released or at rest).
        if block.theta_rad() != 0.0 || block.theta_dot() != 0.0 {
            b = RigidBlock::released(
                *block.params(),
                options,
                block.theta_rad(),
                block.theta_dot(),
            );
        }
        run(&mut b, input);
        (
            b.stats().max_abs_theta_over_alpha,
            b.stats().max_abs_slide_m,
        )
    };
    let live = BlockOptions::default();
    let tight = BlockOptions {
        tolerance: rockwatch_core::ode::Tolerance {
            rtol: live.tolerance.rtol / 100.0,
            atol: live.tolerance.atol / 100.0,
        },
        ..live
    };
    let (a, b) = (peaks(live), peaks(tight));
    let rel = |x: f64, y: f64| {
        if y == 0.0 {
            (x - y).abs()
        } else {
            ((x - y) / y).abs()
        }
    };
    let (d_theta, d_slide) = (rel(a.0, b.0), rel(a.1, b.1));
    println!(
        "tolerance effect {name}: peak |θ|/α {:.9} vs {:.9} at rtol/100 (relative {d_theta:.1e}), peak |u| {:.3e} m vs {:.3e} m (relative {d_slide:.1e}); target ≤ 1e-6",
        a.0, b.0, a.1, b.1
    );
    d_theta.max(d_slide)
}

/// This thread's CPU time so far (ns), None if unreadable.
fn thread_cpu_ns() -> Option<u64> {
    thread_time::run_and_wait_ns().map(|(run, _)| run)
}

/// Prints the CPU time (not wall time: on a shared machine the thread also waits for a CPU)
/// per 100 Hz sample of `block` under `input`, over 100 runs of the whole input.
fn cpu_time_per_sample(name: &str, block: &RigidBlock, input: &[GroundAccel]) {
    const RUNS: usize = 100;
    let Some(start) = thread_cpu_ns() else {
        println!("cpu time {name}: /proc/thread-self/schedstat unreadable");
        return;
    };
    for _ in 0..RUNS {
        let mut b = block.clone();
        run(&mut b, black_box(input));
        black_box(&b);
    }
    let ns = thread_cpu_ns().unwrap_or(start) - start;
    println!(
        "cpu time {name}: {:.0} ns per sample ({} samples; target ≤ 300 ns moving)",
        ns as f64 / (RUNS * (input.len() - 1)) as f64,
        RUNS * (input.len() - 1)
    );
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("block_step_100hz");
    group.throughput(Throughput::Elements(N as u64));

    // (a) At rest: a 1 m × 2 m block under 0.02 g at 2 Hz (threshold ≈ 0.5 g).
    let rest = RigidBlock::new(
        BlockParams::from_width_height(1.0, 2.0, 0.7, 0.5, None).expect("valid"),
        BlockOptions::default(),
    );
    let weak = sine(0.02, 2.0, N);
    group.bench_function("a_rest_weak_motion", |b| {
        b.iter_batched_ref(
            || rest.clone(),
            |blk| run(blk, &weak),
            criterion::BatchSize::SmallInput,
        )
    });

    // (b) Rocking: the seed's rocking block (R = 3.29 m, α = 11.31°) with perfectly elastic
    // impacts (restitution 1) released at 0.5 α under a 0.05 g, 0.5 Hz sine: it rocks all along.
    let rocking_params =
        BlockParams::from_width_height(1.2904, 6.4520, 1.5, 1.0, Some(1.0)).expect("valid");
    let rocking = RigidBlock::released(
        rocking_params,
        BlockOptions::default(),
        0.5 * rocking_params.alpha_rad,
        0.0,
    );
    let mild = sine(0.05, 0.5, N);
    {
        let mut check = rocking.clone();
        run(&mut check, &mild);
        assert_eq!(check.mode(), Mode::Rock, "benchmark (b) must stay rocking");
    }
    tolerance_effect("(b) rocking", &rocking, &mild);
    cpu_time_per_sample("(b) rocking", &rocking, &mild);
    group.bench_function("b_rocking", |b| {
        b.iter_batched_ref(
            || rocking.clone(),
            |blk| run(blk, &mild),
            criterion::BatchSize::SmallInput,
        )
    });

    // (c) Slide-rocking: a block with friction just above tan α = 0.3 (μs = 0.32, μk = 0.31)
    // under a 0.4 g, 1 Hz sine: it rocks with repeated slide-rock episodes (about 2 % of the
    // samples; slide-rock decelerates the rotation for μk ≈ tan α, spec §5, so it never lasts).
    // The figure is the mean over the whole 10 s window.
    let sr_params = BlockParams::from_width_height(0.6, 2.0, 0.32, 0.31, None).expect("valid");
    let sr = RigidBlock::new(sr_params, BlockOptions::default());
    let strong = sine(0.4, 1.0, N);
    let mut visited_slide_rock = false;
    {
        let mut check = sr.clone();
        for w in strong.windows(2) {
            check.advance(DT, w[0], w[1], |_| {}).expect("valid");
            visited_slide_rock |= check.mode() == Mode::SlideRock;
        }
        assert!(
            visited_slide_rock,
            "benchmark (c) must slide-rock (ended {:?})",
            check.mode()
        );
        assert_ne!(
            check.mode(),
            Mode::Overturned,
            "benchmark (c) must not overturn"
        );
    }
    tolerance_effect("(c) slide-rocking", &sr, &strong);
    cpu_time_per_sample("(c) slide-rocking", &sr, &strong);
    group.bench_function("c_slide_rocking", |b| {
        b.iter_batched_ref(
            || sr.clone(),
            |blk| run(blk, &strong),
            criterion::BatchSize::SmallInput,
        )
    });

    // (d) General body (docs/general-body.md): the seed block of (b) with its −x pivot moved
    // out (b₊ = 0.645 m as in (b), b₋ = 0.9 m, h = 3.226 m, ρ = 1.9 m), released at 0.5 α₊
    // under the mild sine of (b): rocking on both pivots with the per-pivot constants.
    // Compare with (b): the generalisation costs nothing per step.
    let body_params =
        BlockParams::from_body(0.645, 0.9, 3.226, 1.9, 1.5, 1.0, Some(1.0)).expect("valid");
    let body = RigidBlock::released(
        body_params,
        BlockOptions::default(),
        0.5 * body_params.plus.alpha_rad,
        0.0,
    );
    {
        let mut check = body.clone();
        run(&mut check, &mild);
        assert_eq!(check.mode(), Mode::Rock, "benchmark (d) must stay rocking");
    }
    tolerance_effect("(d) general body", &body, &mild);
    cpu_time_per_sample("(d) general body", &body, &mild);
    group.bench_function("d_general_body_rocking", |b| {
        b.iter_batched_ref(
            || body.clone(),
            |blk| run(blk, &mild),
            criterion::BatchSize::SmallInput,
        )
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
