//! ROS 2 transport (ros2-client over RustDDS): the `pbr_msgs` interfaces, the node's
//! subscriptions, publishers, parameters and reset service, the replay sink, an alert
//! listener and the reset client.
//!
//! Networking follows rclcpp: the DDS domain is `ROS_DOMAIN_ID` (default 0) and
//! `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (or `OFF`) restricts the participant to the
//! loopback interface (multicast joins, multicast sends and advertised locators); the `[ros2]`
//! section of the node configuration may override both and name the interfaces to use.
//!
//! - [`msg`]: the `pbr_msgs` messages and service on the wire; [`viz_msg`]: the standard
//!   messages of the 3-D view (markers, transforms);
//! - [`markers`]: the 3-D view, `pbr/markers` and `/tf_static` ([`Scene`]);
//! - `names.rs`: the node, topic and service names and their resolution ([`Naming`]);
//! - `ros_args.rs`: `--ros-args` ([`RosArgs`]);
//! - [`diagnostics`]: the node's status on `/diagnostics`, its log records on `/rosout`;
//! - `config.rs`: the `[ros2]` configuration section;
//! - `network.rs`: the DDS domain and interfaces ([`NetworkPlan`]);
//! - `security.rs`: DDS Security from the SROS2 variables and keystore ([`security_plan`]);
//! - `qos.rs`: the QoS profiles;
//! - `session.rs`: a participant with one ROS 2 node ([`Ros2Session`]);
//! - `/pbr/intake` carries the intake reports of `crate::intake` (`pbr_msgs/IntakeReport`);
//! - `liveness.rs`: whether a participant's RustDDS threads still run ([`DdsThreads`]);
//! - `watchdog.rs`: the node's [`Watchdog`], which rebuilds a participant whose threads ended;
//! - `node.rs`: the node's ROS 2 side ([`Ros2Node`]), made of `parameters.rs` (descriptors and
//!   the parameter services), `input.rs` (with `imu.rs`), `publish.rs` and `reset.rs` (both
//!   services on `held_server.rs`);
//! - clients: `packet_sink.rs`, `reset_client.rs`, `alert_listener.rs`.

mod alert_listener;
mod config;
pub mod diagnostics;
mod held_server;
mod imu;
mod input;
mod liveness;
pub mod markers;
pub mod msg;
mod names;
mod network;
mod node;
mod packet_sink;
mod parameters;
mod publish;
mod qos;
mod reset;
mod reset_client;
pub mod ros_args;
mod rpc_wire;
mod security;
mod session;
pub mod viz_msg;
mod watchdog;

pub use alert_listener::Ros2AlertListener;
pub use config::{DiscoveryRange, ImuInput, InputQos, Ros2Config};
pub use imu::{imu_packet, ImuMsg};
pub use input::IntakeCounters;
pub use liveness::DdsThreads;
pub use markers::{rock_frame, Scene, SceneError, MAP_FRAME, MARKER_PERIOD};
pub use names::{
    accel_topic, IntoNaming, Naming, Remap, ACCEL_TOPIC, ALERTS_TOPIC, DIAGNOSTICS_TOPIC,
    IMS_TOPIC, INTAKE_TOPIC, MARKERS_TOPIC, NODE_NAME, RESET_SERVICE, RESET_SERVICE_MAPPING,
    STATE_TOPIC, TF_STATIC_TOPIC,
};
pub use network::{network_plan, network_plan_from_env, NetworkPlan, NetworkPlanError};
pub use node::Ros2Node;
pub use packet_sink::{Ros2PacketSink, CREDIT_WINDOW, DEFAULT_INTAKE_WAIT};
pub use parameters::{
    param_spec, ParamSpec, ParamValues, PARAMETERS, PARAM_CATALOGUE, PARAM_IMMINENT_PROBABILITY,
    PARAM_IMMINENT_THETA_RATIO, PARAM_QUIET_S, PARAM_QUIET_THRESHOLD_MPS2, PARAM_STATE_DIR,
    PARAM_STATE_INTERVAL_S,
};
pub use publish::Ros2Publisher;
pub use qos::{
    alerts_qos, input_qos, intake_qos, output_qos, replay_qos, sender_status_qos, service_qos,
    view_qos, REPLAY_HISTORY,
};
pub use reset::{RESET_MATCH_GRACE, RESET_REPLIES_HELD, RESET_REPLY_WAIT, RESET_REQUESTS_PER_TURN};
pub use reset_client::Ros2ResetClient;
pub use ros_args::{split_ros_args, RosArgs};
pub use security::{
    pad_for_protection, security_from_env, security_plan, DdsSecurity, SecurityEnv, SecurityError,
    SecurityPlan, ENCLAVE_FILES, NODE_ENCLAVE, OPERATOR_ENCLAVE, READER_ENCLAVE, STATION_ENCLAVE,
};
pub use session::Ros2Session;
pub use watchdog::{Ros2Tokens, Watchdog, LIVENESS_CHECK, REBUILD_GIVE_UP};
