//! A receiver's spool: the alerts handed to it and which of them it acknowledged, in an
//! append-only file of the state directory (`<state_dir>/notify/<receiver>.spool`), so that
//! what was not acknowledged is delivered after a restart.
//!
//! Format: the journal's (`crate::journal`): one checksummed JSON line per record,
//! `{"op": "alert", "alert": {…}}` (an alert to deliver, the shared schema of
//! `crate::alert_json`; synced to disk before it is handed to the receiver's thread) or
//! `{"op": "ack", "pbr_id", "episode", "level"}` (delivered; not synced: a lost ack only means
//! one more delivery). A corrupt or torn line is skipped. On open, and whenever the file holds
//! many superfluous lines, it is compacted: rewritten (to a temporary file, synced,
//! renamed) with one ack per acknowledged alert, then the pending alerts in order. The acks
//! are kept so that alerts of the node's journal can be matched against the spool
//! ([`Spool::contains`]).

use std::collections::{HashSet, VecDeque};
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};

use rockwatch_core::engine::{AlertKey, AlertLevel, PbrId};

use crate::alert_json::AlertJson;
use crate::journal::{decode, encode};

/// Superfluous lines (delivered alerts) that trigger a compaction, at least.
const COMPACT_MIN_WASTE: usize = 1024;

/// One line of the spool.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "op", rename_all = "snake_case")]
enum SpoolRecord {
    Alert {
        alert: AlertJson,
    },
    Ack {
        pbr_id: PbrId,
        episode: u32,
        level: AlertLevel,
    },
}

/// What opening a spool found.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SpoolReport {
    /// The file did not exist: a new receiver.
    pub created: bool,
    /// Lines skipped (bad checksum or JSON, or a torn last line), 1-based.
    pub corrupt_lines: Vec<usize>,
    /// The spool could not be compacted because its file system is full: it is appended to
    /// as it was, or kept in memory only if the file could not be opened at all (the reason).
    pub degraded: Option<String>,
}

/// A receiver's pending and acknowledged alerts, kept in a file (or in memory only, without a
/// state directory).
#[derive(Debug)]
pub struct Spool {
    /// The file and its path; None: memory only.
    file: Option<(PathBuf, File)>,
    /// Handed over, not acknowledged, in order.
    pending: VecDeque<AlertJson>,
    acked: HashSet<AlertKey>,
    /// Lines in the file.
    lines: usize,
}

fn with_path(path: &Path) -> impl Fn(std::io::Error) -> std::io::Error + '_ {
    move |e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display()))
}

impl Spool {
    /// A spool without a file: nothing survives a restart.
    #[must_use]
    pub fn in_memory() -> Spool {
        Spool {
            file: None,
            pending: VecDeque::new(),
            acked: HashSet::new(),
            lines: 0,
        }
    }

    /// Opens (creating) the spool at `path` and compacts it.
    pub fn open(path: &Path) -> std::io::Result<(Spool, SpoolReport)> {
        let err = with_path(path);
        let mut report = SpoolReport::default();
        let mut spool = Spool::in_memory();
        match File::open(path) {
            Ok(file) => {
                let mut reader = BufReader::new(file);
                let mut line = Vec::new();
                let mut number = 0;
                loop {
                    line.clear();
                    if reader.read_until(b'\n', &mut line).map_err(&err)? == 0 {
                        break;
                    }
                    number += 1;
                    let record = line
                        .strip_suffix(b"\n")
                        .and_then(|l| std::str::from_utf8(l).ok())
                        .and_then(decode::<SpoolRecord>);
                    match record {
                        Some(r) => spool.apply(r),
                        None => report.corrupt_lines.push(number),
                    }
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => report.created = true,
            Err(e) => return Err(err(e)),
        }
        let lines_read = spool.acked.len() + spool.pending.len() + report.corrupt_lines.len();
        let rewritten = path
            .parent()
            .map_or(Ok(()), |dir| {
                std::fs::create_dir_all(dir).map_err(with_path(dir))
            })
            .and_then(|()| Spool::rewrite(path, &spool));
        match rewritten {
            Ok(file) => {
                spool.file = Some((path.to_path_buf(), file));
                spool.lines = spool.acked.len() + spool.pending.len();
            }
            // A full disk cannot take the compacted copy (a new file): the spool goes on
            // appending to the file as it was, or lives in memory until the next start.
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded
                ) =>
            {
                let _ = std::fs::remove_file(path.with_extension("spool.tmp"));
                match OpenOptions::new().append(true).open(path) {
                    Ok(file) => {
                        spool.file = Some((path.to_path_buf(), file));
                        spool.lines = lines_read;
                        report.degraded =
                            Some(format!("{e}: not compacted, appended to as it was"));
                    }
                    Err(open) => {
                        report.degraded = Some(format!(
                            "{e}; {open}: kept in memory (undelivered alerts are lost if the node stops before the disk has room)"
                        ));
                    }
                }
            }
            Err(e) => return Err(e),
        }
        Ok((spool, report))
    }

    fn apply(&mut self, record: SpoolRecord) {
        match record {
            SpoolRecord::Alert { alert } => {
                let key = alert.key();
                if !self.acked.contains(&key) && !self.pending.iter().any(|a| a.key() == key) {
                    self.pending.push_back(alert);
                }
            }
            SpoolRecord::Ack {
                pbr_id,
                episode,
                level,
            } => {
                let key = (pbr_id, episode, level);
                self.pending.retain(|a| a.key() != key);
                self.acked.insert(key);
            }
        }
    }

    /// Writes `spool`'s records to a temporary file, syncs it and renames it over `path`;
    /// returns `path` opened for appending.
    fn rewrite(path: &Path, spool: &Spool) -> std::io::Result<File> {
        let tmp = path.with_extension("spool.tmp");
        let err = with_path(&tmp);
        let mut text = String::new();
        let acks = spool
            .acked
            .iter()
            .map(|(pbr_id, episode, level)| SpoolRecord::Ack {
                pbr_id: pbr_id.clone(),
                episode: *episode,
                level: *level,
            });
        let alerts = spool
            .pending
            .iter()
            .map(|a| SpoolRecord::Alert { alert: a.clone() });
        for record in acks.chain(alerts) {
            text.push_str(&encode(&record).map_err(std::io::Error::other)?);
        }
        let mut file = File::create(&tmp).map_err(&err)?;
        file.write_all(text.as_bytes()).map_err(&err)?;
        file.sync_all().map_err(&err)?;
        std::fs::rename(&tmp, path).map_err(with_path(path))?;
        if let Some(dir) = path.parent() {
            // The rename is durable once the directory is synced.
            File::open(dir)
                .and_then(|d| d.sync_all())
                .map_err(with_path(dir))?;
        }
        OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(with_path(path))
    }

    /// Appends `record` (synced to disk if `sync`).
    fn append(&mut self, record: &SpoolRecord, sync: bool) -> std::io::Result<()> {
        let Some((path, file)) = &mut self.file else {
            return Ok(());
        };
        let err = with_path(path);
        let line = encode(record).map_err(std::io::Error::other)?;
        file.write_all(line.as_bytes()).map_err(&err)?;
        self.lines += 1;
        if sync {
            file.sync_data().map_err(&err)?;
        }
        Ok(())
    }

    /// Whether the spool holds `key`, pending or acknowledged.
    #[must_use]
    pub fn contains(&self, key: &AlertKey) -> bool {
        self.acked.contains(key) || self.pending.iter().any(|a| a.key() == *key)
    }

    /// Whether `key` was acknowledged.
    #[must_use]
    pub fn is_acked(&self, key: &AlertKey) -> bool {
        self.acked.contains(key)
    }

    /// Alerts not yet acknowledged, in order.
    #[must_use]
    pub fn pending(&self) -> Vec<AlertJson> {
        self.pending.iter().cloned().collect()
    }

    /// Adds an alert to deliver, synced to disk before this returns; false (nothing done) if
    /// the spool holds it already. On a file error the alert is still pending in memory.
    pub fn add(&mut self, alert: &AlertJson) -> std::io::Result<bool> {
        if self.contains(&alert.key()) {
            return Ok(false);
        }
        self.pending.push_back(alert.clone());
        self.append(
            &SpoolRecord::Alert {
                alert: alert.clone(),
            },
            true,
        )?;
        Ok(true)
    }

    /// Records that `key` was delivered (acknowledged): it will not be delivered again. An ack
    /// of an alert the spool does not hold marks it delivered (a receiver's baseline).
    pub fn ack(&mut self, key: &AlertKey) -> std::io::Result<()> {
        if self.acked.contains(key) {
            return Ok(());
        }
        self.pending.retain(|a| a.key() != *key);
        self.acked.insert(key.clone());
        self.append(
            &SpoolRecord::Ack {
                pbr_id: key.0.clone(),
                episode: key.1,
                level: key.2,
            },
            false,
        )?;
        // Lines of delivered alerts are waste; rewriting once they reach half the records kept
        // costs O(1) per alert, amortized.
        let keep = self.acked.len() + self.pending.len();
        if self.lines.saturating_sub(keep) >= COMPACT_MIN_WASTE.max(keep / 2) {
            self.compact()?;
        }
        Ok(())
    }

    /// Rewrites the file with only what it must keep.
    pub fn compact(&mut self) -> std::io::Result<()> {
        let Some((path, _)) = &self.file else {
            return Ok(());
        };
        let path = path.clone();
        let file = Spool::rewrite(&path, self)?;
        self.file = Some((path, file));
        self.lines = self.acked.len() + self.pending.len();
        Ok(())
    }

    /// Lines in the file (0 in memory).
    #[must_use]
    pub fn file_lines(&self) -> usize {
        self.lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rockwatch_core::dynamics::Mode;

    fn alert(pbr: &str, episode: u32) -> AlertJson {
        AlertJson {
            pbr_id: rockwatch_core::engine::PbrId::parse(pbr).unwrap(),
            level: AlertLevel::MotionOnset,
            episode,
            data_time: "1970-01-01T00:00:00.000000000Z".into(),
            data_time_ns: 0,
            station: rockwatch_core::engine::StationId::parse("XX.A.00").unwrap(),
            mode: Mode::Rock,
            theta_over_alpha: 0.1,
            slide_m: 0.0,
            overturn_probability: 0.0,
            pga_mps2: 1.0,
            pgv_mps: 0.1,
            direction_deg: 0.0,
            lat_deg: Default::default(),
            lon_deg: Default::default(),
            pbr_name: Default::default(),
        }
    }

    #[test]
    fn pending_alerts_survive_a_reopen_and_acked_ones_do_not_come_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("notify/x.spool");
        let (mut spool, report) = Spool::open(&path).unwrap();
        assert!(report.created);
        assert!(spool.add(&alert("a", 1)).unwrap());
        assert!(spool.add(&alert("b", 1)).unwrap());
        assert!(!spool.add(&alert("a", 1)).unwrap(), "added twice");
        assert!(spool.add(&alert("c", 1)).unwrap());
        spool.ack(&alert("b", 1).key()).unwrap();
        drop(spool);
        let (spool, report) = Spool::open(&path).unwrap();
        assert!(!report.created && report.corrupt_lines.is_empty());
        assert_eq!(spool.pending(), vec![alert("a", 1), alert("c", 1)]);
        assert!(spool.is_acked(&alert("b", 1).key()));
        assert!(spool.contains(&alert("a", 1).key()));
        // Compacted on open: one line per record.
        assert_eq!(std::fs::read_to_string(&path).unwrap().lines().count(), 3);
    }

    #[test]
    fn a_torn_or_corrupt_line_is_skipped_and_the_rest_kept() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.spool");
        let (mut spool, _) = Spool::open(&path).unwrap();
        spool.add(&alert("a", 1)).unwrap();
        spool.add(&alert("b", 1)).unwrap();
        drop(spool);
        let mut text = std::fs::read_to_string(&path).unwrap();
        text = text.replacen("\"a\"", "\"z\"", 1); // checksum no longer matches
        text.push_str("0badc0de {\"op\":\"ack\",\"pbr_"); // torn write
        std::fs::write(&path, text).unwrap();
        let (spool, report) = Spool::open(&path).unwrap();
        assert_eq!(report.corrupt_lines, vec![1, 3]);
        assert_eq!(spool.pending(), vec![alert("b", 1)]);
    }

    #[test]
    fn many_acks_compact_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.spool");
        let (mut spool, _) = Spool::open(&path).unwrap();
        for episode in 0..2000 {
            spool.add(&alert("a", episode)).unwrap();
            spool.ack(&alert("a", episode).key()).unwrap();
        }
        spool.add(&alert("b", 1)).unwrap();
        // 2000 acks and one pending alert to keep; most of the 2000 delivered alert lines
        // were dropped (at most COMPACT_MIN_WASTE remain).
        let lines = std::fs::read_to_string(&path).unwrap().lines().count();
        assert!(lines < 2001 + COMPACT_MIN_WASTE, "{lines} lines");
        assert_eq!(lines, spool.file_lines());
        drop(spool);
        let (spool, _) = Spool::open(&path).unwrap();
        assert_eq!(spool.pending(), vec![alert("b", 1)]);
        assert!((0..2000).all(|e| spool.is_acked(&alert("a", e).key())));
    }
}
