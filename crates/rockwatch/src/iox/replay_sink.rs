//! Replay over iceoryx2 ([`IoxPacketSink`]): packets sent to `pbr/accel` with a notification
//! of its event service, for `rockwatch replay --transport iceoryx2` and tests.

use std::time::{Duration, Instant};

use iceoryx2::port::publisher::Publisher as IoxPublisherPort;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;

use super::config::IoxConfig;
use super::service::{create_node, iox_err, open_accel_service, open_event, AccelService};
use super::types::{AccelHeader, AccelSample};
use crate::ports::PacketSink;
use rockwatch_core::engine::AccelPacket;

/// Sends packets to `pbr/accel` and notifies its event service (for the replay tool and
/// tests). Never blocks on a slow node: a full subscriber buffer overwrites its oldest packet.
pub struct IoxPacketSink {
    publisher: IoxPublisherPort<ipc::Service, [AccelSample], AccelHeader>,
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    service: AccelService,
    _node: Node<ipc::Service>,
}

impl IoxPacketSink {
    /// Opens (or creates) `pbr/accel` as [`IoxInput`](super::IoxInput) does.
    pub fn new(config: &IoxConfig) -> anyhow::Result<IoxPacketSink> {
        let node = create_node(config)?;
        let service = open_accel_service(&node, config)?;
        let publisher = service
            .publisher_builder()
            .initial_max_slice_len(256)
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .backpressure_strategy(BackpressureStrategy::DiscardData)
            .create()
            .map_err(iox_err("cannot create the pbr/accel publisher"))?;
        let notifier = open_event(&node, &config.accel_service)?
            .notifier_builder()
            .create()
            .map_err(iox_err("cannot create the pbr/accel notifier"))?;
        Ok(IoxPacketSink {
            publisher,
            notifier,
            service,
            _node: node,
        })
    }

    /// Sends a header and samples exactly as given (no checks: for tests of hostile input).
    pub fn send_raw(
        &mut self,
        header: &AccelHeader,
        samples: &[AccelSample],
    ) -> anyhow::Result<()> {
        let mut sample = self
            .publisher
            .loan_slice_uninit(samples.len())
            .map_err(iox_err("pbr/accel: loan failed"))?;
        *sample.user_header_mut() = *header;
        sample
            .write_from_slice(samples)
            .send()
            .map_err(iox_err("pbr/accel: send failed"))?;
        self.notifier
            .notify()
            .map_err(iox_err("pbr/accel: notify failed"))?;
        Ok(())
    }

    /// Number of subscribers connected to `pbr/accel`.
    #[must_use]
    pub fn subscribers(&self) -> usize {
        self.service.dynamic_config().number_of_subscribers()
    }
}

impl PacketSink for IoxPacketSink {
    fn wait_for_subscriber(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        let start = Instant::now();
        loop {
            if self.subscribers() > 0 {
                // Let the publisher connect to the new subscriber before the first send.
                self.publisher
                    .update_connections()
                    .map_err(iox_err("pbr/accel: cannot connect"))?;
                return Ok(true);
            }
            if start.elapsed() >= timeout {
                return Ok(false);
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    fn send(&mut self, packet: &AccelPacket) -> anyhow::Result<()> {
        let n = packet.east.len();
        if packet.north.len() != n || !(packet.up.is_empty() || packet.up.len() == n) {
            anyhow::bail!(
                "packet {} of {}: component lengths differ",
                packet.sequence,
                packet.station
            );
        }
        let mut sample = self
            .publisher
            .loan_slice_uninit(n)
            .map_err(iox_err("pbr/accel: loan failed"))?;
        *sample.user_header_mut() = AccelHeader::from_packet(packet);
        let at = |v: &[f32], i: usize| v.get(i).copied().unwrap_or(0.0);
        let sample = sample.write_from_fn(|i| AccelSample {
            east: packet.east[i],
            north: packet.north[i],
            up: at(&packet.up, i),
        });
        sample.send().map_err(iox_err("pbr/accel: send failed"))?;
        self.notifier
            .notify()
            .map_err(iox_err("pbr/accel: notify failed"))?;
        Ok(())
    }
}
