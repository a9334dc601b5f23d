//! A ROS 2 session: one DDS participant following a [`NetworkPlan`], one ROS 2 node on it and
//! the node's spinner thread (discovery, parameter services); the topics, publishers and
//! subscriptions of every endpoint are made through it.

use std::thread::JoinHandle;

use anyhow::anyhow;
use ros2_client::dds::rustdds::{DomainParticipantBuilder, DomainParticipantSecurityConfigFiles};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, QosProfile, Subscription,
};

use super::liveness::DdsThreads;
use super::msg;
use super::names::Naming;
use super::network::NetworkPlan;
use crate::logging::MuteLibraries;

fn dds_err(what: &str) -> impl Fn(ros2_client::CreateError) -> anyhow::Error + '_ {
    move |e| anyhow!("ROS 2: {what}: {e:?}")
}

/// Longest wait for the spinner thread to create its readers when a session opens.
const SPINNER_SETUP_WAIT: std::time::Duration = std::time::Duration::from_secs(10);

/// Longest wait for the spinner thread to stop when a session is dropped.
const SPINNER_STOP_WAIT: std::time::Duration = std::time::Duration::from_secs(2);

/// A DDS participant with one ROS 2 node and its spinner thread (discovery, parameters).
pub struct Ros2Session {
    pub(super) node: Node,
    pub(super) context: Context,
    plan: NetworkPlan,
    /// How the node's topic and service names resolve (namespace, name, remaps).
    naming: Naming,
    spinner: Option<JoinHandle<()>>,
    /// The participant's RustDDS threads (see [`Ros2Session::ended_thread`]).
    threads: DdsThreads,
    /// Dropped last: ends the muting of the libraries' log lines that `drop` starts, so the
    /// participant's teardown (every field above) is quiet.
    _teardown: Option<MuteLibraries>,
}

impl Ros2Session {
    /// Creates the participant following `plan` and the node `naming` names (its namespace
    /// and name; every topic and service name of the session resolves through it).
    pub fn open(
        plan: &NetworkPlan,
        naming: &Naming,
        options: NodeOptions,
    ) -> anyhow::Result<Ros2Session> {
        let (namespace, name) = (naming.namespace(), naming.node());
        let mut builder = DomainParticipantBuilder::new(plan.domain_id);
        if let Some(networks) = &plan.only_networks {
            builder = builder.with_only_networks(networks.iter().copied());
        }
        if !plan.beyond_localhost() {
            // RustDDS's warnings that a loopback-only participant makes expected: at debug.
            crate::logging::expect(crate::logging::Expectation::LoopbackOnlyDds);
        }
        if let Some(security) = &plan.security {
            // The SROS2 file names; keys are not encrypted (RustDDS reads no encrypted key).
            builder = builder.builtin_security(
                DomainParticipantSecurityConfigFiles::with_ros_default_names(
                    &security.dir,
                    String::new(),
                ),
            );
        }
        let (participant, threads) = DdsThreads::spawned_by(|| builder.build());
        let participant = participant.map_err(|e| match &plan.security {
            Some(s) => anyhow!(
                "DDS participant (domain {}, DDS Security enclave {} in {}): {e:?}",
                plan.domain_id,
                s.enclave,
                s.dir.display()
            ),
            None => anyhow!("DDS participant (domain {}): {e:?}", plan.domain_id),
        })?;
        let context = Context::from_domain_participant(participant).map_err(dds_err("context"))?;
        let node_name = NodeName::new(namespace, name)
            .map_err(|e| anyhow!("ROS 2 node name {namespace:?}/{name:?}: {e:?}"))?;
        let mut node = context
            .new_node(node_name, options)
            .map_err(|e| anyhow!("ROS 2 node: {e:?}"))?;
        let spinner = node.spinner().map_err(dds_err("spinner"))?;
        // The spinner creates its readers (ros_discovery_info, clock) when it is first
        // polled. With DDS Security, RustDDS 0.15.1 deadlocks if another thread creates a
        // topic meanwhile: creating a reader takes the security plugins' lock and then the
        // participant's, creating a topic takes them the other way round (seen: `acquire`
        // hung for good, RustDDS logging "I need my lock!!" every 100 ms). So the caller
        // waits here until that first poll is over, before it creates any endpoint.
        let (set_up, spinner_set_up) = std::sync::mpsc::channel::<()>();
        let spinner = std::thread::Builder::new()
            .name(format!("ros2-spin-{name}"))
            .spawn(move || {
                let spun = futures::executor::block_on(async move {
                    let mut spin = std::pin::pin!(spinner.spin());
                    let first = futures::poll!(spin.as_mut());
                    drop(set_up);
                    match first {
                        std::task::Poll::Ready(result) => result,
                        std::task::Poll::Pending => spin.await,
                    }
                });
                if let Err(e) = spun {
                    tracing::warn!("ROS 2 spinner stopped: {e:?}");
                }
            })?;
        // Disconnected once the first poll is over (or the thread ended); bounded all the same.
        let _ = spinner_set_up.recv_timeout(SPINNER_SETUP_WAIT);
        Ok(Ros2Session {
            node,
            context,
            plan: plan.clone(),
            naming: naming.clone(),
            spinner: Some(spinner),
            threads,
            _teardown: None,
        })
    }

    /// The first of the participant's RustDDS threads that has ended, if any (then the
    /// participant is dead for good: it neither sends, receives nor discovers). See
    /// [`DdsThreads`].
    #[must_use]
    pub fn ended_thread(&self) -> Option<String> {
        self.threads.ended()
    }

    /// A session for the client node `name` of a tool (replay, listener, reset client) in
    /// `naming`'s namespace, with its remaps: without `/rosout` and without parameter services
    /// (nothing to set; and none to grant in a DDS Security permissions document).
    pub fn open_client(
        plan: &NetworkPlan,
        naming: &Naming,
        name: &str,
    ) -> anyhow::Result<Ros2Session> {
        Ros2Session::open(
            plan,
            &naming.for_node(name),
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )
    }

    /// How the session's names resolve.
    #[must_use]
    pub fn naming(&self) -> &Naming {
        &self.naming
    }

    /// The absolute name `name` (relative, absolute or `~`) resolves to on this node.
    pub fn resolve(&self, name: &str) -> anyhow::Result<String> {
        self.naming.resolve(name)
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

    /// The topic `<package>/<type_name>` on `name`, resolved ([`Ros2Session::resolve`]).
    pub(super) fn topic(
        &mut self,
        name: &str,
        package: &str,
        type_name: &str,
        qos: &QosProfile,
    ) -> anyhow::Result<ros2_client::dds::rustdds::Topic> {
        let name = &self.resolve(name)?;
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
        self.publisher_of(name, msg::PACKAGE, type_name, qos)
    }

    /// A publisher of `<package>/<type_name>` on `name`.
    pub fn publisher_of<M: serde::Serialize>(
        &mut self,
        name: &str,
        package: &str,
        type_name: &str,
        qos: QosProfile,
    ) -> anyhow::Result<ros2_client::Publisher<M>> {
        let topic = self.topic(name, package, type_name, &qos)?;
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
        // RustDDS logs an error per endpoint it cannot remove from an ended event loop, and
        // per multicast group it leaves on an interface that is gone: nothing to act on.
        self._teardown = Some(MuteLibraries::new());
        self.node.stop_spinner();
        if let Some(spinner) = self.spinner.take() {
            // Bounded: a spinner that missed the stop (its stop channel already closed, seen
            // when a secured participant is dropped right after a refused endpoint) is left
            // to end with the process rather than hang it.
            let deadline = std::time::Instant::now() + SPINNER_STOP_WAIT;
            while !spinner.is_finished() && std::time::Instant::now() < deadline {
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
            if spinner.is_finished() {
                let _ = spinner.join();
            }
        }
    }
}
