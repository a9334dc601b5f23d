//! The node's names in the ROS graph: the node, its topics and its service (absolute names,
//! whatever the namespace), and the service's ROS 2 <-> DDS mapping.

use rockwatch_core::partition::Partition;
use ros2_client::ServiceMapping;

/// The node's name in the ROS graph.
pub const NODE_NAME: &str = "rockwatch";
/// Input topic (`pbr_msgs/AccelPacket`).
pub const ACCEL_TOPIC: &str = "/pbr/accel";
/// The input topic of `partition` of a scaled-out service, `/pbr/accel/p<i>of<N>`
/// (docs/capacity.md); [`ACCEL_TOPIC`] without one. RustDDS 0.15 implements neither the DDS
/// Partition QoS nor content-filtered topics, and ROS 2 messages carry no DDS key: a topic per
/// partition is what lets a node receive only its stations' packets.
#[must_use]
pub fn accel_topic(partition: Option<Partition>) -> String {
    match partition {
        Some(p) => format!("{ACCEL_TOPIC}/p{}of{}", p.index(), p.count()),
        None => ACCEL_TOPIC.to_string(),
    }
}

/// Output topics.
pub const IMS_TOPIC: &str = "/pbr/ims";
pub const STATE_TOPIC: &str = "/pbr/state";
pub const ALERTS_TOPIC: &str = "/pbr/alerts";
/// What the node has taken from each writer of [`ACCEL_TOPIC`] (`pbr_msgs/IntakeReport`).
pub const INTAKE_TOPIC: &str = "/pbr/intake";
/// The operator reset service (`pbr_msgs/srv/ResetPbr`), absolute like the topics.
pub const RESET_SERVICE: &str = "/pbr/reset";
/// The ROS 2 <-> DDS mapping of the reset service: the "enhanced" RPC-over-DDS mapping, that of
/// ROS 2's default middleware (rmw_fastrtps) and of rmw_connextdds; rmw_cyclonedds uses its
/// own, and its clients are not served (as for the parameter services).
pub const RESET_SERVICE_MAPPING: ServiceMapping = ServiceMapping::Enhanced;
