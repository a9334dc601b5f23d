//! The node's ROS 2 inputs: the subscriptions to `/pbr/accel` and to the configured
//! `sensor_msgs/msg/Imu` topics, drained by the node's event loop, and the intake's counters
//! (packets taken, undecodable messages, the latter logged at most once per 10 s).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::anyhow;
use ros2_client::dds::rustdds::mio1::{Interest, Registry, Token};
use ros2_client::Subscription;

use super::config::{ImuInput, Ros2Config};
use super::imu::{imu_packet, ImuMsg};
use super::msg;
use super::names::accel_topic;
use super::qos::input_qos;
use super::session::Ros2Session;
use crate::intake::{Taken, WriterCounts};
use crate::ports::Received;
use rockwatch_core::engine::{AccelPacket, Source};
use rockwatch_core::partition::Partition;

/// Counters of the node's ROS 2 intake.
#[derive(Debug, Default)]
pub struct IntakeCounters {
    /// Packets received and handed to the engine.
    pub packets: AtomicU64,
    /// Messages that could not be decoded (reported by DDS as read errors).
    pub decode_errors: AtomicU64,
    /// Messages of `/pbr/accel` taken again (a writer's history handed to the reader of a
    /// rebuilt participant), recognised by their DDS sequence numbers and skipped.
    pub redelivered: AtomicU64,
}

/// Counts what the intake takes and logs undecodable messages (at most one line per 10 s).
pub(super) struct IntakeLog {
    counters: Arc<IntakeCounters>,
    /// Messages of `/pbr/accel` taken per writer (reported on `/pbr/intake`).
    pub(super) writers: WriterCounts,
    last_error_report: Option<Instant>,
}

impl IntakeLog {
    pub(super) fn new(counters: Arc<IntakeCounters>, writers: WriterCounts) -> IntakeLog {
        IntakeLog {
            counters,
            writers,
            last_error_report: None,
        }
    }

    fn packet(&self) {
        self.counters.packets.fetch_add(1, Ordering::Relaxed);
    }

    /// Counts an undecodable message of `what` (a topic or service) and logs `error`.
    pub(super) fn undecodable(&mut self, what: &str, error: &str) {
        let n = self.counters.decode_errors.fetch_add(1, Ordering::Relaxed) + 1;
        if self
            .last_error_report
            .is_none_or(|t| t.elapsed() >= Duration::from_secs(10))
        {
            tracing::warn!("ROS 2 {what}: undecodable message ({error}; {n} in all)");
            self.last_error_report = Some(Instant::now());
        }
    }
}

/// The input subscriptions: `pbr/accel` or the partition's `pbr/accel/p<i>of<N>` (input 0),
/// then the Imu topics (inputs 1..).
pub(super) struct Inputs {
    accel: Subscription<msg::AccelPacket>,
    /// Name of input 0.
    accel_topic: String,
    /// Imu inputs with the sequence number of their next one-sample packet.
    imus: Vec<(ImuInput, Subscription<ImuMsg>, u64)>,
}

impl Inputs {
    /// Subscribes `/pbr/accel` (`partition`: its own topic) and every configured Imu topic on
    /// `session`'s node.
    pub(super) fn subscribe(
        session: &mut Ros2Session,
        config: &Ros2Config,
        partition: Option<Partition>,
    ) -> anyhow::Result<Inputs> {
        let accel_topic = accel_topic(partition);
        let accel: Subscription<msg::AccelPacket> = session.subscription(
            &accel_topic,
            msg::PACKAGE,
            "AccelPacket",
            input_qos(config.input_qos, config.input_depth),
        )?;
        let mut imus = Vec::new();
        for imu in &config.imu {
            if !(imu.sample_rate_hz.is_finite() && imu.sample_rate_hz > 0.0) {
                return Err(anyhow!(
                    "[[ros2.imu]] {}: sample_rate_hz must be > 0",
                    imu.topic
                ));
            }
            let qos = input_qos(imu.qos, config.input_depth);
            let sub: Subscription<ImuMsg> =
                session.subscription(&imu.topic, "sensor_msgs", "Imu", qos)?;
            imus.push((imu.clone(), sub, 0));
        }
        Ok(Inputs {
            accel,
            accel_topic,
            imus,
        })
    }

    /// The GUID (rmw gid) of the `/pbr/accel` subscription.
    pub(super) fn accel_gid(&self) -> [u8; 16] {
        self.accel.gid().to_bytes16()
    }

    /// Number of input subscriptions.
    pub(super) fn len(&self) -> usize {
        1 + self.imus.len()
    }

    /// Registers input `i` with `registry` as `Token(first + i)`, readable.
    pub(super) fn register(&mut self, registry: &Registry, first: usize) -> std::io::Result<()> {
        registry.register(&mut self.accel, Token(first), Interest::READABLE)?;
        for (i, (_, sub, _)) in self.imus.iter_mut().enumerate() {
            registry.register(sub, Token(first + 1 + i), Interest::READABLE)?;
        }
        Ok(())
    }

    /// Takes up to `max` messages of input `input` and hands each, as a packet (or the
    /// refusal of its malformed station id), to `submit` with its writer's slot
    /// (`/pbr/accel`), counting them (and the undecodable ones, and per writer those of a
    /// station that `monitors` denies) in `log`. Returns true if `max` was reached.
    pub(super) fn drain(
        &mut self,
        input: usize,
        max: usize,
        log: &mut IntakeLog,
        monitors: &dyn Fn(&str) -> bool,
        submit: &mut impl FnMut(Received, Option<Source>),
    ) -> bool {
        for _ in 0..max {
            if input == 0 {
                match self.accel.take() {
                    Ok(Some((m, info))) => {
                        let packet = AccelPacket::try_from(&m);
                        // A malformed id is refused (told to its sender), not ignored.
                        let monitored = match &packet {
                            Ok(p) => monitors(p.station.as_str()),
                            Err(_) => true,
                        };
                        match log.writers.taken(
                            info.publisher_gid().to_bytes16(),
                            info.sequence_number(),
                            monitored,
                        ) {
                            Taken::Redelivered => {
                                log.counters.redelivered.fetch_add(1, Ordering::Relaxed);
                            }
                            Taken::New(slot) => {
                                log.packet();
                                submit(packet, Some(slot));
                            }
                        }
                    }
                    Ok(None) => return false,
                    Err(e) => log.undecodable(&self.accel_topic, &format!("{e:?}")),
                }
            } else {
                let Some((imu, sub, sequence)) = self.imus.get_mut(input - 1) else {
                    return false;
                };
                match sub.take() {
                    Ok(Some((m, _))) => {
                        log.packet();
                        let packet = imu_packet(imu, &m, *sequence);
                        *sequence += 1;
                        submit(Ok(packet), None);
                    }
                    Ok(None) => return false,
                    Err(e) => log.undecodable(&imu.topic, &format!("{e:?}")),
                }
            }
        }
        true
    }
}
