//! The node's ROS 2 parameters: the run-time settings (alert thresholds, state interval) and
//! two read-only ones (catalogue, state directory), each with its descriptor (description,
//! `floating_point_range`, `read_only`), their values ([`ParamValues`]: set at start from
//! `--ros-args -p`/`--params-file`, then through the services), and the six
//! `rcl_interfaces` parameter services (`~/get_parameters`, `~/set_parameters`, …) served by
//! the node's event loop ([`ParamServer`]).
//!
//! ros2-client's own parameter services describe every parameter as "(description missing)"
//! without range, so the node serves its own (ros2-client's are switched off). A change is
//! validated by the descriptor's range and by the engine's own configuration check
//! (`EngineConfig::validate`, the one policy for the configuration file and the parameters);
//! a refused change says why, an accepted one is handed to the event loop, applies to the
//! next packet and is announced on `/parameter_events` (`rcl_interfaces/msg/ParameterEvent`).

use ros2_client::dds::rustdds::mio1::{Registry, Token};
use ros2_client::parameters::raw;
use ros2_client::rcl_interfaces::{
    DescribeParametersRequest, DescribeParametersResponse, GetParameterTypesRequest,
    GetParameterTypesResponse, GetParametersRequest, GetParametersResponse, ListParametersRequest,
    ListParametersResponse, ListParametersResult, SetParametersAtomicallyResponse,
    SetParametersRequest, SetParametersResponse,
};
use ros2_client::{Message, ParameterValue, ROSTime, SystemTime};

use super::held_server::HeldServer;
use super::input::IntakeLog;
use super::ros_args::ParamAssignment;
use super::session::Ros2Session;
use crate::ports::ControlSender;
use rockwatch_core::engine::{ConfigError, EngineConfig};

/// ROS 2 parameter names of the run-time settings (doubles).
pub const PARAM_IMMINENT_THETA_RATIO: &str = "alerts.imminent_theta_ratio";
pub const PARAM_IMMINENT_PROBABILITY: &str = "alerts.imminent_probability";
pub const PARAM_QUIET_THRESHOLD_MPS2: &str = "alerts.quiet_threshold_mps2";
pub const PARAM_QUIET_S: &str = "alerts.quiet_s";
pub const PARAM_STATE_INTERVAL_S: &str = "state_interval_s";
/// Read-only parameters (strings): settable at start only (`-p`, `--params-file`).
pub const PARAM_CATALOGUE: &str = "catalogue";
pub const PARAM_STATE_DIR: &str = "state_dir";
/// rclcpp's `use_sim_time` (bool, default false), declared so that a launch-wide
/// `SetParameter(name='use_sim_time', value=True)` or `-p use_sim_time:=true` is accepted.
/// The node reads no clock for its outputs: every stamp is a data time (the time of a
/// sample), so simulated and wall time give the same messages; `/clock` is not read.
pub const PARAM_USE_SIM_TIME: &str = "use_sim_time";

/// One parameter's descriptor.
#[derive(Debug, Clone, Copy)]
pub struct ParamSpec {
    pub name: &'static str,
    pub description: &'static str,
    /// What the range cannot say (an open bound).
    pub constraints: &'static str,
    /// Inclusive range of a double (`floating_point_range`); `None` for strings and bools.
    pub range: Option<(f64, f64)>,
    /// A bool (`use_sim_time`) rather than a string, when `range` is `None`.
    pub boolean: bool,
    pub read_only: bool,
}

/// Every parameter of the node, in listing order. The ranges are those of
/// `EngineConfig::validate` (a test checks each bound against it).
pub const PARAMETERS: [ParamSpec; 8] = [
    ParamSpec {
        name: PARAM_IMMINENT_THETA_RATIO,
        description: "overturn_imminent is raised when the block's |θ|/α reaches this ratio \
                      (θ: rocking angle, α: its overturning angle; 1 = tipped past static balance)",
        constraints: "greater than 0",
        range: Some((0.0, 1.0)),
        boolean: false,
        read_only: false,
    },
    ParamSpec {
        name: PARAM_IMMINENT_PROBABILITY,
        description: "overturn_imminent is raised when the ensemble's overturn probability \
                      reaches this value",
        constraints: "greater than 0",
        range: Some((0.0, 1.0)),
        boolean: false,
        read_only: false,
    },
    ParamSpec {
        name: PARAM_QUIET_THRESHOLD_MPS2,
        description: "a station is quiet while every |a| stays below this (m/s²)",
        constraints: "",
        range: Some((0.0, 100.0)),
        boolean: false,
        read_only: false,
    },
    ParamSpec {
        name: PARAM_QUIET_S,
        description: "an episode ends when the block is at rest and its station has been quiet \
                      this long (s)",
        constraints: "greater than 0",
        range: Some((0.0, 86_400.0)),
        boolean: false,
        read_only: false,
    },
    ParamSpec {
        name: PARAM_STATE_INTERVAL_S,
        description: "interval of PbrState publications per block (s of data)",
        constraints: "greater than 0",
        range: Some((0.0, 3600.0)),
        boolean: false,
        read_only: false,
    },
    ParamSpec {
        name: PARAM_CATALOGUE,
        description: "the PBR catalogue file in force (reload it with SIGHUP)",
        constraints: "settable at start only",
        range: None,
        boolean: false,
        read_only: true,
    },
    ParamSpec {
        name: PARAM_STATE_DIR,
        description: "the state directory (alert journal); empty: none",
        constraints: "settable at start only",
        range: None,
        boolean: false,
        read_only: true,
    },
    ParamSpec {
        name: PARAM_USE_SIM_TIME,
        description: "rclcpp's use_sim_time, accepted for launch files: the node's outputs are \
                      stamped with data time (sample times) whatever its value; /clock is not \
                      read",
        constraints: "no effect on the stamps",
        range: None,
        boolean: true,
        read_only: false,
    },
];

/// The descriptor of `name`, if it is a parameter of the node.
#[must_use]
pub fn param_spec(name: &str) -> Option<&'static ParamSpec> {
    PARAMETERS.iter().find(|p| p.name == name)
}

/// The values of the node's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamValues {
    /// Holds the run-time settings (alerts, state interval).
    pub engine: EngineConfig,
    pub catalogue: String,
    pub state_dir: String,
    /// `use_sim_time` ([`PARAM_USE_SIM_TIME`]).
    pub use_sim_time: bool,
}

/// Why a parameter change was refused: the `reason` of the `set_parameters` answer, and of
/// the start-up error for `--ros-args -p`/`--params-file`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error("parameter {name} is not declared by rockwatch")]
    Undeclared { name: String },
    #[error("parameter {name} is read-only (set it at start with --ros-args -p)")]
    ReadOnly { name: String },
    #[error("parameter {name} must be a bool")]
    NotABool { name: String },
    #[error("parameter {name} must be a string")]
    NotAString { name: String },
    #[error("parameter {name} must be a double, got {got:?}")]
    NotADouble {
        name: String,
        got: ros2_client::parameters::ParameterType,
    },
    /// Outside the descriptor's `floating_point_range` [lo, hi].
    #[error("invalid value for {name}: {value} is out of range [{lo}, {hi}]")]
    OutOfRange {
        name: String,
        value: f64,
        lo: f64,
        hi: f64,
    },
    /// Refused by `EngineConfig::validate`.
    #[error("invalid value for {name}: {error}")]
    Invalid { name: String, error: ConfigError },
}

/// What an accepted change touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamChange {
    Alerts,
    StateInterval,
    /// A read-only parameter (at start).
    Path,
    /// `use_sim_time` (nothing to hand over: the stamps are data times).
    SimTime,
}

impl ParamValues {
    /// The value of `name` (None: no such parameter).
    #[must_use]
    pub fn get(&self, name: &str) -> Option<ParameterValue> {
        let a = &self.engine.alerts;
        Some(match name {
            PARAM_IMMINENT_THETA_RATIO => ParameterValue::Double(a.imminent_theta_ratio),
            PARAM_IMMINENT_PROBABILITY => ParameterValue::Double(a.imminent_probability),
            PARAM_QUIET_THRESHOLD_MPS2 => ParameterValue::Double(a.quiet_threshold_mps2),
            PARAM_QUIET_S => ParameterValue::Double(a.quiet_s),
            PARAM_STATE_INTERVAL_S => ParameterValue::Double(self.engine.state_interval_s),
            PARAM_CATALOGUE => ParameterValue::String(self.catalogue.clone()),
            PARAM_STATE_DIR => ParameterValue::String(self.state_dir.clone()),
            PARAM_USE_SIM_TIME => ParameterValue::Boolean(self.use_sim_time),
            _ => return None,
        })
    }

    /// Sets `name` to `value` if the parameter exists, is writable (`at_start` allows the
    /// read-only ones), has the right type (an integer is taken for a double) and the value is
    /// in its range and passes `EngineConfig::validate`; else the reason, and nothing changes.
    pub fn set(
        &mut self,
        name: &str,
        value: &ParameterValue,
        at_start: bool,
    ) -> Result<ParamChange, ParamError> {
        let name_owned = || name.to_owned();
        let spec = param_spec(name).ok_or_else(|| ParamError::Undeclared { name: name_owned() })?;
        if spec.read_only && !at_start {
            return Err(ParamError::ReadOnly { name: name_owned() });
        }
        if spec.boolean {
            let ParameterValue::Boolean(b) = value else {
                return Err(ParamError::NotABool { name: name_owned() });
            };
            self.use_sim_time = *b;
            return Ok(ParamChange::SimTime);
        }
        if spec.range.is_none() {
            let ParameterValue::String(s) = value else {
                return Err(ParamError::NotAString { name: name_owned() });
            };
            match name {
                PARAM_CATALOGUE => self.catalogue.clone_from(s),
                _ => self.state_dir.clone_from(s),
            }
            return Ok(ParamChange::Path);
        }
        let v = match value {
            ParameterValue::Double(v) => *v,
            ParameterValue::Integer(i) => *i as f64,
            other => {
                return Err(ParamError::NotADouble {
                    name: name_owned(),
                    got: other.to_parameter_type(),
                })
            }
        };
        let (engine, change) = with_value(self.engine, name, v);
        if let Some((lo, hi)) = spec.range {
            if !(lo..=hi).contains(&v) {
                return Err(ParamError::OutOfRange {
                    name: name_owned(),
                    value: v,
                    lo,
                    hi,
                });
            }
        }
        engine.validate().map_err(|error| ParamError::Invalid {
            name: name_owned(),
            error,
        })?;
        self.engine = engine;
        Ok(change)
    }

    /// Applies start-time assignments (`--ros-args -p`, `--params-file`) in order. A
    /// parameter rockwatch does not have is an error, except from a wildcard section of a
    /// file (`/**`, shared by several nodes), where it is logged and skipped.
    pub fn apply_overrides(&mut self, assignments: &[ParamAssignment]) -> anyhow::Result<()> {
        for a in assignments {
            if param_spec(&a.name).is_none() && a.source.contains('*') {
                tracing::info!(
                    "{}: parameter {} is not a parameter of rockwatch: ignored",
                    a.source,
                    a.name
                );
                continue;
            }
            self.set(&a.name, &a.value, true)
                .map_err(|e| anyhow::anyhow!("{}: {e}", a.source))?;
        }
        Ok(())
    }

    /// The descriptor of `name` as `rcl_interfaces/msg/ParameterDescriptor` (an unknown name
    /// gets type NOT_SET, as rclcpp answers).
    fn describe(&self, name: &str) -> raw::ParameterDescriptor {
        let Some(spec) = param_spec(name) else {
            return raw::ParameterDescriptor {
                name: name.into(),
                r#type: raw::ParameterType::NOT_SET,
                description: String::new(),
                additional_constraints: String::new(),
                read_only: false,
                dynamic_typing: false,
                floating_point_range: Vec::new(),
                integer_range: Vec::new(),
            };
        };
        raw::ParameterDescriptor {
            name: name.into(),
            r#type: match (spec.range, spec.boolean) {
                (Some(_), _) => raw::ParameterType::DOUBLE,
                (None, true) => raw::ParameterType::BOOL,
                (None, false) => raw::ParameterType::STRING,
            },
            description: spec.description.into(),
            additional_constraints: spec.constraints.into(),
            read_only: spec.read_only,
            dynamic_typing: false,
            floating_point_range: spec
                .range
                .map(|(from_value, to_value)| raw::FloatingPointRange {
                    from_value,
                    to_value,
                    step: 0.0,
                })
                .into_iter()
                .collect(),
            integer_range: Vec::new(),
        }
    }

    /// `ListParameters` with rclcpp's semantics: without prefixes, the names with fewer than
    /// `depth` dots (0: any); else the names equal to a prefix or under `prefix.` within
    /// `depth` further levels; `prefixes` are the distinct namespaces of the names listed.
    fn list(prefixes: &[String], depth: u64) -> ListParametersResult {
        let within = |s: &str| depth == 0 || (s.matches('.').count() as u64) < depth;
        let mut result = ListParametersResult {
            names: Vec::new(),
            prefixes: Vec::new(),
        };
        for spec in &PARAMETERS {
            let name = spec.name;
            let listed = (prefixes.is_empty() && within(name))
                || prefixes.iter().any(|p| {
                    name == p
                        || name
                            .strip_prefix(p.as_str())
                            .and_then(|rest| rest.strip_prefix('.'))
                            .is_some_and(|rest| within(&format!(".{rest}")))
                });
            if listed {
                result.names.push(name.into());
                if let Some((ns, _)) = name.rsplit_once('.') {
                    if !result.prefixes.iter().any(|p| p == ns) {
                        result.prefixes.push(ns.into());
                    }
                }
            }
        }
        result
    }
}

/// `engine` with the double parameter `name` set to `v` (unchecked), and what it touched.
fn with_value(mut engine: EngineConfig, name: &str, v: f64) -> (EngineConfig, ParamChange) {
    let a = &mut engine.alerts;
    let field = match name {
        PARAM_IMMINENT_THETA_RATIO => &mut a.imminent_theta_ratio,
        PARAM_IMMINENT_PROBABILITY => &mut a.imminent_probability,
        PARAM_QUIET_THRESHOLD_MPS2 => &mut a.quiet_threshold_mps2,
        PARAM_QUIET_S => &mut a.quiet_s,
        _ => {
            engine.state_interval_s = v;
            return (engine, ParamChange::StateInterval);
        }
    };
    *field = v;
    (engine, ParamChange::Alerts)
}

/// Most requests served per parameter service per turn of the event loop.
pub const PARAM_REQUESTS_PER_TURN: usize = 16;

/// The six `rcl_interfaces` parameter services of the node (`<node>/get_parameters`, …,
/// resolved like every name), with the values they serve; an accepted change goes to the
/// event loop through `controls`.
pub(super) struct ParamServer {
    get: HeldServer<GetParametersRequest, GetParametersResponse>,
    types: HeldServer<GetParameterTypesRequest, GetParameterTypesResponse>,
    set: HeldServer<SetParametersRequest, SetParametersResponse>,
    atomic: HeldServer<SetParametersRequest, SetParametersAtomicallyResponse>,
    list: HeldServer<ListParametersRequest, ListParametersResponse>,
    describe: HeldServer<DescribeParametersRequest, DescribeParametersResponse>,
    pub(super) values: ParamValues,
    controls: ControlSender,
    /// `/parameter_events`: each accepted change, through the node's one writer of it
    /// (volatile, as rcl's: crates/vendor/README.md).
    events: std::sync::Arc<ros2_client::Publisher<raw::ParameterEvent>>,
    /// The node's fully qualified name (the events' `node`).
    node_fqn: String,
}

impl ParamServer {
    pub(super) fn open(
        session: &mut Ros2Session,
        values: ParamValues,
        controls: ControlSender,
    ) -> anyhow::Result<ParamServer> {
        fn open<Q: Message + Clone + 'static, S: Message + Clone + 'static>(
            session: &mut Ros2Session,
            name: &str,
            type_name: &str,
        ) -> anyhow::Result<HeldServer<Q, S>> {
            HeldServer::open(session, &format!("~/{name}"), "rcl_interfaces", type_name)
        }
        Ok(ParamServer {
            get: open(session, "get_parameters", "GetParameters")?,
            types: open(session, "get_parameter_types", "GetParameterTypes")?,
            set: open(session, "set_parameters", "SetParameters")?,
            atomic: open(
                session,
                "set_parameters_atomically",
                "SetParametersAtomically",
            )?,
            list: open(session, "list_parameters", "ListParameters")?,
            describe: open(session, "describe_parameters", "DescribeParameters")?,
            values,
            controls,
            events: session.node.parameter_events_publisher(),
            node_fqn: session.naming().node_fqn(),
        })
    }

    /// Registers the six servers with `registry`, all as `token`.
    pub(super) fn register(&mut self, registry: &Registry, token: Token) -> std::io::Result<()> {
        self.get.register(registry, token)?;
        self.types.register(registry, token)?;
        self.set.register(registry, token)?;
        self.atomic.register(registry, token)?;
        self.list.register(registry, token)?;
        self.describe.register(registry, token)
    }

    /// Responses not sent yet.
    pub(super) fn pending(&self) -> usize {
        self.get.pending()
            + self.types.pending()
            + self.set.pending()
            + self.atomic.pending()
            + self.list.pending()
            + self.describe.pending()
    }

    /// Serves up to [`PARAM_REQUESTS_PER_TURN`] requests of each service, then sends the
    /// responses due. Returns true if a bound was reached (more may be waiting).
    pub(super) fn serve(&mut self, session: &Ros2Session, log: &mut IntakeLog) -> bool {
        let mut more = false;
        let values = &mut self.values;
        more |= serve_one(&mut self.get, log, |r| GetParametersResponse {
            values: r
                .names
                .iter()
                .map(|n| values.get(n).unwrap_or(ParameterValue::NotSet).into())
                .collect(),
        });
        more |= serve_one(&mut self.types, log, |r| GetParameterTypesResponse {
            values: r
                .names
                .iter()
                .map(|n| {
                    ParameterValue::to_parameter_type_raw(
                        &values.get(n).unwrap_or(ParameterValue::NotSet),
                    )
                })
                .collect(),
        });
        more |= serve_one(&mut self.list, log, |r| ListParametersResponse {
            result: ParamValues::list(&r.prefixes, r.depth),
        });
        more |= serve_one(&mut self.describe, log, |r| DescribeParametersResponse {
            values: r.names.iter().map(|n| values.describe(n)).collect(),
        });
        let controls = &self.controls;
        let mut changed: Vec<raw::Parameter> = Vec::new();
        more |= serve_one(&mut self.set, log, |r| SetParametersResponse {
            results: r
                .parameter
                .iter()
                .map(|p| {
                    let value = ParameterValue::from(p.value.clone());
                    let result = values.set(&p.name, &value, false);
                    if let Ok(change) = result {
                        hand_over(values, change, controls);
                        changed.push(p.clone());
                    }
                    set_result(&p.name, result)
                })
                .collect(),
        });
        more |= serve_one(&mut self.atomic, log, |r| {
            // All or nothing: every change on a copy, then the copy in force.
            let mut copy = values.clone();
            let mut changes = Vec::new();
            let mut failed = None;
            for p in &r.parameter {
                match copy.set(&p.name, &ParameterValue::from(p.value.clone()), false) {
                    Ok(change) => changes.push(change),
                    Err(e) => {
                        failed = Some(e);
                        break;
                    }
                }
            }
            let result = match failed {
                Some(reason) => raw::SetParametersResult {
                    successful: false,
                    reason: reason.to_string(),
                },
                None => {
                    *values = copy;
                    for change in changes {
                        hand_over(values, change, controls);
                    }
                    changed.extend(r.parameter.iter().cloned());
                    raw::SetParametersResult {
                        successful: true,
                        reason: String::new(),
                    }
                }
            };
            SetParametersAtomicallyResponse { result }
        });
        self.announce(changed);
        self.send_due(session);
        more
    }

    /// Publishes the accepted changes on `/parameter_events` (one event; none if empty). A
    /// failure is logged: the change itself stands.
    fn announce(&mut self, changed: Vec<raw::Parameter>) {
        if changed.is_empty() {
            return;
        }
        let event = raw::ParameterEvent {
            stamp: ROSTime::from(SystemTime::now()).into(),
            node: self.node_fqn.clone(),
            new_parameters: Vec::new(),
            changed_parameters: changed,
            deleted_parameters: Vec::new(),
        };
        if let Err(e) = self.events.publish(event) {
            tracing::info!("ROS 2 /parameter_events: not published: {e:?}");
        }
    }

    /// Sends the responses that are due (see `HeldServer::send_due`).
    pub(super) fn send_due(&mut self, session: &Ros2Session) {
        self.get.send_due(session);
        self.types.send_due(session);
        self.set.send_due(session);
        self.atomic.send_due(session);
        self.list.send_due(session);
        self.describe.send_due(session);
    }

    /// Sends every waiting response now.
    pub(super) fn flush(&mut self) {
        self.get.flush();
        self.types.flush();
        self.set.flush();
        self.atomic.flush();
        self.list.flush();
        self.describe.flush();
    }
}

/// Hands an accepted change to the event loop.
fn hand_over(values: &ParamValues, change: ParamChange, controls: &ControlSender) {
    match change {
        ParamChange::Alerts => controls.set_alert_config(values.engine.alerts),
        ParamChange::StateInterval => controls.set_state_interval_s(values.engine.state_interval_s),
        ParamChange::Path | ParamChange::SimTime => {}
    }
}

fn set_result(name: &str, result: Result<ParamChange, ParamError>) -> raw::SetParametersResult {
    match result {
        Ok(_) => raw::SetParametersResult {
            successful: true,
            reason: String::new(),
        },
        Err(reason) => {
            tracing::info!("ROS 2 parameter {name}: change refused: {reason}");
            raw::SetParametersResult {
                successful: false,
                reason: reason.to_string(),
            }
        }
    }
}

/// Serves up to [`PARAM_REQUESTS_PER_TURN`] requests of `server` with `answer`; true if the
/// bound was reached.
fn serve_one<Q: Message + Clone + 'static, S: Message + Clone + 'static>(
    server: &mut HeldServer<Q, S>,
    log: &mut IntakeLog,
    mut answer: impl FnMut(&Q) -> S,
) -> bool {
    for _ in 0..PARAM_REQUESTS_PER_TURN {
        match server.receive() {
            Ok(Some((id, request))) => {
                let response = answer(&request);
                server.reply(id, response);
            }
            Ok(None) => return false,
            Err(e) => log.undecodable(&server.name.clone(), &e),
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn values() -> ParamValues {
        ParamValues {
            engine: EngineConfig::default(),
            catalogue: "/etc/rockwatch/catalogue.toml".into(),
            state_dir: String::new(),
            use_sim_time: false,
        }
    }

    #[test]
    fn changes_are_validated_by_range_type_and_writability() {
        let mut v = values();
        assert_eq!(
            v.set(
                PARAM_IMMINENT_THETA_RATIO,
                &ParameterValue::Double(0.5),
                false
            ),
            Ok(ParamChange::Alerts)
        );
        assert_eq!(v.engine.alerts.imminent_theta_ratio, 0.5);
        // 1.5 was accepted before descriptors: |θ|/α > 1 is past the tipping angle.
        let e = v
            .set(
                PARAM_IMMINENT_THETA_RATIO,
                &ParameterValue::Double(1.5),
                false,
            )
            .unwrap_err()
            .to_string();
        assert!(e.contains("out of range [0, 1]"), "{e}");
        assert_eq!(v.engine.alerts.imminent_theta_ratio, 0.5);
        // The open bound at 0 is refused by the engine's check.
        let e = v
            .set(PARAM_QUIET_S, &ParameterValue::Double(0.0), false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("invalid value for alerts.quiet_s"), "{e}");
        assert!(v
            .set(PARAM_QUIET_S, &ParameterValue::Double(f64::NAN), false)
            .is_err());
        assert_eq!(
            v.set(PARAM_QUIET_S, &ParameterValue::Integer(5), false),
            Ok(ParamChange::Alerts)
        );
        assert!(v
            .set(PARAM_QUIET_S, &ParameterValue::String("5".into()), false)
            .unwrap_err()
            .to_string()
            .contains("must be a double"));
        assert!(v
            .set(PARAM_CATALOGUE, &ParameterValue::String("x".into()), false)
            .unwrap_err()
            .to_string()
            .contains("read-only"));
        assert_eq!(
            v.set(PARAM_CATALOGUE, &ParameterValue::String("x".into()), true),
            Ok(ParamChange::Path)
        );
        assert!(v
            .set("alerts.nope", &ParameterValue::Double(1.0), false)
            .unwrap_err()
            .to_string()
            .contains("not declared"));
    }

    #[test]
    fn every_descriptor_range_is_the_engine_checks_range() {
        // EngineConfig::validate ALONE (the configuration file's check) accepts the descriptor's
        // closed ends and refuses beyond them; an open lower bound (constraint "greater than
        // 0") is refused at the end itself. So the descriptors tell clients the truth.
        for spec in PARAMETERS.iter().filter(|p| p.range.is_some()) {
            let (lo, hi) = spec.range.unwrap();
            let ok = |x: f64| {
                with_value(EngineConfig::default(), spec.name, x)
                    .0
                    .validate()
                    .is_ok()
            };
            assert!(ok(hi), "{} at {hi}", spec.name);
            assert!(ok(lo + (hi - lo) * 1e-3), "{}", spec.name);
            assert!(!ok(hi * (1.0 + 1e-9) + 1e-12), "{} above {hi}", spec.name);
            assert!(!ok(lo - 1e-9), "{} below {lo}", spec.name);
            assert_eq!(
                ok(lo),
                spec.constraints.is_empty(),
                "{} at {lo}: constraint {:?}",
                spec.name,
                spec.constraints
            );
        }
    }

    #[test]
    fn descriptors_and_listing_follow_rcl_interfaces() {
        let v = values();
        let d = v.describe(PARAM_IMMINENT_THETA_RATIO);
        assert_eq!(d.r#type, raw::ParameterType::DOUBLE);
        assert!(d.description.contains("|θ|/α"));
        assert_eq!(d.floating_point_range.len(), 1);
        assert_eq!(d.floating_point_range[0].to_value, 1.0);
        assert!(!d.read_only);
        assert!(v.describe(PARAM_CATALOGUE).read_only);
        assert_eq!(v.describe("nope").r#type, raw::ParameterType::NOT_SET);
        let all = ParamValues::list(&[], 0);
        assert_eq!(all.names.len(), PARAMETERS.len());
        assert_eq!(all.prefixes, ["alerts"]);
        let top = ParamValues::list(&[], 1);
        assert_eq!(
            top.names,
            ["state_interval_s", "catalogue", "state_dir", "use_sim_time"]
        );
        let alerts = ParamValues::list(&["alerts".into()], 0);
        assert_eq!(alerts.names.len(), 4);
        assert_eq!(
            v.describe(PARAM_USE_SIM_TIME).r#type,
            raw::ParameterType::BOOL
        );
    }

    /// A launch-wide `SetParameter(use_sim_time)` (`-p use_sim_time:=true`) is accepted at
    /// start and later, as a bool only; before it was declared, it ended the node at start.
    #[test]
    fn use_sim_time_is_a_bool_parameter_accepted_at_start_and_later() {
        let mut v = values();
        assert_eq!(
            v.get(PARAM_USE_SIM_TIME),
            Some(ParameterValue::Boolean(false))
        );
        v.apply_overrides(&[ParamAssignment {
            name: PARAM_USE_SIM_TIME.into(),
            value: ParameterValue::Boolean(true),
            source: "-p".into(),
        }])
        .unwrap();
        assert!(v.use_sim_time);
        assert_eq!(
            v.set(PARAM_USE_SIM_TIME, &ParameterValue::Boolean(false), false),
            Ok(ParamChange::SimTime)
        );
        let e = v
            .set(PARAM_USE_SIM_TIME, &ParameterValue::Double(1.0), false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("must be a bool"), "{e}");
        assert!(!v.use_sim_time);
    }

    #[test]
    fn start_overrides_apply_in_order_and_name_their_source() {
        let mut v = values();
        let a = |name: &str, value: ParameterValue, source: &str| ParamAssignment {
            name: name.into(),
            value,
            source: source.into(),
        };
        v.apply_overrides(&[
            a(PARAM_QUIET_S, ParameterValue::Double(10.0), "f.yaml (/**)"),
            a(
                "other_node_param",
                ParameterValue::Integer(1),
                "f.yaml (/**)",
            ),
            a(
                PARAM_QUIET_S,
                ParameterValue::Double(20.0),
                "-p alerts.quiet_s:=20.0",
            ),
            a(
                PARAM_STATE_DIR,
                ParameterValue::String("/var/lib/rw".into()),
                "-p",
            ),
        ])
        .unwrap();
        assert_eq!(v.engine.alerts.quiet_s, 20.0);
        assert_eq!(v.state_dir, "/var/lib/rw");
        let e = v
            .apply_overrides(&[a("typo", ParameterValue::Double(1.0), "-p typo:=1.0")])
            .unwrap_err();
        assert!(
            format!("{e}").contains("-p typo:=1.0: parameter typo is not declared"),
            "{e}"
        );
        let e = v
            .apply_overrides(&[a(
                PARAM_IMMINENT_THETA_RATIO,
                ParameterValue::Double(1.5),
                "-p alerts.imminent_theta_ratio:=1.5",
            )])
            .unwrap_err();
        assert!(format!("{e}").contains("out of range"), "{e}");
    }
}
