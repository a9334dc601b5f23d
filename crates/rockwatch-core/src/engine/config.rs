//! Engine configuration: stations, thresholds, and the blocks to integrate.

use super::packet::StationId;
use super::stream::StreamConfig;
use crate::azimuth::Azimuth;
use crate::dynamics::BlockParams;
use crate::pbr_id::PbrId;

/// A configuration value out of its range; the message names the station or key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConfigError {
    #[error("station {station}: gain_mps2_per_count must be > 0, got {gain}")]
    Gain { station: StationId, gain: f64 },
    #[error("station {station}: full_scale must be > 0, got {full_scale}")]
    FullScale { station: StationId, full_scale: f64 },
    #[error("station {station}: horizontal azimuths {h1_deg}° and {h2_deg}° must be orthogonal")]
    NotOrthogonal {
        station: StationId,
        h1_deg: f64,
        h2_deg: f64,
    },
    #[error("station {station}: lat/lon out of range")]
    Coordinates { station: StationId },
    /// An engine key (`engine.…`) out of `range`.
    #[error("{key} = {value} is out of range: expected {range}")]
    OutOfRange {
        key: &'static str,
        value: f64,
        range: &'static str,
    },
    /// A 3-D rock whose parameters the dynamics refuse.
    #[error("pbr {pbr:?}: 3-D rock: {error}")]
    Rock3d { pbr: String, error: Rock3dSpecError },
    /// An ensemble member the engine cannot store compactly (parameters built field by field,
    /// not by `BlockParams::from_body`; `engine::members`).
    #[error("pbr {pbr:?}: direction {direction_deg}°: {error}")]
    Member {
        pbr: String,
        direction_deg: f64,
        error: super::members::MemberError,
    },
    /// A catalogue entry whose ensemble cannot be drawn.
    #[error("pbr {pbr:?}: ensemble: {error}")]
    Ensemble {
        pbr: String,
        error: crate::catalogue::EnsembleError,
    },
}

/// How a station's horizontal channels are oriented.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Orientation {
    /// `east` carries east, `north` carries north.
    EastNorth,
    /// `east` carries channel 1 and `north` channel 2, whose directions are given as
    /// azimuths (keys `h1_deg`, `h2_deg`: degrees clockwise from north); they must be
    /// orthogonal (to 1°). East/north are recovered as the sum of the channels' vectors
    /// (see [`crate::azimuth`]).
    Azimuths {
        #[serde(rename = "h1_deg")]
        h1: Azimuth,
        #[serde(rename = "h2_deg")]
        h2: Azimuth,
    },
}

/// One station as configured.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StationConfig {
    pub id: StationId,
    #[serde(default = "default_orientation")]
    pub orientation: Orientation,
    /// Sensitivity in (m/s²)/count (the convention of the MiniSEED reader); when set, packet
    /// values are counts and are multiplied by it.
    #[serde(default)]
    pub gain_mps2_per_count: Option<f64>,
    /// Full-scale value of the sensor in packet units (counts or m/s²); samples at or beyond
    /// 99.9 % of it are flagged as clipped.
    #[serde(default)]
    pub full_scale: Option<f64>,
    #[serde(default)]
    pub lat: Option<f64>,
    #[serde(default)]
    pub lon: Option<f64>,
}

fn default_orientation() -> Orientation {
    Orientation::EastNorth
}

impl StationConfig {
    /// A station with data in m/s² on east/north/up and no clipping level.
    #[must_use]
    pub fn default_for(id: StationId) -> Self {
        StationConfig {
            id,
            orientation: Orientation::EastNorth,
            gain_mps2_per_count: None,
            full_scale: None,
            lat: None,
            lon: None,
        }
    }

    /// Checks gains, full scale, azimuths and coordinates; the message names the field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let station = self.id.clone();
        if let Some(gain) = self.gain_mps2_per_count {
            if !(gain.is_finite() && gain > 0.0) {
                return Err(ConfigError::Gain { station, gain });
            }
        }
        if let Some(full_scale) = self.full_scale {
            if !(full_scale.is_finite() && full_scale > 0.0) {
                return Err(ConfigError::FullScale {
                    station,
                    full_scale,
                });
            }
        }
        if let Orientation::Azimuths { h1, h2 } = self.orientation {
            let (h1_deg, h2_deg) = (h1.degrees(), h2.degrees());
            let d = (h2_deg - h1_deg).rem_euclid(180.0);
            if (d - 90.0).abs() > 1.0 {
                return Err(ConfigError::NotOrthogonal {
                    station,
                    h1_deg,
                    h2_deg,
                });
            }
        }
        if self.lat.is_some_and(|v| !(-90.0..=90.0).contains(&v))
            || self.lon.is_some_and(|v| !(-180.0..=180.0).contains(&v))
        {
            return Err(ConfigError::Coordinates { station });
        }
        Ok(())
    }
}

/// Alert and episode thresholds.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AlertConfig {
    /// `overturn_imminent` when |θ|/α reaches this ratio, in (0, 1] (at 1 the block has tipped
    /// past its static balance angle α).
    pub imminent_theta_ratio: f64,
    /// `overturn_imminent` when the ensemble overturn probability reaches this value.
    pub imminent_probability: f64,
    /// A station is quiet while every horizontal and vertical |a| stays below this (m/s², at
    /// most 100).
    pub quiet_threshold_mps2: f64,
    /// An episode ends when the block is at rest and its station has been quiet this long (s).
    pub quiet_s: f64,
}

impl Default for AlertConfig {
    fn default() -> Self {
        AlertConfig {
            imminent_theta_ratio: 0.8,
            imminent_probability: 0.5,
            quiet_threshold_mps2: 0.05,
            quiet_s: 30.0,
        }
    }
}

/// Physical plausibility of the input: what no real station can send.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlausibilityConfig {
    /// A packet with any sample beyond this |acceleration| (in g = 9.80665 m/s², after the
    /// station's gain) is rejected and counted (`implausible_packets`). Default 20 g: the
    /// largest range of strong-motion accelerometers in use (real ground motion stays below
    /// about 4 g).
    pub max_abs_accel_g: f64,
    /// The live node rejects and counts (`future_packets`) a packet whose last sample is
    /// stamped more than this (s) ahead of its arrival (UTC wall clock of the node). Offline
    /// runs (monitor) have no arrival clock and do not apply it; the engine itself is
    /// clock-free.
    pub max_ahead_s: f64,
}

impl Default for PlausibilityConfig {
    fn default() -> Self {
        PlausibilityConfig {
            max_abs_accel_g: 20.0,
            max_ahead_s: 5.0,
        }
    }
}

impl PlausibilityConfig {
    /// [`PlausibilityConfig::max_abs_accel_g`] in m/s².
    #[must_use]
    pub fn max_abs_accel_mps2(&self) -> f64 {
        self.max_abs_accel_g * crate::STANDARD_GRAVITY_MPS2
    }
}

/// Engine-wide options.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EngineConfig {
    pub stream: StreamConfig,
    pub alerts: AlertConfig,
    pub plausibility: PlausibilityConfig,
    /// Each block's state is published on every mode change and at least this often (s of
    /// data time); station intensities at the same rate.
    pub state_interval_s: f64,
    /// A station from which no accepted packet has arrived for this long (s, on the node's
    /// clock) is stale: reported, and its blocks flagged not monitored (`engine::health`).
    pub stale_after_s: f64,
}

impl Default for EngineConfig {
    fn default() -> Self {
        EngineConfig {
            stream: StreamConfig::default(),
            alerts: AlertConfig::default(),
            plausibility: PlausibilityConfig::default(),
            state_interval_s: 1.0,
            stale_after_s: 60.0,
        }
    }
}

impl EngineConfig {
    /// Checks every threshold; the message names the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let a = &self.alerts;
        let p = &self.plausibility;
        let checks: [(&str, f64, bool); 11] = [
            (
                "engine.stale_after_s",
                self.stale_after_s,
                self.stale_after_s > 0.0 && self.stale_after_s <= 86_400.0,
            ),
            (
                "engine.state_interval_s",
                self.state_interval_s,
                self.state_interval_s > 0.0 && self.state_interval_s <= 3600.0,
            ),
            (
                "engine.stream.max_bridge_s",
                self.stream.max_bridge_s,
                (0.0..=60.0).contains(&self.stream.max_bridge_s),
            ),
            (
                "engine.stream.reorder_window_packets",
                self.stream.reorder_window_packets as f64,
                self.stream.reorder_window_packets <= 1024,
            ),
            (
                "engine.stream.resync_packets",
                self.stream.resync_packets as f64,
                (1..=64).contains(&self.stream.resync_packets),
            ),
            (
                "engine.plausibility.max_abs_accel_g",
                p.max_abs_accel_g,
                p.max_abs_accel_g > 0.0 && p.max_abs_accel_g <= 1000.0,
            ),
            (
                "engine.plausibility.max_ahead_s",
                p.max_ahead_s,
                (0.0..=86_400.0).contains(&p.max_ahead_s),
            ),
            (
                "engine.alerts.imminent_theta_ratio",
                a.imminent_theta_ratio,
                a.imminent_theta_ratio > 0.0 && a.imminent_theta_ratio <= 1.0,
            ),
            (
                "engine.alerts.imminent_probability",
                a.imminent_probability,
                a.imminent_probability > 0.0 && a.imminent_probability <= 1.0,
            ),
            (
                "engine.alerts.quiet_threshold_mps2",
                a.quiet_threshold_mps2,
                (0.0..=100.0).contains(&a.quiet_threshold_mps2),
            ),
            (
                "engine.alerts.quiet_s",
                a.quiet_s,
                a.quiet_s > 0.0 && a.quiet_s <= 86_400.0,
            ),
        ];
        for (key, value, ok) in checks {
            if !ok {
                let range = match key {
                    "engine.state_interval_s" => "(0, 3600] s",
                    "engine.stream.max_bridge_s" => "[0, 60] s",
                    "engine.stream.reorder_window_packets" => "0 to 1024",
                    "engine.stream.resync_packets" => "1 to 64",
                    "engine.plausibility.max_abs_accel_g" => "(0, 1000] g",
                    "engine.plausibility.max_ahead_s" => "[0, 86400] s",
                    "engine.alerts.imminent_probability" => "(0, 1]",
                    "engine.alerts.imminent_theta_ratio" => {
                        "(0, 1] (1: tipped past static balance)"
                    }
                    "engine.alerts.quiet_threshold_mps2" => "[0, 100] m/s²",
                    "engine.alerts.quiet_s" | "engine.stale_after_s" => "(0, 86400] s",
                    _ => "a finite positive number",
                };
                return Err(ConfigError::OutOfRange { key, value, range });
            }
        }
        Ok(())
    }
}

/// Where a rock is, for the people an alert reaches: its catalogue name and its WGS84
/// position (degrees; `None` when not given, e.g. a block made in code).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RockPlace {
    pub name: String,
    pub lat_deg: Option<f64>,
    pub lon_deg: Option<f64>,
}

/// A block bound to a station, ready to integrate: the nominal block and, for an uncertainty
/// ensemble, its members.
#[derive(Debug, Clone, PartialEq)]
pub struct PbrSpec {
    pub id: PbrId,
    /// Its name and position, carried into its alerts.
    pub place: RockPlace,
    pub station: StationId,
    /// Direction of the block's +x axis.
    pub azimuth: Azimuth,
    pub nominal: BlockParams,
    /// Ensemble members (empty: nominal only).
    pub members: Vec<BlockParams>,
    /// Further toppling directions of a rock from a mesh (empty for a planar block), each
    /// with its own azimuth, nominal block and members (as many as `members`). The rock is
    /// integrated in every direction under the ground motion projected on it; it overturns
    /// when any direction does.
    pub more_directions: Vec<crate::catalogue::DirectionBlocks>,
    /// A mesh rock integrated in 3-D (`model = "3d"`): when set, it is the rock, and the
    /// planar fields above only describe it (`azimuth`, `nominal`: its first planar
    /// direction; `members`, `more_directions` empty) and are not integrated.
    pub rock_3d: Option<Rock3dSpec>,
}

/// Why a [`Rock3dSpec`] member cannot be integrated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Rock3dSpecError {
    /// Friction the 3-D dynamics refuse (not 0 ≤ μk ≤ μs, finite).
    #[error(transparent)]
    Friction(#[from] crate::rocking3d::Advance3dError),
    #[error("heading_deg = {0} is not a finite number of degrees")]
    Heading(f64),
}

/// A mesh rock integrated in 3-D (docs/rocking-3d.md): its rigid body (body frame: the
/// mesh's east, north, up at rest) and the heading and friction of its nominal rock and of
/// each ensemble member (empty: nominal only).
#[derive(Debug, Clone, PartialEq)]
pub struct Rock3dSpec {
    pub body: crate::rocking3d::RockBody,
    pub nominal: crate::catalogue::RigidMember,
    pub members: Vec<crate::catalogue::RigidMember>,
}

impl RockPlace {
    /// The name and position of a catalogue entry.
    #[must_use]
    pub fn of(pbr: &crate::catalogue::Pbr) -> RockPlace {
        RockPlace {
            name: pbr.name().to_string(),
            lat_deg: Some(pbr.lat_deg()),
            lon_deg: Some(pbr.lon_deg()),
        }
    }
}

impl PbrSpec {
    /// The engine's view of a catalogue entry: its nominal block, and its Latin-hypercube
    /// members when it declares an ensemble of more than one.
    pub fn from_catalogue(pbr: &crate::catalogue::Pbr) -> Result<PbrSpec, ConfigError> {
        let body = pbr.mesh().and_then(crate::catalogue::MeshRock::body);
        if let (Some(body), Some((nominal, members))) =
            (body, pbr.rigid_members(pbr.ensemble_size()))
        {
            return Ok(PbrSpec {
                id: pbr.id().clone(),
                place: RockPlace::of(pbr),
                station: pbr.station().clone(),
                azimuth: pbr.azimuth(),
                nominal: pbr.nominal(),
                members: Vec::new(),
                more_directions: Vec::new(),
                rock_3d: Some(Rock3dSpec {
                    body: body.clone(),
                    nominal,
                    members,
                }),
            });
        }
        let mut directions = pbr
            .directions()
            .map_err(|error| ConfigError::Ensemble {
                pbr: pbr.id().to_string(),
                error,
            })?
            .into_iter();
        let Some(first) = directions.next() else {
            // `directions` always has one at least; an empty list would be a catalogue bug.
            return Err(ConfigError::OutOfRange {
                key: "pbr.azimuths",
                value: 0.0,
                range: "at least one direction",
            });
        };
        Ok(PbrSpec {
            id: pbr.id().clone(),
            place: RockPlace::of(pbr),
            station: pbr.station().clone(),
            azimuth: first.azimuth,
            nominal: first.nominal,
            members: first.members,
            more_directions: directions.collect(),
            rock_3d: None,
        })
    }
}
