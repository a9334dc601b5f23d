//! The `[ros2]` section of the node configuration: namespace, DDS domain and discovery range,
//! interfaces, the QoS and depth of the inputs, and the `sensor_msgs/msg/Imu` inputs.

use std::net::IpAddr;

use super::names::{Naming, Remap, NODE_NAME};

/// `ROS_AUTOMATIC_DISCOVERY_RANGE` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum DiscoveryRange {
    /// No discovery beyond this host (treated as `Localhost`: loopback only).
    Off,
    /// Loopback only.
    Localhost,
    /// Every interface (or those named in `interfaces`).
    Subnet,
    /// As `Subnet`.
    SystemDefault,
}

impl std::str::FromStr for DiscoveryRange {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "OFF" => Ok(DiscoveryRange::Off),
            "LOCALHOST" => Ok(DiscoveryRange::Localhost),
            "SUBNET" => Ok(DiscoveryRange::Subnet),
            "SYSTEM_DEFAULT" | "" => Ok(DiscoveryRange::SystemDefault),
            other => Err(format!(
                "ROS_AUTOMATIC_DISCOVERY_RANGE must be OFF, LOCALHOST, SUBNET or SYSTEM_DEFAULT, got {other:?}"
            )),
        }
    }
}

/// QoS of the input subscriptions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputQos {
    /// Reliable, volatile, keep last `input_depth`.
    #[default]
    Reliable,
    /// Best effort, volatile (the ROS 2 sensor-data profile), keep last `input_depth`.
    SensorData,
}

/// A `sensor_msgs/msg/Imu` topic read as a station: one message = one sample.
///
/// Frame: the Imu must be mounted level with x east, y north, z up (ENU, REP 103);
/// `linear_acceleration` (m/s²) is taken as east = x, north = y, up = z − g when
/// `remove_gravity` (an accelerometer reports the specific force: +g on z at rest, REP 145).
/// There is no rotation: a sensor mounted otherwise must be re-published in ENU first.
/// `orientation` and `angular_velocity` are ignored. `header.stamp` is the sample time: the
/// node places each message on the station's sample grid (rate `sample_rate_hz`), so stamps
/// must advance by 1/`sample_rate_hz` per message (sensor time, not the arrival time).
/// The subscription uses the ROS 2 sensor-data QoS by default (best effort, as REP 2003 asks
/// of sensor subscribers): it matches Imu drivers that publish best effort (most do) as well
/// as reliable ones. `qos = "reliable"` asks reliable publishers to repair losses, but then a
/// best-effort driver is never matched (no data, no error: DDS QoS mismatch).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuInput {
    /// Topic name, e.g. `/imu/data`.
    pub topic: String,
    /// Station SEED id `NET.STA.LOC` the samples belong to (checked when the configuration
    /// is read).
    pub station: rockwatch_core::engine::StationId,
    /// Nominal sample rate (Hz) of the topic.
    pub sample_rate_hz: f64,
    /// Subtract standard gravity from z (m/s²; default true: an Imu at rest reads +g up).
    #[serde(default = "yes")]
    pub remove_gravity: bool,
    /// QoS of this subscription (default `sensor_data`; `reliable` keeps `input_depth`).
    #[serde(default = "sensor_data")]
    pub qos: InputQos,
}

fn yes() -> bool {
    true
}

fn sensor_data() -> InputQos {
    InputQos::SensorData
}

/// The `[ros2]` section of the node configuration.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Ros2Config {
    /// Node namespace (`/` by default). The node's topics and service are relative
    /// (`pbr/alerts`), so they resolve in it (`/site_a/pbr/alerts`); so do relative Imu
    /// topics. `--ros-args -r __ns:=/x` overrides it.
    pub namespace: String,
    /// DDS domain id; default `ROS_DOMAIN_ID`, else 0.
    pub domain_id: Option<u16>,
    /// Discovery range; default `ROS_AUTOMATIC_DISCOVERY_RANGE`, else SUBNET.
    pub discovery_range: Option<DiscoveryRange>,
    /// Local interface addresses to use (multicast and advertised locators); empty = all.
    /// Ignored under LOCALHOST/OFF, which use 127.0.0.1 only.
    pub interfaces: Vec<IpAddr>,
    /// QoS of `/pbr/accel` (each Imu topic has its own `qos`).
    pub input_qos: InputQos,
    /// History depth of the reliable input subscriptions (messages).
    pub input_depth: usize,
    /// `sensor_msgs/msg/Imu` inputs.
    pub imu: Vec<ImuInput>,
    /// Origin of the 3-D view's `map` frame (local ENU): `[lat, lon, alt]`, WGS84 degrees
    /// and ellipsoidal height (m); default the mean position of the node's rocks at 0 m
    /// (`ros2::markers`). Checked at start.
    pub map_origin: Option<[f64; 3]>,
    /// The node's name (`rockwatch`; `--ros-args -r __node:=NAME`): command line only.
    #[serde(skip)]
    pub node_name: Option<String>,
    /// Remap rules (`--ros-args -r from:=to`): command line only.
    #[serde(skip)]
    pub remaps: Vec<Remap>,
    /// `use_sim_time` (`--ros-args -p use_sim_time:=true`, a launch file's
    /// `SetParameter`): accepted and reported, without effect on the stamps, which are data
    /// times ([`PARAM_USE_SIM_TIME`](super::parameters::PARAM_USE_SIM_TIME)): command line
    /// only.
    #[serde(skip)]
    pub use_sim_time: bool,
    /// The SROS2 enclave (`--ros-args --enclave NAME`), instead of the command's own
    /// (`ROS_SECURITY_ENCLAVE_OVERRIDE` still wins): command line only.
    #[serde(skip)]
    pub enclave: Option<String>,
}

impl Default for Ros2Config {
    fn default() -> Self {
        Ros2Config {
            namespace: "/".into(),
            domain_id: None,
            discovery_range: None,
            interfaces: Vec::new(),
            input_qos: InputQos::Reliable,
            input_depth: 1000,
            imu: Vec::new(),
            map_origin: None,
            node_name: None,
            remaps: Vec::new(),
            use_sim_time: false,
            enclave: None,
        }
    }
}

impl Ros2Config {
    /// How the node's names resolve: namespace, node name and remaps, checked.
    pub fn naming(&self) -> anyhow::Result<Naming> {
        Naming::new(
            &self.namespace,
            self.node_name.as_deref().unwrap_or(NODE_NAME),
            self.remaps.clone(),
        )
        .map_err(|e| e.context("[ros2]"))
    }

    /// Loopback only, whatever the environment says (the demo and tests).
    #[must_use]
    pub fn loopback_only() -> Ros2Config {
        Ros2Config {
            discovery_range: Some(DiscoveryRange::Localhost),
            ..Ros2Config::default()
        }
    }
}
