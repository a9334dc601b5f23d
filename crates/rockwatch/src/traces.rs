//! What the node keeps of its recent data for display (the web dashboard) and event reports:
//! each station's last [`RETENTION_S`] of its three components, each rock's θ/α and slide
//! traces of its current or last episode with its alerts, each station's running intensity
//! measures. Filled on the event loop's thread ([`Traces::push_packet`] before the engine
//! takes a packet, [`Traces::observe`] for each publication), never waiting for anyone; a
//! [`TracesSnapshot`] (shared, immutable) is taken once per status period and handed to the
//! web thread the way the status is (a `watch`, the latest replaces the previous). A snapshot
//! copies the rings of the stations the web side asked for in the last [`WANTED_FOR`] only
//! ([`WantedStations`]; 16.8 kB a ring): a node of thousands of stations copies what its
//! viewers look at, not every ring every period.
//!
//! Bounded, allocated up front:
//! - [`StationTrace`]: a ring of [`BINS`] time-aligned bins of [`BIN_NS`] each (bin `k`
//!   covers data time `[k·BIN_NS, (k+1)·BIN_NS)`), each holding the minimum and maximum of
//!   each component over its samples: a min/max envelope (every peak stays visible at any
//!   zoom, unlike picking every n-th sample). Allocated when the station is configured (at
//!   start, or by a reload), never per sample; a gap in the data leaves empty bins, a late
//!   packet fills its bins if they are still in the ring, older samples are ignored
//!   (counted).
//! - [`EpisodeTrace`]: from a rock's `motion_onset` alert (a new episode number) on, at most
//!   [`EPISODE_POINTS`] points (from its states, every
//!   `engine.state_interval_s` while it moves and at each mode change, and from its alerts)
//!   and [`EPISODE_MARKS`] alert marks; when the points are full every other one is dropped
//!   and from then on only every 2nd (4th, …) state is kept: the whole episode at a coarser
//!   step. An alert's point is always added (a later thinning drops it like any other); its
//!   mark is kept with the marks.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::ports::Publication;
use rockwatch_core::dynamics::Mode;
use rockwatch_core::engine::{AccelPacket, AlertLevel, SampleUnit, StationIntensity};

/// Data seconds each station's ring holds (`/api/stations/{id}/trace?seconds=` at most).
pub const RETENTION_S: u32 = 120;

/// Bins of a station's ring.
pub const BINS: usize = 600;

/// Data time per bin (ns): [`RETENTION_S`] / [`BINS`] = 0.2 s.
pub const BIN_NS: i64 = RETENTION_S as i64 * 1_000_000_000 / BINS as i64;

/// A packet stamped further than this ahead of the node's clock (UTC) is not taken: one bad
/// stamp would otherwise move the ring into the future and leave the real data "too old".
pub const MAX_AHEAD_NS: i64 = 60_000_000_000;

/// Most points of one rock's episode trace.
pub const EPISODE_POINTS: usize = 1024;

/// Most alert marks of one episode (there are three levels; a restart may repeat them).
pub const EPISODE_MARKS: usize = 8;

/// The components of a station's trace, in order: east, north, up (as the packets carry
/// them: the sensor's first, second and vertical channels, before any `orientation`).
pub const COMPONENTS: [&str; 3] = ["E", "N", "Z"];

/// One bin of a station's ring: the extremes of each component (m/s²) over its samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bin {
    pub min: [f32; 3],
    pub max: [f32; 3],
    /// Samples taken into the bin (0: no data in that time; a component without data, e.g.
    /// a packet without `up`, keeps min > max).
    pub samples: u32,
}

impl Bin {
    const EMPTY: Bin = Bin {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
        samples: 0,
    };
}

/// One station's recent data: a min/max envelope ring (see the module's doc).
#[derive(Debug, Clone)]
pub struct StationTrace {
    bins: Box<[Bin]>,
    /// Absolute index (data time / [`BIN_NS`]) of the newest bin, once data came.
    newest: Option<i64>,
    /// (m/s²)/count, for packets in counts.
    gain_mps2_per_count: Option<f64>,
    /// Samples older than the ring, ignored.
    pub too_old_samples: u64,
    /// Packets not taken (no usable rate, components of different lengths, counts without
    /// a gain, an unknown unit, stamped more than [`MAX_AHEAD_NS`] ahead of the clock): the
    /// engine refuses and reports most of them too.
    pub refused_packets: u64,
}

impl StationTrace {
    #[must_use]
    pub fn new(gain_mps2_per_count: Option<f64>) -> StationTrace {
        StationTrace {
            bins: vec![Bin::EMPTY; BINS].into_boxed_slice(),
            newest: None,
            gain_mps2_per_count,
            too_old_samples: 0,
            refused_packets: 0,
        }
    }

    /// Takes in one packet's samples (no allocation), `now_ns` being UTC now (ns since the
    /// Unix epoch).
    pub fn push(&mut self, packet: &AccelPacket, now_ns: i64) {
        let scale = match (packet.unit, self.gain_mps2_per_count) {
            (SampleUnit::MetresPerSecondSquared, _) => 1.0,
            (SampleUnit::Counts, Some(gain)) => gain as f32,
            _ => {
                self.refused_packets += 1;
                return;
            }
        };
        let n = packet.east.len();
        let rate = packet.sample_rate_hz;
        if !(rate.is_finite() && (1.0..=10_000.0).contains(&rate))
            || packet.start_time_ns > now_ns.saturating_add(MAX_AHEAD_NS)
            || packet.north.len() != n
            || !(packet.up.is_empty() || packet.up.len() == n)
        {
            self.refused_packets += 1;
            return;
        }
        let step_ns = 1e9 / rate;
        for i in 0..n {
            let t = packet
                .start_time_ns
                .saturating_add((i as f64 * step_ns).round() as i64);
            let k = t.div_euclid(BIN_NS);
            if !self.advance_to(k) {
                self.too_old_samples += 1;
                continue;
            }
            let bin = &mut self.bins[k.rem_euclid(BINS as i64) as usize];
            bin.samples += 1;
            let values = [
                Some(packet.east[i]),
                Some(packet.north[i]),
                packet.up.get(i).copied(),
            ];
            for (c, v) in values.into_iter().enumerate() {
                if let Some(v) = v.map(|v| v * scale).filter(|v| v.is_finite()) {
                    bin.min[c] = bin.min[c].min(v);
                    bin.max[c] = bin.max[c].max(v);
                }
            }
        }
    }

    /// Makes bin `k` the newest if it is later (clearing the bins skipped, at most
    /// [`BINS`]); false if `k` is older than the ring.
    fn advance_to(&mut self, k: i64) -> bool {
        let Some(newest) = self.newest else {
            self.newest = Some(k);
            return true;
        };
        if k <= newest {
            return k > newest - BINS as i64;
        }
        let from = (newest + 1).max(k - BINS as i64 + 1);
        for j in from..=k {
            self.bins[j.rem_euclid(BINS as i64) as usize] = Bin::EMPTY;
        }
        self.newest = Some(k);
        true
    }

    /// The ring, oldest bin first.
    #[must_use]
    pub fn view(&self) -> StationTraceView {
        let bins = match self.newest {
            None => Vec::new(),
            Some(newest) => (newest - BINS as i64 + 1..=newest)
                .map(|k| self.bins[k.rem_euclid(BINS as i64) as usize])
                .collect(),
        };
        StationTraceView {
            first_bin: self.newest.map(|n| n - BINS as i64 + 1),
            bins,
        }
    }
}

/// A copy of a station's ring, oldest bin first.
#[derive(Debug, Clone, PartialEq)]
pub struct StationTraceView {
    /// Absolute index of `bins[0]` (its start is `first_bin · BIN_NS`, ns since the Unix
    /// epoch); None before any data.
    pub first_bin: Option<i64>,
    /// [`BINS`] bins (none before any data).
    pub bins: Vec<Bin>,
}

impl StationTraceView {
    /// The newest bins covering `seconds` of data time (at least one bin).
    #[must_use]
    pub fn last(&self, seconds: f64) -> (Option<i64>, &[Bin]) {
        let want = ((seconds * 1e9 / BIN_NS as f64).ceil() as usize).clamp(1, BINS);
        let skip = self.bins.len().saturating_sub(want);
        (self.first_bin.map(|f| f + skip as i64), &self.bins[skip..])
    }
}

/// One point of an episode trace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpisodePoint {
    /// Data time (ns since the Unix epoch).
    pub data_time_ns: i64,
    /// θ/α, signed (dimensionless; |θ/α| = 1 is the static overturning angle).
    pub theta_over_alpha: f64,
    /// Slide displacement (m).
    pub slide_m: f64,
    pub mode: Mode,
}

/// An alert of an episode, where the trace marks it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlertMark {
    pub data_time_ns: i64,
    pub level: AlertLevel,
    pub theta_over_alpha: f64,
    pub overturn_probability: f64,
}

/// One rock's current or last episode (see the module's doc for the bounds).
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeTrace {
    /// The episode's number (its alerts'), None if no alert of it was seen (e.g. motion that
    /// stayed below every alert).
    pub episode: Option<u32>,
    pub points: Vec<EpisodePoint>,
    pub marks: Vec<AlertMark>,
    /// The rock is at rest or fallen again: the episode is over.
    pub ended: bool,
    /// One state in `stride` is kept (1, then 2, 4, … once the points have filled up).
    pub stride: u32,
    /// States seen since the last one kept.
    skipped: u32,
}

impl Default for EpisodeTrace {
    fn default() -> Self {
        EpisodeTrace {
            episode: None,
            // Reserved at the rock's first episode ([`EpisodeTrace::restart`]): a rock that
            // never moves costs no buffer.
            points: Vec::new(),
            marks: Vec::new(),
            ended: true,
            stride: 1,
            skipped: 0,
        }
    }
}

impl EpisodeTrace {
    /// Starts afresh (the buffers, allocated at the first episode, are kept).
    fn restart(&mut self, episode: Option<u32>) {
        self.episode = episode;
        self.points.clear();
        self.marks.clear();
        self.points.reserve_exact(EPISODE_POINTS);
        self.marks.reserve_exact(EPISODE_MARKS);
        self.ended = false;
        self.stride = 1;
        self.skipped = 0;
    }

    /// Appends `point` (unless the stride skips it: then false); when full, every other
    /// point is dropped first and the stride doubles.
    fn add(&mut self, point: EpisodePoint, always: bool) -> bool {
        if !always {
            self.skipped += 1;
            if self.skipped < self.stride {
                return false;
            }
        }
        self.skipped = 0;
        if self.points.len() == EPISODE_POINTS {
            let mut i = 0;
            self.points.retain(|_| {
                i += 1;
                i % 2 == 1
            });
            self.stride = self.stride.saturating_mul(2);
        }
        self.points.push(point);
        true
    }

    /// Takes in one of the rock's states. A state never starts a new trace: an episode may
    /// hold brief rests (the engine ends it after a quiet time), and the next episode starts
    /// with its `motion_onset` alert ([`EpisodeTrace::alert`]). Returns whether the trace
    /// changed (a rock at rest or fallen, already recorded so, leaves it as it was).
    pub fn state(&mut self, point: EpisodePoint) -> bool {
        let moving = !matches!(point.mode, Mode::Rest | Mode::Overturned | Mode::Flight);
        if self.ended && !moving {
            return false; // at rest (or fallen) and already recorded so
        }
        let added = self.add(point, !moving);
        let ended_changed = self.ended == moving;
        self.ended = !moving;
        added || ended_changed
    }

    /// Takes in one of the rock's alerts: a mark, and a point (always added). An alert of
    /// another episode starts that episode.
    pub fn alert(&mut self, episode: u32, mark: AlertMark, point: EpisodePoint) {
        if self.episode != Some(episode) {
            self.restart(Some(episode));
        }
        if self.marks.len() < EPISODE_MARKS {
            self.marks.push(mark);
        }
        let _ = self.add(point, true);
        if matches!(point.mode, Mode::Overturned | Mode::Flight) {
            self.ended = true;
        }
    }
}

/// How long a station's ring stays in the snapshots after the web side last asked for it.
pub const WANTED_FOR: Duration = Duration::from_secs(10);

/// The stations whose traces the web side asked for lately: marked by the web thread (only
/// stations the node has: at most one entry each), read by the event loop at each snapshot
/// with `try_lock` — when the web thread holds the lock, the event loop takes the previous
/// period's set instead of waiting.
#[derive(Debug, Default)]
pub struct WantedStations(Mutex<HashMap<String, Instant>>);

impl WantedStations {
    /// Asks for `station`'s ring in the snapshots of the next [`WANTED_FOR`].
    pub fn mark(&self, station: &str) {
        if let Ok(mut wanted) = self.0.lock() {
            match wanted.get_mut(station) {
                Some(at) => *at = Instant::now(),
                None => {
                    wanted.insert(station.to_string(), Instant::now());
                }
            }
        }
    }
}

/// What the event loop keeps (see the module's doc).
#[derive(Debug, Default)]
pub struct Traces {
    stations: HashMap<String, StationTrace>,
    /// The stations of the last [`WantedStations`] read (kept when the lock was busy).
    wanted: Vec<String>,
    rocks: HashMap<String, Rock>,
    intensities: HashMap<String, Arc<StationIntensity>>,
    /// Packets of stations without a trace (not configured here).
    pub untraced_packets: u64,
}

#[derive(Debug, Default)]
struct Rock {
    trace: EpisodeTrace,
    /// The trace changed since the last snapshot.
    changed: bool,
    /// The last snapshot's copy.
    shared: Arc<EpisodeTrace>,
}

impl Traces {
    /// A ring for each station of `stations` (id, gain in (m/s²)/count), allocated now.
    #[must_use]
    pub fn new(stations: &[(String, Option<f64>)]) -> Traces {
        let mut traces = Traces::default();
        traces.configure(stations);
        traces
    }

    /// After a reload: a ring for each new station (the others keep theirs; a removed
    /// station's is dropped).
    pub fn configure(&mut self, stations: &[(String, Option<f64>)]) {
        self.stations
            .retain(|id, _| stations.iter().any(|(s, _)| s == id));
        for (id, gain) in stations {
            match self.stations.get_mut(id) {
                Some(trace) => trace.gain_mps2_per_count = *gain,
                None => {
                    self.stations.insert(id.clone(), StationTrace::new(*gain));
                }
            }
        }
    }

    /// Takes in one packet (before the engine does; no allocation).
    pub fn push_packet(&mut self, packet: &AccelPacket) {
        match self.stations.get_mut(packet.station.as_str()) {
            Some(trace) => {
                let now_ns = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(i64::MAX, |d| {
                        i64::try_from(d.as_nanos()).unwrap_or(i64::MAX)
                    });
                trace.push(packet, now_ns);
            }
            None => self.untraced_packets += 1,
        }
    }

    /// Takes in one publication: states and alerts into their rock's episode trace,
    /// intensities as their station's latest.
    pub fn observe(&mut self, publication: &Publication) {
        match publication {
            Publication::State(s) => {
                let rock = self.rock(s.pbr_id.as_str());
                rock.changed |= rock.trace.state(EpisodePoint {
                    data_time_ns: s.data_time_ns,
                    theta_over_alpha: s.theta_over_alpha,
                    slide_m: s.slide_m,
                    mode: s.mode,
                });
            }
            Publication::Alert { alert: a, .. } => {
                let rock = self.rock(a.pbr_id.as_str());
                rock.trace.alert(
                    a.episode,
                    AlertMark {
                        data_time_ns: a.data_time_ns,
                        level: a.level,
                        theta_over_alpha: a.theta_over_alpha,
                        overturn_probability: a.overturn_probability,
                    },
                    EpisodePoint {
                        data_time_ns: a.data_time_ns,
                        theta_over_alpha: a.theta_over_alpha,
                        slide_m: a.slide_m,
                        mode: a.mode,
                    },
                );
                rock.changed = true;
            }
            Publication::Intensity(i) => {
                if self.stations.contains_key(i.station.as_str()) {
                    self.intensities
                        .insert(i.station.to_string(), Arc::new(i.clone()));
                }
            }
            Publication::Reset(_) => {}
        }
    }

    /// The rock's entry (made at its first state or alert: one per rock of the node).
    fn rock(&mut self, pbr_id: &str) -> &mut Rock {
        if !self.rocks.contains_key(pbr_id) {
            self.rocks.insert(pbr_id.to_string(), Rock::default());
        }
        self.rocks.get_mut(pbr_id).expect("inserted above")
    }

    /// A station's ring.
    #[must_use]
    pub fn station(&self, id: &str) -> Option<&StationTrace> {
        self.stations.get(id)
    }

    /// A station's last intensity measures.
    #[must_use]
    pub fn intensity(&self, station: &str) -> Option<&Arc<StationIntensity>> {
        self.intensities.get(station)
    }

    /// A rock's episode trace.
    #[must_use]
    pub fn episode(&self, pbr_id: &str) -> Option<&EpisodeTrace> {
        self.rocks.get(pbr_id).map(|r| &r.trace)
    }

    /// A copy for the web thread: the rings of the stations `wanted` lists, the trace of every
    /// rock that has had an episode (copied only when it changed since the last snapshot),
    /// the intensities. Never waits on `wanted` (see [`WantedStations`]).
    pub fn snapshot(&mut self, wanted: &WantedStations) -> TracesSnapshot {
        if let Ok(mut asked) = wanted.0.try_lock() {
            asked.retain(|_, at| at.elapsed() < WANTED_FOR);
            self.wanted.clear();
            self.wanted.extend(asked.keys().cloned());
        }
        let rocks = self
            .rocks
            .iter_mut()
            .filter(|(_, rock)| rock.trace.episode.is_some() || !rock.trace.points.is_empty())
            .map(|(id, rock)| {
                if rock.changed {
                    rock.shared = Arc::new(rock.trace.clone());
                    rock.changed = false;
                }
                (id.clone(), Arc::clone(&rock.shared))
            })
            .collect();
        TracesSnapshot {
            stations: self
                .wanted
                .iter()
                .filter_map(|id| self.stations.get(id).map(|t| (id.clone(), t.view())))
                .collect(),
            rocks,
            intensities: self.intensities.clone(),
        }
    }
}

/// The traces at one instant, for the web thread.
#[derive(Debug, Clone, Default)]
pub struct TracesSnapshot {
    pub stations: HashMap<String, StationTraceView>,
    pub rocks: HashMap<String, Arc<EpisodeTrace>>,
    pub intensities: HashMap<String, Arc<StationIntensity>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// UTC now in the tests (2024).
    const NOW: i64 = 1_700_000_000_000_000_000;

    fn packet(start_s: f64, rate: f64, east: Vec<f32>) -> AccelPacket {
        let n = east.len();
        AccelPacket {
            station: rockwatch_core::engine::StationId::parse("XX.STA.00").unwrap(),
            start_time_ns: (start_s * 1e9) as i64,
            sample_rate_hz: rate,
            sequence: 0,
            north: east.iter().map(|v| -v).collect(),
            east,
            up: vec![0.5; n],
            unit: SampleUnit::MetresPerSecondSquared,
        }
    }

    #[test]
    fn a_snapshot_copies_the_rings_asked_for_and_never_waits_for_the_lock() {
        let ids = ["XX.A.00", "XX.B.00", "XX.C.00"];
        let stations: Vec<(String, Option<f64>)> =
            ids.iter().map(|id| (id.to_string(), None)).collect();
        let mut traces = Traces::new(&stations);
        let wanted = WantedStations::default();
        assert!(traces.snapshot(&wanted).stations.is_empty());
        wanted.mark("XX.B.00");
        let snapshot = traces.snapshot(&wanted);
        assert_eq!(snapshot.stations.keys().collect::<Vec<_>>(), ["XX.B.00"]);
        // The web thread holds the lock: the event loop takes the previous set, at once.
        let held = wanted.0.lock().unwrap();
        let snapshot = traces.snapshot(&wanted);
        assert_eq!(snapshot.stations.keys().collect::<Vec<_>>(), ["XX.B.00"]);
        drop(held);
        // An entry older than WANTED_FOR goes.
        wanted
            .0
            .lock()
            .unwrap()
            .insert("XX.B.00".into(), Instant::now() - WANTED_FOR);
        assert!(traces.snapshot(&wanted).stations.is_empty());
        assert!(wanted.0.lock().unwrap().is_empty());
    }

    #[test]
    fn the_envelope_keeps_every_peak_and_each_bin_its_own_time() {
        let mut t = StationTrace::new(None);
        // 100 Hz for 10 s: a sine, plus one spike of one sample at 3.01 s.
        let rate = 100.0;
        let mut east: Vec<f32> = (0..1000)
            .map(|i| (2.0 * std::f32::consts::PI * 1.3 * i as f32 / 100.0).sin())
            .collect();
        east[301] = 7.0;
        // In packets of 50 samples.
        for (j, chunk) in east.chunks(50).enumerate() {
            t.push(&packet(1000.0 + j as f64 * 0.5, rate, chunk.to_vec()), NOW);
        }
        let view = t.view();
        assert_eq!(view.bins.len(), BINS);
        let first = view.first_bin.unwrap();
        // The newest bin holds 9.8 .. 10.0 s after the start.
        assert_eq!(
            first + BINS as i64 - 1,
            ((1000.0 + 9.99) * 1e9) as i64 / BIN_NS
        );
        let (start, bins) = view.last(10.0);
        assert_eq!(bins.len(), 50);
        assert_eq!(start, Some((1000.0 * 1e9) as i64 / BIN_NS));
        // Every bin: its 20 samples' extremes, computed here independently.
        for (b, bin) in bins.iter().enumerate() {
            let s = &east[b * 20..(b + 1) * 20];
            let max = s.iter().copied().fold(f32::MIN, f32::max);
            let min = s.iter().copied().fold(f32::MAX, f32::min);
            assert_eq!((bin.min[0], bin.max[0]), (min, max), "bin {b}");
            assert_eq!((bin.min[1], bin.max[1]), (-max, -min));
            assert_eq!((bin.min[2], bin.max[2], bin.samples), (0.5, 0.5, 20));
        }
        // The one-sample spike survives decimation.
        assert_eq!(bins[15].max[0], 7.0);
    }

    #[test]
    fn a_gap_leaves_empty_bins_and_old_samples_are_ignored() {
        let mut t = StationTrace::new(Some(2.0));
        let mut p = packet(0.0, 10.0, vec![1.0; 10]);
        p.unit = SampleUnit::Counts;
        t.push(&p, NOW);
        // 5 s later (a gap of 4 s), then 200 s later (the whole ring replaced).
        p.start_time_ns = 5_000_000_000;
        t.push(&p, NOW);
        let view = t.view();
        let (_, bins) = view.last(6.0);
        let filled: Vec<bool> = bins.iter().map(|b| b.samples > 0).collect();
        assert_eq!(filled.iter().filter(|f| **f).count(), 10, "{filled:?}");
        assert_eq!(bins.last().unwrap().max[0], 2.0, "counts × gain");
        p.start_time_ns = 200_000_000_000;
        t.push(&p, NOW);
        assert_eq!(t.view().bins.iter().filter(|b| b.samples > 0).count(), 5);
        // Data from before the ring: ignored, counted.
        p.start_time_ns = 0;
        t.push(&p, NOW);
        assert_eq!(t.too_old_samples, 10);
        // A packet from the future: refused, the ring untouched.
        let before = t.view();
        p.start_time_ns = NOW + MAX_AHEAD_NS + 1;
        t.push(&p, NOW);
        assert_eq!((t.refused_packets, t.view()), (1, before));
        p.start_time_ns = 0;
        // Counts without a gain: refused.
        let mut t = StationTrace::new(None);
        t.push(&p, NOW);
        assert_eq!((t.refused_packets, t.view().first_bin), (1, None));
        assert_eq!(p.start_time_ns, 0);
    }

    fn point(t: i64, theta: f64, mode: Mode) -> EpisodePoint {
        EpisodePoint {
            data_time_ns: t,
            theta_over_alpha: theta,
            slide_m: 0.0,
            mode,
        }
    }

    #[test]
    fn an_episode_trace_is_bounded_and_a_new_episode_starts_afresh() {
        let mut e = EpisodeTrace::default();
        // A rock that never moved holds no buffer, and its rest states change nothing.
        assert_eq!((e.points.capacity(), e.marks.capacity()), (0, 0));
        assert!(!e.state(point(-1, 0.0, Mode::Rest)));
        let mark = |t| AlertMark {
            data_time_ns: t,
            level: AlertLevel::MotionOnset,
            theta_over_alpha: 0.1,
            overturn_probability: 0.0,
        };
        e.alert(1, mark(0), point(0, 0.1, Mode::Rock));
        let capacity = e.points.capacity();
        assert_eq!(capacity, EPISODE_POINTS);
        for i in 1..=10 * EPISODE_POINTS as i64 {
            e.state(point(i, 0.2, Mode::Rock));
            assert!(e.points.len() <= EPISODE_POINTS);
        }
        // Still the whole episode, at a coarser step; no reallocation.
        assert_eq!(e.points[0].data_time_ns, 0);
        assert!(e.points.last().unwrap().data_time_ns > 9 * EPISODE_POINTS as i64);
        assert!(e.stride >= 8 && e.points.capacity() == capacity);
        e.state(point(1 << 40, 0.0, Mode::Rest));
        assert!(e.ended);
        // At rest again: nothing more recorded, and the trace did not change.
        let n = e.points.len();
        assert!(!e.state(point(1 << 41, 0.0, Mode::Rest)));
        assert_eq!(e.points.len(), n);
        // Moving again within the same episode (no new onset): the same trace goes on.
        e.alert(1, mark(6), point(3 << 40, 0.9, Mode::Rock));
        e.state(point(4 << 40, 0.5, Mode::Rock));
        // (the alert's point always kept; the state's as the stride says)
        assert_eq!((e.episode, e.marks.len()), (Some(1), 2));
        assert!(e.points.iter().any(|p| p.data_time_ns == 3 << 40) && e.points.len() > n);
        assert!(!e.ended);
        // The next episode's onset: a fresh trace.
        e.alert(2, mark(5), point(5 << 40, 0.1, Mode::Rock));
        assert_eq!((e.episode, e.points.len(), e.marks.len()), (Some(2), 1, 1));
        assert!(!e.ended);
    }
}
