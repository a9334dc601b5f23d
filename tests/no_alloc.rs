//! Architecture invariant: `RigidBlock::advance` never allocates, in any mode.
//! `allocation_counter` installs a counting global allocator for this test binary.

use rockwatch_core::dynamics::{
    BlockEvent, BlockOptions, BlockParams, GroundAccel, Mode, RigidBlock,
};

/// A two-cycle 1 Hz sine of `amp_g` g, then 8 s of quiet, at 100 Hz.
fn input(amp_g: f64) -> Vec<GroundAccel> {
    (0..=1000)
        .map(|i| {
            let t = i as f64 * 0.01;
            let a = if t < 2.0 {
                amp_g * 9.80665 * (2.0 * std::f64::consts::PI * 0.5 * t).sin()
            } else {
                0.0
            };
            GroundAccel::horizontal(a)
        })
        .collect()
}

#[test]
fn advance_does_not_allocate_in_any_mode() {
    // Three blocks that together visit every mode but flight: a slender one that rocks,
    // slide-rocks and overturns; a squat one on low friction that slides; and one whose
    // friction lies just above tan α, which slide-rocks (as in benches/block_step.rs).
    let cases = [
        (
            BlockParams::from_width_height(0.4, 2.0, 0.5, 0.45, None).unwrap(),
            0.6,
        ),
        (
            BlockParams::from_width_height(1.5, 1.5, 0.2, 0.15, None).unwrap(),
            0.4,
        ),
        (
            BlockParams::from_width_height(0.6, 2.0, 0.32, 0.31, None).unwrap(),
            0.4,
        ),
        // A general body (docs/general-body.md): asymmetric pivots, its own inertia.
        (
            BlockParams::from_body(0.12, 0.3, 0.9, 0.35, 0.5, 0.45, None).unwrap(),
            0.6,
        ),
    ];
    let mut visited = [false; 6];
    let mut blocks: Vec<(RigidBlock, Vec<GroundAccel>)> = cases
        .iter()
        .map(|(p, amp)| (RigidBlock::new(*p, BlockOptions::default()), input(*amp)))
        .collect();
    let info = allocation_counter::measure(|| {
        for (block, input) in &mut blocks {
            for w in input.windows(2) {
                block
                    .advance(0.01, w[0], w[1], |e| {
                        if let BlockEvent::ModeChange { to, .. } = e {
                            visited[to as usize] = true;
                        }
                    })
                    .unwrap();
            }
        }
    });
    // The counter itself works (else this test could not fail).
    let probe = allocation_counter::measure(|| {
        std::hint::black_box(vec![1u8; 8]);
    });
    assert!(probe.count_total > 0);
    assert_eq!(
        info.count_total, 0,
        "advance allocated {} times",
        info.count_total
    );
    for mode in [
        Mode::Slide,
        Mode::Rock,
        Mode::SlideRock,
        Mode::Overturned,
        Mode::Rest,
    ] {
        assert!(visited[mode as usize], "the test must exercise {mode}");
    }
}
