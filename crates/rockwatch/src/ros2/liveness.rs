//! Liveness of a DDS participant: the threads RustDDS started for it ([`DdsThreads`]).
//!
//! RustDDS 0.15.1 runs each participant on two threads, "RustDDS discovery thread" and
//! "RustDDS Participant N event loop", and ends either of them for good on any error of its
//! poll — EINTR included, which Linux returns from `epoll_wait` after a stop/continue
//! (SIGSTOP/SIGCONT, a debugger attach) even without a signal handler (signal(7)). The
//! participant then looks alive to its owner while it neither sends, receives nor discovers.
//! Their join handles are private, so the participant's threads are found as the threads
//! named `RustDDS…` that appeared in `/proc/self/task` while it was built (builds are
//! serialised in the process), and each is alive while `/proc/self/task/<tid>/comm` still
//! names it.

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::sync::Mutex;

/// Serialises participant builds, so that the threads that appear belong to the one built.
static BUILD: Mutex<()> = Mutex::new(());

/// The threads of one DDS participant.
#[derive(Debug, Clone, Default)]
pub struct DdsThreads {
    /// (thread id, name as in `comm`).
    threads: Vec<(u32, String)>,
}

fn task_dir() -> PathBuf {
    PathBuf::from("/proc/self/task")
}

fn comm(tid: u32) -> Option<String> {
    std::fs::read_to_string(task_dir().join(tid.to_string()).join("comm"))
        .ok()
        .map(|s| s.trim_end().to_string())
}

fn tids() -> BTreeSet<u32> {
    std::fs::read_dir(task_dir())
        .map(|dir| {
            dir.filter_map(|e| e.ok()?.file_name().to_str()?.parse().ok())
                .collect()
        })
        .unwrap_or_default()
}

impl DdsThreads {
    /// Runs `build` (which creates one DDS participant) and returns its result with the
    /// RustDDS threads that appeared meanwhile. Without `/proc` (not Linux) no thread is
    /// found and [`DdsThreads::ended`] never reports one.
    pub fn spawned_by<T>(build: impl FnOnce() -> T) -> (T, DdsThreads) {
        let _serial = BUILD
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let before = tids();
        let built = build();
        let threads = tids()
            .difference(&before)
            .filter_map(|&tid| Some((tid, comm(tid)?)))
            .filter(|(_, name)| name.starts_with("RustDDS"))
            .collect();
        (built, DdsThreads { threads })
    }

    /// Number of participant threads watched (2 with RustDDS 0.15.1 on Linux).
    #[must_use]
    pub fn watched(&self) -> usize {
        self.threads.len()
    }

    /// The first of the participant's threads that has ended, as "NAME (thread TID)".
    #[must_use]
    pub fn ended(&self) -> Option<String> {
        self.threads
            .iter()
            .find(|(tid, name)| comm(*tid).as_deref() != Some(name.as_str()))
            .map(|(tid, name)| format!("{name:?} (thread {tid})"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_that_ends_is_reported() {
        let (stop, watch) = DdsThreads::spawned_by(|| {
            let (tx, rx) = std::sync::mpsc::channel::<()>();
            let handle = std::thread::Builder::new()
                .name("RustDDS test".into())
                .spawn(move || {
                    let _ = rx.recv();
                })
                .unwrap();
            // comm is set by the new thread itself: wait until it shows.
            while !tids()
                .iter()
                .any(|&t| comm(t).as_deref() == Some("RustDDS test"))
            {
                std::thread::yield_now();
            }
            (tx, handle)
        });
        assert_eq!(watch.watched(), 1, "{watch:?}");
        assert_eq!(watch.ended(), None);
        drop(stop.0);
        stop.1.join().unwrap();
        assert!(watch.ended().unwrap().contains("RustDDS test"));
    }
}
