//! Engine configuration: stations, thresholds, and the blocks to integrate.

use super::packet::StationId;
use super::stream::StreamConfig;
use crate::azimuth::Azimuth;
use crate::dynamics::BlockParams;

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
    pub fn validate(&self) -> Result<(), String> {
        let id = &self.id;
        if let Some(g) = self.gain_mps2_per_count {
            if !(g.is_finite() && g > 0.0) {
                return Err(format!(
                    "station {id}: gain_mps2_per_count must be > 0, got {g}"
                ));
            }
        }
        if let Some(f) = self.full_scale {
            if !(f.is_finite() && f > 0.0) {
                return Err(format!("station {id}: full_scale must be > 0, got {f}"));
            }
        }
        if let Orientation::Azimuths { h1, h2 } = self.orientation {
            let (h1_deg, h2_deg) = (h1.degrees(), h2.degrees());
            let d = (h2_deg - h1_deg).rem_euclid(180.0);
            if (d - 90.0).abs() > 1.0 {
                return Err(format!(
                    "station {id}: horizontal azimuths {h1_deg}° and {h2_deg}° must be orthogonal"
                ));
            }
        }
        if self.lat.is_some_and(|v| !(-90.0..=90.0).contains(&v))
            || self.lon.is_some_and(|v| !(-180.0..=180.0).contains(&v))
        {
            return Err(format!("station {id}: lat/lon out of range"));
        }
        Ok(())
    }
}

/// Alert and episode thresholds.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AlertConfig {
    /// `overturn_imminent` when |θ|/α reaches this ratio.
    pub imminent_theta_ratio: f64,
    /// `overturn_imminent` when the ensemble overturn probability reaches this value.
    pub imminent_probability: f64,
    /// A station is quiet while every horizontal and vertical |a| stays below this (m/s²).
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

/// Engine-wide options.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EngineConfig {
    pub stream: StreamConfig,
    pub alerts: AlertConfig,
    /// Each block's state is published on every mode change and at least this often (s of
    /// data time); station intensities at the same rate.
    pub state_interval_s: f64,
}

impl Default for EngineConfig {
    fn default() -> Self {
        EngineConfig {
            stream: StreamConfig::default(),
            alerts: AlertConfig::default(),
            state_interval_s: 1.0,
        }
    }
}

impl EngineConfig {
    /// Checks every threshold; the message names the key.
    pub fn validate(&self) -> Result<(), String> {
        let a = &self.alerts;
        let checks: [(&str, f64, bool); 7] = [
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
                "engine.alerts.imminent_theta_ratio",
                a.imminent_theta_ratio,
                a.imminent_theta_ratio > 0.0 && a.imminent_theta_ratio.is_finite(),
            ),
            (
                "engine.alerts.imminent_probability",
                a.imminent_probability,
                a.imminent_probability > 0.0 && a.imminent_probability <= 1.0,
            ),
            (
                "engine.alerts.quiet_threshold_mps2",
                a.quiet_threshold_mps2,
                a.quiet_threshold_mps2 >= 0.0 && a.quiet_threshold_mps2.is_finite(),
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
                    "engine.alerts.imminent_probability" => "(0, 1]",
                    "engine.alerts.quiet_s" => "(0, 86400] s",
                    _ => "a finite positive number",
                };
                return Err(format!("{key} = {value} is out of range: expected {range}"));
            }
        }
        Ok(())
    }
}

/// A block bound to a station, ready to integrate: the nominal block and, for an uncertainty
/// ensemble, its members.
#[derive(Debug, Clone, PartialEq)]
pub struct PbrSpec {
    pub id: String,
    pub station: StationId,
    /// Direction of the block's +x axis.
    pub azimuth: Azimuth,
    pub nominal: BlockParams,
    /// Ensemble members (empty: nominal only).
    pub members: Vec<BlockParams>,
}

impl PbrSpec {
    /// The engine's view of a catalogue entry: its nominal block, and its Latin-hypercube
    /// members when it declares an ensemble of more than one.
    pub fn from_catalogue(pbr: &crate::catalogue::Pbr) -> Result<PbrSpec, String> {
        let members = if pbr.ensemble_size() > 1 {
            pbr.members()
                .map_err(|e| format!("pbr {:?}: ensemble: {e}", pbr.id()))?
        } else {
            Vec::new()
        };
        Ok(PbrSpec {
            id: pbr.id().to_string(),
            station: pbr.station().clone(),
            azimuth: pbr.azimuth(),
            nominal: pbr.nominal(),
            members,
        })
    }
}
