//! The shared-memory layouts of the iceoryx2 services (`#[repr(C)]`, no implicit padding), the
//! contract with C, C++ and Python clients (docs/iceoryx2.md lists every offset).
//!
//! Service `pbr/accel` (publish-subscribe): user header [`AccelHeader`], payload a slice of
//! [`AccelSample`]. Service `pbr/alerts` (publish-subscribe): payload [`PbrAlertIox`].
//! Service `pbr/accel/intake` (publish-subscribe, the node to the senders): payload
//! [`IntakeIox`].
//! Type names are explicit (`#[type_name]`) and must be spelled identically by every client.

use iceoryx2::prelude::ZeroCopySend;

use rockwatch_core::engine::{
    station_at_edge, AccelPacket, Alert, AlertLevel, MalformedStation, ResetEvent, SampleUnit,
};

/// The mode code of [`PbrAlertIox::mode`] (the table shared with ROS 2).
pub use crate::wire_codes::mode_code;
use crate::wire_codes::{level_code, level_of_code};

/// Type name of [`AccelHeader`] on the wire.
pub const ACCEL_HEADER_TYPE_NAME: &str = "rockwatch::AccelHeader";
/// Type name of [`AccelSample`] (the slice element) on the wire.
pub const ACCEL_SAMPLE_TYPE_NAME: &str = "rockwatch::AccelSample";
/// Type name of [`PbrAlertIox`] on the wire.
pub const PBR_ALERT_TYPE_NAME: &str = "rockwatch::PbrAlert";

/// [`AccelHeader::flags`] bit: the `up` component of the samples is valid. When clear the
/// station has no vertical channel and `up` is ignored (send 0).
pub const ACCEL_FLAG_HAS_UP: u32 = 1;

/// [`AccelHeader::flags`] bit: the samples are digitiser counts, converted by the station's
/// `gain_mps2_per_count` in the node's configuration; when clear they are m/s². The node
/// refuses a packet whose unit is not the one its configuration expects for the station.
pub const ACCEL_FLAG_COUNTS: u32 = 2;

/// Length of the NUL-padded station field (a SEED id `NET.STA.LOC` has at most 11 bytes).
pub const STATION_BYTES: usize = 16;
/// Length of the NUL-padded block-id field of an alert.
pub const PBR_ID_BYTES: usize = 64;

/// User header of one `pbr/accel` sample (56 bytes, alignment 8).
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[repr(C)]
#[type_name("rockwatch::AccelHeader")]
pub struct AccelHeader {
    /// Station SEED id `NET.STA.LOC`, ASCII, padded with NUL bytes (no NUL inside).
    pub station: [u8; STATION_BYTES],
    /// Sample rate (Hz), in [1, 10000].
    pub sample_rate_hz: f64,
    /// UTC time of the first sample (ns since the Unix epoch).
    pub start_time_ns: i64,
    /// Per-station packet number, incremented by one per packet by the sender: a jump is a
    /// gap (counted by the node).
    pub sequence: u64,
    /// Number of samples in the payload slice (must equal the slice length).
    pub sample_count: u64,
    /// Bits: [`ACCEL_FLAG_HAS_UP`], [`ACCEL_FLAG_COUNTS`]; other bits must be 0.
    pub flags: u32,
    /// Must be 0.
    pub reserved: u32,
}

/// One three-component sample (12 bytes, alignment 4): acceleration in m/s² (or counts, with
/// [`ACCEL_FLAG_COUNTS`]), east/north/up positive.
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[repr(C)]
#[type_name("rockwatch::AccelSample")]
pub struct AccelSample {
    pub east: f32,
    pub north: f32,
    pub up: f32,
}

/// Type name of [`IntakeIox`] on the wire.
pub const INTAKE_TYPE_NAME: &str = "rockwatch::IntakeReport";

/// Bytes of [`IntakeIox::node`].
pub const NODE_NAME_BYTES: usize = 64;

/// One intake report on `<accel service>/intake` (200 bytes, alignment 8): what one node made
/// of the packets of one publisher of `pbr/accel` (the fields of
/// [`IntakeCount`](crate::intake::IntakeCount); ids are iceoryx2's u128 ids, little-endian).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("rockwatch::IntakeReport")]
pub struct IntakeIox {
    pub node_id: [u8; 16],
    /// The node's reader: its `pbr/accel` subscriber's id.
    pub reader: [u8; 16],
    /// The publisher's id.
    pub writer: [u8; 16],
    pub taken: u64,
    pub ignored: u64,
    pub processed: u64,
    pub refused: u64,
    pub window: u64,
    /// Bytes of `node` used.
    pub node_len: u64,
    /// The node's name, UTF-8, truncated to [`NODE_NAME_BYTES`].
    pub node: [u8; NODE_NAME_BYTES],
    /// Packets whose samples were dropped as already processed (in what was reserved space
    /// before: a node of an older version says 0).
    pub dropped: u64,
    pub reserved: [u8; 32],
}

impl From<&crate::intake::IntakeCount> for IntakeIox {
    fn from(c: &crate::intake::IntakeCount) -> Self {
        let mut node = [0u8; NODE_NAME_BYTES];
        let mut len = c.node.len().min(NODE_NAME_BYTES);
        while !c.node.is_char_boundary(len) {
            len -= 1;
        }
        node[..len].copy_from_slice(&c.node.as_bytes()[..len]);
        IntakeIox {
            node_id: c.node_id,
            reader: c.reader,
            writer: c.writer,
            taken: c.taken,
            ignored: c.ignored,
            processed: c.processed,
            refused: c.refused,
            window: c.window,
            node_len: len as u64,
            node,
            dropped: c.dropped,
            reserved: [0; 32],
        }
    }
}

impl From<&IntakeIox> for crate::intake::IntakeCount {
    fn from(r: &IntakeIox) -> Self {
        let len = (r.node_len as usize).min(NODE_NAME_BYTES);
        crate::intake::IntakeCount {
            node_id: r.node_id,
            node: String::from_utf8_lossy(&r.node[..len]).into_owned(),
            reader: r.reader,
            writer: r.writer,
            taken: r.taken,
            ignored: r.ignored,
            processed: r.processed,
            refused: r.refused,
            dropped: r.dropped,
            window: r.window,
        }
    }
}

/// [`PbrAlertIox::flags`] bit: the block id was longer than [`PBR_ID_BYTES`] and is truncated.
pub const ALERT_FLAG_ID_TRUNCATED: u32 = 1;

/// [`PbrAlertIox::flags`] bit: the node's state directory is failing (e.g. a full disk): the
/// alert is published before it could be journaled (it will be when the directory recovers).
pub const ALERT_FLAG_JOURNAL_PENDING: u32 = 2;

/// One alert on `pbr/alerts` (168 bytes, alignment 8). Levels and modes are numbered as in
/// `msg/pbr_msgs/msg/PbrAlert.msg` ([`crate::wire_codes`]).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("rockwatch::PbrAlert")]
pub struct PbrAlertIox {
    /// Number of this alert from this publisher, from 0 (a jump means alerts were lost).
    pub sequence: u64,
    /// UTC time of the triggering sample (ns).
    pub data_time_ns: i64,
    /// Node-side latency: publication time − arrival of the triggering packet (ns).
    pub latency_ns: i64,
    /// θ/α, signed (dimensionless): the rocking angle θ (> 0 clockwise about the +x pivot,
    /// spec §1) over the block's slenderness α; |θ/α| = 1 is the static overturning angle.
    pub theta_over_alpha: f64,
    /// Slip of the contact point (m).
    pub slide_m: f64,
    /// Ensemble overturn probability in [0, 1].
    pub overturn_probability: f64,
    /// Station's running PGA, larger horizontal component (m/s²).
    pub pga_mps2: f64,
    /// Station's running PGV, larger horizontal component (m/s).
    pub pgv_mps: f64,
    /// Episode of the block (1 for the first).
    pub episode: u32,
    /// Bits: [`ALERT_FLAG_ID_TRUNCATED`], [`ALERT_FLAG_JOURNAL_PENDING`].
    pub flags: u32,
    /// MOTION_ONSET = 1, OVERTURN_IMMINENT = 2, OVERTURNED = 3.
    pub level: u8,
    /// REST = 0, SLIDE = 1, ROCK = 2, SLIDE_ROCK = 3, OVERTURNED = 4, FLIGHT = 5.
    pub mode: u8,
    /// Must be 0.
    pub reserved: [u8; 6],
    /// Station SEED id, NUL-padded.
    pub station: [u8; STATION_BYTES],
    /// Block id from the catalogue, UTF-8, NUL-padded (truncated at a character boundary).
    pub pbr_id: [u8; PBR_ID_BYTES],
    /// The direction that raised the alert: azimuth of its +x axis, degrees clockwise from
    /// north (a planar block's own azimuth; one of a meshed rock's directions).
    pub direction_deg: f64,
}

/// Copies `text` into a NUL-padded field, truncated at a character boundary; returns whether
/// it was truncated.
fn write_padded<const N: usize>(text: &str, field: &mut [u8; N]) -> bool {
    let mut end = text.len().min(N);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    *field = [0; N];
    field[..end].copy_from_slice(&text.as_bytes()[..end]);
    end < text.len()
}

/// Why a NUL-padded text field is not text.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PaddedTextError {
    #[error("bytes after the terminating NUL are not NUL")]
    AfterNul,
    #[error("not UTF-8: {0}")]
    NotUtf8(std::str::Utf8Error),
}

/// The text of a NUL-padded field: bytes up to the first NUL, which must be followed by NULs
/// only and be valid UTF-8.
pub fn read_padded(field: &[u8]) -> Result<&str, PaddedTextError> {
    let end = field.iter().position(|&b| b == 0).unwrap_or(field.len());
    if field[end..].iter().any(|&b| b != 0) {
        return Err(PaddedTextError::AfterNul);
    }
    std::str::from_utf8(&field[..end]).map_err(PaddedTextError::NotUtf8)
}

impl AccelHeader {
    /// The header of `packet`: station truncated to 16 bytes (a valid SEED id never is).
    #[must_use]
    pub fn from_packet(packet: &AccelPacket) -> AccelHeader {
        let mut station = [0; STATION_BYTES];
        write_padded(packet.station.as_str(), &mut station);
        AccelHeader {
            station,
            sample_rate_hz: packet.sample_rate_hz,
            start_time_ns: packet.start_time_ns,
            sequence: packet.sequence,
            sample_count: packet.east.len() as u64,
            flags: if packet.up.is_empty() {
                0
            } else {
                ACCEL_FLAG_HAS_UP
            } | if packet.unit == SampleUnit::Counts {
                ACCEL_FLAG_COUNTS
            } else {
                0
            },
            reserved: 0,
        }
    }
}

/// Why a received `pbr/accel` sample was rejected before the engine saw it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WireError {
    #[error("header sample_count {header} differs from the payload length {payload}")]
    CountMismatch { header: u64, payload: usize },
    #[error("station field: {0}")]
    Station(PaddedTextError),
    /// The station field is text, but not `NET.STA.LOC`: the refusal every transport makes
    /// ([`rockwatch_core::engine::station_at_edge`]), for the node to count and say.
    #[error(transparent)]
    MalformedStation(#[from] MalformedStation),
    #[error("unknown header flags {0:#x} or non-zero reserved field")]
    Flags(u32),
    #[error("{got} samples exceed the limit of {limit}")]
    TooLarge { got: usize, limit: usize },
}

/// Rebuilds the engine's packet from a received header and samples, checking the wire-level
/// structure (count, station bytes, flags, size) and parsing the station id once
/// ([`station_at_edge`], as the ROS 2 input does); the values are the engine's to check
/// (`AccelPacket::validate_samples`), the same for every transport.
pub fn packet_from_wire(
    header: &AccelHeader,
    samples: &[AccelSample],
) -> Result<AccelPacket, WireError> {
    if header.sample_count != samples.len() as u64 {
        return Err(WireError::CountMismatch {
            header: header.sample_count,
            payload: samples.len(),
        });
    }
    let limit = rockwatch_core::engine::packet::MAX_SAMPLES_PER_PACKET;
    if samples.len() > limit {
        return Err(WireError::TooLarge {
            got: samples.len(),
            limit,
        });
    }
    if header.flags & !(ACCEL_FLAG_HAS_UP | ACCEL_FLAG_COUNTS) != 0 || header.reserved != 0 {
        return Err(WireError::Flags(header.flags));
    }
    let station = read_padded(&header.station).map_err(WireError::Station)?;
    let has_up = header.flags & ACCEL_FLAG_HAS_UP != 0;
    Ok(AccelPacket {
        station: station_at_edge(station)?,
        start_time_ns: header.start_time_ns,
        sample_rate_hz: header.sample_rate_hz,
        sequence: header.sequence,
        east: samples.iter().map(|s| s.east).collect(),
        north: samples.iter().map(|s| s.north).collect(),
        up: if has_up {
            samples.iter().map(|s| s.up).collect()
        } else {
            Vec::new()
        },
        unit: if header.flags & ACCEL_FLAG_COUNTS != 0 {
            SampleUnit::Counts
        } else {
            SampleUnit::MetresPerSecondSquared
        },
    })
}

impl PbrAlertIox {
    /// The wire form of an alert (`sequence` = the publisher's alert counter).
    #[must_use]
    pub fn from_alert(alert: &Alert, latency_ns: i64, sequence: u64) -> PbrAlertIox {
        let mut out = PbrAlertIox {
            sequence,
            data_time_ns: alert.data_time_ns,
            latency_ns,
            theta_over_alpha: alert.theta_over_alpha,
            slide_m: alert.slide_m,
            overturn_probability: alert.overturn_probability,
            pga_mps2: alert.pga_mps2,
            pgv_mps: alert.pgv_mps,
            episode: alert.episode,
            flags: 0,
            level: level_code(alert.level),
            mode: mode_code(alert.mode),
            reserved: [0; 6],
            station: [0; STATION_BYTES],
            pbr_id: [0; PBR_ID_BYTES],
            direction_deg: alert.direction_deg,
        };
        write_padded(alert.station.as_str(), &mut out.station);
        if write_padded(alert.pbr_id.as_str(), &mut out.pbr_id) {
            out.flags |= ALERT_FLAG_ID_TRUNCATED;
        }
        out
    }

    /// The wire form of an operator reset (level code 4, `LEVEL_RESET`; mode REST; the
    /// reset's wall-clock time as `data_time_ns`).
    #[must_use]
    pub fn from_reset(reset: &ResetEvent, sequence: u64) -> PbrAlertIox {
        let mut out = PbrAlertIox {
            sequence,
            data_time_ns: reset.time_ns,
            latency_ns: 0,
            theta_over_alpha: 0.0,
            slide_m: 0.0,
            overturn_probability: 0.0,
            pga_mps2: 0.0,
            pgv_mps: 0.0,
            episode: reset.episode,
            flags: 0,
            level: crate::wire_codes::LEVEL_RESET,
            mode: mode_code(rockwatch_core::dynamics::Mode::Rest),
            reserved: [0; 6],
            station: [0; STATION_BYTES],
            pbr_id: [0; PBR_ID_BYTES],
            direction_deg: 0.0,
        };
        write_padded(reset.station.as_str(), &mut out.station);
        if write_padded(reset.pbr_id.as_str(), &mut out.pbr_id) {
            out.flags |= ALERT_FLAG_ID_TRUNCATED;
        }
        out
    }

    /// The block id (lossy if a client wrote invalid UTF-8).
    #[must_use]
    pub fn pbr_id(&self) -> String {
        padded_lossy(&self.pbr_id)
    }

    /// The station id.
    #[must_use]
    pub fn station(&self) -> String {
        padded_lossy(&self.station)
    }

    /// The alert level, if the byte is a known one.
    #[must_use]
    pub fn alert_level(&self) -> Option<AlertLevel> {
        level_of_code(self.level)
    }
}

fn padded_lossy(field: &[u8]) -> String {
    let end = field.iter().position(|&b| b == 0).unwrap_or(field.len());
    String::from_utf8_lossy(&field[..end]).into_owned()
}
