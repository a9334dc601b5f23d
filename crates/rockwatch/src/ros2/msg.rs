//! The `pbr_msgs` interfaces (`msg/pbr_msgs/msg/*.msg`, `msg/pbr_msgs/srv/*.srv`) as Rust structs for the CDR wire
//! format.
//!
//! CDR is positional: the fields below are declared in exactly the order and with exactly the
//! types of the `.msg` and `.srv` files (checked by `tests/ros2_msgs.rs`, which parses `msg/pbr_msgs/`).
//! Field names are those of the files, so they carry no unit suffix; the units are in each doc
//! comment (SI: m/s², m/s, m, s, rad).

use ros2_client::builtin_interfaces::Time;
use serde::{Deserialize, Serialize};

use rockwatch_core::engine;

/// The mode and level codes of the messages (one table for both transports).
pub use crate::wire_codes::{
    level_code, level_name, level_of_code, mode_code, mode_of_code, LEVEL_MOTION_ONSET,
    LEVEL_OVERTURNED, LEVEL_OVERTURN_IMMINENT, MODE_FLIGHT, MODE_OVERTURNED, MODE_REST, MODE_ROCK,
    MODE_SLIDE, MODE_SLIDE_ROCK, UNIT_COUNTS, UNIT_MPS2,
};

/// The ROS 2 package of the messages (DDS type names `pbr_msgs::msg::dds_::<Name>_`) and of
/// the service (`pbr_msgs::srv::dds_::ResetPbr_Request_` / `_Response_`).
pub const PACKAGE: &str = "pbr_msgs";

/// The service type `pbr_msgs/srv/ResetPbr`.
pub const RESET_SERVICE_TYPE: &str = "ResetPbr";

/// `std_msgs/Header`: `builtin_interfaces/Time stamp`, `string frame_id`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// UTC time (ns since the Unix epoch on the wire as sec + nanosec).
    pub stamp: Time,
    pub frame_id: String,
}

impl Header {
    /// A header stamped `time_ns` (UTC ns) with `frame_id`.
    #[must_use]
    pub fn new(time_ns: i64, frame_id: &str) -> Header {
        Header {
            stamp: Time::from_nanos(time_ns),
            frame_id: frame_id.to_string(),
        }
    }
}

/// `pbr_msgs/AccelPacket`: three-component acceleration of one station.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AccelPacket {
    /// stamp = UTC time of the first sample; frame_id = station SEED id `NET.STA.LOC`.
    pub header: Header,
    /// Samples per second (Hz).
    pub sample_rate: f64,
    /// Packet sequence number of the station's stream.
    pub sequence: u64,
    /// 0: m/s², 1: counts ([`engine::SampleUnit`]'s wire codes, [`crate::wire_codes`]).
    /// Before the arrays: as the last field, RustDDS 0.15.1's secured readers failed to
    /// decrypt the packets (`tests/ros2_security.rs`).
    pub unit: u8,
    /// East acceleration, in `unit`.
    pub east: Vec<f32>,
    /// North acceleration (same units as `east`).
    pub north: Vec<f32>,
    /// Up acceleration (same units; may be empty).
    pub up: Vec<f32>,
}

/// `pbr_msgs/StationIntensity`: a station's running intensity measures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StationIntensity {
    /// stamp = data time of the latest sample; frame_id = station.
    pub header: Header,
    /// Peak ground acceleration (m/s²), larger horizontal component.
    pub pga: f64,
    /// Peak ground velocity (m/s).
    pub pgv: f64,
    /// Peak ground displacement (m).
    pub pgd: f64,
    /// Cumulative absolute velocity (m/s).
    pub cav: f64,
    /// Arias intensity (m/s).
    pub arias: f64,
    /// Acceleration spectrum intensity (m/s).
    pub asi: f64,
    /// Significant duration D5–95 (s).
    pub d5_95: f64,
    /// Periods of `sa` (s).
    pub sa_periods: Vec<f64>,
    /// Pseudo-spectral acceleration, 5 % damping (m/s²).
    pub sa: Vec<f64>,
    pub rejected_samples: u64,
    pub gap_samples: u64,
    pub late_samples: u64,
}

/// `pbr_msgs/PbrState`: one block's state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PbrState {
    /// stamp = data time of the latest sample integrated; frame_id = the rock's frame
    /// `pbr/<pbr_id>` ([`rock_frame`](super::names::rock_frame), on `/tf_static`).
    pub header: Header,
    pub pbr_id: String,
    /// The station driving the block (SEED id `NET.STA.LOC`).
    pub station: String,
    /// One of the `MODE_*` constants ([`mode_code`]).
    pub mode: u8,
    /// Rocking angle θ (rad).
    pub theta: f64,
    /// θ/α, signed (dimensionless): the rocking angle θ (> 0 clockwise about the +x pivot,
    /// spec §1) over the block's slenderness α; |θ/α| = 1 is the static overturning angle.
    pub theta_over_alpha: f64,
    /// Slip of the contact point (m).
    pub slide: f64,
    pub data_gap: bool,
    /// Fraction of the ensemble that overturned (0..1).
    pub overturn_probability: f64,
    /// The block's station is stale (no data for `engine.stale_after_s`): the block is not
    /// monitored. Published for each block when its station goes stale and when it recovers.
    pub not_monitored: bool,
    /// The direction described: azimuth of the +x axis, degrees clockwise from north.
    pub direction_deg: f64,
}

/// `pbr_msgs/PbrAlert`: an alert about one block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PbrAlert {
    /// stamp = data time of the triggering sample (a reset's: its wall-clock time);
    /// frame_id = the rock's frame `pbr/<pbr_id>` ([`rock_frame`](super::names::rock_frame),
    /// as the rock's `PbrState`; its station is in `station`).
    pub header: Header,
    pub pbr_id: String,
    /// The station driving the block (SEED id `NET.STA.LOC`).
    pub station: String,
    /// One of the `LEVEL_*` constants ([`level_code`]).
    pub level: u8,
    /// One of the `MODE_*` constants ([`mode_code`]).
    pub mode: u8,
    /// θ/α, signed (dimensionless): the rocking angle θ (> 0 clockwise about the +x pivot,
    /// spec §1) over the block's slenderness α; |θ/α| = 1 is the static overturning angle.
    pub theta_over_alpha: f64,
    /// Slip of the contact point (m).
    pub slide: f64,
    pub overturn_probability: f64,
    /// Station's running PGA (m/s²) and PGV (m/s).
    pub pga: f64,
    pub pgv: f64,
    pub message: String,
    /// The direction that raised the alert: azimuth of the +x axis, degrees clockwise from
    /// north.
    pub direction_deg: f64,
    /// The block's episode: one alert per (pbr_id, episode, level), the key subscribers
    /// de-duplicate by.
    pub episode: u32,
    /// The rock's catalogue name; its WGS84 position (degrees; NaN when unknown).
    pub pbr_name: String,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
}

/// `pbr_msgs/IntakeReport` (`msg/pbr_msgs/msg/IntakeReport.msg`): what one node made of the
/// packets of one writer of `/pbr/accel` (published on `/pbr/intake`); the fields are those of
/// [`IntakeCount`](crate::intake::IntakeCount).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct IntakeReport {
    pub node_id: [u8; 16],
    pub node: String,
    /// The node's reader's DDS GUID (rmw gid).
    pub reader_gid: [u8; 16],
    /// The writer's DDS GUID (rmw gid): 12-byte GUID prefix, 4-byte entity id.
    pub writer_gid: [u8; 16],
    pub taken: u64,
    pub ignored: u64,
    pub processed: u64,
    pub refused: u64,
    pub window: u64,
    pub dropped: u64,
}

impl From<crate::intake::IntakeCount> for IntakeReport {
    fn from(c: crate::intake::IntakeCount) -> Self {
        IntakeReport {
            node_id: c.node_id,
            node: c.node,
            reader_gid: c.reader,
            writer_gid: c.writer,
            taken: c.taken,
            ignored: c.ignored,
            processed: c.processed,
            refused: c.refused,
            window: c.window,
            dropped: c.dropped,
        }
    }
}

impl From<IntakeReport> for crate::intake::IntakeCount {
    fn from(r: IntakeReport) -> Self {
        crate::intake::IntakeCount {
            node_id: r.node_id,
            node: r.node,
            reader: r.reader_gid,
            writer: r.writer_gid,
            taken: r.taken,
            ignored: r.ignored,
            processed: r.processed,
            refused: r.refused,
            window: r.window,
            dropped: r.dropped,
        }
    }
}

/// `pbr_msgs/srv/ResetPbr` request (`msg/pbr_msgs/srv/ResetPbr.srv`): the operator reset of a block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResetPbrRequest {
    /// Catalogue id of the block.
    pub pbr_id: String,
}

/// `pbr_msgs/srv/ResetPbr` response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResetPbrResponse {
    /// True if the block was reset or stood already; false for an unknown id or a failed
    /// journal.
    pub success: bool,
    /// What the node did, for people.
    pub message: String,
}

impl ros2_client::Message for Header {}
impl ros2_client::Message for AccelPacket {}
impl ros2_client::Message for StationIntensity {}
impl ros2_client::Message for PbrState {}
impl ros2_client::Message for PbrAlert {}
impl ros2_client::Message for ResetPbrRequest {}
impl ros2_client::Message for ResetPbrResponse {}

impl TryFrom<&AccelPacket> for engine::AccelPacket {
    type Error = engine::MalformedStation;

    /// The engine's packet: station = frame_id, parsed here once
    /// ([`engine::station_at_edge`], as the iceoryx2 input does), start = stamp (UTC ns). The
    /// samples are not validated here: the engine validates and counts bad packets.
    fn try_from(m: &AccelPacket) -> Result<engine::AccelPacket, engine::MalformedStation> {
        Ok(engine::AccelPacket {
            station: engine::station_at_edge(&m.header.frame_id)?,
            start_time_ns: m.header.stamp.to_nanos(),
            sample_rate_hz: m.sample_rate,
            sequence: m.sequence,
            east: m.east.clone(),
            north: m.north.clone(),
            up: m.up.clone(),
            unit: crate::wire_codes::unit_of_code(m.unit),
        })
    }
}

impl From<&engine::AccelPacket> for AccelPacket {
    fn from(p: &engine::AccelPacket) -> AccelPacket {
        AccelPacket {
            header: Header::new(p.start_time_ns, p.station.as_str()),
            sample_rate: p.sample_rate_hz,
            sequence: p.sequence,
            east: p.east.clone(),
            north: p.north.clone(),
            up: p.up.clone(),
            unit: crate::wire_codes::unit_code(p.unit),
        }
    }
}

impl From<&engine::StationIntensity> for StationIntensity {
    fn from(i: &engine::StationIntensity) -> StationIntensity {
        StationIntensity {
            header: Header::new(i.data_time_ns, i.station.as_str()),
            pga: i.pga_mps2,
            pgv: i.pgv_mps,
            pgd: i.pgd_m,
            cav: i.cav_mps,
            arias: i.arias_mps,
            asi: i.asi_mps,
            d5_95: i.d5_95_s,
            sa_periods: i.sa_periods_s.clone(),
            sa: i.sa_mps2.clone(),
            rejected_samples: i.rejected_samples,
            gap_samples: i.gap_samples,
            late_samples: i.late_samples,
        }
    }
}

impl From<&engine::PbrState> for PbrState {
    fn from(s: &engine::PbrState) -> PbrState {
        PbrState {
            header: Header::new(s.data_time_ns, &super::names::rock_frame(s.pbr_id.as_str())),
            pbr_id: s.pbr_id.to_string(),
            station: s.station.to_string(),
            mode: mode_code(s.mode),
            theta: s.theta_rad,
            theta_over_alpha: s.theta_over_alpha,
            slide: s.slide_m,
            data_gap: s.data_gap,
            overturn_probability: s.overturn_probability,
            not_monitored: s.not_monitored,
            direction_deg: s.direction_deg,
        }
    }
}

impl From<&engine::ResetEvent> for PbrAlert {
    /// Level [`LEVEL_RESET`](crate::wire_codes::LEVEL_RESET), mode REST, stamped with the
    /// reset's wall-clock time.
    fn from(r: &engine::ResetEvent) -> PbrAlert {
        PbrAlert {
            header: Header::new(r.time_ns, &super::names::rock_frame(r.pbr_id.as_str())),
            pbr_id: r.pbr_id.to_string(),
            station: r.station.to_string(),
            level: crate::wire_codes::LEVEL_RESET,
            mode: mode_code(rockwatch_core::dynamics::Mode::Rest),
            theta_over_alpha: 0.0,
            slide: 0.0,
            overturn_probability: 0.0,
            pga: 0.0,
            pgv: 0.0,
            message: format!(
                "reset {}: reset by the operator after its fall in episode {}: it stands again",
                r.pbr_id, r.episode
            ),
            direction_deg: 0.0,
            episode: r.episode,
            pbr_name: String::new(),
            latitude_deg: f64::NAN,
            longitude_deg: f64::NAN,
        }
    }
}

impl From<&engine::Alert> for PbrAlert {
    fn from(a: &engine::Alert) -> PbrAlert {
        PbrAlert {
            header: Header::new(a.data_time_ns, &super::names::rock_frame(a.pbr_id.as_str())),
            pbr_id: a.pbr_id.to_string(),
            station: a.station.to_string(),
            level: level_code(a.level),
            mode: mode_code(a.mode),
            theta_over_alpha: a.theta_over_alpha,
            slide: a.slide_m,
            overturn_probability: a.overturn_probability,
            pga: a.pga_mps2,
            pgv: a.pgv_mps,
            message: format!(
                "{} {}: {} (episode {}, θ/α {:+.2}, slide {:+.3} m, PGA {:.2} m/s²)",
                a.level.as_str(),
                a.pbr_id,
                a.mode,
                a.episode,
                a.theta_over_alpha,
                a.slide_m,
                a.pga_mps2
            ),
            direction_deg: a.direction_deg,
            episode: a.episode,
            pbr_name: a.pbr_name.clone(),
            latitude_deg: a.lat_deg.unwrap_or(f64::NAN),
            longitude_deg: a.lon_deg.unwrap_or(f64::NAN),
        }
    }
}
