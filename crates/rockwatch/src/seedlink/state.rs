//! The resume state of a SeedLink client in the state directory: per station the last
//! sequence number committed (and the protocol it belongs to), per stream the latest record
//! start time delivered, and per stream of which nothing is committed yet the start of the
//! first record received. Written atomically (temporary file, then rename), so a crash leaves
//! the previous or the new state, never a torn one.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use rockwatch_core::seedlink::Protocol;

/// Why the resume state could not be read or written; each names the file (the cause is in
/// the message, not a `source`: `{:#}` prints it once).
#[derive(Debug, thiserror::Error)]
pub enum StateFileError {
    #[error("{}: cannot read: {error}", path.display())]
    Read {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{}: not a SeedLink state file: {error}", path.display())]
    Format {
        path: PathBuf,
        error: serde_json::Error,
    },
    #[error("{}: belongs to server {found:?}, not {expected:?} (move it away to start afresh)", path.display())]
    OtherServer {
        path: PathBuf,
        found: String,
        expected: String,
    },
    #[error("{}: cannot write: {error}", path.display())]
    Write {
        path: PathBuf,
        error: std::io::Error,
    },
}

/// What a client needs to resume.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResumeState {
    /// The server the state belongs to (another server's numbers mean nothing).
    pub server: String,
    /// When that server started (its INFO ID `started`), if it says.
    #[serde(default)]
    pub server_started: Option<String>,
    /// `NET_STA` → last sequence number committed.
    pub stations: BTreeMap<String, StationResume>,
    /// `NET.STA.LOC.CHA` → start of the latest record delivered (ns since the epoch, UTC).
    pub streams: BTreeMap<String, i64>,
    /// `NET.STA.LOC.CHA` → start of the earliest record received (ns since the epoch, UTC)
    /// of a stream nothing of which is committed yet (its records are held, e.g. waiting for
    /// the other components): a station with no committed point resumes from here, so an
    /// `acquire` killed before its first publication fetches again what it had received.
    /// Dropped once the stream has a committed record (`streams`). Absent in files written
    /// before it existed.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub received: BTreeMap<String, i64>,
}

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StationResume {
    pub sequence: u64,
    pub protocol: Protocol,
}

/// The state file of one server in a state directory.
#[derive(Debug, Clone)]
pub struct StateFile {
    path: PathBuf,
}

impl StateFile {
    /// `DIR/seedlink-HOST_PORT.json` for `server` (characters other than letters, digits,
    /// `.`, `-` become `_`).
    #[must_use]
    pub fn in_dir(dir: &Path, server: &str) -> StateFile {
        let name: String = server
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '.' || c == '-' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        StateFile {
            path: dir.join(format!("seedlink-{name}.json")),
        }
    }

    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The saved state; empty when there is none yet. A file that cannot be read or parsed
    /// is an error naming it (never silently reset: that would re-deliver or lose data).
    pub fn load(&self, server: &str) -> Result<ResumeState, StateFileError> {
        let path = || self.path.clone();
        let text = match std::fs::read_to_string(&self.path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Ok(ResumeState {
                    server: server.to_string(),
                    ..ResumeState::default()
                })
            }
            Err(error) => {
                return Err(StateFileError::Read {
                    path: path(),
                    error,
                })
            }
        };
        let state: ResumeState =
            serde_json::from_str(&text).map_err(|error| StateFileError::Format {
                path: path(),
                error,
            })?;
        if state.server != server {
            return Err(StateFileError::OtherServer {
                path: path(),
                found: state.server,
                expected: server.to_owned(),
            });
        }
        Ok(state)
    }

    /// Replaces the file with `state` atomically; `durable` also syncs it and its directory
    /// to disk (a rename alone survives a crash of the process, not of the machine).
    pub fn save(&self, state: &ResumeState, durable: bool) -> Result<(), StateFileError> {
        let fail = |error: std::io::Error| StateFileError::Write {
            path: self.path.clone(),
            error,
        };
        let tmp = self.path.with_extension("json.tmp");
        let mut file = std::fs::File::create(&tmp).map_err(fail)?;
        let text = serde_json::to_vec_pretty(state).map_err(|e| fail(std::io::Error::other(e)))?;
        file.write_all(&text).map_err(fail)?;
        if durable {
            file.sync_all().map_err(fail)?;
        }
        drop(file);
        std::fs::rename(&tmp, &self.path).map_err(fail)?;
        if durable {
            if let Some(dir) = self.path.parent() {
                std::fs::File::open(dir)
                    .and_then(|d| d.sync_all())
                    .map_err(fail)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_round_trips_and_belongs_to_its_server() {
        let dir = tempfile::tempdir().unwrap();
        let file = StateFile::in_dir(dir.path(), "127.0.0.1:18000");
        assert!(file.path().ends_with("seedlink-127.0.0.1_18000.json"));
        let empty = file.load("127.0.0.1:18000").unwrap();
        assert!(empty.stations.is_empty());
        let mut state = empty.clone();
        state.stations.insert(
            "XX_STN".into(),
            StationResume {
                sequence: 0xFF_FFFF,
                protocol: Protocol::V3,
            },
        );
        state
            .streams
            .insert("XX.STN..HN1".into(), 1_027_313_215_794_233_025);
        state
            .received
            .insert("XX.STN..HN2".into(), 1_027_313_215_000_000_000);
        file.save(&state, true).unwrap();
        assert_eq!(file.load("127.0.0.1:18000").unwrap(), state);
        let e = file.load("other:1").unwrap_err();
        assert!(
            matches!(e, StateFileError::OtherServer { .. })
                && e.to_string().contains("belongs to server"),
            "{e}"
        );
        // A file of an older acquire (no `received`) still loads.
        std::fs::write(
            file.path(),
            r#"{"server":"127.0.0.1:18000","stations":{},"streams":{"XX.STN..HN1":5}}"#,
        )
        .unwrap();
        let old = file.load("127.0.0.1:18000").unwrap();
        assert_eq!((old.streams.len(), old.received.len()), (1, 0));
        std::fs::write(file.path(), "{").unwrap();
        let e = file.load("127.0.0.1:18000").unwrap_err();
        assert!(
            matches!(e, StateFileError::Format { .. })
                && e.to_string().contains("not a SeedLink state file"),
            "{e}"
        );
    }
}
