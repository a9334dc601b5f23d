//! The iceoryx2 input's counters: what it received, submitted and rejected, sequence gaps,
//! errors, dead nodes cleaned and wake-ups ([`IoxInputStats`], [`IoxStatsHandle`]).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Counts of what the input did (snapshot of [`IoxInput::stats`](super::IoxInput::stats)).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct IoxInputStats {
    /// Samples taken from the subscriber.
    pub received: u64,
    /// Packets handed to the engine (which checks their values, as for every transport).
    pub submitted: u64,
    /// Rejected: header `sample_count` ≠ payload length.
    pub rejected_count_mismatch: u64,
    /// Rejected: station bytes not NUL-padded UTF-8. (A station field that is text but not
    /// `NET.STA.LOC` is refused by the node as on every transport: `InputTotals`'
    /// `malformed_station_packets`.)
    pub rejected_station: u64,
    /// Rejected: unknown flags, non-zero reserved field, or more samples than the engine takes.
    pub rejected_structure: u64,
    /// Packets missing according to the per-station sequence numbers (overflow or sender loss).
    pub sequence_gaps: u64,
    /// Receive errors reported by iceoryx2.
    pub receive_errors: u64,
    /// Dead iceoryx2 nodes cleaned up by this input.
    pub dead_nodes_cleaned: u64,
    /// Times the input was drained (readiness of its listener, and the event loop's periodic
    /// safety-net drain).
    pub wakeups: u64,
}

/// The input's counters, indexed by the constants below (in the order of [`IoxInputStats`]).
#[derive(Debug, Default)]
pub(super) struct Counters([AtomicU64; 9]);

impl Counters {
    pub(super) fn add(&self, index: usize, n: u64) {
        self.0[index].fetch_add(n, Ordering::Relaxed);
    }
    pub(super) fn snapshot(&self) -> IoxInputStats {
        let g = |i: usize| self.0[i].load(Ordering::Relaxed);
        IoxInputStats {
            received: g(0),
            submitted: g(1),
            rejected_count_mismatch: g(2),
            rejected_station: g(3),
            rejected_structure: g(4),
            sequence_gaps: g(5),
            receive_errors: g(6),
            dead_nodes_cleaned: g(7),
            wakeups: g(8),
        }
    }
}

pub(super) const RECEIVED: usize = 0;
pub(super) const SUBMITTED: usize = 1;
pub(super) const REJ_COUNT: usize = 2;
pub(super) const REJ_STATION: usize = 3;
pub(super) const REJ_STRUCTURE: usize = 4;
pub(super) const GAPS: usize = 5;
pub(super) const RECV_ERRORS: usize = 6;
pub(super) const DEAD_NODES: usize = 7;
pub(super) const WAKEUPS: usize = 8;

/// A thread-safe view of an [`IoxInput`](super::IoxInput)'s counters (for tests, benchmarks and logs).
#[derive(Debug, Clone)]
pub struct IoxStatsHandle(pub(super) Arc<Counters>);

impl IoxStatsHandle {
    /// Counters so far.
    #[must_use]
    pub fn stats(&self) -> IoxInputStats {
        self.0.snapshot()
    }
}
