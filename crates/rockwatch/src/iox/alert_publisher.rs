//! The node's iceoryx2 output ([`IoxAlertPublisher`]): alerts on `pbr/alerts` and a
//! notification of its event service.

use iceoryx2::port::publisher::Publisher as IoxPublisherPort;
use iceoryx2::prelude::*;

use super::config::IoxConfig;
use super::service::{create_node, iox_err, open_alert_service, open_event};
use super::types::PbrAlertIox;
use crate::ports::{Publication, Publisher};

/// Publishes alerts on `pbr/alerts` (payload [`PbrAlertIox`]) and notifies the event service
/// of the same name; states and intensities are not published over iceoryx2.
pub struct IoxAlertPublisher {
    publisher: IoxPublisherPort<ipc::Service, PbrAlertIox, ()>,
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    sequence: u64,
    _node: Node<ipc::Service>,
}

impl IoxAlertPublisher {
    /// Opens (or creates) `pbr/alerts` with [`IoxConfig::alert_history`] alerts of history.
    /// Use it on the thread that created it (the node's event loop).
    pub fn new(config: &IoxConfig) -> anyhow::Result<IoxAlertPublisher> {
        let node = create_node(config)?;
        let name = &config.alerts_service;
        let service = open_alert_service(&node, config)?;
        let publisher = service
            .publisher_builder()
            .backpressure_strategy(BackpressureStrategy::DiscardData)
            .create()
            .map_err(iox_err(format!("cannot create the {name} publisher")))?;
        let notifier = open_event(&node, name)?
            .notifier_builder()
            .create()
            .map_err(iox_err(format!("cannot create the {name} notifier")))?;
        Ok(IoxAlertPublisher {
            publisher,
            notifier,
            sequence: 0,
            _node: node,
        })
    }
}

impl Publisher for IoxAlertPublisher {
    fn publish(&mut self, publication: &Publication) -> anyhow::Result<()> {
        let wire = match publication {
            Publication::Alert {
                alert,
                latency_ns,
                journal_pending,
            } => {
                let mut wire = PbrAlertIox::from_alert(alert, *latency_ns, self.sequence);
                if *journal_pending {
                    wire.flags |= super::ALERT_FLAG_JOURNAL_PENDING;
                }
                wire
            }
            Publication::Reset(reset) => PbrAlertIox::from_reset(reset, self.sequence),
            Publication::State(_) | Publication::Intensity(_) => return Ok(()),
        };
        self.sequence += 1;
        self.publisher
            .send_copy(wire)
            .map_err(iox_err("pbr/alerts: send failed"))?;
        self.notifier
            .notify()
            .map_err(iox_err("pbr/alerts: notify failed"))?;
        Ok(())
    }
}
