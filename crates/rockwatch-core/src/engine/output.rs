//! What the engine emits: alerts, block states, station intensities and notices.

use std::collections::{HashMap, HashSet};

use crate::dynamics::Mode;
use crate::pbr_id::PbrId;
use crate::station_id::StationId;

/// Where the engine puts its outputs, each as soon as it is produced (an alert mid-packet
/// need not wait for the rest of the packet). A `Vec<Output>` just collects them.
pub trait OutputSink {
    /// Takes one output.
    fn push(&mut self, output: Output);
}

impl OutputSink for Vec<Output> {
    fn push(&mut self, output: Output) {
        Vec::push(self, output);
    }
}

/// Alert levels, in increasing severity (numbering as in `msg/pbr_msgs/msg/PbrAlert.msg`).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum AlertLevel {
    /// The block left rest: rocking or sliding began.
    MotionOnset = 1,
    /// |θ|/α or the overturn probability reached its threshold.
    OverturnImminent = 2,
    /// The block fell.
    Overturned = 3,
}

impl AlertLevel {
    pub const ALL: [AlertLevel; 3] = [
        AlertLevel::MotionOnset,
        AlertLevel::OverturnImminent,
        AlertLevel::Overturned,
    ];

    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            AlertLevel::MotionOnset => "motion_onset",
            AlertLevel::OverturnImminent => "overturn_imminent",
            AlertLevel::Overturned => "overturned",
        }
    }

    fn index(self) -> usize {
        self as usize - 1
    }
}

/// An alert, emitted once per block per episode and level.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Alert {
    pub pbr_id: PbrId,
    pub station: StationId,
    pub level: AlertLevel,
    /// Episode number of this block (1 for the first), part of the alert's identity.
    pub episode: u32,
    pub mode: Mode,
    /// θ/α, signed (dimensionless): the rocking angle θ (> 0 clockwise about the +x pivot,
    /// spec §1) over the block's slenderness α; |θ/α| = 1 is the static overturning angle.
    pub theta_over_alpha: f64,
    /// Slip of the contact point u (m).
    pub slide_m: f64,
    pub overturn_probability: f64,
    /// Station's running PGA (m/s²), the peak of the horizontal vector (orientation-
    /// independent, = RotD100), and PGV (m/s), the larger horizontal component's.
    pub pga_mps2: f64,
    pub pgv_mps: f64,
    /// UTC time of the triggering sample (ns).
    pub data_time_ns: i64,
    /// Wall time at which the triggering packet arrived (ns; the caller's clock).
    pub arrival_ns: i64,
    /// The direction that raised the alert: the azimuth of its +x axis (degrees clockwise
    /// from north); a planar block's own azimuth. Journals written before this field read
    /// as 0.
    #[serde(default)]
    pub direction_deg: f64,
    /// The rock's catalogue name and WGS84 position (degrees; null when not given). Journals
    /// written before these fields read as "" and null.
    #[serde(default)]
    pub pbr_name: String,
    #[serde(default)]
    pub lat_deg: Option<f64>,
    #[serde(default)]
    pub lon_deg: Option<f64>,
}

impl Alert {
    /// The identity under which an alert is stored and de-duplicated.
    #[must_use]
    pub fn key(&self) -> AlertKey {
        (self.pbr_id.clone(), self.episode, self.level)
    }
}

/// A block's state, published on every mode change and at the state rate.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PbrState {
    pub pbr_id: PbrId,
    pub station: StationId,
    pub mode: Mode,
    pub theta_rad: f64,
    /// θ/α, signed (dimensionless): the rocking angle θ (> 0 clockwise about the +x pivot,
    /// spec §1) over the block's slenderness α; |θ/α| = 1 is the static overturning angle.
    pub theta_over_alpha: f64,
    pub slide_m: f64,
    pub overturned: bool,
    pub overturn_probability: f64,
    /// The block's prediction is uncertain: data were missing (a gap too long to bridge).
    pub data_gap: bool,
    /// UTC time of the latest sample integrated (ns; 0 if its station never sent data).
    pub data_time_ns: i64,
    /// Its station is stale (no data for `engine.stale_after_s`): the block is not monitored,
    /// whatever its last state says (`engine::health`).
    pub not_monitored: bool,
    /// The direction the state describes (degrees clockwise from north): the one that
    /// overturned, else the one with the largest |θ/α|; a planar block's own azimuth.
    pub direction_deg: f64,
}

/// A station's running intensity measures over the current event window.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StationIntensity {
    pub station: StationId,
    pub data_time_ns: i64,
    /// PGA (m/s²): the peak of the horizontal vector |(a_E, a_N)| (orientation-independent;
    /// = RotD100); PGV, PGD, CAV, Arias: the larger of the two horizontal components (m/s, m,
    /// m/s, m/s).
    pub pga_mps2: f64,
    pub pgv_mps: f64,
    pub pgd_m: f64,
    pub cav_mps: f64,
    pub arias_mps: f64,
    pub asi_mps: f64,
    pub d5_95_s: f64,
    pub sa_periods_s: Vec<f64>,
    pub sa_mps2: Vec<f64>,
    pub rejected_samples: u64,
    pub gap_samples: u64,
    pub late_samples: u64,
}

/// A noteworthy irregularity, for the shell to log (rate-limited) and count.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Notice {
    /// Station id as received: the text, not a [`StationId`], because a packet refused at
    /// its transport's edge for a malformed id ([`MalformedStation`](super::MalformedStation))
    /// has no `StationId` and its notice must still say what came (bound and escape it
    /// before showing it).
    pub station: String,
    pub kind: NoticeKind,
    pub message: String,
}

/// What a [`Notice`] is about (its name in logs and JSON: [`NoticeKind::as_str`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NoticeKind {
    /// A packet failed validation (NaN/Inf, bad lengths, absurd rate, malformed id).
    Rejected,
    /// A packet from a station neither configured nor in the catalogue.
    UnknownStation,
    /// A sample beyond the physical bound `engine.plausibility.max_abs_accel_g`.
    Implausible,
    /// Data already processed dropped (duplicate, late or overlapping).
    Dropped,
    /// The grid was rewound to before a forward jump the stream did not confirm.
    GridRewound,
    /// The sample rate changed.
    RateChange,
    /// Missing samples bridged by interpolation.
    GapBridged,
    /// Missing samples too many to bridge: the blocks are flagged `data_gap`.
    Gap,
    /// A block lost contact with the ground and was put down again.
    Flight,
}

impl NoticeKind {
    /// The kind's name (snake case, as in the JSON).
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            NoticeKind::Rejected => "rejected",
            NoticeKind::UnknownStation => "unknown_station",
            NoticeKind::Implausible => "implausible",
            NoticeKind::Dropped => "dropped",
            NoticeKind::GridRewound => "grid_rewound",
            NoticeKind::RateChange => "rate_change",
            NoticeKind::GapBridged => "gap_bridged",
            NoticeKind::Gap => "gap",
            NoticeKind::Flight => "flight",
        }
    }
}

/// One engine output.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    Alert(Alert),
    State(PbrState),
    Intensity(StationIntensity),
    Notice(Notice),
    /// A block's episode ended (back at rest on a quiet station): journal it.
    EpisodeEnd {
        pbr_id: PbrId,
        episode: u32,
        /// Data time of the sample at which it ended (ns since the Unix epoch, UTC).
        data_time_ns: i64,
    },
    /// A station went stale or recovered; the states of its blocks follow (`engine::health`).
    Health(super::health::HealthChange),
    /// Every station's health, asked for by `Engine::report_health` (a sharded engine's
    /// workers answer through their outputs).
    HealthReport(Vec<super::health::StationHealth>),
}

/// A durable record of the state directory's journal (see `crate::journal`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum JournalRecord {
    /// An alert, written before it is published.
    Alert(Alert),
    /// The end of a block's episode.
    EpisodeEnd {
        pbr_id: PbrId,
        episode: u32,
        /// Data time of the sample at which it ended (ns since the Unix epoch, UTC); absent
        /// from records written before it was kept.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        data_time_ns: Option<i64>,
    },
    /// An operator reset a (fallen) block: it stands again, its episode is closed.
    Reset {
        pbr_id: PbrId,
        /// Wall-clock UTC time of the reset, as the process that journaled it read its clock
        /// (ns since the Unix epoch); absent from records written before it was kept.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        time_ns: Option<i64>,
    },
    /// The alert (`pbr_id`, `episode`, `level`) journaled earlier has been handed to the
    /// publishers. Written after them and not synced: if a crash loses it, the alert is
    /// published again at restart (at least once, never silently lost).
    Published {
        pbr_id: PbrId,
        episode: u32,
        level: AlertLevel,
    },
}

/// The last `depth` alerts of the journal `records`, in order, each with whether a
/// [`JournalRecord::Published`] marker follows it: the alerts of [`journaled_history`].
#[must_use]
pub fn journaled_alerts(records: &[JournalRecord], depth: usize) -> Vec<(Alert, bool)> {
    journaled_history(records, depth)
        .into_iter()
        .filter_map(|entry| match entry {
            HistoryEntry::Alert(alert, published) => Some((alert, published)),
            HistoryEntry::Reset(_) => None,
        })
        .collect()
}

/// An operator reset of a fallen block as published with the alerts: a block's history on
/// `/pbr/alerts` ends in the truth (a late subscriber does not believe a reset block down).
#[derive(Debug, Clone, PartialEq)]
pub struct ResetEvent {
    pub pbr_id: PbrId,
    /// The block's station, and the episode in which it fell (of its last alert).
    pub station: StationId,
    pub episode: u32,
    /// Wall-clock UTC time of the reset (ns since the Unix epoch; 0 if the journal did not
    /// keep it).
    pub time_ns: i64,
}

/// One entry of the alert history a node publishes again at start.
#[derive(Debug, Clone, PartialEq)]
pub enum HistoryEntry {
    /// A journaled alert, and whether it was published before (a `Published` marker).
    Alert(Alert, bool),
    /// An operator reset of a block that has an alert before it.
    Reset(ResetEvent),
}

/// The journal's last `depth` alerts, in journal order, each with whether it was published,
/// and the operator resets among them (after the first of them), in place.
#[must_use]
pub fn journaled_history(records: &[JournalRecord], depth: usize) -> Vec<HistoryEntry> {
    let published: HashSet<AlertKey> = records
        .iter()
        .filter_map(|r| match r {
            JournalRecord::Published {
                pbr_id,
                episode,
                level,
            } => Some((pbr_id.clone(), *episode, *level)),
            _ => None,
        })
        .collect();
    let alerts = records
        .iter()
        .filter(|r| matches!(r, JournalRecord::Alert(_)))
        .count();
    let skip = alerts.saturating_sub(depth);
    let mut seen = 0usize;
    // Per block, its last alert so far (station and episode of a reset).
    let mut last: HashMap<&str, &Alert> = HashMap::new();
    let mut history = Vec::new();
    for record in records {
        match record {
            JournalRecord::Alert(a) => {
                last.insert(a.pbr_id.as_str(), a);
                seen += 1;
                if seen > skip {
                    history.push(HistoryEntry::Alert(a.clone(), published.contains(&a.key())));
                }
            }
            JournalRecord::Reset { pbr_id, time_ns } if seen > skip => {
                if let Some(a) = last.get(pbr_id.as_str()) {
                    history.push(HistoryEntry::Reset(ResetEvent {
                        pbr_id: pbr_id.clone(),
                        station: a.station.clone(),
                        episode: a.episode,
                        time_ns: time_ns.unwrap_or(0),
                    }));
                }
            }
            _ => {}
        }
    }
    history
}

/// Ids of the blocks that are fallen according to the journal `records` (read in order): an
/// `overturned` alert and no operator reset since. A restart restores them fallen.
#[must_use]
pub fn fallen_blocks(records: &[JournalRecord]) -> HashSet<PbrId> {
    let mut fallen = HashSet::new();
    for record in records {
        match record {
            JournalRecord::Alert(a) if a.level == AlertLevel::Overturned => {
                fallen.insert(a.pbr_id.clone());
            }
            JournalRecord::Reset { pbr_id, .. } => {
                fallen.remove(pbr_id);
            }
            _ => {}
        }
    }
    fallen
}

/// The records of the journal `records` that a restart needs, in their order: what
/// [`Engine::restore`](super::Engine::restore), [`fallen_blocks`] and
/// [`journaled_alerts`]`(…, history)` derive from `records` they derive equally from the result.
/// Kept: per block, the alerts of its last episode (its open episode, the alert that felled
/// it, and the episode number the next episode continues from), that episode's end and the
/// resets after its first alert; the last `history` alerts (the republished history); and the
/// [`JournalRecord::Published`] markers of every alert kept. Dropped: older episodes' alerts,
/// ends and resets, and markers of dropped alerts. The result is bounded by the blocks and
/// `history`, not by the journal's age. Pure; the shell writes it atomically
/// (`rockwatch::journal`).
#[must_use]
pub fn compact_journal(records: &[JournalRecord], history: usize) -> Vec<JournalRecord> {
    // Per block: its last episode.
    let mut last: HashMap<&str, u32> = HashMap::new();
    let mut alert_count = 0usize;
    for r in records {
        if let JournalRecord::Alert(a) = r {
            alert_count += 1;
            let e = last.entry(a.pbr_id.as_str()).or_insert(a.episode);
            *e = (*e).max(a.episode);
        }
    }
    // The alerts kept, and per block the index of its first kept alert.
    let history_from = alert_count.saturating_sub(history);
    let mut kept_alerts: HashSet<AlertKey> = HashSet::new();
    let mut first_kept: HashMap<&str, usize> = HashMap::new();
    let mut keep = vec![false; records.len()];
    let mut alert_index = 0usize;
    for (i, r) in records.iter().enumerate() {
        if let JournalRecord::Alert(a) = r {
            let in_history = alert_index >= history_from;
            alert_index += 1;
            if in_history || last.get(a.pbr_id.as_str()) == Some(&a.episode) {
                keep[i] = true;
                kept_alerts.insert(a.key());
                first_kept.entry(a.pbr_id.as_str()).or_insert(i);
            }
        }
    }
    for (i, r) in records.iter().enumerate() {
        keep[i] = keep[i]
            || match r {
                JournalRecord::Alert(_) => false,
                // Only an end of the last episode closes it (restore takes the largest).
                JournalRecord::EpisodeEnd {
                    pbr_id, episode, ..
                } => last.get(pbr_id.as_str()).is_some_and(|l| episode >= l),
                // A reset after a kept alert may stand a kept overturned block again; one
                // before every kept alert of its block changes nothing derived from them.
                JournalRecord::Reset { pbr_id, .. } => {
                    first_kept.get(pbr_id.as_str()).is_some_and(|f| i > *f)
                }
                JournalRecord::Published {
                    pbr_id,
                    episode,
                    level,
                } => kept_alerts.contains(&(pbr_id.clone(), *episode, *level)),
            };
    }
    records
        .iter()
        .zip(keep)
        .filter(|(_, k)| *k)
        .map(|(r, _)| r.clone())
        .collect()
}

/// Identity of an alert: block, episode, level.
pub type AlertKey = (PbrId, u32, AlertLevel);

/// Which alert levels a block has raised in its current episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RaisedLevels([bool; 3]);

impl RaisedLevels {
    #[must_use]
    pub fn contains(self, level: AlertLevel) -> bool {
        self.0[level.index()]
    }
    pub fn insert(&mut self, level: AlertLevel) {
        self.0[level.index()] = true;
    }

    /// Every level raised.
    #[must_use]
    pub fn all() -> Self {
        RaisedLevels([true; 3])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn alert(pbr_id: &str, level: AlertLevel) -> JournalRecord {
        JournalRecord::Alert(Alert {
            pbr_id: PbrId::parse(pbr_id).unwrap(),
            station: StationId::parse("CI.RRS.00").unwrap(),
            level,
            episode: 1,
            mode: Mode::Rock,
            theta_over_alpha: 0.0,
            slide_m: 0.0,
            overturn_probability: 0.0,
            pga_mps2: 0.0,
            pgv_mps: 0.0,
            data_time_ns: 0,
            arrival_ns: 0,
            direction_deg: 0.0,
            lat_deg: Default::default(),
            lon_deg: Default::default(),
            pbr_name: Default::default(),
        })
    }

    #[test]
    fn a_block_is_fallen_from_its_overturned_alert_until_a_reset() {
        let reset = |id: &str| JournalRecord::Reset {
            pbr_id: PbrId::parse(id).unwrap(),
            time_ns: None,
        };
        let records = [
            alert("a", AlertLevel::MotionOnset),
            alert("a", AlertLevel::Overturned),
            alert("b", AlertLevel::Overturned),
            alert("c", AlertLevel::OverturnImminent),
            reset("b"),
            alert("b", AlertLevel::MotionOnset),
        ];
        assert_eq!(
            fallen_blocks(&records),
            HashSet::from([PbrId::parse("a").unwrap()])
        );
        assert_eq!(
            fallen_blocks(&[alert("a", AlertLevel::Overturned), reset("a")]),
            HashSet::new()
        );
    }

    #[test]
    fn journaled_alerts_are_the_last_ones_with_their_published_markers() {
        let published = |id: &str, level| JournalRecord::Published {
            pbr_id: PbrId::parse(id).unwrap(),
            episode: 1,
            level,
        };
        let records = [
            alert("a", AlertLevel::MotionOnset),
            published("a", AlertLevel::MotionOnset),
            alert("b", AlertLevel::MotionOnset),
            alert("a", AlertLevel::Overturned),
            published("a", AlertLevel::Overturned),
        ];
        let got: Vec<(String, AlertLevel, bool)> = journaled_alerts(&records, 10)
            .into_iter()
            .map(|(a, p)| (a.pbr_id.to_string(), a.level, p))
            .collect();
        assert_eq!(
            got,
            vec![
                ("a".into(), AlertLevel::MotionOnset, true),
                ("b".into(), AlertLevel::MotionOnset, false),
                ("a".into(), AlertLevel::Overturned, true),
            ]
        );
        // Bounded to the last `depth` alerts.
        let last = journaled_alerts(&records, 1);
        assert_eq!(last.len(), 1);
        assert_eq!(last[0].0.level, AlertLevel::Overturned);
    }
}
