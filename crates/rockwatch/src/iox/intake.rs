//! The pure part of the iceoryx2 input: wire checks of each received `pbr/accel` sample and
//! per-station sequence tracking, counted in the input's [`Counters`].

use std::collections::HashMap;

use super::stats::{Counters, GAPS, RECEIVED, REJ_COUNT, REJ_STATION, REJ_STRUCTURE, REJ_VALUES};
use super::types::{packet_from_wire, AccelHeader, AccelSample, WireError, STATION_BYTES};
use rockwatch_core::engine::AccelPacket;

/// Per-station sequence tracking and wire checks: the pure part of the input.
#[derive(Debug, Default)]
pub(super) struct Intake {
    last_sequence: HashMap<[u8; STATION_BYTES], u64>,
}

impl Intake {
    /// Checks one received sample; returns the packet to submit or the counter to bump.
    pub(super) fn accept(
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
