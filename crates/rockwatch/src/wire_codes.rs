//! The wire codes of block modes, alert levels and sample units: the single table used by both transports,
//! ROS 2 (`pbr_msgs/PbrState.mode`, `pbr_msgs/PbrAlert.level` and `.mode`) and iceoryx2
//! (`PbrAlertIox::level` and `::mode`).
//!
//! The numbering is an interface contract, fixed by the constants of `msg/pbr_msgs/msg/PbrState.msg` and
//! `msg/pbr_msgs/msg/PbrAlert.msg` (which docs/iceoryx2.md repeats for the C, C++ and Python clients), not a
//! property of the physics: it lives here in the shell, next to the transports, and the core's
//! [`Mode`] and [`AlertLevel`] stay free of wire concerns. `tests/ros2_msgs.rs` checks this
//! table against the `.msg` files and that both transports send the same codes.

use rockwatch_core::dynamics::Mode;
use rockwatch_core::engine::{AlertLevel, SampleUnit};

/// `PbrState` / `PbrAlert` mode constants.
pub const MODE_REST: u8 = 0;
pub const MODE_SLIDE: u8 = 1;
pub const MODE_ROCK: u8 = 2;
pub const MODE_SLIDE_ROCK: u8 = 3;
pub const MODE_OVERTURNED: u8 = 4;
pub const MODE_FLIGHT: u8 = 5;

/// `PbrAlert` level constants.
pub const LEVEL_MOTION_ONSET: u8 = 1;
pub const LEVEL_OVERTURN_IMMINENT: u8 = 2;
pub const LEVEL_OVERTURNED: u8 = 3;
/// `PbrAlert.RESET`: an operator reset of a fallen block (`Publication::Reset`), not an engine
/// alert level.
pub const LEVEL_RESET: u8 = 4;

/// `AccelPacket.unit` constants (iceoryx2: the `COUNTS` header flag instead).
pub const UNIT_MPS2: u8 = 0;
pub const UNIT_COUNTS: u8 = 1;

/// The sample unit of a wire code (an unknown code is kept, to be refused by the engine).
#[must_use]
pub fn unit_of_code(code: u8) -> SampleUnit {
    match code {
        UNIT_MPS2 => SampleUnit::MetresPerSecondSquared,
        UNIT_COUNTS => SampleUnit::Counts,
        other => SampleUnit::Unknown(other),
    }
}

/// The wire code of a sample unit.
#[must_use]
pub fn unit_code(unit: SampleUnit) -> u8 {
    match unit {
        SampleUnit::MetresPerSecondSquared => UNIT_MPS2,
        SampleUnit::Counts => UNIT_COUNTS,
        SampleUnit::Unknown(code) => code,
    }
}

/// The wire code of a mode.
#[must_use]
pub fn mode_code(mode: Mode) -> u8 {
    match mode {
        Mode::Rest => MODE_REST,
        Mode::Slide => MODE_SLIDE,
        Mode::Rock => MODE_ROCK,
        Mode::SlideRock => MODE_SLIDE_ROCK,
        Mode::Overturned => MODE_OVERTURNED,
        Mode::Flight => MODE_FLIGHT,
    }
}

/// The wire code of an alert level.
#[must_use]
pub fn level_code(level: AlertLevel) -> u8 {
    match level {
        AlertLevel::MotionOnset => LEVEL_MOTION_ONSET,
        AlertLevel::OverturnImminent => LEVEL_OVERTURN_IMMINENT,
        AlertLevel::Overturned => LEVEL_OVERTURNED,
    }
}

/// The alert level of a wire code, if it is one.
#[must_use]
pub fn level_of_code(code: u8) -> Option<AlertLevel> {
    AlertLevel::ALL.into_iter().find(|l| level_code(*l) == code)
}

/// The name of a `PbrAlert.level` code: an alert level's (`overturned`, …), `reset`, or
/// `unknown`.
#[must_use]
pub fn level_name(code: u8) -> &'static str {
    match level_of_code(code) {
        Some(level) => level.as_str(),
        None if code == LEVEL_RESET => "reset",
        None => "unknown",
    }
}

/// The block mode of a wire code, if it is one.
#[must_use]
pub fn mode_of_code(code: u8) -> Option<Mode> {
    Mode::ALL.into_iter().find(|m| mode_code(*m) == code)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_mode_and_level_round_trips_and_other_codes_are_refused() {
        for mode in Mode::ALL {
            assert_eq!(mode_of_code(mode_code(mode)), Some(mode));
        }
        for level in AlertLevel::ALL {
            assert_eq!(level_of_code(level_code(level)), Some(level));
        }
        assert_eq!(mode_of_code(MODE_FLIGHT + 1), None);
        assert_eq!(level_of_code(0), None);
        assert_eq!(
            level_of_code(LEVEL_OVERTURNED + 1),
            None,
            "RESET is no engine level"
        );
        assert_eq!(level_name(LEVEL_RESET), "reset");
        assert_eq!(level_name(LEVEL_OVERTURNED), "overturned");
        assert_eq!(level_name(0), "unknown");
    }
}
