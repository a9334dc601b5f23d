//! `sensor_msgs/msg/Imu` as an input: the message's wire layout and its reading as a
//! one-sample packet of the configured station (the physics of the reading, gravity and axes,
//! is the core's [`ground_acceleration_enu`]).

use rockwatch_core::engine::sensor_frame::ground_acceleration_enu;
use rockwatch_core::engine::AccelPacket;

use super::config::ImuInput;
use super::msg;

/// The `sensor_msgs/msg/Imu` wire layout (fixed arrays carry no length in CDR).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct ImuMsg {
    pub header: msg::Header,
    /// Quaternion x, y, z, w.
    pub orientation: [f64; 4],
    pub orientation_covariance: [f64; 9],
    /// rad/s.
    pub angular_velocity: [f64; 3],
    pub angular_velocity_covariance: [f64; 9],
    /// m/s².
    pub linear_acceleration: [f64; 3],
    pub linear_acceleration_covariance: [f64; 9],
}
impl ros2_client::Message for ImuMsg {}

/// One Imu message as a one-sample packet of its configured station: `linear_acceleration`
/// (m/s², ENU-mounted sensor) as east/north/up ground acceleration, `header.stamp` as the
/// sample time.
#[must_use]
pub fn imu_packet(imu: &ImuInput, m: &ImuMsg, sequence: u64) -> AccelPacket {
    let [east, north, up] = ground_acceleration_enu(m.linear_acceleration, imu.remove_gravity);
    AccelPacket {
        station: imu.station.clone(),
        start_time_ns: m.header.stamp.to_nanos(),
        sample_rate_hz: imu.sample_rate_hz,
        sequence,
        east: vec![east as f32],
        north: vec![north as f32],
        up: vec![up as f32],
        unit: rockwatch_core::engine::SampleUnit::MetresPerSecondSquared, // sensor_msgs/Imu: m/s²
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::config::InputQos;

    #[test]
    fn imu_sample_maps_xyz_to_east_north_up_without_gravity() {
        let imu = ImuInput {
            topic: "/imu".into(),
            station: rockwatch_core::engine::StationId::parse("XX.IMU.00").unwrap(),
            sample_rate_hz: 200.0,
            remove_gravity: true,
            qos: InputQos::SensorData,
        };
        let m = ImuMsg {
            header: msg::Header::new(1_500_000_000, "imu_link"),
            orientation: [0.0, 0.0, 0.0, 1.0],
            orientation_covariance: [0.0; 9],
            angular_velocity: [0.0; 3],
            angular_velocity_covariance: [0.0; 9],
            linear_acceleration: [0.5, -0.25, 9.80665 + 0.125],
            linear_acceleration_covariance: [0.0; 9],
        };
        let p = imu_packet(&imu, &m, 42);
        assert_eq!((p.east[0], p.north[0]), (0.5, -0.25));
        // 0.125 is exact in f32; the f64 subtraction of g leaves < 1e-15 error.
        assert!((p.up[0] - 0.125).abs() < 1e-6);
        assert_eq!(
            (p.sequence, p.start_time_ns, p.sample_rate_hz),
            (42, 1_500_000_000, 200.0)
        );
    }
}
