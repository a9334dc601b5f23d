//! rockwatch-core: the functional core of rockwatch, live seismic monitoring of precariously
//! balanced rocks (PBRs).
//!
//! Pure, deterministic and transport-free: no network, no clock, no threads but the engine's
//! optional shards and the data-parallel loops of the study and the fragility runs. The shell
//! (`crates/rockwatch`: ROS 2, iceoryx2, the live node, files of state, CLI) is built on this
//! crate and never the reverse.
//! See ARCHITECTURE.md for the map of modules and their invariants.

pub mod assembly;
pub mod azimuth;
pub mod bounded_read;
pub mod catalogue;
pub mod differentiate;
pub mod dynamics;
pub mod engine;
pub mod fragility;
pub mod geodesy;
pub mod hazard;
pub mod ims;
pub mod inventory;
pub mod lhs;
pub mod mesh;
pub mod ode;
pub mod partition;
pub mod pbr_id;
pub mod pulse;
pub mod record;
pub mod rocking3d;
pub mod seedlink;
pub mod simulate;
pub mod station_id;
pub mod stats;
pub mod study;
pub mod utc;

/// Standard gravity g (m/s²): the unit of AT2 records and the gravity of the block dynamics.
pub const STANDARD_GRAVITY_MPS2: f64 = 9.80665;
