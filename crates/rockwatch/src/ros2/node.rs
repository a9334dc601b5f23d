//! The node's ROS 2 side ([`Ros2Node`]): its session, parameter services, input subscriptions
//! and reset service, driven by the node's event loop; [`Ros2Node::start`] also returns the
//! output publishers.

use std::sync::Arc;

use ros2_client::dds::rustdds::mio1::{Registry, Token};
use ros2_client::NodeOptions;

use super::config::Ros2Config;
use super::diagnostics::StatusPublisher;
use super::input::{Inputs, IntakeCounters, IntakeLog};
use super::msg;
use super::names::INTAKE_TOPIC;
use super::network::NetworkPlan;
use super::parameters::{ParamServer, ParamValues};
use super::publish::Ros2Publisher;
use super::qos::intake_qos;
use super::reset::ResetServer;
use super::session::Ros2Session;
use crate::intake::WriterCounts;
use crate::ports::{ControlSender, Received};
use rockwatch_core::engine::{EngineConfig, Source, SourceTally};
use rockwatch_core::partition::Partition;

/// The node's ROS 2 side: parameters, the input subscriptions, the reset service and (returned
/// separately by [`Ros2Node::start`]) the output publishers. It has no intake thread: the
/// node's event loop registers the subscriptions ([`Ros2Node::register`]) and the service
/// ([`Ros2Node::register_reset`]), drains the subscriptions that are ready
/// ([`Ros2Node::drain`]) and serves the service ([`Ros2Node::serve_resets`]).
pub struct Ros2Node {
    /// What [`Ros2Node::rebuild`] starts again from.
    started: Started,
    inputs: Inputs,
    pub counters: Arc<IntakeCounters>,
    log: IntakeLog,
    reset: ResetServer,
    params: ParamServer,
    /// `/pbr/intake`: what the node took of each writer of `/pbr/accel`.
    intake: ros2_client::Publisher<msg::IntakeReport>,
    /// Reports that could not be published.
    intake_errors: u64,
    /// `/diagnostics` and `/rosout`.
    status: StatusPublisher,
    /// Last: the endpoints above are dropped before their participant.
    session: Ros2Session,
}

/// The arguments of [`Ros2Node::start`], kept for [`Ros2Node::rebuild`].
struct Started {
    config: Ros2Config,
    plan: NetworkPlan,
    params: ParamValues,
    controls: ControlSender,
    partition: Option<Partition>,
}

impl Ros2Node {
    /// Joins the ROS 2 graph as `<namespace>/<name>` (`config.naming()`), offers the
    /// parameter services (initial values `params`; changes go to `controls`, i.e. the node's
    /// event loop), subscribes the inputs, creates the output publishers and the server of
    /// [`RESET_SERVICE`](super::RESET_SERVICE), every name resolved in the namespace.
    /// With a `partition` (scale-out), the packet input is that partition's topic
    /// (`pbr/accel/p<i>of<N>`, resolved in the namespace) instead of `pbr/accel`; the outputs,
    /// parameters and service are the same as every other node's of the service.
    /// The node's engine counts what it made of each writer's packets in `tally` (reported
    /// on `/pbr/intake`).
    pub fn start(
        config: &Ros2Config,
        plan: &NetworkPlan,
        params: ParamValues,
        controls: ControlSender,
        partition: Option<Partition>,
        tally: Arc<SourceTally>,
    ) -> anyhow::Result<(Ros2Node, Ros2Publisher)> {
        let started = Started {
            config: config.clone(),
            plan: plan.clone(),
            params,
            controls,
            partition,
        };
        let writers = WriterCounts::new(
            crate::intake::node_id(),
            format!(
                "{} (pid {})",
                config.naming()?.node_fqn(),
                std::process::id()
            ),
            tally,
            config.input_depth as u64,
        );
        Self::open(started, Arc::new(IntakeCounters::default()), writers)
    }

    fn open(
        started: Started,
        counters: Arc<IntakeCounters>,
        writers: WriterCounts,
    ) -> anyhow::Result<(Ros2Node, Ros2Publisher)> {
        let Started {
            config,
            plan,
            params,
            controls,
            partition,
        } = &started;
        // The node serves its own parameter services (with descriptors): ros2-client's off.
        let options = NodeOptions::new()
            .enable_rosout(true)
            .start_parameter_services(false);
        let mut session = Ros2Session::open(plan, &config.naming()?, options)?;
        let publisher = Ros2Publisher::open(&mut session)?;
        let inputs = Inputs::subscribe(&mut session, config, *partition)?;
        let reset = ResetServer::open(&mut session)?;
        let params = ParamServer::open(&mut session, params.clone(), controls.clone())?;
        let intake = session.publisher(INTAKE_TOPIC, "IntakeReport", intake_qos())?;
        let status = StatusPublisher::open(&mut session)?;
        Ok((
            Ros2Node {
                session,
                started,
                inputs,
                log: IntakeLog::new(Arc::clone(&counters), writers),
                counters,
                reset,
                params,
                intake,
                intake_errors: 0,
                status,
            },
            publisher,
        ))
    }

    /// The first RustDDS thread of the node's participant that has ended, if any: the
    /// participant is then dead for good (see [`Ros2Session::ended_thread`]).
    #[must_use]
    pub fn ended_thread(&self) -> Option<String> {
        self.session.ended_thread()
    }

    /// Replaces the participant and everything on it (subscriptions, publishers, reset
    /// service, parameter services) by new ones, as [`Ros2Node::start`] made them: call it
    /// once [`Ros2Node::ended_thread`] reports a dead participant, after taking what the old
    /// subscriptions still hold. The intake counters and the parameters' current values carry
    /// on; responses not yet sent are lost (the client times out and may ask again). Register
    /// the new inputs and services with the event loop again. On error `self` is left as it
    /// was.
    pub fn rebuild(&mut self) -> anyhow::Result<Ros2Publisher> {
        let started = Started {
            config: self.started.config.clone(),
            plan: self.started.plan.clone(),
            params: self.params.values.clone(),
            controls: self.started.controls.clone(),
            partition: self.started.partition,
        };
        // The counts carry over (swapped in once the new participant stands).
        let throwaway =
            WriterCounts::new([0; 16], String::new(), Arc::new(SourceTally::default()), 0);
        let (mut node, publisher) = Self::open(started, Arc::clone(&self.counters), throwaway)?;
        std::mem::swap(&mut node.log.writers, &mut self.log.writers);
        *self = node; // the old participant goes (its threads have ended: nothing to join)
        Ok(publisher)
    }

    /// Whether an intake report will be due without any new message ([`WriterCounts::pending`]).
    #[must_use]
    pub fn intake_pending(&self) -> bool {
        self.log.writers.pending()
    }

    /// Publishes the `/pbr/intake` reports due (see [`WriterCounts::due`]; `force`: every
    /// changed count now). Cheap when none is: call it after every turn of the event loop.
    pub fn publish_intake_reports(&mut self, force: bool) {
        let intake = &self.intake;
        let mut failed = None;
        let reader = self.inputs.accel_gid();
        self.log.writers.due(force, reader, &mut |report| {
            if let Err(e) = intake.publish(report.into()) {
                failed = Some(format!("{e:?}"));
            }
        });
        if let Some(e) = failed {
            self.intake_errors += 1;
            if self.intake_errors.is_power_of_two() {
                tracing::warn!(
                    "ROS 2 {INTAKE_TOPIC}: cannot publish a report ({e}; {} in all)",
                    self.intake_errors
                );
            }
        }
    }

    /// Publishes the node's status on `/diagnostics`.
    pub fn publish_status(&mut self, status: &crate::status::NodeStatus) {
        self.status.publish_status(status);
    }

    /// Publishes log records on `/rosout` (drained).
    pub fn publish_rosout(&mut self, records: &mut Vec<crate::logging::RosoutRecord>) {
        self.status.publish_rosout(records);
    }

    /// Registers the `/pbr/reset` server with `registry` as `token`, readable (edge-triggered:
    /// serve every request once it is reported, see [`Ros2Node::serve_resets`]).
    pub fn register_reset(&mut self, registry: &Registry, token: Token) -> std::io::Result<()> {
        self.reset.register(registry, token)
    }

    /// Serves up to [`RESET_REQUESTS_PER_TURN`](super::RESET_REQUESTS_PER_TURN) requests of `/pbr/reset`: `handle` gets each
    /// block id and gives the response, which is sent once the client can receive it
    /// ([`Ros2Node::send_due_replies`]). Undecodable requests are counted and logged like
    /// undecodable packets. Returns true if the bound was reached (more may be waiting).
    /// `handle` gives None for a block that another node of the service owns: no response.
    pub fn serve_resets(
        &mut self,
        handle: &mut impl FnMut(&str) -> Option<msg::ResetPbrResponse>,
    ) -> bool {
        self.reset.serve(&self.session, &mut self.log, handle)
    }

    /// Registers the six parameter services with `registry`, all as `token` (edge-triggered:
    /// serve them once reported, see [`Ros2Node::serve_parameters`]).
    pub fn register_parameters(
        &mut self,
        registry: &Registry,
        token: Token,
    ) -> std::io::Result<()> {
        self.params.register(registry, token)
    }

    /// Serves the parameter services' requests (a bounded number per service): reads answer
    /// at once, accepted changes are handed to the event loop (as controls, applied before
    /// the next packet), refused ones answer why. Returns true if a bound was reached.
    pub fn serve_parameters(&mut self) -> bool {
        self.params.serve(&self.session, &mut self.log)
    }

    /// The parameters' values now.
    #[must_use]
    pub fn parameters(&self) -> &ParamValues {
        &self.params.values
    }

    /// The run-time settings changed by other means (a reload): the parameters show `engine`'s.
    pub fn set_engine_parameters(&mut self, engine: &EngineConfig) {
        self.params.values.engine = *engine;
    }

    /// Service responses (reset, parameters) not sent yet.
    #[must_use]
    pub fn pending_replies(&self) -> usize {
        self.reset.pending() + self.params.pending()
    }

    /// Sends each waiting reset response whose client's response reader has been discovered
    /// (a reader of the service's response topic in the requester's DDS participant: the
    /// request id names the client's writer, or with Fast DDS its reader, whose GUID prefix
    /// is its participant's), or that has waited [`RESET_REPLY_WAIT`](super::RESET_REPLY_WAIT).
    /// The response writer is
    /// volatile, as ROS 2 services are: a response written before it has matched the client's
    /// reader would never reach it, and the request can arrive before that match (discovery
    /// is two-sided). Fast DDS servers wait in the same way. Costs nothing when none waits.
    pub fn send_due_replies(&mut self) {
        self.reset.send_due(&self.session);
        self.params.send_due(&self.session);
    }

    /// Sends every waiting service response now (at shutdown).
    pub fn flush_replies(&mut self) {
        self.reset.flush();
        self.params.flush();
    }

    /// Number of input subscriptions: `/pbr/accel` (input 0), then the Imu topics.
    #[must_use]
    pub fn inputs(&self) -> usize {
        self.inputs.len()
    }

    /// Registers input `i` (0..[`Ros2Node::inputs`]) with `registry` as `Token(first + i)`,
    /// readable. Readiness is edge-triggered: drain an input fully once it is reported.
    pub fn register(&mut self, registry: &Registry, first: usize) -> std::io::Result<()> {
        self.inputs.register(registry, first)
    }

    /// Takes up to `max` messages of input `input` and hands each, as a packet (or the
    /// refusal of its malformed station id), to `submit` (an Imu message is a one-sample
    /// packet of its station). Undecodable messages are
    /// counted and logged (at most one line per 10 s); a `/pbr/accel` packet of a station
    /// the engine does not `monitor` is counted as ignored in its writer's intake report.
    /// Returns true if `max` was reached (more may be waiting: bounded so that a flood on one
    /// input cannot starve the others).
    pub fn drain(
        &mut self,
        input: usize,
        max: usize,
        monitors: &dyn Fn(&str) -> bool,
        submit: &mut impl FnMut(Received, Option<Source>),
    ) -> bool {
        self.inputs
            .drain(input, max, &mut self.log, monitors, submit)
    }
}
