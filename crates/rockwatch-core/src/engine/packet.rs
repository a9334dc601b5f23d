//! Acceleration packets as the engine receives them from any transport, and their validation.

/// Largest number of samples accepted in one packet (≈ 8 min at 200 Hz).
pub const MAX_SAMPLES_PER_PACKET: usize = 100_000;
/// Accepted sample rates (Hz).
pub const SAMPLE_RATE_RANGE_HZ: (f64, f64) = (1.0, 10_000.0);
/// Accepted start times (ns since the Unix epoch): 1900-01-01 to 2100-01-01. Keeps every
/// time difference the engine forms far from i64 overflow.
pub const START_TIME_RANGE_NS: (i64, i64) = (-2_208_988_800_000_000_000, 4_102_444_800_000_000_000);

use super::output::{Notice, NoticeKind};
pub use crate::station_id::StationId;
use crate::station_id::StationIdError;

/// The unit of a packet's samples, as its sender says (issue 20 item 15). The engine refuses
/// a packet whose unit does not match its station's configuration: counts need the station's
/// `gain_mps2_per_count`, and m/s² must not meet one (the node would scale calibrated data by a
/// gain, silently shrinking the shaking).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SampleUnit {
    /// Calibrated acceleration, m/s² (the default).
    #[default]
    MetresPerSecondSquared,
    /// Digitiser counts, converted by the station's configured gain.
    Counts,
    /// A unit the sender named with a code the node does not know (the transport's code,
    /// for the log line): the packet is refused.
    Unknown(u8),
}

/// Three-component acceleration from one station, as sent by a transport.
///
/// `station` was parsed once, at the transport's edge, by [`station_at_edge`]: a packet whose
/// id is not `NET.STA.LOC` never becomes an `AccelPacket`.
///
/// `east`, `north`, `up` are in `unit`: m/s², or counts for a station with a gain, at
/// `t = start_time_ns + i / sample_rate_hz`; `up` may be empty. For stations whose horizontal
/// channels are oriented 1/2, `east` carries channel 1 and `north` channel 2 (the station
/// configuration rotates them).
#[derive(Debug, Clone, PartialEq)]
pub struct AccelPacket {
    pub station: StationId,
    /// UTC time of the first sample (ns since the Unix epoch).
    pub start_time_ns: i64,
    pub sample_rate_hz: f64,
    /// Per-station sequence number, incremented by one per packet by the sender.
    pub sequence: u64,
    pub east: Vec<f32>,
    pub north: Vec<f32>,
    pub up: Vec<f32>,
    /// The unit of the samples.
    pub unit: SampleUnit,
}

/// A packet refused at its transport's edge: its station id, as received, is not
/// `NET.STA.LOC` ([`station_at_edge`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("malformed station id: {error}")]
pub struct MalformedStation {
    /// The id as received (any text: bound and escape it before showing it).
    pub received: String,
    pub error: StationIdError,
}

impl MalformedStation {
    /// The notice of the refusal, the same whatever the transport: kind
    /// [`NoticeKind::Rejected`], under the id as received.
    #[must_use]
    pub fn notice(&self) -> Notice {
        Notice {
            station: self.received.clone(),
            kind: NoticeKind::Rejected,
            message: self.error.to_string(),
        }
    }
}

/// The station id of a received packet, `received` as its transport carries it: the one
/// check every transport makes at its edge (iceoryx2, ROS 2 `AccelPacket`), so that a
/// malformed id is refused, counted and said the same way whichever way it came
/// (the node: `NodeRuntime::refuse_malformed`). Allocates only the returned id or error.
pub fn station_at_edge(received: &str) -> Result<StationId, MalformedStation> {
    StationId::parse(received).map_err(|error| MalformedStation {
        received: received.to_owned(),
        error,
    })
}

/// Why a packet was rejected as a whole.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PacketError {
    #[error("empty packet")]
    Empty,
    #[error("{got} samples exceed the limit of {MAX_SAMPLES_PER_PACKET}")]
    TooLarge { got: usize },
    #[error("component lengths differ: east {east}, north {north}, up {up} (up may be empty)")]
    LengthMismatch {
        east: usize,
        north: usize,
        up: usize,
    },
    #[error("sample rate {0} Hz outside [1, 10000] Hz")]
    SampleRate(f64),
    #[error("start time {0} ns is outside the years 1900-2100")]
    StartTime(i64),
    #[error("non-finite sample ({component}[{index}] = {value})")]
    NonFinite {
        component: &'static str,
        index: usize,
        value: f32,
    },
}

impl AccelPacket {
    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.east.len()
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.east.is_empty()
    }

    /// Checks the packet's structure and values (not its place in the stream): lengths,
    /// sample rate, start time, finiteness (its station id was checked at the transport's
    /// edge, [`station_at_edge`]). The engine runs it once per packet, for every transport.
    /// Does not allocate.
    pub fn validate_samples(&self) -> Result<(), PacketError> {
        let n = self.east.len();
        if n == 0 {
            return Err(PacketError::Empty);
        }
        if n > MAX_SAMPLES_PER_PACKET {
            return Err(PacketError::TooLarge { got: n });
        }
        if self.north.len() != n || !(self.up.is_empty() || self.up.len() == n) {
            return Err(PacketError::LengthMismatch {
                east: n,
                north: self.north.len(),
                up: self.up.len(),
            });
        }
        let (lo, hi) = SAMPLE_RATE_RANGE_HZ;
        if !(self.sample_rate_hz.is_finite()
            && self.sample_rate_hz >= lo
            && self.sample_rate_hz <= hi)
        {
            return Err(PacketError::SampleRate(self.sample_rate_hz));
        }
        let (t_lo, t_hi) = START_TIME_RANGE_NS;
        if !(t_lo..=t_hi).contains(&self.start_time_ns) {
            return Err(PacketError::StartTime(self.start_time_ns));
        }
        for (component, values) in [
            ("east", &self.east),
            ("north", &self.north),
            ("up", &self.up),
        ] {
            if let Some((index, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(PacketError::NonFinite {
                    component,
                    index,
                    value,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn packet(n: usize) -> AccelPacket {
        AccelPacket {
            station: StationId::parse("CI.RRS.00").unwrap(),
            start_time_ns: 0,
            sample_rate_hz: 100.0,
            sequence: 0,
            east: vec![0.0; n],
            north: vec![0.0; n],
            up: vec![],
            unit: Default::default(),
        }
    }

    #[test]
    fn each_malformation_is_named() {
        assert_eq!(packet(0).validate_samples(), Err(PacketError::Empty));
        let mut p = packet(3);
        p.up = vec![0.0; 2];
        assert!(matches!(
            p.validate_samples(),
            Err(PacketError::LengthMismatch { .. })
        ));
        let mut p = packet(3);
        p.sample_rate_hz = 1e9;
        assert_eq!(p.validate_samples(), Err(PacketError::SampleRate(1e9)));
        let mut p = packet(3);
        p.north[2] = f32::NAN;
        assert!(matches!(
            p.validate_samples(),
            Err(PacketError::NonFinite {
                component: "north",
                index: 2,
                ..
            })
        ));
        assert!(matches!(
            packet(MAX_SAMPLES_PER_PACKET + 1).validate_samples(),
            Err(PacketError::TooLarge { .. })
        ));
        let mut p = packet(1);
        p.start_time_ns = i64::MAX - 1_000_000;
        assert!(matches!(
            p.validate_samples(),
            Err(PacketError::StartTime(_))
        ));
    }

    #[test]
    fn a_malformed_station_id_is_refused_at_the_edge_with_its_notice() {
        assert_eq!(
            station_at_edge("CI.RRS.00").unwrap(),
            StationId::parse("CI.RRS.00").unwrap()
        );
        let refused = station_at_edge("nope").unwrap_err();
        assert_eq!(refused.received, "nope");
        let notice = refused.notice();
        assert_eq!(
            (notice.station.as_str(), notice.kind),
            ("nope", NoticeKind::Rejected)
        );
        assert!(notice.message.contains("NET.STA.LOC"), "{}", notice.message);
    }
}
