//! What a packet's sequence number and its record's start time say about it.
//!
//! Sequence numbers order one station's packets on one server. SeedLink 3 carries 24 bits
//! (they wrap from 0xFFFFFF to 0, or to 1 on servers that never use 0); SeedLink 4 carries 64.
//! A number behind the last one is either a server that restarted and numbers again from the
//! start, or an old packet sent again or out of order: the record's start time tells them
//! apart. Duplicates are recognised by (stream, record start time), never by sequence alone,
//! so a restarted server is not mistaken for one resending old data.
//!
//! One odd number is not a restart: a record numbered far ahead (a server fault, a corrupt
//! header) followed by new data numbered on from before it is an *outlier*
//! ([`Verdict::DeliverAfterOutlier`]), and the station goes on from its earlier number. The
//! number to resume from ([`StationSequence::resume_point`]) is the last one *confirmed*, i.e.
//! reached in order or followed by a later number: never a jump nothing has followed yet.

use std::collections::BTreeSet;

use super::Protocol;

/// v3 sequence numbers are taken modulo 2^24.
pub const V3_MODULUS: u64 = 1 << 24;

/// How `seq` follows `last` on the same station.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// The next number (v3: modulo 2^24; 0xFFFFFF → 1 as well, for servers that skip 0).
    Next,
    /// Ahead, with `missing` numbers skipped (a gap in the server's ring, or other stations'
    /// packets on a server with one sequence for all stations).
    Gap { missing: u64 },
    /// The same number again.
    Repeat,
    /// Behind: a server restart, or an old packet (v3: more than 2^23 behind counts as ahead,
    /// the usual half-window rule).
    Behind,
}

/// The order of `seq` after `last` for `protocol`.
#[must_use]
pub fn order(protocol: Protocol, last: u64, seq: u64) -> Order {
    let forward = match protocol {
        Protocol::V3 => {
            let d = seq.wrapping_sub(last) % V3_MODULUS;
            if d == 0 {
                return Order::Repeat;
            }
            if d >= V3_MODULUS / 2 {
                return Order::Behind;
            }
            // 0xFFFFFF → 0x000001 on servers that never assign 0 is the next packet.
            if last % V3_MODULUS == V3_MODULUS - 1 && seq % V3_MODULUS == 1 {
                1
            } else {
                d
            }
        }
        Protocol::V4 => match seq.cmp(&last) {
            std::cmp::Ordering::Equal => return Order::Repeat,
            std::cmp::Ordering::Less => return Order::Behind,
            std::cmp::Ordering::Greater => seq - last,
        },
    };
    if forward == 1 {
        Order::Next
    } else {
        Order::Gap {
            missing: forward - 1,
        }
    }
}

/// Start times of the records of one stream already delivered: the most recent
/// [`DeliveredStarts::CAPACITY`] exactly, and a floor below which everything counts as
/// delivered (what was evicted, or the last start time saved before a restart).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DeliveredStarts {
    recent: BTreeSet<i64>,
    floor: Option<i64>,
}

impl DeliveredStarts {
    /// Start times remembered exactly per stream (at 100 Hz and 512-byte Steim records,
    /// about an hour): reordering deeper than that is treated as duplication.
    pub const CAPACITY: usize = 1024;

    /// Everything at or before `latest_ns` counts as delivered (state restored after a
    /// restart).
    #[must_use]
    pub fn from_latest(latest_ns: Option<i64>) -> DeliveredStarts {
        DeliveredStarts {
            recent: BTreeSet::new(),
            floor: latest_ns,
        }
    }

    /// Whether a record starting at `start_ns` was delivered already.
    #[must_use]
    pub fn contains(&self, start_ns: i64) -> bool {
        self.floor.is_some_and(|f| start_ns <= f) || self.recent.contains(&start_ns)
    }

    /// The latest start time delivered.
    #[must_use]
    pub fn latest(&self) -> Option<i64> {
        self.recent.last().copied().max(self.floor)
    }

    /// Records `start_ns` as delivered (evicting the oldest beyond the capacity).
    pub fn insert(&mut self, start_ns: i64) {
        self.recent.insert(start_ns);
        while self.recent.len() > Self::CAPACITY {
            if let Some(oldest) = self.recent.pop_first() {
                self.floor = Some(self.floor.map_or(oldest, |f| f.max(oldest)));
            }
        }
    }
}

/// The sequence numbers of one station as received: the last accepted, and the last
/// *confirmed* one (the resume point: reached in order, or followed by a later number).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StationSequence {
    last: Option<u64>,
    confirmed: Option<u64>,
    /// Numbers counted as missing when `last` came by a jump (undone if it was an outlier).
    jump_missing: u64,
}

impl StationSequence {
    /// The state after a restart of the client: `saved` is a resume point (confirmed).
    #[must_use]
    pub fn resumed(saved: Option<u64>) -> StationSequence {
        StationSequence {
            last: saved,
            confirmed: saved,
            jump_missing: 0,
        }
    }

    /// The last number accepted.
    #[must_use]
    pub fn last(&self) -> Option<u64> {
        self.last
    }

    /// The number to resume from: the last confirmed one (`None` before any).
    #[must_use]
    pub fn resume_point(&self) -> Option<u64> {
        self.confirmed
    }

    /// Takes a delivered packet's number `seq` judged `verdict` (duplicates and records the
    /// sink refused are not taken: they say nothing about the station's numbering). Returns
    /// the numbers counted as missing by an earlier jump that turned out to be an outlier (to
    /// take back from the counters).
    pub fn accept(&mut self, protocol: Protocol, seq: u64, verdict: Verdict) -> u64 {
        let mut undone = 0;
        match verdict {
            Verdict::Deliver { missing } => {
                if missing == 0 {
                    self.confirmed = Some(seq);
                    self.jump_missing = 0;
                } else {
                    // The previous number is followed by a later one: confirmed; this one
                    // not yet.
                    self.confirmed = self.last;
                    self.jump_missing = missing;
                }
                self.last = Some(seq);
            }
            Verdict::DeliverAfterOutlier { .. } => {
                undone = self.jump_missing;
                let from = self.confirmed;
                match from.map(|c| order(protocol, c, seq)) {
                    Some(Order::Gap { missing }) => self.jump_missing = missing,
                    _ => {
                        self.confirmed = Some(seq);
                        self.jump_missing = 0;
                    }
                }
                self.last = Some(seq);
            }
            Verdict::DeliverAfterReset => {
                self.last = Some(seq);
                self.confirmed = Some(seq);
                self.jump_missing = 0;
            }
            Verdict::DeliverReordered | Verdict::Duplicate => {}
        }
        undone
    }
}

/// What to do with a packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// New data in order (first packet, next, or after a gap of `missing` numbers).
    Deliver { missing: u64 },
    /// New data behind the station's last sequence number and newer than anything delivered
    /// on its stream: the server restarted and numbers again. The station's sequence starts
    /// over from this packet.
    DeliverAfterReset,
    /// New data behind the station's last number but ahead of the confirmed one before it:
    /// the last number (`odd`) was one out of line (a jump nothing followed), not a server
    /// restart. The station goes on from this packet.
    DeliverAfterOutlier { odd: u64 },
    /// New data older than the stream's latest (out of order): delivered, sequence kept.
    DeliverReordered,
    /// Already delivered (same stream and start time, or older than what is remembered).
    Duplicate,
}

impl Verdict {
    /// Whether the record goes on.
    #[must_use]
    pub fn delivers(self) -> bool {
        self != Verdict::Duplicate
    }

    /// Whether the station's last sequence number becomes this packet's.
    #[must_use]
    pub fn advances_sequence(self) -> bool {
        matches!(
            self,
            Verdict::Deliver { .. }
                | Verdict::DeliverAfterReset
                | Verdict::DeliverAfterOutlier { .. }
        )
    }
}

/// Judges a packet of sequence `seq` on a station whose numbers so far are `station`,
/// carrying a record of a stream whose deliveries are `delivered`, starting at `start_ns`.
#[must_use]
pub fn judge(
    protocol: Protocol,
    station: &StationSequence,
    seq: u64,
    delivered: &DeliveredStarts,
    start_ns: i64,
) -> Verdict {
    if delivered.contains(start_ns) {
        return Verdict::Duplicate;
    }
    let newest = delivered.latest().is_none_or(|l| start_ns > l);
    let Some(last) = station.last else {
        return Verdict::Deliver { missing: 0 };
    };
    match order(protocol, last, seq) {
        Order::Next => Verdict::Deliver { missing: 0 },
        Order::Gap { missing } if newest => Verdict::Deliver { missing },
        Order::Gap { .. } => Verdict::DeliverReordered,
        Order::Repeat | Order::Behind if newest => {
            // Behind the last number but on from the confirmed one before it: the last was
            // one number out of line.
            let on_from_confirmed = station.confirmed.filter(|&c| c != last).is_some_and(|c| {
                matches!(order(protocol, c, seq), Order::Next | Order::Gap { .. })
            });
            if on_from_confirmed {
                Verdict::DeliverAfterOutlier { odd: last }
            } else {
                Verdict::DeliverAfterReset
            }
        }
        Order::Repeat | Order::Behind => Verdict::DeliverReordered,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn v3_sequences_wrap_at_24_bits() {
        assert_eq!(order(Protocol::V3, 0xFF_FFFE, 0xFF_FFFF), Order::Next);
        assert_eq!(order(Protocol::V3, 0xFF_FFFF, 0), Order::Next);
        // Servers that never assign 0 go from 0xFFFFFF to 1.
        assert_eq!(order(Protocol::V3, 0xFF_FFFF, 1), Order::Next);
        assert_eq!(
            order(Protocol::V3, 0xFF_FFF0, 0x10),
            Order::Gap { missing: 0x1F }
        );
        assert_eq!(order(Protocol::V3, 0x10, 0xFF_FFF0), Order::Behind);
        assert_eq!(order(Protocol::V3, 5, 5), Order::Repeat);
        // Half window: 2^23 − 1 ahead is ahead, 2^23 is behind.
        assert_eq!(
            order(Protocol::V3, 0, (1 << 23) - 1),
            Order::Gap {
                missing: (1 << 23) - 2
            }
        );
        assert_eq!(order(Protocol::V3, 0, 1 << 23), Order::Behind);
        // v4 has no wrap.
        assert_eq!(order(Protocol::V4, 0xFF_FFFF, 0x100_0000), Order::Next);
        assert_eq!(order(Protocol::V4, 0xFF_FFFF, 1), Order::Behind);
    }

    fn at(seq: u64) -> StationSequence {
        StationSequence::resumed(Some(seq))
    }

    fn delivered(starts: &[i64]) -> DeliveredStarts {
        let mut d = DeliveredStarts::default();
        starts.iter().for_each(|&s| d.insert(s));
        d
    }

    #[test]
    fn a_restarted_server_is_not_taken_for_duplicates() {
        // The server restarts and numbers from 1 again; its records are new (later start).
        let d = delivered(&[100, 200, 300]);
        assert_eq!(
            judge(Protocol::V3, &at(0x500), 1, &d, 400),
            Verdict::DeliverAfterReset
        );
        assert_eq!(
            judge(Protocol::V4, &at(9_000), 1, &d, 400),
            Verdict::DeliverAfterReset
        );
        assert!(Verdict::DeliverAfterReset.advances_sequence());
    }

    #[test]
    fn duplicates_are_dropped_by_stream_and_start_time() {
        let d = delivered(&[100, 200, 300]);
        // Resent after a reconnect with the same or an older number: dropped.
        assert_eq!(judge(Protocol::V3, &at(3), 3, &d, 300), Verdict::Duplicate);
        assert_eq!(judge(Protocol::V3, &at(3), 2, &d, 200), Verdict::Duplicate);
        // Even with a new number (a server that renumbered its ring): dropped.
        assert_eq!(judge(Protocol::V4, &at(3), 10, &d, 200), Verdict::Duplicate);
        // After a restart of acquire, only the saved latest start survives: older is dropped.
        let restored = DeliveredStarts::from_latest(Some(300));
        assert_eq!(
            judge(Protocol::V3, &at(3), 3, &restored, 250),
            Verdict::Duplicate
        );
        assert_eq!(
            judge(Protocol::V3, &at(3), 4, &restored, 400),
            Verdict::Deliver { missing: 0 }
        );
    }

    #[test]
    fn reordered_records_are_delivered_without_moving_the_sequence_back() {
        // 100 and 300 delivered; 200 arrives late with an older number.
        let d = delivered(&[100, 300]);
        let v = judge(Protocol::V3, &at(3), 2, &d, 200);
        assert_eq!(v, Verdict::DeliverReordered);
        assert!(v.delivers() && !v.advances_sequence());
        // A gap then an old record filling it: also reordered.
        assert_eq!(
            judge(Protocol::V4, &at(3), 7, &d, 200),
            Verdict::DeliverReordered
        );
        // A gap with new data is a gap.
        assert_eq!(
            judge(Protocol::V4, &at(3), 7, &d, 400),
            Verdict::Deliver { missing: 3 }
        );
    }

    #[test]
    fn memory_is_bounded_and_evicted_starts_count_as_delivered() {
        let n = DeliveredStarts::CAPACITY as i64 + 10;
        let d = delivered(&(0..n).collect::<Vec<_>>());
        assert_eq!(d.recent.len(), DeliveredStarts::CAPACITY);
        assert!(d.contains(0) && d.contains(9) && d.contains(n - 1) && !d.contains(n));
        assert_eq!(d.latest(), Some(n - 1));
    }

    /// Delivers `seq` at `start` on `station` (judged, then taken), returning the verdict.
    fn feed(
        station: &mut StationSequence,
        d: &mut DeliveredStarts,
        seq: u64,
        start: i64,
    ) -> Verdict {
        let v = judge(Protocol::V3, station, seq, d, start);
        if v.delivers() {
            station.accept(Protocol::V3, seq, v);
            d.insert(start);
        }
        v
    }

    #[test]
    fn one_number_far_ahead_is_an_outlier_not_a_restart_and_never_the_resume_point() {
        let mut s = StationSequence::resumed(Some(10));
        let mut d = delivered(&[100]);
        assert_eq!(
            feed(&mut s, &mut d, 11, 110),
            Verdict::Deliver { missing: 0 }
        );
        assert_eq!(s.resume_point(), Some(11));
        // The next record arrives numbered 500 000 ahead (a jump nothing has followed yet):
        // delivered, but the resume point stays at 11.
        assert_eq!(
            feed(&mut s, &mut d, 500_012, 120),
            Verdict::Deliver { missing: 500_000 }
        );
        assert_eq!(s.resume_point(), Some(11));
        // Its clean copy numbered 12 is a duplicate (same start): it moves nothing.
        assert_eq!(feed(&mut s, &mut d, 12, 120), Verdict::Duplicate);
        assert_eq!((s.last(), s.resume_point()), (Some(500_012), Some(11)));
        // New data numbered on from 11: the jump was one odd number, not a server restart;
        // the 500 000 counted as missing are taken back.
        let mut s2 = s;
        assert_eq!(
            judge(Protocol::V3, &s2, 13, &d, 130),
            Verdict::DeliverAfterOutlier { odd: 500_012 }
        );
        assert_eq!(
            s2.accept(
                Protocol::V3,
                13,
                Verdict::DeliverAfterOutlier { odd: 500_012 }
            ),
            500_000
        );
        assert_eq!((s2.last(), s2.resume_point()), (Some(13), Some(11)));
        assert_eq!(
            feed(&mut s2, &mut d, 14, 140),
            Verdict::Deliver { missing: 0 }
        );
        assert_eq!(s2.resume_point(), Some(14));
        // A real restart (numbers from 1 again, confirmed before): still a restart.
        s.accept(Protocol::V3, 500_013, Verdict::Deliver { missing: 0 });
        assert_eq!(
            judge(Protocol::V3, &s, 1, &d, 150),
            Verdict::DeliverAfterReset
        );
    }

    #[test]
    fn a_jump_followed_by_a_later_number_is_confirmed() {
        // A server with one numbering for all stations: every step is a gap; each number is
        // confirmed by the next, so the resume point lags one record (sent again, dropped).
        let mut s = StationSequence::resumed(None);
        let mut d = DeliveredStarts::default();
        feed(&mut s, &mut d, 5, 100);
        assert_eq!(s.resume_point(), Some(5));
        feed(&mut s, &mut d, 9, 110);
        assert_eq!(s.resume_point(), Some(5));
        feed(&mut s, &mut d, 20, 120);
        assert_eq!((s.last(), s.resume_point()), (Some(20), Some(9)));
    }
}
