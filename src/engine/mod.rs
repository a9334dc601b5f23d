//! The monitoring engine: the transport-free core of the live node. It takes acceleration
//! packets from many stations, keeps running intensity measures per station, advances every
//! catalogued block bound to each station sample by sample, and emits states and alerts.
//!
//! - [`packet`]: packets and their validation;
//! - [`stream`]: per-station sequencing (gaps, overlaps, duplicates, reordering, rate changes).

pub mod packet;
pub mod stream;
