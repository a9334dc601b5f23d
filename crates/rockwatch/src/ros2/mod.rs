//! ROS 2 transport (ros2-client over RustDDS): the `pbr_msgs` interfaces, the node's
//! subscriptions, publishers, parameters and reset service, the replay sink, an alert
//! listener and the reset client.
//!
//! Networking follows rclcpp: the DDS domain is `ROS_DOMAIN_ID` (default 0) and
//! `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (or `OFF`) restricts the participant to the
//! loopback interface (multicast joins, multicast sends and advertised locators); the `[ros2]`
//! section of the node configuration may override both and name the interfaces to use.

pub mod msg;

use std::net::{IpAddr, Ipv4Addr};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context as _};
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Registry, Token};
use ros2_client::dds::rustdds::{
    no_key, DataWriterStatus, DomainParticipantBuilder, StatusEvented,
};
use ros2_client::qos::{Durability, History, Reliability, WhenFull};
use ros2_client::{
    Client, Context, MessageTypeName, Name, Node, NodeName, NodeOptions, ParameterValue,
    QosProfile, RmwRequestId, Server, ServiceMapping, ServiceTypeName, Subscription,
};

use crate::ports::{ControlSender, PacketSink, Publication};
use rockwatch_core::engine::{AccelPacket, AlertConfig, EngineConfig};

/// The node's name in the ROS graph.
pub const NODE_NAME: &str = "rockwatch";
/// Input topic (`pbr_msgs/AccelPacket`).
pub const ACCEL_TOPIC: &str = "/pbr/accel";
/// Output topics.
pub const IMS_TOPIC: &str = "/pbr/ims";
pub const STATE_TOPIC: &str = "/pbr/state";
pub const ALERTS_TOPIC: &str = "/pbr/alerts";
/// History depth of `/pbr/alerts` (transient local: a late subscriber gets this many).
pub const ALERTS_DEPTH: usize = 1000;
/// The operator reset service (`pbr_msgs/srv/ResetPbr`), absolute like the topics.
pub const RESET_SERVICE: &str = "/pbr/reset";
/// The ROS 2 <-> DDS mapping of the reset service: the "enhanced" RPC-over-DDS mapping, that of
/// ROS 2's default middleware (rmw_fastrtps) and of rmw_connextdds; rmw_cyclonedds uses its
/// own, and its clients are not served (as for the parameter services).
pub const RESET_SERVICE_MAPPING: ServiceMapping = ServiceMapping::Enhanced;
/// Longest a reset response waits for the requesting client's response reader to be
/// discovered (a volatile writer does not send a sample to a reader it has not matched).
pub const RESET_REPLY_WAIT: Duration = Duration::from_secs(2);
/// How long a reset response waits after its client's reader is discovered, for RustDDS to
/// match that reader with the response writer.
pub const RESET_MATCH_GRACE: Duration = Duration::from_millis(20);
/// Most reset requests served per turn of the event loop (the rest on the next turn).
pub const RESET_REQUESTS_PER_TURN: usize = 64;
/// Most reset responses held for their client (see [`Ros2Node::send_due_replies`]); beyond,
/// a response is sent at once (bounded memory and work under a flood of requests).
pub const RESET_REPLIES_HELD: usize = 256;

/// ROS 2 parameter names of the run-time settings (all doubles).
pub const PARAM_IMMINENT_THETA_RATIO: &str = "alerts.imminent_theta_ratio";
pub const PARAM_IMMINENT_PROBABILITY: &str = "alerts.imminent_probability";
pub const PARAM_QUIET_THRESHOLD_MPS2: &str = "alerts.quiet_threshold_mps2";
pub const PARAM_QUIET_S: &str = "alerts.quiet_s";
pub const PARAM_STATE_INTERVAL_S: &str = "state_interval_s";

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
    /// Station SEED id `NET.STA.LOC` the samples belong to.
    pub station: String,
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
    /// Node namespace (`/` by default); topics are absolute (`/pbr/...`).
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
        }
    }
}

impl Ros2Config {
    /// Loopback only, whatever the environment says (the demo and tests).
    #[must_use]
    pub fn loopback_only() -> Ros2Config {
        Ros2Config {
            discovery_range: Some(DiscoveryRange::Localhost),
            ..Ros2Config::default()
        }
    }
}

/// Which DDS domain and interfaces a participant uses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NetworkPlan {
    pub domain_id: u16,
    /// `None`: every interface.
    pub only_networks: Option<Vec<IpAddr>>,
}

/// Resolves the configuration and the values of `ROS_DOMAIN_ID` and
/// `ROS_AUTOMATIC_DISCOVERY_RANGE` (the environment variables, passed in) into a plan.
pub fn network_plan(
    config: &Ros2Config,
    ros_domain_id: Option<&str>,
    ros_discovery_range: Option<&str>,
) -> Result<NetworkPlan, String> {
    let domain_id = match (config.domain_id, ros_domain_id.map(str::trim)) {
        (Some(d), _) => d,
        (None, None | Some("")) => 0,
        (None, Some(s)) => s
            .parse::<u16>()
            .map_err(|_| format!("ROS_DOMAIN_ID must be an integer 0..=232, got {s:?}"))?,
    };
    if domain_id > 232 {
        return Err(format!("DDS domain id must be 0..=232, got {domain_id}"));
    }
    let range = match (config.discovery_range, ros_discovery_range) {
        (Some(r), _) => r,
        (None, None) => DiscoveryRange::SystemDefault,
        (None, Some(s)) => s.trim().parse()?,
    };
    let only_networks = match range {
        DiscoveryRange::Off | DiscoveryRange::Localhost => {
            Some(vec![IpAddr::V4(Ipv4Addr::LOCALHOST)])
        }
        DiscoveryRange::Subnet | DiscoveryRange::SystemDefault if !config.interfaces.is_empty() => {
            Some(config.interfaces.clone())
        }
        DiscoveryRange::Subnet | DiscoveryRange::SystemDefault => None,
    };
    Ok(NetworkPlan {
        domain_id,
        only_networks,
    })
}

/// The plan for this process's environment.
pub fn network_plan_from_env(config: &Ros2Config) -> Result<NetworkPlan, String> {
    let domain = std::env::var("ROS_DOMAIN_ID").ok();
    let range = std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE").ok();
    network_plan(config, domain.as_deref(), range.as_deref())
}

/// QoS of `/pbr/alerts`: reliable, transient local, keep last [`ALERTS_DEPTH`].
#[must_use]
pub fn alerts_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(1)))
        .durability(Durability::TransientLocal)
        .history(History::KeepLast {
            depth: ALERTS_DEPTH,
        })
}

/// QoS of `/pbr/state` and `/pbr/ims`: reliable, volatile, keep last 100.
#[must_use]
pub fn output_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 100 })
}

/// QoS of an input subscription: `kind`, with `depth` for the reliable one.
#[must_use]
pub fn input_qos(kind: InputQos, depth: usize) -> QosProfile {
    match kind {
        InputQos::Reliable => QosProfile::subscription_default()
            .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
            .history(History::KeepLast {
                depth: depth.max(1),
            }),
        // Best effort as the ROS 2 sensor-data profile, but with the deep history of the
        // reliable one: the reader's depth does not affect matching, and the node's event loop
        // may be busy for a moment (an alert's fsync) while a 200 Hz Imu keeps sending.
        InputQos::SensorData => QosProfile::subscription_default()
            .reliability(Reliability::BestEffort)
            .history(History::KeepLast {
                depth: depth.max(1),
            }),
    }
}

/// QoS of the reset service's requests and responses: ROS 2's services default (reliable,
/// volatile, keep last 10).
#[must_use]
pub fn service_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// QoS of the replay publisher: reliable and keep-all, so `publish` waits for the
/// subscriber instead of dropping packets.
#[must_use]
pub fn replay_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::Wait(Duration::from_secs(5)))
        .durability(Durability::Volatile)
        .history(History::KeepAll)
}

fn dds_err(what: &str) -> impl Fn(ros2_client::CreateError) -> anyhow::Error + '_ {
    move |e| anyhow!("ROS 2: {what}: {e:?}")
}

/// A DDS participant with one ROS 2 node and its spinner thread (discovery, parameters).
pub struct Ros2Session {
    node: Node,
    context: Context,
    plan: NetworkPlan,
    spinner: Option<JoinHandle<()>>,
}

impl Ros2Session {
    /// Creates the participant following `plan` and the node `namespace`/`name`.
    pub fn open(
        plan: &NetworkPlan,
        namespace: &str,
        name: &str,
        options: NodeOptions,
    ) -> anyhow::Result<Ros2Session> {
        let mut builder = DomainParticipantBuilder::new(plan.domain_id);
        if let Some(networks) = &plan.only_networks {
            builder = builder.with_only_networks(networks.iter().copied());
        }
        let participant = builder
            .build()
            .map_err(|e| anyhow!("DDS participant (domain {}): {e:?}", plan.domain_id))?;
        let context = Context::from_domain_participant(participant).map_err(dds_err("context"))?;
        let node_name = NodeName::new(namespace, name)
            .map_err(|e| anyhow!("ROS 2 node name {namespace:?}/{name:?}: {e:?}"))?;
        let mut node = context
            .new_node(node_name, options)
            .map_err(|e| anyhow!("ROS 2 node: {e:?}"))?;
        let spinner = node.spinner().map_err(dds_err("spinner"))?;
        let spinner = std::thread::Builder::new()
            .name(format!("ros2-spin-{name}"))
            .spawn(move || {
                if let Err(e) = futures::executor::block_on(spinner.spin()) {
                    eprintln!("rockwatch: ROS 2 spinner stopped: {e:?}");
                }
            })?;
        Ok(Ros2Session {
            node,
            context,
            plan: plan.clone(),
            spinner: Some(spinner),
        })
    }

    /// The network plan the participant was built with.
    #[must_use]
    pub fn plan(&self) -> &NetworkPlan {
        &self.plan
    }

    /// The ROS 2 node.
    pub fn node(&mut self) -> &mut Node {
        &mut self.node
    }

    fn topic(
        &mut self,
        name: &str,
        package: &str,
        type_name: &str,
        qos: &QosProfile,
    ) -> anyhow::Result<ros2_client::dds::rustdds::Topic> {
        let topic_name = Name::parse(name).map_err(|e| anyhow!("topic {name:?}: {e:?}"))?;
        self.node
            .create_topic(&topic_name, MessageTypeName::new(package, type_name), qos)
            .map_err(|e| anyhow!("ROS 2 topic {name}: {e:?}"))
    }

    /// A publisher of `pbr_msgs/<type_name>` on `name`.
    pub fn publisher<M: serde::Serialize>(
        &mut self,
        name: &str,
        type_name: &str,
        qos: QosProfile,
    ) -> anyhow::Result<ros2_client::Publisher<M>> {
        let topic = self.topic(name, msg::PACKAGE, type_name, &qos)?;
        self.node
            .create_publisher(&topic, Some(qos))
            .map_err(|e| anyhow!("ROS 2 publisher {name}: {e:?}"))
    }

    /// A subscription to `<package>/<type_name>` on `name`.
    pub fn subscription<M: 'static>(
        &mut self,
        name: &str,
        package: &str,
        type_name: &str,
        qos: QosProfile,
    ) -> anyhow::Result<Subscription<M>> {
        let topic = self.topic(name, package, type_name, &qos)?;
        self.node
            .create_subscription(&topic, Some(qos))
            .map_err(|e| anyhow!("ROS 2 subscription {name}: {e:?}"))
    }
}

impl Drop for Ros2Session {
    fn drop(&mut self) {
        self.node.stop_spinner();
        if let Some(spinner) = self.spinner.take() {
            let _ = spinner.join();
        }
    }
}

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

/// Counters of the node's ROS 2 intake.
#[derive(Debug, Default)]
pub struct IntakeCounters {
    /// Packets received and handed to the engine.
    pub packets: AtomicU64,
    /// Messages that could not be decoded (reported by DDS as read errors).
    pub decode_errors: AtomicU64,
}

/// The node's ROS 2 side: parameters, the input subscriptions, the reset service and (returned
/// separately by [`Ros2Node::start`]) the output publishers. It has no intake thread: the
/// node's event loop registers the subscriptions ([`Ros2Node::register`]) and the service
/// ([`Ros2Node::register_reset`]), drains the subscriptions that are ready
/// ([`Ros2Node::drain`]) and serves the service ([`Ros2Node::serve_resets`]).
pub struct Ros2Node {
    session: Ros2Session,
    accel: Subscription<msg::AccelPacket>,
    /// Imu inputs with the sequence number of their next one-sample packet.
    imus: Vec<(ImuInput, Subscription<ImuMsg>, u64)>,
    pub counters: Arc<IntakeCounters>,
    last_error_report: Option<Instant>,
    /// The `/pbr/reset` server and the DDS name of its response topic.
    reset: Server<msg::ResetPbrRequest, msg::ResetPbrResponse>,
    reset_reply_topic: String,
    /// Responses waiting for their client's response reader to be discovered.
    pending_replies: Vec<PendingReply>,
}

/// A reset response not sent yet (see [`Ros2Node::send_due_replies`]).
struct PendingReply {
    id: RmwRequestId,
    response: msg::ResetPbrResponse,
    since: Instant,
    /// When the client's response reader was first seen in the discovery database.
    discovered: Option<Instant>,
}

/// The node's output publishers (a [`crate::ports::Publisher`]).
pub struct Ros2Publisher {
    alerts: ros2_client::Publisher<msg::PbrAlert>,
    states: ros2_client::Publisher<msg::PbrState>,
    ims: ros2_client::Publisher<msg::StationIntensity>,
}

impl crate::ports::Publisher for Ros2Publisher {
    fn publish(&mut self, publication: &Publication) -> anyhow::Result<()> {
        let result = match publication {
            Publication::Alert { alert, .. } => self
                .alerts
                .publish(msg::PbrAlert::from(alert))
                .map_err(|e| format!("{ALERTS_TOPIC}: {e:?}")),
            Publication::State(s) => self
                .states
                .publish(msg::PbrState::from(s))
                .map_err(|e| format!("{STATE_TOPIC}: {e:?}")),
            Publication::Intensity(i) => self
                .ims
                .publish(msg::StationIntensity::from(i))
                .map_err(|e| format!("{IMS_TOPIC}: {e:?}")),
        };
        result.map_err(|e| anyhow!("ROS 2 publish failed: {e}"))
    }
}

/// Checks a parameter value: finite, > 0 (probabilities ≤ 1).
fn validate_parameter(name: &str, value: &ParameterValue) -> Result<(), String> {
    let v = parameter_f64(value).ok_or_else(|| format!("{name} must be a double"))?;
    let ok = match name {
        PARAM_IMMINENT_PROBABILITY => v > 0.0 && v <= 1.0,
        _ => v.is_finite() && v > 0.0,
    };
    if ok {
        Ok(())
    } else {
        Err(format!("{name}: invalid value {v}"))
    }
}

fn parameter_f64(value: &ParameterValue) -> Option<f64> {
    match value {
        ParameterValue::Double(v) => Some(*v),
        ParameterValue::Integer(v) => Some(*v as f64),
        _ => None,
    }
}

/// Applies a parameter to the alert configuration and hands the change to the node's event
/// loop (effective before its next packet).
fn apply_parameter(
    name: &str,
    value: &ParameterValue,
    alerts: &Mutex<AlertConfig>,
    controls: &ControlSender,
) -> Result<(), String> {
    validate_parameter(name, value)?;
    let v = parameter_f64(value).ok_or_else(|| format!("{name} must be a double"))?;
    if name == PARAM_STATE_INTERVAL_S {
        controls.set_state_interval_s(v);
        return Ok(());
    }
    let mut config = alerts
        .lock()
        .map_err(|_| "alert configuration lock poisoned".to_string())?;
    match name {
        PARAM_IMMINENT_THETA_RATIO => config.imminent_theta_ratio = v,
        PARAM_IMMINENT_PROBABILITY => config.imminent_probability = v,
        PARAM_QUIET_THRESHOLD_MPS2 => config.quiet_threshold_mps2 = v,
        PARAM_QUIET_S => config.quiet_s = v,
        // Built-in parameters such as use_sim_time.
        _ => return Ok(()),
    }
    controls.set_alert_config(*config);
    Ok(())
}

impl Ros2Node {
    /// Joins the ROS 2 graph as `<namespace>/rockwatch`, declares the parameters (initial
    /// values from `engine`; changes go to `controls`, i.e. the node's event loop), subscribes
    /// the inputs, creates the output publishers and the server of [`RESET_SERVICE`].
    pub fn start(
        config: &Ros2Config,
        plan: &NetworkPlan,
        engine: &EngineConfig,
        controls: ControlSender,
    ) -> anyhow::Result<(Ros2Node, Ros2Publisher)> {
        let alerts = Arc::new(Mutex::new(engine.alerts));
        let options = NodeOptions::new()
            .enable_rosout(true)
            .start_parameter_services(true)
            .declare_parameter(
                PARAM_IMMINENT_THETA_RATIO,
                ParameterValue::Double(engine.alerts.imminent_theta_ratio),
            )
            .declare_parameter(
                PARAM_IMMINENT_PROBABILITY,
                ParameterValue::Double(engine.alerts.imminent_probability),
            )
            .declare_parameter(
                PARAM_QUIET_THRESHOLD_MPS2,
                ParameterValue::Double(engine.alerts.quiet_threshold_mps2),
            )
            .declare_parameter(PARAM_QUIET_S, ParameterValue::Double(engine.alerts.quiet_s))
            .declare_parameter(
                PARAM_STATE_INTERVAL_S,
                ParameterValue::Double(engine.state_interval_s),
            )
            .parameter_validator(Box::new(|name, value| {
                if name.starts_with("alerts.") || name == PARAM_STATE_INTERVAL_S {
                    validate_parameter(name, value)
                } else {
                    Ok(())
                }
            }))
            .parameter_set_action(Box::new(move |name, value| {
                apply_parameter(name, value, &alerts, &controls)
            }));
        let mut session = Ros2Session::open(plan, &config.namespace, NODE_NAME, options)?;
        let publisher = Ros2Publisher {
            alerts: session.publisher(ALERTS_TOPIC, "PbrAlert", alerts_qos())?,
            states: session.publisher(STATE_TOPIC, "PbrState", output_qos())?,
            ims: session.publisher(IMS_TOPIC, "StationIntensity", output_qos())?,
        };
        let accel: Subscription<msg::AccelPacket> = session.subscription(
            ACCEL_TOPIC,
            msg::PACKAGE,
            "AccelPacket",
            input_qos(config.input_qos, config.input_depth),
        )?;
        let mut imus = Vec::new();
        for imu in &config.imu {
            if !(imu.sample_rate_hz.is_finite() && imu.sample_rate_hz > 0.0) {
                return Err(anyhow!(
                    "[[ros2.imu]] {}: sample_rate_hz must be > 0",
                    imu.topic
                ));
            }
            let qos = input_qos(imu.qos, config.input_depth);
            let sub: Subscription<ImuMsg> =
                session.subscription(&imu.topic, "sensor_msgs", "Imu", qos)?;
            imus.push((imu.clone(), sub, 0));
        }
        let reset_name =
            Name::parse(RESET_SERVICE).map_err(|e| anyhow!("service {RESET_SERVICE}: {e:?}"))?;
        let node_name = NodeName::new(&config.namespace, NODE_NAME)
            .map_err(|e| anyhow!("ROS 2 node name {:?}: {e:?}", config.namespace))?;
        let reset_reply_topic = reset_name.to_dds_name("rr", &node_name, "Reply");
        let reset = session
            .node
            .create_server(
                RESET_SERVICE_MAPPING,
                &reset_name,
                &ServiceTypeName::new(msg::PACKAGE, msg::RESET_SERVICE_TYPE),
                service_qos(),
                service_qos(),
            )
            .map_err(|e| anyhow!("ROS 2 service {RESET_SERVICE}: {e:?}"))?;
        Ok((
            Ros2Node {
                session,
                accel,
                imus,
                counters: Arc::new(IntakeCounters::default()),
                last_error_report: None,
                reset,
                reset_reply_topic,
                pending_replies: Vec::new(),
            },
            publisher,
        ))
    }

    /// Registers the `/pbr/reset` server with `registry` as `token`, readable (edge-triggered:
    /// serve every request once it is reported, see [`Ros2Node::serve_resets`]).
    pub fn register_reset(&mut self, registry: &Registry, token: Token) -> std::io::Result<()> {
        registry.register(&mut self.reset, token, Interest::READABLE)
    }

    /// Serves up to [`RESET_REQUESTS_PER_TURN`] requests of `/pbr/reset`: `handle` gets each
    /// block id and gives the response, which is sent once the client can receive it
    /// ([`Ros2Node::send_due_replies`]). Undecodable requests are counted and logged like
    /// undecodable packets. Returns true if the bound was reached (more may be waiting).
    pub fn serve_resets(&mut self, handle: &mut impl FnMut(&str) -> msg::ResetPbrResponse) -> bool {
        for _ in 0..RESET_REQUESTS_PER_TURN {
            match self.reset.receive_request() {
                Ok(Some((id, request))) => {
                    let response = handle(&request.pbr_id);
                    if self.pending_replies.len() < RESET_REPLIES_HELD {
                        self.pending_replies.push(PendingReply {
                            id,
                            response,
                            since: Instant::now(),
                            discovered: None,
                        });
                    } else if let Err(e) = self.reset.send_response(id, response) {
                        eprintln!("rockwatch: ROS 2 {RESET_SERVICE}: response not sent: {e:?}");
                    }
                }
                Ok(None) => {
                    self.send_due_replies();
                    return false;
                }
                Err(e) => self.report_error(RESET_SERVICE.to_string(), &format!("{e:?}")),
            }
        }
        self.send_due_replies();
        true
    }

    /// Reset responses not sent yet.
    #[must_use]
    pub fn pending_replies(&self) -> usize {
        self.pending_replies.len()
    }

    /// Sends each waiting reset response whose client's response reader has been discovered
    /// (a reader of the service's response topic in the requester's DDS participant: the
    /// request id names the client's writer, or with Fast DDS its reader, whose GUID prefix
    /// is its participant's), or that has waited [`RESET_REPLY_WAIT`]. The response writer is
    /// volatile, as ROS 2 services are: a response written before it has matched the client's
    /// reader would never reach it, and the request can arrive before that match (discovery
    /// is two-sided). Fast DDS servers wait in the same way. Costs nothing when none waits.
    pub fn send_due_replies(&mut self) {
        if self.pending_replies.is_empty() {
            return;
        }
        let readers = self
            .session
            .context
            .domain_participant()
            .discovered_readers();
        let topic = &self.reset_reply_topic;
        let mut i = 0;
        while i < self.pending_replies.len() {
            let p = &mut self.pending_replies[i];
            let client = ros2_client::dds::rustdds::GUID::from(p.id.writer_gid).prefix;
            if p.discovered.is_none()
                && readers.iter().any(|r| {
                    r.reader_proxy.remote_reader_guid.prefix == client
                        && r.subscription_topic_data.topic_name() == topic
                })
            {
                p.discovered = Some(Instant::now());
            }
            // The discovery database learns of the reader before RustDDS's event loop thread
            // matches it with the response writer: give it RESET_MATCH_GRACE.
            let matched = p
                .discovered
                .is_some_and(|t| t.elapsed() >= RESET_MATCH_GRACE);
            if !matched && p.since.elapsed() < RESET_REPLY_WAIT {
                i += 1;
                continue;
            }
            let p = self.pending_replies.swap_remove(i);
            if let Err(e) = self.reset.send_response(p.id, p.response) {
                eprintln!("rockwatch: ROS 2 {RESET_SERVICE}: response not sent: {e:?}");
            }
        }
    }

    /// Sends every waiting reset response now (at shutdown).
    pub fn flush_replies(&mut self) {
        for p in std::mem::take(&mut self.pending_replies) {
            if let Err(e) = self.reset.send_response(p.id, p.response) {
                eprintln!("rockwatch: ROS 2 {RESET_SERVICE}: response not sent: {e:?}");
            }
        }
    }

    /// Number of input subscriptions: `/pbr/accel` (input 0), then the Imu topics.
    #[must_use]
    pub fn inputs(&self) -> usize {
        1 + self.imus.len()
    }

    /// Registers input `i` (0..[`Ros2Node::inputs`]) with `registry` as `Token(first + i)`,
    /// readable. Readiness is edge-triggered: drain an input fully once it is reported.
    pub fn register(&mut self, registry: &Registry, first: usize) -> std::io::Result<()> {
        registry.register(&mut self.accel, Token(first), Interest::READABLE)?;
        for (i, (_, sub, _)) in self.imus.iter_mut().enumerate() {
            registry.register(sub, Token(first + 1 + i), Interest::READABLE)?;
        }
        Ok(())
    }

    /// Takes up to `max` messages of input `input` and hands each, as a packet, to `submit`
    /// (an Imu message is a one-sample packet of its station). Undecodable messages are
    /// counted and logged (at most one line per 10 s). Returns true if `max` was reached
    /// (more may be waiting: bounded so that a flood on one input cannot starve the others).
    pub fn drain(
        &mut self,
        input: usize,
        max: usize,
        submit: &mut impl FnMut(AccelPacket) -> anyhow::Result<()>,
    ) -> anyhow::Result<bool> {
        for _ in 0..max {
            if input == 0 {
                match self.accel.take() {
                    Ok(Some((m, _))) => {
                        self.counters.packets.fetch_add(1, Ordering::Relaxed);
                        submit(AccelPacket::from(&m))?;
                    }
                    Ok(None) => return Ok(false),
                    Err(e) => self.report_error(ACCEL_TOPIC.to_string(), &format!("{e:?}")),
                }
            } else {
                let Some((imu, sub, sequence)) = self.imus.get_mut(input - 1) else {
                    return Ok(false);
                };
                match sub.take() {
                    Ok(Some((m, _))) => {
                        self.counters.packets.fetch_add(1, Ordering::Relaxed);
                        let packet = imu_packet(imu, &m, *sequence);
                        *sequence += 1;
                        submit(packet)?;
                    }
                    Ok(None) => return Ok(false),
                    Err(e) => {
                        let topic = imu.topic.clone();
                        self.report_error(topic, &format!("{e:?}"));
                    }
                }
            }
        }
        Ok(true)
    }

    fn report_error(&mut self, what: String, error: &str) {
        let n = self.counters.decode_errors.fetch_add(1, Ordering::Relaxed) + 1;
        if self
            .last_error_report
            .is_none_or(|t| t.elapsed() >= Duration::from_secs(10))
        {
            eprintln!("rockwatch: ROS 2 {what}: undecodable message ({error}; {n} in all)");
            self.last_error_report = Some(Instant::now());
        }
    }
}

/// One Imu message as a one-sample packet of its configured station.
#[must_use]
pub fn imu_packet(imu: &ImuInput, m: &ImuMsg, sequence: u64) -> AccelPacket {
    let [x, y, z] = m.linear_acceleration;
    let up = if imu.remove_gravity {
        z - rockwatch_core::STANDARD_GRAVITY_MPS2
    } else {
        z
    };
    AccelPacket {
        station: imu.station.clone(),
        start_time_ns: m.header.stamp.to_nanos(),
        sample_rate_hz: imu.sample_rate_hz,
        sequence,
        east: vec![x as f32],
        north: vec![y as f32],
        up: vec![up as f32],
    }
}

/// How long a replay's writer stays after the node has acknowledged every packet (see
/// [`Ros2PacketSink`]'s `finish`).
pub const REPLAY_LINGER: Duration = Duration::from_secs(1);

/// Replay over ROS 2: publishes `/pbr/accel` from a node `rockwatch_replay`.
///
/// The writer is a plain RustDDS data writer on the node's participant and ROS 2 topic
/// (ros2-client's `Publisher` hides it), because a replay must know that the subscriber has
/// *received* what was sent before it exits: discovery is two-sided, and the writer can see
/// the node's reader before the reader has matched the writer; samples sent in that window
/// are only repaired later by the reliable protocol (the reader asks for everything from the
/// writer's first sequence number once it matches), which needs the writer alive.
/// [`PacketSink::finish`] waits for every matched reader's acknowledgement, then
/// [`REPLAY_LINGER`], because the node's DDS reader discards the samples of a writer that has
/// left which the node has not yet taken (a RustDDS 0.15.1 defect). The writer is not
/// listed under the node in the ROS 2 graph (`ros2 topic info` shows the publisher without
/// its node name).
pub struct Ros2PacketSink {
    _session: Ros2Session,
    writer: no_key::DataWriterCdr<msg::AccelPacket>,
    /// Readers matched now, from the writer's publication-matched status events.
    matched: i32,
    /// A matched reader went away (the node stopped or died mid-replay).
    lost_reader: bool,
}

impl Ros2PacketSink {
    pub fn open(plan: &NetworkPlan, namespace: &str) -> anyhow::Result<Ros2PacketSink> {
        let mut session = Ros2Session::open(
            plan,
            namespace,
            "rockwatch_replay",
            NodeOptions::new().enable_rosout(false),
        )?;
        let qos = replay_qos();
        let topic = session.topic(ACCEL_TOPIC, msg::PACKAGE, "AccelPacket", &qos)?;
        let dds_qos = ros2_client::dds::rustdds::QosPolicies::from(qos);
        let writer = session
            .context
            .domain_participant()
            .create_publisher(&dds_qos)
            .and_then(|p| p.create_datawriter_no_key_cdr(&topic, Some(dds_qos.clone())))
            .map_err(|e| anyhow!("ROS 2 publisher {ACCEL_TOPIC}: {e:?}"))?;
        Ok(Ros2PacketSink {
            _session: session,
            writer,
            matched: 0,
            lost_reader: false,
        })
    }

    /// Sends a raw message (tests of malformed input).
    pub fn send_msg(&mut self, m: msg::AccelPacket) -> anyhow::Result<()> {
        self.writer
            .write(m, Some(ros2_client::dds::rustdds::Timestamp::now()))
            .map_err(|e| anyhow!("ROS 2 publish on {ACCEL_TOPIC}: {e:?}"))
    }

    /// Readers matched now (after taking the writer's pending status events).
    fn matched_readers(&mut self) -> i32 {
        while let Some(status) = self.writer.try_recv_status() {
            if let DataWriterStatus::PublicationMatched { current, .. } = status {
                self.matched = current.count();
                self.lost_reader |= current.count_change() < 0;
            }
        }
        self.matched
    }
}

impl PacketSink for Ros2PacketSink {
    fn wait_for_subscriber(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        let deadline = Instant::now() + timeout;
        loop {
            if self.matched_readers() > 0 {
                return Ok(true);
            }
            if Instant::now() >= deadline {
                return Ok(false);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn send(&mut self, packet: &AccelPacket) -> anyhow::Result<()> {
        self.send_msg(msg::AccelPacket::from(packet))
    }

    fn finish(&mut self, timeout: Duration) -> anyhow::Result<bool> {
        // RustDDS also reports "acknowledged" when no reader is left: a reader that went
        // away mid-replay (the node stopped or died) means it has not got everything.
        let acknowledged = self
            .writer
            .wait_for_acknowledgments(timeout)
            .map_err(|e| anyhow!("ROS 2 {ACCEL_TOPIC}: waiting for acknowledgements: {e:?}"))?
            && self.matched_readers() > 0
            && !self.lost_reader;
        // An acknowledged sample sits in the node's reader cache until the node takes it, and
        // RustDDS 0.15.1 makes the unread samples of a writer that has left unreadable
        // (`forget_reliable_writer` drops the writer's delivery marker): stay a moment so the
        // node, even when busy, takes everything before this writer goes.
        std::thread::sleep(REPLAY_LINGER);
        Ok(acknowledged)
    }
}

/// Runs `future` on this thread until it completes (true) or `timeout` passes (false).
fn block_on_with_timeout(future: impl std::future::Future<Output = ()>, timeout: Duration) -> bool {
    use futures::future::{select, Either};
    let (tx, rx) = futures::channel::oneshot::channel::<()>();
    // The timer: a thread that completes `rx` after `timeout`. If the future wins, the
    // thread's send fails later and it ends (a CLI's process usually ends first).
    let timer = std::thread::Builder::new()
        .name("rockwatch-timeout".into())
        .spawn(move || {
            std::thread::sleep(timeout);
            let _ = tx.send(());
        });
    if timer.is_err() {
        return false;
    }
    let future = std::pin::pin!(future);
    matches!(
        futures::executor::block_on(select(future, rx)),
        Either::Left(_)
    )
}

/// A client of a running node's `/pbr/reset` service (`pbr_msgs/srv/ResetPbr`), as node
/// `rockwatch_reset` of its own DDS participant: `rockwatch reset --node`.
pub struct Ros2ResetClient {
    session: Ros2Session,
    client: Client<msg::ResetPbrRequest, msg::ResetPbrResponse>,
    poll: Poll,
    events: Events,
}

impl Ros2ResetClient {
    /// Joins the graph following `plan` (the node's namespace: the service name is absolute).
    pub fn open(plan: &NetworkPlan, namespace: &str) -> anyhow::Result<Ros2ResetClient> {
        let mut session = Ros2Session::open(
            plan,
            namespace,
            "rockwatch_reset",
            NodeOptions::new().enable_rosout(false),
        )?;
        let name =
            Name::parse(RESET_SERVICE).map_err(|e| anyhow!("service {RESET_SERVICE}: {e:?}"))?;
        let mut client = session
            .node
            .create_client(
                RESET_SERVICE_MAPPING,
                &name,
                &ServiceTypeName::new(msg::PACKAGE, msg::RESET_SERVICE_TYPE),
                service_qos(),
                service_qos(),
            )
            .map_err(|e| anyhow!("ROS 2 client of {RESET_SERVICE}: {e:?}"))?;
        let poll = Poll::new().context("reset client poller")?;
        poll.registry()
            .register(&mut client, Token(0), Interest::READABLE)
            .context("reset client registration")?;
        Ok(Ros2ResetClient {
            session,
            client,
            poll,
            events: Events::with_capacity(4),
        })
    }

    /// Waits up to `timeout` for a server of the service (a matched request reader and
    /// response writer); false if none appeared.
    pub fn wait_for_service(&mut self, timeout: Duration) -> bool {
        block_on_with_timeout(self.client.wait_for_service(&self.session.node), timeout)
    }

    /// Asks for the reset of block `pbr_id` and waits up to `timeout` for the response.
    pub fn reset(
        &mut self,
        pbr_id: &str,
        timeout: Duration,
    ) -> anyhow::Result<msg::ResetPbrResponse> {
        let deadline = Instant::now() + timeout;
        let id = self
            .client
            .send_request(msg::ResetPbrRequest {
                pbr_id: pbr_id.to_string(),
            })
            .map_err(|e| anyhow!("ROS 2 {RESET_SERVICE}: request not sent: {e:?}"))?;
        loop {
            // Responses to other clients' requests share the topic: keep only ours.
            while let Some((rid, response)) = self
                .client
                .receive_response()
                .map_err(|e| anyhow!("ROS 2 {RESET_SERVICE}: bad response: {e:?}"))?
            {
                if rid == id {
                    return Ok(response);
                }
            }
            let now = Instant::now();
            if now >= deadline {
                return Err(anyhow!(
                    "no response from {RESET_SERVICE} within {} s (the node may be overloaded or gone; \
                     the reset may or may not have been applied: see `rockwatch alerts`)",
                    timeout.as_secs_f64()
                ));
            }
            let wait = (deadline - now).min(Duration::from_millis(50));
            let _ = self.poll.poll(&mut self.events, Some(wait));
        }
    }
}

/// A subscriber of `/pbr/alerts` (transient local: receives the history too).
pub struct Ros2AlertListener {
    _session: Ros2Session,
    subscription: Subscription<msg::PbrAlert>,
    poll: Poll,
    events: Events,
}

impl Ros2AlertListener {
    pub fn open(plan: &NetworkPlan, namespace: &str) -> anyhow::Result<Ros2AlertListener> {
        let mut session = Ros2Session::open(
            plan,
            namespace,
            "rockwatch_listener",
            NodeOptions::new().enable_rosout(false),
        )?;
        let mut subscription =
            session.subscription(ALERTS_TOPIC, msg::PACKAGE, "PbrAlert", alerts_qos())?;
        let poll = Poll::new().context("alert listener poller")?;
        poll.registry()
            .register(&mut subscription, Token(0), Interest::READABLE)
            .context("alert listener registration")?;
        Ok(Ros2AlertListener {
            _session: session,
            subscription,
            poll,
            events: Events::with_capacity(4),
        })
    }

    /// Every alert received within `timeout` (returns as soon as there is at least one).
    pub fn recv(&mut self, timeout: Duration) -> anyhow::Result<Vec<msg::PbrAlert>> {
        let deadline = Instant::now() + timeout;
        let mut out = Vec::new();
        loop {
            while let Some((alert, _)) = self
                .subscription
                .take()
                .map_err(|e| anyhow!("{ALERTS_TOPIC}: {e:?}"))?
            {
                out.push(alert);
            }
            let now = Instant::now();
            if !out.is_empty() || now >= deadline {
                return Ok(out);
            }
            let wait = (deadline - now).min(Duration::from_millis(50));
            let _ = self.poll.poll(&mut self.events, Some(wait));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn localhost_range_means_loopback_only_whatever_the_config_names() {
        let mut config = Ros2Config {
            interfaces: vec!["10.0.0.5".parse().unwrap()],
            ..Ros2Config::default()
        };
        let plan = network_plan(&config, Some("7"), Some("LOCALHOST")).unwrap();
        assert_eq!(plan.domain_id, 7);
        assert_eq!(plan.only_networks, Some(vec!["127.0.0.1".parse().unwrap()]));
        let plan = network_plan(&config, None, Some("OFF")).unwrap();
        assert_eq!(plan.only_networks, Some(vec!["127.0.0.1".parse().unwrap()]));
        // SUBNET: the configured interfaces, or every interface when none is named.
        let plan = network_plan(&config, None, Some("SUBNET")).unwrap();
        assert_eq!(plan.only_networks, Some(vec!["10.0.0.5".parse().unwrap()]));
        config.interfaces.clear();
        assert_eq!(
            network_plan(&config, None, None).unwrap().only_networks,
            None
        );
        // The configuration overrides the environment.
        let demo = Ros2Config::loopback_only();
        let plan = network_plan(&demo, Some("3"), Some("SUBNET")).unwrap();
        assert_eq!(plan.only_networks, Some(vec!["127.0.0.1".parse().unwrap()]));
        assert_eq!(plan.domain_id, 3);
    }

    #[test]
    fn bad_environment_values_are_named() {
        let config = Ros2Config::default();
        let e = network_plan(&config, Some("x"), None).unwrap_err();
        assert!(e.contains("ROS_DOMAIN_ID"), "{e}");
        let e = network_plan(&config, Some("300"), None).unwrap_err();
        assert!(e.contains("300"), "{e}");
        let e = network_plan(&config, None, Some("localhost")).unwrap_err();
        assert!(e.contains("ROS_AUTOMATIC_DISCOVERY_RANGE"), "{e}");
        assert_eq!(
            network_plan(&config, Some(""), Some("")).unwrap().domain_id,
            0
        );
    }

    #[test]
    fn imu_sample_maps_xyz_to_east_north_up_without_gravity() {
        let imu = ImuInput {
            topic: "/imu".into(),
            station: "XX.IMU.00".into(),
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

    #[test]
    fn parameters_update_alert_thresholds_and_reject_bad_values() {
        assert!(
            validate_parameter(PARAM_IMMINENT_THETA_RATIO, &ParameterValue::Double(0.5)).is_ok()
        );
        assert!(
            validate_parameter(PARAM_IMMINENT_PROBABILITY, &ParameterValue::Double(1.5)).is_err()
        );
        assert!(validate_parameter(PARAM_QUIET_S, &ParameterValue::Double(f64::NAN)).is_err());
        assert!(validate_parameter(PARAM_STATE_INTERVAL_S, &ParameterValue::Double(-1.0)).is_err());
        assert!(validate_parameter(PARAM_QUIET_S, &ParameterValue::Integer(5)).is_ok());
        assert!(validate_parameter(PARAM_QUIET_S, &ParameterValue::String("5".into())).is_err());
    }
}
