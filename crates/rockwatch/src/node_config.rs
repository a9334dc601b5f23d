//! The node / monitor configuration file (TOML): which catalogue, which stations, the engine's
//! thresholds, and where the state directory is. Relative paths are relative to the file.
//!
//! ```toml
//! catalogue = "catalogue.toml"
//! state_dir = "/var/lib/rockwatch"      # optional
//!
//! [engine]
//! state_interval_s = 1.0
//! [engine.alerts]
//! imminent_theta_ratio = 0.8
//! [engine.stream]
//! max_bridge_s = 0.5
//!
//! [[station]]
//! id = "CI.RRS.00"
//! gain_mps2_per_count = 2.384185791015625e-06
//! full_scale = 8388608
//! orientation = { kind = "azimuths", h1_deg = 0.0, h2_deg = 90.0 }
//!
//! [ros2]
//! input_qos = "reliable"                # of /pbr/accel (default)
//!
//! # A sensor_msgs/msg/Imu topic as a station (see `crate::ros2::ImuInput`): mounted level,
//! # x east, y north, z up; east = x, north = y, up = z − 9.80665 (remove_gravity).
//! [[ros2.imu]]
//! topic = "/imu/data"
//! station = "XB.IMU.00"
//! sample_rate_hz = 100.0
//! remove_gravity = true
//! qos = "sensor_data"                   # default: best effort, as most Imu drivers publish
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rockwatch_core::partition::{Partition, PartitionError, PartitionMap};
use rockwatch_core::station_id::StationId;

use rockwatch_core::engine::{EngineConfig, StationConfig};

/// A setting a reload changed: its name as in the file (`engine.alerts.imminent_theta_ratio`,
/// `[[station]] CI.RRS.00 gain_mps2_per_count`), its old and its new value (as TOML would
/// write them; `none` for an absent one).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SettingChange {
    pub setting: String,
    pub old: String,
    pub new: String,
}

/// The settings that differ between the running engine configuration and stations (`old`)
/// and a reloaded one (`new`): every `[engine]` key (nested tables flattened with dots) and
/// every key of a `[[station]]` (matched by id; a station added or removed is one change,
/// `none` on its absent side). In the files' order of keys, stations by id.
#[must_use]
pub fn setting_changes(
    old: (&EngineConfig, &[StationConfig]),
    new: (&EngineConfig, &[StationConfig]),
) -> Vec<SettingChange> {
    let mut changes = Vec::new();
    diff_values(
        "engine",
        ".",
        &to_json(old.0),
        &to_json(new.0),
        &mut changes,
    );
    let by_id = |stations: &[StationConfig]| -> BTreeMap<String, serde_json::Value> {
        stations
            .iter()
            .map(|s| (s.id.to_string(), to_json(s)))
            .collect()
    };
    let (before, after) = (by_id(old.1), by_id(new.1));
    let ids: std::collections::BTreeSet<&String> = before.keys().chain(after.keys()).collect();
    for id in ids {
        let name = format!("[[station]] {id}");
        match (before.get(id), after.get(id)) {
            (Some(a), Some(b)) => diff_values(&name, " ", a, b, &mut changes),
            (a, b) => changes.push(SettingChange {
                setting: name,
                old: a.map_or("none".into(), |_| "configured".into()),
                new: b.map_or("none".into(), |_| "configured".into()),
            }),
        }
    }
    changes
}

/// A configuration section as JSON (for [`setting_changes`]); the sections serialise with the
/// files' key names.
fn to_json<T: serde::Serialize>(section: &T) -> serde_json::Value {
    serde_json::to_value(section).unwrap_or(serde_json::Value::Null)
}

/// Appends to `out` every leaf of `old` and `new` under `prefix` whose value differs (a key
/// joined to `prefix` by `separator`, deeper keys by dots).
fn diff_values(
    prefix: &str,
    separator: &str,
    old: &serde_json::Value,
    new: &serde_json::Value,
    out: &mut Vec<SettingChange>,
) {
    use serde_json::Value;
    match (old, new) {
        (Value::Object(a), Value::Object(b)) => {
            let keys: Vec<&String> = a
                .keys()
                .chain(b.keys().filter(|k| !a.contains_key(*k)))
                .collect();
            for key in keys {
                let name = format!("{prefix}{separator}{key}");
                diff_values(
                    &name,
                    ".",
                    a.get(key).unwrap_or(&Value::Null),
                    b.get(key).unwrap_or(&Value::Null),
                    out,
                );
            }
        }
        (a, b) if a != b => out.push(SettingChange {
            setting: prefix.to_string(),
            old: setting_text(a),
            new: setting_text(b),
        }),
        _ => {}
    }
}

/// A value as the file would write it (a string unquoted, an absent value `none`).
fn setting_text(value: &serde_json::Value) -> String {
    match value {
        serde_json::Value::Null => "none".into(),
        serde_json::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// A parsed configuration file.
#[derive(Debug, Clone, Default, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeConfig {
    /// PBR catalogue (TOML or CSV).
    #[serde(default)]
    pub catalogue: Option<PathBuf>,
    /// State directory (journal of alerts and fallen blocks).
    #[serde(default)]
    pub state_dir: Option<PathBuf>,
    /// Scale-out: the partition of the service's stations this node owns, `"i/N"`
    /// (docs/capacity.md); none: every station.
    #[serde(default)]
    pub partition: Option<String>,
    /// Stations assigned to a partition explicitly (`[partition_assign]`, `"NET.STA.LOC" = i`),
    /// the others by hash.
    #[serde(default)]
    pub partition_assign: BTreeMap<String, u32>,
    #[serde(default)]
    pub engine: EngineConfig,
    #[serde(default, rename = "station")]
    pub stations: Vec<StationConfig>,
    /// The `[ros2]` section: namespace, domain, interfaces, input QoS, Imu topics.
    #[serde(default)]
    pub ros2: crate::ros2::Ros2Config,
    /// The iceoryx2 transport (`[iceoryx2]`).
    #[serde(default)]
    pub iceoryx2: crate::iox::IoxConfig,
    /// Alert receivers (`[[notify]]`, see `crate::notify`), used by `rockwatch node`.
    #[serde(default)]
    pub notify: Vec<crate::notify::NotifyConfig>,
    /// `/diagnostics` and `/rosout` (`[status]`, see `crate::status`).
    #[serde(default)]
    pub status: crate::status::StatusConfig,
    /// The optional Prometheus endpoint (`[metrics]`, see `crate::metrics`).
    #[serde(default)]
    pub metrics: crate::metrics::MetricsConfig,
    /// The optional web dashboard (`[web]`, see `crate::web`).
    #[serde(default)]
    pub web: crate::web::WebConfig,
}

/// Why a configuration file could not be loaded: `path: problem`.
#[derive(Debug, thiserror::Error)]
#[error("{}: {problem}", path.display())]
pub struct NodeConfigError {
    /// The configuration file.
    pub path: PathBuf,
    pub problem: NodeConfigProblem,
}

/// What is wrong with a configuration file.
#[derive(Debug, thiserror::Error)]
pub enum NodeConfigProblem {
    /// It could not be read.
    #[error("{0}")]
    Read(#[from] std::io::Error),
    /// It is not valid TOML for this schema: `line N: message`.
    #[error("{0}")]
    Syntax(String),
    /// A value is invalid (engine or station settings).
    #[error("{0}")]
    Invalid(#[from] rockwatch_core::engine::ConfigError),
    /// `partition` or `[partition_assign]` is invalid.
    #[error("{0}")]
    Partition(PartitionConfigError),
    /// A `[[notify]]` entry is invalid: its number (1-based) and why.
    #[error("[[notify]] #{0}: {1}")]
    Notify(usize, crate::notify::NotifyConfigError),
    /// A `[status]` value is invalid.
    #[error("{0}")]
    Status(crate::status::StatusConfigError),
    /// A `[web]` or `[metrics]` value is invalid (e.g. a non-loopback listen without a token).
    #[error("{0}")]
    Listener(crate::web::config::ListenerError),
    /// `[web] tiles` or `tiles_attribution` is invalid.
    #[error("{0}")]
    Tiles(crate::web::tiles::TilesConfigError),
}

/// Why a partition setting (`partition`, `partitions`, `[partition_assign]`) is invalid, for
/// nodes ([`NodeConfig::partitioning`]) and senders (`AcquireConfig::partition_map`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PartitionConfigError {
    /// `[partition_assign]` without the setting that says how many partitions there are.
    #[error("[partition_assign] needs `{needs}`")]
    AssignWithoutCount { needs: &'static str },
    /// `partition` is not `i/N`.
    #[error("{0}")]
    Partition(PartitionError),
    /// A key of `[partition_assign]` is not a station id.
    #[error("[partition_assign]: station {0}")]
    Station(rockwatch_core::station_id::StationIdError),
    /// A value of `[partition_assign]` is not a partition of the service.
    #[error("[partition_assign]: {0}")]
    Assign(PartitionError),
}

impl NodeConfig {
    /// Reads and validates `path`; errors name the file (and the line, for TOML syntax).
    pub fn load(path: &Path) -> Result<NodeConfig, NodeConfigError> {
        let error = |problem: NodeConfigProblem| NodeConfigError {
            path: path.to_owned(),
            problem,
        };
        let text = rockwatch_core::bounded_read::read_to_string_bounded(
            path,
            rockwatch_core::bounded_read::MAX_CONFIG_FILE_BYTES,
        )
        .map_err(|e| error(e.into()))?;
        let mut config: NodeConfig = toml::from_str(&text).map_err(|e| {
            error(NodeConfigProblem::Syntax(
                rockwatch_core::catalogue::toml_error_line(&text, &e),
            ))
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        config.catalogue = config.catalogue.map(|c| base.join(c));
        config.state_dir = config.state_dir.map(|d| base.join(d));
        config.engine.validate().map_err(|e| error(e.into()))?;
        config.iceoryx2.config_file = config.iceoryx2.config_file.map(|f| base.join(f));
        for s in &config.stations {
            s.validate().map_err(|e| error(e.into()))?;
        }
        config
            .status
            .validate()
            .map_err(|e| error(NodeConfigProblem::Status(e)))?;
        config
            .partitioning()
            .map_err(|e| error(NodeConfigProblem::Partition(e)))?;
        config.web.resolve(base);
        config
            .web
            .tiles()
            .map_err(|e| error(NodeConfigProblem::Tiles(e)))?;
        config
            .web
            .token()
            .map_err(|e| error(NodeConfigProblem::Listener(e)))?;
        config.metrics.resolve(base);
        config
            .metrics
            .token()
            .map_err(|e| error(NodeConfigProblem::Listener(e)))?;
        for (i, n) in config.notify.iter().enumerate() {
            n.validate()
                .map_err(|e| error(NodeConfigProblem::Notify(i + 1, e)))?;
        }
        Ok(config)
    }

    /// The node's partition and the service's partition map (`partition`,
    /// `[partition_assign]`), or None if the node owns every station; the error says which
    /// setting is wrong.
    pub fn partitioning(&self) -> Result<Option<(Partition, PartitionMap)>, PartitionConfigError> {
        let Some(text) = &self.partition else {
            if self.partition_assign.is_empty() {
                return Ok(None);
            }
            return Err(PartitionConfigError::AssignWithoutCount {
                needs: "partition = \"i/N\"",
            });
        };
        let partition = Partition::parse(text).map_err(PartitionConfigError::Partition)?;
        let map = partition_map(partition.count(), &self.partition_assign)?;
        Ok(Some((partition, map)))
    }

    /// The stations of `[[station]]` this node serves: those of its partition (all without
    /// one); the error says which partition setting is wrong.
    pub fn owned_stations(&self) -> Result<Vec<StationConfig>, PartitionConfigError> {
        Ok(match self.partitioning()? {
            Some((partition, map)) => self
                .stations
                .iter()
                .filter(|s| map.owns(partition, s.id.as_str()))
                .cloned()
                .collect(),
            None => self.stations.clone(),
        })
    }
}

/// The partition map of a service of `count` partitions with the `[partition_assign]` table
/// `assign` (`"NET.STA.LOC" = i`): the one reading of that table, for nodes and senders.
pub fn partition_map(
    count: u32,
    assign: &BTreeMap<String, u32>,
) -> Result<PartitionMap, PartitionConfigError> {
    let assigned = assign
        .iter()
        .map(|(id, &i)| {
            StationId::parse(id)
                .map(|s| (s, i))
                .map_err(PartitionConfigError::Station)
        })
        .collect::<Result<Vec<_>, _>>()?;
    PartitionMap::assign(count, assigned).map_err(PartitionConfigError::Assign)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn setting_changes_name_each_changed_key_old_and_new() {
        let old = EngineConfig::default();
        let mut new = old;
        new.alerts.imminent_theta_ratio = 0.5;
        let station = |gain: Option<f64>| {
            let mut s = StationConfig::default_for(StationId::parse("XB.ONE.00").unwrap());
            s.gain_mps2_per_count = gain;
            s
        };
        let two = StationConfig::default_for(StationId::parse("XB.TWO.00").unwrap());
        let changes = setting_changes(
            (&old, &[station(None)]),
            (&new, &[station(Some(2e-6)), two]),
        );
        let text: Vec<String> = changes
            .iter()
            .map(|c| format!("{} {} → {}", c.setting, c.old, c.new))
            .collect();
        assert_eq!(
            text,
            [
                format!(
                    "engine.alerts.imminent_theta_ratio {} → 0.5",
                    old.alerts.imminent_theta_ratio
                ),
                "[[station]] XB.ONE.00 gain_mps2_per_count none → 2e-6".to_string(),
                "[[station]] XB.TWO.00 none → configured".to_string(),
            ]
        );
        assert!(setting_changes((&old, &[]), (&old, &[])).is_empty());
    }

    /// Loads `text` as a file; the error as its message.
    fn load(text: &str) -> Result<NodeConfig, String> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("node.toml");
        std::fs::write(&path, text).unwrap();
        NodeConfig::load(&path).map_err(|e| e.to_string())
    }

    #[test]
    fn a_web_listen_off_loopback_without_a_token_is_refused_at_load() {
        let e = load("[web]\nlisten = \"0.0.0.0:8080\"\n").unwrap_err();
        assert!(
            e.contains("node.toml: [web] listen = \"0.0.0.0:8080\" is not a loopback address"),
            "{e}"
        );
        let c = load("[web]\nlisten = \"127.0.0.1:8080\"\n").unwrap();
        assert_eq!(c.web.listen.as_deref(), Some("127.0.0.1:8080"));
        // The token file is relative to the configuration file (missing here: refused).
        let e = load("[web]\nlisten = \"0.0.0.0:8080\"\ntoken_file = \"t\"\n").unwrap_err();
        assert!(e.contains("[web] token_file") && e.contains("/t\""), "{e}");
    }

    #[test]
    fn a_bad_web_tiles_template_is_refused_at_load_naming_the_key() {
        let e =
            load("[web]\nlisten = \"127.0.0.1:8080\"\ntiles = \"https://h/{z}/{x}/{y}/{s}.png\"\n")
                .unwrap_err();
        assert!(
            e.contains(
                "node.toml: [web] tiles = \"https://h/{z}/{x}/{y}/{s}.png\": unknown placeholder"
            ),
            "{e}"
        );
        let c = load(
            "[web]\nlisten = \"127.0.0.1:8080\"\ntiles = \"https://tile.openstreetmap.org/{z}/{x}/{y}.png\"\n\
             tiles_attribution = \"© OpenStreetMap contributors\"\n",
        )
        .unwrap();
        let tiles = c.web.tiles().unwrap().unwrap();
        assert_eq!(tiles.template.origin(), "https://tile.openstreetmap.org");
        assert_eq!(
            tiles.attribution.as_deref(),
            Some("© OpenStreetMap contributors")
        );
    }

    #[test]
    fn full_config_parses_with_paths_relative_to_the_file() {
        let c = load(
            "catalogue = \"cat.toml\"\n[engine]\nstate_interval_s = 2.0\n[engine.alerts]\nimminent_theta_ratio = 0.7\n\
             [[station]]\nid = \"CI.RRS.00\"\ngain_mps2_per_count = 1e-6\norientation = { kind = \"azimuths\", h1_deg = 10.0, h2_deg = 100.0 }\n",
        )
        .unwrap();
        assert!(c.catalogue.unwrap().ends_with("cat.toml"));
        assert_eq!(c.engine.state_interval_s, 2.0);
        assert_eq!(c.engine.alerts.imminent_theta_ratio, 0.7);
        assert_eq!(c.engine.alerts.quiet_s, 30.0); // default kept
        assert_eq!(c.stations[0].gain_mps2_per_count, Some(1e-6));
    }

    /// config/node.toml with every commented `# key = value` line and `# [section]` header
    /// made live.
    fn documented_config() -> String {
        let shipped = include_str!("../../../config/node.toml");
        shipped
            .lines()
            .map(|line| {
                let body = line.strip_prefix("# ").unwrap_or("");
                let is_header = body.starts_with('[') && body.trim_end().ends_with(']');
                let is_key = body.split_once(" = ").is_some_and(|(k, _)| {
                    !k.is_empty()
                        && k.chars()
                            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
                });
                if is_header || is_key {
                    body
                } else {
                    line
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn every_key_documented_in_config_node_toml_is_valid_with_its_documented_value() {
        // The token files [web] and [metrics] token_file name are read at load: beside the
        // file, as documented.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("node.toml");
        std::fs::write(&path, documented_config()).unwrap();
        std::fs::write(dir.path().join("web.token"), "0123456789abcdef-example\n").unwrap();
        std::fs::write(
            dir.path().join("metrics.token"),
            "fedcba9876543210-example\n",
        )
        .unwrap();
        let config = NodeConfig::load(&path).unwrap();
        assert_eq!(config.web.listen.as_deref(), Some("127.0.0.1:8080"));
        assert_eq!(
            config.metrics.token().unwrap().as_deref(),
            Some("fedcba9876543210-example")
        );
        assert!(config.state_dir.is_some());
        assert_eq!(config.stations[0].gain_mps2_per_count, Some(1.0e-6));
        assert_eq!(config.stations[0].full_scale, Some(8_388_607.0));
        assert!(matches!(
            config.stations[0].orientation,
            rockwatch_core::engine::Orientation::Azimuths { .. }
        ));
        assert_eq!(config.ros2.imu.len(), 1);
        assert_eq!(config.iceoryx2.alert_history, 128);
        assert_eq!(config.notify.len(), 2);
        assert_eq!(config.notify[0].kind, crate::notify::NotifyKind::Webhook);
        assert_eq!(config.notify[1].command[0], "/usr/local/bin/page-on-call");
    }

    #[test]
    fn config_node_toml_documents_every_key_of_the_schema() {
        // deny_unknown_fields lists a section's keys when it meets an unknown one.
        let documented = documented_config();
        let sections = [
            "",
            "[engine]",
            "[engine.alerts]",
            "[engine.stream]",
            "[[station]]\nid = \"XX.KEYS.00\"",
            "[ros2]",
            "[[ros2.imu]]\ntopic = \"/t\"\nstation = \"XX.IMU.00\"\nsample_rate_hz = 100.0",
            "[iceoryx2]",
            "[[notify]]\nkind = \"exec\"\ncommand = [\"true\"]",
            "[status]",
            "[metrics]",
            "[web]",
        ];
        for section in sections {
            let probe = format!("{section}\nno_such_key = 0\n");
            let error = load(&probe).unwrap_err();
            // serde's wording: "expected `a`", "expected `a` or `b`", "expected one of `a`, …".
            let (_, expected) = error
                .split_once(", expected ")
                .unwrap_or_else(|| panic!("{section}: {error}"));
            let expected = expected.trim_start_matches("one of ").replace(" or ", ", ");
            for key in expected.split(", ") {
                let key = key.trim().trim_matches('`');
                // A key as `key = …`, or a table as `[key]`, `[[key]]` or `[parent.key]`.
                let table = |l: &str| {
                    let name = l.trim_matches(|c| c == '[' || c == ']');
                    l.starts_with('[') && name.rsplit('.').next() == Some(key)
                };
                assert!(
                    documented
                        .lines()
                        .any(|l| l.starts_with(&format!("{key} = ")) || table(l)),
                    "config/node.toml does not document `{key}` of {section:?}"
                );
            }
        }
    }

    #[test]
    fn readme_imu_example_parses_with_the_documented_values() {
        let readme = include_str!("../../../README.md");
        let block = readme
            .split("```toml\n")
            .skip(1)
            .filter_map(|b| b.split("```").next())
            .find(|b| b.contains("[[ros2.imu]]"))
            .expect("README has a [[ros2.imu]] example");
        let c = load(block).unwrap();
        assert_eq!(c.ros2.input_qos, crate::ros2::InputQos::Reliable);
        assert_eq!(
            c.ros2.imu,
            vec![crate::ros2::ImuInput {
                topic: "/imu/data".into(),
                station: rockwatch_core::engine::StationId::parse("XB.IMU.00").unwrap(),
                sample_rate_hz: 100.0,
                remove_gravity: true,
                qos: crate::ros2::InputQos::SensorData,
            }]
        );
        // remove_gravity defaults to true.
        let c = load(
            "[[ros2.imu]]\ntopic = \"/imu\"\nstation = \"XB.IMU.00\"\nsample_rate_hz = 200.0\n",
        )
        .unwrap();
        assert!(c.ros2.imu[0].remove_gravity);
        // qos defaults to the sensor-data profile (best effort), whatever input_qos says.
        assert_eq!(c.ros2.imu[0].qos, crate::ros2::InputQos::SensorData);
    }

    #[test]
    fn bad_config_is_named() {
        let e = load("[engine]\nstate_intervl_s = 2.0\n").unwrap_err();
        assert!(
            e.contains("node.toml") && e.contains("state_intervl_s"),
            "{e}"
        );
        let e = load(
            "[[notify]]\nkind = \"exec\"\ncommand = [\"x\"]\n[[notify]]\nkind = \"webhook\"\n",
        )
        .unwrap_err();
        assert!(
            e.contains("node.toml") && e.contains("[[notify]] #2") && e.contains("url"),
            "{e}"
        );
        for (bad, says) in [
            ("partition = \"3/3\"\n", "i/N"),
            (
                "partition = \"1/3\"\n[partition_assign]\n\"CI.RRS.00\" = 3\n",
                "only 3",
            ),
            (
                "partition = \"1/3\"\n[partition_assign]\n\"CI.R-S.00\" = 0\n",
                "R-S",
            ),
            ("[partition_assign]\n\"CI.RRS.00\" = 0\n", "needs"),
        ] {
            let e = load(bad).unwrap_err();
            assert!(e.contains("node.toml") && e.contains(says), "{bad}: {e}");
        }
        let (p, map) = load("partition = \"2/3\"\n[partition_assign]\n\"CI.RRS.00\" = 0\n")
            .unwrap()
            .partitioning()
            .unwrap()
            .unwrap();
        assert_eq!(
            (p.index(), p.count(), map.partition_of("CI.RRS.00")),
            (2, 3, 0)
        );
        let e = load("[[station]]\nid = \"CI.R-S.00\"\n").unwrap_err();
        assert!(e.contains("node.toml") && e.contains("R-S"), "{e}");
        let e = load("[[station]]\nid = \"CI.RRS.00\"\norientation = { kind = \"azimuths\", h1_deg = 0.0, h2_deg = 45.0 }\n").unwrap_err();
        assert!(e.contains("orthogonal"), "{e}");
        let e = load("[status]\nrosout_level = \"loud\"\n").unwrap_err();
        assert!(
            e.contains("node.toml") && e.contains("status.rosout_level") && e.contains("loud"),
            "{e}"
        );
        for bad in [
            "[engine.stream]\nreorder_window_packets = 9223372036854775807\n",
            "[engine.alerts]\nimminent_theta_ratio = -1.0\n",
            "[engine.alerts]\nquiet_s = nan\n",
            "[engine.stream]\nmax_bridge_s = 1e12\n",
            "[engine]\nstale_after_s = 0.0\n",
            "[status]\ndiagnostics_period_s = 0.0\n",
        ] {
            let e = load(bad).unwrap_err();
            assert!(
                e.contains("node.toml") && e.contains("out of range"),
                "{bad}: {e}"
            );
        }
    }
}
