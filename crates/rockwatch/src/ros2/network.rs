//! The network plan: which DDS domain and interfaces a participant uses, resolved like rclcpp
//! from `ROS_DOMAIN_ID` (default 0) and `ROS_AUTOMATIC_DISCOVERY_RANGE` (`LOCALHOST` or `OFF`:
//! the loopback interface only), which the `[ros2]` configuration may override; and the DDS
//! Security enclave from the SROS2 variables (`security.rs`).

use std::net::{IpAddr, Ipv4Addr};

use rockwatch_core::partition::Partition;

use super::config::{DiscoveryRange, Ros2Config};
use super::names::{accel_topic, Naming, ALERTS_TOPIC, RESET_SERVICE};
use super::security::{security_from_env, DdsSecurity, SecurityError};

/// Which DDS domain and interfaces a participant uses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NetworkPlan {
    pub domain_id: u16,
    /// `None`: every interface.
    pub only_networks: Option<Vec<IpAddr>>,
    /// DDS Security (SROS2 enclave), `None`: unsecured.
    pub security: Option<DdsSecurity>,
}

impl NetworkPlan {
    /// True when the participant may be reached from beyond this host: it does not keep to
    /// loopback interfaces.
    #[must_use]
    pub fn beyond_localhost(&self) -> bool {
        match &self.only_networks {
            None => true,
            Some(n) => n.iter().any(|a| !a.is_loopback()),
        }
    }

    /// The line `rockwatch node` prints at start when its participant is reachable from other
    /// hosts without DDS Security (anyone there can publish packets and reset blocks), if so.
    /// It names the node's topics and service as `naming` resolves them (namespace and remaps),
    /// the input topic being `partition`'s ([`accel_topic`]). Error: a name does not resolve.
    pub fn exposure_warning(
        &self,
        naming: &Naming,
        partition: Option<Partition>,
    ) -> anyhow::Result<Option<String>> {
        if self.security.is_some() || !self.beyond_localhost() {
            return Ok(None);
        }
        let accel = naming.resolve(&accel_topic(partition))?;
        let reset = naming.resolve(RESET_SERVICE)?;
        let alerts = naming.resolve(ALERTS_TOPIC)?;
        Ok(Some(format!(
            "DDS Security is off and the node listens beyond localhost: \
             any host that reaches these interfaces can publish {accel} packets, reset \
             blocks ({reset}) and read alerts ({alerts}). Enable SROS2 \
             (launch-scripts/keystore.sh, ROS_SECURITY_ENABLE=true, ROS_SECURITY_KEYSTORE, \
             ROS_SECURITY_STRATEGY=Enforce) or keep DDS on loopback \
             (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST)"
        )))
    }
}

/// Why the DDS domain or interfaces could not be resolved.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NetworkPlanError {
    /// `ROS_DOMAIN_ID` is not an integer.
    #[error("ROS_DOMAIN_ID must be an integer 0..=232, got {0:?}")]
    DomainIdNotInteger(String),
    /// The domain id (from the configuration or the environment) is beyond ROS 2's range.
    #[error("DDS domain id must be 0..=232, got {0}")]
    DomainIdOutOfRange(u16),
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE` names no range.
    #[error("{0}")]
    DiscoveryRange(String),
    /// The SROS2 variables cannot be followed.
    #[error("DDS Security: {0}")]
    Security(#[from] SecurityError),
}

/// Resolves the configuration and the values of `ROS_DOMAIN_ID` and
/// `ROS_AUTOMATIC_DISCOVERY_RANGE` (the environment variables, passed in) into a plan.
pub fn network_plan(
    config: &Ros2Config,
    ros_domain_id: Option<&str>,
    ros_discovery_range: Option<&str>,
) -> Result<NetworkPlan, NetworkPlanError> {
    let domain_id = match (config.domain_id, ros_domain_id.map(str::trim)) {
        (Some(d), _) => d,
        (None, None | Some("")) => 0,
        (None, Some(s)) => s
            .parse::<u16>()
            .map_err(|_| NetworkPlanError::DomainIdNotInteger(s.to_owned()))?,
    };
    if domain_id > 232 {
        return Err(NetworkPlanError::DomainIdOutOfRange(domain_id));
    }
    let range = match (config.discovery_range, ros_discovery_range) {
        (Some(r), _) => r,
        (None, None) => DiscoveryRange::SystemDefault,
        (None, Some(s)) => s.trim().parse().map_err(NetworkPlanError::DiscoveryRange)?,
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
        security: None,
    })
}

/// The plan for this process's environment, for a participant whose own SROS2 enclave is
/// `enclave` (e.g. [`super::NODE_ENCLAVE`]; `ROS_SECURITY_ENCLAVE_OVERRIDE` replaces it): the
/// one way every command (`node`, `replay`, `acquire`, `reset`) resolves its domain,
/// interfaces and security.
pub fn network_plan_from_env(
    config: &Ros2Config,
    enclave: &str,
) -> Result<NetworkPlan, NetworkPlanError> {
    let domain = std::env::var("ROS_DOMAIN_ID").ok();
    let range = std::env::var("ROS_AUTOMATIC_DISCOVERY_RANGE").ok();
    let mut plan = network_plan(config, domain.as_deref(), range.as_deref())?;
    plan.security = security_from_env(config.enclave.as_deref().unwrap_or(enclave))?;
    Ok(plan)
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
    fn unsecured_participants_beyond_localhost_are_warned_about() {
        let naming = Naming::default();
        let warning = |plan: &NetworkPlan| plan.exposure_warning(&naming, None).unwrap();
        let mut plan = network_plan(&Ros2Config::default(), None, Some("LOCALHOST")).unwrap();
        assert!(warning(&plan).is_none());
        plan.only_networks = None;
        let text = warning(&plan).unwrap();
        assert!(text.contains("beyond localhost"), "{text}");
        assert!(text.contains("publish /pbr/accel packets"), "{text}");
        plan.only_networks = Some(vec![
            "127.0.0.1".parse().unwrap(),
            "10.0.0.5".parse().unwrap(),
        ]);
        assert!(warning(&plan).is_some());
        // In a namespace, partitioned: the names the node really uses.
        let site = Naming::new("/site_a", "rockwatch", Vec::new()).unwrap();
        let text = plan
            .exposure_warning(&site, Some(Partition::new(1, 3).unwrap()))
            .unwrap()
            .unwrap();
        assert!(
            text.contains("publish /site_a/pbr/accel/p1of3 packets")
                && text.contains("(/site_a/pbr/reset)")
                && text.contains("(/site_a/pbr/alerts)")
                && !text.contains(" /pbr/"),
            "{text}"
        );
        plan.security = Some(DdsSecurity {
            enclave: "/rockwatch/node".into(),
            dir: "/k/enclaves/rockwatch/node".into(),
        });
        assert!(warning(&plan).is_none());
    }

    #[test]
    fn bad_environment_values_are_named() {
        let config = Ros2Config::default();
        let e = network_plan(&config, Some("x"), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("ROS_DOMAIN_ID"), "{e}");
        let e = network_plan(&config, Some("300"), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("300"), "{e}");
        let e = network_plan(&config, None, Some("localhost"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("ROS_AUTOMATIC_DISCOVERY_RANGE"), "{e}");
        assert_eq!(
            network_plan(&config, Some(""), Some("")).unwrap().domain_id,
            0
        );
    }
}
