//! The node's names in the ROS graph and their resolution, as rcl does it
//! (design.ros2.org "Topic and Service name mapping", rcl's `rcl_expand_topic_name` and
//! `rcl_remap_*`): the node, its topics and its service are named RELATIVE (`pbr/alerts`),
//! so a node in the namespace `/site_a` publishes `/site_a/pbr/alerts`; an absolute name
//! (`/imu/data`) stays as it is; `~` is the node's own name (`~/x` = `/site_a/rockwatch/x`).
//! Remap rules (`--ros-args -r from:=to`) then replace a resolved name: the first rule whose
//! resolved `from` equals it wins. `[Naming]` does both for one node; the session resolves
//! every topic and service name through it.

use anyhow::{anyhow, bail};
use rockwatch_core::partition::Partition;
use ros2_client::ServiceMapping;

/// The node's default name in the ROS graph (`-r __node:=NAME` changes it).
pub const NODE_NAME: &str = "rockwatch";
/// Input topic (`pbr_msgs/AccelPacket`), relative: resolved in the node's namespace.
pub const ACCEL_TOPIC: &str = "pbr/accel";
/// The input topic of `partition` of a scaled-out service, `pbr/accel/p<i>of<N>` (relative,
/// resolved in the node's namespace like [`ACCEL_TOPIC`]; docs/capacity.md); [`ACCEL_TOPIC`]
/// without one. RustDDS 0.15 implements neither the DDS Partition QoS nor content-filtered
/// topics, and ROS 2 messages carry no DDS key: a topic per partition is what lets a node
/// receive only its stations' packets.
#[must_use]
pub fn accel_topic(partition: Option<Partition>) -> String {
    match partition {
        Some(p) => format!("{ACCEL_TOPIC}/p{}of{}", p.index(), p.count()),
        None => ACCEL_TOPIC.to_string(),
    }
}
/// Output topics, relative.
pub const IMS_TOPIC: &str = "pbr/ims";
pub const STATE_TOPIC: &str = "pbr/state";
pub const ALERTS_TOPIC: &str = "pbr/alerts";
/// What the node has taken from each writer of [`ACCEL_TOPIC`] (`pbr_msgs/IntakeReport`).
pub const INTAKE_TOPIC: &str = "pbr/intake";
/// The node's status (`diagnostic_msgs/DiagnosticArray`), absolute as diagnostic_updater's:
/// one `/diagnostics` per ROS 2 graph, whatever the node's namespace.
pub const DIAGNOSTICS_TOPIC: &str = "/diagnostics";
/// The 3-D view's markers (`visualization_msgs/MarkerArray`), relative: in the node's namespace.
pub const MARKERS_TOPIC: &str = "pbr/markers";
/// The rocks' static frames (`tf2_msgs/TFMessage`), absolute as tf2's.
pub const TF_STATIC_TOPIC: &str = "/tf_static";
/// The fixed frame of the 3-D view (`markers.rs`): local ENU at `[ros2] map_origin`.
pub const MAP_FRAME: &str = "map";

/// The frame of rock `pbr_id`: `pbr/<id>` (the `header.frame_id` of its `PbrState`; `map` →
/// `pbr/<id>` on `/tf_static`).
#[must_use]
pub fn rock_frame(pbr_id: &str) -> String {
    format!("pbr/{pbr_id}")
}
/// The operator reset service (`pbr_msgs/srv/ResetPbr`), relative like the topics.
pub const RESET_SERVICE: &str = "pbr/reset";
/// The ROS 2 <-> DDS mapping the reset CLIENT (`rockwatch reset`) uses: the "enhanced"
/// RPC-over-DDS mapping, that of ROS 2's default middleware (rmw_fastrtps) and of
/// rmw_connextdds. The node's servers answer it and rmw_cyclonedds's mapping alike
/// (`held_server.rs`, `rpc_wire.rs`).
pub const RESET_SERVICE_MAPPING: ServiceMapping = ServiceMapping::Enhanced;

/// One remap rule `[node:]from:=to` (topic and service names; `__ns` and `__node` are taken
/// apart by the argument parser).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Remap {
    /// Applies to the node of this name only (`node:from:=to`); `None`: to every node.
    pub node: Option<String>,
    pub from: String,
    pub to: String,
}

impl std::fmt::Display for Remap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(node) = &self.node {
            write!(f, "{node}:")?;
        }
        write!(f, "{}:={}", self.from, self.to)
    }
}

/// How one node's names resolve: its namespace, its name and the remap rules in force.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Naming {
    /// Absolute namespace, `/` or `/a/b` (no trailing slash).
    namespace: String,
    /// The node's base name.
    node: String,
    remaps: Vec<Remap>,
}

impl Default for Naming {
    fn default() -> Self {
        Naming {
            namespace: "/".into(),
            node: NODE_NAME.into(),
            remaps: Vec::new(),
        }
    }
}

/// The namespace alone (the node name [`NODE_NAME`], no remaps); an invalid namespace is
/// an error, as [`Naming::new`] says.
impl TryFrom<&str> for Naming {
    type Error = anyhow::Error;

    fn try_from(namespace: &str) -> anyhow::Result<Naming> {
        Naming::new(namespace, NODE_NAME, Vec::new())
    }
}

/// What the ROS 2 clients take as their naming: a [`Naming`] (or `&Naming`), or a namespace
/// (`&str`, checked).
pub trait IntoNaming {
    /// The naming, or why the namespace is invalid.
    fn into_naming(self) -> anyhow::Result<Naming>;
}

impl<T: TryInto<Naming>> IntoNaming for T
where
    T::Error: Into<anyhow::Error>,
{
    fn into_naming(self) -> anyhow::Result<Naming> {
        self.try_into().map_err(Into::into)
    }
}

impl From<&Naming> for Naming {
    fn from(naming: &Naming) -> Naming {
        naming.clone()
    }
}

impl Naming {
    /// Checks and normalises: a namespace without its leading `/` gets one (as rcl does for
    /// `__ns`), a trailing `/` is dropped; the node name is one token; every remap rule's
    /// names are valid.
    pub fn new(namespace: &str, node: &str, remaps: Vec<Remap>) -> anyhow::Result<Naming> {
        let namespace = normalise_namespace(namespace)?;
        check_base_name(node).map_err(|e| anyhow!("node name {node:?}: {e}"))?;
        for r in &remaps {
            if let Some(n) = &r.node {
                check_base_name(n).map_err(|e| anyhow!("remap {r}: node name {n:?}: {e}"))?;
            }
            check_name(&r.from).map_err(|e| anyhow!("remap {r}: {:?}: {e}", r.from))?;
            check_name(&r.to).map_err(|e| anyhow!("remap {r}: {:?}: {e}", r.to))?;
        }
        Ok(Naming {
            namespace,
            node: node.into(),
            remaps,
        })
    }

    /// The same namespace and remaps for another node of the process (a tool's client node,
    /// e.g. `rockwatch_replay`): node-specific rules then apply to that name.
    #[must_use]
    pub fn for_node(&self, node: &str) -> Naming {
        Naming {
            node: node.into(),
            ..self.clone()
        }
    }

    #[must_use]
    pub fn namespace(&self) -> &str {
        &self.namespace
    }

    #[must_use]
    pub fn node(&self) -> &str {
        &self.node
    }

    #[must_use]
    pub fn remaps(&self) -> &[Remap] {
        &self.remaps
    }

    /// The node's fully qualified name, `/ns/node`.
    #[must_use]
    pub fn node_fqn(&self) -> String {
        join(&self.namespace, &self.node)
    }

    /// `name` expanded against this node (relative → in the namespace, `~` → the node's
    /// name), without remapping.
    pub fn expand(&self, name: &str) -> anyhow::Result<String> {
        check_name(name).map_err(|e| anyhow!("ROS 2 name {name:?}: {e}"))?;
        Ok(if let Some(rest) = name.strip_prefix('~') {
            let fqn = self.node_fqn();
            match rest.strip_prefix('/') {
                Some(rest) => join(&fqn, rest),
                None => fqn,
            }
        } else if name.starts_with('/') {
            name.to_string()
        } else {
            join(&self.namespace, name)
        })
    }

    /// The absolute name a topic or service `name` of this node resolves to: expanded, then
    /// the first matching remap rule applied (its replacement expanded too).
    pub fn resolve(&self, name: &str) -> anyhow::Result<String> {
        let expanded = self.expand(name)?;
        for rule in &self.remaps {
            if rule.node.as_deref().is_some_and(|n| n != self.node) {
                continue;
            }
            if self.expand(&rule.from)? == expanded {
                return self.expand(&rule.to);
            }
        }
        Ok(expanded)
    }
}

/// `base` + `/` + `name` (`base` absolute, `/` or without trailing slash).
fn join(base: &str, name: &str) -> String {
    if base == "/" {
        format!("/{name}")
    } else {
        format!("{base}/{name}")
    }
}

/// An absolute namespace without trailing slash (`/` for the root).
pub(crate) fn normalise_namespace(namespace: &str) -> anyhow::Result<String> {
    let trimmed = namespace.trim_end_matches('/');
    if trimmed.is_empty() {
        return Ok("/".into());
    }
    let absolute = if trimmed.starts_with('/') {
        trimmed.to_string()
    } else {
        format!("/{trimmed}")
    };
    for token in absolute[1..].split('/') {
        check_token(token).map_err(|e| anyhow!("namespace {namespace:?}: {e}"))?;
    }
    Ok(absolute)
}

/// One token of a name: `[A-Za-z_][A-Za-z0-9_]*` without `__` (ROS 2 name rules).
fn check_token(token: &str) -> Result<(), String> {
    let mut chars = token.chars();
    match chars.next() {
        None => return Err("empty token (a repeated or misplaced '/')".into()),
        Some(c) if c.is_ascii_alphabetic() || c == '_' => {}
        Some(c) => return Err(format!("a token must not start with {c:?}")),
    }
    if let Some(c) = token
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '_'))
    {
        return Err(format!(
            "{c:?} is not allowed (letters, digits, '_' and '/' only)"
        ));
    }
    if token.contains("__") {
        return Err("'__' (repeated underscores) is not allowed".into());
    }
    Ok(())
}

/// A node's base name: one token.
fn check_base_name(name: &str) -> Result<(), String> {
    check_token(name)
}

/// A topic or service name: absolute (`/a/b`), relative (`a/b`) or private (`~`, `~/a`).
fn check_name(name: &str) -> Result<(), String> {
    if name.contains('{') || name.contains('}') {
        return Err("substitutions ({node}, {ns}) are not supported".into());
    }
    let rest = if let Some(rest) = name.strip_prefix('~') {
        if rest.is_empty() {
            return Ok(());
        }
        rest.strip_prefix('/')
            .ok_or("'~' must be followed by '/' or end the name")?
    } else {
        name.strip_prefix('/').unwrap_or(name)
    };
    if rest.is_empty() {
        return Err("empty name".into());
    }
    if rest.ends_with('/') {
        return Err("a name must not end with '/'".into());
    }
    rest.split('/').try_for_each(check_token)
}

/// Fails unless `name` is one token (a node name).
pub(crate) fn check_node_name(name: &str) -> anyhow::Result<()> {
    check_base_name(name).map_err(|e| anyhow!("node name {name:?}: {e}"))
}

/// Used by the argument parser for `__ns`.
pub(crate) fn check_namespace(namespace: &str) -> anyhow::Result<String> {
    if namespace.is_empty() {
        bail!("empty namespace");
    }
    normalise_namespace(namespace)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn remap(node: Option<&str>, from: &str, to: &str) -> Remap {
        Remap {
            node: node.map(Into::into),
            from: from.into(),
            to: to.into(),
        }
    }

    #[test]
    fn partition_topics_are_relative_and_resolve_in_the_namespace() {
        let p = Partition::new(1, 3).unwrap();
        assert_eq!(accel_topic(None), ACCEL_TOPIC);
        assert_eq!(accel_topic(Some(p)), "pbr/accel/p1of3");
        let site = Naming::new("/site_a", NODE_NAME, vec![]).unwrap();
        assert_eq!(
            site.resolve(&accel_topic(Some(p))).unwrap(),
            "/site_a/pbr/accel/p1of3"
        );
        assert_eq!(
            Naming::default().resolve(&accel_topic(Some(p))).unwrap(),
            "/pbr/accel/p1of3"
        );
    }

    #[test]
    fn relative_names_resolve_in_the_namespace_absolute_ones_stay() {
        let site = Naming::new("/site_a", NODE_NAME, vec![]).unwrap();
        assert_eq!(site.resolve(ALERTS_TOPIC).unwrap(), "/site_a/pbr/alerts");
        assert_eq!(site.resolve(RESET_SERVICE).unwrap(), "/site_a/pbr/reset");
        assert_eq!(site.resolve("/imu/data").unwrap(), "/imu/data");
        assert_eq!(site.resolve("~").unwrap(), "/site_a/rockwatch");
        assert_eq!(site.resolve("~/x").unwrap(), "/site_a/rockwatch/x");
        let root = Naming::default();
        assert_eq!(root.resolve(ALERTS_TOPIC).unwrap(), "/pbr/alerts");
        assert_eq!(root.node_fqn(), "/rockwatch");
        // Nested namespaces, a namespace given without its leading slash or with a trailing one.
        let nested = Naming::new("a/b/", "n", vec![]).unwrap();
        assert_eq!(nested.namespace(), "/a/b");
        assert_eq!(nested.resolve("t").unwrap(), "/a/b/t");
        assert_eq!(nested.node_fqn(), "/a/b/n");
    }

    #[test]
    fn remaps_match_resolved_names_first_rule_wins_node_specific_rules_filter() {
        let n = Naming::new(
            "/site_a",
            NODE_NAME,
            vec![
                remap(Some("other"), "pbr/alerts", "/never"),
                remap(None, "pbr/alerts", "alerts_out"),
                remap(None, "/site_a/pbr/alerts", "/second"),
                remap(Some("rockwatch"), "/site_a/pbr/accel", "/shared/accel"),
            ],
        )
        .unwrap();
        // Relative from and to: both resolved in the namespace.
        assert_eq!(n.resolve("pbr/alerts").unwrap(), "/site_a/alerts_out");
        // The rule's `from` is compared after resolution: the absolute spelling matches too.
        assert_eq!(
            n.resolve("/site_a/pbr/alerts").unwrap(),
            "/site_a/alerts_out"
        );
        assert_eq!(n.resolve("pbr/accel").unwrap(), "/shared/accel");
        assert_eq!(n.resolve("pbr/state").unwrap(), "/site_a/pbr/state");
        // A client node of the same process: the node-specific rule does not apply to it.
        assert_eq!(
            n.for_node("rockwatch_replay").resolve("pbr/accel").unwrap(),
            "/site_a/pbr/accel"
        );
    }

    #[test]
    fn invalid_names_are_refused_with_the_rule() {
        for bad in [
            "", "/", "a//b", "a/", "1a", "a b", "a__b", "~x", "{node}/x", "a/-",
        ] {
            assert!(Naming::default().resolve(bad).is_err(), "{bad:?}");
        }
        assert!(Naming::new("/a b", NODE_NAME, vec![]).is_err());
        assert!(Naming::new("/", "a/b", vec![]).is_err());
        let e = Naming::new("/", NODE_NAME, vec![remap(None, "ok", "not ok")]).unwrap_err();
        assert!(format!("{e}").contains("not ok"), "{e}");
    }
}
