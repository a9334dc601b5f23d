//! rockwatch: live seismic monitoring of precariously balanced rocks (PBRs).
//!
//! The library is the functional core: pure, deterministic and transport-free.
//! See ARCHITECTURE.md for the map of modules and their invariants.

pub mod catalogue;
pub mod dynamics;
pub mod engine;
pub mod ims;
pub mod iox;
pub mod journal;
pub mod lhs;
pub mod mseed;
pub mod node;
pub mod node_config;
pub mod ode;
pub mod plot;
pub mod pulse;
pub mod record;
pub mod replay;
pub mod ros2;
pub mod simulate;
pub mod station_id;
pub mod study;

/// Standard gravity g (m/s²): the unit of AT2 records and the gravity of the block dynamics.
pub const STANDARD_GRAVITY_MPS2: f64 = 9.80665;
