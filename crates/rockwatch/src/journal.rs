//! The state directory's journal: an append-only, checksummed log of alerts, episode ends and
//! operator resets. An alert is appended and flushed to disk (`fsync`) *before* it is reported
//! as published, so a crash can never lose a published alert; on restart the engine restores
//! the journal and suppresses alerts it already holds, so none is duplicated.
//!
//! Format: one record per line, `CRC32(json) as 8 hex digits`, a space, the record as JSON.
//! A torn last line (a crash mid-write) is discarded and truncated away on open; a corrupt line
//! elsewhere is skipped and reported.

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use rockwatch_core::engine::JournalRecord;

/// File name of the journal inside the state directory.
pub const JOURNAL_FILE: &str = "journal.log";

/// A problem with the state directory.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
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
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> JournalError + '_ {
    move |source| JournalError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn encode(record: &JournalRecord) -> Result<String, String> {
    let json = serde_json::to_string(record).map_err(|e| e.to_string())?;
    Ok(format!("{:08x} {json}\n", crc32fast::hash(json.as_bytes())))
}

fn decode(line: &str) -> Option<JournalRecord> {
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

impl Journal {
    /// Opens (creating) the journal in `dir`, returning its valid records. A torn last line is
    /// truncated away so that appends start on a clean line.
    pub fn open(dir: &Path) -> Result<(Journal, Vec<JournalRecord>, LoadReport), JournalError> {
        std::fs::create_dir_all(dir).map_err(io(dir))?;
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
        Ok((Journal { path, file }, records, report))
    }

    /// Appends `record` and flushes it to stable storage before returning.
    pub fn append(&mut self, record: &JournalRecord) -> Result<(), JournalError> {
        self.append_unsynced(record)?;
        self.file.sync_data().map_err(io(&self.path))
    }

    /// Appends `record` without waiting for stable storage (the next synced append, or the
    /// system, flushes it): for records whose loss in a crash is harmless
    /// ([`JournalRecord::Published`]: the alert is published again).
    pub fn append_unsynced(&mut self, record: &JournalRecord) -> Result<(), JournalError> {
        let line = encode(record).map_err(|message| JournalError::Encode {
            path: self.path.clone(),
            message,
        })?;
        self.file.write_all(line.as_bytes()).map_err(io(&self.path))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reset(id: &str) -> JournalRecord {
        JournalRecord::Reset { pbr_id: id.into() }
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
