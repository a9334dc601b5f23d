//! iceoryx2 transport (zero-copy, same host): a thin adapter around `crate::node`.
//!
//! - [`IoxInput`]: the subscription to `pbr/accel` (user header [`AccelHeader`], slice of
//!   [`AccelSample`]) plus the listener of the event service of the same name: a mio event
//!   source driven by the node's event loop (`crate::node::Reactor`; no thread of its own, no
//!   busy polling), which validates and counts what it takes and tracks sequence gaps.
//! - [`IoxAlertPublisher`]: a [`Publisher`] that publishes alerts on `pbr/alerts` and notifies
//!   the event service of the same name.
//! - [`IoxPacketSink`]: a [`PacketSink`] for `rockwatch replay --transport iceoryx2`.
//!
//! Every endpoint loads ONE explicit iceoryx2 configuration file ([`IoxConfig::config_file`],
//! shipped as `config/iceoryx2.toml`): iceoryx2's own lookup (`config/iceoryx2.toml` relative
//! to the working directory, then the user's and the global one) silently falls back to the
//! built-in defaults when it finds nothing, and services created with different settings then
//! refuse to open. Layouts and the client protocol: docs/iceoryx2.md.

pub mod types;

use std::collections::HashMap;
use std::fmt::Debug;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context};
use iceoryx2::config::Config;
use iceoryx2::port::publisher::Publisher as IoxPublisherPort;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;
use mio::unix::SourceFd;

use crate::ports::{PacketSink, Publication, Publisher};
use rockwatch_core::engine::AccelPacket;
pub use types::{
    packet_from_wire, AccelHeader, AccelSample, PbrAlertIox, WireError, ACCEL_FLAG_HAS_UP,
    ACCEL_HEADER_TYPE_NAME, ACCEL_SAMPLE_TYPE_NAME, PBR_ALERT_TYPE_NAME,
};

/// The `[iceoryx2]` section of the node configuration.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IoxConfig {
    /// The iceoryx2 configuration file (required by every endpoint; relative paths are
    /// relative to the node configuration file).
    pub config_file: Option<PathBuf>,
    /// Input service name (publish-subscribe and event).
    pub accel_service: String,
    /// Output service name (publish-subscribe and event).
    pub alerts_service: String,
    /// Packets a subscriber buffers per publisher; beyond that the oldest is overwritten
    /// (safe overflow: a slow node never blocks a station) and the loss shows as a sequence gap.
    pub subscriber_buffer: usize,
    /// Most publishers (stations) on `pbr/accel`.
    pub max_publishers: usize,
    /// Alerts kept for subscribers that join late (`pbr/alerts` history).
    pub alert_history: usize,
    /// Dead iceoryx2 nodes (e.g. a `kill -9`ed station) are cleaned at start-up and then
    /// this often (s).
    pub dead_node_check_s: f64,
}

impl Default for IoxConfig {
    fn default() -> Self {
        IoxConfig {
            config_file: None,
            accel_service: "pbr/accel".into(),
            alerts_service: "pbr/alerts".into(),
            subscriber_buffer: 1024,
            max_publishers: 64,
            alert_history: 128,
            dead_node_check_s: 1.0,
        }
    }
}

impl IoxConfig {
    /// The settings of `config_file` (an error if none is set or it cannot be read: iceoryx2
    /// defaults are never used silently).
    pub fn load_iceoryx2_config(&self) -> anyhow::Result<Config> {
        let path = self.config_file.as_deref().context(
            "no iceoryx2 configuration file: set [iceoryx2] config_file (e.g. config/iceoryx2.toml)",
        )?;
        load_config_file(path)
    }

    fn dead_node_period(&self) -> Duration {
        Duration::from_secs_f64(self.dead_node_check_s.clamp(0.01, 3600.0))
    }
}

/// Reads an iceoryx2 configuration file; the error names the file.
pub fn load_config_file(path: &Path) -> anyhow::Result<Config> {
    // Read it ourselves first for a clear error (iceoryx2 reports only an error code).
    std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the iceoryx2 configuration", path.display()))?;
    let text = path
        .to_str()
        .with_context(|| format!("{}: path is not UTF-8", path.display()))?;
    let file_path = FilePath::new(text.as_bytes()).map_err(iox_err(path.display()))?;
    Config::from_file(&file_path).map_err(iox_err(format!(
        "{}: not a valid iceoryx2 configuration",
        path.display()
    )))
}

fn iox_err<E: Debug>(what: impl std::fmt::Display) -> impl FnOnce(E) -> anyhow::Error {
    move |e| anyhow!("{what}: {e:?}")
}

fn service_name(name: &str) -> anyhow::Result<ServiceName> {
    ServiceName::new(name).map_err(iox_err(format!("invalid iceoryx2 service name {name:?}")))
}

type AccelService = iceoryx2::service::port_factory::publish_subscribe::PortFactory<
    ipc::Service,
    [AccelSample],
    AccelHeader,
>;

fn open_accel_service(
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

fn open_event(
    node: &Node<ipc::Service>,
    name: &str,
) -> anyhow::Result<iceoryx2::service::port_factory::event::PortFactory<ipc::Service>> {
    node.service_builder(&service_name(name)?)
        .event()
        .open_or_create()
        .map_err(iox_err(format!("iceoryx2 service {name:?} (event)")))
}

type AlertService =
    iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, PbrAlertIox, ()>;

/// `pbr/alerts` with its history: whoever creates it first (node or client) must ask for the
/// same history, else the other cannot open it.
fn open_alert_service(
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

/// An iceoryx2 node that leaves SIGINT/SIGTERM to the application.
fn create_node(config: &IoxConfig) -> anyhow::Result<Node<ipc::Service>> {
    let iox_config = config.load_iceoryx2_config()?;
    NodeBuilder::new()
        .config(&iox_config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(iox_err("cannot create the iceoryx2 node"))
}

/// Counts of what the input did (snapshot of [`IoxInput::stats`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct IoxInputStats {
    /// Samples taken from the subscriber.
    pub received: u64,
    /// Packets handed to the engine.
    pub submitted: u64,
    /// Rejected: header `sample_count` ≠ payload length.
    pub rejected_count_mismatch: u64,
    /// Rejected: station bytes not NUL-padded UTF-8 or not a SEED id.
    pub rejected_station: u64,
    /// Rejected: unknown flags, non-zero reserved field, or more samples than the engine takes.
    pub rejected_structure: u64,
    /// Rejected: values (empty, NaN/∞, sample rate outside [1, 10000] Hz).
    pub rejected_values: u64,
    /// Packets missing according to the per-station sequence numbers (overflow or sender loss).
    pub sequence_gaps: u64,
    /// Receive errors reported by iceoryx2.
    pub receive_errors: u64,
    /// Dead iceoryx2 nodes cleaned up by this input.
    pub dead_nodes_cleaned: u64,
    /// Times the input was drained (readiness of its listener, and the event loop's periodic
    /// safety-net drain).
    pub wakeups: u64,
}

#[derive(Debug, Default)]
struct Counters([AtomicU64; 10]);

impl Counters {
    fn add(&self, index: usize, n: u64) {
        self.0[index].fetch_add(n, Ordering::Relaxed);
    }
    fn snapshot(&self) -> IoxInputStats {
        let g = |i: usize| self.0[i].load(Ordering::Relaxed);
        IoxInputStats {
            received: g(0),
            submitted: g(1),
            rejected_count_mismatch: g(2),
            rejected_station: g(3),
            rejected_structure: g(4),
            rejected_values: g(5),
            sequence_gaps: g(6),
            receive_errors: g(7),
            dead_nodes_cleaned: g(8),
            wakeups: g(9),
        }
    }
}

const RECEIVED: usize = 0;
const SUBMITTED: usize = 1;
const REJ_COUNT: usize = 2;
const REJ_STATION: usize = 3;
const REJ_STRUCTURE: usize = 4;
const REJ_VALUES: usize = 5;
const GAPS: usize = 6;
const RECV_ERRORS: usize = 7;
const DEAD_NODES: usize = 8;
const WAKEUPS: usize = 9;

/// The input side, subscribed to `pbr/accel`: a subscriber plus the listener of the event
/// service of the same name. It has no thread: register it with a `mio::Poll` (it is a mio
/// event source, readable when a station has notified) and call [`IoxInput::drain`] whenever
/// it is ready, and [`IoxInput::maintain`] regularly (the node's event loop does both).
pub struct IoxInput {
    subscriber: iceoryx2::port::subscriber::Subscriber<ipc::Service, [AccelSample], AccelHeader>,
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    intake: Intake,
    counters: Arc<Counters>,
    cleanup_period: Duration,
    last_cleanup: Instant,
    node: Node<ipc::Service>,
}

/// A thread-safe view of an [`IoxInput`]'s counters (for tests, benchmarks and logs).
#[derive(Debug, Clone)]
pub struct IoxStatsHandle(Arc<Counters>);

impl IoxStatsHandle {
    /// Counters so far.
    #[must_use]
    pub fn stats(&self) -> IoxInputStats {
        self.0.snapshot()
    }
}

impl IoxInput {
    /// Cleans up dead iceoryx2 nodes (e.g. `kill -9`ed stations), then opens (or creates)
    /// `pbr/accel` and subscribes.
    pub fn open(config: &IoxConfig) -> anyhow::Result<IoxInput> {
        let node = create_node(config)?;
        let counters = Arc::new(Counters::default());
        counters.add(DEAD_NODES, node.try_cleanup_dead_nodes().cleanups);
        let service = open_accel_service(&node, config)?;
        let event = open_event(&node, &config.accel_service)?;
        let subscriber = service
            .subscriber_builder()
            .buffer_size(config.subscriber_buffer)
            .create()
            .map_err(iox_err("cannot create the pbr/accel subscriber"))?;
        let listener = event
            .listener_builder()
            .create()
            .map_err(iox_err("cannot create the pbr/accel listener"))?;
        Ok(IoxInput {
            subscriber,
            listener,
            intake: Intake::default(),
            counters,
            cleanup_period: config.dead_node_period(),
            last_cleanup: Instant::now(),
            node,
        })
    }

    /// Counters so far.
    #[must_use]
    pub fn stats(&self) -> IoxInputStats {
        self.counters.snapshot()
    }

    /// A handle to read the counters from other threads.
    #[must_use]
    pub fn stats_handle(&self) -> IoxStatsHandle {
        IoxStatsHandle(Arc::clone(&self.counters))
    }

    /// Takes the pending notifications, then up to `max` packets: each is checked (wire
    /// layout, values; counted when rejected, with per-station sequence gaps) and handed to
    /// `submit`. Returns true if `max` was reached (more may be waiting: call again without
    /// waiting for readiness, which is edge-triggered). An error of `submit` is returned.
    pub fn drain(
        &mut self,
        max: usize,
        submit: &mut impl FnMut(AccelPacket) -> anyhow::Result<()>,
    ) -> anyhow::Result<bool> {
        self.counters.add(WAKEUPS, 1);
        // Consume the notifications first: a notifier sends again only once the listener has
        // taken them, and samples sent before a notification are then all visible below.
        if self.listener.try_wait(|_| {}).is_err() {
            self.counters.add(RECV_ERRORS, 1);
        }
        for _ in 0..max {
            match self.subscriber.receive() {
                Ok(Some(sample)) => {
                    let packet =
                        self.intake
                            .accept(sample.user_header(), sample.payload(), &self.counters);
                    drop(sample); // return the shared-memory slot before the engine runs
                    if let Some(packet) = packet {
                        self.counters.add(SUBMITTED, 1);
                        submit(packet)?;
                    }
                }
                Ok(None) => return Ok(false),
                Err(_) => {
                    self.counters.add(RECV_ERRORS, 1);
                    return Ok(false);
                }
            }
        }
        Ok(true)
    }

    /// Cleans up dead iceoryx2 nodes when [`IoxConfig::dead_node_check_s`] has passed since
    /// the last clean-up (cheap otherwise: call it on every turn of the event loop).
    pub fn maintain(&mut self) {
        if self.last_cleanup.elapsed() >= self.cleanup_period {
            let state = self.node.try_cleanup_dead_nodes();
            self.counters.add(DEAD_NODES, state.cleanups);
            self.last_cleanup = Instant::now();
        }
    }

    fn raw_fd(&self) -> i32 {
        // SAFETY: `native_handle` is unsafe only because the number must not outlive the
        // listener nor be closed by the caller; it is used transiently to (de)register the
        // listener's socket with a poller, and the listener lives as long as `self`.
        unsafe { self.listener.file_descriptor().native_handle() }
    }
}

/// Readable when a station has notified `pbr/accel` (the listener's socket).
impl mio::event::Source for IoxInput {
    fn register(
        &mut self,
        registry: &mio::Registry,
        token: mio::Token,
        interests: mio::Interest,
    ) -> std::io::Result<()> {
        SourceFd(&self.raw_fd()).register(registry, token, interests)
    }

    fn reregister(
        &mut self,
        registry: &mio::Registry,
        token: mio::Token,
        interests: mio::Interest,
    ) -> std::io::Result<()> {
        SourceFd(&self.raw_fd()).reregister(registry, token, interests)
    }

    fn deregister(&mut self, registry: &mio::Registry) -> std::io::Result<()> {
        SourceFd(&self.raw_fd()).deregister(registry)
    }
}

/// Per-station sequence tracking and wire checks: the pure part of the input.
#[derive(Debug, Default)]
struct Intake {
    last_sequence: HashMap<[u8; types::STATION_BYTES], u64>,
}

impl Intake {
    /// Checks one received sample; returns the packet to submit or the counter to bump.
    fn accept(
        &mut self,
        header: &AccelHeader,
        samples: &[AccelSample],
        counters: &Counters,
    ) -> Option<AccelPacket> {
        counters.add(RECEIVED, 1);
        let packet = match packet_from_wire(header, samples) {
            Ok(p) => p,
            Err(WireError::CountMismatch { .. }) => {
                counters.add(REJ_COUNT, 1);
                return None;
            }
            Err(WireError::Station(_)) => {
                counters.add(REJ_STATION, 1);
                return None;
            }
            Err(WireError::Flags(_) | WireError::TooLarge { .. }) => {
                counters.add(REJ_STRUCTURE, 1);
                return None;
            }
        };
        match packet.validate() {
            Ok(_) => {}
            Err(rockwatch_core::engine::PacketError::Station(_)) => {
                counters.add(REJ_STATION, 1);
                return None;
            }
            Err(rockwatch_core::engine::PacketError::TooLarge { .. }) => {
                counters.add(REJ_STRUCTURE, 1);
                return None;
            }
            Err(_) => {
                counters.add(REJ_VALUES, 1);
                return None;
            }
        }
        if let Some(last) = self.last_sequence.insert(header.station, header.sequence) {
            // A lower number is a restarted sender: no gap.
            if header.sequence > last {
                counters.add(GAPS, header.sequence - last - 1);
            }
        }
        Some(packet)
    }
}

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
        let Publication::Alert { alert, latency_ns } = publication else {
            return Ok(());
        };
        let wire = PbrAlertIox::from_alert(alert, *latency_ns, self.sequence);
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

/// Sends packets to `pbr/accel` and notifies its event service (for the replay tool and
/// tests). Never blocks on a slow node: a full subscriber buffer overwrites its oldest packet.
pub struct IoxPacketSink {
    publisher: IoxPublisherPort<ipc::Service, [AccelSample], AccelHeader>,
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    service: AccelService,
    _node: Node<ipc::Service>,
}

impl IoxPacketSink {
    /// Opens (or creates) `pbr/accel` as [`IoxInput`] does.
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
