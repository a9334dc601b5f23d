//! The part of the test harness that uses the shell's API (the rest is the crate
//! `rockwatch-test-harness`, which must not depend on the shell: the core's tests use it):
//! the Rinaldi record as `rockwatch replay` cuts it into packets, and a ROS 2 alert listener
//! drained.

// A module compiled into each test binary that declares it (11 binaries): 8 use only
// `rinaldi_packets` and one only `collect`; there the other is dead code. The two cannot move
// into the harness crate, whose public items would not be (see above).
#![allow(dead_code)]

use std::time::{Duration, Instant};

use rockwatch::replay::Traces;
use rockwatch::ros2::msg::PbrAlert;
use rockwatch::ros2::Ros2AlertListener;
use rockwatch_core::engine::AccelPacket;
use rockwatch_test_harness::fixtures::{rinaldi, rinaldi_azimuth, rinaldi_station};

/// The bundled Rinaldi record (228° + vertical) as station CI.RRS.00 would send it: 100 ms
/// packets, horizontal along azimuth 228° (the axis of the example catalogue's CI.RRS.00
/// blocks), followed by `tail_s` of quiet.
pub fn rinaldi_packets(tail_s: f64) -> Vec<AccelPacket> {
    Traces::from_record(&rinaldi(), rinaldi_azimuth()).packets(&rinaldi_station(), 100, tail_s)
}

/// Every alert a listener receives until none has come for `quiet`.
pub fn collect(listener: &mut Ros2AlertListener, quiet: Duration) -> Vec<PbrAlert> {
    let mut got = Vec::new();
    let mut last = Instant::now();
    while last.elapsed() < quiet {
        let batch = listener.recv(Duration::from_millis(100)).unwrap();
        if !batch.is_empty() {
            got.extend(batch);
            last = Instant::now();
        }
    }
    got
}
