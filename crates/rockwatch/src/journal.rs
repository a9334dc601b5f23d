//! The state directory's journal: an append-only, checksummed log of alerts, episode ends and
//! operator resets. An alert is appended and flushed to disk (`fsync`) *before* it is reported
//! as published, so a crash can never lose a published alert; on restart the engine restores
//! the journal and suppresses alerts it already holds, so none is duplicated.
//!
//! Format: one record per line, `CRC32(json) as 8 hex digits`, a space, the record as JSON.
//! A torn last line (a crash mid-write) is discarded and truncated away on open; a corrupt line
//! elsewhere is skipped and reported.
//!
//! Bounded: once the file passes [`COMPACT_AT_BYTES`] it is compacted
//! ([`Journal::compact`]) to what a restart needs ([`compact_journal`]: the open episodes,
//! fallen blocks, resets, the last [`HISTORY_ALERTS`] alerts republished at start and their
//! `Published` markers), written atomically: a temporary file [`COMPACT_TMP`] is written and
//! synced, renamed over the journal, and the directory synced. A crash at any point leaves
//! either the old journal or the compacted one (a leftover temporary file is removed on open).
//!
//! One process per state directory: [`Journal::open`] takes an exclusive OS lock (`flock`) on
//! the directory itself and on [`LOCK_FILE`] and holds them as long as the journal is open (the
//! process's lifetime for the node); a second opener is refused ([`JournalError::Locked`]),
//! even if the lock file was deleted meanwhile (the directory's lock remains). The locks are
//! released by the kernel when the process ends, however it ends (a `kill -9` leaves no stale
//! lock). [`check_state_dir_free`] lets a node refuse a held directory before it starts
//! anything else.
//!
//! The journal must be a regular file (a journal symlinked to `/dev/null` would swallow every
//! alert: refused, [`JournalError::NotAFile`]); a state directory others may write is warned of
//! ([`LoadReport::world_writable`]).

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use rockwatch_core::engine::{compact_journal, JournalRecord};

/// File name of the journal inside the state directory.
pub const JOURNAL_FILE: &str = "journal.log";

/// File name of the lock inside the state directory (empty; only its `flock` matters).
pub const LOCK_FILE: &str = "lock";

/// File name of the marker `rockwatch monitor` leaves in a state directory of its own (a
/// rehearsal's journal): `monitor` writes only a directory that is new, empty or so marked
/// ([`claim_rehearsal_dir`]), and `rockwatch node` refuses a marked one
/// ([`refuse_rehearsal_dir`]): a rehearsal's alerts never reach a node's state.
pub const REHEARSAL_MARKER: &str = "rehearsal";

/// The compacted journal while it is written (renamed over [`JOURNAL_FILE`] once synced).
pub const COMPACT_TMP: &str = "journal.log.compact";

/// Journal size (bytes) beyond which it is compacted: ≈ 100 000 records of ≈ 300 bytes. If
/// what a restart needs is itself larger (a very large catalogue), the next compaction waits
/// until the file has doubled.
pub const COMPACT_AT_BYTES: u64 = 32 << 20;

/// The alert history: the alerts a compaction keeps, the journaled alerts a starting node
/// publishes again, and the depth of the transient-local history of `/pbr/alerts` (a late
/// subscriber gets this many).
pub const HISTORY_ALERTS: usize = 1000;

/// What a compaction did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Compacted {
    pub records_before: usize,
    pub records_after: usize,
    pub bytes_before: u64,
    pub bytes_after: u64,
}

/// Fault injection for the crash-safety tests: with this variable set to `mid-temporary`,
/// `before-rename` or `before-dir-sync`, the process aborts at that point of a compaction
/// ([`CrashPoint`]).
pub const FAULT_ABORT_IN_COMPACTION_ENV: &str = "ROCKWATCH_FAULT_ABORT_IN_COMPACTION";

/// Where a compaction stops as if the process had crashed there (crash-safety tests).
#[doc(hidden)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CrashPoint {
    /// Half of the temporary file written, nothing synced.
    MidTemporary,
    /// The temporary file written and synced, not renamed.
    BeforeRename,
    /// Renamed over the journal, the directory not synced.
    BeforeDirSync,
}

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
        "{dir}: the state directory is in use by another rockwatch process (it holds the \
         directory's lock): one node per state directory"
    )]
    Locked { dir: PathBuf },
    #[error("{path}: {waiting} records wait for the state directory (it is failing, e.g. full)")]
    Backlog { path: PathBuf, waiting: usize },
    #[error("{path}: cannot encode a record: {message}")]
    Encode { path: PathBuf, message: String },
    #[error(
        "{path}: the journal is not a regular file (a link to a device such as /dev/null would \
         swallow every alert): point the state directory elsewhere or remove it"
    )]
    NotAFile { path: PathBuf },
    #[error(
        "{dir}: holds or held a node's state (it is not empty and has no `rehearsal` marker \
         of `rockwatch monitor`): monitor never writes a node's state directory; give \
         --state-dir a new or empty directory of its own"
    )]
    NodeState { dir: PathBuf },
    #[error(
        "{dir}: written by `rockwatch monitor` (a rehearsal's alerts; marker \
         {dir}/rehearsal), not a node's state: a node on it would publish the rehearsal's \
         alerts again and start with its rocks fallen; give the node a state directory of its \
         own"
    )]
    Rehearsal { dir: PathBuf },
}

/// What opening a journal found.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LoadReport {
    pub records: usize,
    /// Lines whose checksum or JSON was wrong, or whose episode number is absurd (beyond
    /// [`MAX_JOURNAL_EPISODE`]: a forged line), skipped; 1-based line numbers.
    pub corrupt_lines: Vec<usize>,
    /// A torn last line was found and truncated away.
    pub truncated_tail: bool,
    /// Lines ending in CR LF (a journal converted to DOS line endings): read as if LF.
    pub crlf_lines: usize,
    /// Alert records repeating an earlier one's identity (pbr, episode, level), e.g. a
    /// journal appended to itself: the first is kept, the repeats ignored.
    pub repeated_alerts: usize,
    /// The state directory is writable by every user (mode o+w): anyone could forge or
    /// delete the alert history ([`Journal::open`] only; `read_journal` does not check).
    pub world_writable: bool,
}

impl LoadReport {
    /// Whether anything was repaired or ignored (worth a warning).
    #[must_use]
    pub fn repaired(&self) -> bool {
        !self.corrupt_lines.is_empty()
            || self.truncated_tail
            || self.crlf_lines > 0
            || self.repeated_alerts > 0
    }

    /// The warnings this report calls for, one line each (none if all is well).
    #[must_use]
    pub fn warnings(&self, dir: &Path) -> Vec<String> {
        let mut lines = Vec::new();
        if self.repaired() {
            lines.push(format!("{}: journal repaired: {self}", dir.display()));
        }
        if self.world_writable {
            lines.push(format!(
                "{}: the state directory is writable by every user (mode o+w): anyone on this \
                 machine could forge or delete the alert history; chmod o-w it",
                dir.display()
            ));
        }
        lines
    }
}

impl std::fmt::Display for LoadReport {
    /// `12 records; 2 corrupt lines skipped (3, 9); …` (at most 10 line numbers).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} records", self.records)?;
        if !self.corrupt_lines.is_empty() {
            let shown: Vec<String> = self
                .corrupt_lines
                .iter()
                .take(10)
                .map(ToString::to_string)
                .collect();
            let more = if self.corrupt_lines.len() > 10 {
                ", …"
            } else {
                ""
            };
            write!(
                f,
                "; {} corrupt lines skipped (bad checksum, JSON or episode: lines {}{more})",
                self.corrupt_lines.len(),
                shown.join(", ")
            )?;
        }
        if self.truncated_tail {
            write!(f, "; a torn last line truncated")?;
        }
        if self.crlf_lines > 0 {
            write!(
                f,
                "; {} lines ended in CR LF (DOS line endings), read as LF",
                self.crlf_lines
            )?;
        }
        if self.repeated_alerts > 0 {
            write!(
                f,
                "; {} repeated alert records ignored (the journal holds some lines twice)",
                self.repeated_alerts
            )?;
        }
        Ok(())
    }
}

/// The largest episode number a journal line may carry: a rock's episode lasts seconds at
/// least, so 10⁹ episodes are decades of continuous shaking; a larger number is a forged or
/// corrupted line (one at 2³² − 1 would wrap the next episode to 0).
pub const MAX_JOURNAL_EPISODE: u32 = 1_000_000_000;

/// The episode number a record carries, if any.
fn episode_of(record: &JournalRecord) -> Option<u32> {
    match record {
        JournalRecord::Alert(a) => Some(a.episode),
        JournalRecord::EpisodeEnd { episode, .. } | JournalRecord::Published { episode, .. } => {
            Some(*episode)
        }
        JournalRecord::Reset { .. } => None,
    }
}

/// An open journal, appending.
#[derive(Debug)]
pub struct Journal {
    path: PathBuf,
    file: File,
    /// Length of the file's complete lines: a failed append is truncated back to it.
    len: u64,
    /// Size beyond which [`Journal::compact_if_due`] compacts.
    compact_at: u64,
    /// Holds the state directory's exclusive lock while open.
    /// The state directory's locks.
    _lock: StateLock,
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
    let mut alert_keys = std::collections::HashSet::new();
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
        let mut body = &line[..line.len() - 1];
        if let Some(stripped) = body.strip_suffix(b"\r") {
            report.crlf_lines += 1;
            body = stripped;
        }
        // A line that is not UTF-8 is as corrupt as one whose checksum fails.
        match std::str::from_utf8(body)
            .ok()
            .and_then(decode::<JournalRecord>)
        {
            Some(r) if episode_of(&r).is_some_and(|e| e > MAX_JOURNAL_EPISODE) => {
                report.corrupt_lines.push(number);
            }
            Some(JournalRecord::Alert(a)) if !alert_keys.insert(a.key()) => {
                report.repeated_alerts += 1;
            }
            Some(r) => records.push(r),
            None => report.corrupt_lines.push(number),
        }
    }
    report.records = records.len();
    Ok((records, report))
}

/// The exclusive locks of a state directory: the directory itself, and its lock file when it
/// could be created (a disk without free inodes cannot create one; the directory's lock needs
/// none).
#[derive(Debug)]
pub struct StateLock {
    _dir: File,
    _file: Option<File>,
}

/// Takes the exclusive lock of `file` (the state directory `dir` or its lock file), without
/// waiting: [`JournalError::Locked`] if another process holds it.
fn try_lock(file: File, path: &Path, dir: &Path) -> Result<File, JournalError> {
    match file.try_lock() {
        Ok(()) => Ok(file),
        Err(std::fs::TryLockError::WouldBlock) => Err(JournalError::Locked {
            dir: dir.to_path_buf(),
        }),
        Err(std::fs::TryLockError::Error(e)) => Err(io(path)(e)),
    }
}

/// Takes the exclusive locks of the state directory `dir` (the directory and its lock
/// file), without waiting.
fn lock_state_dir(dir: &Path) -> Result<StateLock, JournalError> {
    let locked = |file: File, path: &Path| try_lock(file, path, dir);
    let directory = locked(File::open(dir).map_err(io(dir))?, dir)?;
    let path = dir.join(LOCK_FILE);
    let file = match OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
    {
        Ok(file) => Some(locked(file, &path)?),
        // A full disk (no inode for a new lock file): the directory's lock is the lock.
        Err(e) if is_storage_full(&e) => None,
        Err(e) => return Err(io(&path)(e)),
    };
    Ok(StateLock {
        _dir: directory,
        _file: file,
    })
}

/// Whether `e` says the file system is full (no space or no inode: `ENOSPC`, `EDQUOT`).
fn is_storage_full(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded
    )
}

impl JournalError {
    /// Whether the state directory failed because its file system is full: a node starts
    /// degraded then ([`JournalWriter::degraded`]) rather than not at all.
    #[must_use]
    pub fn is_storage_full(&self) -> bool {
        matches!(self, JournalError::Io { source, .. } if is_storage_full(source))
    }
}

/// The wall clock as UTC, ns since the Unix epoch (0 before 1970): the time of records made by
/// an operator (resets) and the node's UTC epoch.
#[must_use]
pub fn utc_now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

/// Refuses (`JournalError::Locked`) a state directory another process holds, without keeping
/// it: a node calls it before it starts anything (DDS, notifications), then opens the journal.
/// A directory that does not exist yet is free.
pub fn check_state_dir_free(dir: &Path) -> Result<(), JournalError> {
    if !dir.exists() {
        return Ok(());
    }
    lock_state_dir(dir).map(drop)
}

/// Claims `dir` for `rockwatch monitor --state-dir` (a rehearsal's journal), creating it with
/// its [`REHEARSAL_MARKER`] if it is new or empty. Refused: a directory another process holds
/// now ([`JournalError::Locked`]), and any other non-empty directory without the marker
/// ([`JournalError::NodeState`]: a node's journal or lock file — one a node holds or held —
/// or files that are not rockwatch's). Creates nothing in a refused directory.
pub fn claim_rehearsal_dir(dir: &Path) -> Result<(), JournalError> {
    let marker = dir.join(REHEARSAL_MARKER);
    if dir.exists() && !marker.exists() {
        let mut entries = std::fs::read_dir(dir).map_err(io(dir))?;
        if entries.next().is_some() {
            // Held now: said as such (the directory's lock and an existing lock file's; no
            // lock file is created).
            try_lock(File::open(dir).map_err(io(dir))?, dir, dir)?;
            let lock = dir.join(LOCK_FILE);
            if let Ok(file) = OpenOptions::new().write(true).open(&lock) {
                try_lock(file, &lock, dir)?;
            }
            return Err(JournalError::NodeState {
                dir: dir.to_path_buf(),
            });
        }
    }
    if !marker.exists() {
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        std::fs::write(
            &marker,
            "This state directory was written by `rockwatch monitor` (an offline rehearsal). \
             `rockwatch node` refuses it.\n",
        )
        .map_err(io(&marker))?;
    }
    Ok(())
}

/// Refuses ([`JournalError::Rehearsal`]) a state directory `rockwatch monitor` wrote
/// ([`REHEARSAL_MARKER`]): `rockwatch node` calls it before it opens the journal.
pub fn refuse_rehearsal_dir(dir: &Path) -> Result<(), JournalError> {
    if dir.join(REHEARSAL_MARKER).exists() {
        return Err(JournalError::Rehearsal {
            dir: dir.to_path_buf(),
        });
    }
    Ok(())
}

impl Journal {
    /// Opens (creating) the journal in `dir`, returning its valid records. A torn last line is
    /// truncated away so that appends start on a clean line.
    pub fn open(dir: &Path) -> Result<(Journal, Vec<JournalRecord>, LoadReport), JournalError> {
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        let lock = lock_state_dir(dir)?;
        // A compaction that crashed before its rename: the journal is the old one, whole.
        let tmp = dir.join(COMPACT_TMP);
        match std::fs::remove_file(&tmp) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io(&tmp)(e)),
            _ => {}
        }
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
        let metadata = file.metadata().map_err(io(&path))?;
        if !metadata.is_file() {
            return Err(JournalError::NotAFile { path });
        }
        let len = metadata.len();
        let mut report = report;
        report.world_writable = {
            use std::os::unix::fs::PermissionsExt;
            std::fs::metadata(dir)
                .map_err(io(dir))?
                .permissions()
                .mode()
                & 0o002
                != 0
        };
        Ok((
            Journal {
                path,
                file,
                len,
                compact_at: COMPACT_AT_BYTES,
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

    /// The journal's size in bytes (complete lines).
    #[must_use]
    pub fn len_bytes(&self) -> u64 {
        self.len
    }

    /// Sets the size beyond which [`Journal::compact_if_due`] compacts (default
    /// [`COMPACT_AT_BYTES`]).
    pub fn set_compact_at(&mut self, bytes: u64) {
        self.compact_at = bytes;
    }

    /// Compacts the journal if it has grown beyond its bound. After a compaction (or a failed
    /// one) the bound becomes at least twice the journal's size, so a journal whose needed
    /// part is large, or a directory that keeps failing, is not rewritten on every append.
    pub fn compact_if_due(&mut self) -> Result<Option<Compacted>, JournalError> {
        if self.len <= self.compact_at {
            return Ok(None);
        }
        let result = self.compact();
        self.compact_at = self.compact_at.max(self.len.saturating_mul(2));
        result.map(Some)
    }

    /// Rewrites the journal with only what a restart needs ([`compact_journal`] with
    /// [`HISTORY_ALERTS`]), atomically (see the module doc). On error the journal is left as
    /// it was (the temporary file removed) and appends go on.
    pub fn compact(&mut self) -> Result<Compacted, JournalError> {
        self.compact_until(None)
    }

    /// [`Journal::compact`], stopping at `crash` as a crash there would (nothing cleaned up).
    #[doc(hidden)]
    pub fn compact_until(&mut self, crash: Option<CrashPoint>) -> Result<Compacted, JournalError> {
        let dir = self.path.parent().unwrap_or(Path::new(".")).to_path_buf();
        let (records, _) = read_journal(&dir)?;
        let kept = compact_journal(&records, HISTORY_ALERTS);
        let mut text = String::new();
        for r in &kept {
            text.push_str(&encode(r).map_err(|message| JournalError::Encode {
                path: self.path.clone(),
                message,
            })?);
        }
        // A crash point is simulated (`crash`: return, as if nothing more ran) or, under
        // FAULT_ABORT_IN_COMPACTION_ENV, a real abort of the process.
        let abort_at = std::env::var(FAULT_ABORT_IN_COMPACTION_ENV).ok();
        let stop = |point: CrashPoint| {
            let name = match point {
                CrashPoint::MidTemporary => "mid-temporary",
                CrashPoint::BeforeRename => "before-rename",
                CrashPoint::BeforeDirSync => "before-dir-sync",
            };
            if abort_at.as_deref() == Some(name) {
                std::process::abort();
            }
            crash == Some(point)
        };
        let tmp = dir.join(COMPACT_TMP);
        let mut simulated = false;
        let written = (|| -> std::io::Result<()> {
            let mut f = File::create(&tmp)?;
            let half = &text.as_bytes()[..text.len() / 2];
            f.write_all(half)?;
            if stop(CrashPoint::MidTemporary) {
                simulated = true;
                return Ok(());
            }
            f.write_all(&text.as_bytes()[half.len()..])?;
            f.sync_all()
        })();
        if simulated || stop(CrashPoint::BeforeRename) {
            return Err(io(&tmp)(std::io::Error::other("simulated crash")));
        }
        if let Err(e) = written.and_then(|()| std::fs::rename(&tmp, &self.path)) {
            let _ = std::fs::remove_file(&tmp);
            return Err(io(&tmp)(e));
        }
        // From here the journal is the compacted file: append to it.
        let file = OpenOptions::new()
            .read(true)
            .append(true)
            .open(&self.path)
            .map_err(io(&self.path))?;
        let before = self.len;
        self.file = file;
        self.len = text.len() as u64;
        if stop(CrashPoint::BeforeDirSync) {
            return Err(io(&dir)(std::io::Error::other("simulated crash")));
        }
        File::open(&dir)
            .and_then(|d| d.sync_all())
            .map_err(io(&dir))?;
        Ok(Compacted {
            records_before: records.len(),
            records_after: kept.len(),
            bytes_before: before,
            bytes_after: self.len,
        })
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
    /// None: the journal could not be opened at start (a full disk); reopened by
    /// [`JournalWriter::retry`], at most once a second.
    journal: Option<Journal>,
    /// The state directory, and the lock held while the journal is not open.
    dir: PathBuf,
    lock: Option<StateLock>,
    last_reopen: Option<std::time::Instant>,
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
        let dir = journal
            .path
            .parent()
            .unwrap_or(Path::new("."))
            .to_path_buf();
        let mut writer = JournalWriter {
            journal: Some(journal),
            dir,
            lock: None,
            last_reopen: None,
            backlog: std::collections::VecDeque::new(),
            failures: 0,
            dropped: 0,
            last_error: None,
        };
        writer.compact_if_due(); // a journal that grew past its bound before this start
        writer
    }

    /// A writer for the state directory `dir` whose journal could not be opened because its
    /// file system is full (`error`, [`JournalError::is_storage_full`]): it holds the
    /// directory's lock, keeps every record in the backlog and opens the journal once the
    /// directory takes it ([`JournalWriter::retry`]). Refused if another process holds `dir`.
    pub fn degraded(dir: &Path, error: &JournalError) -> Result<JournalWriter, JournalError> {
        Ok(JournalWriter {
            journal: None,
            dir: dir.to_path_buf(),
            lock: Some(lock_state_dir(dir)?),
            last_reopen: Some(std::time::Instant::now()),
            backlog: std::collections::VecDeque::new(),
            failures: 1,
            dropped: 0,
            last_error: Some(error.to_string()),
        })
    }

    /// Whether the journal is open (false: started degraded, waiting for the directory).
    #[must_use]
    pub fn is_open(&self) -> bool {
        self.journal.is_some()
    }

    /// Opens the journal if the writer started degraded and a second has passed since the last
    /// attempt (an error, the journal still closed, otherwise).
    fn ensure_open(&mut self) -> Result<(), JournalError> {
        if self.journal.is_some() {
            return Ok(());
        }
        let due = self
            .last_reopen
            .is_none_or(|at| at.elapsed() >= std::time::Duration::from_secs(1));
        if !due {
            return Err(self.waiting());
        }
        self.last_reopen = Some(std::time::Instant::now());
        // The directory's lock is ours: let the journal take it again.
        self.lock = None;
        match Journal::open(&self.dir) {
            Ok((journal, _, _)) => {
                tracing::info!(
                    "{}: the journal is open again: {} waiting records are written now",
                    self.dir.display(),
                    self.backlog.len()
                );
                self.journal = Some(journal);
                Ok(())
            }
            Err(e) => {
                self.lock = lock_state_dir(&self.dir).ok();
                Err(e)
            }
        }
    }

    /// The error of a journal not open: the records waiting for it.
    fn waiting(&self) -> JournalError {
        JournalError::Backlog {
            path: self.dir.join(JOURNAL_FILE),
            waiting: self.backlog.len(),
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
            self.compact_if_due();
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
            return Err(self.waiting());
        }
        let result = self
            .ensure_open()
            .and_then(|()| match self.journal.as_mut() {
                Some(journal) => journal.append(record),
                None => Err(self.waiting()),
            });
        result.inspect_err(|e| {
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
        let Some(journal) = self.journal.as_mut() else {
            return false;
        };
        match journal.append_unsynced(record) {
            Ok(()) => true,
            Err(e) => {
                self.failures += 1;
                self.last_error = Some(e.to_string());
                false
            }
        }
    }

    /// The underlying journal (None while it could not be opened).
    pub fn journal_mut(&mut self) -> Option<&mut Journal> {
        self.journal.as_mut()
    }

    /// Compacts the journal when it has passed its bound (see [`Journal::compact_if_due`]),
    /// saying so on stderr; a failed compaction is counted and said, and appends go on.
    fn compact_if_due(&mut self) {
        let Some(journal) = self.journal.as_mut() else {
            return;
        };
        match journal.compact_if_due() {
            Ok(None) => {}
            Ok(Some(c)) => tracing::info!(
                "journal {} compacted: {} records ({} bytes) -> {} records ({} bytes) kept for restarts",
                journal.path.display(),
                c.records_before,
                c.bytes_before,
                c.records_after,
                c.bytes_after
            ),
            Err(e) => {
                self.failures += 1;
                tracing::error!(
                    "journal compaction failed ({e}): the journal is kept whole and grows on; \
                     compaction is tried again once it has doubled"
                );
            }
        }
    }

    /// Tries to write the backlog; returns how many records were written.
    pub fn retry(&mut self) -> usize {
        let before = self.backlog.len();
        self.drain();
        before - self.backlog.len()
    }

    /// Opens the journal if it is not (a degraded start), then writes the backlog in order;
    /// the error is cleared only once the journal is open and the backlog written.
    fn drain(&mut self) {
        if let Err(e) = self.ensure_open() {
            self.failures += 1;
            self.last_error = Some(e.to_string());
            return;
        }
        let Some(journal) = self.journal.as_mut() else {
            return; // ensure_open succeeded: open
        };
        while let Some(record) = self.backlog.front() {
            match journal.append(record) {
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
        JournalRecord::Reset {
            pbr_id: rockwatch_core::engine::PbrId::parse(id).unwrap(),
            time_ns: None,
        }
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
    fn deleting_the_lock_file_does_not_let_a_second_node_in() {
        // Issue 24 item 8: with `state/lock` deleted, a second node created a new lock file,
        // locked it and shared the directory. The directory itself is locked too.
        let dir = tempfile::tempdir().unwrap();
        let (first, _, _) = Journal::open(dir.path()).unwrap();
        std::fs::remove_file(dir.path().join(LOCK_FILE)).unwrap();
        let err = Journal::open(dir.path()).unwrap_err();
        assert!(matches!(err, JournalError::Locked { .. }), "{err}");
        assert!(matches!(
            check_state_dir_free(dir.path()),
            Err(JournalError::Locked { .. })
        ));
        drop(first);
        check_state_dir_free(dir.path()).unwrap();
        check_state_dir_free(&dir.path().join("not-yet")).unwrap();
        Journal::open(dir.path()).unwrap();
    }

    #[test]
    fn a_journal_that_is_not_a_regular_file_is_refused_and_an_open_directory_is_warned_of() {
        use std::os::unix::fs::PermissionsExt;
        // Issue 24 item 8: a journal symlinked to /dev/null was accepted (every alert lost).
        let dir = tempfile::tempdir().unwrap();
        std::os::unix::fs::symlink("/dev/null", dir.path().join(JOURNAL_FILE)).unwrap();
        let err = Journal::open(dir.path()).unwrap_err();
        assert!(matches!(err, JournalError::NotAFile { .. }), "{err}");
        // A world-writable state directory opens, with a warning.
        let dir = tempfile::tempdir().unwrap();
        std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
        let (_, _, report) = Journal::open(dir.path()).unwrap();
        assert!(report.world_writable);
        let warnings = report.warnings(dir.path());
        assert!(
            warnings.len() == 1 && warnings[0].contains("writable by every user"),
            "{warnings:?}"
        );
        let dir = tempfile::tempdir().unwrap();
        std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o750)).unwrap();
        let (_, _, report) = Journal::open(dir.path()).unwrap();
        assert!(report.warnings(dir.path()).is_empty(), "{report:?}");
    }

    #[test]
    fn records_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let (mut j, recs, _) = Journal::open(dir.path()).unwrap();
        assert!(recs.is_empty());
        j.append(&reset("a")).unwrap();
        j.append(&JournalRecord::EpisodeEnd {
            pbr_id: rockwatch_core::engine::PbrId::parse("b").unwrap(),
            episode: 2,
            data_time_ns: None,
        })
        .unwrap();
        drop(j);
        let (_, recs, report) = Journal::open(dir.path()).unwrap();
        assert_eq!(
            recs,
            vec![
                reset("a"),
                JournalRecord::EpisodeEnd {
                    pbr_id: rockwatch_core::engine::PbrId::parse("b").unwrap(),
                    episode: 2,
                    data_time_ns: None,
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
    fn a_crlf_doubled_or_forged_journal_keeps_its_history_and_says_so() {
        // Issue 24 item 8: a journal converted to CR LF lost all its history (every checksum
        // failed) with a warning printed as a debug struct; a journal appended to itself
        // republished every alert twice without a word; a forged line (valid checksum)
        // at episode 2³² − 1 wrapped the next episode to 0.
        use rockwatch_core::engine::AlertLevel;
        let dir = tempfile::tempdir().unwrap();
        let (mut j, _, _) = Journal::open(dir.path()).unwrap();
        let records = [
            alert("p", 1, AlertLevel::MotionOnset),
            alert("p", 1, AlertLevel::Overturned),
            reset("p"),
        ];
        for r in &records {
            j.append(r).unwrap();
        }
        drop(j);
        let path = dir.path().join(JOURNAL_FILE);
        let text = std::fs::read_to_string(&path).unwrap();
        // CR LF: every record read, the conversion reported.
        std::fs::write(&path, text.replace('\n', "\r\n")).unwrap();
        let (recs, report) = read_journal(dir.path()).unwrap();
        assert_eq!(recs, records);
        assert_eq!(report.crlf_lines, 3);
        assert!(report.repaired());
        assert!(
            report.to_string().contains("3 lines ended in CR LF"),
            "{report}"
        );
        // Doubled: the repeated alerts are ignored and counted (the reset, harmless, is kept).
        std::fs::write(&path, format!("{text}{text}")).unwrap();
        let (recs, report) = read_journal(dir.path()).unwrap();
        assert_eq!(recs[..3], records);
        assert_eq!(recs[3..], [reset("p")]);
        assert_eq!(report.repeated_alerts, 2);
        assert!(
            report
                .to_string()
                .contains("2 repeated alert records ignored"),
            "{report}"
        );
        // Forged: a valid checksum on an absurd episode is a corrupt line.
        let forged = encode(&alert("p", u32::MAX, AlertLevel::MotionOnset)).unwrap();
        std::fs::write(&path, format!("{text}{forged}")).unwrap();
        let (recs, report) = read_journal(dir.path()).unwrap();
        assert_eq!(recs, records);
        assert_eq!(report.corrupt_lines, vec![4]);
        assert!(
            report.to_string().contains("1 corrupt lines skipped"),
            "{report}"
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

    fn alert(id: &str, episode: u32, level: rockwatch_core::engine::AlertLevel) -> JournalRecord {
        JournalRecord::Alert(rockwatch_core::engine::Alert {
            pbr_id: rockwatch_core::engine::PbrId::parse(id).unwrap(),
            station: rockwatch_core::engine::StationId::parse("CI.RRS.00").unwrap(),
            level,
            episode,
            mode: rockwatch_core::dynamics::Mode::Rock,
            theta_over_alpha: 1.0,
            slide_m: 0.0,
            overturn_probability: 1.0,
            pga_mps2: 3.0,
            pgv_mps: 0.5,
            data_time_ns: i64::from(episode) * 1_000_000_000,
            arrival_ns: 0,
            direction_deg: 0.0,
            lat_deg: Default::default(),
            lon_deg: Default::default(),
            pbr_name: Default::default(),
        })
    }

    /// A long journal: 3000 episodes of block "p" (each reset after its overturn), 1500 of
    /// "q" (each ended), "r" fallen in its last episode, every alert marked published but the
    /// last two.
    fn long_journal() -> Vec<JournalRecord> {
        use rockwatch_core::engine::AlertLevel::{MotionOnset, Overturned};
        let mut r = Vec::new();
        let published = |a: &JournalRecord| match a {
            JournalRecord::Alert(a) => JournalRecord::Published {
                pbr_id: a.pbr_id.clone(),
                episode: a.episode,
                level: a.level,
            },
            _ => unreachable!(),
        };
        for e in 1..=3000u32 {
            for rec in [alert("p", e, MotionOnset), alert("p", e, Overturned)] {
                r.push(rec.clone());
                r.push(published(&rec));
            }
            r.push(reset("p"));
            if e % 2 == 0 {
                let q = alert("q", e / 2, MotionOnset);
                r.push(q.clone());
                r.push(published(&q));
                r.push(JournalRecord::EpisodeEnd {
                    pbr_id: rockwatch_core::engine::PbrId::parse("q").unwrap(),
                    episode: e / 2,
                    data_time_ns: None,
                });
            }
        }
        r.push(alert("r", 1, MotionOnset));
        r.push(alert("r", 1, Overturned));
        r
    }

    fn derived(records: &[JournalRecord]) -> impl PartialEq + std::fmt::Debug {
        use rockwatch_core::engine::{fallen_blocks, journaled_alerts};
        let mut fallen: Vec<String> = fallen_blocks(records)
            .into_iter()
            .map(String::from)
            .collect();
        fallen.sort();
        (fallen, journaled_alerts(records, HISTORY_ALERTS))
    }

    #[test]
    fn compaction_keeps_what_a_restart_needs_and_a_crash_at_any_step_loses_nothing() {
        let records = long_journal();
        let compacted = compact_journal(&records, HISTORY_ALERTS);
        assert!(compacted.len() * 4 < records.len(), "{}", compacted.len());
        for crash in [
            None,
            Some(CrashPoint::MidTemporary),
            Some(CrashPoint::BeforeRename),
            Some(CrashPoint::BeforeDirSync),
        ] {
            let dir = tempfile::tempdir().unwrap();
            let (mut j, _, _) = Journal::open(dir.path()).unwrap();
            for r in &records {
                j.append_unsynced(r).unwrap();
            }
            let full = j.len_bytes();
            let result = j.compact_until(crash);
            assert_eq!(result.is_ok(), crash.is_none(), "{crash:?}: {result:?}");
            drop(j); // the crash: nothing more runs
            let (mut j, after, report) = Journal::open(dir.path()).unwrap();
            assert!(report.corrupt_lines.is_empty() && !report.truncated_tail);
            assert!(!dir.path().join(COMPACT_TMP).exists(), "{crash:?}");
            // Either the old journal, whole, or the compacted one: never a mix.
            match crash {
                Some(CrashPoint::MidTemporary | CrashPoint::BeforeRename) => {
                    assert_eq!(after, records, "{crash:?}");
                    assert_eq!(j.len_bytes(), full);
                }
                _ => assert_eq!(after, compacted, "{crash:?}"),
            }
            // Restarts derive the same fallen blocks and republished history.
            assert_eq!(derived(&after), derived(&records), "{crash:?}");
            // And appends go on after it.
            j.append(&reset("r")).unwrap();
            let (again, _) = read_journal(dir.path()).unwrap();
            assert_eq!(again.last(), Some(&reset("r")));
            assert_eq!(again.len(), after.len() + 1);
        }
    }

    #[test]
    fn the_writer_compacts_once_the_journal_passes_its_bound() {
        let records = long_journal();
        // Every append is synced: on tmpfs when there is one, so the test stays quick.
        let dir = tempfile::tempdir_in("/dev/shm")
            .or_else(|_| tempfile::tempdir())
            .unwrap();
        let (mut j, _, _) = Journal::open(dir.path()).unwrap();
        j.set_compact_at(1_000_000);
        let mut w = JournalWriter::new(j);
        let mut largest = 0;
        for r in &records {
            assert_eq!(w.append(r.clone()), Appended::Written);
            largest = largest.max(w.journal_mut().unwrap().len_bytes());
        }
        let size = std::fs::metadata(dir.path().join(JOURNAL_FILE))
            .unwrap()
            .len();
        // Bounded: never far beyond the bound, and compacted now.
        assert!(largest <= 1_000_000 + 400, "{largest}");
        assert!(size < 1_000_000, "{size}");
        assert_eq!(w.failures, 0);
        let (after, _) = read_journal(dir.path()).unwrap();
        // What is left: the last compaction's kept records plus what was appended since, all
        // within the 1 MB bound: under half of everything written (≈ 3 bounds' worth). How
        // far past the last compaction the appends went depends on the records' size, so the
        // margin is not tighter than that.
        assert!(
            after.len() < records.len() / 2,
            "{} of {}",
            after.len(),
            records.len()
        );
        assert_eq!(derived(&after), derived(&records));
    }
}
