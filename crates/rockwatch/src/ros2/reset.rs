//! The server of the operator reset service `/pbr/reset` (`pbr_msgs/srv/ResetPbr`): requests
//! served by the node's event loop, responses held until the requesting client can receive
//! them.

use std::time::{Duration, Instant};

use anyhow::anyhow;
use ros2_client::dds::rustdds::mio1::{Interest, Registry, Token};
use ros2_client::{Name, NodeName, RmwRequestId, Server, ServiceTypeName};

use super::input::IntakeLog;
use super::msg;
use super::names::{NODE_NAME, RESET_SERVICE, RESET_SERVICE_MAPPING};
use super::qos::service_qos;
use super::session::Ros2Session;

/// Longest a reset response waits for the requesting client's response reader to be
/// discovered (a volatile writer does not send a sample to a reader it has not matched).
pub const RESET_REPLY_WAIT: Duration = Duration::from_secs(2);
/// How long a reset response waits after its client's reader is discovered, for RustDDS to
/// match that reader with the response writer.
pub const RESET_MATCH_GRACE: Duration = Duration::from_millis(20);
/// Most reset requests served per turn of the event loop (the rest on the next turn).
pub const RESET_REQUESTS_PER_TURN: usize = 64;
/// Most reset responses held for their client (see [`super::Ros2Node::send_due_replies`]);
/// beyond, a response is sent at once (bounded memory and work under a flood of requests).
pub const RESET_REPLIES_HELD: usize = 256;

/// A reset response not sent yet (see [`ResetServer::send_due`]).
struct PendingReply {
    id: RmwRequestId,
    response: msg::ResetPbrResponse,
    since: Instant,
    /// When the client's response reader was first seen in the discovery database.
    discovered: Option<Instant>,
}

/// The `/pbr/reset` server, the DDS name of its response topic and the responses waiting for
/// their client's response reader to be discovered.
pub(super) struct ResetServer {
    server: Server<msg::ResetPbrRequest, msg::ResetPbrResponse>,
    reply_topic: String,
    pending: Vec<PendingReply>,
}

impl ResetServer {
    /// Creates the server of [`RESET_SERVICE`] on `session`'s node `<namespace>/rockwatch`.
    pub(super) fn open(session: &mut Ros2Session, namespace: &str) -> anyhow::Result<ResetServer> {
        let reset_name =
            Name::parse(RESET_SERVICE).map_err(|e| anyhow!("service {RESET_SERVICE}: {e:?}"))?;
        let node_name = NodeName::new(namespace, NODE_NAME)
            .map_err(|e| anyhow!("ROS 2 node name {namespace:?}: {e:?}"))?;
        let reply_topic = reset_name.to_dds_name("rr", &node_name, "Reply");
        let server = session
            .node
            .create_server(
                RESET_SERVICE_MAPPING,
                &reset_name,
                &ServiceTypeName::new(msg::PACKAGE, msg::RESET_SERVICE_TYPE),
                service_qos(),
                service_qos(),
            )
            .map_err(|e| anyhow!("ROS 2 service {RESET_SERVICE}: {e:?}"))?;
        Ok(ResetServer {
            server,
            reply_topic,
            pending: Vec::new(),
        })
    }

    /// Registers the server with `registry` as `token`, readable (edge-triggered).
    pub(super) fn register(&mut self, registry: &Registry, token: Token) -> std::io::Result<()> {
        registry.register(&mut self.server, token, Interest::READABLE)
    }

    /// Serves up to [`RESET_REQUESTS_PER_TURN`] requests (undecodable ones go to `log`), then
    /// sends the responses that are due. Returns true if the bound was reached.
    pub(super) fn serve(
        &mut self,
        session: &Ros2Session,
        log: &mut IntakeLog,
        handle: &mut impl FnMut(&str) -> Option<msg::ResetPbrResponse>,
    ) -> bool {
        for _ in 0..RESET_REQUESTS_PER_TURN {
            match self.server.receive_request() {
                Ok(Some((id, request))) => {
                    // None: a block another node of the service owns (it answers).
                    let Some(response) = handle(&request.pbr_id) else {
                        continue;
                    };
                    if self.pending.len() < RESET_REPLIES_HELD {
                        self.pending.push(PendingReply {
                            id,
                            response,
                            since: Instant::now(),
                            discovered: None,
                        });
                    } else {
                        send_response(&mut self.server, id, response);
                    }
                }
                Ok(None) => {
                    self.send_due(session);
                    return false;
                }
                Err(e) => log.undecodable(RESET_SERVICE, &format!("{e:?}")),
            }
        }
        self.send_due(session);
        true
    }

    /// Responses not sent yet.
    pub(super) fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Sends each waiting response whose client's response reader `session`'s participant
    /// has discovered (and had [`RESET_MATCH_GRACE`] to match), or that has waited
    /// [`RESET_REPLY_WAIT`]. Costs nothing when none waits.
    pub(super) fn send_due(&mut self, session: &Ros2Session) {
        if self.pending.is_empty() {
            return;
        }
        let readers = session.context.domain_participant().discovered_readers();
        let topic = &self.reply_topic;
        let mut i = 0;
        while i < self.pending.len() {
            let p = &mut self.pending[i];
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
            let p = self.pending.swap_remove(i);
            send_response(&mut self.server, p.id, p.response);
        }
    }

    /// Sends every waiting response now.
    pub(super) fn flush(&mut self) {
        for p in std::mem::take(&mut self.pending) {
            send_response(&mut self.server, p.id, p.response);
        }
    }
}

/// Sends one response; a failure is logged (the client times out).
fn send_response(
    server: &mut Server<msg::ResetPbrRequest, msg::ResetPbrResponse>,
    id: RmwRequestId,
    response: msg::ResetPbrResponse,
) {
    if let Err(e) = server.send_response(id, response) {
        eprintln!("rockwatch: ROS 2 {RESET_SERVICE}: response not sent: {e:?}");
    }
}
