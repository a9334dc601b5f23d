//! Signals on one thread: the stop signals (and the node's reload signal, SIGHUP) are blocked
//! in every thread and taken by one dedicated thread (`sigwait`), which sets a flag.
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

/// The signals the signal thread takes (SIGHUP stops the tools, the terminal went away; the
/// node reloads on it, see [`NodeSignals`]).
pub const STOP_SIGNALS: [Signal; 3] = [Signal::SIGINT, Signal::SIGTERM, Signal::SIGHUP];

/// Blocks [`STOP_SIGNALS`] on the calling thread (and so on every thread it starts later)
/// and starts the thread `rockwatch-signals` that waits for them: the first sets the returned
/// flag and logs one line naming the signal. Call it first thing, before any other thread.
pub fn stop_on_signals() -> anyhow::Result<Arc<AtomicBool>> {
    Ok(take_signals(false)?.stop)
}

/// The node's signal flags: SIGINT and SIGTERM set `stop`; SIGHUP sets `reload` (read the
/// configuration and catalogue again, see `node::serve`), which the event loop clears when it
/// takes the request.
#[derive(Debug, Clone)]
pub struct NodeSignals {
    pub stop: Arc<AtomicBool>,
    pub reload: Arc<AtomicBool>,
}

/// As [`stop_on_signals`], with SIGHUP a reload request instead of a stop (the node under
/// systemd: `ExecReload=kill -HUP $MAINPID`).
pub fn node_signals() -> anyhow::Result<NodeSignals> {
    take_signals(true)
}

fn take_signals(reload_on_hup: bool) -> anyhow::Result<NodeSignals> {
    let mut set = SigSet::empty();
    for s in STOP_SIGNALS {
        set.add(s);
    }
    set.thread_block()
        .context("cannot block SIGINT/SIGTERM/SIGHUP")?;
    let flags = NodeSignals {
        stop: Arc::new(AtomicBool::new(false)),
        reload: Arc::new(AtomicBool::new(false)),
    };
    let theirs = flags.clone();
    std::thread::Builder::new()
        .name("rockwatch-signals".into())
        .spawn(move || loop {
            match set.wait() {
                Ok(Signal::SIGHUP) if reload_on_hup => {
                    let again = theirs.reload.swap(true, Ordering::Relaxed);
                    tracing::info!(
                        "SIGHUP: {}",
                        if again {
                            "a reload is already pending"
                        } else {
                            "reloading the configuration and the catalogue between packets"
                        }
                    );
                }
                Ok(signal) => {
                    let again = theirs.stop.swap(true, Ordering::Relaxed);
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
                    theirs.stop.store(true, Ordering::Relaxed);
                    return;
                }
            }
        })
        .context("cannot start the signal thread")?;
    Ok(flags)
}

/// The line a bus error writes on stderr before the process ends (exit status 1).
pub const BUS_ERROR_MESSAGE: &str = "rockwatch: error: bus error (SIGBUS): memory mapped from a \
file could not be backed: most likely an iceoryx2 shared-memory segment in /dev/shm, whose file \
system is full (another user may be filling it; `df /dev/shm`); the process ends\n";

/// Reports a bus error (SIGBUS) with one line on stderr ([`BUS_ERROR_MESSAGE`]) and ends the
/// process with status 1, instead of dying silently with status 135: a full `/dev/shm` cannot
/// back the pages of an iceoryx2 segment mapped before it filled, and touching them faults
/// (issue 24 item 7; another user can fill a world-writable /dev/shm). Process-wide; call it
/// once, early. A fault signal goes to the thread that faulted, whatever the signal mask, so
/// this does not disturb the one-thread rule of the stop signals.
pub fn report_bus_errors() -> anyhow::Result<()> {
    use nix::libc;
    use nix::sys::signal::{sigaction, SaFlags, SigAction, SigHandler};
    extern "C" fn on_bus_error(_: libc::c_int) {
        let message = BUS_ERROR_MESSAGE.as_bytes();
        // SAFETY: write(2) and _exit(2) are async-signal-safe (signal-safety(7)); `message`
        // is a static buffer of `len` bytes; the handler never returns to the faulting access.
        unsafe {
            libc::write(2, message.as_ptr().cast(), message.len());
            libc::_exit(1);
        }
    }
    let action = SigAction::new(
        SigHandler::Handler(on_bus_error),
        SaFlags::empty(),
        SigSet::empty(),
    );
    // SAFETY: the handler calls only async-signal-safe functions and ends the process; nix
    // requires `unsafe` for installing any handler.
    unsafe { sigaction(Signal::SIGBUS, &action) }.context("cannot install the SIGBUS handler")?;
    Ok(())
}
