//! systemd's service notifications (sd_notify(3)) without libsystemd: one datagram per
//! notification to the socket named by `$NOTIFY_SOCKET` (a path, or `@name` in the abstract
//! namespace). A unit with `Type=notify` waits for `READY=1`; with `WatchdogSec=`, systemd
//! sets `$WATCHDOG_USEC` and restarts the service when no `WATCHDOG=1` comes for that long.
//!
//! The node sends `READY=1` once every input is subscribed, `WATCHDOG=1` from its event loop
//! every half watchdog period while the loop turns and its transports are up (a stalled loop
//! stops pinging: systemd then kills and restarts it), `RELOADING=1` … `READY=1` around a
//! SIGHUP reload and `STOPPING=1` when it stops. Without `$NOTIFY_SOCKET` nothing is sent.

use std::os::unix::net::{SocketAddr, UnixDatagram};
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context as _};

/// Environment variables of the protocol.
pub const NOTIFY_SOCKET_ENV: &str = "NOTIFY_SOCKET";
pub const WATCHDOG_USEC_ENV: &str = "WATCHDOG_USEC";
pub const WATCHDOG_PID_ENV: &str = "WATCHDOG_PID";

/// A connection to systemd's notification socket.
#[derive(Debug)]
pub struct SystemdNotifier {
    socket: UnixDatagram,
    addr: SocketAddr,
    /// How often to ping: half of `$WATCHDOG_USEC` (as sd_watchdog_enabled(3) advises).
    ping_every: Option<Duration>,
    last_ping: Option<Instant>,
    /// Failed sends (logged at powers of two).
    failures: u64,
}

impl SystemdNotifier {
    /// From the environment: `None` without `$NOTIFY_SOCKET` (not run by systemd with
    /// `Type=notify`); an error if it is set but unusable. The watchdog is on when
    /// `$WATCHDOG_USEC` is set (and `$WATCHDOG_PID`, if set, is this process).
    pub fn from_env() -> anyhow::Result<Option<SystemdNotifier>> {
        let Some(path) = std::env::var_os(NOTIFY_SOCKET_ENV) else {
            return Ok(None);
        };
        let path = path.to_string_lossy().into_owned();
        let addr = if let Some(name) = path.strip_prefix('@') {
            use std::os::linux::net::SocketAddrExt as _;
            SocketAddr::from_abstract_name(name.as_bytes())
        } else {
            SocketAddr::from_pathname(&path)
        }
        .with_context(|| format!("${NOTIFY_SOCKET_ENV}={path:?} is not a socket address"))?;
        let socket = UnixDatagram::unbound().context("cannot create the sd_notify socket")?;
        let for_us = std::env::var(WATCHDOG_PID_ENV)
            .ok()
            .is_none_or(|pid| pid.trim() == std::process::id().to_string());
        let ping_every = match std::env::var(WATCHDOG_USEC_ENV) {
            Ok(usec) if for_us => {
                let usec: u64 = usec.trim().parse().map_err(|_| {
                    anyhow!("${WATCHDOG_USEC_ENV}={usec:?} is not a number of microseconds")
                })?;
                (usec > 0).then(|| Duration::from_micros(usec / 2))
            }
            _ => None,
        };
        Ok(Some(SystemdNotifier {
            socket,
            addr,
            ping_every,
            last_ping: None,
            failures: 0,
        }))
    }

    /// Sends `state` (newline-separated `KEY=value` lines). A failure is logged (at powers of
    /// two) and the node goes on: systemd's watchdog then acts if it must.
    pub fn notify(&mut self, state: &str) {
        if let Err(e) = self.socket.send_to_addr(state.as_bytes(), &self.addr) {
            self.failures += 1;
            if self.failures.is_power_of_two() {
                tracing::info!(
                    "sd_notify: cannot send {:?} ({e}; {} failures in all)",
                    state.lines().next().unwrap_or(""),
                    self.failures
                );
            }
        }
    }

    /// `READY=1` with a status line.
    pub fn ready(&mut self, status: &str) {
        self.notify(&format!("READY=1\nSTATUS={status}"));
        self.last_ping = Some(Instant::now());
    }

    /// `RELOADING=1` (a reload starts; [`SystemdNotifier::ready`] ends it).
    pub fn reloading(&mut self) {
        self.notify("RELOADING=1\nSTATUS=reloading the configuration and catalogue");
    }

    /// `STOPPING=1`.
    pub fn stopping(&mut self) {
        self.notify("STOPPING=1\nSTATUS=stopping");
    }

    /// Sends `WATCHDOG=1` if half the watchdog period has passed since the last ping. Call it
    /// from the event loop on every turn while it is healthy.
    pub fn ping_if_due(&mut self) {
        let Some(every) = self.ping_every else {
            return;
        };
        if self.last_ping.is_none_or(|t| t.elapsed() >= every) {
            self.notify("WATCHDOG=1");
            self.last_ping = Some(Instant::now());
        }
    }
}
