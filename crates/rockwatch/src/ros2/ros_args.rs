//! `--ros-args`, as every ROS 2 node takes them (rcl's argument rules, design.ros2.org
//! "ROS command line arguments"): the arguments between `--ros-args` and `--` (or the end) are
//! ROS arguments, several `--ros-args` sections may be given, the rest are the program's own.
//!
//! Supported: `-r`/`--remap [node:]from:=to` (with `__ns:=/x`, `__node:=n`, `__name:=n`),
//! `-p`/`--param name:=value` (the value read as YAML, as rcl does), `--params-file FILE` (the
//! ROS 2 parameter YAML: `node: {ros__parameters: {...}}`, nested namespaces, `/**` and `/*`
//! wildcards), `--log-level [logger:=]level` and `-e`/`--enclave NAME` (the SROS2 enclave of
//! the participant, as rcl: `ROS_SECURITY_ENCLAVE_OVERRIDE` still wins). Other rcl arguments
//! (`--log-config-file`, the `--enable/--disable-*-logs` switches) and anything unknown are an
//! error naming them, as rclcpp's `UnknownROSArgsError` is.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context as _};
use ros2_client::ParameterValue;
use yaml_rust2::{Yaml, YamlLoader};

use super::config::Ros2Config;
use super::names::{check_namespace, check_node_name, Remap, NODE_NAME};
use super::security::check_enclave;

/// A ROS 2 log level (`--log-level`): rcutils' severities.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RosLogLevel {
    Debug,
    Info,
    Warn,
    Error,
    Fatal,
}

impl RosLogLevel {
    fn parse(s: &str) -> anyhow::Result<RosLogLevel> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "debug" => RosLogLevel::Debug,
            "info" => RosLogLevel::Info,
            "warn" | "warning" => RosLogLevel::Warn,
            "error" => RosLogLevel::Error,
            "fatal" => RosLogLevel::Fatal,
            other => {
                bail!("--log-level: {other:?} is not a log level (debug, info, warn, error, fatal)")
            }
        })
    }

    /// The `log` crate's filter for this severity (fatal is error: `log` has no fatal).
    #[must_use]
    pub fn filter(self) -> log::LevelFilter {
        match self {
            RosLogLevel::Debug => log::LevelFilter::Debug,
            RosLogLevel::Info => log::LevelFilter::Info,
            RosLogLevel::Warn => log::LevelFilter::Warn,
            RosLogLevel::Error | RosLogLevel::Fatal => log::LevelFilter::Error,
        }
    }
}

/// One parameter assignment, with where it came from (for error messages).
#[derive(Debug, Clone, PartialEq)]
pub struct ParamAssignment {
    pub name: String,
    pub value: ParameterValue,
    /// `-p name:=value`, or `FILE (node pattern)`.
    pub source: String,
}

/// The parsed ROS arguments of one process.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RosArgs {
    /// Topic and service remaps, in the order given.
    pub remaps: Vec<Remap>,
    /// `__ns:=` rules: (node it is limited to, namespace).
    pub namespaces: Vec<(Option<String>, String)>,
    /// `__node:=` / `__name:=` rules: (node it is limited to, new name).
    pub node_names: Vec<(Option<String>, String)>,
    /// `-p` assignments, in order.
    pub params: Vec<ParamAssignment>,
    /// `--params-file` files, in order.
    pub params_files: Vec<PathBuf>,
    /// `--log-level LEVEL`: the default level.
    pub log_level: Option<RosLogLevel>,
    /// `--log-level NAME:=LEVEL`: per logger.
    pub logger_levels: Vec<(String, RosLogLevel)>,
    /// `--enclave NAME`: the participant's SROS2 enclave (the last one given).
    pub enclave: Option<String>,
}

/// The program's own arguments and the ROS arguments of a command line (rcl's split:
/// `--ros-args` opens a section of ROS arguments, a lone `--` closes it, another `--ros-args`
/// opens another). The returned flag tells whether any `--ros-args` was seen.
#[must_use]
pub fn split_ros_args<S: AsRef<std::ffi::OsStr> + Clone>(args: &[S]) -> (Vec<S>, Vec<S>, bool) {
    let (mut own, mut ros, mut seen, mut inside) = (Vec::new(), Vec::new(), false, false);
    for a in args {
        let s = a.as_ref();
        if s == "--ros-args" {
            seen = true;
            inside = true;
        } else if inside && s == "--" {
            inside = false;
        } else if inside {
            ros.push(a.clone());
        } else {
            own.push(a.clone());
        }
    }
    (own, ros, seen)
}

/// rcl arguments rockwatch knows but does not implement.
const UNSUPPORTED: [(&str, &str); 8] = [
    (
        "--log-config-file",
        "logging is configured with --log-level",
    ),
    (
        "--log-file-name",
        "rockwatch logs to stderr (journald under systemd)",
    ),
    ("--enable-rosout-logs", "not configurable"),
    ("--disable-rosout-logs", "not configurable"),
    ("--enable-stdout-logs", "logs always go to stderr"),
    ("--disable-stdout-logs", "logs always go to stderr"),
    ("--enable-external-lib-logs", "not configurable"),
    ("--disable-external-lib-logs", "not configurable"),
];

impl RosArgs {
    /// Parses the arguments of the ROS sections (see [`split_ros_args`]). Unknown arguments
    /// are collected and reported together; a known one without its value, or with a bad
    /// value, is an error naming it.
    pub fn parse<S: AsRef<str>>(args: &[S]) -> anyhow::Result<RosArgs> {
        let mut out = RosArgs::default();
        let mut unknown = Vec::new();
        let mut i = 0;
        while i < args.len() {
            let flag = args[i].as_ref();
            let value = |what: &str| -> anyhow::Result<&str> {
                args.get(i + 1)
                    .map(AsRef::as_ref)
                    .ok_or_else(|| anyhow!("--ros-args: {flag} needs a value ({what})"))
            };
            match flag {
                "-r" | "--remap" => {
                    out.remap(value("from:=to")?)?;
                    i += 2;
                }
                "-p" | "--param" => {
                    let rule = value("name:=value")?;
                    let (name, text) = rule.split_once(":=").ok_or_else(|| {
                        anyhow!("--ros-args {flag} {rule:?}: expected name:=value")
                    })?;
                    check_param_name(name)
                        .with_context(|| format!("--ros-args {flag} {rule:?}"))?;
                    let value =
                        parse_value(text).with_context(|| format!("--ros-args {flag} {rule:?}"))?;
                    out.params.push(ParamAssignment {
                        name: name.to_string(),
                        value,
                        source: format!("{flag} {rule}"),
                    });
                    i += 2;
                }
                "--params-file" => {
                    let file = value("a YAML parameter file")?;
                    out.params_files.push(PathBuf::from(file));
                    i += 2;
                }
                "-e" | "--enclave" => {
                    let name = value("an enclave, e.g. /rockwatch/node")?;
                    check_enclave(name).with_context(|| format!("--ros-args {flag} {name:?}"))?;
                    out.enclave = Some(name.to_string());
                    i += 2;
                }
                "--log-level" => {
                    let rule = value("a level, or logger:=level")?;
                    match rule.split_once(":=") {
                        Some((logger, level)) => out
                            .logger_levels
                            .push((logger.to_string(), RosLogLevel::parse(level)?)),
                        None => out.log_level = Some(RosLogLevel::parse(rule)?),
                    }
                    i += 2;
                }
                _ => {
                    if let Some((_, why)) = UNSUPPORTED.iter().find(|(f, _)| *f == flag) {
                        bail!("--ros-args: {flag} is a ROS 2 argument rockwatch does not support ({why})");
                    }
                    unknown.push(flag.to_string());
                    i += 1;
                }
            }
        }
        if !unknown.is_empty() {
            bail!(
                "unknown ROS arguments: {} (rockwatch takes -r/--remap, -p/--param, --params-file, --log-level and -e/--enclave after --ros-args; end them with --)",
                unknown
                    .iter()
                    .map(|a| format!("'{a}'"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        // The files must be readable and valid now, not at the node's start only.
        for file in &out.params_files {
            read_params_file(file)?;
        }
        Ok(out)
    }

    fn remap(&mut self, rule: &str) -> anyhow::Result<()> {
        let bad = |why: &str| anyhow!("--ros-args -r {rule:?}: {why}");
        let (lhs, to) = rule
            .split_once(":=")
            .ok_or_else(|| bad("expected from:=to"))?;
        // `node:from` limits the rule to one node; a name holds no ':'.
        let (node, from) = match lhs.split_once(':') {
            Some((node, from)) => {
                check_node_name(node).map_err(|e| bad(&format!("{e:#}")))?;
                (Some(node.to_string()), from)
            }
            None => (None, lhs),
        };
        if to.is_empty() {
            return Err(bad("empty replacement"));
        }
        match from {
            "__ns" => {
                let ns = check_namespace(to).map_err(|e| bad(&format!("{e:#}")))?;
                self.namespaces.push((node, ns));
            }
            "__node" | "__name" => {
                check_node_name(to).map_err(|e| bad(&format!("{e:#}")))?;
                self.node_names.push((node, to.to_string()));
            }
            _ => {
                let remap = Remap {
                    node,
                    from: from.to_string(),
                    to: to.to_string(),
                };
                // The names are checked here, so a bad rule fails at once.
                super::names::Naming::new("/", NODE_NAME, vec![remap.clone()])
                    .map_err(|e| bad(&format!("{e:#}")))?;
                self.remaps.push(remap);
            }
        }
        Ok(())
    }

    /// Applies the naming rules to the `[ros2]` section of the node `config.node_name` (or
    /// [`NODE_NAME`]): `__ns` and `__node` (the last matching rule of each wins, node-specific
    /// rules compared with the node's original name) and the remaps.
    pub fn apply_naming(&self, config: &mut Ros2Config) {
        let original = config.node_name.clone().unwrap_or(NODE_NAME.to_string());
        let applies = |node: &Option<String>| node.as_deref().is_none_or(|n| n == original);
        if let Some((_, ns)) = self.namespaces.iter().rev().find(|(n, _)| applies(n)) {
            config.namespace.clone_from(ns);
        }
        if let Some((_, name)) = self.node_names.iter().rev().find(|(n, _)| applies(n)) {
            config.node_name = Some(name.clone());
        }
        config.remaps.extend(self.remaps.iter().cloned());
        if let Some(enclave) = &self.enclave {
            config.enclave = Some(enclave.clone());
        }
    }

    /// Every parameter assignment for the node `node_fqn` (`/ns/name`), in the order they
    /// take effect (a later one overrides an earlier one): the parameter files in order, each
    /// file's matching sections in file order, then the `-p` assignments (which rcl gives
    /// precedence over files).
    pub fn parameters_for(&self, node_fqn: &str) -> anyhow::Result<Vec<ParamAssignment>> {
        let mut out = Vec::new();
        for file in &self.params_files {
            for (pattern, params) in read_params_file(file)? {
                if node_pattern_matches(&pattern, node_fqn) {
                    out.extend(params.into_iter().map(|(name, value)| ParamAssignment {
                        name,
                        value,
                        source: format!("{} ({pattern})", file.display()),
                    }));
                }
            }
        }
        out.extend(self.params.iter().cloned());
        Ok(out)
    }
}

/// A parameter name: tokens of `[A-Za-z0-9_]` separated by dots.
fn check_param_name(name: &str) -> anyhow::Result<()> {
    if name.is_empty()
        || name
            .split('.')
            .any(|t| t.is_empty() || !t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
    {
        bail!("{name:?} is not a parameter name (letters, digits, '_', separated by '.')");
    }
    Ok(())
}

/// A `-p` value: YAML, as rcl reads it (`1` integer, `1.0` double, `true` bool, `[1, 2]`
/// array, anything else a string).
fn parse_value(text: &str) -> anyhow::Result<ParameterValue> {
    let docs =
        YamlLoader::load_from_str(text).map_err(|e| anyhow!("value {text:?} is not YAML: {e}"))?;
    match docs.as_slice() {
        [] => Ok(ParameterValue::String(String::new())),
        [one] => yaml_value(one),
        _ => bail!("value {text:?} holds several YAML documents"),
    }
}

/// A YAML scalar or sequence as a parameter value.
fn yaml_value(y: &Yaml) -> anyhow::Result<ParameterValue> {
    let real = |s: &str| -> anyhow::Result<f64> {
        Yaml::Real(s.to_string())
            .as_f64()
            .ok_or_else(|| anyhow!("{s:?} is not a number"))
    };
    Ok(match y {
        Yaml::Boolean(b) => ParameterValue::Boolean(*b),
        Yaml::Integer(i) => ParameterValue::Integer(*i),
        Yaml::Real(s) => ParameterValue::Double(real(s)?),
        Yaml::String(s) => ParameterValue::String(s.clone()),
        Yaml::Array(items) => {
            if items.iter().all(|i| matches!(i, Yaml::Boolean(_))) && !items.is_empty() {
                ParameterValue::BooleanArray(items.iter().filter_map(Yaml::as_bool).collect())
            } else if items.iter().all(|i| matches!(i, Yaml::Integer(_))) && !items.is_empty() {
                ParameterValue::IntegerArray(items.iter().filter_map(Yaml::as_i64).collect())
            } else if items
                .iter()
                .all(|i| matches!(i, Yaml::Real(_) | Yaml::Integer(_)))
                && !items.is_empty()
            {
                let mut v = Vec::with_capacity(items.len());
                for i in items {
                    v.push(match i {
                        Yaml::Integer(n) => *n as f64,
                        Yaml::Real(s) => real(s)?,
                        _ => unreachable!("filtered above"),
                    });
                }
                ParameterValue::DoubleArray(v)
            } else if items.iter().all(|i| matches!(i, Yaml::String(_))) {
                ParameterValue::StringArray(
                    items
                        .iter()
                        .filter_map(|i| i.as_str().map(String::from))
                        .collect(),
                )
            } else {
                bail!("an array's items must all be of one type (bool, integer, double or string)")
            }
        }
        Yaml::Null => bail!("empty value (null)"),
        Yaml::Hash(_) => bail!("a mapping is not a parameter value"),
        Yaml::Alias(_) | Yaml::BadValue => bail!("unsupported YAML value"),
    })
}

/// The sections of a parameter file: (node pattern, its parameters in order).
type ParamSections = Vec<(String, Vec<(String, ParameterValue)>)>;

/// The sections of a ROS 2 parameter file: (node pattern, parameters) in file order. Keys
/// above `ros__parameters` form the node's name (`/ns/node`, or nested mappings `ns: node:`);
/// nested mappings below it form dotted parameter names.
fn read_params_file(path: &Path) -> anyhow::Result<ParamSections> {
    let text = rockwatch_core::bounded_read::read_to_string_bounded(
        path,
        rockwatch_core::bounded_read::MAX_CONFIG_FILE_BYTES,
    )
    .with_context(|| format!("--params-file {}: cannot read it", path.display()))?;
    let docs = YamlLoader::load_from_str(&text)
        .map_err(|e| anyhow!("--params-file {}: not YAML: {e}", path.display()))?;
    let mut sections = Vec::new();
    for doc in &docs {
        walk_nodes(doc, "", &mut sections)
            .with_context(|| format!("--params-file {}", path.display()))?;
    }
    if sections.is_empty() {
        bail!(
            "--params-file {}: no `ros__parameters` section (expected `node_name: {{ros__parameters: {{name: value}}}}`)",
            path.display()
        );
    }
    Ok(sections)
}

fn walk_nodes(y: &Yaml, path: &str, sections: &mut ParamSections) -> anyhow::Result<()> {
    let Yaml::Hash(map) = y else {
        bail!(
            "{}: expected node names above a `ros__parameters` mapping (`node_name: {{ros__parameters: {{name: value}}}}`)",
            if path.is_empty() { "top level" } else { path }
        );
    };
    for (k, v) in map {
        let key = k
            .as_str()
            .ok_or_else(|| anyhow!("{path}: a key is not a string: {k:?}"))?;
        if key == "ros__parameters" {
            if path.is_empty() {
                bail!("ros__parameters at the top level: it goes under a node name");
            }
            let mut params = Vec::new();
            walk_params(v, "", &mut params).with_context(|| path.to_string())?;
            sections.push((path.to_string(), params));
        } else {
            let key = key.trim_matches('/');
            let sub = format!("{path}/{key}");
            walk_nodes(v, &sub, sections)?;
        }
    }
    Ok(())
}

fn walk_params(
    y: &Yaml,
    prefix: &str,
    out: &mut Vec<(String, ParameterValue)>,
) -> anyhow::Result<()> {
    let Yaml::Hash(map) = y else {
        bail!("ros__parameters must be a mapping of parameter names");
    };
    for (k, v) in map {
        let key = match k {
            Yaml::String(s) => s.clone(),
            Yaml::Integer(i) => i.to_string(),
            other => bail!("a parameter name is not a string: {other:?}"),
        };
        let name = if prefix.is_empty() {
            key
        } else {
            format!("{prefix}.{key}")
        };
        if let Yaml::Hash(_) = v {
            walk_params(v, &name, out)?;
        } else {
            check_param_name(&name)?;
            let value = yaml_value(v).with_context(|| format!("parameter {name}"))?;
            out.push((name, value));
        }
    }
    Ok(())
}

/// Whether the node pattern of a parameter file (`/ns/node`, `/**`, `/**/node`, `/*/node`)
/// matches the node `fqn`: `*` is one name token, `**` any number of them (none included).
#[must_use]
pub fn node_pattern_matches(pattern: &str, fqn: &str) -> bool {
    fn tokens(s: &str) -> Vec<&str> {
        s.split('/').filter(|t| !t.is_empty()).collect()
    }
    fn matches(p: &[&str], n: &[&str]) -> bool {
        match p.split_first() {
            None => n.is_empty(),
            Some((&"**", rest)) => (0..=n.len()).any(|k| matches(rest, &n[k..])),
            Some((&t, rest)) => n
                .split_first()
                .is_some_and(|(&first, tail)| (t == "*" || t == first) && matches(rest, tail)),
        }
    }
    matches(&tokens(pattern), &tokens(fqn))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    #[test]
    fn sections_split_as_rcl_does() {
        let (own, ros, seen) = split_ros_args(&args(
            "node --config a.toml --ros-args -r __ns:=/x -- --shards 2 --ros-args -p a:=1",
        ));
        assert!(seen);
        assert_eq!(own, args("node --config a.toml --shards 2"));
        assert_eq!(ros, args("-r __ns:=/x -p a:=1"));
        let (own, ros, seen) = split_ros_args(&args("node --config a.toml"));
        assert!(!seen && ros.is_empty() && own.len() == 3);
    }

    #[test]
    fn remaps_namespace_node_name_params_and_log_level_are_parsed() {
        let a = RosArgs::parse(&args(
            "-r __ns:=/site_a --remap rockwatch:__node:=rw -r pbr/alerts:=/all/alerts \
             -r other:~/x:=y -p alerts.quiet_s:=12 --param state_interval_s:=2.5 \
             -p names:=[a,b] -p flag:=true -p text:=hello --log-level debug --log-level rockwatch:=warn",
        ))
        .unwrap();
        assert_eq!(a.namespaces, [(None, "/site_a".to_string())]);
        assert_eq!(a.node_names, [(Some("rockwatch".into()), "rw".to_string())]);
        assert_eq!(a.remaps.len(), 2);
        assert_eq!(a.remaps[0].from, "pbr/alerts");
        assert_eq!(a.remaps[1].node.as_deref(), Some("other"));
        let values: Vec<_> = a.params.iter().map(|p| (&p.name[..], &p.value)).collect();
        assert_eq!(
            values,
            [
                ("alerts.quiet_s", &ParameterValue::Integer(12)),
                ("state_interval_s", &ParameterValue::Double(2.5)),
                (
                    "names",
                    &ParameterValue::StringArray(vec!["a".into(), "b".into()])
                ),
                ("flag", &ParameterValue::Boolean(true)),
                ("text", &ParameterValue::String("hello".into())),
            ]
        );
        assert_eq!(a.log_level, Some(RosLogLevel::Debug));
        assert_eq!(a.logger_levels, [("rockwatch".into(), RosLogLevel::Warn)]);

        let mut config = Ros2Config::default();
        a.apply_naming(&mut config);
        let naming = config.naming().unwrap();
        assert_eq!(naming.node_fqn(), "/site_a/rw");
        assert_eq!(naming.resolve("pbr/alerts").unwrap(), "/all/alerts");
        assert_eq!(naming.resolve("pbr/state").unwrap(), "/site_a/pbr/state");
    }

    #[test]
    fn unknown_unsupported_and_incomplete_arguments_are_errors_naming_them() {
        let e = RosArgs::parse(&args("-r a:=b --frobnicate -x")).unwrap_err();
        let e = format!("{e:#}");
        assert!(
            e.contains("unknown ROS arguments: '--frobnicate', '-x'"),
            "{e}"
        );
        let e = format!(
            "{:#}",
            RosArgs::parse(&args("--log-config-file f")).unwrap_err()
        );
        assert!(
            e.contains("--log-config-file") && e.contains("does not support"),
            "{e}"
        );
        // Issue 20 item 13: --enclave is taken (a well-formed name), as rcl takes it.
        let parsed = RosArgs::parse(&args("--enclave /site/node -e /site/other")).unwrap();
        assert_eq!(parsed.enclave.as_deref(), Some("/site/other"));
        let mut config = Ros2Config::default();
        parsed.apply_naming(&mut config);
        assert_eq!(config.enclave.as_deref(), Some("/site/other"));
        for bad in ["--enclave relative", "--enclave /a/../b", "-e"] {
            assert!(RosArgs::parse(&args(bad)).is_err(), "{bad}");
        }
        for (bad, what) in [
            ("-r", "needs a value"),
            ("-r a=b", "from:=to"),
            ("-r a:=", "empty"),
            ("-r __ns:=/a-b", "not allowed"),
            ("-r __node:=a/b", "not allowed"),
            ("-r a:=b//c", "token"),
            ("-p x", "name:=value"),
            ("-p bad-name:=1", "not a parameter name"),
            ("-p x:=[1,a]", "one type"),
            ("--log-level loud", "not a log level"),
            ("--params-file /nonexistent/p.yaml", "cannot read"),
        ] {
            let e = format!("{:#}", RosArgs::parse(&args(bad)).unwrap_err());
            assert!(e.contains(what), "{bad}: {e}");
        }
    }

    #[test]
    fn params_files_nested_namespaces_wildcards_and_precedence() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("p.yaml");
        std::fs::write(
            &file,
            "/**:\n  ros__parameters:\n    alerts:\n      quiet_s: 10.0\n    state_interval_s: 3.0\n\
             site_a:\n  rockwatch:\n    ros__parameters:\n      alerts.quiet_s: 20.0\n\
             /site_b/rockwatch:\n  ros__parameters:\n    alerts:\n      quiet_s: 99.0\n\
             /*/rockwatch:\n  ros__parameters:\n    state_interval_s: 4\n",
        )
        .unwrap();
        let a = RosArgs::parse(&[
            "--params-file".to_string(),
            file.display().to_string(),
            "-p".into(),
            "alerts.quiet_s:=30.0".into(),
        ])
        .unwrap();
        let got: Vec<(String, ParameterValue)> = a
            .parameters_for("/site_a/rockwatch")
            .unwrap()
            .into_iter()
            .map(|p| (p.name, p.value))
            .collect();
        assert_eq!(
            got,
            [
                ("alerts.quiet_s".into(), ParameterValue::Double(10.0)),
                ("state_interval_s".into(), ParameterValue::Double(3.0)),
                ("alerts.quiet_s".into(), ParameterValue::Double(20.0)),
                ("state_interval_s".into(), ParameterValue::Integer(4)),
                ("alerts.quiet_s".into(), ParameterValue::Double(30.0)),
            ]
        );
        // /*/rockwatch needs exactly one namespace token; /** matches the root node too.
        let root: Vec<String> = a
            .parameters_for("/rockwatch")
            .unwrap()
            .into_iter()
            .map(|p| p.source)
            .collect();
        assert_eq!(root.len(), 3, "{root:?}");
        assert!(node_pattern_matches("/**", "/a/b/c"));
        assert!(node_pattern_matches("/**/c", "/c"));
        assert!(node_pattern_matches("/a/*/c", "/a/b/c"));
        assert!(!node_pattern_matches("/a/*/c", "/a/c"));
        assert!(!node_pattern_matches(
            "/site_a/rockwatch",
            "/site_b/rockwatch"
        ));

        // A file without any node section, and one that is not YAML, are refused.
        std::fs::write(&file, "alerts:\n  quiet_s: 1\n").unwrap();
        let e =
            RosArgs::parse(&["--params-file".to_string(), file.display().to_string()]).unwrap_err();
        assert!(format!("{e:#}").contains("ros__parameters"), "{e:#}");
        std::fs::write(&file, "a: [1\n").unwrap();
        let e =
            RosArgs::parse(&["--params-file".to_string(), file.display().to_string()]).unwrap_err();
        assert!(format!("{e:#}").contains("not YAML"), "{e:#}");
    }
}
