//! What every iceoryx2 endpoint opens: an iceoryx2 node with the configured settings, the
//! `pbr/accel` and `pbr/alerts` publish-subscribe services, their event services, and the
//! conversion of iceoryx2's errors.

use std::fmt::Debug;
use std::path::Path;

use anyhow::anyhow;
use iceoryx2::prelude::*;

use super::access::{
    effective_uid, management_segments, restrict_management_segment, AccessError, Deployment,
};
use super::config::IoxConfig;
use super::types::{AccelHeader, AccelSample, IntakeIox, PbrAlertIox};

pub(super) fn iox_err<E: Debug>(what: impl std::fmt::Display) -> impl FnOnce(E) -> anyhow::Error {
    move |e| anyhow!("{what}: {e:?}")
}

pub(super) fn service_name(name: &str) -> anyhow::Result<ServiceName> {
    ServiceName::new(name).map_err(iox_err(format!("invalid iceoryx2 service name {name:?}")))
}

pub(super) type AccelService = iceoryx2::service::port_factory::publish_subscribe::PortFactory<
    ipc::Service,
    [AccelSample],
    AccelHeader,
>;

pub(super) fn open_accel_service(
    node: &Node<ipc::Service>,
    config: &IoxConfig,
) -> anyhow::Result<AccelService> {
    node.service_builder(&service_name(&config.accel_service)?)
        .publish_subscribe::<[AccelSample]>()
        .user_header::<AccelHeader>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(config.subscriber_buffer)
        .max_publishers(config.max_publishers)
        .open_or_create()
        .map_err(iox_err(format!(
            "iceoryx2 service {:?} (publish-subscribe)",
            config.accel_service
        )))
}

pub(super) fn open_event(
    node: &Node<ipc::Service>,
    name: &str,
) -> anyhow::Result<iceoryx2::service::port_factory::event::PortFactory<ipc::Service>> {
    node.service_builder(&service_name(name)?)
        .event()
        .open_or_create()
        .map_err(iox_err(format!("iceoryx2 service {name:?} (event)")))
}

pub(super) type IntakeService =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, IntakeIox, ()>;

/// Reports a sender reads without falling behind: cumulative counts, so an overwritten report
/// only delays what the next one says.
const INTAKE_BUFFER: usize = 256;

/// `<accel service>/intake`: the nodes' intake reports to the senders of `pbr/accel`
/// (`crate::intake`).
pub(super) fn open_intake_service(
    node: &Node<ipc::Service>,
    config: &IoxConfig,
) -> anyhow::Result<IntakeService> {
    let name = format!("{}/intake", config.accel_service);
    node.service_builder(&service_name(&name)?)
        .publish_subscribe::<IntakeIox>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(INTAKE_BUFFER)
        .max_publishers(config.max_publishers)
        .open_or_create()
        .map_err(iox_err(format!(
            "iceoryx2 service {name:?} (publish-subscribe)"
        )))
}

pub(super) type AlertService =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, PbrAlertIox, ()>;

/// `pbr/alerts` with its history: whoever creates it first (node or client) must ask for the
/// same history, else the other cannot open it.
pub(super) fn open_alert_service(
    node: &Node<ipc::Service>,
    config: &IoxConfig,
) -> anyhow::Result<AlertService> {
    let name = &config.alerts_service;
    node.service_builder(&service_name(name)?)
        .publish_subscribe::<PbrAlertIox>()
        .enable_safe_overflow(true)
        .history_size(config.alert_history)
        .subscriber_max_buffer_size(config.alert_history.max(1))
        .open_or_create()
        .map_err(iox_err(format!(
            "iceoryx2 service {name:?} (publish-subscribe)"
        )))
}

/// An iceoryx2 node that leaves SIGINT/SIGTERM to the application, created only if no other
/// user can reach this deployment's resources (`access.rs`: private root directory, no
/// foreign segment with the prefix), with the global management segment restricted to 0600
/// before and right after the creation.
pub(super) fn create_node(config: &IoxConfig) -> anyhow::Result<Node<ipc::Service>> {
    let iox_config = config.load_iceoryx2_config()?;
    let file = config.config_file.as_deref().unwrap_or(Path::new("?"));
    let refused = |e: AccessError| anyhow!("{e} (iceoryx2 configuration {})", file.display());
    let deployment = Deployment::of(&iox_config);
    effective_uid()
        .and_then(|uid| deployment.check_before_node(uid))
        .map_err(refused)?;
    let node = NodeBuilder::new()
        .config(&iox_config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| {
            // A management segment of this user whose content a process of this user (or one
            // that opened it while it was world-writable) overwrote: iceoryx2 recreates it.
            let hint = management_segments(&deployment)
                .iter()
                .map(|p| format!(" (if {} was overwritten, remove it)", p.display()))
                .collect::<String>();
            anyhow!("cannot create the iceoryx2 node: {e:?}{hint}")
        })?;
    restrict_management_segment(&deployment).map_err(refused)?;
    Ok(node)
}
