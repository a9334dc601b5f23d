//! Signals on one thread: the node's stop signals are blocked in every thread and taken by
//! one dedicated thread (`sigwait`), which sets a stop flag.
//!
//! RustDDS 0.15.1 ends its event-loop and discovery threads on any error of their poll,
//! EINTR included: a signal delivered to one of them (the kernel picks any thread that does
//! not block it) would silently end the DDS participant. The mask is inherited by every thread
//! started afterwards, so [`stop_on_signals`] must run before the first other thread (before
//! any DDS participant, engine worker or iceoryx2 node). A stop/continue (SIGSTOP, SIGCONT,
//! a debugger attach) still interrupts `epoll_wait` without any handler (signal(7)); that case
//! is caught by the participant watchdog (`ros2::DdsThreads`) and the participant rebuilt.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::Context;
use nix::sys::signal::{SigSet, Signal};

/// The signals that stop the node (SIGHUP too: the terminal went away).
pub const STOP_SIGNALS: [Signal; 3] = [Signal::SIGINT, Signal::SIGTERM, Signal::SIGHUP];

/// Blocks [`STOP_SIGNALS`] on the calling thread (and so on every thread it starts later)
/// and starts the thread `rockwatch-signals` that waits for them: the first sets the returned
/// flag and logs one line naming the signal. Call it first thing, before any other thread.
pub fn stop_on_signals() -> anyhow::Result<Arc<AtomicBool>> {
    let mut set = SigSet::empty();
    for s in STOP_SIGNALS {
        set.add(s);
    }
    set.thread_block()
        .context("cannot block SIGINT/SIGTERM/SIGHUP")?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    std::thread::Builder::new()
        .name("rockwatch-signals".into())
        .spawn(move || loop {
            match set.wait() {
                Ok(signal) => {
                    let again = flag.swap(true, Ordering::Relaxed);
                    tracing::info!(
                        "{signal}: {}",
                        if again {
                            "already stopping"
                        } else {
                            "stopping (finishing the packets taken, then exiting)"
                        }
                    );
                }
                Err(e) => {
                    tracing::error!("waiting for signals failed ({e}): stopping");
                    flag.store(true, Ordering::Relaxed);
                    return;
                }
            }
        })
        .context("cannot start the signal thread")?;
    Ok(stop)
}
