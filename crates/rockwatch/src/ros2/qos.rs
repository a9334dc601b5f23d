//! The QoS profiles of the node's topics and service, of its inputs and of the replay writer.

use std::time::Duration;

use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::QosProfile;

use super::config::InputQos;

/// QoS of `/pbr/alerts`: reliable, transient local, keep last
/// [`HISTORY_ALERTS`](crate::journal::HISTORY_ALERTS) (the journal's alert history).
#[must_use]
pub fn alerts_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(1)))
        .durability(Durability::TransientLocal)
        .history(History::KeepLast {
            depth: crate::journal::HISTORY_ALERTS,
        })
}

/// QoS of `/pbr/state` and `/pbr/ims`: reliable, volatile, keep last 100.
#[must_use]
pub fn output_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 100 })
}

/// QoS of `pbr/markers` and `/tf_static`: reliable, transient local, keep last 1 (tf2's
/// static broadcaster's profile): a subscriber that joins late gets the last array, which is
/// the whole picture. A full writer fails the publication at once (the view is sent again at
/// the next tick) instead of making the event loop wait.
#[must_use]
pub fn view_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Fail)
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// QoS of a sender's status on `/diagnostics` (`rockwatch acquire`): that of
/// [`output_qos`], but a send window full of unacknowledged reports (a slow subscriber) fails
/// the publication at once ([`WhenFull::Fail`]) instead of waiting: the acquisition loop
/// never waits on DDS for its status (the report is lost, counted and logged).
#[must_use]
pub fn sender_status_qos() -> QosProfile {
    output_qos().reliability_reliable(WhenFull::Fail)
}

/// QoS of `/pbr/intake` (both ends): reliable, volatile, keep last 100.
#[must_use]
pub fn intake_qos() -> QosProfile {
    output_qos()
}

/// QoS of an input subscription: `kind`, with `depth` for the reliable one.
#[must_use]
pub fn input_qos(kind: InputQos, depth: usize) -> QosProfile {
    match kind {
        InputQos::Reliable => QosProfile::subscription_default()
            .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
            .history(History::KeepLast {
                depth: depth.max(1),
            }),
        // Best effort as the ROS 2 sensor-data profile, but with the deep history of the
        // reliable one: the reader's depth does not affect matching, and the node's event loop
        // may be busy for a moment (an alert's fsync) while a 200 Hz Imu keeps sending.
        InputQos::SensorData => QosProfile::subscription_default()
            .reliability(Reliability::BestEffort)
            .history(History::KeepLast {
                depth: depth.max(1),
            }),
    }
}

/// QoS of the reset service's requests and responses: ROS 2's services default (reliable,
/// volatile, keep last 10).
#[must_use]
pub fn service_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// History depth of the replay writer: twice the replay's credit window
/// (`CREDIT_WINDOW`), so it holds every packet the node may not have taken yet.
pub const REPLAY_HISTORY: usize = 512;

/// QoS of the replay publisher: reliable, transient local, keep last [`REPLAY_HISTORY`].
/// The replay never has more than half of that unreported by the node (flow control on
/// `/pbr/intake`), so nothing the node has not taken is dropped from the history; transient
/// local makes the writer hand its history to a reader that matches late — the node's new
/// reader after its participant was rebuilt, which gets the packets its dead reader lost (and
/// skips those it had, by their DDS sequence numbers).
#[must_use]
pub fn replay_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(5)))
        .durability(Durability::TransientLocal)
        .history(History::KeepLast {
            depth: REPLAY_HISTORY,
        })
}
