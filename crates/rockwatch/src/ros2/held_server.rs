//! A service server served by the node's event loop whose responses are held until the
//! requesting client can receive them ([`HeldServer`]): the reset service and the parameter
//! services.
//!
//! The response writer is volatile, as ROS 2 services are: a response written before it has
//! matched the client's response reader would never reach it, and the request can arrive
//! before that match (discovery is two-sided). Fast DDS servers wait in the same way.

use std::time::{Duration, Instant};

use anyhow::anyhow;
use ros2_client::dds::rustdds::mio1::{Interest, Registry, Token};
use ros2_client::{Message, Name, NodeName, RmwRequestId, Server, ServiceMapping, ServiceTypeName};

use super::qos::service_qos;
use super::session::Ros2Session;

/// Longest a response waits for the requesting client's response reader to be discovered.
pub const RESET_REPLY_WAIT: Duration = Duration::from_secs(2);
/// How long a response waits after its client's reader is discovered, for RustDDS to match
/// that reader with the response writer.
pub const RESET_MATCH_GRACE: Duration = Duration::from_millis(20);
/// Most responses held per server (see [`HeldServer::send_due`]); beyond, a response is sent
/// at once (bounded memory and work under a flood of requests).
pub const RESET_REPLIES_HELD: usize = 256;

/// A response not sent yet.
struct PendingReply<Resp> {
    id: RmwRequestId,
    response: Resp,
    since: Instant,
    /// When the client's response reader was first seen in the discovery database.
    discovered: Option<Instant>,
}

/// A server, its resolved name, the DDS name of its response topic and the responses waiting
/// for their client's response reader to be discovered.
pub(super) struct HeldServer<Req: Message, Resp: Message> {
    server: Server<Req, Resp>,
    /// The service's resolved name (for log lines).
    pub(super) name: String,
    reply_topic: String,
    pending: Vec<PendingReply<Resp>>,
}

impl<Req: Message + Clone + 'static, Resp: Message + Clone + 'static> HeldServer<Req, Resp> {
    /// The server of `name` (resolved in `session`'s namespace, remaps applied) of type
    /// `package/srv/type_name` on `session`'s node.
    pub(super) fn open(
        session: &mut Ros2Session,
        mapping: ServiceMapping,
        name: &str,
        package: &str,
        type_name: &str,
    ) -> anyhow::Result<Self> {
        let resolved = session.resolve(name)?;
        let service = Name::parse(&resolved).map_err(|e| anyhow!("service {resolved}: {e:?}"))?;
        let naming = session.naming();
        let node_name = NodeName::new(naming.namespace(), naming.node())
            .map_err(|e| anyhow!("ROS 2 node name {:?}: {e:?}", naming.node_fqn()))?;
        let reply_topic = service.to_dds_name("rr", &node_name, "Reply");
        let server = session
            .node
            .create_server(
                mapping,
                &service,
                &ServiceTypeName::new(package, type_name),
                service_qos(),
                service_qos(),
            )
            .map_err(|e| anyhow!("ROS 2 service {resolved}: {e:?}"))?;
        Ok(HeldServer {
            server,
            name: resolved,
            reply_topic,
            pending: Vec::new(),
        })
    }

    /// Registers the server with `registry` as `token`, readable (edge-triggered: serve every
    /// request once it is reported).
    pub(super) fn register(&mut self, registry: &Registry, token: Token) -> std::io::Result<()> {
        registry.register(&mut self.server, token, Interest::READABLE)
    }

    /// The next request, if any (an undecodable one is an error: count it, go on).
    pub(super) fn receive(&mut self) -> Result<Option<(RmwRequestId, Req)>, String> {
        self.server.receive_request().map_err(|e| format!("{e:?}"))
    }

    /// Answers request `id`: held until the client can receive it, or sent at once when
    /// [`RESET_REPLIES_HELD`] responses already wait.
    pub(super) fn reply(&mut self, id: RmwRequestId, response: Resp) {
        if self.pending.len() < RESET_REPLIES_HELD {
            self.pending.push(PendingReply {
                id,
                response,
                since: Instant::now(),
                discovered: None,
            });
        } else {
            self.send(id, response);
        }
    }

    /// Responses not sent yet.
    pub(super) fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Sends each waiting response whose client's response reader `session`'s participant
    /// has discovered (and had [`RESET_MATCH_GRACE`] to match), or that has waited
    /// [`RESET_REPLY_WAIT`]. The request id names the client's writer (or, with Fast DDS,
    /// its reader), whose GUID prefix is its participant's. Costs nothing when none waits.
    pub(super) fn send_due(&mut self, session: &Ros2Session) {
        if self.pending.is_empty() {
            return;
        }
        let readers = session.context.domain_participant().discovered_readers();
        let topic = self.reply_topic.clone();
        let mut i = 0;
        while i < self.pending.len() {
            let p = &mut self.pending[i];
            let client = ros2_client::dds::rustdds::GUID::from(p.id.writer_gid).prefix;
            if p.discovered.is_none()
                && readers.iter().any(|r| {
                    r.reader_proxy.remote_reader_guid.prefix == client
                        && *r.subscription_topic_data.topic_name() == topic
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
            let p = self.pending.swap_remove(i);
            self.send(p.id, p.response);
        }
    }

    /// Sends every waiting response now.
    pub(super) fn flush(&mut self) {
        for p in std::mem::take(&mut self.pending) {
            self.send(p.id, p.response);
        }
    }

    /// Sends one response; a failure is logged (the client times out).
    fn send(&mut self, id: RmwRequestId, response: Resp) {
        if let Err(e) = self.server.send_response(id, response) {
            tracing::info!("ROS 2 {}: response not sent: {e:?}", self.name);
        }
    }
}
