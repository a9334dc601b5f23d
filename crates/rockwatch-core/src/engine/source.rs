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
    /// Taken into its station's stream (its samples may still be dropped as duplicate or late:
    /// those are counted per station, `StreamCounters`).
    Accepted,
    /// Of a station the engine does not monitor.
    Ignored,
    /// Refused whole: malformed station id, invalid samples, implausible values, or stamped
    /// ahead of the clock (counted and logged per station, as a notice).
    Refused,
}

/// Packets processed and refused per [`Source`] (monotonic counts since the tally was made).
#[derive(Debug)]
pub struct SourceTally {
    processed: Box<[AtomicU64]>,
    refused: Box<[AtomicU64]>,
}

impl Default for SourceTally {
    fn default() -> Self {
        let zeros = || (0..MAX_SOURCES).map(|_| AtomicU64::new(0)).collect();
        SourceTally {
            processed: zeros(),
            refused: zeros(),
        }
    }
}

impl SourceTally {
    /// Counts one packet of `source` with its verdict.
    pub fn count(&self, source: Source, verdict: Verdict) {
        self.processed[source.index()].fetch_add(1, Ordering::Relaxed);
        if verdict == Verdict::Refused {
            // Release: a reader that sees this refusal sees the packet processed too.
            self.refused[source.index()].fetch_add(1, Ordering::Release);
        }
    }

    /// Packets of `source` processed (every verdict) and, of those, refused, since the tally
    /// was made. A reader of a reused slot subtracts what it read when the slot was assigned.
    #[must_use]
    pub fn of(&self, source: Source) -> (u64, u64) {
        // Refused first: a concurrent count can then only make `processed` look larger,
        // never `refused` larger than `processed`.
        let refused = self.refused[source.index()].load(Ordering::Acquire);
        let processed = self.processed[source.index()].load(Ordering::Relaxed);
        (processed, refused)
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
        assert_eq!(tally.of(a), (3, 1));
        assert_eq!(tally.of(b), (1, 1));
        assert_eq!(tally.of(Source::new(5).unwrap()), (0, 0));
    }
}
