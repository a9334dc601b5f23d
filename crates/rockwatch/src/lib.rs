//! rockwatch: the shell around [`rockwatch_core`]: the live node and its transports (ROS 2,
//! iceoryx2), the state directory's journal, replay, plots and report writing.
//!
//! Physics, intensity measures, record formats and the monitoring engine are in
//! `rockwatch_core`; this crate translates the outside world into calls on it.
//! See ARCHITECTURE.md for the map of crates and modules.

pub mod acquire;
pub mod alert_json;
pub mod fragility;
pub mod hazard_plots;
pub mod intake;
pub mod iox;
pub mod journal;
pub mod log_text;
pub mod logging;
pub mod metrics;
pub mod node;
pub mod node_config;
pub mod notify;
pub mod number_text;
pub mod plot;
pub mod ports;
pub mod replay;
pub mod reports;
pub mod rock_plots;
pub mod ros2;
pub mod sd_notify;
pub mod seedlink;
pub mod signals;
pub mod status;
pub mod study;
pub mod traces;
pub mod units;
pub mod web;
pub mod wire_codes;
