//! The node's status on `/diagnostics` (`diagnostic_msgs/msg/DiagnosticArray`, about once a
//! second) and its log records on `/rosout` (`rcl_interfaces/msg/Log`); the one
//! `/diagnostics` writer ([`DiagnosticsWriter`]), also `rockwatch acquire`'s (through its
//! ROS 2 sink, `packet_sink.rs`).
//!
//! The `diagnostic_msgs` structs below are in CDR field order, exactly as the message
//! definitions of ROS 2 (checked against an independent rclpy peer by
//! `tests/ros2_diagnostics.rs`):
//! - `DiagnosticArray`: `std_msgs/Header header`, `DiagnosticStatus[] status`;
//! - `DiagnosticStatus`: `byte level` (OK=0, WARN=1, ERROR=2, STALE=3), `string name`,
//!   `string message`, `string hardware_id`, `KeyValue[] values`;
//! - `KeyValue`: `string key`, `string value`.
//!
//! Names follow diagnostic_updater: `<program>: <item>` (`rockwatch: station CI.RRS.00`,
//! `rockwatch: journal`, `rockwatch acquire: link`, …), the station id as `hardware_id`.

use anyhow::anyhow;
use ros2_client::builtin_interfaces::Time;
use ros2_client::dds::RosoutRaw;
use ros2_client::{Log, MessageTypeName, Name, QosProfile};
use serde::{Deserialize, Serialize};

use super::msg::Header;
use super::names::{DIAGNOSTICS_TOPIC, NODE_NAME};
use super::qos::output_qos;
use super::session::Ros2Session;
use crate::logging::RosoutRecord;
use crate::status::{NodeStatus, StatusReport};

/// `diagnostic_msgs/KeyValue`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct KeyValue {
    pub key: String,
    pub value: String,
}

/// `diagnostic_msgs/DiagnosticStatus`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// OK=0, WARN=1, ERROR=2, STALE=3.
    pub level: u8,
    pub name: String,
    pub message: String,
    pub hardware_id: String,
    pub values: Vec<KeyValue>,
}

/// `diagnostic_msgs/DiagnosticArray`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// stamp: UTC of the report; frame_id empty.
    pub header: Header,
    pub status: Vec<DiagnosticStatus>,
}

impl ros2_client::Message for DiagnosticArray {}

impl From<&NodeStatus> for DiagnosticArray {
    fn from(status: &NodeStatus) -> DiagnosticArray {
        DiagnosticArray::from(StatusReport {
            stamp_ns: status.stamp_ns,
            prefix: NODE_NAME,
            items: status.items(),
        })
    }
}

impl From<StatusReport> for DiagnosticArray {
    fn from(report: StatusReport) -> DiagnosticArray {
        DiagnosticArray {
            header: Header::new(report.stamp_ns, ""),
            status: report
                .items
                .into_iter()
                .map(|item| DiagnosticStatus {
                    level: item.level.diagnostic_level(),
                    name: format!("{}: {}", report.prefix, item.name),
                    message: item.message,
                    hardware_id: item.hardware_id,
                    values: item
                        .values
                        .into_iter()
                        .map(|(key, value)| KeyValue { key, value })
                        .collect(),
                })
                .collect(),
        }
    }
}

/// A writer of `/diagnostics` (absolute, as diagnostic_updater's) on a session's node: the
/// node's ([`StatusPublisher`]) and `rockwatch acquire`'s.
pub struct DiagnosticsWriter {
    publisher: ros2_client::Publisher<DiagnosticArray>,
}

impl DiagnosticsWriter {
    /// Creates the `/diagnostics` topic and publisher on `session`'s node with `qos` (the
    /// node: [`output_qos`]; acquire: [`super::qos::sender_status_qos`], which never waits).
    pub(super) fn open(session: &mut Ros2Session, qos: QosProfile) -> anyhow::Result<Self> {
        let name =
            Name::parse(DIAGNOSTICS_TOPIC).map_err(|e| anyhow!("{DIAGNOSTICS_TOPIC}: {e:?}"))?;
        let topic = session
            .node
            .create_topic(
                &name,
                MessageTypeName::new("diagnostic_msgs", "DiagnosticArray"),
                &qos,
            )
            .map_err(|e| anyhow!("ROS 2 topic {DIAGNOSTICS_TOPIC}: {e:?}"))?;
        let publisher = session
            .node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| anyhow!("ROS 2 publisher {DIAGNOSTICS_TOPIC}: {e:?}"))?;
        Ok(DiagnosticsWriter { publisher })
    }

    /// Publishes `array`; an error is the middleware's reason it did not (the caller logs it).
    pub fn publish(&self, array: DiagnosticArray) -> anyhow::Result<()> {
        self.publisher.publish(array).map_err(|e| anyhow!("{e:?}"))
    }
}

/// The publisher of `/diagnostics` and the node's `/rosout` writer.
pub struct StatusPublisher {
    diagnostics: DiagnosticsWriter,
    rosout: std::sync::Arc<Option<ros2_client::Publisher<Log>>>,
    /// The `name` of the node's `/rosout` records.
    logger: String,
    errors: u64,
}

impl StatusPublisher {
    /// Creates the `/diagnostics` publisher on `session`'s node and takes its `/rosout` writer
    /// (present when the node was made with `/rosout` enabled).
    pub(super) fn open(session: &mut Ros2Session) -> anyhow::Result<Self> {
        let diagnostics = DiagnosticsWriter::open(session, output_qos())?;
        // rcl's logger name: the namespace's parts and the node name (after remaps) joined
        // by dots.
        let naming = session.naming();
        let logger = naming
            .namespace()
            .split('/')
            .filter(|p| !p.is_empty())
            .chain(std::iter::once(naming.node()))
            .collect::<Vec<_>>()
            .join(".");
        Ok(StatusPublisher {
            diagnostics,
            rosout: session.node.rosout_writer(),
            logger,
            errors: 0,
        })
    }

    /// Publishes `status` on `/diagnostics`; a failure is logged (every power of two).
    pub fn publish_status(&mut self, status: &NodeStatus) {
        if let Err(e) = self.diagnostics.publish(DiagnosticArray::from(status)) {
            self.failed(DIAGNOSTICS_TOPIC, &format!("{e:#}"));
        }
    }

    /// Publishes `records` on `/rosout` (nothing if the node has no `/rosout` writer).
    pub fn publish_rosout(&mut self, records: &mut Vec<RosoutRecord>) {
        let Some(writer) = self.rosout.as_ref().as_ref() else {
            records.clear();
            return;
        };
        let mut failed = None;
        for r in records.drain(..) {
            let log = Log {
                stamp: Time::from_nanos(r.stamp_ns),
                level: r.level,
                name: self.logger.clone(),
                msg: r.message,
                file: r.file,
                function: r.target,
                line: r.line,
            };
            if let Err(e) = writer.publish(log) {
                failed = Some(format!("{e:?}"));
            }
        }
        if let Some(e) = failed {
            self.failed("/rosout", &e);
        }
    }

    fn failed(&mut self, topic: &str, error: &str) {
        self.errors += 1;
        if self.errors.is_power_of_two() {
            // Not at warn level: a record about /rosout must not feed /rosout in a loop.
            eprintln!(
                "rockwatch: warning: ROS 2 {topic}: cannot publish ({error}; {} failures in all)",
                self.errors
            );
        }
    }
}
