//! Per-station stream sequencing: places each packet on the station's sample grid and decides
//! what of it is new data — contiguous, after a gap, overlapping, duplicate, early (held in a
//! small reorder window), or at a new sample rate.
//!
//! The grid: sample `k` of a station is at `anchor_ns + k / rate`. A packet's first sample is
//! placed at the nearest grid index (timing off-grid by more than a quarter sample is counted
//! as misaligned). Decisions depend only on the order of packets, never on wall time, so the
//! same packets give the same output (the reorder window counts packets, not seconds).
//!
//! No handful of packets moves the grid irreversibly: after a forward jump too long to bridge
//! (a station back from an outage, or packets stamped ahead), the grid before the jump is
//! remembered. The jump is confirmed once the stream after it has lasted as long as the gap it
//! left (a few packets stamped seconds ahead confirm one another, but not for that long); if
//! instead `resync_packets` packets in a row land in the gap (the jumping packets were the
//! outliers), the grid is rewound to before the jump and those packets are released
//! ([`Gap::Rewind`]); packets held beyond the jump are dropped. A packet continuing the jumped
//! stream breaks the row: the gap packets before it are dropped (counted).

use super::packet::AccelPacket;
use super::source::Source;

/// Stream-sequencing options.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StreamConfig {
    /// Gaps up to this length (s) are bridged by linear interpolation; longer gaps break the
    /// stream (data-gap flag).
    pub max_bridge_s: f64,
    /// How many early packets may wait for missing data before the gap is accepted.
    pub reorder_window_packets: usize,
    /// After a forward jump too long to bridge, this many packets in a row landing in the gap
    /// the jump left (rather than continuing after it) rewind the grid to before the jump.
    pub resync_packets: usize,
}

impl Default for StreamConfig {
    fn default() -> Self {
        StreamConfig {
            max_bridge_s: 0.5,
            reorder_window_packets: 4,
            resync_packets: 3,
        }
    }
}

/// What precedes a released packet's new samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Gap {
    /// Contiguous with the previous data.
    None,
    /// `n` missing samples, to be bridged by linear interpolation.
    Bridge(u64),
    /// `n` missing samples, too many to bridge: the stream breaks.
    Break(u64),
    /// The sample rate changed: a new grid starts with this packet.
    RateChange,
    /// First packet of the stream.
    Start,
    /// The grid was rewound to before a forward jump that the following packets did not
    /// confirm (see the module doc): the data time goes back; the blocks' input is
    /// discontinuous and the data between the jump and this packet is suspect.
    Rewind,
}

/// A packet released for processing: its samples `skip..` are new, preceded by `gap`.
#[derive(Debug, Clone, PartialEq)]
pub struct Released {
    pub packet: AccelPacket,
    pub skip: usize,
    pub gap: Gap,
    /// Grid index of the packet's first new sample.
    pub first_index: i64,
    /// UTC time of the packet's first new sample on the grid it was placed on (ns).
    pub first_time_ns: i64,
    /// Sample rate of that grid (Hz).
    pub rate_hz: f64,
}

impl Released {
    /// UTC time (ns) of the `k`-th new sample (k may be negative: bridged samples before).
    #[must_use]
    pub fn time_ns(&self, k: i64) -> i64 {
        self.first_time_ns + (k as f64 * 1e9 / self.rate_hz).round() as i64
    }
}

/// Samples of one packet dropped because the station had processed them (or later data)
/// already: a duplicate, late or overlapping packet, or one held beyond an undone jump. The
/// sequencer lists each ([`Sequencer::dropped`]) so that its station can say what was dropped
/// and tell the packet's sender.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dropped {
    /// The packet's sender, as given to [`Sequencer::offer`].
    pub source: Option<Source>,
    /// Samples of the packet dropped (all of them, or its first ones for a partial overlap:
    /// the new samples after the overlap are never dropped).
    pub samples: u64,
    /// UTC time (ns) of the first dropped sample and just after the last one.
    pub start_ns: i64,
    pub end_ns: i64,
}

/// Counters of stream irregularities (cumulative).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct StreamCounters {
    /// Packets whose every sample had been processed already.
    pub duplicate_packets: u64,
    /// Samples dropped because they had been processed already (overlaps, late packets).
    pub overlap_samples: u64,
    /// Packets that arrived after later data had been processed (dropped wholly or partly).
    pub late_packets: u64,
    /// Early packets that waited in the reorder window and were then put in order.
    pub reordered_packets: u64,
    pub gaps_bridged: u64,
    pub bridged_samples: u64,
    pub gaps_broken: u64,
    pub missing_samples: u64,
    pub rate_changes: u64,
    /// Packets whose start time was more than a quarter sample off the grid.
    pub misaligned_packets: u64,
    /// Forward jumps undone: the grid was rewound to before them ([`Gap::Rewind`]).
    pub grid_rewinds: u64,
}

/// The grid as it was before a forward jump not yet confirmed.
#[derive(Debug, Clone, Copy)]
struct Jump {
    anchor_ns: i64,
    rate_hz: f64,
    /// Grid index of the next expected sample before the jump.
    next_index: i64,
    max_sequence: Option<u64>,
    /// UTC time (ns) of the first sample after the jump.
    to_ns: i64,
}

impl Jump {
    /// UTC time (ns) of index `k` of the grid before the jump.
    fn time_ns(&self, k: i64) -> i64 {
        self.anchor_ns + (k as f64 * 1e9 / self.rate_hz).round() as i64
    }

    /// Whether `p` lies in the gap the jump left, on the grid before it.
    fn in_gap(&self, p: &AccelPacket) -> bool {
        let half_sample_ns = (0.5e9 / self.rate_hz) as i64;
        let end_ns = p.start_time_ns + (p.len() as f64 * 1e9 / self.rate_hz).round() as i64;
        (p.sample_rate_hz - self.rate_hz).abs() <= 1e-9 * self.rate_hz
            && p.start_time_ns >= self.time_ns(self.next_index) - half_sample_ns
            && end_ns <= self.to_ns + half_sample_ns
    }
}

/// The sequencer of one station.
#[derive(Debug, Clone)]
pub struct Sequencer {
    config: StreamConfig,
    anchor_ns: i64,
    rate_hz: f64,
    /// Grid index of the next expected sample; `None` before the first packet.
    next_index: Option<i64>,
    max_sequence: Option<u64>,
    held: Vec<(i64, AccelPacket, Option<Source>)>,
    /// The grid before the last forward jump, until the jump is confirmed or undone.
    jump: Option<Jump>,
    /// Packets that landed in the gap of `jump` (at most `resync_packets`), by start time.
    behind: Vec<(AccelPacket, Option<Source>)>,
    /// Data dropped by the last offer or flush (at most one entry per packet held, behind or
    /// offered: the capacity is reserved once).
    dropped: Vec<Dropped>,
    /// The next released packet follows a rewind.
    rewound: bool,
    pub counters: StreamCounters,
}

impl Sequencer {
    #[must_use]
    pub fn new(config: StreamConfig) -> Self {
        Sequencer {
            config,
            anchor_ns: 0,
            rate_hz: 0.0,
            next_index: None,
            max_sequence: None,
            held: Vec::with_capacity(config.reorder_window_packets + 1),
            jump: None,
            behind: Vec::with_capacity(config.resync_packets),
            dropped: Vec::with_capacity(config.reorder_window_packets + config.resync_packets + 4),
            rewound: false,
            counters: StreamCounters::default(),
        }
    }

    /// Sample rate of the current grid (Hz); 0 before the first packet.
    #[must_use]
    pub fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    /// UTC time (ns) of grid index `k`.
    #[must_use]
    pub fn time_ns(&self, k: i64) -> i64 {
        self.anchor_ns + (k as f64 * 1e9 / self.rate_hz).round() as i64
    }

    /// What the last [`Sequencer::offer`] or [`Sequencer::flush`] dropped, packet by packet.
    #[must_use]
    pub fn dropped(&self) -> &[Dropped] {
        &self.dropped
    }

    /// Packets held in the reorder window.
    #[must_use]
    pub fn held(&self) -> usize {
        self.held.len()
    }

    fn grid_index(&mut self, start_ns: i64) -> i64 {
        let exact = (start_ns - self.anchor_ns) as f64 * self.rate_hz * 1e-9;
        let k = exact.round();
        if (exact - k).abs() > 0.25 {
            self.counters.misaligned_packets += 1;
        }
        k as i64
    }

    /// Records that `samples` samples of `packet` from its first were dropped (all of them
    /// when `samples` is its length), on a grid of `rate_hz`.
    fn drop_samples(
        &mut self,
        packet: &AccelPacket,
        source: Option<Source>,
        samples: u64,
        rate_hz: f64,
    ) {
        if samples == 0 {
            return;
        }
        if samples >= packet.len() as u64 {
            self.counters.duplicate_packets += 1;
        }
        self.counters.overlap_samples += samples;
        self.dropped.push(Dropped {
            source,
            samples,
            start_ns: packet.start_time_ns,
            end_ns: packet.start_time_ns + (samples as f64 * 1e9 / rate_hz).round() as i64,
        });
    }

    /// Offers a validated packet from `source` (its sender, if the caller tells senders
    /// apart); appends to `out` every packet now ready, in stream order. What is dropped is
    /// counted and listed in [`Sequencer::dropped`].
    pub fn offer(&mut self, packet: AccelPacket, source: Option<Source>, out: &mut Vec<Released>) {
        self.dropped.clear();
        if self.jump.as_ref().is_some_and(|j| j.in_gap(&packet)) {
            let position = self
                .behind
                .partition_point(|(p, _)| p.start_time_ns <= packet.start_time_ns);
            self.behind.insert(position, (packet, source));
            if self.behind.len() >= self.config.resync_packets.max(1) {
                self.rewind(out);
            }
            return;
        }
        // Sent before a packet we already have?
        let out_of_order = self.max_sequence.is_some_and(|max| packet.sequence < max);
        self.max_sequence = Some(
            self.max_sequence
                .map_or(packet.sequence, |m| m.max(packet.sequence)),
        );
        let Some(next) = self.next_index else {
            self.start_grid(packet, Gap::Start, out);
            return;
        };
        if (packet.sample_rate_hz - self.rate_hz).abs() > 1e-9 * self.rate_hz {
            // A packet from before the data we already have (e.g. a late one at the old rate
            // after a change) must not restart the grid in the past.
            if packet.start_time_ns < self.time_ns(next) - (0.5e9 / self.rate_hz) as i64 {
                self.counters.late_packets += 1;
                let rate = packet.sample_rate_hz;
                self.drop_samples(&packet, source, packet.len() as u64, rate);
                return;
            }
            self.release_held(out);
            self.counters.rate_changes += 1;
            // A change of rate far ahead of the stream is a jump like any other.
            let ahead_s = (packet.start_time_ns - self.time_ns(next)) as f64 * 1e-9;
            let jump = (ahead_s > self.config.max_bridge_s).then_some(Jump {
                anchor_ns: self.anchor_ns,
                rate_hz: self.rate_hz,
                next_index: next,
                max_sequence: self.max_sequence,
                to_ns: packet.start_time_ns,
            });
            self.settle_jump(jump);
            self.start_grid(packet, Gap::RateChange, out);
            return;
        }
        let k = self.grid_index(packet.start_time_ns);
        if out_of_order {
            if k < next {
                self.counters.late_packets += 1;
            } else {
                self.counters.reordered_packets += 1;
            }
        }
        if k > next && self.config.reorder_window_packets > 0 {
            let position = self.held.partition_point(|(hk, _, _)| *hk <= k);
            self.held.insert(position, (k, packet, source));
            if self.held.len() > self.config.reorder_window_packets {
                let (hk, p, s) = self.held.remove(0);
                self.release(hk, p, s, out);
            }
        } else {
            self.release(k, packet, source, out);
        }
        self.release_ready(out);
    }

    /// A new forward jump (`Some`) replaces the one remembered; a packet continuing the stream
    /// (`None`) confirms it. Either way the packets that landed behind it are dropped.
    fn settle_jump(&mut self, jump: Option<Jump>) {
        self.drop_behind();
        self.jump = jump;
    }

    /// Drops the packets that landed in the gap of the remembered jump (counted).
    fn drop_behind(&mut self) {
        let mut behind = std::mem::take(&mut self.behind);
        for (p, source) in behind.drain(..) {
            self.drop_samples(&p, source, p.len() as u64, p.sample_rate_hz);
        }
        self.behind = behind;
    }

    /// Undoes the last forward jump: the grid before it comes back, the packets held beyond
    /// it are dropped, and the packets that landed in its gap are released in time order.
    fn rewind(&mut self, out: &mut Vec<Released>) {
        let Some(jump) = self.jump.take() else {
            return;
        };
        let mut held = std::mem::take(&mut self.held);
        for (_, p, source) in held.drain(..) {
            self.drop_samples(&p, source, p.len() as u64, p.sample_rate_hz);
        }
        self.held = held;
        self.counters.grid_rewinds += 1;
        self.anchor_ns = jump.anchor_ns;
        self.rate_hz = jump.rate_hz;
        self.next_index = Some(jump.next_index);
        let mut behind = std::mem::take(&mut self.behind);
        self.max_sequence = behind
            .iter()
            .map(|(p, _)| p.sequence)
            .chain(jump.max_sequence)
            .max();
        self.rewound = true;
        for (p, source) in behind.drain(..) {
            let k = self.grid_index(p.start_time_ns);
            self.release(k, p, source, out);
        }
        self.behind = behind;
    }

    /// Releases every held packet (gaps accepted), e.g. when the stream has gone quiet.
    pub fn flush(&mut self, out: &mut Vec<Released>) {
        self.dropped.clear();
        self.release_held(out);
    }

    fn release_held(&mut self, out: &mut Vec<Released>) {
        while !self.held.is_empty() {
            let (k, p, source) = self.held.remove(0);
            self.release(k, p, source, out);
        }
    }

    fn start_grid(&mut self, packet: AccelPacket, gap: Gap, out: &mut Vec<Released>) {
        self.anchor_ns = packet.start_time_ns;
        self.rate_hz = packet.sample_rate_hz;
        self.next_index = Some(packet.len() as i64);
        out.push(Released {
            first_time_ns: packet.start_time_ns,
            rate_hz: packet.sample_rate_hz,
            packet,
            skip: 0,
            gap,
            first_index: 0,
        });
    }

    fn release_ready(&mut self, out: &mut Vec<Released>) {
        while let (Some(next), Some((k, _, _))) = (self.next_index, self.held.first()) {
            if *k > next {
                break;
            }
            let (k, p, source) = self.held.remove(0);
            self.release(k, p, source, out);
        }
    }

    /// Places packet `p` starting at grid index `k` relative to the next expected sample.
    fn release(
        &mut self,
        k: i64,
        packet: AccelPacket,
        source: Option<Source>,
        out: &mut Vec<Released>,
    ) {
        let next = self.next_index.unwrap_or(k);
        let n = packet.len() as i64;
        if k + n <= next {
            self.drop_samples(&packet, source, n as u64, self.rate_hz);
            return;
        }
        let (skip, mut gap) = if k < next {
            self.drop_samples(&packet, source, (next - k) as u64, self.rate_hz);
            ((next - k) as usize, Gap::None)
        } else if k == next {
            (0, Gap::None)
        } else {
            let missing = (k - next) as u64;
            self.counters.missing_samples += missing;
            if missing as f64 / self.rate_hz <= self.config.max_bridge_s {
                self.counters.gaps_bridged += 1;
                self.counters.bridged_samples += missing;
                (0, Gap::Bridge(missing))
            } else {
                self.counters.gaps_broken += 1;
                (0, Gap::Break(missing))
            }
        };
        if let Gap::Break(_) = gap {
            self.settle_jump(Some(Jump {
                anchor_ns: self.anchor_ns,
                rate_hz: self.rate_hz,
                next_index: next,
                max_sequence: self.max_sequence,
                to_ns: self.time_ns(k),
            }));
        } else if let Some(jump) = self.jump {
            if self.time_ns(k + n) - jump.to_ns >= jump.to_ns - jump.time_ns(jump.next_index) {
                // The stream after the jump has lasted as long as the gap: confirmed.
                self.settle_jump(None);
            } else {
                // A burst after the jump (a few packets stamped ahead confirm one another):
                // not yet a confirmation, but the packets behind it are no longer in a row.
                self.drop_behind();
            }
        }
        if std::mem::take(&mut self.rewound) {
            gap = Gap::Rewind;
        }
        self.next_index = Some(k + n);
        let first_index = k + skip as i64;
        out.push(Released {
            first_time_ns: self.time_ns(first_index),
            rate_hz: self.rate_hz,
            packet,
            skip,
            gap,
            first_index,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATE: f64 = 100.0;

    /// A packet of `n` samples starting at grid index `k` (10 ms grid), values = index.
    fn packet(k: i64, n: usize, sequence: u64) -> AccelPacket {
        let values: Vec<f32> = (0..n).map(|i| (k + i as i64) as f32).collect();
        AccelPacket {
            station: crate::station_id::StationId::parse("CI.RRS.00").unwrap(),
            start_time_ns: 1_000_000_000 + k * 10_000_000,
            sample_rate_hz: RATE,
            sequence,
            east: values.clone(),
            north: values,
            up: vec![],
            unit: Default::default(),
        }
    }

    fn offer_all(seq: &mut Sequencer, packets: Vec<AccelPacket>) -> Vec<(i64, usize, Gap)> {
        let mut out = Vec::new();
        for p in packets {
            seq.offer(p, None, &mut out);
        }
        seq.flush(&mut out);
        out.iter()
            .map(|r| (r.first_index, r.packet.len() - r.skip, r.gap))
            .collect()
    }

    #[test]
    fn contiguous_packets_pass_in_order() {
        let mut s = Sequencer::new(StreamConfig::default());
        let got = offer_all(
            &mut s,
            vec![packet(0, 10, 0), packet(10, 10, 1), packet(20, 5, 2)],
        );
        assert_eq!(
            got,
            vec![(0, 10, Gap::Start), (10, 10, Gap::None), (20, 5, Gap::None)]
        );
        assert_eq!(s.counters, StreamCounters::default());
    }

    #[test]
    fn duplicate_and_overlap_drop_only_old_samples() {
        let mut s = Sequencer::new(StreamConfig::default());
        let got = offer_all(
            &mut s,
            vec![packet(0, 10, 0), packet(0, 10, 0), packet(5, 10, 1)],
        );
        assert_eq!(got, vec![(0, 10, Gap::Start), (10, 5, Gap::None)]);
        assert_eq!(s.counters.duplicate_packets, 1);
        assert_eq!(s.counters.overlap_samples, 10 + 5);
    }

    /// Issue 20 item 3: each drop names its packet's sender and the span of the dropped
    /// samples; a partly overlapping packet loses only its old samples, and a packet held
    /// beyond an undone jump is charged to its own sender, not to the packet that undid it.
    #[test]
    fn drops_name_their_sender_and_span() {
        let (a, b) = (Source::new(1), Source::new(2));
        let mut s = Sequencer::new(StreamConfig::default());
        let mut out = Vec::new();
        s.offer(packet(0, 10, 0), a, &mut out);
        assert!(s.dropped().is_empty());
        s.offer(packet(0, 10, 0), b, &mut out);
        let whole = Dropped {
            source: b,
            samples: 10,
            start_ns: 1_000_000_000,
            end_ns: 1_100_000_000,
        };
        assert_eq!(s.dropped(), &[whole]);
        s.offer(packet(5, 10, 1), b, &mut out);
        let partial = Dropped {
            source: b,
            samples: 5,
            start_ns: 1_050_000_000,
            end_ns: 1_100_000_000,
        };
        assert_eq!(s.dropped(), &[partial], "only the 5 old samples");
        assert_eq!(
            (out[1].skip, out[1].first_index, out[1].packet.len()),
            (5, 10, 10),
            "the 5 new samples are released"
        );
        // A forward jump (held beyond it: a packet of sender b), undone by three packets of
        // sender a landing in its gap: the held packet is dropped, charged to b.
        let mut s = Sequencer::new(StreamConfig {
            reorder_window_packets: 1,
            ..StreamConfig::default()
        });
        let mut out = Vec::new();
        s.offer(packet(0, 10, 0), a, &mut out);
        s.offer(packet(1000, 10, 1), a, &mut out);
        s.offer(packet(1010, 10, 2), a, &mut out);
        s.offer(packet(1030, 10, 3), b, &mut out); // held: 1020..1030 missing
        s.offer(packet(10, 10, 4), a, &mut out);
        s.offer(packet(20, 10, 5), a, &mut out);
        assert!(s.dropped().is_empty());
        s.offer(packet(30, 10, 6), a, &mut out);
        assert_eq!(s.counters.grid_rewinds, 1);
        assert_eq!(
            s.dropped(),
            &[Dropped {
                source: b,
                samples: 10,
                start_ns: 1_000_000_000 + 1030 * 10_000_000,
                end_ns: 1_000_000_000 + 1040 * 10_000_000,
            }]
        );
    }

    #[test]
    fn out_of_order_within_window_is_put_back_in_order() {
        let mut s = Sequencer::new(StreamConfig::default());
        let got = offer_all(
            &mut s,
            vec![
                packet(0, 10, 0),
                packet(20, 10, 2),
                packet(10, 10, 1),
                packet(30, 10, 3),
            ],
        );
        assert_eq!(
            got,
            vec![
                (0, 10, Gap::Start),
                (10, 10, Gap::None),
                (20, 10, Gap::None),
                (30, 10, Gap::None)
            ]
        );
        assert_eq!(s.counters.reordered_packets, 1);
        assert_eq!(s.counters.missing_samples, 0);
    }

    #[test]
    fn late_packet_beyond_window_is_dropped_and_gap_accepted() {
        let cfg = StreamConfig {
            reorder_window_packets: 1,
            max_bridge_s: 0.5,
            ..StreamConfig::default()
        };
        let mut s = Sequencer::new(cfg);
        // Packet 1 (samples 10..20) is missing while 2 and 3 arrive: the window of one
        // releases packet 2 after a bridged 10-sample gap; packet 1 then arrives late.
        let got = offer_all(
            &mut s,
            vec![
                packet(0, 10, 0),
                packet(20, 10, 2),
                packet(30, 10, 3),
                packet(10, 10, 1),
            ],
        );
        assert_eq!(
            got,
            vec![
                (0, 10, Gap::Start),
                (20, 10, Gap::Bridge(10)),
                (30, 10, Gap::None)
            ]
        );
        assert_eq!(s.counters.late_packets, 1);
        assert_eq!(s.counters.duplicate_packets, 1);
        assert_eq!(s.counters.bridged_samples, 10);
    }

    #[test]
    fn long_gap_breaks_the_stream() {
        let mut s = Sequencer::new(StreamConfig {
            max_bridge_s: 0.5,
            reorder_window_packets: 0,
            ..StreamConfig::default()
        });
        let got = offer_all(&mut s, vec![packet(0, 10, 0), packet(110, 10, 1)]);
        assert_eq!(got[1], (110, 10, Gap::Break(100)));
        assert_eq!(s.counters.gaps_broken, 1);
        assert_eq!(s.counters.missing_samples, 100);
    }

    #[test]
    fn rate_change_starts_a_new_grid() {
        let mut s = Sequencer::new(StreamConfig::default());
        let mut p = packet(10, 20, 1);
        p.sample_rate_hz = 200.0;
        let got = offer_all(&mut s, vec![packet(0, 10, 0), p]);
        assert_eq!(got[1], (0, 20, Gap::RateChange));
        assert_eq!(s.counters.rate_changes, 1);
        assert_eq!(s.rate_hz(), 200.0);
    }

    #[test]
    fn held_packets_keep_their_rate_and_times_across_a_rate_change() {
        let mut s = Sequencer::new(StreamConfig::default());
        let mut out = Vec::new();
        s.offer(packet(0, 10, 0), None, &mut out);
        s.offer(packet(20, 10, 2), None, &mut out); // held: samples 10..20 missing
        let mut fast = packet(0, 20, 3);
        fast.start_time_ns = 1_000_000_000 + 400_000_000;
        fast.sample_rate_hz = 200.0;
        s.offer(fast, None, &mut out);
        let held = &out[1];
        assert_eq!(
            (held.gap, held.rate_hz, held.first_time_ns),
            (Gap::Bridge(10), 100.0, 1_200_000_000)
        );
        assert_eq!(held.time_ns(1), 1_210_000_000);
        assert_eq!(
            (out[2].gap, out[2].rate_hz, out[2].first_time_ns),
            (Gap::RateChange, 200.0, 1_400_000_000)
        );
        // A late 100 Hz packet after the change is dropped, not a new grid in the past.
        s.offer(packet(10, 10, 1), None, &mut out);
        assert_eq!(out.len(), 3);
        assert_eq!(
            (
                s.counters.late_packets,
                s.counters.rate_changes,
                s.rate_hz()
            ),
            (1, 1, 200.0)
        );
    }

    #[test]
    fn off_grid_start_is_rounded_and_counted() {
        let mut s = Sequencer::new(StreamConfig::default());
        let mut p = packet(10, 10, 1);
        p.start_time_ns += 4_000_000; // 0.4 sample late
        let got = offer_all(&mut s, vec![packet(0, 10, 0), p]);
        assert_eq!(got[1], (10, 10, Gap::None));
        assert_eq!(s.counters.misaligned_packets, 1);
    }

    /// A packet 9.5 years ahead of the stream (offline, or within the live tolerance after a
    /// clock fault) moves the grid once it is released; the three real packets that follow
    /// land in the gap it left and rewind the grid: they are released, none lost, and the
    /// stream goes on as before.
    #[test]
    fn one_packet_far_ahead_is_undone_by_the_packets_that_follow() {
        let mut s = Sequencer::new(StreamConfig::default());
        let mut forged = packet(40, 10, 99);
        forged.start_time_ns += 300_000_000_000_000_000; // 9.5 years
        let mut packets = vec![packet(0, 10, 0), packet(10, 10, 1), forged];
        let mut out = Vec::new();
        for p in packets.drain(..) {
            s.offer(p, None, &mut out);
        }
        s.flush(&mut out); // the live node releases held packets after 1 s
        assert!(matches!(out.last().unwrap().gap, Gap::Break(_)));
        for k in [2, 3, 4, 5] {
            s.offer(packet(10 * k, 10, k as u64), None, &mut out);
        }
        s.flush(&mut out);
        let got: Vec<(i64, Gap)> = out[3..].iter().map(|r| (r.first_index, r.gap)).collect();
        assert_eq!(
            got,
            vec![
                (20, Gap::Rewind),
                (30, Gap::None),
                (40, Gap::None),
                (50, Gap::None)
            ]
        );
        assert_eq!(out[3].first_time_ns, 1_200_000_000);
        assert_eq!(s.counters.grid_rewinds, 1);
        assert_eq!(s.counters.duplicate_packets, 0);
    }

    /// A real outage: the stream continues after the jump, which is confirmed; a stale packet
    /// from the outage arriving later is dropped, not a rewind.
    #[test]
    fn a_jump_the_stream_continues_for_as_long_as_its_gap_is_kept() {
        // A 0.9 s jump, then 0.9 s of the stream after it: confirmed; packets landing in the
        // gap afterwards are late (dropped, counted).
        let mut s = Sequencer::new(StreamConfig {
            reorder_window_packets: 0,
            ..StreamConfig::default()
        });
        let mut packets = vec![packet(0, 10, 0)];
        packets.extend((0..9).map(|i| packet(100 + 10 * i, 10, 1 + i as u64)));
        packets.extend([packet(10, 10, 10), packet(20, 10, 11), packet(30, 10, 12)]);
        let got = offer_all(&mut s, packets);
        let mut expected = vec![(0, 10, Gap::Start), (100, 10, Gap::Break(90))];
        expected.extend((1..9).map(|i| (100 + 10 * i, 10, Gap::None)));
        assert_eq!(got, expected);
        assert_eq!(s.counters.grid_rewinds, 0);
        assert_eq!(s.counters.duplicate_packets, 3);
    }

    #[test]
    fn a_burst_stamped_ahead_does_not_confirm_its_jump() {
        // Issue 24 item 6: two packets 9.9 s ahead confirm one another, but 0.2 s of stream
        // does not confirm a 9.9 s jump: the real packets landing in the gap rewind the grid
        // and none of them is dropped.
        let mut s = Sequencer::new(StreamConfig {
            reorder_window_packets: 0,
            ..StreamConfig::default()
        });
        let got = offer_all(
            &mut s,
            vec![
                packet(0, 10, 0),
                packet(1000, 10, 1),
                packet(1010, 10, 2),
                packet(10, 10, 3),
                packet(20, 10, 4),
                packet(30, 10, 5),
                packet(40, 10, 6),
            ],
        );
        assert_eq!(
            got,
            vec![
                (0, 10, Gap::Start),
                (1000, 10, Gap::Break(990)),
                (1010, 10, Gap::None),
                (10, 10, Gap::Rewind),
                (20, 10, Gap::None),
                (30, 10, Gap::None),
                (40, 10, Gap::None),
            ]
        );
        assert_eq!(s.counters.grid_rewinds, 1);
        assert_eq!(s.counters.duplicate_packets, 0);
    }
}
