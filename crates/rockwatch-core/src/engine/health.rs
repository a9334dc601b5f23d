//! Station health: whether each station still sends, and the figures an operator watches.
//!
//! A station is **stale** once no accepted packet (one that passed validation and the
//! plausibility bound) has arrived for `engine.stale_after_s`, counted on the caller's clock
//! (the node's monotonic arrival stamps) from its last accepted packet, or from the first
//! health check for a station never heard from. The engine reads no clock: the caller passes
//! `now_ns` to [`Engine::check_health`](super::Engine::check_health), on the same clock as
//! the arrival stamps it passes with packets, so the decision is deterministic.
//!
//! A station going stale, and its recovery (its next accepted packet), are reported once each
//! as an [`Output::Health`](super::Output::Health) followed by a
//! [`PbrState`](super::PbrState) of each of its blocks flagged `not_monitored` (true while
//! stale, false on recovery): a rock bound to a dead station must not look quiet.

use crate::station_id::StationId;

/// What the engine keeps per station to judge its health (updated per accepted packet:
/// no allocation).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Liveness {
    /// Arrival (caller's clock, ns) of the last accepted packet.
    pub(crate) last_arrival_ns: Option<i64>,
    /// UTC data time (ns) of the last sample of the last accepted packet (its record end).
    pub(crate) last_sample_ns: Option<i64>,
    /// Sample rate of the last accepted packet (Hz).
    pub(crate) rate_hz: f64,
    /// Stale now (see the module doc).
    pub(crate) stale: bool,
    /// While stale: since when it has been silent (its last arrival, or the first check).
    pub(crate) silent_since_ns: i64,
    /// Times the station went stale.
    pub(crate) stale_events: u64,
}

impl Liveness {
    /// An accepted packet arrived at `arrival_ns`, its last sample at `last_sample_ns` (UTC).
    /// Returns how long it was silent if it was stale (it has recovered).
    pub(crate) fn accepted(
        &mut self,
        arrival_ns: i64,
        last_sample_ns: i64,
        rate_hz: f64,
    ) -> Option<i64> {
        self.last_arrival_ns = Some(arrival_ns);
        self.last_sample_ns = Some(
            self.last_sample_ns
                .map_or(last_sample_ns, |t| t.max(last_sample_ns)),
        );
        self.rate_hz = rate_hz;
        std::mem::replace(&mut self.stale, false).then(|| arrival_ns - self.silent_since_ns)
    }

    /// At `now_ns`, with health checks running since `since_ns` and the limit `stale_after_ns`:
    /// returns the silence (ns) if the station goes stale now.
    pub(crate) fn goes_stale(
        &mut self,
        now_ns: i64,
        since_ns: i64,
        stale_after_ns: i64,
    ) -> Option<i64> {
        if self.stale {
            return None;
        }
        let silent_since_ns = self.last_arrival_ns.unwrap_or(since_ns);
        let silent_ns = now_ns - silent_since_ns;
        if silent_ns <= stale_after_ns {
            return None;
        }
        self.stale = true;
        self.silent_since_ns = silent_since_ns;
        self.stale_events += 1;
        Some(silent_ns)
    }
}

/// A station went stale or recovered (one output per change).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct HealthChange {
    pub station: StationId,
    /// False: the station went stale (its blocks are not monitored); true: it recovered.
    pub monitored: bool,
    /// Going stale: time since its last accepted packet (or since the first check, if it
    /// never sent one), in ns of the caller's clock. Recovering: how long it was silent.
    pub silent_ns: i64,
    /// Blocks bound to the station.
    pub blocks: usize,
}

/// A snapshot of one station's health ([`Engine::health`](super::Engine::health)).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StationHealth {
    pub station: StationId,
    /// Not stale.
    pub monitored: bool,
    /// Blocks bound to the station.
    pub blocks: usize,
    /// Arrival of the last accepted packet (caller's clock, ns), if any.
    pub last_arrival_ns: Option<i64>,
    /// UTC data time of the last sample received (ns), if any.
    pub last_sample_ns: Option<i64>,
    /// Sample rate of the last accepted packet (Hz; 0 before any).
    pub sample_rate_hz: f64,
    /// Accepted and rejected packets, samples processed.
    pub packets: u64,
    pub samples: u64,
    pub rejected_packets: u64,
    pub rejected_samples: u64,
    /// Samples at or beyond 99.9 % of the sensor's full scale.
    pub clipped_samples: u64,
    /// Gaps bridged by interpolation, and gaps too long (the stream broken).
    pub gaps_bridged: u64,
    pub gaps_broken: u64,
    pub missing_samples: u64,
    pub late_packets: u64,
    pub duplicate_packets: u64,
    /// Samples dropped because the station had processed them, or later data, already
    /// (duplicate, late or overlapping packets; the new samples of a packet are never dropped).
    pub dropped_samples: u64,
    /// Times the station went stale.
    pub stale_events: u64,
}
