//! Event reports: when a rock's episode ends, and when it overturns, the node (and `rockwatch
//! monitor --state-dir`) writes `reports/<UTC data time>_<pbr>.json` and `.png` under its
//! state directory — the station's three components around the event (the last
//! [`RETENTION_S`](crate::traces::RETENTION_S) s as a min/max envelope of
//! [`BIN_NS`](crate::traces::BIN_NS) = 0.2 s bins: every peak kept), its last intensity
//! measures, the rock's θ/α and slide traces of the episode with its alert marks and the
//! thresholds, and the rock's parameters. `rockwatch report` draws the PNG again from the JSON.
//!
//! The event loop only copies (at an episode's end or fall, never per sample) its
//! [`Traces`] into an [`EventReport`] and hands it to ONE writer thread over a bounded queue
//! of [`QUEUE`] reports: a full queue drops the report (counted in [`ReportCounts::dropped`],
//! logged), the loop never waits. The writer keeps the newest [`KEEP_PER_ROCK`] reports of each
//! rock (older ones are deleted, JSON and PNG).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;

use plotters::coord::Shift;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};

use crate::plot::{by_extension, fit_title, DrawResult, PlotError};
use crate::ports::Publication;
use crate::traces::{Traces, BIN_NS, COMPONENTS};
use rockwatch_core::dynamics::Mode;
use rockwatch_core::engine::{AlertConfig, AlertLevel, PbrSpec};

/// The reports' directory under a state directory.
pub const DIR: &str = "reports";

/// Reports waiting for the writer thread at most (more are dropped, counted).
pub const QUEUE: usize = 16;

/// Newest reports kept per rock (older ones are deleted when a new one is written).
pub const KEEP_PER_ROCK: usize = 20;

/// Size of a report's PNG (pixels).
const SIZE: (u32, u32) = (1100, 1000);

/// A report could not be written, found or read.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{path}: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{path}: not an event report: {error}")]
    Json {
        path: PathBuf,
        error: serde_json::Error,
    },
    #[error("{dir}: no report of rock {pbr}{}", episode.map(|e| format!(" episode {e}")).unwrap_or_default())]
    NotFound {
        dir: PathBuf,
        pbr: String,
        episode: Option<u32>,
    },
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// Why a report was written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReportReason {
    /// The rock's `overturned` alert.
    Overturned,
    /// The engine ended the episode (the rock at rest and its station quiet).
    EpisodeEnd,
}

/// The rock's parameters as the catalogue gives them (its nominal block, first direction).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RockParams {
    pub name: String,
    pub station: String,
    /// Direction of the block's +x axis (degrees clockwise from north).
    pub azimuth_deg: f64,
    /// Half-widths to the + and − pivots (m).
    pub b_plus_m: f64,
    pub b_minus_m: f64,
    /// Height of the centre of mass over the base (m).
    pub com_height_m: f64,
    /// Static overturning angle α (rad).
    pub alpha_rad: f64,
    pub mu_s: f64,
    pub mu_k: f64,
}

/// The alert thresholds in force (the engine's `[engine.alerts]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Thresholds {
    /// `overturn_imminent` at |θ|/α ≥ this.
    pub imminent_theta_ratio: f64,
    /// `overturn_imminent` at P(overturn) ≥ this.
    pub imminent_probability: f64,
}

/// One component's envelope: per bin, the minimum and maximum (m/s², null: no sample).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComponentEnvelope {
    /// "E", "N" or "Z" ([`COMPONENTS`]).
    pub component: String,
    pub min_mps2: Vec<Option<f32>>,
    pub max_mps2: Vec<Option<f32>>,
}

/// The station's recent data: bins of `bin_s` from `start_ns` (ns since the Unix epoch).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StationEnvelope {
    pub start_ns: i64,
    pub bin_s: f64,
    pub components: Vec<ComponentEnvelope>,
}

/// One point of the rock's episode.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReportPoint {
    pub data_time_ns: i64,
    /// Signed θ/α (dimensionless).
    pub theta_over_alpha: f64,
    pub slide_m: f64,
    pub mode: Mode,
}

/// One alert of the episode.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReportAlert {
    pub data_time_ns: i64,
    pub level: AlertLevel,
    pub theta_over_alpha: f64,
    pub overturn_probability: f64,
}

/// An event report: what the JSON file holds (the PNG is drawn from it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EventReport {
    pub pbr_id: String,
    /// The alerts' episode number (None: no alert of it was seen).
    pub episode: Option<u32>,
    pub reason: ReportReason,
    /// Data time of the event (the fall, or the episode's end), ns since the Unix epoch.
    pub data_time_ns: i64,
    /// The same, ISO 8601 UTC.
    pub data_time: String,
    pub rock: RockParams,
    pub thresholds: Thresholds,
    /// None: the station sent no data the node kept.
    pub station: Option<StationEnvelope>,
    /// The station's last intensity measures (the /pbr/ims message's fields), if any.
    pub intensity: Option<serde_json::Value>,
    pub points: Vec<ReportPoint>,
    pub alerts: Vec<ReportAlert>,
}

impl EventReport {
    /// Its file name without extension ([`report_stem`]).
    #[must_use]
    pub fn file_stem(&self) -> String {
        report_stem(self.data_time_ns, &self.pbr_id)
    }
}

/// The file name (without extension) of `pbr_id`'s report of an event at `data_time_ns`:
/// `<UTC data time>_<pbr>`, the time as `YYYYMMDDThhmmss.fffZ` (sorts as time, no `_`).
#[must_use]
pub fn report_stem(data_time_ns: i64, pbr_id: &str) -> String {
    let iso = rockwatch_core::utc::format_utc_ns(i128::from(data_time_ns));
    // YYYY-MM-DDThh:mm:ss.fffffffffZ → YYYYMMDDThhmmss.fffZ
    let compact: String = iso
        .chars()
        .filter(|c| *c != '-' && *c != ':')
        .take(19)
        .collect();
    format!("{compact}Z_{pbr_id}")
}

/// Counts of the report writer (shared with the writer thread).
#[derive(Debug, Default)]
pub struct ReportCounts {
    pub written: AtomicU64,
    /// Dropped: the queue was full.
    pub dropped: AtomicU64,
    /// Could not be written (the error logged).
    pub failed: AtomicU64,
}

/// The event loop's side: the traces a report needs (the web dashboard's too), and the
/// writer's queue (none: [`ReportFeed::traces_only`]).
pub struct ReportFeed {
    /// Fed each packet and publication by the runtime.
    pub traces: Traces,
    rocks: HashMap<String, RockParams>,
    thresholds: Thresholds,
    sender: Option<SyncSender<Box<EventReport>>>,
    worker: Option<JoinHandle<()>>,
    counts: Arc<ReportCounts>,
}

impl std::fmt::Debug for ReportFeed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReportFeed")
            .field("counts", &self.counts)
            .finish_non_exhaustive()
    }
}

impl ReportFeed {
    /// Starts the writer thread writing into `state_dir/reports` (made if missing).
    pub fn start(
        state_dir: &Path,
        specs: &[PbrSpec],
        stations: &[(String, Option<f64>)],
        alerts: &AlertConfig,
    ) -> Result<ReportFeed, ReportError> {
        let dir = state_dir.join(DIR);
        std::fs::create_dir_all(&dir).map_err(|error| ReportError::Io {
            path: dir.clone(),
            error,
        })?;
        let (sender, receiver) = sync_channel(QUEUE);
        let counts = Arc::new(ReportCounts::default());
        let worker = {
            let counts = Arc::clone(&counts);
            std::thread::Builder::new()
                .name("reports".into())
                .spawn(move || writer(&dir, &receiver, &counts))
                .map_err(|error| ReportError::Io {
                    path: state_dir.to_path_buf(),
                    error,
                })?
        };
        Ok(ReportFeed {
            traces: Traces::new(&traced(specs, stations)),
            rocks: rock_params(specs),
            thresholds: thresholds(alerts),
            sender: Some(sender),
            worker: Some(worker),
            counts,
        })
    }

    /// The traces without reports (no state directory: the web dashboard's only).
    #[must_use]
    pub fn traces_only(stations: &[(String, Option<f64>)]) -> ReportFeed {
        ReportFeed {
            traces: Traces::new(stations),
            rocks: HashMap::new(),
            thresholds: Thresholds {
                imminent_theta_ratio: 1.0,
                imminent_probability: 1.0,
            },
            sender: None,
            worker: None,
            counts: Arc::new(ReportCounts::default()),
        }
    }

    /// After a reload: the rocks', stations' and thresholds' new values (traces of stations
    /// kept stay as they are).
    pub fn reconfigure(
        &mut self,
        specs: &[PbrSpec],
        stations: &[(String, Option<f64>)],
        alerts: &AlertConfig,
    ) {
        self.traces.configure(&traced(specs, stations));
        if self.sender.is_some() {
            self.rocks = rock_params(specs);
            self.thresholds = thresholds(alerts);
        }
    }

    /// The writer's counts.
    #[must_use]
    pub fn counts(&self) -> Arc<ReportCounts> {
        Arc::clone(&self.counts)
    }

    /// Takes in one publication (into the traces); an `overturned` alert is reported.
    pub fn observe(&mut self, publication: &Publication) {
        self.traces.observe(publication);
        if let Publication::Alert { alert, .. } = publication {
            if alert.level == AlertLevel::Overturned {
                self.report(
                    alert.pbr_id.as_str(),
                    ReportReason::Overturned,
                    alert.data_time_ns,
                );
            }
        }
    }

    /// The engine ended `pbr_id`'s episode at `data_time_ns`: reported (a fallen rock's too:
    /// its fall's report holds the data up to the fall, this one the shaking after).
    pub fn episode_end(&mut self, pbr_id: &str, _episode: u32, data_time_ns: i64) {
        self.report(pbr_id, ReportReason::EpisodeEnd, data_time_ns);
    }

    /// Copies the traces into a report and queues it (dropped, counted, if the queue is full).
    fn report(&mut self, pbr_id: &str, reason: ReportReason, data_time_ns: i64) {
        let Some(rock) = self.rocks.get(pbr_id) else {
            return; // not one of this node's rocks
        };
        let episode = self.traces.episode(pbr_id);
        let station = self.traces.station(&rock.station).and_then(|t| {
            let view = t.view();
            let first = view.first_bin?;
            // The bins from the first with data to the last (the ring's empty start left out).
            let from = view.bins.iter().position(|b| b.samples > 0)?;
            let to = view.bins.iter().rposition(|b| b.samples > 0)?;
            let bins = &view.bins[from..=to];
            let comp = |c: usize| ComponentEnvelope {
                component: COMPONENTS[c].to_string(),
                min_mps2: bins
                    .iter()
                    .map(|b| (b.min[c] <= b.max[c]).then_some(b.min[c]))
                    .collect(),
                max_mps2: bins
                    .iter()
                    .map(|b| (b.min[c] <= b.max[c]).then_some(b.max[c]))
                    .collect(),
            };
            Some(StationEnvelope {
                start_ns: (first + from as i64) * BIN_NS,
                bin_s: BIN_NS as f64 * 1e-9,
                components: (0..3).map(comp).collect(),
            })
        });
        let report = EventReport {
            pbr_id: pbr_id.to_string(),
            episode: episode.and_then(|e| e.episode),
            reason,
            data_time_ns,
            data_time: rockwatch_core::utc::format_utc_ns(i128::from(data_time_ns)),
            rock: rock.clone(),
            thresholds: self.thresholds,
            station,
            intensity: self
                .traces
                .intensity(&rock.station)
                .and_then(|i| serde_json::to_value(&**i).ok()),
            points: episode
                .map(|e| {
                    e.points
                        .iter()
                        .map(|p| ReportPoint {
                            data_time_ns: p.data_time_ns,
                            theta_over_alpha: p.theta_over_alpha,
                            slide_m: p.slide_m,
                            mode: p.mode,
                        })
                        .collect()
                })
                .unwrap_or_default(),
            alerts: episode
                .map(|e| {
                    e.marks
                        .iter()
                        .map(|m| ReportAlert {
                            data_time_ns: m.data_time_ns,
                            level: m.level,
                            theta_over_alpha: m.theta_over_alpha,
                            overturn_probability: m.overturn_probability,
                        })
                        .collect()
                })
                .unwrap_or_default(),
        };
        let Some(sender) = &self.sender else { return };
        match sender.try_send(Box::new(report)) {
            Ok(()) => {}
            Err(TrySendError::Full(r) | TrySendError::Disconnected(r)) => {
                let dropped = self.counts.dropped.fetch_add(1, Ordering::Relaxed) + 1;
                tracing::warn!(
                    target: "rockwatch::reports",
                    pbr_id = %crate::log_text::printable(&r.pbr_id, crate::log_text::PBR_ID_CHARS),
                    dropped,
                    "event report of {} not written: the report writer is behind ({dropped} \
                     dropped in all)",
                    crate::log_text::printable(&r.pbr_id, crate::log_text::PBR_ID_CHARS)
                );
            }
        }
    }

    /// Waits for the writer to write what is queued.
    pub fn finish(mut self) -> Arc<ReportCounts> {
        self.sender = None;
        if let Some(worker) = self.worker.take() {
            let _ = worker.join();
        }
        Arc::clone(&self.counts)
    }
}

/// The stations to trace: `stations` and those of `specs`' rocks.
fn traced(specs: &[PbrSpec], stations: &[(String, Option<f64>)]) -> Vec<(String, Option<f64>)> {
    let mut all: Vec<(String, Option<f64>)> = stations.to_vec();
    for s in specs {
        if !all.iter().any(|(id, _)| id == s.station.as_str()) {
            all.push((s.station.to_string(), None));
        }
    }
    all
}

/// Each rock's parameters as a report gives them.
fn rock_params(specs: &[PbrSpec]) -> HashMap<String, RockParams> {
    specs
        .iter()
        .map(|s| {
            (
                s.id.to_string(),
                RockParams {
                    name: s.place.name.clone(),
                    station: s.station.to_string(),
                    azimuth_deg: s.azimuth.degrees(),
                    b_plus_m: s.nominal.b_plus_m,
                    b_minus_m: s.nominal.b_minus_m,
                    com_height_m: s.nominal.com_height_m,
                    alpha_rad: s.nominal.alpha_rad,
                    mu_s: s.nominal.mu_s,
                    mu_k: s.nominal.mu_k,
                },
            )
        })
        .collect()
}

fn thresholds(alerts: &AlertConfig) -> Thresholds {
    Thresholds {
        imminent_theta_ratio: alerts.imminent_theta_ratio,
        imminent_probability: alerts.imminent_probability,
    }
}

/// The writer thread: writes each report, then prunes its rock's old ones.
fn writer(dir: &Path, receiver: &Receiver<Box<EventReport>>, counts: &ReportCounts) {
    while let Ok(report) = receiver.recv() {
        match write_report(dir, &report) {
            Ok(path) => {
                counts.written.fetch_add(1, Ordering::Relaxed);
                tracing::info!(
                    target: "rockwatch::reports",
                    "event report written: {}",
                    path.display()
                );
            }
            Err(e) => {
                let failed = counts.failed.fetch_add(1, Ordering::Relaxed) + 1;
                tracing::warn!(target: "rockwatch::reports", failed, "event report not written: {e}");
            }
        }
        if let Err(e) = prune(dir, &report.pbr_id, KEEP_PER_ROCK) {
            tracing::warn!(target: "rockwatch::reports", "cannot prune old reports: {e}");
        }
    }
}

/// Writes `<stem>.json` (atomically: a temporary file renamed) and `<stem>.png` into `dir`;
/// returns the JSON's path.
pub fn write_report(dir: &Path, report: &EventReport) -> Result<PathBuf, ReportError> {
    let stem = report.file_stem();
    let json = dir.join(format!("{stem}.json"));
    let tmp = dir.join(format!(".{stem}.json.tmp"));
    let mut bytes = serde_json::to_vec_pretty(report).map_err(|error| ReportError::Json {
        path: json.clone(),
        error,
    })?;
    bytes.push(b'\n');
    std::fs::write(&tmp, bytes)
        .and_then(|()| std::fs::rename(&tmp, &json))
        .map_err(|error| ReportError::Io {
            path: json.clone(),
            error,
        })?;
    plot_report(report, &json.with_extension("png"))?;
    Ok(json)
}

/// Reads a report's JSON.
pub fn read_report(path: &Path) -> Result<EventReport, ReportError> {
    let bytes = std::fs::read(path).map_err(|error| ReportError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    serde_json::from_slice(&bytes).map_err(|error| ReportError::Json {
        path: path.to_path_buf(),
        error,
    })
}

/// The reports (JSON) of `pbr_id` in `dir`, oldest first (by their names: the data time).
pub fn list_reports(dir: &Path, pbr_id: &str) -> Result<Vec<PathBuf>, ReportError> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(error) => {
            return Err(ReportError::Io {
                path: dir.to_path_buf(),
                error,
            })
        }
    };
    let mut found: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .and_then(|n| n.strip_suffix(".json"))
                .and_then(|n| n.split_once('_'))
                .is_some_and(|(time, pbr)| !time.starts_with('.') && pbr == pbr_id)
        })
        .collect();
    found.sort();
    Ok(found)
}

/// The report of `pbr_id` under `state_dir/reports`: the last one of episode `episode`, or
/// the last one of all.
pub fn find_report(
    state_dir: &Path,
    pbr_id: &str,
    episode: Option<u32>,
) -> Result<PathBuf, ReportError> {
    let dir = state_dir.join(DIR);
    let all = list_reports(&dir, pbr_id)?;
    let found = match episode {
        None => all.last().cloned(),
        Some(n) => {
            let mut hit = None;
            for path in all.iter().rev() {
                if read_report(path)?.episode == Some(n) {
                    hit = Some(path.clone());
                    break;
                }
            }
            hit
        }
    };
    found.ok_or(ReportError::NotFound {
        dir,
        pbr: pbr_id.to_string(),
        episode,
    })
}

/// Deletes all but the newest `keep` reports of `pbr_id` (JSON and PNG).
fn prune(dir: &Path, pbr_id: &str, keep: usize) -> Result<(), ReportError> {
    let all = list_reports(dir, pbr_id)?;
    for old in &all[..all.len().saturating_sub(keep)] {
        for path in [old.clone(), old.with_extension("png")] {
            match std::fs::remove_file(&path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(error) => return Err(ReportError::Io { path, error }),
            }
        }
    }
    Ok(())
}

/// Draws `report` into `path` (PNG or SVG by extension): the station's E, N, Z envelopes;
/// θ/α with ±1 and ±the imminent ratio; slide; the alerts as vertical lines. Time in seconds
/// from the event (`data_time_ns`).
pub fn plot_report(report: &EventReport, path: &Path) -> Result<(), PlotError> {
    by_extension(
        path,
        SIZE,
        |root| draw(report, root),
        |root| draw(report, root),
    )
}

fn span(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    if lo > hi {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-6);
    (lo - pad, hi + pad)
}

fn draw<DB: DrawingBackend>(report: &EventReport, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let r = &report.rock;
    let title = format!(
        "{} ({}) — {} at {} — station {}, episode {}; b = {:.3}/{:.3} m, h = {:.3} m, α = {:.3} rad, azimuth {:.0}°, μs = {}, μk = {}",
        report.pbr_id,
        r.name,
        match report.reason {
            ReportReason::Overturned => "overturned",
            ReportReason::EpisodeEnd => "episode end",
        },
        report.data_time,
        r.station,
        report.episode.map_or("-".to_string(), |e| e.to_string()),
        r.b_plus_m,
        r.b_minus_m,
        r.com_height_m,
        r.alpha_rad,
        r.azimuth_deg,
        r.mu_s,
        r.mu_k
    );
    let title = fit_title(root, &title)?;
    let (head, body) = root.split_vertically(title.height_px() + 4);
    title.draw(&head)?;
    let t = |ns: i64| (ns - report.data_time_ns) as f64 * 1e-9;
    // The time axis: the station's window and the episode's points.
    let (mut t0, mut t1) = span(report.points.iter().map(|p| t(p.data_time_ns)).chain([0.0]));
    if let Some(s) = &report.station {
        let n = s.components.first().map_or(0, |c| c.min_mps2.len());
        t0 = t0.min(t(s.start_ns));
        t1 = t1.max(t(s.start_ns) + n as f64 * s.bin_s);
    }
    let panels = body.split_evenly((5, 1));
    let colours = [
        RGBColor(0, 0, 0),
        RGBColor(0, 114, 178),
        RGBColor(153, 153, 153),
    ];
    let alert_lines = |lo: f64, hi: f64| {
        report.alerts.iter().map(move |a| {
            let colour = match a.level {
                AlertLevel::MotionOnset => RGBColor(0, 158, 115),
                AlertLevel::OverturnImminent => RGBColor(230, 159, 0),
                AlertLevel::Overturned => RGBColor(213, 94, 0),
            };
            PathElement::new(
                [(t(a.data_time_ns), lo), (t(a.data_time_ns), hi)],
                colour.stroke_width(2),
            )
        })
    };
    for c in 0..3 {
        let comp = report
            .station
            .as_ref()
            .and_then(|s| s.components.get(c).map(|e| (s, e)));
        let (lo, hi) = span(comp.iter().flat_map(|(_, e)| {
            e.min_mps2
                .iter()
                .chain(&e.max_mps2)
                .filter_map(|v| v.map(f64::from))
        }));
        let mut chart = ChartBuilder::on(&panels[c])
            .margin(6)
            .x_label_area_size(24)
            .y_label_area_size(60)
            .build_cartesian_2d(t0..t1, lo..hi)?;
        chart
            .configure_mesh()
            .y_desc(format!("{} (m/s²)", COMPONENTS[c]))
            .light_line_style(WHITE)
            .draw()?;
        if let Some((s, e)) = comp {
            chart.draw_series(e.min_mps2.iter().zip(&e.max_mps2).enumerate().filter_map(
                |(k, (lo, hi))| {
                    let (lo, hi) = ((*lo)?, (*hi)?);
                    let x = t(s.start_ns) + (k as f64 + 0.5) * s.bin_s;
                    Some(PathElement::new(
                        [(x, f64::from(lo)), (x, f64::from(hi))],
                        colours[c].stroke_width(1),
                    ))
                },
            ))?;
        }
        chart.draw_series(alert_lines(lo, hi))?;
    }
    let thresholds = [
        (1.0, RGBColor(213, 94, 0)),
        (
            report.thresholds.imminent_theta_ratio,
            RGBColor(230, 159, 0),
        ),
    ];
    let (lo, hi) = span(
        report
            .points
            .iter()
            .map(|p| p.theta_over_alpha)
            .chain([-1.1, 1.1]),
    );
    let mut chart = ChartBuilder::on(&panels[3])
        .margin(6)
        .x_label_area_size(24)
        .y_label_area_size(60)
        .build_cartesian_2d(t0..t1, lo..hi)?;
    chart
        .configure_mesh()
        .y_desc("θ/α")
        .light_line_style(WHITE)
        .draw()?;
    for (level, colour) in thresholds {
        for sign in [-1.0, 1.0] {
            chart.draw_series(LineSeries::new(
                [(t0, sign * level), (t1, sign * level)],
                colour.stroke_width(1),
            ))?;
        }
    }
    chart.draw_series(LineSeries::new(
        report
            .points
            .iter()
            .map(|p| (t(p.data_time_ns), p.theta_over_alpha)),
        RGBColor(0, 114, 178).stroke_width(2),
    ))?;
    chart.draw_series(alert_lines(lo, hi))?;
    let (lo, hi) = span(report.points.iter().map(|p| p.slide_m).chain([0.0]));
    let mut chart = ChartBuilder::on(&panels[4])
        .margin(6)
        .x_label_area_size(30)
        .y_label_area_size(60)
        .build_cartesian_2d(t0..t1, lo..hi)?;
    chart
        .configure_mesh()
        .x_desc("time from the event (s)")
        .y_desc("slide (m)")
        .light_line_style(WHITE)
        .draw()?;
    chart.draw_series(LineSeries::new(
        report.points.iter().map(|p| (t(p.data_time_ns), p.slide_m)),
        RGBColor(0, 158, 115).stroke_width(2),
    ))?;
    chart.draw_series(alert_lines(lo, hi))?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(pbr: &str, t_s: i64, episode: u32) -> EventReport {
        EventReport {
            pbr_id: pbr.into(),
            episode: Some(episode),
            reason: ReportReason::EpisodeEnd,
            data_time_ns: t_s * 1_000_000_000,
            data_time: String::new(),
            rock: RockParams {
                name: "n".into(),
                station: "XX.STA.00".into(),
                azimuth_deg: 90.0,
                b_plus_m: 0.1,
                b_minus_m: 0.1,
                com_height_m: 0.5,
                alpha_rad: 0.2,
                mu_s: 0.7,
                mu_k: 0.5,
            },
            thresholds: Thresholds {
                imminent_theta_ratio: 0.8,
                imminent_probability: 0.5,
            },
            station: None,
            intensity: None,
            points: Vec::new(),
            alerts: Vec::new(),
        }
    }

    #[test]
    fn names_sort_by_time_and_each_rock_keeps_its_newest() {
        assert_eq!(
            report("a_b", 1_700_000_000, 1).file_stem(),
            "20231114T221320.000Z_a_b"
        );
        let dir = tempfile::tempdir().unwrap();
        let reports = dir.path().join(DIR);
        std::fs::create_dir_all(&reports).unwrap();
        // Rock "b" and rock "a_b" (an id with "_"): each its own reports.
        for i in 0..KEEP_PER_ROCK as i64 + 3 {
            let r = report("b", 1_000 + i, 1 + i as u32 / 10);
            std::fs::write(
                reports.join(format!("{}.json", r.file_stem())),
                serde_json::to_vec(&r).unwrap(),
            )
            .unwrap();
            prune(&reports, "b", KEEP_PER_ROCK).unwrap();
        }
        let other = report("a_b", 500, 7);
        std::fs::write(
            reports.join(format!("{}.json", other.file_stem())),
            serde_json::to_vec(&other).unwrap(),
        )
        .unwrap();
        prune(&reports, "b", KEEP_PER_ROCK).unwrap();
        let kept = list_reports(&reports, "b").unwrap();
        assert_eq!(kept.len(), KEEP_PER_ROCK);
        assert_eq!(
            read_report(&kept[0]).unwrap().data_time_ns,
            1_003_000_000_000
        );
        assert_eq!(list_reports(&reports, "a_b").unwrap().len(), 1);
        // The last report, of all or of an episode.
        let last = find_report(dir.path(), "b", None).unwrap();
        assert_eq!(read_report(&last).unwrap().data_time_ns, 1_022_000_000_000);
        let of_2 = find_report(dir.path(), "b", Some(2)).unwrap();
        assert_eq!(read_report(&of_2).unwrap().data_time_ns, 1_019_000_000_000);
        assert!(matches!(
            find_report(dir.path(), "b", Some(9)),
            Err(ReportError::NotFound { .. })
        ));
    }
}
