//! A service server served by the node's event loop whose responses are held until the
//! requesting client can receive them ([`HeldServer`]): the reset service and the parameter
//! services. It answers clients of both ROS 2 service mappings on one pair of topics (Fast
//! DDS's and Connext's "enhanced" one, rmw_cyclonedds's: [`super::rpc_wire`]), which
//! ros2-client's `Server` (one mapping per server) cannot: it reads and writes the wire itself,
//! through a reader and a writer of the node (they are the node's in the ROS graph).
//!
//! The response writer is volatile, as ROS 2 services are: a response written before it has
//! matched the client's response reader would never reach it, and the request can arrive
//! before that match (discovery is two-sided). Fast DDS servers wait in the same way.

use std::marker::PhantomData;
use std::time::{Duration, Instant};

use anyhow::anyhow;
use ros2_client::dds::rustdds::mio1::{Interest, Registry, Token};
use ros2_client::dds::rustdds::no_key::{DataWriter, SimpleDataReader};
use ros2_client::dds::rustdds::{Timestamp, TopicKind, WriteOptionsBuilder};
use ros2_client::{Message, Name, NodeName};

use super::qos::service_qos;
use super::rpc_wire::{self, Framing, RequestId, SampleMeta, Wire, WireAdapter};
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
    id: RequestId,
    response: Resp,
    since: Instant,
    /// When the client's response reader was first seen in the discovery database.
    discovered: Option<Instant>,
}

/// A server, its resolved name, the DDS name of its response topic and the responses waiting
/// for their client's response reader to be discovered.
pub(super) struct HeldServer<Req: Message, Resp: Message> {
    requests: SimpleDataReader<Wire, WireAdapter>,
    replies: DataWriter<Wire, WireAdapter>,
    /// The service's resolved name (for log lines).
    pub(super) name: String,
    reply_topic: String,
    pending: Vec<PendingReply<Resp>>,
    request_type: PhantomData<Req>,
}

impl<Req: Message + Clone + 'static, Resp: Message + Clone + 'static> HeldServer<Req, Resp> {
    /// The server of `name` (resolved in `session`'s namespace, remaps applied) of type
    /// `package/srv/type_name` on `session`'s node.
    pub(super) fn open(
        session: &mut Ros2Session,
        name: &str,
        package: &str,
        type_name: &str,
    ) -> anyhow::Result<Self> {
        let resolved = session.resolve(name)?;
        let service = Name::parse(&resolved).map_err(|e| anyhow!("service {resolved}: {e:?}"))?;
        let naming = session.naming();
        let node_name = NodeName::new(naming.namespace(), naming.node())
            .map_err(|e| anyhow!("ROS 2 node name {:?}: {e:?}", naming.node_fqn()))?;
        let request_topic = service.to_dds_name("rq", &node_name, "Request");
        let reply_topic = service.to_dds_name("rr", &node_name, "Reply");
        let qos = service_qos();
        let dds_qos = (&qos).into();
        let participant = session.context.domain_participant();
        let err = |e| anyhow!("ROS 2 service {resolved}: {e:?}");
        let rq = participant
            .create_topic(
                request_topic,
                format!("{package}::srv::dds_::{type_name}_Request_"),
                &dds_qos,
                TopicKind::NoKey,
            )
            .map_err(err)?;
        let rr = participant
            .create_topic(
                reply_topic.clone(),
                format!("{package}::srv::dds_::{type_name}_Response_"),
                &dds_qos,
                TopicKind::NoKey,
            )
            .map_err(err)?;
        let requests = session
            .node
            .create_simpledatareader::<Wire, WireAdapter>(&rq, Some(qos.clone()))
            .map_err(|e| anyhow!("ROS 2 service {resolved}: {e:?}"))?;
        let replies = session
            .node
            .create_datawriter::<Wire, WireAdapter>(&rr, Some(qos))
            .map_err(|e| anyhow!("ROS 2 service {resolved}: {e:?}"))?;
        Ok(HeldServer {
            requests,
            replies,
            name: resolved,
            reply_topic,
            pending: Vec::new(),
            request_type: PhantomData,
        })
    }

    /// Registers the server with `registry` as `token`, readable (edge-triggered: serve every
    /// request once it is reported).
    pub(super) fn register(&mut self, registry: &Registry, token: Token) -> std::io::Result<()> {
        registry.register(&mut self.requests, token, Interest::READABLE)
    }

    /// The next request, if any, in either mapping (an undecodable one is an error: count it,
    /// go on).
    pub(super) fn receive(&mut self) -> Result<Option<(RequestId, Req)>, String> {
        self.requests.drain_read_notifications();
        let Some(sample) = self.requests.try_take_one().map_err(|e| format!("{e:?}"))? else {
            return Ok(None);
        };
        let meta = SampleMeta {
            writer: sample.writer_guid(),
            sequence: sample.sequence_number,
            related: sample.related_sample_identity(),
        };
        let wire = sample.into_value();
        rpc_wire::decode_request::<Req>(&wire, meta)
            .map(Some)
            .map_err(|e| e.to_string())
    }

    /// Answers request `id`: held until the client can receive it, or sent at once when
    /// [`RESET_REPLIES_HELD`] responses already wait.
    pub(super) fn reply(&mut self, id: RequestId, response: Resp) {
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
    /// [`RESET_REPLY_WAIT`]. The request's writer names the client's participant (its GUID
    /// prefix). Costs nothing when none waits.
    pub(super) fn send_due(&mut self, session: &Ros2Session) {
        if self.pending.is_empty() {
            return;
        }
        let readers = session.context.domain_participant().discovered_readers();
        let topic = self.reply_topic.clone();
        let mut i = 0;
        while i < self.pending.len() {
            let p = &mut self.pending[i];
            let client = p.id.client.prefix;
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

    /// Sends one response in its request's mapping; a failure is logged (the client times
    /// out).
    fn send(&mut self, id: RequestId, response: Resp) {
        let wire = match rpc_wire::encode_reply(&id, &response) {
            Ok(wire) => wire,
            Err(e) => {
                tracing::info!("ROS 2 {}: response not encoded: {e}", self.name);
                return;
            }
        };
        let mut options = WriteOptionsBuilder::new().source_timestamp(Timestamp::now());
        if let Framing::Enhanced(request) = id.framing {
            options = options.related_sample_identity(request);
        }
        if let Err(e) = self.replies.write_with_options(wire, options.build()) {
            tracing::info!("ROS 2 {}: response not sent: {e:?}", self.name);
        }
    }
}
