//! Where packets come from, and what the engine made of each source's packets: a sender (a
//! replay, an acquisition process) learns from the node that every packet it sent was
//! processed, and how many were refused.
//!
//! A transport gives each sender it hears from a [`Source`] slot (`0..MAX_SOURCES`, reused
//! after a sender is forgotten) and hands the slot with each packet ([`Engine::process`]'s
//! [`Verdict`] is counted by the caller; [`ShardedEngine`] counts on its workers). The counts
//! are monotonic atomics, shared between the engine's threads and the transport's.
//!
//! [`Engine::process`]: super::Engine::process
//! [`ShardedEngine`]: super::ShardedEngine

use std::sync::atomic::{AtomicU64, Ordering};

/// Slots of a [`SourceTally`]: at most this many senders are told apart at once.
pub const MAX_SOURCES: usize = 1024;

/// A sender's slot in a [`SourceTally`] (`< MAX_SOURCES`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Source(u16);

impl Source {
    /// Slot `index`, None if not below [`MAX_SOURCES`].
    #[must_use]
    pub fn new(index: usize) -> Option<Source> {
        (index < MAX_SOURCES).then_some(Source(index as u16))
    }

    #[must_use]
    pub fn index(self) -> usize {
        usize::from(self.0)
    }
}

/// What the engine made of one packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Taken into its station's stream (its samples may still be dropped as already processed
    /// — duplicate, late or overlapping data: counted per station, `StreamCounters`, and per
    /// source, [`SourceCounts::dropped`]).
    Accepted,
    /// Of a station the engine does not monitor.
    Ignored,
    /// Refused whole: malformed station id, invalid samples, implausible values, or stamped
    /// ahead of the clock (counted and logged per station, as a notice).
    Refused,
}

/// What the engine made of one source's packets (monotonic counts).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SourceCounts {
    /// Packets processed, whatever the verdict.
    pub processed: u64,
    /// Of `processed`, packets refused whole ([`Verdict::Refused`]).
    pub refused: u64,
    /// Accepted packets whose samples were dropped, wholly or in part, because their station
    /// had processed them (or later data) already: duplicates, late packets, overlaps, and
    /// packets held beyond an undone forward jump. A packet partly overlapping keeps its new
    /// samples; it counts here for its old ones.
    pub dropped: u64,
}

impl SourceCounts {
    /// The counts since `base` (the counts of a reused slot when it was assigned).
    #[must_use]
    pub fn since(self, base: SourceCounts) -> SourceCounts {
        SourceCounts {
            processed: self.processed - base.processed,
            refused: self.refused - base.refused,
            dropped: self.dropped - base.dropped,
        }
    }
}

/// [`SourceCounts`] per [`Source`] (monotonic counts since the tally was made).
#[derive(Debug)]
pub struct SourceTally {
    processed: Box<[AtomicU64]>,
    refused: Box<[AtomicU64]>,
    dropped: Box<[AtomicU64]>,
}

impl Default for SourceTally {
    fn default() -> Self {
        let zeros = || (0..MAX_SOURCES).map(|_| AtomicU64::new(0)).collect();
        SourceTally {
            processed: zeros(),
            refused: zeros(),
            dropped: zeros(),
        }
    }
}

impl SourceTally {
    /// Counts one packet of `source` with its verdict.
    pub fn count(&self, source: Source, verdict: Verdict) {
        self.processed[source.index()].fetch_add(1, Ordering::Release);
        if verdict == Verdict::Refused {
            // Release: a reader that sees this refusal sees the packet processed too.
            self.refused[source.index()].fetch_add(1, Ordering::Release);
        }
    }

    /// Counts one packet of `source` whose samples were dropped as already processed (before
    /// [`SourceTally::count`] of the same packet, if it is dropped while it is processed: a
    /// reader that sees the packet processed then sees the drop too).
    pub fn count_dropped(&self, source: Source) {
        self.dropped[source.index()].fetch_add(1, Ordering::Release);
    }

    /// What the engine made of `source`'s packets since the tally was made. A reader of a
    /// reused slot subtracts what it read when the slot was assigned ([`SourceCounts::since`]).
    #[must_use]
    pub fn of(&self, source: Source) -> SourceCounts {
        // Refused before processed (counted after it): `refused` never looks larger than
        // `processed`. Dropped after processed (counted before it): a packet seen processed
        // has its drop seen too.
        let refused = self.refused[source.index()].load(Ordering::Acquire);
        let processed = self.processed[source.index()].load(Ordering::Acquire);
        let dropped = self.dropped[source.index()].load(Ordering::Acquire);
        SourceCounts {
            processed,
            refused,
            dropped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_source_counts_its_own_packets_and_refusals() {
        let tally = SourceTally::default();
        let (a, b) = (
            Source::new(0).unwrap(),
            Source::new(MAX_SOURCES - 1).unwrap(),
        );
        assert!(Source::new(MAX_SOURCES).is_none());
        tally.count(a, Verdict::Accepted);
        tally.count(a, Verdict::Refused);
        tally.count(a, Verdict::Ignored);
        tally.count(b, Verdict::Refused);
        tally.count_dropped(b);
        let counts = |processed, refused, dropped| SourceCounts {
            processed,
            refused,
            dropped,
        };
        assert_eq!(tally.of(a), counts(3, 1, 0));
        assert_eq!(tally.of(b), counts(1, 1, 1));
        assert_eq!(tally.of(Source::new(5).unwrap()), SourceCounts::default());
        assert_eq!(tally.of(b).since(counts(1, 0, 1)), counts(0, 1, 0));
    }
}
