//! Replay over ROS 2 ([`Ros2PacketSink`]): `/pbr/accel` published from a node
//! `rockwatch_replay`, with a writer that knows when the node has received everything.

use std::time::{Duration, Instant};

use anyhow::anyhow;
use ros2_client::dds::rustdds::{no_key, DataWriterStatus, StatusEvented};

use super::msg;
use super::names::ACCEL_TOPIC;
use super::network::NetworkPlan;
use super::qos::replay_qos;
use super::session::Ros2Session;
use crate::ports::PacketSink;
use rockwatch_core::engine::AccelPacket;

/// How long a replay's writer stays after the node has acknowledged every packet (see
/// [`Ros2PacketSink`]'s `finish`).
pub const REPLAY_LINGER: Duration = Duration::from_secs(1);

/// Replay over ROS 2: publishes `/pbr/accel` from a node `rockwatch_replay`.
///
/// The writer is a plain RustDDS data writer on the node's participant and ROS 2 topic
/// (ros2-client's `Publisher` hides it), because a replay must know that the subscriber has
/// *received* what was sent before it exits: discovery is two-sided, and the writer can see
/// the node's reader before the reader has matched the writer; samples sent in that window
/// are only repaired later by the reliable protocol (the reader asks for everything from the
/// writer's first sequence number once it matches), which needs the writer alive.
/// [`PacketSink::finish`] waits for every matched reader's acknowledgement, then
/// [`REPLAY_LINGER`], because the node's DDS reader discards the samples of a writer that has
/// left which the node has not yet taken (a RustDDS 0.15.1 defect). The writer is not
/// listed under the node in the ROS 2 graph (`ros2 topic info` shows the publisher without
/// its node name).
pub struct Ros2PacketSink {
    _session: Ros2Session,
    writer: no_key::DataWriterCdr<msg::AccelPacket>,
    /// Readers matched now, from the writer's publication-matched status events.
    matched: i32,
    /// A matched reader went away (the node stopped or died mid-replay).
    lost_reader: bool,
}

impl Ros2PacketSink {
    pub fn open(plan: &NetworkPlan, namespace: &str) -> anyhow::Result<Ros2PacketSink> {
        let mut session = Ros2Session::open_client(plan, namespace, "rockwatch_replay")?;
        let qos = replay_qos();
        let topic = session.topic(ACCEL_TOPIC, msg::PACKAGE, "AccelPacket", &qos)?;
        let dds_qos = ros2_client::dds::rustdds::QosPolicies::from(qos);
        let writer = session
            .context
            .domain_participant()
            .create_publisher(&dds_qos)
            .and_then(|p| p.create_datawriter_no_key_cdr(&topic, Some(dds_qos.clone())))
            .map_err(|e| anyhow!("ROS 2 publisher {ACCEL_TOPIC}: {e:?}"))?;
        Ok(Ros2PacketSink {
            _session: session,
            writer,
            matched: 0,
            lost_reader: false,
        })
    }

    /// Sends a raw message (tests of malformed input).
    pub fn send_msg(&mut self, m: msg::AccelPacket) -> anyhow::Result<()> {
        self.writer
            .write(m, Some(ros2_client::dds::rustdds::Timestamp::now()))
            .map_err(|e| anyhow!("ROS 2 publish on {ACCEL_TOPIC}: {e:?}"))
    }

    /// Readers matched now (after taking the writer's pending status events).
    fn matched_readers(&mut self) -> i32 {
        while let Some(status) = self.writer.try_recv_status() {
            if let DataWriterStatus::PublicationMatched { current, .. } = status {
                self.matched = current.count();
                self.lost_reader |= current.count_change() < 0;
            }
        }
        self.matched
    }
}

impl PacketSink for Ros2PacketSink {
    fn wait_for_subscriber(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        let deadline = Instant::now() + timeout;
        loop {
            if self.matched_readers() > 0 {
                return Ok(true);
            }
            if Instant::now() >= deadline {
                return Ok(false);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn send(&mut self, packet: &AccelPacket) -> anyhow::Result<()> {
        self.send_msg(msg::AccelPacket::from(packet))
    }

    fn finish(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        // RustDDS also reports "acknowledged" when no reader is left: a reader that went
        // away mid-replay (the node stopped or died) means it has not got everything.
        let acknowledged = self
            .writer
            .wait_for_acknowledgments(timeout)
            .map_err(|e| anyhow!("ROS 2 {ACCEL_TOPIC}: waiting for acknowledgements: {e:?}"))?
            && self.matched_readers() > 0
            && !self.lost_reader;
        // An acknowledged sample sits in the node's reader cache until the node takes it, and
        // RustDDS 0.15.1 makes the unread samples of a writer that has left unreadable
        // (`forget_reliable_writer` drops the writer's delivery marker): stay a moment so the
        // node, even when busy, takes everything before this writer goes.
        std::thread::sleep(REPLAY_LINGER);
        Ok(acknowledged)
    }
}
