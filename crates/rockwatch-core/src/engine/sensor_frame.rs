//! Sensor frames: from what an accelerometer measures to the ground acceleration the engine
//! takes (east, north, up, m/s²). Physics only; the transports decode their messages and call
//! this.

use crate::STANDARD_GRAVITY_MPS2;

/// The ground acceleration `[east, north, up]` (m/s²) measured by an accelerometer mounted
/// level with x east, y north, z up (ENU axes, REP 103), from its reading
/// `specific_force_xyz_mps2` (m/s², positive along +x, +y, +z).
///
/// An accelerometer measures the specific force, the ground acceleration minus gravity's:
/// at rest it reads +g on z (REP 145). With `remove_gravity`, up = z − g
/// (g = [`STANDARD_GRAVITY_MPS2`]); without, z is taken as is (a driver that has removed
/// gravity already). East = x and north = y: there is no rotation, so a sensor mounted
/// otherwise must be rotated into ENU first.
#[must_use]
pub fn ground_acceleration_enu(
    specific_force_xyz_mps2: [f64; 3],
    remove_gravity: bool,
) -> [f64; 3] {
    let [x, y, z] = specific_force_xyz_mps2;
    let up = if remove_gravity {
        z - STANDARD_GRAVITY_MPS2
    } else {
        z
    };
    [x, y, up]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xyz_maps_to_east_north_up_and_gravity_is_removed_from_up_only() {
        let [east, north, up] = ground_acceleration_enu([0.5, -0.25, 9.80665 + 0.125], true);
        assert_eq!((east, north), (0.5, -0.25));
        // The f64 subtraction of g leaves < 1e-15 error.
        assert!((up - 0.125).abs() < 1e-12);
        // Without removal the reading passes through unchanged; at rest with removal, 0.
        assert_eq!(
            ground_acceleration_enu([0.5, -0.25, 0.125], false),
            [0.5, -0.25, 0.125]
        );
        assert_eq!(
            ground_acceleration_enu([0.0, 0.0, STANDARD_GRAVITY_MPS2], true),
            [0.0, 0.0, 0.0]
        );
    }
}
