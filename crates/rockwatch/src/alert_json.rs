//! The one JSON schema of alerts (and of the other journal records) for the outside world:
//! `rockwatch monitor --format jsonl`, `rockwatch alerts --format json` and the payload of the
//! `[[notify]]` receivers (`crate::notify`) all write [`RecordJson`].
//!
//! An alert is one flat object, tagged `"type": "alert"`:
//!
//! ```json
//! {"type": "alert", "pbr_id": "rrs-slender-pillar", "level": "overturned", "episode": 1,
//!  "data_time": "1994-01-17T12:31:05.120000000Z", "data_time_ns": 758809865120000000,
//!  "station": "CI.RRS.00", "mode": "overturned", "theta_over_alpha": 7.958,
//!  "slide_m": 0.0, "overturn_probability": 1.0, "pga_mps2": 8.1, "pgv_mps": 1.6,
//!  "direction_deg": 228.0, "pbr_name": "Slender pillar east of Rinaldi",
//!  "lat_deg": 34.2835, "lon_deg": -118.4765}
//! ```
//!
//! - `level`: `motion_onset` | `overturn_imminent` | `overturned` (increasing severity).
//! - (`pbr_id`, `episode`, `level`) identifies an alert: the engine raises each at most once,
//!   so a receiver de-duplicates on it (delivery to receivers is at least once).
//! - `data_time`: ISO 8601 / RFC 3339 UTC time of the triggering sample, nanoseconds;
//!   `data_time_ns`: the same as ns since 1970-01-01T00:00:00Z.
//! - `mode`: `rest` | `slide` | `rock` | `slide-rock` | `overturned` | `flight`.
//! - `theta_over_alpha`: signed θ/α (θ > 0 clockwise about the +x pivot; |θ/α| = 1 is the
//!   static overturning angle); `slide_m`: slip of the contact point (m);
//!   `overturn_probability`: ensemble probability (0–1); `pga_mps2`: the station's running
//!   peak of the horizontal vector (orientation-independent, = RotD100, m/s²); `pgv_mps`: its
//!   running PGV, larger horizontal component (m/s). A non-finite value is `null`.
//! - `direction_deg`: the direction that raised the alert, the azimuth of the block's +x axis
//!   in degrees clockwise from north (a planar block's own azimuth; for a rock from a mesh,
//!   the direction that overturned or rocks most).
//! - `pbr_name`, `lat_deg`, `lon_deg`: the rock's catalogue name and WGS84 position (degrees
//!   north and east; `null` when unknown; `""` and `null` in alerts journaled before
//!   rockwatch carried them).
//!
//! The other records of a state directory's journal (`alerts --format json`; README, "Alert
//! JSON", lists every key): `{"type": "episode_end", "pbr_id", "episode", "data_time",
//! "data_time_ns"}` (the block is back at rest on a quiet station, at that data time),
//! `{"type": "reset", "pbr_id", "time", "time_ns"}` (an operator reset a fallen block, at
//! that wall-clock time) and `{"type": "published", "pbr_id", "episode", "level"}` (the node
//! handed that alert to its publishers). The times are absent from records journaled before
//! rockwatch kept them. Readers must ignore keys they do not know: `monitor` adds `t_s` and
//! `latency_us` to its alert lines, and keys may be added later.

use rockwatch_core::dynamics::Mode;
use rockwatch_core::engine::{Alert, AlertKey, AlertLevel, JournalRecord, PbrId, StationId};
use rockwatch_core::record::mseed::format_time_ns;

/// An alert in the shared schema (see the module documentation).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AlertJson {
    /// The rock's catalogue id (a JSON string).
    pub pbr_id: PbrId,
    pub level: AlertLevel,
    /// Episode of the block (1 for the first).
    pub episode: u32,
    /// ISO 8601 UTC time of the triggering sample (ns resolution, `Z`).
    pub data_time: String,
    /// The same time as ns since the Unix epoch.
    pub data_time_ns: i64,
    /// SEED `NET.STA.LOC` of the station the block follows (a JSON string).
    pub station: StationId,
    pub mode: Mode,
    /// θ/α, signed (dimensionless).
    pub theta_over_alpha: f64,
    /// Slip of the contact point (m).
    pub slide_m: f64,
    /// Ensemble overturn probability (0–1).
    pub overturn_probability: f64,
    /// Station's running PGA, peak of the horizontal vector (m/s²).
    pub pga_mps2: f64,
    /// Station's running PGV, larger horizontal component (m/s).
    pub pgv_mps: f64,
    /// The direction that raised the alert: azimuth of the block's +x axis, degrees
    /// clockwise from north (absent in records written before it existed: 0).
    #[serde(default)]
    pub direction_deg: f64,
    /// The rock's catalogue name ("" in records written before it existed).
    #[serde(default)]
    pub pbr_name: String,
    /// The rock's WGS84 latitude and longitude (degrees; null when unknown).
    #[serde(default)]
    pub lat_deg: Option<f64>,
    #[serde(default)]
    pub lon_deg: Option<f64>,
}

impl AlertJson {
    /// The identity under which receivers de-duplicate: (block, episode, level).
    #[must_use]
    pub fn key(&self) -> AlertKey {
        (self.pbr_id.clone(), self.episode, self.level)
    }
}

impl From<&Alert> for AlertJson {
    fn from(a: &Alert) -> AlertJson {
        AlertJson {
            pbr_id: a.pbr_id.clone(),
            level: a.level,
            episode: a.episode,
            data_time: format_time_ns(a.data_time_ns),
            data_time_ns: a.data_time_ns,
            station: a.station.clone(),
            mode: a.mode,
            theta_over_alpha: a.theta_over_alpha,
            slide_m: a.slide_m,
            overturn_probability: a.overturn_probability,
            pga_mps2: a.pga_mps2,
            pgv_mps: a.pgv_mps,
            direction_deg: a.direction_deg,
            pbr_name: a.pbr_name.clone(),
            lat_deg: a.lat_deg,
            lon_deg: a.lon_deg,
        }
    }
}

/// A journal record in the shared schema, tagged by `type`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum RecordJson {
    Alert(AlertJson),
    /// A block's episode ended.
    EpisodeEnd {
        pbr_id: PbrId,
        episode: u32,
        /// ISO 8601 UTC data time of the sample at which it ended (absent from records
        /// journaled before rockwatch kept it).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        data_time: Option<String>,
        /// The same as ns since the Unix epoch.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        data_time_ns: Option<i64>,
    },
    /// An operator reset a fallen block.
    Reset {
        pbr_id: PbrId,
        /// ISO 8601 UTC wall-clock time of the reset (the node's clock, or the `reset
        /// --state-dir` command's); absent from records journaled before rockwatch kept it.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        time: Option<String>,
        /// The same as ns since the Unix epoch.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        time_ns: Option<i64>,
    },
    /// The alert (pbr_id, episode, level) was handed to the publishers (the node's marker for
    /// at-least-once publication across crashes).
    Published {
        pbr_id: PbrId,
        episode: u32,
        level: AlertLevel,
    },
}

impl From<&JournalRecord> for RecordJson {
    fn from(r: &JournalRecord) -> RecordJson {
        match r {
            JournalRecord::Alert(a) => RecordJson::Alert(a.into()),
            JournalRecord::EpisodeEnd {
                pbr_id,
                episode,
                data_time_ns,
            } => RecordJson::EpisodeEnd {
                pbr_id: pbr_id.clone(),
                episode: *episode,
                data_time: data_time_ns.map(format_time_ns),
                data_time_ns: *data_time_ns,
            },
            JournalRecord::Reset { pbr_id, time_ns } => RecordJson::Reset {
                pbr_id: pbr_id.clone(),
                time: time_ns.map(format_time_ns),
                time_ns: *time_ns,
            },
            JournalRecord::Published {
                pbr_id,
                episode,
                level,
            } => RecordJson::Published {
                pbr_id: pbr_id.clone(),
                episode: *episode,
                level: *level,
            },
        }
    }
}

/// An alert as one JSON object (`{"type": "alert", …}`).
#[must_use]
pub fn alert_value(a: &Alert) -> serde_json::Value {
    // Serializing plain fields (strings, numbers, unit enums) cannot fail.
    serde_json::to_value(RecordJson::Alert(a.into())).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn alert() -> Alert {
        Alert {
            pbr_id: rockwatch_core::engine::PbrId::parse("rrs-slender-pillar").unwrap(),
            station: rockwatch_core::engine::StationId::parse("CI.RRS.00").unwrap(),
            level: AlertLevel::OverturnImminent,
            episode: 2,
            mode: Mode::SlideRock,
            theta_over_alpha: -0.85,
            slide_m: 0.01,
            overturn_probability: 0.25,
            pga_mps2: 8.0,
            pgv_mps: 1.5,
            // 1994-01-17T12:30:55.5Z (Northridge origin time, rounded): 8782 days × 86400 s
            // + 45055 s = 758 809 855 s since the epoch.
            data_time_ns: 758_809_855_500_000_000,
            arrival_ns: 42,
            direction_deg: 228.0,
            pbr_name: "Slender pillar east of Rinaldi".into(),
            lat_deg: Some(34.2835),
            lon_deg: None,
        }
    }

    #[test]
    fn an_alert_is_one_flat_object_tagged_alert_with_an_iso_utc_time() {
        let v = alert_value(&alert());
        let expected = serde_json::json!({
            "type": "alert", "pbr_id": "rrs-slender-pillar", "level": "overturn_imminent",
            "episode": 2, "data_time": "1994-01-17T12:30:55.500000000Z",
            "data_time_ns": 758_809_855_500_000_000_i64, "station": "CI.RRS.00",
            "mode": "slide-rock", "theta_over_alpha": -0.85, "slide_m": 0.01,
            "overturn_probability": 0.25, "pga_mps2": 8.0, "pgv_mps": 1.5,
            "direction_deg": 228.0, "pbr_name": "Slender pillar east of Rinaldi",
            "lat_deg": 34.2835, "lon_deg": null,
        });
        assert_eq!(v, expected);
        // It reads back.
        let back: RecordJson = serde_json::from_value(v.clone()).unwrap();
        assert_eq!(back, RecordJson::Alert((&alert()).into()));
        // A record written before `direction_deg` and the rock's place existed reads with 0,
        // "" and null.
        let mut old = v;
        if let Some(map) = old.as_object_mut() {
            for key in ["direction_deg", "pbr_name", "lat_deg", "lon_deg"] {
                map.remove(key);
            }
        }
        let back: RecordJson = serde_json::from_value(old).unwrap();
        let RecordJson::Alert(back) = back else {
            panic!("not an alert: {back:?}");
        };
        assert_eq!(
            (
                back.direction_deg,
                back.pbr_name.as_str(),
                back.lat_deg,
                back.lon_deg
            ),
            (0.0, "", None, None)
        );
    }

    #[test]
    fn the_other_journal_records_are_tagged_by_type() {
        let end = RecordJson::from(&JournalRecord::EpisodeEnd {
            pbr_id: rockwatch_core::engine::PbrId::parse("a").unwrap(),
            episode: 3,
            data_time_ns: Some(758_809_855_500_000_000),
        });
        assert_eq!(
            serde_json::to_value(&end).unwrap(),
            serde_json::json!({"type": "episode_end", "pbr_id": "a", "episode": 3,
                "data_time": "1994-01-17T12:30:55.500000000Z",
                "data_time_ns": 758_809_855_500_000_000_i64})
        );
        let reset = RecordJson::from(&JournalRecord::Reset {
            pbr_id: rockwatch_core::engine::PbrId::parse("b").unwrap(),
            time_ns: Some(0),
        });
        assert_eq!(
            serde_json::to_value(&reset).unwrap(),
            serde_json::json!({"type": "reset", "pbr_id": "b",
                "time": "1970-01-01T00:00:00.000000000Z", "time_ns": 0})
        );
        // Records journaled before the times were kept: the keys are absent.
        let old = RecordJson::from(&JournalRecord::Reset {
            pbr_id: rockwatch_core::engine::PbrId::parse("b").unwrap(),
            time_ns: None,
        });
        assert_eq!(
            serde_json::to_value(&old).unwrap(),
            serde_json::json!({"type": "reset", "pbr_id": "b"})
        );
    }
}
