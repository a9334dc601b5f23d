//! The ports between the node and its transports: what a transport takes in ([`Received`]),
//! what it publishes ([`Publication`] through a [`Publisher`]), what it sends when replaying
//! ([`PacketSink`]), and how another thread hands the node's event loop a settings change
//! ([`ControlSender`]).
//!
//! Architecture invariant: this module depends only on the engine's types (`rockwatch_core`)
//! and the transport-free status report (`status`); the transports (`ros2`, `iox`) and the
//! node (`node`) depend on it, never the reverse.

use std::sync::mpsc;

use rockwatch_core::engine::{
    AccelPacket, Alert, AlertConfig, MalformedStation, PbrState, ResetEvent, StationIntensity,
};

/// What an input transport (iceoryx2, ROS 2) hands the node for each packet it took: the
/// packet, its station id parsed at the edge by `engine::station_at_edge`; or the refusal of
/// a malformed id, which the node counts and says the same way whichever transport it came
/// by (`NodeRuntime::refuse_malformed`).
pub type Received = Result<AccelPacket, MalformedStation>;

/// Appended to the `message` of a ROS 2 `PbrAlert` published with `journal_pending` (the
/// message type has no flag field; changing it would break interoperability).
pub const JOURNAL_PENDING_NOTE: &str = " [journal pending: the node's state directory is failing]";

/// What a transport publishes.
#[derive(Debug, Clone, PartialEq)]
pub enum Publication {
    /// An alert, already journaled unless `journal_pending`; `latency_ns` = wall time now −
    /// arrival of the packet that triggered it.
    Alert {
        alert: Alert,
        latency_ns: i64,
        /// The state directory is failing (e.g. the disk is full): the alert is published
        /// before it could be journaled; it waits in memory and is journaled when the
        /// directory recovers (a crash before then loses it from the journal). On the wire:
        /// iceoryx2 `flags` bit [`crate::iox::ALERT_FLAG_JOURNAL_PENDING`], ROS 2 `message`
        /// suffix [`JOURNAL_PENDING_NOTE`].
        journal_pending: bool,
    },
    State(PbrState),
    Intensity(StationIntensity),
    /// An operator reset of a fallen block, already journaled: published with the alerts
    /// (ROS 2 `PbrAlert.level` RESET, iceoryx2 level code 4) so that a block's alert history
    /// ends in the truth.
    Reset(ResetEvent),
}

/// A transport's output side: publishes what the runtime hands it (alerts already journaled).
pub trait Publisher {
    /// Publishes one item; an error is logged (rate-limited) and the node goes on.
    fn publish(&mut self, publication: &Publication) -> anyhow::Result<()>;
}

/// Wakes an event loop from another thread.
pub use rockwatch_core::engine::sharded::Wake;

/// A settings change handed to the node's event loop by another thread (e.g. a ROS 2
/// parameter service).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Control {
    /// New alert thresholds.
    Alerts(AlertConfig),
    /// New state publication interval (s of data); ignored unless finite and > 0.
    StateIntervalS(f64),
}

/// A cloneable, thread-safe handle that queues settings changes for the node's event loop and
/// wakes it; the loop applies them before the next packet.
#[derive(Clone)]
pub struct ControlSender {
    tx: mpsc::Sender<Control>,
    wake: Wake,
}

impl ControlSender {
    /// A sender and the receiver the event loop drains; `wake` is called after each change.
    #[must_use]
    pub fn channel(wake: Wake) -> (ControlSender, mpsc::Receiver<Control>) {
        let (tx, rx) = mpsc::channel();
        (ControlSender { tx, wake }, rx)
    }

    /// Queues a change (dropped silently once the event loop has stopped).
    pub fn send(&self, control: Control) {
        if self.tx.send(control).is_ok() {
            (self.wake)();
        }
    }

    /// New alert thresholds, effective for the next packet.
    pub fn set_alert_config(&self, alerts: AlertConfig) {
        self.send(Control::Alerts(alerts));
    }

    /// New state publication interval (s of data), effective for the next packet.
    pub fn set_state_interval_s(&self, state_interval_s: f64) {
        self.send(Control::StateIntervalS(state_interval_s));
    }
}

/// A transport's replay side: where replayed packets go.
pub trait PacketSink {
    /// Waits until at least one subscriber is connected or `timeout` passes; true if connected.
    fn wait_for_subscriber(&mut self, timeout: std::time::Duration) -> anyhow::Result<bool>;
    /// Sends one packet.
    fn send(&mut self, packet: &AccelPacket) -> anyhow::Result<()>;
    /// Housekeeping while nothing is sent (a live sender calls it about every 100 ms), e.g.
    /// checking that the transport still runs. An error: the sink can no longer send.
    fn tick(&mut self) -> anyhow::Result<()> {
        Ok(())
    }
    /// Waits up to `timeout` until every connected subscriber has received everything sent
    /// (reliable transports acknowledge); true if it has. Call before the sink is dropped.
    fn finish(&mut self, timeout: std::time::Duration) -> anyhow::Result<bool> {
        let _ = timeout;
        Ok(true)
    }
    /// Publishes the sender's status (`rockwatch acquire`'s, about once a second) where the
    /// transport has a status channel — ROS 2: `/diagnostics` — and drops it elsewhere. Never
    /// waits on the transport. An error: this report was not published (sending goes on).
    fn status(&mut self, report: crate::status::StatusReport) -> anyhow::Result<()> {
        let _ = report;
        Ok(())
    }
}
