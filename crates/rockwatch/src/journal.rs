//! The state directory's journal: an append-only, checksummed log of alerts, episode ends and
//! operator resets. An alert is appended and flushed to disk (`fsync`) *before* it is reported
//! as published, so a crash can never lose a published alert; on restart the engine restores
//! the journal and suppresses alerts it already holds, so none is duplicated.
//!
//! Format: one record per line, `CRC32(json) as 8 hex digits`, a space, the record as JSON.
//! A torn last line (a crash mid-write) is discarded and truncated away on open; a corrupt line
//! elsewhere is skipped and reported.
//!
//! One process per state directory: [`Journal::open`] takes an exclusive OS lock (`flock`) on
//! [`LOCK_FILE`] and holds it as long as the journal is open (the process's lifetime for the
//! node); a second opener is refused ([`JournalError::Locked`]). The lock is released by the
//! kernel when the process ends, however it ends (a `kill -9` leaves no stale lock).

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use rockwatch_core::engine::JournalRecord;

/// File name of the journal inside the state directory.
pub const JOURNAL_FILE: &str = "journal.log";

/// File name of the lock inside the state directory (empty; only its `flock` matters).
pub const LOCK_FILE: &str = "lock";

/// A problem with the state directory.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "{dir}: the state directory is in use by another rockwatch process (it holds \
         {LOCK_FILE}): one node per state directory"
    )]
    Locked { dir: PathBuf },
    #[error("{path}: {waiting} records wait for the state directory (it is failing, e.g. full)")]
    Backlog { path: PathBuf, waiting: usize },
    #[error("{path}: cannot encode a record: {message}")]
    Encode { path: PathBuf, message: String },
}

/// What opening a journal found.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LoadReport {
    pub records: usize,
    /// Lines whose checksum or JSON was wrong (skipped), 1-based line numbers.
    pub corrupt_lines: Vec<usize>,
    /// A torn last line was found and truncated away.
    pub truncated_tail: bool,
}

/// An open journal, appending.
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    file: File,
    /// Length of the file's complete lines: a failed append is truncated back to it.
    len: u64,
    /// Holds the state directory's exclusive lock while open.
    _lock: File,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> JournalError + '_ {
    move |source| JournalError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// One checksummed line: `CRC32(json) as 8 hex digits`, a space, `record` as JSON, `\n`
/// (also the format of the notify spools, `crate::notify`).
pub(crate) fn encode<T: serde::Serialize>(record: &T) -> Result<String, String> {
    let json = serde_json::to_string(record).map_err(|e| e.to_string())?;
    Ok(format!("{:08x} {json}\n", crc32fast::hash(json.as_bytes())))
}

/// The record of one line written by [`encode`] (without its `\n`); None if the checksum or
/// the JSON is wrong.
pub(crate) fn decode<T: serde::de::DeserializeOwned>(line: &str) -> Option<T> {
    let (crc, json) = line.split_once(' ')?;
    let crc = u32::from_str_radix(crc, 16).ok()?;
    (crc == crc32fast::hash(json.as_bytes()))
        .then(|| serde_json::from_str(json).ok())
        .flatten()
}

/// Reads every valid record of the journal in `dir` (none if it does not exist).
pub fn read_journal(dir: &Path) -> Result<(Vec<JournalRecord>, LoadReport), JournalError> {
    let path = dir.join(JOURNAL_FILE);
    let file = match File::open(&path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Ok((Vec::new(), LoadReport::default()))
        }
        Err(e) => return Err(io(&path)(e)),
    };
    let mut records = Vec::new();
    let mut report = LoadReport::default();
    let mut reader = BufReader::new(file);
    let mut line = Vec::new();
    let mut number = 0;
    loop {
        line.clear();
        let n = reader.read_until(b'\n', &mut line).map_err(io(&path))?;
        if n == 0 {
            break;
        }
        number += 1;
        if line.last() != Some(&b'\n') {
            report.truncated_tail = true; // torn write: never acknowledged
            break;
        }
        // A line that is not UTF-8 is as corrupt as one whose checksum fails.
        match std::str::from_utf8(&line[..line.len() - 1])
            .ok()
            .and_then(decode)
        {
            Some(r) => records.push(r),
            None => report.corrupt_lines.push(number),
        }
    }
    report.records = records.len();
    Ok((records, report))
}

/// Takes the exclusive lock of the state directory `dir`, without waiting.
fn lock_state_dir(dir: &Path) -> Result<File, JournalError> {
    let path = dir.join(LOCK_FILE);
    let file = OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(io(&path))?;
    match file.try_lock() {
        Ok(()) => Ok(file),
        Err(std::fs::TryLockError::WouldBlock) => Err(JournalError::Locked {
            dir: dir.to_path_buf(),
        }),
        Err(std::fs::TryLockError::Error(e)) => Err(io(&path)(e)),
    }
}

impl Journal {
    /// Opens (creating) the journal in `dir`, returning its valid records. A torn last line is
    /// truncated away so that appends start on a clean line.
    pub fn open(dir: &Path) -> Result<(Journal, Vec<JournalRecord>, LoadReport), JournalError> {
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        let lock = lock_state_dir(dir)?;
        let (records, report) = read_journal(dir)?;
        let path = dir.join(JOURNAL_FILE);
        let mut file = OpenOptions::new()
            .create(true)
            .read(true)
            .append(true)
            .open(&path)
            .map_err(io(&path))?;
        if report.truncated_tail {
            let text = std::fs::read(&path).map_err(io(&path))?;
            let keep = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
            file.set_len(keep as u64).map_err(io(&path))?;
            file.seek(SeekFrom::End(0)).map_err(io(&path))?;
        }
        let len = file.metadata().map_err(io(&path))?.len();
        Ok((
            Journal {
                path,
                file,
                len,
                _lock: lock,
            },
            records,
            report,
        ))
    }

    /// Appends `record` and flushes it to stable storage before returning. On failure (a
    /// full disk: `ENOSPC` on the write or on the sync) the file is truncated back to its
    /// last complete line, so a later append starts on a clean line and nothing half-written
    /// stays behind.
    pub fn append(&mut self, record: &JournalRecord) -> Result<(), JournalError> {
        self.write(record, true)
    }

    /// Appends `record` without waiting for stable storage (the next synced append, or the
    /// system, flushes it): for records whose loss in a crash is harmless
    /// ([`JournalRecord::Published`]: the alert is published again). A failed write is
    /// truncated as in [`Journal::append`].
    pub fn append_unsynced(&mut self, record: &JournalRecord) -> Result<(), JournalError> {
        self.write(record, false)
    }

    fn write(&mut self, record: &JournalRecord, sync: bool) -> Result<(), JournalError> {
        let line = encode(record).map_err(|message| JournalError::Encode {
            path: self.path.clone(),
            message,
        })?;
        let written = self.file.write_all(line.as_bytes()).and_then(|()| {
            if sync {
                self.file.sync_data()
            } else {
                Ok(())
            }
        });
        if let Err(e) = written {
            // Truncation frees blocks: it works on a full file system. If it fails too,
            // the torn line is discarded on the next open (see the module doc).
            let _ = self.file.set_len(self.len);
            return Err(io(&self.path)(e));
        }
        self.len += line.len() as u64;
        Ok(())
    }
}

/// Most records waiting for a failing state directory ([`JournalWriter`]); beyond, new
/// records are dropped and counted. Alerts are rare (three per block and episode): 100 000
/// is days of a station network in continuous alarm, ≈ 30 MB.
pub const MAX_BACKLOG: usize = 100_000;

/// A [`Journal`] that survives a failing state directory (a full disk): a record that
/// cannot be written waits, in order, in a bounded backlog and is written when the
/// directory recovers ([`JournalWriter::retry`], and before every later record).
#[derive(Debug)]
pub struct JournalWriter {
    journal: Journal,
    backlog: std::collections::VecDeque<JournalRecord>,
    /// Failed write attempts since start.
    pub failures: u64,
    /// Records dropped because the backlog was full ([`MAX_BACKLOG`]).
    pub dropped: u64,
    /// The last failure, while the backlog is not empty.
    pub last_error: Option<String>,
}

/// What a [`JournalWriter`] did with a record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Appended {
    /// On stable storage, after every record before it.
    Written,
    /// Waiting in the backlog (the state directory is failing).
    Pending,
    /// Lost: the backlog was full.
    Dropped,
}

impl JournalWriter {
    #[must_use]
    pub fn new(journal: Journal) -> JournalWriter {
        JournalWriter {
            journal,
            backlog: std::collections::VecDeque::new(),
            failures: 0,
            dropped: 0,
            last_error: None,
        }
    }

    /// Records waiting for the state directory.
    #[must_use]
    pub fn backlog(&self) -> usize {
        self.backlog.len()
    }

    /// Writes `record` after the backlog, or queues it if the state directory fails.
    pub fn append(&mut self, record: JournalRecord) -> Appended {
        if self.backlog.len() >= MAX_BACKLOG {
            self.dropped += 1;
            return Appended::Dropped;
        }
        self.backlog.push_back(record);
        self.drain();
        if self.backlog.is_empty() {
            Appended::Written
        } else {
            Appended::Pending
        }
    }

    /// Writes `record` now, only if nothing waits and the write succeeds (an operator reset:
    /// applied only once journaled); nothing is queued on failure.
    pub fn append_now(&mut self, record: &JournalRecord) -> Result<(), JournalError> {
        self.retry();
        if !self.backlog.is_empty() {
            return Err(JournalError::Backlog {
                path: self.journal.path.clone(),
                waiting: self.backlog.len(),
            });
        }
        self.journal.append(record).inspect_err(|e| {
            self.failures += 1;
            self.last_error = Some(e.to_string());
        })
    }

    /// Writes `record` unsynced ([`Journal::append_unsynced`]) if nothing waits in the
    /// backlog; returns whether it was written. For records whose loss is harmless
    /// ([`JournalRecord::Published`]): never queued, so a failing directory only means the
    /// alert is published again at the next start.
    pub fn append_unsynced(&mut self, record: &JournalRecord) -> bool {
        if !self.backlog.is_empty() {
            return false;
        }
        match self.journal.append_unsynced(record) {
            Ok(()) => true,
            Err(e) => {
                self.failures += 1;
                self.last_error = Some(e.to_string());
                false
            }
        }
    }

    /// Tries to write the backlog; returns how many records were written.
    pub fn retry(&mut self) -> usize {
        let before = self.backlog.len();
        self.drain();
        before - self.backlog.len()
    }

    fn drain(&mut self) {
        while let Some(record) = self.backlog.front() {
            match self.journal.append(record) {
                Ok(()) => {
                    self.backlog.pop_front();
                }
                Err(e) => {
                    self.failures += 1;
                    self.last_error = Some(e.to_string());
                    return;
                }
            }
        }
        self.last_error = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reset(id: &str) -> JournalRecord {
        JournalRecord::Reset { pbr_id: id.into() }
    }

    #[test]
    fn a_second_opener_of_the_state_directory_is_refused_until_the_first_closes() {
        let dir = tempfile::tempdir().unwrap();
        let (first, _, _) = Journal::open(dir.path()).unwrap();
        let err = Journal::open(dir.path()).unwrap_err();
        assert!(matches!(err, JournalError::Locked { .. }), "{err}");
        assert!(err.to_string().contains("one node per state directory"));
        drop(first);
        Journal::open(dir.path()).unwrap();
    }

    #[test]
    fn records_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let (mut j, recs, _) = Journal::open(dir.path()).unwrap();
        assert!(recs.is_empty());
        j.append(&reset("a")).unwrap();
        j.append(&JournalRecord::EpisodeEnd {
            pbr_id: "b".into(),
            episode: 2,
        })
        .unwrap();
        drop(j);
        let (_, recs, report) = Journal::open(dir.path()).unwrap();
        assert_eq!(
            recs,
            vec![
                reset("a"),
                JournalRecord::EpisodeEnd {
                    pbr_id: "b".into(),
                    episode: 2
                }
            ]
        );
        assert_eq!(
            report,
            LoadReport {
                records: 2,
                ..LoadReport::default()
            }
        );
    }

    #[test]
    fn torn_tail_is_truncated_and_corrupt_lines_are_skipped() {
        let dir = tempfile::tempdir().unwrap();
        let (mut j, _, _) = Journal::open(dir.path()).unwrap();
        j.append(&reset("a")).unwrap();
        j.append(&reset("b")).unwrap();
        drop(j);
        let path = dir.path().join(JOURNAL_FILE);
        let mut text = std::fs::read_to_string(&path).unwrap();
        text = text.replacen("\"a\"", "\"x\"", 1); // checksum no longer matches
        text.push_str("0badc0de {\"Reset\":{\"pbr_"); // torn write
        let mut bytes = text.into_bytes();
        let second_line = bytes.iter().position(|&b| b == b'\n').unwrap() + 1;
        bytes.splice(
            second_line..second_line,
            b"\xff\xfe not utf-8\n".iter().copied(),
        );
        std::fs::write(&path, bytes).unwrap();
        let (mut j, recs, report) = Journal::open(dir.path()).unwrap();
        assert_eq!(recs, vec![reset("b")]);
        assert_eq!(report.corrupt_lines, vec![1, 2]);
        assert!(report.truncated_tail);
        j.append(&reset("c")).unwrap();
        let (recs, report) = read_journal(dir.path()).unwrap();
        assert_eq!(recs, vec![reset("b"), reset("c")]);
        assert!(!report.truncated_tail);
    }
}
