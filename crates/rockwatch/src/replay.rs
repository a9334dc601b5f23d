//! Turning records into the packets a live station would send: aligned east/north/up traces
//! with their timing, cut into packets of a given length and followed by a quiet tail. Used by
//! `rockwatch monitor` and the replay tool, so offline and live runs see the same packets.

use std::path::Path;

use crate::node_config::NodeConfig;
use crate::ports::PacketSink;
use rockwatch_core::azimuth::{Azimuth, ChannelsToEnu};
use rockwatch_core::differentiate::differentiate;
use rockwatch_core::engine::packet::MAX_SAMPLES_PER_PACKET;
use rockwatch_core::engine::{AccelPacket, Orientation, SampleUnit, StationId};
use rockwatch_core::inventory::{Inventory, SensorInput};
use rockwatch_core::record::mseed::{
    align_channels, read_mseed, AlignedChannels, Channel, GapFill, SampleKind,
};
use rockwatch_core::record::{Record, RecordError, MAX_RECORD_SAMPLES};

/// Longest quiet tail a replay or monitor run appends (s): one day.
pub const MAX_TAIL_S: f64 = 86_400.0;

/// Why a replay cannot be cut or calibrated as asked: one sentence naming the flag or the setting.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ReplayPlanError(pub String);

impl From<String> for ReplayPlanError {
    fn from(reason: String) -> Self {
        ReplayPlanError(reason)
    }
}

impl From<&str> for ReplayPlanError {
    fn from(reason: &str) -> Self {
        ReplayPlanError(reason.to_owned())
    }
}

/// Checks the flags of a cut into packets on their own (before any record is read): packets
/// of 1 ms to 60 s, a tail of 0 to [`MAX_TAIL_S`]. See [`Traces::check_packets`].
pub fn check_packet_flags(packet_ms: u32, tail_s: f64) -> Result<(), ReplayPlanError> {
    if !(1..=60_000).contains(&packet_ms) {
        return Err(ReplayPlanError::from(format!(
            "--packet-ms must be 1 to 60000, got {packet_ms}"
        )));
    }
    if !(tail_s.is_finite() && (0.0..=MAX_TAIL_S).contains(&tail_s)) {
        return Err(ReplayPlanError::from(format!(
            "--tail must be 0 to {MAX_TAIL_S} s, got {tail_s}"
        )));
    }
    Ok(())
}

/// How the values of MiniSEED channels become m/s² on east/north/up
/// ([`Traces::from_mseed`]).
#[derive(Debug, Clone, Copy)]
pub enum MseedCalibration<'a> {
    /// Values as stored, channels 1/E, 2/N, 3/Z as east, north, up. Integer counts only when
    /// `counts_have_gain`: the station's configured gain converts them downstream.
    AsStored { counts_have_gain: bool },
    /// Gains and sensor axes from StationXML.
    Inventory(&'a Inventory),
}

impl<'a> MseedCalibration<'a> {
    /// The calibration of `station`'s MiniSEED data: the inventory when given — then the
    /// station's configuration must leave gain and orientation at their defaults, or the data
    /// would be converted twice — else as stored, counts allowed when the configuration gives
    /// the station a gain.
    pub fn for_station(
        inventory: Option<&'a Inventory>,
        config: &NodeConfig,
        station: &StationId,
    ) -> Result<MseedCalibration<'a>, ReplayPlanError> {
        let configured = config.stations.iter().find(|s| &s.id == station);
        let gain = configured.and_then(|s| s.gain_mps2_per_count);
        match inventory {
            Some(inventory) => {
                if let Some(s) = configured {
                    if gain.is_some() || s.orientation != Orientation::EastNorth {
                        return Err(ReplayPlanError::from(format!(
                            "station {station}: --stationxml gives gains and orientation, so \
                             the configuration must not set gain_mps2_per_count or orientation"
                        )));
                    }
                }
                Ok(MseedCalibration::Inventory(inventory))
            }
            None => Ok(MseedCalibration::AsStored {
                counts_have_gain: gain.is_some(),
            }),
        }
    }
}

/// Which of a station's MiniSEED channels are used, and what is done with velocity channels.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ChannelChoice {
    /// A channel-code pattern (`?` one character, `*` any run), e.g. `HN?` from
    /// `--channels`. `None`: the station's one sensor, or among several the
    /// one accelerometer (instrument code `N`).
    pub channels: Option<String>,
    /// With an inventory, velocity channels (input units M/S) are differentiated to
    /// acceleration (`rockwatch_core::differentiate`) instead of refused.
    pub differentiate_velocity: bool,
}

/// The band + instrument code of a channel (`HN` of `HNZ`).
fn sensor_code(c: &Channel) -> String {
    c.cha.chars().take(2).collect()
}

/// The channels of one sensor among `mine` (a station's): those matching `choice.channels`,
/// which must all share one band + instrument code; else, when the station has several
/// sensors, the one accelerometer (instrument code `N`, as in `HN?`; SEED: N = accelerometer).
/// Several sensors and no single accelerometer: an error naming them and `--channels`.
fn choose_channels<'c>(
    mine: &[&'c Channel],
    station: &StationId,
    choice: &ChannelChoice,
) -> Result<Vec<&'c Channel>, String> {
    let codes = |cs: &[&Channel]| {
        let mut v: Vec<String> = cs.iter().map(|c| format!("{}?", sensor_code(c))).collect();
        v.sort();
        v.dedup();
        v
    };
    let all: Vec<String> = mine.iter().map(|c| c.cha.clone()).collect();
    let candidates: Vec<&Channel> = match &choice.channels {
        Some(pattern) => {
            let p = rockwatch_core::seedlink::select::StreamPattern::parse(&format!(
                "{station}.{pattern}"
            ))
            .map_err(|e| format!("--channels {pattern:?}: {e}"))?;
            let matching: Vec<&Channel> = mine
                .iter()
                .copied()
                .filter(|c| p.matches(&c.net, &c.sta, &c.loc, &c.cha))
                .collect();
            if matching.is_empty() {
                return Err(format!(
                    "--channels {pattern:?} matches no channel of station {station} (channels: {})",
                    all.join(", ")
                ));
            }
            matching
        }
        None => mine.to_vec(),
    };
    let sensors = codes(&candidates);
    if sensors.len() <= 1 {
        return Ok(candidates);
    }
    if choice.channels.is_some() {
        return Err(format!(
            "--channels matches channels of several sensors of station {station} ({}): give one band and instrument code, e.g. --channels {}",
            sensors.join(", "),
            sensors[0]
        ));
    }
    let accelerometers: Vec<&String> = sensors
        .iter()
        .filter(|c| c.chars().nth(1) == Some('N'))
        .collect();
    match accelerometers.as_slice() {
        [one] => {
            let code = &one[..2];
            Ok(candidates
                .into_iter()
                .filter(|c| sensor_code(c) == code)
                .collect())
        }
        _ => Err(format!(
            "station {station} has channels of several sensors ({}) and {} accelerometer (instrument code N): choose one with --channels, e.g. --channels {}",
            sensors.join(", "),
            if accelerometers.is_empty() { "no" } else { "more than one" },
            sensors[0]
        )),
    }
}

/// Three aligned components (m/s², or counts for integer MiniSEED) with their timing.
#[derive(Debug, Clone, PartialEq)]
pub struct Traces {
    /// UTC time of the first sample (ns).
    pub start_ns: i64,
    pub rate_hz: f64,
    pub east: Vec<f64>,
    pub north: Vec<f64>,
    pub up: Option<Vec<f64>>,
    /// m/s², or counts (MiniSEED as stored for a station whose configured gain converts them).
    pub unit: SampleUnit,
}

impl Traces {
    /// A record's horizontal component pointing to `azimuth` split into east and north
    /// ([`Azimuth::to_east_north`]: a_E = a sin az, a_N = a cos az), its vertical as up.
    /// Time 0 is the Unix epoch (AT2 and CSV records carry no absolute time).
    #[must_use]
    pub fn from_record(record: &Record, azimuth: Azimuth) -> Traces {
        let (east, north) = record
            .horizontal_mps2
            .iter()
            .map(|&a| azimuth.to_east_north(a))
            .unzip();
        Traces {
            start_ns: 0,
            rate_hz: 1.0 / record.dt_s,
            east,
            north,
            up: record.vertical_mps2.clone(),
            unit: SampleUnit::MetresPerSecondSquared,
        }
    }

    /// [`Traces::from_mseed_with`] with the default [`ChannelChoice`].
    pub fn from_mseed(
        path: &Path,
        station: &StationId,
        calibration: MseedCalibration<'_>,
    ) -> Result<Traces, RecordError> {
        Self::from_mseed_with(path, station, calibration, &ChannelChoice::default())
    }

    /// The channels of `station` in a MiniSEED file, of one sensor ([`ChannelChoice`]: a
    /// `--channels` pattern, else the station's accelerometer when it has several sensors):
    /// …E or …1 first, …N or …2 second, …Z or …3 third (a missing horizontal is zero). Gaps inside the file are filled linearly; the
    /// channels are aligned and cut to their common time window by [`align_channels`] (same
    /// rate, sample instants within
    /// [`MAX_ALIGNMENT_OFFSET_SAMPLES`](rockwatch_core::record::mseed::MAX_ALIGNMENT_OFFSET_SAMPLES)
    /// of a sample). What the values become depends on `calibration`:
    /// - [`MseedCalibration::AsStored`]: the first channel is east, the second north, the third
    ///   up, values as stored. Integer (count) channels are refused, naming the channel, unless
    ///   `counts_have_gain` (the station's configured gain converts them downstream).
    /// - [`MseedCalibration::Inventory`]: each channel's gain, azimuth and dip come from the
    ///   inventory epoch containing the first common sample (its rate must match); the counts
    ///   are calibrated and rotated to m/s² on east/north/up ([`ChannelsToEnu`]), whatever the
    ///   channels are called. Velocity channels are differentiated first when
    ///   `choice.differentiate_velocity`, else refused.
    pub fn from_mseed_with(
        path: &Path,
        station: &StationId,
        calibration: MseedCalibration<'_>,
        choice: &ChannelChoice,
    ) -> Result<Traces, RecordError> {
        let err = |problem: String| RecordError::new(path, None, problem);
        let file = read_mseed(path)?;
        let mine: Vec<&Channel> = file
            .channels
            .iter()
            .filter(|c| format!("{}.{}.{}", c.net, c.sta, c.loc) == station.as_str())
            .collect();
        if mine.is_empty() {
            let ids: Vec<String> = file.channels.iter().map(Channel::id).collect();
            return Err(err(format!(
                "no channel of station {station} (channels: {})",
                ids.join(", ")
            )));
        }
        let mine = choose_channels(&mine, station, choice).map_err(err)?;
        let pick = |codes: [char; 2]| mine.iter().find(|c| c.cha.ends_with(codes)).copied();
        let picked = [pick(['E', '1']), pick(['N', '2']), pick(['Z', '3'])];
        if picked[0].is_none() && picked[1].is_none() {
            return Err(err(format!(
                "station {station} has no horizontal channel (…E/…N or …1/…2)"
            )));
        }
        if let MseedCalibration::AsStored {
            counts_have_gain: false,
        } = calibration
        {
            if let Some(c) = picked
                .iter()
                .flatten()
                .find(|c| c.sample_kind != SampleKind::Float)
            {
                return Err(err(format!(
                    "channel {} holds integer counts and no gain is known: give --stationxml \
                     FILE, or the station's gain_mps2_per_count in the configuration",
                    c.id()
                )));
            }
        }
        // Values as stored (gain 1): the inventory's gains, signs included, are applied below.
        let present: Vec<(&Channel, f64)> = picked.iter().flatten().map(|&c| (c, 1.0)).collect();
        let aligned = align_channels(&present, GapFill::Linear)?;
        let len = aligned.samples[0].len();
        if let MseedCalibration::Inventory(inventory) = calibration {
            return Self::calibrated(aligned, &present, inventory, choice.differentiate_velocity)
                .map_err(err);
        }
        let mut series = aligned.samples.into_iter();
        let [east, north, up] = picked.map(|c| c.and_then(|_| series.next()));
        Ok(Traces {
            start_ns: aligned.start_time_ns,
            rate_hz: aligned.sample_rate_hz,
            east: east.unwrap_or_else(|| vec![0.0; len]),
            north: north.unwrap_or_else(|| vec![0.0; len]),
            up,
            // As stored: counts when the station's configured gain converts them.
            unit: match calibration {
                MseedCalibration::AsStored {
                    counts_have_gain: true,
                } => SampleUnit::Counts,
                _ => SampleUnit::MetresPerSecondSquared,
            },
        })
    }

    /// Aligned raw channels calibrated and rotated to east/north/up with the inventory.
    fn calibrated(
        mut aligned: AlignedChannels,
        channels: &[(&Channel, f64)],
        inventory: &Inventory,
        differentiate_velocity: bool,
    ) -> Result<Traces, String> {
        let mut axes = Vec::with_capacity(channels.len());
        for (i, (channel, _)) in channels.iter().enumerate() {
            let cal = inventory
                .calibration_at_with(
                    &channel.id(),
                    i128::from(aligned.start_time_ns),
                    aligned.sample_rate_hz,
                    differentiate_velocity,
                )
                .map_err(|e| e.to_string())?;
            if cal.input == SensorInput::Velocity {
                // Counts → counts per second on the grid (the core's scheme); the gain in
                // (m/s)/count then gives m/s².
                let d = differentiate(&aligned.samples[i], aligned.sample_rate_hz);
                if d.is_empty() {
                    return Err(format!(
                        "channel {}: one sample cannot be differentiated",
                        channel.id()
                    ));
                }
                aligned.samples[i] = d;
            }
            axes.push((cal.axis, cal.gain_mps2_per_count));
        }
        let ids: Vec<String> = channels.iter().map(|(c, _)| c.id()).collect();
        let to_enu =
            ChannelsToEnu::new(&axes).map_err(|e| format!("channels {}: {e}", ids.join(", ")))?;
        let len = aligned.samples[0].len();
        let (mut east, mut north) = (Vec::with_capacity(len), Vec::with_capacity(len));
        let mut up = to_enu.has_up().then(|| Vec::with_capacity(len));
        let s = &aligned.samples;
        for i in 0..len {
            let reading = [s[0][i], s[1][i], s.get(2).map_or(0.0, |c| c[i])];
            let [e, n, u] = to_enu.apply(reading);
            east.push(e);
            north.push(n);
            if let Some(up) = &mut up {
                up.push(u);
            }
        }
        Ok(Traces {
            start_ns: aligned.start_time_ns,
            rate_hz: aligned.sample_rate_hz,
            east,
            north,
            up,
            unit: SampleUnit::MetresPerSecondSquared,
        })
    }

    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.east.len()
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.east.is_empty()
    }

    /// Checks that cutting the traces into packets of `packet_ms`, followed by `tail_s`
    /// seconds of zeros, is bounded work: 1 ms to 60 s packets of at most
    /// [`MAX_SAMPLES_PER_PACKET`] samples, a tail of 0 to [`MAX_TAIL_S`], and at most
    /// [`MAX_RECORD_SAMPLES`] samples in all (the packets are held in memory). The message
    /// names the flag (`--packet-ms`, `--tail`).
    pub fn check_packets(&self, packet_ms: u32, tail_s: f64) -> Result<(), ReplayPlanError> {
        check_packet_flags(packet_ms, tail_s)?;
        let per_packet = (f64::from(packet_ms) * 1e-3 * self.rate_hz).round();
        if per_packet > MAX_SAMPLES_PER_PACKET as f64 {
            return Err(ReplayPlanError::from(format!(
                "--packet-ms {packet_ms} at {} Hz makes packets of {per_packet} samples, more than \
                 the {MAX_SAMPLES_PER_PACKET} a packet may hold",
                self.rate_hz
            )));
        }
        let total = self.len() as f64 + (tail_s * self.rate_hz).round();
        if total > MAX_RECORD_SAMPLES as f64 {
            return Err(ReplayPlanError::from(format!(
                "the record plus --tail {tail_s} s is {total} samples at {} Hz, more than \
                 {MAX_RECORD_SAMPLES}",
                self.rate_hz
            )));
        }
        Ok(())
    }

    /// Cuts the traces, followed by `tail_s` seconds of zeros (at most [`MAX_TAIL_S`]), into
    /// packets of `packet_ms` (at least one sample), sequence numbers from 0.
    #[must_use]
    pub fn packets(&self, station: &StationId, packet_ms: u32, tail_s: f64) -> Vec<AccelPacket> {
        let per_packet = ((f64::from(packet_ms) * 1e-3 * self.rate_hz).round() as usize).max(1);
        let tail = (tail_s.clamp(0.0, MAX_TAIL_S) * self.rate_hz).round() as usize;
        let total = self.len().saturating_add(tail);
        let at = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(0.0) as f32;
        (0..total)
            .step_by(per_packet)
            .enumerate()
            .map(|(sequence, first)| {
                let range = first..(first + per_packet).min(total);
                AccelPacket {
                    station: station.clone(),
                    start_time_ns: self.start_ns
                        + (first as f64 * 1e9 / self.rate_hz).round() as i64,
                    sample_rate_hz: self.rate_hz,
                    sequence: sequence as u64,
                    east: range.clone().map(|i| at(&self.east, i)).collect(),
                    north: range.clone().map(|i| at(&self.north, i)).collect(),
                    up: self
                        .up
                        .as_ref()
                        .map_or_else(Vec::new, |u| range.map(|i| at(u, i)).collect()),
                    unit: self.unit,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packets_cover_record_and_tail_contiguously() {
        let record = Record {
            source: "test".into(),
            dt_s: 0.01,
            horizontal_mps2: (0..25).map(f64::from).collect(),
            vertical_mps2: None,
        };
        let t = Traces::from_record(&record, Azimuth::from_degrees(90.0).unwrap());
        let id = StationId::parse("CI.RRS.00").unwrap();
        let p = t.packets(&id, 100, 0.1);
        let lens: Vec<usize> = p.iter().map(AccelPacket::len).collect();
        assert_eq!(lens, vec![10, 10, 10, 5]);
        assert_eq!(p[2].start_time_ns, 200_000_000);
        assert_eq!(p[2].east[4], 24.0);
        assert_eq!(p[3].east, vec![0.0; 5]);
        assert!(p
            .iter()
            .all(|q| q.up.is_empty() && q.north.iter().all(|v| v.abs() < 1e-5)));
        assert_eq!(
            p.iter().map(|q| q.sequence).collect::<Vec<_>>(),
            vec![0, 1, 2, 3]
        );
    }
}

/// Replay pace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Speed {
    /// `factor` × real time (1.0 = real time).
    Times(f64),
    /// As fast as the sink takes packets.
    Max,
}

impl std::str::FromStr for Speed {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s == "max" {
            return Ok(Speed::Max);
        }
        match s.parse::<f64>() {
            Ok(f) if f.is_finite() && f > 0.0 => Ok(Speed::Times(f)),
            _ => Err(format!(
                "speed must be a positive number or \"max\", got {s:?}"
            )),
        }
    }
}

/// Time stamps of replayed packets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Restamp {
    /// Shifted to the wall clock ([`now_shift_ns`]): at real time or slower the first sample
    /// is "now" (UTC) and later ones follow at the data rate; faster than real time the
    /// stream is placed to end "now", so that no packet is stamped ahead of the clock (a live
    /// node rejects such packets: `engine.plausibility.max_ahead_s`).
    Now,
    /// As in the record.
    Original,
}

/// What a replay sent.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReplayReport {
    pub packets: u64,
    pub samples: u64,
    /// Data seconds sent.
    pub data_s: f64,
    /// Wall seconds taken.
    pub wall_s: f64,
    /// Largest lateness of a packet behind its schedule (s), at finite speeds.
    pub max_lag_s: f64,
}

/// The shift (ns) that [`Restamp::Now`] adds to the time stamps of `packets` replayed
/// `loops` times at `speed`, the wall clock reading `now_ns` (UTC ns) at the start: the first
/// sample at `now_ns` when the replay is no faster than real time (each packet then leaves
/// when its last sample would have been recorded, never ahead of the clock); faster, the
/// whole stream ends at `now_ns`, so it lies in the past as it is sent.
#[must_use]
pub fn now_shift_ns(packets: &[AccelPacket], speed: Speed, loops: u32, now_ns: i64) -> i64 {
    let (Some(first), Some(last)) = (packets.first(), packets.last()) else {
        return 0;
    };
    let duration_ns = last.start_time_ns - first.start_time_ns
        + (last.len() as f64 * 1e9 / last.sample_rate_hz).round() as i64;
    match speed {
        Speed::Times(factor) if factor <= 1.0 => now_ns - first.start_time_ns,
        _ => now_ns - first.start_time_ns - duration_ns.saturating_mul(i64::from(loops)),
    }
}

/// Sends `packets` (of one station, in order) `loops` times through `sink`. At a finite speed
/// each packet leaves when its last sample would have been recorded, scaled by the speed, on
/// an absolute schedule from a monotonic clock (no drift). Each loop continues the timeline
/// and the sequence numbers, so the receiver sees one continuous stream.
pub fn replay(
    packets: &[AccelPacket],
    sink: &mut dyn PacketSink,
    speed: Speed,
    restamp: Restamp,
    loops: u32,
) -> anyhow::Result<ReplayReport> {
    use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
    let (Some(first), Some(last)) = (packets.first(), packets.last()) else {
        return Ok(ReplayReport::default());
    };
    let duration_ns = last.start_time_ns - first.start_time_ns
        + (last.len() as f64 * 1e9 / last.sample_rate_hz).round() as i64;
    let wall_epoch_ns = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
    let shift_ns = match restamp {
        Restamp::Now => now_shift_ns(packets, speed, loops, wall_epoch_ns),
        Restamp::Original => 0,
    };
    let start = Instant::now();
    let mut report = ReplayReport::default();
    let sequences = packets.len() as u64;
    for lap in 0..u64::from(loops) {
        for p in packets {
            let offset_ns = p.start_time_ns - first.start_time_ns + lap as i64 * duration_ns;
            let ready_ns = offset_ns + (p.len() as f64 * 1e9 / p.sample_rate_hz).round() as i64;
            if let Speed::Times(factor) = speed {
                let due = Duration::from_nanos((ready_ns as f64 / factor).max(0.0) as u64);
                let now = start.elapsed();
                if due > now {
                    std::thread::sleep(due - now);
                } else {
                    report.max_lag_s = report.max_lag_s.max((now - due).as_secs_f64());
                }
            }
            let mut packet = p.clone();
            packet.start_time_ns = first.start_time_ns + offset_ns + shift_ns;
            packet.sequence = p.sequence + lap * sequences;
            sink.send(&packet)?;
            report.packets += 1;
            report.samples += packet.len() as u64;
        }
    }
    report.data_s = (duration_ns as f64 * f64::from(loops)) * 1e-9;
    report.wall_s = start.elapsed().as_secs_f64();
    Ok(report)
}

#[cfg(test)]
mod replay_tests {
    use super::*;
    use std::time::Duration;

    /// Restamp::Now: live-like at real time, in the past when faster (never ahead of the
    /// clock), over every loop.
    #[test]
    fn now_shift_puts_the_first_sample_now_at_real_time_and_the_end_now_when_faster() {
        let packets: Vec<AccelPacket> = (0..10)
            .map(|i| AccelPacket {
                station: StationId::parse("XX.T.00").unwrap(),
                start_time_ns: 5_000_000_000 + i * 100_000_000,
                sample_rate_hz: 100.0,
                sequence: i as u64,
                east: vec![0.0; 10],
                north: vec![0.0; 10],
                up: Vec::new(),
                unit: Default::default(),
            })
            .collect();
        let now = 1_800_000_000_000_000_000;
        // 10 packets of 0.1 s: 1 s of data.
        assert_eq!(
            now_shift_ns(&packets, Speed::Times(1.0), 1, now),
            now - 5_000_000_000
        );
        assert_eq!(
            now_shift_ns(&packets, Speed::Times(0.5), 3, now),
            now - 5_000_000_000
        );
        assert_eq!(
            now_shift_ns(&packets, Speed::Max, 1, now),
            now - 5_000_000_000 - 1_000_000_000
        );
        assert_eq!(
            now_shift_ns(&packets, Speed::Times(10.0), 3, now),
            now - 5_000_000_000 - 3_000_000_000
        );
        assert_eq!(now_shift_ns(&[], Speed::Max, 1, now), 0);
    }

    struct Recorder(Vec<(std::time::Instant, AccelPacket)>);
    impl PacketSink for Recorder {
        fn wait_for_subscriber(&mut self, _: Duration) -> anyhow::Result<bool> {
            Ok(true)
        }
        fn send(&mut self, p: &AccelPacket) -> anyhow::Result<()> {
            self.0.push((std::time::Instant::now(), p.clone()));
            Ok(())
        }
    }

    fn traces(n: usize) -> Traces {
        Traces {
            start_ns: 5_000_000_000,
            rate_hz: 100.0,
            east: vec![1.0; n],
            north: vec![0.0; n],
            up: None,
            unit: SampleUnit::MetresPerSecondSquared,
        }
    }

    #[test]
    fn paced_replay_follows_the_data_clock_without_drift() {
        let id = StationId::parse("CI.RRS.00").unwrap();
        let packets = traces(100).packets(&id, 100, 0.0); // 10 packets, 1 s of data
        let mut sink = Recorder(Vec::new());
        let t0 = std::time::Instant::now();
        let report = replay(&packets, &mut sink, Speed::Times(5.0), Restamp::Original, 2).unwrap();
        // 2 s of data at 5× → 0.4 s; the last packet leaves at 0.4 s (sleep granularity ~ms).
        let last = sink.0.last().unwrap().0.duration_since(t0).as_secs_f64();
        assert!((0.39..0.5).contains(&last), "last packet at {last} s");
        assert_eq!(report.packets, 20);
        assert!((report.data_s - 2.0).abs() < 1e-9);
        // The second loop continues time and sequence numbers.
        let p10 = &sink.0[10].1;
        assert_eq!((p10.sequence, p10.start_time_ns), (10, 6_000_000_000));
    }

    #[test]
    fn restamp_now_starts_at_the_wall_clock() {
        let id = StationId::parse("CI.RRS.00").unwrap();
        let packets = traces(20).packets(&id, 100, 0.0);
        let mut sink = Recorder(Vec::new());
        replay(&packets, &mut sink, Speed::Max, Restamp::Now, 1).unwrap();
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos() as i64;
        let first = sink.0[0].1.start_time_ns;
        assert!((now - first).abs() < 5_000_000_000, "{first} vs {now}");
        assert_eq!(sink.0[1].1.start_time_ns - first, 100_000_000);
    }

    #[test]
    fn speed_parses() {
        assert_eq!("max".parse::<Speed>(), Ok(Speed::Max));
        assert_eq!("10".parse::<Speed>(), Ok(Speed::Times(10.0)));
        assert!("0".parse::<Speed>().is_err());
        assert!("fast".parse::<Speed>().is_err());
    }
}
