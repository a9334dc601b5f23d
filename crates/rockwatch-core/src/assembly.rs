//! Assembling acceleration packets from the separate component records of a station (as
//! SeedLink delivers them): each record is calibrated with its StationXML epoch (counts →
//! m/s²), placed on the station's sample grid, and as soon as all components cover a span the
//! span is rotated to east/north/up ([`ChannelsToEnu`]) and emitted as an [`AccelPacket`].
//!
//! - A station is `NET.STA.LOC` with one band+instrument code (`HN`, `HL`, …): the first code
//!   seen for a `NET.STA.LOC` is assembled; records of another code are refused (counted).
//! - Its components are the channels of that code in the inventory at the first record's
//!   time (2 horizontal, or 3); their gains and axes come from there, and are looked up again
//!   when a record falls outside the cached epoch.
//! - Grid: the earliest record before the first packet is index 0; a record whose start is
//!   more than
//!   [`MAX_ALIGNMENT_OFFSET_SAMPLES`] of a sample off the grid, or at another rate, is refused.
//! - Values: a record holding a sample that is not finite or beyond ±100 g once calibrated
//!   ([`MAX_ABS_ACCEL_MPS2`]) is refused whole (corrupt, not clipped). A refused record is
//!   never placed: it costs its own span at most, and its stream's other records go on.
//! - Overlaps with what was emitted are trimmed (counted); gaps stay gaps (the engine bridges
//!   or breaks them).
//! - A component that lags: after `max_wait_ns` (caller's clock: wall time in `acquire`,
//!   anything in tests) what is there is emitted with zeros for the missing samples, counted.
//!
//! - Velocity channels (only with `differentiate_velocity`): their counts are differentiated
//!   on the grid ([`crate::differentiate`]: central differences, one-sided at the ends of a
//!   contiguous run), continuously across records; a component's latest sample waits for its
//!   successor, or for `max_wait_ns` like a missing component (then a backward difference).
//!
//! Work per record is bounded by the record; memory per station by `max_buffer_s`.

use std::collections::{HashMap, VecDeque};

use crate::azimuth::ChannelsToEnu;
use crate::differentiate::Differentiator;
use crate::engine::{AccelPacket, StationId};
use crate::inventory::{Calibration, ChannelEpoch, Inventory, LookupError, SensorInput};
use crate::record::mseed::{Channel, MAX_ALIGNMENT_OFFSET_SAMPLES, NS_PER_S};
use crate::record::MAX_ABS_ACCEL_MPS2;

/// Assembly settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AssemblyConfig {
    /// How long a span waits for a missing component before it is emitted without it (ns,
    /// on the caller's clock; `acquire` counts only time the link is up). Components arrive
    /// record by record, each record when its digitizer filled it: this must exceed the
    /// duration of one record of the slowest-filling component (a 512-byte Steim-2 record
    /// holds up to ~8 s at 100 Hz), or live data would be zero-filled at record boundaries.
    pub max_wait_ns: i64,
    /// Most samples per packet (longer spans are cut).
    pub max_packet_samples: usize,
    /// Most data held per component waiting for the others (s of data); beyond, the oldest
    /// is emitted as if the wait had run out.
    pub max_buffer_s: f64,
    /// Velocity channels are differentiated to acceleration (else refused).
    pub differentiate_velocity: bool,
}

impl Default for AssemblyConfig {
    fn default() -> Self {
        AssemblyConfig {
            max_wait_ns: 30 * NS_PER_S,
            max_packet_samples: 1000,
            max_buffer_s: 600.0,
            differentiate_velocity: false,
        }
    }
}

/// What the assembler did (monotonic).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct AssemblyCounters {
    pub records: u64,
    pub packets: u64,
    pub samples: u64,
    /// Records refused: channel not in the inventory, unusable, other rate, off the grid,
    /// second band code, too many components, empty.
    pub refused_records: u64,
    /// Samples already emitted when their record arrived (dropped).
    pub overlap_samples: u64,
    /// Samples emitted as zero because their component had not arrived in time.
    pub missing_component_samples: u64,
    /// Records refused for starting more than `max_buffer_s` after what the station holds
    /// (included in `refused_records`), and station grids restarted because its components
    /// all moved there (an outage longer than `max_buffer_s`).
    pub far_ahead_records: u64,
    pub grid_restarts: u64,
    /// Records refused for claiming another sampling rate than their station's (or their
    /// inventory epoch's); included in `refused_records`.
    pub other_rate_records: u64,
    /// Records refused for impossible values: a sample not finite, or beyond ±100 g once
    /// calibrated ([`MAX_ABS_ACCEL_MPS2`]); included in `refused_records`. Never used, never
    /// counted as clipping.
    pub implausible_records: u64,
}

/// Why a record was refused (the caller logs it once per stream).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordIssue {
    #[error(transparent)]
    Inventory(#[from] LookupError),
    #[error("station {station} is assembled from {assembled}?; {channel} ignored")]
    OtherBand {
        station: String,
        assembled: String,
        channel: String,
    },
    #[error("{0}")]
    Grid(String),
    #[error("{channel}: record starts {ahead_s:.0} s after the station's data, more than max_buffer_s; refused (the station's grid restarts there once its components all move on)")]
    FarAhead { channel: String, ahead_s: f64 },
    #[error("{0}")]
    Orientation(String),
    #[error("{channel}: {record_hz} Hz, but the station is assembled at {station_hz} Hz; refused")]
    OtherRate {
        channel: String,
        record_hz: f64,
        station_hz: f64,
    },
    #[error("{channel}: impossible sample values ({value:e} counts, {mps2:e} m/s² calibrated; the limit is ±{MAX_ABS_ACCEL_MPS2} m/s², 100 g): corrupt data; refused, not used")]
    Implausible {
        channel: String,
        value: f64,
        mps2: f64,
    },
}

impl RecordIssue {
    /// Whether the record claims another sampling rate than its station or its epoch.
    #[must_use]
    pub fn is_other_rate(&self) -> bool {
        matches!(
            self,
            RecordIssue::OtherRate { .. }
                | RecordIssue::Inventory(LookupError::RateMismatch { .. })
        )
    }
}

/// One component of a station.
#[derive(Debug)]
struct Component {
    /// `NET.STA.LOC.CHA`.
    id: String,
    calibration: Calibration,
    /// The cached epoch `[from, to)` (ns); outside it, look up again.
    valid: EpochBounds,
    /// Counts (velocity channels: counts per second, differentiated) from grid index
    /// `emitted` on; NaN where nothing arrived.
    buffer: VecDeque<f64>,
    /// The differentiator of a velocity channel.
    diff: Option<Differentiator>,
}

#[derive(Debug)]
struct StationAssembly {
    id: StationId,
    band: String,
    rate_hz: f64,
    t0_ns: i64,
    /// Grid index of the next sample to emit.
    emitted: i64,
    components: Vec<Component>,
    to_enu: ChannelsToEnu,
    /// Caller time since which data beyond `emitted` has waited for a lagging component.
    waiting_since: Option<i64>,
    sequence: u64,
    /// Records in a row refused as far ahead (kept, to be placed if the grid restarts).
    far_ahead: Vec<Channel>,
}

/// The assembler of every station.
pub struct Assembler {
    /// The inventory split by station (`NET.STA.LOC`): lookups scan one station's epochs.
    inventory: HashMap<String, Inventory>,
    /// For stations the inventory does not have.
    empty: Inventory,
    config: AssemblyConfig,
    stations: HashMap<String, StationAssembly>,
    counters: AssemblyCounters,
    /// (grid index, value) of the record being placed (reused).
    scratch: Vec<(i64, f64)>,
}

impl Assembler {
    #[must_use]
    pub fn new(inventory: Inventory, config: AssemblyConfig) -> Assembler {
        let mut by_station: HashMap<String, Inventory> = HashMap::new();
        for epoch in inventory.channels {
            let key = format!("{}.{}.{}", epoch.network, epoch.station, epoch.location);
            by_station.entry(key).or_default().channels.push(epoch);
        }
        Assembler {
            inventory: by_station,
            empty: Inventory::default(),
            config,
            stations: HashMap::new(),
            counters: AssemblyCounters::default(),
            scratch: Vec::new(),
        }
    }

    #[must_use]
    pub fn counters(&self) -> AssemblyCounters {
        self.counters
    }

    /// Adds one decoded record (one channel; integer counts or floats in the inventory's
    /// input units) received at `now_ns` (caller's clock); every packet that becomes ready is
    /// passed to `out`.
    pub fn push(
        &mut self,
        record: &Channel,
        now_ns: i64,
        out: &mut dyn FnMut(AccelPacket),
    ) -> Result<(), RecordIssue> {
        self.counters.records += 1;
        // The station's `NET.STA.LOC`, formed once per record.
        let key = format!("{}.{}.{}", record.net, record.sta, record.loc);
        let mut result = self.place(record, &key, now_ns);
        if matches!(result, Err(RecordIssue::FarAhead { .. })) {
            self.counters.far_ahead_records += 1;
            // Every component (as many records in a row) has moved on: an outage longer than
            // max_buffer_s, not one bad time stamp. What is held goes out (missing parts as
            // zeros), and the station starts again on a grid at this record (a gap for the
            // engine) — no buffer spanning the outage is ever allocated.
            let restart = self
                .stations
                .get(&key)
                .is_some_and(|s| s.far_ahead.len() >= s.components.len().max(2));
            if restart {
                let mut earlier = Vec::new();
                if let Some(mut station) = self.stations.remove(&key) {
                    flush_derivatives(&mut station, &mut self.counters);
                    emit_ready(
                        &mut station,
                        &self.config,
                        &mut self.counters,
                        i64::MAX,
                        out,
                    );
                    earlier = std::mem::take(&mut station.far_ahead);
                }
                self.counters.grid_restarts += 1;
                // The records refused on the way are placed after all, in arrival order.
                if let Some((_current, before)) = earlier.split_last() {
                    for r in before {
                        let _ = self.place(r, &key, now_ns);
                    }
                }
                result = self.place(record, &key, now_ns);
            }
        }
        if let Err(issue) = &result {
            self.counters.refused_records += 1;
            if issue.is_other_rate() {
                self.counters.other_rate_records += 1;
            }
            if matches!(issue, RecordIssue::Implausible { .. }) {
                self.counters.implausible_records += 1;
            }
        }
        if let Some(station) = self.stations.get_mut(&key) {
            emit_ready(station, &self.config, &mut self.counters, now_ns, out);
        }
        result
    }

    /// Emits what has waited longer than `max_wait_ns` at `now_ns` (call regularly).
    pub fn tick(&mut self, now_ns: i64, out: &mut dyn FnMut(AccelPacket)) {
        for station in self.stations.values_mut() {
            if station.timed_out(&self.config, now_ns) {
                flush_derivatives(station, &mut self.counters);
            }
            emit_ready(station, &self.config, &mut self.counters, now_ns, out);
        }
    }

    /// Emits everything held, missing components as zeros (at shutdown).
    pub fn flush(&mut self, out: &mut dyn FnMut(AccelPacket)) {
        for station in self.stations.values_mut() {
            flush_derivatives(station, &mut self.counters);
            emit_ready(station, &self.config, &mut self.counters, i64::MAX, out);
        }
    }

    /// Time before which every sample of `NET.STA.LOC` has been emitted (ns).
    #[must_use]
    pub fn emitted_until_ns(&self, station: &str) -> Option<i64> {
        self.stations.get(station).map(|s| s.time_ns(s.emitted))
    }

    /// Places `record` of station `key` (its `NET.STA.LOC`).
    fn place(&mut self, record: &Channel, key: &str, now_ns: i64) -> Result<(), RecordIssue> {
        let id = record.id();
        let band: String = record.cha.chars().take(2).collect();
        let Some(first) = record.segments.first() else {
            return Ok(());
        };
        let t_ns = i128::from(first.start_time_ns);
        if !self.stations.contains_key(key) {
            let station = self.start_station(key, &band, record, first.start_time_ns)?;
            self.stations.insert(key.to_owned(), station);
        }
        let Some(station) = self.stations.get_mut(key) else {
            return Ok(());
        };
        if station.band != band {
            return Err(RecordIssue::OtherBand {
                station: key.to_owned(),
                assembled: station.band.clone(),
                channel: id,
            });
        }
        let Some(slot) = station.components.iter().position(|c| c.id == id) else {
            return Err(RecordIssue::Grid(format!(
                "{id}: not one of the station's components in the inventory"
            )));
        };
        // A new epoch (gain or axis changed): look up again and rebuild the rotation.
        let (from, to) = station.components[slot].valid;
        if from.is_some_and(|f| t_ns < f) || to.is_some_and(|e| t_ns >= e) {
            let inventory = self.inventory.get(key).unwrap_or(&self.empty);
            let (calibration, valid) = lookup(
                inventory,
                &id,
                t_ns,
                record.sample_rate_hz,
                self.config.differentiate_velocity,
            )?;
            let c = &mut station.components[slot];
            c.calibration = calibration;
            c.valid = valid;
            match calibration.input {
                SensorInput::Velocity => {
                    c.diff.get_or_insert_with(Differentiator::new);
                }
                SensorInput::Acceleration => c.diff = None,
            }
            let axes: Vec<_> = station
                .components
                .iter()
                .map(|c| (c.calibration.axis, c.calibration.gain_mps2_per_count))
                .collect();
            station.to_enu = ChannelsToEnu::new(&axes)
                .map_err(|e| RecordIssue::Orientation(format!("station {key}: {e}")))?;
        }
        if (record.sample_rate_hz - station.rate_hz).abs() > 1e-9 * station.rate_hz {
            return Err(RecordIssue::OtherRate {
                channel: id,
                record_hz: record.sample_rate_hz,
                station_hz: station.rate_hz,
            });
        }
        // Impossible values are refused whole (a record with one is corrupt), never placed.
        let gain = station.components[slot].calibration.gain_mps2_per_count;
        let impossible = record
            .segments
            .iter()
            .flat_map(|s| &s.samples)
            .find(|x| !(x.is_finite() && (*x * gain).abs() <= MAX_ABS_ACCEL_MPS2));
        if let Some(&value) = impossible {
            return Err(RecordIssue::Implausible {
                channel: id,
                value,
                mps2: value * gain,
            });
        }
        let limit = (self.config.max_buffer_s * station.rate_hz) as i64;
        let ahead = record
            .segments
            .iter()
            .map(|s| ((s.start_time_ns - station.t0_ns) as f64 * station.rate_hz * 1e-9).round())
            .fold(f64::MIN, f64::max);
        if ahead - station.emitted as f64 > limit.max(1) as f64 {
            // Bounded: at most one record per component is kept.
            if station.far_ahead.len() <= station.components.len() {
                station.far_ahead.push(record.clone());
            }
            return Err(RecordIssue::FarAhead {
                channel: id,
                ahead_s: (ahead - station.emitted as f64) / station.rate_hz,
            });
        }
        station.far_ahead.clear();
        for segment in &record.segments {
            let exact = (segment.start_time_ns - station.t0_ns) as f64 * station.rate_hz * 1e-9;
            let k = exact.round();
            if (exact - k).abs() > MAX_ALIGNMENT_OFFSET_SAMPLES {
                return Err(RecordIssue::Grid(format!(
                    "{id}: record at {} ns is {:.2} samples off the station's sample grid",
                    segment.start_time_ns,
                    exact - k
                )));
            }
            let mut k = k as i64;
            let mut samples = &segment.samples[..];
            if k < 0 && station.sequence == 0 && -k <= limit {
                // Nothing emitted yet: the grid starts at the earliest record (records of
                // the components arrive in any order after a (re)start).
                station.t0_ns = station.time_ns(k);
                for c in &mut station.components {
                    for _ in 0..-k {
                        c.buffer.push_front(f64::NAN);
                    }
                    if let Some(d) = &mut c.diff {
                        d.shift(-k);
                    }
                }
                k = 0;
            }
            let rate_hz = station.rate_hz;
            let scratch = &mut self.scratch;
            scratch.clear();
            match &mut station.components[slot].diff {
                Some(diff) => {
                    for (i, &x) in samples.iter().enumerate() {
                        let taken = diff.push(k + i as i64, x, &mut |j, d| {
                            scratch.push((j, d * rate_hz));
                        });
                        if !taken {
                            self.counters.overlap_samples += 1;
                        }
                    }
                }
                None => {
                    if k < station.emitted {
                        let skip = ((station.emitted - k) as usize).min(samples.len());
                        self.counters.overlap_samples += skip as u64;
                        samples = &samples[skip..];
                        k = station.emitted;
                    }
                    scratch.extend(samples.iter().enumerate().map(|(i, &x)| (k + i as i64, x)));
                }
            }
            if let Some(&(last, _)) = scratch.last() {
                if last - station.emitted + 1 > limit.max(1) {
                    // Too far ahead of a lagging component: give up waiting for the old data.
                    station.waiting_since = Some(i64::MIN);
                }
            }
            put(station, slot, scratch, &mut self.counters);
        }
        if station.waiting_since.is_none() {
            station.waiting_since = Some(now_ns);
        }
        Ok(())
    }

    fn start_station(
        &self,
        key: &str,
        band: &str,
        record: &Channel,
        start_ns: i64,
    ) -> Result<StationAssembly, RecordIssue> {
        let t_ns = i128::from(start_ns);
        let inventory = self.inventory.get(key).unwrap_or(&self.empty);
        let id = StationId::parse(key).map_err(|e| RecordIssue::Grid(format!("{key}: {e}")))?;
        // The components: the inventory's channels of this band at this time, by code.
        let prefix = format!("{key}.{band}");
        let differentiate = self.config.differentiate_velocity;
        let mut codes: Vec<String> = inventory
            .channels
            .iter()
            .filter(|c| c.contains(t_ns))
            .map(ChannelEpoch::id)
            .filter(|c| c.starts_with(&prefix) && c.len() == prefix.len() + 1)
            .collect();
        codes.sort();
        codes.dedup();
        if codes.is_empty() || !codes.contains(&record.id()) {
            // Names the channel: not in the inventory at all, or no epoch at this time.
            lookup(
                inventory,
                &record.id(),
                t_ns,
                record.sample_rate_hz,
                differentiate,
            )?;
        }
        let mut components = Vec::with_capacity(codes.len());
        for code in &codes {
            let (calibration, valid) =
                lookup(inventory, code, t_ns, record.sample_rate_hz, differentiate)?;
            components.push(Component {
                id: code.clone(),
                calibration,
                valid,
                buffer: VecDeque::new(),
                diff: (calibration.input == SensorInput::Velocity).then(Differentiator::new),
            });
        }
        let axes: Vec<_> = components
            .iter()
            .map(|c| (c.calibration.axis, c.calibration.gain_mps2_per_count))
            .collect();
        let to_enu = ChannelsToEnu::new(&axes).map_err(|e| {
            RecordIssue::Orientation(format!("station {key} ({}): {e}", codes.join(", ")))
        })?;
        Ok(StationAssembly {
            id,
            band: band.to_string(),
            rate_hz: record.sample_rate_hz,
            t0_ns: start_ns,
            emitted: 0,
            components,
            to_enu,
            waiting_since: None,
            sequence: 0,
            far_ahead: Vec::new(),
        })
    }
}

/// An epoch's `[start, end)` (ns; `None` unbounded).
type EpochBounds = (Option<i128>, Option<i128>);

/// The calibration of `id` at `t_ns`, with the epoch's bounds.
fn lookup(
    inventory: &Inventory,
    id: &str,
    t_ns: i128,
    rate_hz: f64,
    differentiate_velocity: bool,
) -> Result<(Calibration, EpochBounds), LookupError> {
    let calibration = inventory.calibration_at_with(id, t_ns, rate_hz, differentiate_velocity)?;
    let valid = inventory
        .epoch_at(id, t_ns)
        .map_or((None, None), |e| (e.start_ns, e.end_ns));
    Ok((calibration, valid))
}

impl StationAssembly {
    fn time_ns(&self, index: i64) -> i64 {
        self.t0_ns + (index as f64 * 1e9 / self.rate_hz).round() as i64
    }

    /// Whether what waits has waited `max_wait_ns` at `now_ns`.
    fn timed_out(&self, config: &AssemblyConfig, now_ns: i64) -> bool {
        self.waiting_since
            .is_some_and(|since| now_ns.saturating_sub(since) >= config.max_wait_ns)
    }

    /// Whether a velocity component holds a sample for its successor.
    fn holds_derivative(&self) -> bool {
        self.components
            .iter()
            .any(|c| c.diff.is_some_and(|d| d.held_index().is_some()))
    }
}

/// Puts (grid index, value) samples into component `slot`'s buffer: before `emitted` or
/// where a value is already, counted as overlap.
fn put(
    station: &mut StationAssembly,
    slot: usize,
    samples: &[(i64, f64)],
    counters: &mut AssemblyCounters,
) {
    let emitted = station.emitted;
    let buffer = &mut station.components[slot].buffer;
    for &(j, x) in samples {
        if j < emitted {
            counters.overlap_samples += 1;
            continue;
        }
        let offset = (j - emitted) as usize;
        if buffer.len() <= offset {
            buffer.resize(offset + 1, f64::NAN);
        }
        let cell = &mut buffer[offset];
        if cell.is_nan() {
            *cell = x;
        } else {
            counters.overlap_samples += 1;
        }
    }
}

/// The wait is over: the velocity components' held samples get their backward difference.
fn flush_derivatives(station: &mut StationAssembly, counters: &mut AssemblyCounters) {
    let rate_hz = station.rate_hz;
    for slot in 0..station.components.len() {
        let mut flushed = None;
        if let Some(d) = &mut station.components[slot].diff {
            d.flush(&mut |j, v| flushed = Some((j, v * rate_hz)));
        }
        if let Some(sample) = flushed {
            put(station, slot, &[sample], counters);
        }
    }
}

/// Emits every span all components cover; skips spans none has once all have later data;
/// after the wait, also emits spans some cover (zeros for the others).
fn emit_ready(
    station: &mut StationAssembly,
    config: &AssemblyConfig,
    counters: &mut AssemblyCounters,
    now_ns: i64,
    out: &mut dyn FnMut(AccelPacket),
) {
    let has = |c: &Component, i: usize| c.buffer.get(i).is_some_and(|x| !x.is_nan());
    loop {
        let longest = station
            .components
            .iter()
            .map(|c| c.buffer.len())
            .max()
            .unwrap_or(0);
        if longest == 0 {
            if !station.holds_derivative() {
                station.waiting_since = None;
            }
            return;
        }
        let timed_out = station.timed_out(config, now_ns);
        // A gap in every component: skip it once each has data after it (or the wait is over).
        let empty = (0..longest)
            .take_while(|&i| station.components.iter().all(|c| !has(c, i)))
            .count();
        if empty > 0 {
            let all_resumed = station
                .components
                .iter()
                .all(|c| c.buffer.iter().any(|x| !x.is_nan()));
            if !(all_resumed || timed_out) {
                return;
            }
            for c in &mut station.components {
                let k = empty.min(c.buffer.len());
                c.buffer.drain(..k);
            }
            station.emitted += empty as i64;
            continue;
        }
        let complete = station
            .components
            .iter()
            .map(|c| (0..c.buffer.len()).take_while(|&i| has(c, i)).count())
            .min()
            .unwrap_or(0);
        let n = if complete > 0 {
            complete
        } else if timed_out {
            (0..longest)
                .take_while(|&i| station.components.iter().any(|c| has(c, i)))
                .count()
        } else {
            return;
        };
        emit(station, n.min(config.max_packet_samples), counters, out);
        if !timed_out {
            station.waiting_since = Some(now_ns);
        }
    }
}

/// Emits the next `n` samples (missing ones as zero) as one packet.
fn emit(
    station: &mut StationAssembly,
    n: usize,
    counters: &mut AssemblyCounters,
    out: &mut dyn FnMut(AccelPacket),
) {
    let has_up = station.to_enu.has_up();
    let (mut east, mut north) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let mut up = Vec::with_capacity(if has_up { n } else { 0 });
    for i in 0..n {
        let mut reading = [0.0; 3];
        for (slot, c) in station.components.iter().enumerate() {
            match c.buffer.get(i) {
                Some(x) if !x.is_nan() => reading[slot] = *x,
                _ => counters.missing_component_samples += 1,
            }
        }
        let [e, nn, u] = station.to_enu.apply(reading);
        east.push(e as f32);
        north.push(nn as f32);
        if has_up {
            up.push(u as f32);
        }
    }
    for c in &mut station.components {
        let k = n.min(c.buffer.len());
        c.buffer.drain(..k);
    }
    let packet = AccelPacket {
        station: station.id.clone(),
        start_time_ns: station.time_ns(station.emitted),
        sample_rate_hz: station.rate_hz,
        sequence: station.sequence,
        east,
        north,
        up,
        unit: crate::engine::SampleUnit::MetresPerSecondSquared, // calibrated with the inventory
    };
    station.emitted += n as i64;
    station.sequence += 1;
    counters.packets += 1;
    counters.samples += n as u64;
    out(packet);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inventory::{ChannelEpoch, Sensitivity};
    use crate::record::mseed::{SampleKind, Segment};

    const RATE: f64 = 100.0;

    fn epoch(cha: &str, az: f64, dip: f64, sensitivity: f64) -> ChannelEpoch {
        ChannelEpoch {
            source: "test".into(),
            network: "XX".into(),
            station: "S".into(),
            location: String::new(),
            channel: cha.into(),
            start_ns: Some(0),
            end_ns: None,
            sample_rate_hz: Some(RATE),
            azimuth_deg: Some(az),
            dip_deg: Some(dip),
            sensitivity: Some(Sensitivity {
                value: sensitivity,
                frequency_hz: Some(1.0),
                input_units: "M/S**2".into(),
                output_units: Some("COUNTS".into()),
            }),
        }
    }

    /// HN1 east, HN2 north, HN3 up; 1000 counts per m/s².
    fn inventory() -> Inventory {
        Inventory {
            channels: vec![
                epoch("HN1", 90.0, 0.0, 1000.0),
                epoch("HN2", 0.0, 0.0, 1000.0),
                epoch("HN3", 0.0, -90.0, 1000.0),
            ],
        }
    }

    fn record(cha: &str, first_index: i64, counts: &[f64]) -> Channel {
        let start = first_index * 10_000_000; // 100 Hz
        Channel {
            source: "test".into(),
            net: "XX".into(),
            sta: "S".into(),
            loc: String::new(),
            cha: cha.into(),
            sample_rate_hz: RATE,
            start_time_ns: start,
            sample_kind: SampleKind::Integer,
            segments: vec![Segment {
                start_time_ns: start,
                samples: counts.to_vec(),
            }],
            gaps: vec![],
            overlaps: vec![],
        }
    }

    fn run(asm: &mut Assembler, records: &[Channel], now: i64) -> Vec<AccelPacket> {
        let mut out = Vec::new();
        for r in records {
            asm.push(r, now, &mut |p| out.push(p)).unwrap();
        }
        out
    }

    #[test]
    fn components_with_different_record_boundaries_are_aligned_calibrated_and_rotated() {
        let mut asm = Assembler::new(inventory(), AssemblyConfig::default());
        // HN1 in records of 5 and 7 samples, HN2 one of 12, HN3 of 4, 4, 4: spans are emitted
        // only when all three cover them.
        let e: Vec<f64> = (0..12).map(f64::from).collect();
        let n: Vec<f64> = (0..12).map(|i| f64::from(100 + i)).collect();
        let u: Vec<f64> = (0..12).map(|i| f64::from(-i)).collect();
        let mut out = run(
            &mut asm,
            &[record("HN1", 0, &e[..5]), record("HN2", 0, &n)],
            0,
        );
        assert!(out.is_empty());
        out.extend(run(
            &mut asm,
            &[record("HN3", 0, &u[..4]), record("HN3", 4, &u[4..8])],
            0,
        ));
        out.extend(run(
            &mut asm,
            &[record("HN1", 5, &e[5..]), record("HN3", 8, &u[8..])],
            0,
        ));
        let east: Vec<f32> = out.iter().flat_map(|p| p.east.clone()).collect();
        let north: Vec<f32> = out.iter().flat_map(|p| p.north.clone()).collect();
        let up: Vec<f32> = out.iter().flat_map(|p| p.up.clone()).collect();
        // counts × 1e-3 m/s² per count, HN1 → east, HN2 → north, HN3 → up (f32 packets).
        let scaled = |v: &[f64]| v.iter().map(|x| (x * 1e-3) as f32).collect::<Vec<f32>>();
        let close = |a: &[f32], b: &[f32]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| (x - y).abs() <= 1e-6 * y.abs().max(1e-3))
        };
        assert!(
            close(&east, &scaled(&e)) && close(&north, &scaled(&n)) && close(&up, &scaled(&u)),
            "{east:?} {north:?} {up:?}"
        );
        // Contiguous packets: each starts where the previous ended, sequences 0, 1, 2, …
        let mut next = 0;
        for (i, p) in out.iter().enumerate() {
            assert_eq!((p.start_time_ns, p.sequence), (next, i as u64));
            next += p.len() as i64 * 10_000_000;
        }
        assert_eq!(asm.counters().samples, 12);
        assert_eq!(asm.emitted_until_ns("XX.S."), Some(120_000_000));
    }

    #[test]
    fn a_missing_component_is_waited_for_then_zero_filled_and_counted() {
        let config = AssemblyConfig {
            max_wait_ns: 1_000,
            ..AssemblyConfig::default()
        };
        let mut asm = Assembler::new(inventory(), config);
        let x = [10.0; 6];
        let out = run(&mut asm, &[record("HN1", 0, &x), record("HN2", 0, &x)], 0);
        assert!(out.is_empty());
        let mut out = Vec::new();
        asm.tick(999, &mut |p| out.push(p));
        assert!(out.is_empty(), "still within the wait");
        asm.tick(1_000, &mut |p| out.push(p));
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].len(), 6);
        // Zero vertical counts; the horizontal axes' round-off (cos 90° ≈ 6e-17) leaves ~1e-18.
        assert!(out[0].up.iter().all(|&u| u.abs() < 1e-12));
        assert_eq!(asm.counters().missing_component_samples, 6);
        // The late vertical of the emitted span is trimmed as overlap.
        let late = run(&mut asm, &[record("HN3", 0, &x)], 2_000);
        assert!(late.is_empty());
        assert_eq!(asm.counters().overlap_samples, 6);
    }

    #[test]
    fn duplicates_and_overlaps_are_trimmed_and_gaps_stay_gaps() {
        let mut asm = Assembler::new(inventory(), AssemblyConfig::default());
        let x = [1.0; 4];
        let all = |k| {
            [
                record("HN1", k, &x),
                record("HN2", k, &x),
                record("HN3", k, &x),
            ]
        };
        let mut out = run(&mut asm, &all(0), 0);
        out.extend(run(&mut asm, &all(0), 0)); // sent again
        out.extend(run(&mut asm, &all(10), 0)); // after a gap of 6 samples
        let starts: Vec<(i64, usize)> = out.iter().map(|p| (p.start_time_ns, p.len())).collect();
        assert_eq!(starts, vec![(0, 4), (100_000_000, 4)]);
        assert_eq!(asm.counters().overlap_samples, 12);
    }

    #[test]
    fn records_before_the_first_packet_move_the_grid_start_back() {
        let mut asm = Assembler::new(inventory(), AssemblyConfig::default());
        let x = [1.0; 4];
        // After a restart the vertical's record from index 10 comes first, then the others
        // from index 6.
        let mut out = run(
            &mut asm,
            &[record("HN3", 10, &x), record("HN1", 6, &[2.0; 8])],
            0,
        );
        out.extend(run(
            &mut asm,
            &[record("HN2", 6, &[3.0; 8]), record("HN3", 6, &x)],
            0,
        ));
        assert_eq!(out.len(), 1);
        assert_eq!((out[0].start_time_ns, out[0].len()), (60_000_000, 8));
        assert_eq!(asm.counters().overlap_samples, 0);
    }

    #[test]
    fn a_record_far_ahead_is_refused_and_an_outage_restarts_the_grid_without_a_huge_buffer() {
        let mut asm = Assembler::new(inventory(), AssemblyConfig::default());
        let x = [1.0; 4];
        let all = |k| {
            [
                record("HN1", k, &x),
                record("HN2", k, &x),
                record("HN3", k, &x),
            ]
        };
        let mut out = run(&mut asm, &all(0), 0);
        // One record stamped a year ahead (a bad time stamp): refused, the stream goes on.
        let year = 365 * 86_400 * 100;
        let mut sink = |p: AccelPacket| out.push(p);
        let e = asm
            .push(&record("HN1", year, &x), 0, &mut sink)
            .unwrap_err();
        assert!(matches!(e, RecordIssue::FarAhead { .. }), "{e}");
        for r in all(4) {
            asm.push(&r, 0, &mut sink).unwrap();
        }
        assert_eq!(asm.emitted_until_ns("XX.S."), Some(80_000_000));
        // An outage of a year: every component moves on; the third record restarts the grid
        // there (the first two are refused, counted, kept and placed then), no year-long
        // buffer is allocated.
        let later = all(year);
        assert!(asm.push(&later[0], 0, &mut sink).is_err());
        assert!(asm.push(&later[1], 0, &mut sink).is_err());
        asm.push(&later[2], 0, &mut sink).unwrap();
        for r in all(year + 4) {
            asm.push(&r, 0, &mut sink).unwrap();
        }
        let c = asm.counters();
        // The two records refused on the way were kept and placed after the restart.
        assert_eq!(c.missing_component_samples, 0);
        assert_eq!((c.far_ahead_records, c.grid_restarts), (4, 1));
        assert_eq!(
            out.last().map(|p| p.start_time_ns),
            Some((year + 4) * 10_000_000)
        );
    }

    #[test]
    fn unknown_channels_other_bands_and_off_grid_records_are_refused_with_a_reason() {
        let mut asm = Assembler::new(inventory(), AssemblyConfig::default());
        let x = [1.0; 4];
        let mut sink = |_p: AccelPacket| {};
        let mut unknown = record("HN1", 0, &x);
        unknown.sta = "T".into();
        let e = asm.push(&unknown, 0, &mut sink).unwrap_err();
        assert_eq!(e.to_string(), "channel XX.T..HN1 is not in the inventory");
        asm.push(&record("HN1", 0, &x), 0, &mut sink).unwrap();
        let e = asm.push(&record("HH1", 0, &x), 0, &mut sink).unwrap_err();
        assert!(matches!(e, RecordIssue::OtherBand { .. }), "{e}");
        let mut off = record("HN2", 0, &x);
        off.segments[0].start_time_ns += 3_000_000; // 0.3 sample
        let e = asm.push(&off, 0, &mut sink).unwrap_err();
        assert!(
            e.to_string().contains("off the station's sample grid"),
            "{e}"
        );
        assert_eq!(asm.counters().refused_records, 3);
    }

    #[test]
    fn records_at_another_rate_or_with_impossible_values_are_refused_and_cost_nothing_else() {
        let mut asm = Assembler::new(inventory(), AssemblyConfig::default());
        let x = [1.0; 4];
        let mut out = Vec::new();
        let mut sink = |p: AccelPacket| out.push(p);
        for cha in ["HN1", "HN2", "HN3"] {
            asm.push(&record(cha, 0, &x), 0, &mut sink).unwrap();
        }
        // Copies of the next HN1 record: at 200× the rate, with 1e30, with a NaN, and with
        // 101 g once calibrated (1000 counts per m/s²): each refused, none placed.
        let mut fast = record("HN1", 4, &x);
        fast.sample_rate_hz *= 200.0;
        let e = asm.push(&fast, 0, &mut sink).unwrap_err();
        assert!(e.is_other_rate(), "{e}");
        for bad in [1e30, f64::NAN, 1000.0 * 101.0 * 9.80665] {
            let e = asm
                .push(&record("HN1", 4, &[1.0, bad, 1.0, 1.0]), 0, &mut sink)
                .unwrap_err();
            assert!(matches!(e, RecordIssue::Implausible { .. }), "{e}");
        }
        // The clean records of that span go through as if nothing had happened.
        for cha in ["HN1", "HN2", "HN3"] {
            asm.push(&record(cha, 4, &x), 0, &mut sink).unwrap();
        }
        let c = asm.counters();
        assert_eq!(
            (
                c.refused_records,
                c.other_rate_records,
                c.implausible_records
            ),
            (4, 1, 3)
        );
        assert_eq!(
            (c.samples, c.overlap_samples, c.missing_component_samples),
            (8, 0, 0)
        );
        assert!(out
            .iter()
            .all(|p| p.east.iter().all(|v| (v - 1e-3).abs() < 1e-9)));
    }
}
