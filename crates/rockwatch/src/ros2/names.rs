//! The node's names in the ROS graph: the node, its topics and its service (absolute names,
//! whatever the namespace), and the service's ROS 2 <-> DDS mapping.

use ros2_client::ServiceMapping;

/// The node's name in the ROS graph.
pub const NODE_NAME: &str = "rockwatch";
/// Input topic (`pbr_msgs/AccelPacket`).
pub const ACCEL_TOPIC: &str = "/pbr/accel";
/// Output topics.
pub const IMS_TOPIC: &str = "/pbr/ims";
pub const STATE_TOPIC: &str = "/pbr/state";
pub const ALERTS_TOPIC: &str = "/pbr/alerts";
/// What the node has taken from each writer of [`ACCEL_TOPIC`] (`pbr_msgs/IntakeReport`).
pub const INTAKE_TOPIC: &str = "/pbr/intake";
/// The node's status (`diagnostic_msgs/DiagnosticArray`), absolute as diagnostic_updater's.
pub const DIAGNOSTICS_TOPIC: &str = "/diagnostics";
/// The operator reset service (`pbr_msgs/srv/ResetPbr`), absolute like the topics.
pub const RESET_SERVICE: &str = "/pbr/reset";
/// The ROS 2 <-> DDS mapping of the reset service: the "enhanced" RPC-over-DDS mapping, that of
/// ROS 2's default middleware (rmw_fastrtps) and of rmw_connextdds; rmw_cyclonedds uses its
/// own, and its clients are not served (as for the parameter services).
pub const RESET_SERVICE_MAPPING: ServiceMapping = ServiceMapping::Enhanced;
