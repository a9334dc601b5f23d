//! A Rust client of `pbr/alerts` ([`IoxAlertSubscriber`]): tests, benchmark, tools.

use std::time::Duration;

use iceoryx2::prelude::*;

use super::config::IoxConfig;
use super::service::{create_node, iox_err, open_alert_service, open_event};
use super::types::PbrAlertIox;

/// A Rust client of `pbr/alerts` (tests, benchmark, tools): subscriber plus listener.
pub struct IoxAlertSubscriber {
    subscriber: iceoryx2::port::subscriber::Subscriber<ipc::Service, PbrAlertIox, ()>,
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    _node: Node<ipc::Service>,
}

impl IoxAlertSubscriber {
    /// Subscribes to `pbr/alerts`, receiving up to [`IoxConfig::alert_history`] earlier alerts.
    pub fn new(config: &IoxConfig) -> anyhow::Result<IoxAlertSubscriber> {
        let node = create_node(config)?;
        let service = open_alert_service(&node, config)?;
        let subscriber = service
            .subscriber_builder()
            .create()
            .map_err(iox_err("cannot create the pbr/alerts subscriber"))?;
        let listener = open_event(&node, &config.alerts_service)?
            .listener_builder()
            .create()
            .map_err(iox_err("cannot create the pbr/alerts listener"))?;
        Ok(IoxAlertSubscriber {
            subscriber,
            listener,
            _node: node,
        })
    }

    /// Waits up to `timeout` for a notification, then appends every alert received to `out`.
    pub fn wait(&self, timeout: Duration, out: &mut Vec<PbrAlertIox>) -> anyhow::Result<()> {
        self.listener
            .timed_wait(|_| {}, timeout)
            .map_err(iox_err("pbr/alerts: wait failed"))?;
        self.try_receive(out)
    }

    /// Appends every alert received so far to `out`, without waiting.
    pub fn try_receive(&self, out: &mut Vec<PbrAlertIox>) -> anyhow::Result<()> {
        while let Some(sample) = self
            .subscriber
            .receive()
            .map_err(iox_err("pbr/alerts: receive failed"))?
        {
            out.push(*sample.payload());
        }
        Ok(())
    }
}
