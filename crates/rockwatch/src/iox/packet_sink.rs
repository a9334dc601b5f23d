//! The packet sender over iceoryx2 ([`IoxPacketSink`]): packets sent to `pbr/accel` with a
//! notification of its event service, for `rockwatch replay --transport iceoryx2`, `rockwatch
//! acquire` and tests.

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use anyhow::bail;
use iceoryx2::port::publisher::Publisher as IoxPublisherPort;
use iceoryx2::port::subscriber::Subscriber as IoxSubscriberPort;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;

use super::config::IoxConfig;
use super::service::{
    create_node, iox_err, open_accel_service, open_event, open_intake_service, AccelService,
};
use super::types::{AccelHeader, AccelSample, IntakeIox};
use crate::intake::{ignored_line, refusal_line, Delivery, IntakeCount};
use crate::ports::PacketSink;
use rockwatch_core::engine::AccelPacket;

/// Sends packets to `pbr/accel` and notifies its event service.
///
/// Made by [`IoxPacketSink::new`] (a live sender: `acquire`, a station) it never blocks on a
/// slow node: a full subscriber buffer overwrites its oldest packet (the node counts the gap).
/// Made by [`IoxPacketSink::confirmed`] (a replay) it reads the nodes' intake reports on
/// `pbr/accel/intake` (`crate::intake`): [`PacketSink::send`] waits while the node furthest
/// behind has the window it grants unreported (half its per-publisher buffer: nothing is ever
/// overwritten), and [`PacketSink::finish`] waits until every node has processed every packet,
/// else fails naming each node that did not, that refused, dropped or ignored packets. A
/// subscriber that never reports (not a rockwatch node, e.g. a Python client) is named in a
/// warning and not waited for.
pub struct IoxPacketSink {
    publisher: IoxPublisherPort<ipc::Service, [AccelSample], AccelHeader>,
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    service: AccelService,
    /// With [`IoxPacketSink::confirmed`]: the reports, what the nodes made of the packets, and
    /// how long to wait for the reports to move.
    confirm: Option<Confirm>,
    _node: Node<ipc::Service>,
}

struct Confirm {
    reports: IoxSubscriberPort<ipc::Service, IntakeIox, ()>,
    delivery: Delivery,
    wait: Duration,
    /// The stations sent (the first few, to name them when the node ignores packets).
    stations: BTreeSet<String>,
}

/// Stations a confirming sink remembers by name.
const NAMED_STATIONS: usize = 8;

/// Most packets a replay keeps unreported, whatever window the nodes grant.
const MAX_WINDOW: u64 = 4096;

impl IoxPacketSink {
    /// Opens (or creates) `pbr/accel` as [`IoxInput`](super::IoxInput) does: a sender that
    /// never waits for the node.
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
            confirm: None,
            _node: node,
        })
    }

    /// As [`IoxPacketSink::new`], paced and confirmed by the nodes' intake reports, waiting up
    /// to `wait` for them to move.
    pub fn confirmed(config: &IoxConfig, wait: Duration) -> anyhow::Result<IoxPacketSink> {
        let mut sink = Self::new(config)?;
        let reports = open_intake_service(&sink._node, config)?
            .subscriber_builder()
            .create()
            .map_err(iox_err("cannot subscribe to the intake reports"))?;
        let writer = sink.publisher.id().value().to_le_bytes();
        sink.confirm = Some(Confirm {
            reports,
            delivery: Delivery::new(writer),
            wait,
            stations: BTreeSet::new(),
        });
        Ok(sink)
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
        if let Some(c) = &mut self.confirm {
            c.delivery.sent += 1;
        }
        Ok(())
    }

    /// Number of subscribers connected to `pbr/accel`.
    #[must_use]
    pub fn subscribers(&self) -> usize {
        self.service.dynamic_config().number_of_subscribers()
    }

    /// The ids of the subscribers of `pbr/accel` now.
    fn subscriber_ids(&self) -> BTreeSet<[u8; 16]> {
        let mut ids = BTreeSet::new();
        self.service.dynamic_config().list_subscribers(|d| {
            ids.insert(d.subscriber_id.value().to_le_bytes());
            CallbackProgression::Continue
        });
        ids
    }

    /// Packets sent so far, and of those the node furthest behind has reported taken (all
    /// sent, without confirmation).
    pub fn progress(&mut self) -> (u64, u64) {
        match &mut self.confirm {
            Some(c) => {
                c.read_reports();
                (c.delivery.sent, c.delivery.confirmed())
            }
            None => (0, 0),
        }
    }

    /// One line on why the nodes have not processed everything.
    fn shortfall(&mut self) -> String {
        let matched = self.subscriber_ids();
        let Some(c) = &mut self.confirm else {
            return String::new();
        };
        c.read_reports();
        c.delivery
            .shortfall(&matched, c.wait, "", "pbr/accel/intake")
    }
}

impl Confirm {
    fn read_reports(&mut self) {
        while let Ok(Some(report)) = self.reports.receive() {
            self.delivery
                .watch
                .offer(&IntakeCount::from(report.payload()));
        }
    }

    /// Waits until `done` holds of the delivery, as long as `progress` keeps moving within
    /// the wait; false if it stood still.
    fn wait_until<P: PartialEq>(
        &mut self,
        progress: impl Fn(&Delivery) -> P,
        done: impl Fn(&Delivery) -> bool,
    ) -> bool {
        self.read_reports();
        let mut last = progress(&self.delivery);
        let mut last_move = Instant::now();
        while !done(&self.delivery) {
            std::thread::sleep(Duration::from_micros(200));
            self.read_reports();
            let now = progress(&self.delivery);
            if now != last {
                last = now;
                last_move = Instant::now();
            } else if last_move.elapsed() >= self.wait {
                return false;
            }
        }
        true
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
        if let Some(c) = &mut self.confirm {
            c.read_reports();
            let window = c.delivery.window(MAX_WINDOW);
            if !c.wait_until(Delivery::confirmed, |d| d.unconfirmed() < window) {
                bail!("{}", self.shortfall());
            }
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
        if let Some(c) = &mut self.confirm {
            c.delivery.sent += 1;
            if c.stations.len() < NAMED_STATIONS {
                c.stations.insert(packet.station.to_string());
            }
        }
        Ok(())
    }

    /// With confirmation: waits until every node that reports has processed every packet;
    /// fails naming each node that did not, that refused or dropped packets, or that ignored some.
    fn finish(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        let matched = self.subscriber_ids();
        let Some(c) = &mut self.confirm else {
            return Ok(true);
        };
        c.wait = timeout;
        if c.delivery.sent > 0 && !c.wait_until(|d| d.processing().0, |d| d.processing().1) {
            bail!("{}", self.shortfall());
        }
        let Some(c) = &mut self.confirm else {
            return Ok(true);
        };
        let refusals = c.delivery.refusals();
        if !refusals.is_empty() {
            bail!("{}", refusal_line(&refusals));
        }
        let ignored = c.delivery.ignored();
        if ignored > 0 {
            let stations = c.stations.iter().map(String::as_str).collect();
            bail!(
                "{}",
                ignored_line(ignored, c.delivery.sent, &stations, false)
            );
        }
        let silent = c.delivery.silent(&matched);
        if silent > 0 {
            tracing::warn!(
                "{silent} subscriber(s) of pbr/accel never reported on pbr/accel/intake what they took (not rockwatch nodes): not checked"
            );
        }
        Ok(true)
    }
}
