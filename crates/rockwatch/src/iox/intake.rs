//! The pure part of the iceoryx2 input: wire checks of each received `pbr/accel` sample and
//! per-station sequence tracking, counted in the input's [`Counters`].

use std::collections::HashMap;

use super::stats::{Counters, GAPS, RECEIVED, REJ_COUNT, REJ_STATION, REJ_STRUCTURE};
use super::types::{packet_from_wire, AccelHeader, AccelSample, WireError, STATION_BYTES};
use crate::ports::Received;

/// Per-station sequence tracking and wire checks: the pure part of the input.
#[derive(Debug, Default)]
pub(super) struct Intake {
    last_sequence: HashMap<[u8; STATION_BYTES], u64>,
}

impl Intake {
    /// Checks one received sample's wire structure: the packet (its station id parsed) or
    /// the refusal of its malformed station id, for the node; `None` if refused at the wire
    /// (the counter bumped). Its values are the engine's to check, as on every transport.
    pub(super) fn accept(
        &mut self,
        header: &AccelHeader,
        samples: &[AccelSample],
        counters: &Counters,
    ) -> Option<Received> {
        counters.add(RECEIVED, 1);
        let packet = match packet_from_wire(header, samples) {
            Ok(p) => p,
            Err(WireError::MalformedStation(refused)) => return Some(Err(refused)),
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
        if let Some(last) = self.last_sequence.insert(header.station, header.sequence) {
            // A lower number is a restarted sender: no gap.
            if header.sequence > last {
                counters.add(GAPS, header.sequence - last - 1);
            }
        }
        Some(Ok(packet))
    }
}
