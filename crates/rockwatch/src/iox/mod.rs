//! iceoryx2 transport (zero-copy, same host): a thin adapter between the node's ports
//! (`crate::ports`) and iceoryx2.
//!
//! - [`IoxInput`]: the subscription to `pbr/accel` (user header [`AccelHeader`], slice of
//!   [`AccelSample`]) plus the listener of the event service of the same name: a mio event
//!   source driven by the node's event loop (`crate::node::Reactor`; no thread of its own, no
//!   busy polling), which validates and counts what it takes and tracks sequence gaps.
//! - [`IoxAlertPublisher`]: a [`Publisher`](crate::ports::Publisher) that publishes alerts on `pbr/alerts` and notifies
//!   the event service of the same name.
//! - [`IoxPacketSink`]: a [`PacketSink`](crate::ports::PacketSink) for `rockwatch replay --transport iceoryx2`.
//!
//! Every endpoint loads ONE explicit iceoryx2 configuration file ([`IoxConfig::config_file`],
//! shipped as `config/iceoryx2.toml`): iceoryx2's own lookup (`config/iceoryx2.toml` relative
//! to the working directory, then the user's and the global one) silently falls back to the
//! built-in defaults when it finds nothing, and services created with different settings then
//! refuse to open. Layouts and the client protocol: docs/iceoryx2.md.
//!
//! - [`types`]: the wire layouts;
//! - `config.rs`: the `[iceoryx2]` configuration section and the iceoryx2 configuration file;
//! - `service.rs`: the iceoryx2 node and services every endpoint opens;
//! - [`access`]: who can reach them (private root directory, owner-only segments);
//! - the node's side: `input.rs` (with `intake.rs`, `stats.rs` and `cleanup.rs`, the clean-up
//!   of dead nodes) and `alert_publisher.rs`;
//! - `alert_subscriber.rs`, `packet_sink.rs`: clients.

pub mod access;
mod alert_publisher;
mod alert_subscriber;
mod cleanup;
mod config;
mod input;
mod intake;
mod packet_sink;
mod service;
mod stats;
pub mod types;

pub use alert_publisher::IoxAlertPublisher;
pub use alert_subscriber::IoxAlertSubscriber;
pub use config::{load_config_file, IoxConfig};
pub use input::IoxInput;
pub use packet_sink::IoxPacketSink;
pub use stats::{IoxInputStats, IoxStatsHandle};
pub use types::{
    packet_from_wire, AccelHeader, AccelSample, PbrAlertIox, WireError, ACCEL_FLAG_HAS_UP,
    ACCEL_HEADER_TYPE_NAME, ACCEL_SAMPLE_TYPE_NAME, ALERT_FLAG_ID_TRUNCATED,
    ALERT_FLAG_JOURNAL_PENDING, PBR_ALERT_TYPE_NAME,
};
