//! rockwatch: live seismic monitoring of precariously balanced rocks (PBRs).
//!
//! The library is the functional core: pure, deterministic and transport-free.
//! See ARCHITECTURE.md for the map of modules and their invariants.

pub mod mseed;
pub mod record;
